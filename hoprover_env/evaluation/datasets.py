"""Offline-RL datasets of hoprover's tasks, in Minari.

    python -m hoprover_env.evaluation.datasets --task HopRover-v0 --level expert \\
        --steps 1000000 --out DIR
    hoprover-datasets --task HopRover-v0 --level random --steps 100000 --out DIR

Each dataset is written with Minari's own API (`minari.create_dataset_from_buffers`),
under DIR as `MINARI_DATASETS_PATH=DIR` finds it, with the id
``hoprover/<task>/<level>-v0``. Its episodes are collected from the task's native
vector env; every episode is reset with its own seed (recorded per episode, as Minari
keeps it), so resetting the env with that seed and stepping the recorded actions
reproduces the recorded observations, rewards and terminations bit for bit.

Levels: ``random`` (uniform actions), ``medium`` (a PPO policy that reaches about half of
its validation targets), ``expert`` (the task's bundled learned policy) and ``mixed``
(each episode's agent drawn among the three). All levels of a task share one MDP: the
env arguments the expert was trained with. ``ref_min_score`` and ``ref_max_score`` are
the mean returns of the random and the expert agent on the task's frozen suite
(hoprover_env.evaluation.suites), so that `minari.get_normalized_score` maps them to 0 and 1.

Minari comes in the ``offline`` extra: ``pip install 'hoprover[offline]'``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

LEVELS = ("random", "medium", "expert", "mixed")
# the bundled policy each dataset's expert level plays (agents/policies of the package:
# which of them is the best learned one for an id is a fact about the bundled files, not
# about the task), and the mid-training checkpoints of the medium level; the datasets'
# tasks are these ids
EXPERT = {"HopRover-v0": "scratch", "HopRoverHop-v0": "hop", "HopRoverTerrain-v0": "terrain"}
MEDIUM = {"HopRover-v0": "scratch_medium"}
TASKS = tuple(EXPERT)
CODE = "https://github.com/hoprover/hoprover/blob/main/hoprover_env/datasets.py"


def _minari():
    try:
        import minari
    except ImportError as err:
        raise ImportError("datasets need Minari: pip install 'hoprover[offline]'") from err
    return minari


def dataset_id(task: str, level: str) -> str:
    return f"hoprover/{task}/{level}-v0"


def agents(task: str, level: str, seed: int) -> list:
    """The policies a level's episodes are drawn from (one, or three for mixed)."""
    from hoprover_env.agents.policies import BUNDLED, RandomPolicy, load_policy

    if task not in TASKS:
        raise ValueError(f"unknown task {task!r}; datasets exist for {list(TASKS)}")
    if level not in LEVELS:
        raise ValueError(f"unknown level {level!r}; valid: {list(LEVELS)}")
    if level == "random":
        return [RandomPolicy(seed)]
    if level == "expert":
        return [load_policy(EXPERT[task])]
    if task not in MEDIUM or MEDIUM[task] not in BUNDLED:
        raise ValueError(
            f"no medium policy is bundled for {task}: levels 'medium' and "
            f"'mixed' exist for {[t for t in MEDIUM if MEDIUM[t] in BUNDLED]}"
        )
    medium = load_policy(MEDIUM[task])
    if level == "medium":
        return [medium]
    return [RandomPolicy(seed), medium, load_policy(EXPERT[task])]


def collect(
    task: str,
    policies: list,
    kwargs: dict,
    n_steps: int | None = None,
    episodes: list | None = None,
    num_envs: int = 64,
    seed: int = 0,
):
    """Episodes of `policies` in `task`'s vector env, as Minari EpisodeBuffers.

    Either `n_steps` (episodes seeded seed, seed + 1, ... until that many steps are
    recorded, then the episodes under way run to their end: at least `n_steps`, every
    episode whole; episode k's agent is policies[k % len(policies)]) or `episodes` (a list of
    (seed, options) to run, each once). Returns the buffers in episode order."""
    from gymnasium.vector import AutoresetMode
    from minari.data_collector.episode_buffer import EpisodeBuffer

    from hoprover_env.envs import registry as _registry

    if n_steps is None and episodes is None:
        raise ValueError("collect: give n_steps or episodes")
    venv = _registry.vector_env_class(task)(
        num_envs, autoreset_mode=AutoresetMode.NEXT_STEP, **kwargs
    )
    queue = list(episodes) if episodes is not None else None
    next_k = 0

    def next_episode():
        nonlocal next_k
        if queue is not None:
            if next_k >= len(queue):
                return None
            s, opt = queue[next_k]
        else:
            s, opt = seed + next_k, {}
        next_k += 1
        return next_k - 1, int(s), dict(opt)

    for p in policies:
        p.reset(num_envs)
    slots: list = [None] * num_envs  # (k, seed, options, obs, acts, rews, terms, truncs)
    buffers: dict = {}
    recorded = 0
    obs = np.zeros((num_envs, venv.single_observation_space.shape[0]), np.float32)

    def start(i):
        ep = next_episode()
        if ep is None:
            slots[i] = None
            return
        k, s, opt = ep
        mask = np.zeros(num_envs, bool)
        mask[i] = True
        seeds = [None] * num_envs
        seeds[i] = s
        o, _ = venv.reset(
            seed=seeds,
            options={"reset_mask": mask, **{key: np.full(num_envs, v) for key, v in opt.items()}},
        )
        obs[i] = o[i]
        slots[i] = (k, s, opt, [o[i].copy()], [], [], [], [])
        for p in policies:  # a recurrent policy forgets the slot's last episode
            if hasattr(p, "restart"):
                p.restart([i])

    for i in range(num_envs):
        start(i)
    while any(sl is not None for sl in slots):
        live = np.array([sl is not None for sl in slots])
        act = np.zeros((num_envs, 1))
        for j, p in enumerate(policies):
            mine = np.array([sl is not None and sl[0] % len(policies) == j for sl in slots])
            if mine.any():
                act[mine] = p.act(obs, venv)[mine]
        # the recorded actions are float32 (the action space's dtype): the env steps
        # with exactly those values, so that a replay of the record is the same run
        act = np.clip(act, -1.0, 1.0).astype(np.float32).astype(np.float64)
        o, r, te, tr, _ = venv.step(act)
        obs[:] = o
        for i in np.flatnonzero(live).tolist():
            k, s, opt, ob, ac, rw, tm, tc = slots[i]
            ob.append(o[i].copy())
            ac.append(act[i].astype(np.float32))
            rw.append(float(r[i]))
            tm.append(bool(te[i]))
            tc.append(bool(tr[i]))
            recorded += 1
            if te[i] or tr[i]:
                buffers[k] = EpisodeBuffer(
                    id=k,
                    seed=s,
                    options=opt or None,
                    observations=np.array(ob),
                    actions=np.array(ac),
                    rewards=rw,
                    terminations=tm,
                    truncations=tc,
                )
                if queue is None and n_steps is not None and recorded >= n_steps:
                    slots[i] = None  # enough: let the others finish theirs
                    queue = []
                else:
                    start(i)
    return [buffers[k] for k in sorted(buffers)]


