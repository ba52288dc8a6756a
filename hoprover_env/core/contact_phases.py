"""The event integrator's contact phases: state G in closed form and the
single-contact states B-E by DOP853 with every guard located as an event (the step, the
guards and their location: contact_steps.py)."""

import math

import numpy as np

from hoprover_env.core.contact_steps import (
    _dop853_step,
    _finite4,
    _first_crossing,
    _guard_event,
    _guard_rates,
    _guards,
    _next_band_boundary,
    _rhs,
)
from hoprover_env.core.forces import contact_corner, corner_offset
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
    PH_NONE,
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
from hoprover_env.core.params import P_BAND, P_GC, P_GS, P_MUD, P_R
from hoprover_env.jit.compiler import F64, I64, VEC, kernel


# ----------------------------------------------------------------------------------
# Event integrator: state G in closed form
# ----------------------------------------------------------------------------------
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
