"""Corner geometry and the contact forces of the seven states (docs/MODEL.md
section 4), written once for a generic contact corner, and the setters that put the
body on one or two corners."""

import math

from numba import types as nt

from hoprover_env.core.layout import (
    MODE_A,
    MODE_B,
    MODE_C,
    MODE_D,
    MODE_E,
    MODE_F,
    MODE_G,
    S_MODE,
    S_SIGMA,
    S_TH,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_Y,
    TWO_PI,
)
from hoprover_env.core.params import P_GC, P_GS, P_H, P_I, P_M, P_MUD, P_R, P_VXMIN
from hoprover_env.jit.compiler import F64, I64, VEC, F64x2, F64x5, kernel


# ----------------------------------------------------------------------------------
# Geometry
# ----------------------------------------------------------------------------------
@kernel(F64x2(VEC, I64))
def corner_body(P, k):
    """Body coordinates (bx, by) of corner k: 0 A, 1 B (bottom), 2 TR, 3 TL (top)."""
    bx = P[P_R] if (k == 0 or k == 2) else -P[P_R]
    by = -P[P_H] if k < 2 else P[P_H]
    return bx, by


@kernel(F64x2(VEC, I64, F64, F64), inner=True)
def corner_offset_cs(P, k, c, s):
    """corner_offset with cos(th), sin(th) given: hot paths compute them once."""
    bx, by = corner_body(P, k)
    return bx * c + by * s, -bx * s + by * c


@kernel(F64x2(VEC, I64, F64))
def corner_offset(P, k, th):
    """World offset (dx, dy) of corner k from the c.m. at attitude th."""
    return corner_offset_cs(P, k, math.cos(th), math.sin(th))


@kernel
def wrap_angle(th):
    """Attitude in (-pi, pi]."""
    w = th - TWO_PI * math.floor((th + math.pi) / TWO_PI)  # exact for th in range
    return math.pi if w == -math.pi else w


@kernel(inner=True)
def kinetic_energy(S, P):
    return 0.5 * P[P_M] * (S[S_VX] ** 2 + S[S_VY] ** 2) + 0.5 * P[P_I] * S[S_W] ** 2


@kernel
def total_energy(S, P):
    """Kinetic plus potential energy along the tilted gravity, m g (x sin phi + y cos phi)."""
    return (
        0.5 * P[P_M] * (S[S_VX] ** 2 + S[S_VY] ** 2)
        + 0.5 * P[P_I] * S[S_W] ** 2
        + P[P_M] * (P[P_GS] * S[S_X] + P[P_GC] * S[S_Y])
    )


@kernel(I64(I64), inner=True)
def contact_corner(mode):
    """Corner index in contact for the single-contact modes (A for B/C, B for D/E)."""
    return 0 if (mode == MODE_B or mode == MODE_C) else 1


@kernel(I64(I64), inner=True)
def pinned_mode(k):
    """The state pivoting on bottom corner k: B on A (k = 0), D on B (k = 1)."""
    return MODE_B if k == 0 else MODE_D


@kernel(I64(I64), inner=True)
def sliding_mode(k):
    """The state sliding on bottom corner k: C on A (k = 0), E on B (k = 1)."""
    return MODE_C if k == 0 else MODE_E


# ----------------------------------------------------------------------------------
# Forces (docs/MODEL.md section 4), written once for a generic contact corner.
# ----------------------------------------------------------------------------------
@kernel(F64x5(VEC, I64, F64, F64, F64), inner=True)
def pivot_dynamics(P, k, T, th, w):
    """Pivot on corner k (state B for A, D for B).

    The corner is fixed: c.m. acceleration a = -thdd (dy, -dx) + w^2 (dx, dy), and
    f = m a + m (gs, gc) with gravity g (-sin phi, -cos phi) in the ground frame, so
    thdd = (T - m gc dx + m gs dy) / (I + m l^2): the along-surface weight enters the
    moment through the friction force that holds the corner.
    Returns (thdd, fx, fy, dx, dy).
    """
    m = P[P_M]
    gc = P[P_GC]
    gs = P[P_GS]
    dx, dy = corner_offset(P, k, th)
    thdd = (T - m * gc * dx + m * gs * dy) / (P[P_I] + m * (dx * dx + dy * dy))
    fx = m * (-thdd * dy + w * w * dx + gs)
    fy = m * (thdd * dx + w * w * dy + gc)
    return thdd, fx, fy, dx, dy


