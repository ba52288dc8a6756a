"""HopRoverMission: the contest's task under mission conditions.

## Description

HopRover-v0 on the terrain task's sloped, rough ground (terrain_env.py), as a flight
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

As HopRover-v0, on the true state. The rover starts at rest with a fix.

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
"""
from __future__ import annotations

from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.tasks import mission
from hoprover_env.envs.vector_env import HopRoverVectorEnv


class HopRoverMissionEnv(HopRoverEnv):
    """The mission task (HopRoverMission-v0) as a Gymnasium env."""
    task = mission.TASK


# VectorEnv named again (already a base): skrl's wrap_env recognises a Gymnasium env by
# its class's direct bases
class HopRoverMissionVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N mission envs stepped in one jitted call; sub-env i equals HopRoverMissionEnv
    seeded with seed + i."""
    task = mission.TASK
