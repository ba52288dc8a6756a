"""HopRoverRL-v1: the torque task with settings for RL that sees what its reward pays for.

## Description

The contest's task (hoprover_env/tasks/torque.py: the same rover, physics, action and
judge), with the settings a learner trains on and an observation that resolves every
state its reward depends on. `HopRover-v0` and `HopRoverContest-v0` stay the contest's
task; `HopRoverRL-v0` stays as it was.

## Action space

`Box(-1, 1, (1,), float32)`: HopRover-v0's (`action_map`, `action_scale`), held for one
control period (`control_dt`, 2 s by default here).

## Observation space

`Box(float32, (20,))`. HopRover-v0's, changed where the reward could change while the
observation could not (v0 clips omega at 3 rad/s, the reference point at 1 m from the
target, while the attitude potential changes up to 30 rad/s and the distance up to
`dist_cap` = 5 m), and without the time (see "Time limits"):

| Num | Observation | Scaling | Min | Max |
|-----|-------------|---------|-----|-----|
| 0 | c.m. x relative to the target | / 1 m, clipped | -10 | 10 |
| 1 | c.m. height above its resting height h | / 0.5 m, clipped | -1 | 10 |
| 2 | c.m. horizontal velocity | / 0.01 m/s, clipped | -10 | 10 |
| 3 | c.m. vertical velocity | / 0.01 m/s, clipped | -10 | 10 |
| 4 | sin(theta) | | -1 | 1 |
| 5 | cos(theta) | | -1 | 1 |
| 6 | omega, fine | / 0.3 rad/s, clipped | -10 | 10 |
| 7 | omega, whole range | asinh(omega / 0.3 rad/s), clipped | -10 | 10 |
| 8-14 | contact state A..G, one-hot | | 0 | 1 |
| 15 | judge: time in the band / 5 s (0 when out) | | 0 | 1 |
| 16 | contact point (nearest bottom corner in flight) minus target, fine | / 0.05 m, clipped | -20 | 20 |
| 17 | the same, whole range | / 1 m, clipped | -10 | 10 |
| 18 | ballistic landing point of the c.m. minus target | / 1 m, clipped | -10 | 10 |
| 19 | torque applied during the last period | / T_max | -1 | 1 |

Slot 7 saturates at 3300 rad/s and slots 0, 17 and 18 at 10 m, beyond anything the
reward resolves: the attitude term is constant past 30 rad/s and `dist_cap` may not
exceed 10 m here. So the reward is a function of the observations (and the step's
length), never of hidden state.

## Rewards

HopRover-v0's (hoprover_env/tasks/reward.py), with these defaults: the landing-point
shaping (a hop is credited at launch), the flight-attitude potential (weight 1), a time
cost of 0.01 per second, gamma 0.995, and `attitude_cost` 0.1: every decision that ends
in flight pays -0.1 a(s'), a(s') the attitude potential's own error (tilt plus bounded
spin). The potential pays only differences, which a critic absorbs into Q; the cost
gives each decision its own credit for a still, upright flight.
`info_level="full"` reports it as `reward_attitude_cost`.

## Time limits

Episodes are truncated at `episode_time` (600 s), and the time is not observed: the
task is treated as one without a deadline, so learners bootstrap from the truncated
state (partial-episode bootstrapping, Pardo et al. 2018; SB3 reads
`TimeLimit.truncated`). The time cost makes a faster TTRTP pay whatever the clock says.

## Starting state

Upright at rest at x = 0, as in the contest, unless `flight_start` > 0 (a training
option, 0 by default): that share of the episodes starts in flight, over the target
range, in any attitude and spinning at up to 3 rad/s (tasks/draws.py `training_starts`),
so that a learner meets landings before it has learnt to launch; and unless
`near_start` > 0 (a training option too, 0 by default): that share starts upright at
rest within 0.5 m of the target, so that it meets the last approach and the 5 s of
keeping still in the band (flight_start + near_start <= 1). Evaluation
(hoprover_env.evaluation.episodes, the frozen suites) always starts at rest.

## Episode end

As HopRover-v0: terminated on success or a break, truncated at `episode_time`.

## Arguments

HopRover-v0's, with the defaults above, and `flight_start` and `near_start` (shares in
[0, 1]); `dist_cap` at most 10 m.

## Version history

* v1: this observation (unclipped spin and distances, no time), the per-decision
  attitude cost, and `flight_start`; `near_start` was added later, 0 by default, so
  what the id computes did not change.
"""  # noqa: E501 (Markdown tables, rendered by docs/_ext/envpages.py: a row cannot wrap)

import dataclasses
import math

import numpy as np

