"""research/offpolicy/actors.py: what a trained actor does per contact state. Its counts
must add up: every decision in one contact state, every break traced to the contact
state of the decision before it."""

import json

import numpy as np
import pytest

from helpers import train_tiny
from hoprover_env.agents.policies import load_sb3
from research.offpolicy import actors


@pytest.mark.slow  # trains a tiny SAC, then plays whole episodes
def test_the_report_accounts_for_every_decision_and_every_break(tmp_path):
    model = train_tiny(tmp_path)
    report_path = tmp_path / "actors.json"
    assert (
        actors.main(
            [
                "--model",
                str(model),
                "--episodes",
                "6",
                "--gap-states",
                "2",
                "--out",
                str(report_path),
            ]
        )
        == 0
    )
    report = json.loads(report_path.read_text())
    assert report["episodes"] == 6
    assert sum(report["broken_from"].values()) == report["broken"]
    assert report["broken"] + report["success"] <= 6
    # the two sides split the episodes and their successes
    sides = report["by_side"]
    assert sum(side["episodes"] for side in sides.values()) == 6
    assert sum(side["success"] for side in sides.values()) == report["success"]
    states = report["per_state"]
    assert set(states) == {"rest", "contact", "flight"}
    assert sum(s["decisions"] for s in states.values()) > 0
    assert states["rest"]["decisions"] >= 6  # every episode starts at rest
    if states["flight"]["decisions"] > 2:
        assert 0.0 <= states["flight"]["p90_abs_theta_deg"] <= 180.0
    # a SAC actor explores: every state it acted in reports its spread and how often
    # an exploring action would tip a rover at rest
    for s in states.values():
        if s["decisions"]:
            assert s["median_exploring_spread"] > 0.0
            assert 0.0 <= s["exploring_tip_probability"] <= 1.0
            assert s["median_abs_pre_tanh_mean"] >= 0.0
            assert 0.0 <= s["saturated_share"] <= 1.0
    # the pre-tanh mean it reports is the one the actor acts with: action = tanh(mean)
    policy = load_sb3(model)
    obs = np.random.default_rng(0).normal(size=(16, policy.model.observation_space.shape[0]))
    np.testing.assert_allclose(
        np.tanh(actors.pre_tanh_mean(policy, obs)), policy.act(obs, None)[:, 0], atol=1e-6
    )


def test_the_tipping_probability_of_an_exploring_action():
    """P(|a + spread z| > tip) for z standard normal: at a = 0 and spread = tip it is
    P(|z| > 1); without spread it is whether the action itself tips; far beyond the
    tipping torque it is 1."""

    p = actors.tip_probability(
        np.array([0.0, 0.0, 0.005, 0.5]), np.array([0.01, 0.0, 0.0, 0.01]), 0.01
    )
    assert p[0] == pytest.approx(0.3173, abs=1e-4)
    assert p[1] == 0.0 and p[2] == 0.0
    assert p[3] == pytest.approx(1.0)


def test_td3s_exploring_spread_is_its_action_noise_also_when_vectorized():
    """SB3 wraps TD3's Gaussian noise in a VectorizedActionNoise once it learns with
    several envs (and saves it so); the spread is the noise's sigma either way."""
    from types import SimpleNamespace

    from stable_baselines3.common.noise import NormalActionNoise, VectorizedActionNoise

    noise = NormalActionNoise(np.zeros(1), 0.03 * np.ones(1))
    obs = np.zeros((3, 20), np.float32)
    for n in (noise, VectorizedActionNoise(noise, 4)):
        policy = SimpleNamespace(model=SimpleNamespace(action_noise=n))
        assert actors.exploring_spread(policy, obs) == pytest.approx([0.03] * 3)
