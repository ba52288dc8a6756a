"""HopRoverTerrain: the contest's task on sloped, rough ground.

## Description

HopRover-v0 (hoprover_env/envs/env.py) on a ground that is neither flat nor smooth. Each
episode draws the ground's inclination phi from `slope_range`; the ground frame is kept
(x along the surface, y along its outward normal; gravity is g (-sin phi, -cos phi)),
so the target is a point along the surface and the judge is the contest's. Each impact
bounces off a local normal tilted from the mean one by a normal draw of standard
deviation `roughness` (truncated at 3 sigma), keyed by the episode's terrain seed.
Physics: docs/MODEL.md section 11, decisions in docs/PHYSICS.md ("Terrain").

## Action space

As HopRover-v0: `Box(-1, 1, (1,), float32)`, the torque held for one control period.

## Observation space

`Box(float32, (20,))`: HopRover-v0's 19 components, then

| Num | Observation | Scaling | Min | Max |
|-----|-------------|---------|-----|-----|
| 19 | slope phi of the ground (rising toward +x when positive) | / 0.5 rad | -1 | 1 |

Component 17, the ballistic landing point, is computed on the slope (the flight's
along-surface deceleration g sin phi included).

## Rewards, starting state, episode end, info

As HopRover-v0 (the same reward module, hoprover_env/tasks/reward.py, and judge). At rest on
an incline steeper than atan(mu_s) (0.54 rad with the contest's mu_s = 0.6, beyond the
largest slope) the rover would slide from the start. `info["slope"]` is the episode's
slope and `info["terrain_seed"]` the seed of its bumps; `reset(options={"slope": ...,
"roughness": ...})` fixes them for one episode (evaluate.py does, for held-out pairs).

## Arguments

Those of HopRover-v0 and:

| Argument | Default | Description |
|---|---|---|
| `slope_range` | (-0.2, 0.2) | slopes drawn from U(low, high) [rad], within +-0.5 |
| `roughness` | 0.05 | standard deviation of each impact normal's tilt [rad] |

HopRover-v0 itself takes a fixed slope and roughness through `params`, e.g.
`gym.make("HopRover-v0", params={"slope": 0.1, "roughness": 0.05})`.

## Version history

* v0: first version (slope and rough bounces, exact events).

## Vectorized environment

`gym.make_vec("HopRoverTerrain-v0", num_envs=N)` returns `HopRoverTerrainVectorEnv`:
sub-env i equals a `HopRoverTerrainEnv` seeded with s + i, bumps included.

## The step, in the kernel

The terrain task (HopRoverTerrain-v0): the torque task on a sloped, rough ground.

Each episode draws its slope (the env's config); the step is the torque task's
(tasks/torque.py, the same template), and the observation is the torque task's plus the
slope, so that one policy can hop on any incline.

Its step is the torque task's (`torque.step`: `common.open_step`,
`torque.commanded_torque`, `ADVANCE`, `reward.charge`, `common.close_step`); its
observe is `observe` below, which calls `observation.observe`.
"""

import dataclasses
import math

import numpy as np

from hoprover_env.core.params import MAX_SLOPE, P_SLOPE
from hoprover_env.jit.compiler import NONE, VEC, VEC32, kernel
from hoprover_env.tasks import Registration, torque
from hoprover_env.tasks.config import RL_SETTINGS, EnvConfig
from hoprover_env.tasks.observation import OBS_DIM
from hoprover_env.tasks.observation import OBS_HIGH as FLAT_HIGH
from hoprover_env.tasks.observation import OBS_LOW as FLAT_LOW
from hoprover_env.tasks.observation import observe as flat_observe
from hoprover_env.util.validate import is_real


@dataclasses.dataclass(frozen=True)
class TerrainEnvConfig(EnvConfig):
    """Arguments of HopRoverTerrain-v0: those of HopRover-v0 plus the terrain each episode
    draws (the table above)."""

    slope_range: tuple = (-0.2, 0.2)
    roughness: float = 0.05

    def __post_init__(self):
        super().__post_init__()
        rng = self.slope_range
        if not (
            isinstance(rng, (tuple, list, np.ndarray))
            and len(rng) == 2
            and all(is_real(v) and abs(v) <= MAX_SLOPE for v in rng)
            and rng[0] <= rng[1]
        ):
            raise ValueError(
                f"slope_range must be (low, high) [rad] with low <= high, both "
                f"in [-{MAX_SLOPE}, {MAX_SLOPE}]; got {self.slope_range!r}"
            )
        object.__setattr__(self, "slope_range", (float(rng[0]), float(rng[1])))
        if not (is_real(self.roughness) and math.isfinite(self.roughness) and self.roughness >= 0):
            raise ValueError(
                f"roughness must be a finite number >= 0 [rad], got {self.roughness!r}"
            )

    def terrain_columns(self, u: np.ndarray) -> dict:
        lo, hi = self.slope_range
        return {"slope": lo + (hi - lo) * u, "roughness": float(self.roughness)}

    def ground(self) -> dict:
        return {"slope": self.slope_range, "roughness": self.roughness}

    def draws_bumps(self) -> bool:
        return self.roughness > 0.0


OBS_SLOPE = OBS_DIM  # the slope / SLOPE_SCALE, after the torque task's slots
SLOPE_SCALE = 0.5  # rad: the largest slope the model accepts
OBS_LOW = np.append(FLAT_LOW, np.float32(-1.0))
OBS_HIGH = np.append(FLAT_HIGH, np.float32(1.0))


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """The torque task's observation (slots 0..18), then the slope (slot OBS_SLOPE)."""
    flat_observe(S, P, E, M, obs)
    obs[OBS_SLOPE] = P[P_SLOPE] / SLOPE_SCALE


TASK = dataclasses.replace(
    torque.TASK,
    name="terrain",
    config=TerrainEnvConfig,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
)
REGISTER = (
    Registration("HopRoverTerrain-v0", suite="terrain"),
    Registration("HopRoverTerrainRL-v0", RL_SETTINGS, suite="terrain"),
)
