"""`simulate_batch`: N whole runs in one call, threaded over the cores.

>>> from hoprover_env import simulate_batch
>>> b = simulate_batch(np.full((64, 30), 3e-4), targets=np.linspace(-1, 1, 64), t_end=600.0)
>>> b.ttrtp, b.broken, b.n_events          # per run, leading axis N
>>> b.rollout(3)                           # run 3 as a Rollout: equal to simulate(...) of run 3

Each run is the loop of `simulate` compiled with the kernel (hoprover_env/sim/control_loop.py);
numba's `prange` spreads the runs over its threads (`numba.set_num_threads` chooses how
many). Run i equals `simulate` of run i bit for bit: same schedule row (or compiled
controller), target, parameters and initial state.

Arguments
---------
controller     a torque schedule array (N, K) (row i drives run i, zero torque after K
               control periods), or one numba-compiled contest controller for all runs
               (see hoprover_env/sim/control_loop.py for its signature)
targets        (N,) target x of each run
params         None (contest values), one RoverParams for all, or a sequence of N
               RoverParams (or dicts of RoverParams fields)
randomize      relative half-ranges {field: r} as in the environments: run i's parameters
               are the base `params` with each field scaled by U(1 - r, 1 + r), drawn in
               run order from numpy's default_rng(seed)
seed           an integer in [0, 2^64) or None: seeds `randomize` and keys the
               rough-terrain draws, run i with rover index i (so run i equals
               simulate(..., seed=seed, rover=i) whatever the threads or batch size); on
               rough ground None becomes a fresh seed, recorded in BatchRollout.seed.
               Or one seed per run, an integer array (N,): run i is keyed (seeds[i],
               rover 0), so it equals simulate(..., seed=seeds[i]) at any position of any
               batch (`randomize` then draws from default_rng(seeds))
               Every run's Rollout records what replays it: simulate(**b.rollout(i).replay_args)
initial_states None (upright rest), one (x, y, theta, vx, vy, omega), or (N, 6)
controller_args (N, M) per-run parameters for a compiled controller: run i calls it with
               posT = (x_T, 0, controller_args[i, 0], ...) (the contest's posT[:2] first)
record         keep every sample and event (default). False keeps only the per-run
               summaries (for large N); `rollout(i)` then re-runs run i.

Bad input raises ValueError (or TypeError) naming the argument and, for per-run input,
the run index.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numba
import numpy as np

from hoprover_env import core
from hoprover_env.core.params import (
    N_PARAMS,
    P_ROUGH,
    RoverParams,
    as_arrays,
    from_fields,
    kernel_rows,
)
from hoprover_env.jit.spread import spread_order
from hoprover_env.jit.threads import run_threaded
from hoprover_env.sim import control_loop, rollout
from hoprover_env.sim.randomize import check_randomize, draw_fields, rng_for_seeds
from hoprover_env.sim.rollout import SampledStates
from hoprover_env.sim.simulate import (
    DEFAULT_RTOL,
    control_grid,
    make_options,
    make_states,
    simulate,
)
from hoprover_env.util.validate import check_seed, positive_real, real_array, run_rows, seed_array

MAX_STEPS = 10**9  # control intervals x samples per run
MAX_RECORD_BYTES = 4 * 10**9  # sample arrays of a recorded batch


@dataclasses.dataclass
class BatchRollout(SampledStates):
    """N runs. Sample arrays have shape (N, M), M the longest run's sample count; a run
    that broke early is padded with NaN (and '' in `state`) after its n_samples[i]."""

    targets: np.ndarray  # (N,)
    params: Sequence  # N RoverParams (a list, or RunParams when drawn)
    ttrtp: np.ndarray  # (N,) NaN where the target was not reached
    broken: np.ndarray  # (N,) bool
    n_events: np.ndarray  # (N,) events (transitions, impacts, band crossings)
    n_impacts: np.ndarray  # (N,)
    final: np.ndarray  # (N, 7) x, y, theta, vx, vy, omega, t at the end
    n_samples: np.ndarray  # (N,) samples recorded per run (0 without record)
    torque: np.ndarray
    torque_cmd: np.ndarray
    event_log: np.ndarray  # (N, L, 5): t, kind, mode before, mode after, value
    n_logged: np.ndarray  # (N,) rows of event_log used per run
    _run: dict = dataclasses.field(repr=False, default_factory=dict)
    seed: int | np.ndarray | None = None  # key of the rough-terrain draws: one seed, run
    #                    i with rover index i; or (N,) seeds, each run rover 0 (None: smooth)
    rovers: np.ndarray | None = None  # (N,) rover index of each run's key

    @property
    def success(self) -> np.ndarray:
        """(N,) bool: whether each run reached the judge's TTRTP."""
        return ~np.isnan(self.ttrtp)

    def __len__(self) -> int:
        return len(self.targets)

    def rollout(self, i: int):
        """Run i as a `Rollout` (identical to `simulate` of run i)."""
        n = len(self)
        if not (isinstance(i, (int, np.integer)) and -n <= i < n):
            raise IndexError(f"run index {i!r} out of range for {n} runs")
        i = int(i) % n
        r = self._run
        # on smooth ground nothing is drawn: no seed, and the rover index keys nothing
        rough = self.params[i].roughness > 0.0
        seeds = r["seeds"]
        seed = (int(seeds[i]) if np.ndim(seeds) else seeds) if rough else None
        rover = int(r["rovers"][i]) if rough else 0
        initial = r["initial"]
        replay = dict(
            controller=r["schedules"][i].copy() if r["controller"] is None else r["controller"],
            **r["kwargs"],
            target_x=float(self.targets[i]),
            params=self.params[i],
            initial_state=None
            if initial is None
            else tuple(map(float, initial[i if len(initial) > 1 else 0])),
            seed=seed,
            rover=rover,
            controller_args=r["cargs"][i].copy() if r["cargs"].shape[1] else None,
        )
        if not r["record"]:
            return simulate(**replay)
        buf = r["buffers"]
        roll = rollout.build_rollout(
            buf.rows[i],
            buf.cmds[i],
            buf.applied[i],
            buf.log[i],
            buf.prog[i],
            r["S"][i],
            self.params[i],
            self.targets[i],
        )
        roll.seed, roll.rover, roll.replay_args = seed, rover, replay
        return roll


