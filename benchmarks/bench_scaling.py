"""The numbers behind docs/SCALING.md: how the simulator uses the cores of one machine,
what one core does, and what Ray costs.

    PYTHONPATH=. python -m benchmarks --only scaling [--quick]     # the report's section
    PYTHONPATH=. python -m benchmarks.bench_scaling --threads [--quick]   # the same, printed
    PYTHONPATH=. python -m benchmarks.bench_scaling [--quick]      # one core, PPO, Ray

The section (`run`) measures fixed work at 1, 2, 4, ... numba threads up to all of this
machine's cores (numba.set_num_threads, restored after): `simulate_batch` runs of 300 s
under sparse random torques (runs/s), the same batch with its second half at rest (the
costly runs grouped together: how evenly the threads share them) and the HopRover-v0
vector env stepped from one reset (steps/s); for each, the speed-up, the parallel
efficiency, the kernel's own speed-up, the speed-up the threads' CPU time implies on
idle cores (`Clock`), and the serial time (Python outside the threaded kernel) per run
and per step, with what Amdahl's law predicts from that serial fraction at 16 and 64
threads. Each thread count is timed `repeat` times, in turn with the others (best
kept), so that a machine shared with other work slows all of them alike.

Without --threads: vector-env steps/s on one core (numba serial), PPO steps/s of one
trial with configs/ppo_scratch.yaml's settings (one torch thread), evaluation episodes/s
on one core (the scripted hopper and the bundled scratch policy), and Ray's overhead: per
task (a no-op task's round trip, tasks in flight together) and per Tune trial (a trial
that reports once and returns). Needs the [ray] extra for the last two.
"""

from __future__ import annotations

import argparse
import json
import os
import threading
import time

import numpy as np

# ---- threads: fixed work at 1, 2, 4, ... threads -------------------------------------------
BATCH_CONTROL_DT = 0.5  # s
BATCH_KICK_RATE = 0.02  # share of control periods with a torque kick
BATCH_KICK_NM = 5e-5  # kicks uniform in +-this [N m]: hops and slides, no breaks
ENV_ACTION = 0.05  # vector env: actions uniform in +-this (of full scale)


def thread_counts() -> list[int]:
    """1, 2, 4, ... up to numba's thread count (all the cores), which ends the list."""
    import numba

    top = numba.config.NUMBA_NUM_THREADS
    out = [1]
    while out[-1] * 2 < top:
        out.append(out[-1] * 2)
    return out + [top] if top > 1 else out


def batch_workload(n: int, t_end: float, seed: int = 0):
    """(schedules, targets) of n runs: zero torque but for kicks in BATCH_KICK_RATE of
    the control periods (about one per 25 s), each held one period."""
    rng = np.random.default_rng(seed)
    k = int(round(t_end / BATCH_CONTROL_DT))
    kicks = rng.random((n, k)) < BATCH_KICK_RATE
    sched = np.where(kicks, rng.uniform(-BATCH_KICK_NM, BATCH_KICK_NM, (n, k)), 0.0)
    return sched, rng.uniform(-1.0, 1.0, n)


