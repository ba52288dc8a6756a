"""Cases found by the stability stress benchmark (benchmarks/bench_stress.py), kept as
regression tests. Each once violated an invariant; see docs/PHYSICS.md."""
import math

import numpy as np
import pytest

from hoprover_env import RoverParams, simulate
from helpers import kinematic_violations


def test_near_flat_impact_leaves_no_corner_under_the_ground():
    # both corners within H_IMPACT; one ends at rest, the other bounces: the snap onto
    # the resting corner used to leave the other 1.6e-10 m under the ground (theta < 0 in C)
    init = (0.0, 0.05000414186453813, 1.1672600724199145e-08, -0.0015462824529916227,
            -6.167918008154045e-05, 3.172066852200424e-13)
    dt = 0.06391457114538655
    for law in ("dissipative", "contest"):
        roll = simulate(np.zeros(2), t_end=2 * dt, control_dt=dt, target_x=0.3,
                        impact_law=law, initial_state=init)
        assert kinematic_violations(roll) == []
        assert roll.min_corner_height >= -1e-12


def test_repeated_near_flat_impacts_do_not_sink():
    p = RoverParams(mass=7.917033223160445, inertia=0.0007843822739184555,
                    half_width=0.059897583228545104, half_height=0.01, gravity=0.001,
                    mu_static=0.0, mu_dynamic=0.0, restitution_x=0.45237039302774695,
                    restitution_y=0.4083367981428754)
    init = (-4.1210468773629811e-05, 1.0000000726722429e-02, -1.2132750461299240e-08,
            -1.5395796538378596e-07, -5.8108087961116235e-07, 9.7012408425732076e-06)
    roll = simulate(np.array([0.00017767875814184676]), t_end=0.1, control_dt=0.1, params=p,
                    target_x=0.3, initial_state=init)
    assert roll.min_corner_height >= -1e-9


@pytest.mark.parametrize("law", ["contest", "dissipative"])
def test_pressed_bounce_dies_out(law):
    # a hard torque presses a bouncing corner down (e_y = 0.8): detected 1e-12 m low, each
    # bounce gained energy and the sequence never ended (event budget exhausted)
    p = RoverParams(mass=0.4, inertia=6.6e-5, half_width=0.08, half_height=0.01,
                    gravity=1e-3, mu_static=0.1, mu_dynamic=0.0, restitution_x=0.9,
                    restitution_y=0.8)
    th = 1e-3
    roll = simulate(np.array([3e-4]), t_end=0.1, control_dt=0.1, params=p, impact_law=law,
                    initial_state=(0, 0.08 * math.sin(th) + 0.01 * math.cos(th), th, 0, 1e-5, 0))
    assert roll.n_events < 100
    assert np.all(roll.impact_energy_ratios <= 1.0 + 1e-12) or law == "contest"


def test_euler_pressed_micro_bounces_fit_the_budget():
    roll = simulate(np.array([-0.0002273978004155527]), t_end=4.157780733212458,
                    control_dt=4.157780733212458, integrator="euler",
                    initial_state=(0.0, 0.050667766580636306, -0.013401712023356667,
                                   -0.0008537434721861206, -4.256916749950787e-05, 0.0))
    assert roll.t[-1] == pytest.approx(4.157780733212458)


def test_euler_breaking_step_leaves_no_bottom_corner_under_the_ground():
    p = RoverParams(mass=10.0, inertia=0.00018834480037759906, half_width=0.01,
                    half_height=0.02901248010577509, gravity=0.001,
                    mu_static=0.46532751652347326, mu_dynamic=0.0, restitution_x=0.0,
                    restitution_y=0.648218349547975)
    init = (-0.10737519629590697, 0.010310367351709489, -1.560081357406534,
            -0.0018562368757420386, -0.0051583149325933825, -0.17811210532669478)
    roll = simulate(np.array([7.426682180536331e-05]), t_end=0.1, control_dt=0.1, params=p,
                    integrator="euler", initial_state=init)
    assert roll.broken and roll.min_corner_height >= -1e-9


# ---- issue 9: a hang near the Painleve limit --------------------------------------------
HANG_SCRIPT = r"""
import math, sys, numpy as np
from hoprover_env import core
from hoprover_env.params import RoverParams, PAINLEVE_MARGIN
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
S[core.S_XT], S[core.S_TTRTP], S[core.S_STOP_ON], S[core.S_PHI] = 5.0, math.nan, -1.0, math.nan
S[core.S_HSTEP] = float(sys.argv[2])
from hoprover_env.simulate import make_options
core.advance(S, P, make_options("event", "contest", 1e-11, 1e-3), 0.0, 1.0,
             np.zeros((64, core.EV_COLS)), np.zeros(core.N_WORK))
print("returned", S[core.S_T], S[core.S_ERROR])
"""


