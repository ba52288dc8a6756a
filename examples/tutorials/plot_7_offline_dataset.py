"""
Offline RL: build a Minari dataset, clone it, judge the clone on the suite
==========================================================================

hoprover writes D4RL-style datasets with Minari (``hoprover_env.evaluation.datasets``, the
``offline`` extra). Here we build a small expert dataset of ``HopRover-v0`` from the
native vector env, load it back as any Minari user would, check that an episode replays
bit for bit from its recorded seed, train behaviour cloning with a few lines of PyTorch,
and score the clone on the task's frozen suite against the best-known references.
The same steps at full size (1 M steps, d3rlpy's BC, IQL and CQL, three seeds) are
``python -m research.offline_baselines``; their results are in docs/studies/offline.md.

Needs: ``pip install 'hoprover[offline,scores]'`` (Minari and h5py for the dataset,
rliable for the score intervals).
"""

# %%
# Build the dataset
# -----------------
# ``build`` runs the task's expert (the bundled ``scratch`` policy) in 64 sub-envs until
# the step budget is reached and writes ``hoprover/HopRover-v0/expert-v0`` under the
# directory, where ``MINARI_DATASETS_PATH`` finds it. The command line does the same:
# ``hoprover-datasets --task HopRover-v0 --level expert --steps 20000 --out DIR``.
import os
import tempfile
import time

try:  # the offline and scores extras
    import h5py  # noqa: F401  (Minari's dataset files)
    import minari
    import rliable  # noqa: F401  (the score intervals)
except ImportError as err:
    raise SystemExit(
        f"This tutorial needs the offline and scores extras ({err.name} is "
        "missing): pip install 'hoprover[offline,scores]'"
    ) from err
import matplotlib.pyplot as plt
import numpy as np
import torch

import hoprover_env  # noqa: F401  (registers the env ids Minari recovers)
from hoprover_env.agents.policies import ArrayPolicy, load_policy
from hoprover_env.evaluation import datasets, suites
from hoprover_env.evaluation.scores import summarize

torch.set_num_threads(1)
out = tempfile.mkdtemp(prefix="hoprover-datasets-")
t0 = time.perf_counter()
datasets.build("HopRover-v0", "expert", 20_000, out)
print(f"built in {time.perf_counter() - t0:.1f} s")

# %%
# Load it with Minari
# -------------------
# The dataset carries its reference scores (the random agent's and the expert's mean
# return on the frozen suite), the env it was collected in and the agent that made it.
os.environ["MINARI_DATASETS_PATH"] = out
ds = minari.load_dataset("hoprover/HopRover-v0/expert-v0")
print(ds.total_episodes, "episodes,", ds.total_steps, "steps")
meta = ds.storage.metadata
print("ref_min_score", meta["ref_min_score"], "ref_max_score", meta["ref_max_score"])
print("made by:", meta["algorithm_name"])
returns = [e.rewards.sum() for e in ds.iterate_episodes()]
print(
    "normalised score of the dataset's episodes:",
    minari.get_normalized_score(ds, np.array(returns)).mean().round(3),
)
env = ds.recover_environment()
print("recovered:", env.spec.id, env.spec.kwargs)

# %%
# Replay an episode from its seed
# -------------------------------
# Every episode records, in Minari's per-episode metadata, the seed (and reset options)
# it was reset with. Resetting the recovered env with them and stepping the recorded
# actions gives the recorded observations and rewards bit for bit.
ep = next(ds.iterate_episodes())
meta = next(iter(ds.storage.get_episode_metadata([ep.id])))
obs, _ = env.reset(seed=int(meta["seed"]), options=meta.get("options") or None)
same = np.array_equal(obs, ep.observations[0])
for k, a in enumerate(ep.actions):
    obs, reward, *_ = env.step(a)
    same &= np.array_equal(obs, ep.observations[k + 1]) and reward == ep.rewards[k]
print("episode", ep.id, "replays bit for bit:", bool(same))

# %%
# Behaviour cloning
# -----------------
# A 2 x 128 tanh network regresses the expert's actions from standardised observations.
obs = np.concatenate([e.observations[:-1] for e in ds.iterate_episodes()]).astype(np.float32)
act = np.concatenate([e.actions for e in ds.iterate_episodes()]).astype(np.float32)
mean, std = obs.mean(0), obs.std(0) + 1e-6
x, y = torch.from_numpy((obs - mean) / std), torch.from_numpy(act)
torch.manual_seed(0)
net = torch.nn.Sequential(
    torch.nn.Linear(x.shape[1], 128),
    torch.nn.Tanh(),
    torch.nn.Linear(128, 128),
    torch.nn.Tanh(),
    torch.nn.Linear(128, y.shape[1]),
    torch.nn.Tanh(),
)
opt = torch.optim.Adam(net.parameters(), lr=1e-3)
losses = []
for _epoch in range(30):
    perm = torch.randperm(len(x))
    for i in range(0, len(x), 256):
        idx = perm[i : i + 256]
        loss = torch.nn.functional.mse_loss(net(x[idx]), y[idx])
        opt.zero_grad()
        loss.backward()
        opt.step()
    losses.append(loss.item())
plt.semilogy(losses)
plt.xlabel("epoch")
plt.ylabel("last batch's MSE")
plt.title("behaviour cloning on 20 k expert steps")
plt.show()

# %%
# Judge the clone on the frozen suite
# -----------------------------------
# The suite's 200 episodes fix targets and seeds, each with a best-known reference time
# (the yardstick). The clone acts in the dataset's env (its control period) and is
# scored beside the expert it imitates: success, median regret (TTRTP over the
# reference) and the IQM of the normalised score, with bootstrap intervals.
suite = suites.load("HopRover-v0")
kwargs = dict(ds.spec.env_spec.kwargs)


@torch.no_grad()
def clone_actions(o):
    return net(torch.from_numpy((np.asarray(o, np.float32) - mean) / std)).numpy()


clone = ArrayPolicy(clone_actions, name="bc clone", env_kwargs=kwargs)
summaries = []
for policy in (clone, load_policy("scratch")):
    rows = suites.run(policy, suite)
    summaries.append(summarize(policy.name, np.array([[r["score"] for r in rows]])))
    p = summaries[-1].point
    print(
        f"{policy.name:>10}: success {p['success']:.1%}, median regret "
        f"{p['median_regret']:.3f}, IQM score {p['iqm_score']:.3f}"
    )

# %%
# The dataset was written to a temporary directory; a real one goes where
# ``MINARI_DATASETS_PATH`` points, and docs/datasets.md says how to publish it.
import shutil  # noqa: E402

shutil.rmtree(out)
