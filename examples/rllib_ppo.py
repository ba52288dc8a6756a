"""RLlib's PPO on HopRover-v0, with several EnvRunners each stepping hoprover's native
vector env (pip install "hoprover[ray]").

    python examples/rllib_ppo.py                          # local Ray, 2 EnvRunners
    python examples/rllib_ppo.py --iterations 50 --env-runners 8 --envs-per-runner 64
    python examples/rllib_ppo.py --address ray://HOST:10001   # an existing cluster

What RLlib needs from an environment, and how hoprover gives it:

* **Registration with `ray.tune.registry.register_env`.** The EnvRunners are separate
  processes (on other machines, in a cluster): a gymnasium id registered by importing
  `hoprover_env` in the driver does not exist there. `register_env(name, creator)`
  ships the creator to every runner.
* **`env_config` becomes the env's keyword arguments.** RLlib calls the creator with an
  `EnvContext` (a dict: the `env_config` plus `worker_index` etc. as attributes). The
  creator passes it on as `HopRoverEnv` keyword arguments (`control_dt`, `shaping`, ...).
* **The native vector env, not a SyncVectorEnv of single envs.** With
  `gym_env_vectorize_mode="vector_entry_point"` RLlib calls the registered env's
  vector entry point with `num_envs=num_envs_per_env_runner`: the creator sees
  `num_envs` in its config and builds one `HopRoverVectorEnv`, which steps all its
  sub-envs in one numba call. RLlib's runners expect gymnasium's default NEXT_STEP
  autoreset, which is the vector env's default too.
* **Code the runners can import.** The creator and the metrics callback live in the
  installed package (`hoprover_env/envs/rllib.py`), so every runner process unpickles them.
  On a cluster the runners import the hoprover installed on their node (checked against
  this driver's before training starts), or this checkout's copy with --ship-code:
  the same mechanism as sweep.py and evaluate.py --ray (hoprover_env/training/ray_utils.py).
* **Episode metrics.** `HopRoverMetrics.on_episode_end` reads the judge's verdict from
  the last step's info (`is_success`, `ttrtp`, `broken`) and logs it with RLlib's
  MetricsLogger: `env_runners/hoprover_success`, `hoprover_ttrtp`, `hoprover_broken` in
  each result, next to RLlib's own `episode_return_mean`.

The settings follow configs/ppo_scratch.yaml (control period 2 s, landing shaping,
bounded attitude potential, gamma 0.995, small initial exploration noise); this is a
plumbing example, and RLlib's PPO has not been tuned to the SB3 results in README.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # research/ of this checkout, run from anywhere
from hoprover_env.training.ray_utils import SHIP_CODE_HELP, ClusterCodeError, init_ray  # noqa: E402

ENV_NAME = "hoprover"
ENV_CONFIG = {"control_dt": 2.0, "shaping": "landing", "attitude_weight": 1.0, "gamma": 0.995}


def build_config(
    env_runners: int = 2,
    envs_per_runner: int = 32,
    env_config: dict | None = None,
    train_batch: int | None = None,
    minibatch: int = 512,
    epochs: int = 5,
    lr: float = 3e-4,
):
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    from hoprover_env.envs.rllib import HopRoverMetrics, make_env

    register_env(ENV_NAME, make_env)
    rollout = 64  # steps per sub-env per iteration
    batch = train_batch or max(env_runners, 1) * envs_per_runner * rollout
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config={**ENV_CONFIG, **(env_config or {})})
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=envs_per_runner,
            gym_env_vectorize_mode="vector_entry_point",
            rollout_fragment_length="auto",
            num_cpus_per_env_runner=1,
        )
        .learners(num_learners=0)
        .training(
            gamma=0.995,
            lambda_=0.95,
            lr=lr,
            train_batch_size_per_learner=batch,
            minibatch_size=min(minibatch, batch),
            num_epochs=epochs,
            clip_param=0.2,
            entropy_coeff=0.0,
            grad_clip=0.5,
        )
        .rl_module(
            model_config={
                "fcnet_hiddens": [128, 128],
                "fcnet_activation": "tanh",
                "vf_share_layers": False,
            }
        )
        .callbacks(HopRoverMetrics)
    )


def summary(result: dict) -> dict:
    """The numbers this example prints from one RLlib training result."""
    runners = result.get("env_runners", {})

    def get(key):
        v = runners.get(key)
        return math.nan if v is None else float(v)

    return {
        "iteration": result.get("training_iteration"),
        "env_steps": runners.get("num_env_steps_sampled_lifetime"),
        "episodes": runners.get("num_episodes_lifetime"),
        "return_mean": get("episode_return_mean"),
        "success": get("hoprover_success"),
        "ttrtp": get("hoprover_ttrtp"),
        "broken": get("hoprover_broken"),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=20)
    ap.add_argument("--env-runners", type=int, default=2)
    ap.add_argument("--envs-per-runner", type=int, default=32)
    ap.add_argument("--address", default=None, help="Ray cluster (default RAY_ADDRESS or local)")
    ap.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray")
    ap.add_argument("--ship-code", action="store_true", help=SHIP_CODE_HELP)
    args = ap.parse_args(argv)
    try:
        init_ray(args.address, args.num_cpus, args.ship_code)
    except ClusterCodeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    algo = build_config(args.env_runners, args.envs_per_runner).build_algo()
    try:
        for _ in range(args.iterations):
            s = summary(algo.train())
            print(
                f"iter {s['iteration']:>3}  env steps {s['env_steps']}  episodes "
                f"{s['episodes']}  return {s['return_mean']:.3f}  success "
                f"{s['success']:.2f}  TTRTP {s['ttrtp']:.1f} s  broken {s['broken']:.2f}",
                flush=True,
            )
    finally:
        algo.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
