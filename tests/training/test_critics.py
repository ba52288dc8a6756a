"""Critics with layer normalisation (`policy.critic_layer_norm`, training/critics.py): the
option puts a LayerNorm after each hidden layer of every Q-network, online and target,
leaves the actor as SB3 builds it, survives save and load, and the config refuses it
where hoprover has no such critic."""

import numpy as np
import pytest
import torch.nn as nn

from helpers import TINY_SAC_V1, tiny_config, train_run, write_config
from hoprover_env.training.sb3_agents import ConfigError, load_config


def _norms(module):
    return [m for m in module.modules() if isinstance(m, nn.LayerNorm)]


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_each_hidden_layer_of_each_critic_is_normalised(tmp_path, algo):
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import make_agent

    cfg = load_config(
        write_config(
            tmp_path,
            {
                **TINY_SAC_V1,
                "algo": algo,
                "policy": {"net_arch": [16, 8], "critic_layer_norm": True},
            },
        )
    )
    venv = HopRoverSB3VecEnv(1, env_id="HopRoverRL-v1")
    model = make_agent(cfg, venv)
    plain = make_agent({**cfg, "policy": {"net_arch": [16, 8]}}, venv)
    for critic in (model.critic, model.critic_target):
        assert len(critic.q_networks) == 2
        for q_net in critic.q_networks:
            widths = [m.normalized_shape[0] for m in _norms(q_net)]
            assert widths == [16, 8]  # after each hidden layer, none after the output
        params = set(map(id, critic.parameters()))
        assert all(id(p) in params for q in critic.q_networks for p in q.parameters())
    # the optimiser updates the normalised networks, not SB3's replaced ones
    optimised = {id(p) for g in model.critic.optimizer.param_groups for p in g["params"]}
    assert {id(p) for q in model.critic.q_networks for p in q.parameters()} <= optimised
    assert not _norms(model.actor) and not _norms(plain.critic)


@pytest.mark.slow  # trains 64 steps and evaluates
def test_a_normalised_critic_trains_saves_and_loads(tmp_path):
    from hoprover_env.agents.policies import _algo_class

    cfg = {**TINY_SAC_V1, "policy": {"net_arch": [16, 16], "critic_layer_norm": True}}
    out = train_run(tmp_path, cfg)
    model = _algo_class("sac").load(out / "final_model.zip", device="cpu")
    assert len(_norms(model.critic)) == 4 and len(_norms(model.critic_target)) == 4
    obs = np.zeros((3, model.observation_space.shape[0]), dtype=np.float32)
    action, _ = model.predict(obs, deterministic=True)
    assert action.shape == (3, 1) and np.all(np.isfinite(action))


@pytest.mark.parametrize(
    "algo, value, message",
    [
        ("ppo", True, "unknown config key 'policy.critic_layer_norm'"),
        ("tqc", True, "unknown config key 'policy.critic_layer_norm'"),
        ("sac", "yes", "critic_layer_norm"),
    ],
)
def test_the_config_refuses_it_where_it_cannot_apply(tmp_path, algo, value, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write_config(tmp_path, tiny_config(algo, {"critic_layer_norm": value})))
