"""Stable-Baselines3 agents for hoprover, built from a YAML config (configs/*.yaml).

A config has these sections (every key is checked; a typo is an error that names it):

    algo: ppo | sac | td3 | tqc | crossq | recurrentppo   # the last three: sb3-contrib
    env_id: HopRover-v0             # or HopRoverContest-v0 (fixes the target)
    n_envs: 32                      # sub-envs of the native batched env
    timesteps: 2000000
    seed: 0
    env: {...}                      # HopRoverEnv arguments (control_dt, shaping, ...)
    normalize: {obs: true, reward: true, clip_obs: 10.0}
    policy: {...}                   # policy_kwargs: net_arch, activation_fn, log_std_init,
                                    # and the algorithm's own (n_quantiles, lstm_hidden_size);
                                    # critic_layer_norm (SAC, TD3), actor_mean_reg
                                    # (SAC, TQC, CrossQ), actor_lr_scale (those and
                                    # TD3) and actor_layer_norm (SAC, TQC) are hoprover's
    hyperparams: {...}              # keyword arguments of the algorithm (PPO, SAC, ...)
    pretrain: {...}                 # optional behaviour cloning (PPO): expert, episodes, epochs
    init_from: terrain              # optional: start from this model's weights and its
                                    # VecNormalize statistics (a bundled name, a run
                                    # directory or a .zip); everything else from here
    demonstrations: {...}           # optional (off-policy): training/demonstrations.py
    redo: {freq, tau, batch}        # optional (SAC, TQC): training/redo.py
    evaluation: {freq, episodes, seed}
    checkpoint: {freq, seconds}     # every freq steps and every `seconds` of wall time;
                                    # keep: true also keeps each freq checkpoint's model
                                    # (checkpoints/model_STEPS.zip, no replay buffer)
"""

from __future__ import annotations

import copy
import inspect
import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hoprover_env.agents.policies import ALGOS, SB3_ALGOS, _algo_class
from hoprover_env.training.config_types import (
    CHECKPOINT_TYPES,
    DEMONSTRATION_TYPES,
    EVAL_TYPES,
    HYPER_TYPES,
    INT,
    NORMALIZE_TYPES,
    POLICY_TYPES,
    POS_INT,
    PRETRAIN_TYPES,
    REDO_TYPES,
)

TOP_KEYS = {
    "algo",
    "env_id",
    "n_envs",
    "timesteps",
    "seed",
    "env",
    "normalize",
    "policy",
    "hyperparams",
    "pretrain",
    "evaluation",
    "checkpoint",
    "init_from",
    "demonstrations",
    "redo",
}
# hyperparams keys that are hoprover's, not the algorithm's: `learning_rate_end` makes the
# learning rate fall linearly from `learning_rate` to it over the run
OWN_HYPER_KEYS = {"learning_rate_end"}
NORMALIZE_KEYS = {"obs", "reward", "clip_obs", "clip_reward", "update"}
# the policy keys a config may set; an algorithm takes those its policy class does
# (policy_keys): TQC's n_quantiles, CrossQ's batch renormalisation, RecurrentPPO's LSTM
POLICY_KEYS = {
    "net_arch",
    "activation_fn",
    "log_std_init",
    "ortho_init",
    "use_expln",
    "squash_output",
    "n_critics",
    "share_features_extractor",
    "features_extractor",
    "full_std",
    "clip_mean",
    "n_quantiles",
    "batch_norm",
    "batch_norm_momentum",
    "batch_norm_eps",
    "renorm_warmup_steps",
    "lstm_hidden_size",
    "n_lstm_layers",
    "shared_lstm",
    "enable_critic_lstm",
    "critic_layer_norm",
    "actor_mean_reg",
    "actor_layer_norm",
    "actor_lr_scale",
}
# the algorithms whose critics hoprover can normalise (training/critics.py)
LAYER_NORM_ALGOS = {"sac", "td3"}
# the algorithms whose actor's pre-tanh mean hoprover can penalise (training/actor_penalty.py)
MEAN_PENALTY_ALGOS = {"sac", "tqc", "crossq"}
# the algorithms whose actor hoprover can step at a rate of its own (the same module)
ACTOR_RATE_ALGOS = MEAN_PENALTY_ALGOS | {"td3"}
# the algorithms whose actor's hidden layers hoprover can normalise (the same module; CrossQ's
# actor has batch normalisation of its own)
ACTOR_LAYER_NORM_ALGOS = {"sac", "tqc"}
# the actor options (training/actor_penalty.py): any of them set chooses its policy class
ACTOR_OPTION_KEYS = ("actor_mean_reg", "actor_layer_norm", "actor_lr_scale")
# the policy keys hoprover's own policy classes take (make_agent), not SB3's policies
HOPROVER_POLICY_KEYS = {"critic_layer_norm", *ACTOR_OPTION_KEYS}
# a config's `pretrain` section: every key it may set, with the value it takes when unset
PRETRAIN_DEFAULTS = {
    "expert": "scripted",
    "episodes": 400,
    "epochs": 30,
    "batch_size": 1024,
    "learning_rate": 1e-3,
    "seed": 1,
    "value_epochs": 10,
    "log_std": -2.5,
    "noise": 0.0,
    "dagger_rounds": 0,
    "dagger_episodes": 200,
    "ground_weight": 1.0,
    "learning_rate_end": None,
}
PRETRAIN_KEYS = set(PRETRAIN_DEFAULTS)
EVAL_KEYS = {"freq", "episodes", "seed"}
CHECKPOINT_KEYS = {"freq", "seconds", "keep"}
ACTIVATIONS = {
    "tanh": "Tanh",
    "relu": "ReLU",
    "elu": "ELU",
    "leaky_relu": "LeakyReLU",
    "gelu": "GELU",
    "silu": "SiLU",
}
DEFAULTS = {
    "env_id": "HopRover-v0",
    "n_envs": 32,
    "timesteps": 1_000_000,
    "seed": 0,
    "env": {},
    "normalize": {"obs": True, "reward": True, "clip_obs": 10.0},
    "policy": {},
    "hyperparams": {},
    "pretrain": None,
    "init_from": None,
    "demonstrations": None,
    "redo": None,
    "evaluation": {"freq": 100_000, "episodes": 100, "seed": 7},
    "checkpoint": {"freq": 200_000, "seconds": 300.0},
}


