"""A policy input layer that resolves the rover's small motions.

HopRover-v0's observation is scaled so that every component is of order one over a
whole episode (a hop spans metres, turns, cm/s). The decisions that settle a nudge at
the band's edge or a slide after landing act on motions a thousand times smaller: a
rock of a milliradian, a corner a fraction of a millimetre out of the band, a slide of
a millimetre per second. After VecNormalize those differ by 1e-3 in the network's input,
which a network of order-one weights fitted by least squares does not separate, so a
clone averages the labels of states it cannot tell apart (docs/studies/plan-clone.md,
section 3).

`MicroStateFeatures` passes the normalised observation on unchanged and appends
``tanh(q / scale)`` for a few physical quantities q at fine scales (`FEATURES`: the
tilt, the rate and the horizontal speed, each signed by the direction to the target,
and how far the nearest corner is beyond the band's edge), computed from the normalised
observation with the frozen statistics it was normalised with. It is part of the
network: an SB3 features extractor, saved with the model (its statistics as buffers)
and found again on load (`policy_kwargs`); a config asks for it with
``policy: {features: micro}``.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

# (observation slot, factor to the physical quantity, scales of that quantity), each
# signed by the direction to the target (+1 when the target is ahead in +x): the
# physics is mirror-symmetric, so "tilted toward the target and still tipping that way"
# is one sign whichever side the target is on
#   4: sin(theta) -> rad;  6: omega / 0.3 rad/s -> rad/s;  2: velocity / 0.01 m/s -> m/s
FEATURES = (
    (4, 1.0, (0.0003, 0.001, 0.003, 0.01)),
    (6, 0.3, (0.0005, 0.002, 0.01)),
    (2, 0.01, (0.0005, 0.005)),
)
DX_SLOT = 0  # c.m. minus target [m]
EDGE_SLOT, EDGE_SCALES = 16, (0.0005, 0.002, 0.01)  # m beyond the band's edge
BAND_HALF_WIDTH = 0.05  # m: slot 16's unit


def n_features() -> int:
    return sum(len(s) for _, _, s in FEATURES) + len(EDGE_SCALES)


def micro_features(raw):
    """The appended features of raw (unnormalised) observations (N, 19), numpy or torch:
    one formula for the layer and for checking it."""
    lib = torch if isinstance(raw, torch.Tensor) else np
    ahead = lib.where(raw[:, DX_SLOT] <= 0.0, 1.0, -1.0)
    cols = []
    for slot, factor, scales in FEATURES:
        cols += [lib.tanh(ahead * raw[:, slot] * (factor / s)) for s in scales]
    edge = (lib.abs(raw[:, EDGE_SLOT]) - 1.0) * BAND_HALF_WIDTH
    cols += [lib.tanh(edge / s) for s in EDGE_SCALES]
    return lib.stack(cols, 1)


class MicroStateFeatures(BaseFeaturesExtractor):
    """The normalised observation, then `micro_features` of the raw one (module
    docstring). The raw observation is recovered with the VecNormalize statistics the
    inputs are normalised with, held as buffers (saved with the weights) and set by
    `set_statistics`; they must stay frozen while the network is trained and used."""

    def __init__(self, observation_space: spaces.Box):
        dim = int(np.prod(observation_space.shape))
        super().__init__(observation_space, dim + n_features())
        self.register_buffer("mean", torch.zeros(dim))
        self.register_buffer("std", torch.ones(dim))

    frozen_statistics = True  # hoprover_env.training: the statistics stay fixed

    def forward(self, obs):
        return torch.cat([obs, micro_features(obs * self.std + self.mean)], dim=1)

    def use_statistics(self, mean, std) -> None:
        """The VecNormalize statistics the inputs are normalised with (the hook
        hoprover_env.training.warm_start.share_statistics calls)."""
        self.mean.copy_(mean)
        self.std.copy_(std)


def set_statistics(policy, vecnorm) -> None:
    """Give `policy`'s MicroStateFeatures (if any) the observation statistics of
    `vecnorm` (a VecNormalize), as it normalises: (obs - mean) / sqrt(var + epsilon)."""
    mean = torch.as_tensor(np.asarray(vecnorm.obs_rms.mean), dtype=torch.float32)
    std = torch.as_tensor(
        np.sqrt(np.asarray(vecnorm.obs_rms.var) + vecnorm.epsilon), dtype=torch.float32
    )
    for name in ("features_extractor", "pi_features_extractor", "vf_features_extractor"):
        ext = getattr(policy, name, None)
        if isinstance(ext, MicroStateFeatures):
            ext.use_statistics(mean, std)


# `policy.features` in a training config: the extractor it names
FEATURE_EXTRACTORS = {"micro": MicroStateFeatures}
# the same, as train.py's configs name them (policy.features_extractor)
EXTRACTOR_PATHS = {"micro": "research.plan_clone.features:MicroStateFeatures"}
