"""Configuration of the RL environments and the per-episode sampling they share.

`EnvConfig` validates every argument once (with errors that name the argument). The
single env, the vector env and the SB3 adapter all draw an episode's target and
(randomised) parameters with `sample_episode` from a per-env numpy Generator, in the
same order, so that sub-env i of a vector env seeded with s replays a single env seeded
with s + i bit for bit.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any, Mapping

import numpy as np

from . import core, rl_kernel
from .params import RoverParams
from .simulate import make_options, make_state, finite_real, positive_real, DEFAULT_RTOL

# Parameters that domain randomisation may scale, and the bounds they are clipped to.
RANDOMIZABLE = {
    "mass": (1e-6, math.inf), "inertia": (1e-9, math.inf), "gravity": (1e-12, math.inf),
    "half_width": (1e-6, math.inf), "half_height": (1e-6, math.inf),
    "mu_static": (0.0, 1.0), "mu_dynamic": (0.0, 1.0),
    "restitution_x": (0.0, 1.0), "restitution_y": (0.0, 1.0),
}
SHAPINGS = {"contact": rl_kernel.SHAPING_CONTACT, "landing": rl_kernel.SHAPING_LANDING}
ACTION_MAPS = {"linear": rl_kernel.ACTION_LINEAR, "cubic": rl_kernel.ACTION_CUBIC}


def _is_real(v) -> bool:
    """A real number, numpy scalars included; booleans are not numbers here."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """Arguments of HopRoverEnv / HopRoverVectorEnv (see the table in env.py)."""

    control_dt: float = 0.5
    episode_time: float = 600.0
    target_range: tuple = (-1.0, 1.0)
    target_x: float | None = None
    integrator: str = "event"
    impact_law: str = "contest"
    rtol: float = DEFAULT_RTOL
    euler_dt: float = 1e-3
    params: RoverParams = dataclasses.field(default_factory=RoverParams)
    randomize: Mapping[str, float] | None = None
    dist_weight: float = 1.0
    time_cost: float = 1.0 / 600.0
    success_bonus: float = 10.0
    break_penalty: float = 10.0
    gamma: float = 0.99
    shaping: str = "contact"
    attitude_weight: float = 0.0
    band_weight: float = 0.5
    dist_cap: float = 5.0
    action_map: str = "linear"
    action_scale: float = 1.0
    info_level: str = "basic"

    def __post_init__(self):
        def positive(name):
            object.__setattr__(self, name, positive_real(name, getattr(self, name)))

        positive("control_dt")
        positive("episode_time")
        if self.control_dt > self.episode_time:
            raise ValueError(f"control_dt ({self.control_dt}) exceeds episode_time "
                             f"({self.episode_time})")
        rng = self.target_range
        if not (isinstance(rng, (tuple, list, np.ndarray)) and len(rng) == 2
                and all(_is_real(v) and math.isfinite(v) for v in rng) and rng[0] <= rng[1]):
            raise ValueError(f"target_range must be (low, high) with low <= high, got "
                             f"{self.target_range!r}")
        object.__setattr__(self, "target_range", (float(rng[0]), float(rng[1])))
        if self.target_x is not None:
            object.__setattr__(self, "target_x", finite_real("target_x", self.target_x))
        make_options(self.integrator, self.impact_law, self.rtol, self.euler_dt)
        if isinstance(self.params, Mapping):
            object.__setattr__(self, "params", RoverParams(**self.params))
        if not isinstance(self.params, RoverParams):
            raise ValueError(f"params must be a RoverParams or a dict of its fields, got "
                             f"{type(self.params).__name__}")
        if self.randomize is not None and not isinstance(self.randomize, Mapping):
            raise ValueError("randomize must map parameter names to relative half-ranges, "
                             f"e.g. {{'mass': 0.1}}; got {self.randomize!r}")
        rand = dict(self.randomize or {})
        for key, rel in rand.items():
            if key not in RANDOMIZABLE:
                raise ValueError(f"randomize: unknown parameter {key!r}; choose from "
                                 f"{sorted(RANDOMIZABLE)}")
            if not (_is_real(rel) and 0.0 <= rel < 1.0):
                raise ValueError(f"randomize[{key!r}] must be a relative half-range in "
                                 f"[0, 1), got {rel!r}")
        object.__setattr__(self, "randomize", dict(sorted(rand.items())))
        for name in ("dist_weight", "time_cost", "success_bonus", "break_penalty",
                     "attitude_weight", "band_weight"):
            v = getattr(self, name)
            if not (_is_real(v) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a non-negative number, got {v!r}")
        if not (_is_real(self.gamma) and 0.0 < self.gamma <= 1.0):
            raise ValueError(f"gamma must lie in (0, 1], got {self.gamma!r}")
        if self.shaping not in SHAPINGS:
            raise ValueError(f"shaping must be one of {sorted(SHAPINGS)}, got {self.shaping!r}")
        if not (_is_real(self.dist_cap) and math.isfinite(self.dist_cap)
                and self.dist_cap > 0):
            raise ValueError(f"dist_cap must be a positive number [m], got {self.dist_cap!r}")
        if self.action_map not in ACTION_MAPS:
            raise ValueError(f"action_map must be one of {sorted(ACTION_MAPS)}, got "
                             f"{self.action_map!r}")
        if not (_is_real(self.action_scale) and 0.0 < self.action_scale <= 1.0):
            raise ValueError(f"action_scale must lie in (0, 1], got {self.action_scale!r}")
        if self.info_level not in ("basic", "full"):
            raise ValueError(f"info_level must be 'basic' or 'full', got {self.info_level!r}")

    @classmethod
    def from_kwargs(cls, owner: str | None = None, /, **kwargs: Any) -> "EnvConfig":
        """The config of these keyword arguments; `owner` names the caller in errors."""
        names = {f.name for f in dataclasses.fields(cls)}
        bad = [k for k in kwargs if k not in names]
        if bad:
            # Python's own wording: TorchRL's GymEnv probes with frameskip=1 and drops it
            # only on "unexpected keyword argument 'frameskip'"
            also = f" (and {bad[1:]})" if len(bad) > 1 else ""
            raise TypeError(f"{owner or cls.__name__}() got an unexpected keyword argument "
                            f"{bad[0]!r}{also}; valid environment arguments: {sorted(names)}")
        return cls(**kwargs)

    def options_vector(self) -> np.ndarray:
        return make_options(self.integrator, self.impact_law, self.rtol, self.euler_dt)

    def reward_vector(self) -> np.ndarray:
        e = np.zeros(rl_kernel.N_ECONFIG)
        e[rl_kernel.E_CONTROL_DT] = self.control_dt
        e[rl_kernel.E_T_TOTAL] = self.episode_time
        e[rl_kernel.E_W_DIST] = self.dist_weight
        e[rl_kernel.E_W_TIME] = self.time_cost
        e[rl_kernel.E_SUCCESS] = self.success_bonus
        e[rl_kernel.E_BREAK] = self.break_penalty
        e[rl_kernel.E_GAMMA] = self.gamma
        e[rl_kernel.E_SHAPING] = SHAPINGS[self.shaping]
        e[rl_kernel.E_W_ATT] = self.attitude_weight
        e[rl_kernel.E_W_BAND] = self.band_weight
        e[rl_kernel.E_DIST_CAP] = self.dist_cap
        e[rl_kernel.E_ACTION_MAP] = ACTION_MAPS[self.action_map]
        e[rl_kernel.E_ACTION_SCALE] = self.action_scale
        return e

    @property
    def max_steps(self) -> int:
        """Control steps in a full episode."""
        return int(math.ceil(self.episode_time / self.control_dt - 1e-9))


@dataclasses.dataclass(frozen=True)
class HopEnvConfig(EnvConfig):
    """Arguments of HopRoverHopEnv: those of HopRoverEnv plus the built-in hop controller
    (see the table in hop_env.py). `control_dt` is the controller's period here."""

    gamma: float = 0.98
    hold_kp: float = 0.15
    hold_kd: float = 0.9
    launch_max: float = 60.0
    launch_min: float = 1.05

    def __post_init__(self):
        super().__post_init__()
        for name in ("hold_kp", "hold_kd", "launch_max"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool)
                    and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (_is_real(self.launch_min) and 1.0 < self.launch_min < 1e3):
            raise ValueError(f"launch_min (a multiple of the tipping torque m g r) must lie "
                             f"in (1, 1000), got {self.launch_min!r}")

    def reward_vector(self) -> np.ndarray:
        e = super().reward_vector()
        e[rl_kernel.E_HOLD_KP] = self.hold_kp
        e[rl_kernel.E_HOLD_KD] = self.hold_kd
        e[rl_kernel.E_LAUNCH_MAX] = self.launch_max
        e[rl_kernel.E_LAUNCH_MIN] = self.launch_min
        return e


