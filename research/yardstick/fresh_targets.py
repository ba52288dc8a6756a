"""A policy against a reference agent on targets nobody chose anything on: a hidden
check, reproducible.

The frozen suites (hoprover_env.evaluation.suites) are what every table in BENCHMARKS.md is
measured on, and so what networks get chosen on; a policy that is within 5 % of the
best-known plans there can still be far from them on other targets (the band's edge is
a few millimetres wide). This driver draws fresh targets from a seed, `n` uniform over
HopRover-v0's target range and `edge` more at 0.1-0.125 m on either side (where the
nudges are), flies the policy and a reference on each, and reports per target the
ratio policy TTRTP / reference TTRTP (a miss is inf). Targets that start in the band
count as the suites count them: staying still takes the judge's 5 s, and a policy that
tips the rover out of the band is slower than that:

    python -m research.yardstick.fresh_targets --policy plan_clone --seed 9001
    python -m research.yardstick.fresh_targets --policy plan_clone --seed 9001 \\
        --reference-table runs/plan_table/table_nudge.npz --out fresh.json

The reference is `mpc` (the planning agent) or, with
`--reference-table`, the plan-table teacher of that table (research/plan_clone/plan_table.py, within
0.1 % of the suites' references at the median). Use a seed you have not chosen
anything on, once.

With `--task terrain` the episodes are drawn as the terrain suite's are (a target, a
slope from U(-0.2, 0.2) rad and its own bumps at roughness 0.05 rad each; no edge
targets), and the policy acts in its own task (the terrain policy sees the slope):

    python -m research.yardstick.fresh_targets --task terrain --policy terrain --seed 4242 --n 200
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

EDGE = (0.1, 0.125)  # m: the band's edge (research.plan_clone.plan_table.BAND_EDGE) and beyond


def draw(seed: int, n: int, edge: int) -> np.ndarray:
    """`n` targets uniform in HopRover-v0's target range, then `edge` at EDGE m on
    either side (sign drawn), from `seed`."""
    from hoprover_env.tasks.config import EnvConfig

    lo, hi = EnvConfig().target_range
    rng = np.random.default_rng(seed)
    return np.concatenate(
        [rng.uniform(lo, hi, n), rng.uniform(*EDGE, edge) * rng.choice([-1.0, 1.0], edge)]
    )


def draw_terrain(seed: int, n: int) -> dict:
    """`n` episodes drawn as the terrain suite's are, from `seed`: {"targets",
    "terrain": run_episodes' per-episode ground}."""
    from hoprover_env.evaluation.suites import draw_episodes

    cols = draw_episodes("terrain", seed=seed, n=n)
    return {
        "targets": cols["target_x"],
        "terrain": {k: cols[k] for k in ("slope", "roughness", "terrain_seed")},
    }


def times(policy, targets: np.ndarray, terrain: dict | None = None) -> np.ndarray:
    """TTRTP [s] of `policy` on each target (on `terrain`'s ground per episode, if
    given) at its own control period (inf: missed)."""
    from hoprover_env.evaluation.episodes import run_episodes

    res = run_episodes(policy, targets, {"control_dt": 0.5}, terrain=terrain)
    return np.array([r.ttrtp if r.success else np.inf for r in res])


