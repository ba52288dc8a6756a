"""`simulate`: run the rover model under a torque schedule or a contest controller.

>>> from hoprover_env import simulate
>>> roll = simulate(np.full(50, 3e-4), t_end=600.0, control_dt=0.1, target_x=0.5)
>>> roll.ttrtp, roll.state[-1], len(roll.events)

The controller is either a 1-D array of torques (element k held on
[k control_dt, (k+1) control_dt); zero torque after the array ends) or a callable with
the contest signature ``control(pos, vel, the, omg, posT, t, smt, state) -> torque``,
called at every control instant with the state at that instant (no delay). The torque
is clipped to [T_min, T_max] and held (zero-order hold). A NaN or infinite torque raises
``ValueError``; it never reaches the state.

Every controller runs through the one compiled control loop of hoprover_env/sim/control_loop.py:
a torque schedule, or a controller compiled with ``numba.njit`` (state passed as an
integer code 0..6 for A..G), in one kernel call; a plain Python callable at the cost of
one Python call per control instant. All give the same `Rollout` for the same torques,
bit for bit. For many runs at once see `hoprover_env.simulate_batch`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numba import types as nt

from hoprover_env import core
from hoprover_env.core.params import MAX_MAGNITUDE, P_H, P_ROUGH, RoverParams, from_fields
from hoprover_env.jit import compiler as _compile
from hoprover_env.jit.compiler import MAT, VEC, kernel
from hoprover_env.sim.control_loop import ADVANCE, is_compiled
from hoprover_env.sim.rollout import Rollout, budget_error, run_rollout
from hoprover_env.util.validate import (
    check_rover,
    check_seed,
    check_torque,
    finite_real,
    positive_real,
    real_array,
)

__all__ = [
    "simulate",
    "RoverSim",
    "Rollout",
    "make_options",
    "make_state",
    "make_states",
    "control_grid",
    "DEFAULT_RTOL",
]

INTEGRATORS = {"event": core.INTEGRATOR_EVENT, "euler": core.INTEGRATOR_EULER}
IMPACT_LAWS = {"contest": core.LAW_CONTEST, "dissipative": core.LAW_DISSIPATIVE}
DEFAULT_RTOL = 1e-11

_INIT_ERRORS = {
    core.INIT_PENETRATION: "a bottom corner is below the ground",
    core.INIT_TOP_DOWN: "a top corner is on or below the ground (the rover starts broken)",
    core.INIT_MOVING_DOWN: "a corner on the ground is moving down into it (an impact, not a state)",
    core.INIT_NOT_FLAT: "both bottom corners are on the ground but the rover is rotating or tilted",
}


def make_options(
    integrator: str = "event",
    impact_law: str = "contest",
    rtol: float = DEFAULT_RTOL,
    euler_dt: float = 1e-3,
) -> np.ndarray:
    """The kernel's option vector, with the names checked."""
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    if not isinstance(impact_law, str) or impact_law not in IMPACT_LAWS:
        raise ValueError(f"impact_law must be one of {sorted(IMPACT_LAWS)}, got {impact_law!r}")
    rtol = finite_real("rtol", rtol)
    if not 1e-15 <= rtol <= 1e-2:
        raise ValueError(f"rtol must lie in [1e-15, 1e-2], got {rtol!r}")
    euler_dt = positive_real("euler_dt", euler_dt)
    o = np.zeros(core.N_OPTIONS)
    o[core.O_INTEGRATOR] = INTEGRATORS[integrator]
    o[core.O_LAW] = IMPACT_LAWS[impact_law]
    o[core.O_RTOL] = rtol
    o[core.O_EULER_DT] = euler_dt
    return o


