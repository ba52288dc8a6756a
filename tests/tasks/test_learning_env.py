"""The reward cannot be gamed, the action maps, and the hop-level task HopRoverHop-v0."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.vector import AutoresetMode

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env.agents.policies import ControllerPolicy, torque_to_action
from hoprover_env.agents.scripted import ScriptedHopper
from hoprover_env.core.params import RoverParams
from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.registry import HopRoverHopEnv, HopRoverHopVectorEnv
from hoprover_env.tasks import hop, reward, torque

GAMED = dict(shaping="landing", attitude_weight=1.0, gamma=0.995)  # the probe's setting


def _episode(env, act, seed=0, target=0.5):
    """Undiscounted return, the rewards and the last info of one episode."""
    obs, info = env.reset(seed=seed, options={"target_x": target})
    rewards = []
    rng = np.random.default_rng(seed)
    for k in range(100_000):
        obs, r, te, tr, info = env.step(act(obs, rng, k))
        rewards.append(r)
        if te or tr:
            return sum(rewards), rewards, info
    raise AssertionError("episode did not end")


def _random(obs, rng, k):
    return rng.uniform(-1, 1, 1).astype(np.float32)


def _spinner(env):
    """A constant 1.5e-4 N m: the rover launches spinning and lands on a top corner."""
    a = torque_to_action(1.5e-4, env.config.params, env.config)
    return lambda obs, rng, k: np.array([a], np.float32)


@pytest.mark.parametrize(
    "kw", [GAMED, dict(GAMED, control_dt=2.0), dict(GAMED, action_map="cubic"), {}]
)
def test_no_positive_reward_at_a_breaking_step(kw):
    """Random and spinning policies: every breaking step is penalised, whatever spin the
    rover had (the unbounded attitude potential once paid up to +142 here)."""
    breaks = 0
    for seed in range(12):
        env = HopRoverEnv(**kw)
        for policy in (_random, _spinner(env)):
            _, rewards, info = _episode(env, policy, seed=seed, target=0.5)
            if info["broken"]:
                breaks += 1
                # exactly the penalty and the time cost: no potential is released
                dt_cost = env.config.time_cost * env.config.control_dt
                assert (
                    -env.config.break_penalty - dt_cost - 1e-9
                    <= rewards[-1]
                    <= -env.config.break_penalty
                )
    assert breaks >= 12  # the spinning policy breaks the rover every time


def test_return_ranks_success_over_staying_put_over_breaking():
    for kw in (GAMED, dict(GAMED, control_dt=2.0), {}):
        env = HopRoverEnv(**kw)
        dt = env.config.control_dt
        hopper = ScriptedHopper(control_dt=dt)
        params = env.config.params

        def scripted(obs, rng, k, env=env, hopper=hopper, params=params):
            s = env.unwrapped._s
            t = hopper(
                s[0:2].copy(),
                s[3:5].copy(),
                s[2],
                s[5],
                np.array([0.5, 0.0]),
                s[6],
                env.config.episode_time,
                "ABCDEFG"[int(s[7])],
            )
            return np.array([torque_to_action(t, params, env.config)], np.float32)

        succ, _, info_s = _episode(env, scripted, target=0.5)
        assert info_s["is_success"]
        stay, _, info_0 = _episode(env, lambda o, r, k: np.zeros(1, np.float32), target=0.5)
        assert not info_0["is_success"] and not info_0["broken"]
        brk, _, info_b = _episode(env, _spinner(env), target=0.5)
        assert info_b["broken"]
        assert succ > stay > brk, (kw, succ, stay, brk)


def test_potential_is_bounded_below_by_phi_min():
    env = HopRoverEnv(**GAMED)
    e = env.config.reward_vector()
    m = reward.new_memory()
    env.reset(seed=0)  # sets env._s
    S = env.unwrapped._s.copy()
    P = env.unwrapped._p
    S[hoprover_env.core.S_MODE] = hoprover_env.core.MODE_A
    for w in (0.0, 1.0, 1e3, 1e12):
        for th in (0.0, 1.0, math.pi):
            S[hoprover_env.core.S_W], S[hoprover_env.core.S_TH] = w, th
            S[hoprover_env.core.S_X] = 1e6
            assert reward.potential(S, P, e, m) >= reward.phi_min(e) - 1e-12


@pytest.mark.parametrize("amap", ["linear", "cubic"])
@pytest.mark.parametrize("scale", [1.0, 0.1])
def test_action_maps_and_their_inverse(amap, scale):
    env = HopRoverEnv(action_map=amap, action_scale=scale)
    p = RoverParams()
    e = env.config.task_vector()
    for a in np.linspace(-1, 1, 41):
        t = torque.action_to_torque(a, p.as_array(), e)
        assert abs(t) <= scale * p.torque_max + 1e-18
        assert torque_to_action(t, p, env.config) == pytest.approx(a, abs=1e-9)
    assert torque.action_to_torque(0.0, p.as_array(), e) == 0.0
    if amap == "cubic":  # fine resolution near zero: the tipping torque at |a| ~ 0.2
        a_tip = torque_to_action(p.tipping_torque, p, env.config)
        assert 0.2 * scale ** (-1 / 3) * 0.9 < a_tip < 0.25 * scale ** (-1 / 3)
    with pytest.raises(ValueError, match="action_map"):
        HopRoverEnv(action_map="quadratic")
    with pytest.raises(ValueError, match="action_scale"):
        HopRoverEnv(action_scale=0.0)


# ---- the hop-level task ----------------------------------------------------------------
def test_hop_env_passes_both_checkers():
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    gym_check_env(gym.make("HopRoverHop-v0").unwrapped, skip_render_check=True)
    sb3_check_env(HopRoverHopEnv(), warn=True)


def test_hop_env_is_deterministic_under_a_seed():
    def run(seed):
        env = gym.make("HopRoverHop-v0")
        obs, _ = env.reset(seed=seed)
        out = [obs]
        rng = np.random.default_rng(1)
        for _ in range(6):
            obs, r, te, tr, info = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
            out.append(np.append(obs, [r, te, tr]))
            if te or tr:
                break
        return np.concatenate(out)

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_hop_vector_env_matches_single_env():
    n = 5
    venv = gym.make_vec("HopRoverHop-v0", num_envs=n)
    assert isinstance(venv, HopRoverHopVectorEnv)
    venv_t = HopRoverHopVectorEnv(n, threads=True)
    obs_v, _ = venv.reset(seed=10)
    obs_t, _ = venv_t.reset(seed=10)
    singles = [HopRoverHopEnv() for _ in range(n)]
    obs_s = np.stack([e.reset(seed=10 + i)[0] for i, e in enumerate(singles)])
    assert np.array_equal(obs_v, obs_s) and np.array_equal(obs_t, obs_s)
    rng = np.random.default_rng(0)
    done = np.zeros(n, bool)
    for _ in range(4):
        a = rng.uniform(-1, 1, (n, 1)).astype(np.float32).astype(np.float64)
        ov, rv, tv, trv, _ = venv.step(a)
        ot, rt, tt, trt, _ = venv_t.step(a)
        for i, e in enumerate(singles):
            if done[i]:
                continue
            o, r, te, tr, _ = e.step(a[i].astype(np.float32))
            assert np.array_equal(ov[i], o) and rv[i] == r and tv[i] == te and trv[i] == tr
            assert np.array_equal(ot[i], o) and rt[i] == r
            done[i] = te or tr


def test_hop_lands_near_where_the_torque_sends_it_and_in_band_succeeds():
    """A hop that ends at rest in the band is left there until the judge's 5 s are up;
    a target already in the band succeeds at t = 5 s whatever the action."""
    env = HopRoverHopEnv(info_level="full")
    env.reset(seed=0, options={"target_x": 0.02})
    obs, r, te, tr, info = env.step(np.array([0.9], np.float32))
    assert te and info["is_success"] and info["ttrtp"] == 5.0 and info["t"] == 5.0
    env.reset(seed=0, options={"target_x": 5.0})
    x = []
    for a in (-0.6, 0.3, 0.6):
        env.reset(seed=0, options={"target_x": 5.0})
        obs, r, te, tr, info = env.step(np.array([a], np.float32))
        assert info["state"] == hoprover_env.core.MODE_F and not te
        x.append(info["rover_state"][0])
    assert x[0] < -0.1 and 0.0 < x[1] < x[2]  # direction and length follow |a|


def test_hop_policy_through_controller_matches_hop_env():
    """The hop env's built-in controller is a contest controller: the scripted hopper's
    hold law on the same control grid gives the same first hop in the torque env."""
    env = HopRoverHopEnv(info_level="full")
    env.reset(seed=0, options={"target_x": 3.0})
    a = float(np.float32(0.55))  # what the env receives
    env.step(np.array([a], np.float32))
    x_hop = env.unwrapped._s[0]
    launch = hop.hop_torque(a, RoverParams().as_array(), env.config.task_vector())
    hopper = ScriptedHopper(control_dt=0.5)
    x_pred, t_rest, broken = hopper.predict(0.0, launch, 0.0, 590.0)
    assert not broken
    assert x_hop == pytest.approx(x_pred, abs=1e-12)
    assert env.unwrapped._s[6] == pytest.approx(t_rest, abs=1e-12)


def test_controller_policy_uses_the_envs_action_map():
    env_kwargs = {"action_map": "cubic", "action_scale": 0.5}
    pol = ControllerPolicy(lambda: lambda *a: 1e-5, env_kwargs=env_kwargs)
    from hoprover_env.envs.vector_env import HopRoverVectorEnv

    venv = HopRoverVectorEnv(2, autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
    obs, _ = venv.reset(seed=0)
    pol.reset(2)
    a = pol.act(obs, venv)
    t = torque.action_to_torque(a[0, 0], RoverParams().as_array(), venv.config.task_vector())
    assert t == pytest.approx(1e-5, rel=1e-9)


# ---- the bundled from-scratch policies -------------------------------------------------
@pytest.mark.parametrize("name", ["hop", "scratch", "mission", "terrain", "terrain_base"])
def test_bundled_from_scratch_policy_records_how_it_was_trained(name):
    import json

    from hoprover_env.agents.policies import BUNDLED, BUNDLED_DIR

    path = BUNDLED_DIR / f"{BUNDLED[name]}.json"
    if name == "scratch" and not path.exists():
        pytest.skip("no bundled torque-level policy from scratch")
    text = path.read_text()
    for word in ("clon", "dagger", "expert", "pretrain", "scripted"):
        assert word not in text.lower(), word
    meta = json.loads(text)
    for key in ("config", "seed", "git_commit", "timesteps", "wall_s", "evaluation"):
        assert meta[key] is not None, key
    assert meta["config"]["seed"] == meta["seed"]
    assert "pretrain" not in meta["config"]


def test_bundled_hop_policy_runs_in_the_hop_task():
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes, summarize

    pol = load_policy("hop")
    assert pol.env_id == "HopRoverHop-v0" and pol.name == "hop"
    res = summarize(run_episodes(pol, np.linspace(-0.9, 0.9, 7)))
    assert res["success_rate"] >= 6 / 7 and res["broken"] == 0
