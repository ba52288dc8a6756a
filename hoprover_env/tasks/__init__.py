"""The RL tasks over the physics core: what an action does, what a step returns.

=================  ==================================================================
``common``         the written interface (`TaskSpec`), the opening and end of every
                   step (`open_step`, `close_step`), the batched loops, `build`
``config``         `EnvConfig`, the arguments every task shares
``draws``          the episode draws (counter-based, keyed by seed and episode)
``options``        the reset options, checked in one place; a task's start options
``layout``         the shared slots of the task configuration vector E
``observation``    the observation vector (one slot each), observe, the reference and
                   landing points the observation and the reward share
``reward``         the reward: its parameters, the potential it keeps, the terms it pays
``torque``         the torque task: action -> torque held for one control period
``torque_rl``      the torque task's RL settings, v1: an observation that resolves the
                   reward, a per-decision attitude cost, flight starts for training
``hop``            the hop-level task: action -> one hop flown by a built-in controller
``terrain``        the torque task on sloped, rough ground: the observation plus the slope
``mission``        the torque task under mission conditions: noisy sensing, position
                   fixes only at rest, unknown ground, an actuator scale error
=================  ==================================================================

A task is one module. It holds its env's documentation (its docstring: the tables of a
Gymnasium env), its config dataclass (with the fields its kernels read, its
``kernel_fields``, and the reward options it reads), the named slots of those fields in
E, its step template and observe, ``TASK = TaskSpec(...)`` and ``REGISTER``: the ids it
is registered under. Adding one to the package is that module, its name in
`TASK_MODULES` below and its two env classes written out in hoprover_env/envs/tasks.py;
gymnasium registers its ids when hoprover_env is imported. A module outside the package
registers itself instead (``hoprover_env.register_task(__name__)``, its last line).
docs/ARCHITECTURE.md walks through one.
"""

from __future__ import annotations

import dataclasses
import importlib

# Every registered task, by module: one line each.
TASK_MODULES = (
    "hoprover_env.tasks.torque",
    "hoprover_env.tasks.torque_rl",
    "hoprover_env.tasks.hop",
    "hoprover_env.tasks.terrain",
    "hoprover_env.tasks.mission",
)


@dataclasses.dataclass(frozen=True)
class Registration:
    """One registered id of a task: the `id` gym.make takes, the env arguments it fixes
    (`kwargs`), the frozen test suite it is scored on (`suite`,
    hoprover_env.evaluation.suites: "level", "terrain" or "contest"; None, the default:
    none, and scoring it on a suite is refused) and whether one action is a whole hop
    (`hops`) rather than a torque held over a control period."""

    id: str
    kwargs: dict = dataclasses.field(default_factory=dict)
    suite: str | None = None
    hops: bool = False


def task_module(name: str):
    """The task module `name` (a dotted path), checked for what a task module defines:
    TASK (a TaskSpec) and REGISTER (Registrations). TypeError names what is missing."""
    from hoprover_env.tasks.common import TaskSpec

    module = importlib.import_module(name)
    if not isinstance(getattr(module, "TASK", None), TaskSpec):
        raise TypeError(f"task module {name} defines no TASK = TaskSpec(...)")
    register = getattr(module, "REGISTER", None)
    if not (
        isinstance(register, tuple)
        and register
        and all(isinstance(r, Registration) for r in register)
    ):
        raise TypeError(f"task module {name} defines no REGISTER = (Registration(...), ...)")
    return module
