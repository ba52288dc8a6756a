"""The reinforcement-learning step, jitted: one function for one env, looped for many.

`env_step` advances one rover by one control period with the torque an action maps to,
then writes the reward and the observation. `batch_step` (serial) and
`batch_step_threaded` (numba prange over the cores) loop it over the rows of 2-D state
and parameter arrays: the single env, the Gymnasium vector env and the SB3 adapter all
run this same code, so their numbers agree bit for bit. They integrate with the event
integrator only (`core.advance_event`), so that the default env compiles no Euler code;
the `*_any_integrator` twins call `core.advance` and serve envs made with
integrator="euler".

Config vector ``E`` (layout ``E_*``): control period, episode length, reward weights.
"""
import math

import numpy as np
from numba import get_thread_id, njit, prange, types as nt

from ._jitcache import drop_stale_cache

drop_stale_cache(__file__)      # this module's cached code embeds the core's

from . import core  # noqa: E402
from .core import JIT, INNER, njit_declared  # noqa: E402
from .core._jit import _B, _F, _V, _V32  # noqa: E402
from .core import (S_X, S_Y, S_TH, S_VX, S_VY, S_W, S_T, S_MODE, S_TORQUE, S_XT, S_BROKEN,
                   S_INBAND, S_TIN, S_TTRTP, S_NEVENTS, S_ERROR, MODE_A, MODE_F, MODE_G,
                   MODE_B, MODE_C)
from .params import P_H, P_R, P_G, P_TMIN, P_TMAX, P_BAND, P_DWELL

E_CONTROL_DT, E_T_TOTAL, E_W_DIST, E_W_TIME, E_SUCCESS, E_BREAK, E_GAMMA, E_SHAPING, \
    E_W_ATT, E_W_BAND, E_DIST_CAP, E_ACTION_MAP, E_ACTION_SCALE, \
    E_HOLD_KP, E_HOLD_KD, E_LAUNCH_MAX, E_LAUNCH_MIN = range(17)
N_ECONFIG = 17
SHAPING_CONTACT, SHAPING_LANDING = 0, 1
ACTION_LINEAR, ACTION_CUBIC = 0, 1
# The spin term of a(s) is U_Q ln(1 + min(u, U_MAX) / U_Q), u = (omega / 0.3)^2 / 2: the
# quadratic cost u up to spins of about 2 rad/s (u = U_Q is 3 rad/s), logarithmic beyond,
# constant past U_MAX (30 rad/s). A pull that weakens early lets PPO settle for spinning
# flights: with ln(1 + u) (twenty times weaker at 3 rad/s) it spun the rover at 1-4 rad/s
# for whole episodes; with a term saturating at 1.3 rad/s, at 30 rad/s.
U_Q = 50.0
U_MAX = 5000.0
ATT_MAX = 2.0 + U_Q * math.log1p(U_MAX / U_Q)   # bound of a(s): (1 - cos theta) <= 2

# Compiled by the parallel-compile helper on a cold cache, beside the core's contact
# phases (hoprover_env/_parallel_compile.py): the reward and observation code.
HELPER_EXTRA = tuple(f"hoprover_env.rl_kernel:{name}" for name in
                     ("finish_step", "start_potential", "action_to_torque"))

# Observation layout and scales (documented in env.py's table).
OBS_DIM = 19
POS_SCALE = 1.0        # m
HEIGHT_SCALE = 0.5     # m
VEL_SCALE = 0.01       # m/s
RATE_SCALE = 0.3       # rad/s
OBS_LOW = np.array([-5, -1, -10, -10, -1, -1, -10] + [0] * 7 + [0, 0, -20, -5, -1],
                   dtype=np.float32)
OBS_HIGH = np.array([5, 10, 10, 10, 1, 1, 10] + [1] * 7 + [1, 1, 20, 5, 1], dtype=np.float32)


@njit(**INNER)
def _clip(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)


@njit(**INNER)
def reference_point(S, P):
    """x of the contact point (the one nearer the target in F/G), or of the bottom corner
    nearest the target in flight: what the distance reward measures."""
    mode = int(S[S_MODE])
    xt = S[S_XT]
    if mode == MODE_F or mode == MODE_G:
        xa = S[S_X] + P[P_R]
        xb = S[S_X] - P[P_R]
        return xa if abs(xa - xt) <= abs(xb - xt) else xb
    c = math.cos(S[S_TH])
    sn = math.sin(S[S_TH])
    dxa, _ = core.corner_offset_cs(P, 0, c, sn)
    dxb, _ = core.corner_offset_cs(P, 1, c, sn)
    if mode == MODE_B or mode == MODE_C:
        return S[S_X] + dxa
    if mode != MODE_A:
        return S[S_X] + dxb
    xa = S[S_X] + dxa
    xb = S[S_X] + dxb
    return xa if abs(xa - xt) <= abs(xb - xt) else xb


