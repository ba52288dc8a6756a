"""The single-contact phases' step (states B-E): the reduced dynamics and one DOP853
step of them, the guard functions and their rates, and the location of the first guard
crossing inside an accepted step (contact_phases.py drives a phase with them).

Reduced state u = (theta, omega, x, vx); y and vy follow from the contact constraint.
Its vectors and the guards' live in the workspace (layout.py: W_U ..., GUARD_*).
"""

import math

import numpy as np

from hoprover_env.core._dop853_tableau import E3 as _RK_E3
from hoprover_env.core._dop853_tableau import E5 as _RK_E5
from hoprover_env.core._dop853_tableau import A as _RK_A
from hoprover_env.core._dop853_tableau import B as _RK_B
from hoprover_env.core.forces import corner_offset, pivot_dynamics, slide_dynamics
from hoprover_env.core.layout import (
    GUARD_BAND,
    GUARD_FRICTION,
    GUARD_LIFTOFF,
    GUARD_TOP_L,
    GUARD_TOP_R,
    GUARD_TOUCH,
    N_GUARDS,
    PH_BAND,
    PH_BROKEN,
    PH_LIFTOFF,
    PH_SLIP,
    PH_STICK,
    PH_TOUCH,
)
from hoprover_env.core.params import P_BAND, P_G, P_GS, P_M, P_MUS
from hoprover_env.jit.compiler import BOOL, I64, kernel


@kernel(inner=True)
def _next_band_boundary(xp, sigma, xt, w, offset):
    """Nearest boundary of the band (for a point at c.m. offset `offset`) strictly ahead
    of xp in direction sigma, as a c.m. position; NaN when none is ahead."""
    best = np.nan
    for b in (xt - w - offset, xt + w - offset):
        if sigma * (b - xp) > 1e-15 * (1.0 + abs(xp)):
            if math.isnan(best) or sigma * (b - best) < 0.0:
                best = b
    return best


@kernel(inner=True)
def _rhs(P, k, sliding, sigma, T, u, out):
    if sliding:
        thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, u[0], u[1])
    else:
        thdd, fx, fy, dx, dy = pivot_dynamics(P, k, T, u[0], u[1])
    out[0] = u[1]
    out[1] = thdd
    out[2] = u[3]
    out[3] = fx / P[P_M] - P[P_GS]


@kernel(inner=True)
def _finite4(u):
    return (
        math.isfinite(u[0]) and math.isfinite(u[1]) and math.isfinite(u[2]) and math.isfinite(u[3])
    )


@kernel(inner=True)
def _dop853_step(P, k, sliding, sigma, T, u, h, f0, kst, ytmp, unew, rtol, atol):
    """One DOP853 step of length h from u (f0 = f(u)); returns the scaled error norm."""
    for j in range(4):
        kst[0, j] = f0[j]
    for s in range(1, 12):
        for j in range(4):
            acc = 0.0
            for q in range(s):
                acc += _RK_A[s, q] * kst[q, j]
            ytmp[j] = u[j] + h * acc
        _rhs(P, k, sliding, sigma, T, ytmp, kst[s])
    for j in range(4):
        acc = 0.0
        for q in range(12):
            acc += _RK_B[q] * kst[q, j]
        unew[j] = u[j] + h * acc
    _rhs(P, k, sliding, sigma, T, unew, kst[12])
    e5 = 0.0
    e3 = 0.0
    for j in range(4):
        a5 = 0.0
        a3 = 0.0
        for q in range(13):
            a5 += _RK_E5[q] * kst[q, j]
            a3 += _RK_E3[q] * kst[q, j]
        sc = atol[j] + rtol * max(abs(u[j]), abs(unew[j]))
        e5 += (a5 / sc) ** 2
        e3 += (a3 / sc) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 4.0)


