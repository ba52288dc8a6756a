"""TorchRL's PPO on the hop-level task HopRoverHop-v0, on hoprover's native vector env
(pip install -e ".[rl]"), then the contest judge on the evaluation targets.

    python examples/torchrl_ppo.py                      # 200 k steps, then 200 targets
    python examples/torchrl_ppo.py --steps 20000 --eval-episodes 20   # a smoke run

What TorchRL needs from the environment:

* `GymWrapper` takes the native vector env (all sub-envs in one numba call) in
  SAME_STEP autoreset mode; TorchRL refuses gymnasium's default NEXT_STEP mode.
* Every info value is a number of fixed type (TTRTP -1.0 until reached, the contact
  state a code 0..6), so TorchRL's info reader builds specs from the first step: each
  batch carries ("next", "is_success"), ("next", "ttrtp") etc. `GymEnv("HopRoverHop-v0")`
  (one env) and `GymEnv(..., num_envs=N)` (N subprocesses) work too, but are slower.

The settings are those of configs/ppo_hop.yaml (SB3): 64 envs x 32 steps per batch,
10 epochs of minibatches of 512, lr 3e-4, gamma 0.98, GAE 0.95, a state-independent
std starting at exp(-2), a 64x64 tanh MLP for actor and critic; no observation or
reward normalisation (the observations are already of order one).

The mean's output layer starts as SB3's does (orthogonal, gain 0.01, zero bias), so the
first policy's mean action is about 0 in every state and its exploration (std 0.135)
hops both ways. With PyTorch's default init the mean starts anywhere within about
+-0.5, often with one sign in every state: at seed 0 it was +0.13..+0.29 in the start
states, so only 14 % of the first hops towards a target at -x went that way (97 % at
+x), and with no entropy bonus PPO learned the +x side alone (judged: 100 % of the
targets at +x, 11 % of those at -x, 59.5 % in all).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import torch
from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, ReplayBuffer
from torchrl.data.replay_buffers.samplers import SamplerWithoutReplacement
from torchrl.envs import GymWrapper
from torchrl.modules import IndependentNormal, ProbabilisticActor, ValueOperator
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # research/ (the project's evaluation code)

import hoprover_env  # noqa: E402,F401  (registers the envs)

ENV_ID = "HopRoverHop-v0"
ENV_KWARGS = {"control_dt": 0.5, "gamma": 0.98, "time_cost": 0.01}  # configs/ppo_hop.yaml


def make_env(num_envs: int, seed: int):
    venv = gym.make_vec(
        ENV_ID, num_envs=num_envs, autoreset_mode="SameStep", threads=False, **ENV_KWARGS
    )
    env = GymWrapper(venv)  # reads every info key; at an episode's end, its last
    env.set_seed(seed)
    return env


def mlp(n_in: int, n_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(n_in, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh(), nn.Linear(64, n_out)
    )


def build(env):
    n_obs = env.observation_spec["observation"].shape[-1]
    n_act = env.action_spec.shape[-1]
    loc_net = mlp(n_obs, n_act)
    nn.init.orthogonal_(loc_net[-1].weight, gain=0.01)  # mean ~0 everywhere at the start
    nn.init.zeros_(loc_net[-1].bias)
    actor_net = nn.Sequential(loc_net, AddStateIndependentNormalScale(n_act, init_value=-2.0))
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=["observation"], out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"],
        spec=env.action_spec,
        distribution_class=IndependentNormal,
        return_log_prob=True,
    )  # the env clips actions to [-1, 1] itself
    critic = ValueOperator(mlp(n_obs, 1), in_keys=["observation"])
    return actor, critic


def train(
    steps: int,
    num_envs: int = 64,
    rollout: int = 32,
    epochs: int = 10,
    minibatch: int = 512,
    lr: float = 3e-4,
    seed: int = 0,
    log=print,
):
    torch.manual_seed(seed)
    env = make_env(num_envs, seed)
    actor, critic = build(env)
    batch = num_envs * rollout
    collector = Collector(env, actor, frames_per_batch=batch, total_frames=steps)
    buffer = ReplayBuffer(
        storage=LazyTensorStorage(batch), sampler=SamplerWithoutReplacement(), batch_size=minibatch
    )
    gae = GAE(gamma=0.98, lmbda=0.95, value_network=critic)
    loss_fn = ClipPPOLoss(
        actor,
        critic,
        clip_epsilon=0.2,
        entropy_bonus=False,
        critic_coeff=0.5,
        loss_critic_type="l2",
        normalize_advantage=True,
    )
    optim = torch.optim.Adam(loss_fn.parameters(), lr=lr)
    done_steps = 0
    for data in collector:
        with torch.no_grad():
            gae(data)
        buffer.extend(data.reshape(-1))
        for _ in range(epochs):
            for _ in range(batch // minibatch):
                loss = loss_fn(buffer.sample())
                total = loss["loss_objective"] + loss["loss_critic"]
                optim.zero_grad()
                total.backward()
                nn.utils.clip_grad_norm_(loss_fn.parameters(), 0.5)
                optim.step()
        done_steps += data.numel()
        ended = data["next", "done"].squeeze(-1)
        if ended.any():
            success = data["next", "is_success"][ended].float().mean().item()
            log(f"{done_steps:>8d} steps  episodes {int(ended.sum()):>4d}  success {success:.2f}")
    collector.shutdown()
    return actor


def judge(actor, episodes: int, seed: int = 2015) -> dict:
    """The contest judge (hoprover_env/evaluation/episodes.py, as evaluate.py) on the seeded
    targets, acting with the mean action."""
    from hoprover_env.agents.policies import ArrayPolicy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

    loc_net = actor.module[0].module[0]  # the MLP giving the mean

    def act(obs):
        with torch.no_grad():
            return loc_net(torch.as_tensor(obs))

    policy = ArrayPolicy(act, "torchrl_ppo", ENV_ID, ENV_KWARGS)
    return summarize(run_episodes(policy, seeded_targets(episodes, seed)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-episodes", type=int, default=200)
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    actor = train(args.steps, seed=args.seed)
    wall = time.perf_counter() - t0
    res = judge(actor, args.eval_episodes)
    print(
        f"TorchRL PPO, {args.steps} steps in {wall:.0f} s: success {res['success_rate']:.1%}, "
        f"median TTRTP {res['median_ttrtp']:.1f} s, p90 {res['p90_ttrtp']:.1f} s, "
        f"broken {res['broken']} ({args.eval_episodes} targets, seed 2015)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
