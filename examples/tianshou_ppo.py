"""Tianshou's PPO on the hop-level task HopRoverHop-v0 (pip install -e ".[rl]"), then
the contest judge on the evaluation targets.

    python examples/tianshou_ppo.py                     # 200 k steps, then 200 targets
    python examples/tianshou_ppo.py --steps 20000 --eval-episodes 20   # a smoke run

What Tianshou needs from the environment:

* Its collectors step its own vector envs (DummyVectorEnv in this process,
  SubprocVectorEnv in worker processes) of single `gym.make` envs, and reset each
  finished env themselves; hoprover's native vector env has no place there.
* Tianshou stores every info value in its buffer and refuses a buffer with a missing
  value (`pd.isnull`: None or NaN). hoprover's infos are numbers throughout: the TTRTP
  is -1.0 until reached, the contact state a code 0..6.

The settings are those of configs/ppo_hop.yaml (SB3): 64 envs, 2048 steps per
collection, 10 passes over it in minibatches of 512, lr 3e-4, gamma 0.98, GAE 0.95, a
state-independent std starting at exp(-2), 64x64 tanh MLPs; no observation or reward
normalisation (the observations are already of order one).

The mean's output layer starts as SB3's does (orthogonal, gain 0.01, zero bias), so
that the first policy hops both ways; examples/torchrl_ppo.py says why this matters
(with PyTorch's default init this example gave 52.0 % at seed 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from tianshou.algorithm import PPO
from tianshou.algorithm.modelfree.reinforce import ProbabilisticActorPolicy
from tianshou.algorithm.optim import AdamOptimizerFactory
from tianshou.data import Collector, CollectStats, VectorReplayBuffer
from tianshou.env import DummyVectorEnv
from tianshou.trainer import OnPolicyTrainerParams
from tianshou.utils.net.common import Net
from tianshou.utils.net.continuous import ContinuousActorProbabilistic, ContinuousCritic
from torch import nn
from torch.distributions import Independent, Normal

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # research/ (the project's evaluation code)

import hoprover_env  # noqa: E402,F401  (registers the envs)

ENV_ID = "HopRoverHop-v0"
ENV_KWARGS = {"control_dt": 0.5, "gamma": 0.98, "time_cost": 0.01}  # configs/ppo_hop.yaml


def gaussian(loc_scale):
    loc, scale = loc_scale
    return Independent(Normal(loc, scale), 1)


def build(env, lr: float = 3e-4):
    obs_shape, act_shape = env.observation_space.shape, env.action_space.shape
    actor = ContinuousActorProbabilistic(
        preprocess_net=Net(state_shape=obs_shape, hidden_sizes=[64, 64], activation=nn.Tanh),
        action_shape=act_shape,
        unbounded=True,
    )
    nn.init.orthogonal_(actor.mu.model[-1].weight, gain=0.01)  # mean ~0 everywhere at
    nn.init.zeros_(actor.mu.model[-1].bias)  # the start, as SB3's
    nn.init.constant_(actor.sigma_param, -2.0)  # std exp(-2), state-independent
    critic = ContinuousCritic(
        preprocess_net=Net(state_shape=obs_shape, hidden_sizes=[64, 64], activation=nn.Tanh)
    )
    policy = ProbabilisticActorPolicy(
        actor=actor,
        dist_fn=gaussian,
        action_scaling=True,
        action_bound_method="clip",
        action_space=env.action_space,
    )
    algorithm = PPO(
        policy=policy,
        critic=critic,
        optim=AdamOptimizerFactory(lr=lr),
        gamma=0.98,
        gae_lambda=0.95,
        eps_clip=0.2,
        vf_coef=0.5,
        ent_coef=0.0,
        max_grad_norm=0.5,
        advantage_normalization=True,
    )
    return algorithm, actor


def train(
    steps: int,
    num_envs: int = 64,
    collect: int = 2048,
    minibatch: int = 512,
    seed: int = 0,
    venv_class=DummyVectorEnv,
    progress: bool = True,
):
    """The trained actor and the buffer of the last collection."""
    torch.manual_seed(seed)
    # "module:id": a worker process (SubprocVectorEnv) imports hoprover_env, which
    # registers the ids; a partial of gym.make pickles by reference
    make = partial(gym.make, f"hoprover_env:{ENV_ID}", **ENV_KWARGS)
    envs = venv_class([make] * num_envs)
    envs.seed(seed)
    algorithm, actor = build(gym.make(ENV_ID, **ENV_KWARGS))
    collector = Collector[CollectStats](
        algorithm, envs, VectorReplayBuffer(collect, num_envs), exploration_noise=True
    )
    epochs = max(1, steps // (10 * collect))  # an epoch: 10 collections
    algorithm.run_training(
        OnPolicyTrainerParams(
            training_collector=collector,
            test_collector=None,
            max_epochs=epochs,
            epoch_num_steps=steps // epochs,
            collection_step_num_env_steps=collect,
            update_step_num_repetitions=10,
            batch_size=minibatch,
            show_progress=progress,
        )
    )
    envs.close()
    return actor, collector.buffer


def judge(actor, episodes: int, seed: int = 2015) -> dict:
    """The contest judge (hoprover_env/evaluation/episodes.py, as evaluate.py) on the seeded
    targets, acting with the mean action."""
    from hoprover_env.agents.policies import ArrayPolicy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

    def act(obs: np.ndarray):
        with torch.no_grad():
            (loc, _), _ = actor(obs)
        return loc

    policy = ArrayPolicy(act, "tianshou_ppo", ENV_ID, ENV_KWARGS)
    return summarize(run_episodes(policy, seeded_targets(episodes, seed)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-episodes", type=int, default=200)
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    actor, _ = train(args.steps, seed=args.seed)
    wall = time.perf_counter() - t0
    res = judge(actor, args.eval_episodes)
    print(
        f"Tianshou PPO, {args.steps} steps in {wall:.0f} s: success "
        f"{res['success_rate']:.1%}, median TTRTP {res['median_ttrtp']:.1f} s, p90 "
        f"{res['p90_ttrtp']:.1f} s, broken {res['broken']} ({args.eval_episodes} targets, "
        "seed 2015)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
