"""The compiled whole-run loop (hoprover_env/sim/control_loop.py) against simulate's Python loop
(on the stress benchmark's schedules too: tests/research/test_stress_replays.py).

A torque schedule or a compiled controller runs in one kernel call; a plain Python
callable runs the Python loop. Replaying a schedule through a Python callable therefore
exercises the old path on the same torques, and the two Rollouts must agree bit for bit.
"""

import math

import numba
import numpy as np
import pytest

from helpers import assert_identical, replay
from hoprover_env import RoverParams, simulate
from hoprover_env.sim.controllers import attitude_hold


@pytest.mark.parametrize(
    "kw",
    [
        dict(t_end=60.0, control_dt=0.7, sample_dt=0.05),  # samples between instants
        dict(t_end=7, control_dt=2),  # ints, a short last interval
        dict(t_end=40.0, control_dt=0.5, integrator="euler", euler_dt=1e-3),
    ],
)
def test_compiled_loop_equals_python_loop_variants(kw):
    sched = 4e-4 * np.sin(np.arange(200) * 0.37)
    assert_identical(
        simulate(sched, target_x=0.1, **kw), simulate(replay(sched), target_x=0.1, **kw)
    )


def test_broken_run_stops_like_the_python_loop():
    sched = 1e-5 * np.ones(10)  # a spinning drop lands on a top corner
    kw = dict(t_end=600.0, control_dt=0.5, target_x=0.5, initial_state=(0, 0.3, 0, 0, 0, 0.5))
    fast = simulate(sched, **kw)
    assert fast.broken and fast.t[-1] < 600.0
    assert_identical(fast, simulate(replay(sched), **kw))


@numba.njit
def hold_then_launch(pos, vel, the, omg, posT, t, smt, state_code):
    if state_code == 0:  # flight: PD attitude hold
        return attitude_hold(the, omg, 0.0017, 0.15, 0.9)
    if t < 8.0:
        return 3e-4 if posT[0] > pos[0] else -3e-4
    return 0.0


@pytest.mark.parametrize(
    "kw",
    [
        dict(t_end=300.0, control_dt=0.1, target_x=-0.4),
        dict(
            t_end=120.0,
            control_dt=0.5,
            sample_dt=0.2,
            target_x=0.3,
            integrator="euler",
            euler_dt=2e-3,
        ),
    ],
)
def test_compiled_controller_equals_its_python_twin(kw):
    fast = simulate(hold_then_launch, **kw)

    def twin(pos, vel, the, omg, posT, t, smt, state):
        return hold_then_launch.py_func(pos, vel, the, omg, posT, t, smt, "ABCDEFG".index(state))

    assert_identical(fast, simulate(twin, **kw))
    assert "liftoff" in [e[1] for e in fast.events]


def test_compiled_controller_sees_copies_and_the_contest_arguments():
    @numba.njit
    def scribble(pos, vel, the, omg, posT, t, smt, state_code):
        pos[0] = 99.0  # must not move the rover
        posT[1] = 5.0
        return 1e-4 * state_code + posT[0] * 0.0 + smt * 0.0

    roll = simulate(scribble, t_end=3.0, control_dt=1.0, target_x=0.25)
    assert np.all(np.abs(roll.x) < 1.0)
    assert roll.torque_cmd[0] == 1e-4 * 5  # at rest: state F = code 5


def test_compiled_controller_errors():
    @numba.njit
    def nan_after(pos, vel, the, omg, posT, t, smt, state_code):
        return math.nan if t >= 2.0 else 0.0

    with pytest.raises(ValueError, match="the controller's torque must be finite"):
        simulate(nan_after, t_end=5.0, control_dt=1.0)

    @numba.njit
    def wrong(pos, vel):
        return 0.0

    with pytest.raises(TypeError, match="contest signature"):
        simulate(wrong, t_end=1.0)


def test_no_compile_at_import():
    # the explicit-signature loops are built on first use, not when simulate is imported
    import subprocess
    import sys

    code = (
        "import hoprover_env.sim.control_loop as r; import hoprover_env; "
        "print(r.run_one == {} and r.run_many == {} and r.no_control is None)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "True"


def test_default_params_object_is_kept():
    p = RoverParams(mu_static=0.7)
    assert simulate(np.zeros(2), t_end=1.0, params=p).params is p
