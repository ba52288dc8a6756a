"""The mission task decided hop by hop (hoprover_env/agents/mission_hop.py): the training view
(MissionHopEnv) and the deployed policy (LearnedHopper through ControllerPolicy in the
mission's vector env) are the same loop, and the hopper's memory is what it says."""

import math

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from hoprover_env.agents.mission_hop import (
    F_HOPS,
    F_LAST_ACTION,
    F_LAST_MOVED,
    F_LAST_TO_GO,
    F_TO_GO,
    LearnedHopper,
    MissionHopEnv,
)
from hoprover_env.agents.policies import ControllerPolicy
from hoprover_env.envs.registry import HopRoverMissionVectorEnv


def toward(f):
    """A fixed hop rule: a short hop towards the target, longer when it is far."""
    return math.copysign(0.2 + 0.4 * min(abs(float(f[F_TO_GO])), 1.0), float(f[F_TO_GO]))


@pytest.mark.slow  # gymnasium's checker steps many hops
def test_the_hop_env_passes_the_gymnasium_checker():
    check_env(MissionHopEnv(), skip_render_check=True)


def test_training_view_and_deployed_policy_give_the_same_episodes_bit_for_bit():
    n, seed = 4, 21
    venv = HopRoverMissionVectorEnv(n, control_dt=0.5)
    policy = ControllerPolicy(lambda: LearnedHopper(toward, control_dt=0.5), name="rule")
    policy.reset(n)
    obs, _ = venv.reset(seed=seed)
    done = np.zeros(n, bool)
    final = [None] * n
    while not done.all():
        obs, _, term, trunc, infos = venv.step(policy.act(obs, venv))
        for i in np.flatnonzero((term | trunc) & ~done):
            final[i] = (bool(infos["is_success"][i]), float(infos["ttrtp"][i]))
        done |= term | trunc
    for i in range(n):
        env = MissionHopEnv(control_dt=0.5)
        f, _ = env.reset(seed=seed + i)
        hops, over = 0, False
        while not over:
            f, _, term, trunc, info = env.step([toward(f)])
            hops += 1
            over = term or trunc
        assert hops >= 1
        assert (bool(info["is_success"]), float(info["ttrtp"])) == final[i], i


def test_the_hopper_remembers_its_last_hop_and_what_it_achieved():
    env = MissionHopEnv()
    f0, _ = env.reset(seed=3)
    assert f0[F_LAST_ACTION] == 0.0 and f0[F_HOPS] == 0.0
    a = math.copysign(0.1, float(f0[F_TO_GO]))
    f1, _, term, trunc, _ = env.step([a])
    if term or trunc:
        pytest.skip("the first hop ended the episode")
    assert f1[F_LAST_ACTION] == pytest.approx(a)
    assert f1[F_LAST_TO_GO] == pytest.approx(f0[F_TO_GO])
    # what the hop moved is what the distance to go shrank by (both from the fixes)
    assert f1[F_LAST_MOVED] == pytest.approx(f0[F_TO_GO] - f1[F_TO_GO], abs=1e-6)
    assert f1[F_HOPS] > f0[F_HOPS]


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_hop_action_is_refused_by_name(bad):
    env = MissionHopEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be finite"):
        env.step([bad])


@pytest.mark.slow  # whole suite episodes
def test_the_bundled_mission_policy_reaches_its_goal_on_suite_episodes():
    """The bar of 90 % on the suite, on the suite's first 40 episodes; the whole
    suite's 97.5 % is in docs/studies/mission.md."""
    import dataclasses

    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation import suites

    policy = load_policy("mission")
    assert policy.env_id == "HopRoverMission-v0"
    suite = suites.load("HopRoverMission-v0")
    rows = suites.run(policy, dataclasses.replace(suite, episodes=suite.episodes[:40]))
    assert np.mean([r["success"] for r in rows]) >= 0.9
    assert not any(r["broken"] for r in rows)


def test_train_py_points_a_hop_config_to_its_own_trainer():
    from pathlib import Path

    from hoprover_env.training.sb3_agents import ConfigError, load_config

    path = Path(__file__).resolve().parents[2] / "configs" / "ppo_mission_hop.yaml"
    with pytest.raises(ConfigError, match="research.train_mission"):
        load_config(path)


def test_an_episode_that_needs_no_hop_is_refused_when_the_options_fix_it():
    env = MissionHopEnv()
    with pytest.raises(ValueError, match="needs no hop"):
        env.reset(seed=0, options={"target_x": 0.0})
    f, _ = env.reset(seed=0, options={"target_x": 0.6})
    assert f[F_TO_GO] > 0.4
