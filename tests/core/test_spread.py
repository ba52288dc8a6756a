"""Work spread over the cores: the threaded loops read their rows through a permutation
(hoprover_env/jit/spread.py) and give the same bits on any thread count; mpc's episodes
spread over worker processes give the serial run's results."""

import dataclasses
import os
import subprocess
import sys
import threading
from pathlib import Path

import numba
import numpy as np
import pytest

from hoprover_env import HopRoverVectorEnv, simulate_batch
from hoprover_env.jit import spread
from hoprover_env.jit.spread import spread_order

TWO_THREADS = pytest.mark.skipif(
    numba.config.NUMBA_NUM_THREADS < 2, reason="needs numba to have two threads"
)


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 100, 4096, 4099])
def test_spread_order_is_a_permutation_of_blocks(n):
    order = spread_order(n)
    assert order.dtype == np.int64 and order.flags.c_contiguous and order.flags.writeable
    assert np.array_equal(np.sort(order), np.arange(n))
    # blocks of BLOCK consecutive rows stay together: a row either starts a block or
    # follows the row before it
    starts = order % spread.BLOCK == 0
    assert np.all(starts[1:] | (np.diff(order) == 1)) and (n == 0 or starts[0])
    assert np.array_equal(spread_order(n), order)  # deterministic


