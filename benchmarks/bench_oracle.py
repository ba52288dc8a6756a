"""A reference for TTRTP: the best hop plan a search finds, next to the policies.

    python -m benchmarks.bench_oracle [--quick]

For 20 fixed targets in [-1, 1] m (the first 20 of evaluate.py's seeded targets) and the
contest target 0.5 m, CMA-ES (the `cma` package) searches parametrised hop plans for the
smallest TTRTP, every candidate population simulated in one `simulate_batch` call. A plan
(hoprover_env/agents/compiled.py `planned_hops`, a numba-compiled contest controller) is a launch
torque held for a time window from t = 0 while the rover is on the ground, a PD attitude
hold in flight with searched gains, and one correction hop (start time, window, torque);
contest parameters, control period 0.5 s (the environments' default, as the policies
use), 600 s episodes. The search starts from the best one-hop plans of a grid over
launch torque and window (CMA-ES with BIPOP restarts from the two best distinct launch
torques, up to 12000 episodes each).

This is a best-known plan within this family and budget, not a proof of optimality:
another parametrisation or a longer search may find shorter times. The regret of a
policy is its TTRTP divided by the best found (below 1: the policy beat the search).
"""

from __future__ import annotations

import math
import sys
import tempfile
import time

import numpy as np

from benchmarks.report import Section, table
from hoprover_env import RoverParams, simulate, simulate_batch
from hoprover_env.agents.compiled import PLAN_HEAD, PLAN_HOP, hop_plan, planned_hops

CONTROL_DT = 0.5
T_END = 600.0
CONTEST_TARGET = 0.5
P = RoverParams()
T_MAX = P.torque_max
# search box of a plan: launch torque, launch window, kp, kd, correction start,
# correction window, correction torque (all scaled to [0, 1] for CMA-ES)
LOWER = np.array([-T_MAX, 0.5, 0.02, 0.1, 0.0, 0.0, -T_MAX])
UPPER = np.array([T_MAX, 20.0, 1.0, 3.0, 400.0, 20.0, T_MAX])
NAMES = (
    "launch torque",
    "launch window",
    "kp",
    "kd",
    "correction start",
    "correction window",
    "correction torque",
)
POLICIES = ("scripted", "bundled", "scratch", "hop")
MISS_COST = 600.0  # a failed run scores this plus 100 s per metre of final miss


def plan_args(u: np.ndarray) -> np.ndarray:
    """Rows of controller_args (hoprover_env/agents/compiled.py layout) from points of [0, 1]^7."""
    v = LOWER + np.clip(u, 0.0, 1.0) * (UPPER - LOWER)
    n = len(v)
    args = np.zeros((n, PLAN_HEAD + 2 * PLAN_HOP))
    args[:, 0] = P.inertia
    args[:, 1:3] = v[:, 2:4]
    args[:, 3:6] = np.column_stack([np.zeros(n), v[:, 1], v[:, 0]])
    args[:, 6:9] = v[:, 4:7]
    return args


def score(u: np.ndarray, target: float):
    """(cost, TTRTP or NaN) of plans u (rows) for one target, in one batch."""
    b = simulate_batch(
        planned_hops,
        np.full(len(u), target),
        t_end=T_END,
        control_dt=CONTROL_DT,
        controller_args=plan_args(u),
        record=False,
    )
    miss = np.maximum(np.abs(b.final[:, 0] - target) - P.half_width - P.band_half_width, 0)
    cost = np.where(b.success, b.ttrtp, MISS_COST + 100.0 * miss + 200.0 * b.broken)
    return cost, b.ttrtp


def search(target: float, quick: bool, seed: int = 0):
    """Best plan for one target: a one-hop grid, then CMA-ES from its best point."""
    import cma

    n_torque, n_window = (12, 4) if quick else (40, 8)
    tq = np.linspace(0.0, 1.0, n_torque)
    wd = np.linspace(0.0, 0.4, n_window)  # windows 0.5..8.3 s
    grid = np.array([[a, b, 0.13, 0.27, 0.0, 0.0, 0.5] for a in tq for b in wd])
    cost, _ = score(grid, target)
    order = np.argsort(cost, kind="stable")
    best_u, best_c = grid[order[0]], float(cost[order[0]])
    evals = len(grid)
    # CMA-ES from the best grid plans of distinct launch torques (different basins),
    # with BIPOP restarts (large and small populations alternating)
    starts, seen = [], set()
    for i in order:
        if grid[i][0] not in seen:
            seen.add(grid[i][0])
            starts.append(grid[i])
        if len(starts) == (1 if quick else 2):
            break

    def population_cost(xs):
        nonlocal evals, best_c, best_u
        xs = np.array(xs)
        cost, _ = score(xs, target)
        evals += len(xs)
        i = int(np.argmin(cost))
        if cost[i] < best_c:
            best_c, best_u = float(cost[i]), xs[i].copy()
        return list(cost)

    for r, start in enumerate(starts):
        cma.fmin2(
            None,
            start,
            0.15,
            {
                "bounds": [0.0, 1.0],
                "popsize": 12 if quick else 24,
                "seed": seed * 10 + r + 1,
                "maxfevals": 72 if quick else 12000,
                "verbose": -9,
                "tolfun": 1e-3,
            },
            parallel_objective=population_cost,
            restarts=0 if quick else 4,
            bipop=True,
        )
    ttrtp = best_c if best_c < MISS_COST else math.nan
    if ttrtp == ttrtp:  # the plan replayed alone through simulate() gives the same
        roll = simulate(
            hop_plan(plan_args(best_u[None])[0]),
            t_end=T_END,
            control_dt=CONTROL_DT,
            target_x=target,
        )
        assert roll.ttrtp == ttrtp, (roll.ttrtp, ttrtp)
    return ttrtp, best_u, evals


