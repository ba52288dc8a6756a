"""Sloped ground (docs/MODEL.md section 11): against the independent scipy reference,
closed forms on an incline, energy with the tilted gravity, and Euler's convergence."""

import math

import numpy as np
import pytest

from helpers import first_landing
from hoprover_env import RoverParams, RoverSim, core, simulate
from hoprover_env.sim.reference import Ref

SLOPES = [-0.3, -0.1, 0.1, 0.3]


def modes_of(events):
    return "".join(
        [events[0][2]] + [e[3] for e in events if e[1] in ("tip", "slip", "stick", "liftoff")]
    )


@pytest.mark.parametrize("slope", SLOPES)
@pytest.mark.parametrize("torque", [5e-5, 2e-4])
def test_launch_and_landing_on_a_slope_match_scipy(slope, torque):
    ref = Ref(slope=slope)
    t_lo, s_lo, modes = ref.launch(torque)
    sim = RoverSim(params=RoverParams(slope=slope), target_x=0.5)
    ev = sim.advance(torque, 300.0, stop_on="liftoff")
    assert modes_of(ev) == "".join(modes)
    assert abs(sim.t - t_lo) <= 1e-9
    assert np.max(np.abs(sim.state - s_lo)) <= 1e-9
    # the flight under a small opposite torque, to the first corner that comes down
    t_td, s_td, k = ref.flight(s_lo, -1e-5, t_lo, t_max=t_lo + 400.0)
    ev = sim.advance(-1e-5, t_lo + 400.0, stop_on="impact")
    assert ev[-1][1] == ("impact" if k < 2 else "broken")
    assert abs(sim.t - t_td) <= 1e-9
    # the touchdown point (the impact changes velocities only)
    x_ref, y_ref = ref.corners(s_td)[k]
    x_sim, y_sim = ref.corners(sim.state)[k]
    assert abs(x_sim - x_ref) <= 1e-9 and abs(y_sim) <= 1e-9 and abs(y_ref) <= 1e-9
    assert np.max(np.abs(sim.state[:2] - s_td[:2])) <= 1e-9


LOOSE = dict(mu_static=0.3, mu_dynamic=0.2)  # atan(mu_s) = 0.2915 < 0.5 rad


@pytest.mark.parametrize("slope, kw", [(0.28, LOOSE), (-0.2914, LOOSE), (0.5, {}), (-0.5, {})])
def test_rest_holds_below_atan_mu_s(slope, kw):
    p = RoverParams(slope=slope, **kw)
    assert abs(math.tan(slope)) <= p.mu_static
    roll = simulate(np.zeros(1000), t_end=100.0, params=p, target_x=3.0)
    assert set(roll.state) == {"F"} and roll.n_events == 0
    assert np.all(roll.x == 0.0) and np.all(roll.y == p.half_height)
    sim = RoverSim(params=p, target_x=3.0)
    fax, fay, fbx, fby = sim.contact_forces()
    m, g = p.mass, p.gravity
    assert fax + fbx == pytest.approx(m * g * math.sin(slope), rel=1e-13)
    assert fay + fby == pytest.approx(m * g * math.cos(slope), rel=1e-13)
    # moment about the c.m.: -h (fAx + fBx) - r fAy + r fBy = 0 (torque 0)
    assert -p.half_height * (fax + fbx) - p.half_width * (fay - fby) == pytest.approx(
        0.0, abs=1e-19
    )
    assert fax / fay == pytest.approx(fbx / fby, rel=1e-13)  # the proportional split
    assert abs(fax) <= p.mu_static * fay and abs(fbx) <= p.mu_static * fby


