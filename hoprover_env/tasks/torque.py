"""The torque task (HopRover-v0, HopRoverContest-v0): one action is the torque held for
one control period, as in the contest.

`action_to_torque` maps the action; the step advances the rover by one control period
and ends as every task does (tasks/common.py `finish`). KERNELS[integrator] holds the
step and the batched loops over it.
"""
import math

from .._compile import kernel, F64, VEC
from ..core.layout import S_NEVENTS, S_T, S_TTRTP
from ..params import P_TMAX, P_TMIN
from .. import reward
from .common import build, finish
from .layout import ACTION_CUBIC, E_ACTION_MAP, E_ACTION_SCALE, E_CONTROL_DT, E_T_TOTAL
from .observation import OBS_HIGH, OBS_LOW, clip, observe


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


def step(S, P, O, E, RW, RM, action, obs, ev, W):
    """One control period with the torque `action` maps to. Returns (reward, terminated,
    truncated, success, n_events)."""
    phi0 = reward.begin(S, P, RW, RM)
    had_ttrtp = not math.isnan(S[S_TTRTP])
    t0 = S[S_T]
    nev0 = S[S_NEVENTS]
    torque = action_to_torque(action, P, E)
    ADVANCE(S, P, O, torque, min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]),  # noqa: F821 (build)
            ev, W)
    reward.charge(P, RM, torque, S[S_T] - t0)
    r, terminated, truncated, success = finish(S, P, E, RW, RM, phi0, had_ttrtp,
                                               S[S_T] - t0)
    OBSERVE(S, P, E, obs)  # noqa: F821 (bound by build)
    return r, terminated, truncated, success, int(S[S_NEVENTS] - nev0)


KERNELS = build("torque", step)
# Compiled by the parallel-compile helper on a cold cache (hoprover_env/_compile.py).
HELPER_EXTRA = tuple(f"{module}:{name}" for module, name in (
    ("hoprover_env.tasks.common", "finish"), ("hoprover_env.reward", "begin"),
    ("hoprover_env.tasks.torque", "action_to_torque"),
    ("hoprover_env.tasks.observation", "observe")))
# what an env reads of a task: its kernels, its observation and the observation's bounds
__all__ = ["KERNELS", "observe", "OBS_LOW", "OBS_HIGH", "action_to_torque", "step"]
