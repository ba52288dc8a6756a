"""Impacts (docs/MODEL.md section 6): the contest law, the frictionless fallback and
the post-impact classification."""

import math

import numpy as np

from hoprover_env.core.forces import (
    corner_offset,
    kinetic_energy,
    pin_or_slide,
    set_double_contact,
    set_single_contact,
    turn_flat_about,
    wrap_angle,
)
from hoprover_env.core.judge import log_event
from hoprover_env.core.layout import (
    EV_IMPACT,
    H_IMPACT,
    LAW_DISSIPATIVE,
    MODE_A,
    O_LAW,
    S_MAXGAIN,
    S_MODE,
    S_NGAIN,
    S_NIMPACT,
    S_SIGMA,
    S_T,
    S_TH,
    S_VX,
    S_VY,
    S_W,
    S_Y,
    V_TOL,
    W_IMP,
    W_IMP_DV,
    W_IMP_DX,
    W_IMP_DY,
    W_IMP_END,
    W_IMP_LX,
    W_IMP_LY,
    W_IMP_ON,
    W_IMP_PART,
    W_IMP_TGT_Y,
    W_IMP_VPX,
    W_IMP_VPY,
)
from hoprover_env.core.params import P_EX, P_EY, P_I, P_M, P_MUS, P_VXMIN, P_VYMIN
from hoprover_env.core.terrain import impact_tilt
from hoprover_env.jit.compiler import I64, MAT, VEC, kernel


# ----------------------------------------------------------------------------------
# Impacts (docs/MODEL.md section 6)
# ----------------------------------------------------------------------------------
@kernel(inner=True)
def _solve_sym3(a00, a01, a02, a11, a12, a22, b0, b1, b2):
    """Solve a symmetric 3x3 system by Cramer's rule (well conditioned here)."""
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    return (
        (c00 * b0 + c01 * b1 + c02 * b2) / det,
        (c01 * b0 + c11 * b1 + c12 * b2) / det,
        (c02 * b0 + c12 * b1 + c22 * b2) / det,
    )


@kernel
def contest_impulses(P, dxs, dys, part, dv, lx, ly):
    """The contest law's impulses: K Lambda = dv over the taking-part corners.

    One corner: the 2x2 system with K = I2/m + u u^T / I, u = (dy, -dx).
    Two corners: K = J W J^T is 4x4 of rank 3 (the body has 3 degrees of freedom);
    the minimum-norm least-squares impulse is K^+ dv = J G W^-1 G J^T dv with
    G = (J^T J)^-1, J the 4x3 contact Jacobian (rows (1, 0, dy_k), (0, 1, -dx_k)) and
    W = diag(1/m, 1/m, 1/I). `dv[2k], dv[2k+1]` are the wanted changes of corner k's
    (vx, vy).
    """
    m = P[P_M]
    inertia = P[P_I]
    lx[0] = 0.0
    lx[1] = 0.0
    ly[0] = 0.0
    ly[1] = 0.0
    if part[0] != 0.0 and part[1] != 0.0:
        dxa, dya, dxb, dyb = dxs[0], dys[0], dxs[1], dys[1]
        # J^T J
        a02 = dya + dyb
        a12 = -dxa - dxb
        a22 = dxa * dxa + dya * dya + dxb * dxb + dyb * dyb
        # J^T dv
        b0 = dv[0] + dv[2]
        b1 = dv[1] + dv[3]
        b2 = dya * dv[0] - dxa * dv[1] + dyb * dv[2] - dxb * dv[3]
        z0, z1, z2 = _solve_sym3(2.0, 0.0, a02, 2.0, a12, a22, b0, b1, b2)
        y0, y1, y2 = _solve_sym3(2.0, 0.0, a02, 2.0, a12, a22, m * z0, m * z1, inertia * z2)
        lx[0] = y0 + dya * y2
        ly[0] = y1 - dxa * y2
        lx[1] = y0 + dyb * y2
        ly[1] = y1 - dxb * y2
        return
    for k in range(2):
        if part[k] != 0.0:
            dx = dxs[k]
            dy = dys[k]
            k11 = 1.0 / m + dy * dy / inertia
            k12 = -dy * dx / inertia
            k22 = 1.0 / m + dx * dx / inertia
            det = k11 * k22 - k12 * k12
            lx[k] = (dv[2 * k] * k22 - dv[2 * k + 1] * k12) / det
            ly[k] = (dv[2 * k + 1] * k11 - dv[2 * k] * k12) / det


