"""The actor's own learning rate (`policy.actor_lr_scale`, training/actor_penalty.py):
the actor's optimiser steps with that multiple of the rate SB3 gives it and the critics'
with the rate itself, the rate reads as given between steps, the option survives save
and load, and the config refuses it where it cannot apply."""

import pytest
import torch

from helpers import TINY_SAC_V1, tiny_config, write_config
from hoprover_env.training.sb3_agents import ConfigError, load_config


def _agent(tmp_path, algo: str, scale: float | None):
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import make_agent

    policy = {"net_arch": [16, 16]} | ({} if scale is None else {"actor_lr_scale": scale})
    cfg = load_config(write_config(tmp_path, {**TINY_SAC_V1, "algo": algo, "policy": policy}))
    return make_agent(cfg, HopRoverSB3VecEnv(2, env_id="HopRoverRL-v1"))


def _first_weight(actor) -> torch.nn.Parameter:
    # SAC's and TQC's actors: an MLP then a Gaussian head; TD3's: one MLP, `mu`
    return actor.latent_pi[0].weight if hasattr(actor, "latent_pi") else actor.mu[0].weight


def _act(actor, obs) -> torch.Tensor:
    return actor(obs, deterministic=True) if hasattr(actor, "latent_pi") else actor(obs)


def _step_deltas(model, obs) -> tuple[torch.Tensor, torch.Tensor]:
    """One Adam step of the actor and of the critic at SB3's rate 1e-3, on losses of the
    same batch; the change of each one's first weight matrix."""
    from stable_baselines3.common.utils import update_learning_rate

    actor, critic = model.actor, model.critic
    a0, c0 = _first_weight(actor).clone(), critic.qf0[0].weight.clone()
    for opt in (actor.optimizer, critic.optimizer):
        update_learning_rate(opt, 1e-3)
        opt.zero_grad()
    _act(actor, obs).square().sum().backward()
    critic(obs, torch.zeros(len(obs), 1))[0].square().sum().backward()
    actor.optimizer.step()
    critic.optimizer.step()
    return _first_weight(actor) - a0, critic.qf0[0].weight - c0


@pytest.mark.parametrize("algo", ["sac", "tqc", "td3"])
def test_the_actor_steps_with_its_multiple_of_the_rate(tmp_path, algo):
    torch.manual_seed(3)
    plain = _agent(tmp_path, algo, None)
    torch.manual_seed(3)
    scaled = _agent(tmp_path, algo, 0.1)
    obs = torch.randn(32, plain.observation_space.shape[0])
    assert torch.equal(_first_weight(plain.actor), _first_weight(scaled.actor))
    if algo == "tqc":  # TQC's critic returns quantiles, not a tuple of Q-values
        return _check_tqc(plain, scaled, obs)
    (pa, pc), (sa, sc) = _step_deltas(plain, obs), _step_deltas(scaled, obs)
    # Adam's first step is the rate times g / (|g| + eps): the deltas scale with the rate
    torch.testing.assert_close(sa, 0.1 * pa, rtol=1e-4, atol=1e-9)
    torch.testing.assert_close(sc, pc, rtol=0, atol=0)
    assert scaled.actor.optimizer.param_groups[0]["lr"] == pytest.approx(1e-3, rel=1e-12)
    assert scaled.policy.actor_lr_scale == 0.1 and plain.policy.__class__.__module__.startswith(
        "stable_baselines3"
    )


def _check_tqc(plain, scaled, obs):
    from stable_baselines3.common.utils import update_learning_rate

    deltas = []
    for model in (plain, scaled):
        w0 = model.actor.latent_pi[0].weight.clone()
        update_learning_rate(model.actor.optimizer, 1e-3)
        model.actor.optimizer.zero_grad()
        model.actor(obs, deterministic=True).square().sum().backward()
        model.actor.optimizer.step()
        deltas.append(model.actor.latent_pi[0].weight - w0)
    torch.testing.assert_close(deltas[1], 0.1 * deltas[0], rtol=1e-4, atol=1e-9)


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_the_scale_survives_save_and_load(tmp_path, algo):
    from hoprover_env.training.sb3_agents import algo_class

    torch.manual_seed(5)
    model = _agent(tmp_path, algo, 0.25)
    model.save(tmp_path / "m.zip")
    loaded = algo_class(algo).load(tmp_path / "m.zip")
    assert loaded.policy.actor_lr_scale == 0.25
    obs = torch.randn(16, model.observation_space.shape[0])
    torch.manual_seed(5)
    fresh = _agent(tmp_path, algo, None)
    fresh.policy.load_state_dict(loaded.policy.state_dict())
    (fa, _), (la, _) = _step_deltas(fresh, obs), _step_deltas(loaded, obs)
    torch.testing.assert_close(la, 0.25 * fa, rtol=1e-4, atol=1e-9)


@pytest.mark.parametrize(
    ("algo", "policy", "message"),
    [
        ("td3", {"actor_mean_reg": 1e-3}, "unknown config key 'policy.actor_mean_reg'"),
        ("ppo", {"actor_lr_scale": 0.1}, "unknown config key 'policy.actor_lr_scale'"),
        ("sac", {"actor_lr_scale": 0.0}, "policy.actor_lr_scale"),
        ("sac", {"actor_lr_scale": "low"}, "policy.actor_lr_scale"),
    ],
)
def test_the_config_refuses_it_where_it_cannot_apply(tmp_path, algo, policy, message):
    with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
        load_config(write_config(tmp_path, tiny_config(algo, policy)))
