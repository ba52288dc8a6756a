"""The independent reference of benchmarks/bench_accuracy.py: a launch integrated by
scipy (hoprover_env.sim.reference.Ref, MODEL.md section 4), then the flight under the
attitude hold in closed form to the touchdown."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from hoprover_env import RoverParams
from hoprover_env.sim.controllers import attitude_hold
from hoprover_env.sim.reference import Ref


def scipy_launch_and_landing(
    params: RoverParams, torque: float, kp: float, kd: float, control_dt: float, t_end: float
) -> dict:
    """Lift-off by scipy, then the flight under the attitude hold in closed form.

    The hold T = -I (kp theta + kd omega) is applied every `control_dt` seconds from the
    lift-off, for at most `t_end` seconds. Between control instants (lift-off + k
    control_dt) the torque is constant, so the c.m. follows one parabola from the
    lift-off and theta a quadratic in t per interval. The touchdown is the first root of
    the lowest bottom corner's height, y - l max(sin(theta + alpha), sin(alpha - theta)),
    found by Brent's method in the first interval (past the apex) whose end is below the
    ground.
    """
    ref = Ref(
        m=params.mass,
        I=params.inertia,
        r=params.half_width,
        h=params.half_height,
        g=params.gravity,
        mus=params.mu_static,
        mud=params.mu_dynamic,
    )
    t_lo, s_lo, modes = ref.launch(torque)
    x0, y0, theta, vx, vy0, omega = (float(v) for v in s_lo)
    g, inertia, ell, alpha = ref.g, ref.I, ref.l, ref.alpha
    t_apex = t_lo + vy0 / g

    def y_at(t):
        tau = t - t_lo
        return y0 + vy0 * tau - 0.5 * g * tau * tau

    t_a = t_lo
    for k in range(1, int(t_end / control_dt)):
        t_b = t_lo + k * control_dt
        cmd = attitude_hold(theta, omega, inertia, kp, kd)
        beta = min(max(cmd, params.torque_min), params.torque_max) / inertia

        def lowest_corner(t, th0=theta, w0=omega, t0=t_a, beta=beta):
            th = th0 + w0 * (t - t0) + 0.5 * beta * (t - t0) ** 2
            return y_at(t) - ell * max(math.sin(th + alpha), math.sin(alpha - th))

        if t_b > t_apex and lowest_corner(t_b) < 0.0:
            t_land = brentq(lowest_corner, t_a, t_b, xtol=1e-15, rtol=8.9e-16)
            return {
                "liftoff_t": t_lo,
                "liftoff_state": np.asarray(s_lo, float),
                "modes": "".join(modes),
                "land_t": t_land,
                "land_x": x0 + vx * (t_land - t_lo),
            }
        theta = theta + omega * (t_b - t_a) + 0.5 * beta * (t_b - t_a) ** 2
        omega = omega + beta * (t_b - t_a)
        t_a = t_b
    raise RuntimeError(f"scipy reference: no touchdown by t_end (torque {torque:g})")
