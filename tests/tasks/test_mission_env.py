"""HopRoverMission-v0: checkers, vector == single, replay from a seed, the documented
noise (statistics over many readings), no hidden state in the observation, the
actuator's scale error and the unknown ground, bad arguments."""

import math

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env import core
from hoprover_env.envs.registry import HopRoverMissionEnv, HopRoverMissionVectorEnv
from hoprover_env.tasks import mission

TRUNC_STD = 0.9866  # standard deviation of a unit normal truncated at |z| <= 3


def _random_actions(n, seed, scale=0.05):
    """Mostly small torques (the rover tips, rests, now and then hops), some full ones."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, (n, 1)) * scale
    a[rng.random(n) < 0.05] *= 1 / scale
    return a.astype(np.float32)


def test_checkers_pass_and_the_observation_has_the_documented_shape():
    env = HopRoverMissionEnv(history=3)
    gym_check_env(env)
    sb3_check_env(env)
    obs, info = env.reset(seed=2)
    assert obs.shape == (24,) and env.observation_space.contains(obs)
    # at reset every slot of the history holds the first reading
    assert np.array_equal(obs[:8], obs[8:16]) and np.array_equal(obs[:8], obs[16:])
    first = obs[:8].copy()
    obs, *_ = env.step(np.array([0.02], np.float32))
    assert np.array_equal(obs[8:16], first)  # shifted back by one, newest first


def test_the_vector_env_equals_single_envs_bit_for_bit_and_a_seed_replays():
    n, steps = 4, 120
    acts = _random_actions(steps * n, 5).reshape(steps, n, 1)
    venv = HopRoverMissionVectorEnv(n, history=2)
    vo, _ = venv.reset(seed=10)
    vobs, vrew = [vo.copy()], []
    for a in acts:
        o, r, *_ = venv.step(a.astype(np.float64))
        vobs.append(o.copy())
        vrew.append(r.copy())
    for i in range(n):
        for _ in range(2):  # twice: a seed replays
            env = HopRoverMissionEnv(history=2)
            o, _ = env.reset(seed=10 + i)
            assert np.array_equal(o, vobs[0][i])
            done = False
            for k, a in enumerate(acts):
                if done:  # NextStep: the vector env resets here
                    o, _ = env.reset()
                    done = False
                    assert np.array_equal(o, vobs[k + 1][i])
                    continue
                o, r, te, tr, _ = env.step(a[i])
                done = te or tr
                assert np.array_equal(o, vobs[k + 1][i]) and r == vrew[k][i], (i, k)


def _readings(noise_scale=1.0, episodes=6, steps=300, scale=0.05, **kw):
    """(observation, true state, hidden info) at every control instant of random
    episodes."""
    env = HopRoverMissionEnv(info_level="full", noise_scale=noise_scale, **kw)
    rows = []
    for ep in range(episodes):
        obs, info = env.reset(seed=ep)
        acts = _random_actions(steps, 100 + ep, scale)
        for a in acts:
            rows.append(
                (
                    obs.copy(),
                    info["rover_state"].copy(),
                    info["target_x"],
                    info["attitude_bias"],
                    env.params,
                    float(info["t"]) if "t" in info else 0.0,
                )
            )
            obs, _, te, tr, info = env.step(a)
            if te or tr:
                break
    return rows


def test_the_readings_differ_from_the_true_state_by_the_documented_noise():
    cfg = HopRoverMissionEnv().config
    rows = _readings()
    att = np.array(
        [math.atan2(o[mission.OBS_SIN], o[mission.OBS_COS]) - s[2] - b for o, s, _, b, _, _ in rows]
    )
    att = (att + math.pi) % (2 * math.pi) - math.pi
    rate = np.array([o[mission.OBS_RATE] * 0.3 - s[5] for o, s, *_ in rows])
    incl = np.array([o[mission.OBS_SLOPE] * 0.5 - p.slope for o, _, _, _, p, _ in rows])
    n = len(rows)
    assert n > 1000
    for err, sigma in (
        (att, cfg.attitude_noise),
        (rate, cfg.rate_noise),
        (incl, cfg.inclinometer_noise),
    ):
        # float32 rounding of the readings is far below these noises
        assert abs(err.mean()) < 4 * sigma / math.sqrt(n)
        assert err.std() == pytest.approx(sigma * TRUNC_STD, rel=0.08)
        assert np.abs(err).max() <= 3 * sigma * 1.001 + 1e-6
    # the bias walks: it is not constant, and it is of the documented size
    biases = np.array([b for *_, b, _, _ in rows])
    assert biases.std() > 0 and np.abs(biases).max() < 6 * cfg.bias_walk * math.sqrt(600)


def test_a_fix_comes_only_after_a_second_at_rest_and_has_the_documented_noise():
    env = HopRoverMissionEnv(info_level="full", control_dt=0.5)
    errs = []
    for ep in range(30):
        obs, info = env.reset(seed=ep)
        # the first reading carries a fix of the start
        errs.append(obs[mission.OBS_FIX] + info["target_x"] - info["rover_state"][0])
        assert obs[mission.OBS_FIX_AGE] == 0.0
        rest = 1.0  # it rested before the episode
        for a in _random_actions(200, ep, scale=0.005):
            last_fix = float(info["last_fix_x"])
            obs, _, te, tr, info = env.step(a)
            if te or tr:
                break
            rest = rest + 0.5 if info["state"] == core.MODE_F else 0.0
            if rest >= 1.0:  # a fix now
                assert obs[mission.OBS_FIX_AGE] == 0.0
                errs.append(float(info["last_fix_x"]) - info["rover_state"][0])
            else:  # the last fix, ageing
                assert info["last_fix_x"] == last_fix and obs[mission.OBS_FIX_AGE] > 0
    errs = np.array(errs)
    assert len(errs) > 300
    assert errs.std() == pytest.approx(0.01 * TRUNC_STD, rel=0.12)


def _probe_rms(X, y):
    """RMS error of the least-squares fit of y on X's columns, their squares and 1."""
    A = np.column_stack([X, X**2, np.ones(len(X))]).astype(np.float64)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(np.sqrt(np.mean((A @ coef - y) ** 2)))


