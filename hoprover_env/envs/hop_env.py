"""HopRoverHop: the same rover and judge, one action per hop.

## Description

The hop-level formulation of the hopping-rover literature (sequential hop planning as an
MDP, e.g. Hockman & Pavone, "Stochastic motion planning for hopping rovers on small
Solar System bodies", 2017): the agent chooses where to hop, a built-in controller flies
the hop. Each step runs, inside the jitted kernel on the control grid of `control_dt`:

1. **Launch**: hold the commanded torque until the rover leaves the ground (at most
   `launch_max` s; if it has not lifted off by then, the torque drops to zero).
2. **Flight**: a PD attitude hold, T = -I (kp theta + kd omega), clipped to the torque
   limits, so the rover lands on its bottom face.
3. **Landing**: zero torque while it bounces (attitude hold again in each bounce), slides
   and stops.

The step returns when the rover is at rest again outside the band, when the judge's TTRTP
is reached, when it breaks, or when the episode's time is up. A rover that comes to rest
with a contact point in the band is left at rest until the judge's 5 s are up (so a
step that starts in the band, e.g. a target within 0.1 m of the start, only waits). It is the physics of
HopRover-v0, the same kernel and the same judge; only the decision points differ.

## Action space

`Box(-1, 1, (1,), float32)`. The sign is the direction of the hop (positive torque sends
the rover towards +x). |a| maps log-uniformly onto launch torques from `launch_min` x
m g r (1.05 x the tipping torque) at a = 0 to the torque limit at |a| = 1: the hop length
grows about geometrically with the torque, so this gives equal resolution to short and
long hops.

## Observation space

That of HopRover-v0 (`Box(float32, (19,))`, the table in env.py), observed at the end of
each hop: at rest, so the useful parts are the offset from the target (0, 16, 17), the
time (14) and the judge's dwell (15).

## Rewards

HopRover-v0's potential-based reward over the whole hop: `gamma * Phi(s') - Phi(s) -
time_cost * (simulated seconds of the hop)`, plus `success_bonus` at TTRTP and minus
`break_penalty` if a top corner touches the ground. The time cost makes a faster TTRTP
pay; gamma defaults to 0.98 per decision (a hop, not a control period).

## Starting state, episode end, info

As HopRover-v0: upright at rest at x = 0, the target from `target_range`. Termination on
success, on breaking, and when `episode_time` (600 s) runs out: the contest's time limit
is part of this task and the time is observed, so it is a terminal state (with its
potential: a rover far from the target is not let off), not a truncation. A learner that
bootstraps at a truncation would value a rover the clock caught mid-flight, a state no
hop decision is ever taken in; PPO exploited exactly that with long hops. `info["ttrtp"]` is the
judge's TTRTP, `info["is_success"]`, `info["broken"]`, `info["state"]`.

## Arguments

Those of HopRover-v0 (`control_dt` is the controller's period, default 0.5 s) and:

| Argument | Default | Description |
|---|---|---|
| `hold_kp`, `hold_kd` | 0.15, 0.9 | attitude-hold gains [1/s^2, 1/s] (times the inertia) |
| `launch_max` | 60.0 | longest a launch torque is held without lift-off [s] |
| `launch_min` | 1.05 | weakest launch torque, as a multiple of m g r |
| `gamma` | 0.98 | discount per hop (shaping) |

## Vectorized environment

`gym.make_vec("HopRoverHop-v0", num_envs=N)` returns `HopRoverHopVectorEnv`: all N hops
of a step in one jitted call, threaded over the cores from 64 sub-envs on.
"""
from __future__ import annotations

from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.tasks import hop
from hoprover_env.envs.vector_env import HopRoverVectorEnv


class HopRoverHopEnv(HopRoverEnv):
    """The hop-level task (HopRoverHop-v0) as a Gymnasium env: one action, one hop."""
    task = hop.TASK


# VectorEnv named again (already a base): skrl's wrap_env recognises a Gymnasium env by
# its class's direct bases
class HopRoverHopVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N hop-level envs stepped in one jitted call; sub-env i equals HopRoverHopEnv
    seeded with seed + i."""
    task = hop.TASK
