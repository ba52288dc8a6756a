"""Baselines from scratch over several seeds, scored on the frozen suites as researchers
report them: several seeds, intervals over them, learning curves and wall times.

    python -m research.baselines --config configs/ppo_scratch.yaml --seeds 0-4 \\
        --timesteps 4000000 --out runs/baselines/ppo_torque          # train, then score
    python -m research.baselines --config configs/ppo_scratch.yaml --seeds 0-4 \\
        --out runs/baselines/ppo_torque --score-only                  # score what is there

Each seed trains with `train.py` in a process of its own, into `OUT/s<seed>` (a run
directory that has no `done` marker resumes from its last checkpoint, so a killed
baseline loses at most a checkpoint interval). Runs that are done are not trained again.

Then every finished run's model (its `best_model`, chosen on train.py's validation
episodes, which the suites never share) plays the suite of its task
(`hoprover_env.evaluation.suites`), and the runs' score matrix (seeds x episodes) is summarised by
`hoprover_env.evaluation.scores.summarize`: success, median regret, and the mean and IQM normalised
score with 95 % stratified bootstrap intervals over seeds (rliable). Per run: success,
median and worst regret, and the wall time and environment steps to 95 % validation
success. Written atomically into OUT: `summary.json`, `summary.md` (the tables) and
`curves.png` (validation success against environment steps and against wall time: the
mean over seeds with its 95 % bootstrap band, and each seed); with --record also into
benchmarks/results/baselines/, where the leaderboard page reads them.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from hoprover_env.util.buildinfo import git_commit
from hoprover_env.util.files import atomic_write

ROOT = Path(__file__).resolve().parent.parent
SUCCESS_GOAL = 0.95


def parse_seeds(text: str) -> list[int]:
    """'0-4' -> [0, 1, 2, 3, 4]; '0,2,5' -> [0, 2, 5]. ValueError names a bad spec."""
    seeds = []
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            seeds.extend(range(int(lo), int(hi) + 1) if hi else [int(lo)])
        except ValueError:
            raise ValueError(f"--seeds must look like 0-4 or 0,2,5; got {text!r}") from None
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise ValueError(f"--seeds must name distinct seeds >= 0; got {text!r}")
    return seeds


def train(
    config: str,
    seeds: list[int],
    out: Path,
    timesteps: int | None,
    torch_threads: int | None = None,
) -> None:
    """Train (or resume) each seed's run, one after the other, each alone on the machine
    (`torch_threads`: passed on to train.py, e.g. 1 when two drivers share the cores)."""
    for seed in seeds:
        run = out / f"s{seed}"
        if (run / "done").exists():
            print(f"seed {seed}: done already ({run})", flush=True)
            continue
        # a config may name its own trainer module (configs/ppo_mission_hop.yaml)
        trainer = (yaml.safe_load(Path(config).read_text()) or {}).get("trainer")
        cmd = [
            sys.executable,
            *(["-m", trainer] if trainer else [str(ROOT / "train.py")]),
            "--config",
            config,
            "--seed",
            str(seed),
            "--out",
            str(run),
            "--no-progress",
        ]
        if timesteps is not None:
            cmd += ["--timesteps", str(timesteps)]
        if torch_threads is not None:
            if trainer:
                raise SystemExit(
                    f"--torch-threads is train.py's flag; this config's trainer "
                    f"({trainer}) does not take it"
                )
            cmd += ["--torch-threads", str(torch_threads)]
        if (run / "checkpoints").exists():
            cmd.append("--resume")
        print(f"seed {seed}: {' '.join(cmd[1:])}", flush=True)
        with open(out / f"s{seed}.log", "a") as log:
            rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)
        if rc != 0:
            raise SystemExit(f"seed {seed} failed (exit {rc}); see {out / f's{seed}.log'}")
        (run / "done").touch()


# the leaderboard's groups of baselines (research/yardstick/leaderboard.py)
RL, DEMOS = "RL from reward", "RL from reward and demonstrations"


def group_of(cfg: dict) -> str:
    """A baseline's group: demonstrations in the replay buffer make it RL from reward and
    demonstrations; otherwise RL from reward."""
    return DEMOS if cfg.get("demonstrations") else RL


def provenance() -> tuple[str, str]:
    """The checkout's commit (buildinfo.git_commit: '+dirty' with uncommitted changes,
    'unknown' outside git), abbreviated as the docs quote commits, and today's date (UTC)
    for a recorded result."""
    import datetime

    rev, plus, mark = (git_commit(ROOT) or "unknown").partition("+")
    today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    return rev[:7] + plus + mark, today


def curve(run: Path) -> dict:
    """A run's validation curve (train.py's evaluations.csv) and when it first reached
    SUCCESS_GOAL (None if never)."""
    with open(run / "evaluations.csv") as f:
        rows = list(csv.DictReader(f))
    steps = np.array([int(r["timesteps"]) for r in rows])
    wall = np.array([float(r["wall_s"]) for r in rows])
    success = np.array([float(r["success_rate"]) for r in rows])
    hit = np.flatnonzero(success >= SUCCESS_GOAL)
    return {
        "timesteps": steps.tolist(),
        "wall_s": wall.tolist(),
        "val_success": success.tolist(),
        "steps_to_goal": int(steps[hit[0]]) if hit.size else None,
        "wall_s_to_goal": float(wall[hit[0]]) if hit.size else None,
    }


def score(out: Path, seeds: list[int], name: str) -> dict:
    """Every finished run on its task's suite; the summary over seeds."""
    from hoprover_env.agents.policies import load_sb3
    from hoprover_env.evaluation import suites
    from hoprover_env.evaluation.scores import episode_regrets, summarize

    runs, matrix = [], []
    suite = None
    for seed in seeds:
        run = out / f"s{seed}"
        if not (run / "done").exists():
            print(f"seed {seed}: not finished, left out of the scores", flush=True)
            continue
        policy = load_sb3(run, name=f"{name} s{seed}")
        env_id = getattr(policy, "env_id", "HopRover-v0")
        suite = suite or suites.load(env_id)
        rows = suites.run(policy, suite)
        s = np.array([r["score"] for r in rows])
        reg = episode_regrets(
            [r["ttrtp"] if r["success"] else None for r in rows], suite.reference_ttrtp
        )
        matrix.append(s)
        runs.append(
            {
                "seed": seed,
                "success": float(np.mean(s > 0)),
                "median_regret": float(np.median(reg)),
                "worst_regret": float(np.max(reg)),
                **curve(run),
            }
        )
        print(
            f"seed {seed}: success {runs[-1]['success']:.1%}, median regret "
            f"{runs[-1]['median_regret']:.3f}",
            flush=True,
        )
    if not runs:
        raise SystemExit(f"no finished run in {out}")
    summary = summarize(name, np.array(matrix))
    return {
        "name": name,
        "suite": f"{suite.name}-v{suite.version}",
        "env_id": env_id,
        "summary": summary.row(),
        "runs": runs,
        "_summary": summary,
    }


