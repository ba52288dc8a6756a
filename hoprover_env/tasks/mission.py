"""HopRoverMission: the contest's task under mission conditions.

## Description

HopRover-v0 on the terrain task's sloped, rough ground (hoprover_env/tasks/terrain.py), as a flight
rover would meet it: it senses its state through noisy sensors, knows its position only
from occasional fixes, does not know the ground it hops on, and its torquer is not
calibrated. The physics, the reward and the judge are HopRover-v0's, on the true state;
only what the policy sees and what its action does differ (hoprover_env/tasks/mission.py).

* **Sensing.** Attitude with white noise (`attitude_noise`, 0.5 deg, the order of a
  MEMS attitude solution's) plus a bias that walks (`bias_walk`, 1e-3 rad/sqrt(s): about
  1.4 deg after 600 s), rate with white noise (`rate_noise`, 1e-4 rad/s), the slope
  through an inclinometer (`inclinometer_noise`, 0.02 rad).
* **Position.** A fix of accuracy `fix_noise` (1 cm: imaging the ground beside a known
  landmark) whenever the rover has been at rest for `fix_rest` (1 s) at the control
  instants; otherwise the last fix and its age. Velocity and the contact state are not
  observed.
* **Unknown ground.** Restitutions and friction are drawn each episode (`randomize`,
  default +-20 % on the horizontal restitution, +-50 % on the vertical, +-25 % on the
  friction coefficients), the slope from `slope_range`, the bumps from `roughness`;
  none is observed.
* **Actuator.** The applied torque is the commanded one times a scale drawn each
  episode from 1 +- `actuator_error` (5 %), within the torque limits.

`noise_scale` multiplies every noise and the actuator error (0: exact sensors, still
fixes only at rest). Every draw comes from the episode's seed (sensor noise from a
counter-based generator keyed by a seed drawn at reset), so an episode replays bit for
bit and sub-env i of a vector env seeded with s equals a single env seeded with s + i.
The judge judges the true position.

## Action space

As HopRover-v0: `Box(-1, 1, (1,), float32)`, the commanded torque held for one control
period (applied with the episode's scale error).

## Observation space

`Box(float32, (8,))`:

| Num | Observation | Scaling | Min | Max |
|-----|-------------|---------|-----|-----|
| 0 | last position fix minus the target | / 1 m, clipped | -5 | 5 |
| 1 | age of that fix | / 60 s, clipped | 0 | 10 |
| 2 | sin of the measured attitude | | -1 | 1 |
| 3 | cos of the measured attitude | | -1 | 1 |
| 4 | measured angular rate | / 0.3 rad/s, clipped | -10 | 10 |
| 5 | time / episode time | | 0 | 1 |
| 6 | torque commanded in the last period | / T_max | -1 | 1 |
| 7 | inclinometer reading of the slope | / 0.5 rad, clipped | -1 | 1 |

With `history=k` the observation holds the last k readings, newest first
(`Box(float32, (8 k,))`; at reset every slot holds the first reading): a frame stack
built into the env, so that a feed-forward policy has memory and any library can train
it. A policy needs memory (this stack or a recurrent network) to tell flight from rest.

## Rewards, starting state, episode end

As HopRover-v0, on the true state. The rover starts at rest with a fix. Besides
HopRover-v0's reset options, `sensor_seed` (an integer in [0, 2^63)) fixes the episode's
sensor noise and `actuator_draw` (u in [-1, 1]) its actuator scale, 1 + `actuator_error`
`noise_scale` u; with the ground's values (`restitution_x`, `restitution_y`,
`mu_static`, `mu_dynamic`) they start a frozen episode (a test suite's).

## Info

HopRover-v0's keys. `info_level="full"` adds the true state (`rover_state`, `t`,
`contact_forces`, the reward's terms) and what the sensors hide: `attitude_bias` [rad],
`actuator_scale`, `last_fix_x` [m]. None of it enters the observation.

## Arguments

Those of HopRoverTerrain-v0 and:

| Argument | Default | Description |
|---|---|---|
| `noise_scale` | 1.0 | multiplies every noise below and the actuator error |
| `attitude_noise` | 0.0087 (0.5 deg) | attitude sensor white noise, 1 sigma [rad] |
| `bias_walk` | 1e-3 | attitude bias random walk [rad/sqrt(s)] |
| `rate_noise` | 1e-4 | rate sensor white noise [rad/s] |
| `fix_noise` | 0.01 | position fix noise [m] |
| `fix_rest` | 1.0 | time at rest before a fix [s] |
| `inclinometer_noise` | 0.02 | slope reading noise [rad] |
| `actuator_error` | 0.05 | half-range of the actuator's scale error |
| `history` | 1 | readings per observation, newest first |
| `randomize` | MISSION_GROUND | the ground's unknown parameters and their relative half-ranges |

## Version history

* v0: first version.

## Vectorized environment

`gym.make_vec("HopRoverMission-v0", num_envs=N)` returns `HopRoverMissionVectorEnv`.

## The step, in the kernel

The mission task (HopRoverMission-v0): the torque task on unknown ground, sensed
through noise.

The physics, the step and the judge are the torque task's on the terrain task's ground
(tasks/torque.py `step`); this module adds what a flight rover has instead of the true
state, all of it in the task memory M of each rover:

* an actuator with a per-episode scale error: the torque applied is the commanded one
  times ``M_ACT_SCALE`` (clipped to the torquer's limits), bound as the step's
  ``ACTUATE``;
* sensors, read at every control instant by `observe`: attitude with white noise and a
  slowly walking bias, rate with white noise, an inclinometer, and a position fix taken
  only when the rover has been at rest for E_FIX_REST seconds (it images the ground);
  between fixes it sees the last fix and its age.

Every draw is a truncated normal (|z| <= 3) from the counter-based generator of the
rough terrain (core/terrain.py `truncated_normal`), keyed by the episode's sensor seed
(drawn at reset from the episode's seed, or given as the reset option `sensor_seed`) and
the sensor's channel, at counter = the
number of readings so far: an episode replays bit for bit, whatever thread or batch it
runs in. Velocity and the contact state are never observed.

Its step is the torque task's template (`torque.step`: `common.open_step`, `ACTUATE`
bound to `actuate` below, `ADVANCE`, `reward.charge`, `common.close_step`); its observe
is `observe` below (the sensors, drawn by `core.terrain.truncated_normal`).
"""

