"""LayerNorm in the actor's hidden layers (`policy.actor_layer_norm`,
training/actor_penalty.py): each hidden layer is normalised over its units before its
activation, the optimiser trains the norms' parameters, a state for which every unit of a
plain ReLU layer is off keeps units on (so its action still depends on the observation),
it survives save and load, and the config refuses it where it cannot apply."""

import numpy as np
import pytest
import torch

from helpers import TINY_SAC_V1, tiny_config, train_run, write_config
from hoprover_env.training.sb3_agents import ConfigError, load_config


def _agent(tmp_path, algo: str, layer_norm: bool):
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import make_agent

    policy = {"net_arch": [16, 16], "actor_layer_norm": layer_norm}
    cfg = load_config(write_config(tmp_path, {**TINY_SAC_V1, "algo": algo, "policy": policy}))
    return make_agent(cfg, HopRoverSB3VecEnv(2, env_id="HopRoverRL-v1"))


@pytest.mark.parametrize("algo", ["sac", "tqc"])
def test_each_hidden_layer_is_normalised_and_trained(tmp_path, algo):
    model = _agent(tmp_path, algo, True)
    kinds = [type(m).__name__ for m in model.actor.latent_pi]
    assert kinds == ["Linear", "LayerNorm", "ReLU"] * 2
    optimised = {id(p) for g in model.actor.optimizer.param_groups for p in g["params"]}
    assert all(id(p) in optimised for p in model.actor.latent_pi.parameters())
    # what each norm sees is the linear layer's output, whatever the input's scale
    obs = 50.0 * torch.randn(9, model.observation_space.shape[0])
    x = model.actor.features_extractor(obs)
    for linear, norm, _ in zip(*[iter(model.actor.latent_pi)] * 3, strict=True):
        x = norm(linear(x))
        torch.testing.assert_close(x.mean(dim=1), torch.zeros(9), atol=1e-5, rtol=0)
        x = torch.relu(x)
    assert model.policy.actor_layer_norm is True
    assert _agent(tmp_path, algo, False).policy.__class__.__module__.startswith(
        ("stable_baselines3", "sb3_contrib")
    )


def test_a_state_that_turns_a_plain_layer_off_keeps_units_on(tmp_path):
    """The failure it is for: with every pre-activation of the last hidden layer negative,
    a plain actor's mean is its output bias, the same for every state; with the same
    weights and the layer normalised, units stay on and the mean follows the state."""
    plain, normed = _agent(tmp_path, "sac", False), _agent(tmp_path, "sac", True)
    plain_linear = [m for m in plain.actor.latent_pi if isinstance(m, torch.nn.Linear)]
    normed_linear = [m for m in normed.actor.latent_pi if isinstance(m, torch.nn.Linear)]
    with torch.no_grad():
        for a, b in zip(plain_linear, normed_linear, strict=True):
            b.weight.copy_(a.weight)
            b.bias.copy_(a.bias)
        for linear in (plain_linear[-1], normed_linear[-1]):
            linear.bias.fill_(-100.0)  # every unit off for every state
        normed.actor.mu.load_state_dict(plain.actor.mu.state_dict())
        obs = torch.randn(8, plain.observation_space.shape[0])
        for model, expect_on in ((plain, False), (normed, True)):
            hidden = model.actor.latent_pi(model.actor.features_extractor(obs))
            mean, _, _ = model.actor.get_action_dist_params(obs)
            assert bool((hidden > 0).any(dim=1).all()) is expect_on
            assert bool(np.ptp(mean[:, 0].numpy()) > 1e-6) is expect_on
    torch.testing.assert_close(
        plain.actor.get_action_dist_params(obs)[0],
        plain.actor.mu.bias.expand(8, 1),
    )


@pytest.mark.slow  # trains 64 steps and evaluates
def test_it_trains_saves_and_loads(tmp_path):
    from hoprover_env.agents.policies import _algo_class

    cfg = {**TINY_SAC_V1, "policy": {"net_arch": [16, 16], "actor_layer_norm": True}}
    out = train_run(tmp_path, cfg)
    model = _algo_class("sac").load(out / "final_model.zip", device="cpu")
    assert model.policy.actor_layer_norm is True
    assert any(isinstance(m, torch.nn.LayerNorm) for m in model.actor.latent_pi)
    assert model.policy.actor_mean_reg == 0.0


@pytest.mark.parametrize(
    "algo, value, message",
    [
        ("td3", True, "unknown config key 'policy.actor_layer_norm'"),
        ("crossq", True, "unknown config key 'policy.actor_layer_norm'"),
        ("ppo", True, "unknown config key 'policy.actor_layer_norm'"),
        ("sac", "yes", "actor_layer_norm"),
    ],
)
def test_the_config_refuses_it_where_it_cannot_apply(tmp_path, algo, value, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write_config(tmp_path, tiny_config(algo, {"actor_layer_norm": value})))
