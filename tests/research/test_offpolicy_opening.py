"""research/offpolicy/opening.py: the opening it reports is the actor's own at rest (its
actions are tanh of its means and those the deterministic policy takes), and a model
without a squashed-Gaussian actor is refused by name."""

import json

import numpy as np
import pytest

from helpers import train_tiny
from hoprover_env.agents.policies import BUNDLED_DIR, load_sb3
from hoprover_env.envs.registry import vector_env_class
from research.offpolicy import opening
from research.offpolicy.actors import env_arguments

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


def test_a_model_without_a_gaussian_actor_is_refused(tmp_path):
    with pytest.raises(SystemExit, match="squashed-Gaussian"):
        opening.main(["--models", str(PPO), "--out", str(tmp_path / "o.json")])
