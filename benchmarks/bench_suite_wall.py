"""Wall time of a policy on (a slice of) the HopRover-v0 suite, and a digest of its
results, for comparing two checkouts or worker counts (docs/SCALING.md, "Evaluation and
the planner on every core"):

    PYTHONPATH=. python -m benchmarks.bench_suite_wall --policy mpc [--first 0 --count 100]
    PYTHONPATH=. python -m benchmarks.bench_suite_wall --policy mpc --workers 1

Prints one JSON line: the episodes, the wall time of `suites.run` (the policy loaded and
warmed up on one episode before), mpc's decisions, the successes and a SHA-256 of every
episode's outcome (episode, success, TTRTP, broken, steps, final x): the same digest
means the same results. `--workers` is passed only when given, so the script also runs
on a checkout whose `suites.run` has no such argument.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time


def digest(rows) -> str:
    h = hashlib.sha256()
    for r in rows:
        h.update(
            repr(
                (r["episode"], r["success"], r["ttrtp"], r["broken"], r["steps"], r["final_x"])
            ).encode()
        )
    return h.hexdigest()


def main(argv=None) -> int:
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation import suites

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy", default="mpc")
    ap.add_argument("--first", type=int, default=0, help="first episode of the slice")
    ap.add_argument("--count", type=int, default=None, help="episodes (default: to the end)")
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args(argv)
    suite = suites.load("HopRover-v0")
    end = len(suite) if args.count is None else args.first + args.count
    part = suites.Suite(
        suite.name, suite.version, suite.checksum, suite.episodes[args.first : end], suite.meta
    )
    kw = {} if args.workers is None else {"workers": args.workers}
    warm = suites.Suite(suite.name, suite.version, suite.checksum, suite.episodes[:1], suite.meta)
    suites.run(load_policy(args.policy), warm, **kw)  # compiled, loaded, warm
    policy = load_policy(args.policy)
    t0 = time.perf_counter()
    rows = suites.run(policy, part, **kw)
    wall = time.perf_counter() - t0
    # a slice is run as episodes 0.. of its own: number them as in the whole suite
    for r in rows:
        r["episode"] += args.first
    print(
        json.dumps(
            {
                "policy": args.policy,
                "episodes": [args.first, end],
                "workers": args.workers,
                "wall_s": round(wall, 2),
                "decisions": getattr(policy, "decisions", None),
                "success": sum(bool(r["success"]) for r in rows),
                "digest": digest(rows),
            }
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
