"""Rough-terrain bounces: the tilt of each impact's surface normal, drawn from a
counter-based generator (docs/MODEL.md section 11, docs/PHYSICS.md "Terrain").

The generator is Philox4x64-10 (Salmon, Moraes, Dror, Shaw, "Parallel random numbers:
as easy as 1, 2, 3", SC 2011), the one numpy ships as `numpy.random.Philox`
(tests/core/test_terrain_rough.py checks this implementation against it bit for bit). Being
counter-based, a draw is a pure function of (key, counter): key = (seed, rover index),
counter = (impact count, attempt, 0, 0). No generator state is carried, so a run's
bumps do not depend on the threads, the batch it sits in, or what other runs do.
"""

import math

import numpy as np
from numba import types as nt

from hoprover_env.core.layout import S_NDRAW, S_NIMPACT, S_ROVER, S_SEED_HI, S_SEED_LO
from hoprover_env.core.params import P_ROUGH
from hoprover_env.jit.compiler import F64, VEC, kernel

_U = nt.uint64
_M0 = np.uint64(0xD2E7470EE14C6C93)  # Philox4x64 multipliers
_M1 = np.uint64(0xCA5A826395121157)
_W0 = np.uint64(0x9E3779B97F4A7C15)  # Weyl key increments
_W1 = np.uint64(0xBB67AE8584CAA73B)
_LO32 = np.uint64(0xFFFFFFFF)
_32 = np.uint64(32)
_11 = np.uint64(11)
_ONE = np.uint64(1)
_2M53 = 2.0**-53
TRUNCATION = 3.0  # tilts beyond 3 standard deviations are redrawn
MAX_ATTEMPTS = 64  # blocks of 4 candidates; P(all 256 rejected) = 0.0027^256


@kernel(nt.UniTuple(_U, 2)(_U, _U), inner=True)
def _mulhilo64(a, b):
    """High and low 64 bits of the 128-bit product a b, from 32-bit halves."""
    a0 = a & _LO32
    a1 = a >> _32
    b0 = b & _LO32
    b1 = b >> _32
    p01 = a0 * b1
    p10 = a1 * b0
    mid = ((a0 * b0) >> _32) + (p01 & _LO32) + (p10 & _LO32)
    return a1 * b1 + (p01 >> _32) + (p10 >> _32) + (mid >> _32), a * b


@kernel(nt.UniTuple(_U, 4)(_U, _U, _U, _U, _U, _U))
def philox4x64(c0, c1, c2, c3, k0, k1):
    """Philox4x64-10 of the counter (c0..c3) under the key (k0, k1): 4 random words."""
    for r in range(10):
        if r > 0:
            k0 = k0 + _W0
            k1 = k1 + _W1
        hi0, lo0 = _mulhilo64(_M0, c0)
        hi1, lo1 = _mulhilo64(_M1, c2)
        c0, c1, c2, c3 = hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0
    return c0, c1, c2, c3


@kernel(F64(_U), inner=True)
def _unit(x):
    """A word as a double in (0, 1] (53 bits; never 0, so its log is finite)."""
    return float((x >> _11) + _ONE) * _2M53


@kernel(F64(_U, _U, _U))
def truncated_normal(seed, rover, count):
    """A standard normal draw truncated to |z| <= 3, a pure function of its key (seed,
    rover) and counter `count`: Box-Muller on the four words of one Philox block (two
    pairs, cos then sin of each), first candidate within the truncation wins; otherwise
    the next block (counter word 1 = attempt). Rejection keeps the truncated normal
    exact (an inverse CDF would need an erfinv we do not have in numba)."""
    for attempt in range(MAX_ATTEMPTS):
        w = philox4x64(count, np.uint64(attempt), np.uint64(0), np.uint64(0), seed, rover)
        for pair in range(2):
            r = math.sqrt(-2.0 * math.log(_unit(w[2 * pair])))
            a = 2.0 * math.pi * _unit(w[2 * pair + 1])
            z = r * math.cos(a)
            if abs(z) <= TRUNCATION:
                return z
            z = r * math.sin(a)
            if abs(z) <= TRUNCATION:
                return z
    return 0.0


@kernel(F64(VEC, VEC), inner=True)
def impact_tilt(S, P):
    """The tilt psi of the surface normal at the impact about to be resolved: 0 without
    a draw when the roughness is 0, else roughness x a truncated normal keyed by
    (seed, rover) at counter = the impact's index (S_NIMPACT before it counts this one).
    Positive psi tilts the local surface like a positive slope (rising toward +x)."""
    s = P[P_ROUGH]
    if s == 0.0:
        return 0.0
    S[S_NDRAW] += 1.0
    seed = np.uint64(S[S_SEED_LO]) | (np.uint64(S[S_SEED_HI]) << _32)
    return s * truncated_normal(seed, np.uint64(S[S_ROVER]), np.uint64(S[S_NIMPACT]))
