"""The leaderboard: every bundled agent on every frozen suite, scored against the
best-known references, grouped by how each agent was made.

    python -m research.yardstick.leaderboard                   # all suites, writes the files below
    python -m research.yardstick.leaderboard --suite contest --agents mpc scripted --merge
    python -m research.yardstick.leaderboard --pages-only --skip-readme   # no evaluation

For each suite (hoprover_env/evaluation/suites.py) and agent it runs the suite's episodes
(`hoprover_env.evaluation.suites.run`, the contest judge), and summarises them with
`hoprover_env.evaluation.scores.summarize`: success, median regret, mean and IQM normalised score,
each with a 95 % bootstrap interval over the episodes (rliable). The suites' references
get a row of their own, read from the suite (score 1 by definition, nothing is run).

Each row carries its agent's group (`GROUPS`: RL from reward, imitation of a planner,
planners that use the simulator as their model, references) and a line on how it was
made: a bundled model's from the "group" and "how_made" keys of its .json in
hoprover_env/agents/policies/ (with "teacher" and "hand_written" for an imitation), the
others' from `OTHERS`. Writes `benchmarks/results/leaderboard.json` (every episode) and
`docs/leaderboard.md` (one heading per group, one table per suite under it), and splices
the tables into README.md between its leaderboard markers (not with --skip-readme).
`--pages-only` evaluates nothing: it refreshes the groups and the references' rows in
the stored results and rewrites the pages from them. Every file is written atomically.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from hoprover_env.evaluation import suites
from hoprover_env.evaluation.scores import format_table, summarize
from hoprover_env.util.files import atomic_write
from research.baselines import DEMOS as DEMOS_GROUP  # the baselines' groups (group_of)
from research.baselines import RL

ROOT = Path(__file__).resolve().parents[2]  # the repository
SUITES = {name: suites.task_of(name) for name in ("level", "terrain", "contest")}
AGENTS = {
    # every bundled agent on every suite, each task's own learned policy first; the
    # suites' references are read from the suite, not run
    "level": [
        "mpc",
        "plan_clone",
        "scratch",
        "hop",
        "bundled",
        "terrain",
        "terrain_base",
        "mission",
        "scripted",
        "reference",
        "random",
    ],
    "terrain": [
        "mpc",
        "terrain",
        "terrain_base",
        "plan_clone",
        "scratch",
        "hop",
        "bundled",
        "mission",
        "scripted",
        "reference",
        "random",
    ],
    "contest": [
        "mpc",
        "plan_clone",
        "scratch",
        "hop",
        "bundled",
        "terrain",
        "terrain_base",
        "mission",
        "scripted",
        "reference",
        "random",
    ],
}
# the groups, in the order the pages show them: (heading, what the group's agents are)
IMITATION = "Imitation of a planner"
PLANNERS, REFERENCES = "Planners that use the simulator as their model", "References"
GROUPS = {
    RL: (
        "RL from reward",
        "PPO from each task's reward alone, from random weights: no demonstrations and no "
        "planner in the loop. Where a task acts through hand-written parts the line says "
        "so: the hop task's built-in flight controller, and the mission agent's estimator "
        "and the scripted hopper's flight control, through which its hop network acts.",
    ),
    IMITATION: (
        "Imitation of a planner (hand-written parts named)",
        "Networks fitted to a planner's actions (behaviour cloning, DAgger), some "
        "fine-tuned by PPO afterwards; each names its teacher and the parts written "
        "by hand rather than learned.",
    ),
    PLANNERS: (
        "Planners that use the simulator as their model (privileged)",
        "Nothing learned: they search for plans with the simulator itself from the "
        "exact state, information no observation-only policy has.",
    ),
    REFERENCES: (
        "References (clairvoyant on rough ground)",
        "The two ends of the scale: the suites' best-known plans (a clairvoyant "
        "search with the simulator as its model that on rough ground knew the "
        "episode's bumps; every score above is reference TTRTP / TTRTP, so they "
        "score 1 by definition), and uniform random actions as the floor.",
    ),
}
# the agents that are not bundled models (a bundled model's .json says how it was made)
OTHERS = {
    "mpc": {
        "group": PLANNERS,
        "how_made": "receding-horizon search of hop plans (a launch "
        "grid, then CMA-ES) with the simulator as its model, from the exact state "
        "(hoprover_env.agents.mpc)",
    },
    "scripted": {
        "group": PLANNERS,
        "how_made": "a hand-written contest entry that plans each "
        "hop's launch torque with the simulator as its look-ahead on the mean plane "
        "and flies it flat (hoprover_env.agents.scripted.ScriptedHopper)",
    },
    "reference": {
        "group": REFERENCES,
        "how_made": "the suites' best-known plans, replayable "
        "bit for bit (hoprover_env.evaluation.suites; regenerated by python -m "
        "research.yardstick.references)",
    },
    "random": {"group": REFERENCES, "how_made": "uniform random actions (seed 0): the floor"},
}
# what each agent knows beyond the observation
PRIVILEGE = {
    "reference": "clairvoyant search: the simulator as model, and on rough ground the "
    "episode's own bumps",
    "mpc": "the simulator as its model and the exact state (not the bumps)",
    "scripted": "the simulator as its look-ahead and the exact state (plans on the mean plane)",
    "plan_clone": "observation only (a network cloned from a table of the planner's plans "
    "from the start state on level ground, and a nudge law; no slope input)",
    "scratch": "observation only (learned)",
    "hop": "observation only (learned)",
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
# the baselines' summaries, written by python -m research.baselines ... --record
BASELINES = ROOT / "benchmarks" / "results" / "baselines"


def load_agent(name: str):
    if name == "mpc":
        from hoprover_env.agents.mpc import MPCPolicy

        return MPCPolicy()
    from hoprover_env.agents.policies import load_policy

    return load_policy(name, control_dt=suites.CONTROL_DT)


def agent_info(name: str) -> dict:
    """How agent `name` was made: its "group" (a key of GROUPS) and "how_made", and for an
    imitation its "teacher" and "hand_written" parts; a bundled model's from its .json,
    the others' from OTHERS. Raises KeyError for an agent with no group recorded."""
    from hoprover_env.agents.policies import BUNDLED, BUNDLED_DIR, BUNDLED_NETS

    files = {**BUNDLED, **BUNDLED_NETS}
    if name in files:
        meta = json.loads((BUNDLED_DIR / f"{files[name]}.json").read_text())
    elif name in OTHERS:
        meta = OTHERS[name]
    else:
        raise KeyError(
            f"{name!r}: no group recorded (a bundled model's .json has none, or add it to OTHERS)"
        )
    if meta.get("group") not in GROUPS:
        raise KeyError(f"{name!r}: group {meta.get('group')!r} is not one of {list(GROUPS)}")
    info = {"group": meta["group"], "how_made": meta.get("how_made", "")}
    if meta["group"] == IMITATION:
        info.update(teacher=meta.get("teacher", ""), hand_written=list(meta["hand_written"]))
    return info


