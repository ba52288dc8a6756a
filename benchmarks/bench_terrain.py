"""Terrain: what a slope costs the simulator, and how each policy degrades on
sloped and rough ground.

* `ground_costs`: CPU time per simulated second at rest (F), in flight (A), in a launch
  (B/C by DOP853 to lift-off), in a pivot (B) and in a two-corner slide (G), on level
  ground and at slopes +-0.3 rad, best of N, the slopes interleaved with level ground.
* `measure`: success and median TTRTP of the bundled policies and the scripted hopper
  against the slope (roughness 0.05) and against the roughness (level ground), on the
  same seeded targets, with the contest judge.

    python -m benchmarks --only terrain            # as a section of BENCHMARKS.md
    python -m benchmarks.bench_terrain --episodes 40 --json out.json   # measure only

Every policy acts in its own task (scratch and bundled in HopRover-v0, hop in
HopRoverHop-v0, terrain in HopRoverTerrain-v0, the scripted hopper through the torque
task); the ground is set per episode by the reset options `slope` and `roughness`, which
every hoprover env takes, so all rows face the same ground and targets.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from benchmarks.report import Section, table
from hoprover_env import RoverParams, RoverSim, simulate
from hoprover_env.agents.policies import BUNDLED, BUNDLED_DIR, load_policy
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.util.files import write_json

SLOPES = (-0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3)  # rad, at roughness SLOPE_ROUGHNESS
SLOPE_ROUGHNESS = 0.05
ROUGHNESSES = (0.0, 0.05, 0.1, 0.2)  # rad, on level ground
POLICIES = ("scratch", "hop", "bundled", "scripted", "terrain")
SEED = 2015


def _cpu_per_second(run, params, repeat):
    best = math.inf
    for _ in range(repeat):
        t0 = time.process_time()
        seconds = run(params)
        best = min(best, (time.process_time() - t0) / seconds)
    return best


def _rest(p):
    roll = simulate(np.zeros(6000), t_end=600.0, params=p)
    assert set(roll.state) == {"F"}
    return 600.0


def _flight(p):
    roll = simulate(
        np.zeros(1000), t_end=100.0, params=p, initial_state=(0.0, 0.6, 0.1, 1e-3, 1e-3, 0.03)
    )
    assert set(roll.state) == {"A"} and not roll.events
    return 100.0


def _launch(p):
    total = 0.0
    for torque in (3e-5, 5e-5, 2e-4, 4e-4):  # pivot and/or slide to lift-off
        sim = RoverSim(params=p, target_x=0.5)
        sim.advance(torque, 300.0, stop_on="liftoff")
        total += sim.t
    return total


def _pivot(p):
    sim = RoverSim(params=p, target_x=0.5)
    events = sim.advance(1.5e-5, 1.8)  # at +0.3 rad it slips at 1.84 s
    assert [e[1:4] for e in events] == [("tip", "F", "B")], events
    return 1.8


def _slide(p):
    roll = simulate(
        np.zeros(600), t_end=60.0, params=p, initial_state=(0.0, p.half_height, 0.0, 4e-3, 0.0, 0.0)
    )
    assert "G" in set(roll.state)
    return 60.0


GROUND_PHASES = (
    ("rest (F)", _rest),
    ("flight (A)", _flight),
    ("launch (B/C)", _launch),
    ("pivot (B)", _pivot),
    ("slide (G)", _slide),
)
COST_SLOPES = (0.0, 0.3, -0.3)


def ground_costs(repeat: int = 20, rounds: int = 3) -> dict:
    """{phase: {slope: best CPU seconds per simulated second}} (module docstring)."""
    out = {}
    for name, run in GROUND_PHASES:
        best = {phi: math.inf for phi in COST_SLOPES}
        for _ in range(rounds):  # interleaved: level, +0.3, -0.3, ...
            for phi in COST_SLOPES:
                best[phi] = min(best[phi], _cpu_per_second(run, RoverParams(slope=phi), repeat))
        out[name] = best
    return out


def ground_cost_table(costs: dict) -> str:
    rows = [
        [name, f"{c[0.0] * 1e6:.2f}"]
        + [f"{c[phi] * 1e6:.2f} ({c[phi] / c[0.0]:.2f}x)" for phi in COST_SLOPES[1:]]
        for name, c in costs.items()
    ]
    return table(
        ["phase", "level [us CPU / s simulated]"]
        + [f"slope {phi:+.1f} rad" for phi in COST_SLOPES[1:]],
        rows,
    )


def conditions():
    """(label, slope, roughness) of every measured ground."""
    return [(f"slope {s:+.1f}", s, SLOPE_ROUGHNESS) for s in SLOPES] + [
        (f"roughness {r:.2f}", 0.0, r) for r in ROUGHNESSES if r != SLOPE_ROUGHNESS
    ]


def available(names=POLICIES):
    """The policies that can be loaded here (a bundled file may not exist yet)."""
    return [n for n in names if n not in BUNDLED or (BUNDLED_DIR / f"{BUNDLED[n]}.zip").exists()]


def measure(episodes: int, names=POLICIES, progress=print) -> dict:
    """{policy: {label: summary}} over `episodes` seeded targets per ground."""
    targets = seeded_targets(episodes, SEED, -1.0, 1.0)
    out = {"episodes": episodes, "seed": SEED, "results": {}, "wall": {}}
    for name in available(names):
        pol = load_policy(name, control_dt=0.5, seed=SEED)
        t0 = time.perf_counter()
        rows = {}
        for label, slope, rough in conditions():
            rows[label] = summarize(
                run_episodes(pol, targets, terrain={"slope": slope, "roughness": rough})
            )
            progress(f"  {name:9s} {label:16s} success {rows[label]['success_rate']:.0%}")
        out["results"][name] = rows
        out["wall"][name] = time.perf_counter() - t0
    return out


def _cell(s: dict) -> str:
    med = s["median_ttrtp"]
    return f"{100 * s['success_rate']:.0f} % / " + (
        "-" if med is None or math.isnan(med) else f"{med:.0f} s"
    )


def figure(data: dict, path: str) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey="row")
    for name, rows in data["results"].items():
        for col, (xs, labels) in enumerate(
            (
                (SLOPES, [f"slope {s:+.1f}" for s in SLOPES]),
                (
                    ROUGHNESSES,
                    [
                        f"slope {0.0:+.1f}" if r == SLOPE_ROUGHNESS else f"roughness {r:.2f}"
                        for r in ROUGHNESSES
                    ],
                ),
            )
        ):
            succ = [100 * rows[lb]["success_rate"] for lb in labels]
            med = [rows[lb]["median_ttrtp"] for lb in labels]
            axes[0, col].plot(xs, succ, "o-", label=name)
            axes[1, col].plot(xs, [np.nan if m is None else m for m in med], "o-", label=name)
    axes[0, 0].set_title(f"against the slope (roughness {SLOPE_ROUGHNESS} rad)")
    axes[0, 1].set_title("against the roughness (level ground)")
    axes[0, 0].set_ylabel("success [%]")
    axes[1, 0].set_ylabel("median TTRTP [s]")
    axes[1, 0].set_xlabel("slope [rad]")
    axes[1, 1].set_xlabel("roughness [rad]")
    axes[0, 1].legend()
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    fig.suptitle(
        f"{data['episodes']} seeded targets per ground (seed {data['seed']}), contest judge, 600 s"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def markdown(data: dict) -> str:
    labels = [lb for lb, _, _ in conditions()]
    rows = [[name] + [_cell(r[lb]) for lb in labels] for name, r in data["results"].items()]
    text = (
        f"Success and median TTRTP (success % / median) of each policy on "
        f"{data['episodes']} seeded targets in [-1, 1] m (seed {data['seed']}) per "
        f"ground, the contest judge, 600 s. Slopes at roughness {SLOPE_ROUGHNESS} rad; "
        "roughness on level ground. Every policy acts in its own task (module "
        "docstring of benchmarks/bench_terrain.py).\n\n"
    )
    return text + table(["policy"] + labels, rows)


def learning_curves(run_dirs, path: str) -> str:
    """A figure and a table of train.py's own evaluations (`evaluations.csv`) of terrain
    runs (one per seed): success and median TTRTP against environment steps."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_s, ax_m) = plt.subplots(1, 2, figsize=(11, 4))
    rows = []
    for run_dir in run_dirs:
        with open(f"{run_dir}/evaluations.csv") as fh:
            ev = list(csv.DictReader(fh))
        steps = np.array([float(r["timesteps"]) for r in ev])
        succ = np.array([float(r["success_rate"]) for r in ev])
        med = np.array(
            [
                float(r["median_ttrtp"]) if r["median_ttrtp"] not in ("", "nan") else np.nan
                for r in ev
            ]
        )
        wall = np.array([float(r["wall_s"]) for r in ev])
        name = str(run_dir).rstrip("/").rsplit("/", 1)[-1]
        ax_s.plot(steps / 1e6, 100 * succ, "o-", label=name)
        ax_m.plot(steps / 1e6, med, "o-", label=name)
        hit = np.flatnonzero(succ >= 0.95)
        best = int(np.argmax(succ))
        rows.append(
            [
                name,
                f"{steps[-1] / 1e6:.1f} M",
                f"{wall[-1]:.0f}",
                f"{100 * succ[-1]:.0f} %",
                f"{100 * succ[best]:.0f} % at {steps[best] / 1e6:.1f} M",
                "-" if not hit.size else f"{steps[hit[0]] / 1e6:.1f} M / {wall[hit[0]]:.0f} s",
            ]
        )
    ax_s.set_ylabel("validation success [%]")
    ax_m.set_ylabel("validation median TTRTP [s]")
    for ax in (ax_s, ax_m):
        ax.set_xlabel("environment steps [M]")
        ax.grid(alpha=0.3)
    ax_s.legend()
    fig.suptitle(
        "PPO from scratch on HopRoverTerrain-v0 (train.py evaluations: 100 "
        "validation targets and slopes, seed 7)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return table(
        ["run", "steps", "wall s", "last success", "best success", "first >= 95 % (steps / wall)"],
        rows,
    )


