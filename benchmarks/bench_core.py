"""Core benchmark: wall time per simulated 600 s, event vs Euler, and compile time.

    python -m benchmarks.bench_core [--repeat 5]

The same scripted hop sequence (benchmarks/scenarios.py: launch, attitude hold in
flight, bounces, slides, rest, repeat) drives every integrator, closed loop through the
contest controller interface. A second table replays the event run's torques open loop,
timing the kernel alone. Ratios are against `event`, from this one run. Compile time
is measured in fresh subprocesses: cold (empty numba cache) and cached.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from numba import njit

from benchmarks.scenarios import HopSequence, hop_schedule
from hoprover_env import RoverParams, core, simulate
from hoprover_env.simulate import make_options, make_state
from hoprover_env._jitcache import drop_stale_cache

drop_stale_cache(__file__)      # the jitted drivers below embed the core's code

RUNS = [("event", {}), ("euler dt=1e-3", {"integrator": "euler", "euler_dt": 1e-3}),
        ("euler dt=1e-4", {"integrator": "euler", "euler_dt": 1e-4})]

FIRST_CALL = ("import time; t0 = time.perf_counter(); import numpy as np; "
              "from hoprover_env import simulate; t1 = time.perf_counter(); "
              "simulate(np.zeros(3), t_end=3.0, control_dt=1.0); "
              "print(t1 - t0, time.perf_counter() - t1)")


@njit(cache=True, error_model="numpy", _nrt=False)
def replay(S, P, O, torques, control_dt, ev, W):
    """Hold torques[k] on [k dt, (k+1) dt): the kernel alone, no Python per step."""
    for k in range(torques.shape[0]):
        core.advance(S, P, O, torques[k], (k + 1) * control_dt, ev, W)
        if S[core.S_BROKEN] != 0.0:
            break


def kernel_replay(sched, control_dt, integrator="event", euler_dt=1e-3):
    p = RoverParams()
    s = make_state(p, 0.0)
    replay(s, p.as_array(), make_options(integrator, "contest", 1e-11, euler_dt), sched,
           control_dt, np.zeros((0, core.EV_COLS)), np.zeros(core.N_WORK))
    return s


def best_time(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def compile_times():
    """(import s, first simulate s) in a fresh interpreter: cold cache, then cached."""
    res = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "cached"):
            out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env,
                                 capture_output=True, text=True, check=True).stdout.split()
            res[label] = tuple(float(v) for v in out)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=600.0)
    ap.add_argument("--no-compile", action="store_true", help="skip the compile timing")
    args = ap.parse_args(argv)

    simulate(np.zeros(2), t_end=1.0)                      # warm (compiled or cached)
    print(f"# bench_core: {args.t_end:g} s simulated per run, best of {args.repeat}\n")
    print("closed loop (HopSequence controller through the contest interface):")
    print(f"{'integrator':<16}{'wall s':>10}{'x event':>10}{'events':>8}"
          f"{'hops':>6}{'final x':>10}")
    base = None
    for name, kw in RUNS:
        ctrl = HopSequence()

        def run():
            ctrl.reset()
            return simulate(ctrl, t_end=args.t_end, control_dt=0.1, target_x=0.0, **kw)

        wall, roll = best_time(run, args.repeat)
        base = base or wall
        hops = sum(1 for e in roll.events if e[1] == "liftoff")
        print(f"{name:<16}{wall:>10.4f}{wall / base:>10.1f}{roll.n_events:>8}{hops:>6}"
              f"{roll.x[-1]:>10.4f}")

    sched = hop_schedule(0.1, args.t_end)
    print("\nopen loop (the event run's torques replayed by a jitted loop: the kernel alone):")
    print(f"{'integrator':<16}{'wall s':>10}{'x event':>10}{'final x':>10}")
    base = None
    for name, kw in RUNS:
        wall, s = best_time(lambda: kernel_replay(sched, 0.1, kw.get("integrator", "event"),
                                                  kw.get("euler_dt", 1e-3)), args.repeat)
        base = base or wall
        print(f"{name:<16}{wall:>10.5f}{wall / base:>10.1f}{s[core.S_X]:>10.4f}")

    if not args.no_compile:
        ct = compile_times()
        print("\nnumba compile (fresh interpreter; import, then first simulate call):")
        for label, (imp, first) in ct.items():
            print(f"  {label:<7} import {imp:6.2f} s   first simulate {first:6.2f} s")


if __name__ == "__main__":
    main()
