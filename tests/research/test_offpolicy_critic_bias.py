"""research/offpolicy/critic_bias.py: a critic's value against the soft return its
policy earned. The return must be the sum the learner's target unrolls to (rewards,
the entropy bonus of every later action, the bootstrap at a cut), and the report must
place every decision in one contact state."""

import json

import numpy as np
import pytest

from helpers import train_tiny
from research.offpolicy import critic_bias


def test_soft_returns_are_the_discounted_sum_the_target_unrolls_to():
    rng = np.random.default_rng(0)
    rewards, logps = rng.normal(size=7), rng.normal(size=7)
    steps = [(0.0, r, lp, 0, 0.0) for r, lp in zip(rewards, logps)]
    gamma, alpha, tail = 0.9, 0.3, 2.5
    g = critic_bias.soft_returns(steps, tail, gamma, alpha)
    T = len(steps)
    for t in range(T):
        want = sum(gamma**k * rewards[t + k] for k in range(T - t))
        want -= alpha * sum(gamma**k * logps[t + k] for k in range(1, T - t))
        want += gamma ** (T - t) * tail
        assert g[t] == pytest.approx(want, rel=1e-12)


@pytest.mark.slow  # trains a tiny SAC, then plays whole episodes
def test_every_decision_is_counted_once(tmp_path):
    model = str(train_tiny(tmp_path))
    report_path = tmp_path / "bias.json"
    args = ["--model", model, "--episodes", "3", "--out", str(report_path)]
    assert critic_bias.main(args) == 0
    report = json.loads(report_path.read_text())
    states = report["per_state"]
    assert states["rest"]["decisions"] >= 3  # every episode starts at rest
    flight = states["flight"]["decisions"]
    assert states["flight_upright"]["decisions"] + states["flight_tilted"]["decisions"] == flight
    assert report["alpha"] > 0 and report["gamma"] == pytest.approx(0.995)
    for row in states.values():
        if row["decisions"]:
            assert np.isfinite(row["median_bias"]) and np.isfinite(row["median_return"])