@kernel(inner=True)
def _guards(P, k, sliding, sigma, T, xpiv, xt, u, gv):
    """Guard functions of a single-contact phase (positive = no event yet).

    GUARD_LIFTOFF: f_y / (m g)
    GUARD_FRICTION: pivot: (mu_s f_y - |f_x|) / (m g) (slip); slide: sigma * v_Px (stick)
    GUARD_TOUCH: the other bottom corner's height (it closes onto both corners: impact)
    GUARD_TOP_R, GUARD_TOP_L: the top corners' heights (broken)
    GUARD_BAND: slide only: distance to the next band boundary ahead (band crossing)
    """
    m = P[P_M]
    mg = m * P[P_G]
    th = u[0]
    w = u[1]
    if sliding:
        _, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, th, w)
    else:
        _, fx, fy, dx, dy = pivot_dynamics(P, k, T, th, w)
    gv[GUARD_LIFTOFF] = fy / mg
    y = -dy
    if sliding:
        gv[GUARD_FRICTION] = sigma * (u[3] + w * dy)
        xp = u[2] + dx
        b = _next_band_boundary(xpiv, sigma, xt, P[P_BAND], 0.0)
        gv[GUARD_BAND] = np.inf if math.isnan(b) else sigma * (b - xp)
    else:
        gv[GUARD_FRICTION] = (P[P_MUS] * fy - abs(fx)) / mg
        gv[GUARD_BAND] = np.inf
    _, dyo = corner_offset(P, 1 - k, th)
    gv[GUARD_TOUCH] = y + dyo
    _, dy2 = corner_offset(P, 2, th)
    _, dy3 = corner_offset(P, 3, th)
    gv[GUARD_TOP_R] = y + dy2
    gv[GUARD_TOP_L] = y + dy3


@kernel(inner=True)
def _force_guards(P, k, sliding, sigma, T, th, w):
    """The two force guards (lift-off, slip) as functions of (theta, omega)."""
    mg = P[P_M] * P[P_G]
    if sliding:
        _, fx, fy, _, _ = slide_dynamics(P, k, sigma, T, th, w)
        return fy / mg, 0.0
    _, fx, fy, _, _ = pivot_dynamics(P, k, T, th, w)
    return fy / mg, (P[P_MUS] * fy - abs(fx)) / mg


@kernel(inner=True)
def _guard_rates(P, k, sliding, sigma, T, u, du, gr):
    """Time derivatives of the guards at u (du = f(u)): analytic for the heights, the
    stick and the band guards, central differences in (theta, omega) for the forces."""
    th = u[0]
    w = u[1]
    eps_t = 1e-6
    eps_w = 1e-6 * (abs(w) + 1e-3)
    a_tp, b_tp = _force_guards(P, k, sliding, sigma, T, th + eps_t, w)
    a_tm, b_tm = _force_guards(P, k, sliding, sigma, T, th - eps_t, w)
    a_wp, b_wp = _force_guards(P, k, sliding, sigma, T, th, w + eps_w)
    a_wm, b_wm = _force_guards(P, k, sliding, sigma, T, th, w - eps_w)
    gr[GUARD_LIFTOFF] = (a_tp - a_tm) / (2 * eps_t) * du[0] + (a_wp - a_wm) / (2 * eps_w) * du[1]
    dxk, dyk = corner_offset(P, k, th)
    if sliding:
        # sigma * d/dt v_Px = sigma * (ax + thdd dy - w^2 dx)
        gr[GUARD_FRICTION] = sigma * (du[3] + du[1] * dyk - w * w * dxk)
        gr[GUARD_BAND] = -sigma * (u[3] + w * dyk)
    else:
        gr[GUARD_FRICTION] = (b_tp - b_tm) / (2 * eps_t) * du[0] + (b_wp - b_wm) / (2 * eps_w) * du[
            1
        ]
        gr[GUARD_BAND] = 0.0
    # the heights' rates: GUARD_TOUCH (the other bottom corner), GUARD_TOP_R (corner
    # 2), GUARD_TOP_L (corner 3) in turn
    for c in range(3):
        dxc, _ = corner_offset(P, (1 - k) if c == 0 else c + 1, th)
        gr[GUARD_TOUCH + c] = w * (dxk - dxc)  # that corner's vertical speed (vy = w dx_k)


@kernel(inner=True)
def _hermite_dip(g0, g1, d0, d1):
    """Where the cubic Hermite interpolant of a guard over a step (values g0, g1 and
    slopes d0, d1 per unit step) is lowest inside (0, 1): returns (tau, value)."""
    # p(t) = g0 h00 + d0 h10 + g1 h01 + d1 h11 ; p'(t) = a t^2 + b t + c
    a = 6.0 * g0 + 3.0 * d0 - 6.0 * g1 + 3.0 * d1
    b = -6.0 * g0 - 4.0 * d0 + 6.0 * g1 - 2.0 * d1
    c = d0
    best_t = 0.5
    best_v = np.inf
    if abs(a) > 1e-300:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            for r in ((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)):
                if 0.0 < r < 1.0:
                    t2 = r * r
                    t3 = t2 * r
                    v = (
                        g0 * (2 * t3 - 3 * t2 + 1)
                        + d0 * (t3 - 2 * t2 + r)
                        + g1 * (-2 * t3 + 3 * t2)
                        + d1 * (t3 - t2)
                    )
                    if v < best_v:
                        best_v = v
                        best_t = r
    elif abs(b) > 1e-300:
        r = -c / b
        if 0.0 < r < 1.0:
            t2 = r * r
            t3 = t2 * r
            best_v = (
                g0 * (2 * t3 - 3 * t2 + 1)
                + d0 * (t3 - 2 * t2 + r)
                + g1 * (-2 * t3 + 3 * t2)
                + d1 * (t3 - t2)
            )
            best_t = r
    return best_t, best_v