def make_state(
    params: RoverParams, target_x: float, initial_state=None, seed=None, rover: int = 0
) -> np.ndarray:
    """A kernel state vector at t = 0: the upright rest of docs/MODEL.md section 9, or
    `initial_state` = (x, y, theta, vx, vy, omega) if consistent with a contact state.
    `seed` and `rover` key the rough-terrain draws (see validate.check_seed)."""
    # on a cold numba cache: compile on two cores, for the ground this run is on
    _compile.prepare(rough=params.roughness > 0.0)
    target_x = finite_real("target_x", target_x)
    if initial_state is None:
        initial_state = (0.0, params.half_height, 0.0, 0.0, 0.0, 0.0)
    try:
        st = np.asarray(initial_state, dtype=np.float64)
    except (TypeError, ValueError):
        st = None
    if (
        st is None
        or st.shape != (6,)
        or not np.all(np.isfinite(st))
        or np.asarray(initial_state).dtype.kind not in "iuf"
    ):
        raise ValueError(
            "initial_state must be 6 finite numbers (x, y, theta, vx, "
            f"vy, omega), got {initial_state!r}"
        )
    if np.max(np.abs(st)) > MAX_MAGNITUDE or abs(target_x) > MAX_MAGNITUDE:
        raise ValueError(
            f"initial_state {tuple(map(float, st))} / target_x {target_x!r}: "
            f"components beyond {MAX_MAGNITUDE:g} (SI) overflow the kernel's "
            "arithmetic"
        )
    s = np.zeros(core.N_STATE)
    code = core.init_state(s, params.as_array(), *st, float(target_x))
    if code != core.INIT_OK:
        raise ValueError(
            f"initial_state {tuple(st)} is not consistent with a contact "
            f"state: {_INIT_ERRORS[code]}"
        )
    seed = check_seed(seed, params.roughness > 0.0)
    if seed is not None:
        s[core.S_SEED_LO] = seed & 0xFFFFFFFF
        s[core.S_SEED_HI] = seed >> 32
    s[core.S_ROVER] = check_rover(rover)
    return s


@kernel(nt.void(MAT, MAT, MAT, VEC, nt.int64[::1]))
def _init_states(S, P, X, xt, codes):
    """init_state of every row of S: parameters P[i] (P[0] for all if P has one row),
    c.m. state X[i] (X[0] for all if one row; upright rest on P's half height if none),
    target xt[i]; codes[i] its INIT_* code."""
    for i in range(S.shape[0]):
        p = P[0] if P.shape[0] == 1 else P[i]
        if X.shape[0] == 0:
            codes[i] = core.init_state(S[i], p, 0.0, p[P_H], 0.0, 0.0, 0.0, 0.0, xt[i])
        else:
            x = X[0] if X.shape[0] == 1 else X[i]
            codes[i] = core.init_state(S[i], p, x[0], x[1], x[2], x[3], x[4], x[5], xt[i])


def make_states(
    P: np.ndarray,
    targets: np.ndarray,
    initial: np.ndarray | None = None,
    seeds=None,
    rovers: np.ndarray | None = None,
) -> np.ndarray:
    """Kernel state vectors at t = 0 of n runs: row i equals make_state(parameters of row
    i, targets[i], initial[i], seeds[i], rovers[i]) bit for bit, built in one compiled
    loop with the checks on whole arrays.

    P: kernel parameter rows (validated RoverParams as as_array makes them), (n, N_PARAMS)
    or one row (1, N_PARAMS) for all runs; targets: (n,) finite floats; initial: None
    (upright rest), or float64 (1, 6) for all or (n, 6); seeds: None (no key), one
    integer in [0, 2^64) for all, or (n,) uint64; rovers: (n,) integers (None: 0). A run
    on rough ground needs a seed (make_state would draw a fresh one; here the caller
    draws and records it). The first run make_state would refuse raises its ValueError,
    prefixed with "run i: "."""
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    n = targets.shape[0]
    P = np.ascontiguousarray(P, dtype=np.float64).reshape(-1, P.shape[-1])
    # on a cold numba cache: compile on two cores, for the ground these runs are on
    _compile.prepare(rough=bool((P[:, P_ROUGH] > 0.0).any()))
    X = np.zeros((0, 6)) if initial is None else np.ascontiguousarray(initial, np.float64)
    rovers = np.zeros(n, np.int64) if rovers is None else np.asarray(rovers, np.int64)
    if seeds is None and (P[:, P_ROUGH] > 0.0).any():
        raise ValueError(
            "make_states: runs on rough ground need seeds (the key of their terrain draws)"
        )
    with np.errstate(invalid="ignore"):
        bad = (
            ~np.isfinite(targets)
            | (np.abs(targets) > MAX_MAGNITUDE)
            | (rovers < 0)
            | (rovers >= 2**53)
        )
        if X.shape[0]:
            xbad = np.asarray(~np.isfinite(X).all(axis=1) | (np.abs(X) > MAX_MAGNITUDE).any(axis=1))
            bad |= xbad if X.shape[0] == n else xbad[0]
    S = np.zeros((n, core.N_STATE))
    codes = np.zeros(n, np.int64)
    _init_states(S, P, X, targets, codes)
    bad |= codes != core.INIT_OK
    if bad.any():
        i = int(np.argmax(bad))
        seed = None if seeds is None else int(seeds if np.ndim(seeds) == 0 else seeds[i])
        row = None if initial is None else X[i if X.shape[0] == n else 0]
        try:
            make_state(
                from_fields(P[i if P.shape[0] == n else 0]),
                float(targets[i]),
                row,
                seed,
                int(rovers[i]),
            )
        except ValueError as err:
            raise ValueError(f"run {i}: {err}") from None
        raise ValueError(f"run {i}: not a valid start (target_x {targets[i]!r}, rover {rovers[i]})")
    if seeds is not None:
        if np.ndim(seeds) == 0:
            S[:, core.S_SEED_LO] = int(seeds) & 0xFFFFFFFF
            S[:, core.S_SEED_HI] = int(seeds) >> 32
        else:
            seeds = np.asarray(seeds, dtype=np.uint64)
            S[:, core.S_SEED_LO] = seeds & np.uint64(0xFFFFFFFF)
            S[:, core.S_SEED_HI] = seeds >> np.uint64(32)
    S[:, core.S_ROVER] = rovers
    return S


