"""hoprover: the hopping-rover problem of the 8th Spacecraft Control System Design
Contest (2015) as an exact, fast simulator and a Gymnasium environment.

    from hoprover_env import simulate, RoverParams        # the simulator
    import gymnasium as gym, hoprover_env                   # registers the envs
    env = gym.make("HopRover-v0")                           # random targets in [-1, 1] m
    envs = gym.make_vec("HopRover-v0", num_envs=1024)       # native batched vector env
"""
from gymnasium.envs.registration import register, registry

from .params import RoverParams
from .simulate import Rollout, RoverSim, simulate

__all__ = ["RoverParams", "Rollout", "RoverSim", "simulate", "HopRoverEnv",
           "HopRoverVectorEnv"]
__version__ = "0.1.0"

for _id, _kwargs in (("HopRover-v0", {}), ("HopRoverContest-v0", {"target_x": 0.5})):
    if _id not in registry:
        register(id=_id, entry_point="hoprover_env.env:HopRoverEnv",
                 vector_entry_point="hoprover_env.vector_env:HopRoverVectorEnv",
                 kwargs=_kwargs)


def __getattr__(name):          # the envs import gymnasium spaces etc. only when used
    if name == "HopRoverEnv":
        from .env import HopRoverEnv
        return HopRoverEnv
    if name == "HopRoverVectorEnv":
        from .vector_env import HopRoverVectorEnv
        return HopRoverVectorEnv
    raise AttributeError(name)
