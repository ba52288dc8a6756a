"""What happens when a phase of either integrator ends: the transition or impact it
ended on is applied and logged, and the judge and diagnostics are updated."""

import math

from hoprover_env.core.forces import (
    contact_corner,
    corner_offset,
    corner_offset_cs,
    pivot_dynamics,
    sliding_mode,
)
from hoprover_env.core.impacts import impact_event
from hoprover_env.core.judge import judge_set, judge_update, log_event
from hoprover_env.core.layout import (
    EV_BROKEN,
    EV_LIFTOFF,
    EV_SLIP,
    EV_STOP,
    MODE_A,
    MODE_F,
    MODE_G,
    PH_BAND,
    PH_BROKEN,
    PH_LIFTOFF,
    PH_NONE,
    PH_SLIP,
    PH_STICK,
    PH_STOP,
    PH_TOUCH,
    S_BROKEN,
    S_MIN_HEIGHT,
    S_MODE,
    S_SIGMA,
    S_T,
    S_TH,
    S_TORQUE,
    S_VX,
    S_W,
    S_X,
    S_XT,
    S_Y,
)
from hoprover_env.core.params import P_BAND, P_R
from hoprover_env.core.transitions import settle
from hoprover_env.jit.compiler import I64, MAT, VEC, kernel


# ----------------------------------------------------------------------------------
# Event integrator: the loop over phases
# ----------------------------------------------------------------------------------
@kernel(inner=True)
def track_min_height(S, P):
    c = math.cos(S[S_TH])
    sn = math.sin(S[S_TH])
    _, dy0 = corner_offset_cs(P, 0, c, sn)
    _, dy1 = corner_offset_cs(P, 1, c, sn)
    low = S[S_Y] + min(dy0, dy1)
    if low < S[S_MIN_HEIGHT]:
        S[S_MIN_HEIGHT] = low


@kernel(inner=True)
def _band_status_ahead(S, P, sigma):
    """Band membership just past the current position in direction sigma: decides a
    crossing unambiguously even where two corners' intervals meet (r = w)."""
    mode = int(S[S_MODE])
    xt = S[S_XT]
    w = P[P_BAND]
    probe = sigma * 1e-12
    if mode == MODE_G or mode == MODE_F:
        xa = S[S_X] + P[P_R] + probe
        xb = S[S_X] - P[P_R] + probe
        return abs(xa - xt) <= w or abs(xb - xt) <= w
    dx, _ = corner_offset(P, contact_corner(mode), S[S_TH])
    return abs(S[S_X] + dx + probe - xt) <= w


@kernel(I64(VEC, VEC, VEC, MAT, I64, I64, VEC), inner=True)
def after_phase(S, P, O, ev, n, kind, W):
    """Carry out the transition that ended a phase, then settle and update the judge."""
    mode = int(S[S_MODE])
    t = S[S_T]
    if kind == PH_NONE:
        return n
    track_min_height(S, P)
    if kind == PH_BROKEN:
        S[S_BROKEN] = 1.0
        n = judge_set(S, P, ev, n, False)
        return log_event(S, ev, n, t, EV_BROKEN, mode, mode, 0.0)
    if kind == PH_BAND:
        return judge_set(S, P, ev, n, _band_status_ahead(S, P, S[S_SIGMA]))
    if kind == PH_TOUCH:
        n = impact_event(S, P, O, ev, n, W)
    elif kind == PH_LIFTOFF:
        S[S_MODE] = MODE_A
        S[S_SIGMA] = 0.0
        n = log_event(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0)
    elif kind == PH_SLIP:
        k = contact_corner(mode)
        _, fx, _, _, _ = pivot_dynamics(P, k, S[S_TORQUE], S[S_TH], S[S_W])
        new = sliding_mode(k)
        S[S_MODE] = new
        S[S_SIGMA] = -1.0 if fx > 0.0 else 1.0
        n = log_event(S, ev, n, t, EV_SLIP, mode, new, 0.0)
    elif kind == PH_STICK:
        # the sliding velocity reached zero: settle decides stick or reversal
        _, dy = corner_offset(P, contact_corner(mode), S[S_TH])
        S[S_VX] = -S[S_W] * dy
    elif kind == PH_STOP:
        S[S_MODE] = MODE_F
        S[S_SIGMA] = 0.0
        n = log_event(S, ev, n, t, EV_STOP, mode, MODE_F, 0.0)
    n = settle(S, P, ev, n)
    track_min_height(S, P)
    return judge_update(S, P, ev, n)
