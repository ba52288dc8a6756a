"""The event integrator's loop over phases, the entry points `advance` /
`advance_event` shared by every caller, and `init_state`."""

import math

import numpy as np

from hoprover_env.core.contact_phases import contact_phase, g_phase
from hoprover_env.core.euler import advance_euler
from hoprover_env.core.flight import flight_phase
from hoprover_env.core.forces import (
    corner_offset,
    pin_or_slide,
    set_double_contact,
    set_single_contact,
    wrap_angle,
)
from hoprover_env.core.judge import in_band, judge_check, judge_update
from hoprover_env.core.layout import (
    ERR_BUDGET,
    ERR_STEP,
    ERR_TORQUE,
    INTEGRATOR_EULER,
    MAX_EVENTS,
    MAX_PHASES,
    MODE_A,
    MODE_F,
    MODE_G,
    N_STATE,
    O_INTEGRATOR,
    PH_NONE,
    S_BROKEN,
    S_ERROR,
    S_INBAND,
    S_MIN_HEIGHT,
    S_MODE,
    S_STOP_ON,
    S_STOPPED,
    S_T,
    S_TH,
    S_TIN,
    S_TORQUE,
    S_TTRTP,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_XT,
    S_Y,
    W_WORK,
)
from hoprover_env.core.params import P_DWELL, P_TMAX, P_TMIN
from hoprover_env.core.phase_end import after_phase, track_min_height
from hoprover_env.core.transitions import settle
from hoprover_env.jit.compiler import F64, I64, VEC, kernel


@kernel(inner=True, inline=True)
def advance_event_loop(S, P, O, t_stop, ev, n, W):
    n_start = n
    phases = 0
    while S[S_T] < t_stop and S[S_BROKEN] == 0.0 and S[S_STOPPED] == 0.0:
        if n - n_start > MAX_EVENTS:
            S[S_ERROR] = ERR_BUDGET
            break
        if S[S_ERROR] != 0.0:
            break
        phases += 1
        if phases > MAX_PHASES:  # phases that log no event would otherwise spin
            S[S_ERROR] = ERR_STEP
            break
        mode = int(S[S_MODE])
        # a phase ends where the judge's dwell would complete, so that TTRTP is logged
        # (and `stop_on="ttrtp"` stops) at its time, in order with the other events
        t_lim = t_stop
        if S[S_INBAND] == 1.0 and math.isnan(S[S_TTRTP]):
            t_star = S[S_TIN] + P[P_DWELL]
            if S[S_T] < t_star < t_stop:
                t_lim = t_star
        if mode == MODE_F:
            S[S_T] = t_lim  # at rest: nothing to integrate
            if t_lim < t_stop:
                n = judge_check(S, P, ev, n)
                continue
            break
        if mode == MODE_A:
            kind, _ = flight_phase(S, P, t_lim, W)
        elif mode == MODE_G:
            kind = g_phase(S, P, t_lim)
        else:
            kind = contact_phase(S, P, O, t_lim, W)
        n = after_phase(S, P, O, ev, n, kind, W)
        if kind == PH_NONE and t_lim < t_stop:
            n = judge_check(S, P, ev, n)  # the phase ended at the judge's deadline
    return n


# ----------------------------------------------------------------------------------
# Entry points
# ----------------------------------------------------------------------------------
@kernel(inner=True)
def _advance_begin(S, P, torque_cmd, t_stop, ev, W):
    """What both integrators do first: refuse a non-finite torque, apply the clipped
    torque and resolve the transitions it causes at once. Returns (integrate?, events)."""
    if not math.isfinite(torque_cmd):
        S[S_ERROR] = ERR_TORQUE
        return False, 0
    if S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0 or S[S_T] >= t_stop:
        return False, 0
    S[S_TORQUE] = min(max(torque_cmd, P[P_TMIN]), P[P_TMAX])
    S[S_STOPPED] = 0.0
    W[W_WORK] = 0.0
    n = settle(S, P, ev, 0)
    n = judge_update(S, P, ev, n)
    return S[S_STOPPED] == 0.0, n


