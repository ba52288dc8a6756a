"""The penalty on the actor's pre-tanh mean (`policy.actor_mean_reg`,
training/actor_penalty.py): its gradient is that of weight * mean(mu^2) added to the
actor's loss, it leaves the actions alone, it brings back a saturated actor that SB3's
loss alone leaves where it is, it survives save and load, and the config refuses it
where it cannot apply."""

import numpy as np
import pytest
import torch

from helpers import TINY_SAC_V1, tiny_config, train_run, write_config
from hoprover_env.training.sb3_agents import ConfigError, load_config


def _agents(tmp_path, algo: str, weight: float):
    """The same agent (same weights) with and without the penalty."""
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import make_agent

    policy = {"net_arch": [16, 16], "actor_mean_reg": weight}
    cfg = load_config(write_config(tmp_path, {**TINY_SAC_V1, "algo": algo, "policy": policy}))
    venv = HopRoverSB3VecEnv(2, env_id="HopRoverRL-v1")
    penalised = make_agent(cfg, venv)
    plain = make_agent({**cfg, "policy": {"net_arch": [16, 16]}}, venv)
    plain.policy.load_state_dict(penalised.policy.state_dict())
    return penalised, plain, venv


@pytest.mark.parametrize("algo", ["sac", "tqc", "crossq"])
def test_its_gradient_is_that_of_the_penalty_added_to_the_loss(tmp_path, algo):
    weight = 0.3
    penalised, plain, _ = _agents(tmp_path, algo, weight)
    assert type(penalised.policy).__name__.startswith("MeanPenalty")
    assert type(plain.policy).__module__.startswith(("stable_baselines3", "sb3_contrib"))
    obs = torch.randn(7, penalised.observation_space.shape[0])
    for model in (penalised, plain):
        model.actor.train()
        model.actor.zero_grad()
    w = torch.linspace(-1.0, 2.0, 7)[:, None]  # any loss of the mean

    mean, _, _ = penalised.actor.get_action_dist_params(obs)
    (w * mean).sum().backward()
    mean, _, _ = plain.actor.get_action_dist_params(obs)
    ((w * mean).sum() + weight * (mean**2).mean()).backward()

    for (name, a), (_, b) in zip(
        penalised.actor.named_parameters(), plain.actor.named_parameters(), strict=True
    ):
        assert (a.grad is None) == (b.grad is None), name
        if a.grad is not None:
            torch.testing.assert_close(a.grad, b.grad, msg=name)
    assert penalised.actor.mu.weight.grad.abs().sum() > 0


def test_it_leaves_the_actions_alone(tmp_path):
    penalised, plain, venv = _agents(tmp_path, "sac", 1.0)
    obs = venv.reset()
    a, _ = penalised.predict(obs, deterministic=True)
    b, _ = plain.predict(obs, deterministic=True)
    np.testing.assert_array_equal(a, b)


@pytest.mark.slow  # collects 64 steps and trains 30 updates twice
def test_a_saturated_actor_comes_back_only_with_the_penalty(tmp_path):
    """With mu at -40 everywhere, tanh's slope is 0 in float32: SAC's own actor loss has
    no gradient for mu's bias (the critic's through tanh, the entropy's through SB3's
    bounded correction) and it stays put; the penalty moves it towards 0."""
    penalised, plain, _ = _agents(tmp_path, "sac", 1e-3)
    biases = []
    for model in (penalised, plain):
        with torch.no_grad():
            model.actor.mu.weight.zero_()
            model.actor.mu.bias.fill_(-40.0)
        model.learn(64)  # learning_starts 32: a few updates in
        before = float(model.actor.mu.bias.detach())
        model.train(gradient_steps=30, batch_size=16)
        biases.append((before, float(model.actor.mu.bias.detach())))
    (pen_before, pen_after), (plain_before, plain_after) = biases
    assert plain_after == plain_before  # nothing reaches a saturated mean
    assert pen_after > pen_before + 1e-3  # the penalty pulls it towards 0


@pytest.mark.slow  # trains 64 steps and evaluates
def test_it_trains_saves_and_loads(tmp_path):
    from hoprover_env.agents.policies import _algo_class

    cfg = {**TINY_SAC_V1, "policy": {"net_arch": [16, 16], "actor_mean_reg": 1e-3}}
    out = train_run(tmp_path, cfg)
    model = _algo_class("sac").load(out / "final_model.zip", device="cpu")
    assert type(model.policy).__name__ == "MeanPenaltySACPolicy"
    assert model.policy.actor_mean_reg == 1e-3
    assert model.actor.mu._forward_hooks  # the penalty is back on the loaded actor


@pytest.mark.parametrize(
    "algo, value, message",
    [
        ("td3", 1e-3, "unknown config key 'policy.actor_mean_reg'"),
        ("ppo", 1e-3, "unknown config key 'policy.actor_mean_reg'"),
        ("sac", -1e-3, "actor_mean_reg"),
        ("sac", "1e-3", "actor_mean_reg"),
    ],
)
def test_the_config_refuses_it_where_it_cannot_apply(tmp_path, algo, value, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write_config(tmp_path, tiny_config(algo, {"actor_mean_reg": value})))
