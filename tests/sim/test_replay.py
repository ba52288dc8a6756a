"""Every run records what replays it; per-run seeds keep a run's bumps anywhere."""

import numba
import numpy as np
import pytest

from hoprover_env import RoverParams, simulate, simulate_batch
from hoprover_env.agents.planning import PLAN_SIZE, plan_controller

ROUGH = RoverParams(slope=0.1, roughness=0.15)


def _schedules(n, k=40, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-5e-4, 5e-4, (n, k))


def _same(a, b):
    assert a.ttrtp == b.ttrtp or (a.ttrtp is None and b.ttrtp is None)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.theta, b.theta)
    assert a.n_events == b.n_events


@pytest.mark.parametrize("record", [True, False])
def test_batch_runs_on_rough_ground_replay_from_their_rollout(record):
    sched = _schedules(6)
    b = simulate_batch(
        sched,
        np.linspace(-0.8, 0.8, 6),
        t_end=120.0,
        control_dt=0.5,
        params=ROUGH,
        seed=777,
        record=record,
    )
    for i in range(6):
        roll = b.rollout(i)
        assert roll.seed == 777 and roll.rover == i
        _same(roll, simulate(**roll.replay_args))
    # without the rover index the bumps differ: the index is part of the key
    again = simulate(
        sched[3], t_end=120.0, control_dt=0.5, target_x=b.targets[3], params=ROUGH, seed=777
    )
    assert not np.array_equal(again.x, b.rollout(3).x)


def test_per_run_seeds_give_the_same_run_at_any_position_and_thread_count():
    sched = _schedules(5, seed=1)
    seeds = np.array([11, 2**63 + 5, 42, 7, 2**64 - 1], dtype=np.uint64)
    targets = np.linspace(-0.5, 0.5, 5)
    kw = dict(t_end=150.0, control_dt=0.5, params=ROUGH, record=False)
    a = simulate_batch(sched, targets, seed=seeds, **kw)
    perm = np.array([4, 2, 0, 3, 1])
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = simulate_batch(sched[perm], targets[perm], seed=seeds[perm], **kw)
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(a.final[perm], b.final)
    np.testing.assert_array_equal(a.ttrtp[perm], b.ttrtp, strict=False)
    for i in range(5):  # each equals simulate with its own seed, rover 0
        one = simulate(
            sched[i],
            t_end=150.0,
            control_dt=0.5,
            target_x=targets[i],
            params=ROUGH,
            seed=int(seeds[i]),
        )
        np.testing.assert_array_equal(one.x[-1], a.final[i, 0])
        assert a.rollout(i).replay_args["seed"] == int(seeds[i])
        assert a.rollout(i).replay_args["rover"] == 0


def test_a_compiled_controller_with_args_replays():
    args = np.zeros((2, PLAN_SIZE))
    args[:, 1] = RoverParams().inertia
    args[:, 2:4] = 0.2, 0.6
    args[:, 5:8] = [[0.0, 13.0, 2.1e-4], [0.0, 6.0, -3e-4]]
    for record in (True, False):
        b = simulate_batch(
            plan_controller,
            [0.5, -0.6],
            t_end=400.0,
            control_dt=0.5,
            controller_args=args,
            record=record,
        )
        for i in range(2):
            roll = b.rollout(i)
            assert (roll.ttrtp if roll.success else np.nan) == pytest.approx(
                b.ttrtp[i], rel=0, abs=0, nan_ok=True
            )
            _same(roll, simulate(**roll.replay_args))


def test_bad_per_run_seeds_are_named():
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        simulate_batch(_schedules(3), [0, 0, 0], seed=np.array([1, 2]))
    with pytest.raises(ValueError, match="run 1"):
        simulate_batch(_schedules(3), [0, 0, 0], seed=np.array([1, -2, 3]))
    with pytest.raises(ValueError, match="controller_args"):
        simulate([1e-4], controller_args=[1.0])