def reference_row(suite) -> dict:
    """The suite's references as a row like an agent's (nothing is run): each episode
    succeeds in its reference's TTRTP, regret and score 1."""
    episodes = [
        {
            "policy": "reference",
            "episode": ep.index,
            "target_x": ep.target_x,
            "success": True,
            "ttrtp": ep.reference_ttrtp,
            "suite": f"{suite.name}-v{suite.version}",
            "slope": ep.slope,
            "roughness": ep.roughness,
            "terrain_seed": ep.terrain_seed,
            "reference_ttrtp": ep.reference_ttrtp,
            "regret": 1.0,
            "score": 1.0,
        }
        for ep in suite.episodes
    ]
    return {"wall_s": 0.0, "episodes": episodes}


def annotate(results: dict) -> dict:
    """`results` with each suite's references' row (if missing) and every row's group
    and how it was made (agent_info) written into it, in place; the scores untouched."""
    for name, res in results.items():
        if "reference" not in res["agents"]:
            suite = suites.load(SUITES[name])
            if suite.checksum != res["checksum"]:
                raise ValueError(f"{name}: the stored results are of another suite version")
            res["agents"]["reference"] = reference_row(suite)
        for agent, row in res["agents"].items():
            for key in ("group", "how_made", "teacher", "hand_written"):
                row.pop(key, None)
            row.update(agent_info(agent))
    return results


