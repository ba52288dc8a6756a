"""hoprover: the hopping-rover problem of the 8th Spacecraft Control System Design
Contest (2015) as an exact, fast simulator and a Gymnasium environment.

    from hoprover_env import simulate, RoverParams        # the simulator
    import gymnasium as gym, hoprover_env                   # registers the envs
    env = gym.make("HopRover-v0")                           # random targets in [-1, 1] m
    envs = gym.make_vec("HopRover-v0", num_envs=1024)       # native batched vector env
"""
from gymnasium.envs.registration import register, registry

from .params import RoverParams
from .rollout import Rollout
from .simulate import RoverSim, simulate
from .batch import BatchRollout, simulate_batch

__all__ = ["RoverParams", "Rollout", "RoverSim", "simulate", "simulate_batch",
           "BatchRollout", "HopRoverEnv",
           "HopRoverVectorEnv", "HopRoverHopEnv", "HopRoverHopVectorEnv",
           "HopRoverTerrainEnv", "HopRoverTerrainVectorEnv", "ENVS",
           "vector_env_class"]
__version__ = "0.1.0"

# id -> (single env, native vector env, fixed kwargs)
ENVS = {
    "HopRover-v0": ("hoprover_env.env:HopRoverEnv",
                    "hoprover_env.vector_env:HopRoverVectorEnv", {}),
    "HopRoverContest-v0": ("hoprover_env.env:HopRoverEnv",
                           "hoprover_env.vector_env:HopRoverVectorEnv", {"target_x": 0.5}),
    "HopRoverHop-v0": ("hoprover_env.hop_env:HopRoverHopEnv",
                       "hoprover_env.hop_env:HopRoverHopVectorEnv", {}),
    "HopRoverTerrain-v0": ("hoprover_env.terrain_env:HopRoverTerrainEnv",
                           "hoprover_env.terrain_env:HopRoverTerrainVectorEnv", {}),
}
for _id, (_entry, _vector_entry, _kwargs) in ENVS.items():
    if _id not in registry:
        register(id=_id, entry_point=_entry, vector_entry_point=_vector_entry,
                 kwargs=_kwargs)


def vector_env_class(env_id: str):
    """The native vector env class of a registered hoprover id (ValueError for an
    unknown id)."""
    import importlib
    if env_id not in ENVS:
        raise ValueError(f"unknown hoprover env id {env_id!r}; valid: {sorted(ENVS)}")
    module, name = ENVS[env_id][1].split(":")
    return getattr(importlib.import_module(module), name)


def __getattr__(name):          # the envs import gymnasium spaces etc. only when used
    if name == "HopRoverEnv":
        from .env import HopRoverEnv
        return HopRoverEnv
    if name == "HopRoverVectorEnv":
        from .vector_env import HopRoverVectorEnv
        return HopRoverVectorEnv
    if name in ("HopRoverHopEnv", "HopRoverHopVectorEnv"):
        from . import hop_env
        return getattr(hop_env, name)
    if name in ("HopRoverTerrainEnv", "HopRoverTerrainVectorEnv"):
        from . import terrain_env
        return getattr(terrain_env, name)
    raise AttributeError(name)
