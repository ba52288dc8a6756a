"""Recycling the dormant units of a squashed-Gaussian actor during training (the config
section `redo`): ReDo, Sokar et al. (2023), "The Dormant Neuron Phenomenon in Deep
Reinforcement Learning".

    redo:
      freq: 2000          # env steps between recyclings (2000 = 1000 updates at
                          # gradient_steps 2 on 4 envs)
      tau: 0.1            # a unit is dormant when its mean |activation| over the batch is
                          # at most tau times its layer's mean
      batch: 1024         # states drawn from the replay buffer to score the units

A ReLU unit whose input is negative for every state passes no gradient, so once it is
off it stays off. On HopRoverRL-v1, SAC's actor had 162 of the 256 units of its last
hidden layer tau-dormant (tau 0.025) at 50 k steps and 230 at 1 M, with 0-2 active at the
contest's start: its opening there was the output layer's bias, one action for every
target (docs/studies/off-policy/actor-units.md, "It is the dormant-neuron phenomenon").
ReDo gives such units back to the learner: every `freq` steps it scores each hidden unit
of the actor on a batch of the replay buffer's states, and for each dormant one

- draws its incoming weights and bias afresh from the layer's initialiser (torch's
  default for nn.Linear, which SB3's off-policy actors keep),
- sets its outgoing weights (in the next hidden layer, or in the mean and log-std heads)
  to zero, so that at the moment of recycling the actor's actions lose only what the
  dormant units added to them (nothing, for a unit that was off for every state),
- sets the Adam moments of those weights to zero, so that the old moments do not push
  the fresh weights back where the old ones were.

Only the actor is recycled (its dormancy is what the study measured; the critics'
is not). SAC and TQC (one actor class); not with `policy.actor_layer_norm`, whose
LayerNorm mixes a layer's units, so a unit cannot be recycled alone, nor with
`use_sde`, whose log-std is not a layer of the actor's.
"""

from __future__ import annotations

import sys

import torch
from stable_baselines3.common.callbacks import BaseCallback

DEFAULTS = {"freq": 2000, "tau": 0.1, "batch": 1024}
KEYS = set(DEFAULTS)
ALGOS = {"sac", "tqc"}


def settings(cfg: dict) -> dict:
    """The config's `redo` section with every unset key at its default."""
    return {**DEFAULTS, **(cfg.get("redo") or {})}


def _hidden_layers(actor) -> list[tuple[torch.nn.Linear, list[torch.nn.Linear]]]:
    """Each hidden linear layer of SB3's actor MLP with the layers that read its units."""
    linears = [m for m in actor.latent_pi if isinstance(m, torch.nn.Linear)]
    heads = [actor.mu, actor.log_std]
    return [
        (lin, [linears[i + 1]] if i + 1 < len(linears) else heads) for i, lin in enumerate(linears)
    ]


def hidden_activations(actor, obs: torch.Tensor) -> list[torch.Tensor]:
    """The output of each hidden layer's activation of SB3's actor MLP (`latent_pi`, or
    TD3's `mu` less its output layers), after the layer's LayerNorm where it has one. The
    output is positive where the activation's input is (ReLU, ELU, SiLU, tanh), so
    `> 0` marks a unit that is on."""
    net = actor.latent_pi if hasattr(actor, "latent_pi") else actor.mu[:-2]
    outs = []
    with torch.no_grad():
        x = actor.features_extractor(obs)
        for layer in net:
            x = layer(x)
            if not isinstance(layer, (torch.nn.Linear, torch.nn.LayerNorm)):
                outs.append(x)
    return outs


def dormant_mask(h: torch.Tensor, tau: float) -> torch.Tensor:
    """The tau-dormant units of one layer's activations `h` (states x units): mean
    |activation| at most tau times the layer's mean (Sokar et al.'s score)."""
    score = h.abs().mean(dim=0)
    return score / (score.mean() + 1e-12) <= tau


def dormant_units(actor, obs: torch.Tensor, tau: float) -> list[torch.Tensor]:
    """Per hidden layer of the actor, a mask of its tau-dormant units over `obs`."""
    return [dormant_mask(h, tau) for h in hidden_activations(actor, obs)]


def _zero_moments(optimizer: torch.optim.Optimizer, param: torch.Tensor, index) -> None:
    state = optimizer.state.get(param)
    for key in ("exp_avg", "exp_avg_sq"):
        if state and key in state:
            state[key][index] = 0.0


def recycle(
    actor,
    optimizer: torch.optim.Optimizer,
    obs: torch.Tensor,
    tau: float,
    reset_moments: bool = True,
) -> list[int]:
    """Recycle the actor's tau-dormant hidden units on `obs` (module docstring); the
    number recycled per hidden layer. `reset_moments=False` keeps the recycled weights'
    Adam moments (research.offpolicy.unit_survival's control)."""
    counts = []
    with torch.no_grad():
        for (layer, readers), mask in zip(_hidden_layers(actor), dormant_units(actor, obs, tau)):
            counts.append(int(mask.sum()))
            if not mask.any():
                continue
            fresh = torch.nn.Linear(layer.in_features, layer.out_features).to(layer.weight.device)
            layer.weight[mask] = fresh.weight[mask]
            layer.bias[mask] = fresh.bias[mask]
            moments = [(layer.weight, mask), (layer.bias, mask)]
            for reader in readers:
                reader.weight[:, mask] = 0.0
                moments.append((reader.weight, (slice(None), mask)))
            if reset_moments:
                for param, index in moments:
                    _zero_moments(optimizer, param, index)
    return counts


class RecycleDormant(BaseCallback):
    """Recycles the actor's dormant units every `freq` env steps once learning has
    started (module docstring); logs the counts as redo/recycled_<layer>."""

    def __init__(self, freq: int, tau: float, batch: int):
        super().__init__()
        self.freq, self.tau, self.batch = freq, tau, batch

    def _on_training_start(self) -> None:
        self.next_at = (self.num_timesteps // self.freq + 1) * self.freq

    def _on_step(self) -> bool:
        model = self.model
        if self.num_timesteps < self.next_at:
            return True
        self.next_at += self.freq
        if self.num_timesteps <= model.learning_starts or model.replay_buffer.size() == 0:
            return True
        obs = model.replay_buffer.sample(self.batch, env=model._vec_normalize_env).observations
        actor = model.policy.actor
        counts = recycle(actor, actor.optimizer, obs, self.tau)
        for i, n in enumerate(counts):
            self.logger.record(f"redo/recycled_{i}", n)
        print(f"  redo @ {self.num_timesteps:>9d}: recycled {counts}", file=sys.stderr)
        return True