def evaluate(suite_names, agent_names=None) -> dict:
    out = {}
    for name in suite_names:
        suite = suites.load(SUITES[name])
        rows = {}
        for agent in agent_names or AGENTS[name]:
            if agent == "reference":
                rows[agent] = reference_row(suite)
                continue
            policy = load_agent(agent)
            t0 = time.perf_counter()
            episodes = suites.run(policy, suite)
            wall = time.perf_counter() - t0
            rows[agent] = {"wall_s": wall, "episodes": episodes}
            if hasattr(policy, "decisions"):  # a planner: what its decisions cost
                rows[agent].update(
                    decisions=policy.decisions,
                    planning_s=policy.planning_seconds,
                    ms_per_decision=1e3 * policy.planning_seconds / max(policy.decisions, 1),
                )
            ok = np.mean([e["success"] for e in episodes])
            print(
                f"[{name}] {agent}: {len(episodes)} episodes in {wall:.0f} s, success {ok:.1%}",
                flush=True,
            )
        out[name] = {
            "suite": f"{suite.name}-v{suite.version}",
            "checksum": suite.checksum,
            "agents": rows,
        }
    return out


def suite_line(name: str, res: dict) -> str:
    """'**level-v1** (HopRover-v0, HopRoverHop-v0; 200 episodes, checksum `...`)'."""
    n = len(next(iter(res["agents"].values()))["episodes"])
    also = [i for i in suites.suite_ids(name) if i != SUITES[name]]
    return (
        f"**{res['suite']}** ({', '.join([SUITES[name], *also])}; {n} episodes, "
        f"checksum `{res['checksum'][:12]}`)"
    )


def tables(results: dict) -> str:
    """One heading per group (GROUPS' order), its statement, one table per suite of the
    group's agents (AGENTS' order), the planners' costs, and how each agent was made."""
    parts = ["Suites: " + "; ".join(suite_line(name, res) for name, res in results.items()) + "."]
    for group, (heading, statement) in GROUPS.items():
        body, made = [], {}
        for name, res in results.items():
            order = AGENTS.get(name, [])
            rows = dict(
                sorted(
                    ((a, r) for a, r in res["agents"].items() if r["group"] == group),
                    key=lambda kv: order.index(kv[0]) if kv[0] in order else len(order),
                )
            )
            if not rows:
                continue
            summaries = [summarize(a, [e["score"] for e in r["episodes"]]) for a, r in rows.items()]
            costs = [
                f"{a}: {r['wall_s']:.0f} s for the suite, {r['decisions']} plans at "
                f"{r['ms_per_decision']:.0f} ms each"
                for a, r in rows.items()
                if "decisions" in r
            ]
            body.append(
                f"**{res['suite']}**:\n\n"
                + format_table(summaries)
                + ("\n\nPlanning cost (2 cores): " + "; ".join(costs) if costs else "")
            )
            made.update(rows)
        if not body:
            continue
        lines = []
        for a, r in made.items():
            line = f"- **{a}**: {r['how_made']}"
            if "teacher" in r:
                line += f". Teacher: {r['teacher']}"
            if "hand_written" in r:
                line += (
                    ". Hand-written: "
                    + "; ".join(f"({i}) {h}" for i, h in enumerate(r["hand_written"], 1))
                    if r["hand_written"]
                    else ". Hand-written parts: none (a plain network)"
                )
            lines.append(line + ".")
        parts.append(
            f"### {heading}\n\n{statement}\n\n"
            + "\n\n".join(body)
            + "\n\nHow each was made:\n\n"
            + "\n".join(lines)
        )
    return "\n\n".join(parts)