def grouped_workload(n: int, t_end: float, seed: int = 0):
    """batch_workload with the second half of the runs at rest (zero torque): the
    costly runs sit together, as the hops of a planner's population or the rovers in
    flight of a vector env do."""
    sched, targets = batch_workload(n, t_end, seed)
    sched[n // 2 :] = 0.0
    return sched, targets


def thread_cpu() -> dict:
    """{thread id: CPU seconds it has run} for this process's threads (Linux: schedstat's
    nanoseconds; elsewhere empty)."""
    out = {}
    try:
        tids = os.listdir("/proc/self/task")
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/schedstat") as fh:
                out[int(tid)] = int(fh.read().split()[0]) * 1e-9
        except (OSError, ValueError, IndexError):
            pass
    return out


class Clock:
    """Wall and CPU time of one piece of work, and of the threaded kernel inside it (wrap
    the kernel with `kernel`). `critical` estimates the wall time the work would take on
    idle cores: the calling thread's CPU time outside the kernel plus the busiest
    thread's CPU time in it (a thread that waits for a core does not count), so that
    the speed-up it implies does not depend on what else the machine runs."""

    def __init__(self):
        self.kernel_wall = self.kernel_cpu = 0.0

    def kernel(self, fn):
        def timed(*args):
            t0, c0 = time.perf_counter(), time.thread_time()
            try:
                return fn(*args)
            finally:
                self.kernel_wall += time.perf_counter() - t0
                self.kernel_cpu += time.thread_time() - c0

        return timed

    def __enter__(self):
        self.threads0 = thread_cpu()
        self.t0, self.c0, self.m0 = time.perf_counter(), time.process_time(), time.thread_time()
        return self

    def __exit__(self, *exc):
        wall, cpu = time.perf_counter() - self.t0, time.process_time() - self.c0
        mine = time.thread_time() - self.m0
        after, me = thread_cpu(), threading.get_native_id()
        others = [after[t] - self.threads0.get(t, 0.0) for t in after if t != me]
        serial_cpu = mine - self.kernel_cpu
        self.result = {
            "wall": wall,
            "cpu": cpu,
            "kernel": self.kernel_wall,
            "serial": wall - self.kernel_wall,
            "serial_cpu": serial_cpu,
            "critical": serial_cpu + max([self.kernel_cpu] + others) if after else float("nan"),
        }


def time_batch(sched, targets, t_end: float, **kw) -> dict:
    """One simulate_batch call (summaries only), timed by a Clock around
    batch._run_threaded (the threaded kernel)."""
    from hoprover_env import simulate_batch
    from hoprover_env.sim import batch

    real = batch._run_threaded
    clock = Clock()
    batch._run_threaded = clock.kernel(real)
    try:
        with clock:
            simulate_batch(
                sched, targets, t_end=t_end, control_dt=BATCH_CONTROL_DT, record=False, **kw
            )
    finally:
        batch._run_threaded = real
    return clock.result


class VectorEnvWork:
    """The same steps of a HopRover-v0 vector env (threaded kernel) each time: reset(seed=0),
    then `steps` steps of fixed random actions, autoresets included."""

    def __init__(self, n: int, steps: int):
        from hoprover_env import HopRoverVectorEnv

        self.n, self.steps = n, steps
        self.env = HopRoverVectorEnv(n, threads=True)
        rng = np.random.default_rng(0)
        self.actions = rng.uniform(-ENV_ACTION, ENV_ACTION, (steps, n, 1))
        self.env.reset(seed=0)
        self.env.step(self.actions[0])  # compiled and warm

    def __call__(self) -> dict:
        env = self.env
        env.reset(seed=0)
        real = env._kernel  # the threaded step, chosen at reset
        clock = Clock()
        env._kernel = clock.kernel(real)
        try:
            with clock:
                for a in self.actions:
                    env.step(a)
        finally:
            env._kernel = real
        return clock.result


def over_threads(work, threads: list[int], repeat: int) -> dict:
    """{threads: the best of `repeat` timings of work()} (the timing with the least wall
    time; its `critical` the least of all), the thread counts timed in turn within each
    round; numba's thread count restored after."""
    import numba

    before = numba.get_num_threads()
    best: dict = {}
    try:
        for _ in range(repeat):
            for t in threads:
                numba.set_num_threads(t)
                r = work()
                if t in best:
                    critical = min(r["critical"], best[t]["critical"])
                    if r["wall"] < best[t]["wall"]:
                        best[t] = r
                    best[t]["critical"] = critical
                else:
                    best[t] = r
    finally:
        numba.set_num_threads(before)
    return best


def _process_worker(n_runs: int, t_end: float, barrier, results) -> None:
    """One of `independent_processes`' processes: warm, wait for the others, time one
    simulate_batch call on one numba thread."""
    import numba

    numba.set_num_threads(1)
    sched, targets = batch_workload(n_runs, t_end)
    time_batch(sched[:8], targets[:8], t_end)
    barrier.wait()
    results.put(time_batch(sched, targets, t_end)["wall"])


def independent_processes(counts: list[int], n_runs: int, t_end: float, repeat: int) -> dict:
    """{p: runs/s of p independent one-thread processes together}: each runs the same
    simulate_batch call at once (started together after warming), so their sum is what
    the machine's cores give work that shares nothing. The best of `repeat` rounds."""
    import multiprocessing as mp

    ctx = mp.get_context("spawn")
    best: dict = {}
    for _ in range(repeat):
        for p in counts:
            barrier, results = ctx.Barrier(p), ctx.Queue()
            procs = [
                ctx.Process(target=_process_worker, args=(n_runs, t_end, barrier, results))
                for _ in range(p)
            ]
            for proc in procs:
                proc.start()
            walls = [results.get() for _ in procs]
            for proc in procs:
                proc.join()
            best[p] = max(best.get(p, 0.0), p * n_runs / max(walls))
    return best


def amdahl(serial_fraction: float, p: int) -> float:
    """The speed-up Amdahl's law gives p threads when serial_fraction of the one-thread
    time cannot be shared."""
    return 1.0 / (serial_fraction + (1.0 - serial_fraction) / p)


def karp_flatt(speedup: float, p: int) -> float:
    """The serial fraction that explains a measured speed-up on p threads (Karp-Flatt):
    everything that did not scale, imbalance and contention included."""
    return (1.0 / speedup - 1.0 / p) / (1.0 - 1.0 / p) if p > 1 else float("nan")


def scaling_rows(best: dict, units: float) -> tuple[list, dict]:
    """Table rows (threads, rate, speed-up, efficiency, kernel speed-up, speed-up on idle
    cores by CPU time, CPU s per wall s) and a summary: the serial fraction at one thread
    and the speed-ups it predicts."""
    one = best[1]
    rows = []
    for t, r in sorted(best.items()):
        s = one["wall"] / r["wall"]
        rows.append(
            [
                t,
                units / r["wall"],
                s,
                s / t,
                one["kernel"] / r["kernel"],
                one["critical"] / r["critical"],
                r["cpu"] / r["wall"],
            ]
        )
    f = one["serial"] / one["wall"]
    top = max(best)
    s_top = one["wall"] / best[top]["wall"]
    return rows, {
        "serial_fraction": f,
        "serial_s": one["serial"],
        "top": top,
        "speedup_top": s_top,
        "karp_flatt_top": karp_flatt(s_top, top),
        "amdahl_16": amdahl(f, 16),
        "amdahl_64": amdahl(f, 64),
    }


def run(quick: bool = False, fig_dir: str = "benchmarks/figures"):
    """The report's section: simulate_batch and the vector env at 1..all threads."""
    import numba

    from benchmarks.report import Section, table

    threads = thread_counts()
    repeat = 2 if quick else 3
    n_runs, t_end = (256, 60.0) if quick else (4096, 300.0)
    n_envs, steps = (256, 20) if quick else (4096, 100)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")

    sched, targets = batch_workload(n_runs, t_end)
    time_batch(sched[:8], targets[:8], t_end)  # compiled and warm
    batch_best = over_threads(lambda: time_batch(sched, targets, t_end), threads, repeat)
    b_rows, b_sum = scaling_rows(batch_best, n_runs)
    g_sched, g_targets = grouped_workload(n_runs, t_end)
    grouped_best = over_threads(lambda: time_batch(g_sched, g_targets, t_end), threads, repeat)
    g_rows, g_sum = scaling_rows(grouped_best, n_runs)
    env_best = over_threads(VectorEnvWork(n_envs, steps), threads, repeat)
    e_rows, e_sum = scaling_rows(env_best, n_envs * steps)
    procs = independent_processes(threads, n_runs, t_end, 1 if quick else repeat)
    p_rows = [[p, rate, rate / procs[1], rate / procs[1] / p] for p, rate in procs.items()]

    fmt = {
        "speed-up": ".2f",
        "efficiency": ".0%",
        "kernel speed-up": ".2f",
        "speed-up by CPU time": ".2f",
        "CPU s / wall s": ".2f",
    }
    head = [
        "threads",
        "runs / s",
        "speed-up",
        "efficiency",
        "kernel speed-up",
        "speed-up by CPU time",
        "CPU s / wall s",
    ]
    b_md = table(head, b_rows, {"runs / s": ",.0f", **fmt})
    g_md = table(head, g_rows, {"runs / s": ",.0f", **fmt})
    e_md = table(["threads", "steps / s"] + head[2:], e_rows, {"steps / s": ",.0f", **fmt})
    summary = table(
        [
            "",
            "serial (outside the kernel), 1 thread",
            "serial fraction f",
            f"speed-up at {b_sum['top']} threads (measured)",
            "Karp-Flatt serial fraction",
            "Amdahl, 16 threads",
            "Amdahl, 64 threads",
        ],
        [
            [
                "simulate_batch, per run",
                f"{b_sum['serial_s'] / n_runs * 1e6:.2f} us",
                b_sum["serial_fraction"],
                b_sum["speedup_top"],
                b_sum["karp_flatt_top"],
                b_sum["amdahl_16"],
                b_sum["amdahl_64"],
            ],
            [
                f"vector env, per step of {n_envs}",
                f"{e_sum['serial_s'] / steps * 1e6:.0f} us",
                e_sum["serial_fraction"],
                e_sum["speedup_top"],
                e_sum["karp_flatt_top"],
                e_sum["amdahl_16"],
                e_sum["amdahl_64"],
            ],
        ],
        {
            "serial fraction f": ".4f",
            f"speed-up at {b_sum['top']} threads (measured)": ".2f",
            "Karp-Flatt serial fraction": ".3f",
            "Amdahl, 16 threads": ".1f",
            "Amdahl, 64 threads": ".1f",
        },
    )
    md = "\n\n".join(
        [
            f"Fixed work at 1, 2, 4, ... numba threads up to this machine's "
            f"{numba.config.NUMBA_NUM_THREADS} (`numba.set_num_threads`), each timed {repeat} "
            f"times in turn with the others, best kept; load average {load:.1f} when it "
            "started (on a machine shared with other work the speed-ups are lower bounds). "
            "Speed-up and efficiency are of the whole call against one thread; kernel "
            "speed-up is of the threaded kernel alone; speed-up by CPU time is what the "
            "threads' own CPU time implies on idle cores (the calling thread's time outside "
            "the kernel plus the busiest thread's time in it: waiting for a core shared with "
            "other work does not count, spinning at the end of the kernel does); CPU s / "
            "wall s counts every thread.",
            f"`simulate_batch`: {n_runs} runs of {t_end:g} s (control period "
            f"{BATCH_CONTROL_DT:g} s, zero torque but for kicks of up to "
            f"{BATCH_KICK_NM:g} N m in {BATCH_KICK_RATE:.0%} of the periods; summaries only):",
            b_md,
            f"The same {n_runs} runs with the second half at rest (zero torque): the costly "
            "runs grouped together, which a thread per contiguous block of runs would "
            "split unevenly:",
            g_md,
            f"HopRover-v0 vector env (`HopRoverVectorEnv({n_envs}, threads=True)`): {steps} "
            f"steps from one reset, random actions in +-{ENV_ACTION:g}:",
            e_md,
            f"The machine's own ceiling: p independent processes of one numba thread each, "
            f"each running the first table's {n_runs} runs at once (warmed, then started "
            "together; runs / s of all of them, the best of "
            f"{1 if quick else repeat}). Threads that scale less than this lose to "
            "hoprover's loop; "
            "processes that scale no better than the threads show the cores themselves "
            "(shared caches, memory bandwidth, clock or hyper-threads) set the limit:",
            table(
                ["processes", "runs / s", "speed-up", "efficiency"],
                p_rows,
                {"runs / s": ",.0f", "speed-up": ".2f", "efficiency": ".0%"},
            ),
            "Serial time (Python outside the threaded kernel, at one thread) and what it "
            "allows: Amdahl's law with that serial fraction f predicts 1 / (f + (1 - f) / p) "
            "on p threads; the Karp-Flatt fraction is the serial fraction the measured "
            "speed-up implies (imbalance between threads and contention count in it):",
            summary,
        ]
    )
    headline = {
        "batch_runs_per_s_1": b_rows[0][1],
        "batch_runs_per_s_top": b_rows[-1][1],
        "batch_speedup_top": b_sum["speedup_top"],
        "batch_serial_us_per_run": b_sum["serial_s"] / n_runs * 1e6,
        "batch_amdahl_16": b_sum["amdahl_16"],
        "batch_amdahl_64": b_sum["amdahl_64"],
        "grouped_runs_per_s_1": g_rows[0][1],
        "grouped_speedup_top": g_sum["speedup_top"],
        "env_steps_per_s_1": e_rows[0][1],
        "env_steps_per_s_top": e_rows[-1][1],
        "env_speedup_top": e_sum["speedup_top"],
        "processes_speedup_top": p_rows[-1][2],
        "env_serial_us_per_step": e_sum["serial_s"] / steps * 1e6,
        "env_amdahl_16": e_sum["amdahl_16"],
        "env_amdahl_64": e_sum["amdahl_64"],
        "threads": threads,
        "load_average": load,
    }
    return Section("Threads: simulate_batch and the vector env on 1 to all cores", md, [], headline)


# ---- one core, PPO, evaluation, Ray ----------------------------------------------------------
def env_steps_per_s(n: int = 256, steps: int = 400) -> float:
    from hoprover_env import HopRoverVectorEnv

    venv = HopRoverVectorEnv(n, threads=False, control_dt=2.0)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-0.05, 0.05, (steps, n, 1))
    for a in acts[:20]:
        venv.step(a)
    t0 = time.perf_counter()
    for a in acts[20:]:
        venv.step(a)
    return n * (steps - 20) / (time.perf_counter() - t0)