class RoverSim:
    """A stateful handle on the kernel: hold a torque to a time, optionally stopping at
    the first event of a kind, and copy the whole state (for look-ahead planning).

    >>> sim = RoverSim(target_x=0.5)
    >>> sim.advance(3e-4, 10.0, stop_on="liftoff")   # -> events; sim.t is the lift-off time
    """

    def __init__(
        self,
        params: RoverParams | None = None,
        target_x: float = 0.5,
        initial_state=None,
        integrator: str = "event",
        impact_law: str = "contest",
        rtol: float = DEFAULT_RTOL,
        euler_dt: float = 1e-3,
        seed=None,
        rover: int = 0,
    ):
        self.params = RoverParams() if params is None else params
        if not isinstance(self.params, RoverParams):
            raise TypeError(f"params must be a RoverParams, got {type(params).__name__}")
        self.p = self.params.as_array()
        self.o = make_options(integrator, impact_law, rtol, euler_dt)
        rough = self.params.roughness > 0.0
        seed = check_seed(seed, rough)
        self.s = make_state(self.params, target_x, initial_state, seed, rover)
        self.seed = seed if rough else None  # the key of the draws, for replays
        self._ev = np.zeros((core.MAX_EVENTS + 64, core.EV_COLS))
        self._w = np.zeros(core.N_WORK)

    def copy(self) -> RoverSim:
        """An independent copy of the simulator's state (for look-ahead planning)."""
        new = object.__new__(RoverSim)
        new.params, new.p, new.o, new.seed = self.params, self.p, self.o, self.seed
        new.s = self.s.copy()
        new._ev = np.zeros_like(self._ev)
        new._w = np.zeros_like(self._w)
        return new

    def advance(self, torque: float, t_stop: float, stop_on: str | None = None) -> list:
        """Hold `torque` from now to `t_stop` (or to the first `stop_on` event).
        Returns the events as (time, kind, state before, state after, value)."""
        torque = check_torque(torque)
        t_stop = finite_real("t_stop", t_stop)
        if t_stop < self.t:
            raise ValueError(f"t_stop ({t_stop!r}) is before the current time {self.t!r}")
        if stop_on is not None and stop_on not in core.EVENT_NAMES:
            raise ValueError(
                f"stop_on must be None or one of {', '.join(core.EVENT_NAMES)}; got {stop_on!r}"
            )
        self.s[core.S_STOP_ON] = -1.0 if stop_on is None else core.EVENT_NAMES.index(stop_on)
        # the integrator this sim's options and ground need, no more (control_loop.loop_kind)
        if self.o[core.O_INTEGRATOR] == core.INTEGRATOR_EULER:
            advance = ADVANCE["euler"]
        else:
            advance = ADVANCE["event" if self.p[P_ROUGH] > 0.0 else "event_smooth"]
        n = advance(self.s, self.p, self.o, torque, t_stop, self._ev, self._w)
        if self.s[core.S_ERROR] in (core.ERR_BUDGET, core.ERR_STEP, core.ERR_WORK):
            raise budget_error(self.t, float(self.s[core.S_ERROR]))
        ev = self._ev
        return [
            (
                float(ev[i, 0]),
                core.EVENT_NAMES[int(ev[i, 1])],
                core.MODE_LETTERS[int(ev[i, 2])],
                core.MODE_LETTERS[int(ev[i, 3])],
                float(ev[i, 4]),
            )
            for i in range(min(n, ev.shape[0]))
        ]

    @property
    def t(self) -> float:
        """Simulated time [s]."""
        return float(self.s[core.S_T])

    @property
    def mode(self) -> str:
        """The contact state's letter, 'A'..'G'."""
        return core.MODE_LETTERS[int(self.s[core.S_MODE])]

    @property
    def state(self) -> np.ndarray:
        """(x, y, theta, vx, vy, omega) of the c.m."""
        return self.s[:6].copy()

    @property
    def stopped(self) -> bool:
        """Whether the last advance stopped on its stop_on event."""
        return bool(self.s[core.S_STOPPED])

    @property
    def broken(self) -> bool:
        """Whether a top corner has touched the ground."""
        return bool(self.s[core.S_BROKEN])

    @property
    def ttrtp(self) -> float | None:
        """The judge's TTRTP [s], or None before the target is reached."""
        v = self.s[core.S_TTRTP]
        return None if math.isnan(v) else float(v)

    def contact_forces(self):
        """(fAx, fAy, fBx, fBy) now, under the torque last applied."""
        return core.contact_forces(self.s, self.p)


