"""Instantaneous transitions between the contact states (docs/MODEL.md section 5)."""

import math

from hoprover_env.core.flight import resting_corner_driven_down
from hoprover_env.core.forces import (
    contact_corner,
    corner_offset_cs,
    double_contact_forces,
    pin_corner,
    pin_or_slide,
    pinned_mode,
    pivot_dynamics,
    set_double_contact,
    set_single_contact,
    slide_dynamics,
    sliding_mode,
    wrap_angle,
)
from hoprover_env.core.judge import log_event
from hoprover_env.core.layout import (
    A_TOL,
    EV_LIFTOFF,
    EV_RESUME,
    EV_REVERSE,
    EV_SLIP,
    EV_STICK,
    EV_TIP,
    F_TOL,
    H_TOL,
    MODE_A,
    MODE_B,
    MODE_C,
    MODE_D,
    MODE_E,
    MODE_F,
    MODE_G,
    S_MODE,
    S_SIGMA,
    S_T,
    S_TH,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_Y,
    V_TOL,
)
from hoprover_env.core.params import P_G, P_GC, P_GS, P_M, P_MUS
from hoprover_env.jit.compiler import F64, I64, MAT, VEC, kernel


# ----------------------------------------------------------------------------------
# Instantaneous transitions (docs/MODEL.md section 5)
# ----------------------------------------------------------------------------------
@kernel(F64(VEC, VEC, I64, F64), inner=True)
def _consistent_slide_direction(S, P, k, T):
    """A slide direction sigma of corner k, at rest horizontally, that is consistent:
    compressive normal force and the point accelerating along sigma (0 if none)."""
    m = P[P_M]
    ftol = F_TOL * m * P[P_G]
    w = S[S_W]
    for sigma in (1.0, -1.0):
        thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, S[S_TH], w)
        apx = fx / m - P[P_GS] + thdd * dy - w * w * dx
        if fy >= -ftol and sigma * apx > 0.0:
            return sigma
    return 0.0


@kernel(I64(VEC, VEC, MAT, I64))
def settle(S, P, ev, n):
    """Resolve every transition due at the current instant, in a bounded loop.

    Each pass checks the current state's consistency conditions (contact forces
    compressive, friction inside its cone, a slide that is really sliding, a resting
    corner in flight not pressed down) and switches state when one fails. Signs within
    the tolerances are decided by the dynamics (the next derivative), never by
    round-off. Returns the updated log count.
    """
    ftol = F_TOL * P[P_M] * P[P_G]
    for _ in range(12):
        mode = int(S[S_MODE])
        if mode == MODE_F or mode == MODE_G:
            n, moved = _settle_double(S, P, ev, n, mode, ftol)
        elif mode == MODE_B or mode == MODE_D:
            n, moved = _settle_pivot(S, P, ev, n, mode, ftol)
        elif mode == MODE_C or mode == MODE_E:
            n, moved = _settle_slide(S, P, ev, n, mode, ftol)
        else:
            n, moved = _resume_contact(S, P, ev, n)
        if not moved:
            return n
    return n


@kernel(inner=True)
def _settle_double(S, P, ev, n, mode, ftol):
    """F or G: a corner lifts (tip onto the other), or F's friction gives way (G).
    Returns (log count, whether the state changed)."""
    T = S[S_TORQUE]
    t = S[S_T]
    sigma = S[S_SIGMA] if mode == MODE_G else 0.0
    _, fay, _, fby = double_contact_forces(P, sigma, T)
    if fby < -ftol or fay < -ftol:
        # One corner lifts: the rover tips about the other (B/D pivot when at
        # rest, C/E slide when already sliding).
        k = 0 if fby < -ftol else 1
        if mode == MODE_F:
            new = pinned_mode(k)
            S[S_SIGMA] = 0.0
        else:
            new = sliding_mode(k)
        S[S_MODE] = new
        return log_event(S, ev, n, t, EV_TIP, mode, new, 0.0), True
    gs = P[P_GS]
    if mode == MODE_F and abs(gs) > P[P_MUS] * P[P_GC] + F_TOL * P[P_G]:
        # Static friction cannot hold the along-surface weight. Decision: the
        # split between the corners is indeterminate, so the totals decide:
        # F holds while |m g sin(phi)| <= mu_s (f_Ay + f_By) = mu_s m g cos(phi).
        S[S_MODE] = MODE_G
        S[S_SIGMA] = -1.0 if gs > 0.0 else 1.0  # down the slope
        return log_event(S, ev, n, t, EV_SLIP, mode, MODE_G, 0.0), True
    return n, False