def ppo_steps_per_s(quick: bool) -> float:
    from benchmarks.bench_training import ppo_speed

    rollouts = 1 if quick else 4
    sps, _ = ppo_speed(1, 1, 128, 32 if quick else 256, 4096, 5, [128, 128], rollouts)
    return sps


def eval_episodes_per_s(policy: str, n: int) -> float:
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets

    pol = load_policy(policy, control_dt=0.5)
    targets = seeded_targets(n, 11)
    run_episodes(pol, targets[:4])  # warm-up (compiles, loads)
    t0 = time.perf_counter()
    run_episodes(pol, targets)
    return n / (time.perf_counter() - t0)


def ray_task_overhead(n: int) -> dict:
    from hoprover_env.training.ray_utils import init_ray

    ray = init_ray(num_cpus=2)

    @ray.remote(num_cpus=1)
    def noop(x):
        return x

    ray.get([noop.remote(i) for i in range(20)])  # workers started
    t0 = time.perf_counter()
    for i in range(n):
        ray.get(noop.remote(i))
    serial = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    ray.get([noop.remote(i) for i in range(n)])
    batched = (time.perf_counter() - t0) / n
    return {"task_round_trip_s": serial, "task_in_flight_s": batched}


def tune_trial_overhead(n: int, tmp: str) -> float:
    from ray import tune
    from ray.tune import RunConfig

    def trivial(config):
        tune.report({"score": config["x"]})

    t0 = time.perf_counter()
    tune.Tuner(
        tune.with_resources(trivial, {"cpu": 1}),
        param_space={"x": tune.uniform(0, 1)},
        tune_config=tune.TuneConfig(num_samples=n),
        run_config=RunConfig(storage_path=tmp, name="overhead", verbose=0),
    ).fit()
    return (time.perf_counter() - t0) / n


