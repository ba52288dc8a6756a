"""The mission task (HopRoverMission-v0): the torque task on unknown ground, sensed
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
(drawn at reset from the env's generator) and the sensor's channel, at counter = the
number of readings so far: an episode replays bit for bit, whatever thread or batch it
runs in. Velocity and the contact state are never observed.
"""
import dataclasses
import math

import numpy as np

from hoprover_env.jit.compiler import kernel, NONE, VEC, VEC32
from hoprover_env.core.layout import MODE_F, S_MODE, S_T, S_TH, S_W, S_X, S_XT
from hoprover_env.core.terrain import truncated_normal
from hoprover_env.tasks.config import MissionEnvConfig
from hoprover_env.core.params import P_SLOPE, P_TMAX, P_TMIN
from hoprover_env.tasks import torque
from hoprover_env.tasks.layout import (E_ATT_NOISE, E_BIAS_WALK, E_FIX_NOISE, E_FIX_REST, E_HISTORY,
                     E_INCL_NOISE, E_RATE_NOISE, E_T_TOTAL)
from hoprover_env.tasks.observation import POS_SCALE, RATE_SCALE, clip
from hoprover_env.tasks.terrain import SLOPE_SCALE

# the task memory M of one rover
M_SEED_LO, M_SEED_HI = 0, 1     # the episode's sensor seed, in two 32-bit halves
M_COUNT = 2                     # readings taken (the generator's counter)
M_ACT_SCALE = 3                 # the actuator's scale this episode
M_BIAS = 4                      # the attitude sensor's bias now [rad]
M_REST = 5                      # time at rest seen at control instants [s]
M_FIX_X = 6                     # the last position fix [m]
M_FIX_T = 7                     # when it was taken [s]
M_LAST_T = 8                    # the time of the last reading [s]
M_CMD = 9                       # the torque commanded in the last step [N m]
N_M = 10
# the generator's channels (its key's second word)
CH_ATT, CH_RATE, CH_BIAS, CH_FIX, CH_INCL = range(5)

OBS_FIX = 0          # (last fix - target) / POS_SCALE
OBS_FIX_AGE = 1      # (t - time of the last fix) / FIX_AGE_SCALE
OBS_SIN = 2          # sin of the measured attitude
OBS_COS = 3          # cos of the measured attitude
OBS_RATE = 4         # measured rate / RATE_SCALE
OBS_TIME = 5         # t / episode length
OBS_TORQUE = 6       # commanded torque / max |T|
OBS_SLOPE = 7        # inclinometer / SLOPE_SCALE
OBS_DIM = 8          # one reading; the observation holds `history` of them, newest first
FIX_AGE_SCALE = 60.0     # s
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


def start(config, rng: np.random.Generator, S, P, M) -> None:
    """A new episode's sensors and actuator, drawn from the env's generator after the
    episode's target, ground and terrain: the sensor seed, then the actuator's scale.
    The rover has rested before the episode, so its first reading carries a fix."""
    seed = int(rng.integers(2**63))
    scale = 1.0 + config.actuator_error * config.noise_scale * rng.uniform(-1.0, 1.0)
    M[M_SEED_LO] = seed & 0xFFFFFFFF
    M[M_SEED_HI] = seed >> 32
    M[M_ACT_SCALE] = scale
    M[M_REST] = config.fix_rest
    M[M_LAST_T] = S[S_T]


def hidden_info(M) -> dict:
    """What the rover does not see, for analysis (info_level="full"; the true state is
    info's rover_state): its attitude sensor's bias [rad], its actuator's scale and its
    last fix [m], for one rover (numpy scalars) or N (arrays)."""
    cols = {"attitude_bias": M_BIAS, "actuator_scale": M_ACT_SCALE, "last_fix_x": M_FIX_X}
    return {key: (np.float64(M[col]) if M.ndim == 1 else M[:, col].copy())
            for key, col in cols.items()}


TASK = dataclasses.replace(
    torque.TASK, name="mission", config=MissionEnvConfig, observe=observe,
    obs_low=OBS_LOW, obs_high=OBS_HIGH, memory=N_M, reset_memory=start,
    holes={"ACTUATE": actuate}, hidden_info=hidden_info, obs_bounds=bounds)
