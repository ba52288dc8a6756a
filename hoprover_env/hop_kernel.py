"""The hop-level step, jitted: one action is one hop, flown by a built-in controller.

`hop_step` maps the action to a signed launch torque, then runs the rover on the
control grid (`E_CONTROL_DT`) with the controller a contest entry would use: hold the
launch torque until lift-off, a PD attitude hold in the air (so the rover lands on its
bottom face), zero torque on the ground while it bounces, slides and stops. The step
returns when the rover is at rest again outside the band, when the judge's TTRTP is
reached (a rover at rest in the band is left there until the judge's 5 s are up), when
it breaks, or at the end of the episode.

Reward and observation are the torque-level env's (`rl_kernel.finish_step`), with the
time cost charged for the simulated seconds the hop took. `batch_hop_step` and
`batch_hop_step_threaded` have the signatures of `rl_kernel.batch_step(_threaded)`, so
the vector env runs either kernel unchanged.
"""
import math

from numba import get_thread_id, njit, prange

from ._jitcache import drop_stale_cache

drop_stale_cache(__file__)      # this module's cached code embeds the core's

from . import core, rl_kernel  # noqa: E402
from .core import JIT, INNER  # noqa: E402
from .core import S_TH, S_W, S_T, S_MODE, S_TTRTP, S_BROKEN, S_ERROR, S_NEVENTS, S_INBAND, \
    MODE_A, MODE_F  # noqa: E402
from .params import P_M, P_I, P_R, P_G, P_TMIN, P_TMAX  # noqa: E402
from .rl_kernel import E_CONTROL_DT, E_T_TOTAL, E_HOLD_KP, E_HOLD_KD, E_LAUNCH_MAX, \
    E_LAUNCH_MIN  # noqa: E402

# A hop that never ends (it cannot: every state decays to rest or flies ballistically)
# would still stop here, in the kernel's error state, which ends the episode.
MAX_SUBSTEPS = 1_000_000


@njit(**JIT)
def hop_torque(a, P, E):
    """Signed launch torque of a hop action.

    |a| maps log-uniformly onto [launch_min * m g r, min |T_limit|]: the hop length grows
    roughly geometrically with the torque, so equal steps of the action are about equal
    relative changes of the hop. a = 0 is the weakest hop towards +x.
    """
    a = rl_kernel._clip(a, -1.0, 1.0)
    lo = E[E_LAUNCH_MIN] * P[P_M] * P[P_G] * P[P_R]
    hi = min(abs(P[P_TMIN]), P[P_TMAX])
    if hi <= lo:
        mag = hi
    else:
        mag = lo * math.exp(abs(a) * math.log(hi / lo))
    return -mag if a < 0.0 else mag


@njit(**JIT)
def attitude_hold(S, P, E):
    """PD hold of theta -> 0 (wrapped to (-pi, pi]) and omega -> 0, clipped."""
    th = (S[S_TH] + math.pi) % (2.0 * math.pi) - math.pi
    t = -P[P_I] * (E[E_HOLD_KP] * th + E[E_HOLD_KD] * S[S_W])
    return rl_kernel._clip(t, P[P_TMIN], P[P_TMAX])


@njit(**INNER)
def _ended(S, had_ttrtp):
    return ((not had_ttrtp) and not math.isnan(S[S_TTRTP])) or S[S_BROKEN] != 0.0 \
        or S[S_ERROR] != 0.0


@njit(**JIT)
def hop_step(S, P, O, E, action, obs, ev, W):
    """One hop (or, at rest in the band, the wait for the judge). Returns (reward,
    terminated, truncated, success, n_events)."""
    phi0 = rl_kernel.start_potential(S, P, E)
    had_ttrtp = not math.isnan(S[S_TTRTP])
    t0 = S[S_T]
    t_end = E[E_T_TOTAL]
    dt = E[E_CONTROL_DT]
    nev0 = S[S_NEVENTS]
    torque = hop_torque(action, P, E)
    # at rest in the band the judge's clock runs: the step waits it out, whatever the action
    flown = int(S[S_MODE]) == MODE_F and S[S_INBAND] == 1.0
    k = 0
    while S[S_T] < t_end and not _ended(S, had_ttrtp):
        mode = int(S[S_MODE])
        if mode == MODE_A:
            flown = True
            cmd = attitude_hold(S, P, E)
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
        core.advance(S, P, O, cmd, min(t0 + k * dt, t_end), ev, W)
        if k >= MAX_SUBSTEPS:
            S[S_ERROR] = core.ERR_STEP
            break
    reward, terminated, truncated, success = rl_kernel.finish_step(
        S, P, E, phi0, had_ttrtp, S[S_T] - t0, obs)
    # The contest's 600 s belong to this task (the time is observed): running out of time
    # ends it, a terminal state with the potential it has. Declared a truncation instead,
    # learners bootstrap from the value of a rover caught mid-flight by the clock, a state
    # no decision is ever taken in, and PPO learned to launch long hops that end there.
    if truncated:
        terminated = True
        truncated = False
    return reward, terminated, truncated, success, int(S[S_NEVENTS] - nev0)


@njit(**JIT)
def batch_hop_step(S, P, O, E, actions, active, obs, rew, term, trunc, succ, nev, ev, W):
    """hop_step over the rows where `active` is set. Returns the index of a non-finite
    action (nothing stepped) or -1."""
    bad = rl_kernel.first_bad_action(actions, active)
    if bad >= 0:
        return bad
    w = W[0]
    for i in range(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = hop_step(
                S[i], P[i], O, E, actions[i], obs[i], ev, w)
    return -1


@njit(parallel=True, **JIT)
def batch_hop_step_threaded(S, P, O, E, actions, active, obs, rew, term, trunc, succ, nev,
                            ev, W):
    """hop_step over the active rows, spread over numba's threads."""
    bad = rl_kernel.first_bad_action(actions, active)
    if bad >= 0:
        return bad
    for i in prange(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = hop_step(
                S[i], P[i], O, E, actions[i], obs[i], ev, W[get_thread_id()])
    return -1


core.guard_jit_only(globals())
