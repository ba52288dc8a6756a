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
from typing import Any, Mapping

import numpy as np

from hoprover_env.core.params import MAX_SLOPE, RoverParams
from hoprover_env.tasks.reward import RewardConfig
from hoprover_env.sim.randomize import RANDOMIZABLE, check_randomize, draw_params
from hoprover_env.sim.simulate import DEFAULT_RTOL, make_options, make_state
from hoprover_env.tasks.layout import (ACTION_MAPS, E_ACTION_MAP, E_ACTION_SCALE, E_ATT_NOISE,
                           E_BIAS_WALK, E_CONTROL_DT, E_FIX_NOISE, E_FIX_REST, E_HOLD_KD,
                           E_HISTORY, E_HOLD_KP, E_INCL_NOISE, E_LAUNCH_MAX, E_LAUNCH_MIN,
                           E_RATE_NOISE,
                           E_T_TOTAL, N_E)
from hoprover_env.util.validate import finite_real, is_real, non_negative_real, positive_real

@dataclasses.dataclass(frozen=True)
class EnvConfig(RewardConfig):
    """Arguments of HopRoverEnv / HopRoverVectorEnv (see the table in env.py); the
    reward's own arguments and their checks are RewardConfig's (hoprover_env/tasks/reward.py)."""

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
    action_map: str = "linear"
    action_scale: float = 1.0
    info_level: str = "basic"

    def __post_init__(self):
        super().__post_init__()

        def positive(name):
            object.__setattr__(self, name, positive_real(name, getattr(self, name)))

        positive("control_dt")
        positive("episode_time")
        if self.control_dt > self.episode_time:
            raise ValueError(f"control_dt ({self.control_dt}) exceeds episode_time "
                             f"({self.episode_time})")
        rng = self.target_range
        if not (isinstance(rng, (tuple, list, np.ndarray)) and len(rng) == 2
                and all(is_real(v) and math.isfinite(v) for v in rng) and rng[0] <= rng[1]):
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
        object.__setattr__(self, "randomize", check_randomize(self.randomize))
        if self.action_map not in ACTION_MAPS:
            raise ValueError(f"action_map must be one of {sorted(ACTION_MAPS)}, got "
                             f"{self.action_map!r}")
        if not (is_real(self.action_scale) and 0.0 < self.action_scale <= 1.0):
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
        """The kernel's option vector O (integrator, impact law, tolerances)."""
        return make_options(self.integrator, self.impact_law, self.rtol, self.euler_dt)

    def task_vector(self) -> np.ndarray:
        """The task configuration vector E (hoprover_env/tasks/layout.py)."""
        e = np.zeros(N_E)
        e[E_CONTROL_DT] = self.control_dt
        e[E_T_TOTAL] = self.episode_time
        e[E_ACTION_MAP] = ACTION_MAPS[self.action_map]
        e[E_ACTION_SCALE] = self.action_scale
        return e

    def draw_terrain(self, rng: np.random.Generator) -> dict:
        """The terrain of a new episode ({} here: the ground `params` says; a terrain task
        draws its slope)."""
        return {}

    def draws_bumps(self) -> bool:
        """Whether this config's episodes are on rough ground (reset options may still
        ask for bumps): the envs compile for smooth ground first when they are not."""
        return self.params.roughness > 0.0

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
            if not (is_real(v) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (is_real(self.launch_min) and 1.0 < self.launch_min < 1e3):
            raise ValueError(f"launch_min (a multiple of the tipping torque m g r) must lie "
                             f"in (1, 1000), got {self.launch_min!r}")

    def task_vector(self) -> np.ndarray:
        e = super().task_vector()
        e[E_HOLD_KP] = self.hold_kp
        e[E_HOLD_KD] = self.hold_kd
        e[E_LAUNCH_MAX] = self.launch_max
        e[E_LAUNCH_MIN] = self.launch_min
        return e


def randomized_params(cfg: EnvConfig, rng: np.random.Generator) -> RoverParams:
    """The base parameters, each randomised field scaled by U(1 - r, 1 + r)."""
    return draw_params(cfg.params, cfg.randomize, rng)


def sample_episode(cfg: EnvConfig, rng: np.random.Generator,
                   options: Mapping[str, Any] | None = None):
    """Target, parameters and rough-terrain seed of a new episode, and its initial kernel
    state and parameter vectors: (target, params, S, P, terrain_seed). `options` may fix
    'target_x', 'initial_state', 'slope' [rad], 'roughness' [rad] and 'terrain_seed' (an
    integer in [0, 2^63): the seed of the bumps, to replay an episode such as a frozen
    test suite's; ignored on smooth ground).

    The draws come from `rng` in a fixed order whatever the options say (target, the
    randomised parameters, the slope of a terrain task), so seeded streams stay aligned;
    on rough ground the seed of the bumps is the next draw (none on smooth ground, so a
    flat env's stream is the one it always was)."""
    options = dict(options or {})
    bad = sorted(set(options) - set(RESET_OPTIONS))
    if bad:
        raise ValueError(f"unknown reset option(s) {bad}; valid: {sorted(RESET_OPTIONS)}")
    lo, hi = cfg.target_range
    drawn = float(rng.uniform(lo, hi))
    params = randomized_params(cfg, rng)
    terrain = cfg.draw_terrain(rng)
    for key in ("slope", "roughness"):
        if key in options:
            terrain[key] = finite_real(f"options[{key!r}]", options[key])
    if terrain and any(getattr(params, k) != v for k, v in terrain.items()):
        params = dataclasses.replace(params, **terrain)
    if "target_x" in options:
        target = float(options["target_x"])
        if not math.isfinite(target):
            raise ValueError(f"options['target_x'] must be finite, got {options['target_x']!r}")
    else:
        target = cfg.target_x if cfg.target_x is not None else drawn
    seed = int(rng.integers(2**63)) if params.roughness > 0.0 else None
    if seed is not None and "terrain_seed" in options:     # drawn all the same: aligned
        seed = options["terrain_seed"]
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) \
                or not 0 <= int(seed) < 2**63:
            raise ValueError(f"options['terrain_seed'] must be an integer in [0, 2**63), got "
                             f"{seed!r}")
        seed = int(seed)
    state = make_state(params, target, options.get("initial_state"), seed=seed)
    return target, params, state, params.as_array(), seed


