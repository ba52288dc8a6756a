"""HopRoverTerrain-v0 and terrain through the environments: checkers, vector == single
(bumps included), replays from info's terrain seed, the landing point on a slope, the
scripted hopper on an incline, bad input."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env import RoverParams, simulate
from hoprover_env.envs.registry import HopRoverTerrainVectorEnv
from hoprover_env.tasks.observation import OBS_LANDING
from hoprover_env.tasks.terrain import OBS_SLOPE


def test_checkers_pass_and_the_observation_carries_the_slope():
    env = gym.make("HopRoverTerrain-v0").unwrapped
    gym_check_env(env)
    sb3_check_env(env)
    obs, info = env.reset(seed=4)
    assert obs.shape == (20,) and env.observation_space.contains(obs)
    assert -0.2 <= info["slope"] <= 0.2 and info["slope"] == env.params.slope
    assert obs[OBS_SLOPE] == np.float32(info["slope"] / 0.5)
    assert env.params.roughness == 0.05 and info["terrain_seed"] >= 0


def _drive(env_or_venv, actions, vector=False):
    """Observations and rewards of a fixed action sequence."""
    out = []
    for a in actions:
        if vector:
            obs, r, *_ = env_or_venv.step(a)
        else:
            obs, r, te, tr, _ = env_or_venv.step(a)
            if te or tr:
                obs, _ = env_or_venv.reset()
        out.append((obs.copy(), np.asarray(r).copy()))
    return out


def test_the_vector_env_equals_single_envs_bumps_included():
    n, seed = 3, 11
    rng = np.random.default_rng(0)
    # hops and landings: strong launches, then quiet periods (rough impacts happen)
    acts = [
        np.where(rng.random((n, 1)) < 0.1, rng.uniform(-0.9, 0.9, (n, 1)), 0.0).astype(np.float32)
        for _ in range(250)
    ]
    venv = HopRoverTerrainVectorEnv(n, autoreset_mode="SameStep", roughness=0.2)
    _, vinfo = venv.reset(seed=seed)
    vec = _drive(venv, acts, vector=True)
    impacts = 0
    for i in range(n):
        env = gym.make("HopRoverTerrain-v0", roughness=0.2).unwrapped
        _, info = env.reset(seed=seed + i)
        assert info["terrain_seed"] == vinfo["terrain_seed"][i]
        assert info["slope"] == vinfo["slope"][i]
        single = _drive(env, [a[i : i + 1, 0] for a in acts])
        for (vo, vr), (so, sr) in zip(vec, single):
            assert np.array_equal(vo[i], so) and vr[i] == sr
        impacts += int(env._s[hoprover_env.core.S_NIMPACT])
    assert impacts > 0  # the comparison covered rough bounces


def test_an_episode_replays_from_its_terrain_seed():
    env = gym.make(
        "HopRover-v0", params={"slope": 0.15, "roughness": 0.1}, control_dt=1.0
    ).unwrapped
    _, info = env.reset(seed=2, options={"target_x": 0.8})
    assert info["slope"] == 0.15 and info["terrain_seed"] >= 0
    torques = []
    for k in range(300):  # a weak launch, no attitude control: it bounces
        *_, te, tr, _ = env.step(np.array([0.05 if k < 10 else 0.0], np.float32))
        torques.append(float(env._s[hoprover_env.core.S_TORQUE]))
        if te or tr:
            break
    roll = simulate(
        torques,
        t_end=float(len(torques)),
        control_dt=1.0,
        target_x=0.8,
        params=env.params,
        seed=info["terrain_seed"],
    )
    assert roll.seed == info["terrain_seed"] and len(roll.impact_energy_ratios) > 0
    assert roll.x[-1] == env._s[0] and roll.theta[-1] == env._s[2]


def test_the_landing_point_is_computed_on_the_slope():
    phi, g = 0.3, RoverParams().gravity
    env = gym.make("HopRover-v0", params={"slope": phi}).unwrapped
    env.reset(seed=0, options={"target_x": 0.0})
    for k in range(200):
        obs, *_ = env.step(np.array([0.8 if k < 4 else 0.0], np.float32))
        if (
            env._s[hoprover_env.core.S_MODE] == hoprover_env.core.MODE_A
            and env._s[hoprover_env.core.S_Y] > 0.2
        ):
            break
    x, y, _, vx, vy, _ = env._s[:6]
    # the c.m. back at rest height h: y(t) = y + vy t - g cos(phi) t^2 / 2 = h
    gc, gs = g * math.cos(phi), g * math.sin(phi)
    t = (vy + math.sqrt(vy * vy + 2 * gc * (y - env.params.half_height))) / gc
    expected = x + vx * t - 0.5 * gs * t * t
    assert obs[OBS_LANDING] == pytest.approx(expected - 0.0, abs=1e-6)
    flat_guess = x + vx * t
    assert abs(expected - flat_guess) > 1e-3  # the slope term matters here


@pytest.mark.parametrize("phi", [-0.2, 0.2])
def test_the_scripted_hopper_plans_on_the_slope_it_is_given(phi):
    from hoprover_env.agents.policies import ControllerPolicy, load_policy
    from hoprover_env.agents.scripted import ScriptedHopper
    from hoprover_env.evaluation.episodes import run_episodes

    class FlatPlanner(ScriptedHopper):  # keeps planning for the level ground
        def use_params(self, params):
            if self.params is None:
                super().use_params(params)

    targets, ground = [0.8, -0.6, 0.4, -0.9], {"slope": phi, "roughness": 0.0}
    aware = run_episodes(load_policy("scripted"), targets, terrain=ground)
    assert all(r.success and not r.broken for r in aware), aware
    flat = run_episodes(
        ControllerPolicy(
            lambda: FlatPlanner(control_dt=0.5), name="flat", env_kwargs={"control_dt": 0.5}
        ),
        targets,
        terrain=ground,
    )
    # planning for level ground on this incline misses (measured: 2 of these 4 fail)
    assert sum(r.success for r in flat) < len(targets)


def test_bad_terrain_input_is_refused_by_name():
    with pytest.raises(ValueError, match="slope_range"):
        gym.make("HopRoverTerrain-v0", slope_range=(-0.7, 0.1))
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="roughness"):
            gym.make("HopRoverTerrain-v0", roughness=bad)
    env = gym.make("HopRoverTerrain-v0")
    with pytest.raises(ValueError, match="slope"):
        env.reset(seed=0, options={"slope": 0.8})
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(seed=0, options={"tilt": 0.1})
    with pytest.raises(ValueError, match="slope"):
        gym.make("HopRover-v0", params={"slope": 0.6})


def test_reset_option_terrain_seed_replays_an_episode_in_simulate_and_the_vector_env():
    """reset(options={"terrain_seed": k}) fixes the bumps: the episode equals simulate(...,
    seed=k) under the same torques, and sub-env 0 of a vector env given the same option;
    the env's own draws stay aligned (the next episode is the one it always was)."""
    from hoprover_env import RoverParams, simulate
    from hoprover_env.envs.registry import HopRoverTerrainEnv, HopRoverTerrainVectorEnv

    opts = {"target_x": 0.4, "slope": 0.1, "roughness": 0.1, "terrain_seed": 12345}
    env = HopRoverTerrainEnv()
    _, info = env.reset(seed=3, options=opts)
    assert info["terrain_seed"] == 12345
    acts = np.random.default_rng(0).uniform(-1, 1, 120)
    for a in acts:
        env.step(np.array([a]))
    p = RoverParams(slope=0.1, roughness=0.1)
    torques = [p.torque_min + 0.5 * (a + 1) * (p.torque_max - p.torque_min) for a in acts]
    roll = simulate(torques, t_end=60.0, control_dt=0.5, target_x=0.4, params=p, seed=12345)
    assert roll.x[-1] == env.unwrapped._s[0] and roll.theta[-1] == env.unwrapped._s[2]
    venv = HopRoverTerrainVectorEnv(2)
    _, vinfo = venv.reset(seed=0, options={**opts, "terrain_seed": np.array([12345, 9])})
    assert list(vinfo["terrain_seed"]) == [12345, 9]
    for a in acts:
        venv.step(np.full((2, 1), a))
    assert venv.S[0][0] == env.unwrapped._s[0]
    # the option does not move the env's own stream: the next draws are unchanged
    a, b = HopRoverTerrainEnv(), HopRoverTerrainEnv()
    a.reset(seed=5, options={"terrain_seed": 1})
    b.reset(seed=5)
    assert a.reset()[1]["terrain_seed"] == b.reset()[1]["terrain_seed"]


def test_bad_terrain_seed_and_initial_state_options_are_named():
    from hoprover_env.envs.registry import HopRoverTerrainEnv, HopRoverTerrainVectorEnv

    with pytest.raises(ValueError, match="terrain_seed"):
        HopRoverTerrainEnv().reset(options={"terrain_seed": -1})
    venv = HopRoverTerrainVectorEnv(2)
    with pytest.raises(ValueError, match="terrain_seed.*integers"):
        venv.reset(options={"terrain_seed": 1.5})
    with pytest.raises(ValueError, match="initial_state"):
        venv.reset(options={"initial_state": [0.0, 0.05]})
    # initial_state is honoured per sub-env, not ignored
    obs, _ = venv.reset(
        options={"initial_state": [[0.3, 0.05, 0, 0, 0, 0], [-0.2, 0.05, 0, 0, 0, 0]], "slope": 0.0}
    )
    assert venv.S[0][0] == 0.3 and venv.S[1][0] == -0.2
