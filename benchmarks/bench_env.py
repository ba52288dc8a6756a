"""Throughput and scaling of the environments, next to Gymnasium's CartPole anchors.

    python -m benchmarks.bench_env [--quick]

Measured in one run on one machine, reported as ratios:
* single-env `step` through `gym.make` (all default wrappers): HopRover-v0 vs CartPole-v1;
* vector steps/s against N: the native HopRoverVectorEnv (serial and threaded), Gymnasium's
  numpy CartPoleVectorEnv, and a SyncVectorEnv of HopRover single envs;
* cost per simulated second at rest, in flight and in contact (the kernel alone);
* what rendering and full infos cost when asked for (nothing when not);
* time to first step, numba cold (empty cache) and cached, in fresh interpreters (cached
  only with --quick);
* memory per sub-env.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc

import gymnasium as gym
import numba
import numpy as np

import hoprover_env  # noqa: F401  (registers the envs)
from benchmarks.report import Section, best_of, table
from hoprover_env import core
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.tasks import torque


def single_step_us(env_id: str, n: int, **kw) -> float:
    """Mean microseconds per `env.step` with random actions, resets included."""
    env = gym.make(env_id, **kw)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(1000)]
    for a in actions[:50]:  # warm up (compilation, checker)
        if any(env.step(a)[2:4]):
            env.reset()
    t0 = time.perf_counter()
    for k in range(n):
        _, _, te, tr, _ = env.step(actions[k % 1000])
        if te or tr:
            env.reset()
    return (time.perf_counter() - t0) / n * 1e6


def vector_steps_per_s(
    make, n_envs: int, min_steps: int, warmup: int = 30, per_env: int = 60
) -> float:
    """Steps per second of a vector env under random actions: `warmup` steps first (past
    the launch transient that every episode starts with), then at least `per_env` steps
    per sub-env and at least `min_steps` steps in all, so every N is measured on a
    comparable mix of rest, contact and flight."""
    envs = make(n_envs)
    envs.reset(seed=0)
    rng = np.random.default_rng(0)
    sample = envs.action_space.sample()
    discrete = np.issubdtype(np.asarray(sample).dtype, np.integer)
    pool = [
        rng.integers(0, 2, n_envs) if discrete else rng.uniform(-1, 1, (n_envs, 1))
        for _ in range(16)
    ]
    for k in range(warmup):
        envs.step(pool[k % 16])
    steps = max(per_env, min_steps // n_envs)
    t0 = time.perf_counter()
    for k in range(steps):
        envs.step(pool[k % 16])
    dt = time.perf_counter() - t0
    envs.close()
    return n_envs * steps / dt


def kernel_cost_per_sim_second(kind: str, n: int = 512, steps: int = 40) -> float:
    """Wall microseconds per simulated second for rovers kept at rest, in flight or in
    contact (serial kernel, control period 0.5 s)."""
    venv = HopRoverVectorEnv(n, threads=False, episode_time=1e9, control_dt=0.5)
    venv.reset(seed=0)
    act = np.zeros(n)  # zero torque (action 0 = mid-range)
    if kind == "flight":
        # a high vertical throw with a slow spin: stays in the air for the whole test
        for i in range(n):
            s = venv.S[i]
            s[core.S_Y], s[core.S_VY], s[core.S_W] = 1.0, 0.02, 0.01
            s[core.S_MODE] = core.MODE_A
    elif kind == "contact":
        # a torque just above the tipping torque: a long, slow pivot on corner A
        act[:] = action_of(6e-6)
    S0 = venv.S.copy()
    active = np.ones(n, dtype=bool)
    args = (
        venv.P,
        venv._o,
        venv._e,
        venv._rw,
        venv._rm,
        venv.M,
        act[:, None].copy(),
        active,
        venv._obs,
        venv._rew,
        venv._term,
        venv._trunc,
        venv._succ,
        venv._nev,
        venv._log,
        venv._work,
        venv._steps,
        0,
        venv._ended,
        *venv._info_columns,
    )
    batch = torque.TASK.kernels("event").batch

    def go():
        venv.S[:] = S0
        for _ in range(steps):
            batch(venv.S, *args)

    wall, _ = best_of(go, 3)
    modes = np.bincount(venv.S[:, core.S_MODE].astype(int), minlength=7)
    expect = {"rest": core.MODE_F, "flight": core.MODE_A, "contact": core.MODE_B}[kind]
    assert modes[expect] == n, f"{kind}: rovers left the intended state: {modes}"
    return wall / (n * steps * 0.5) * 1e6


def action_of(torque_nm: float) -> float:
    return torque_nm / 5e-4  # the action of a symmetric +-5e-4 range


# the time to a single env's first step: t1 - t0 (benchmarks/cold_compare.py runs it alone)
SINGLE_FIRST_STEP = """
import time; t0 = time.perf_counter()
import gymnasium as gym, numpy as np, hoprover_env
env = gym.make("HopRover-v0"); env.reset(seed=0); env.step(np.array([0.5], np.float32))
t1 = time.perf_counter()
"""
FIRST_STEP = (
    SINGLE_FIRST_STEP
    + """