@kernel(F64x5(VEC, I64, F64, F64, F64, F64), inner=True)
def slide_dynamics(P, k, sigma, T, th, w):
    """Slide on corner k in direction sigma (state C for A, E for B).

    Only the normal constraint holds; friction f_x = -sigma mu_d f_y.
    D = I + m dx (dx + sigma mu_d dy) (> 0 outside the Painleve regime),
    thdd = [T - m (dx + sigma mu_d dy)(w^2 dy + gc)] / D, f_y = m (thdd dx + w^2 dy + gc),
    with gc = g cos(phi) the weight normal to the ground. The along-surface part
    -g sin(phi) has no moment here: it only accelerates the c.m. (x'' = fx / m - gs).
    Returns (thdd, fx, fy, dx, dy).
    """
    m = P[P_M]
    g = P[P_GC]
    dx, dy = corner_offset(P, k, th)
    q = dx + sigma * P[P_MUD] * dy
    thdd = (T - m * q * (w * w * dy + g)) / (P[P_I] + m * dx * q)
    fy = m * (thdd * dx + w * w * dy + g)
    fx = -sigma * P[P_MUD] * fy
    return thdd, fx, fy, dx, dy


@kernel(inner=True)
def double_contact_forces(P, sigma, T):
    """States F (sigma = 0) and G: both corners on the ground, theta = 0, omega = 0.

    f_Ay + f_By = m gc and, from the moment balance,
    f_Ay - f_By = (T - h (f_Ax + f_Bx)) / r: in G the friction is -sigma mu_d m gc; in F
    static friction holds the along-surface weight, f_Ax + f_Bx = m gs.
    Decision: F's split of that friction between the corners is indeterminate (rigid
    body); it is reported in proportion to the normal forces, the split that loads both
    corners' friction cones equally (so F holds, |gs| <= mu_s gc, iff each corner is
    inside its cone).
    Returns (fAx, fAy, fBx, fBy).
    """
    m = P[P_M]
    g = P[P_GC]
    gs = P[P_GS]
    diff = (T + sigma * P[P_MUD] * m * g * P[P_H]) / P[P_R]
    ratio = -sigma * P[P_MUD]
    if sigma == 0.0 and gs != 0.0:
        diff = (T - m * gs * P[P_H]) / P[P_R]
        ratio = gs / g
    fay = 0.5 * (m * g + diff)
    fby = 0.5 * (m * g - diff)
    return ratio * fay, fay, ratio * fby, fby


@kernel
def contact_forces(S, P):
    """Contact forces (fAx, fAy, fBx, fBy) of the current state and torque."""
    mode = int(S[S_MODE])
    T = S[S_TORQUE]
    if mode == MODE_F:
        return double_contact_forces(P, 0.0, T)
    if mode == MODE_G:
        return double_contact_forces(P, S[S_SIGMA], T)
    if mode == MODE_A:
        return 0.0, 0.0, 0.0, 0.0
    k = contact_corner(mode)
    if mode == MODE_B or mode == MODE_D:
        _, fx, fy, _, _ = pivot_dynamics(P, k, T, S[S_TH], S[S_W])
    else:
        _, fx, fy, _, _ = slide_dynamics(P, k, S[S_SIGMA], T, S[S_TH], S[S_W])
    if k == 0:
        return fx, fy, 0.0, 0.0
    return 0.0, 0.0, fx, fy


