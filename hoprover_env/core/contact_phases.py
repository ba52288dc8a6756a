"""The event integrator's contact phases: state G in closed form and the
single-contact states B-E by DOP853 with every guard located as an event."""

import math

import numpy as np

from hoprover_env.core._dop853_tableau import E3 as _RK_E3
from hoprover_env.core._dop853_tableau import E5 as _RK_E5
from hoprover_env.core._dop853_tableau import A as _RK_A
from hoprover_env.core._dop853_tableau import B as _RK_B
from hoprover_env.core.forces import contact_corner, corner_offset, pivot_dynamics, slide_dynamics
from hoprover_env.core.layout import (
    ERR_STEP,
    ERR_WORK,
    F_TOL,
    GUARD_BAND,
    GUARD_FRICTION,
    GUARD_LIFTOFF,
    GUARD_TOP_L,
    GUARD_TOP_R,
    GUARD_TOUCH,
    H_TOL,
    MAX_RK_STEPS,
    MAX_WORK,
    MODE_C,
    MODE_E,
    N_GUARDS,
    N_U,
    O_RTOL,
    PH_BAND,
    PH_BROKEN,
    PH_LIFTOFF,
    PH_NONE,
    PH_SLIP,
    PH_STICK,
    PH_STOP,
    PH_TOUCH,
    RK_MAX_FACTOR,
    RK_MIN_FACTOR,
    RK_SAFETY,
    RK_STAGES,
    S_ERROR,
    S_HSTEP,
    S_MODE,
    S_SIGMA,
    S_T,
    S_TH,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_XT,
    S_Y,
    V_TOL,
    W_ARMED,
    W_ATOL,
    W_F0,
    W_F1,
    W_GNEW,
    W_GTMP,
    W_GTOL,
    W_GTRY,
    W_GV,
    W_KST,
    W_LEVEL,
    W_RATE0,
    W_RATE1,
    W_U,
    W_UNEW,
    W_UTRY,
    W_WORK,
    W_YTMP,
)
from hoprover_env.core.params import P_BAND, P_G, P_GC, P_GS, P_M, P_MUD, P_MUS, P_R
from hoprover_env.jit.compiler import BOOL, F64, I64, VEC, kernel


# ----------------------------------------------------------------------------------
# Event integrator: state G in closed form
# ----------------------------------------------------------------------------------
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


@kernel(I64(VEC, VEC, F64), inner=True)
def g_phase(S, P, t_stop):
    """Slide on both corners: x(t) quadratic, x'' = -g sin(phi) - sigma mu_d g cos(phi).

    The speed u = sigma vx falls at a = mu_d gc + sigma gs (on level ground mu_d g) to a
    stop; a <= 0 (sliding down a slope steeper than atan(mu_d)) never stops.
    Events: the stop (G -> F) and the next band boundary of either corner.
    """
    sigma = S[S_SIGMA]
    a = P[P_MUD] * P[P_GC] + sigma * P[P_GS]
    u = sigma * S[S_VX]  # speed, > 0
    tau_end = t_stop - S[S_T]
    tau_stop = u / a if a > 0.0 else np.inf
    kind = PH_NONE
    tau = tau_end
    if tau_stop <= tau_end:
        kind = PH_STOP
        tau = tau_stop
    # band boundaries for either corner (offsets +r for A, -r for B)
    x0 = S[S_X]
    for off in (P[P_R], -P[P_R]):
        b = _next_band_boundary(x0, sigma, S[S_XT], P[P_BAND], off)
        if not math.isnan(b):
            d = sigma * (b - x0)
            disc = u * u - 2.0 * a * d
            if disc >= 0.0:
                tb = 2.0 * d / (u + math.sqrt(disc))
                if tb < tau:
                    tau = tb
                    kind = PH_BAND
    S[S_X] = x0 + sigma * (u * tau - 0.5 * a * tau * tau)
    S[S_VX] = sigma * (u - a * tau)
    S[S_T] = t_stop if kind == PH_NONE else S[S_T] + tau
    if kind == PH_STOP:
        S[S_VX] = 0.0
    return kind


