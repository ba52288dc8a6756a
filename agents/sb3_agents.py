"""Stable-Baselines3 agents for hoprover, built from a YAML config (configs/*.yaml).

A config has these sections (every key is checked; a typo is an error that names it):

    algo: ppo | sac | td3
    env_id: HopRover-v0             # or HopRoverContest-v0 (fixes the target)
    n_envs: 32                      # sub-envs of the native batched env
    timesteps: 2000000
    seed: 0
    env: {...}                      # HopRoverEnv arguments (control_dt, shaping, ...)
    normalize: {obs: true, reward: true, clip_obs: 10.0}
    policy: {...}                   # policy_kwargs: net_arch, activation_fn, log_std_init
    hyperparams: {...}              # keyword arguments of PPO / SAC / TD3
    pretrain: {...}                 # optional behaviour cloning (PPO): expert, episodes, epochs
    evaluation: {freq, episodes, seed}
    checkpoint: {freq}
"""
from __future__ import annotations

import copy
import dataclasses
import inspect
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hoprover_env.env_config import EnvConfig, HopEnvConfig

ALGOS = ("ppo", "sac", "td3")
TOP_KEYS = {"algo", "env_id", "n_envs", "timesteps", "seed", "env", "normalize", "policy",
            "hyperparams", "pretrain", "evaluation", "checkpoint"}
NORMALIZE_KEYS = {"obs", "reward", "clip_obs", "clip_reward", "update"}
POLICY_KEYS = {"net_arch", "activation_fn", "log_std_init", "ortho_init", "use_expln",
               "squash_output", "n_critics", "share_features_extractor"}
PRETRAIN_KEYS = {"expert", "episodes", "epochs", "batch_size", "learning_rate", "seed",
                 "value_epochs", "log_std", "noise", "dagger_rounds", "dagger_episodes"}
EVAL_KEYS = {"freq", "episodes", "seed"}
CHECKPOINT_KEYS = {"freq"}
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU",
               "gelu": "GELU", "silu": "SiLU"}
DEFAULTS = {"env_id": "HopRover-v0", "n_envs": 32, "timesteps": 1_000_000, "seed": 0,
            "env": {}, "normalize": {"obs": True, "reward": True, "clip_obs": 10.0},
            "policy": {}, "hyperparams": {}, "pretrain": None,
            "evaluation": {"freq": 100_000, "episodes": 100, "seed": 7},
            "checkpoint": {"freq": 200_000}}


class ConfigError(ValueError):
    """A bad config key or value; the message names it."""


def algo_class(algo: str):
    from stable_baselines3 import PPO, SAC, TD3
    if algo not in ALGOS:
        raise ConfigError(f"algo must be one of {list(ALGOS)}, got {algo!r}")
    return {"ppo": PPO, "sac": SAC, "td3": TD3}[algo]


def _check_keys(section: str, given: dict, valid: set):
    if not isinstance(given, dict):
        raise ConfigError(f"config section '{section}' must be a mapping, got {type(given).__name__}")
    bad = sorted(set(given) - valid)
    if bad:
        raise ConfigError(f"unknown config key '{section}.{bad[0]}' (valid: {sorted(valid)})")


def load_config(path: str | Path | None, overrides: dict | None = None) -> dict:
    """Read, fill in defaults, apply command-line overrides, and validate a config."""
    raw: dict = {}
    if path is not None:
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"config file not found: {path}")
        raw = yaml.safe_load(path.read_text()) or {}
        if not isinstance(raw, dict):
            raise ConfigError(f"{path}: the config must be a mapping")
    bad = sorted(set(raw) - TOP_KEYS)
    if bad:
        raise ConfigError(f"unknown config key '{bad[0]}' (valid: {sorted(TOP_KEYS)})")
    cfg = copy.deepcopy(DEFAULTS)
    for key, value in raw.items():
        if isinstance(cfg.get(key), dict) and isinstance(value, dict) and key != "env":
            cfg[key] = {**cfg[key], **value}
        else:
            cfg[key] = value
    for key, value in (overrides or {}).items():
        if value is not None:
            cfg[key] = value
    validate(cfg)
    return cfg


def validate(cfg: dict) -> None:
    if "algo" not in cfg:
        raise ConfigError("config key 'algo' is missing (ppo, sac or td3)")
    cls = algo_class(cfg["algo"])
    from hoprover_env import ENVS
    if cfg.get("env_id") not in ENVS:
        raise ConfigError(f"config key 'env_id' must be one of {sorted(ENVS)}, "
                          f"got {cfg.get('env_id')!r}")
    env_cls = HopEnvConfig if cfg["env_id"] == "HopRoverHop-v0" else EnvConfig
    env_fields = {f.name for f in dataclasses.fields(env_cls)}
    _check_keys("env", cfg["env"], env_fields)
    try:
        env_cls(**cfg["env"])
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"config section 'env': {exc}") from None
    _check_keys("normalize", cfg["normalize"], NORMALIZE_KEYS)
    _check_keys("policy", cfg["policy"], POLICY_KEYS)
    if "activation_fn" in cfg["policy"] and cfg["policy"]["activation_fn"] not in ACTIVATIONS:
        raise ConfigError(f"config key 'policy.activation_fn' must be one of "
                          f"{sorted(ACTIVATIONS)}, got {cfg['policy']['activation_fn']!r}")
    params = set(inspect.signature(cls.__init__).parameters) - {"self", "policy", "env",
                                                                 "policy_kwargs", "seed",
                                                                 "tensorboard_log", "_init_setup_model"}
    _check_keys("hyperparams", cfg["hyperparams"], params)
    if cfg.get("pretrain") is not None:
        _check_keys("pretrain", cfg["pretrain"], PRETRAIN_KEYS)
        if cfg["algo"] != "ppo":
            raise ConfigError("config section 'pretrain' (behaviour cloning) is only "
                              "supported with algo: ppo")
    _check_keys("evaluation", cfg["evaluation"], EVAL_KEYS)
    _check_keys("checkpoint", cfg["checkpoint"], CHECKPOINT_KEYS)
    for key in ("n_envs", "timesteps"):
        if not (isinstance(cfg[key], int) and cfg[key] >= 1):
            raise ConfigError(f"config key '{key}' must be a positive integer, got {cfg[key]!r}")


def env_kwargs(cfg: dict) -> dict:
    """HopRoverEnv arguments of a config (the contest id fixes the target)."""
    kw = dict(cfg["env"])
    if cfg["env_id"] == "HopRoverContest-v0":
        kw.setdefault("target_x", 0.5)
    return kw


def policy_kwargs(cfg: dict) -> dict:
    import torch.nn as nn
    kw = dict(cfg["policy"])
    if "activation_fn" in kw:
        kw["activation_fn"] = getattr(nn, ACTIVATIONS[kw["activation_fn"]])
    return kw


def make_agent(cfg: dict, venv, tensorboard_log: str | None = None, device: str = "cpu"):
    """A fresh PPO / SAC / TD3 from a validated config."""
    cls = algo_class(cfg["algo"])
    hyper: dict[str, Any] = dict(cfg["hyperparams"])
    if cfg["algo"] == "td3" and isinstance(hyper.get("action_noise"), (int, float)):
        from stable_baselines3.common.noise import NormalActionNoise
        sigma = float(hyper.pop("action_noise"))
        hyper["action_noise"] = NormalActionNoise(np.zeros(1), sigma * np.ones(1))
    return cls("MlpPolicy", venv, policy_kwargs=policy_kwargs(cfg), seed=cfg["seed"],
               tensorboard_log=tensorboard_log, device=device, verbose=0, **hyper)
