"""skrl's PPO on the hop-level task HopRoverHop-v0, on hoprover's native vector env
(pip install -e ".[rl]"), then the contest judge on the evaluation targets.

    python examples/skrl_ppo.py                         # 200 k steps, then 200 targets
    python examples/skrl_ppo.py --steps 20000 --eval-episodes 20     # a smoke run

What skrl needs from the environment:

* `wrap_env` takes the native vector env (all sub-envs in one numba call).
* **SAME_STEP autoreset.** skrl ignores `autoreset_mode` and records every step as a
  transition. With gymnasium's default NEXT_STEP mode, the step after an episode's end
  is a reset whose reward 0 and first observation it would store as a transition of
  the ended episode (true of any gymnasium 1.x NEXT_STEP vector env). In SAME_STEP mode
  the reset happens inside the ending step and no such transition exists.

The settings are those of configs/ppo_hop.yaml (SB3): 64 envs x 32 steps per rollout,
10 epochs of 4 minibatches (512), lr 3e-4, gamma 0.98, GAE 0.95, a state-independent
log std starting at -2, 64x64 tanh MLPs; no observation or reward normalisation (the
observations are already of order one).

The mean's output layer starts as SB3's does (orthogonal, gain 0.01, zero bias), so
that the first policy hops both ways; examples/torchrl_ppo.py says why this matters
(with PyTorch's default init this example gave 52.0 % at seed 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import torch
from skrl.agents.torch.ppo import PPO, PPO_CFG
from skrl.envs.wrappers.torch import wrap_env
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
from skrl.trainers.torch import SequentialTrainer
from skrl.utils import set_seed
from torch import nn

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # research/ (the project's evaluation code)

import hoprover_env  # noqa: E402,F401  (registers the envs)

ENV_ID = "HopRoverHop-v0"
ENV_KWARGS = {"control_dt": 0.5, "gamma": 0.98, "time_cost": 0.01}  # configs/ppo_hop.yaml


def mlp(n_in: int, n_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(n_in, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh(), nn.Linear(64, n_out)
    )


class Policy(GaussianMixin, Model):
    def __init__(self, observation_space, state_space, action_space, device):
        Model.__init__(
            self,
            observation_space=observation_space,
            state_space=state_space,
            action_space=action_space,
            device=device,
        )
        GaussianMixin.__init__(self, clip_actions=True)
        self.net = mlp(self.num_observations, self.num_actions)
        nn.init.orthogonal_(self.net[-1].weight, gain=0.01)  # mean ~0 everywhere at the
        nn.init.zeros_(self.net[-1].bias)  # start, as SB3's
        self.log_std = nn.Parameter(torch.full((self.num_actions,), -2.0))

    def compute(self, inputs, role):
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class Value(DeterministicMixin, Model):
    def __init__(self, observation_space, state_space, action_space, device):
        Model.__init__(
            self,
            observation_space=observation_space,
            state_space=state_space,
            action_space=action_space,
            device=device,
        )
        DeterministicMixin.__init__(self)
        self.net = mlp(self.num_observations, 1)

    def compute(self, inputs, role):
        return self.net(inputs["observations"]), {}


def build(env) -> dict:
    spaces = (env.observation_space, env.state_space, env.action_space, env.device)
    return {"policy": Policy(*spaces), "value": Value(*spaces)}


def train(
    steps: int,
    num_envs: int = 64,
    rollout: int = 32,
    minibatch: int = 512,
    seed: int = 0,
    progress: bool = True,
) -> Policy:
    set_seed(seed)
    env = wrap_env(
        gym.make_vec(
            ENV_ID, num_envs=num_envs, autoreset_mode="SameStep", threads=False, **ENV_KWARGS
        )
    )
    models = build(env)
    cfg = PPO_CFG(
        rollouts=rollout,
        learning_epochs=10,
        mini_batches=max(1, num_envs * rollout // minibatch),
        discount_factor=0.98,
        gae_lambda=0.95,
        learning_rate=3e-4,
        grad_norm_clip=0.5,
        ratio_clip=0.2,
        value_clip=0.0,
        entropy_loss_scale=0.0,
        value_loss_scale=0.5,
    )
    cfg.experiment.write_interval = 0  # no TensorBoard files, no checkpoints
    cfg.experiment.checkpoint_interval = 0
    agent = PPO(
        models=models,
        memory=RandomMemory(memory_size=rollout, num_envs=num_envs),
        cfg=cfg,
        observation_space=env.observation_space,
        state_space=env.state_space,
        action_space=env.action_space,
        device=env.device,
    )
    # close_environment_at_exit: skrl otherwise closes the env again in an atexit hook and
    # logs "Environment closed" to a stream that may be gone by then (pytest's capture:
    # two "--- Logging error ---" tracebacks at exit); this function closes it itself
    SequentialTrainer(
        cfg={
            "timesteps": steps // num_envs,
            "headless": True,
            "disable_progressbar": not progress,
            "close_environment_at_exit": False,
        },
        env=env,
        agents=agent,
    ).train()
    env.close()
    return models["policy"]


def judge(policy: Policy, episodes: int, seed: int = 2015) -> dict:
    """The contest judge (hoprover_env/evaluation/episodes.py, as evaluate.py) on the seeded
    targets, acting with the mean action."""
    from hoprover_env.agents.policies import ArrayPolicy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

    def act(obs):
        with torch.no_grad():
            return policy.net(torch.as_tensor(obs))

    return summarize(
        run_episodes(
            ArrayPolicy(act, "skrl_ppo", ENV_ID, ENV_KWARGS), seeded_targets(episodes, seed)
        )
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-episodes", type=int, default=200)
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    policy = train(args.steps, seed=args.seed)
    wall = time.perf_counter() - t0
    res = judge(policy, args.eval_episodes)
    print(
        f"skrl PPO, {args.steps} steps in {wall:.0f} s: success {res['success_rate']:.1%}, "
        f"median TTRTP {res['median_ttrtp']:.1f} s, p90 {res['p90_ttrtp']:.1f} s, "
        f"broken {res['broken']} ({args.eval_episodes} targets, seed 2015)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
