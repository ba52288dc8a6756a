"""What every task shares: the end of a step (judge outcome, reward, observation) and
the batched loops over the rovers of a vector env, written once.

A task is one jitted step function with the signature

    step(S, P, O, E, RW, RM, action, obs, ev, W) -> (reward, terminated, truncated,
                                                     success, n_events)

on one rover's rows (state S, parameters P, reward memory RM, observation obs) and the
env's shared vectors (options O, task config E, reward parameters RW). Its module
writes it once as a template that calls ``ADVANCE`` (the integrator) and hands it to
`build`, which makes, for each integrator, the step and the serial and threaded batch
loops over it: one source for every task and integrator, compiled separately (numba
fixes a callee at compile time), so that a default env compiles no Euler code. A step
ends with ``OBSERVE(S, P, E, obs)``, bound by `build` to the task's observation.
"""
import math
import types

from numba import get_thread_id, prange, types as nt

from .._compile import kernel, BOOL, F64, VEC
from .. import core
from ..core.layout import S_BROKEN, S_ERROR, S_T, S_TTRTP
from .. import reward
from .layout import E_T_TOTAL
from .observation import observe as default_observe

INTEGRATORS = {"event": core.advance_event, "euler": core.advance}


@kernel(inner=True)
def first_bad_action(actions, active):
    """Index of the first active non-finite action, or -1: checked before any rover moves."""
    for i in range(actions.shape[0]):
        if active[i] and not math.isfinite(actions[i]):
            return i
    return -1


@kernel(BOOL(VEC, BOOL), inner=True)
def episode_ended(S, had_ttrtp):
    """The judge's TTRTP was reached in this step, or the rover broke (or the kernel
    stopped on an error, which ends the episode as broken)."""
    return ((not had_ttrtp) and not math.isnan(S[S_TTRTP])) or S[S_BROKEN] != 0.0 \
        or S[S_ERROR] != 0.0


@kernel(nt.Tuple((F64, BOOL, BOOL, BOOL))(VEC, VEC, VEC, VEC, VEC, F64, BOOL, F64),
        inner=True)
def finish(S, P, E, RW, RM, phi0, had_ttrtp, elapsed):
    """Reward and outcome after the rover moved for `elapsed` seconds from a state of
    potential phi0. Returns (reward, terminated, truncated, success): success or a break
    terminate, the episode's clock truncates."""
    success = (not had_ttrtp) and not math.isnan(S[S_TTRTP])
    broken = S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0
    terminated = success or broken
    truncated = (not terminated) and S[S_T] >= E[E_T_TOTAL]
    r = reward.pay(S, P, RW, RM, phi0, success, broken, elapsed)
    return r, terminated, truncated, success


# The loop templates: STEP is bound by `build`.
def batch_serial(S, P, O, E, RW, RM, actions, active, obs, rew, term, trunc, succ, nev, ev,
                 W):
    """STEP over the rows where `active` is set, one after the other. Returns the index of
    a non-finite action (nothing stepped) or -1."""
    bad = first_bad_action(actions, active)
    if bad >= 0:
        return bad
    w = W[0]
    for i in range(S.shape[0]):
        if active[i]:
            rew[i], term[i], trunc[i], succ[i], nev[i] = STEP(  # noqa: F821 (bound by build)
                S[i], P[i], O, E, RW, RM[i], actions[i], obs[i], ev, w)
    return -1


def batch_threaded(Sb, Pb, Ob, Eb, RWb, RMb, actionsb, activeb, obsb, rewb, termb, truncb,
                   succb, nevb, evb, Wb):
    """STEP over the active rows, spread over numba's threads; each thread uses its own
    workspace row W[thread id]. Returns as batch_serial. (Argument names differ from
    batch_serial's: numba's parfor outlining clashes on shared names.)"""
    bad = first_bad_action(actionsb, activeb)
    if bad >= 0:
        return bad
    for i in prange(Sb.shape[0]):
        if activeb[i]:
            rewb[i], termb[i], truncb[i], succb[i], nevb[i] = STEP(  # noqa: F821
                Sb[i], Pb[i], Ob, Eb, RWb, RMb[i], actionsb[i], obsb[i], evb,
                Wb[get_thread_id()])
    return -1


class TaskKernels(types.SimpleNamespace):
    """The compiled pieces of a task for one integrator: `step` (one rover, the single
    env), `batch` and `batch_threaded` (the vector env)."""


def _bind(template, name: str, **names):
    """`template` with some global names bound, as a new function called `name`. numba
    resolves globals when it compiles and caches a function under its qualified name,
    so each binding is compiled and cached on its own."""
    func = types.FunctionType(template.__code__, {**template.__globals__, **names}, name,
                              template.__defaults__)
    func.__qualname__ = name
    func.__doc__ = template.__doc__
    return func


def build(task: str, step_template, observe=default_observe) -> dict:
    """{integrator: TaskKernels} for a task's step template (which calls ADVANCE and
    OBSERVE) and its observation function (tasks/observation.py `observe` by default)."""
    out = {}
    for integrator, advance in INTEGRATORS.items():
        step = kernel(_bind(step_template, f"{task}_step_{integrator}", ADVANCE=advance,
                            OBSERVE=observe))
        out[integrator] = TaskKernels(
            step=step,
            batch=kernel(_bind(batch_serial, f"{task}_batch_{integrator}", STEP=step)),
            batch_threaded=kernel(parallel=True)(
                _bind(batch_threaded, f"{task}_batch_threaded_{integrator}", STEP=step)))
    return out
