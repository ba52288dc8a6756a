"""The control loop of `simulate` and `simulate_batch`, compiled with the physics: one
whole run (`_run`) or N of them on numba's threads (`_run_many`), built per kind of run
on first use, and the arrays they write (rollout.py drives `simulate`'s run and builds
the `Rollout` it produces).

Every control instant, every sample (t, x, y, theta, vx, vy, omega, state, sigma, torque)
and every event is written into preallocated arrays by one jitted loop, `_run`, the only
control loop there is. A torque schedule or a numba-compiled controller runs a whole
run in one call, so a run costs what the kernel costs. A plain Python controller runs
through the same loop: at each control instant the loop returns to Python
(ST_NEED_COMMAND), `run_rollout` (rollout.py) calls the controller and the loop goes on where it
stopped, so the bookkeeping (sampling, the event log, t_end, errors) exists once and
every controller gets the same `Rollout` for the same torques, bit for bit.

Compiled controllers
--------------------
A controller compiled with ``numba.njit`` and the contest signature

    @numba.njit
    def control(pos, vel, the, omg, posT, t, smt, state_code):
        return torque

runs inside the same compiled loop. The arguments are those of the contest, as
`simulate` passes them to a Python controller, except the state: ``state_code`` is an
integer 0..6 for the contact states A..G (``"ABCDEFG"[state_code]``; 0 = flight, 5 = at
rest). ``pos``, ``vel`` and ``posT`` are float64 arrays of length 2 (copies: writing to
them does not touch the rover); ``the``, ``omg``, ``t`` and ``smt`` are floats. The
function must return a float. It is called through a function pointer, so the loop is
compiled (and cached) once for all controllers. A numba function cannot keep memory
between calls: the state, the time and ``posT`` are what it decides on.
`simulate_batch(..., controller_args=A)` appends row i of A to ``posT`` of run i
(``posT = (x_T, 0, A[i, 0], ...)``) so that one compiled controller can run N different
parameter sets (gains, launch torques) side by side.

Kernel layout
-------------
One run writes rows of the kernel state S[:9] = (x, y, theta, vx, vy, omega, t, mode,
sigma) taken before each advance, and the final state; the commanded and applied
torque per row; and the event log (t, kind, mode before, mode after, value). The event
log grows on demand: when the events of one advance do not fit, the run restores the
state it had before that advance and returns; the caller enlarges the log and calls
again, and the run continues where it stopped (same arithmetic, so the same result).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import get_thread_id, prange
from numba import types as nt
from numba.experimental.function_type import WrapperAddressProtocol
from numba.extending import is_jitted

from hoprover_env import core
from hoprover_env.core import integrator, smooth
from hoprover_env.core.params import P_ROUGH, P_TMAX, P_TMIN
from hoprover_env.jit.compiler import bind_globals, compile_now, kernel

ROW_COLS = core.S_SIGMA + 1  # x, y, theta, vx, vy, omega, t, mode, sigma
EV_CAP = core.MAX_EVENTS + 64  # events one advance may log (as RoverSim keeps)

# prog: where a run stands (float64 so one vector carries the held command too)
G_K, G_J, G_ROWS, G_LOG, G_STATUS, G_CMD, G_CMD_K = range(7)  # G_CMD_K: G_CMD's instant
N_PROG = 7
ST_RUNNING, ST_DONE, ST_ROOM, ST_BUDGET, ST_BAD_TORQUE, ST_NEED_COMMAND = range(6)
# who decides the torque at a control instant
CTRL_SCHEDULE, CTRL_COMPILED, CTRL_PYTHON = 0, 1, 2
POS_T = 4  # scratch: pos 0:2, vel 2:4, posT 4:6, args 6:

_V = nt.float64[::1]
_M = nt.float64[:, ::1]
_T3 = nt.float64[:, :, ::1]
_F = nt.float64
_I = nt.int64
_B = nt.boolean
CONTROL_SIG = _F(_V, _V, _F, _F, _V, _F, _F, _I)
CONTROL_TYPE = nt.FunctionType(CONTROL_SIG)


@kernel(nt.void(_V, _I, _I, _I, _I, _I), inner=True)
def _save_progress(prog, k, j, nr, nl, status):
    """Record where a run stands (control instant k, sub-step j, rows and log rows
    written) and why it returned, so that the next call goes on from there."""
    prog[G_K] = k
    prog[G_J] = j
    prog[G_ROWS] = nr
    prog[G_LOG] = nl
    prog[G_STATUS] = status


@kernel(inner=True)
def _contest_arguments(S, cargs, cbuf):
    """The contest controller's array arguments in cbuf: pos, vel, then posT = (x_T, 0)
    followed by this run's controller_args (layout at POS_T)."""
    cbuf[0] = S[core.S_X]
    cbuf[1] = S[core.S_Y]
    cbuf[2] = S[core.S_VX]
    cbuf[3] = S[core.S_VY]
    cbuf[POS_T] = S[core.S_XT]
    cbuf[POS_T + 1] = 0.0
    for a in range(cargs.shape[0]):
        cbuf[POS_T + 2 + a] = cargs[a]