import dataclasses
import math
from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from hoprover_env.core.layout import MODE_F, S_MODE, S_T, S_TH, S_W, S_X, S_XT
from hoprover_env.core.params import P_SLOPE, P_TMAX, P_TMIN
from hoprover_env.core.terrain import truncated_normal
from hoprover_env.jit.compiler import NONE, VEC, VEC32, kernel
from hoprover_env.tasks import Registration, torque
from hoprover_env.tasks.layout import E_T_TOTAL, task_slots
from hoprover_env.tasks.observation import POS_SCALE, RATE_SCALE, clip
from hoprover_env.tasks.options import StartOption
from hoprover_env.tasks.terrain import SLOPE_SCALE, TerrainEnvConfig
from hoprover_env.util.validate import non_negative_real, positive_real

# The ground a mission does not know: restitutions and friction drawn per episode
# (relative half-ranges, EnvConfig.randomize), about the spread of the regolith
# measurements Hayabusa2's MINERVA-II and MASCOT landings left open.
MISSION_GROUND = {"restitution_x": 0.2, "restitution_y": 0.5, "mu_static": 0.25, "mu_dynamic": 0.25}
_NOISES = (
    "attitude_noise",
    "rate_noise",
    "bias_walk",
    "fix_noise",
    "inclinometer_noise",
    "actuator_error",
)


@dataclasses.dataclass(frozen=True)
class MissionEnvConfig(TerrainEnvConfig):
    """Arguments of HopRoverMission-v0: those of HopRoverTerrain-v0 (the ground drawn
    each episode, `randomize` defaulting to MISSION_GROUND) plus its sensors and
    actuator (the table above). `noise_scale` multiplies every noise."""

    # its own slots of E: its sensors (tasks/layout.py task_slots), the noises scaled
    # by noise_scale (kernel_values)
    kernel_fields: ClassVar[tuple[str, ...]] = (
        "attitude_noise",
        "rate_noise",
        "bias_walk",
        "fix_noise",
        "fix_rest",
        "inclinometer_noise",
        "history",
    )

    randomize: Mapping[str, float] | None = dataclasses.field(
        default_factory=lambda: dict(MISSION_GROUND)
    )
    noise_scale: float = 1.0
    attitude_noise: float = math.radians(0.5)  # attitude sensor noise, 1 sigma [rad]
    rate_noise: float = 1e-4  # rate sensor noise [rad/s]
    bias_walk: float = 1e-3  # attitude bias random walk [rad/sqrt(s)]
    fix_noise: float = 0.01  # position fix noise [m]
    fix_rest: float = 1.0  # time at rest before a fix [s]
    inclinometer_noise: float = 0.02  # inclinometer noise [rad]
    actuator_error: float = 0.05
    history: int = 1  # readings in the observation, newest first

    def __post_init__(self):
        super().__post_init__()
        if not (
            isinstance(self.history, (int, np.integer))
            and not isinstance(self.history, bool)
            and 1 <= self.history <= 64
        ):
            raise ValueError(
                f"history (readings per observation) must be an integer in "
                f"[1, 64], got {self.history!r}"
            )
        for name in _NOISES + ("noise_scale",):
            object.__setattr__(self, name, non_negative_real(name, getattr(self, name)))
        object.__setattr__(self, "fix_rest", positive_real("fix_rest", self.fix_rest))
        if self.actuator_error * self.noise_scale >= 1.0:
            raise ValueError(
                f"actuator_error x noise_scale must be below 1 (a scale error "
                f"of 100 % or more reverses the torque), got "
                f"{self.actuator_error} x {self.noise_scale}"
            )

    def kernel_values(self) -> dict[str, float]:
        values = super().kernel_values()
        for name in (
            "attitude_noise",
            "rate_noise",
            "bias_walk",
            "fix_noise",
            "inclinometer_noise",
        ):
            values[name] = self.noise_scale * values[name]
        return values


