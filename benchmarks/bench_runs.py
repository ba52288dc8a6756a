"""Whole runs in the kernel: simulate() speed, compiled controllers, batches, cold start.

    python -m benchmarks.bench_runs [--quick]

* `simulate()` with closed-loop torque schedules (recorded from HopSequence variants,
  benchmarks/bench_core.py): event against euler at dt 1e-3 and 1e-4, ms per episode;
* a hop plan as a numba-compiled controller (inside the kernel loop) against the same
  plan as a Python controller;
* `simulate_batch` episodes per second against a Python loop over `simulate`, on 1 and
  on all of numba's threads;
* the cold start, per jitted function: a fresh interpreter with an empty numba cache
  runs `import hoprover_env`, `gym.make` + `reset` and the first `env.step`, timing every
  compilation with numba's event API ("numba:compile"; exclusive = minus the callees
  compiled inside it), then the same with the cache warm; all in one process
  (HOPROVER_PARALLEL_COMPILE=0);
* the cold wall time to the first step with the parallel-compile helper (the default)
  and without it, in alternating runs.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

import numba
import numpy as np

from benchmarks import bench_core
from benchmarks.report import Section, table

COLD_SCRIPT = r"""
import json, sys, time
from numba.core import event as ev
stack, records = [], []

class L(ev.Listener):
    def on_start(self, e):
        d = e.data.get("dispatcher")
        f = getattr(d, "py_func", None)
        name = f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', d)}"
        stack.append([name, time.process_time(), 0.0])

    def on_end(self, e):
        name, t0, child = stack.pop()
        dt = time.process_time() - t0
        if stack:
            stack[-1][2] += dt
        records.append((name, dt, dt - child))

ev.register("numba:compile", L())
phases = []
def mark(label, c0, w0):
    phases.append((label, time.process_time() - c0, time.perf_counter() - w0))
c0, w0 = time.process_time(), time.perf_counter()
import numpy as np
import hoprover_env
mark("import hoprover_env", c0, w0)
if sys.argv[1] == "step":
    import gymnasium as gym
    c0, w0 = time.process_time(), time.perf_counter()
    env = gym.make("HopRover-v0"); env.reset(seed=0)
    mark("gym.make + reset", c0, w0)
    c0, w0 = time.process_time(), time.perf_counter()
    env.step(np.array([0.5], np.float32))
    mark("first env.step", c0, w0)
print(json.dumps({"phases": phases, "records": records}))
"""


def cold_start(what: str = "step", parallel: bool = False, warm: bool = True) -> dict:
    """Phases and per-function compile times (of this process; the parallel-compile
    helper's are not seen), cold (empty numba cache), then warm unless warm=False."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(
            os.environ, NUMBA_CACHE_DIR=cache, HOPROVER_PARALLEL_COMPILE="1" if parallel else "0"
        )
        for label in ("cold", "warm") if warm else ("cold",):
            res = subprocess.run(
                [sys.executable, "-c", COLD_SCRIPT, what],
                env=env,
                check=True,
                capture_output=True,
                text=True,
            )
            out[label] = json.loads(res.stdout.strip().splitlines()[-1])
    return out


def cold_walls(pairs: int) -> dict:
    """Cold wall time to the first env.step, with and without the parallel-compile
    helper, in alternating fresh interpreters (the host's load drifts)."""
    walls = {"two processes (default)": [], "one process": []}
    for _ in range(pairs):
        for label, parallel in (("two processes (default)", True), ("one process", False)):
            cold = cold_start("step", parallel, warm=False)["cold"]
            walls[label].append(sum(p[2] for p in cold["phases"]))
    return walls


def per_function(records) -> list:
    """[(function, compilations, exclusive s, inclusive s)], most expensive first."""
    agg = {}
    for name, incl, excl in records:
        a = agg.setdefault(name, [0, 0.0, 0.0])
        a[0] += 1
        a[1] += excl
        a[2] = max(a[2], incl)
    return sorted(([k, *v] for k, v in agg.items()), key=lambda r: -r[2])


def cold_markdown(cs: dict, top: int) -> tuple[str, dict]:
    cold, warm = cs["cold"], cs["warm"]
    phases = [
        [label, c, w, wc, ww] for (label, c, w), (_, wc, ww) in zip(cold["phases"], warm["phases"])
    ]
    total = [sum(p[i] for p in phases) for i in (1, 2, 3, 4)]
    phases.append(["total", *total])
    funcs = per_function(cold["records"])
    modules = {}
    for name, n, excl, _ in funcs:
        mod = name.rsplit(".", 1)[0] if name.startswith("hoprover_env.") else "numba internals"
        m = modules.setdefault(mod, [0, 0, 0.0])
        m[0] += 1
        m[1] += n
        m[2] += excl
    twice = [f for f in funcs if f[1] > 1 and f[0].startswith("hoprover_env.")]
    md = "\n\n".join(
        [
            table(
                ["phase", "cold CPU s", "cold wall s", "warm CPU s", "warm wall s"],
                phases,
                {c: ".2f" for c in ("cold CPU s", "cold wall s", "warm CPU s", "warm wall s")},
            ),
            "Compile time per module (cold; exclusive CPU seconds, summed over its functions):",
            table(
                ["module", "functions", "compilations", "exclusive CPU s"],
                [[k, *v] for k, v in sorted(modules.items(), key=lambda kv: -kv[1][2])],
                {"exclusive CPU s": ".2f"},
            ),
            f"The {top} most expensive compilations (exclusive: without the callees compiled "
            "inside; inclusive: with them):",
            table(
                ["function", "compilations", "exclusive CPU s", "inclusive CPU s"],
                [[f"`{n}`", c, e, i] for n, c, e, i in funcs[:top]],
                {"exclusive CPU s": ".2f", "inclusive CPU s": ".2f"},
            ),
            (
                "Functions of this package compiled more than once: "
                + (", ".join(f"`{f[0]}` ({f[1]}x)" for f in twice) if twice else "none")
                + "."
            ),
        ]
    )
    return md, {
        "cold_first_step_cpu_s": total[0],
        "cold_first_step_wall_s": total[1],
        "warm_first_step_wall_s": total[3],
        "compiled_functions": len(funcs),
    }