@kernel(inner=True)
def _record_advance(rows, cmds, applied, log, nr, nl, before, cmd, app, evbuf, m):
    """Append one advance to a run's record: the state it started from (row nr), its
    commanded and applied torque, and its m events (log rows from nl on). Returns the
    new (nr, nl)."""
    for c in range(ROW_COLS):
        rows[nr, c] = before[c]
    cmds[nr] = cmd
    applied[nr] = app
    for e in range(m):
        for c in range(core.EV_COLS):
            log[nl, c] = evbuf[e, c]
        nl += 1
    return nr + 1, nl


def _no_control(pos, vel, the, omg, posT, t, smt, state_code):
    """Stands in for the controller argument of a scheduled run (never called)."""
    return 0.0


def _run(
    S,
    P,
    O,
    sched,
    ctrl,
    source,
    cargs,
    control_dt,
    t_end,
    n_ctrl,
    sub,
    record,
    rows,
    cmds,
    applied,
    log,
    prog,
    evbuf,
    W,
    backup,
    cbuf,
):
    """One run from prog[G_K], prog[G_J] on, with the torque from `source` (CTRL_*); see
    the module docstring."""
    k = int(prog[G_K])
    j = int(prog[G_J])
    nr = int(prog[G_ROWS])
    nl = int(prog[G_LOG])
    tmin = P[P_TMIN]
    tmax = P[P_TMAX]
    n_args = cargs.shape[0]
    while k < n_ctrl:
        t_k = k * control_dt
        t_next = (k + 1) * control_dt
        if t_end < t_next:
            t_next = t_end
        if j == 0 and prog[G_CMD_K] != k:
            if source == CTRL_PYTHON:
                _save_progress(prog, k, 0, nr, nl, ST_NEED_COMMAND)
                return
            if source == CTRL_COMPILED:
                _contest_arguments(S, cargs, cbuf)
                cmd = ctrl(
                    cbuf[0:2],
                    cbuf[2:4],
                    S[core.S_TH],
                    S[core.S_W],
                    cbuf[POS_T : POS_T + 2 + n_args],
                    S[core.S_T],
                    t_end,
                    int(S[core.S_MODE]),
                )
                if not math.isfinite(cmd):
                    prog[G_CMD] = cmd
                    prog[G_STATUS] = ST_BAD_TORQUE
                    return
            else:
                cmd = sched[k] if k < sched.shape[0] else 0.0
            prog[G_CMD] = cmd
            prog[G_CMD_K] = k
        cmd = prog[G_CMD]
        # Python's min(max(cmd, tmin), tmax), ties included
        app = tmin if tmin > cmd else cmd
        app = tmax if tmax < app else app
        while j < sub:
            if j == sub - 1:
                t_stop = t_next
            else:
                t_stop = t_k + (j + 1) * control_dt / sub
                if t_next < t_stop:
                    t_stop = t_next
            for c in range(core.N_STATE):
                backup[c] = S[c]
            S[core.S_STOP_ON] = -1.0
            n = advance(S, P, O, cmd, t_stop, evbuf, W)
            if (
                S[core.S_ERROR] == core.ERR_BUDGET
                or S[core.S_ERROR] == core.ERR_STEP
                or S[core.S_ERROR] == core.ERR_WORK
            ):
                prog[G_STATUS] = ST_BUDGET
                return
            m = n if n < evbuf.shape[0] else evbuf.shape[0]
            if record:
                if nl + m > log.shape[0]:
                    for c in range(core.N_STATE):
                        S[c] = backup[c]
                    _save_progress(prog, k, j, nr, nl, ST_ROOM)
                    return
                nr, nl = _record_advance(
                    rows, cmds, applied, log, nr, nl, backup, cmd, app, evbuf, m
                )
            j += 1
            if S[core.S_BROKEN] != 0.0:
                break
        if S[core.S_BROKEN] != 0.0:
            break
        j = 0
        k += 1
    if record:
        for c in range(ROW_COLS):
            rows[nr, c] = S[c]
        cmds[nr] = cmds[nr - 1]
        applied[nr] = applied[nr - 1]
        nr += 1
    _save_progress(prog, k, j, nr, nl, ST_DONE)


