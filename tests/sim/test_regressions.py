"""Cases found by the stability stress benchmark (benchmarks/bench_stress.py), kept as
regression tests. Each once violated an invariant; see docs/PHYSICS.md."""

import math

import numpy as np
import pytest

from hoprover_env import RoverParams, simulate
from hoprover_env.core import params
from hoprover_env.sim.invariants import kinematic_violations


def test_near_flat_impact_leaves_no_corner_under_the_ground():
    # both corners within H_IMPACT; one ends at rest, the other bounces: the snap onto
    # the resting corner used to leave the other 1.6e-10 m under the ground (theta < 0 in C)
    init = (
        0.0,
        0.05000414186453813,
        1.1672600724199145e-08,
        -0.0015462824529916227,
        -6.167918008154045e-05,
        3.172066852200424e-13,
    )
    dt = 0.06391457114538655
    for law in ("dissipative", "contest"):
        roll = simulate(
            np.zeros(2),
            t_end=2 * dt,
            control_dt=dt,
            target_x=0.3,
            impact_law=law,
            initial_state=init,
        )
        assert kinematic_violations(roll) == []
        assert roll.min_corner_height >= -1e-12


def test_repeated_near_flat_impacts_do_not_sink():
    p = RoverParams(
        mass=7.917033223160445,
        inertia=0.0007843822739184555,
        half_width=0.059897583228545104,
        half_height=0.01,
        gravity=0.001,
        mu_static=0.0,
        mu_dynamic=0.0,
        restitution_x=0.45237039302774695,
        restitution_y=0.4083367981428754,
    )
    init = (
        -4.1210468773629811e-05,
        1.0000000726722429e-02,
        -1.2132750461299240e-08,
        -1.5395796538378596e-07,
        -5.8108087961116235e-07,
        9.7012408425732076e-06,
    )
    roll = simulate(
        np.array([0.00017767875814184676]),
        t_end=0.1,
        control_dt=0.1,
        params=p,
        target_x=0.3,
        initial_state=init,
    )
    assert roll.min_corner_height >= -1e-9


@pytest.mark.parametrize("law", ["contest", "dissipative"])
def test_pressed_bounce_dies_out(law):
    # a hard torque presses a bouncing corner down (e_y = 0.8): detected 1e-12 m low, each
    # bounce gained energy and the sequence never ended (event budget exhausted)
    p = RoverParams(
        mass=0.4,
        inertia=6.6e-5,
        half_width=0.08,
        half_height=0.01,
        gravity=1e-3,
        mu_static=0.1,
        mu_dynamic=0.0,
        restitution_x=0.9,
        restitution_y=0.8,
    )
    th = 1e-3
    roll = simulate(
        np.array([3e-4]),
        t_end=0.1,
        control_dt=0.1,
        params=p,
        impact_law=law,
        initial_state=(0, 0.08 * math.sin(th) + 0.01 * math.cos(th), th, 0, 1e-5, 0),
    )
    assert roll.n_events < 100
    assert np.all(roll.impact_energy_ratios <= 1.0 + 1e-12) or law == "contest"


def test_euler_pressed_micro_bounces_fit_the_budget():
    roll = simulate(
        np.array([-0.0002273978004155527]),
        t_end=4.157780733212458,
        control_dt=4.157780733212458,
        integrator="euler",
        initial_state=(
            0.0,
            0.050667766580636306,
            -0.013401712023356667,
            -0.0008537434721861206,
            -4.256916749950787e-05,
            0.0,
        ),
    )
    assert roll.t[-1] == pytest.approx(4.157780733212458)


def test_euler_breaking_step_leaves_no_bottom_corner_under_the_ground():
    p = RoverParams(
        mass=10.0,
        inertia=0.00018834480037759906,
        half_width=0.01,
        half_height=0.02901248010577509,
        gravity=0.001,
        mu_static=0.46532751652347326,
        mu_dynamic=0.0,
        restitution_x=0.0,
        restitution_y=0.648218349547975,
    )
    init = (
        -0.10737519629590697,
        0.010310367351709489,
        -1.560081357406534,
        -0.0018562368757420386,
        -0.0051583149325933825,
        -0.17811210532669478,
    )
    roll = simulate(
        np.array([7.426682180536331e-05]),
        t_end=0.1,
        control_dt=0.1,
        params=p,
        integrator="euler",
        initial_state=init,
    )
    assert roll.broken and roll.min_corner_height >= -1e-9


