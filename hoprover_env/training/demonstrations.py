"""Demonstrations in an off-policy learner's replay buffer (the config section
`demonstrations`): RL from reward and demonstrations.

    demonstrations:
      policy: scripted        # any load_policy name that acts on the config's env
      steps: 20000            # decisions played, in whole episodes (a few cut: prefill)
      seed: 0                 # the demonstrated episodes' seeds: seed, seed + 1, ...
      batch_share: 0.5        # share of every batch drawn from them (0: one shared buffer)

Before the first update of a fresh run, the policy plays whole episodes of the config's
env id with the config's env arguments (hoprover_env.evaluation.datasets.collect, the
collector of the offline datasets, so a demonstration is a replayable episode), at the
env's own control period and from rest (`flight_start` is a training start distribution,
not the demonstrator's). Every transition goes into the learner's replay buffer as SB3's
own collection stores one: the raw observation and the next one (VecNormalize normalises
both when it samples), the action in the policy's [-1, 1] scale, the unnormalised
reward, and a truncation at the time limit marked `TimeLimit.truncated`, so the learner
bootstraps there as it does on its own data. Each episode goes whole down one of the
buffer's env columns (`prefill` says why). The observation statistics of VecNormalize
are updated with the demonstrations' observations. The demonstrations stay in the buffer
until its ring overwrites them; a resumed run restores the buffer with them.

With `batch_share` > 0 the demonstrations are kept in a store of their own instead, and
every batch draws that share from it and the rest from the learner's own data (the
symmetric sampling of RLPD, Ball et al. 2023, at 0.5): the demonstrations keep their
weight in every update however much the learner has collected, where in one shared
buffer its own data dilutes them (20 k demonstrated decisions are 10 % of the buffer at
200 k steps). `DemonstrationReplayBuffer` and `DemonstrationNStepReplayBuffer` (for
`n_steps` > 1) are the learner's buffer then; `buffer_kwargs` says which.
"""

from __future__ import annotations

import numpy as np
import torch
from stable_baselines3.common.buffers import NStepReplayBuffer, ReplayBuffer

from hoprover_env.tasks.config import TRAINING_STARTS

DEFAULTS = {"policy": "scripted", "steps": 20_000, "seed": 0, "batch_share": 0.0}
KEYS = set(DEFAULTS)


def settings(cfg: dict) -> dict:
    """The config's demonstrations with every unset key at its default."""
    return {**DEFAULTS, **(cfg.get("demonstrations") or {})}


class _DemonstrationStore:
    """A replay buffer whose batches draw `batch_share` of their rows from a store of
    demonstrations (`demonstration_store`) and the rest from the learner's own data."""

    def __init__(self, *args, batch_share: float = 0.5, **kwargs):
        if not 0.0 < batch_share < 1.0:
            raise ValueError(f"batch_share must lie in (0, 1), got {batch_share!r}")
        super().__init__(*args, **kwargs)
        self.batch_share = batch_share
        self.demonstrations: ReplayBuffer | None = None

    def demonstration_store(self, rows: int) -> ReplayBuffer:
        """A new, empty store of `rows` rows per env, of this buffer's own kind (n-step
        returns included), that every batch draws from from now on."""
        base: type[ReplayBuffer] = ReplayBuffer
        extra = {}
        if isinstance(self, NStepReplayBuffer):
            base, extra = NStepReplayBuffer, {"n_steps": self.n_steps, "gamma": self.gamma}
        self.demonstrations = base(
            max(rows, 1) * self.n_envs,  # SB3 sizes a buffer in rows of all envs
            self.observation_space,
            self.action_space,
            device=self.device,
            n_envs=self.n_envs,
            handle_timeout_termination=self.handle_timeout_termination,
            **extra,
        )
        return self.demonstrations

    def sample(self, batch_size: int, env=None):
        demos = self.demonstrations
        if demos is None or demos.size() == 0:
            return super().sample(batch_size, env=env)
        k = int(round(self.batch_share * batch_size))
        own = super().sample(batch_size - k, env=env)
        theirs = demos.sample(k, env=env)
        return type(own)(*(None if a is None else torch.cat([a, b]) for a, b in zip(own, theirs)))


class DemonstrationReplayBuffer(_DemonstrationStore, ReplayBuffer):
    """SB3's ReplayBuffer with a demonstrations store (module docstring)."""


class DemonstrationNStepReplayBuffer(_DemonstrationStore, NStepReplayBuffer):
    """SB3's NStepReplayBuffer with a demonstrations store (module docstring)."""


