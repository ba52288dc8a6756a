"""The episode draws of the envs: counter-based and
vectorised over rovers, one function for one rover (the single env) and for N (the
vector env), so that sub-env i of a vector env seeded with s equals a single env seeded
with s + i bit for bit, whatever the batch, the rows reset together and the threads.

Every draw of an episode is a pure function of (the rover's seed, its episode number):
Philox4x64-10 (core/terrain.py `philox4x64`, the generator of the rough ground and the
mission's sensors) under the key (seed mod 2^64, (seed >> 64) xor KEY_TAG), at the
counter (episode, block, stream, attempt). Stream EPISODE holds, word by word,

    0 the target, 1 the slope (a terrain task), 2 the seed of the bumps (rough ground),
    3.. the task's own (TaskSpec.reset_draws uniforms, for its reset_memory)

at fixed places whatever the config and the options say, so that the draws stay aligned;
stream RANDOMIZE holds domain randomisation's uniforms (one per randomised field, in
sorted order), attempt a being the a-th draw of a row whose earlier draws broke
RoverParams' constraints (Painleve); stream START the training starts of `flight_start`
and `near_start` (`training_starts`). A word u becomes a uniform (u >> 11) 2^-53 in
[0, 1) and a terrain seed u >> 1 in [0, 2^63).

Reset options (tasks/options.py, checked there) replace the outcome of a draw, never the
draw itself: a frozen episode (a test suite's) is given as options, so that an env
started with them plays exactly that episode, whatever its seed.
"""

from __future__ import annotations

import dataclasses
import math
import os

import numpy as np
from numba import types as nt

from hoprover_env import core
from hoprover_env.core.params import (
    FIELD_INDEX,
    MAX_MAGNITUDE,
    N_FIELDS,
    N_PARAMS,
    P_G,
    P_GC,
    P_GS,
    P_H,
    P_MUD,
    P_MUS,
    P_R,
    P_ROUGH,
    P_SLOPE,
    from_fields,
)
from hoprover_env.core.params import invalid_rows as invalid_field_rows
from hoprover_env.core.terrain import philox4x64
from hoprover_env.jit.compiler import MAT, VEC, kernel
from hoprover_env.sim.randomize import RANDOMIZABLE
from hoprover_env.sim.simulate import make_state

STREAM_EPISODE, STREAM_RANDOMIZE, STREAM_START = 0, 1, 2
W_TARGET, W_SLOPE, W_TERRAIN_SEED, W_TASK = 0, 1, 2, 3
KEY_TAG = 0x6570697364726177  # "episdraw": keys apart from the terrain's
MAX_ATTEMPTS = 100  # randomisation draws per row before giving up
_U64 = np.uint64
_MASK64 = (1 << 64) - 1
_COLUMN = FIELD_INDEX  # a field's column in a parameter row (P_* order)
_NO_SEED = -1


