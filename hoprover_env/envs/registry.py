"""Every registered task's env classes and ids.

A task module (hoprover_env/tasks/*.py, listed in hoprover_env.tasks.TASK_MODULES) says
what the env does; its two classes are a subclass of HopRoverEnv and one of
HopRoverVectorEnv with ``task = TASK``, written out in hoprover_env/envs/tasks.py for
the package's tasks (the torque task's are HopRoverEnv and HopRoverVectorEnv
themselves). `ENVS` maps every id to its `Task` entry; hoprover_env/__init__.py
registers them with gymnasium.

A task module outside hoprover_env (an experiment's own task) registers itself: it
ends with ``hoprover_env.register_task(__name__)``, so that importing it registers its
ids with gymnasium (``gym.make("my_module:MyTask-v0")`` imports it first, Gymnasium's
``module:id`` convention). Its classes are its own where it defines them (subclasses of
HopRoverEnv and HopRoverVectorEnv with its TASK), else made here and stored in the task
module, named after its first id ("HopRoverTip-v0" -> HopRoverTipEnv,
HopRoverTipVectorEnv), so that they import and pickle by name. An installed package of
tasks names its task modules in the entry-point group ``hoprover.tasks`` (its
pyproject's ``[project.entry-points."hoprover.tasks"]``, ``name = "package.module"``):
importing hoprover_env registers each (`register_installed`).
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import warnings

import gymnasium as gym
from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.tasks import (  # noqa: F401 (the classes, importable from here too)
    CLASSES,
    HopRoverHopEnv,
    HopRoverHopVectorEnv,
    HopRoverMissionEnv,
    HopRoverMissionVectorEnv,
    HopRoverRLEnv,
    HopRoverRLVectorEnv,
    HopRoverTerrainEnv,
    HopRoverTerrainVectorEnv,
)
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.tasks import TASK_MODULES, task_module

ENTRY_POINT_GROUP = "hoprover.tasks"  # installed task modules (register_installed)


@dataclasses.dataclass(frozen=True)
class Task:
    """A registered id: where its env classes live, what the id fixes, and what the
    drivers need to know of it, so that nothing compares an id as a string. `env` and
    `vector_env` are "module:Class" entry points; `kwargs` are the env arguments the id
    fixes; `suite` names its frozen test suite (hoprover_env.evaluation.suites; None: the
    task is scored on none); `hops` says whether one action is a whole hop (its launch
    torque) rather than a torque held over a control period; `module` is the task
    module."""

    env: str
    vector_env: str
    kwargs: dict = dataclasses.field(default_factory=dict)
    suite: str | None = None
    hops: bool = False
    module: str = "hoprover_env.tasks.torque"


ENVS: dict[str, Task] = {}


def class_names(env_id: str) -> tuple[str, str]:
    """The env and vector env class names of an id: "HopRoverHop-v0" -> (HopRoverHopEnv,
    HopRoverHopVectorEnv)."""
    stem = env_id.split("-v")[0].replace("-", "")
    return f"{stem}Env", f"{stem}VectorEnv"


def _own_classes(module) -> tuple[type | None, type | None]:
    """The env and vector env classes a task module defines itself (with its TASK), or
    None for each it does not."""
    env_cls = vec_cls = None
    for value in vars(module).values():
        if isinstance(value, type) and getattr(value, "task", None) is module.TASK:
            if issubclass(value, HopRoverVectorEnv) and vec_cls is None:
                vec_cls = value
            elif issubclass(value, HopRoverEnv) and env_cls is None:
                env_cls = value
    return env_cls, vec_cls


def classes_of(module) -> tuple[type, type]:
    """The env and vector env classes of a task module: the package's, written out in
    hoprover_env/envs/tasks.py; a module's own; else made here and stored as attributes
    of the task module (so that they import and pickle by name)."""
    if module.__name__ in CLASSES:
        return CLASSES[module.__name__]
    env_cls, vec_cls = _own_classes(module)
    env_name, vec_name = class_names(module.REGISTER[0].id)
    if env_cls is None:
        title = (module.__doc__ or env_name).strip().splitlines()[0]
        doc = (
            f"{title}\n\n{env_name}: HopRoverEnv with the task of {module.__name__}, "
            f"whose module docstring has the env's tables (spaces, rewards, episode, "
            f"arguments)."
        )
        env_cls = type(
            env_name,
            (HopRoverEnv,),
            {"task": module.TASK, "__doc__": doc, "__module__": module.__name__},
        )
        setattr(module, env_name, env_cls)
    if vec_cls is None:
        # VectorEnv named again (already a base): skrl's wrap_env recognises a Gymnasium
        # env by its class's direct bases
        vec_cls = type(
            vec_name,
            (HopRoverVectorEnv, VectorEnv),
            {
                "task": module.TASK,
                "__module__": module.__name__,
                "__doc__": f"N {env_cls.__name__} rovers stepped in one jitted call; sub-env i "
                f"equals {env_cls.__name__} seeded with seed + i. The task: "
                f"{module.__name__}.",
            },
        )
        setattr(module, vec_name, vec_cls)
    return env_cls, vec_cls


def add_task(name: str) -> list[str]:
    """Find the classes of the task module `name` and enter its ids in ENVS (not yet
    registered with gymnasium). Returns the ids."""
    module = task_module(name)
    env_cls, vec_cls = classes_of(module)
    ids = []
    for reg in module.REGISTER:
        ENVS[reg.id] = Task(
            f"{env_cls.__module__}:{env_cls.__name__}",
            f"{vec_cls.__module__}:{vec_cls.__name__}",
            dict(reg.kwargs),
            reg.suite,
            reg.hops,
            module.__name__,
        )
        ids.append(reg.id)
    return ids


def gym_register(env_id: str) -> None:
    """Register one id of ENVS with gymnasium (nothing if it already is)."""
    entry = ENVS[env_id]
    if env_id not in gym.registry:
        gym.register(
            id=env_id,
            entry_point=entry.env,
            vector_entry_point=entry.vector_env,
            kwargs=entry.kwargs,
        )


def register_task(name: str) -> list[str]:
    """Register a task module (a dotted module path that defines TASK and REGISTER, as
    hoprover_env/tasks/torque.py does): its env classes are found or made and its ids
    entered in ENVS and registered with gymnasium. Returns the ids. A task module calls
    it at its bottom, ``register_task(__name__)``, to register itself when imported;
    calling it again for the same module changes nothing."""
    ids = add_task(name)
    for env_id in ids:
        gym_register(env_id)
    return ids


def register_installed() -> list[str]:
    """Register the task modules installed packages name in the entry-point group
    ``hoprover.tasks`` (each entry's value a module path, "package.module"). A module
    that fails to import or is no task module is skipped with a RuntimeWarning that
    names it, so that one broken package does not stop hoprover_env from importing.
    Returns the ids registered."""
    ids: list[str] = []
    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        module = entry.value.split(":")[0].strip()
        try:
            ids += register_task(module)
        except Exception as exc:  # noqa: BLE001 - another package's fault, reported
            warnings.warn(
                f"hoprover_env: the task module {module!r} (entry point "
                f"{entry.name!r} of group {ENTRY_POINT_GROUP!r}) was not "
                f"registered: {type(exc).__name__}: {exc}",
                RuntimeWarning,
                stacklevel=2,
            )
    return ids


def task(env_id: str) -> Task:
    """The registry entry of a hoprover id (ValueError naming an unknown id)."""
    if env_id not in ENVS:
        raise ValueError(f"unknown hoprover env id {env_id!r}; valid: {sorted(ENVS)}")
    return ENVS[env_id]


def _load(entry: str):
    module, name = entry.split(":")
    return getattr(importlib.import_module(module), name)


def env_class(env_id: str):
    """The single env class of a registered hoprover id (ValueError for an unknown id)."""
    return _load(task(env_id).env)


def vector_env_class(env_id: str):
    """The native vector env class of a registered hoprover id (ValueError for an
    unknown id)."""
    return _load(task(env_id).vector_env)


def config_class(env_id: str):
    """The config dataclass of a registered hoprover id (the task module's): the env
    arguments a YAML's `env:` section may set."""
    return env_class(env_id).task.config


def default_config(env_id: str):
    """The config of a registered id with no further arguments: its task's defaults and
    what the id fixes (its Registration's kwargs)."""
    return config_class(env_id)(**task(env_id).kwargs)


for _name in TASK_MODULES:
    add_task(_name)


# The goal-conditioned variant of HopRoverRL-v1 for hindsight replay (a Dict observation,
# so an env of its own rather than a task module's: hoprover_env/envs/goal.py)
GOAL_ENVS = {"HopRoverGoal-v1": "hoprover_env.envs.goal:HopRoverGoalEnv"}
for _goal_id, _entry in GOAL_ENVS.items():
    if _goal_id not in gym.registry:
        gym.register(id=_goal_id, entry_point=_entry)
