"""Cloning an expert (hoprover_env.training.warm_start): the weighted fit, and mpc's labels while a
learner drives (DAgger)."""

import numpy as np
import pytest
import torch

from hoprover_env.training.warm_start import _fit, collect


def _constant_fit(weight, lr_end=None, epochs=200):
    """Fit one constant to samples 0 (first half) and 1 (second half)."""
    torch.manual_seed(0)
    c = torch.zeros(1, requires_grad=True)
    x = torch.zeros(100, 1)
    y = torch.cat([torch.zeros(50, 1), torch.ones(50, 1)])
    _fit(
        [c],
        lambda xb: c.expand(len(xb), 1),
        x,
        y,
        epochs,
        25,
        0.05,
        np.random.default_rng(0),
        weight=weight,
        learning_rate_end=lr_end,
    )
    return float(c.detach())


def test_weighted_fit_finds_the_weighted_mean():
    # least squares of a constant is the (weighted) mean of the targets
    assert _constant_fit(None, lr_end=1e-4) == pytest.approx(0.5, abs=0.01)
    w = torch.cat([torch.ones(50), torch.full((50,), 9.0)])
    assert _constant_fit(w, lr_end=1e-4) == pytest.approx(0.9, abs=0.01)


def test_cosine_decay_settles_where_a_constant_rate_keeps_jumping():
    # mini-batches of 25 from two groups: Adam at a constant 0.05 keeps moving with the
    # batch mix; decayed to 1e-4 it ends at the mean
    decayed = [abs(_constant_fit(None, lr_end=1e-4, epochs=e) - 0.5) for e in (50, 51, 52)]
    constant = [abs(_constant_fit(None, epochs=e) - 0.5) for e in (50, 51, 52)]
    assert max(decayed) < 0.002 < max(constant)


def test_mpc_replans_from_the_learners_flight_when_shadowing():
    # driving itself, mpc plans once per hop; labelling a learner's episode (DAgger) it
    # plans again at the learner's liftoff, from the flight the learner actually made
    from hoprover_env.agents.mpc import MPCPolicy
    from hoprover_env.agents.policies import load_policy

    kw = {"control_dt": 0.5, "episode_time": 300.0, "target_range": (0.6, 0.6)}
    alone = MPCPolicy(budget=200)
    collect(alone, kw, 1, seed=0, gamma=0.99)
    shadow = MPCPolicy(budget=200)
    obs, act, _ = collect(
        shadow, kw, 1, seed=0, gamma=0.99, executor=load_policy("scripted", control_dt=0.5)
    )
    assert alone.decisions == 1
    assert shadow.shadowing and shadow.decisions >= 2
    assert len(obs) == len(act) and np.all(np.abs(act) <= 1.0)


def test_sample_weights_single_out_the_launch_and_the_first_decision():
    from hoprover_env.tasks.observation import OBS_DIM, OBS_MODE, OBS_TIME
    from hoprover_env.training.warm_start import sample_weights

    obs = np.zeros((4, OBS_DIM), dtype=np.float32)
    obs[:, OBS_TIME] = np.array([0.0, 10.0, 30.0, 10.0]) / 600.0
    obs[3, OBS_MODE] = 1.0  # the last one in flight
    assert sample_weights(obs) is None  # plain least squares
    # ground_weight alone weighs every ground sample alike, as before launch weights
    assert sample_weights(obs, 10.0).tolist() == [10.0, 10.0, 10.0, 1.0]
    assert sample_weights(obs, 10.0, 100.0).tolist() == [100.0, 100.0, 10.0, 1.0]
    assert sample_weights(obs, 10.0, 100.0, 1000.0).tolist() == [1000.0, 100.0, 10.0, 1.0]
    # the clock is scaled by the env's episode length
    assert sample_weights(obs, 10.0, 100.0, episode_time=6000.0).tolist() == [
        100.0,
        10.0,
        10.0,
        1.0,
    ]
    with pytest.raises(ValueError, match="observation"):
        sample_weights(np.zeros((2, 5)), 10.0)


def test_collect_runs_the_targets_it_is_given():
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.tasks.observation import OBS_DX, OBS_TIME

    targets = np.array([0.3, -0.7, 0.05])
    obs, act, _ = collect(
        load_policy("scripted", control_dt=2.0),
        {"control_dt": 2.0, "episode_time": 100.0},
        3,
        seed=0,
        gamma=0.99,
        targets=targets,
    )
    first = obs[obs[:, OBS_TIME] == 0.0]
    # the start is at x = 0: the first observation of each episode is -target
    assert sorted(first[:, OBS_DX].tolist()) == pytest.approx(sorted(-targets), abs=1e-6)
    with pytest.raises(ValueError, match="targets"):
        collect(load_policy("scripted"), {}, 2, seed=0, gamma=0.99, targets=targets)
