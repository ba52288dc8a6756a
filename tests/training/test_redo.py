"""Recycling the actor's dormant units (the config section `redo`, training/redo.py):
the units it finds are those whose activation is small against their layer's, recycling
them leaves the actor's actions as they were and every other weight and Adam moment
untouched, gives those units fresh incoming weights that turn them on again, and clears
their moments; a run with it trains and resumes; the config refuses it where it cannot
apply."""

import numpy as np
import pytest
import torch

from helpers import TINY_SAC_V1, tiny_config, train_run, write_config
from hoprover_env.training import redo
from hoprover_env.training.sb3_agents import ConfigError, load_config


def _agent(tmp_path, algo: str = "sac"):
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import make_agent

    cfg = load_config(write_config(tmp_path, {**TINY_SAC_V1, "algo": algo}))
    return make_agent(cfg, HopRoverSB3VecEnv(2, env_id="HopRoverRL-v1"))


def _actor_step(actor, obs):
    """One optimiser step on a loss through every actor weight, so Adam has moments."""
    actor.optimizer.zero_grad()
    mean, log_std, _ = actor.get_action_dist_params(obs)
    (mean.square().sum() + log_std.square().sum()).backward()
    actor.optimizer.step()


def _activations(actor, obs) -> list[torch.Tensor]:
    """The output of each hidden ReLU of the actor's MLP."""
    with torch.no_grad():
        x = actor.features_extractor(obs)
        h0 = torch.relu(actor.latent_pi[0](x))
        return [h0, torch.relu(actor.latent_pi[2](h0))]


@pytest.mark.parametrize("algo", ["sac", "tqc"])
def test_recycling_keeps_the_actions_and_revives_only_the_dormant_units(tmp_path, algo):
    torch.manual_seed(0)
    model = _agent(tmp_path, algo)
    actor = model.actor
    obs = torch.randn(256, model.observation_space.shape[0])
    hidden = [m for m in actor.latent_pi if isinstance(m, torch.nn.Linear)]
    _actor_step(actor, obs)
    with torch.no_grad():
        hidden[0].bias[[1, 4]] = -100.0  # off for every state: dormant in layer 0
        hidden[1].bias[[0, 2, 9]] = -100.0  # and three in layer 1
    _actor_step(actor, obs)
    for tau in (0.1, 0.3):  # Sokar et al.'s score
        for mask, h in zip(redo.dormant_units(actor, obs, tau), _activations(actor, obs)):
            score = h.abs().mean(dim=0)
            assert torch.equal(mask, score <= tau * score.mean())
    # tau 0: the units off for every state, which the actor's actions do not depend on
    masks = redo.dormant_units(actor, obs, tau=0.0)
    found = [set(np.flatnonzero(m.numpy())) for m in masks]
    assert found == [{1, 4}, {0, 2, 9}]

    before_params = {id(p): p.detach().clone() for p in actor.parameters()}
    moments = {
        id(p): {k: s[k].clone() for k in ("exp_avg", "exp_avg_sq")}
        for p, s in actor.optimizer.state.items()
    }
    with torch.no_grad():
        mean_before = actor.get_action_dist_params(obs)[:2]
    assert redo.recycle(actor, actor.optimizer, obs, tau=0.0) == [2, 3]
    with torch.no_grad():
        mean_after = actor.get_action_dist_params(obs)[:2]
    for a, b in zip(mean_before, mean_after, strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)  # outgoing weights are zero

    # the units forced off are on again for some states; the rest of the actor is as it was
    h0, h1 = _activations(actor, obs)
    assert (h0[:, [1, 4]] > 0).any(dim=0).all() and (h1[:, [0, 2, 9]] > 0).any(dim=0).all()
    assert redo.recycle(actor, actor.optimizer, obs, tau=0.0) == [0, 0]
    # each weight matrix: rows of its own recycled units drawn afresh, columns of the units
    # it reads that were recycled zeroed (with their Adam moments), every other entry kept
    hidden0, hidden1 = hidden
    cases = [
        (hidden0, masks[0], None),
        (hidden1, masks[1], masks[0]),
        (actor.mu, None, masks[1]),
        (actor.log_std, None, masks[1]),
    ]
    for layer, rows, cols in cases:
        w, old = layer.weight, before_params[id(layer.weight)]
        state, old_state = actor.optimizer.state[w], moments[id(w)]
        keep_rows = ~rows if rows is not None else torch.ones(w.shape[0], dtype=torch.bool)
        keep_cols = ~cols if cols is not None else torch.ones(w.shape[1], dtype=torch.bool)
        kept = keep_rows[:, None] & keep_cols[None, :]
        assert torch.equal(w[kept], old[kept])
        for key in ("exp_avg", "exp_avg_sq"):
            assert torch.equal(state[key][kept], old_state[key][kept])
            assert not state[key][~kept].any()
        if cols is not None:  # (a recycled row reads recycled units: its outputs are zeroed)
            assert not w[keep_rows][:, cols].any()
        if rows is not None:
            assert (w[rows][:, keep_cols] != old[rows][:, keep_cols]).all()
            b = layer.bias
            assert torch.equal(b[~rows], before_params[id(b)][~rows])
            assert not actor.optimizer.state[b]["exp_avg"][rows].any()


def test_nothing_changes_where_no_unit_is_dormant(tmp_path):
    torch.manual_seed(1)
    model = _agent(tmp_path)
    obs = torch.randn(512, model.observation_space.shape[0])
    assert not any(m.any() for m in redo.dormant_units(model.actor, obs, tau=0.01))
    before = {k: v.clone() for k, v in model.actor.state_dict().items()}
    assert redo.recycle(model.actor, model.actor.optimizer, obs, tau=0.01) == [0, 0]
    for k, v in model.actor.state_dict().items():
        assert torch.equal(v, before[k]), k


def test_a_run_with_redo_trains_recycles_and_resumes(tmp_path, capfd):
    from hoprover_env.training import train

    cfg = {**TINY_SAC_V1, "timesteps": 96, "redo": {"freq": 16, "tau": 0.5, "batch": 32}}
    out = train_run(tmp_path, cfg)
    lines = [x for x in capfd.readouterr().err.splitlines() if "redo @" in x]
    # after learning_starts (32 steps), every 16 steps: at 48, 64, 80 and 96
    assert [int(x.split("@")[1].split(":")[0]) for x in lines] == [48, 64, 80, 96]
    args = ["--config", str(out / "config.yaml"), "--out", str(out), "--resume"]
    assert train.main([*args, "--timesteps", "128", "--no-progress"]) == 0
    lines = [x for x in capfd.readouterr().err.splitlines() if "redo @" in x]
    assert [int(x.split("@")[1].split(":")[0]) for x in lines] == [112, 128]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"algo": "td3", "policy": {}}, "needs algo sac or tqc, got 'td3'"),
        ({"policy": {"actor_layer_norm": True}}, "policy.actor_layer_norm: true"),
        ({"redo": {"tau": 0.0}}, "redo.tau"),
        ({"redo": {"freq": 0}}, "redo.freq"),
        ({"redo": {"every": 10}}, "unknown config key 'redo.every'"),
    ],
)
def test_the_config_refuses_redo_where_it_cannot_apply(tmp_path, change, message):
    cfg = {**tiny_config("sac", {"net_arch": [16, 16]}), "redo": {}, **change}
    with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
        load_config(write_config(tmp_path, cfg))