# ----------------------------------------------------------------------------------
# Event integrator: single-contact phases (B-E) by DOP853 with event location
# ----------------------------------------------------------------------------------
# Reduced state u = (theta, omega, x, vx); y and vy follow from the contact constraint.
# Its vectors and the guards' live in the workspace (layout.py: W_U ..., GUARD_*).


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
def _rk_vectors(W):
    """The contact phases' vectors in the workspace (layout W_U ... in layout.py)."""
    return (
        W[W_U : W_U + N_U],
        W[W_ATOL : W_ATOL + N_U],
        W[W_GV : W_GV + N_GUARDS],
        W[W_GNEW : W_GNEW + N_GUARDS],
        W[W_LEVEL : W_LEVEL + N_GUARDS],
        W[W_GTOL : W_GTOL + N_GUARDS],
        W[W_ARMED : W_ARMED + N_GUARDS],
        W[W_F0 : W_F0 + N_U],
        W[W_KST : W_KST + RK_STAGES * N_U].reshape((RK_STAGES, N_U)),
        W[W_YTMP : W_YTMP + N_U],
        W[W_UNEW : W_UNEW + N_U],
        W[W_UTRY : W_UTRY + N_U],
        W[W_F1 : W_F1 + N_U],
        W[W_RATE0 : W_RATE0 + N_GUARDS],
        W[W_RATE1 : W_RATE1 + N_GUARDS],
        W[W_GTRY : W_GTRY + N_GUARDS],
        W[W_GTMP : W_GTMP + N_GUARDS],
    )


@kernel(inner=True)
def _start_phase(S, P, k, sliding, sigma, T, rtol, xpiv, xt, dx0, W):
    """Load u from S, set the tolerances, evaluate the guards and arm them. Returns
    PH_TOUCH or PH_BROKEN when the phase ends before it starts, else PH_NONE."""
    u, atol, gv, _, level, tol, armed, f0, _, _, _, _, _, rate0, _, _, _ = _rk_vectors(W)
    u[0] = S[S_TH]
    u[1] = S[S_W]
    u[2] = S[S_X]
    u[3] = S[S_VX]
    # absolute tolerances from the problem's natural scales
    atol[0] = rtol * 1.0
    atol[1] = rtol * 0.1
    atol[2] = rtol * 1.0
    atol[3] = rtol * 0.01
    tol[GUARD_LIFTOFF] = F_TOL
    tol[GUARD_FRICTION] = V_TOL if sliding else F_TOL
    tol[GUARD_TOUCH] = H_TOL
    tol[GUARD_TOP_R] = H_TOL
    tol[GUARD_TOP_L] = H_TOL
    tol[GUARD_BAND] = 0.0
    _guards(P, k, sliding, sigma, T, xpiv, xt, u, gv)
    # the other bottom corner already down and moving down: impact now
    dxo, dyo = corner_offset(P, 1 - k, u[0])
    vyo = S[S_W] * dx0 - S[S_W] * dxo  # vy = w dx_k, minus w dx_other
    if gv[GUARD_TOUCH] <= H_TOL and vyo < -V_TOL:
        return PH_TOUCH
    if gv[GUARD_TOP_R] <= 0.0 or gv[GUARD_TOP_L] <= 0.0:
        return PH_BROKEN
    _rhs(P, k, sliding, sigma, T, u, f0)
    _guard_rates(P, k, sliding, sigma, T, u, f0, rate0)
    for i in range(N_GUARDS):
        armed[i] = 1.0 if gv[i] > tol[i] else 0.0
        level[i] = 0.0 if armed[i] != 0.0 else min(gv[i], 0.0) - tol[i]
    if armed[GUARD_TOUCH] == 0.0 and rate0[GUARD_TOUCH] > V_TOL:
        # the other corner leaves the ground at first order (it bounced): its next
        # touchdown is at the height it starts from, not H_TOL lower (see flight_phase)
        armed[GUARD_TOUCH] = 1.0
        level[GUARD_TOUCH] = min(gv[GUARD_TOUCH], 0.0)
    return PH_NONE


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
def _next_step_start(u, gv, gnew, level, tol, armed, f0, unew, f1, rate0, rate1):
    """The accepted step's end becomes the next step's start; a guard that has moved
    clear of its level is armed (it fires at 0 from now on)."""
    for j in range(N_U):
        u[j] = unew[j]
        f0[j] = f1[j]
    for i in range(N_GUARDS):
        gv[i] = gnew[i]
        rate0[i] = rate1[i]
        if armed[i] == 0.0 and gv[i] > tol[i]:
            armed[i] = 1.0
            level[i] = 0.0


@kernel(inner=True)
def _write_back(S, P, k, sliding, u, xpiv, t):
    """Write the reduced state u back to S at time t; the contact constraint gives y and
    vy (and x, vx when pivoting about xpiv)."""
    th = u[0]
    w = u[1]
    dx, dy = corner_offset(P, k, th)
    S[S_TH] = th
    S[S_W] = w
    S[S_Y] = -dy
    S[S_VY] = w * dx
    if sliding:
        S[S_X] = u[2]
        S[S_VX] = u[3]
    else:
        S[S_X] = xpiv - dx
        S[S_VX] = -w * dy
    S[S_T] = t