def pretrain_settings(cfg: dict) -> dict:
    """The config's pretraining with every unset key at its default."""
    return {**PRETRAIN_DEFAULTS, **cfg["pretrain"]}


class ConfigError(ValueError):
    """A bad config key or value; the message names it."""


def algo_class(algo: str):
    """The SB3 class of `algo`; ConfigError for an unknown name, or when sb3-contrib (for
    tqc, crossq, recurrentppo) is not installed."""
    if algo not in ALGOS:
        raise ConfigError(f"algo must be one of {list(ALGOS)}, got {algo!r}")
    try:
        return _algo_class(algo)
    except ImportError as exc:
        raise ConfigError(str(exc)) from None


def hyper_keys(algo: str) -> set:
    """The `hyperparams` keys of `algo`: its constructor's keyword arguments (less those
    train.py sets itself) and hoprover's own."""
    params = set(inspect.signature(algo_class(algo).__init__).parameters)
    return (
        params
        - {"self", "policy", "env", "policy_kwargs", "seed", "tensorboard_log", "_init_setup_model"}
    ) | OWN_HYPER_KEYS


def algo_default(algo: str, name: str):
    """The default of `algo`'s constructor argument `name` (what a config that leaves it
    unset trains with)."""
    return inspect.signature(algo_class(algo).__init__).parameters[name].default


def policy_keys(algo: str) -> set:
    """The `policy` keys of `algo`: those of POLICY_KEYS that its policy class takes."""
    cls = algo_class(algo)
    params = set(inspect.signature(cls.policy_aliases[SB3_ALGOS[algo][2]].__init__).parameters)
    params.add("features_extractor")  # hoprover's name of features_extractor_class
    if algo in LAYER_NORM_ALGOS:
        params.add("critic_layer_norm")  # hoprover's: a policy class of its own
    if algo in MEAN_PENALTY_ALGOS:
        params.add("actor_mean_reg")  # hoprover's: a class of its own
    if algo in ACTOR_RATE_ALGOS:
        params.add("actor_lr_scale")  # the same class
    if algo in ACTOR_LAYER_NORM_ALGOS:
        params.add("actor_layer_norm")  # the same class
    return POLICY_KEYS & params


