"""Three options of actors: a penalty on the pre-tanh mean (SAC, TQC, CrossQ; a config's
`policy.actor_mean_reg`), a LayerNorm after each hidden layer (SAC, TQC;
`policy.actor_layer_norm`) and a learning rate of the actor's own (SAC, TQC, CrossQ and
TD3; `policy.actor_lr_scale`). The first two concern squashed-Gaussian actors; the third
any actor with an optimiser of its own.

SB3's squashed-Gaussian actor acts with tanh(mu(s)). When |mu| grows past about 10,
tanh's slope (1 - tanh(mu)^2) is 0 in float32, so the critic's gradient no longer
reaches mu: whatever the critic learns about that state, the actor's action there stays
at +1 or -1 for good. The entropy bonus does not pull it back either, since SB3 bounds
the tanh correction of the log-probability with an epsilon. On HopRoverRL-v1 this froze
one SAC seed's opening action at rest at -1 (mu between -1400 and -2000 from 350 k steps
on, for every target) while its critic preferred -0.25 to -0.75
(docs/studies/off-policy/actor-units.md). The SAC authors' own code penalised the
Gaussian's mean towards zero for this reason (rlkit's SAC: `policy_mean_reg_weight`, 1e-3
by default); this is that penalty:

    actor loss += actor_mean_reg * mean over the batch (and action dimensions) of mu(s)^2

With a small weight it changes nothing where tanh has a slope (|mu| of a few units), and
it brings a saturated mu back to where the critic's gradient acts again.

It is added as a gradient hook on the actor's `mu` layer, not by rewriting the
algorithm's `train`: every forward pass that builds a graph through `mu` adds the
penalty's gradient to whatever loss is backpropagated through it. In SB3's SAC, TQC and
CrossQ that is only the actor's loss (the critics' targets and `predict` run under
`no_grad`, the entropy coefficient's loss detaches the log-probability).

LayerNorm in the actor's hidden layers (`actor_layer_norm`). A ReLU unit whose
pre-activation is negative passes no gradient, and a layer can turn every unit off for one
kind of state while it serves the others. On HopRoverRL-v1 every SAC actor measured had
0-2 of the 256 units of its last hidden layer active at the contest's start from 50 k
steps on: its opening there was the output layer's bias, the same for every target and
moved by the training of every other state, and when that bias fell below the tipping
torque the rover never launched (docs/studies/off-policy/actor-units.md, "The opening is
the output layer's bias"). Normalised over its units, each state's pre-activations have
mean beta and spread gamma whatever the input, so a layer cannot turn all of its units off
for one state alone. This is the LayerNorm of the actor in the large-network agents of
Nauman et al. (2024, BRO) and Lee et al. (2024, SimBa), here after each hidden linear
layer of SB3's MLP, as `policy.critic_layer_norm` does for the critics.

The actor's learning rate (`actor_lr_scale`). SB3's SAC, TQC, CrossQ and TD3 step the
actor and the critics with one learning rate. With Adam, which moves each weight by about the
learning rate whatever the gradient's scale, the actor's rate decides how fast its units
turn off: on HopRoverRL-v1, of the 173-177 units of a SAC actor's last hidden layer
recycled at once (training/redo.py), 163-175 were dormant again after 300 updates at an
actor rate of 1e-3, 114-117 at 3e-4 and 37-43 at 1e-4, the critics at 1e-3 in every
case (docs/studies/off-policy/actor-units.md, "Why recycled units die"). The option
multiplies the actor's rate alone, at every step and whatever the schedule: 0.1 gives the
actor a tenth of the critics' rate, as DDPG's authors did (1e-4 and 1e-3). It is applied
by hooks around the actor optimiser's step, since the algorithms set every optimiser's
rate to the one schedule before each update.

A model saved with one of these policies names the class in its zip, so loading it needs
hoprover installed, as every hoprover model does.
"""

from __future__ import annotations

import torch
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.sac.policies import MultiInputPolicy as SACMultiInputPolicy
from stable_baselines3.sac.policies import SACPolicy
from stable_baselines3.td3.policies import MultiInputPolicy as TD3MultiInputPolicy
from stable_baselines3.td3.policies import TD3Policy

from hoprover_env.training.critics import LayerNormSACPolicy, LayerNormTD3Policy


def penalise_mean(actor: torch.nn.Module, weight: float) -> None:
    """Add the gradient of `weight * mean(mu^2)` (over the batch and the action
    dimensions) to every backward pass through `actor.mu` (module docstring)."""
    if weight <= 0:
        return

    def on_forward(_module, _inputs, mean: torch.Tensor) -> None:
        if mean.requires_grad:
            kept = mean.detach()
            mean.register_hook(lambda grad: grad + (2.0 * weight / kept.numel()) * kept)

    actor.mu.register_forward_hook(on_forward)


def scale_learning_rate(optimizer: torch.optim.Optimizer, scale: float) -> None:
    """Step `optimizer` with `scale` times the learning rate its groups are given
    (module docstring); the groups show the given rate between steps."""
    if scale == 1.0:
        return

    def before(opt, _args, _kwargs) -> None:
        for group in opt.param_groups:
            group["lr"] = group["lr"] * scale

    def after(opt, _args, _kwargs) -> None:
        for group in opt.param_groups:
            group["lr"] = group["lr"] / scale

    optimizer.register_step_pre_hook(before)
    optimizer.register_step_post_hook(after)


