"""The task configuration vector ``E`` shared by every rover of an env: the slots every
task reads, then the task's own (the reward's own parameters are in
hoprover_env/tasks/reward.py).

A task that needs parameters of its own (the hop task's controller gains, the mission
task's noise levels) names the fields of its config that go to the kernel, in its
config's ``kernel_fields`` (a ClassVar tuple of field names). Its slots follow the
shared ones, in that order, and its module names them with `task_slots` at import:

    SLOTS = task_slots(HopEnvConfig)      # SLOTS.hold_kp == 4, ...
    E_HOLD_KP = SLOTS.hold_kp             # a module-level int: numba folds it

EnvConfig.task_vector writes the vector (its length: N_SHARED plus the task's fields);
two tasks may use the same slots for different things, since each env has one task.
"""

from __future__ import annotations

import dataclasses
import types

E_CONTROL_DT = 0  # control period [s] (the hop task: its controller's period)
E_T_TOTAL = 1  # episode length [s]
E_ACTION_MAP = 2  # ACTION_LINEAR or ACTION_CUBIC (torque task)
E_ACTION_SCALE = 3  # fraction of the torque range reached at |a| = 1 (torque task)
N_SHARED = 4  # the shared slots; a task's own follow

ACTION_LINEAR, ACTION_CUBIC = 0, 1
ACTION_MAPS = {"linear": ACTION_LINEAR, "cubic": ACTION_CUBIC}


class TaskSlots(types.SimpleNamespace):
    """A task's own slots of E by field name (int attributes), `names` in slot order and
    `size`, the length of its vector E."""

    names: tuple[str, ...]
    size: int


def task_slots(config: type) -> TaskSlots:
    """The slots of E of a task config class's ``kernel_fields``, after the shared ones,
    in declared order. TypeError names a declared name that is not a field of the
    config, or one declared twice."""
    names = tuple(getattr(config, "kernel_fields", ()))
    fields = (
        {f.name for f in dataclasses.fields(config)} if dataclasses.is_dataclass(config) else set()
    )
    for name in names:
        if name not in fields:
            raise TypeError(
                f"{config.__name__}.kernel_fields names {name!r}, which is not one of its fields"
            )
    if {"names", "size"} & set(names):
        raise TypeError(
            f"{config.__name__}.kernel_fields may not name a field 'names' or "
            f"'size' (TaskSlots keeps its own there)"
        )
    if len(set(names)) != len(names):
        raise TypeError(f"{config.__name__}.kernel_fields names a field twice: {names}")
    return TaskSlots(
        **{name: N_SHARED + k for k, name in enumerate(names)},
        names=names,
        size=N_SHARED + len(names),
    )
