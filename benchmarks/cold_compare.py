"""The cold first step (or first simulate) of several checkouts or settings, in
alternating fresh interpreters.

    git worktree add ../hoprover-old d9bab3a
    python -m benchmarks.cold_compare ../hoprover-old . --rounds 5
    python -m benchmarks.cold_compare ../hoprover-old . --rounds 4 --one-process
    python -m benchmarks.cold_compare ../hoprover-old . --rounds 3 --what step simulate
    python -m benchmarks.cold_compare .:HOPROVER_PARALLEL_COMPILE=0 . --rounds 3

Each argument is a checkout, optionally followed by ``:VAR=VALUE,VAR=VALUE`` settings
for its runs (every other HOPROVER_* variable of this shell is left out, so a checkout
runs with its defaults unless told otherwise). Each run is a fresh interpreter with the
checkout first on PYTHONPATH and an empty NUMBA_CACHE_DIR (a new temporary directory
per run), timed from just before the interpreter starts to the end of the workload:

* ``step``: ``import hoprover_env``, ``gym.make("HopRover-v0")`` + reset, the first
  ``env.step`` returning (bench_env's first-step script);
* ``simulate``: ``import hoprover_env``, the first ``simulate`` of a torque schedule
  returning its result.

The same cache is then used once more for the cached time. The settings take turns run
by run (the order flips every round), because a VM's speed drifts by tens of per cent
between minutes; the ratios of each round's pair are what to compare. --one-process
turns the parallel-compile helper off (HOPROVER_PARALLEL_COMPILE=0).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

from benchmarks.bench_env import SINGLE_FIRST_STEP

# the workloads, and the scripts that time them: each prints the clock when it ends
WORKLOADS = {
    "step": SINGLE_FIRST_STEP,
    "simulate": (
        "import hoprover_env\n"
        "roll = hoprover_env.simulate([3e-4, 0.0, 0.0], t_end=30.0, control_dt=0.5)\n"
    ),
}
SCRIPTS = {what: w + "import time as _t; print(_t.time())\n" for what, w in WORKLOADS.items()}
SCRIPT = SCRIPTS["step"]


def parse(spec: str) -> tuple[str, dict]:
    """(checkout, settings) of an argument ``PATH[:VAR=VALUE,...]``."""
    tree, _, settings = spec.partition(":")
    env = dict(item.split("=", 1) for item in settings.split(",") if item)
    return tree, env


CPU = {}  # run -> CPU s of the interpreter and its helper (information only)


def run_once(tree: str, settings: dict, what: str, cache: str) -> float:
    """Seconds from the start of a fresh interpreter to the end of workload `what`."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("HOPROVER_")}
    env.update(settings, NUMBA_CACHE_DIR=cache, PYTHONPATH=os.path.abspath(tree))
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.time()
    out = subprocess.run(
        [sys.executable, "-c", SCRIPTS[what]],
        env=env,
        cwd=tree,
        check=True,
        capture_output=True,
        text=True,
    )
    wall = float(out.stdout.split()[-1]) - start
    now = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU[wall] = now.ru_utime + now.ru_stime - used.ru_utime - used.ru_stime
    return wall


def first_step(
    tree: str, parallel: bool, what: str = "step", settings: dict | None = None
) -> tuple[float, float]:
    """(cold s, cached s) of one fresh interpreter each, for the checkout at `tree`."""
    settings = dict(settings or {})
    if not parallel:
        settings["HOPROVER_PARALLEL_COMPILE"] = "0"
    with tempfile.TemporaryDirectory() as cache:
        return tuple(run_once(tree, settings, what, cache) for _ in range(2))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "trees",
        nargs="+",
        help="checkouts to compare (the first is the base), each optionally PATH:VAR=VALUE,...",
    )
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--one-process", action="store_true")
    ap.add_argument("--what", nargs="+", choices=sorted(SCRIPTS), default=["step"])
    args = ap.parse_args(argv)
    for what in args.what:
        runs = {t: [] for t in args.trees}
        for r in range(args.rounds):
            for spec in args.trees if r % 2 == 0 else args.trees[::-1]:
                tree, settings = parse(spec)
                runs[spec].append(first_step(tree, not args.one_process, what, settings))
                cold, cached = runs[spec][-1]
                print(
                    f"{what} round {r}: {spec}: cold {cold:.2f} s, cached {cached:.2f} s "
                    f"(CPU {CPU[cold]:.1f} s, {CPU[cached]:.1f} s)",
                    flush=True,
                )
        base = [c for c, _ in runs[args.trees[0]]]
        for spec, rs in runs.items():
            cold = [c for c, _ in rs]
            ratios = [c / b for c, b in zip(cold, base)]
            cached = statistics.median(w for _, w in rs)
            print(
                f"{what}: {spec}: cold {min(cold):.2f}-{max(cold):.2f} s (median "
                f"{statistics.median(cold):.2f}), cached {cached:.2f} s, x base per round "
                f"{min(ratios):.3f}-{max(ratios):.3f} (median "
                f"{statistics.median(ratios):.3f}); runs "
                f"{', '.join(f'{c:.2f}' for c in cold)} s",
                flush=True,
            )


if __name__ == "__main__":
    main()
