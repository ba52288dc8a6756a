"""Demonstrations in an off-policy learner's replay buffer (the config section
`demonstrations`): RL from reward and demonstrations.

    demonstrations:
      policy: scripted        # any load_policy name that acts on the config's env
      steps: 20000            # at least this many decisions, every episode whole
      seed: 0                 # the demonstrated episodes' seeds: seed, seed + 1, ...

Before the first update of a fresh run, the policy plays whole episodes of the config's
env id with the config's env arguments (hoprover_env.evaluation.datasets.collect, the
collector of the offline datasets, so a demonstration is a replayable episode), at the
env's own control period and from rest (`flight_start` is a training start distribution,
not the demonstrator's). Every transition goes into the learner's replay buffer as SB3's
own collection stores one: the raw observation and the next one (VecNormalize normalises
both when it samples), the action in the policy's [-1, 1] scale, the unnormalised
reward, and a truncation at the time limit marked `TimeLimit.truncated`, so the learner
bootstraps there as it does on its own data. The observation statistics of VecNormalize
are updated with the demonstrations' observations. The demonstrations stay in the buffer
until its ring overwrites them; a resumed run restores the buffer with them.
"""

from __future__ import annotations

import numpy as np

DEFAULTS = {"policy": "scripted", "steps": 20_000, "seed": 0}
KEYS = set(DEFAULTS)


def settings(cfg: dict) -> dict:
    """The config's demonstrations with every unset key at its default."""
    return {**DEFAULTS, **(cfg.get("demonstrations") or {})}


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
    kwargs = {k: v for k, v in env_kwargs.items() if k != "flight_start"}
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


def prefill(model, venv, episodes: list) -> dict:
    """Add the transitions of `episodes` to `model`'s replay buffer (see the module
    docstring) and update `venv`'s observation statistics when it normalises them.
    Returns what was added: transitions, episodes and their mean return."""
    buf = model.replay_buffer
    n = buf.n_envs
    obs, nxt, act, rew, done, trunc = [], [], [], [], [], []
    for ep in episodes:
        o = np.asarray(ep.observations, np.float32)
        steps = len(ep.actions)
        obs.append(o[:-1])
        nxt.append(o[1:])
        act.append(np.asarray(ep.actions, np.float32).reshape(steps, -1))
        rew.append(np.asarray(ep.rewards, np.float32))
        te, tr = np.asarray(ep.terminations, bool), np.asarray(ep.truncations, bool)
        done.append(te | tr)
        trunc.append(tr & ~te)
    obs, nxt, act, rew, done, trunc = map(np.concatenate, (obs, nxt, act, rew, done, trunc))
    usable = len(obs) - len(obs) % n  # the buffer takes one row per env at a time
    for i in range(0, usable, n):
        rows = slice(i, i + n)
        buf.add(
            obs[rows],
            nxt[rows],
            act[rows],
            rew[rows],
            done[rows],
            [{"TimeLimit.truncated": bool(t)} for t in trunc[rows]],
        )
    rms = getattr(venv, "obs_rms", None)
    if rms is not None and getattr(venv, "norm_obs", False):
        rms.update(obs)
    return {
        "transitions": int(usable),
        "episodes": len(episodes),
        "return_mean": float(np.mean([np.sum(ep.rewards) for ep in episodes])),
    }
