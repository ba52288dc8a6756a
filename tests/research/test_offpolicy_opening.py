"""research/offpolicy/opening.py: the opening it reports is the actor's own at rest (its
actions are tanh of its means and those the deterministic policy takes), and a model
without a squashed-Gaussian actor is refused by name; its count of active hidden units and
its critic slope are the actor's and the critic's own."""

import json

import numpy as np
import pytest
import torch

from helpers import train_tiny
from hoprover_env.agents.policies import BUNDLED_DIR, load_sb3
from hoprover_env.envs.registry import vector_env_class
from research.offpolicy import opening
from research.offpolicy.actors import critic_value, env_arguments

PPO = BUNDLED_DIR / "ppo_scratch.zip"  # PPO's actor is a Gaussian without tanh


@pytest.mark.slow  # trains a tiny SAC
def test_the_opening_is_the_actors_action_at_rest(tmp_path):
    model = train_tiny(tmp_path)
    out = tmp_path / "opening.json"
    assert opening.main(["--models", str(model), "--targets", "5", "--out", str(out)]) == 0
    (row,) = json.loads(out.read_text())
    assert row["timesteps"] == 64 and row["targets"] == [-1.0, -0.5, 0.0, 0.5, 1.0]
    mu = np.asarray(row["mu"])
    assert row["max_abs_mu"] == pytest.approx(np.abs(mu).max())
    assert row["action_min"] == pytest.approx(np.tanh(mu).min())
    assert set(row["critic_argmax"]) <= set(opening.ACTIONS.tolist())
    assert all(r >= 0 for r in row["critic_range"])
    # the same starts played by the deterministic policy give tanh(mu)
    policy = load_sb3(model)
    venv = vector_env_class(policy.env_id)(5, **env_arguments(policy))
    obs, _ = venv.reset(seed=0, options={"target_x": np.asarray(row["targets"])})
    np.testing.assert_allclose(policy.act(obs, venv)[:, 0], np.tanh(mu), atol=1e-6)
    # a count per hidden layer and target, within the layer's width
    widths = [m.out_features for m in policy.model.actor.latent_pi if hasattr(m, "out_features")]
    assert [len(layer) for layer in row["active_units"]] == [5] * len(widths)
    for layer, width in zip(row["active_units"], widths, strict=True):
        assert all(0 <= n <= width for n in layer)
    assert row["last_layer_active_max"] == max(row["active_units"][-1])
    # the critic's slope at the actor's action is the critic's own, by central differences
    o = torch.as_tensor(policy.normalize(obs), dtype=torch.float32)
    a, h = np.tanh(mu), 1e-3
    value = [
        critic_value(policy.model, o, torch.as_tensor((a + d)[:, None], dtype=torch.float32))
        for d in (h, -h)
    ]
    np.testing.assert_allclose(row["critic_slope"], (value[0] - value[1]) / (2 * h), atol=2e-3)


def test_a_model_without_a_gaussian_actor_is_refused(tmp_path):
    with pytest.raises(SystemExit, match="squashed-Gaussian"):
        opening.main(["--models", str(PPO), "--out", str(tmp_path / "o.json")])