@kernel(nt.void(VEC, VEC, I64), inner=True)
def set_single_contact(S, P, k):
    """Make the c.m. state satisfy corner k's constraint exactly: y_k = 0, vy_k = 0.

    The height is snapped (a round-off-sized move); the vertical point velocity is
    removed by a vertical impulse at the corner (an energy-non-increasing projection).
    """
    dx, dy = corner_offset(P, k, S[S_TH])
    S[S_Y] = -dy
    vpy = S[S_VY] - S[S_W] * dx
    if vpy != 0.0:
        m = P[P_M]
        inv_i = 1.0 / P[P_I]
        lam = -vpy / (1.0 / m + dx * dx * inv_i)
        S[S_VY] += lam / m
        S[S_W] += -dx * lam * inv_i


@kernel(nt.void(VEC, VEC, I64), inner=True)
def pin_corner(S, P, k):
    """Bring corner k's whole velocity to zero by one impulse there (a projection)."""
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    dx, dy = corner_offset(P, k, S[S_TH])
    vpx = S[S_VX] + S[S_W] * dy
    vpy = S[S_VY] - S[S_W] * dx
    # K = I2/m + u u^T / I with u = (dy, -dx)
    k11 = 1.0 / m + dy * dy * inv_i
    k12 = -dy * dx * inv_i
    k22 = 1.0 / m + dx * dx * inv_i
    det = k11 * k22 - k12 * k12
    lx = (-vpx * k22 + vpy * k12) / det
    ly = (-vpy * k11 + vpx * k12) / det
    S[S_VX] += lx / m
    S[S_VY] += ly / m
    S[S_W] += (dy * lx - dx * ly) * inv_i
    S[S_Y] = -dy


@kernel(I64(VEC, VEC, I64, F64), inner=True)
def pin_or_slide(S, P, k, v_pin):
    """Put the rover, already on corner k's constraint (set_single_contact), in the
    single-contact state its velocity says: pinned (B/D, corner brought to rest) when the
    corner's sliding speed |v_Px| is at most v_pin, else sliding (C/E) the way the corner
    moves. Sets S_MODE and S_SIGMA; returns the new mode."""
    _, dy = corner_offset(P, k, S[S_TH])
    vpx = S[S_VX] + S[S_W] * dy
    if abs(vpx) <= v_pin:
        pin_corner(S, P, k)
        mode = pinned_mode(k)
        S[S_SIGMA] = 0.0
    else:
        mode = sliding_mode(k)
        S[S_SIGMA] = 1.0 if vpx > 0.0 else -1.0
    S[S_MODE] = mode
    return mode


@kernel(nt.void(VEC, VEC, I64), inner=True)
def turn_flat_about(S, P, k):
    """Turn the body about contact corner k to theta = 0, where the other bottom corner
    touches too: the projection used when that corner ended (round-off or a finite step)
    under the ground. Keeps corner k's position and its contact constraint."""
    dx, _ = corner_offset(P, k, S[S_TH])
    xpiv = S[S_X] + dx
    S[S_TH] = 0.0
    dx, dy = corner_offset(P, k, 0.0)
    S[S_X] = xpiv - dx
    S[S_Y] = -dy
    S[S_VY] = S[S_W] * dx


@kernel(inner=True)
def set_double_contact(S, P):
    """Both corners on the ground: theta = 0, omega = 0, vy = 0, y = h; F or G.

    Decision: the horizontal velocity kept is the c.m.'s. The residual vertical and
    angular velocities (below v_ymin) are removed by vertical impulses at A and B, which
    leave vx unchanged and cannot add energy; with omega = 0 the contact points then
    move with vx, the common horizontal contact velocity.
    """
    S[S_TH] = 0.0
    S[S_W] = 0.0
    S[S_Y] = P[P_H]
    S[S_VY] = 0.0
    if abs(S[S_VX]) < P[P_VXMIN] or S[S_VX] == 0.0:
        S[S_VX] = 0.0
        S[S_MODE] = MODE_F
        S[S_SIGMA] = 0.0
    else:
        S[S_MODE] = MODE_G
        S[S_SIGMA] = 1.0 if S[S_VX] > 0.0 else -1.0
