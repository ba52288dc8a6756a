"""The written interface of a task, and what every task shares: the opening and the end
of a step (judge outcome, reward), the batched loops over the rovers of a vector env,
and `build`, which compiles them for each integrator.

A task is a `TaskSpec` (below): its config class, its observation (a jitted
``observe(S, P, E, M, obs)`` and its bounds), its action size, its per-rover memory,
and one step template

    step(S, P, O, E, RW, RM, M, action, ev, W) -> (reward, terminated, truncated,
                                                   success, n_events)

on one rover's rows (state S, parameters P, reward memory RM, task memory M, action, a
float64 row of `action_dim`) and the env's shared vectors (options O, task config E,
reward parameters RW). A step template opens with `open_step`, moves the rover with
``ADVANCE(S, P, O, torque, t_end, ev, W)`` (the integrator), charges the reward with
every torque it held (`reward.charge`) and ends with `close_step`; its observation is
written after it by the compiled step (`build`). ``ADVANCE`` and any other name in
`TaskSpec.holes` are placeholders that `build` binds at compile time (numba fixes a
callee when it compiles), so that one source serves every integrator and a default env
compiles no Euler code.
"""

from __future__ import annotations

import dataclasses
import math
import types
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import get_thread_id, prange
from numba import types as nt

from hoprover_env import core
from hoprover_env.core.layout import S_BROKEN, S_ERROR, S_MODE, S_NEVENTS, S_T, S_TTRTP
from hoprover_env.jit.compiler import BOOL, F64, I64, VEC, bind, kernel
from hoprover_env.tasks import reward
from hoprover_env.tasks.layout import E_T_TOTAL
from hoprover_env.tasks.options import StartOption

if TYPE_CHECKING:
    from hoprover_env.tasks.config import EnvConfig

TTRTP_NOT_REACHED = -1.0  # info["ttrtp"] before the target is reached

INTEGRATORS = {"event": core.advance_event, "euler": core.advance}
# on smooth ground (roughness 0) the event integrator without rough-terrain code
SMOOTH_INTEGRATORS = {"event": core.smooth.advance_event_smooth}


def ADVANCE(S, P, O, torque, t_end, ev, W):
    """Placeholder in a step template: the integrator, bound by `build`. Moves the rover
    with `torque` held until t_end (or an end of the episode's physics)."""
    raise NotImplementedError("ADVANCE is bound by tasks.common.build")


def _STEP(S, P, O, E, RW, RM, M, action, ev, W):
    """Placeholder in the loops below: the task's step template, bound by `build`."""
    raise NotImplementedError("_STEP is bound by tasks.common.build")


def _OBSERVE(S, P, E, M, obs):
    """Placeholder in the loops below: the task's observe, bound by `build`."""
    raise NotImplementedError("_OBSERVE is bound by tasks.common.build")