@njit(**INNER)
def landing_x(S, P):
    """Where the c.m. will come down to rest height in a ballistic flight (the current x
    when not flying): a closed form any contest controller could compute."""
    if int(S[S_MODE]) != MODE_A:
        return S[S_X]
    g = P[P_G]
    vy = S[S_VY]
    drop = max(S[S_Y] - P[P_H], 0.0)
    t_fall = (vy + math.sqrt(vy * vy + 2.0 * g * drop)) / g
    return S[S_X] + S[S_VX] * t_fall


@njit_declared(_F(_V, _V, _V), **JIT)
def potential(S, P, E):
    """Phi(s) = -w_dist min(|x_ref - x_T|, cap) / 1 m - w_att a(s) - w_band (1 - d(s)).

    x_ref is the contact point (or nearest bottom corner in flight), or with
    E_SHAPING = landing the ballistic landing point in flight (constant along a flight,
    so a hop is credited at its launch). a(s) = (1 - cos theta) + U_Q ln(1 + min(u, U_MAX)
    / U_Q) with u = (omega / 0.3)^2 / 2, in flight only: the quadratic attitude cost up
    to spins of about 2 rad/s, a pull back at any faster spin, and bounded (<= ATT_MAX),
    so no spin can make Phi arbitrarily low and then release it at termination. d(s) is
    the judge's dwell fraction (time in the band / 5 s, 0 out of it): settling in the band
    pays before the success bonus, hovering next to it does not. Every term is bounded, so Phi >= phi_min(E).
    """
    flying = int(S[S_MODE]) == MODE_A
    if int(E[E_SHAPING]) == SHAPING_LANDING and flying:
        x = landing_x(S, P)
    else:
        x = reference_point(S, P)
    phi = -E[E_W_DIST] * min(abs(x - S[S_XT]), E[E_DIST_CAP]) / POS_SCALE
    if flying:
        w = S[S_W] / RATE_SCALE
        u = 0.5 * w * w
        spin = U_Q * math.log1p(min(u, U_MAX) / U_Q)
        phi -= E[E_W_ATT] * ((1.0 - math.cos(S[S_TH])) + spin)
    if E[E_W_BAND] != 0.0:
        phi -= E[E_W_BAND] * (1.0 - dwell_fraction(S, P))
    return phi


@njit(**JIT)
def phi_min(E):
    """The lowest value the potential can take (every term is bounded)."""
    return -(E[E_W_DIST] * E[E_DIST_CAP] / POS_SCALE + E[E_W_ATT] * ATT_MAX + E[E_W_BAND])


@njit(**INNER)
def dwell_fraction(S, P):
    """The judge's clock: time in the band / dwell time, 0 out of the band."""
    if S[S_INBAND] == 1.0:
        return _clip((S[S_T] - S[S_TIN]) / P[P_DWELL], 0.0, 1.0)
    return 0.0


@njit_declared(nt.none(_V, _V, _V, _V32), **JIT)
def observe(S, P, E, obs):
    """Write the float32 observation (see the table in env.py)."""
    xt = S[S_XT]
    obs[0] = _clip((S[S_X] - xt) / POS_SCALE, -5.0, 5.0)
    obs[1] = _clip((S[S_Y] - P[P_H]) / HEIGHT_SCALE, -1.0, 10.0)
    obs[2] = _clip(S[S_VX] / VEL_SCALE, -10.0, 10.0)
    obs[3] = _clip(S[S_VY] / VEL_SCALE, -10.0, 10.0)
    obs[4] = math.sin(S[S_TH])
    obs[5] = math.cos(S[S_TH])
    obs[6] = _clip(S[S_W] / RATE_SCALE, -10.0, 10.0)
    mode = int(S[S_MODE])
    for i in range(7):
        obs[7 + i] = 1.0 if i == mode else 0.0
    obs[14] = _clip(S[S_T] / E[E_T_TOTAL], 0.0, 1.0)
    obs[15] = dwell_fraction(S, P)
    obs[16] = _clip((reference_point(S, P) - xt) / P[P_BAND], -20.0, 20.0)
    obs[17] = _clip((landing_x(S, P) - xt) / POS_SCALE, -5.0, 5.0)
    obs[18] = S[S_TORQUE] / max(abs(P[P_TMIN]), abs(P[P_TMAX]), 1e-300)


@njit_declared(_F(_F, _V, _V), **JIT)
def action_to_torque(a, P, E):
    """Box(-1, 1) onto the torque range; out-of-range actions are clipped.

    linear (the contest's task): [-1, 1] -> [T_min, T_max]. cubic: T = a^3 T_max for
    a >= 0 and |a|^3 T_min below, so zero torque sits at a = 0 and the fine torques that
    tip the rover (about 1 % of T_max) are 0.2 of the action range instead of 0.01.
    Either is then scaled by action_scale (the fraction of the range reached at |a| = 1).
    """
    a = _clip(a, -1.0, 1.0)
    if int(E[E_ACTION_MAP]) == ACTION_CUBIC:
        c = a * a * a
        t = c * P[P_TMAX] if c >= 0.0 else -c * P[P_TMIN]
    else:
        t = P[P_TMIN] + 0.5 * (a + 1.0) * (P[P_TMAX] - P[P_TMIN])
    return E[E_ACTION_SCALE] * t


