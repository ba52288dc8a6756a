"""The numbers behind docs/SCALING.md: what one core does, and what Ray costs.

    PYTHONPATH=. python -m benchmarks.bench_scaling [--quick]

Prints, on this machine: vector-env steps/s on one core (numba serial), PPO steps/s of
one trial with configs/ppo_scratch.yaml's settings (one torch thread), evaluation
episodes/s on one core (the scripted hopper and the bundled scratch policy), and Ray's
overhead: per task (a no-op task's round trip, tasks in flight together) and per Tune
trial (a trial that reports once and returns). Needs the [ray] extra for the last two.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


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
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets
    from hoprover_env.agents.policies import load_policy
    pol = load_policy(policy, control_dt=0.5)
    targets = seeded_targets(n, 11)
    run_episodes(pol, targets[:4])                    # warm-up (compiles, loads)
    t0 = time.perf_counter()
    run_episodes(pol, targets)
    return n / (time.perf_counter() - t0)


def ray_task_overhead(n: int) -> dict:
    from hoprover_env.training.ray_utils import init_ray
    ray = init_ray(num_cpus=2)

    @ray.remote(num_cpus=1)
    def noop(x):
        return x
    ray.get([noop.remote(i) for i in range(20)])      # workers started
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
    tune.Tuner(tune.with_resources(trivial, {"cpu": 1}),
               param_space={"x": tune.uniform(0, 1)},
               tune_config=tune.TuneConfig(num_samples=n),
               run_config=RunConfig(storage_path=tmp, name="overhead", verbose=0)).fit()
    return (time.perf_counter() - t0) / n


def main(argv=None) -> int:
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    out = {"vector_env_steps_per_s_1core": env_steps_per_s(64 if args.quick else 256,
                                                           60 if args.quick else 400)}
    print(json.dumps(out), flush=True)
    out["ppo_steps_per_s_1trial"] = ppo_steps_per_s(args.quick)
    print(json.dumps(out), flush=True)
    for pol in ("scripted", "scratch"):
        out[f"eval_episodes_per_s_1core_{pol}"] = eval_episodes_per_s(pol, 16 if args.quick
                                                                      else 256)
    print(json.dumps(out), flush=True)
    try:
        import ray  # noqa: F401
    except ImportError:
        print("Ray not installed: no overhead numbers")
        return 0
    out.update(ray_task_overhead(50 if args.quick else 500))
    out["tune_trial_overhead_s"] = tune_trial_overhead(4 if args.quick else 16,
                                                       tempfile.mkdtemp())
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