RESET_OPTIONS = ("target_x", "initial_state", "slope", "roughness", "terrain_seed")


@dataclasses.dataclass(frozen=True)
class TerrainEnvConfig(EnvConfig):
    """Arguments of HopRoverTerrainEnv: those of HopRoverEnv plus the terrain each episode
    draws (see the table in terrain_env.py)."""

    slope_range: tuple = (-0.2, 0.2)
    roughness: float = 0.05

    def __post_init__(self):
        super().__post_init__()
        rng = self.slope_range
        if not (isinstance(rng, (tuple, list, np.ndarray)) and len(rng) == 2
                and all(is_real(v) and abs(v) <= MAX_SLOPE for v in rng) and rng[0] <= rng[1]):
            raise ValueError(f"slope_range must be (low, high) [rad] with low <= high, both "
                             f"in [-{MAX_SLOPE}, {MAX_SLOPE}]; got {self.slope_range!r}")
        object.__setattr__(self, "slope_range", (float(rng[0]), float(rng[1])))
        if not (is_real(self.roughness) and math.isfinite(self.roughness)
                and self.roughness >= 0):
            raise ValueError(f"roughness must be a finite number >= 0 [rad], got "
                             f"{self.roughness!r}")

    def draw_terrain(self, rng: np.random.Generator) -> dict:
        return {"slope": float(rng.uniform(*self.slope_range)),
                "roughness": float(self.roughness)}

    def draws_bumps(self) -> bool:
        return self.roughness > 0.0


# The ground a mission does not know: restitutions and friction drawn per episode
# (relative half-ranges, EnvConfig.randomize), about the spread of the regolith
# measurements Hayabusa2's MINERVA-II and MASCOT landings left open.
MISSION_GROUND = {"restitution_x": 0.2, "restitution_y": 0.5, "mu_static": 0.25,
                  "mu_dynamic": 0.25}
_NOISES = ("attitude_noise", "rate_noise", "bias_walk", "fix_noise", "inclinometer_noise",
           "actuator_error")


@dataclasses.dataclass(frozen=True)
class MissionEnvConfig(TerrainEnvConfig):
    """Arguments of HopRoverMissionEnv: those of HopRoverTerrainEnv (the ground drawn
    each episode, `randomize` defaulting to MISSION_GROUND) plus its sensors and
    actuator (see the table in mission_env.py). `noise_scale` multiplies every noise."""

    randomize: Mapping[str, float] | None = dataclasses.field(
        default_factory=lambda: dict(MISSION_GROUND))
    noise_scale: float = 1.0
    attitude_noise: float = math.radians(0.5)
    rate_noise: float = 1e-4
    bias_walk: float = 1e-3
    fix_noise: float = 0.01
    fix_rest: float = 1.0
    inclinometer_noise: float = 0.02
    actuator_error: float = 0.05
    history: int = 1

    def __post_init__(self):
        super().__post_init__()
        if not (isinstance(self.history, (int, np.integer)) and not isinstance(
                self.history, bool) and 1 <= self.history <= 64):
            raise ValueError(f"history (readings per observation) must be an integer in "
                             f"[1, 64], got {self.history!r}")
        for name in _NOISES + ("noise_scale",):
            object.__setattr__(self, name, non_negative_real(name, getattr(self, name)))
        object.__setattr__(self, "fix_rest", positive_real("fix_rest", self.fix_rest))
        if self.actuator_error * self.noise_scale >= 1.0:
            raise ValueError(f"actuator_error x noise_scale must be below 1 (a scale error "
                             f"of 100 % or more reverses the torque), got "
                             f"{self.actuator_error} x {self.noise_scale}")

    def task_vector(self) -> np.ndarray:
        e = super().task_vector()
        k = self.noise_scale
        e[E_ATT_NOISE] = k * self.attitude_noise
        e[E_RATE_NOISE] = k * self.rate_noise
        e[E_BIAS_WALK] = k * self.bias_walk
        e[E_FIX_NOISE] = k * self.fix_noise
        e[E_FIX_REST] = self.fix_rest
        e[E_INCL_NOISE] = k * self.inclinometer_noise
        e[E_HISTORY] = self.history
        return e