def _controller(controller, n):
    """What decides the torques of n runs: (compiled?, control_loop.CTRL_*, the compiled
    controller or None, the (n, K) schedules or an (n, 0) placeholder)."""
    use_ctrl = control_loop.is_compiled(controller)
    source = control_loop.CTRL_COMPILED if use_ctrl else control_loop.CTRL_SCHEDULE
    if use_ctrl:
        control_loop.control_stub()
        ctrl = control_loop.control_function(controller)
        sched = np.zeros((n, 0))
    elif callable(controller):
        raise TypeError(
            "simulate_batch runs a torque schedule array (N, K) or a "
            "numba-compiled controller; loop over simulate() for a Python "
            "controller"
        )
    else:
        sched = real_array("torque schedules", controller)
        if sched.ndim != 2:
            raise ValueError(
                f"torque schedules must have shape (N, K), one row per run, got shape {sched.shape}"
            )
        if sched.shape[0] != n:
            raise ValueError(f"torque schedules have {sched.shape[0]} rows for {n} targets")
        if not np.isfinite(sched).all():
            i, k = np.argwhere(~np.isfinite(sched))[0]
            raise ValueError(
                f"run {i}: torque schedule element {k} is {sched[i, k]!r}; torques must be finite"
            )
        ctrl = None
    return use_ctrl, source, ctrl, sched