# ---- a hang near the Painleve limit -----------------------------------------------------
HANG_SCRIPT = r"""
import math, sys, numpy as np
from hoprover_env import core
from hoprover_env.core.params import RoverParams, PAINLEVE_MARGIN
base = RoverParams(mu_static=1.0, mu_dynamic=1.0)
j_of = lambda inertia: inertia + base.mass * base.corner_distance ** 2
def d_rel(inertia):     # the slide denominator relative to I + m l^2, for this inertia
    return (base.min_slide_denominator() - base.inertia + inertia) / j_of(inertia)
# the inertia where the old check (margin 1e-12) stopped: D_min = 1e-12 J
lo, hi = 0.0, base.inertia
for _ in range(200):
    mid = 0.5 * (lo + hi)
    lo, hi = (mid, hi) if d_rel(mid) <= float(sys.argv[1]) else (lo, mid)
P = base.as_array()
P[1] = hi                                  # bypass RoverParams: the kernel on its own
th = 0.3927
r, h = base.half_width, base.half_height
dy = -r * math.sin(th) - h * math.cos(th)
S = np.zeros(core.N_STATE)
S[core.S_Y], S[core.S_TH], S[core.S_VX] = -dy, th, 1e-3
S[core.S_MODE], S[core.S_SIGMA] = core.MODE_C, 1.0
S[core.S_XT], S[core.S_TTRTP], S[core.S_STOP_ON] = 5.0, math.nan, -1.0
S[core.S_HSTEP] = float(sys.argv[2])
from hoprover_env.sim.simulate import make_options
core.advance(S, P, make_options("event", "contest", 1e-11, 1e-3), 0.0, 1.0,
             np.zeros((64, core.EV_COLS)), np.zeros(core.N_WORK))
print("returned", S[core.S_T], S[core.S_ERROR])
"""