def _check_keys(section: str, given: dict, valid: set):
    if not isinstance(given, dict):
        raise ConfigError(
            f"config section '{section}' must be a mapping, got {type(given).__name__}"
        )
    bad = sorted(set(given) - valid)
    if bad:
        raise ConfigError(f"unknown config key '{section}.{bad[0]}' (valid: {sorted(valid)})")


PACKAGED_CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def packaged_configs() -> list[str]:
    """The names of the configs that travel with the package (configs/*.yaml)."""
    return sorted(p.stem for p in PACKAGED_CONFIGS.glob("*.y*ml"))


def config_path(spec: str | Path) -> Path:
    """A config file: a path, or the name of a packaged config ("ppo_hop" or
    "ppo_hop.yaml"). FileNotFoundError names the missing file and the packaged names."""
    path = Path(spec)
    if path.is_file():
        return path
    if path.name == str(spec):  # a bare name: the packaged configs
        for cand in (PACKAGED_CONFIGS / path.name, PACKAGED_CONFIGS / f"{path.name}.yaml"):
            if cand.is_file():
                return cand
    raise FileNotFoundError(
        f"config file not found: {spec} (packaged configs, usable by "
        f"name: {', '.join(packaged_configs())})"
    )


def load_config(
    path: str | Path | None, overrides: dict | None = None, section_overrides: dict | None = None
) -> dict:
    """Read, fill in defaults, apply command-line overrides (top-level keys, and keys of
    sections: {"checkpoint": {"seconds": 60}}; None leaves a value as it is), and
    validate a config."""
    raw: dict = {}
    if path is not None:
        path = config_path(path)
        try:
            raw = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
            problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
            raise ConfigError(f"{path}: not valid YAML{where}: {problem}") from None
        if not isinstance(raw, dict):
            raise ConfigError(f"{path}: the config must be a mapping")
    if "trainer" in raw:  # a config for another trainer (configs/ppo_mission_hop.yaml)
        raise ConfigError(
            f"this config names its own trainer: run it with "
            f"`python -m {raw['trainer']} --config {path}`, not train.py"
        )
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
    for section, values in (section_overrides or {}).items():
        for key, value in values.items():
            if value is not None:
                cfg[section] = {**cfg[section], key: value}
    validate(cfg)
    return cfg


def _check_discounts(cfg: dict, env_config) -> None:
    """The reward's shaping, gamma Phi(s') - Phi(s), leaves the best policy unchanged only
    when the learner discounts with the same gamma (Ng et al. 1999); with another, it adds
    (gamma - gamma_learner) Phi(s') to every step, a bonus or a cost for being far from
    the target. Both default to 0.99, so a config that sets one must set the other."""
    env_gamma = getattr(env_config, "gamma", None)
    if env_gamma is None:
        return
    learner = cfg["hyperparams"].get("gamma", algo_default(cfg["algo"], "gamma"))
    if not math.isclose(float(env_gamma), float(learner), rel_tol=0, abs_tol=1e-12):
        raise ConfigError(
            f"config keys 'env.gamma' ({env_gamma}) and 'hyperparams.gamma' "
            f"({learner}) differ: the reward's shaping must be discounted as "
            f"the learner discounts, or it changes what the best policy is; "
            f"set both to the same value"
        )