@kernel(inner=True)
def frictionless_impulses(P, dxs, on, vpy, target, ly):
    """Vertical impulses only, as a complementarity problem over the grounded corners.

    Each corner either takes a compressive impulse and ends with exactly its target
    vertical speed, or takes none and ends at or above it. With two corners: both
    active, then each alone (the 2x2 Delassus matrix is positive definite, so exactly
    one of the cases is consistent).
    """
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    ly[0] = 0.0
    ly[1] = 0.0
    # Delassus matrix of the vertical directions: 1/m + dx_j dx_k / I
    kaa = 1.0 / m + dxs[0] * dxs[0] * inv_i
    kbb = 1.0 / m + dxs[1] * dxs[1] * inv_i
    kab = 1.0 / m + dxs[0] * dxs[1] * inv_i
    ra = target[0] - vpy[0]
    rb = target[1] - vpy[1]
    tol = 1e-14 * (abs(ra) + abs(rb) + 1e-300)
    if on[0] != 0.0 and on[1] != 0.0:
        det = kaa * kbb - kab * kab
        la = (ra * kbb - rb * kab) / det
        lb = (rb * kaa - ra * kab) / det
        if la >= 0.0 and lb >= 0.0:
            ly[0] = la
            ly[1] = lb
            return
        la = ra / kaa
        if la >= 0.0 and vpy[1] + kab * la >= target[1] - tol:
            ly[0] = la
            return
        lb = rb / kbb
        if lb >= 0.0 and vpy[0] + kab * lb >= target[0] - tol:
            ly[1] = lb
            return
        return
    for k in range(2):
        if on[k] != 0.0:
            kk = kaa if k == 0 else kbb
            ly[k] = max(0.0, (target[k] - vpy[k]) / kk)


@kernel(inner=True)
def _apply_impulses(S, P, dxs, dys, lx, ly):
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    S[S_VX] += (lx[0] + lx[1]) / m
    S[S_VY] += (ly[0] + ly[1]) / m
    S[S_W] += (dys[0] * lx[0] - dxs[0] * ly[0] + dys[1] * lx[1] - dxs[1] * ly[1]) * inv_i


# False in the smooth-ground build of the integrator (core/smooth.py): numba prunes the
# branches on it, so a scene without bumps compiles no tilt draw and no tilted impact.
ROUGH = True


@kernel
def resolve_impact(S, P, law, W):
    """Apply the impact law at the current configuration and set the new contact state.

    On rough terrain (roughness > 0) the law acts on a surface tilted by a random angle
    (`impact_tilt`); with roughness 0 no draw is made and the tilt is exactly 0.
    Returns the kinetic energy ratio (after / before) of the impact, after the
    post-impact classification. See docs/MODEL.md section 6 and docs/PHYSICS.md.
    """
    if ROUGH:
        return resolve_impact_tilted(S, P, law, W, impact_tilt(S, P))
    return resolve_impact_tilted(S, P, law, W, 0.0)


@kernel(inner=True)
def _rotate_velocity(S, c, s):
    """The c.m. velocity in a frame turned by the angle whose cosine, sine are c, s."""
    vx = S[S_VX]
    vy = S[S_VY]
    S[S_VX] = c * vx + s * vy
    S[S_VY] = -s * vx + c * vy


