"""hoprover: the hopping-rover problem of the 8th Spacecraft Control System Design
Contest (2015) as an exact, fast simulator and a Gymnasium environment.

    from hoprover_env import simulate, RoverParams        # the simulator
    import gymnasium as gym, hoprover_env                   # registers the envs
    env = gym.make("HopRover-v0")                           # random targets in [-1, 1] m
    envs = gym.make_vec("HopRover-v0", num_envs=1024)       # native batched vector env

The package has one subpackage per layer, each importing only from those below it
(docs/ARCHITECTURE.md): `jit`, `util`, `core` (the physics kernel), `sim` (simulate,
batches), `tasks`, `envs`, `agents`, `evaluation`, `training`.
"""
from dataclasses import dataclass, field

from gymnasium.envs.registration import register, registry

from hoprover_env.util import moved as _moved
from hoprover_env.util.buildinfo import VERSION as __version__
from hoprover_env.core.params import RoverParams
from hoprover_env.sim.rollout import Rollout
from hoprover_env.sim.simulate import RoverSim, simulate
from hoprover_env.sim.batch import BatchRollout, simulate_batch

_moved.install()

__all__ = ["RoverParams", "Rollout", "RoverSim", "simulate", "simulate_batch",
           "BatchRollout", "HopRoverEnv",
           "HopRoverVectorEnv", "HopRoverHopEnv", "HopRoverHopVectorEnv",
           "HopRoverTerrainEnv", "HopRoverTerrainVectorEnv", "HopRoverMissionEnv",
           "HopRoverMissionVectorEnv", "ENVS", "Task",
           "task", "env_class", "vector_env_class", "config_class"]


@dataclass(frozen=True)
class Task:
    """A registered task: where its env classes live, what its id fixes, and what the
    drivers need to know of it, so that nothing compares an id as a string. `env` and
    `vector_env` are "module:Class" entry points (imported only when used); `kwargs` are
    the env arguments the id fixes; `suite` names its frozen test suite
    (hoprover_env.suites); `hops` says whether one action is a whole hop (its launch
    torque) rather than a torque held over a control interval."""
    env: str
    vector_env: str
    kwargs: dict = field(default_factory=dict)
    suite: str = "level"
    hops: bool = False


ENVS = {
    "HopRover-v0": Task("hoprover_env.envs.env:HopRoverEnv",
                        "hoprover_env.envs.vector_env:HopRoverVectorEnv"),
    "HopRoverContest-v0": Task("hoprover_env.envs.env:HopRoverEnv",
                               "hoprover_env.envs.vector_env:HopRoverVectorEnv",
                               {"target_x": 0.5}, suite="contest"),
    "HopRoverHop-v0": Task("hoprover_env.envs.hop_env:HopRoverHopEnv",
                           "hoprover_env.envs.hop_env:HopRoverHopVectorEnv", hops=True),
    "HopRoverTerrain-v0": Task("hoprover_env.envs.terrain_env:HopRoverTerrainEnv",
                               "hoprover_env.envs.terrain_env:HopRoverTerrainVectorEnv",
                               suite="terrain"),
    "HopRoverMission-v0": Task("hoprover_env.envs.mission_env:HopRoverMissionEnv",
                               "hoprover_env.envs.mission_env:HopRoverMissionVectorEnv",
                               suite="terrain"),
}
for _id, _task in ENVS.items():
    if _id not in registry:
        register(id=_id, entry_point=_task.env, vector_entry_point=_task.vector_env,
                 kwargs=_task.kwargs)


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
    """The config dataclass of a registered hoprover id (EnvConfig, HopEnvConfig,
    TerrainEnvConfig): the env arguments a YAML's `env:` section may set."""
    return env_class(env_id).task.config


def __getattr__(name):          # the envs import gymnasium spaces etc. only when used
    if name == "HopRoverEnv":
        from hoprover_env.envs.env import HopRoverEnv
        return HopRoverEnv
    if name == "HopRoverVectorEnv":
        from hoprover_env.envs.vector_env import HopRoverVectorEnv
        return HopRoverVectorEnv
    if name in ("HopRoverHopEnv", "HopRoverHopVectorEnv"):
        from hoprover_env.envs import hop_env
        return getattr(hop_env, name)
    if name in ("HopRoverTerrainEnv", "HopRoverTerrainVectorEnv"):
        from hoprover_env.envs import terrain_env
        return getattr(terrain_env, name)
    if name in ("HopRoverMissionEnv", "HopRoverMissionVectorEnv"):
        from hoprover_env.envs import mission_env
        return getattr(mission_env, name)
    raise AttributeError(name)
