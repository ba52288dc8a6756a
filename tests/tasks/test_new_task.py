"""A task is one module: tests/toy_task.py, made by ARCHITECTURE.md's recipe, becomes a
registered Gymnasium env (single and native vector) with nothing else written for it;
and the options a task does not use are refused, not ignored."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import hoprover_env
from hoprover_env.envs import registry


@pytest.fixture(scope="module")
def tip_id():
    (env_id,) = hoprover_env.register_task("toy_task")
    return env_id


def test_the_toy_task_module_is_a_registered_env_with_its_own_classes(tip_id):
    assert tip_id == "HopRoverTip-v0" and tip_id in gym.registry
    env = gym.make(tip_id)
    assert type(env.unwrapped).__name__ == "HopRoverTipEnv"
    assert env.unwrapped.__doc__.startswith("HopRoverTip")  # its module's docstring
    assert env.observation_space.shape == (4,)
    assert hoprover_env.task(tip_id).kwargs == {"episode_time": 120.0}
    assert hoprover_env.config_class(tip_id).__name__ == "TipEnvConfig"
    check_env(env.unwrapped, skip_render_check=True)


def test_its_own_slot_of_E_reaches_the_kernel(tip_id):
    """The reward pays for |theta - tip_angle|: at rest upright, -tip_angle per second."""
    for tip in (0.1, 0.4):
        env = gym.make(tip_id, tip_angle=tip, control_dt=2.0)
        env.reset(seed=0)
        _, reward, *_ = env.step(np.array([0.0], dtype=np.float32))  # zero torque: still
        assert reward == pytest.approx(-tip * 2.0, rel=1e-12)


def test_a_pushed_rover_tips_and_the_vector_env_equals_single_envs(tip_id):
    envs = gym.make_vec(tip_id, num_envs=3)
    obs, _ = envs.reset(seed=7)
    singles = [gym.make(tip_id) for _ in range(3)]
    single_obs = [e.reset(seed=7 + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.stack(single_obs))
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-0.05, 0.05, (3, 1)).astype(np.float32)
        obs, rew, term, trunc, _ = envs.step(a)
        for i, e in enumerate(singles):
            o, r, t, tr, _ = e.step(a[i])
            np.testing.assert_array_equal(obs[i], o)
            assert rew[i] == r and term[i] == t and trunc[i] == tr
    assert np.any(np.abs(obs[:, 0]) > 1e-3)  # the torques tipped it


def test_the_options_a_task_does_not_use_are_refused(tip_id):
    with pytest.raises(TypeError, match="action_map.*does not use"):
        gym.make(tip_id, action_map="cubic")
    with pytest.raises(TypeError, match="action_map.*does not use"):
        gym.make("HopRoverHop-v0", action_map="linear")
    with pytest.raises(TypeError, match="action_scale.*does not use"):
        gym.make_vec("HopRoverHop-v0", num_envs=2, action_scale=0.5)
    from hoprover_env.tasks.hop import HopEnvConfig

    with pytest.raises(ValueError, match="does not use action_map"):
        HopEnvConfig(action_map="cubic")
    gym.make("HopRover-v0", action_map="cubic")  # the torque task uses it


def test_a_module_that_is_not_a_task_is_refused():
    with pytest.raises(TypeError, match="no TASK"):
        registry.register_task("helpers")


def test_the_reward_options_a_task_does_not_read_are_refused(tip_id):
    """The toy task pays its own reward: every option of the shared reward is refused,
    named, at gym.make (TypeError) and when its config is built (ValueError)."""
    import toy_task

    for name, value in (("success_bonus", 123), ("shaping", "landing"), ("energy_weight", 5)):
        with pytest.raises(TypeError, match=f"'{name}', which this task does not use"):
            gym.make(tip_id, **{name: value})
        with pytest.raises(ValueError, match=f"does not use {name}"):
            toy_task.TipEnvConfig(**{name: value})
    # a task that reads the reward takes its options flat, as before
    cfg = gym.make("HopRoverRL-v1", attitude_cost=0.3).unwrapped.config
    assert cfg.attitude_cost == 0.3 and cfg.reward.attitude_cost == 0.3
    from hoprover_env.tasks.hop import HopEnvConfig

    assert HopEnvConfig().gamma == 0.98 and HopEnvConfig(gamma=0.9).reward.gamma == 0.9


def test_a_tasks_own_slots_of_E_are_its_declared_fields_after_the_shared_ones(tip_id):
    import toy_task
    from hoprover_env.tasks import hop, mission
    from hoprover_env.tasks.layout import N_SHARED, task_slots

    assert toy_task.E_TIP == N_SHARED
    e = toy_task.TipEnvConfig(tip_angle=0.3).task_vector()
    assert e.shape == (N_SHARED + 1,) and e[toy_task.E_TIP] == 0.3
    assert (hop.E_HOLD_KP, hop.E_LAUNCH_MIN) == (N_SHARED, N_SHARED + 3)
    m = mission.MissionEnvConfig(noise_scale=2.0, history=3)
    e = m.task_vector()
    assert e[mission.E_RATE_NOISE] == 2.0 * m.rate_noise and e[mission.E_HISTORY] == 3
    assert len(e) == task_slots(mission.MissionEnvConfig).size == N_SHARED + 7