MAX_SAMPLES = 10**7  # samples one call may produce: ~1 GB of output arrays, minutes of CPU
MAX_EULER_STEPS = 10**10  # fixed Euler steps one simulate() call may take (hours of CPU)


def control_grid(t_end: float, control_dt: float, sample_dt: float | None) -> tuple[int, int]:
    """(control intervals, samples per interval) of a run. The last interval always ends
    at t_end exactly (a t_end a hair past a multiple of control_dt gets its own short
    interval; rounding the count down once ended such runs early). Refuses grids that
    would never finish or fill memory: at most MAX_SAMPLES samples per call."""
    ratio = t_end / control_dt
    sub_ratio = 1.0 if sample_dt is None else control_dt / sample_dt
    if ratio * max(sub_ratio, 1.0) > MAX_SAMPLES:
        raise ValueError(
            f"t_end / control_dt = {ratio:.3g} control intervals"
            + ("" if sample_dt is None else f" x {sub_ratio:.3g} samples each")
            + f" is more than one call may produce (at most {MAX_SAMPLES:.0e} samples): shorten "
            "t_end, lengthen control_dt or sample_dt, or split the run with RoverSim"
        )
    n_ctrl = max(1, int(math.ceil(ratio - 1e-9)))
    if n_ctrl * control_dt < t_end:
        n_ctrl += 1
    sub = 1 if sample_dt is None else max(1, int(math.ceil(sub_ratio - 1e-9)))
    return n_ctrl, sub


