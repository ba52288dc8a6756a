"""Every registered task's env classes and ids, made from its task module.

A task module (hoprover_env/tasks/*.py, listed in hoprover_env.tasks.TASK_MODULES) says
what the env does; this module makes its two classes from it: a subclass of HopRoverEnv
and one of HopRoverVectorEnv with ``task = TASK`` (their docstrings point to the
module's, which has the env's tables), named after its first id ("HopRoverHop-v0" ->
HopRoverHopEnv, HopRoverHopVectorEnv). The torque task's classes are HopRoverEnv and
HopRoverVectorEnv themselves. `ENVS` maps every id to its `Task` entry;
hoprover_env/__init__.py registers them with gymnasium.

`register_task("package.module")` does the same for a task module outside hoprover_env
(an experiment's own task): its classes and ids, registered with gymnasium.
"""
from __future__ import annotations

import dataclasses
import sys

import gymnasium as gym
from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.tasks import TASK_MODULES, task_module


@dataclasses.dataclass(frozen=True)
class Task:
    """A registered id: where its env classes live, what the id fixes, and what the
    drivers need to know of it, so that nothing compares an id as a string. `env` and
    `vector_env` are "module:Class" entry points; `kwargs` are the env arguments the id
    fixes; `suite` names its frozen test suite (hoprover_env.evaluation.suites); `hops`
    says whether one action is a whole hop (its launch torque) rather than a torque held
    over a control period; `module` is the task module."""
    env: str
    vector_env: str
    kwargs: dict = dataclasses.field(default_factory=dict)
    suite: str = "level"
    hops: bool = False
    module: str = "hoprover_env.tasks.torque"


ENVS: dict[str, Task] = {}
_CLASSES: dict[str, type] = {}


def class_names(env_id: str) -> tuple[str, str]:
    """The env and vector env class names of an id: "HopRoverHop-v0" -> (HopRoverHopEnv,
    HopRoverHopVectorEnv)."""
    stem = env_id.split("-v")[0].replace("-", "")
    return f"{stem}Env", f"{stem}VectorEnv"


def make_classes(module) -> tuple[type, type]:
    """The env and vector env classes of a task module, stored as attributes of this
    module (so that they import and pickle by name)."""
    task = module.TASK
    if task is HopRoverEnv.task:
        return HopRoverEnv, HopRoverVectorEnv
    env_name, vec_name = class_names(module.REGISTER[0].id)
    here = sys.modules[__name__]
    title = (module.__doc__ or env_name).strip().splitlines()[0]
    doc = (f"{title}\n\n{env_name}: HopRoverEnv with the task of {module.__name__}, whose "
           f"module docstring has the env's tables (spaces, rewards, episode, arguments).")
    env_cls = type(env_name, (HopRoverEnv,), {"task": task, "__doc__": doc,
                                              "__module__": __name__})
    # VectorEnv named again (already a base): skrl's wrap_env recognises a Gymnasium env
    # by its class's direct bases
    vec_cls = type(vec_name, (HopRoverVectorEnv, VectorEnv), {
        "task": task, "__module__": __name__,
        "__doc__": f"N {env_name} rovers stepped in one jitted call; sub-env i equals "
                   f"{env_name} seeded with seed + i. The task: {module.__name__}."})
    for cls in (env_cls, vec_cls):
        cls.__qualname__ = cls.__name__
        setattr(here, cls.__name__, cls)
        _CLASSES[cls.__name__] = cls
    return env_cls, vec_cls


def add_task(name: str) -> list[str]:
    """Make the classes of the task module `name` and enter its ids in ENVS (not yet
    registered with gymnasium). Returns the ids."""
    module = task_module(name)
    env_cls, vec_cls = make_classes(module)
    ids = []
    for reg in module.REGISTER:
        ENVS[reg.id] = Task(f"{env_cls.__module__}:{env_cls.__name__}",
                            f"{vec_cls.__module__}:{vec_cls.__name__}",
                            dict(reg.kwargs), reg.suite, reg.hops, module.__name__)
        ids.append(reg.id)
    return ids


def gym_register(env_id: str) -> None:
    """Register one id of ENVS with gymnasium (nothing if it already is)."""
    entry = ENVS[env_id]
    if env_id not in gym.registry:
        gym.register(id=env_id, entry_point=entry.env, vector_entry_point=entry.vector_env,
                     kwargs=entry.kwargs)


def register_task(name: str) -> list[str]:
    """Register a task module from outside hoprover_env (a dotted module path that
    defines TASK and REGISTER, as hoprover_env/tasks/torque.py does): its env classes
    are made and its ids registered with gymnasium. Returns the ids."""
    ids = add_task(name)
    for env_id in ids:
        gym_register(env_id)
    return ids


def task(env_id: str) -> Task:
    """The registry entry of a hoprover id (ValueError naming an unknown id)."""
    if env_id not in ENVS:
        raise ValueError(f"unknown hoprover env id {env_id!r}; valid: {sorted(ENVS)}")
    return ENVS[env_id]


def _load(entry: str):
    import importlib
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


for _name in TASK_MODULES:
    add_task(_name)


# The goal-conditioned variant of HopRoverRL-v1 for hindsight replay (a Dict observation,
# so an env of its own rather than a task module's: hoprover_env/envs/goal.py)
GOAL_ENVS = {"HopRoverGoal-v1": "hoprover_env.envs.goal:HopRoverGoalEnv"}
for _goal_id, _entry in GOAL_ENVS.items():
    if _goal_id not in gym.registry:
        gym.register(id=_goal_id, entry_point=_entry)
