"""The cold first step of several checkouts, in alternating fresh interpreters.

    git worktree add /tmp/old d9bab3a
    python -m benchmarks.cold_compare /tmp/old . --rounds 5
    python -m benchmarks.cold_compare /tmp/old . --rounds 4 --one-process

Each run is a fresh interpreter with the checkout first on PYTHONPATH and an empty
NUMBA_CACHE_DIR, timing bench_env's first-step script (import, gym.make("HopRover-v0")
+ reset, the first env.step); the same cache is then used once more for the cached
time. The checkouts take turns run by run (the order flips every round), because a VM's
speed drifts by tens of per cent between minutes; the ratios of each round's pair are
what to compare. --one-process turns the parallel-compile helper off.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

from benchmarks.bench_env import SINGLE_FIRST_STEP

SCRIPT = SINGLE_FIRST_STEP + "print(t1 - t0)\n"


def first_step(tree: str, parallel: bool) -> tuple[float, float]:
    """(cold s, cached s) of one fresh interpreter each, for the checkout at `tree`."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=os.path.abspath(tree),
                   HOPROVER_PARALLEL_COMPILE="1" if parallel else "0")
        return tuple(float(subprocess.run([sys.executable, "-c", SCRIPT], env=env, cwd=tree,
                                          check=True, capture_output=True,
                                          text=True).stdout.split()[-1])
                     for _ in range(2))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trees", nargs="+", help="checkouts to compare (the first is the base)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--one-process", action="store_true")
    args = ap.parse_args(argv)
    runs = {t: [] for t in args.trees}
    for r in range(args.rounds):
        for tree in args.trees if r % 2 == 0 else args.trees[::-1]:
            runs[tree].append(first_step(tree, not args.one_process))
            print(f"round {r}: {tree}: cold {runs[tree][-1][0]:.2f} s, cached "
                  f"{runs[tree][-1][1]:.2f} s", flush=True)
    base = [c for c, _ in runs[args.trees[0]]]
    for tree, rs in runs.items():
        cold = [c for c, _ in rs]
        ratios = [c / b for c, b in zip(cold, base)]
        cached = statistics.median(w for _, w in rs)
        print(f"{tree}: cold {min(cold):.2f}-{max(cold):.2f} s (median "
              f"{statistics.median(cold):.2f}), cached {cached:.2f} s, x base per round "
              f"{min(ratios):.3f}-{max(ratios):.3f} (median {statistics.median(ratios):.3f})")


if __name__ == "__main__":
    main()