@pytest.mark.parametrize("h_carried", [0.0, 10.0])
def test_slide_at_the_old_painleve_margin_returns_instead_of_hanging(h_carried):
    """Issue 9.1: mu = 1, inertia at the old 1e-12 margin, a slide at the attitude of the
    smallest denominator. The first DOP853 step overflowed, its NaN error was accepted
    (`err > 1.0` is False for NaN) and the loop crept towards t_stop for ever. Now the
    kernel rejects the step, ends on its bounds and returns (here: an error state)."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", HANG_SCRIPT, "1e-12", str(h_carried)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    t, err = map(float, out.stdout.split()[-2:])
    assert t == 1.0 or err == 3.0


def test_painleve_margin_refuses_parameters_the_integrator_cannot_handle():
    from hoprover_env.params import PAINLEVE_MARGIN
    base = RoverParams(mu_static=1.0, mu_dynamic=1.0)
    j = lambda i: i + base.mass * base.corner_distance ** 2     # noqa: E731
    shift = base.min_slide_denominator() - base.inertia          # D_min = I + shift
    at_old_limit = -shift + 1e-11 * j(-shift)
    with pytest.raises(ValueError, match="Painleve"):
        RoverParams(mu_static=1.0, mu_dynamic=1.0, inertia=at_old_limit)
    # just inside the new margin the slide integrates: it sticks, no error
    ok = -shift + 2 * PAINLEVE_MARGIN * j(-shift)
    p = RoverParams(mu_static=1.0, mu_dynamic=1.0, inertia=ok)
    th = 0.3927
    dy = -p.half_width * math.sin(th) - p.half_height * math.cos(th)
    roll = simulate(np.zeros(1), t_end=1.0, control_dt=1.0, params=p, target_x=5.0,
                    initial_state=(0.0, -dy, th, 1e-3, 0.0, 0.0))
    assert roll.t[-1] == 1.0 and roll.events and roll.events[0][1] == "stick"


# ---- issue 9.5 and 9.6: runs reach t_end exactly; grids that would never finish ---------
def test_run_reaches_t_end_exactly_past_a_multiple_of_control_dt():
    t_end = 100 + 4e-8
    for ctrl in (np.zeros(3), lambda *a: 0.0):
        roll = simulate(ctrl, t_end=t_end, control_dt=50.0)
        assert roll.t[-1] == t_end


@pytest.mark.parametrize("kw", [dict(t_end=1e300), dict(control_dt=1e-300),
                                dict(sample_dt=1e-300)])
def test_grids_that_would_never_finish_are_refused(kw):
    args = dict(t_end=10.0, control_dt=1.0)
    args.update(kw)
    with pytest.raises(ValueError, match="more than one call may produce"):
        simulate(np.zeros(1), **args)


def test_an_euler_step_that_would_never_finish_is_refused():
    with pytest.raises(ValueError, match="Euler steps"):
        simulate(np.zeros(1), t_end=10.0, control_dt=1.0, integrator="euler", euler_dt=1e-300)


# ---- issue 9.7: numpy scalars accepted, strings / booleans / complex refused by name -----
def test_numpy_scalars_are_accepted_and_strings_booleans_refused():
    from hoprover_env.env import HopRoverEnv
    roll = simulate(np.zeros(2), t_end=np.float32(1.0), control_dt=np.int64(1))
    assert roll.t[-1] == 1.0
    env = HopRoverEnv(control_dt=np.float32(0.5), episode_time=np.int64(60))
    assert env.config.control_dt == 0.5 and env.config.episode_time == 60.0
    for bad in ("1.0", True, 1 + 2j):
        with pytest.raises(TypeError, match="t_end"):
            simulate(np.zeros(1), t_end=bad)
        with pytest.raises(TypeError, match="control_dt"):
            HopRoverEnv(control_dt=bad)


# ---- issue 9.4: TTRTP is logged when it happens ------------------------------------------
def test_ttrtp_is_logged_in_time_order_and_stop_on_ttrtp_stops_there():
    from hoprover_env import RoverSim
    roll = simulate(np.full(1, 2e-5), t_end=20.0, control_dt=20.0, target_x=0.0)
    times = [e[0] for e in roll.events]
    assert times == sorted(times)
    assert ("ttrtp" in [e[1] for e in roll.events]) and roll.ttrtp == 5.0
    sim = RoverSim(target_x=0.0)
    events = sim.advance(2e-5, 20.0, stop_on="ttrtp")
    assert sim.t == 5.0 and events[-1][1] == "ttrtp"