envs = gym.make_vec("HopRover-v0", num_envs=256); envs.reset(seed=0); envs.step(np.zeros((256, 1)))
print(t1 - t0, time.perf_counter() - t1)
"""
)


def first_step_times(cold: bool = True) -> dict:
    """{"cold", "cached"}: (single env s, vector env s) to the first step in a fresh
    interpreter, on an empty numba cache and then on the cache it wrote. cold=False
    (--quick, whose point is that every section runs, not a full compile): "cached"
    only, on this process's own cache, which the sections before have warmed."""

    def first_step(env):
        res = subprocess.run(
            [sys.executable, "-c", FIRST_STEP], env=env, check=True, capture_output=True, text=True
        ).stdout.split()
        return tuple(float(v) for v in res[-2:])

    if not cold:
        return {"cached": first_step(dict(os.environ))}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        return {label: first_step(env) for label in ("cold", "cached")}


def memory_per_env(n: int) -> float:
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    venv = HopRoverVectorEnv(n)
    venv.reset(seed=0)
    after = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    del venv
    return (after - before) / n


TASK_IDS = ("HopRover-v0", "HopRoverHop-v0", "HopRoverTerrain-v0", "HopRoverMission-v0")


def task_step_costs(n: int = 4096, steps: int = 60, rounds: int = 5) -> dict:
    """Microseconds per sub-env step of each task's native vector env at N = n, the
    same seeded action stream for all, measured in alternating rounds (best of
    `rounds`), so that a busy machine slows each task alike."""
    envs = {}
    for env_id in TASK_IDS:
        envs[env_id] = gym.make_vec(env_id, num_envs=n)
        envs[env_id].reset(seed=0)
        envs[env_id].step(np.zeros((n, 1)))  # compile, warm
    best = {env_id: math.inf for env_id in TASK_IDS}
    for _ in range(rounds):
        for env_id, venv in envs.items():
            venv.reset(seed=0)
            rng = np.random.default_rng(0)
            t0 = time.perf_counter()
            for _ in range(steps):
                venv.step(rng.uniform(-1, 1, (n, 1)) * 0.2)
            best[env_id] = min(best[env_id], (time.perf_counter() - t0) / (steps * n) * 1e6)
    return best


