"""The torque task (HopRover-v0, HopRoverContest-v0): one action is the torque held for
one control period, as in the contest.

`action_to_torque` maps the action; the step advances the rover by one control period
and ends as every task does (tasks/common.py `close_step`). `TASK` is its written
interface (tasks/common.py `TaskSpec`); the step's actuator is a placeholder,
``ACTUATE``, that a task built on this step may bind to its own (the mission task's
carries a per-episode scale error).
"""
import math

from hoprover_env.jit.compiler import kernel, F64, VEC
from hoprover_env.core.layout import S_T
from hoprover_env.tasks.config import EnvConfig
from hoprover_env.core.params import P_TMAX, P_TMIN
from hoprover_env.tasks import reward
from hoprover_env.tasks.common import ADVANCE, TaskSpec, close_step, open_step
from hoprover_env.tasks.layout import ACTION_CUBIC, E_ACTION_MAP, E_ACTION_SCALE, E_CONTROL_DT, E_T_TOTAL
from hoprover_env.tasks.observation import OBS_HIGH, OBS_LOW, clip, observe


@kernel(F64(F64, VEC, VEC))
def action_to_torque(a, P, E):
    """Box(-1, 1) onto the torque range [N m]; out-of-range actions are clipped.

    linear (the contest's task): [-1, 1] -> [T_min, T_max]. cubic: T = a^3 T_max for
    a >= 0 and |a|^3 T_min below, so zero torque sits at a = 0 and the fine torques that
    tip the rover (about 1 % of T_max) are 0.2 of the action range instead of 0.01.
    Either is then scaled by action_scale (the fraction of the range reached at |a| = 1).
    """
    a = clip(a, -1.0, 1.0)
    if int(E[E_ACTION_MAP]) == ACTION_CUBIC:
        c = a * a * a
        t = c * P[P_TMAX] if c >= 0.0 else -c * P[P_TMIN]
    else:
        t = P[P_TMIN] + 0.5 * (a + 1.0) * (P[P_TMAX] - P[P_TMIN])
    return E[E_ACTION_SCALE] * t


def step(S, P, O, E, RW, RM, M, action, ev, W):
    """One control period with the torque `action` maps to. Returns (reward, terminated,
    truncated, success, n_events)."""
    phi0, had_ttrtp, t0, nev0 = open_step(S, P, RW, RM)
    torque = ACTUATE(action, P, E, M)
    ADVANCE(S, P, O, torque, min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]), ev, W)
    reward.charge(P, RM, torque, S[S_T] - t0)
    return close_step(S, P, E, RW, RM, phi0, had_ttrtp, t0, nev0)


def ACTUATE(action, P, E, M):
    """Placeholder in `step`: the torque [N m] an action row commands, bound per task
    (TaskSpec.holes)."""
    raise NotImplementedError("ACTUATE is bound by tasks.common.build")


@kernel(inner=True)
def commanded_torque(action, P, E, M):
    """The torque task's actuator: exactly the torque `action_to_torque` maps to."""
    return action_to_torque(action[0], P, E)


TASK = TaskSpec(
    name="torque", config=EnvConfig, step=step, observe=observe, obs_low=OBS_LOW,
    obs_high=OBS_HIGH, holes={"ACTUATE": commanded_torque},
    compile_extra=tuple(f"{module}:{name}" for module, name in (
        ("hoprover_env.tasks.common", "open_step"), ("hoprover_env.tasks.common", "close_step"),
        ("hoprover_env.tasks.torque", "action_to_torque"),
        ("hoprover_env.tasks.observation", "observe"))))
