"""
Domain randomisation and the robustness of a policy
===================================================

The bundled policies were trained on the contest's rover. How do they fare on rovers
that differ from it: other friction, restitution, gravity, mass? Every environment takes
``randomize={parameter: r}``: at each reset the listed parameters are scaled by
U(1 - r, 1 + r), drawn from the env's own seeded generator. This tutorial measures
success and TTRTP of two bundled policies and the scripted hopper as the spread grows.
"""

# %%
# Randomised episodes
# -------------------
# The parameters of an episode are in ``env.unwrapped.params`` (a
# :class:`~hoprover_env.RoverParams`):
import gymnasium as gym
import matplotlib.pyplot as plt

import hoprover_env  # noqa: F401  (registers the env ids)
from hoprover_env.agents.policies import load_policy
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

env = gym.make("HopRover-v0", randomize={"gravity": 0.3, "mu_static": 0.2})
for seed in range(3):
    env.reset(seed=seed)
    p = env.unwrapped.params
    print(
        f"seed {seed}: gravity {p.gravity:.3e} m/s^2, mu_static {p.mu_static:.3f}, "
        f"target {env.unwrapped.target_x:+.3f} m"
    )

# %%
# Robustness against the spread
# -----------------------------
# The same 40 targets at each level; the relative half-range r applies to all five
# parameters at once. Evaluation runs the episodes side by side in one vector env, so
# each sub-env draws its own rover.
levels = [0.0, 0.1, 0.2, 0.3]
names = ("gravity", "mu_static", "mu_dynamic", "restitution_x", "restitution_y")
targets = seeded_targets(40, seed=11)
table = {}
for spec in ("scratch", "hop", "scripted"):
    policy = load_policy(spec)
    for r in levels:
        randomize = {n: r for n in names} if r else None
        s = summarize(run_episodes(policy, targets, env_kwargs={"randomize": randomize}))
        table[spec, r] = s
        print(
            f"{spec:>8} r = {r:.1f}: success {s['success_rate']:6.1%}, median TTRTP "
            f"{s['median_ttrtp']:6.1f} s, broken {s['broken']}"
        )

# %%
# The scripted hopper plans its hops with the *nominal* rover (it does not know the
# drawn parameters), like the policies; it corrects with further hops when a plan lands
# wrong.
fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
for spec in ("scratch", "hop", "scripted"):
    ax[0].plot(levels, [table[spec, r]["success_rate"] for r in levels], "o-", label=spec)
    ax[1].plot(levels, [table[spec, r]["median_ttrtp"] for r in levels], "o-", label=spec)
ax[0].set(xlabel="relative half-range r", ylabel="success rate", ylim=(0, 1.05))
ax[1].set(xlabel="relative half-range r", ylabel="median TTRTP [s]")
for a in ax:
    a.grid(alpha=0.3)
    a.legend()
fig.tight_layout()

# %%
# Training under randomisation
# ----------------------------
# To make a policy robust, train it on randomised episodes: put ``randomize`` in the
# ``env`` section of a config (``python train.py --config ...``), or pass it to the
# SB3 adapter as any env argument::
#
#     from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
#     venv = HopRoverSB3VecEnv(64, seed=0, env_id="HopRoverHop-v0",
#                              randomize={"gravity": 0.2, "mu_static": 0.2})
#
# Sub-env i of a vector env seeded with s draws the same rovers as a single env seeded
# with s + i, so a randomised training run is reproducible.