@kernel(I64(VEC, VEC, VEC, F64, VEC), inner=True)
def contact_phase(S, P, O, t_stop, W):
    """Advance a single-contact phase (B, C, D, E) to t_stop or its first event.

    Adaptive DOP853 on u = (theta, omega, x, vx). After each accepted step the guards
    are evaluated; a guard that crossed its level is located by root finding
    (Illinois) on the step length s, re-taking the step from its start with length s,
    so the event is as accurate as the step itself. A guard that starts on its
    switching surface (a slide starting from rest, a corner just lifted) is armed only
    after it has moved clear of it, so the search finds the *next* crossing.
    """
    mode = int(S[S_MODE])
    k = contact_corner(mode)
    sliding = mode == MODE_C or mode == MODE_E
    sigma = S[S_SIGMA]
    T = S[S_TORQUE]
    rtol = O[O_RTOL]
    xt = S[S_XT]
    dx0, dy0 = corner_offset(P, k, S[S_TH])
    xpiv = S[S_X] + dx0  # pivot point (fixed when pivoting)
    kind = _start_phase(S, P, k, sliding, sigma, T, rtol, xpiv, xt, dx0, W)
    if kind != PH_NONE:
        return kind
    # the hot loop below passes these views on (not W): one slicing per phase
    (
        u,
        atol,
        gv,
        gnew,
        level,
        tol,
        armed,
        f0,
        kst,
        ytmp,
        unew,
        utry,
        f1,
        rate0,
        rate1,
        gtry,
        gtmp,
    ) = _rk_vectors(W)
    h_prop = S[S_HSTEP]  # proposed step, remembered across phases
    if not (h_prop > 0.0 and h_prop < math.inf):
        h_prop = 1e-3
    t = S[S_T]
    n_steps = 0
    while t < t_stop:
        h = h_prop
        last = False
        if h >= t_stop - t:
            h = t_stop - t
            last = True
        err = _dop853_step(P, k, sliding, sigma, T, u, h, f0, kst, ytmp, unew, rtol, atol)
        n_steps += 1
        if n_steps > MAX_RK_STEPS:
            S[S_ERROR] = ERR_STEP  # a bound on every loop: never a hang
            break
        W[W_WORK] += 1.0
        if W[W_WORK] > MAX_WORK:
            S[S_ERROR] = ERR_WORK
            break
        # written so that a NaN error (an overflowing trial step) is a rejection: with
        # `err > 1.0` it was accepted, and time crept towards a limit short of t_stop
        if not (err <= 1.0) or not _finite4(unew):
            if err > 1.0 and err < math.inf:
                h_prop = h * max(RK_MIN_FACTOR, RK_SAFETY * err ** (-1.0 / 8.0))
            else:
                h_prop = h * RK_MIN_FACTOR
            if h_prop < 1e-14 * (1.0 + abs(t)):
                S[S_ERROR] = ERR_STEP  # step-size underflow: the field is too stiff
                break
            continue
        for j in range(N_U):
            f1[j] = kst[RK_STAGES - 1, j]  # kst is scratch for the searches below
        _guards(P, k, sliding, sigma, T, xpiv, xt, unew, gnew)
        _guard_rates(P, k, sliding, sigma, T, unew, f1, rate1)
        first, s_first = _first_crossing(
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
        )
        if first >= 0:
            _dop853_step(P, k, sliding, sigma, T, u, s_first, f0, kst, ytmp, unew, rtol, atol)
            for j in range(N_U):
                u[j] = unew[j]
            t += s_first
            kind = _guard_event(first, sliding)
            break
        _next_step_start(u, gv, gnew, level, tol, armed, f0, unew, f1, rate0, rate1)
        t = t_stop if last else t + h
        fac = (
            RK_MAX_FACTOR
            if err == 0.0
            else min(RK_MAX_FACTOR, max(RK_MIN_FACTOR, RK_SAFETY * err ** (-1.0 / 8.0)))
        )
        if last and h < h_prop:
            h_prop = max(h_prop, h * fac)  # a step cut short by t_stop says little
        else:
            h_prop = h * fac
    S[S_HSTEP] = h_prop
    _write_back(S, P, k, sliding, u, xpiv, t)
    return kind


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
