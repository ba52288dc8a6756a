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
"""
from __future__ import annotations

from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.tasks import terrain
from hoprover_env.envs.vector_env import HopRoverVectorEnv


class HopRoverTerrainEnv(HopRoverEnv):
    """The terrain task (HopRoverTerrain-v0) as a Gymnasium env (tables above)."""
    task = terrain.TASK


# VectorEnv named again (already a base): skrl's wrap_env recognises a Gymnasium env by
# its class's direct bases
class HopRoverTerrainVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N terrain envs stepped in one jitted call; sub-env i equals HopRoverTerrainEnv
    seeded with seed + i, bumps included."""
    task = terrain.TASK
