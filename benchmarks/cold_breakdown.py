"""Where a cold first step's time goes: numba's Python-side compiler against LLVM.

    python -m benchmarks.cold_breakdown --rounds 2 --what step simulate

Each round is a fresh interpreter with an empty NUMBA_CACHE_DIR and the parallel-compile
helper off (HOPROVER_PARALLEL_COMPILE=0: all of the compile in the one process), running
cold_compare's workload (`step`: import, `gym.make("HopRover-v0")` + reset, the first
`env.step`; `simulate`: the first `simulate`). It listens to numba's own events and
reports the seconds numba held its compiler lock (every compile: bytecode, IR, type
inference, lowering to LLVM IR, LLVM) and, within that, the LLVM lock that llvmlite takes
around every call into LLVM (parsing the IR numba built, optimising it, emitting and
linking machine code), beside the workload's wall and CPU time. What
the compiler lock holds outside the LLVM lock is numba's Python-side work, which fewer
or larger kernels change only as far as they change the code typed and lowered.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

from benchmarks.cold_compare import WORKLOADS

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# a listener of numba's events around a cold-compare workload; prints one JSON line
PROBE = """
import time
from numba.core import event as _ev
_locks = {{"compiler": _ev.RecordingListener(), "llvm": _ev.RecordingListener()}}
_ev.register("numba:compiler_lock", _locks["compiler"])
_ev.register("numba:llvm_lock", _locks["llvm"])
_t0, _c0 = time.perf_counter(), time.process_time()
{workload}
_wall, _cpu = time.perf_counter() - _t0, time.process_time() - _c0
import json
from benchmarks.cold_breakdown import held
print(json.dumps({{"wall": _wall, "cpu": _cpu, **{{k: held(r) for k, r in _locks.items()}}}}))
"""


def held(rec) -> float:
    """Seconds between the outermost start and end events of a RecordingListener."""
    depth, start, total = 0, 0.0, 0.0
    for ts, e in rec.buffer:
        if e.is_start:
            start = ts if depth == 0 else start
            depth += 1
        else:
            depth -= 1
            total += ts - start if depth == 0 else 0.0
    return total


def breakdown(what: str) -> dict:
    """One cold run of workload `what` in a fresh interpreter: wall, CPU, and the seconds
    numba held its compiler and LLVM locks."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("HOPROVER_")}
    with tempfile.TemporaryDirectory() as cache:
        env.update(NUMBA_CACHE_DIR=cache, HOPROVER_PARALLEL_COMPILE="0")
        out = subprocess.run(
            [sys.executable, "-c", PROBE.format(workload=WORKLOADS[what])],
            env=env,
            cwd=ROOT,  # `-c` puts the working directory first on sys.path: the probe imports held
            check=True,
            capture_output=True,
            text=True,
        )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--what", nargs="+", choices=sorted(WORKLOADS), default=["step"])
    args = ap.parse_args(argv)
    for what in args.what:
        for r in range(args.rounds):
            b = breakdown(what)
            rest = b["compiler"] - b["llvm"]
            print(
                f"{what} round {r}: wall {b['wall']:.1f} s, CPU {b['cpu']:.1f} s; compiler "
                f"lock {b['compiler']:.1f} s = numba's Python side {rest:.1f} s "
                f"({100 * rest / b['compiler']:.0f} %) + LLVM {b['llvm']:.1f} s "
                f"({100 * b['llvm'] / b['compiler']:.0f} %)",
                flush=True,
            )


if __name__ == "__main__":
    main()