# this task's slots of E, named for its kernels (module-level ints: numba folds them)
SLOTS = task_slots(MissionEnvConfig)
E_ATT_NOISE = SLOTS.attitude_noise
E_RATE_NOISE = SLOTS.rate_noise
E_BIAS_WALK = SLOTS.bias_walk
E_FIX_NOISE = SLOTS.fix_noise
E_FIX_REST = SLOTS.fix_rest
E_INCL_NOISE = SLOTS.inclinometer_noise
E_HISTORY = SLOTS.history


# the task memory M of one rover
M_SEED_LO, M_SEED_HI = 0, 1  # the episode's sensor seed, in two 32-bit halves
M_COUNT = 2  # readings taken (the generator's counter)
M_ACT_SCALE = 3  # the actuator's scale this episode
M_BIAS = 4  # the attitude sensor's bias now [rad]
M_REST = 5  # time at rest seen at control instants [s]
M_FIX_X = 6  # the last position fix [m]
M_FIX_T = 7  # when it was taken [s]
M_LAST_T = 8  # the time of the last reading [s]
M_CMD = 9  # the torque commanded in the last step [N m]
N_M = 10
# the generator's channels (its key's second word)
CH_ATT, CH_RATE, CH_BIAS, CH_FIX, CH_INCL = range(5)

OBS_FIX = 0  # (last fix - target) / POS_SCALE
OBS_FIX_AGE = 1  # (t - time of the last fix) / FIX_AGE_SCALE
OBS_SIN = 2  # sin of the measured attitude
OBS_COS = 3  # cos of the measured attitude
OBS_RATE = 4  # measured rate / RATE_SCALE
OBS_TIME = 5  # t / episode length
OBS_TORQUE = 6  # commanded torque / max |T|
OBS_SLOPE = 7  # inclinometer / SLOPE_SCALE
OBS_DIM = 8  # one reading; the observation holds `history` of them, newest first
FIX_AGE_SCALE = 60.0  # s
OBS_LOW = np.array([-5, 0, -1, -1, -10, 0, -1, -1], dtype=np.float32)
OBS_HIGH = np.array([5, 10, 1, 1, 10, 1, 1, 1], dtype=np.float32)
_32 = np.uint64(32)