def validate(cfg: dict) -> None:
    if "algo" not in cfg:
        raise ConfigError(f"config key 'algo' is missing ({', '.join(ALGOS)})")
    algo_class(cfg["algo"])
    from hoprover_env.envs.registry import ENVS, config_class

    if cfg.get("env_id") not in ENVS:
        raise ConfigError(
            f"config key 'env_id' must be one of {sorted(ENVS)}, got {cfg.get('env_id')!r}"
        )
    env_cls = config_class(cfg["env_id"])
    env_fields = env_cls.option_names()
    _check_keys("env", cfg["env"], env_fields)
    try:
        env_config = env_cls(**env_kwargs(cfg))
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"config section 'env': {exc}") from None
    _check_keys("normalize", cfg["normalize"], NORMALIZE_KEYS)
    _check_keys("policy", cfg["policy"], policy_keys(cfg["algo"]))
    if "activation_fn" in cfg["policy"] and cfg["policy"]["activation_fn"] not in ACTIVATIONS:
        raise ConfigError(
            f"config key 'policy.activation_fn' must be one of "
            f"{sorted(ACTIVATIONS)}, got {cfg['policy']['activation_fn']!r}"
        )
    if "features_extractor" in cfg["policy"]:
        extractor = features_extractor(cfg["policy"]["features_extractor"])
        if getattr(extractor, "frozen_statistics", False) and (
            cfg["normalize"].get("update", True) or not cfg["normalize"].get("obs", True)
        ):
            raise ConfigError(
                "config key 'policy.features_extractor' "
                f"({extractor.__name__}) needs normalize.obs: true and "
                "normalize.update: false (it reads the frozen observation "
                "statistics)"
            )
    _check_keys("hyperparams", cfg["hyperparams"], hyper_keys(cfg["algo"]))
    init = cfg.get("init_from")
    if init is not None:
        if not (isinstance(init, str) and init):
            raise ConfigError(
                f"config key 'init_from' must be a model (a bundled name, a run "
                f"directory or a .zip), got {init!r}"
            )
        if cfg.get("pretrain") is not None:
            raise ConfigError(
                "config keys 'init_from' and 'pretrain' exclude each other: "
                "a run starts from a model or from cloning, not both"
            )
    if cfg.get("pretrain") is not None:
        _check_keys("pretrain", cfg["pretrain"], PRETRAIN_KEYS)
        if cfg["algo"] != "ppo":
            raise ConfigError(
                "config section 'pretrain' (behaviour cloning) is only supported with algo: ppo"
            )
    if cfg.get("demonstrations") is not None:
        from hoprover_env.training import demonstrations

        _check_keys("demonstrations", cfg["demonstrations"], demonstrations.KEYS)
        from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

        if not issubclass(algo_class(cfg["algo"]), OffPolicyAlgorithm):
            raise ConfigError(
                "config section 'demonstrations' (a replay buffer filled "
                "before learning) needs an off-policy algo (sac, td3, tqc, "
                f"crossq), got {cfg['algo']!r}"
            )
    if cfg.get("redo") is not None:
        _check_redo(cfg)
    _check_keys("evaluation", cfg["evaluation"], EVAL_KEYS)
    _check_keys("checkpoint", cfg["checkpoint"], CHECKPOINT_KEYS)
    for key in ("n_envs", "timesteps"):
        check_value(key, cfg[key], POS_INT)
    check_value("seed", cfg["seed"], INT)
    check_sections(
        cfg,
        normalize=NORMALIZE_TYPES,
        policy=POLICY_TYPES,
        hyperparams=HYPER_TYPES,
        pretrain=PRETRAIN_TYPES,
        demonstrations=DEMONSTRATION_TYPES,
        redo=REDO_TYPES,
        evaluation=EVAL_TYPES,
        checkpoint=CHECKPOINT_TYPES,
    )
    pol = cfg["policy"]
    if pol.get("shared_lstm") and (
        pol.get("enable_critic_lstm", True) or not pol.get("share_features_extractor", True)
    ):
        raise ConfigError(
            "config key 'policy.shared_lstm': true shares the actor's LSTM "
            "with the critic: it needs policy.enable_critic_lstm: false (and "
            "share_features_extractor left true)"
        )
    _check_discounts(cfg, env_config)


def _check_redo(cfg: dict) -> None:
    """The `redo` section recycles an SB3 squashed-Gaussian actor's own hidden units
    (training/redo.py): the algorithms with that actor, without a LayerNorm or gSDE."""
    from hoprover_env.training import redo

    _check_keys("redo", cfg["redo"], redo.KEYS)
    if cfg["algo"] not in redo.ALGOS:
        raise ConfigError(
            f"config section 'redo' (recycling the actor's dormant units) needs algo "
            f"{' or '.join(sorted(redo.ALGOS))}, got {cfg['algo']!r}"
        )
    for key, option in (("policy", "actor_layer_norm"), ("hyperparams", "use_sde")):
        if cfg[key].get(option):
            raise ConfigError(
                f"config section 'redo' cannot recycle the units of an actor with "
                f"{key}.{option}: true (training/redo.py says why)"
            )


def check_sections(cfg: dict, **sections: dict) -> None:
    """check_value on every key of each named section of `cfg` that its table of
    training/config_types.py knows (keys it does not know are _check_keys' business)."""
    for section, types in sections.items():
        for key, value in (cfg.get(section) or {}).items():
            if key in types:
                check_value(f"{section}.{key}", value, types[key])


