"""Learning curves: the contest judge's success rate and median TTRTP against environment
steps and against wall seconds, for PPO from scratch on the full torque task
(configs/ppo_scratch.yaml), PPO from scratch on the hop-level task
(configs/ppo_hop.yaml) and behaviour cloning + PPO (configs/ppo.yaml), 3 seeds each.

Each (task, seed) is one `train.py` run in `runs/learning/<task>_s<seed>`; a run that
already finished there is read, not repeated (delete the directory to redo it). The
curves are train.py's own evaluations (`evaluations.csv`: 100 validation targets, seed
7, deterministic policy); the wall axis includes behaviour cloning for the cloned task.

    python -m benchmarks.bench_learning [--quick] [--runs runs/learning] [--seeds 0,1,2]
                                        [--tasks scratch,hop,clone] [--finished-only]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from benchmarks.report import Section, table

ROOT = Path(__file__).resolve().parent.parent
TASKS = {  # label, config, what it is
    "scratch": ("configs/ppo_scratch.yaml", "HopRover-v0, PPO from scratch"),
    "hop": ("configs/ppo_hop.yaml", "HopRoverHop-v0, PPO from scratch"),
    "clone": ("configs/ppo.yaml", "HopRover-v0, cloning of the scripted hopper + PPO"),
}
QUICK = {
    "timesteps": 4096,
    "n_envs": 8,
    "evaluation": {"freq": 2048, "episodes": 4, "seed": 7},
    "checkpoint": {"freq": 2048},
}
QUICK_PRETRAIN = {"episodes": 4, "epochs": 1, "dagger_rounds": 1, "dagger_episodes": 2}


def _config_for(task: str, quick: bool, tmp: Path) -> Path:
    path = ROOT / TASKS[task][0]
    if not quick:
        return path
    cfg = yaml.safe_load(path.read_text())
    cfg.update(QUICK)
    cfg["hyperparams"] = {**cfg.get("hyperparams", {}), "n_steps": 256, "batch_size": 512}
    if cfg.get("pretrain"):
        cfg["pretrain"] = {**cfg["pretrain"], **QUICK_PRETRAIN}
    out = tmp / f"{task}.yaml"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


def train(task: str, seed: int, runs: Path, quick: bool, tmp: Path) -> Path:
    """Run train.py for (task, seed) unless a finished run is already there."""
    out = runs / f"{task}_s{seed}"
    if (out / "final_model.json").exists():
        return out
    cmd = [
        sys.executable,
        str(ROOT / "train.py"),
        "--config",
        str(_config_for(task, quick, tmp)),
        "--seed",
        str(seed),
        "--out",
        str(out),
        "--no-progress",
    ]
    if (out / "checkpoints" / "last.json").exists():
        cmd.append("--resume")
    if quick:
        # quick runs feed batches of 8 observations through small networks: with torch's
        # default of a thread per core, every small matmul waits for a team of threads,
        # and on cores that other work keeps busy (the test suite runs this beside its
        # other workers) a 4096-step run took 42 s instead of 5 s. Full runs keep the
        # default, as train.py's users run it
        cmd += ["--torch-threads", "1"]
    print(f"[bench_learning] {' '.join(cmd)}", file=sys.stderr, flush=True)
    subprocess.run(cmd, check=True, cwd=ROOT)
    return out


def read_run(out: Path) -> dict:
    """A run's evaluation curve and its cost."""
    meta = json.loads((out / "final_model.json").read_text())
    offset = float(meta.get("pretrain_s") or 0.0)  # cloning happens before RL
    rows = list(csv.DictReader(open(out / "evaluations.csv")))

    def num(v):
        return float(v) if v not in ("", "nan", "None", None) else math.nan

    curve = np.array(
        [
            [
                num(r["timesteps"]),
                num(r["wall_s"]) + offset,
                num(r["success_rate"]),
                num(r["median_ttrtp"]),
            ]
            for r in rows
        ]
    )
    wall = float(meta["wall_s"])
    return {
        "curve": curve,
        "steps": int(meta["timesteps"]),
        "rl_wall": wall,
        "wall": wall + offset,
        "env_share": float(meta.get("env_s", math.nan)) / wall,
        "steps_per_s": int(meta["timesteps"]) / wall,
    }


def first_reaching(curve: np.ndarray, level: float) -> tuple[float, float]:
    """(steps, wall s) of the first evaluation with success >= level, or NaNs."""
    hit = np.flatnonzero(curve[:, 2] >= level)
    return (curve[hit[0], 0], curve[hit[0], 1]) if hit.size else (math.nan, math.nan)


def _band(runs: list[dict], col: int, ycol: int, grid: np.ndarray):
    """Mean, min and max over seeds of a curve, step-interpolated onto `grid` (the last
    evaluation at or before each grid point)."""
    ys = []
    for r in runs:
        c = r["curve"]
        idx = np.searchsorted(c[:, col], grid, side="right") - 1
        y = np.where(idx >= 0, c[np.clip(idx, 0, None), ycol], np.nan)
        y[grid > c[-1, col]] = np.nan
        ys.append(y)
    ys = np.array(ys)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmean(ys, 0), np.nanmin(ys, 0), np.nanmax(ys, 0)


