"""Regenerate the frozen suites' best-known references.

    python -m research.yardstick.references [--suite level terrain contest] [--budget 12000]
                                [--agents scripted bundled scratch mpc] [--version 1]
                                [--report runs/references.json]

For every episode of a suite (hoprover_env/evaluation/suites.py draws them from the suite's seed),
a clairvoyant search (`hoprover_env.agents.planning.search`: a launch grid, then CMA-ES from
several starts, every population of every episode in one `simulate_batch` call; on
rough ground every candidate is flown over the episode's own terrain seed) looks for
the fastest plan within `--budget` simulated candidates. The best plan is recorded as
the torque of each 0.5 s control interval. The plans of the agents named by
`--agents` are recorded the same way (their applied torques, step by step, in the
vector env on the same episodes) and replace the search's where they are faster, so
that a reference is at least as fast as every one of them. Every schedule is replayed
through `simulate` before it is stored: the stored TTRTP is the replay's, bit for bit.

It prints the budget, the candidates simulated per second and the wall time, and the
improvement of each reference over the search at half the budget (`--budget-check`),
as evidence of how far the search has converged.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import hoprover_env
from hoprover_env import RoverParams, simulate_batch
from hoprover_env.agents.planning import CONTROL_DT, Problem, plan_controller, search
from hoprover_env.evaluation import suites

T_END = suites.EPISODE_TIME


def problems_of(cols: dict) -> list[Problem]:
    out = []
    for i in range(len(cols["target_x"])):
        p = RoverParams(slope=float(cols["slope"][i]), roughness=float(cols["roughness"][i]))
        seed = int(cols["terrain_seed"][i])
        out.append(
            Problem(
                state=np.array([0.0, p.half_height, 0.0, 0.0, 0.0, 0.0]),
                target=float(cols["target_x"][i]),
                params=p,
                t0=0.0,
                t_total=T_END,
                seeds=None if seed == suites.NO_TERRAIN_SEED else (seed,),
            )
        )
    return out


def seeds_of(cols: dict):
    s = np.asarray(cols["terrain_seed"])
    return None if (s == suites.NO_TERRAIN_SEED).all() else s.astype(np.uint64)


def plan_schedules(problems, result) -> list[np.ndarray]:
    """The torque each best plan commands per control interval, from a recorded run."""
    plans = np.array([result.plan(i, p) for i, p in enumerate(problems)])
    b = simulate_batch(
        plan_controller,
        np.array([p.target for p in problems]),
        t_end=T_END,
        control_dt=CONTROL_DT,
        params=[p.params for p in problems],
        controller_args=plans,
        seed=seeds_of_problems(problems),
        record=True,
    )
    out = []
    for i in range(len(problems)):
        k = int(b.n_samples[i]) - 1  # control intervals flown
        out.append(np.array(b.torque_cmd[i, :k], dtype=np.float64))
    return out, b.ttrtp


def seeds_of_problems(problems):
    if not any(p.seeds for p in problems):
        return None
    return np.array([p.seeds[0] if p.seeds else 0 for p in problems], dtype=np.uint64)


def replay(cols: dict, schedules: list[np.ndarray]) -> np.ndarray:
    """TTRTP of each schedule through `simulate_batch` (NaN: missed)."""
    n = len(schedules)
    width = max(len(s) for s in schedules)
    sched = np.zeros((n, max(width, 1)))
    for i, s in enumerate(schedules):
        sched[i, : len(s)] = s
    b = simulate_batch(
        sched,
        np.asarray(cols["target_x"], dtype=float),
        t_end=T_END,
        control_dt=CONTROL_DT,
        params=[
            RoverParams(slope=float(a), roughness=float(r))
            for a, r in zip(cols["slope"], cols["roughness"])
        ],
        seed=seeds_of(cols),
        record=False,
    )
    return b.ttrtp


def trim(schedule: np.ndarray, ttrtp: float) -> np.ndarray:
    """The schedule up to the interval in which the judge's clock completed (what comes
    after TTRTP cannot change it)."""
    k = int(math.ceil(ttrtp / CONTROL_DT)) + 1
    return schedule[:k].copy()


def agent_schedules(name: str, cols: dict, env_id: str) -> list[np.ndarray]:
    """An agent's applied torque per 0.5 s interval on each episode, recorded in the
    vector env (an agent acting every 2 s holds its torque over four intervals)."""
    from gymnasium.vector import AutoresetMode

    from hoprover_env import vector_env_class

    if name == "mpc":
        from hoprover_env.agents.mpc import MPCPolicy

        policy = MPCPolicy()
    else:
        from hoprover_env.agents.policies import load_policy

        policy = load_policy(name, control_dt=CONTROL_DT)
    if hoprover_env.task(getattr(policy, "env_id", "HopRover-v0")).hops:
        raise ValueError(f"{name}: a hop-level agent's torques are not seen step by step")
    kwargs = {**getattr(policy, "env_kwargs", {}), "episode_time": T_END}
    n = len(cols["target_x"])
    venv = vector_env_class(env_id)(n, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    cfg = venv.config
    if getattr(cfg, "action_map", "linear") != "linear" or getattr(cfg, "action_scale", 1.0) != 1.0:
        raise ValueError(f"{name}: only the linear action map is recorded")
    ground = {"slope": np.asarray(cols["slope"]), "roughness": np.asarray(cols["roughness"])}
    if seeds_of(cols) is not None:
        ground["terrain_seed"] = np.asarray(cols["terrain_seed"])
    obs, _ = venv.reset(seed=0, options={"target_x": np.asarray(cols["target_x"]), **ground})
    policy.reset(n)
    reps = int(round(cfg.control_dt / CONTROL_DT))
    torques = [[] for _ in range(n)]
    done = np.zeros(n, dtype=bool)
    while not done.all():
        action = np.asarray(policy.act(obs, venv), dtype=np.float64).reshape(n)
        # the env's linear map (tasks/torque.py action_to_torque), the same arithmetic;
        # read from the action because a sub-env that ends in this step is reset in it
        for i in np.flatnonzero(~done):
            p = venv.params[i]
            a = min(max(float(action[i]), -1.0), 1.0)
            torques[i].extend(
                [p.torque_min + 0.5 * (a + 1.0) * (p.torque_max - p.torque_min)] * reps
            )
        obs, _, term, trunc, _ = venv.step(action.reshape(n, 1))
        done |= term | trunc
    venv.close()
    return [np.array(t) for t in torques]


def search_references(name, problems, cols, budget, check, entry):
    """The clairvoyant search: (schedules, their replayed TTRTP, wall s, candidates)."""
    t0 = time.perf_counter()
    result = search(problems, budget=budget, starts=3)
    wall = time.perf_counter() - t0
    evals = int(result.evaluations.sum())
    print(
        f"[{name}] search: budget {budget} per episode, {evals} candidates in {wall:.0f} s "
        f"({evals / wall:.0f} episodes simulated per second)",
        flush=True,
    )
    entry.update(
        budget=budget,
        candidates=evals,
        search_s=wall,
        episodes_per_s=evals / wall,
        search_ttrtp=result.ttrtp.tolist(),
    )
    if check:
        t1 = time.perf_counter()
        half = search(problems, budget=budget // 2, starts=3)
        entry["half_budget_ttrtp"] = half.ttrtp.tolist()
        entry["half_search_s"] = time.perf_counter() - t1
        gain = (half.ttrtp - result.ttrtp) / half.ttrtp
        print(
            f"[{name}] budget {budget // 2} -> {budget}: median gain {np.nanmedian(gain):.2%}, "
            f"largest {np.nanmax(gain):.2%}, {np.sum(gain > 1e-9)} of {len(gain)} improved",
            flush=True,
        )
    scheds, planned = plan_schedules(problems, result)
    best = replay(cols, scheds)
    same = np.array_equal(best, planned, equal_nan=True)
    print(f"[{name}] schedules replay the plans bit for bit: {same}", flush=True)
    return scheds, best, wall, evals


def carried_start(name: str, cols: dict) -> dict:
    """The frozen start conditions of the newest stored version of the suite `name` (what
    its episodes' draws gave the tasks that draw more than the episode's options fix,
    such as the mission's sensors), carried over when its episodes are these; {} (and a
    warning) when there are none to carry: the tasks then draw them from episode e's
    seed."""
    have = suites.versions(name)
    if have:
        old = suites._read(suites.path_of(name, have[-1]), name, have[-1])
        same = all(np.array_equal(old.column(f), cols[f]) for f in suites.FIELDS[:5])
        if same:
            return old.start_conditions()
    print(
        f"[{name}] no stored version with these episodes: the new file carries no frozen "
        f"start conditions",
        file=sys.stderr,
    )
    return {}


def build(
    name: str,
    budget: int,
    agents: list[str],
    version: int,
    check: bool,
    report: dict,
    stored: bool = False,
) -> None:
    """Search (or, with `stored`, take the stored references), let the agents' plans
    compete, trim, verify by replay and save the suite."""
    cols = suites.draw_episodes(name)
    problems = problems_of(cols)
    env_id = suites.task_of(name)
    entry = report.setdefault(name, {})
    if stored:
        old = suites._read(suites.path_of(name, version), name, version)
        scheds = [e.reference_schedule.copy() for e in old]
        best = replay(cols, scheds)
        sources = [e.reference_source for e in old]
        budget, wall, evals = old.meta["budget"], old.meta["search_s"], old.meta["candidates"]
        agents_before = list(old.meta.get("agents", []))
    else:
        scheds, best, wall, evals = search_references(name, problems, cols, budget, check, entry)
        sources = ["search"] * len(best)
        agents_before = []
    for agent in agents:
        try:
            sc = agent_schedules(agent, cols, env_id)
        except (ValueError, FileNotFoundError) as err:
            print(f"[{name}] {agent}: skipped ({err})", file=sys.stderr)
            continue
        tt = replay(cols, sc)
        better = np.nan_to_num(tt, nan=np.inf) < np.nan_to_num(best, nan=np.inf)
        print(
            f"[{name}] {agent}: faster than the references on {int(better.sum())} episodes",
            flush=True,
        )
        entry[f"{agent}_replayed_ttrtp"] = tt.tolist()
        for i in np.flatnonzero(better):
            scheds[i], best[i], sources[i] = sc[i], tt[i], agent
    if np.isnan(best).any():
        raise RuntimeError(f"[{name}] no reference for episodes {np.flatnonzero(np.isnan(best))}")
    scheds = [trim(s, t) for s, t in zip(scheds, best)]
    final = replay(cols, scheds)
    if not np.array_equal(final, best):
        raise RuntimeError(f"[{name}] trimmed schedules do not replay their TTRTP")
    cols["reference_ttrtp"] = final
    meta = {
        "budget": budget,
        "agents": sorted(set(agents_before + agents)),
        "search_s": wall,
        "candidates": evals,
        "created": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "env_ids": sorted(suites.suite_ids(name)),
    }
    path = suites.save(name, version, cols, scheds, sources, meta, start=carried_start(name, cols))
    entry["reference_ttrtp"] = final.tolist()
    entry["sources"] = sources
    print(f"[{name}] wrote {path}: median reference {np.median(final):.1f} s", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--suite",
        nargs="+",
        default=["level", "terrain", "contest"],
        choices=["level", "terrain", "contest"],
    )
    ap.add_argument(
        "--budget", type=int, default=12000, help="simulated candidates per episode (default 12000)"
    )
    ap.add_argument(
        "--agents",
        nargs="*",
        default=["scripted", "bundled", "scratch", "mpc"],
        help="agents whose plans compete with the search's",
    )
    ap.add_argument("--version", type=int, default=1)
    ap.add_argument(
        "--budget-check",
        action="store_true",
        help="also search at half the budget and report the gain",
    )
    ap.add_argument("--report", type=str, default=None, help="JSON of every number")
    ap.add_argument(
        "--stored",
        action="store_true",
        help="no search: improve the stored references with --agents' plans",
    )
    args = ap.parse_args(argv)
    report: dict = {}
    for name in args.suite:
        agents = [a for a in args.agents if not (name == "terrain" and a in ("bundled", "scratch"))]
        if name == "terrain" and "terrain" not in agents and args.agents:
            agents.append("terrain")
        build(name, args.budget, agents, args.version, args.budget_check, report, args.stored)
        if args.report:
            tmp = Path(args.report).with_suffix(".tmp")
            tmp.write_text(json.dumps(report, indent=1))
            tmp.replace(args.report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
