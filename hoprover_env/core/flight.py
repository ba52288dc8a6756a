"""Flight (state A): the closed form, touchdown location and the event integrator's
flight phase by conservative advancement on the closed form."""

import math

import numpy as np

from hoprover_env.core.forces import corner_body, corner_offset, corner_offset_cs
from hoprover_env.core.layout import (
    A_TOL,
    CA_TOL,
    ERR_STEP,
    ERR_WORK,
    FLIGHT_WINDOW_MAX,
    H_IMPACT,
    H_TOL,
    MAX_CA_ITER,
    MAX_WORK,
    PH_BROKEN,
    PH_NONE,
    PH_TOUCH,
    S_ERROR,
    S_T,
    S_TH,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_Y,
    V_TOL,
    W_FLT,
    W_WORK,
)
from hoprover_env.core.params import P_GC, P_GS, P_H, P_I, P_R
from hoprover_env.jit.compiler import BOOL, F64, I64, VEC, I64x2, kernel


# ----------------------------------------------------------------------------------
# Flight (state A) in closed form
# ----------------------------------------------------------------------------------
@kernel(inner=True)
def flight_at(S, P, tau):
    """State after a flight of duration tau under the held torque: a parabola with both
    components of gravity in the ground frame, g (-sin phi, -cos phi)."""
    g = P[P_GC]
    gs = P[P_GS]
    beta = S[S_TORQUE] / P[P_I]
    x = S[S_X] + S[S_VX] * tau - 0.5 * gs * tau * tau
    y = S[S_Y] + S[S_VY] * tau - 0.5 * g * tau * tau
    th = S[S_TH] + S[S_W] * tau + 0.5 * beta * tau * tau
    return x, y, th, S[S_VX] - gs * tau, S[S_VY] - g * tau, S[S_W] + beta * tau


@kernel(F64(VEC, VEC, I64, F64), inner=True)
def flight_rise(S, P, k, tau):
    """Height gained by corner k after a flight of duration tau, h_k(tau) - h_k(0),
    computed as a difference (sin a - sin b = 2 cos((a+b)/2) sin((a-b)/2)): a corner
    that returns to the ground microseconds after a lift-off moves 1e-14 m, below the
    round-off of y + dy(theta) (~1e-17 m at y ~ 0.05 m, i.e. 1e-8 s at 1e-9 m/s)."""
    bx, by = corner_body(P, k)
    dth = S[S_W] * tau + 0.5 * S[S_TORQUE] / P[P_I] * tau * tau
    mid = S[S_TH] + 0.5 * dth
    sh = math.sin(0.5 * dth)
    d_sin = 2.0 * math.cos(mid) * sh
    d_cos = -2.0 * math.sin(mid) * sh
    return S[S_VY] * tau - 0.5 * P[P_GC] * tau * tau - bx * d_sin + by * d_cos