@kernel
def resolve_impact_tilted(S, P, law, W, psi):
    """`resolve_impact` with the local surface tilted by psi (rad) from the mean plane.

    The law of docs/MODEL.md section 6 (contest or dissipative, with its fallbacks) is
    applied in the tilted frame: offsets and velocities turned by -psi, the taking-part
    test and the targets (e_x along, -e_y normal to the facet) in that frame, the
    impulses turned back. Rotations commute with the point-velocity and moment formulas,
    so the flat code runs unchanged on the turned vectors. Which corners are on the
    ground is decided on the mean plane, and contact afterwards is on the mean plane.
    Decision: if the tilted law leaves a grounded corner moving into the mean plane, a
    second, plastic and frictionless impact on the mean plane follows (the
    complementarity of `frictionless_impulses` with target 0): each such corner ends at
    rest normal to the plane, no impulse pulls, and it never adds energy.
    """
    S[S_TH] = wrap_angle(S[S_TH])
    th = S[S_TH]
    for j in range(W_IMP_END - W_IMP):
        W[W_IMP + j] = 0.0
    tilted = psi != 0.0
    ct = 1.0
    st = 0.0
    if ROUGH and tilted:
        ct = math.cos(psi)
        st = math.sin(psi)
        _rotate_velocity(S, ct, st)
    _impact_targets(S, P, th, tilted, ct, st, W)
    ke0 = kinetic_energy(S, P)
    _, _, _, _, _, part, _, _, _, _ = _impact_vectors(W)
    if part[0] != 0.0 or part[1] != 0.0:
        _apply_law(S, P, law, ke0, W)
    if ROUGH and tilted:
        _rotate_velocity(S, ct, -st)
        _stop_on_mean_plane(S, P, th, W)
    _classify_after_impact(S, P, W)
    ke1 = kinetic_energy(S, P)
    ratio = ke1 / ke0 if ke0 > 0.0 else 1.0
    S[S_NIMPACT] += 1.0
    if ratio > 1.0 + 1e-12:
        S[S_NGAIN] += 1.0
        if ratio - 1.0 > S[S_MAXGAIN]:
            S[S_MAXGAIN] = ratio - 1.0
    return ratio


@kernel(inner=True)
def _impact_vectors(W):
    """The impacts' vectors in the workspace (layout W_IMP_* in layout.py)."""
    return (
        W[W_IMP_DX : W_IMP_DX + 2],
        W[W_IMP_DY : W_IMP_DY + 2],
        W[W_IMP_VPX : W_IMP_VPX + 2],
        W[W_IMP_VPY : W_IMP_VPY + 2],
        W[W_IMP_ON : W_IMP_ON + 2],
        W[W_IMP_PART : W_IMP_PART + 2],
        W[W_IMP_DV : W_IMP_DV + 4],
        W[W_IMP_TGT_Y : W_IMP_TGT_Y + 2],
        W[W_IMP_LX : W_IMP_LX + 2],
        W[W_IMP_LY : W_IMP_LY + 2],
    )


@kernel(inner=True)
def _impact_targets(S, P, th, tilted, ct, st, W):
    """Per bottom corner, in the (tilted) impact frame: its offset and point velocity,
    whether it is on the ground and takes part, and the law's targets for it."""
    dxs, dys, vpx, vpy, on, part, dv, tgt_y, _, _ = _impact_vectors(W)
    for k in range(2):
        dx, dy = corner_offset(P, k, th)
        on[k] = 1.0 if S[S_Y] + dy <= H_IMPACT else 0.0
        if tilted:
            dx, dy = ct * dx + st * dy, -st * dx + ct * dy
        dxs[k] = dx
        dys[k] = dy
        vpx[k] = S[S_VX] + S[S_W] * dy
        vpy[k] = S[S_VY] - S[S_W] * dx
        part[k] = 1.0 if (on[k] != 0.0 and vpy[k] <= V_TOL) else 0.0
        if part[k] != 0.0:
            tx = P[P_EX] * vpx[k]
            if abs(tx) < P[P_VXMIN]:
                tx = 0.0
            ty = -P[P_EY] * vpy[k] if vpy[k] < 0.0 else 0.0
            if abs(ty) < P[P_VYMIN]:
                ty = 0.0
            dv[2 * k] = tx - vpx[k]
            dv[2 * k + 1] = ty - vpy[k]
            tgt_y[k] = ty