def summarise(targets, t_policy, t_reference, bound: float = 1.30) -> dict:
    """Success rates, ratios over every target and the targets above `bound`: the
    ratio is inf where the policy misses and the reference does not, and 1 where both
    miss (or take the same time); `in_band` counts the targets that start in the band."""
    from research.plan_clone.plan_table import BAND_EDGE

    targets, tp, tr = (np.asarray(a, dtype=float) for a in (targets, t_policy, t_reference))
    with np.errstate(invalid="ignore", divide="ignore"):  # inf / inf, percentiles over inf
        ratio = np.where(tp == tr, 1.0, tp / tr)
        p99 = float(np.percentile(ratio, 99)) if len(ratio) else float("nan")
    above = np.flatnonzero(ratio > bound)
    worst = above[np.argsort(-ratio[above])]
    return {
        "targets": int(len(targets)),
        "in_band": int((np.abs(targets) <= BAND_EDGE).sum()),
        "policy_success": float(np.isfinite(tp).mean()),
        "reference_success": float(np.isfinite(tr).mean()),
        "median_ratio": float(np.median(ratio)) if len(ratio) else float("nan"),
        "p99_ratio": p99,
        "worst_ratio": float(ratio.max()) if len(ratio) else float("nan"),
        "bound": bound,
        "above_bound": int(len(above)),
        "worst": [
            {
                "target": float(targets[i]),
                "ratio": float(ratio[i]),
                "policy": float(tp[i]),
                "reference": float(tr[i]),
            }
            for i in worst[:20]
        ],
    }


def report(name: str, s: dict, log=print) -> None:
    log(
        f"{name}: {s['targets']} targets ({s['in_band']} in the band at the start), success "
        f"{100 * s['policy_success']:.1f} % (reference {100 * s['reference_success']:.1f} "
        f"%), ratio median {s['median_ratio']:.4f}, p99 {s['p99_ratio']:.3f}, worst "
        f"{s['worst_ratio']:.3f}; {s['above_bound']} above {s['bound']}"
    )
    if s["worst"]:
        log(
            "  above the bound: "
            + " ".join(
                f"{w['target']:+.4f} m {w['ratio']:.2f} ({w['policy']:.0f}/{w['reference']:.0f} s)"
                for w in s["worst"]
            )
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--policy", required=True, help="a name or path load_policy reads")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument(
        "--task",
        choices=("level", "terrain"),
        default="level",
        help="level ground (HopRover-v0) or the terrain suite's grounds",
    )
    ap.add_argument("--n", type=int, default=1000, help="targets uniform in the range")
    ap.add_argument(
        "--edge",
        type=int,
        default=None,
        help="targets at 0.1-0.125 m (default 100 on level ground; none on terrain)",
    )
    ap.add_argument(
        "--reference-table",
        default=None,
        help="the plan-table teacher of this table as the reference (default: mpc)",
    )
    ap.add_argument("--bound", type=float, default=1.30)
    ap.add_argument("--out", default=None, help="write the per-target times (JSON)")
    args = ap.parse_args(argv)
    from research.plan_clone.gated import load_any as load_policy  # a research .pt too

    if args.edge is None:
        args.edge = 100 if args.task == "level" else 0
    if args.task == "terrain" and args.edge:
        ap.error("--edge is for level ground: the terrain episodes are drawn as its suite's")
    if args.n < 0 or args.edge < 0 or args.n + args.edge == 0:
        ap.error("--n and --edge must be >= 0 and not both 0")
    try:
        policy = load_policy(args.policy)
        if args.reference_table:
            from research.plan_clone.plan_table import PlanTableTeacher, load_table

            reference = PlanTableTeacher(load_table(args.reference_table))
        else:
            reference = load_policy("mpc")
    except (FileNotFoundError, ValueError, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    terrain = None
    if args.task == "terrain":
        episodes = draw_terrain(args.seed, args.n)
        targets, terrain = episodes["targets"], episodes["terrain"]
    else:
        targets = draw(args.seed, args.n, args.edge)
    tp, tr = times(policy, targets, terrain), times(reference, targets, terrain)
    parts = {"uniform": slice(0, args.n), "edge": slice(args.n, None)}
    out = {
        name: summarise(targets[s], tp[s], tr[s], args.bound)
        for name, s in parts.items()
        if len(targets[s])
    }
    for name, s in out.items():
        report(name, s)
    if args.out:
        from hoprover_env.util.files import write_json

        write_json(
            args.out,
            {
                "policy": args.policy,
                "seed": args.seed,
                "task": args.task,
                "reference": args.reference_table or "mpc",
                "targets": targets.tolist(),
                "policy_ttrtp": tp.tolist(),
                "reference_ttrtp": tr.tolist(),
                **out,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