def check_value(key: str, value, kind) -> None:
    """ConfigError naming `key` unless `kind` (a (test, "what it must be") pair of
    training/config_types.py) accepts `value`."""
    test, expected = kind
    if not test(value):
        hint = ""
        if isinstance(value, str):
            try:
                float(value)
                hint = " (YAML reads a number like 3e-4 as text: write 3.0e-4)"
            except ValueError:
                pass
        raise ConfigError(f"config key '{key}' must be {expected}, got {value!r}{hint}")


def env_kwargs(cfg: dict) -> dict:
    """Env arguments of a config: what its id fixes (the contest's target), then its
    `env:` section."""
    from hoprover_env.envs.registry import task

    return {**task(cfg["env_id"]).kwargs, **cfg["env"]}


def features_extractor(spec):
    """The SB3 features extractor class a config names as "module:Class" (importable from
    where train.py runs). ConfigError names the key when it cannot be imported or is not
    a BaseFeaturesExtractor. An extractor with `frozen_statistics = True` reads the
    observation statistics through `use_statistics(mean, std)` (training.warm_start)."""
    import importlib

    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    key = "config key 'policy.features_extractor'"
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise ConfigError(f"{key} must be 'module:Class', got {spec!r}")
    module, name = spec.split(":")
    try:
        cls = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"{key}: cannot import {spec!r} ({exc})") from None
    if not (isinstance(cls, type) and issubclass(cls, BaseFeaturesExtractor)):
        raise ConfigError(f"{key}: {spec!r} is not an SB3 BaseFeaturesExtractor")
    return cls


def policy_kwargs(cfg: dict) -> dict:
    import torch.nn as nn

    kw = dict(cfg["policy"])
    kw.pop("critic_layer_norm", None)  # chooses the policy class (make_agent)
    for key in ACTOR_OPTION_KEYS:
        if not kw.get(key):
            kw.pop(key, None)  # 0 or false: SB3's own policy class (make_agent)
    if "features_extractor" in kw:
        kw["features_extractor_class"] = features_extractor(kw.pop("features_extractor"))
    if "activation_fn" in kw:
        kw["activation_fn"] = getattr(nn, ACTIVATIONS[kw["activation_fn"]])
    return kw


def make_agent(cfg: dict, venv, tensorboard_log: str | None = None, device: str = "cpu"):
    """A fresh agent of the config's algorithm (ALGOS) from a validated config."""
    cls = algo_class(cfg["algo"])
    hyper: dict[str, Any] = dict(cfg["hyperparams"])
    if "learning_rate_end" in hyper:
        try:
            from stable_baselines3.common.utils import LinearSchedule
        except ImportError:  # stable-baselines3 < 2.7
            from stable_baselines3.common.utils import get_linear_fn as LinearSchedule
        start = hyper.get("learning_rate", algo_default(cfg["algo"], "learning_rate"))
        hyper["learning_rate"] = LinearSchedule(start, hyper.pop("learning_rate_end"), 1.0)
    if isinstance(hyper.get("action_noise"), (int, float)):  # TD3, TQC, CrossQ
        from stable_baselines3.common.noise import NormalActionNoise

        sigma, dim = float(hyper.pop("action_noise")), venv.action_space.shape[0]
        hyper["action_noise"] = NormalActionNoise(np.zeros(dim), sigma * np.ones(dim))
    if cfg.get("demonstrations") is not None:  # a store of their own, with a batch_share
        from hoprover_env.training.demonstrations import buffer_kwargs

        separate = buffer_kwargs(cfg)
        if separate:
            hyper.pop("n_steps", None)  # the buffer's own (SB3 sets it up only for its own)
            hyper.update(separate)
    policy: Any = SB3_ALGOS[cfg["algo"]][2]
    layer_norm = bool(cfg["policy"].get("critic_layer_norm"))
    if any(cfg["policy"].get(key) for key in ACTOR_OPTION_KEYS):
        from hoprover_env.training.actor_penalty import ACTOR_OPTION_POLICIES

        policy = ACTOR_OPTION_POLICIES[(cfg["algo"], layer_norm)]
    elif layer_norm:
        from hoprover_env.training.critics import LAYER_NORM_POLICIES

        policy = LAYER_NORM_POLICIES[cfg["algo"]]
    return cls(
        policy,
        venv,
        policy_kwargs=policy_kwargs(cfg),
        seed=cfg["seed"],
        tensorboard_log=tensorboard_log,
        device=device,
        verbose=0,
        **hyper,
    )
