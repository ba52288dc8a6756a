"""Core benchmark: wall time per simulated 600 s, event vs Euler, and compile time.

    python -m benchmarks.bench_core [--repeat 5]

The same scripted hop sequence (benchmarks/scenarios.py: launch, attitude hold in
flight, bounces, slides, rest, repeat) drives every integrator, closed loop through the
contest controller interface (a Python controller: `simulate` runs its Python loop).
The next tables replay closed-loop torque schedules through `simulate()` (the whole run
in one kernel call), through a jitted loop of `core.advance` (the kernel alone), run a
numba-compiled hop plan (hoprover_env/agents/compiled.py) inside the kernel against its Python twin,
and time `simulate_batch` against a Python loop over `simulate` on 1 and all threads.
Ratios are within this one run. Compile time is measured in fresh subprocesses: cold
(empty numba cache) and cached.
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numba
import numpy as np
from numba import njit

from benchmarks.report import best_of
from benchmarks.scenarios import HopSequence, hop_schedule
from hoprover_env import RoverParams, core, simulate, simulate_batch
from hoprover_env.agents.compiled import hop_plan, plan_torque
from hoprover_env.sim.simulate import make_options, make_state

RUNS = [
    ("event", {}),
    ("euler dt=1e-3", {"integrator": "euler", "euler_dt": 1e-3}),
    ("euler dt=1e-4", {"integrator": "euler", "euler_dt": 1e-4}),
]

FIRST_CALL = (
    "import time; t0 = time.perf_counter(); import numpy as np; "
    "from hoprover_env import simulate; t1 = time.perf_counter(); "
    "simulate(np.zeros(3), t_end=3.0, control_dt=1.0); "
    "print(t1 - t0, time.perf_counter() - t1)"
)


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
    replay(
        s,
        p.as_array(),
        make_options(integrator, "contest", 1e-11, euler_dt),
        sched,
        control_dt,
        np.zeros((0, core.EV_COLS)),
        np.zeros(core.N_WORK),
    )
    return s


def closed_loop_schedules(control_dt=0.1, t_end=600.0):
    """Torque schedules recorded from closed-loop HopSequence runs (three torque cycles)."""
    out = []
    for torques in ((3e-4, 1.5e-4, 4e-4, 2e-4), (2e-4, 5e-4), (1e-4, 3.5e-4, 2.5e-4)):
        roll = simulate(HopSequence(torques), t_end=t_end, control_dt=control_dt, target_x=0.0)
        out.append(np.asarray(roll.torque_cmd[:-1]))
    return out


def schedule_table(scheds, t_end, repeat):
    """simulate(schedule) per episode for each integrator (mean over the schedules)."""
    print(
        f"\nsimulate() with a torque schedule ({len(scheds)} closed-loop schedules "
        "recorded from HopSequence variants, replayed; the whole run in one kernel call):"
    )
    print(f"{'integrator':<16}{'ms/episode':>12}{'x event':>10}{'events':>8}")
    base, out = None, {}
    for name, kw in RUNS:
        simulate(scheds[0][:10], t_end=1.0, control_dt=0.1, **kw)  # load the kernel
        walls, events = [], 0
        for sched in scheds:
            wall, roll = best_of(
                lambda sched=sched, kw=kw: simulate(
                    sched, t_end=t_end, control_dt=0.1, target_x=0.0, **kw
                ),
                repeat,
            )
            walls.append(wall)
            events += roll.n_events
        wall = float(np.mean(walls))
        base = base or wall
        out[name] = wall
        print(f"{name:<16}{wall * 1e3:>12.3f}{wall / base:>10.1f}{events / len(scheds):>8.0f}")
    return out


# one hop toward x = 0.5: launch torque 2e-4 N m for up to 4 s, PD hold in flight
BENCH_PLAN = (0.0017, 0.15, 0.9, 0.0, 4.0, 2e-4)


def compiled_controller_table(t_end, repeat):
    """The same hop plan as a numba-compiled controller (inside the kernel loop) and as a
    Python controller (simulate's Python loop), event integrator."""
    compiled = hop_plan(BENCH_PLAN)
    plan = np.array(BENCH_PLAN)

    def python_twin(pos, vel, the, omg, posT, t, smt, state):
        return plan_torque.py_func(plan, the, omg, t, core.MODE_LETTERS.index(state))

    simulate(compiled, t_end=1.0)  # compile the controller
    res = {}
    print("\ncontroller (a hop plan: launch windows, PD attitude hold in flight; event):")
    print(f"{'controller':<28}{'ms/episode':>12}{'x compiled':>12}{'TTRTP':>10}")
    for name, ctrl in (("numba-compiled, in kernel", compiled), ("Python twin", python_twin)):
        wall, roll = best_of(
            lambda ctrl=ctrl: simulate(ctrl, t_end=t_end, control_dt=0.1, target_x=0.5), repeat
        )
        res[name] = (wall, roll)
    base = res["numba-compiled, in kernel"][0]
    assert np.array_equal(res["Python twin"][1].x, res["numba-compiled, in kernel"][1].x)
    for name, (wall, roll) in res.items():
        ttrtp = roll.ttrtp if roll.ttrtp is not None else float("nan")
        print(f"{name:<28}{wall * 1e3:>12.3f}{wall / base:>12.1f}{ttrtp:>10.2f}")
    return {k: v[0] for k, v in res.items()}


def batch_table(scheds, t_end, n_runs, repeat):
    """Episodes per second: a Python loop over simulate(schedule) and simulate_batch on 1
    thread and on all of numba's threads (same N episodes)."""
    rng = np.random.default_rng(0)
    sched = np.array([scheds[i % len(scheds)] for i in range(n_runs)])
    targets = rng.uniform(-1, 1, n_runs)

    def loop():
        return [
            simulate(sched[i], t_end=t_end, control_dt=0.1, target_x=targets[i]).ttrtp
            for i in range(n_runs)
        ]

    def batch():
        return simulate_batch(sched, targets, t_end=t_end, control_dt=0.1, record=False)

    before = numba.get_num_threads()
    rows = [("Python loop over simulate", best_of(loop, repeat)[0])]
    try:
        for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(threads)
            batch()  # compile / warm
            rows.append(
                (
                    f"simulate_batch, {threads} thread{'s' * (threads > 1)}",
                    best_of(batch, repeat)[0],
                )
            )
    finally:
        numba.set_num_threads(before)
    print(f"\nbatch: {n_runs} episodes of {t_end:g} s at control_dt 0.1 (event):")
    print(f"{'':<30}{'episodes/s':>12}{'x loop':>10}")
    base = rows[0][1]
    for name, wall in rows:
        print(f"{name:<30}{n_runs / wall:>12.0f}{base / wall:>10.2f}")
    return {name: n_runs / wall for name, wall in rows}


def compile_times():
    """(import s, first simulate s) in a fresh interpreter: cold cache, then cached."""
    res = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "cached"):
            out = subprocess.run(
                [sys.executable, "-c", FIRST_CALL],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout.split()
            res[label] = tuple(float(v) for v in out)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=600.0)
    ap.add_argument("--no-compile", action="store_true", help="skip the compile timing")
    ap.add_argument("--batch", type=int, default=64, help="episodes in the batch table")
    args = ap.parse_args(argv)

    simulate(np.zeros(2), t_end=1.0)  # warm (compiled or cached)
    print(f"# bench_core: {args.t_end:g} s simulated per run, best of {args.repeat}\n")
    print("closed loop (HopSequence controller through the contest interface):")
    print(f"{'integrator':<16}{'wall s':>10}{'x event':>10}{'events':>8}{'hops':>6}{'final x':>10}")
    base = None
    for name, kw in RUNS:
        ctrl = HopSequence()

        def run(ctrl=ctrl, kw=kw):
            ctrl.reset()
            return simulate(ctrl, t_end=args.t_end, control_dt=0.1, target_x=0.0, **kw)

        wall, roll = best_of(run, args.repeat)
        base = base or wall
        hops = sum(1 for e in roll.events if e[1] == "liftoff")
        print(
            f"{name:<16}{wall:>10.4f}{wall / base:>10.1f}{roll.n_events:>8}{hops:>6}"
            f"{roll.x[-1]:>10.4f}"
        )

    scheds = closed_loop_schedules(0.1, args.t_end)
    walls = schedule_table(scheds, args.t_end, args.repeat)
    print(
        f"euler dt=1e-4 / event through simulate(): "
        f"{walls['euler dt=1e-4'] / walls['event']:.0f}x; event "
        f"{walls['event'] * 1e3:.2f} ms per {args.t_end:g} s episode"
    )
    compiled_controller_table(args.t_end, args.repeat)
    batch_table(scheds, args.t_end, args.batch, args.repeat)

    sched = hop_schedule(0.1, args.t_end)
    print("\nopen loop (the event run's torques replayed by a jitted loop: the kernel alone):")
    print(f"{'integrator':<16}{'wall s':>10}{'x event':>10}{'final x':>10}")
    base = None
    for name, kw in RUNS:
        wall, s = best_of(
            lambda kw=kw: kernel_replay(
                sched, 0.1, kw.get("integrator", "event"), kw.get("euler_dt", 1e-3)
            ),
            args.repeat,
        )
        base = base or wall
        print(f"{name:<16}{wall:>10.5f}{wall / base:>10.1f}{s[core.S_X]:>10.4f}")

    if not args.no_compile:
        ct = compile_times()
        print("\nnumba compile (fresh interpreter; import, then first simulate call):")
        for label, (imp, first) in ct.items():
            print(f"  {label:<7} import {imp:6.2f} s   first simulate {first:6.2f} s")


if __name__ == "__main__":
    main()