def main(argv=None) -> int:
    import tempfile

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument(
        "--threads",
        action="store_true",
        help="print the report's section "
        "(simulate_batch and the vector env at 1..all threads) and stop",
    )
    args = ap.parse_args(argv)
    if args.threads:
        sec = run(quick=args.quick)
        print(f"## {sec.title}\n\n{sec.markdown}")
        print(json.dumps(sec.headline))
        return 0
    out = {
        "vector_env_steps_per_s_1core": env_steps_per_s(
            64 if args.quick else 256, 60 if args.quick else 400
        )
    }
    print(json.dumps(out), flush=True)
    out["ppo_steps_per_s_1trial"] = ppo_steps_per_s(args.quick)
    print(json.dumps(out), flush=True)
    for pol in ("scripted", "scratch"):
        out[f"eval_episodes_per_s_1core_{pol}"] = eval_episodes_per_s(
            pol, 16 if args.quick else 256
        )
    print(json.dumps(out), flush=True)
    try:
        import ray  # noqa: F401
    except ImportError:
        print("Ray not installed: no overhead numbers")
        return 0
    out.update(ray_task_overhead(50 if args.quick else 500))
    out["tune_trial_overhead_s"] = tune_trial_overhead(4 if args.quick else 16, tempfile.mkdtemp())
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
