"""Evaluate a policy with the contest judge on a fixed set of targets.

All sub-episodes run side by side in one `HopRoverVectorEnv` (one target each, a
single episode each), so a neural policy is queried once per control step for the
whole batch. The judge is the simulator's own: TTRTP exact to event precision.

A policy that spends its time per rover in Python (`mpc`: a search per decision) gains
little from the vector env's threads; one that says how many processes its episodes
may be spread over (a `workers` attribute: `MPCPolicy`) has them run in chunks in
that many worker processes, each a fresh interpreter (`evaluation.workers`: never a
fork of this process, whose threads may hold locks, and no re-run of the caller's
script), the results put back in episode order. Only a policy whose every episode
plays the same in any batch may say so: the results are then those of the serial run,
field for field (the wall time aside).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np
from gymnasium.vector import AutoresetMode

from hoprover_env.agents.base import RandomPolicy
from hoprover_env.envs.registry import vector_env_class
from hoprover_env.tasks.config import TRAINING_STARTS


@dataclasses.dataclass
class EpisodeResult:
    """One evaluated episode: the policy's name, the episode's index, its target [m],
    success, the judge's TTRTP [s] (None without success), whether the rover broke, the
    env steps, the simulated time [s], the final c.m. x [m] and the wall time [s] (a
    batch's mean)."""

    policy: str
    episode: int
    target_x: float
    success: bool
    ttrtp: float | None
    broken: bool
    steps: int
    sim_time: float
    final_x: float
    wall_time: float

    def as_dict(self) -> dict:
        """The fields as a dict (a row of evaluate.py's JSON and CSV)."""
        return dataclasses.asdict(self)


def seeded_targets(n: int, seed: int = 2015, low: float = -1.0, high: float = 1.0) -> np.ndarray:
    """The fixed evaluation targets: n draws from U(low, high) with this seed."""
    return np.random.default_rng(seed).uniform(low, high, n)


def run_episodes(
    policy,
    targets,
    env_kwargs: dict | None = None,
    batch: int = 256,
    progress=None,
    first_episode: int = 0,
    terrain: dict | None = None,
    workers: int | None = None,
) -> list[EpisodeResult]:
    """One episode per target, `batch` episodes side by side. `env_kwargs` configure the
    env (the policy's own `env_kwargs`, e.g. its control period, take precedence).
    `terrain` fixes each episode's start: {"slope": per-episode slopes [rad],
    "roughness": per-episode roughness [rad], "terrain_seed": per-episode seeds of the
    bumps (integers)} and any other reset option, one value per episode
    (hoprover_env/tasks/options.py: a frozen suite's start conditions, `Suite.conditions`).
    `progress` is called with the number of finished episodes. `first_episode` numbers
    the episodes of a slice of a larger target set (evaluate.py --ray runs slices that
    start at multiples of `batch`, so each batch is the one a local run has).
    `workers`: the processes to spread the episodes over, for a policy that allows it
    (one with a `workers` attribute, such as mpc; the module docstring says why only
    those): None takes the policy's own (mpc's default: one per core, at most one per
    `EPISODES_PER_WORKER` episodes), 1 runs them all here, as any other policy's are.

    Returns one `EpisodeResult` per target [m], in order. Raises ValueError for bad env
    arguments, as the env does."""
    kwargs = {**(env_kwargs or {}), **getattr(policy, "env_kwargs", {})}
    kwargs.pop("target_x", None)
    # a training start distribution (flight_start, near_start) is not the task: every
    # evaluation starts where the contest does, upright at rest
    for name in TRAINING_STARTS:
        kwargs.pop(name, None)
    targets = np.asarray(targets, dtype=float)
    results: list[EpisodeResult] = []
    # seeds stay integers (terrain_seed, a task's seed options): up to 2^63, a float64
    # would round them to other bumps and other noise
    terrain = {k: np.broadcast_to(_column(k, v), targets.shape) for k, v in (terrain or {}).items()}
    n_workers = episode_workers(policy, workers, len(targets))
    if n_workers > 1:
        return _run_spread(
            policy, targets, kwargs, batch, progress, first_episode, terrain, n_workers
        )
    for start in range(0, len(targets), batch):
        chunk = targets[start : start + batch]
        ground = {k: v[start : start + batch] for k, v in terrain.items()}
        results.extend(
            _run_batch(policy, chunk, first_episode + start, kwargs, progress, len(results), ground)
        )
    return results


def _column(key: str, value) -> np.ndarray:
    """A per-episode reset option as an array: integers as int64, the rest float."""
    v = np.asarray(value)
    return (
        v.astype(np.int64)
        if key == "terrain_seed" or (v.dtype.kind in "iu" and v.dtype != np.bool_)
        else v.astype(float)
    )


def policy_env_id(policy) -> str:
    """The registered id whose env a policy acts in (its `env_id`; HopRover-v0)."""
    return getattr(policy, "env_id", "HopRover-v0")


def _run_batch(policy, targets, offset, kwargs, progress, done_before, ground):
    n = len(targets)
    # a policy of the hop-level task acts once per hop, in that task's vector env
    venv = vector_env_class(policy_env_id(policy))(
        n, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs
    )
    # episode e's sub-env is seeded with e, whatever the batch it runs in: the draws a
    # task makes at reset that the options leave open belong to the episode
    obs, _ = venv.reset(seed=offset, options={"target_x": targets, **ground})
    if isinstance(policy, RandomPolicy):
        policy.reset(n, offset)
    else:
        policy.reset(n)
    active = np.ones(n, dtype=bool)
    steps = np.zeros(n, dtype=np.int64)
    out: list = [None] * n
    t_start = time.perf_counter()
    while active.any():
        actions = policy.act(obs, venv)
        actions[~active] = 0.0
        obs, _, term, trunc, info = venv.step(actions)
        steps += active
        ended = active & (term | trunc)
        if ended.any():
            fin = info["final_info"]
            now = time.perf_counter() - t_start
            for i in np.flatnonzero(ended):
                success = bool(fin["is_success"][i])
                out[i] = EpisodeResult(
                    policy=getattr(policy, "name", "policy"),
                    episode=offset + int(i),
                    target_x=float(targets[i]),
                    success=success,
                    ttrtp=float(fin["ttrtp"][i]) if success else None,
                    broken=bool(fin["broken"][i]),
                    steps=int(steps[i]),
                    sim_time=float(fin["t"][i])
                    if "t" in fin
                    else float(steps[i] * venv.config.control_dt),
                    final_x=float(venv_final_x(info, i)),
                    wall_time=now,
                )
            active &= ~ended
            if progress is not None:
                progress(done_before + int((~active).sum()))
    wall = time.perf_counter() - t_start
    for r in out:
        r.wall_time = wall / n  # a batch shares its wall time: report the mean
    return out


CHUNKS_PER_WORKER = 8  # chunks handed out as workers free up: the last ones end together
# a worker costs seconds to start (an interpreter importing hoprover, loading its compiled
# kernels): left to choose, run_episodes gives each at least this many episodes
EPISODES_PER_WORKER = 8


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def episode_workers(policy, workers: int | None, n: int) -> int:
    """How many processes `run_episodes` spreads n episodes of `policy` over: 1 for a
    policy without a `workers` attribute (its episodes may depend on their batch: a
    network's output can differ in the last bit with the batch's size), else `workers`
    or the policy's own, at most one per episode; None for both: one per core, as far as
    each gets `EPISODES_PER_WORKER` episodes (a few episodes run sooner here)."""
    if not hasattr(policy, "workers"):
        return 1
    want = workers if workers is not None else policy.workers
    if want is None:
        want = max(1, min(cores(), n // EPISODES_PER_WORKER))
    if not (isinstance(want, (int, np.integer)) and want >= 1):
        raise ValueError(f"workers must be None or an integer >= 1, got {want!r}")
    return int(max(1, min(want, n)))


def _run_spread(
    policy, targets, kwargs, batch, progress, first_episode, terrain, n_workers
) -> list[EpisodeResult]:
    """run_episodes over chunks of the targets in `n_workers` worker processes
    (evaluation.workers), each running its chunk with a copy of `policy` as the serial path
    would (episode e seeded first_episode + e); the results in order (each with the run's
    wall time per episode), the policy's statistics (if it keeps any: `statistics`/`add_statistics`)
    summed over the copies."""
    from hoprover_env.evaluation import workers as pool

    n = len(targets)
    size = -(-n // (n_workers * CHUNKS_PER_WORKER))
    starts = list(range(0, n, size))
    # each worker gets its share of the cores for numba's threads (a worker on every
    # core with a thread per core would only make them wait for each other)
    threads = max(1, cores() // n_workers)
    calls = [
        (
            _run_chunk,
            (
                policy,
                targets[s : s + size],
                kwargs,
                batch,
                first_episode + s,
                {k: v[s : s + size] for k, v in terrain.items()},
            ),
        )
        for s in starts
    ]
    chunks: list = [None] * len(starts)
    done = 0
    t_start = time.perf_counter()
    for k, (chunk, stats) in pool.run(calls, n_workers, setup=(_start_worker, (threads,))):
        chunks[k] = chunk
        if stats is not None:
            policy.add_statistics(stats)
        done += len(chunk)
        if progress is not None:
            progress(done)
    results = [r for chunk in chunks for r in chunk]
    # the chunks ran side by side: an episode's share of the wall time is the whole
    # run's over all of them (as a batch's is in the serial path), not its chunk's
    wall = time.perf_counter() - t_start
    for r in results:
        r.wall_time = wall / n
    return results


def _start_worker(threads: int) -> None:
    import numba

    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def _run_chunk(policy, targets, kwargs, batch, first_episode, terrain):
    """One chunk in a worker: its results and what the policy's copy counted meanwhile."""
    keeps = hasattr(policy, "statistics")
    before = policy.statistics() if keeps else None
    results = run_episodes(
        policy,
        targets,
        env_kwargs=kwargs,
        batch=batch,
        first_episode=first_episode,
        terrain=terrain,
        workers=1,
    )
    if not keeps:
        return results, None
    after = policy.statistics()
    return results, {k: after[k] - before[k] for k in after}


def venv_final_x(info, i) -> float:
    """c.m. x of an ended episode, from its final observation (obs[0] = x - x_T)."""
    fo = info["final_obs"][i]
    return float(fo[0]) + float(info["final_info"]["target_x"][i])


def summarize(results: list[EpisodeResult]) -> dict:
    """The README's columns over `results`: episodes, success_rate (0..1), median_ttrtp
    and p90_ttrtp [s] over the successful episodes (NaN if none), broken (count) and
    wall_per_episode [s]."""
    n = len(results)
    tt = np.array([r.ttrtp for r in results if r.success])
    return {
        "episodes": n,
        "success_rate": float(np.mean([r.success for r in results])) if n else math.nan,
        "median_ttrtp": float(np.median(tt)) if tt.size else math.nan,
        "p90_ttrtp": float(np.percentile(tt, 90)) if tt.size else math.nan,
        "broken": int(sum(r.broken for r in results)),
        "wall_per_episode": float(np.mean([r.wall_time for r in results])) if n else math.nan,
    }
