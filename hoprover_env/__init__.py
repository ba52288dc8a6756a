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

# first: the kernel sources the compiler's cache fingerprint covers, before any kernel
from hoprover_env import _kernel_sources  # noqa: F401
from hoprover_env.core.params import RoverParams
from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.registry import (
    ENVS,
    Task,
    config_class,
    env_class,
    gym_register,
    register_installed,
    register_task,
    task,
    vector_env_class,
)
from hoprover_env.envs.tasks import (
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
from hoprover_env.sim.batch import BatchRollout, simulate_batch
from hoprover_env.sim.rollout import Rollout
from hoprover_env.sim.simulate import RoverSim, simulate
from hoprover_env.util.buildinfo import VERSION as __version__  # noqa: F401 (the version)

for _id in ENVS:
    gym_register(_id)

__all__ = [
    "RoverParams",
    "Rollout",
    "RoverSim",
    "simulate",
    "simulate_batch",
    "BatchRollout",
    "ENVS",
    "Task",
    "task",
    "env_class",
    "vector_env_class",
    "config_class",
    "register_task",
    "HopRoverEnv",
    "HopRoverVectorEnv",
    "HopRoverHopEnv",
    "HopRoverHopVectorEnv",
    "HopRoverTerrainEnv",
    "HopRoverTerrainVectorEnv",
    "HopRoverMissionEnv",
    "HopRoverMissionVectorEnv",
    "HopRoverRLEnv",
    "HopRoverRLVectorEnv",
]

# last, so that an installed task module may import any name of the package: the task
# modules installed packages name in the entry-point group "hoprover.tasks"
register_installed()
