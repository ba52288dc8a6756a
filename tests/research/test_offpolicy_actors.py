"""research/offpolicy/actors.py: what a trained actor does per contact state. Its counts
must add up: every decision in one contact state, every break traced to the contact
state of the decision before it. The action gap reads each flight state with its own
episode's target, and the return it sets beside Q is the one a plain play-out earns."""

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
                "--gap-returns",
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
    for row in report["action_gap"]:
        assert len(row["returns"]) == len(row["q"]) == len(actors.GRID)
        np.testing.assert_allclose(
            np.subtract(row["q"], row["returns"]), row["q_minus_return"], atol=1e-9
        )


def _played_out(policy, x0, target):
    """The discounted return of each GRID action at x0, then the deterministic actor,
    bootstrapped with the critic at the time limit: the oracle for action_returns, with
    one single env per action. The actor still sees the 21 observations as one batch:
    a float32 network's output for a row differs with the batch's size by rounding (up
    to 2e-7 here), which hundreds of decisions of this dynamics amplify."""
    import torch

    n, model = len(actors.GRID), policy.model
    envs = [
        actors.env_class(policy.env_id)(target_x=target, **actors.env_arguments(policy))
        for _ in range(n)
    ]
    obs = np.stack([env.reset(seed=0, options={"initial_state": x0})[0] for env in envs])
    policy.reset(n)
    act = actors.GRID[:, None].astype(np.float32)
    ret, discount, open_ = np.zeros(n), np.ones(n), np.ones(n, bool)
    while open_.any():
        for i in np.flatnonzero(open_):
            obs[i], rew, term, trunc, _ = envs[i].step(act[i])
            ret[i] += discount[i] * float(rew)
            discount[i] *= model.gamma
            if trunc and not term:
                o = torch.as_tensor(policy.normalize(obs[i : i + 1]), dtype=torch.float32)
                tail_act, _ = model.predict(o.numpy(), deterministic=True)
                ret[i] += discount[i] * float(
                    actors.critic_value(model, o, torch.as_tensor(tail_act))[0]
                )
            open_[i] = not (term or trunc)
        act = np.asarray(policy.act(obs, None), np.float32)
    return ret


@pytest.mark.slow  # trains a tiny SAC, then plays episodes out from flight states
def test_each_flight_state_keeps_its_episodes_target_and_its_returns_are_played_out(
    tmp_path, monkeypatch
):
    policy = load_sb3(train_tiny(tmp_path))
    targets = np.array([-0.9, 0.8, -0.3, 0.5])
    run = actors.play(policy, targets, seed=3)
    assert len(run["flight_state_episode"]) == len(run["flight_states"])
    if len(run["flight_states"]) == 0:
        pytest.skip("the tiny actor never flew")
    built: list[float] = []  # the target of every single env action_gap builds
    make = actors.env_class

    def recording(env_id):
        cls = make(env_id)

        def build(**kw):
            built.append(kw["target_x"])
            return cls(**kw)

        return build

    monkeypatch.setattr(actors, "env_class", recording)
    rng = np.random.default_rng(0)
    pick = np.random.default_rng(0).choice(len(run["flight_states"]), size=2, replace=False)
    rows = actors.action_gap(policy, run, targets, 2, rng, returns=True)
    monkeypatch.setattr(actors, "env_class", make)
    assert built == [targets[run["flight_state_episode"][j]] for j in pick]
    for j, row in zip(pick, rows):
        x0 = run["flight_states"][j]
        target = float(targets[run["flight_state_episode"][j]])
        # equal but for the critic's float32 value at the cut, read here one row at a time
        np.testing.assert_allclose(row["returns"], _played_out(policy, x0, target), rtol=1e-9)


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
