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
with a contact point in the band is left at rest until the judge's 5 s are up (so a step
that starts in the band, e.g. a target within 0.1 m of the start, only waits). It is the
physics of HopRover-v0, the same kernel and the same judge; only the decision points differ.

## Action space

`Box(-1, 1, (1,), float32)`. The sign is the direction of the hop (positive torque sends
the rover towards +x). |a| maps log-uniformly onto launch torques from `launch_min` x
m g r (1.05 x the tipping torque) at a = 0 to the torque limit at |a| = 1: the hop length
grows about geometrically with the torque, so this gives equal resolution to short and
long hops.

## Observation space
 That of HopRover-v0 (`Box(float32, (19,))`, the table in hoprover_env/tasks/torque.py),
observed at the end of
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

## The step, in the kernel

The hop-level task (HopRoverHop-v0): one action is one hop, flown by a built-in
controller.

The step maps the action to a signed launch torque (`hop_torque`), then runs the rover
on the control grid (E_CONTROL_DT) with the controller a contest entry would use: hold
the launch torque until lift-off, the PD attitude hold in the air (so the rover lands on
its bottom face), zero torque on the ground while it bounces, slides and stops. The
step returns when the rover is at rest again outside the band, when the judge's TTRTP
is reached (a rover at rest in the band is left there until the judge's 5 s are up),
when it breaks, or at the end of the episode. Reward, observation and outcome are every
task's (tasks/common.py `close_step`), with the time cost charged for the simulated seconds
the hop took. `TASK` is its written interface (tasks/common.py `TaskSpec`).

Its step calls these jitted functions: `common.open_step`, `hop_torque`,
`sim.controllers.attitude_hold`, `ADVANCE` (bound by `common.build` to
`core.advance_event`, or `core.advance` for `integrator="euler"`), `reward.charge`,
`common.episode_ended` and `common.close_step`; then `observation.observe`.
"""

import dataclasses
import math
from typing import ClassVar

from hoprover_env.core.layout import (
    ERR_STEP,
    MODE_A,
    MODE_F,
    S_ERROR,
    S_INBAND,
    S_MODE,
    S_T,
    S_TH,
    S_W,
)
from hoprover_env.core.params import P_G, P_I, P_M, P_R, P_TMAX, P_TMIN
from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold
from hoprover_env.tasks import Registration, reward, torque
from hoprover_env.tasks.common import ADVANCE, TaskSpec, close_step, episode_ended, open_step
from hoprover_env.tasks.config import EnvConfig
from hoprover_env.tasks.layout import E_CONTROL_DT, E_T_TOTAL, task_slots
from hoprover_env.tasks.observation import OBS_HIGH, OBS_LOW, clip, observe
from hoprover_env.util.validate import is_real


@dataclasses.dataclass(frozen=True)
class HopRewardConfig(reward.RewardConfig):
    """The reward of the hop task: a step is a whole hop, so a lower discount."""

    gamma: float = 0.98


@dataclasses.dataclass(frozen=True)
class HopEnvConfig(EnvConfig):
    """Arguments of HopRoverHop-v0: those of HopRover-v0 plus the built-in hop controller
    (the table above). `control_dt` is the controller's period here. The torque task's
    action map is not used: one action is a hop's launch torque (`hop_torque`)."""

    unused: ClassVar[dict] = {
        "action_map": "one action is a hop's launch torque, mapped by hop_torque",
        "action_scale": "one action is a hop's launch torque, mapped by hop_torque",
        "flight_start": "a hop is launched from rest: every step starts at rest",
        "near_start": "a hop is launched from rest at x = 0: the hops are the task",
    }

    # its own slots of E: the built-in controller (tasks/layout.py task_slots)
    kernel_fields: ClassVar[tuple[str, ...]] = ("hold_kp", "hold_kd", "launch_max", "launch_min")
    reward_config: ClassVar[type[reward.RewardConfig]] = HopRewardConfig

    hold_kp: float = 0.15  # attitude hold in flight [1/s^2]
    hold_kd: float = 0.9  # [1/s]
    launch_max: float = 60.0  # longest a launch torque is held before giving up [s]
    launch_min: float = 1.05  # weakest launch, a multiple of the tipping torque m g r

    def __post_init__(self):
        super().__post_init__()
        for name in ("hold_kp", "hold_kd", "launch_max"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (is_real(self.launch_min) and 1.0 < self.launch_min < 1e3):
            raise ValueError(
                f"launch_min (a multiple of the tipping torque m g r) must lie "
                f"in (1, 1000), got {self.launch_min!r}"
            )


# this task's slots of E, named for its kernels (module-level ints: numba folds them)
SLOTS = task_slots(HopEnvConfig)
E_HOLD_KP = SLOTS.hold_kp
E_HOLD_KD = SLOTS.hold_kd
E_LAUNCH_MAX = SLOTS.launch_max
E_LAUNCH_MIN = SLOTS.launch_min


# A hop that never ends (it cannot: every state decays to rest or flies ballistically)
# would still stop here, in the kernel's error state, which ends the episode.
MAX_SUBSTEPS = 1_000_000


@kernel
def hop_torque(a, P, E):
    """Signed launch torque [N m] of a hop action.

    |a| maps log-uniformly onto [launch_min * m g r, min |T_limit|]: the hop length grows
    roughly geometrically with the torque, so equal steps of the action are about equal
    relative changes of the hop. a = 0 is the weakest hop towards +x.
    """
    a = clip(a, -1.0, 1.0)
    lo = E[E_LAUNCH_MIN] * P[P_M] * P[P_G] * P[P_R]
    hi = min(abs(P[P_TMIN]), P[P_TMAX])
    if hi <= lo:
        mag = hi
    else:
        mag = lo * math.exp(abs(a) * math.log(hi / lo))
    return -mag if a < 0.0 else mag


def step(S, P, O, E, RW, RM, M, action, ev, W):
    """One hop (or, at rest in the band, the wait for the judge). Returns (reward,
    terminated, truncated, success, n_events)."""
    phi0, had_ttrtp, t0, nev0 = open_step(S, P, RW, RM)
    t_end = E[E_T_TOTAL]
    dt = E[E_CONTROL_DT]
    torque = hop_torque(action[0], P, E)
    # at rest in the band the judge's clock runs: the step waits it out, whatever the action
    flown = int(S[S_MODE]) == MODE_F and S[S_INBAND] == 1.0
    k = 0
    while S[S_T] < t_end and not episode_ended(S, had_ttrtp):
        mode = int(S[S_MODE])
        if mode == MODE_A:
            flown = True
            cmd = clip(
                attitude_hold(S[S_TH], S[S_W], P[P_I], E[E_HOLD_KP], E[E_HOLD_KD]),
                P[P_TMIN],
                P[P_TMAX],
            )
        elif not flown:
            if S[S_T] - t0 >= E[E_LAUNCH_MAX]:
                flown = True  # it never lifted off: let it settle
                cmd = 0.0
            else:
                cmd = torque
        elif mode == MODE_F and S[S_INBAND] != 1.0:
            break  # at rest outside the band: the next decision
        else:
            cmd = 0.0  # bouncing, sliding, or resting in the band
        # the grid of control instants is t0 + k dt, as a contest controller's
        k += 1
        t_before = S[S_T]
        ADVANCE(S, P, O, cmd, min(t0 + k * dt, t_end), ev, W)
        reward.charge(P, RM, cmd, S[S_T] - t_before)
        if k >= MAX_SUBSTEPS:
            S[S_ERROR] = ERR_STEP
            break
    r, terminated, truncated, success, n_events = close_step(
        S, P, E, RW, RM, phi0, had_ttrtp, t0, nev0
    )
    # The contest's 600 s belong to this task (the time is observed): running out of time
    # ends it, a terminal state with the potential it has. Declared a truncation instead,
    # learners bootstrap from the value of a rover caught mid-flight by the clock, a state
    # no decision is ever taken in, and PPO learned to launch long hops that end there.
    if truncated:
        terminated = True
        truncated = False
    return r, terminated, truncated, success, n_events


TASK = TaskSpec(
    name="hop",
    config=HopEnvConfig,
    step=step,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
    action_torque=hop_torque,
    compile_extra=torque.TASK.compile_extra,
)
# configs/ppo_hop.yaml's settings as defaults (tasks/config.py RL_SETTINGS says why ids
# carry them): a time cost of 0.01 per second makes one long hop beat a safe series of
# short ones; the discount is per hop.
HOP_RL_SETTINGS = {"gamma": 0.98, "time_cost": 0.01}
REGISTER = (
    Registration("HopRoverHop-v0", suite="level", hops=True),
    Registration("HopRoverHopRL-v0", HOP_RL_SETTINGS, suite="level", hops=True),
)