def randomized_params(cfg: EnvConfig, rng: np.random.Generator) -> RoverParams:
    """The base parameters, each randomised field scaled by U(1 - r, 1 + r)."""
    if not cfg.randomize:
        return cfg.params
    base = cfg.params
    for _ in range(100):
        values = {}
        for key, rel in cfg.randomize.items():
            lo, hi = RANDOMIZABLE[key]
            values[key] = float(np.clip(getattr(base, key) * rng.uniform(1 - rel, 1 + rel),
                                        lo, hi))
        mu_s = values.get("mu_static", base.mu_static)
        if values.get("mu_dynamic", base.mu_dynamic) > mu_s:
            values["mu_dynamic"] = mu_s
        try:
            return dataclasses.replace(base, **values)
        except ValueError:                  # a Painleve draw: draw again
            continue
    raise ValueError("randomize: 100 draws in a row gave invalid parameters; narrow the "
                     f"ranges {cfg.randomize}")


def sample_episode(cfg: EnvConfig, rng: np.random.Generator,
                   options: Mapping[str, Any] | None = None):
    """Target and parameters of a new episode, and its initial kernel state and
    parameter vectors. `options` may fix 'target_x' and 'initial_state'."""
    options = dict(options or {})
    bad = sorted(set(options) - {"target_x", "initial_state"})
    if bad:
        raise ValueError(f"unknown reset option(s) {bad}; valid: ['initial_state', 'target_x']")
    # draw in a fixed order whatever the options say, so seeded streams stay aligned
    lo, hi = cfg.target_range
    drawn = float(rng.uniform(lo, hi))
    params = randomized_params(cfg, rng)
    if "target_x" in options:
        target = float(options["target_x"])
        if not math.isfinite(target):
            raise ValueError(f"options['target_x'] must be finite, got {options['target_x']!r}")
    else:
        target = cfg.target_x if cfg.target_x is not None else drawn
    state = make_state(params, target, options.get("initial_state"))
    return target, params, state, params.as_array()


STATE_LETTERS = np.array(list(core.MODE_LETTERS))
# info["ttrtp"] before the judge's TTRTP is reached: a number (not None or NaN, which
# TorchRL's specs and Tianshou's buffer checks refuse) that no real TTRTP can take
TTRTP_NOT_REACHED = -1.0
