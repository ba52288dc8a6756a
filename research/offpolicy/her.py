"""SAC (or TD3, TQC) with hindsight experience replay on HopRoverGoal-v1, trained the way
SB3's users run HER: `make_vec_env` over the Gymnasium env, `MultiInputPolicy`,
`HerReplayBuffer` with `copy_info_dict` (the goal env's reward reads the transitions'
infos), and every `evaluation.freq` steps the contest's judge on fixed validation targets.

    python -m research.offpolicy.her --config research/offpolicy/sac_her.yaml \\
        --out runs/sac_her_s0 --seed 0 --torch-threads 1
    python -m research.offpolicy.her --config ... --out runs/sac_her_s0 --resume

The config is a train.py-like YAML (algo, n_envs, timesteps, env, her, normalize,
policy, hyperparams, evaluation); its `env` arguments go to the training envs only,
and validation starts every episode upright at rest, as the contest does (no
`flight_start`). A validation episode ends at the judge's success (the 5 s dwell in the
band), a break, or the time limit; it is scored as train.py scores its own (success
rate, median and 90th-percentile TTRTP of the successes, broken count), so the curves
compare with `evaluations.csv` of train.py's runs.

The run directory holds `config.yaml`, `evaluations.csv` (rewritten atomically after
each evaluation), `best_model.zip` with its observation statistics and a JSON, and
`checkpoints/last*` (model, replay buffer, statistics and a JSON with the evaluations so
far, written after each evaluation by train.py's `save_model`): `--resume` continues
from them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.evaluation.episodes import seeded_targets
from hoprover_env.tasks.config import TRAINING_STARTS
from hoprover_env.training.train import save_model, write_evaluations
from hoprover_env.util.files import atomic_write

ENV_ID = "HopRoverGoal-v1"


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--config", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--seed", type=int, default=None, help="the config's seed by default")
    p.add_argument("--timesteps", type=int, default=None)
    p.add_argument("--resume", action="store_true", help="continue from checkpoints/last")
    p.add_argument("--torch-threads", type=int, default=None)
    return p.parse_args(argv)


HER_KEYS = {"n_sampled_goal", "goal_selection_strategy", "copy_info_dict"}


def load_config(path: str, seed: int | None, timesteps: int | None) -> dict:
    """The config at `path`, checked as train.py checks its own where the sections are
    the same (SystemExit naming the key otherwise)."""
    import gymnasium as gym

    from hoprover_env.training.config_types import HYPER_TYPES, POLICY_TYPES
    from hoprover_env.training.sb3_agents import (
        ACTOR_OPTION_KEYS,
        ConfigError,
        check_sections,
        hyper_keys,
        policy_keys,
    )

    with open(path) as f:
        cfg = yaml.safe_load(f)
    known = {"algo", "n_envs", "timesteps", "seed", "env", "her", "normalize", "policy"}
    known |= {"hyperparams", "evaluation"}
    unknown = set(cfg) - known
    if unknown:
        raise SystemExit(f"error: {path}: unknown config keys {sorted(unknown)}")
    own = {"replay_buffer_class", "replay_buffer_kwargs", "learning_rate_end"}
    # SB3's MultiInputPolicy builds its own extractor and has no layer-normalised critics;
    # the actor's options come with a MultiInputPolicy of hoprover's (make_model)
    hoprover_keys = {"critic_layer_norm", "features_extractor"}
    for section, valid in (
        ("hyperparams", hyper_keys(cfg["algo"]) - own),
        ("policy", policy_keys(cfg["algo"]) - hoprover_keys),
        ("her", HER_KEYS),
    ):
        bad = sorted(set(cfg.get(section) or {}) - valid)
        if bad:
            raise SystemExit(f"error: {path}: unknown config key '{section}.{bad[0]}'")
    try:
        check_sections(cfg, policy=POLICY_TYPES, hyperparams=HYPER_TYPES)
    except ConfigError as exc:
        raise SystemExit(f"error: {path}: {exc}") from None
    if any((cfg.get("policy") or {}).get(k) for k in ACTOR_OPTION_KEYS):
        from hoprover_env.training.actor_penalty import MULTI_INPUT_POLICIES

        if cfg["algo"] not in MULTI_INPUT_POLICIES:
            raise SystemExit(
                f"error: {path}: the actor's options ({', '.join(ACTOR_OPTION_KEYS)}) come "
                f"with a Dict-observation policy for {sorted(MULTI_INPUT_POLICIES)} only"
            )
    try:
        env = gym.make(ENV_ID, **(cfg.get("env") or {})).unwrapped
    except (TypeError, ValueError) as exc:
        raise SystemExit(f"error: {path}: config section 'env': {exc}") from None
    gamma = cfg["hyperparams"].get("gamma", 0.99)
    if gamma != env.gamma:
        raise SystemExit(
            f"error: {path}: hyperparams.gamma {gamma} is not the env's shaping discount "
            f"{env.gamma} (the shaping leaves the optimal policy alone only with the same one)"
        )
    if seed is not None:
        cfg["seed"] = seed
    if timesteps is not None:
        cfg["timesteps"] = timesteps
    return cfg


def make_model(cfg: dict, venv):
    from stable_baselines3 import HerReplayBuffer

    from hoprover_env.training.sb3_agents import ACTOR_OPTION_KEYS, algo_class, policy_kwargs

    # train.py's own reading of the section: activation by name, unset actor options dropped
    policy = policy_kwargs({"policy": cfg.get("policy") or {}})
    policy_class: Any = "MultiInputPolicy"
    if any(policy.get(key) for key in ACTOR_OPTION_KEYS):  # as train.py's make_agent chooses
        from hoprover_env.training.actor_penalty import MULTI_INPUT_POLICIES

        policy_class = MULTI_INPUT_POLICIES[cfg["algo"]]
    her = {"copy_info_dict": True, **(cfg.get("her") or {})}
    return algo_class(cfg["algo"])(
        policy_class,
        venv,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=her,
        policy_kwargs=policy,
        seed=cfg["seed"],
        verbose=0,
        **cfg["hyperparams"],
    )


def validate(model, venv, cfg: dict, targets: np.ndarray) -> dict:
    """The judge's summary of the deterministic policy, one episode per target from rest."""
    import gymnasium as gym

    env_kwargs = {k: v for k, v in (cfg.get("env") or {}).items() if k not in TRAINING_STARTS}
    envs = [gym.make(ENV_ID, **env_kwargs).unwrapped for _ in targets]
    obs = [
        env.reset(seed=i, options={"target_x": float(t)})[0]
        for i, (env, t) in enumerate(zip(envs, targets, strict=True))
    ]
    live = np.ones(len(envs), bool)
    ttrtp = np.full(len(envs), np.nan)
    broken = np.zeros(len(envs), bool)
    while live.any():
        idx = np.flatnonzero(live)
        batch = {k: np.stack([obs[i][k] for i in idx]) for k in obs[0]}
        actions, _ = model.predict(venv.normalize_obs(batch), deterministic=True)
        for j, i in enumerate(idx):
            obs[i], _, term, trunc, info = envs[i].step(actions[j])
            if info["is_success"]:
                ttrtp[i] = float(info["ttrtp"])
            broken[i] = bool(info["broken"])
            if info["is_success"] or term or trunc:
                live[i] = False
    for env in envs:
        env.close()
    done = ttrtp[np.isfinite(ttrtp)]
    return {
        "success_rate": float(np.isfinite(ttrtp).mean()),
        "median_ttrtp": float(np.median(done)) if done.size else float("nan"),
        "p90_ttrtp": float(np.percentile(done, 90)) if done.size else float("nan"),
        "broken": int(broken.sum()),
    }


