"""The mission estimator (hoprover_env.agents.estimation): its attitude estimate is consistent
with its covariance, a rest calibrates the bias, the gyro tells flight from contact, and
the scripted hopper acting on the estimate reaches hidden targets of HopRoverMission-v0
(evaluate.py --env HopRoverMission-v0 --policy scripted)."""

import math

import numpy as np
import pytest

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env import core
from hoprover_env.agents.policies import load_policy
from hoprover_env.envs.registry import HopRoverMissionVectorEnv
from hoprover_env.evaluation.episodes import run_episodes
from hoprover_env.tasks import mission


def _run(seeds, targets, noise_scale=1.0):
    """Per control instant of scripted episodes on the mission task: (true theta, its
    estimate, the estimate's variance, true mode letter, estimated mode, bias, its
    estimate, the attitude reading, true rate, rover, bias variance)."""
    n = len(seeds)
    venv = HopRoverMissionVectorEnv(n, info_level="full", noise_scale=noise_scale)
    policy = load_policy("scripted")
    policy.reset(n)
    obs, info = venv.reset(seed=list(seeds), options={"target_x": np.asarray(targets)})
    rows, live = [], np.ones(n, bool)
    for _ in range(1200):
        act = policy.act(obs, venv)
        for i in np.flatnonzero(live):
            est = policy.estimators[i]
            rows.append(
                (
                    venv.S[i, core.S_TH],
                    est.theta,
                    est.P[0, 0],
                    core.MODE_LETTERS[int(venv.S[i, core.S_MODE])],
                    est.state,
                    info["attitude_bias"][i],
                    est.bias,
                    math.atan2(obs[i, mission.OBS_SIN], obs[i, mission.OBS_COS]),
                    venv.S[i, core.S_W],
                    i,
                    est.P[1, 1],
                )
            )
        obs, _, te, tr, info = venv.step(act)
        live &= ~(te | tr)
        if not live.any():
            break
    return rows


@pytest.mark.slow  # statistics over many episodes
def test_the_attitude_estimate_is_consistent_with_its_covariance():
    rows = _run(range(6), [0.6, -0.8, 0.3, 1.0, -0.4, 0.9])
    err = np.array([(e - t + math.pi) % (2 * math.pi) - math.pi for t, e, *_ in rows])
    var = np.array([r[2] for r in rows])
    raw = np.array([(r[7] - r[0] + math.pi) % (2 * math.pi) - math.pi for r in rows])
    nees = err**2 / var
    # the normalised squared error of a consistent 1-D estimate averages about 1, and
    # the estimate beats the raw readings (0.5 deg noise plus the walking bias)
    assert 0.3 < nees.mean() < 3.0, nees.mean()
    assert np.sqrt(np.mean(err**2)) < 0.8 * np.sqrt(np.mean(raw**2))


def test_a_rest_calibrates_the_bias():
    """At rest the bias estimate is within 3 of its own standard deviations of the
    sensor's true bias, and that deviation has shrunk from its prior (3 x the noise)."""
    rows = _run(range(4), [0.7, -0.6, 0.5, -0.9])
    rest = [r for r in rows if r[4] == "F"]
    assert len(rest) > 10
    z = np.array([(r[5] - r[6]) / math.sqrt(r[10]) for r in rest])
    assert np.mean(np.abs(z) < 3) > 0.95, z
    assert max(math.sqrt(r[10]) for r in rest) < 3 * math.radians(0.5)


def test_the_gyro_tells_flight_from_contact():
    rows = _run(range(6), [0.6, -0.8, 0.3, 1.0, -0.4, 0.9])
    flight = np.array([r[3] == "A" for r in rows])
    turning = np.array([abs(r[8]) > 1e-3 for r in rows])  # 10 x the rate noise
    said = np.array([r[4] == "A" for r in rows])
    rover = np.array([r[9] for r in rows])
    assert (flight & turning).sum() > 200
    # a flight that turns is seen as one (a bounce a period late); one that does not
    # turn needs no attitude hold, and may read as contact
    assert (flight & turning & said).sum() / (flight & turning).sum() > 0.9
    # contact reads as flight only next to a flight (the period of a lift-off or of a
    # bounce's touchdown) or while the rover rocks slowly on a corner after a landing
    # (a few mrad/s, when gravity's and the hold's torques are both tiny): never in a
    # launch's pivot, a fast slide or a rest
    slow = np.array([abs(r[8]) < 5e-3 for r in rows])
    assert (~flight & said).sum() < 0.2 * (~flight).sum()
    near = np.zeros_like(flight)
    for i in np.unique(rover):
        idx = np.flatnonzero(rover == i)
        f = flight[idx]
        near[idx] = f | np.r_[f[1:], False] | np.r_[False, f[:-1]]
    assert not (~flight & said & ~near & ~slow).any()
    assert not (np.array([r[3] == "F" for r in rows]) & said).any()


@pytest.mark.slow  # whole episodes
def test_the_scripted_hopper_on_the_estimate_reaches_hidden_targets():
    rng = np.random.default_rng(20261125)  # targets no one tuned on
    targets = rng.uniform(-1.0, 1.0, 16)
    policy = load_policy("scripted")
    policy.env_id = "HopRoverMission-v0"  # as evaluate.py --env sets it
    res = run_episodes(policy, targets, batch=8)
    success = np.mean([r.success for r in res])
    assert success >= 0.9, [(r.target_x, r.success, r.broken) for r in res]