from hoprover_env.core.layout import S_MODE, S_TH, S_TORQUE, S_VX, S_VY, S_W, S_X, S_XT, S_Y
from hoprover_env.core.params import P_BAND, P_H, P_TMAX, P_TMIN
from hoprover_env.jit.compiler import NONE, VEC, VEC32, kernel
from hoprover_env.tasks import Registration
from hoprover_env.tasks.common import TaskSpec, close_step, open_step
from hoprover_env.tasks.config import RL_SETTINGS, EnvConfig
from hoprover_env.tasks.observation import (
    HEIGHT_SCALE,
    POS_SCALE,
    RATE_SCALE,
    VEL_SCALE,
    clip,
    dwell_fraction,
    landing_x,
    reference_point,
)
from hoprover_env.tasks.torque import action_to_torque, commanded_torque, step, torque_to_action

OBS_DX, OBS_HEIGHT, OBS_VX, OBS_VY, OBS_SIN, OBS_COS, OBS_RATE, OBS_SPIN = range(8)
OBS_MODE = 8  # 8..14: one-hot contact state A..G
OBS_DWELL = 15
OBS_REF = 16  # fine: / band half-width
OBS_REF_FAR = 17  # whole range: / POS_SCALE
OBS_LANDING = 18
OBS_TORQUE = 19
OBS_DIM = 20
FAR = 10.0  # the position slots' bound [POS_SCALE]
SPIN_BOUND = 10.0  # asinh(omega / RATE_SCALE) bound
OBS_LOW = np.array(
    [-FAR, -1, -10, -10, -1, -1, -10, -SPIN_BOUND] + [0] * 7 + [0, -20, -FAR, -FAR, -1],
    dtype=np.float32,
)
OBS_HIGH = np.array(
    [FAR, 10, 10, 10, 1, 1, 10, SPIN_BOUND] + [1] * 7 + [1, 20, FAR, FAR, 1], dtype=np.float32
)
assert len(OBS_LOW) == len(OBS_HIGH) == OBS_DIM

# HopRoverRL-v0's settings, plus the per-decision attitude cost
RL_V1_SETTINGS = {**RL_SETTINGS, "attitude_cost": 0.1}


@dataclasses.dataclass(frozen=True)
class RLEnvConfig(EnvConfig):
    """HopRover-v0's arguments; `dist_cap` within what the observation resolves."""

    def __post_init__(self):
        super().__post_init__()
        if self.dist_cap > FAR * POS_SCALE:
            raise ValueError(
                f"dist_cap must be at most {FAR * POS_SCALE} m here (the "
                f"observation's range), got {self.dist_cap!r}"
            )


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """Write the float32 observation of state S into `obs` (slots OBS_* above)."""
    xt = S[S_XT]
    obs[OBS_DX] = clip((S[S_X] - xt) / POS_SCALE, -FAR, FAR)
    obs[OBS_HEIGHT] = clip((S[S_Y] - P[P_H]) / HEIGHT_SCALE, -1.0, 10.0)
    obs[OBS_VX] = clip(S[S_VX] / VEL_SCALE, -10.0, 10.0)
    obs[OBS_VY] = clip(S[S_VY] / VEL_SCALE, -10.0, 10.0)
    obs[OBS_SIN] = math.sin(S[S_TH])
    obs[OBS_COS] = math.cos(S[S_TH])
    w = S[S_W] / RATE_SCALE
    obs[OBS_RATE] = clip(w, -10.0, 10.0)
    obs[OBS_SPIN] = clip(math.asinh(w), -SPIN_BOUND, SPIN_BOUND)
    mode = int(S[S_MODE])
    for i in range(7):
        obs[OBS_MODE + i] = 1.0 if i == mode else 0.0
    obs[OBS_DWELL] = dwell_fraction(S, P)
    ref = reference_point(S, P) - xt
    obs[OBS_REF] = clip(ref / P[P_BAND], -20.0, 20.0)
    obs[OBS_REF_FAR] = clip(ref / POS_SCALE, -FAR, FAR)
    obs[OBS_LANDING] = clip((landing_x(S, P) - xt) / POS_SCALE, -FAR, FAR)
    obs[OBS_TORQUE] = S[S_TORQUE] / max(abs(P[P_TMIN]), abs(P[P_TMAX]), 1e-300)


TASK = TaskSpec(
    name="torque_rl",
    config=RLEnvConfig,
    step=step,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
    holes={"ACTUATE": commanded_torque},
    action_torque=action_to_torque,
    torque_action=torque_to_action,
    compile_extra=(open_step, close_step, action_to_torque, observe),
)
REGISTER = (Registration("HopRoverRL-v1", RL_V1_SETTINGS, suite="level"),)
