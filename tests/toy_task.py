"""HopRoverTip: tip the rover onto a corner and hold it there (a toy task).

The worked example of docs/ARCHITECTURE.md, "Adding a task": one module, made by its
recipe and touching no other file. It registers itself when imported (its last line,
``register_task(__name__)``), so that ``gym.make("toy_task:HopRoverTip-v0")`` works with
the module on sys.path; inside the package, the module would sit in
hoprover_env/tasks/ with one line added to ``hoprover_env.tasks.TASK_MODULES`` instead.

## Description

The contest's rover, upright at rest. The agent holds a torque each control period; it
is paid for keeping the attitude near `tip_angle` (a pivot on a bottom corner), so it
must tip the rover and balance it without a hop.

## Action space

`Box(-1, 1, (1,), float32)`: the torque task's map (`torque.action_to_torque`).

## Observation space

`Box(-1, 1, (4,), float32)`: sin theta, cos theta, omega / 0.3 rad/s (clipped), the
time as a fraction of the episode.

## Rewards

-|theta - tip_angle| [rad] times the seconds of the step.

## Starting state, episode end

Upright at rest at x = 0. Terminated when a top corner touches the ground (broken);
truncated after `episode_time`.

## Arguments

Those of HopRover-v0 except `action_map` and `action_scale` (refused), and:

| Argument | Default | Description |
|---|---|---|
| `tip_angle` | 0.2 | the attitude to hold [rad] |

## The step, in the kernel

`step` calls `torque.action_to_torque`, `ADVANCE` (bound by `common.build` to the
integrator) and nothing else; its observe is `observe` below.
"""

import dataclasses
import math
from typing import ClassVar

import numpy as np

from hoprover_env import register_task
from hoprover_env.core.layout import S_BROKEN, S_ERROR, S_NEVENTS, S_T, S_TH, S_W
from hoprover_env.jit.compiler import NONE, VEC, VEC32, kernel
from hoprover_env.tasks import Registration, torque
from hoprover_env.tasks.common import ADVANCE, TaskSpec
from hoprover_env.tasks.config import EnvConfig
from hoprover_env.tasks.layout import E_CONTROL_DT, E_T_TOTAL, task_slots
from hoprover_env.tasks.observation import clip


@dataclasses.dataclass(frozen=True)
class TipEnvConfig(EnvConfig):
    """HopRover-v0's arguments plus `tip_angle`."""

    unused: ClassVar[dict] = {
        "action_map": "the toy task keeps the linear map",
        "action_scale": "the toy task keeps the full range",
    }
    kernel_fields: ClassVar[tuple[str, ...]] = ("tip_angle",)  # its own slot of E
    reward_options: ClassVar[tuple[str, ...]] = ()  # its step pays its own reward
    tip_angle: float = 0.2  # the attitude to hold [rad]

    def __post_init__(self):
        super().__post_init__()
        if not (isinstance(self.tip_angle, (int, float)) and 0.0 < self.tip_angle < 1.0):
            raise ValueError(f"tip_angle must lie in (0, 1) rad, got {self.tip_angle!r}")


E_TIP = task_slots(TipEnvConfig).tip_angle  # its slot of E, for the kernel


def step(S, P, O, E, RW, RM, M, action, ev, W):
    """One control period of the torque `action` maps to; pays for the attitude error."""
    t0, nev0 = S[S_T], S[S_NEVENTS]
    torque_nm = torque.action_to_torque(action[0], P, E)
    ADVANCE(S, P, O, torque_nm, min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]), ev, W)
    reward = -abs(S[S_TH] - E[E_TIP]) * (S[S_T] - t0)
    broken = S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0
    truncated = (not broken) and S[S_T] >= E[E_T_TOTAL]
    return reward, broken, truncated, False, int(S[S_NEVENTS] - nev0)


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """sin and cos of the attitude, the rate, the time."""
    obs[0] = math.sin(S[S_TH])
    obs[1] = math.cos(S[S_TH])
    obs[2] = clip(S[S_W] / 0.3, -1.0, 1.0)
    obs[3] = clip(S[S_T] / E[E_T_TOTAL], 0.0, 1.0)


OBS_LOW = np.full(4, -1.0, dtype=np.float32)
OBS_HIGH = np.full(4, 1.0, dtype=np.float32)
TASK = TaskSpec(
    name="toy_tip",
    config=TipEnvConfig,
    step=step,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
)
REGISTER = (Registration("HopRoverTip-v0", {"episode_time": 120.0}),)  # no suite

register_task(__name__)