def _controller_args(controller_args, use_ctrl, n):
    """controller_args checked: an (n, M) float array (M = 0 without any)."""
    if controller_args is None:
        cargs = np.zeros((n, 0))
    else:
        if not use_ctrl:
            raise ValueError(
                "controller_args are passed to a compiled controller; a torque schedule takes none"
            )
        cargs = real_array("controller_args", controller_args)
        if cargs.ndim != 2 or cargs.shape[0] != n:
            raise ValueError(
                f"controller_args must have shape (N, M) with N = {n}, got {cargs.shape}"
            )
        if not np.isfinite(cargs).all():
            i, k = np.argwhere(~np.isfinite(cargs))[0]
            raise ValueError(f"run {i}: controller_args element {k} is not finite")
    return cargs


class RunParams(Sequence):
    """The RoverParams of N runs, kept as their (N, N_PARAMS) kernel rows and built when
    asked for (each once): a batch draws N parameter sets as arrays, and most callers
    read a few of them or none."""

    def __init__(self, rows: np.ndarray):
        self.rows = rows
        self._built: dict[int, RoverParams] = {}

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        n = len(self)
        if not (isinstance(i, (int, np.integer)) and -n <= i < n):
            raise IndexError(f"run index {i!r} out of range for {n} runs")
        i = int(i) % n
        p = self._built.get(i)
        if p is None:
            p = self._built[i] = from_fields(self.rows[i])
        return p

    def __eq__(self, other):
        if isinstance(other, RunParams) and len(other) == len(self):
            return bool(np.array_equal(self.rows, other.rows))
        return (
            isinstance(other, Sequence)
            and len(other) == len(self)
            and all(a == b for a, b in zip(self, other))
        )

    def __repr__(self) -> str:
        return f"RunParams({len(self)} runs)"


def _run_params(params, randomize, seed, n):
    """(the runs' RoverParams as a sequence, their (n, N_PARAMS) kernel rows). One set
    for all runs is one object and one row, repeated; `randomize` draws all n as arrays
    (randomize.draw_fields: the numbers of n draw_params calls); a sequence is checked
    per run, each distinct object's as_array taken once."""
    if randomize is not None:
        if params is not None and not isinstance(params, (RoverParams, Mapping)):
            raise ValueError(
                "randomize draws each run's parameters from one base: give "
                "params as one RoverParams (or None), not a sequence"
            )
        if isinstance(params, Mapping):
            params = RoverParams(**params)
        base = params if params is not None else RoverParams()
        randomize = check_randomize(randomize)
        if randomize:
            rng = (
                rng_for_seeds(seed) if isinstance(seed, np.ndarray) else np.random.default_rng(seed)
            )
            rows = kernel_rows(draw_fields(base, randomize, rng, n))
            return RunParams(rows), rows
        params = base
    if params is None:
        params = RoverParams()
    if isinstance(params, RoverParams):
        rows = np.empty((n, N_PARAMS))
        rows[:] = params.as_array()
        return [params] * n, rows
    if isinstance(params, (str, bytes, Mapping)) or not isinstance(params, Sequence):
        raise TypeError(
            f"params must be None, a RoverParams or a sequence of {n} of them, "
            f"got {type(params).__name__}"
        )
    if len(params) != n:
        raise ValueError(f"params has {len(params)} entries for {n} runs")
    out = list(params)
    if not all(issubclass(t, RoverParams) for t in set(map(type, out))):
        for i, p in enumerate(out):  # dicts to build, or something else to refuse
            if isinstance(p, Mapping):
                try:
                    out[i] = p = RoverParams(**p)
                except (TypeError, ValueError) as err:
                    raise ValueError(f"run {i}: {err}") from None
            if not isinstance(p, RoverParams):
                raise TypeError(
                    f"run {i}: params must be a RoverParams or a dict of its "
                    f"fields, got {type(p).__name__}"
                )
    return out, as_arrays(out)