def scripted_median(episodes: int = 100) -> float:
    """The scripted hopper's median TTRTP on train.py's validation targets (seed 7)."""
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

    return summarize(run_episodes(load_policy("scripted"), seeded_targets(episodes, 7)))[
        "median_ttrtp"
    ]


def figure(results: dict, path: str, reference: float | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    for (task, runs), color in zip(results.items(), ("C0", "C1", "C2")):
        for col, ax_col, xlabel in ((0, 0, "environment steps"), (1, 1, "wall seconds")):
            xmax = max(r["curve"][-1, col] for r in runs)
            grid = np.linspace(0, xmax, 200)
            for ycol, ax_row, ylabel in ((2, 0, "success rate"), (3, 1, "median TTRTP [s]")):
                mean, lo, hi = _band(runs, col, ycol, grid)
                ax = axes[ax_row, ax_col]
                ax.plot(grid, mean, color=color, label=f"{task} ({len(runs)} seeds)")
                ax.fill_between(grid, lo, hi, color=color, alpha=0.2)
                ax.set_xlabel(xlabel)
                ax.set_ylabel(ylabel)
    for ax in axes[1]:
        if reference is not None:
            ax.axhline(reference, color="k", ls="--", lw=1, label="scripted hopper")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    axes[1, 0].legend(fontsize=8)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(
        "PPO learning curves on hoprover: mean over seeds, band = min..max (100 validation targets)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def finished(task: str, seed: int, runs: Path) -> bool:
    return (runs / f"{task}_s{seed}" / "final_model.json").exists()


def run(
    quick: bool = False,
    fig_dir: str = "benchmarks/figures",
    runs_dir: str | None = None,
    seeds=(0, 1, 2),
    tasks=tuple(TASKS),
    finished_only: bool = False,
) -> Section:
    """finished_only: read the finished runs and train none (a task keeps the seeds it has)."""
    tmp = Path(tempfile.mkdtemp())
    runs = Path(runs_dir) if runs_dir else (tmp / "runs" if quick else ROOT / "runs" / "learning")
    if quick:
        seeds = seeds[:1]
    used = {
        task: [s for s in seeds if not finished_only or finished(task, s, runs)] for task in tasks
    }
    results = {
        task: [read_run(train(task, s, runs, quick, tmp)) for s in used[task]]
        for task in tasks
        if used[task]
    }
    rows = []
    for task, rs in results.items():
        final_s = [r["curve"][-1, 2] for r in rs]
        best_s = [float(np.nanmax(r["curve"][:, 2])) for r in rs]
        final_m = [r["curve"][-1, 3] for r in rs]
        reach = [first_reaching(r["curve"], 0.95) for r in rs]
        rows.append(
            [
                task,
                TASKS[task][1],
                ", ".join(map(str, used[task])),
                " / ".join(f"{v:.0%}" for v in final_s),
                " / ".join(f"{v:.0%}" for v in best_s),
                " / ".join(f"{v:.0f}" for v in final_m),
                " / ".join("-" if math.isnan(w) else f"{w:.0f}" for _, w in reach),
                " / ".join(f"{r['wall']:.0f}" for r in rs),
                float(np.mean([r["steps_per_s"] for r in rs])),
                float(np.mean([r["env_share"] for r in rs])),
            ]
        )
    os.makedirs(fig_dir, exist_ok=True)
    fig = os.path.join(fig_dir, "learning_curves.png")
    ref = scripted_median(4 if quick else 100)
    figure(results, fig, ref)
    md = [
        f"Runs in `{runs}` (one `train.py` run per task and seed"
        f"{', `--torch-threads 1`' if quick else ''}; seeds "
        f"{', '.join(map(str, seeds))}). Per seed, separated by /: the success rate and "
        "median TTRTP of the last evaluation, the best success rate, the wall seconds "
        "until the first evaluation at >= 95 % ('-': never), and the run's wall seconds "
        "(cloning included). steps/s and the environment's share are over the RL phase. "
        f"The scripted hopper's median TTRTP on the same targets: {ref:.1f} s.",
        table(
            [
                "task",
                "what",
                "seeds",
                "final success",
                "best success",
                "final median TTRTP s",
                "wall s to 95 %",
                "wall s",
                "RL steps/s",
                "env share",
            ],
            rows,
            {"RL steps/s": ",.0f", "env share": ".0%"},
        ),
    ]
    return Section(
        "Learning curves",
        "\n\n".join(md),
        [fig],
        {
            f"{t}_final_success": float(np.mean([r["curve"][-1, 2] for r in rs]))
            for t, rs in results.items()
        },
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny budgets (the test suite)")
    ap.add_argument("--runs", default=None, help="run directory root (default runs/learning)")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--fig-dir", default=str(ROOT / "benchmarks" / "figures"))
    ap.add_argument(
        "--finished-only",
        action="store_true",
        help="tabulate and plot the finished runs only; train nothing",
    )
    args = ap.parse_args(argv)
    sec = run(
        args.quick,
        args.fig_dir,
        args.runs,
        tuple(int(s) for s in args.seeds.split(",")),
        tuple(args.tasks.split(",")),
        args.finished_only,
    )
    print(sec.markdown)
    return 0


if __name__ == "__main__":
    sys.exit(main())
