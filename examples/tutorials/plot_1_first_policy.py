"""
A first policy in a few minutes: hop-level PPO
==============================================

On ``HopRoverHop-v0`` one action is one hop: the sign is the direction, the size the
launch torque (on a log scale), and a built-in attitude hold flies the hop. That puts
decisions on the time scale of the task, and PPO from scratch learns it quickly. Here we
train for a short budget with the settings of ``configs/ppo_hop.yaml``, score the result
with the contest judge, and compare it with the bundled policy that trained longer on the
same config.
"""

# %%
# The environment: 64 rovers stepped in one compiled call
# --------------------------------------------------------
# :class:`~hoprover_env.envs.sb3.HopRoverSB3VecEnv` is Stable-Baselines3's ``VecEnv`` over the
# native batched env. The settings come from the repository's config file, so this
# tutorial trains exactly what ``python train.py --config configs/ppo_hop.yaml`` trains.
import time

import matplotlib.pyplot as plt
import numpy as np
import torch
import yaml
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

from hoprover_env.agents.policies import SB3Policy, load_policy
from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.training.sb3_agents import config_path

torch.set_num_threads(1)
# configs/ppo_hop.yaml, by its name: it travels with the package, so this also runs from
# a wheel install outside a checkout
cfg = yaml.safe_load(config_path("ppo_hop").read_text())
print("env:", cfg["env"])
print("PPO:", cfg["hyperparams"])

venv = HopRoverSB3VecEnv(cfg["n_envs"], seed=0, env_id="HopRoverHop-v0", **cfg["env"])
venv = VecNormalize(
    VecMonitor(venv),
    norm_obs=True,
    norm_reward=True,
    clip_obs=cfg["normalize"]["clip_obs"],
    gamma=cfg["hyperparams"]["gamma"],
)

# %%
# Train for a short budget
# ------------------------
# 24 576 hops (12 PPO updates of 64 envs x 32 hops). A callback records the mean episode
# return and the success rate of the episodes that ended during each rollout.
pol = cfg["policy"]
model = PPO(
    "MlpPolicy",
    venv,
    seed=0,
    device="cpu",
    verbose=0,
    policy_kwargs=dict(
        net_arch=pol["net_arch"], activation_fn=torch.nn.Tanh, log_std_init=pol["log_std_init"]
    ),
    **cfg["hyperparams"],
)

curve = []


def log_rollout(locals_, globals_):
    for info in locals_["infos"]:
        if "episode" in info:
            curve.append((model.num_timesteps, info["episode"]["r"], info["is_success"]))
    return True


t0 = time.perf_counter()
model.learn(24_576, callback=log_rollout)
print(f"trained {model.num_timesteps} hops in {time.perf_counter() - t0:.1f} s")

# %%
# The learning curve: episode return and success of the episodes that ended, binned.
steps, ret, ok = (np.array(c, dtype=float) for c in zip(*curve))
bins = np.linspace(0, steps.max(), 9)
idx = np.digitize(steps, bins[1:-1])
mid = [steps[idx == b].mean() for b in range(8) if np.any(idx == b)]
fig, ax = plt.subplots(1, 2, figsize=(9, 3.2))
ax[0].plot(mid, [ret[idx == b].mean() for b in range(8) if np.any(idx == b)], "o-")
ax[0].set(xlabel="hops trained", ylabel="mean episode return (raw)")
ax[1].plot(mid, [ok[idx == b].mean() for b in range(8) if np.any(idx == b)], "o-")
ax[1].set(xlabel="hops trained", ylabel="success rate", ylim=(0, 1.05))
for a in ax:
    a.grid(alpha=0.3)
fig.tight_layout()

# %%
# Score it with the contest judge
# -------------------------------
# :func:`hoprover_env.evaluation.episodes.run_episodes` runs one episode per target, all side
# by side in one vector env, deterministic actions, and the judge's TTRTP. The trained model and its
# observation statistics become an :class:`hoprover_env.agents.policies.SB3Policy`; the bundled
# ``hop`` policy (200 k hops of the same config) is the reference.
venv.training = False
mine = SB3Policy(
    model,
    venv.obs_rms,
    cfg["normalize"]["clip_obs"],
    name="this run",
    env_kwargs=cfg["env"],
    env_id="HopRoverHop-v0",
)
bundled = load_policy("hop")
targets = seeded_targets(100, seed=7)
rows = {}
for policy in (mine, bundled):
    results = run_episodes(policy, targets)
    rows[policy.name] = (results, summarize(results))
    s = rows[policy.name][1]
    print(
        f"{policy.name:>9}: success {s['success_rate']:.0%}, median TTRTP "
        f"{s['median_ttrtp']:.1f} s, p90 {s['p90_ttrtp']:.1f} s, broken {s['broken']}"
    )

# %%
# TTRTP per target: short hops are cheap, long ones cost a flight of minutes.
fig, ax = plt.subplots(figsize=(7, 3.5))
for name, (results, _) in rows.items():
    x = [r.target_x for r in results if r.success]
    y = [r.ttrtp for r in results if r.success]
    ax.plot(x, y, "o", ms=4, alpha=0.7, label=name)
ax.set(xlabel="target x [m]", ylabel="TTRTP [s]", title="successful episodes")
ax.grid(alpha=0.3)
ax.legend()
fig.tight_layout()

# %%
# A longer run of the same config (``python train.py --config configs/ppo_hop.yaml --out
# runs/hop``, 200 k hops, a few minutes) reaches the bundled policy's numbers; the
# learning curves of three seeds are on the :doc:`../benchmarks` page.