@pytest.mark.parametrize("h_carried", [0.0, 10.0])
def test_slide_at_the_old_painleve_margin_returns_instead_of_hanging(h_carried):
    """mu = 1, inertia at the old 1e-12 margin, a slide at the attitude of the
    smallest denominator. The first DOP853 step overflowed, its NaN error was accepted
    (`err > 1.0` is False for NaN) and the loop crept towards t_stop for ever. Now the
    kernel rejects the step, ends on its bounds and returns (here: an error state)."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", HANG_SCRIPT, "1e-12", str(h_carried)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    t, err = map(float, out.stdout.split()[-2:])
    assert t == 1.0 or err == 3.0


def test_painleve_margin_refuses_parameters_the_integrator_cannot_handle():
    from hoprover_env.core.params import PAINLEVE_MARGIN

    base = RoverParams(mu_static=1.0, mu_dynamic=1.0)
    j = lambda i: i + base.mass * base.corner_distance**2  # noqa: E731
    shift = base.min_slide_denominator() - base.inertia  # D_min = I + shift
    at_old_limit = -shift + 1e-11 * j(-shift)
    with pytest.raises(ValueError, match="Painleve"):
        RoverParams(mu_static=1.0, mu_dynamic=1.0, inertia=at_old_limit)
    # just inside the new margin the slide integrates: it sticks, no error
    ok = -shift + 2 * PAINLEVE_MARGIN * j(-shift)
    p = RoverParams(mu_static=1.0, mu_dynamic=1.0, inertia=ok)
    th = 0.3927
    dy = -p.half_width * math.sin(th) - p.half_height * math.cos(th)
    roll = simulate(
        np.zeros(1),
        t_end=1.0,
        control_dt=1.0,
        params=p,
        target_x=5.0,
        initial_state=(0.0, -dy, th, 1e-3, 0.0, 0.0),
    )
    assert roll.t[-1] == 1.0 and roll.events and roll.events[0][1] == "stick"


# ---- runs reach t_end exactly; grids that would never finish ----------------------------
def test_run_reaches_t_end_exactly_past_a_multiple_of_control_dt():
    t_end = 100 + 4e-8
    for ctrl in (np.zeros(3), lambda *a: 0.0):
        roll = simulate(ctrl, t_end=t_end, control_dt=50.0)
        assert roll.t[-1] == t_end


@pytest.mark.parametrize("kw", [dict(t_end=1e300), dict(control_dt=1e-300), dict(sample_dt=1e-300)])
def test_grids_that_would_never_finish_are_refused(kw):
    args = dict(t_end=10.0, control_dt=1.0)
    args.update(kw)
    with pytest.raises(ValueError, match="more than one call may produce"):
        simulate(np.zeros(1), **args)


def test_an_euler_step_that_would_never_finish_is_refused():
    with pytest.raises(ValueError, match="Euler steps"):
        simulate(np.zeros(1), t_end=10.0, control_dt=1.0, integrator="euler", euler_dt=1e-300)


# ---- numpy scalars accepted, strings / booleans / complex refused by name ----------------
def test_numpy_scalars_are_accepted_and_strings_booleans_refused():
    from hoprover_env.envs.env import HopRoverEnv

    roll = simulate(np.zeros(2), t_end=np.float32(1.0), control_dt=np.int64(1))
    assert roll.t[-1] == 1.0
    env = HopRoverEnv(control_dt=np.float32(0.5), episode_time=np.int64(60))
    assert env.config.control_dt == 0.5 and env.config.episode_time == 60.0
    for bad in ("1.0", True, 1 + 2j):
        with pytest.raises(TypeError, match="t_end"):
            simulate(np.zeros(1), t_end=bad)
        with pytest.raises(TypeError, match="control_dt"):
            HopRoverEnv(control_dt=bad)


# ---- TTRTP is logged when it happens -----------------------------------------------------
def test_ttrtp_is_logged_in_time_order_and_stop_on_ttrtp_stops_there():
    from hoprover_env import RoverSim

    roll = simulate(np.full(1, 2e-5), t_end=20.0, control_dt=20.0, target_x=0.0)
    times = [e[0] for e in roll.events]
    assert times == sorted(times)
    assert ("ttrtp" in [e[1] for e in roll.events]) and roll.ttrtp == 5.0
    sim = RoverSim(target_x=0.0)
    events = sim.advance(2e-5, 20.0, stop_on="ttrtp")
    assert sim.t == 5.0 and events[-1][1] == "ttrtp"


def _lowest_corner_height(sim_or_state, params):
    from hoprover_env import core

    s = sim_or_state
    return min(s[core.S_Y] + core.corner_offset(params, k, s[core.S_TH])[1] for k in range(4))


def test_no_impact_is_logged_in_mid_air_over_a_long_control_interval():
    # the flight bound used the spin rate at the END of a 200 s interval, so
    # steps shrank to 1e-7 s after lift-off, the iteration budget ran out 3.6e-5 m up
    # and an impact that changed nothing was logged at t = 2.88 s
    roll = simulate(np.array([5e-4]), t_end=200, control_dt=200)
    kinds = [e[1] for e in roll.events]
    assert kinds[:3] == ["tip", "slip", "liftoff"]
    t_lift = roll.events[2][0]
    assert not any(e[1] == "impact" and e[0] < t_lift + 10.0 for e in roll.events)


@pytest.mark.slow  # the closed form sampled on millions of points
def test_stop_on_impact_stops_where_a_corner_really_meets_the_ground():
    # RoverSim stopped at t = 140.87 s with every corner 0.32 m up. Checked
    # against the closed-form flight sampled every 1e-5 s.
    from hoprover_env import RoverSim, core

    sim = RoverSim(target_x=1e3)
    sim.advance(3.7e-4, 200, stop_on="liftoff")
    s0, p, t0 = sim.s.copy(), sim.p, sim.t
    ev = sim.advance(3.7e-4, 200, stop_on="impact")
    assert ev and ev[-1][1] in ("impact", "broken")
    assert abs(_lowest_corner_height(sim.s, p)) < 1e-9
    x, y, th, vx, vy, w = s0[:6]
    tt = np.arange(0.0, sim.t - t0 + 1.0, 1e-5)
    thh = th + w * tt + 0.5 * 3.7e-4 / p[params.P_I] * tt**2
    yy = y + vy * tt - 0.5 * p[params.P_G] * tt**2
    h = np.min(
        [
            yy - bx * np.sin(thh) + by * np.cos(thh)
            for bx, by in (core.corner_body(p, k) for k in range(4))
        ],
        axis=0,
    )
    first = t0 + tt[np.argmax(h[10:] <= 0.0) + 10]
    assert abs(sim.t - first) < 2e-5


def _return_time_exact(s0, p, torque, k=0):
    """First return of corner k to the ground in the closed-form flight from state s0,
    in 40-digit arithmetic (independent of the kernel's stepping and round-off)."""
    mp = pytest.importorskip("mpmath")
    from hoprover_env import core

    mp.mp.dps = 40
    y, th, vy, w = (mp.mpf(float(s0[i])) for i in (core.S_Y, core.S_TH, core.S_VY, core.S_W))
    g, beta = mp.mpf(float(p[params.P_G])), mp.mpf(torque) / mp.mpf(float(p[params.P_I]))
    bx, by = (mp.mpf(float(v)) for v in core.corner_body(p, k))

    def h(t):
        a = th + w * t + beta * t * t / 2
        return y + vy * t - g * t * t / 2 - bx * mp.sin(a) + by * mp.cos(a)

    lo = mp.mpf(0)
    for i in range(1, 100_000):
        hi = mp.mpf(i) * mp.mpf("1e-8")
        if h(hi) < 0:
            break
        lo = hi
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if h(mid) >= 0 else (lo, mid)
    return float(hi)


@pytest.mark.parametrize(
    "delay,t1,t2", [(2e-4, 1e-4, 5e-4), (1e-4, 1e-4, 5e-4), (2e-4, 3e-4, 4e-4)]
)
def test_slow_return_after_lift_off_is_located_whatever_the_horizon(delay, t1, t2):
    # a corner lifts off, a torque change `delay` later drives it back within
    # microseconds at ~1e-9 m/s. A Newton polish dividing by that speed reported the
    # return up to 4e-5 s late, and later for longer `advance` horizons.
    from hoprover_env import RoverSim

    found = []
    for horizon in (1e-3, 1.0, 5.0, 20.0, 100.0):
        sim = RoverSim(target_x=1e3)
        sim.advance(t1, 100.0, stop_on="liftoff")
        sim.advance(t1, sim.t + delay)
        t_c, s0, p = sim.t, sim.s.copy(), sim.p
        ev = sim.advance(t2, t_c + horizon, stop_on="impact")
        assert ev[0][1] == "impact", ev
        found.append(ev[0][0] - t_c)
    exact = _return_time_exact(s0, p, t2)
    assert 1e-7 < exact < 1e-5
    # the float state fixes the corner height only to ~1e-17 m: at ~1e-9 m/s that is
    # ~1e-9 s (measured 1.3e-9 s at most)
    assert max(abs(t - exact) for t in found) < 5e-9
    assert max(found) - min(found) < 1e-12


def test_a_flight_towards_a_huge_t_stop_still_lands():
    # found by tests/envs/test_fuzz.py: with t_stop = 1e300 the flight's curvature bound was
    # infinite, every step NaN, and the rover flew through the ground to t = 1e300
    from hoprover_env import RoverSim

    ends = []
    for t_stop in (100.0, 1e5, 1e300):
        sim = RoverSim()
        ev = sim.advance(3.147975132604256e-05, t_stop)
        ends.append((ev[-1][:2], sim.t))
        assert np.all(np.isfinite(sim.state))
    assert ends[0][0][1] == "broken" and len(set(ends)) == 1