def _run_many(
    Sb,
    Pb,
    Ob,
    schedb,
    ctrlb,
    sourceb,
    cargsb,
    control_dtb,
    t_endb,
    n_ctrlb,
    subb,
    recordb,
    rowsb,
    cmdsb,
    appliedb,
    logb,
    progb,
    activeb,
    evbufb,
    Wb,
    backupb,
    cbufb,
    orderb,
):
    """`_run` over the rows where `active` is set, spread over numba's threads; each
    thread uses its own scratch rows (evbuf, W, backup, cbuf)[thread id]. Iteration j
    runs row order[j] (a permutation, jit.spread.spread_order): numba gives each thread
    one contiguous range of iterations, and runs of like cost often sit together (a
    population's candidates, rovers at rest), so rows read in their own order would
    leave one thread most of the work. (Argument names differ from `_run`'s: numba's
    parfor outlining clashes on shared names.)"""
    for j in prange(orderb.shape[0]):
        i = orderb[j]
        if activeb[i]:
            tid = get_thread_id()
            run_loop(
                Sb[i],
                Pb[i],
                Ob,
                schedb[i],
                ctrlb,
                sourceb,
                cargsb[i],
                control_dtb,
                t_endb,
                n_ctrlb,
                subb,
                recordb,
                rowsb[i],
                cmdsb[i],
                appliedb[i],
                logb[i],
                progb[i],
                evbufb[tid],
                Wb[tid],
                backupb[tid],
                cbufb[tid],
            )


_RUN_SIG = nt.void(
    _V, _V, _V, _V, CONTROL_TYPE, _I, _V, _F, _F, _I, _I, _B, _M, _V, _V, _M, _V, _M, _V, _V, _V
)
_RUN_MANY_SIG = nt.void(
    _M,
    _M,
    _V,
    _M,
    CONTROL_TYPE,
    _I,
    _M,
    _F,
    _F,
    _I,
    _I,
    _B,
    _T3,
    _M,
    _M,
    _T3,
    _M,
    nt.boolean[::1],
    _T3,
    _M,
    _M,
    _M,
    nt.int64[::1],
)
# Explicit signatures make the controller a function pointer (one compiled loop for every
# controller); they would also compile at import, so the loops are built on first use:
# most sessions (the environments) never need them.
#
# The loops come in three kinds, by what their runs need (`loop_kind`). numba compiles
# every function a kernel can reach, whichever branch runs, so one loop over
# `core.advance` would compile the Euler integrator and the rough-ground code (the
# terrain generator, the tilted impact) into every run: an event run on smooth ground,
# the common case, gets the smooth build of the event integrator (core/smooth.py), an
# event run on rough ground the general event integrator, an Euler run `core.advance`.
# Each kind is `_run` (and `_run_many` over it) with `advance` (`run_loop`) bound to its
# integrator, compiled and cached under its own name, `_run_<kind>` (`_run_many_<kind>`).
ADVANCE = {
    "event_smooth": smooth.advance_event_smooth,
    "event": integrator.advance_event,
    "euler": core.advance,
}
advance = core.advance  # what `_run` calls; each kind binds its own
run_loop = None  # what `_run_many` calls; each kind binds its own `_run`
run_one: dict = {}  # kind -> the one-run loop, compiled on first use
run_many: dict = {}  # kind -> the threaded N-run loop, compiled on first use
no_control = None


def loop_kind(O: np.ndarray, P: np.ndarray) -> str:
    """The kind of loop (a key of ADVANCE) that runs with options O and parameter rows
    P (one row, or one per run) need: "euler", "event" if any run is on rough ground,
    else "event_smooth". On smooth ground the smooth and the general build give the same
    bits (tests/core/test_smooth_build.py)."""
    if int(O[core.O_INTEGRATOR]) == core.INTEGRATOR_EULER:
        return "euler"
    return "event" if bool((np.asarray(P)[..., P_ROUGH] > 0.0).any()) else "event_smooth"


