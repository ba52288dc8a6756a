"""The event log and the judge (docs/MODEL.md section 8)."""

import math

from hoprover_env.core.forces import contact_corner, corner_offset
from hoprover_env.core.layout import (
    EV_BAND_IN,
    EV_BAND_OUT,
    EV_TTRTP,
    MODE_A,
    MODE_F,
    MODE_G,
    S_INBAND,
    S_MODE,
    S_NEVENTS,
    S_STOP_ON,
    S_STOPPED,
    S_T,
    S_TH,
    S_TIN,
    S_TTRTP,
    S_X,
    S_XT,
)
from hoprover_env.core.params import P_BAND, P_DWELL, P_R
from hoprover_env.jit.compiler import BOOL, F64, I64, MAT, VEC, kernel


# ----------------------------------------------------------------------------------
# Event log and judge (docs/MODEL.md section 8)
# ----------------------------------------------------------------------------------
@kernel(I64(VEC, MAT, I64, F64, F64, F64, F64, F64))
def log_event(S, ev, n, t, kind, before, after, value):
    S[S_NEVENTS] += 1.0
    if kind == S[S_STOP_ON]:
        S[S_STOPPED] = 1.0
    if n < ev.shape[0]:
        ev[n, 0] = t
        ev[n, 1] = kind
        ev[n, 2] = before
        ev[n, 3] = after
        ev[n, 4] = value
    return n + 1


@kernel
def in_band(S, P):
    """Is a contact point within the band? (A, B in F/G; none in flight)."""
    mode = int(S[S_MODE])
    if mode == MODE_A:
        return False
    xt = S[S_XT]
    w = P[P_BAND]
    # inclusive, with a few ulps of slack for round-off in the corner position
    tol = 8.0 * 2.220446049250313e-16 * (1.0 + abs(xt) + abs(S[S_X]))
    if mode == MODE_F or mode == MODE_G:
        xa = S[S_X] + P[P_R]
        xb = S[S_X] - P[P_R]
        return abs(xa - xt) <= w + tol or abs(xb - xt) <= w + tol
    dx, _ = corner_offset(P, contact_corner(mode), S[S_TH])
    return abs(S[S_X] + dx - xt) <= w + tol


@kernel(I64(VEC, VEC, MAT, I64), inner=True)
def judge_check(S, P, ev, n):
    """Record TTRTP once the current stay in the band has lasted the dwell time."""
    if S[S_INBAND] == 1.0 and math.isnan(S[S_TTRTP]):
        t_star = S[S_TIN] + P[P_DWELL]
        if S[S_T] >= t_star:
            S[S_TTRTP] = t_star
            m = S[S_MODE]
            n = log_event(S, ev, n, t_star, EV_TTRTP, m, m, 0.0)
    return n


@kernel(I64(VEC, VEC, MAT, I64, BOOL), inner=True)
def judge_set(S, P, ev, n, status):
    """The band status becomes `status` at the current time."""
    if status and S[S_INBAND] == 0.0:
        S[S_INBAND] = 1.0
        S[S_TIN] = S[S_T]
        n = log_event(S, ev, n, S[S_T], EV_BAND_IN, S[S_MODE], S[S_MODE], 0.0)
    elif (not status) and S[S_INBAND] == 1.0:
        n = judge_check(S, P, ev, n)
        S[S_INBAND] = 0.0
        n = log_event(S, ev, n, S[S_T], EV_BAND_OUT, S[S_MODE], S[S_MODE], 0.0)
    return n


@kernel(I64(VEC, VEC, MAT, I64), inner=True)
def judge_update(S, P, ev, n):
    n = judge_set(S, P, ev, n, in_band(S, P))
    return judge_check(S, P, ev, n)