def run(quick: bool = False, fig_dir: str = "benchmarks/figures") -> Section:
    n_single = 5000 if quick else 50000
    cart = single_step_us("CartPole-v1", n_single)
    hop = single_step_us("HopRover-v0", n_single)
    hop_render = single_step_us("HopRover-v0", n_single // 10, render_mode="rgb_array")
    hop_full = single_step_us("HopRover-v0", n_single, info_level="full")
    single_md = table(
        ["env (through gym.make, random actions)", "us / step", "x CartPole-v1"],
        [
            ["CartPole-v1", cart, 1.0],
            ["HopRover-v0", hop, hop / cart],
            ["HopRover-v0, info_level='full'", hop_full, hop_full / cart],
            [
                "HopRover-v0, render_mode='rgb_array' (no render() calls)",
                hop_render,
                hop_render / cart,
            ],
        ],
        {"us / step": ".2f", "x CartPole-v1": ".2f"},
    )

    sizes = [1, 16, 256] if quick else [1, 16, 256, 4096, 16384, 65536]
    # quick: few steps, as a threaded step of 1 or 16 sub-envs waits for its OpenMP team:
    # on cores kept busy by other work (the test suite's other workers) that took 2-8 ms
    # a step, 34 s for quick's former 20000 steps of one sub-env
    min_steps = 500 if quick else 400000
    rows, curves = (
        [],
        {
            "HopRover native, threaded": [],
            "HopRover native, serial": [],
            "CartPole numpy vector": [],
            "HopRover SyncVectorEnv": [],
        },
    )
    from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

    for n in sizes:
        thr = vector_steps_per_s(lambda k: HopRoverVectorEnv(k, threads=True), n, min_steps)
        ser = vector_steps_per_s(lambda k: HopRoverVectorEnv(k, threads=False), n, min_steps)
        cp = vector_steps_per_s(lambda k: CartPoleVectorEnv(num_envs=k), n, min_steps)
        sync = math_nan = float("nan")
        if n <= (16 if quick else 4096):
            sync = vector_steps_per_s(
                lambda k: gym.make_vec("HopRover-v0", num_envs=k, vectorization_mode="sync"),
                n,
                min(min_steps, 50000),
                warmup=30 if n < 4096 else 10,
                per_env=60 if n < 4096 else 20,
            )
        for key, v in zip(curves, (thr, ser, cp, sync)):
            curves[key].append(v)
        rows.append([n, thr, ser, cp, sync, thr / sync if sync == sync else math_nan])
    vec_md = table(
        [
            "N",
            "native threaded steps/s",
            "native serial steps/s",
            "CartPoleVectorEnv steps/s",
            "SyncVectorEnv(HopRover) steps/s",
            "native / Sync",
        ],
        rows,
        {
            "native threaded steps/s": ",.0f",
            "native serial steps/s": ",.0f",
            "CartPoleVectorEnv steps/s": ",.0f",
            "SyncVectorEnv(HopRover) steps/s": ",.0f",
            "native / Sync": ".0f",
        },
    )

    costs = {
        k: kernel_cost_per_sim_second(k, n=128 if quick else 1024)
        for k in ("rest", "flight", "contact")
    }
    cost_col = "us per simulated second (kernel, per rover)"
    cost_md = table(["rover kept", cost_col], [[k, v] for k, v in costs.items()], {cost_col: ".3f"})

    task_n, task_steps, task_rounds = (512, 20, 2) if quick else (4096, 60, 5)
    task_us = task_step_costs(task_n, steps=task_steps, rounds=task_rounds)
    task_md = table(
        ["task (native vector env)", "us per sub-env step", "x HopRover-v0"],
        [[k, v, v / task_us["HopRover-v0"]] for k, v in task_us.items()],
        {"us per sub-env step": ".3f", "x HopRover-v0": ".2f"},
    )

    ft = first_step_times(cold=not quick)
    first_md = table(
        ["numba cache", "first single-env step s", "then first 256-env vector step s"],
        [[k, v[0], v[1]] for k, v in ft.items()],
        {"first single-env step s": ".2f", "then first 256-env vector step s": ".2f"},
    )
    mem = memory_per_env(1024 if quick else 65536)
    fig = os.path.join(fig_dir, "throughput.png")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.figure(figsize=(6.5, 4))
    for key, vals in curves.items():
        v = np.array(vals, dtype=float)
        ok = ~np.isnan(v)
        plt.loglog(np.array(sizes)[ok], v[ok], "o-", label=key)
    plt.xlabel("number of sub-envs N")
    plt.ylabel("environment steps per second")
    plt.grid(alpha=0.3, which="both")
    plt.legend(fontsize=8)
    plt.title("vector throughput, random actions (one run)")
    plt.tight_layout()
    plt.savefig(fig, dpi=90)
    plt.close()

    n_big = 4096 if 4096 in sizes else sizes[-1]
    big = dict(zip(sizes, curves["HopRover native, threaded"]))[n_big]
    sync_n = max(n for n in sizes if n <= (16 if quick else 4096))
    ratio_sync = (
        dict(zip(sizes, curves["HopRover native, threaded"]))[sync_n]
        / dict(zip(sizes, curves["HopRover SyncVectorEnv"]))[sync_n]
    )
    md = "\n\n".join(
        [
            "Single-env step latency (mean over random-action episodes, resets included):",
            single_md,
            f"Vector throughput (random actions in [-1, 1]; default control period 0.5 s; 30 "
            f"warm-up steps, then at least 60 steps per sub-env; SyncVectorEnv at N = 4096: 10 "
            f"+ 20), numba threads: {numba.config.NUMBA_NUM_THREADS}:",
            vec_md,
            f"Every task's step at N = {task_n} (the same random actions in [-0.2, 0.2], "
            f"{task_steps} steps from reset, best of {task_rounds} rounds run in turn; the hop "
            "task's step is a whole hop, the terrain and mission tasks draw slopes and bounce "
            "off rough ground, the mission also reads its sensors):",
            task_md,
            "Cost of simulated time (the kernel alone, per rover): a rover at rest costs only "
            "the per-step bookkeeping, a flight is closed form, a contact phase runs DOP853 with "
            "event location:",
            cost_md,
            "Time to the first step in a fresh interpreter (compilation included when cold; "
            f"{os.cpu_count()} cores: on two or more, a helper process compiles part of the "
            "kernel meanwhile, see the cold-start table of the runs section):",
            first_md,
            f"Memory per sub-env: {mem:.0f} bytes (state, parameters, observation and result "
            f"arrays; per-thread scratch of {core.N_WORK * 8} bytes on top).",
        ]
    )
    headline = {
        "single_step_us": hop,
        "cartpole_step_us": cart,
        "single_vs_cartpole": hop / cart,
        f"steps_per_s_N{n_big}": big,
        f"native_vs_sync_N{sync_n}": ratio_sync,
        "first_step_cold_s": ft.get("cold", (math.nan,))[0],
        "first_step_cached_s": ft["cached"][0],
        "bytes_per_env": mem,
        **{f"us_per_sim_s_{k}": v for k, v in costs.items()},
        "mission_vs_torque_step": task_us["HopRoverMission-v0"] / task_us["HopRover-v0"],
        "mission_vs_terrain_step": task_us["HopRoverMission-v0"] / task_us["HopRoverTerrain-v0"],
    }
    return Section("Throughput and scaling", md, [fig], headline)


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    sec = run(quick=quick, fig_dir=tempfile.mkdtemp())
    print(sec.markdown)
    print(sec.headline)
