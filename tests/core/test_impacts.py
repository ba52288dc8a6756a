"""The impact laws of MODEL.md section 6, called on hand-built pre-impact states."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hoprover_env import RoverParams, core

P = RoverParams()
PA = P.as_array()
M, I, EX, EY = P.mass, P.inertia, P.restitution_x, P.restitution_y
WORK = np.zeros(core.N_WORK)


def pre_impact(th, w, vx, vy, corner=0, x=0.0, params=PA):
    """A flight state with `corner` exactly on the ground."""
    s = np.zeros(core.N_STATE)
    s[core.S_TTRTP] = np.nan
    s[core.S_STOP_ON] = -1.0
    dx, dy = core.corner_offset(params, corner, th)
    s[:6] = (x, -dy, th, vx, vy, w)
    s[core.S_MODE] = core.MODE_A
    return s


def point_velocity(s, k, params=PA):
    dx, dy = core.corner_offset(params, k, s[core.S_TH])
    return np.array([s[core.S_VX] + s[core.S_W] * dy, s[core.S_VY] - s[core.S_W] * dx])


def ke(s, m=M, inertia=I):
    return 0.5 * m * (s[3] ** 2 + s[4] ** 2) + 0.5 * inertia * s[5] ** 2


def exact_single_impulse(s, k):
    dx, dy = core.corner_offset(PA, k, s[core.S_TH])
    u = np.array([dy, -dx])
    kmat = np.eye(2) / M + np.outer(u, u) / I
    vp = point_velocity(s, k)
    return np.linalg.solve(kmat, np.array([EX * vp[0], -EY * vp[1]]) - vp), u


def test_single_corner_law_exactly():
    s = pre_impact(0.3, 0.02, 2e-3, -3e-3)
    lam, u = exact_single_impulse(s, 0)
    assert lam[1] > 0
    vp0 = point_velocity(s, 0)
    expect = s.copy()
    expect[3:5] += lam / M
    expect[5] += u @ lam / I
    ratio = core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    np.testing.assert_allclose(s[3:6], expect[3:6], rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(point_velocity(s, 0), [EX * vp0[0], -EY * vp0[1]], rtol=1e-12)
    assert s[core.S_MODE] == core.MODE_A  # it bounces: 0.2 * 3e-3 > v_ymin
    assert ratio == pytest.approx(ke(s) / ke(pre_impact(0.3, 0.02, 2e-3, -3e-3)), rel=1e-12)


def test_slow_touchdown_ends_in_contact_with_exact_zero_speeds():
    # vertical target below v_ymin and horizontal below v_xmin: a pivot on A
    s = pre_impact(0.2, 0.0, 1e-7, -2e-6)
    core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    assert s[core.S_MODE] == core.MODE_B
    assert np.all(np.abs(point_velocity(s, 0)) <= 1e-20)
    dx, dy = core.corner_offset(PA, 0, s[core.S_TH])
    assert s[core.S_Y] + dy == 0.0


def test_flat_two_corner_landing():
    s = pre_impact(0.0, 0.0, 1.5e-3, -4e-3)
    core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    # both corners keep e_y of the vertical speed and e_x of the horizontal one
    for k in (0, 1):
        np.testing.assert_allclose(point_velocity(s, k), [EX * 1.5e-3, EY * 4e-3], rtol=1e-12)
    assert s[core.S_W] == pytest.approx(0.0, abs=1e-16)
    # a slow flat landing ends on both corners, sliding (G) at e_x of the speed
    s = pre_impact(0.0, 0.0, 1e-5, -4e-6)
    core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    assert s[core.S_MODE] == core.MODE_G and s[core.S_SIGMA] == 1.0
    assert (s[core.S_TH], s[core.S_W], s[core.S_VY], s[core.S_Y]) == (0.0, 0.0, 0.0, P.half_height)
    assert s[core.S_VX] == pytest.approx(EX * 1e-5, rel=1e-12)


def test_slow_flat_landing_while_sliding_fast_needs_a_pull():
    # e_x = 0.8 asks for a friction impulse 0.2 m vx whose moment about the c.m. must
    # be cancelled by f_Ay - f_By: with a tiny vertical speed that pulls on B. The
    # contest law is refused and the frictionless fallback keeps vx.
    s = pre_impact(0.0, 0.0, 1.5e-3, -4e-6)
    dxs = np.array([P.half_width, -P.half_width])
    dys = np.array([-P.half_height, -P.half_height])
    lx, ly = np.zeros(2), np.zeros(2)
    dv = np.array([-0.2 * 1.5e-3, 4e-6, -0.2 * 1.5e-3, 4e-6])
    core.contest_impulses(PA, dxs, dys, np.array([1.0, 1.0]), dv, lx, ly)
    assert ly[1] < 0 < ly[0]
    core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    assert s[core.S_MODE] == core.MODE_G and s[core.S_VX] == 1.5e-3


def test_pulling_law_falls_back_to_frictionless():
    # found by search: the exact law needs a pulling normal impulse here
    s = pre_impact(
        0.44186331322589567, 0.188648584799799, -0.004103067777836135, 0.004125459074536548
    )
    lam, _ = exact_single_impulse(s, 0)
    vp0 = point_velocity(s, 0)
    assert vp0[1] < 0 and lam[1] < 0
    vx0 = s[core.S_VX]
    core.resolve_impact(s, PA, core.LAW_CONTEST, WORK)
    assert s[core.S_VX] == vx0  # no horizontal impulse
    assert point_velocity(s, 0)[1] == pytest.approx(-EY * vp0[1], rel=1e-12)


def test_departing_corner_is_not_pushed_into_the_ground():
    # flat, rotating clockwise: A comes down, B goes up. An impulse at A alone
    # (1/m - r^2/I < 0) would drive B down; the fallback must stop that.
    s = pre_impact(0.0, 0.02, 0.0, 0.0)
    vpa, vpb = point_velocity(s, 0), point_velocity(s, 1)
    assert vpa[1] < 0 < vpb[1]
    for law in (core.LAW_CONTEST, core.LAW_DISSIPATIVE):
        t = s.copy()
        core.resolve_impact(t, PA, law, WORK)
        assert point_velocity(t, 1)[1] >= 0.0
        assert point_velocity(t, 0)[1] >= 0.0


def test_contest_law_can_gain_energy_dissipative_cannot():
    rng = np.random.default_rng(7)
    gained = 0
    for _ in range(3000):
        th = rng.uniform(-1.4, 1.4)
        k = 0 if th > 0 else 1
        s = pre_impact(
            th, rng.uniform(-0.3, 0.3), rng.uniform(-5e-3, 5e-3), rng.uniform(-5e-3, 5e-3), corner=k
        )
        if point_velocity(s, k)[1] >= 0:
            continue
        e0 = ke(s)
        a, b = s.copy(), s.copy()
        core.resolve_impact(a, PA, core.LAW_CONTEST, WORK)
        core.resolve_impact(b, PA, core.LAW_DISSIPATIVE, WORK)
        gained += ke(a) > e0 * (1 + 1e-12)
        assert ke(b) <= e0 * (1 + 1e-12)
    assert gained > 0  # the contest law is not dissipative (MODEL.md section 6)


params_strategy = st.builds(
    RoverParams,
    mass=st.floats(0.3, 3.0),
    inertia=st.floats(0.001, 0.01),
    half_width=st.floats(0.03, 0.08),
    half_height=st.floats(0.03, 0.08),
    mu_static=st.floats(0.3, 1.0),
    mu_dynamic=st.just(0.3),
    restitution_x=st.floats(0.0, 1.0),
    restitution_y=st.floats(0.0, 1.0),
)


@given(
    p=params_strategy,
    th=st.floats(-1.5, 1.5),
    w=st.floats(-0.5, 0.5),
    vx=st.floats(-1e-2, 1e-2),
    vy=st.floats(-1e-2, 1e-2),
    flat=st.booleans(),
    law=st.sampled_from([core.LAW_CONTEST, core.LAW_DISSIPATIVE]),
)
def test_impact_postconditions(p, th, w, vx, vy, flat, law):
    pa = p.as_array()
    if flat:
        th = 0.0
    k = 0 if th >= 0 else 1
    s = pre_impact(th, w, vx, vy, corner=k, params=pa)
    vpk = point_velocity(s, k, pa)
    if vpk[1] >= 0:
        return
    e0 = ke(s, p.mass, p.inertia)
    if e0 < 1e-30:
        return  # a touchdown at a denormal speed: nothing to check
    ratio = core.resolve_impact(s, pa, law, WORK)
    assert np.all(np.isfinite(s[:6]))
    e1 = ke(s, p.mass, p.inertia)
    assert ratio == pytest.approx(e1 / e0, rel=1e-9)
    if law == core.LAW_DISSIPATIVE:
        assert e1 <= e0 * (1 + 1e-12)
    for c in (0, 1):
        dx, dy = core.corner_offset(pa, c, s[core.S_TH])
        height = s[core.S_Y] + dy
        assert height >= -1e-12  # nobody under the ground
        if height <= 1e-12:  # nobody on it moving down
            assert point_velocity(s, c, pa)[1] >= -1e-12
