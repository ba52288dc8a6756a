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
from hoprover_env.core.params import RoverParams
from hoprover_env.envs import registry as _registry
from hoprover_env.envs.registry import (
    ENVS,
    Task,
    config_class,
    env_class,
    gym_register,
    register_task,
    task,
    vector_env_class,
)
from hoprover_env.sim.batch import BatchRollout, simulate_batch
from hoprover_env.sim.rollout import Rollout
from hoprover_env.sim.simulate import RoverSim, simulate
from hoprover_env.util.buildinfo import VERSION as __version__  # noqa: F401 (the version)

for _id in ENVS:
    gym_register(_id)

__all__ = ["RoverParams", "Rollout", "RoverSim", "simulate", "simulate_batch",
           "BatchRollout", "ENVS", "Task", "task", "env_class", "vector_env_class",
           "config_class", "register_task", "HopRoverEnv", "HopRoverVectorEnv",
           "HopRoverHopEnv", "HopRoverHopVectorEnv", "HopRoverTerrainEnv",
           "HopRoverTerrainVectorEnv", "HopRoverMissionEnv", "HopRoverMissionVectorEnv"]


def __getattr__(name):          # the env classes, by name (hoprover_env.envs.registry)
    if name in ("HopRoverEnv", "HopRoverVectorEnv") or name in _registry._CLASSES:
        return getattr(_registry, name)
    raise AttributeError(f"module 'hoprover_env' has no attribute {name!r}")