def baseline_tables(folder: Path = BASELINES, group: str = RL) -> str:
    """The baselines of `group` scored over seeds (research/baselines.py's summary.json
    files, copied into `folder`; one recorded before groups were is RL from reward), one
    table per suite; "" when there are none."""
    from hoprover_env.evaluation.scores import METRICS, Summary

    by_suite: dict = {}
    for path in sorted(folder.glob("*.json")):
        res = json.loads(path.read_text())
        if res.get("group", RL) != group:
            continue
        row = res["summary"]
        s = Summary(
            row["agent"],
            row["runs"],
            row["episodes"],
            {m: row[m] for m in METRICS},
            {m: row[m + "_low"] for m in METRICS},
            {m: row[m + "_high"] for m in METRICS},
        )
        # one table per suite and task: the mission task plays the terrain suite's
        # episodes under its own conditions
        by_suite.setdefault((res["suite"], res["env_id"]), []).append((s, res))
    return "\n\n".join(
        f"**{suite}** on {env_id}, intervals over seeds:\n\n"
        f"{format_table([s for s, _ in rows])}\n\n"
        + "\n".join(
            f"- {res['name']}: {res['env_id']}, `{res.get('command', '?')}`"
            + (f" (commit {res['commit']}, {res['date']})" if "commit" in res else "")
            for s, res in rows
        )
        for (suite, env_id), rows in by_suite.items()
    )


