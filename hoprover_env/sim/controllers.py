"""Control laws shared by every controller that flies the rover.

One home for each law: the hop-level task's built-in flight controller, the scripted
hopper (hoprover_env/agents/scripted.py), the compiled contest controllers
(hoprover_env/agents/compiled.py) and the benchmark drivers all call these functions, so
their torques agree to the bit. Compiled with `kernel` (hoprover_env/jit/compiler.py) and
callable from Python and from jitted code alike.
"""

import math

from hoprover_env.jit.compiler import kernel


@kernel
def attitude_hold(theta, omega, inertia, kp, kd):
    """PD attitude hold, theta -> 0 and omega -> 0: the torque
    ``-inertia (kp wrap(theta) + kd omega)`` [N m], with theta wrapped to [-pi, pi).

    Parameters: theta [rad], omega [rad/s], inertia [kg m^2], kp [1/s^2], kd [1/s].
    The result is not clipped: the kernel clips every torque to [T_min, T_max].
    """
    th = (theta + math.pi) % (2.0 * math.pi) - math.pi
    return -inertia * (kp * th + kd * omega)