def simulate_batch(
    controller,
    targets,
    t_end: float = 600.0,
    control_dt: float = 0.1,
    integrator: str = "event",
    impact_law: str = "contest",
    params=None,
    randomize: Mapping[str, float] | None = None,
    seed=None,
    initial_states=None,
    euler_dt: float = 1e-3,
    rtol: float = DEFAULT_RTOL,
    sample_dt: float | None = None,
    controller_args=None,
    record: bool = True,
) -> BatchRollout:
    """N runs in one threaded kernel call; see the module docstring."""
    targets = real_array("targets", targets)
    if targets.ndim != 1 or targets.size == 0:
        raise ValueError(
            f"targets must be a non-empty 1-D array (one per run), got shape {targets.shape}"
        )
    n = targets.size
    bad = np.flatnonzero(~np.isfinite(targets))
    if bad.size:
        raise ValueError(f"run {bad[0]}: target_x must be finite, got {targets[bad[0]]!r}")
    t_end = positive_real("t_end", t_end)
    control_dt = positive_real("control_dt", control_dt)
    if sample_dt is not None:
        sample_dt = positive_real("sample_dt", sample_dt)
    if not isinstance(record, bool):
        raise TypeError(f"record must be True or False, got {record!r}")

    use_ctrl, source, ctrl, sched = _controller(controller, n)
    cargs = _controller_args(controller_args, use_ctrl, n)

    per_run = isinstance(seed, (np.ndarray, list, tuple))
    if per_run:  # run i keyed (seeds[i], rover 0)
        key = seed_array(seed, n)
        plist, P = _run_params(params, randomize, key, n)
        rovers = np.zeros(n, dtype=np.int64)
    else:  # run i keyed (seed, rover i)
        seed = check_seed(seed)
        plist, P = _run_params(params, randomize, seed, n)
        key = seed = check_seed(seed, bool((P[:, P_ROUGH] > 0.0).any()))
        rovers = np.arange(n, dtype=np.int64)
    rough = bool((P[:, P_ROUGH] > 0.0).any())
    initial = run_rows("initial_states", initial_states, n, 6)
    opts = make_options(integrator, impact_law, rtol, euler_dt)
    S = make_states(P, targets, initial, key, rovers)

    # the control grid of simulate()
    n_ctrl, sub = control_grid(t_end, control_dt, sample_dt)
    if n_ctrl * sub > MAX_STEPS:
        raise ValueError(
            f"t_end / control_dt (x control_dt / sample_dt) gives {n_ctrl * sub:.3g} "
            f"kernel calls per run; at most {MAX_STEPS:.0e}"
        )
    if record and n * (n_ctrl * sub + 1) * control_loop.ROW_COLS * 8 > MAX_RECORD_BYTES:
        raise ValueError(
            f"recording {n} runs of {n_ctrl * sub + 1} samples needs "
            f"{n * (n_ctrl * sub + 1) * control_loop.ROW_COLS * 8 / 1e9:.1f} GB; pass "
            "record=False (summaries only; rollout(i) re-runs run i)"
        )
    run_many = control_loop.kernel_many(control_loop.loop_kind(opts, P))
    if not use_ctrl:
        ctrl = control_loop.no_control
    buf = control_loop.Buffers(n, n_ctrl * sub + 1, 64, record)
    threads = numba.config.NUMBA_NUM_THREADS
    evbuf, w, backup, cbuf = control_loop.scratch(threads, cargs.shape[1])
    _run_threaded(
        run_many,
        buf,
        S,
        P,
        opts,
        sched,
        ctrl,
        source,
        cargs,
        control_dt,
        t_end,
        n_ctrl,
        sub,
        record,
        evbuf,
        w,
        backup,
        cbuf,
    )
    result = _result(
        buf,
        S,
        targets,
        plist,
        record,
        dict(
            record=record,
            buffers=buf,
            S=S,
            controller=None if not use_ctrl else controller,
            schedules=None if use_ctrl else sched,
            initial=initial,
            cargs=cargs,
            seeds=key,
            rovers=rovers,
            kwargs=dict(
                t_end=t_end,
                control_dt=control_dt,
                integrator=integrator,
                impact_law=impact_law,
                euler_dt=euler_dt,
                rtol=rtol,
                sample_dt=sample_dt,
            ),
        ),
    )
    result.seed = (key.copy() if per_run else seed) if rough else None
    result.rovers = rovers
    return result