@kernel(inner=True)
def _settle_pivot(S, P, ev, n, mode, ftol):
    """B or D: the pivot would need a pull (lift-off, or a slide when the free flight
    still presses the corner down), or friction leaves its cone (slip)."""
    T = S[S_TORQUE]
    t = S[S_T]
    k = contact_corner(mode)
    _, fx, fy, _, _ = pivot_dynamics(P, k, T, S[S_TH], S[S_W])
    if fy < -ftol:
        # Sticking would need a pull. If the free corner would rise, it lifts
        # off; if the flight dynamics still press it down (the pivot's
        # friction couples into the vertical through the rotation), neither
        # stick nor separation is consistent and the corner slides.
        sigma = 0.0
        if resting_corner_driven_down(S, P, k):
            sigma = _consistent_slide_direction(S, P, k, T)
        if sigma == 0.0:
            S[S_MODE] = MODE_A
            S[S_SIGMA] = 0.0
            return log_event(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0), True
        new = sliding_mode(k)
        S[S_MODE] = new
        S[S_SIGMA] = sigma
        return log_event(S, ev, n, t, EV_SLIP, mode, new, 0.0), True
    if abs(fx) > P[P_MUS] * fy + ftol:
        new = sliding_mode(k)
        S[S_MODE] = new
        S[S_SIGMA] = -1.0 if fx > 0.0 else 1.0
        return log_event(S, ev, n, t, EV_SLIP, mode, new, 0.0), True
    return n, False


@kernel(inner=True)
def _settle_slide(S, P, ev, n, mode, ftol):
    """C or E: lift-off, or a contact point (momentarily) at rest that sticks, reverses
    or keeps sliding as its acceleration and the friction cone decide."""
    m = P[P_M]
    T = S[S_TORQUE]
    t = S[S_T]
    k = contact_corner(mode)
    sigma = S[S_SIGMA]
    thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, S[S_TH], S[S_W])
    if fy < -ftol:
        S[S_MODE] = MODE_A
        S[S_SIGMA] = 0.0
        return log_event(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0), True
    w = S[S_W]
    vpx = S[S_VX] + w * dy
    if abs(vpx) > V_TOL:
        if vpx * sigma < 0.0:  # cannot happen after an event; keep sigma honest
            S[S_SIGMA] = 1.0 if vpx > 0.0 else -1.0
            return n, True
        return n, False
    # The contact point is (momentarily) at rest: does it keep sliding?
    apx = fx / m - P[P_GS] + thdd * dy - w * w * dx
    if sigma * apx > A_TOL:
        return n, False  # it accelerates in sigma: the slide goes on
    _, fxp, fyp, _, _ = pivot_dynamics(P, k, T, S[S_TH], w)
    if abs(fxp) <= P[P_MUS] * fyp + ftol and fyp >= -ftol:
        new = pinned_mode(k)
        pin_corner(S, P, k)
        S[S_MODE] = new
        S[S_SIGMA] = 0.0
        return log_event(S, ev, n, t, EV_STICK, mode, new, 0.0), True
    new_sigma = -1.0 if fxp > 0.0 else 1.0
    if new_sigma != sigma:
        S[S_SIGMA] = new_sigma
        return log_event(S, ev, n, t, EV_REVERSE, mode, mode, 0.0), True
    return n, False


@kernel(inner=True)
def _resume_contact(S, P, ev, n):
    """Flight: a bottom corner lying on the ground at rest vertically that the flight
    dynamics would drive down resumes contact, without an impact."""
    t = S[S_T]
    down0 = False
    down1 = False
    c = math.cos(S[S_TH])
    sn = math.sin(S[S_TH])
    for k in range(2):
        dx, dy = corner_offset_cs(P, k, c, sn)
        if abs(S[S_Y] + dy) <= H_TOL and abs(S[S_VY] - S[S_W] * dx) <= V_TOL:
            if resting_corner_driven_down(S, P, k):
                if k == 0:
                    down0 = True
                else:
                    down1 = True
    if down0 and down1:
        S[S_TH] = wrap_angle(S[S_TH])
        set_double_contact(S, P)
        return log_event(S, ev, n, t, EV_RESUME, MODE_A, S[S_MODE], 0.0), True
    if down0 or down1:
        k = 0 if down0 else 1
        S[S_TH] = wrap_angle(S[S_TH])
        set_single_contact(S, P, k)
        new = pin_or_slide(S, P, k, V_TOL)
        return log_event(S, ev, n, t, EV_RESUME, MODE_A, new, 0.0), True
    return n, False
