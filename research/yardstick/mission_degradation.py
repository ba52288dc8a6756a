"""How the mission conditions cost each agent: success and median regret on the
HopRoverMission-v0 suite (the terrain suite's episodes and references) as every noise
of the task (and the actuator error) is scaled by 0, 0.5, 1, 2 and 4.

    python -m research.yardstick.mission_degradation                     # scripted on 200 episodes
    python -m research.yardstick.mission_degradation --policy mpc --episodes 40 --policy scripted
    python -m research.yardstick.mission_degradation --policy runs/mission_s0 --out results.json

The agents act on what the task lets them see: the scripted hopper and mpc through the
estimator (hoprover_env.agents.estimation), a learned policy on the observation. Episode e is
seeded with e at every scale, so its ground, actuator and terrain are the same and only
the noise differs. The JSON (written atomically) holds one row per agent and scale, and
a figure beside it shows the table.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from hoprover_env.agents.policies import load_policy
from hoprover_env.evaluation import suites
from hoprover_env.evaluation.scores import summarize
from hoprover_env.util.files import atomic_write

ENV_ID = "HopRoverMission-v0"
SCALES = (0.0, 0.5, 1.0, 2.0, 4.0)
OUT = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "mission_degradation.json"


def evaluate(spec: str, suite, n: int, scale: float) -> dict:
    """One agent on the first `n` episodes of the suite at one noise scale."""
    policy = load_policy(spec)
    policy.env_id = ENV_ID
    t0 = time.perf_counter()
    rows = suites.run(policy, _head(suite, n), env_kwargs={"noise_scale": scale})
    wall = time.perf_counter() - t0
    s = summarize(spec, np.array([r["score"] for r in rows]))
    return {
        "agent": spec,
        "noise_scale": scale,
        "episodes": n,
        "wall_s": wall,
        "success": s.point["success"],
        "success_low": s.low["success"],
        "success_high": s.high["success"],
        "median_regret": s.point["median_regret"],
        "median_regret_low": s.low["median_regret"],
        "median_regret_high": s.high["median_regret"],
        "broken": int(sum(r["broken"] for r in rows)),
    }


def _head(suite, n: int):
    """The suite's first n episodes, as a suite (for `suites.judged`)."""
    import dataclasses

    return dataclasses.replace(suite, episodes=suite.episodes[:n])


def table(rows: list[dict]) -> str:
    lines = [
        "| agent | noise x | episodes | success | median regret | broken |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        reg = r["median_regret"]
        reg_s = (
            "inf"
            if not np.isfinite(reg)
            else f"{reg:.3f} [{r['median_regret_low']:.3f}, {r['median_regret_high']:.3f}]"
        )
        lines.append(
            f"| {r['agent']} | {r['noise_scale']:g} | {r['episodes']} | "
            f"{100 * r['success']:.1f} % [{100 * r['success_low']:.1f}, "
            f"{100 * r['success_high']:.1f}] | {reg_s} | {r['broken']} |"
        )
    return "\n".join(lines)


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4))
    for agent in dict.fromkeys(r["agent"] for r in rows):
        mine = [r for r in rows if r["agent"] == agent]
        x = [r["noise_scale"] for r in mine]
        a.errorbar(
            x,
            [100 * r["success"] for r in mine],
            yerr=[
                [100 * (r["success"] - r["success_low"]) for r in mine],
                [100 * (r["success_high"] - r["success"]) for r in mine],
            ],
            marker="o",
            capsize=3,
            label=agent,
        )
        b.plot(x, [min(r["median_regret"], 10.0) for r in mine], marker="o", label=agent)
    a.set(xlabel="noise scale (x the defaults)", ylabel="success [%]", ylim=(0, 102))
    b.set(xlabel="noise scale (x the defaults)", ylabel="median regret (TTRTP / reference)")
    a.legend()
    fig.suptitle(f"{ENV_ID}: the cost of the mission conditions")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--policy", action="append", help="agents (default: scripted)")
    ap.add_argument("--episodes", type=int, default=200, help="first N suite episodes")
    ap.add_argument("--scales", type=float, nargs="+", default=list(SCALES))
    ap.add_argument("--out", type=Path, default=OUT, help="JSON of the rows (merged)")
    args = ap.parse_args(argv)
    suite = suites.load(ENV_ID)
    if not 1 <= args.episodes <= len(suite):
        ap.error(f"--episodes must lie in [1, {len(suite)}]")
    done = json.loads(args.out.read_text())["rows"] if args.out.exists() else []
    for spec in args.policy or ["scripted"]:
        for scale in args.scales:
            row = evaluate(spec, suite, args.episodes, scale)
            done = [r for r in done if (r["agent"], r["noise_scale"]) != (spec, scale)]
            done.append(row)
            done.sort(key=lambda r: (r["agent"], r["noise_scale"]))
            print(table([row]).splitlines()[-1], flush=True)
            atomic_write(
                args.out,
                json.dumps({"suite": f"{suite.name}-v{suite.version}", "rows": done}, indent=1),
            )
    print(table(done))
    figure(done, args.out.with_suffix(".png"))


if __name__ == "__main__":
    main()