def buffer_kwargs(cfg: dict) -> dict:
    """The algorithm's replay-buffer arguments for `cfg`'s demonstrations: none for one
    shared buffer; with a `batch_share`, the buffer class that keeps them apart (its
    n-step variant, given the n_steps and gamma that SB3 would give its own)."""
    share = float(settings(cfg)["batch_share"]) if cfg.get("demonstrations") else 0.0
    if share == 0.0:
        return {}
    hyper = cfg["hyperparams"]
    n_steps = int(hyper.get("n_steps", 1))
    if n_steps > 1:
        return {
            "replay_buffer_class": DemonstrationNStepReplayBuffer,
            "replay_buffer_kwargs": {
                "batch_share": share,
                "n_steps": n_steps,
                "gamma": float(hyper.get("gamma", 0.99)),
            },
        }
    return {
        "replay_buffer_class": DemonstrationReplayBuffer,
        "replay_buffer_kwargs": {"batch_share": share},
    }


def collect_demonstrations(cfg: dict, env_kwargs: dict) -> list:
    """The demonstrated episodes (Minari EpisodeBuffers) of `cfg`'s demonstrations."""
    try:
        import minari  # noqa: F401  (the episode buffers of the collector)
    except ImportError:
        raise SystemExit(
            "error: the config's demonstrations need Minari: pip install 'hoprover[offline]'"
        ) from None
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.envs.registry import config_class
    from hoprover_env.evaluation.datasets import collect

    demo = settings(cfg)
    kwargs = {k: v for k, v in env_kwargs.items() if k not in TRAINING_STARTS}
    control_dt = config_class(cfg["env_id"])(**kwargs).control_dt
    try:
        policy = load_policy(demo["policy"], control_dt=control_dt)
    except (ValueError, FileNotFoundError) as exc:
        raise SystemExit(f"error: demonstrations.policy {demo['policy']!r}: {exc}") from None
    return collect(
        cfg["env_id"],
        [policy],
        kwargs,
        n_steps=int(demo["steps"]),
        num_envs=16,
        seed=int(demo["seed"]),
    )


def columns(lengths: list[int], n: int) -> tuple[list[list[int]], int]:
    """Which episodes go to which of the buffer's `n` env columns: each episode, in order,
    to the column holding the fewest transitions so far. Returns the columns' episode
    indices and the rows every column can fill (the shortest column's length)."""
    cols: list[list[int]] = [[] for _ in range(n)]
    filled = [0] * n
    for i, length in enumerate(lengths):
        c = filled.index(min(filled))
        cols[c].append(i)
        filled[c] += length
    return cols, min(filled)


def prefill(model, venv, episodes: list) -> dict:
    """Add the transitions of `episodes` to `model`'s replay buffer (see the module
    docstring) and update `venv`'s observation statistics when it normalises them.
    Returns what was added: transitions, episodes and their mean return.

    The buffer holds one column per env, whose consecutive rows an n-step return
    (SB3's NStepReplayBuffer) reads as consecutive decisions of one episode, so each
    episode goes whole down one column (`columns`), and the columns are cut to the
    shortest: a transition cut from its episode's next one, and the last of each
    column, is marked truncated (bootstrapped from its true next observation), so that
    no return runs past it into another episode or the learner's own data."""
    buf = model.replay_buffer
    n = buf.n_envs
    cols, rows = columns([len(ep.actions) for ep in episodes], n)
    if isinstance(buf, _DemonstrationStore):
        buf = buf.demonstration_store(rows)
    stacked = []
    for col in cols:
        parts = {key: [] for key in ("obs", "next", "act", "rew", "done", "trunc")}
        for i in col:
            ep = episodes[i]
            o = np.asarray(ep.observations, np.float32)
            steps = len(ep.actions)
            te, tr = np.asarray(ep.terminations, bool), np.asarray(ep.truncations, bool)
            parts["obs"].append(o[:-1])
            parts["next"].append(o[1:])
            parts["act"].append(np.asarray(ep.actions, np.float32).reshape(steps, -1))
            parts["rew"].append(np.asarray(ep.rewards, np.float32))
            parts["done"].append(te | tr)
            parts["trunc"].append(tr & ~te)
        col_data = {key: np.concatenate(v)[:rows] for key, v in parts.items()}
        if rows and not col_data["done"][-1]:  # cut: bootstrap, do not run on
            col_data["done"][-1] = col_data["trunc"][-1] = True
        stacked.append(col_data)
    for r in range(rows):
        buf.add(
            np.stack([c["obs"][r] for c in stacked]),
            np.stack([c["next"][r] for c in stacked]),
            np.stack([c["act"][r] for c in stacked]),
            np.array([c["rew"][r] for c in stacked]),
            np.array([c["done"][r] for c in stacked]),
            [{"TimeLimit.truncated": bool(c["trunc"][r])} for c in stacked],
        )
    rms = getattr(venv, "obs_rms", None)
    if rms is not None and getattr(venv, "norm_obs", False) and rows:
        rms.update(np.concatenate([c["obs"] for c in stacked]))
    return {
        "transitions": int(rows * n),
        "episodes": len(episodes),
        "return_mean": float(np.mean([np.sum(ep.rewards) for ep in episodes])),
    }
