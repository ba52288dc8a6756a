"""The terrain task (HopRoverTerrain-v0): the torque task on a sloped, rough ground.

Each episode draws its slope (the env's config); the step is the torque task's
(tasks/torque.py, the same template), and the observation is the torque task's plus the
slope, so that one policy can hop on any incline. KERNELS[integrator] holds the step and
the batched loops over it.
"""
import dataclasses

import numpy as np

from hoprover_env.jit.compiler import kernel, NONE, VEC, VEC32
from hoprover_env.core.params import P_SLOPE
from hoprover_env.tasks import torque
from hoprover_env.tasks.config import TerrainEnvConfig
from hoprover_env.tasks.observation import OBS_DIM, OBS_HIGH as FLAT_HIGH, OBS_LOW as FLAT_LOW, observe as \
    flat_observe

OBS_SLOPE = OBS_DIM            # the slope / SLOPE_SCALE, after the torque task's slots
SLOPE_SCALE = 0.5              # rad: the largest slope the model accepts
OBS_LOW = np.append(FLAT_LOW, np.float32(-1.0))
OBS_HIGH = np.append(FLAT_HIGH, np.float32(1.0))


@kernel(NONE(VEC, VEC, VEC, VEC, VEC32))
def observe(S, P, E, M, obs):
    """The torque task's observation (slots 0..18), then the slope (slot OBS_SLOPE)."""
    flat_observe(S, P, E, M, obs)
    obs[OBS_SLOPE] = P[P_SLOPE] / SLOPE_SCALE


TASK = dataclasses.replace(torque.TASK, name="terrain", config=TerrainEnvConfig,
                           observe=observe, obs_low=OBS_LOW, obs_high=OBS_HIGH)