@kernel(F64(VEC, VEC, I64, F64, F64, F64), inner=True)
def _bisect_touchdown(S, P, k, lo, hi, drop):
    """The time in [lo, hi] at which corner k has risen by `drop` (< 0: it is back at
    the level where it should touch), given rise(lo) >= drop > rise(hi). Bisection on
    the closed form: robust where Newton divides by a vanishing vertical speed."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if flight_rise(S, P, k, mid) >= drop:
            lo = mid
        else:
            hi = mid
    return hi


@kernel(BOOL(VEC, VEC, I64), inner=True)
def resting_corner_driven_down(S, P, k):
    """A corner on the ground at rest vertically, in flight: is it pressed down?

    Decided by the flight dynamics (docs/MODEL.md section 5): the sign of the corner's
    vertical acceleration h'' = -g cos(phi) - beta dx - w^2 dy, or when that vanishes (a lift-off
    instant) of its jerk h''' = -3 beta w dy + w^3 dx.
    """
    beta = S[S_TORQUE] / P[P_I]
    w = S[S_W]
    dx, dy = corner_offset(P, k, S[S_TH])
    acc = -P[P_GC] - beta * dx - w * w * dy
    if acc < -A_TOL:
        return True
    if acc > A_TOL:
        return False
    jerk = -3.0 * beta * w * dy + w * w * w * dx
    return jerk < 0.0


# ----------------------------------------------------------------------------------
# Event integrator: flight by conservative advancement on closed forms
# ----------------------------------------------------------------------------------


@kernel(inner=True)
def _commit_flight(S, P, tau):
    x, y, th, vx, vy, w = flight_at(S, P, tau)
    S[S_X] = x
    S[S_Y] = y
    S[S_TH] = th
    S[S_VX] = vx
    S[S_VY] = vy
    S[S_W] = w
    S[S_T] += tau


@kernel(F64(VEC, VEC, I64, F64, F64, F64, F64, F64, F64), inner=True)
def _polish_touchdown(S, P, k, tau, tau_end, level, armed, f, v):
    """Place a detected touchdown of corner k (at tau, height f above its trigger level,
    descending at v) on the closed form's root, safeguarded against small v."""
    c0 = math.cos(S[S_TH])
    s0 = math.sin(S[S_TH])
    h0 = S[S_Y] + corner_offset_cs(P, k, c0, s0)[1]
    if armed == 0.0:
        # back down before it ever rose above H_TOL (it triggered H_TOL under the
        # ground): the touchdown is where it returns to the level it left from
        target = level + H_TOL
        if h0 >= target:
            return _bisect_touchdown(S, P, k, 0.0, tau, target - h0)
        return tau
    if f <= 0.0 or v >= 0.0:
        return tau
    # CA_TOL is a height: at the 1e-9 m/s of a slow return it is still 1e-6 s from the
    # root, and one Newton step (f / v) can land anywhere. Bracket the root (from the
    # Newton step, doubled while the corner is still above ground) and bisect it.
    dt = f / (-v)
    for _ in range(64):
        hi = min(tau + dt, tau_end)
        if flight_rise(S, P, k, hi) + h0 < 0.0:
            return _bisect_touchdown(S, P, k, tau, hi, -h0)
        if hi >= tau_end:
            break
        dt *= 2.0
    return tau  # it curves away within CA_TOL of the ground: touching at tau


@kernel(I64x2(VEC, VEC, F64, VEC), inner=True)
def flight_phase(S, P, t_stop, W):
    """Advance a flight under constant torque to t_stop or the first touchdown.

    Each corner height h_k(t) = y(t) + dy_k(theta(t)) is known in closed form, with
    |h_k''| <= K = g + l (|T|/I + w_max^2) over a window. Stepping by the smallest
    positive root of h + h' s - K s^2 / 2 = 0 (and no further than the window) can
    never pass a root (conservative advancement), converges quadratically at a
    transversal touchdown, and finishes a high flight in a few steps. The window is
    local, not the whole interval: under a torque held for minutes the spin rate at
    the end of the interval can be 100x the current one, and a bound built on it
    shrank steps to 1e-7 s right after a lift-off until the iteration budget ran out
    mid-air. The window grows 4x per step, so w_max follows the spin as it builds.
    A corner that starts on the ground (just lifted off or bounced) is only armed once
    it has risen above H_TOL; until then it triggers if it comes back below -H_TOL.
    Returns (kind, corner); (PH_NONE, -1) with t < t_stop when the iteration budget
    runs out away from the ground (the caller calls again).
    """
    tau_end = t_stop - S[S_T]
    if tau_end <= 0.0:
        return PH_NONE, -1
    g = P[P_GC]  # corner heights feel only gravity's normal component
    beta = S[S_TORQUE] / P[P_I]
    ell = math.hypot(P[P_R], P[P_H])
    w0 = S[S_W]
    level = W[W_FLT : W_FLT + 4]
    armed = W[W_FLT + 4 : W_FLT + 8]  # 1.0 / 0.0 flags
    kind, corner = _arm_corners(S, P, level, armed)
    if kind != PH_NONE:
        return kind, corner
    tau = 0.0
    # capped so that w_max^2 stays finite for a t_stop of 1e300 (an infinite K made
    # every step NaN, and the flight jumped to t_stop through the ground)
    window = min(tau_end, FLIGHT_WINDOW_MAX)
    for _ in range(MAX_CA_ITER):
        x, y, th, vx, vy, w = flight_at(S, P, tau)
        # |omega| is linear in time, so its bound over [tau, tau + window] is at an end
        window = min(window, tau_end - tau)
        W[W_WORK] += 1.0
        if W[W_WORK] > MAX_WORK:
            S[S_ERROR] = ERR_WORK
            _commit_flight(S, P, tau)
            return PH_NONE, -1
        wmax = max(abs(w), abs(w0 + beta * (tau + window)))
        kbound = g + ell * (abs(beta) + wmax * wmax)
        if not kbound < math.inf:
            S[S_ERROR] = ERR_STEP
            _commit_flight(S, P, tau)
            return PH_NONE, -1
        hit, hit_f, hit_v, step = _nearest_touchdown(P, y, th, vy, w, kbound, level, armed)
        if hit >= 0:
            tau = _polish_touchdown(S, P, hit, tau, tau_end, level[hit], armed[hit], hit_f, hit_v)
            _commit_flight(S, P, tau)
            return (PH_BROKEN if hit >= 2 else PH_TOUCH), hit
        step = min(step, window)
        if tau + step >= tau_end:
            _commit_flight(S, P, tau_end)
            S[S_T] = t_stop
            return PH_NONE, -1
        tau += step
        window = min(4.0 * step, FLIGHT_WINDOW_MAX)
    return _budget_spent(S, P, tau)


@kernel(inner=True)
def _arm_corners(S, P, level, armed):
    """The corners at the flight's start: (PH_BROKEN or PH_TOUCH, corner) if one is
    already through the ground or moving into it, else (PH_NONE, -1) with each corner's
    level and armed flag set."""
    for k in range(4):
        level[k] = 0.0
        armed[k] = 1.0
    c0 = math.cos(S[S_TH])
    s0 = math.sin(S[S_TH])
    for k in range(4):
        dx, dy = corner_offset_cs(P, k, c0, s0)
        hk = S[S_Y] + dy
        vk = S[S_VY] - S[S_W] * dx
        if k >= 2:
            if hk <= 0.0:
                return PH_BROKEN, k
        elif hk <= H_TOL:
            if vk < -V_TOL:
                return PH_TOUCH, k
            if vk <= V_TOL:
                # at rest vertically (a lift-off): it separates at third order, so its
                # height is round-off for a while; armed once clear of H_TOL
                armed[k] = 0.0
                level[k] = min(hk, 0.0) - H_TOL
            # else it leaves at first order (a bounce): armed at once. The conservative
            # step 2 v / K lands exactly on the earliest possible return; arming only
            # above H_TOL let a pressed corner touch down H_TOL low and gain energy.
    return PH_NONE, -1


@kernel(inner=True)
def _nearest_touchdown(P, y, th, vy, w, kbound, level, armed):
    """One conservative-advancement look at the four corners (c.m. height y, attitude
    th, speeds vy, w; |h''| <= kbound): (corner, its height above its level, its
    vertical speed, step) for the lowest corner at its level and not rising, else
    corner -1 and the longest step no corner's height can reach its level in (a corner
    clear of H_TOL is armed on the way)."""
    c = math.cos(th)
    s = math.sin(th)
    step = np.inf
    hit = -1
    hit_f = np.inf
    hit_v = 0.0
    for k in range(4):
        bx, by = corner_body(P, k)
        dx = bx * c + by * s
        hk = y - bx * s + by * c
        vk = vy - w * dx
        if armed[k] == 0.0 and hk > H_TOL:
            armed[k] = 1.0
            level[k] = 0.0
        fk = hk - level[k]
        if fk <= CA_TOL and vk <= V_TOL:
            if fk < hit_f:
                hit = k
                hit_f = fk
                hit_v = vk
        else:
            fpos = max(fk, 0.0)
            sk = (vk + math.sqrt(vk * vk + 2.0 * kbound * fpos)) / kbound
            if sk < step:
                step = sk
    return hit, hit_f, hit_v, step


@kernel(inner=True)
def _budget_spent(S, P, tau):
    """The flight's iteration budget is spent at tau. Creeping along a grazing
    approach, the lowest bottom corner is within a round-off distance of the ground: it
    touches. Anywhere else nothing happened: hand back the time reached (never report a
    touchdown that did not happen; the caller's phase bound keeps this finite)."""
    _commit_flight(S, P, tau)
    h0 = S[S_Y] + corner_offset(P, 0, S[S_TH])[1]
    h1 = S[S_Y] + corner_offset(P, 1, S[S_TH])[1]
    if min(h0, h1) > H_IMPACT:
        return PH_NONE, -1
    return PH_TOUCH, 0 if h0 <= h1 else 1