@kernel(inner=True)
def _apply_law(S, P, law, ke0, W):
    """The contest impulses, or the frictionless fallbacks where they would pull on the
    ground, leave a grounded corner moving down or (dissipative law) leave the friction
    cone or add energy."""
    dxs, dys, _, vpy, on, part, dv, tgt_y, lx, ly = _impact_vectors(W)
    v0x = S[S_VX]
    v0y = S[S_VY]
    w0 = S[S_W]
    contest_impulses(P, dxs, dys, part, dv, lx, ly)
    _apply_impulses(S, P, dxs, dys, lx, ly)
    lam_scale = abs(lx[0]) + abs(lx[1]) + abs(ly[0]) + abs(ly[1])
    ok = True
    for k in range(2):
        if part[k] != 0.0 and ly[k] < -1e-12 * lam_scale:
            ok = False  # the exact law would pull on the ground
        if on[k] != 0.0 and S[S_VY] - S[S_W] * dxs[k] < -V_TOL:
            ok = False  # a grounded corner would end moving down
        if (
            law == LAW_DISSIPATIVE
            and part[k] != 0.0
            and abs(lx[k]) > P[P_MUS] * ly[k] + 1e-12 * lam_scale
        ):
            ok = False  # outside the friction cone
    if ok and law == LAW_DISSIPATIVE and kinetic_energy(S, P) > ke0:
        ok = False
    if not ok:
        S[S_VX] = v0x
        S[S_VY] = v0y
        S[S_W] = w0
        frictionless_impulses(P, dxs, on, vpy, tgt_y, ly)
        lx[0] = 0.0
        lx[1] = 0.0
        _apply_impulses(S, P, dxs, dys, lx, ly)
        if law == LAW_DISSIPATIVE and kinetic_energy(S, P) > ke0:
            # Multi-contact restitution can add energy; the perfectly inelastic
            # frictionless impact (an M-orthogonal projection) never does.
            S[S_VX] = v0x
            S[S_VY] = v0y
            S[S_W] = w0
            tgt_y[0] = 0.0
            tgt_y[1] = 0.0
            frictionless_impulses(P, dxs, on, vpy, tgt_y, ly)
            _apply_impulses(S, P, dxs, dys, lx, ly)


@kernel(inner=True)
def _stop_on_mean_plane(S, P, th, W):
    """After a tilted impact (velocities turned back): a grounded corner still moving
    into the mean plane is stopped there by a plastic frictionless impact."""
    dxs, dys, _, vpy, on, _, _, tgt_y, lx, ly = _impact_vectors(W)
    for k in range(2):
        dxs[k], dys[k] = corner_offset(P, k, th)
        vpy[k] = S[S_VY] - S[S_W] * dxs[k]
        tgt_y[k] = 0.0
    if (on[0] != 0.0 and vpy[0] < -V_TOL) or (on[1] != 0.0 and vpy[1] < -V_TOL):
        frictionless_impulses(P, dxs, on, vpy, tgt_y, ly)
        lx[0] = 0.0
        lx[1] = 0.0
        _apply_impulses(S, P, dxs, dys, lx, ly)


@kernel(inner=True)
def _classify_after_impact(S, P, W):
    """Post-impact classification: a grounded corner slower than v_ymin is in contact."""
    dxs, dys, _, _, on, _, _, _, _, _ = _impact_vectors(W)
    c0 = on[0] != 0.0 and abs(S[S_VY] - S[S_W] * dxs[0]) < P[P_VYMIN]
    c1 = on[1] != 0.0 and abs(S[S_VY] - S[S_W] * dxs[1]) < P[P_VYMIN]
    if c0 and c1:
        set_double_contact(S, P)
    elif c0 or c1:
        k = 0 if c0 else 1
        set_single_contact(S, P, k)
        # the other corner, if it was within H_IMPACT, may now be a hair under the ground
        _, dyo = corner_offset(P, 1 - k, S[S_TH])
        if S[S_Y] + dyo < 0.0:
            turn_flat_about(S, P, k)
        # pinned when the corner slides slower than v_xmin (strictly: for floats,
        # |v| < v_xmin is |v| <= the float just below v_xmin)
        pin_or_slide(S, P, k, np.nextafter(P[P_VXMIN], 0.0))
    else:
        S[S_MODE] = MODE_A
        S[S_SIGMA] = 0.0
        # never leave a corner under the ground (a round-off-sized lift)
        low = min(S[S_Y] + dys[0], S[S_Y] + dys[1])
        if low < 0.0:
            S[S_Y] -= low


@kernel(I64(VEC, VEC, VEC, MAT, I64, VEC), inner=True)
def impact_event(S, P, O, ev, n, W):
    # a touchdown is only ever reported with a bottom corner on the ground
    if min(corner_offset(P, 0, S[S_TH])[1], corner_offset(P, 1, S[S_TH])[1]) + S[S_Y] > H_IMPACT:
        return n
    before = S[S_MODE]
    ratio = resolve_impact(S, P, int(O[O_LAW]), W)
    return log_event(S, ev, n, S[S_T], EV_IMPACT, before, S[S_MODE], ratio)
