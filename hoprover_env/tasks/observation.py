"""What a policy sees: the observation vector, one named slot each, and the two
measurements the observation and the reward share (the reference point and the
ballistic landing point).

Table of slots and scales: hoprover_env/envs/env.py. Every value is clipped to the
observation space's bounds (OBS_LOW, OBS_HIGH).
"""

import math

import numpy as np

from hoprover_env.core import corner_offset_cs
from hoprover_env.core.layout import (
    MODE_A,
    MODE_B,
    MODE_C,
    MODE_D,
    MODE_E,
    MODE_F,
    MODE_G,
    S_INBAND,
    S_MODE,
    S_T,
    S_TH,
    S_TIN,
    S_TORQUE,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_XT,
    S_Y,
)
from hoprover_env.core.params import P_BAND, P_DWELL, P_GC, P_GS, P_H, P_R, P_TMAX, P_TMIN
from hoprover_env.jit.compiler import NONE, VEC, VEC32, kernel
from hoprover_env.tasks.layout import E_T_TOTAL

OBS_DX = 0  # (x - x_T) / POS_SCALE
OBS_HEIGHT = 1  # (y - h) / HEIGHT_SCALE
OBS_VX = 2  # vx / VEL_SCALE
OBS_VY = 3  # vy / VEL_SCALE
OBS_SIN = 4  # sin theta
OBS_COS = 5  # cos theta
OBS_RATE = 6  # omega / RATE_SCALE
OBS_MODE = 7  # 7..13: one-hot contact state A..G
OBS_TIME = 14  # t / episode length
OBS_DWELL = 15  # the judge's clock: time in the band / 5 s
OBS_REF = 16  # (reference point - x_T) / band half-width
OBS_LANDING = 17  # (ballistic landing x - x_T) / POS_SCALE
OBS_TORQUE = 18  # applied torque / max |T|
OBS_DIM = 19

POS_SCALE = 1.0  # m
HEIGHT_SCALE = 0.5  # m
VEL_SCALE = 0.01  # m/s
RATE_SCALE = 0.3  # rad/s
OBS_LOW = np.array(
    [-5, -1, -10, -10, -1, -1, -10] + [0] * 7 + [0, 0, -20, -5, -1], dtype=np.float32
)
OBS_HIGH = np.array([5, 10, 10, 10, 1, 1, 10] + [1] * 7 + [1, 1, 20, 5, 1], dtype=np.float32)

# The mirror x -> -x of level ground: these slots change sign, and corners A and B swap
# (state B, pivoting on A, <-> D, pivoting on B; C <-> E sliding), so the one-hot slots
# of B..E are permuted. The bounds above are symmetric in every slot that changes sign.
MIRROR_SIGN = np.ones(OBS_DIM, dtype=np.float32)
MIRROR_SIGN[[OBS_DX, OBS_VX, OBS_SIN, OBS_RATE, OBS_REF, OBS_LANDING, OBS_TORQUE]] = -1.0
MIRROR_ORDER = np.arange(OBS_DIM)
MIRROR_ORDER[OBS_MODE + MODE_B : OBS_MODE + MODE_E + 1] = OBS_MODE + np.array(
    [MODE_D, MODE_E, MODE_B, MODE_C]
)


def mirror(obs):
    """Observations (N, OBS_DIM; numpy or torch) of the mirror image of each rover and
    its target on level ground, where the mirror image of a good action is its negative
    (research.plan_clone.gated's symmetric networks act as odd functions of this map)."""
    if isinstance(obs, np.ndarray):
        return obs[:, MIRROR_ORDER] * MIRROR_SIGN.astype(obs.dtype)
    import torch

    sign = torch.as_tensor(MIRROR_SIGN, dtype=obs.dtype, device=obs.device)
    return obs[:, torch.as_tensor(MIRROR_ORDER)] * sign


@kernel(inner=True)
def clip(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)


@kernel(inner=True)
def reference_point(S, P):
    """x of the contact point (the one nearer the target in F/G), or of the bottom corner
    nearest the target in flight: what the distance reward measures [m]."""
    mode = int(S[S_MODE])
    xt = S[S_XT]
    if mode == MODE_F or mode == MODE_G:
        xa = S[S_X] + P[P_R]
        xb = S[S_X] - P[P_R]
        return xa if abs(xa - xt) <= abs(xb - xt) else xb
    c = math.cos(S[S_TH])
    sn = math.sin(S[S_TH])
    dxa, _ = corner_offset_cs(P, 0, c, sn)
    dxb, _ = corner_offset_cs(P, 1, c, sn)
    if mode == MODE_B or mode == MODE_C:
        return S[S_X] + dxa
    if mode != MODE_A:
        return S[S_X] + dxb
    xa = S[S_X] + dxa
    xb = S[S_X] + dxb
    return xa if abs(xa - xt) <= abs(xb - xt) else xb


@kernel(inner=True)
def landing_x(S, P):
    """Where the c.m. will come down to rest height in a ballistic flight (the current x
    when not flying) [m], along the ground: a closed form any contest controller could
    compute. On a slope gravity has the components (-g sin phi, -g cos phi) in the ground
    frame (on level ground P_GS is +0.0 and P_GC is g: the flat arithmetic, unchanged)."""
    if int(S[S_MODE]) != MODE_A:
        return S[S_X]
    gc = P[P_GC]
    vy = S[S_VY]
    drop = max(S[S_Y] - P[P_H], 0.0)
    t_fall = (vy + math.sqrt(vy * vy + 2.0 * gc * drop)) / gc
    return S[S_X] + S[S_VX] * t_fall - 0.5 * P[P_GS] * t_fall * t_fall


@kernel(inner=True)
def dwell_fraction(S, P):
    """The judge's clock: time in the band / dwell time, 0 out of the band."""
    if S[S_INBAND] == 1.0:
        return clip((S[S_T] - S[S_TIN]) / P[P_DWELL], 0.0, 1.0)
    return 0.0


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """Write the float32 observation of state S into `obs` (slots OBS_*); the task
    memory M is unused (the true state is observed)."""
    xt = S[S_XT]
    obs[OBS_DX] = clip((S[S_X] - xt) / POS_SCALE, -5.0, 5.0)
    obs[OBS_HEIGHT] = clip((S[S_Y] - P[P_H]) / HEIGHT_SCALE, -1.0, 10.0)
    obs[OBS_VX] = clip(S[S_VX] / VEL_SCALE, -10.0, 10.0)
    obs[OBS_VY] = clip(S[S_VY] / VEL_SCALE, -10.0, 10.0)
    obs[OBS_SIN] = math.sin(S[S_TH])
    obs[OBS_COS] = math.cos(S[S_TH])
    obs[OBS_RATE] = clip(S[S_W] / RATE_SCALE, -10.0, 10.0)
    mode = int(S[S_MODE])
    for i in range(7):
        obs[OBS_MODE + i] = 1.0 if i == mode else 0.0
    obs[OBS_TIME] = clip(S[S_T] / E[E_T_TOTAL], 0.0, 1.0)
    obs[OBS_DWELL] = dwell_fraction(S, P)
    obs[OBS_REF] = clip((reference_point(S, P) - xt) / P[P_BAND], -20.0, 20.0)
    obs[OBS_LANDING] = clip((landing_x(S, P) - xt) / POS_SCALE, -5.0, 5.0)
    obs[OBS_TORQUE] = S[S_TORQUE] / max(abs(P[P_TMIN]), abs(P[P_TMAX]), 1e-300)