@pytest.mark.parametrize("n", [1024, 4096, 6400])
@pytest.mark.parametrize("threads", [2, 3, 4])
def test_each_thread_gets_its_share_of_grouped_rows(n, threads):
    # numba gives thread t one contiguous range of the loop: with the rows of the first
    # half costly, every thread's range holds about half of them
    parts = np.array_split(spread_order(n), threads)
    shares = [float(np.mean(p < n // 2)) for p in parts]
    # within 3 % of an even split, and the one block a short range may be off by
    assert max(abs(s - 0.5) for s in shares) < 0.03 + spread.BLOCK * threads / n, shares


def grouped_batch(n=64, t_end=60.0):
    """Runs whose first half hops (a launch torque, then kicks) and whose second half
    rests: the costly runs sit together."""
    rng = np.random.default_rng(3)
    k = int(t_end / 0.5)
    sched = np.zeros((n, k))
    sched[: n // 2, :4] = 3e-4
    sched[: n // 2] += np.where(
        rng.random((n // 2, k)) < 0.05, rng.uniform(-5e-5, 5e-5, (n // 2, k)), 0.0
    )
    return sched, rng.uniform(-1.0, 1.0, n), dict(t_end=t_end, control_dt=0.5)


@TWO_THREADS
def test_a_batch_gives_the_same_bits_on_one_and_two_threads_through_the_order(monkeypatch):
    from hoprover_env.sim import batch

    seen = []
    real = batch.run_threaded

    def spy(fn, *args):
        seen.append(args[-1].copy())  # the order the loop reads the runs in
        return real(fn, *args)

    monkeypatch.setattr(batch, "run_threaded", spy)
    sched, targets, kw = grouped_batch()
    before = numba.get_num_threads()
    out = {}
    try:
        for t in (1, 2):
            numba.set_num_threads(t)
            out[t] = simulate_batch(sched, targets, **kw)
    finally:
        numba.set_num_threads(before)
    assert seen and all(np.array_equal(o, spread_order(len(targets))) for o in seen)
    assert not np.array_equal(seen[0], np.arange(len(targets)))
    one, two = out[1], out[2]
    for f in ("ttrtp", "final", "n_events", "x", "theta", "torque", "n_samples"):
        assert np.array_equal(getattr(one, f), getattr(two, f), equal_nan=True), f
    assert np.array_equal(one.event_log, two.event_log, equal_nan=True)
    assert np.ptp(one.n_events) > 0  # the halves do differ in cost


@TWO_THREADS
def test_a_vector_env_gives_the_same_bits_on_one_and_two_threads():
    n, steps = 96, 60
    rng = np.random.default_rng(4)
    acts = rng.uniform(-1.0, 1.0, (steps, n, 1))
    acts[:, n // 2 :] *= 0.02  # the second half barely moves
    before = numba.get_num_threads()
    runs = {}
    try:
        for t in (1, 2):
            numba.set_num_threads(t)
            env = HopRoverVectorEnv(n, threads=True, control_dt=1.0, episode_time=40.0)
            assert not np.array_equal(env._order, np.arange(n))
            obs, _ = env.reset(seed=9)
            trace = [obs]
            for a in acts:
                obs, r, te, tr, _ = env.step(a)
                trace += [obs, r, te, tr]
            trace.append(env.S.copy())
            runs[t] = trace
    finally:
        numba.set_num_threads(before)
    for a, b in zip(runs[1], runs[2]):
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f")  # S holds NaNs


def mpc_rows(results):
    return [{k: v for k, v in dataclasses.asdict(r).items() if k != "wall_time"} for r in results]


@pytest.mark.slow  # worker processes
def test_mpc_episodes_spread_over_processes_equal_the_serial_run():
    # same episodes, same order, same numbers: a chunk runs its episodes seeded as the
    # serial run seeds them, and mpc plays an episode alike in any batch
    from hoprover_env.agents.mpc import MPCPolicy
    from hoprover_env.evaluation.episodes import run_episodes

    targets = np.array([0.35, -0.3, 0.01, 0.6, -0.7])
    ground = {
        "slope": np.array([0.0, 0.05, 0.0, -0.05, 0.0]),
        "roughness": np.array([0.0, 0.05, 0.0, 0.05, 0.0]),
        "terrain_seed": np.array([-1, 22, -1, 33, -1]),
    }
    kw = dict(env_kwargs={"episode_time": 200.0}, terrain=ground)

    def agent(workers=None):
        return MPCPolicy(budget=150, rough_budget=150, terrain_samples=2, workers=workers)

    serial_agent = agent()
    serial = run_episodes(serial_agent, targets, workers=1, **kw)
    done = []
    spread_agent = agent(workers=2)
    threads = threading.active_count()
    spread_out = run_episodes(spread_agent, targets, progress=done.append, **kw)
    assert threading.active_count() == threads  # the pool's threads are joined
    assert mpc_rows(spread_out) == mpc_rows(serial)
    assert [r.episode for r in spread_out] == list(range(len(targets)))
    assert done[-1] == len(targets) and done == sorted(done)
    assert spread_agent.decisions > 0 and spread_agent.planning_seconds > 0.0
    # a slice numbered as part of a larger set is numbered alike when spread
    sliced = run_episodes(
        agent(workers=2),
        targets[3:],
        first_episode=3,
        **{**kw, "terrain": {k: v[3:] for k, v in ground.items()}},
    )
    assert mpc_rows(sliced) == mpc_rows(serial)[3:]


def test_who_is_spread_over_processes():
    from hoprover_env.agents.base import RandomPolicy
    from hoprover_env.agents.mpc import MPCPolicy
    from hoprover_env.evaluation.episodes import cores, episode_workers

    assert episode_workers(RandomPolicy(0), None, 100) == 1  # batch-bound policies
    assert episode_workers(RandomPolicy(0), 4, 100) == 1
    assert episode_workers(MPCPolicy(), None, 100) == min(cores(), 12)
    assert episode_workers(MPCPolicy(), None, 7) == 1  # not worth a start
    assert episode_workers(MPCPolicy(workers=3), None, 100) == 3
    assert episode_workers(MPCPolicy(workers=3), 1, 100) == 1  # the caller decides
    assert episode_workers(MPCPolicy(workers=8), None, 5) == 5  # one per episode at most
    with pytest.raises(ValueError, match="workers"):
        MPCPolicy(workers=0)
    with pytest.raises(ValueError, match="workers"):
        episode_workers(MPCPolicy(), 0, 10)


UNGUARDED = """
import numpy as np
from hoprover_env.agents.mpc import MPCPolicy
from hoprover_env.evaluation.episodes import run_episodes
# no `if __name__ == "__main__"`: the workers must not run this script again
results = run_episodes(MPCPolicy(workers=2), np.zeros(3), env_kwargs={"episode_time": 20.0})
print("done", len(results), sum(r.success for r in results))
"""


@pytest.mark.slow  # a script and its workers
def test_a_script_without_a_main_guard_spreads_its_episodes(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED)
    root = str(Path(__file__).resolve().parents[2])
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)
    )
    out = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=900,
        env=env,
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == ["done", "3", "3"]  # once, by the script alone


def test_an_error_in_a_worker_is_raised_in_the_caller():
    from hoprover_env.agents.mpc import MPCPolicy
    from hoprover_env.evaluation.episodes import run_episodes

    with pytest.raises(ValueError, match="episode_time"):
        run_episodes(MPCPolicy(workers=1), np.zeros(2), env_kwargs={"episode_time": -1.0})
    with pytest.raises(ValueError, match="episode_time"):
        run_episodes(MPCPolicy(workers=2), np.zeros(2), env_kwargs={"episode_time": -1.0})