@dataclasses.dataclass(frozen=True, eq=False)
class TaskSpec:
    """What a task is, all an env needs of it. One per task module, named ``TASK``.

    ==================  ==============================================================
    ``name``            prefix of its compiled functions (numba caches them by name)
    ``config``          its EnvConfig subclass: arguments, the vector E, episode draws
    ``step``            the step template (the module docstring has its contract)
    ``observe``         jitted ``observe(S, P, E, M, obs)``: writes the float32
                        observation; may update the task memory M (a sensor's state)
    ``obs_low/high``    the observation's bounds (float32 arrays)
    ``obs_bounds``      ``f(config) -> (low, high)`` when the config sizes the
                        observation (None: obs_low/high)
    ``action_dim``      the action's size: Box(-1, 1, (action_dim,))
    ``memory``          slots of per-rover task memory M (0: none)
    ``reset_memory``    ``f(config, U, S, P, M)`` at every reset, on the rows of the
                        rovers reset (2-D: S, P and M, which it fills, one row per
                        rover; M is zeroed before), after the episode's draws; U holds
                        ``reset_draws`` uniforms in [0, 1) per rover, drawn from the
                        rover's (seed, episode) (tasks/draws.py). None: M is zeroed.
                        A task with start options gets a sixth argument, ``fixed``:
                        the start options given, name -> (n,) values, which replace
                        what its uniforms would draw
    ``reset_draws``     how many uniforms reset_memory takes per rover
    ``start_options``   the reset options of the task's own (tasks/options.py
                        `StartOption`): what reset_memory draws, given instead, so that
                        an env can be started in a frozen episode (a test suite's)
    ``action_torque``   ``f(action, P, E) -> torque`` [N m], callable from Python: the
                        torque one action component commands (a hop task's: the hop's
                        launch torque), for replays of an episode's actions
    ``torque_action``   ``f(torque, params, config) -> action``: its inverse, clipped to
                        [-1, 1], for a controller that commands torques (None: the
                        task's action is no torque held over a control period)
    ``holes``           further placeholders of the step template and their kernels
    ``hidden_info``     ``f(M) -> dict``: what info_level="full" adds of the task memory
                        (a task that hides state from the policy shows it here)
    ``compile_extra``   declared kernels the parallel-compile helper builds on a cold
                        cache (module-level: it finds them by module and name)
    ==================  ==============================================================
    """

    name: str
    config: type[EnvConfig]
    step: Callable
    observe: Any
    obs_low: np.ndarray
    obs_high: np.ndarray
    action_dim: int = 1
    memory: int = 0
    reset_memory: Callable | None = None
    reset_draws: int = 0
    start_options: tuple[StartOption, ...] = ()
    action_torque: Callable | None = None
    torque_action: Callable | None = None
    holes: dict = dataclasses.field(default_factory=dict)
    hidden_info: Callable | None = None
    obs_bounds: Callable | None = None
    compile_extra: tuple = ()

    def __post_init__(self):
        if self.start_options and self.reset_memory is None:
            raise ValueError(
                f"task {self.name!r}: start_options fix what reset_memory draws; it has none"
            )

    def kernels(self, integrator: str, rough: bool = True) -> TaskKernels:
        """The compiled step and batch loops for `integrator` ("event" or "euler"),
        built once per task, integrator and ground: `rough` False gives the build that
        compiles no rough-terrain code (core/smooth.py), for rovers on smooth ground
        only; the general build (True) is exact on any ground."""
        cache = _BUILT.setdefault(id(self), {})
        key = (integrator, bool(rough) or integrator not in SMOOTH_INTEGRATORS)
        if key not in cache:
            cache[key] = build(self, *key)
        return cache[key]

    def bounds(self, config) -> tuple[np.ndarray, np.ndarray]:
        """The observation's (low, high) under `config`."""
        if self.obs_bounds is None:
            return self.obs_low, self.obs_high
        return self.obs_bounds(config)

    @property
    def memory_width(self) -> int:
        """Columns of the task memory array (at least 1: numba wants one array type)."""
        return max(self.memory, 1)

    def new_memory(self, n: int | None = None) -> np.ndarray:
        return np.zeros(self.memory_width if n is None else (n, self.memory_width))

    def start_rows(self, config, U, S, P, M, fixed: dict | None = None) -> None:
        """Fill the task memory M of the rovers reset (2-D rows, one per rover) from
        their uniforms U (n, reset_draws) and the start options given (`fixed`)."""
        M[:] = 0.0
        if self.reset_memory is None:
            return
        if self.start_options:
            self.reset_memory(config, U, S, P, M, dict(fixed or {}))
        else:
            self.reset_memory(config, U, S, P, M)

    def observer(self):
        """A compiled loop of the task's observe over some rows:
        ``f(S, P, E, M, obs, rows)``, built once per task."""
        cache = _BUILT.setdefault(id(self), {})
        if "observe_rows" not in cache:
            cache["observe_rows"] = bind(
                observe_rows, f"{self.name}_observe_rows", _OBSERVE=self.observe
            )
        return cache["observe_rows"]


_BUILT: dict = {}


@kernel(inner=True)
def first_bad_action(actions, active):
    """Index of the first active row with a non-finite action, or -1: checked before any
    rover moves."""
    for i in range(actions.shape[0]):
        if active[i]:
            for j in range(actions.shape[1]):
                if not math.isfinite(actions[i, j]):
                    return i
    return -1


@kernel(BOOL(VEC, BOOL), inner=True)
def episode_ended(S, had_ttrtp):
    """The judge's TTRTP was reached in this step, or the rover broke (or the kernel
    stopped on an error, which ends the episode as broken)."""
    return (
        ((not had_ttrtp) and not math.isnan(S[S_TTRTP])) or S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0
    )