@kernel(inner=True)
def actuate(action, P, E, M):
    """The torque the actuator applies for a command: the torque task's map, times the
    episode's scale error, within the torquer's limits. Records the command (the rover
    knows what it asked for, not what it got)."""
    cmd = torque.action_to_torque(action[0], P, E)
    M[M_CMD] = cmd
    return clip(cmd * M[M_ACT_SCALE], P[P_TMIN], P[P_TMAX])


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """Take this control instant's readings into `obs` (slots OBS_* of its first
    OBS_DIM), after shifting the earlier readings back by one (the first reading of an
    episode fills every slot), advancing the sensors' state in M (the bias walk, the
    rest clock, the last fix)."""
    first = M[M_COUNT] == 0.0
    n = obs.shape[0]
    if not first:
        for j in range(n - 1, OBS_DIM - 1, -1):
            obs[j] = obs[j - OBS_DIM]
    t = S[S_T]
    dt = max(t - M[M_LAST_T], 0.0)
    M[M_LAST_T] = t
    seed = np.uint64(M[M_SEED_LO]) | (np.uint64(M[M_SEED_HI]) << _32)
    k = np.uint64(M[M_COUNT])
    M[M_COUNT] += 1.0
    M[M_BIAS] += E[E_BIAS_WALK] * math.sqrt(dt) * truncated_normal(seed, np.uint64(CH_BIAS), k)
    if int(S[S_MODE]) == MODE_F:
        M[M_REST] += dt
    else:
        M[M_REST] = 0.0
    if M[M_REST] >= E[E_FIX_REST]:
        M[M_FIX_X] = S[S_X] + E[E_FIX_NOISE] * truncated_normal(seed, np.uint64(CH_FIX), k)
        M[M_FIX_T] = t
    th = S[S_TH] + M[M_BIAS] + E[E_ATT_NOISE] * truncated_normal(seed, np.uint64(CH_ATT), k)
    w = S[S_W] + E[E_RATE_NOISE] * truncated_normal(seed, np.uint64(CH_RATE), k)
    incl = P[P_SLOPE] + E[E_INCL_NOISE] * truncated_normal(seed, np.uint64(CH_INCL), k)
    obs[OBS_FIX] = clip((M[M_FIX_X] - S[S_XT]) / POS_SCALE, -5.0, 5.0)
    obs[OBS_FIX_AGE] = clip((t - M[M_FIX_T]) / FIX_AGE_SCALE, 0.0, 10.0)
    obs[OBS_SIN] = math.sin(th)
    obs[OBS_COS] = math.cos(th)
    obs[OBS_RATE] = clip(w / RATE_SCALE, -10.0, 10.0)
    obs[OBS_TIME] = clip(t / E[E_T_TOTAL], 0.0, 1.0)
    obs[OBS_TORQUE] = M[M_CMD] / max(abs(P[P_TMIN]), abs(P[P_TMAX]), 1e-300)
    obs[OBS_SLOPE] = clip(incl / SLOPE_SCALE, -1.0, 1.0)
    if first:
        for j in range(OBS_DIM, n):
            obs[j] = obs[j % OBS_DIM]


def bounds(config) -> tuple:
    """The observation's bounds: `config.history` readings."""
    return np.tile(OBS_LOW, config.history), np.tile(OBS_HIGH, config.history)


# what start draws, as reset options: a frozen episode's (a test suite's) are given so
START_OPTIONS = (
    StartOption("sensor_seed", "seed", "the key of the episode's sensor noise"),
    StartOption(
        "actuator_draw", "unit", "u of the actuator's scale 1 + actuator_error noise_scale u"
    ),
)


def start(config, U, S, P, M, fixed) -> None:
    """New episodes' sensors and actuators, for the rows reset (one per rover), from
    their two uniforms (tasks/draws.py: after the episode's target, ground and terrain):
    the sensor seed (53 bits), then the actuator's draw u in [-1, 1) and its scale
    1 + actuator_error noise_scale u; `fixed` (START_OPTIONS given at reset) replaces
    either. The rover has rested before the episode, so its first reading carries a
    fix."""
    if "sensor_seed" in fixed:
        seed = np.asarray(fixed["sensor_seed"]).astype(np.uint64)
    else:
        seed = (U[:, 0] * 2.0**53).astype(np.uint64)
    u = fixed["actuator_draw"] if "actuator_draw" in fixed else 2.0 * U[:, 1] - 1.0
    M[:, M_SEED_LO] = seed & np.uint64(0xFFFFFFFF)
    M[:, M_SEED_HI] = seed >> np.uint64(32)
    M[:, M_ACT_SCALE] = 1.0 + config.actuator_error * config.noise_scale * u
    M[:, M_REST] = config.fix_rest
    M[:, M_LAST_T] = S[:, S_T]


def hidden_info(M) -> dict:
    """What the rover does not see, for analysis (info_level="full"; the true state is
    info's rover_state): its attitude sensor's bias [rad], its actuator's scale and its
    last fix [m], for one rover (numpy scalars) or N (arrays)."""
    cols = {"attitude_bias": M_BIAS, "actuator_scale": M_ACT_SCALE, "last_fix_x": M_FIX_X}
    return {
        key: (np.float64(M[col]) if M.ndim == 1 else M[:, col].copy()) for key, col in cols.items()
    }


TASK = dataclasses.replace(
    torque.TASK,
    name="mission",
    config=MissionEnvConfig,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
    memory=N_M,
    reset_memory=start,
    reset_draws=2,
    start_options=START_OPTIONS,
    holes={"ACTUATE": actuate},
    hidden_info=hidden_info,
    obs_bounds=bounds,
)
REGISTER = (Registration("HopRoverMission-v0", suite="terrain"),)
