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
