"""HopRoverRL-v1: the observation resolves what the reward depends on, the per-decision
attitude cost, the flight starts of training, and evaluation unchanged by them."""

import math

import gymnasium as gym
import numpy as np
import pytest

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.agents.base import ArrayPolicy
from hoprover_env.evaluation.episodes import run_episodes
from hoprover_env.tasks import reward as rw
from hoprover_env.tasks import torque_rl as v1
from hoprover_env.tasks.draws import NEAR_RADIUS

H = 0.05


def flying(omega, x=0.3, theta=0.4):
    return np.array([x, 1.0, theta, 0.002, 0.001, omega])


def test_the_spin_slot_resolves_every_spin_the_attitude_term_tells_apart():
    env = gym.make("HopRoverRL-v1")
    seen, potentials = [], []
    for omega in (2.0, 5.0, 10.0, 20.0, 29.0):
        obs, _ = env.reset(seed=0, options={"initial_state": flying(omega)})
        seen.append(obs[v1.OBS_SPIN])
        u = 0.5 * (omega / 0.3) ** 2
        potentials.append(rw.U_Q * math.log1p(min(u, rw.U_MAX) / rw.U_Q))
        # the fine slot saturates...
        assert obs[v1.OBS_RATE] == pytest.approx(min(omega / 0.3, 10.0))
    assert np.all(np.diff(seen) > 0.1)  # ...the whole-range one does not
    assert np.all(np.diff(potentials) > 0)
    assert max(seen) < v1.SPIN_BOUND


def test_positions_resolve_the_distance_cap_and_the_time_is_not_observed():
    env = gym.make("HopRoverRL-v1")
    a, _ = env.reset(seed=1, options={"target_x": 0.0, "initial_state": flying(0.0, x=4.9)})
    b, _ = env.reset(seed=1, options={"target_x": 0.0, "initial_state": flying(0.0, x=4.5)})
    assert a[v1.OBS_DX] == pytest.approx(4.9) and b[v1.OBS_DX] == pytest.approx(4.5)
    assert a[v1.OBS_REF_FAR] != b[v1.OBS_REF_FAR]
    assert env.observation_space.shape == (v1.OBS_DIM,)
    # at rest the observation is the same at any time: no clock in it
    env.reset(seed=2, options={"target_x": 0.8})
    first = None
    for _ in range(5):
        obs, *_ = env.step(np.zeros(1, np.float32))
        first = obs if first is None else first
        np.testing.assert_array_equal(obs, first)
    with pytest.raises(ValueError, match="dist_cap"):
        gym.make("HopRoverRL-v1", dist_cap=12.0)


def test_the_attitude_cost_charges_each_decision_that_ends_in_flight():
    kw = dict(info_level="full")
    with_cost = gym.make("HopRoverRL-v1", attitude_cost=0.3, **kw)
    without = gym.make("HopRoverRL-v1", attitude_cost=0.0, **kw)
    rng = np.random.default_rng(0)
    in_flight = 0
    for env in (with_cost, without):
        env.reset(seed=5, options={"initial_state": flying(1.5)})
    for _ in range(30):
        a = rng.uniform(-1, 1, 1).astype(np.float32)
        _, r1, t1, _, i1 = with_cost.step(a)
        _, r0, t0, _, i0 = without.step(a)
        assert t1 == t0
        np.testing.assert_array_equal(i1["rover_state"], i0["rover_state"])
        theta, omega = i1["rover_state"][2], i1["rover_state"][5]
        if i1["state"] == 0 and not i1["broken"]:
            in_flight += 1
            u = 0.5 * (omega / 0.3) ** 2
            err = (1 - math.cos(theta)) + rw.U_Q * math.log1p(min(u, rw.U_MAX) / rw.U_Q)
            assert i1["reward_attitude_cost"] == pytest.approx(-0.3 * err, rel=1e-12)
        else:
            assert i1["reward_attitude_cost"] == 0.0
        assert r1 - r0 == pytest.approx(i1["reward_attitude_cost"], abs=1e-9)
        assert i0["reward_attitude_cost"] == 0.0
        if t1:
            break
    assert in_flight > 0
    with pytest.raises(ValueError, match="attitude_cost"):
        gym.make("HopRoverRL-v1", attitude_cost=-1.0)


