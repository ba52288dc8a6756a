"""Offline-RL baselines on hoprover's Minari datasets, scored on the frozen suites.

    python -m research.offline_baselines --data datasets --level expert --algo bc --seeds 0-2
    python -m research.offline_baselines --data datasets --level medium --algo iql --steps 50000

Each (algorithm, seed) trains with d3rlpy on `hoprover/<task>/<level>-v0` (built into
--data by hoprover_env.evaluation.datasets if it is not there), acts deterministically through
`hoprover_env.agents.policies.ArrayPolicy` in the dataset's own env, and is judged on the task's
suite: success, median regret, mean and IQM score with rliable intervals over the seeds.
Rows are appended to --out (JSON, written atomically).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from hoprover_env.agents.policies import ArrayPolicy
from hoprover_env.evaluation import datasets, suites
from hoprover_env.evaluation.scores import Summary, format_table, summarize
from hoprover_env.util.files import atomic_write

OUT = Path(__file__).resolve().parent.parent / "benchmarks" / "results" / "offline.json"


def load(task: str, level: str, data: Path, steps: int):
    """The Minari dataset (built first if missing) and its d3rlpy MDPDataset."""
    import minari

    os.environ["MINARI_DATASETS_PATH"] = str(data.resolve())
    if not (data / "hoprover" / task / f"{level}-v0").exists():
        datasets.build(task, level, steps, data)
    ds = minari.load_dataset(datasets.dataset_id(task, level))
    import d3rlpy

    obs, act, rew, term, tout = [], [], [], [], []
    for ep in ds.iterate_episodes():
        n = len(ep.rewards)
        obs.append(ep.observations[:n])
        act.append(ep.actions)
        rew.append(ep.rewards)
        term.append(ep.terminations)
        # d3rlpy ends an episode at a terminal or a timeout: the last step is one or
        # the other
        tout.append(
            np.logical_and(ep.truncations, ~ep.terminations)
            | (np.arange(n) == n - 1) & ~ep.terminations
        )
    mdp = d3rlpy.dataset.MDPDataset(
        np.concatenate(obs).astype(np.float32),
        np.concatenate(act).astype(np.float32),
        np.concatenate(rew).astype(np.float32),
        np.concatenate(term).astype(np.float32),
        np.concatenate(tout).astype(np.float32),
    )
    return ds, mdp


def make_algo(name: str, seed: int, gamma: float):
    import d3rlpy

    d3rlpy.seed(seed)
    scaler = d3rlpy.preprocessing.StandardObservationScaler()
    if name == "bc":
        return d3rlpy.algos.BCConfig(
            observation_scaler=scaler, batch_size=256, learning_rate=3e-4
        ).create(device="cpu")
    if name == "iql":
        return d3rlpy.algos.IQLConfig(
            observation_scaler=scaler, batch_size=256, gamma=gamma
        ).create(device="cpu")
    if name == "cql":
        return d3rlpy.algos.CQLConfig(
            observation_scaler=scaler, batch_size=256, gamma=gamma
        ).create(device="cpu")
    raise ValueError(f"unknown algorithm {name!r}: bc, iql or cql")


def table(rows: list[dict]) -> str:
    """The results as a markdown table, by task, level and algorithm, with the gradient
    steps each was trained for."""
    levels = datasets.LEVELS
    rows = sorted(
        rows,
        key=lambda r: (
            r["task"],
            levels.index(r["level"]) if r["level"] in levels else len(levels),
            r["algo"],
        ),
    )
    lines = format_table(
        [
            Summary.from_row({**r, "agent": f"{r['algo'].upper()} on {r['level']} ({r['task']})"})
            for r in rows
        ]
    ).splitlines()
    lines[0] += " gradient steps |"
    lines[1] += "---|"
    return "\n".join(
        [*lines[:2], *(f"{line} {r['gradient_steps']} |" for line, r in zip(lines[2:], rows))]
    )


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default="HopRover-v0")
    ap.add_argument("--level", default="expert")
    ap.add_argument("--algo", default="bc")
    ap.add_argument("--data", type=Path, default=Path("datasets"))
    ap.add_argument("--dataset-steps", type=int, default=1_000_000)
    ap.add_argument("--steps", type=int, default=20_000, help="gradient steps per seed")
    ap.add_argument("--seeds", default="0-2")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument(
        "--table",
        action="store_true",
        help="print the results in --out as a markdown table and stop",
    )
    argv = sys.argv[1:] if argv is None else argv
    args = ap.parse_args(argv)
    if args.table:
        print(table(json.loads(args.out.read_text())["rows"]))
        return
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    ds, mdp = load(args.task, args.level, args.data, args.dataset_steps)
    env_kwargs = dict(ds.spec.env_spec.kwargs)
    suite = suites.load(args.task)
    scores, walls = [], []
    for seed in seeds:
        algo = make_algo(args.algo, seed, env_kwargs.get("gamma", 0.99))
        t0 = time.perf_counter()
        algo.fit(
            mdp,
            n_steps=args.steps,
            n_steps_per_epoch=args.steps,
            show_progress=False,
            save_interval=10**9,
            experiment_name=f"{args.algo}_{args.level}_s{seed}",
            logger_adapter=__import__("d3rlpy").logging.NoopAdapterFactory(),
        )
        walls.append(time.perf_counter() - t0)
        policy = ArrayPolicy(
            lambda o, a=algo: a.predict(np.asarray(o, np.float32)),
            name=f"{args.algo}-{args.level}",
            env_id=args.task,
            env_kwargs=env_kwargs,
        )
        rows = suites.run(policy, suite)
        scores.append([r["score"] for r in rows])
        print(
            f"{args.algo} {args.level} seed {seed}: success "
            f"{np.mean([r['success'] for r in rows]):.3f} ({walls[-1]:.0f} s)",
            flush=True,
        )
    s = summarize(f"{args.algo} on {args.level}", np.array(scores))
    row = {
        **s.row(),
        "task": args.task,
        "level": args.level,
        "algo": args.algo,
        "seeds": seeds,
        "gradient_steps": args.steps,
        "dataset_steps": int(mdp.transition_count),
        "train_wall_s": walls,
        "command": "python -m research.offline_baselines " + " ".join(argv),
    }
    done = json.loads(args.out.read_text())["rows"] if args.out.exists() else []
    done = [
        r for r in done if (r["task"], r["level"], r["algo"]) != (args.task, args.level, args.algo)
    ] + [row]
    atomic_write(
        args.out, json.dumps({"suite": f"{suite.name}-v{suite.version}", "rows": done}, indent=1)
    )
    print(json.dumps(row))


if __name__ == "__main__":
    main()