def seed_table(runs: list[dict]) -> str:
    """The per-seed table of a result's `runs` (as summary.json records them)."""
    lines = [
        "| seed | success | median regret | worst regret | steps to 95 % | wall time to 95 % |",
        "|---|---|---|---|---|---|",
    ]
    for r in runs:
        steps = "never" if r["steps_to_goal"] is None else f"{r['steps_to_goal']:,}"
        wall = "never" if r["wall_s_to_goal"] is None else f"{r['wall_s_to_goal']:.0f} s"
        lines.append(
            f"| {r['seed']} | {100 * r['success']:.1f} % | {r['median_regret']:.3f}"
            f" | {r['worst_regret']:.3f} | {steps} | {wall} |"
        )
    return "\n".join(lines)


def markdown(result: dict) -> str:
    from hoprover_env.evaluation.scores import format_table

    return (
        f"### {result['name']} on the {result['suite']} suite ({result['env_id']})\n\n"
        f"{format_table([result['_summary']])}\n\n{seed_table(result['runs'])}\n"
    )


def plot(result: dict, path: Path) -> None:
    """Validation success against steps (mean over seeds, 95 % bootstrap band) and
    against wall time (each seed: the runs' clocks differ)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = result["runs"]
    n = min(len(r["timesteps"]) for r in runs)
    steps = np.array(runs[0]["timesteps"][:n])
    succ = np.array([r["val_success"][:n] for r in runs])
    rng = np.random.default_rng(0)
    boot = succ[rng.integers(len(runs), size=(2000, len(runs)))].mean(axis=1)
    lo, hi = np.percentile(boot, [2.5, 97.5], axis=0)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    a.fill_between(steps, lo, hi, alpha=0.3, label="95 % bootstrap band")
    a.plot(steps, succ.mean(axis=0), label=f"mean of {len(runs)} seeds")
    a.set_xlabel("environment steps")
    a.ticklabel_format(style="sci", axis="x", scilimits=(0, 0))
    for r in runs:
        b.plot(np.array(r["wall_s"]) / 60, r["val_success"], label=f"seed {r['seed']}")
    b.set_xlabel("wall time [min]")
    for ax in (a, b):
        ax.set_ylabel("validation success")
        ax.set_ylim(-0.02, 1.02)
        ax.axhline(SUCCESS_GOAL, color="grey", lw=0.8, ls="--")
        ax.legend(fontsize=7)
    fig.suptitle(f"{result['name']} ({result['env_id']})")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", required=True, help="YAML config (configs/*.yaml)")
    ap.add_argument("--seeds", default="0-4", help="e.g. 0-4 or 0,2,5 (default 0-4)")
    ap.add_argument(
        "--timesteps",
        type=int,
        default=None,
        help="environment steps per run (default: the config's)",
    )
    ap.add_argument("--out", required=True, help="directory of the runs (OUT/s<seed>)")
    ap.add_argument("--name", default=None, help="the baseline's name (default: OUT's name)")
    ap.add_argument(
        "--torch-threads",
        type=int,
        default=None,
        help="torch's CPU threads per run (train.py's flag; give 1 when several "
        "drivers share the cores: off-policy updates oversubscribed by two "
        "runs of two threads each ran several times slower)",
    )
    ap.add_argument("--score-only", action="store_true", help="no training: score the runs")
    ap.add_argument(
        "--record",
        action="store_true",
        help="also write the summary and curves into benchmarks/results/"
        "baselines/ (OUT's name), where the leaderboard reads them",
    )
    args = ap.parse_args(argv)
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError as err:
        ap.error(str(err))
    if not Path(args.config).is_file():
        ap.error(f"config file not found: {args.config}")
    yaml.safe_load(Path(args.config).read_text())
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.score_only:
        train(args.config, seeds, out, args.timesteps, args.torch_threads)
    result = score(out, seeds, args.name or out.resolve().name)
    budget = f" --timesteps {args.timesteps}" if args.timesteps else ""
    result["group"] = group_of(yaml.safe_load(Path(args.config).read_text()) or {})
    result["commit"], result["date"] = provenance()
    result["command"] = (
        f"python -m research.baselines --config {args.config} --seeds "
        f"{args.seeds}{budget} --out runs/baselines/{out.resolve().name}"
    )
    md = markdown(result)
    print("\n" + md)
    atomic_write(out / "summary.md", md)
    atomic_write(
        out / "summary.json",
        json.dumps({k: v for k, v in result.items() if not k.startswith("_")}, indent=1),
    )
    plot(result, out / "curves.png")
    if args.record:
        rec = ROOT / "benchmarks" / "results" / "baselines"
        rec.mkdir(parents=True, exist_ok=True)
        atomic_write(rec / f"{out.resolve().name}.json", (out / "summary.json").read_text())
        atomic_write(rec / f"{out.resolve().name}.md", md)
        plot(result, rec / f"{out.resolve().name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