def main(argv=None) -> int:
    args = parse_args(argv)
    import torch
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from hoprover_env.training.sb3_agents import algo_class

    if args.torch_threads:
        torch.set_num_threads(args.torch_threads)
    out = Path(args.out)
    ckpt = out / "checkpoints" / "last"
    if args.resume:
        cfg = yaml.safe_load((out / "config.yaml").read_text())
        if args.timesteps is not None:
            cfg["timesteps"] = args.timesteps
    else:
        if (out / "config.yaml").exists():
            raise SystemExit(f"error: {out} holds a run already (--resume continues it)")
        cfg = load_config(args.config, args.seed, args.timesteps)
        atomic_write(out / "config.yaml", yaml.safe_dump(cfg, sort_keys=False))
    ev = cfg["evaluation"]
    targets = seeded_targets(ev["episodes"], ev["seed"])
    base = make_vec_env(ENV_ID, n_envs=cfg["n_envs"], seed=cfg["seed"], env_kwargs=cfg.get("env"))
    norm = cfg.get("normalize") or {}
    if args.resume:
        venv = VecNormalize.load(f"{ckpt}_vecnormalize.pkl", base)
        model = algo_class(cfg["algo"]).load(f"{ckpt}.zip", env=venv)
        model.load_replay_buffer(f"{ckpt}_replay_buffer.pkl")
        state = json.loads(Path(f"{ckpt}.json").read_text())
        rows, best, wall0 = state["evaluations"], state["best"], state["wall_s"]
        print(f"resuming {out} at {model.num_timesteps} steps", flush=True)
    else:
        venv = VecNormalize(
            base,
            norm_obs=norm.get("obs", True),
            norm_reward=False,
            clip_obs=norm.get("clip_obs", 10.0),
            norm_obs_keys=["observation"],
        )
        model = make_model(cfg, venv)
        rows, best, wall0 = [], None, 0.0
    start = time.monotonic()
    chunk = ev["freq"]
    while model.num_timesteps < cfg["timesteps"]:
        steps = min(chunk - model.num_timesteps % chunk, cfg["timesteps"] - model.num_timesteps)
        model.learn(steps, reset_num_timesteps=False)
        wall = wall0 + time.monotonic() - start
        res = validate(model, venv, cfg, targets)
        row = {"timesteps": int(model.num_timesteps), "wall_s": round(wall, 1), **res}
        rows.append(row)
        write_evaluations(out, rows)
        print(json.dumps(row), flush=True)
        key = [res["success_rate"], -res["broken"]]
        state = {"timesteps": int(model.num_timesteps), "evaluations": rows, "wall_s": wall}
        if best is None or key > best:
            best = key
            save_model(model, venv, out / "best_model", {**state, "best": best})
        save_model(model, venv, ckpt, {**state, "best": best}, replay=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