def test_flight_starts_are_the_share_asked_for_valid_and_the_same_in_the_vector_env():
    n = 400
    venv = gym.make_vec("HopRoverRL-v1", num_envs=n, flight_start=0.5, info_level="full")
    obs, info = venv.reset(seed=10)
    modes = np.asarray(info["state"])
    flights = int((modes == 0).sum())
    assert 150 < flights < 250
    assert set(np.unique(modes)) <= {0, 5}
    # in flight the lowest corner is clear of the ground, at rest the rover is upright at 0
    x, y, theta = (np.asarray(info["rover_state"])[:, k] for k in range(3))
    low = y - H * (np.abs(np.cos(theta)) + np.abs(np.sin(theta)))
    assert (low[modes == 0] > 0.0).all()
    assert (x[modes == 5] == 0.0).all()
    env = gym.make("HopRoverRL-v1", flight_start=0.5)
    for i in (0, 1, 7, 123):
        single, _ = env.reset(seed=10 + i)
        np.testing.assert_array_equal(single, obs[i])
    # off by default: every start at rest, as in the contest
    _, info = gym.make_vec("HopRoverRL-v1", num_envs=50).reset(seed=10)
    assert (np.asarray(info["state"]) == 5).all()


def test_near_starts_are_the_share_asked_for_at_rest_near_the_target_and_vectorised():
    n = 400
    kw = {"flight_start": 0.25, "near_start": 0.5, "info_level": "full"}
    venv = gym.make_vec("HopRoverRL-v1", num_envs=n, **kw)
    obs, info = venv.reset(seed=3)
    modes = np.asarray(info["state"])
    x = np.asarray(info["rover_state"])[:, 0]
    gap = x - np.asarray(info["target_x"])
    at_rest = modes == 5
    near = at_rest & (x != 0.0)
    assert 50 < int((modes == 0).sum()) < 150  # flight: a quarter
    assert 150 < int(near.sum()) < 250  # near the target: half
    assert (np.abs(gap[near]) <= NEAR_RADIUS).all()
    assert np.abs(gap[near]).max() > 0.8 * NEAR_RADIUS  # spread over the radius
    assert (np.abs(gap[near]) < 0.1).any()  # some start within reach of the band
    theta = np.asarray(info["rover_state"])[:, 2]
    assert (theta[at_rest] == 0.0).all()
    env = gym.make("HopRoverRL-v1", **kw)
    for i in (0, 2, 5, 77):
        single, _ = env.reset(seed=3 + i)
        np.testing.assert_array_equal(single, obs[i])
    # flight_start alone draws the flight starts it drew before near_start existed
    a, _ = gym.make_vec("HopRoverRL-v1", num_envs=64, flight_start=0.5).reset(seed=9)
    b, _ = gym.make_vec("HopRoverRL-v1", num_envs=64, flight_start=0.5, near_start=0.0).reset(
        seed=9
    )
    np.testing.assert_array_equal(a, b)


def test_near_start_is_checked_and_refused_where_it_cannot_apply():
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="near_start"):
            gym.make("HopRoverRL-v1", near_start=bad)
    with pytest.raises(ValueError, match="flight_start \\+ near_start"):
        gym.make("HopRoverRL-v1", flight_start=0.6, near_start=0.5)
    with pytest.raises(TypeError, match="near_start"):
        gym.make("HopRoverHop-v0", near_start=0.5)


def test_flight_start_is_checked_and_refused_where_it_cannot_apply():
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="flight_start"):
            gym.make("HopRoverRL-v1", flight_start=bad)
    # one draw path: flight starts need no option to apply (`draws` is no argument)
    with pytest.raises(TypeError, match="draws"):
        gym.make("HopRoverRL-v1", flight_start=0.5, draws="legacy")
    with pytest.raises(TypeError, match="flight_start"):
        gym.make("HopRoverHop-v0", flight_start=0.5)


def test_evaluation_starts_at_rest_whatever_the_training_starts():
    policy = ArrayPolicy(
        lambda obs: np.full((len(obs), 1), 0.8, np.float32), name="push", env_id="HopRoverRL-v1"
    )
    targets = np.linspace(-0.9, 0.9, 6)
    trained = run_episodes(policy, targets, {"flight_start": 0.5, "near_start": 0.5})
    contest = run_episodes(policy, targets, {})
    for a, b in zip(trained, contest):
        assert (a.success, a.broken, a.steps, a.final_x) == (
            b.success,
            b.broken,
            b.steps,
            b.final_x,
        )