def simulate(
    controller: Sequence[float] | np.ndarray | Callable,
    t_end: float = 600.0,
    control_dt: float = 0.1,
    target_x: float = 0.5,
    integrator: str = "event",
    impact_law: str = "contest",
    params: RoverParams | None = None,
    initial_state=None,
    euler_dt: float = 1e-3,
    rtol: float = DEFAULT_RTOL,
    sample_dt: float | None = None,
    seed=None,
    rover: int = 0,
    controller_args=None,
) -> Rollout:
    """Simulate one run to `t_end` (or until the rover breaks).

    Parameters mirror the contest: `control_dt` is the control period, `target_x` the
    target point, `integrator` 'event' (default, exact events) or 'euler' (contest-style
    fixed step `euler_dt`), `impact_law` 'contest' or 'dissipative', `rtol` the
    relative tolerance of the event integrator's DOP853 contact phases. `sample_dt`
    adds samples between control instants (for plots); the physics is unchanged.
    `seed` (and `rover`, the run's index in a batch) key the rough-terrain draws; on
    rough ground without a seed one is drawn from fresh entropy and `Rollout.seed` says
    which. `controller_args` (1-D) are appended to a compiled controller's posT, as
    `simulate_batch(..., controller_args=)` does for one run. Times in s, torques in N m,
    lengths in m. `Rollout.replay_args` holds these arguments (seed and rover included):
    `simulate(**roll.replay_args)` replays the run bit for bit.

    Returns the `Rollout`. Raises ValueError for a bad argument (named), a non-finite
    torque from the controller, a grid too large for one call or an initial state no
    contact state allows; TypeError for a compiled controller without the contest
    signature; RuntimeError when the integrator cannot go on (see `budget_error`).
    """
    params = RoverParams() if params is None else params
    if not isinstance(params, RoverParams):
        raise TypeError(f"params must be a RoverParams, got {type(params).__name__}")
    t_end = positive_real("t_end", t_end)
    control_dt = positive_real("control_dt", control_dt)
    if sample_dt is not None:
        sample_dt = positive_real("sample_dt", sample_dt)
    sim = RoverSim(
        params, target_x, initial_state, integrator, impact_law, rtol, euler_dt, seed, rover
    )
    s = sim.s
    if callable(controller):
        schedule = None
    else:
        try:
            raw = np.asarray(controller)
        except ValueError:  # ragged nesting: [0.0, [1.0]]
            raw = np.asarray(None)
        if raw.dtype.kind not in "iuf":
            # strings ('1e-4'), booleans and complex numbers are not converted silently
            raise ValueError(
                "a torque schedule must be a 1-D sequence of real numbers (or a "
                f"controller), got {controller!r}"
            )
        schedule = raw.astype(np.float64)
        if schedule.ndim != 1:
            raise ValueError(f"a torque schedule must be 1-D, got shape {schedule.shape}")
        bad = np.flatnonzero(~np.isfinite(schedule))
        if bad.size:
            raise ValueError(
                f"torque schedule element {bad[0]} is {float(schedule[bad[0]])!r}; "
                "torques must be finite"
            )
    if controller_args is not None:
        if not is_compiled(controller):
            raise ValueError(
                "controller_args are passed to a numba-compiled controller; "
                "a schedule or a Python controller takes none"
            )
        controller_args = real_array("controller_args", controller_args)
        if controller_args.ndim != 1 or not np.all(np.isfinite(controller_args)):
            raise ValueError(
                f"controller_args must be a 1-D array of finite numbers, got "
                f"shape {controller_args.shape}"
            )
    n_ctrl, sub = control_grid(t_end, control_dt, sample_dt)
    if integrator == "euler" and t_end / euler_dt > MAX_EULER_STEPS:
        raise ValueError(
            f"t_end / euler_dt = {t_end / euler_dt:.3g} Euler steps is more than "
            f"one call may take ({MAX_EULER_STEPS:.0e}): use a larger euler_dt "
            "or the event integrator"
        )
    roll = run_rollout(
        s,
        sim.p,
        sim.o,
        schedule,
        controller,
        control_dt,
        t_end,
        n_ctrl,
        sub,
        target_x,
        params,
        controller_args,
    )
    roll.seed = sim.seed
    roll.rover = int(rover)
    roll.replay_args = dict(
        controller=controller if schedule is None else schedule.copy(),
        t_end=t_end,
        control_dt=control_dt,
        target_x=target_x,
        integrator=integrator,
        impact_law=impact_law,
        params=params,
        initial_state=None if initial_state is None else tuple(map(float, initial_state)),
        euler_dt=euler_dt,
        rtol=rtol,
        sample_dt=sample_dt,
        seed=sim.seed,
        rover=int(rover),
        controller_args=None if controller_args is None else controller_args.copy(),
    )
    return roll