@njit_declared(nt.Tuple((_F, _B, _B, _B))(_V, _V, _V, _F, _B, _F, _V32), **INNER)
def finish_step(S, P, E, phi0, had_ttrtp, elapsed, obs):
    """Reward, termination and observation after the rover moved for `elapsed` seconds
    from a state of potential phi0. Returns (reward, terminated, truncated, success).

    Termination values of Phi: 0 on success (the top of Phi), phi0 / gamma when the rover
    breaks, so that the shaping term of a breaking step is exactly 0: breaking cannot
    release a potential (setting Phi = 0 there paid up to +142 for spinning into the
    ground), its reward is -break_penalty - time cost < 0, and an episode that breaks
    keeps every potential it lost on the way down. (Phi = phi_min there instead made a
    landing so costly that PPO from scratch learned to launch and never come down.)
    """
    success = (not had_ttrtp) and not math.isnan(S[S_TTRTP])
    broken = S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0
    terminated = success or broken
    truncated = (not terminated) and S[S_T] >= E[E_T_TOTAL]
    if broken:
        phi1 = phi0 / E[E_GAMMA]
    elif success:
        phi1 = 0.0
    else:
        phi1 = potential(S, P, E)
    S[core.S_PHI] = phi1
    reward = E[E_GAMMA] * phi1 - phi0 - E[E_W_TIME] * elapsed
    if success:
        reward += E[E_SUCCESS]
    if broken:
        reward -= E[E_BREAK]
    observe(S, P, E, obs)
    return reward, terminated, truncated, success


@njit_declared(_F(_V, _V, _V), **INNER)
def start_potential(S, P, E):
    phi0 = S[core.S_PHI]
    if math.isnan(phi0):                  # first step of an episode
        phi0 = potential(S, P, E)
    return phi0


@njit(**JIT)
def env_step(S, P, O, E, action, obs, ev, W):
    """One control period with the event integrator. Returns (reward, terminated,
    truncated, success, n_events)."""
    phi0 = start_potential(S, P, E)
    had_ttrtp = not math.isnan(S[S_TTRTP])
    t0 = S[S_T]
    nev0 = S[S_NEVENTS]
    core.advance_event(S, P, O, action_to_torque(action, P, E),
                       min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]), ev, W)
    reward, terminated, truncated, success = finish_step(S, P, E, phi0, had_ttrtp,
                                                         S[S_T] - t0, obs)
    return reward, terminated, truncated, success, int(S[S_NEVENTS] - nev0)


@njit(**JIT)
def env_step_any_integrator(S, P, O, E, action, obs, ev, W):
    """env_step with the integrator O names (Euler included). A separate function so
    that the event-only kernels, which every default env uses, compile no Euler code."""
    phi0 = start_potential(S, P, E)
    had_ttrtp = not math.isnan(S[S_TTRTP])
    t0 = S[S_T]
    nev0 = S[S_NEVENTS]
    core.advance(S, P, O, action_to_torque(action, P, E),
                 min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]), ev, W)
    reward, terminated, truncated, success = finish_step(S, P, E, phi0, had_ttrtp,
                                                         S[S_T] - t0, obs)
    return reward, terminated, truncated, success, int(S[S_NEVENTS] - nev0)


@njit(**INNER)
def first_bad_action(actions, active):
    """Index of the first active non-finite action, or -1: checked before any rover moves."""
    for i in range(actions.shape[0]):
        if active[i] and not math.isfinite(actions[i]):
            return i
    return -1


@njit(**JIT)
def batch_step(S, P, O, E, actions, active, obs, rew, term, trunc, succ, nev, ev, W):
    """env_step over the rows where `active` is set, one after the other. Returns the
    index of a non-finite action (nothing stepped) or -1."""
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    w = W[0]
    for i in range(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = env_step(
                S[i], P[i], O, E, actions[i], obs[i], ev, w)
    return -1


@njit(parallel=True, **JIT)
def batch_step_threaded(S, P, O, E, actions, active, obs, rew, term, trunc, succ, nev, ev, W):
    """env_step over the rows where `active` is set, spread over numba's threads; each
    thread uses its own workspace row W[thread id]. Returns as batch_step."""
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    for i in prange(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = env_step(
                S[i], P[i], O, E, actions[i], obs[i], ev, W[get_thread_id()])
    return -1


# The same two loops over env_step_any_integrator, for envs made with integrator="euler".
@njit(**JIT)
def batch_step_any_integrator(S, P, O, E, actions, active, obs, rew, term, trunc, succ,
                              nev, ev, W):
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    w = W[0]
    for i in range(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = env_step_any_integrator(
                S[i], P[i], O, E, actions[i], obs[i], ev, w)
    return -1


@njit(parallel=True, **JIT)
def batch_step_threaded_any_integrator(S, P, O, E, actions, active, obs, rew, term, trunc,
                                       succ, nev, ev, W):
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    for i in prange(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = env_step_any_integrator(
                S[i], P[i], O, E, actions[i], obs[i], ev, W[get_thread_id()])
    return -1


core.guard_jit_only(globals())
