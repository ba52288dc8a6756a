"""The hop-level task (HopRoverHop-v0): one action is one hop, flown by a built-in
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
"""
import math

from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold
from hoprover_env.core.layout import ERR_STEP, MODE_A, MODE_F, S_ERROR, S_INBAND, S_MODE, S_T, S_TH, S_W
from hoprover_env.tasks.config import HopEnvConfig
from hoprover_env.core.params import P_G, P_I, P_M, P_R, P_TMAX, P_TMIN
from hoprover_env.tasks import reward
from hoprover_env.tasks import torque
from hoprover_env.tasks.common import ADVANCE, TaskSpec, close_step, episode_ended, open_step
from hoprover_env.tasks.layout import (E_CONTROL_DT, E_HOLD_KD, E_HOLD_KP, E_LAUNCH_MAX, E_LAUNCH_MIN,
                     E_T_TOTAL)
from hoprover_env.tasks.observation import OBS_HIGH, OBS_LOW, clip, observe

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
            cmd = clip(attitude_hold(S[S_TH], S[S_W], P[P_I], E[E_HOLD_KP], E[E_HOLD_KD]),
                       P[P_TMIN], P[P_TMAX])
        elif not flown:
            if S[S_T] - t0 >= E[E_LAUNCH_MAX]:
                flown = True               # it never lifted off: let it settle
                cmd = 0.0
            else:
                cmd = torque
        elif mode == MODE_F and S[S_INBAND] != 1.0:
            break                          # at rest outside the band: the next decision
        else:
            cmd = 0.0                      # bouncing, sliding, or resting in the band
        # the grid of control instants is t0 + k dt, as a contest controller's
        k += 1
        t_before = S[S_T]
        ADVANCE(S, P, O, cmd, min(t0 + k * dt, t_end), ev, W)
        reward.charge(P, RM, cmd, S[S_T] - t_before)
        if k >= MAX_SUBSTEPS:
            S[S_ERROR] = ERR_STEP
            break
    r, terminated, truncated, success, n_events = close_step(S, P, E, RW, RM, phi0,
                                                             had_ttrtp, t0, nev0)
    # The contest's 600 s belong to this task (the time is observed): running out of time
    # ends it, a terminal state with the potential it has. Declared a truncation instead,
    # learners bootstrap from the value of a rover caught mid-flight by the clock, a state
    # no decision is ever taken in, and PPO learned to launch long hops that end there.
    if truncated:
        terminated = True
        truncated = False
    return r, terminated, truncated, success, n_events


TASK = TaskSpec(name="hop", config=HopEnvConfig, step=step, observe=observe,
                obs_low=OBS_LOW, obs_high=OBS_HIGH,
                compile_extra=torque.TASK.compile_extra)
