"""The leaderboard: every bundled agent on every frozen suite, scored against the
best-known references.

    python -m agents.yardstick.leaderboard                   # all suites, writes the files below
    python -m agents.yardstick.leaderboard --suite contest --agents mpc scripted

For each suite (hoprover_env/evaluation/suites.py) and agent it runs the suite's episodes
(`hoprover_env.evaluation.suites.run`, the contest judge), and summarises them with
`hoprover_env.evaluation.scores.summarize`: success, median regret, mean and IQM normalised score,
each with a 95 % bootstrap interval over the episodes (rliable). Writes
`benchmarks/results/leaderboard.json` (every episode) and `docs/leaderboard.md` (the
tables), and splices the summary table into README.md between its leaderboard
markers. Every file is written atomically.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from hoprover_env.util.files import atomic_write
from hoprover_env.evaluation import suites
from hoprover_env.evaluation.scores import format_table, summarize

ROOT = Path(__file__).resolve().parent.parent
SUITES = {name: suites.TASK_OF[name] for name in ("level", "terrain", "contest")}
AGENTS = {
    # every bundled agent on every suite, each task's own learned policy first
    "level": ["mpc", "plan_clone", "scratch", "hop", "bundled", "terrain", "terrain_base",
              "mission", "scripted", "random"],
    "terrain": ["mpc", "terrain", "terrain_base", "plan_clone", "scratch", "hop", "bundled",
                "mission", "scripted", "random"],
    "contest": ["mpc", "plan_clone", "scratch", "hop", "bundled", "terrain", "terrain_base",
                "mission", "scripted", "random"],
}
# what each agent knows beyond the observation
PRIVILEGE = {
    "reference": "clairvoyant search: the simulator as model, and on rough ground the "
                 "episode's own bumps",
    "mpc": "the simulator as its model and the exact state (not the bumps)",
    "scripted": "the simulator as its look-ahead and the exact state (plans on the mean "
                "plane)",
    "plan_clone": "observation only (a network cloned from a table of the planner's plans "
                  "from the start state on level ground, and a nudge law; no slope input)",
    "scratch": "observation only (learned)", "hop": "observation only (learned)",
    "bundled": "observation only (learned, cloned from the scripted hopper)",
    "terrain": "observation only (learned)",
    "terrain_base": "observation only (learned: `terrain` before its fine-tuning)",
    "mission": "less than the others: it plays every suite under mission conditions "
               "(HopRoverMission-v0: noisy readings through the estimator, drawn ground, "
               "actuator error); learned hop choices, flown by the scripted hopper's "
               "controller",
    "random": "nothing",
}
START, END = "<!-- leaderboard start -->", "<!-- leaderboard end -->"
# the baselines' summaries, written by python -m agents.baselines ... --record
BASELINES = ROOT / "benchmarks" / "results" / "baselines"


def load_agent(name: str):
    if name == "mpc":
        from hoprover_env.agents.mpc import MPCPolicy
        return MPCPolicy()
    from hoprover_env.agents.policies import load_policy
    return load_policy(name, control_dt=suites.CONTROL_DT)


def evaluate(suite_names, agent_names=None) -> dict:
    out = {}
    for name in suite_names:
        suite = suites.load(SUITES[name])
        rows = {}
        for agent in agent_names or AGENTS[name]:
            policy = load_agent(agent)
            t0 = time.perf_counter()
            episodes = suites.run(policy, suite)
            wall = time.perf_counter() - t0
            rows[agent] = {"wall_s": wall, "episodes": episodes}
            if hasattr(policy, "decisions"):      # a planner: what its decisions cost
                rows[agent].update(decisions=policy.decisions,
                                   planning_s=policy.planning_seconds,
                                   ms_per_decision=1e3 * policy.planning_seconds
                                   / max(policy.decisions, 1))
            ok = np.mean([e["success"] for e in episodes])
            print(f"[{name}] {agent}: {len(episodes)} episodes in {wall:.0f} s, success "
                  f"{ok:.1%}", flush=True)
        out[name] = {"suite": f"{suite.name}-v{suite.version}", "checksum": suite.checksum,
                     "agents": rows}
    return out


def tables(results: dict) -> str:
    parts = []
    for name, res in results.items():
        summaries = [summarize(agent, [e["score"] for e in r["episodes"]])
                     for agent, r in res["agents"].items()]
        n = len(next(iter(res["agents"].values()))["episodes"])
        also = [i for i, s in suites.SUITE_OF.items() if s == name and i != SUITES[name]]
        costs = [f"{agent}: {r['wall_s']:.0f} s for the suite, {r['decisions']} plans at "
                 f"{r['ms_per_decision']:.0f} ms each" for agent, r in res["agents"].items()
                 if "decisions" in r]
        parts.append(f"**{res['suite']}** ({', '.join([SUITES[name], *also])}; {n} episodes, "
                     f"checksum `{res['checksum'][:12]}`):\n\n" + format_table(summaries)
                     + ("\n\nPlanning cost (2 cores): " + "; ".join(costs) if costs else ""))
    return "\n\n".join(parts)


def baseline_tables(folder: Path = BASELINES) -> str:
    """The baselines scored over seeds (agents/baselines.py's summary.json files, copied
    into `folder`), one table per suite; "" when there are none."""
    from hoprover_env.evaluation.scores import METRICS, Summary
    by_suite: dict = {}
    for path in sorted(folder.glob("*.json")):
        res = json.loads(path.read_text())
        row = res["summary"]
        s = Summary(row["agent"], row["runs"], row["episodes"],
                    {m: row[m] for m in METRICS}, {m: row[m + "_low"] for m in METRICS},
                    {m: row[m + "_high"] for m in METRICS})
        # one table per suite and task: the mission task plays the terrain suite's
        # episodes under its own conditions
        by_suite.setdefault((res["suite"], res["env_id"]), []).append((s, res))
    return "\n\n".join(
        f"**{suite}** on {env_id}, intervals over seeds:\n\n"
        f"{format_table([s for s, _ in rows])}\n\n"
        + "\n".join(f"- {res['name']}: {res['env_id']}, `{res.get('command', '?')}`"
                    for s, res in rows)
        for (suite, env_id), rows in by_suite.items())


def privilege_table() -> str:
    lines = ["| agent | what it knows |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in PRIVILEGE.items()]
    return "\n".join(lines)


def splice(path: Path, text: str) -> None:
    src = path.read_text()
    if START not in src or END not in src:
        raise ValueError(f"{path} has no leaderboard markers {START} ... {END}")
    head, rest = src.split(START, 1)
    _, tail = rest.split(END, 1)
    atomic_write(str(path), f"{head}{START}\n\n{text}\n\n{END}{tail}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", nargs="+", default=list(SUITES), choices=list(SUITES))
    ap.add_argument("--agents", nargs="+", default=None, help="default: every bundled agent")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "leaderboard.json"))
    ap.add_argument("--no-write", action="store_true", help="print the tables only")
    ap.add_argument("--pages-only", action="store_true",
                    help="evaluate nothing: rewrite docs/leaderboard.md and the README's table "
                         "from the stored results in --out (after new baselines are recorded)")
    ap.add_argument("--merge", action="store_true",
                    help="keep the stored results of the agents not evaluated now")
    args = ap.parse_args(argv)
    if args.pages_only:
        out = Path(args.out)
        if not out.is_file():
            raise SystemExit(f"--pages-only: no stored results at {out}; run without it first")
        stored = json.loads(out.read_text())
        write_pages(stored["results"], stored["stamp"])
        return 0
    results = evaluate(args.suite, args.agents)
    now = time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())
    stamp = (f"Command: `python -m agents.yardstick.leaderboard` ({now}). "
             "Score = reference TTRTP / TTRTP (0 for a failure), regret = TTRTP / reference; "
             "intervals: 95 % bootstrap over the episodes (rliable). The references are "
             "best-known plans, not optima.")
    if args.merge:
        stored_all = json.loads(Path(args.out).read_text())
        stored = stored_all["results"]
        stamp = (f"{stored_all['stamp']} Added with `--merge` ({now}): "
                 + ", ".join(f"{a} on {s}" for s in results for a in results[s]["agents"]) + ".")
        for suite, res in results.items():
            if suite in stored and stored[suite]["checksum"] == res["checksum"]:
                stored[suite]["agents"].update(res["agents"])
                order = AGENTS[suite]
                stored[suite]["agents"] = dict(sorted(
                    stored[suite]["agents"].items(),
                    key=lambda kv: order.index(kv[0]) if kv[0] in order else len(order)))
            else:
                stored[suite] = res
        results = stored
    print(tables(results))
    if args.no_write:
        return 0
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps({"stamp": stamp, "results": results}, indent=1,
                                      default=float))
    write_pages(results, stamp)
    return 0


def write_pages(results: dict, stamp: str) -> None:
    """docs/leaderboard.md (agents, baselines over seeds, privileges) and the README's table."""
    md = tables(results)
    page = ROOT / "docs" / "leaderboard.md"
    atomic_write(str(page), "# Leaderboard\n\nEvery bundled agent on every frozen test suite "
                 "(`hoprover_env.evaluation.suites`), scored against the suites' best-known references."
                 f"\n\n{md}\n\n{stamp}\n\n## Baselines from scratch, over seeds\n\n"
                 f"{baseline_tables() or 'None scored yet.'}\n\nEach trained by `python -m "
                 "agents.baselines --config CONFIG --seeds 0-4`, its best model (chosen on "
                 "train.py's validation episodes) scored on the suite; BENCHMARKS.md has "
                 "the per-seed tables, learning curves and times.\n\n"
                 f"## What each agent knows\n\n{privilege_table()}\n")
    splice(ROOT / "README.md", f"{md}\n\n{stamp}")


if __name__ == "__main__":
    sys.exit(main())