@kernel(inner=True)
def _first_crossing(
    P,
    k,
    sliding,
    sigma,
    T,
    xpiv,
    xt,
    h,
    rtol,
    u,
    atol,
    gv,
    gnew,
    level,
    f0,
    kst,
    ytmp,
    utry,
    rate0,
    rate1,
    gtry,
    gtmp,
):
    """The guard that crosses its level first inside the accepted step of length h (the
    guards and rates at both ends given), and the step length s where it does: (-1, h)
    when none does."""
    first = -1
    s_first = h
    for i in range(N_GUARDS):
        if gnew[i] - level[i] <= 0.0:
            s_i = _locate(
                P,
                k,
                sliding,
                sigma,
                T,
                xpiv,
                xt,
                u,
                h,
                f0,
                kst,
                ytmp,
                utry,
                gtmp,
                rtol,
                atol,
                i,
                level[i],
                gv[i] - level[i],
                gnew[i] - level[i],
            )
            if first < 0 or s_i < s_first:
                first = i
                s_first = s_i
    # A guard positive at both ends may still have dipped through its level inside
    # the step (the body rocking through theta = 0 and back): look where its cubic
    # Hermite interpolant is lowest and confirm there with the step itself.
    for i in range(N_GUARDS):
        if gnew[i] - level[i] > 0.0 and rate0[i] * rate1[i] < 0.0 and rate0[i] < 0.0:
            tau, low = _hermite_dip(
                gv[i] - level[i], gnew[i] - level[i], rate0[i] * h, rate1[i] * h
            )
            if low < 0.0:
                _dop853_step(P, k, sliding, sigma, T, u, tau * h, f0, kst, ytmp, utry, rtol, atol)
                _guards(P, k, sliding, sigma, T, xpiv, xt, utry, gtry)
                if gtry[i] - level[i] <= 0.0:
                    s_i = _locate(
                        P,
                        k,
                        sliding,
                        sigma,
                        T,
                        xpiv,
                        xt,
                        u,
                        tau * h,
                        f0,
                        kst,
                        ytmp,
                        utry,
                        gtmp,
                        rtol,
                        atol,
                        i,
                        level[i],
                        gv[i] - level[i],
                        gtry[i] - level[i],
                    )
                    if first < 0 or s_i < s_first:
                        first = i
                        s_first = s_i
    return first, s_first


@kernel(I64(I64, BOOL), inner=True)
def _guard_event(guard, sliding):
    """The phase end (PH_*) a guard's crossing means."""
    if guard == GUARD_LIFTOFF:
        return PH_LIFTOFF
    if guard == GUARD_FRICTION:
        return PH_STICK if sliding else PH_SLIP
    if guard == GUARD_TOUCH:
        return PH_TOUCH
    if guard == GUARD_BAND:
        return PH_BAND
    return PH_BROKEN


@kernel(inner=True)
def _locate(
    P, k, sliding, sigma, T, xpiv, xt, u, h, f0, kst, ytmp, utry, gtmp, rtol, atol, gi, lev, fa, fb
):
    """Smallest s in (0, h] where guard gi - lev changes sign: Illinois regula falsi on
    the step length (the DOP853 step re-taken from u). Returns the right end of the
    final bracket, so the event has happened at the returned length."""
    a = 0.0
    b = h
    side = 0
    stol = 4.0 * 2.220446049250313e-16 * h + 1e-300
    for _ in range(200):
        if b - a <= stol:
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        _dop853_step(P, k, sliding, sigma, T, u, c, f0, kst, ytmp, utry, rtol, atol)
        _guards(P, k, sliding, sigma, T, xpiv, xt, utry, gtmp)
        fc = gtmp[gi] - lev
        if fc <= 0.0:
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
            if fc == 0.0:
                break
        else:
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
    return b