def privilege_table() -> str:
    lines = ["| agent | what it knows |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in PRIVILEGE.items()]
    return "\n".join(lines)


# the README's headline: the best agent of each group, on these suites
HEADLINE_SUITES = ("level", "terrain")


def headline(results: dict) -> str:
    """The README's table: for each group (GROUPS' order, without the floor `random`),
    its best agent by level-v1 IQM score, and that agent's success and median regret
    with 95 % intervals on each suite of HEADLINE_SUITES."""
    suites_here = [s for s in HEADLINE_SUITES if s in results]
    rows = [
        "| how the agent was made | best agent | "
        + " | ".join(results[s]["suite"] for s in suites_here)
        + " |",
        "|---|---|" + "---|" * len(suites_here),
    ]
    first = results[suites_here[0]]["agents"]
    for group, (heading, _) in GROUPS.items():
        members = [a for a, r in first.items() if r["group"] == group and a != "random"]
        if not members:
            continue
        best = max(
            members,
            key=lambda a: summarize(a, [e["score"] for e in first[a]["episodes"]]).point[
                "iqm_score"
            ],
        )
        cells = []
        for name in suites_here:
            r = results[name]["agents"].get(best)
            if r is None:
                cells.append("not scored")
                continue
            m = summarize(best, [e["score"] for e in r["episodes"]])
            cells.append(
                f"{m.point['success']:.1%}, {m.point['median_regret']:.3f} "
                f"[{m.low['median_regret']:.3f}, {m.high['median_regret']:.3f}]"
            )
        rows.append(
            f"| {heading} ({', '.join(f'`{a}`' for a in members)}) | `{best}` | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(rows)


def stamp_lines(stamp: str) -> str:
    """The stamp for docs/leaderboard.md: its sentences, each merge on a line of its own."""
    import re

    parts = re.split(r"(?= Added with `--merge`)| (?=Grouped by)", stamp)
    head, merges = parts[0], [p.strip() for p in parts[1:]]
    return head + ("\n\n" + "\n".join(f"- {m}" for m in merges) if merges else "")


def short_stamp(stamp: str) -> str:
    """The stamp in one line for the README: the first run and the last merge (the full
    stamp, with every merge, is on docs/leaderboard.md)."""
    import re

    first = stamp.split(")", 1)[0] + ")"
    merges = re.findall(r"Added with `--merge` \(([^)]*)\)", stamp)
    last = f"; rows last merged with `--merge` {merges[-1]}" if merges else ""
    return f"{first}{last}. Every row and its provenance: docs/leaderboard.md."


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
    ap.add_argument(
        "--pages-only",
        action="store_true",
        help="evaluate nothing: refresh the groups and the references' rows in "
        "the stored results in --out, and rewrite them, docs/leaderboard.md "
        "and the README's table (after new baselines are recorded, or a "
        "model's .json says how it was made)",
    )
    ap.add_argument(
        "--merge",
        action="store_true",
        help="keep the stored results of the agents not evaluated now",
    )
    ap.add_argument(
        "--skip-readme",
        action="store_true",
        help="leave README.md alone (write the JSON and docs/leaderboard.md)",
    )
    args = ap.parse_args(argv)
    if args.pages_only:
        out = Path(args.out)
        if not out.is_file():
            raise SystemExit(f"--pages-only: no stored results at {out}; run without it first")
        stored = json.loads(out.read_text())
        annotate(stored["results"])
        if not args.no_write:
            atomic_write(args.out, json.dumps(stored, indent=1, default=float))
            write_pages(stored["results"], stored["stamp"], readme=not args.skip_readme)
        else:
            print(tables(stored["results"]))
        return 0
    results = evaluate(args.suite, args.agents)
    now = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    stamp = (
        f"Command: `python -m research.yardstick.leaderboard` ({now}). "
        "Score = reference TTRTP / TTRTP (0 for a failure), regret = TTRTP / reference; "
        "intervals: 95 % bootstrap over the episodes (rliable). The references are "
        "best-known plans, not optima."
    )
    if args.merge:
        stored_all = json.loads(Path(args.out).read_text())
        stored = stored_all["results"]
        stamp = (
            f"{stored_all['stamp']} Added with `--merge` ({now}): "
            + ", ".join(f"{a} on {s}" for s in results for a in results[s]["agents"])
            + "."
        )
        for suite, res in results.items():
            if suite in stored and stored[suite]["checksum"] == res["checksum"]:
                stored[suite]["agents"].update(res["agents"])
                order = AGENTS[suite]
                stored[suite]["agents"] = dict(
                    sorted(
                        stored[suite]["agents"].items(),
                        key=lambda kv: order.index(kv[0]) if kv[0] in order else len(order),
                    )
                )
            else:
                stored[suite] = res
        results = stored
    annotate(results)
    print(tables(results))
    if args.no_write:
        return 0
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    atomic_write(
        args.out, json.dumps({"stamp": stamp, "results": results}, indent=1, default=float)
    )
    write_pages(results, stamp, readme=not args.skip_readme)
    return 0


def write_pages(results: dict, stamp: str, readme: bool = True) -> None:
    """docs/leaderboard.md (agents by group, baselines over seeds, privileges) and, with
    `readme`, the README's table."""
    md = tables(results)
    page = ROOT / "docs" / "leaderboard.md"
    atomic_write(
        str(page),
        "# Leaderboard\n\nEvery bundled agent on every frozen test suite "
        "(`hoprover_env.evaluation.suites`), scored against the suites' best-known "
        "references, and grouped by how each agent was made: learned from the reward, "
        "imitating a planner, planning with the simulator, or the references "
        "themselves. Each group's line says what its agents share; each agent's line "
        "says how it was made (its model's .json in hoprover_env/agents/policies/)."
        f"\n\n## The bundled agents on the frozen suites\n\n{md}\n\n"
        f"{stamp_lines(stamp)}\n\n"
        "## Baselines from scratch, over seeds (RL from reward)\n\n"
        f"{baseline_tables() or 'None scored yet.'}\n\nAll RL from reward (PPO, SAC, "
        "TD3, TQC, CrossQ from random weights; the hop and mission tasks fly each hop "
        "with their hand-written controllers). Each trained by `python -m "
        "research.baselines` with the command under its table, its best model (chosen "
        "on train.py's validation episodes) scored on the suite; "
        "docs/studies/baselines.md and docs/studies/off-policy.md have the per-seed "
        "tables, learning curves and times (BENCHMARKS.md, `baselines`, all of them).\n\n"
        "## Baselines over seeds: RL from reward and demonstrations\n\n"
        f"{baseline_tables(group=DEMOS_GROUP) or 'None scored yet.'}\n\nOff-policy "
        "learners with a demonstrator's episodes in their replay buffer before the first "
        "update (the config section `demonstrations`: which policy, how many decisions, "
        "what share of each batch), then trained on the task's reward alone; the "
        "demonstrator is named in the command's config. Scored as the baselines above.\n\n"
        f"## What each agent knows\n\n{privilege_table()}\n",
    )
    if readme:
        splice(ROOT / "README.md", f"{headline(results)}\n\n{short_stamp(stamp)}")


if __name__ == "__main__":
    sys.exit(main())