def test_no_hidden_state_leaks_into_one_observation():
    """A least-squares probe from one observation predicts the true attitude (while it
    is within 0.5 rad of upright) and the true position (at rest, just after a fix) no
    better than the sensors' noise allows; the same probe given the hidden value as one
    more column does (so it would see a leak)."""
    cfg = HopRoverMissionEnv().config
    rows = _readings(episodes=8) + _readings(episodes=24, scale=0.005)
    obs = np.array([o for o, *_ in rows], dtype=np.float64)
    th = np.array([s[2] for _, s, *_ in rows])
    x = np.array([s[0] - tx for _, s, tx, *_ in rows])
    near = np.abs(th) < 0.5
    fresh = obs[:, mission.OBS_FIX_AGE] == 0.0
    assert near.sum() > 500 and fresh.sum() > 200
    for sel, y, floor in (
        (near, th, cfg.attitude_noise * TRUNC_STD),
        (fresh, x, cfg.fix_noise * TRUNC_STD),
    ):
        assert _probe_rms(obs[sel], y[sel]) > 0.9 * floor
        leaked = np.column_stack([obs[sel], y[sel]])
        assert _probe_rms(leaked, y[sel]) < 0.1 * floor


def test_without_noise_the_readings_are_the_true_state():
    rows = _readings(noise_scale=0.0, episodes=2)
    for o, s, _tx, b, p, _ in rows:
        assert b == 0.0
        assert o[mission.OBS_SIN] == np.float32(math.sin(s[2]))
        assert o[mission.OBS_SLOPE] == np.float32(p.slope / 0.5)


def test_the_actuator_applies_the_commanded_torque_times_its_scale():
    env = HopRoverMissionEnv(info_level="full")
    scales = []
    for ep in range(20):
        _, info = env.reset(seed=ep)
        scale = float(info["actuator_scale"])
        scales.append(scale)
        env.step(np.array([0.004], np.float32))
        cmd = 0.004 * 5e-4
        assert env._s[core.S_TORQUE] == pytest.approx(cmd * scale, rel=1e-12)
    scales = np.array(scales)
    assert scales.min() >= 0.95 and scales.max() <= 1.05 and scales.std() > 0.01
    # a full command stays within the torquer's limits
    env.reset(seed=0)
    env.step(np.array([1.0], np.float32))
    assert env._s[core.S_TORQUE] <= 5e-4


def test_the_ground_is_drawn_per_episode_and_not_observed():
    env = HopRoverMissionEnv()
    draws = set()
    for ep in range(10):
        env.reset(seed=ep)
        p = env.params
        draws.add((p.restitution_x, p.restitution_y, p.mu_static, p.slope))
        assert 0.64 <= p.restitution_x <= 0.96 and 0.1 <= p.restitution_y <= 0.3
    assert len(draws) == 10


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"history": 0}, "history"),
        ({"history": 2.5}, "history"),
        ({"noise_scale": -1.0}, "noise_scale"),
        ({"fix_noise": math.nan}, "fix_noise"),
        ({"actuator_error": 0.5, "noise_scale": 2.0}, "actuator_error"),
        ({"fix_rest": 0.0}, "fix_rest"),
    ],
)
def test_bad_arguments_are_refused_by_name(kw, match):
    with pytest.raises(ValueError, match=match):
        HopRoverMissionEnv(**kw)