def _run_threaded(
    run_many,
    buf,
    S,
    P,
    opts,
    sched,
    ctrl,
    source,
    cargs,
    control_dt,
    t_end,
    n_ctrl,
    sub,
    record,
    evbuf,
    w,
    backup,
    cbuf,
) -> None:
    """Every run to its end on numba's threads, growing the event log and calling again
    for the runs that ran out of room in it; a run that failed raises (check_status)."""
    n = S.shape[0]
    active = np.ones(n, dtype=bool)
    # runs differ in cost (a rover at rest is cheap, a bouncing one is not) and costly
    # ones often sit together: numba's OpenMP and workqueue layers give each thread one
    # contiguous block of the loop, so the loop reads the runs in an order that spreads
    # every block over all of them (jit.spread); chunks of one run also let a layer that
    # hands out chunks dynamically (TBB) balance them (docs/SCALING.md, "Threads")
    order = spread_order(n)
    while True:
        chunk = numba.set_parallel_chunksize(1)
        try:
            run_threaded(
                run_many,
                S,
                P,
                opts,
                sched,
                ctrl,
                source,
                cargs,
                control_dt,
                t_end,
                n_ctrl,
                sub,
                record,
                buf.rows,
                buf.cmds,
                buf.applied,
                buf.log,
                buf.prog,
                active,
                evbuf,
                w,
                backup,
                cbuf,
                order,
            )
        finally:
            numba.set_parallel_chunksize(chunk)
        status = buf.prog[:, control_loop.G_STATUS]
        for i in np.flatnonzero(
            active & (status != control_loop.ST_DONE) & (status != control_loop.ST_ROOM)
        ):
            rollout.check_status(buf.prog[i], S[i], f"run {i}: ")
        active = status == control_loop.ST_ROOM
        if not active.any():
            break
        buf.grow_log()


_PAD_LETTERS = np.array(list(core.MODE_LETTERS) + [""])


def _result(buf, S, targets, plist, record, run) -> BatchRollout:
    n = len(targets)
    n_samples = (
        buf.prog[:, control_loop.G_ROWS].astype(np.int64) if record else np.zeros(n, np.int64)
    )
    rows = buf.rows if record else np.zeros((n, 0, control_loop.ROW_COLS))
    pad = np.arange(rows.shape[1])[None, :] >= n_samples[:, None]

    if record:  # unused rows become padding, in place (no copies)
        buf.rows[pad] = np.nan
        buf.cmds[pad] = np.nan
        buf.applied[pad] = np.nan

    def column(c):
        return rows[:, :, c]

    def torque(a):
        return a if record else np.zeros((n, 0))

    modes = np.where(pad, 7, rows[:, :, core.S_MODE]).astype(np.int64)
    return BatchRollout(
        targets=targets,
        params=plist,
        ttrtp=S[:, core.S_TTRTP].copy(),
        broken=S[:, core.S_BROKEN] != 0.0,
        n_events=S[:, core.S_NEVENTS].astype(np.int64),
        n_impacts=S[:, core.S_NIMPACT].astype(np.int64),
        final=S[:, : core.S_T + 1].copy(),
        n_samples=n_samples,
        t=column(core.S_T),
        x=column(core.S_X),
        y=column(core.S_Y),
        theta=column(core.S_TH),
        vx=column(core.S_VX),
        vy=column(core.S_VY),
        omega=column(core.S_W),
        sigma=column(core.S_SIGMA),
        state=_PAD_LETTERS[modes],
        torque=torque(buf.applied),
        torque_cmd=torque(buf.cmds),
        event_log=buf.log,
        n_logged=buf.prog[:, control_loop.G_LOG].astype(np.int64),
        _run=run,
    )