@kernel(nt.Tuple((F64, BOOL, F64, F64))(VEC, VEC, VEC, VEC), inner=True)
def open_step(S, P, RW, RM):
    """What a step records before the rover moves: (the potential, whether TTRTP was
    already reached, the time, the event count)."""
    phi0 = reward.begin(S, P, RW, RM)
    return phi0, not math.isnan(S[S_TTRTP]), S[S_T], S[S_NEVENTS]


@kernel(
    nt.Tuple((F64, BOOL, BOOL, BOOL, nt.int64))(VEC, VEC, VEC, VEC, VEC, F64, BOOL, F64, F64),
    inner=True,
)
def close_step(S, P, E, RW, RM, phi0, had_ttrtp, t0, nev0):
    """Reward and outcome of a step opened at (phi0, had_ttrtp, t0, nev0): (reward,
    terminated, truncated, success, events located). Success or a break terminate, the
    episode's clock truncates."""
    success = (not had_ttrtp) and not math.isnan(S[S_TTRTP])
    broken = S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0  # episode_ended's two parts
    terminated = success or broken
    truncated = (not terminated) and S[S_T] >= E[E_T_TOTAL]
    r = reward.pay(S, P, RW, RM, phi0, success, broken, S[S_T] - t0)
    return r, terminated, truncated, success, int(S[S_NEVENTS] - nev0)


# The compiled step and the loop templates: _STEP and _OBSERVE are bound by `build`.
def step_and_observe(S, P, O, E, RW, RM, M, action, obs, ev, W):
    """The task's step, then its observation of where the rover ended."""
    out = _STEP(S, P, O, E, RW, RM, M, action, ev, W)
    _OBSERVE(S, P, E, M, obs)
    return out