def policy_ttrtps(targets, quick):
    """TTRTP per target of each bundled policy that loads (None: missed)."""
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes

    out = {}
    for name in POLICIES:
        try:
            policy = load_policy(name, control_dt=CONTROL_DT)
        except (ValueError, FileNotFoundError) as err:
            print(f"[oracle] policy {name!r} not available: {err}", file=sys.stderr)
            continue
        results = run_episodes(policy, targets, env_kwargs={"episode_time": T_END})
        out[name] = [r.ttrtp for r in results]
    return out


def fixed_targets(quick: bool) -> np.ndarray:
    from hoprover_env.evaluation.episodes import seeded_targets

    return np.append(seeded_targets(2 if quick else 20), CONTEST_TARGET)


def run(quick: bool = False, fig_dir: str = "benchmarks/figures") -> Section:
    targets = fixed_targets(quick)
    t0 = time.perf_counter()
    found = [search(float(x), quick, seed=i) for i, x in enumerate(targets)]
    search_wall = time.perf_counter() - t0
    pols = policy_ttrtps(targets, quick)
    header = ["target m", "best found s", "launch T", "window s", "correction"]
    for name in pols:
        header += [f"{name} s", f"{name} regret"]
    rows, regrets = [], {name: [] for name in pols}
    for i, x in enumerate(targets):
        best, u, _ = found[i]
        v = LOWER + u * (UPPER - LOWER)
        # the launch window wins where the two overlap; a correction after TTRTP is moot
        start = max(v[4], v[1])
        length = v[4] + v[5] - start
        corr = (
            f"{v[6]:+.2e} at {start:.0f} s for {length:.1f} s"
            if length > 0.25 and start < best
            else "none"
        )
        row = [
            f"{x:+.3f}" + (" (contest)" if i == len(targets) - 1 else ""),
            best,
            f"{v[0]:+.2e}",
            v[1],
            corr,
        ]
        for name, tt in pols.items():
            r = tt[i] / best if tt[i] is not None and best == best else math.nan
            row += [tt[i] if tt[i] is not None else "missed", r]
            regrets[name].append(r)
        rows.append(row)
    fmt = {"best found s": ".1f", "window s": ".1f"}
    for name in pols:
        fmt[f"{name} s"] = ".1f"
        fmt[f"{name} regret"] = ".2f"
    n_found = sum(1 for f in found if f[0] == f[0])
    evals = sum(f[2] for f in found)
    summary = [
        [
            name,
            f"{np.sum(~np.isnan(r))}/{len(r)}",
            float(np.nanmedian(r)) if np.any(~np.isnan(r)) else math.nan,
            float(np.nanmax(r)) if np.any(~np.isnan(r)) else math.nan,
        ]
        for name, r in ((n, np.array(v, dtype=float)) for n, v in regrets.items())
    ]
    md = "\n\n".join(
        [
            f"Best-known hop plans: {len(targets)} targets ({len(targets) - 1} of evaluate.py's "
            f"seeded targets and the contest target 0.5 m), control period {CONTROL_DT} s, "
            f"{T_END:.0f} s episodes, contest parameters. Search: a one-hop grid, then CMA-ES "
            f"with BIPOP restarts over launch torque and window, attitude-hold gains and one "
            f"correction hop "
            f"({evals} simulated episodes through `simulate_batch` in {search_wall:.0f} s; a "
            f"plan was found for {n_found} of {len(targets)} targets). **A best-known plan, "
            "not a proof of optimality**: the bound holds only within this plan family and "
            "budget. Regret = policy TTRTP / best found (below 1: the policy beat the search; "
            "'missed': no TTRTP within the episode).",
            table(header, rows, fmt),
            "Regret per policy (over the targets both reached):",
            table(
                ["policy", "reached", "median regret", "worst regret"],
                summary,
                {"median regret": ".2f", "worst regret": ".2f"},
            ),
        ]
    )
    headline = {
        "oracle_targets": len(targets),
        "oracle_found": n_found,
        "oracle_contest_ttrtp": found[-1][0],
        "oracle_evals": evals,
        "oracle_search_s": search_wall,
    }
    for name, r in regrets.items():
        a = np.array(r, dtype=float)
        headline[f"regret_median_{name}"] = (
            float(np.nanmedian(a)) if np.any(~np.isnan(a)) else math.nan
        )
    return Section("Optimal-control reference (best-known hop plans)", md, [], headline)


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="3 targets, a short search")
    args = ap.parse_args(argv)
    sec = run(quick=args.quick, fig_dir=tempfile.mkdtemp())
    print(sec.markdown)
    return sec


if __name__ == "__main__":
    main()