def suite_return(task: str, policy, kwargs: dict, suite) -> float:
    """Mean undiscounted return of `policy` on `task`'s frozen suite (episode e seeded e,
    started as frozen: its target, ground and `task`'s start conditions)."""
    from hoprover_env.evaluation.suites import check_frozen

    check_frozen(task, kwargs)
    conditions = suite.conditions(task)
    eps = [
        (e, {"target_x": float(suite.targets[e]), **{k: v[e] for k, v in conditions.items()}})
        for e in range(len(suite))
    ]
    bufs = collect(task, [policy], kwargs, episodes=eps, num_envs=min(64, len(eps)))
    return float(np.mean([sum(b.rewards) for b in bufs]))


def build(
    task: str, level: str, steps: int, out: str | os.PathLike, seed: int = 0, num_envs: int = 64
):
    """Write dataset `hoprover/<task>/<level>-v0` under `out`. Raises ValueError for an
    unknown task or level, FileExistsError if `out` holds that dataset already."""
    minari = _minari()
    pols = agents(task, level, seed)
    out = Path(out).resolve()
    ds_id = dataset_id(task, level)
    if (out / "hoprover" / task / f"{level}-v0").exists():
        raise FileExistsError(f"{out} holds {ds_id} already; nothing was overwritten")
    if steps < 1:
        raise ValueError(f"--steps must be a positive integer, got {steps}")
    os.environ["MINARI_DATASETS_PATH"] = str(out)
    from hoprover_env.agents.policies import RandomPolicy, load_policy
    from hoprover_env.evaluation import suites

    # every level is collected in the expert's MDP: its env arguments
    expert = pols[-1] if level in ("expert", "mixed") else load_policy(EXPERT[task])
    kwargs = dict(expert.env_kwargs)
    t0 = time.perf_counter()
    bufs = collect(task, pols, kwargs, n_steps=steps, num_envs=num_envs, seed=seed)
    collect_s = time.perf_counter() - t0
    suite = suites.load(task)
    lo = suite_return(task, RandomPolicy(seed), kwargs, suite)
    hi = suite_return(task, expert, kwargs, suite)
    import gymnasium as gym

    import hoprover_env  # noqa: F401  (registers the ids)

    env = gym.make(task, **kwargs)
    names = {
        "random": "uniform random actions",
        "medium": f"PPO checkpoint {MEDIUM.get(task)}",
        "expert": f"bundled policy {EXPERT[task]}",
        "mixed": "random, medium and expert, episode by episode",
    }
    ds = minari.create_dataset_from_buffers(
        dataset_id=ds_id,
        buffer=bufs,
        env=env,
        eval_env=env,
        algorithm_name=names[level],
        author="hoprover",
        author_email="hoprover@users.noreply.github.com",
        code_permalink=CODE,
        ref_min_score=lo,
        ref_max_score=hi,
        description=f"{task}, {level}: {names[level]}; env arguments {json.dumps(kwargs)}; "
        f"episodes seeded from {seed}; references: mean returns on the "
        f"{suite.name} suite",
        requirements=["hoprover", "gymnasium", "numba"],
    )
    size = sum(
        f.stat().st_size
        for f in (out / "hoprover" / task / f"{level}-v0").rglob("*")
        if f.is_file()
    )
    return ds, {
        "dataset_id": ds_id,
        "episodes": len(bufs),
        "steps": int(sum(len(b.rewards) for b in bufs)),
        "collect_s": round(collect_s, 2),
        "total_s": round(time.perf_counter() - t0, 2),
        "bytes": size,
        "ref_min_score": lo,
        "ref_max_score": hi,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="hoprover-datasets", description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", required=True, help=f"one of {', '.join(TASKS)}")
    ap.add_argument("--level", required=True, help=f"one of {', '.join(LEVELS)}")
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--out", required=True, help="the datasets' root (MINARI_DATASETS_PATH)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    ap.add_argument("--num-envs", type=int, default=64)
    args = ap.parse_args(argv)
    try:
        _, report = build(args.task, args.level, args.steps, args.out, args.seed, args.num_envs)
    except (ValueError, FileExistsError, ImportError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
