"""Contest controllers compiled with numba: they run inside the kernel's run loop.

`simulate(controller)` and `simulate_batch(controller)` run a numba-compiled controller
with the contest signature inside the compiled loop (hoprover_env/sim/control_loop.py documents
the signature: the state arrives as an integer code 0..6 for A..G). A numba function
keeps no memory between calls, so these controllers decide from the state and the time
(the PD attitude hold they fly with is hoprover_env.sim.controllers.attitude_hold):

* `planned_hops` -- a hop plan: launch torques held over time windows while on the
  ground, the PD hold in flight, zero otherwise. Its parameters arrive in posT[2:]
  (`simulate_batch(..., controller_args=...)`), so one compiled function runs a whole
  population of plans; `hop_plan(args)` bakes them into a controller for `simulate`.

Plan layout (`controller_args` row): inertia, kp, kd, then per hop (start s, duration
d, torque T): while not in flight and s <= t < s + d, the torque is T.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold

FLIGHT = 0  # state code of state A
PLAN_HEAD = 3  # inertia, kp, kd
PLAN_HOP = 3  # start, duration, torque


@kernel
def plan_torque(plan, the, omg, t, state_code):
    """The torque of a hop plan (layout in the module docstring) at this instant; `plan`
    is an array or a tuple of floats."""
    if state_code == FLIGHT:
        return attitude_hold(the, omg, plan[0], plan[1], plan[2])
    for h in range((len(plan) - PLAN_HEAD) // PLAN_HOP):
        b = PLAN_HEAD + PLAN_HOP * h
        if plan[b] <= t < plan[b] + plan[b + 1]:
            return plan[b + 2]
    return 0.0


@kernel
def planned_hops(pos, vel, the, omg, posT, t, smt, state_code):
    """Contest controller reading its hop plan from posT[2:] (simulate_batch's
    controller_args)."""
    return plan_torque(posT[2:], the, omg, t, state_code)


def hop_plan(args) -> Callable[..., float]:
    """A compiled contest controller with the plan `args` built in (for `simulate`):
    (inertia [kg m^2], kp [1/s^2], kd [1/s]) then (start [s], duration [s], torque
    [N m]) per hop. Raises ValueError for a plan of the wrong length or with
    non-finite values."""
    plan = np.asarray(args, dtype=np.float64)
    if plan.ndim != 1 or (plan.size - PLAN_HEAD) % PLAN_HOP or not np.all(np.isfinite(plan)):
        raise ValueError(
            f"a hop plan is (inertia, kp, kd) then (start, duration, torque) "
            f"per hop, all finite; got {args!r}"
        )
    frozen = tuple(float(v) for v in plan)

    # plain njit, not `kernel`: a closure over this plan's constants cannot be cached
    @njit(error_model="numpy")
    def control(pos, vel, the, omg, posT, t, smt, state_code):
        return plan_torque(frozen, the, omg, t, state_code)

    return control
