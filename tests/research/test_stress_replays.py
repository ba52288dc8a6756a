"""The simulator on the stress benchmark's runs (research/stress/: its families of
schedules and the cases found before): the compiled whole-run loop equals simulate's
Python loop bit for bit, and the event logs grow past their first size, single and
batched. Here rather than in tests/sim because the cases come from the research drivers."""

import numpy as np
import pytest

from helpers import assert_identical, replay
from hoprover_env import simulate, simulate_batch
from research.stress import families
from research.stress.controllers import CTRL_SCHEDULE
from research.stress.drivers import TARGET_X


def stress_schedule_specs(max_per_family=6):
    """Scheduled runs of the stress benchmark that `simulate` can start (make_state-able)."""
    rng = np.random.default_rng(11)
    specs = []
    for family in (
        families.family_extreme_torques,
        families.family_near_flat,
        families.family_flat,
        families.family_random_params,
        families.family_found_cases,
    ):
        got = [s for s in family(rng, True) if s.kind == CTRL_SCHEDULE and s.initial is not None]
        step = max(1, len(got) // max_per_family)
        specs += got[::step][:max_per_family]
    return specs


SPECS = stress_schedule_specs()


@pytest.mark.parametrize(
    "spec", SPECS, ids=[f"{s.family}|{s.integrator}|{s.law}|{s.label}" for s in SPECS]
)
def test_compiled_loop_equals_python_loop_on_stress_schedules(spec):
    t_end = min(spec.t_end, 400 * spec.control_dt)  # keep the Python side short
    kw = dict(
        t_end=t_end,
        control_dt=spec.control_dt,
        target_x=TARGET_X,
        integrator=spec.integrator,
        impact_law=spec.law,
        params=spec.params,
        initial_state=spec.initial,
        euler_dt=spec.euler_dt,
    )
    fast = simulate(spec.sched, **kw)
    slow = simulate(replay(spec.sched), **kw)
    assert_identical(fast, slow)
    assert len(fast.t) > 1


def test_event_log_grows_past_its_first_size():
    # Euler bounces of a corner pressed down (a stress benchmark case) log an event every
    # other step: the log starts at 256 rows and the run resumes after each enlargement
    spec = next(
        s
        for s in families.family_found_cases(np.random.default_rng(0), True)
        if s.integrator == "euler" and s.label.startswith("Euler micro-bounces")
    )
    kw = dict(
        t_end=spec.t_end,
        control_dt=spec.control_dt,
        target_x=TARGET_X,
        integrator="euler",
        impact_law=spec.law,
        initial_state=spec.initial,
    )
    fast = simulate(np.full(1, spec.sched[0]), **kw)
    assert len(fast.events) > 1000
    assert_identical(fast, simulate(replay(spec.sched), **kw))


def test_event_logs_grow_per_batch():
    # a stress case with thousands of Euler events in one run, next to quiet runs
    spec = next(
        s
        for s in families.family_found_cases(np.random.default_rng(0), True)
        if s.integrator == "euler" and s.label.startswith("Euler micro-bounces")
    )
    init = np.array([spec.initial, (0, 0.05, 0, 0, 0, 0), spec.initial])
    sched = np.array([[spec.sched[0]], [0.0], [0.5 * spec.sched[0]]])
    kw = dict(t_end=spec.t_end, control_dt=spec.control_dt, integrator="euler", impact_law=spec.law)
    b = simulate_batch(sched, np.full(3, TARGET_X), initial_states=init, **kw)
    assert b.n_logged[0] > 1000 and b.event_log.shape[1] >= b.n_logged.max()
    for i in range(3):
        assert_identical(
            b.rollout(i), simulate(sched[i], target_x=TARGET_X, initial_state=init[i], **kw)
        )
