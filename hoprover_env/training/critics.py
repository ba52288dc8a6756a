"""Critics with layer normalisation for SAC and TD3 (a config's `policy.critic_layer_norm`).

RLPD (Ball et al. 2023) and the critics studied by Nauman et al. (2024) normalise each
hidden layer of the Q-networks: the output of a ReLU layer after LayerNorm is bounded
by the layer's width, so the critic cannot extrapolate Q without limit to actions the
data never took, which is the overestimation that breaks off-policy learners fed
with another policy's data. Stable-Baselines3's `create_mlp` takes the modules
(`post_linear_modules`), but its `ContinuousCritic` does not pass them on; these classes
do, and change nothing else (the actor, the optimisers and the targets are SB3's).

A model saved with one of these policies names the class in its zip, so loading it
needs hoprover installed, as every hoprover model does.
"""

from __future__ import annotations

import torch.nn as nn
from stable_baselines3.common.policies import ContinuousCritic
from stable_baselines3.common.preprocessing import get_action_dim
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.sac.policies import SACPolicy
from stable_baselines3.td3.policies import TD3Policy


class LayerNormContinuousCritic(ContinuousCritic):
    """SB3's `ContinuousCritic` with LayerNorm after every hidden linear layer."""

    def __init__(
        self,
        observation_space,
        action_space,
        net_arch,
        features_extractor,
        features_dim,
        activation_fn=nn.ReLU,
        normalize_images=True,
        n_critics=2,
        share_features_extractor=True,
    ):
        super().__init__(
            observation_space,
            action_space,
            net_arch,
            features_extractor,
            features_dim,
            activation_fn=activation_fn,
            normalize_images=normalize_images,
            n_critics=n_critics,
            share_features_extractor=share_features_extractor,
        )
        in_dim = features_dim + get_action_dim(action_space)
        self.q_networks = []
        for idx in range(n_critics):
            layers = create_mlp(
                in_dim, 1, net_arch, activation_fn, post_linear_modules=[nn.LayerNorm]
            )
            q_net = nn.Sequential(*layers)
            self.add_module(f"qf{idx}", q_net)  # replaces SB3's module of the same name
            self.q_networks.append(q_net)


class LayerNormSACPolicy(SACPolicy):
    """SAC's MlpPolicy whose critics normalise their hidden layers."""

    def make_critic(self, features_extractor=None) -> ContinuousCritic:
        kwargs = self._update_features_extractor(self.critic_kwargs, features_extractor)
        return LayerNormContinuousCritic(**kwargs).to(self.device)


class LayerNormTD3Policy(TD3Policy):
    """TD3's MlpPolicy whose critics normalise their hidden layers."""

    def make_critic(self, features_extractor=None) -> ContinuousCritic:
        kwargs = self._update_features_extractor(self.critic_kwargs, features_extractor)
        return LayerNormContinuousCritic(**kwargs).to(self.device)


LAYER_NORM_POLICIES = {"sac": LayerNormSACPolicy, "td3": LayerNormTD3Policy}