class _FixedAddress(WrapperAddressProtocol):
    """A compiled function passed by its address, looked up once: numba otherwise asks
    the dispatcher for it on every call (about 20 us, a few % of a whole run)."""

    def __init__(self, dispatcher):
        self.dispatcher = dispatcher  # keeps the code alive
        cres = dispatcher.get_compile_result(CONTROL_SIG)
        self.address = cres.library.get_pointer_to_function(cres.fndesc.llvm_cfunc_wrapper_name)

    def __wrapper_address__(self):
        return self.address

    def signature(self):
        return CONTROL_SIG


def _fixed_address(dispatcher):
    """The controller as `_FixedAddress`, or the dispatcher itself (numba then looks its
    address up per call) should a numba release move the internals that needs."""
    try:
        return _FixedAddress(dispatcher)
    except AttributeError as exc:  # an internal moved: the slower, public path
        warnings.warn(
            f"hoprover_env: numba's compile result has no {exc}; whole runs "
            "pass their controller the slower way",
            RuntimeWarning,
            stacklevel=2,
        )
        return dispatcher


def _compiled(func, signature, parallel=False):
    """func compiled by `kernel` for `signature` (or loaded from numba's cache) now;
    nothing else compiles later."""
    dispatcher = kernel(signature, parallel=parallel)(func)
    compile_now(dispatcher)
    if not dispatcher.overloads:  # kernel's plain-numba fallback keeps no signature
        dispatcher.compile(signature)
    dispatcher.disable_compile()
    return dispatcher


def control_stub():
    """The stand-in controller of scheduled and Python-controlled runs, compiled (or
    loaded from numba's cache) on first use."""
    global no_control
    if no_control is None:
        no_control = _fixed_address(_compiled(_no_control, CONTROL_SIG))
    return no_control


def kernel_one(kind: str = "euler"):
    """The one-run loop of `kind` (`loop_kind`; "euler" runs any options and ground),
    compiled (or loaded from numba's cache) on first use."""
    if kind not in run_one:
        control_stub()
        name = f"_run_{kind}"  # stored under it: a kernel pickles by reference
        loop = _compiled(bind_globals(_run, name, __name__, advance=ADVANCE[kind]), _RUN_SIG)
        run_one[kind] = globals()[name] = loop
    return run_one[kind]


def kernel_many(kind: str = "euler"):
    """The threaded N-run loop of `kind` (it calls the one-run loop), built on first use."""
    if kind not in run_many:
        name = f"_run_many_{kind}"
        loop = _compiled(
            bind_globals(_run_many, name, __name__, run_loop=kernel_one(kind)),
            _RUN_MANY_SIG,
            parallel=True,
        )
        run_many[kind] = globals()[name] = loop
    return run_many[kind]


def is_compiled(controller) -> bool:
    """Is `controller` a numba-compiled function (run inside the kernel loop)?"""
    return is_jitted(controller)


def control_function(controller):
    """The compiled controller checked against the contest signature (TypeError if it
    cannot take it)."""
    try:
        controller.compile(CONTROL_SIG)
    except Exception as exc:  # noqa: BLE001 - numba raises several error types
        raise TypeError(
            "a compiled controller must accept the contest signature (pos, vel, the, omg, "
            "posT, t, smt, state_code) with float64 arrays pos, vel, posT, floats the, "
            "omg, t, smt and an integer state_code 0..6, and return a float; compiling "
            f"{getattr(controller, '__name__', controller)!r} for it failed: "
            f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
        ) from None
    return controller


class Buffers:
    """The output arrays of N runs (leading axis N), the event log grown on demand."""

    def __init__(self, n: int, n_rows: int, log_rows: int, record: bool = True):
        rows = n_rows if record else 1
        self.rows = np.zeros((n, rows, ROW_COLS))
        self.cmds = np.zeros((n, rows))
        self.applied = np.zeros((n, rows))
        self.log = np.zeros((n, log_rows if record else 0, core.EV_COLS))
        self.prog = np.zeros((n, N_PROG))
        self.prog[:, G_CMD_K] = -1.0  # no command decided yet

    def grow_log(self) -> None:
        """Double the event log (at least EV_CAP more rows)."""
        n, cap, cols = self.log.shape
        new = np.zeros((n, max(2 * cap, cap + EV_CAP), cols))
        new[:, :cap] = self.log
        self.log = new


def scratch(threads: int, n_args: int):
    """Per-thread scratch: event buffer, kernel workspace, state backup, controller I/O."""
    return (
        np.zeros((threads, EV_CAP, core.EV_COLS)),
        np.zeros((threads, core.N_WORK)),
        np.zeros((threads, core.N_STATE)),
        np.zeros((threads, POS_T + 2 + n_args)),
    )