@pytest.mark.parametrize("slope", [0.2916, 0.35, -0.3, -0.5])
def test_steeper_than_atan_mu_s_slides_down_in_closed_form(slope):
    p = RoverParams(slope=slope, **LOOSE)
    roll = simulate(np.zeros(100), t_end=100.0, params=p, target_x=50.0, sample_dt=0.5)
    assert roll.events[0][1:4] == ("slip", "F", "G") and roll.events[0][0] == 0.0
    sigma = -math.copysign(1.0, slope)
    acc = -p.gravity * (math.sin(slope) + sigma * p.mu_dynamic * math.cos(slope))
    assert np.sign(acc) == sigma
    assert set(roll.state[1:]) == {"G"} and np.all(roll.sigma[1:] == sigma)
    np.testing.assert_allclose(roll.x, 0.5 * acc * roll.t**2, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(roll.vx, acc * roll.t, rtol=1e-13, atol=1e-20)
    assert np.all(roll.y == p.half_height) and np.all(roll.theta == 0.0)


def test_uphill_slide_stops_and_stays_between_atan_mu_d_and_atan_mu_s():
    slope = 0.25  # atan(0.2) = 0.197 < 0.25 < atan(0.3) = 0.2915
    p = RoverParams(slope=slope, **LOOSE)
    g, v0 = p.gravity, 2e-3
    a = g * (math.sin(slope) + p.mu_dynamic * math.cos(slope))  # deceleration up
    roll = simulate(
        np.zeros(100),
        t_end=100.0,
        params=p,
        target_x=50.0,
        sample_dt=0.5,
        initial_state=(0.0, p.half_height, 0.0, v0, 0.0, 0.0),
    )
    t_stop = v0 / a
    stop = [e for e in roll.events if e[1] == "stop"]
    assert len(stop) == 1 and stop[0][0] == pytest.approx(t_stop, rel=1e-14)
    assert roll.n_events == 1  # and it stays in F: static friction holds
    before = roll.t < t_stop
    np.testing.assert_allclose(
        roll.x[before], v0 * roll.t[before] - 0.5 * a * roll.t[before] ** 2, rtol=1e-13, atol=1e-18
    )
    assert np.all(roll.state[~before] == "F")
    assert np.all(roll.x[~before] == pytest.approx(v0 * v0 / (2 * a), rel=1e-13))
    # the same slope, sliding down: dynamic friction cannot stop it
    down = simulate(
        np.zeros(100),
        t_end=100.0,
        params=p,
        target_x=-50.0,
        sample_dt=0.5,
        initial_state=(0.0, p.half_height, 0.0, -v0, 0.0, 0.0),
    )
    acc = -g * (math.sin(slope) - p.mu_dynamic * math.cos(slope))
    assert set(down.state) == {"G"} and down.n_events == 0
    np.testing.assert_allclose(down.vx, -v0 + acc * down.t, rtol=1e-13)


@pytest.mark.parametrize("slope", SLOPES + [0.5])
@pytest.mark.parametrize("omega0, torque", [(0.0, 0.0), (0.03, -2e-5), (-0.02, 1e-5)])
def test_flight_on_a_slope_sample_by_sample(slope, omega0, torque):
    p = RoverParams(slope=slope)
    x0, y0, th0, vx0, vy0 = 0.1, 0.3, 0.2, 1e-3, 2e-3
    roll = simulate(
        np.full(100, torque),
        t_end=100.0,
        control_dt=1.0,
        params=p,
        sample_dt=0.05,
        initial_state=(x0, y0, th0, vx0, vy0, omega0),
    )
    t_land = roll.events[0][0] if roll.events else np.inf  # first touchdown
    fly = roll.t <= t_land
    assert np.all(roll.state[roll.t < t_land] == "A")
    t = roll.t[fly]
    assert t.size > 100
    gs, gc, beta = p.gravity * math.sin(slope), p.gravity * math.cos(slope), torque / p.inertia
    want = (
        x0 + vx0 * t - 0.5 * gs * t * t,
        y0 + vy0 * t - 0.5 * gc * t * t,
        th0 + omega0 * t + 0.5 * beta * t * t,
        vx0 - gs * t,
        vy0 - gc * t,
        omega0 + beta * t,
    )
    got = (roll.x, roll.y, roll.theta, roll.vx, roll.vy, roll.omega)
    for w, g_ in zip(want, got):
        # restarted at every sample: round-off accumulates over ~2000 restarts
        np.testing.assert_allclose(g_[fly], w, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("slope", [-0.3, 0.2])
def test_euler_converges_to_event_at_first_order_on_a_slope(slope):
    t_ref, x_ref = first_landing("event", params=RoverParams(slope=slope))
    dts = [1e-2, 1e-3, 1e-4]
    errs = np.array(
        [
            [
                abs(v - r)
                for v, r in zip(
                    first_landing("euler", dt, params=RoverParams(slope=slope)), (t_ref, x_ref)
                )
            ]
            for dt in dts
        ]
    )
    assert np.all(np.diff(errs[:, 0]) < 0) and np.all(np.diff(errs[:, 1]) < 0)
    overall = np.log(errs[0] / errs[-1]) / np.log(dts[0] / dts[-1])
    assert np.all((overall > 0.8) & (overall < 1.3)), overall


def total_energy(roll):
    p = roll.params
    m, g, phi = p.mass, p.gravity, p.slope
    return (
        0.5 * m * (roll.vx**2 + roll.vy**2)
        + 0.5 * p.inertia * roll.omega**2
        + m * g * (roll.x * math.sin(phi) + roll.y * math.cos(phi))
    )


def energy_runs(n, seed):
    """Random starts on random slopes and roughness: mostly hops landing near upright
    (bounce sequences, slides), also tumbling flights, slides on both corners, pivots."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        kw = dict(slope=rng.uniform(-0.5, 0.5), roughness=rng.choice([0.0, 0.05, 0.1, 0.3]))
        if i % 3 == 1:
            kw.update(mu_static=0.3, mu_dynamic=rng.uniform(0.0, 0.3))
        p = RoverParams(**kw)
        kind = i % 5
        r, h = p.half_width, p.half_height
        if kind <= 1:
            th = rng.uniform(-0.3, 0.3) if kind == 0 else rng.uniform(-math.pi, math.pi)
            st = (
                0.0,
                rng.uniform(0.08, 0.3),
                th,
                *rng.uniform(-3e-3, 3e-3, 2),
                rng.uniform(-0.02, 0.02),
            )
        elif kind == 2:
            st = (0.0, h, 0.0, rng.uniform(-4e-3, 4e-3), 0.0, 0.0)
        else:
            th = rng.uniform(0.05, 0.5) * (1 if kind == 3 else -1)
            bx = r if th > 0 else -r
            dx = bx * math.cos(th) - h * math.sin(th)
            dy = -bx * math.sin(th) - h * math.cos(th)
            w = rng.uniform(-0.01, 0.01)
            st = (0.0, -dy, th, rng.uniform(-3e-3, 3e-3) - w * dy, w * dx, w)
        yield p, st, int(rng.integers(2**32))


@pytest.mark.parametrize("chunk", range(4))
def test_energy_never_grows_with_torque_zero_and_the_dissipative_law(chunk):
    """Total energy, with the potential along the tilted gravity, on slopes and with
    roughness. Between samples it can only fall (friction, impacts); the tolerance is
    round-off (m g x 1e-12 m; the post-event snaps move the body by round-off)."""
    for p, st, seed in list(energy_runs(40, 5))[chunk::4]:
        roll = simulate(
            np.zeros(1),
            t_end=120.0,
            params=p,
            initial_state=st,
            seed=seed,
            impact_law="dissipative",
            sample_dt=0.02,
        )
        e = total_energy(roll)
        s = np.zeros(core.N_STATE)
        s[:6] = (roll.x[-1], roll.y[-1], roll.theta[-1], roll.vx[-1], roll.vy[-1], roll.omega[-1])
        assert core.total_energy(s, p.as_array()) == pytest.approx(e[-1], rel=1e-14)
        tol = p.mass * p.gravity * 1e-12
        assert np.all(np.diff(e) <= tol), (p, st, np.max(np.diff(e)))
        assert np.all(roll.impact_energy_ratios <= 1.0 + 1e-12)
