"""Reset and autoreset of a vector env, per rover (docs/changelog.md, "Counter draws").

    python -m benchmarks.bench_reset [--n 4096] [--env HopRover-v0] [--reps 15]
                                     [--threads auto|on|off]

Prints one JSON line: the median over `reps` of reset(seed=0) of n rovers, of a step of
n rovers (small random torques), and of a step in which every rover autoresets (NextStep:
the step resets them and moves none), each in microseconds per rover. Runs on any
version of the package (it uses only the public API and the NextStep flags), so that
two checkouts can be compared in alternating runs.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=4096)
    ap.add_argument("--env", default="HopRover-v0")
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--threads", choices=["auto", "on", "off"], default="auto")
    args = ap.parse_args(argv)
    import hoprover_env  # noqa: F401
    from hoprover_env.envs.registry import vector_env_class

    n = args.n
    threads = {"auto": None, "on": True, "off": False}[args.threads]
    venv = vector_env_class(args.env)(n, threads=threads)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-0.05, 0.05, (n, venv.single_action_space.shape[0]))
    venv.step(acts)
    reset, step, auto = [], [], []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        venv.reset(seed=0)
        reset.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        venv.step(acts)
        step.append(time.perf_counter() - t0)
        venv._autoreset[:] = True  # every rover ended in the last step
        t0 = time.perf_counter()
        venv.step(acts)
        auto.append(time.perf_counter() - t0)
    us = lambda v: round(float(np.median(v)) / n * 1e6, 3)  # noqa: E731
    print(
        json.dumps(
            {
                "env": args.env,
                "n": n,
                "threads": args.threads,
                "reset_us_per_rover": us(reset),
                "step_us_per_rover": us(step),
                "autoreset_step_us_per_rover": us(auto),
                "file": hoprover_env.__file__,
            }
        )
    )


if __name__ == "__main__":
    main()