def observe_rows(S, P, E, M, obs, rows):
    """The task's observation of the rovers in `rows` (their indices)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        _OBSERVE(S[i], P[i], E, M[i], obs[i])


# The vector env's per-rover outputs besides the step's own, written by the loops below
# while the rover's rows are in the cache of the thread that stepped it: reading the
# state rows' info slots afterwards, across all the rows, cost about half of the
# vector env's Python per step (docs/SCALING.md, "Threads on one machine").
BOOL_COL, I64_COL = nt.boolean[::1], nt.int64[::1]


@kernel(nt.void(VEC, I64, VEC, BOOL_COL, I64_COL, BOOL_COL), inner=True)
def note_info(S, i, ttrtp, reached, mode, broken):
    """Rover i's info columns from its state row S: the TTRTP (TTRTP_NOT_REACHED before
    it is reached), whether it is reached, the contact state code, whether it broke."""
    t = S[S_TTRTP]
    reached[i] = not math.isnan(t)
    ttrtp[i] = t if reached[i] else TTRTP_NOT_REACHED
    mode[i] = np.int64(S[S_MODE])
    broken[i] = S[S_BROKEN] != 0.0


@kernel(nt.void(nt.float64[:, ::1], I64_COL, VEC, BOOL_COL, I64_COL, BOOL_COL))
def note_info_rows(S, rows, ttrtp, reached, mode, broken):
    """note_info of the rovers in `rows` (their indices): rows reset outside the loops."""
    for j in range(rows.shape[0]):
        note_info(S[rows[j]], rows[j], ttrtp, reached, mode, broken)


@kernel(
    nt.void(I64, VEC, BOOL_COL, BOOL_COL, I64_COL, I64, BOOL_COL, VEC, BOOL_COL, I64_COL, BOOL_COL),
    inner=True,
)
def close_row(i, S, term, trunc, steps, max_steps, ended, ttrtp, reached, mode, broken):
    """After rover i's step: its episode's step count, the truncation at max_steps steps
    (0: no limit; a terminated episode is not truncated), whether its episode ended, and
    its info columns (note_info)."""
    steps[i] += 1
    if max_steps > 0 and steps[i] >= max_steps and not term[i]:
        trunc[i] = True
    ended[i] = term[i] or trunc[i]
    note_info(S, i, ttrtp, reached, mode, broken)


@kernel(nt.void(I64, VEC, BOOL_COL, BOOL_COL, I64_COL, BOOL_COL), inner=True)
def idle_row(i, rew, term, trunc, nev, ended):
    """Rover i was not stepped (its reset was this step, NextStep): no reward, no end,
    no events. Its info columns were written at its reset."""
    rew[i] = 0.0
    term[i] = False
    trunc[i] = False
    nev[i] = 0
    ended[i] = False


def batch_serial(
    S,
    P,
    O,
    E,
    RW,
    RM,
    M,
    actions,
    active,
    obs,
    rew,
    term,
    trunc,
    succ,
    nev,
    ev,
    W,
    steps,
    max_steps,
    ended,
    ttrtp,
    reached,
    mode,
    broken,
):
    """The step over the rows where `active` is set, one after the other, each followed
    by close_row (the other rows: idle_row). Returns the index of a non-finite action
    (nothing stepped or written) or -1."""
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    w = W[0]
    for i in range(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = _STEP(
                S[i], P[i], O, E, RW, RM[i], M[i], actions[i], ev, w
            )
            _OBSERVE(S[i], P[i], E, M[i], obs[i])
            close_row(i, S[i], term, trunc, steps, max_steps, ended, ttrtp, reached, mode, broken)
        else:
            idle_row(i, rew, term, trunc, nev, ended)
    return -1


def batch_threaded(
    Sb,
    Pb,
    Ob,
    Eb,
    RWb,
    RMb,
    Mb,
    actionsb,
    activeb,
    obsb,
    rewb,
    termb,
    truncb,
    succb,
    nevb,
    evb,
    Wb,
    stepsb,
    max_stepsb,
    endedb,
    ttrtpb,
    reachedb,
    modeb,
    brokenb,
    orderb,
):
    """batch_serial spread over numba's threads; each thread uses its own workspace row
    W[thread id]. Iteration j steps row order[j] (a permutation,
    jit.spread.spread_order): numba gives each thread one contiguous range of
    iterations, and rovers of like cost sit together (those in flight, those whose
    episodes ended and wait inactive). Returns as batch_serial. (Argument names differ
    from batch_serial's: numba's parfor outlining clashes on shared names.)"""
    bad = first_bad_action(actionsb, activeb)
    if bad >= 0:
        return bad
    for j in prange(orderb.shape[0]):
        i = orderb[j]
        if activeb[i]:
            rewb[i], termb[i], truncb[i], succb[i], nevb[i] = _STEP(
                Sb[i], Pb[i], Ob, Eb, RWb, RMb[i], Mb[i], actionsb[i], evb, Wb[get_thread_id()]
            )
            _OBSERVE(Sb[i], Pb[i], Eb, Mb[i], obsb[i])
            close_row(
                i,
                Sb[i],
                termb,
                truncb,
                stepsb,
                max_stepsb,
                endedb,
                ttrtpb,
                reachedb,
                modeb,
                brokenb,
            )
        else:
            idle_row(i, rewb, termb, truncb, nevb, endedb)
    return -1


class TaskKernels(types.SimpleNamespace):
    """The compiled pieces of a task for one integrator: `step` (one rover, the single
    env: step_and_observe), `batch` and `batch_threaded` (the vector env)."""


def build(task: TaskSpec, integrator: str, rough: bool = True) -> TaskKernels:
    """The kernels of `task` for one integrator and ground (`TaskSpec.kernels`): its
    step template with ADVANCE (and its other holes) bound, followed by its observe,
    alone and in the two batch loops."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    name = f"{task.name}_{integrator}" + ("" if rough else "_smooth")
    advance = INTEGRATORS[integrator] if rough else SMOOTH_INTEGRATORS[integrator]
    # inlined into its three callers: numba then optimises one module per caller instead
    # of emitting the step's own library too (a shorter cold compile, the same bits)
    inner = bind(
        task.step, f"{name}_inner", dict(inner=True, inline=True), ADVANCE=advance, **task.holes
    )
    bound = dict(_STEP=inner, _OBSERVE=task.observe)
    # each named for what it embeds (jit.compiler.bind): an edited task compiles afresh
    return TaskKernels(
        step=bind(step_and_observe, f"{name}_step", **bound),
        batch=bind(batch_serial, f"{name}_batch", **bound),
        batch_threaded=bind(batch_threaded, f"{name}_batch_threaded", dict(parallel=True), **bound),
    )
