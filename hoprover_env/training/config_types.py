"""The kinds of value a train.py config's keys take (hoprover_env/training/sb3_agents.py
checks a config against these tables), each a (test, what is expected) pair."""

from __future__ import annotations

import numpy as np


# Value kinds: (test, what is expected). The test sees the raw YAML value, so 64.5, "fifty"
# or True where an integer belongs are refused here, not deep inside torch or SB3.
def _is_int(v):
    return isinstance(v, int) and not isinstance(v, bool)


def _is_real(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def _is_layers(v):
    return isinstance(v, list) and len(v) > 0 and all(_is_int(n) and n > 0 for n in v)


INT = (_is_int, "an integer")
POS_INT = (lambda v: _is_int(v) and v >= 1, "a positive integer")
NONNEG_INT = (lambda v: _is_int(v) and v >= 0, "an integer >= 0")
BOOL = (lambda v: isinstance(v, bool), "true or false")
REAL = (_is_real, "a finite number")
POS_REAL = (lambda v: _is_real(v) and v > 0, "a finite number > 0")
NONNEG_REAL = (lambda v: _is_real(v) and v >= 0, "a finite number >= 0")
UNIT = (lambda v: _is_real(v) and 0 < v <= 1, "a number in (0, 1]")
UNIT_CLOSED = (lambda v: _is_real(v) and 0 <= v <= 1, "a number in [0, 1]")
OPT_POS_REAL = (lambda v: v is None or POS_REAL[0](v), "null or a finite number > 0")
NET_ARCH = (
    lambda v: (
        _is_layers(v)
        or (
            isinstance(v, dict)
            and len(v) > 0
            and all(k in ("pi", "vf", "qf") and _is_layers(x) for k, x in v.items())
        )
    ),
    "a list of positive layer sizes, e.g. [64, 64], or {pi: [...], vf: [...]} / {pi, qf}",
)
ENT_COEF = (
    lambda v: NONNEG_REAL[0](v) or (isinstance(v, str) and v.startswith("auto")),
    "a finite number >= 0 (or 'auto' for SAC, TQC and CrossQ)",
)
TARGET_ENTROPY = (lambda v: REAL[0](v) or v == "auto", "a finite number or 'auto'")
TRAIN_FREQ = (
    lambda v: (
        POS_INT[0](v)
        or (
            isinstance(v, list) and len(v) == 2 and POS_INT[0](v[0]) and v[1] in ("step", "episode")
        )
    ),
    "a positive integer or [n, step|episode]",
)
GRADIENT_STEPS = (lambda v: _is_int(v) and (v >= 1 or v == -1), "a positive integer or -1")

NORMALIZE_TYPES = {
    "obs": BOOL,
    "reward": BOOL,
    "update": BOOL,
    "clip_obs": POS_REAL,
    "clip_reward": POS_REAL,
}
POLICY_TYPES = {
    "net_arch": NET_ARCH,
    "log_std_init": REAL,
    "ortho_init": BOOL,
    "use_expln": BOOL,
    "squash_output": BOOL,
    "n_critics": POS_INT,
    "share_features_extractor": BOOL,
    "full_std": BOOL,
    "clip_mean": POS_REAL,
    "n_quantiles": POS_INT,
    "batch_norm": BOOL,
    "batch_norm_momentum": UNIT,
    "batch_norm_eps": POS_REAL,
    "renorm_warmup_steps": NONNEG_INT,
    "lstm_hidden_size": POS_INT,
    "n_lstm_layers": POS_INT,
    "shared_lstm": BOOL,
    "enable_critic_lstm": BOOL,
    "critic_layer_norm": BOOL,
    "actor_mean_reg": NONNEG_REAL,
    "actor_layer_norm": BOOL,
    "actor_lr_scale": POS_REAL,
}
DEMONSTRATION_TYPES = {
    "policy": (lambda v: isinstance(v, str) and v != "", "a policy name"),
    "steps": POS_INT,
    "seed": INT,
    "batch_share": (lambda v: _is_real(v) and 0 <= v < 1, "a number in [0, 1)"),
}
PRETRAIN_TYPES = {
    "expert": (lambda v: isinstance(v, str) and v != "", "a policy name"),
    "episodes": POS_INT,
    "epochs": POS_INT,
    "batch_size": POS_INT,
    "learning_rate": POS_REAL,
    "seed": INT,
    "value_epochs": NONNEG_INT,
    "log_std": REAL,
    "noise": NONNEG_REAL,
    "dagger_rounds": NONNEG_INT,
    "dagger_episodes": POS_INT,
    "ground_weight": POS_REAL,
    "learning_rate_end": POS_REAL,
}
REDO_TYPES = {"freq": POS_INT, "tau": UNIT, "batch": POS_INT}
EVAL_TYPES = {"freq": POS_INT, "episodes": POS_INT, "seed": INT}
CHECKPOINT_TYPES = {"freq": POS_INT, "seconds": POS_REAL, "keep": BOOL}
# the keyword arguments of the algorithms (which ones an algorithm takes is checked
# against its constructor's signature in validate)
HYPER_TYPES = {
    "learning_rate": POS_REAL,
    "n_steps": POS_INT,
    "batch_size": POS_INT,
    "n_epochs": POS_INT,
    "gamma": UNIT,
    "gae_lambda": UNIT_CLOSED,
    "clip_range": POS_REAL,
    "clip_range_vf": OPT_POS_REAL,
    "normalize_advantage": BOOL,
    "ent_coef": ENT_COEF,
    "vf_coef": NONNEG_REAL,
    "max_grad_norm": POS_REAL,
    "target_kl": OPT_POS_REAL,
    "use_sde": BOOL,
    "sde_sample_freq": INT,
    "buffer_size": POS_INT,
    "learning_starts": NONNEG_INT,
    "tau": UNIT,
    "train_freq": TRAIN_FREQ,
    "gradient_steps": GRADIENT_STEPS,
    "policy_delay": POS_INT,
    "target_policy_noise": NONNEG_REAL,
    "target_noise_clip": NONNEG_REAL,
    "action_noise": NONNEG_REAL,
    "target_update_interval": POS_INT,
    "stats_window_size": POS_INT,
    "learning_rate_end": POS_REAL,
    "target_entropy": TARGET_ENTROPY,
    "top_quantiles_to_drop_per_net": NONNEG_INT,
    "use_sde_at_warmup": BOOL,
    "optimize_memory_usage": BOOL,
}