def normalise_hidden_layers(actor: torch.nn.Module) -> None:
    """Rebuild SB3's actor MLP (`latent_pi`) with a LayerNorm after every hidden linear
    layer, before its activation (module docstring); the output layers are unchanged."""
    device = next(actor.parameters()).device
    layers = create_mlp(
        actor.features_dim,
        -1,
        actor.net_arch,
        actor.activation_fn,
        post_linear_modules=[torch.nn.LayerNorm],
    )
    actor.latent_pi = torch.nn.Sequential(*layers).to(device)


class _ActorRate:
    """Mixin for an SB3 policy class whose actor has an optimiser of its own: it steps
    with `actor_lr_scale` times the rate the algorithm gives it."""

    def __init__(self, *args, actor_lr_scale: float = 1.0, **kwargs):
        self.actor_lr_scale = float(actor_lr_scale)
        super().__init__(*args, **kwargs)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)  # type: ignore[misc]
        scale_learning_rate(self.actor.optimizer, self.actor_lr_scale)  # type: ignore[attr-defined]

    def _get_constructor_parameters(self) -> dict:
        return {
            **super()._get_constructor_parameters(),  # type: ignore[misc]
            "actor_lr_scale": self.actor_lr_scale,
        }


class _MeanPenalty(_ActorRate):
    """Mixin for an SB3 squashed-Gaussian policy class: its actor's pre-tanh mean is
    penalised with `actor_mean_reg`, its hidden layers normalised with
    `actor_layer_norm`, and its learning rate scaled by `actor_lr_scale`."""

    def __init__(
        self,
        *args,
        actor_mean_reg: float = 0.0,
        actor_layer_norm: bool = False,
        **kwargs,
    ):
        # set before the base class builds the actor (in its __init__, through make_actor)
        self.actor_mean_reg = float(actor_mean_reg)
        self.actor_layer_norm = bool(actor_layer_norm)
        super().__init__(*args, **kwargs)

    def make_actor(self, features_extractor=None):
        actor = super().make_actor(features_extractor)  # type: ignore[misc]
        if self.actor_layer_norm:
            # before the optimiser is made: SB3 builds it from the actor's parameters after
            normalise_hidden_layers(actor)
        penalise_mean(actor, self.actor_mean_reg)
        return actor

    def _get_constructor_parameters(self) -> dict:
        return {
            **super()._get_constructor_parameters(),
            "actor_mean_reg": self.actor_mean_reg,
            "actor_layer_norm": self.actor_layer_norm,
        }


class MeanPenaltySACPolicy(_MeanPenalty, SACPolicy):
    """SAC's MlpPolicy with the actor's options (the mean penalised, hidden layers
    normalised); the name is the first option's, which saved models carry."""


class MeanPenaltyLayerNormSACPolicy(_MeanPenalty, LayerNormSACPolicy):
    """SAC's MlpPolicy with layer-normalised critics and the actor's options."""


class MeanPenaltyMultiInputSACPolicy(_MeanPenalty, SACMultiInputPolicy):
    """SAC's MultiInputPolicy (Dict observations: goal envs, HER) with the actor's options."""


class ActorRateTD3Policy(_ActorRate, TD3Policy):
    """TD3's MlpPolicy with the actor's own learning rate (its deterministic actor has no
    Gaussian mean to penalise)."""


class ActorRateLayerNormTD3Policy(_ActorRate, LayerNormTD3Policy):
    """TD3's MlpPolicy with layer-normalised critics and the actor's own learning rate."""


class ActorRateMultiInputTD3Policy(_ActorRate, TD3MultiInputPolicy):
    """TD3's MultiInputPolicy (Dict observations: goal envs, HER) with the actor's own
    learning rate."""


# (algo, critic_layer_norm) -> the policy class that takes the actor's options
ACTOR_OPTION_POLICIES: dict[tuple[str, bool], type] = {
    ("sac", False): MeanPenaltySACPolicy,
    ("sac", True): MeanPenaltyLayerNormSACPolicy,
    ("td3", False): ActorRateTD3Policy,
    ("td3", True): ActorRateLayerNormTD3Policy,
}
# algo -> policy class for Dict observations (SB3's "MultiInputPolicy"), with the actor's options
MULTI_INPUT_POLICIES: dict[str, type] = {
    "sac": MeanPenaltyMultiInputSACPolicy,
    "td3": ActorRateMultiInputTD3Policy,
}

try:  # TQC and CrossQ come with sb3-contrib (the contrib extra); SAC does not need it
    from sb3_contrib.crossq.policies import CrossQPolicy
    from sb3_contrib.tqc.policies import MultiInputPolicy as TQCMultiInputPolicy
    from sb3_contrib.tqc.policies import TQCPolicy
except ImportError:
    pass
else:

    class MeanPenaltyTQCPolicy(_MeanPenalty, TQCPolicy):
        """TQC's MlpPolicy with the actor's options."""

    class MeanPenaltyCrossQPolicy(_MeanPenalty, CrossQPolicy):
        """CrossQ's MlpPolicy with the actor's mean penalised."""

    class MeanPenaltyMultiInputTQCPolicy(_MeanPenalty, TQCMultiInputPolicy):
        """TQC's MultiInputPolicy with the actor's options."""

    ACTOR_OPTION_POLICIES[("tqc", False)] = MeanPenaltyTQCPolicy
    MULTI_INPUT_POLICIES["tqc"] = MeanPenaltyMultiInputTQCPolicy
    ACTOR_OPTION_POLICIES[("crossq", False)] = MeanPenaltyCrossQPolicy
