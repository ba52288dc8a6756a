"""Configuration of the RL environments.

`EnvConfig` validates every argument once (with errors that name the argument). The
single env, the vector env and the SB3 adapter all draw an episode's target and
(randomised) parameters the same way, from tasks/draws.py (counter-based and vectorised
over rovers, with the ground a config says: `terrain_columns`), so that sub-env i of a
vector env seeded with s replays a single env seeded with s + i bit for bit; the reset
options that fix what the draws would decide are tasks/options.py's.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from hoprover_env.core.params import RoverParams
from hoprover_env.sim.randomize import RANDOMIZABLE, check_randomize  # noqa: F401
from hoprover_env.sim.simulate import DEFAULT_RTOL, make_options
from hoprover_env.tasks.layout import (
    ACTION_MAPS,
    E_ACTION_MAP,
    E_ACTION_SCALE,
    E_CONTROL_DT,
    E_T_TOTAL,
    task_slots,
)
from hoprover_env.tasks.options import RESET_OPTIONS  # noqa: F401 (the env's own options)
from hoprover_env.tasks.reward import OPTIONS as REWARD_OPTIONS
from hoprover_env.tasks.reward import RewardConfig
from hoprover_env.util.validate import finite_real, is_real, positive_real

# The settings that RL from scratch trains with on the torque-level tasks
# (docs/studies/policies.md, "Learning from scratch"): a 2 s control period (a flight is
# tens of decisions, not hundreds), the landing-point shaping (a hop is credited at
# launch), the bounded flight-attitude potential, a time cost of 0.01 per second (a faster
# TTRTP pays) and the discount the learners use, which the shaping must share. The ids
# HopRoverRL-v0 and HopRoverTerrainRL-v0 have them as defaults, so that a front-end that
# passes no env arguments to its evaluation env (RL Baselines3 Zoo) evaluates on what it
# trains on; hyperparams/*.yml and configs/*.yaml are tuned on them.
RL_SETTINGS = {
    "control_dt": 2.0,
    "shaping": "landing",
    "attitude_weight": 1.0,
    "gamma": 0.995,
    "time_cost": 0.01,
}


class _FlatReward(type):
    """An env config takes the reward's options flat, as the env's keyword arguments
    (``EnvConfig(gamma=0.9)``, ``gym.make(id, attitude_cost=0.1)``): they are gathered
    into its `reward` field, a ``reward_config`` built and validated on its own (over a
    `reward` given too, as dataclasses.replace gives it)."""

    def __call__(cls, *args, **kwargs):
        given = {name: kwargs.pop(name) for name in REWARD_OPTIONS if name in kwargs}
        reward = kwargs.pop("reward", None)
        if isinstance(reward, Mapping):
            given = {**reward, **given}
            reward = None
        if reward is None:
            reward = cls.reward_config(**given)
        elif given:
            reward = dataclasses.replace(reward, **given)
        return super().__call__(*args, reward=reward, **kwargs)


# The training start distributions: shares of the episodes that start elsewhere than the
# contest's rest at x = 0 (tasks/draws.py `training_starts`). They are no part of the
# task: every evaluation drops them and starts where the contest does.
TRAINING_STARTS = ("flight_start", "near_start")


@dataclasses.dataclass(frozen=True)
class EnvConfig(metaclass=_FlatReward):
    """The arguments every task shares (the table in hoprover_env/tasks/torque.py). The
    reward is a part of its own, the field `reward` (a RewardConfig, whose fields and
    checks are in hoprover_env/tasks/reward.py), whose options the config takes flat and
    shows as its own attributes (``config.gamma``). A task's config subclasses it with
    its own arguments, lists in `unused` those of these it does not use, and in
    `reward_options` those of the reward's it reads (None: all); the others are refused.
    `reward_config` is the RewardConfig class whose defaults the task keeps."""

    reward: RewardConfig = dataclasses.field(default_factory=RewardConfig)
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
    flight_start: float = 0.0
    near_start: float = 0.0
    # the arguments a task does not use, each with the reason: refused, not ignored
    unused: ClassVar[dict] = {}
    # the task's own fields its kernels read, in the order of their slots of E after the
    # shared ones (tasks/layout.py task_slots)
    kernel_fields: ClassVar[tuple[str, ...]] = ()
    # the reward's options the task reads (None: all of them); the others are refused
    reward_options: ClassVar[tuple[str, ...] | None] = None
    reward_config: ClassVar[type[RewardConfig]] = RewardConfig

    def __getattr__(self, name: str) -> Any:
        """The reward's options, as attributes of the config (``config.gamma``)."""
        if name in REWARD_OPTIONS:
            return getattr(self.reward, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @classmethod
    def unused_options(cls) -> dict[str, str]:
        """Every argument the task does not use, with the reason: `unused`, and the
        reward's options outside `reward_options`."""
        out = dict(cls.unused)
        if cls.reward_options is not None:
            for name in REWARD_OPTIONS:
                if name not in cls.reward_options:
                    out[name] = (
                        f"a reward option its reward does not read; it reads "
                        f"{list(cls.reward_options) or 'none'}"
                    )
        return out

    @classmethod
    def option_names(cls) -> set[str]:
        """The env arguments the config takes: its fields (not `reward` itself) and the
        reward's options."""
        return ({f.name for f in dataclasses.fields(cls)} - {"reward"}) | set(REWARD_OPTIONS)

    def __post_init__(self):
        if not isinstance(self.reward, RewardConfig):
            raise ValueError(f"reward must be a RewardConfig, got {type(self.reward).__name__}")
        defaults = self.reward_config()
        for name, why in self.unused_options().items():
            if name in REWARD_OPTIONS:
                value, default = getattr(self.reward, name), getattr(defaults, name)
            else:
                value = getattr(self, name)
                default = type(self).__dataclass_fields__[name].default
            if value != default:
                raise ValueError(
                    f"{type(self).__name__} does not use {name} ({why}); leave it at {default!r}"
                )

        def positive(name):
            object.__setattr__(self, name, positive_real(name, getattr(self, name)))

        positive("control_dt")
        positive("episode_time")
        if self.control_dt > self.episode_time:
            raise ValueError(
                f"control_dt ({self.control_dt}) exceeds episode_time ({self.episode_time})"
            )
        rng = self.target_range
        if not (
            isinstance(rng, (tuple, list, np.ndarray))
            and len(rng) == 2
            and all(is_real(v) and math.isfinite(v) for v in rng)
            and rng[0] <= rng[1]
        ):
            raise ValueError(
                f"target_range must be (low, high) with low <= high, got {self.target_range!r}"
            )
        object.__setattr__(self, "target_range", (float(rng[0]), float(rng[1])))
        if self.target_x is not None:
            object.__setattr__(self, "target_x", finite_real("target_x", self.target_x))
        make_options(self.integrator, self.impact_law, self.rtol, self.euler_dt)
        if isinstance(self.params, Mapping):
            object.__setattr__(self, "params", RoverParams(**self.params))
        if not isinstance(self.params, RoverParams):
            raise ValueError(
                f"params must be a RoverParams or a dict of its fields, got "
                f"{type(self.params).__name__}"
            )
        object.__setattr__(self, "randomize", check_randomize(self.randomize))
        if self.action_map not in ACTION_MAPS:
            raise ValueError(
                f"action_map must be one of {sorted(ACTION_MAPS)}, got {self.action_map!r}"
            )
        if not (is_real(self.action_scale) and 0.0 < self.action_scale <= 1.0):
            raise ValueError(f"action_scale must lie in (0, 1], got {self.action_scale!r}")
        if self.info_level not in ("basic", "full"):
            raise ValueError(f"info_level must be 'basic' or 'full', got {self.info_level!r}")
        for name in TRAINING_STARTS:
            share = getattr(self, name)
            if not (is_real(share) and 0.0 <= share <= 1.0):
                raise ValueError(f"{name} must be a share in [0, 1], got {share!r}")
        if self.flight_start + self.near_start > 1.0:
            raise ValueError(
                f"flight_start + near_start must be at most 1 (shares of the same episodes), "
                f"got {self.flight_start!r} + {self.near_start!r}"
            )

    @classmethod
    def from_kwargs(cls, owner: str | None = None, /, **kwargs: Any) -> EnvConfig:
        """The config of these keyword arguments; `owner` names the caller in errors."""
        names = cls.option_names()
        refused = cls.unused_options()
        unused = [k for k in kwargs if k in refused]
        if unused:
            raise TypeError(
                f"{owner or cls.__name__}() got the argument {unused[0]!r}, which "
                f"this task does not use ({refused[unused[0]]})"
            )
        bad = [k for k in kwargs if k not in names]
        if bad:
            # Python's own wording: TorchRL's GymEnv probes with frameskip=1 and drops it
            # only on "unexpected keyword argument 'frameskip'"
            also = f" (and {bad[1:]})" if len(bad) > 1 else ""
            raise TypeError(
                f"{owner or cls.__name__}() got an unexpected keyword argument "
                f"{bad[0]!r}{also}; valid environment arguments: {sorted(names)}"
            )
        return cls(**kwargs)

    def reward_vector(self) -> np.ndarray:
        """The RW vector the kernels read: the reward part's."""
        return self.reward.reward_vector()

    def options_vector(self) -> np.ndarray:
        """The kernel's option vector O (integrator, impact law, tolerances)."""
        return make_options(self.integrator, self.impact_law, self.rtol, self.euler_dt)

    def kernel_values(self) -> dict[str, float]:
        """The values of `kernel_fields` the kernel reads, by name: the fields as they
        are, unless a task scales one (the mission task's noise_scale)."""
        return {name: getattr(self, name) for name in self.kernel_fields}

    def task_vector(self) -> np.ndarray:
        """The task configuration vector E (hoprover_env/tasks/layout.py): the shared
        slots, then the task's `kernel_fields` in declared order."""
        slots = task_slots(type(self))
        e = np.zeros(slots.size)
        e[E_CONTROL_DT] = self.control_dt
        e[E_T_TOTAL] = self.episode_time
        e[E_ACTION_MAP] = ACTION_MAPS[self.action_map]
        e[E_ACTION_SCALE] = self.action_scale
        values = self.kernel_values()
        for name in slots.names:
            e[getattr(slots, name)] = values[name]
        return e

    def terrain_columns(self, u: np.ndarray) -> dict:
        """The ground of n new episodes, from one uniform each in [0, 1) (`u`): fields
        of RoverParams and their values (arrays or scalars); {} here, the ground
        `params` says (a terrain task draws its slope)."""
        return {}

    def ground(self) -> dict:
        """The ground fields this config draws per episode and how: a (low, high) range
        (uniform) or one value ({} here: `params`' ground). What a driver needs to draw
        held-out ground like the task's, without knowing the task."""
        return {}

    def draws_bumps(self) -> bool:
        """Whether this config's episodes are on rough ground (reset options may still
        ask for bumps): the envs compile for smooth ground first when they are not."""
        return self.params.roughness > 0.0

    @property
    def max_steps(self) -> int:
        """Control steps in a full episode."""
        return int(math.ceil(self.episode_time / self.control_dt - 1e-9))


# Each task's config lives in its task module; these names are kept here for code
# written when they lived in this module (hoprover_env.env_config).
_IN_TASK_MODULES = {
    "HopEnvConfig": "hop",
    "TerrainEnvConfig": "terrain",
    "MissionEnvConfig": "mission",
    "MISSION_GROUND": "mission",
}


def __getattr__(name):
    if name in _IN_TASK_MODULES:
        import importlib

        return getattr(
            importlib.import_module(f"hoprover_env.tasks.{_IN_TASK_MODULES[name]}"), name
        )
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