@kernel(
    nt.void(nt.uint64[::1], nt.uint64[::1], nt.int64[::1], nt.uint64, nt.uint64, nt.uint64[:, ::1])
)
def philox_words(keys_lo, keys_hi, episodes, stream, attempt, out):
    """out[i, j]: word j of rover i's draws, Philox4x64-10 under the key (keys_lo[i],
    keys_hi[i]) at the counter (episodes[i], j // 4, stream, attempt), word j % 4."""
    n, k = out.shape
    for i in range(n):
        for b in range((k + 3) // 4):
            w = philox4x64(
                np.uint64(episodes[i]), np.uint64(b), stream, attempt, keys_lo[i], keys_hi[i]
            )
            for j in range(4):
                c = 4 * b + j
                if c < k:
                    out[i, c] = w[j]


@kernel(nt.void(MAT, MAT, MAT, VEC, nt.int64[::1]))
def start_rows(S, P, X, targets, codes):
    """Gravity's ground-frame components of every parameter row (as RoverParams.as_array
    computes them), then init_state of every row: c.m. state X[i] (the upright rest on
    P's half height if X has no rows); codes[i] its INIT_* code."""
    for i in range(S.shape[0]):
        p = P[i]
        p[P_GS] = p[P_G] * math.sin(p[P_SLOPE]) + 0.0
        p[P_GC] = p[P_G] * math.cos(p[P_SLOPE])
        if X.shape[0] == 0:
            codes[i] = core.init_state(S[i], p, 0.0, p[P_H], 0.0, 0.0, 0.0, 0.0, targets[i])
        else:
            x = X[i]
            codes[i] = core.init_state(S[i], p, x[0], x[1], x[2], x[3], x[4], x[5], targets[i])


def split_seed(seed) -> tuple[int, int]:
    """The Philox key of a rover's seed (an integer in [0, 2^128))."""
    if (
        isinstance(seed, (bool, np.bool_))
        or not isinstance(seed, (int, np.integer))
        or not 0 <= int(seed) < 2**128
    ):
        raise ValueError(f"seed must be an integer in [0, 2**128), got {seed!r}")
    seed = int(seed)
    return seed & _MASK64, (seed >> 64) ^ KEY_TAG


def words(keys_lo, keys_hi, episodes, stream: int, k: int, attempt: int = 0) -> np.ndarray:
    """(n, k) uint64: the first k words of a stream of each rover's episode."""
    out = np.empty((len(episodes), k), dtype=np.uint64)
    if k:
        philox_words(keys_lo, keys_hi, episodes, _U64(stream), _U64(attempt), out)
    return out


def uniforms(w: np.ndarray) -> np.ndarray:
    """Words as doubles in [0, 1) (53 bits)."""
    return (w >> _U64(11)).astype(np.float64) * 2.0**-53


def invalid_rows(P: np.ndarray) -> np.ndarray:
    """Rows of P whose fields (mass .. roughness) RoverParams would refuse: the
    constructor's verdict (core/params.py `invalid_rows`, on the field columns)."""
    return invalid_field_rows(P[:, :N_FIELDS])


row_params = from_fields  # the RoverParams of a parameter row (validated)


def randomize_rows(cfg, P, keys_lo, keys_hi, episodes) -> None:
    """Domain randomisation of the rows of P (each the config's base parameters): each
    field of cfg.randomize scaled by U(1 - r, 1 + r) in sorted order, clipped to its
    bounds, mu_dynamic clipped to mu_static; a row that breaks RoverParams' constraints
    (Painleve) draws again at the next attempt, up to MAX_ATTEMPTS times."""
    if not cfg.randomize:
        return
    base, cols, rel, lo, hi = _constants(cfg)[1:]
    pending = np.arange(len(P))
    for attempt in range(MAX_ATTEMPTS):
        u = uniforms(
            words(
                keys_lo[pending],
                keys_hi[pending],
                episodes[pending],
                STREAM_RANDOMIZE,
                len(cols),
                attempt,
            )
        )
        rows = P[pending]
        rows[:, cols] = np.clip(base[cols] * ((1.0 - rel) + 2.0 * rel * u), lo, hi)
        rows[:, P_MUD] = np.minimum(rows[:, P_MUD], rows[:, P_MUS])
        bad = invalid_rows(rows)
        P[pending[~bad]] = rows[~bad]
        pending = pending[bad]
        if not pending.size:
            return
    raise ValueError(
        f"randomize: {MAX_ATTEMPTS} draws in a row gave invalid parameters; "
        f"narrow the ranges {dict(cfg.randomize)}"
    )


def _constants(cfg) -> tuple:
    """What every draw under `cfg` uses, computed once per config: (its parameter row,
    then randomisation's base row, columns, half-ranges and bounds)."""
    got = cfg.__dict__.get("_draw_constants")
    if got is None:
        rand = cfg.randomize
        base = cfg.params.as_array()
        got = (
            base,
            base,
            np.array([_COLUMN[key] for key in rand], dtype=np.int64),
            np.array(list(rand.values()), dtype=np.float64),
            np.array([RANDOMIZABLE[key][0] for key in rand], dtype=np.float64),
            np.array([RANDOMIZABLE[key][1] for key in rand], dtype=np.float64),
        )
        object.__setattr__(cfg, "_draw_constants", got)
    return got


@dataclasses.dataclass
class Episodes:
    """The draws of n rovers' new episodes: targets (n,), parameter rows P (n,
    N_PARAMS), initial states S (n, N_STATE), terrain seeds (n,) int64 (-1 on smooth
    ground), the task's uniforms U (n, TaskSpec.reset_draws) and the task's start options
    given (`fixed`: name -> (n,) values, TaskSpec.start_options)."""

    targets: np.ndarray
    P: np.ndarray
    S: np.ndarray
    terrain_seeds: np.ndarray
    U: np.ndarray
    fixed: dict = dataclasses.field(default_factory=dict)


# The flight starts of `flight_start` (a training option; evaluation always starts at
# rest): a c.m. over the target range, clear of the ground in any attitude, moving as a
# hop of up to a few metres does, in any attitude and spinning at up to FLIGHT_SPIN.
# The near starts of `near_start`: upright at rest within NEAR_RADIUS of the target, so
# that the last approach and the keeping still in the band are met before a learner can
# reach them from x = 0 (the band's half-width is 0.05 m).
NEAR_RADIUS = 0.5  # [m]
FLIGHT_CLEARANCE = (0.01, 0.5)  # lowest corner above the ground [m]: its range
FLIGHT_SPEED = (0.01, 0.005)  # |vx|, |vy| up to [m/s]
FLIGHT_SPIN = 3.0  # |omega| up to [rad/s]


def training_starts(cfg, P, targets, keys_lo, keys_hi, episodes) -> np.ndarray:
    """The initial c.m. states (n, 6) of the training starts: with u the first word of
    stream START, a rover with u < cfg.flight_start starts in flight (drawn from the
    next six words), one with u in [flight_start, flight_start + near_start) upright at
    rest at x = target + NEAR_RADIUS (2 u1 - 1), the rest upright at rest at x = 0, as
    with no initial state. Every rover draws the same words, so the streams stay
    aligned (and flight_start alone draws what it drew before near_start existed)."""
    u = uniforms(words(keys_lo, keys_hi, episodes, STREAM_START, 7))
    lo, hi = cfg.target_range
    half_diagonal = np.hypot(P[:, P_R], P[:, P_H])
    flying = np.column_stack(
        [
            lo + (hi - lo) * u[:, 1],
            half_diagonal
            + FLIGHT_CLEARANCE[0]
            + (FLIGHT_CLEARANCE[1] - FLIGHT_CLEARANCE[0]) * u[:, 2],
            math.pi * (2.0 * u[:, 3] - 1.0),
            FLIGHT_SPEED[0] * (2.0 * u[:, 4] - 1.0),
            FLIGHT_SPEED[1] * (2.0 * u[:, 5] - 1.0),
            FLIGHT_SPIN * (2.0 * u[:, 6] - 1.0),
        ]
    )
    rest = np.zeros_like(flying)
    rest[:, 1] = P[:, P_H]
    near = rest.copy()
    near[:, 0] = targets + NEAR_RADIUS * (2.0 * u[:, 1] - 1.0)
    out = np.where((u[:, 0] < cfg.flight_start + cfg.near_start)[:, None], near, rest)
    return np.where((u[:, 0] < cfg.flight_start)[:, None], flying, out)


def sample_episodes(task, cfg, keys_lo, keys_hi, episodes, options=None) -> Episodes:
    """The new episodes of n rovers keyed (keys_lo[i], keys_hi[i]) at episode numbers
    episodes[i], under `options`: reset options as tasks/options.py `check` gives them,
    n rows each. Raises ValueError for parameters RoverParams refuses, a rough episode
    without a terrain seed and a start no contact state allows."""
    options = dict(options or {})
    keys_lo = np.ascontiguousarray(keys_lo, dtype=np.uint64)
    keys_hi = np.ascontiguousarray(keys_hi, dtype=np.uint64)
    episodes = np.ascontiguousarray(episodes, dtype=np.int64)
    n = len(episodes)
    extra = task.reset_draws if task.reset_memory is not None else 0
    w = words(keys_lo, keys_hi, episodes, STREAM_EPISODE, W_TASK + extra)
    u = uniforms(w)
    # the target
    if "target_x" in options:
        targets = np.array(options["target_x"], dtype=np.float64)
    elif cfg.target_x is not None:
        targets = np.full(n, cfg.target_x)
    else:
        lo, hi = cfg.target_range
        targets = lo + (hi - lo) * u[:, W_TARGET]
    # the parameters: drawn, then the ground and the fields the options fix
    P = np.empty((n, N_PARAMS))
    P[:] = _constants(cfg)[0]
    randomize_rows(cfg, P, keys_lo, keys_hi, episodes)
    fixed = cfg.terrain_columns(u[:, W_SLOPE])
    fixed.update({key: v for key, v in options.items() if key in _COLUMN})
    for key, value in fixed.items():
        P[:, _COLUMN[key]] = value
    if fixed:
        bad = invalid_rows(P)
        if bad.any():
            row_params(P[int(np.argmax(bad))])  # raises RoverParams' error
    # the seed of the bumps
    rough = P[:, P_ROUGH] > 0.0
    seeds = np.where(rough, (w[:, W_TERRAIN_SEED] >> _U64(1)).astype(np.int64), _NO_SEED)
    if "terrain_seed" in options:
        given = options["terrain_seed"]
        if (rough & (given < 0)).any():
            raise ValueError(
                f"options['terrain_seed'] must be an integer in [0, 2**63) on "
                f"rough ground, got {given[np.flatnonzero(rough & (given < 0))[0]]!r}"
            )
        seeds = np.where(rough, given, seeds)
    # the initial states
    X = np.zeros((0, 6))
    if "initial_state" in options:
        X = np.array(options["initial_state"], dtype=np.float64, order="C")  # writable
    elif cfg.flight_start > 0.0 or cfg.near_start > 0.0:
        X = training_starts(cfg, P, targets, keys_lo, keys_hi, episodes)
    bad = np.abs(targets) > MAX_MAGNITUDE
    if X.shape[0]:
        bad |= (np.abs(X) > MAX_MAGNITUDE).any(axis=1)
    S = np.zeros((n, core.N_STATE))
    codes = np.zeros(n, dtype=np.int64)
    start_rows(S, P, X, targets, codes)
    bad |= codes != core.INIT_OK
    if bad.any():
        i = int(np.argmax(bad))
        make_state(
            row_params(P[i]),
            float(targets[i]),
            X[i] if X.shape[0] else None,
            int(seeds[i]) if rough[i] else None,
        )  # raises its ValueError
        raise ValueError(f"not a valid start (target_x {targets[i]!r})")
    if rough.any():
        s = np.where(rough, seeds, 0).astype(np.uint64)
        S[:, core.S_SEED_LO] = np.where(rough, s & _U64(0xFFFFFFFF), 0)
        S[:, core.S_SEED_HI] = np.where(rough, s >> _U64(32), 0)
    own = {o.name for o in task.start_options}
    return Episodes(
        targets, P, S, seeds, u[:, W_TASK:], {key: v for key, v in options.items() if key in own}
    )


class ParamsView:
    """The RoverParams of each row of a parameter array, built when first asked for and
    kept until `forget` (a vector env's `params[i]`)."""

    def __init__(self, P: np.ndarray):
        self._P = P
        self._cache = np.full(len(P), None, dtype=object)

    def forget(self, rows) -> None:
        """Rows whose parameters changed (a reset)."""
        self._cache[rows] = None

    def __len__(self) -> int:
        return len(self._P)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(len(self._P))[i]]
        i = int(i)
        p = self._cache[i]
        if p is None:
            p = self._cache[i] = row_params(self._P[i])
        return p

    def __iter__(self):
        return (self[i] for i in range(len(self._P)))