@kernel(inner=True)
def _advance_end(S, P, ev, n):
    if n > 0:
        track_min_height(S, P)  # between events no corner can sink
    return judge_check(S, P, ev, n)


@kernel(inline=True)
def advance(S, P, O, torque_cmd, t_stop, ev, W):
    """Hold `torque_cmd` (clipped to [T_min, T_max]) from S[S_T] to t_stop.

    Resolves the transitions the new torque causes at once, integrates with the
    integrator O[O_INTEGRATOR], updates the judge, and writes events into `ev`
    (rows beyond its length are counted, not written); W is scratch (N_WORK floats).
    Returns the number of events.
    If S[S_STOP_ON] names an event kind, the call returns right after the first such
    event, with S[S_STOPPED] = 1 and the time S[S_T] of the event.
    A non-finite torque sets S[S_ERROR] = ERR_TORQUE and leaves the state untouched.
    """
    go, n = _advance_begin(S, P, torque_cmd, t_stop, ev, W)
    if not go:
        return n
    if int(O[O_INTEGRATOR]) == INTEGRATOR_EULER:
        n = advance_euler(S, P, O, t_stop, ev, n, W)
    else:
        n = advance_event_loop(S, P, O, t_stop, ev, n, W)
    return _advance_end(S, P, ev, n)


@kernel(inline=True)
def advance_event(S, P, O, torque_cmd, t_stop, ev, W):
    """`advance` with the event integrator, whatever O[O_INTEGRATOR] says.

    The environments' step kernels call this one, so that numba compiles no Euler code
    for them (about 1 s of a cold start): a compiled function includes every function
    it can reach, whichever branch runs. Environments made with integrator="euler" use
    kernels that call `advance`.
    """
    go, n = _advance_begin(S, P, torque_cmd, t_stop, ev, W)
    if not go:
        return n
    return _advance_end(S, P, ev, advance_event_loop(S, P, O, t_stop, ev, n, W))


INIT_OK, INIT_PENETRATION, INIT_TOP_DOWN, INIT_MOVING_DOWN, INIT_NOT_FLAT = range(5)
INIT_GROUND_TOL = 1e-9  # m: how far a given initial corner may be from the ground


@kernel(I64(VEC, VEC, F64, F64, F64, F64, F64, F64, F64))
def init_state(S, P, x, y, th, vx, vy, w, xt):
    """Fill S from a c.m. state and classify its contact state from the kinematics.

    A bottom corner within INIT_GROUND_TOL of the ground and at rest vertically is in
    contact (then snapped onto it); one moving down is an inconsistent start. Returns
    an INIT_* code (0 = fine).
    """
    for i in range(N_STATE):
        S[i] = 0.0
    S[S_X] = x
    S[S_Y] = y
    S[S_TH] = wrap_angle(th)
    S[S_VX] = vx
    S[S_VY] = vy
    S[S_W] = w
    S[S_XT] = xt
    S[S_TTRTP] = np.nan
    S[S_STOP_ON] = -1.0
    S[S_MIN_HEIGHT] = np.inf
    S[S_MODE] = MODE_A
    on0 = False
    on1 = False
    for c in range(4):
        dx, dy = corner_offset(P, c, S[S_TH])
        hc = y + dy
        if c >= 2:
            if hc <= INIT_GROUND_TOL:
                return INIT_TOP_DOWN
            continue
        if hc < -INIT_GROUND_TOL:
            return INIT_PENETRATION
        if hc <= INIT_GROUND_TOL:
            vpy = vy - w * dx
            if vpy < -INIT_GROUND_TOL:
                return INIT_MOVING_DOWN
            if vpy <= INIT_GROUND_TOL:
                if c == 0:
                    on0 = True
                else:
                    on1 = True
    if on0 and on1:
        if abs(S[S_TH]) > 1e-6 or abs(w) > 1e-6:
            return INIT_NOT_FLAT
        set_double_contact(S, P)
    elif on0 or on1:
        k = 0 if on0 else 1
        set_single_contact(S, P, k)
        pin_or_slide(S, P, k, INIT_GROUND_TOL)
    S[S_INBAND] = 1.0 if in_band(S, P) else 0.0
    S[S_TIN] = 0.0
    return INIT_OK