def run(quick: bool = False, fig_dir: str = ".") -> Section:
    costs = ground_costs(repeat=2 if quick else 20, rounds=1 if quick else 3)
    data = measure(
        4 if quick else 40,
        names=("scratch", "scripted") if quick else POLICIES,
        progress=lambda line: print(line, file=sys.stderr),
    )
    fig = figure(data, f"{fig_dir}/terrain_degradation.png")
    text = (
        "What a slope costs the simulator: CPU time per simulated second, best of "
        "repeated runs, slopes interleaved with level ground (`ground_costs`).\n\n"
        + ground_cost_table(costs)
        + "\n\n"
        + markdown(data)
    )
    return Section(
        "Terrain: cost on a slope, and degradation with slope and roughness",
        text,
        [fig],
        headline={},
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=40)
    ap.add_argument("--policies", default=",".join(POLICIES))
    ap.add_argument("--json", default=None, help="write the measurements (JSON)")
    ap.add_argument(
        "--from-json",
        action="append",
        default=None,
        help="render saved measurements (repeat to join policies measured apart)",
    )
    ap.add_argument("--figure", default="benchmarks/figures/terrain_degradation.png")
    ap.add_argument(
        "--costs", action="store_true", help="only the cost per simulated second on a slope"
    )
    ap.add_argument(
        "--curves",
        nargs="+",
        default=None,
        metavar="RUN_DIR",
        help="only the learning curves of these train.py run directories",
    )
    args = ap.parse_args(argv)
    if args.curves:
        print(learning_curves(args.curves, "benchmarks/figures/terrain_learning.png"))
        return 0
    if args.costs:
        print(ground_cost_table(ground_costs()))
        return 0
    if args.from_json:
        data = None
        for path in args.from_json:
            with open(path) as fh:
                part = json.load(fh)
            if data is None:
                data = part
            elif (part["episodes"], part["seed"]) != (data["episodes"], data["seed"]):
                raise SystemExit(
                    f"{path}: other targets ({part['episodes']} episodes, seed "
                    f"{part['seed']}) than {args.from_json[0]}"
                )
            else:
                data["results"].update(part["results"])
                data["wall"].update(part["wall"])
    else:
        data = measure(args.episodes, tuple(args.policies.split(",")))
        if args.json:
            write_json(args.json, data)
    figure(data, args.figure)
    print(markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