class RoverKeys:
    """Each rover's Philox key (from its seed) and episode number: the episode number
    restarts at 0 when a seed is given and advances at every later reset."""

    def __init__(self, n: int):
        self.lo = np.zeros(n, dtype=np.uint64)
        self.hi = np.zeros(n, dtype=np.uint64)
        self.episode = np.zeros(n, dtype=np.int64)
        self.keyed = np.zeros(n, dtype=np.bool_)

    def seed_consecutive(self, base: int, rows: np.ndarray) -> None:
        """Rover i of `rows` seeded with base + i (Gymnasium's vector convention)."""
        split_seed(base)
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size and base + int(rows.max()) < 2**64:
            self.lo[rows] = _U64(base) + rows.astype(np.uint64)
            self.hi[rows] = _U64(KEY_TAG)
        else:
            for i in rows:
                self.lo[i], self.hi[i] = split_seed(base + int(i))
        self.keyed[rows] = True
        self.episode[rows] = 0

    def seed_rows(self, rows, seeds) -> None:
        """Rover rows[j] seeded with seeds[j]."""
        for i, s in zip(rows, seeds):
            self.lo[i], self.hi[i] = split_seed(s)
        self.keyed[rows] = True
        self.episode[rows] = 0

    def next_episode(self, rows) -> None:
        """A reset without a seed: the next episode of a keyed rover; a rover never
        seeded gets base + i, base one fresh seed from OS entropy for the whole call."""
        rows = np.asarray(rows, dtype=np.int64)
        fresh = rows[~self.keyed[rows]]
        self.episode[rows[self.keyed[rows]]] += 1
        if fresh.size:
            self.seed_consecutive(fresh_seed(), fresh)


def fresh_seed() -> int:
    """A seed from OS entropy (63 bits)."""
    return int.from_bytes(os.urandom(8), "little") >> 1