def run(quick: bool = False, fig_dir: str = "benchmarks/figures") -> Section:
    t_end = 120.0 if quick else 600.0
    repeat = 1 if quick else 3
    scheds = bench_core.closed_loop_schedules(0.1, t_end)
    walls = bench_core.schedule_table(scheds, t_end, repeat)
    ctrl = bench_core.compiled_controller_table(t_end, repeat)
    n_batch = 16 if quick else 256
    batch = bench_core.batch_table(scheds, t_end, n_batch, repeat)
    cs = cold_start("import" if quick else "step")
    cold_md, cold_head = cold_markdown(cs, 8 if quick else 15)
    cold = cold_walls(0 if quick else 3)
    ev = walls["event"]
    md = "\n\n".join(
        [
            f"`simulate()` with a torque schedule runs the whole episode in one kernel call "
            f"(`hoprover_env/sim/control_loop.py`). Schedules: {len(scheds)} closed-loop "
            f"HopSequence runs recorded and replayed, {t_end:g} s episodes at control_dt "
            f"0.1 s, best of {repeat}, mean over the schedules:",
            table(
                ["integrator", "ms per episode", "x event"],
                [[k, v * 1e3, v / ev] for k, v in walls.items()],
                {"ms per episode": ".3f", "x event": ".1f"},
            ),
            "A numba-compiled contest controller runs inside the same compiled loop "
            "(hoprover_env/agents/compiled.py, a hop plan: launch window, PD attitude hold in "
            "flight); the "
            "same plan as a Python controller runs simulate's Python loop (identical "
            "trajectories, checked):",
            table(
                ["controller", "ms per episode", "x compiled"],
                [[k, v * 1e3, v / ctrl["numba-compiled, in kernel"]] for k, v in ctrl.items()],
                {"ms per episode": ".3f", "x compiled": ".1f"},
            ),
            f"`simulate_batch`: {n_batch} episodes ({t_end:g} s, control_dt 0.1 s, event, "
            f"summaries only) against a Python loop over `simulate` (numba threads available: "
            f"{numba.config.NUMBA_NUM_THREADS}):",
            table(
                ["", "episodes / s", "x loop"],
                [[k, v, v / batch["Python loop over simulate"]] for k, v in batch.items()],
                {"episodes / s": ",.0f", "x loop": ".2f"},
            ),
            "Cold start: a fresh interpreter with an empty numba cache (NUMBA_CACHE_DIR set to "
            "an empty directory), "
            + (
                "`import hoprover_env` only (quick mode)"
                if quick
                else "`import hoprover_env`, `gym.make` + `reset`, the first `env.step`"
            )
            + ", compiling in this one process (HOPROVER_PARALLEL_COMPILE=0); then the same with "
            "the cache it wrote:",
            cold_md,
        ]
        + (
            [
                "Cold wall time to the first `env.step` (import, `gym.make` + `reset`, `step`), by "
                "default (on two or more cores a helper process compiles the contact phases into "
                "the cache meanwhile, hoprover_env/_parallel_compile.py) and in one process, "
                f"{len(cold['one process'])} alternating runs each:",
                table(
                    ["compiled by", "runs (s)", "median s", "x one process"],
                    [
                        [
                            k,
                            " / ".join(f"{w:.2f}" for w in v),
                            float(np.median(v)),
                            float(np.median(v) / np.median(cold["one process"])),
                        ]
                        for k, v in cold.items()
                    ],
                    {"median s": ".2f", "x one process": ".2f"},
                ),
            ]
            if cold["one process"]
            else []
        )
    )
    if cold["one process"]:
        cold_head["cold_first_step_parallel_wall_s"] = float(
            np.median(cold["two processes (default)"])
        )
    headline = {
        "simulate_event_ms": ev * 1e3,
        "euler1e-4_over_event": walls["euler dt=1e-4"] / ev,
        **cold_head,
        **{f"batch_eps_{k}": v for k, v in batch.items()},
    }
    return Section("Whole runs in the kernel: simulate, batches, cold start", md, [], headline)


if __name__ == "__main__":
    sec = run(quick="--quick" in sys.argv, fig_dir=tempfile.mkdtemp())
    print(sec.markdown)
    print(sec.headline)
