"""The env classes of the package's tasks, written out: for each task module of
hoprover_env/tasks/ other than the torque task (whose classes are HopRoverEnv and
HopRoverVectorEnv themselves), a subclass of HopRoverEnv and one of HopRoverVectorEnv
with ``task = TASK``. Each docstring points to its task module, whose docstring has the
env's tables (spaces, rewards, episode, arguments). `CLASSES` maps each task module to
its two classes; hoprover_env.envs.registry enters their ids.

A vector env class names VectorEnv again among its bases (it already is one):
skrl's wrap_env recognises a Gymnasium env by its class's direct bases.
"""

from __future__ import annotations

from gymnasium.vector import VectorEnv

from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.tasks import hop, mission, terrain, torque_rl


class HopRoverRLEnv(HopRoverEnv):
    """HopRoverRL-v1: the torque task with settings for RL that sees what its reward
    pays for.

    HopRoverEnv with the task of hoprover_env.tasks.torque_rl, whose module docstring
    has the env's tables (spaces, rewards, episode, arguments)."""

    task = torque_rl.TASK


class HopRoverRLVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N HopRoverRLEnv rovers stepped in one jitted call; sub-env i equals HopRoverRLEnv
    seeded with seed + i. The task: hoprover_env.tasks.torque_rl."""

    task = torque_rl.TASK


class HopRoverHopEnv(HopRoverEnv):
    """HopRoverHop: the same rover and judge, one action per hop.

    HopRoverEnv with the task of hoprover_env.tasks.hop, whose module docstring has the
    env's tables (spaces, rewards, episode, arguments)."""

    task = hop.TASK


class HopRoverHopVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N HopRoverHopEnv rovers stepped in one jitted call; sub-env i equals
    HopRoverHopEnv seeded with seed + i. The task: hoprover_env.tasks.hop."""

    task = hop.TASK


class HopRoverTerrainEnv(HopRoverEnv):
    """HopRoverTerrain: the contest's task on sloped, rough ground.

    HopRoverEnv with the task of hoprover_env.tasks.terrain, whose module docstring has
    the env's tables (spaces, rewards, episode, arguments)."""

    task = terrain.TASK


class HopRoverTerrainVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N HopRoverTerrainEnv rovers stepped in one jitted call; sub-env i equals
    HopRoverTerrainEnv seeded with seed + i. The task: hoprover_env.tasks.terrain."""

    task = terrain.TASK


class HopRoverMissionEnv(HopRoverEnv):
    """HopRoverMission: the contest's task under mission conditions.

    HopRoverEnv with the task of hoprover_env.tasks.mission, whose module docstring has
    the env's tables (spaces, rewards, episode, arguments)."""

    task = mission.TASK


class HopRoverMissionVectorEnv(HopRoverVectorEnv, VectorEnv):
    """N HopRoverMissionEnv rovers stepped in one jitted call; sub-env i equals
    HopRoverMissionEnv seeded with seed + i. The task: hoprover_env.tasks.mission."""

    task = mission.TASK


# task module -> (env class, vector env class)
CLASSES: dict[str, tuple[type[HopRoverEnv], type[HopRoverVectorEnv]]] = {
    "hoprover_env.tasks.torque": (HopRoverEnv, HopRoverVectorEnv),
    "hoprover_env.tasks.torque_rl": (HopRoverRLEnv, HopRoverRLVectorEnv),
    "hoprover_env.tasks.hop": (HopRoverHopEnv, HopRoverHopVectorEnv),
    "hoprover_env.tasks.terrain": (HopRoverTerrainEnv, HopRoverTerrainVectorEnv),
    "hoprover_env.tasks.mission": (HopRoverMissionEnv, HopRoverMissionVectorEnv),
}
