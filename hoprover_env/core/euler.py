"""The Euler integrator: the contest-style fixed-step baseline (docs/MODEL.md
section 10), over the same forces, transitions and impact law."""

from hoprover_env.core.forces import (
    contact_corner,
    corner_offset,
    pivot_dynamics,
    slide_dynamics,
    turn_flat_about,
)
from hoprover_env.core.judge import judge_update
from hoprover_env.core.layout import (
    ERR_BUDGET,
    H_TOL,
    INTEGRATOR_EULER,
    MAX_EVENTS,
    MODE_A,
    MODE_B,
    MODE_C,
    MODE_D,
    MODE_E,
    MODE_F,
    MODE_G,
    O_EULER_DT,
    O_INTEGRATOR,
    PH_BROKEN,
    PH_NONE,
    PH_STICK,
    PH_STOP,
    PH_TOUCH,
    S_BROKEN,
    S_ERROR,
    S_MODE,
    S_SIGMA,
    S_STOPPED,
    S_T,
    S_TH,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_Y,
    V_TOL,
)
from hoprover_env.core.params import P_GC, P_GS, P_I, P_M, P_MUD
from hoprover_env.core.phase_end import after_phase
from hoprover_env.core.transitions import settle
from hoprover_env.jit.compiler import kernel


# ----------------------------------------------------------------------------------
# Euler integrator: the contest-style fixed-step baseline (docs/MODEL.md section 10)
# ----------------------------------------------------------------------------------
@kernel(inner=True)
def _euler_contact_step(S, P, dt):
    """Explicit Euler on (theta, omega, x, vx) of a single-contact state; y, vy (and
    x, vx for a pivot) from the constraint."""
    mode = int(S[S_MODE])
    k = contact_corner(mode)
    T = S[S_TORQUE]
    th = S[S_TH]
    w = S[S_W]
    if mode == MODE_B or mode == MODE_D:
        thdd, fx, _, dx, _ = pivot_dynamics(P, k, T, th, w)
        xpiv = S[S_X] + dx
        th += w * dt
        w += thdd * dt
        dx, dy = corner_offset(P, k, th)
        S[S_X] = xpiv - dx
        S[S_VX] = -w * dy
    else:
        thdd, fx, _, dx, _ = slide_dynamics(P, k, S[S_SIGMA], T, th, w)
        S[S_X] += S[S_VX] * dt
        S[S_VX] += (fx / P[P_M] - P[P_GS]) * dt
        th += w * dt
        w += thdd * dt
        dx, dy = corner_offset(P, k, th)
    S[S_TH] = th
    S[S_W] = w
    S[S_Y] = -dy
    S[S_VY] = w * dx


@kernel(inner=True)
def _euler_ground_check(S, P):
    """End-of-step geometry check of the Euler baseline (it locates no events).

    A bottom corner that a step carried under the ground is put back on it first (a top
    corner at or under the ground then breaks the rover), as the contest program re-derived the
    configuration from the kinematics: in flight the body is lifted, in a single
    contact it is turned about the contact corner to theta = 0 (where the other corner
    touches). If a grounded corner is then moving down, that is an impact.
    """
    mode = int(S[S_MODE])
    _, dy0 = corner_offset(P, 0, S[S_TH])
    _, dy1 = corner_offset(P, 1, S[S_TH])
    low = min(S[S_Y] + dy0, S[S_Y] + dy1)
    if low < 0.0:
        if mode == MODE_A:
            S[S_Y] -= low
        else:
            k = contact_corner(mode)
            turn_flat_about(S, P, k)
            if mode == MODE_B or mode == MODE_D:
                _, dy = corner_offset(P, k, 0.0)
                S[S_VX] = -S[S_W] * dy
    for c in range(2, 4):
        _, dy = corner_offset(P, c, S[S_TH])
        if S[S_Y] + dy <= 0.0:
            return PH_BROKEN
    if low >= 0.0:
        return PH_NONE
    for c in range(2):
        dx, dy = corner_offset(P, c, S[S_TH])
        if S[S_Y] + dy <= H_TOL and S[S_VY] - S[S_W] * dx < -V_TOL:
            return PH_TOUCH
    return PH_NONE


@kernel
def event_budget(O, duration):
    """Events one `advance` over `duration` may have: MAX_EVENTS for `event`. A corner
    pressed down bounces every other Euler step (it gains a dt of speed per step, an
    artefact of the fixed step), so for `euler` the budget grows with the steps taken."""
    if int(O[O_INTEGRATOR]) == INTEGRATOR_EULER:
        return MAX_EVENTS + 4 * int(duration / O[O_EULER_DT] + 1.0)
    return MAX_EVENTS


@kernel(inner=True)
def advance_euler(S, P, O, t_stop, ev, n, W):
    dt0 = O[O_EULER_DT]
    n_start = n
    budget = event_budget(O, t_stop - S[S_T])
    g = P[P_GC]
    gs = P[P_GS]
    while S[S_BROKEN] == 0.0 and S[S_STOPPED] == 0.0:
        remaining = t_stop - S[S_T]
        if remaining <= 1e-9 * dt0:
            S[S_T] = t_stop
            break
        if n - n_start > budget:
            S[S_ERROR] = ERR_BUDGET
            break
        dt = min(dt0, remaining)
        mode = int(S[S_MODE])
        if mode == MODE_A:
            S[S_X] += S[S_VX] * dt
            S[S_Y] += S[S_VY] * dt
            S[S_TH] += S[S_W] * dt
            S[S_VX] -= gs * dt
            S[S_VY] -= g * dt
            S[S_W] += S[S_TORQUE] / P[P_I] * dt
        elif mode == MODE_G:
            sigma = S[S_SIGMA]
            S[S_X] += S[S_VX] * dt
            S[S_VX] -= sigma * P[P_MUD] * g * dt
            S[S_VX] -= gs * dt
        elif mode != MODE_F:
            _euler_contact_step(S, P, dt)
        S[S_T] = t_stop if dt == remaining else S[S_T] + dt
        # guards, checked only at the end of the step (no event location)
        kind = PH_NONE
        if mode == MODE_G and S[S_SIGMA] * S[S_VX] <= 0.0:
            S[S_VX] = 0.0
            kind = PH_STOP
        elif mode != MODE_F and mode != MODE_G:
            kind = _euler_ground_check(S, P)
            if kind == PH_NONE and (mode == MODE_C or mode == MODE_E):
                _, dy = corner_offset(P, contact_corner(mode), S[S_TH])
                if S[S_SIGMA] * (S[S_VX] + S[S_W] * dy) <= 0.0:
                    kind = PH_STICK
        if kind != PH_NONE:
            n = after_phase(S, P, O, ev, n, kind, W)
        else:
            n = settle(S, P, ev, n)
            n = judge_update(S, P, ev, n)
    return n
