"""HopRoverEnv, HopRoverVectorEnv and the SB3 adapter."""

import math
import os

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env import RoverParams
from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.vector_env import HopRoverVectorEnv

IDS = ["HopRover-v0", "HopRoverContest-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_checkers_pass(env_id):
    gym_check_env(gym.make(env_id).unwrapped)
    gym_check_env(gym.make(env_id, render_mode="rgb_array").unwrapped)
    sb3_check_env(gym.make(env_id).unwrapped)


def test_registration_and_defaults():
    env = gym.make("HopRoverContest-v0")
    _, info = env.reset(seed=3)
    assert info["target_x"] == 0.5 and info["state"] == hoprover_env.core.MODE_F
    envs = gym.make_vec("HopRover-v0", num_envs=3)
    assert isinstance(envs.unwrapped, HopRoverVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.observation_space.shape == (3, 19)


def rollout_actions(n, seed):
    rng = np.random.default_rng(seed)
    # bursts of torque with rests, so that episodes contain hops, landings and ends
    a = rng.uniform(-1, 1, n) * (rng.random(n) < 0.3)
    return a.astype(np.float32)


def run_single(seed, actions, **kw):
    """A single env driven with NEXT_STEP semantics: after an episode ends, the next
    call is a reset (reward 0) and that step's action is not used."""
    env = HopRoverEnv(**kw)
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, False, False)]
    pending = False
    for a in actions:
        if pending:
            obs, info = env.reset()
            r, te, tr, pending = 0.0, False, False, False
        else:
            obs, r, te, tr, info = env.step(np.array([a], dtype=np.float32))
            pending = te or tr
        out.append((obs, r, te, tr))
    return out


ENV_KW = dict(episode_time=60.0, control_dt=1.0, target_range=(-0.3, 0.3))


@pytest.mark.parametrize(
    "threads, integrator", [(False, "event"), (True, "event"), (False, "euler"), (True, "euler")]
)
def test_vector_sub_env_equals_single_env_next_step(threads, integrator):
    n, steps = 4, 150
    kw = dict(ENV_KW, integrator=integrator)
    acts = np.stack([rollout_actions(steps, 10 + i) for i in range(n)], axis=1)
    envs = HopRoverVectorEnv(n, threads=threads, **kw)
    obs, _ = envs.reset(seed=100)
    traj = [[(obs[i], 0.0, False, False)] for i in range(n)]
    for k in range(steps):
        obs, r, te, tr, _ = envs.step(acts[k][:, None])
        for i in range(n):
            traj[i].append((obs[i], r[i], te[i], tr[i]))
    n_ends = 0
    for i in range(n):
        single = run_single(100 + i, acts[:, i], **kw)
        assert len(single) == len(traj[i])
        for (o1, r1, te1, tr1), (o2, r2, te2, tr2) in zip(traj[i], single):
            assert np.array_equal(o1, o2)
            assert r1 == r2 and te1 == te2 and tr1 == tr2
            n_ends += te2 or tr2
    assert n_ends > 0


@pytest.mark.parametrize("integrator", ["event", "euler"])
def test_env_steps_with_the_integrator_it_was_made_with(integrator):
    """The env's kernels (an event-only one and one for any integrator) integrate what
    simulate() integrates for the same torques, start and target."""
    from hoprover_env import simulate
    from hoprover_env.core.params import RoverParams

    env = HopRoverEnv(integrator=integrator, control_dt=0.5, episode_time=60.0, target_x=0.3)
    env.reset(seed=0)
    p = RoverParams()
    acts = rollout_actions(80, 5)
    torques = [p.torque_min + 0.5 * (float(a) + 1.0) * (p.torque_max - p.torque_min) for a in acts]
    for a in acts:
        *_, te, tr, info = env.step(np.array([a], dtype=np.float32))
        assert not (te or tr)
    roll = simulate(
        np.array(torques), t_end=40.0, control_dt=0.5, target_x=0.3, integrator=integrator
    )
    s = env.unwrapped._s
    final = [roll.x[-1], roll.y[-1], roll.theta[-1], roll.vx[-1], roll.vy[-1], roll.omega[-1]]
    assert np.array_equal(s[:6], final)
    assert roll.n_events == s[hoprover_env.core.S_NEVENTS] > 2


def test_vector_same_step_autoreset_matches_single():
    n, steps = 3, 120
    acts = np.stack([rollout_actions(steps, 20 + i) for i in range(n)], axis=1)
    envs = HopRoverVectorEnv(n, autoreset_mode="SameStep", **ENV_KW)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs, _ = envs.reset(seed=7)
    singles = [HopRoverEnv(**ENV_KW) for _ in range(n)]
    s_obs = [e.reset(seed=7 + i)[0] for i, e in enumerate(singles)]
    assert all(np.array_equal(obs[i], s_obs[i]) for i in range(n))
    ended = 0
    for k in range(steps):
        obs, r, te, tr, info = envs.step(acts[k][:, None])
        for i, e in enumerate(singles):
            o, rr, t1, t2, inf = e.step(np.array([acts[k, i]], np.float32))
            assert rr == r[i] and t1 == te[i] and t2 == tr[i]
            if t1 or t2:
                ended += 1
                assert info["_final_obs"][i] and np.array_equal(info["final_obs"][i], o)
                assert info["final_info"]["is_success"][i] == inf["is_success"]
                o, _ = e.reset()
            assert np.array_equal(obs[i], o)
    assert ended > 0


def test_vector_max_episode_steps_and_infos():
    envs = gym.make_vec("HopRover-v0", num_envs=2, max_episode_steps=5)
    envs.reset(seed=0)
    for _k in range(5):
        obs, r, te, tr, info = envs.step(np.zeros((2, 1)))
    assert tr.all() and not te.any()
    for key in ("is_success", "ttrtp", "state", "target_x", "broken", "n_events"):
        assert info[key].shape == (2,) and info["_" + key].all()
    obs, r, te, tr, info = envs.step(np.zeros((2, 1)))  # NEXT_STEP: the reset
    assert (r == 0).all() and not tr.any() and (info["state"] == hoprover_env.core.MODE_F).all()


def test_seeding_is_bit_for_bit():
    a, b = run_single(5, rollout_actions(200, 1)), run_single(5, rollout_actions(200, 1))
    assert all(np.array_equal(x[0], y[0]) and x[1:] == y[1:] for x, y in zip(a, b))
    c = run_single(6, rollout_actions(200, 1))
    assert not all(np.array_equal(x[0], y[0]) for x, y in zip(a, c))


def test_reset_options_and_errors():
    env = HopRoverEnv()
    _, info = env.reset(seed=0, options={"target_x": -0.7})
    assert info["target_x"] == -0.7
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"tarrget_x": 1.0})
    # Python's own wording (TorchRL's GymEnv relies on it), then the valid names
    with pytest.raises(
        TypeError,
        match=r"got an unexpected keyword argument 'contol_dt'; "
        r"valid environment arguments: \[.*'control_dt'",
    ):
        HopRoverEnv(contol_dt=0.1)
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        gym.make_vec("HopRover-v0", num_envs=2, frameskip=1)
    with pytest.raises(ValueError, match="control_dt must be a positive (finite )?number"):
        HopRoverEnv(control_dt=-1.0)


@pytest.mark.parametrize(
    "bad",
    [np.array([np.nan], np.float32), np.array([np.inf]), [float("-inf")], np.array([[0.1, 0.2]])],
)
def test_bad_actions_raise(bad):
    env = HopRoverEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(bad)
    envs = HopRoverVectorEnv(2)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        envs.step(np.array([[0.0], [np.nan]]))


def test_out_of_range_actions_are_clipped():
    a, b = HopRoverEnv(), HopRoverEnv()
    a.reset(seed=1)
    b.reset(seed=1)
    for _ in range(20):
        oa = a.step(np.array([7.0], np.float32))
        ob = b.step(np.array([1.0], np.float32))
        assert np.array_equal(oa[0], ob[0]) and oa[1] == ob[1]


def test_observations_stay_in_bounds_and_types_are_strict():
    env = HopRoverEnv(episode_time=300.0)
    obs, _ = env.reset(seed=2)
    for a in rollout_actions(600, 3):
        obs, r, te, tr, info = env.step(np.array([a], np.float32))
        assert env.observation_space.contains(obs)
        assert type(r) is float and type(te) is bool and type(tr) is bool
        assert type(info["is_success"]) is np.bool_ and type(info["broken"]) is np.bool_
        if te or tr:
            obs, _ = env.reset()


INFO_TYPES = {
    "is_success": np.bool_,
    "ttrtp": np.float64,
    "state": np.int64,
    "target_x": np.float64,
    "broken": np.bool_,
    "n_events": np.int64,
    "slope": np.float64,
    "terrain_seed": np.int64,
}


@pytest.mark.parametrize("env_id", ["HopRover-v0", "HopRoverHop-v0", "HopRoverTerrain-v0"])
def test_info_values_are_numbers_of_fixed_type(env_id):
    """No None, NaN or string in info, single or vector: TorchRL's specs and Tianshou's
    buffer checks store every value. TTRTP is -1 until reached, the state a code 0..6."""
    env = gym.make(env_id, control_dt=2.0)
    _, first = env.reset(seed=0, options={"target_x": 0.0})
    assert first["ttrtp"] == -1.0 and not first["is_success"]
    for _ in range(10):
        _, _, te, _, info = env.step(np.zeros(1, np.float32))
        assert info.keys() == first.keys()
        for key, value in info.items():
            assert type(value) is INFO_TYPES[key] and np.isfinite(value), key
        assert 0 <= info["state"] <= 6
        if te:
            break
    assert info["is_success"] and info["ttrtp"] == 5.0
    envs = gym.make_vec(env_id, num_envs=2, autoreset_mode="SameStep", control_dt=2.0)
    _, info = envs.reset(seed=0, options={"target_x": np.array([0.0, 3.0])})
    for _ in range(10):
        _, _, te, _, step_info = envs.step(np.zeros((2, 1)))
        if te[0]:
            break
    for got in (info, step_info, step_info["final_info"]):
        for key, dtype in INFO_TYPES.items():
            assert got[key].dtype == dtype and got[key].shape == (2,), key
    assert te[0] and step_info["final_info"]["ttrtp"][0] == 5.0
    assert step_info["ttrtp"][1] == -1.0 and not step_info["is_success"][1]


def test_idle_at_target_succeeds_at_five_seconds_with_bonus():
    env = HopRoverEnv(control_dt=0.5)
    env.reset(seed=0, options={"target_x": 0.0})
    total = 0.0
    for _k in range(10):
        obs, r, te, tr, info = env.step(np.zeros(1, np.float32))
        total += r
    assert te and info["is_success"] and info["ttrtp"] == 5.0
    # the last step: bonus + gamma * 0 - Phi(s) - time cost; Phi(s) = -0.05 (corner at
    # 0.05 m) - band_weight 0.5 * (1 - 4.5 s / 5 s in the band)
    assert r == pytest.approx(10.0 + 0.05 + 0.5 * 0.1 - 0.5 / 600.0, rel=1e-12)


def test_reward_is_the_documented_shaping():
    env = HopRoverEnv(control_dt=1.0, gamma=0.9, time_cost=0.01, dist_weight=2.0)
    env.reset(seed=0, options={"target_x": 0.8})
    obs, r, te, tr, info = env.step(np.zeros(1, np.float32))  # at rest: Phi unchanged
    phi = -2.0 * abs(0.05 - 0.8) - 0.5  # out of the band: - band_weight
    assert r == pytest.approx(0.9 * phi - phi - 0.01 * 1.0, rel=1e-12)


def test_breaking_terminates_with_penalty():
    env = HopRoverEnv(control_dt=10.0, break_penalty=7.0)
    env.reset(seed=0, options={"target_x": 0.0, "initial_state": (0.0, 0.2, math.pi, 0, 0, 0)})
    for _ in range(10):
        obs, r, te, tr, info = env.step(np.zeros(1, np.float32))
        if te:
            break
    assert te and info["broken"] and not info["is_success"] and r < -6.9


def test_domain_randomisation_ranges():
    rel = {"mu_static": 0.2, "restitution_y": 0.5, "gravity": 0.3, "mass": 0.1, "inertia": 0.1}
    env = HopRoverEnv(randomize=rel)
    base = RoverParams()
    seen = []
    for seed in range(60):
        env.reset(seed=seed)
        p = env.params
        seen.append(p.gravity)
        for key, r in rel.items():
            v, v0 = getattr(p, key), getattr(base, key)
            cap = 1.0 if key.startswith(("mu", "rest")) else np.inf
            assert v0 * (1 - r) - 1e-15 <= v <= min(v0 * (1 + r), cap)
        assert p.mu_dynamic <= p.mu_static
    assert np.std(seen) > 0.05 * base.gravity  # really random
    env.reset(seed=3)
    p3 = env.params
    env.reset(seed=3)
    assert env.params == p3  # from the env's own seeded RNG
    with pytest.raises(ValueError, match="unknown parameter 'friction'"):
        HopRoverEnv(randomize={"friction": 0.1})
    with pytest.raises(ValueError, match=r"relative half-range in \[0, 1\)"):
        HopRoverEnv(randomize={"mass": 1.5})


def test_rgb_render_and_human_render():
    env = gym.make("HopRover-v0", render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(8):
        env.step(np.array([0.7], np.float32))
        frames.append(env.render())
    f = frames[-1]
    assert f.dtype == np.uint8 and f.shape == (360, 640, 3)
    assert not np.array_equal(frames[0], f)
    human = gym.make("HopRover-v0", render_mode="human")
    human.reset(seed=0)
    human.step(np.zeros(1, np.float32))
    human.close()
    venv = HopRoverVectorEnv(2, render_mode="rgb_array")
    venv.reset(seed=0)
    assert [fr.shape for fr in venv.render()] == [(360, 640, 3)] * 2


def test_record_video(tmp_path):
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(
        gym.make("HopRover-v0", render_mode="rgb_array", episode_time=20.0),
        str(tmp_path),
        episode_trigger=lambda e: True,
        disable_logger=True,
    )
    env.reset(seed=0)
    done = False
    while not done:
        _, _, te, tr, _ = env.step(np.array([0.5], np.float32))
        done = te or tr
    env.close()
    videos = [p for p in os.listdir(tmp_path) if p.endswith(".mp4")]
    assert videos and os.path.getsize(tmp_path / videos[0]) > 1000


def test_rendering_is_off_unless_asked():
    env = HopRoverEnv()
    env.reset(seed=0)
    env.step(np.zeros(1, np.float32))
    assert env._renderer is None and env._trace == []


def test_sb3_adapter_contract():
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    venv = HopRoverSB3VecEnv(3, seed=0, **ENV_KW)
    obs = venv.reset()
    assert obs.shape == (3, 19)
    ended = 0
    for k in range(200):
        obs, rew, dones, infos = venv.step(np.full((3, 1), 0.9 if k % 10 < 4 else 0.0))
        assert rew.dtype == np.float32 and dones.dtype == np.bool_ and len(infos) == 3
        for i in np.flatnonzero(dones):
            ended += 1
            assert infos[i]["terminal_observation"].shape == (19,)
            assert isinstance(infos[i]["TimeLimit.truncated"], bool)
            assert isinstance(infos[i]["is_success"], bool)
    assert ended > 0
    assert venv.get_attr("render_mode") == [None] * 3


@pytest.mark.slow  # trains PPO
def test_sb3_ppo_trains_on_the_adapter(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    venv = VecNormalize(VecMonitor(HopRoverSB3VecEnv(8, seed=0, **ENV_KW)), norm_reward=False)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=128, n_epochs=2, seed=0, verbose=0)
    model.learn(3000)
    assert model.num_timesteps >= 3000
    assert len(model.ep_info_buffer) > 0  # VecMonitor saw whole episodes
    model.save(tmp_path / "m")
    venv.save(str(tmp_path / "vn.pkl"))
    assert (tmp_path / "m.zip").exists()


# ---- counter draws (tasks/draws.py): vector == single at any position --------------
DRAW_TASKS = {
    "HopRover-v0": {"randomize": {"mass": 0.2, "mu_static": 0.3, "restitution_y": 0.5}},
    "HopRoverHop-v0": {},
    "HopRoverTerrain-v0": {},
    "HopRoverMission-v0": {},
}


@pytest.mark.parametrize("threads", [False, True])
@pytest.mark.parametrize("env_id", list(DRAW_TASKS))
def test_vector_equals_single_through_resets_and_autoresets(env_id, threads):
    """Sub-env i of a vector env seeded s equals a single env seeded s + i bit for bit,
    through autoresets (NextStep with threads, SameStep without), a masked reset with new
    seeds at random positions, and an unseeded reset of all: the counter draws depend on
    the rover's seed and episode number only."""
    from hoprover_env.envs.registry import env_class, vector_env_class

    n, seed = 7, 11
    kw = dict(DRAW_TASKS[env_id], episode_time=4.0, info_level="full")
    mode = "NextStep" if threads else "SameStep"
    venv = vector_env_class(env_id)(n, autoreset_mode=mode, threads=threads, **kw)
    singles = [env_class(env_id)(**kw) for _ in range(n)]
    rng = np.random.default_rng(5)
    obs, info = venv.reset(seed=seed)

    def check_reset(i, o, inf):
        assert np.array_equal(obs[i], o)
        for key in ("target_x", "slope", "terrain_seed"):
            assert info[key][i] == inf[key]
        assert np.array_equal(venv.P[i], singles[i]._p) and venv.params[i] == singles[i].params

    for i, e in enumerate(singles):
        check_reset(i, *e.reset(seed=seed + i))
    pending = np.zeros(n, bool)
    ended = 0
    for k in range(40):
        if k == 15:  # new seeds at random positions
            mask = rng.random(n) < 0.5
            mask[rng.integers(n)] = True
            seeds = [int(rng.integers(1000)) if rng.random() < 0.7 else None for _ in range(n)]
            obs, info = venv.reset(seed=seeds, options={"reset_mask": mask})
            for i in np.flatnonzero(mask):
                check_reset(i, *singles[i].reset(seed=seeds[i]))
                pending[i] = False
        if k == 30:  # the next episode of every rover
            obs, info = venv.reset()
            for i, e in enumerate(singles):
                check_reset(i, *e.reset())
            pending[:] = False
        a = rng.uniform(-1, 1, (n,) + venv.single_action_space.shape).astype(np.float32)
        obs, r, te, tr, info = venv.step(a.astype(np.float64))
        for i, e in enumerate(singles):
            if pending[i]:  # NextStep: this step was its reset
                o, inf = e.reset()
                check_reset(i, o, inf)
                assert r[i] == 0.0
                pending[i] = False
                continue
            o, rr, t1, t2, inf = e.step(a[i])
            assert rr == r[i] and t1 == te[i] and t2 == tr[i]
            assert np.array_equal(
                info["contact_forces"][i]
                if mode == "NextStep" or not (t1 or t2)
                else info["final_info"]["contact_forces"][i],
                inf["contact_forces"],
            )
            if t1 or t2:
                ended += 1
                if mode == "SameStep":
                    assert np.array_equal(info["final_obs"][i], o)
                    check_reset(i, *e.reset())
                else:
                    assert np.array_equal(obs[i], o)
                    pending[i] = True
            else:
                assert np.array_equal(obs[i], o)
    assert ended >= n


def test_counter_draws_seed_episode_and_one_draw_path():
    """reset(seed=s) restarts the episode count: the same episodes again; an unseeded
    reset goes on to the next. The draws are tasks/draws.py's, the only ones: `draws`
    is no env argument."""
    env = HopRoverEnv(randomize={"gravity": 0.3})
    first = [env.reset(seed=4)[1]["target_x"]] + [env.reset()[1]["target_x"] for _ in range(3)]
    again = [env.reset(seed=4)[1]["target_x"]] + [env.reset()[1]["target_x"] for _ in range(3)]
    assert first == again and len(set(first)) == 4
    for draws in ("legacy", "counter"):
        with pytest.raises(TypeError, match="unexpected keyword argument 'draws'"):
            HopRoverEnv(draws=draws)
        with pytest.raises(TypeError, match="unexpected keyword argument 'draws'"):
            HopRoverVectorEnv(3, draws=draws)
    venv = HopRoverVectorEnv(3, randomize={"gravity": 0.3})
    obs, _ = venv.reset(seed=4)
    assert np.array_equal(obs[0], env.reset(seed=4)[0]) and venv.params[0] == env.params
    unseeded = HopRoverVectorEnv(3)
    a, b = unseeded.reset()[1]["target_x"], HopRoverVectorEnv(3).reset()[1]["target_x"]
    assert len(set(a)) == 3 and not np.array_equal(a, b)  # fresh OS entropy per call


def test_counter_randomisation_redraws_painleve_rows():
    """A draw in the Painleve regime is drawn again (the next attempt of that rover's
    counter), row by row; every row is valid and equals the single env's."""
    from hoprover_env.tasks import draws

    # a thin, light-inertia rover with high friction: many draws are Painleve
    base = {
        "inertia": 2.5e-4,
        "mu_static": 1.0,
        "mu_dynamic": 0.3,
        "half_width": 0.05,
        "half_height": 0.05,
    }
    rel = {"inertia": 0.9, "mu_dynamic": 0.9}
    n = 64
    venv = HopRoverVectorEnv(n, params=base, randomize=rel)
    venv.reset(seed=0)
    assert not draws.invalid_rows(venv.P).any()
    assert len(set(venv.P[:, 1])) == n
    for i in (0, 17, 63):
        e = HopRoverEnv(params=base, randomize=rel)
        e.reset(seed=i)
        assert np.array_equal(e._p, venv.P[i])
    P = np.tile(RoverParams(**base).as_array(), (200, 1))
    P[:, 1] = np.geomspace(1e-5, 1e-2, 200)
    P[:, 6] = np.linspace(0.0, 1.0, 200)
    painleve = []
    for p in P:
        try:
            draws.row_params(p)
            painleve.append(False)
        except ValueError:
            painleve.append(True)
    assert any(painleve) and not all(painleve)
    assert np.array_equal(draws.invalid_rows(P), painleve)


@pytest.mark.parametrize(
    "rl_id, base",
    [
        ("HopRoverRL-v0", "HopRover-v0"),
        ("HopRoverTerrainRL-v0", "HopRoverTerrain-v0"),
        ("HopRoverHopRL-v0", "HopRoverHop-v0"),
    ],
)
def test_rl_ids_are_their_task_with_the_rl_settings_as_defaults(rl_id, base):
    """An RL id is its task, scored on the same suite, with the settings RL trains with
    as defaults: the same bits as the task given those settings, and still overridable."""
    from hoprover_env.envs.registry import task
    from hoprover_env.evaluation.suites import suite_of

    settings = task(rl_id).kwargs
    assert settings and suite_of(rl_id) == suite_of(base)
    assert task(rl_id).hops == task(base).hops
    a, b = gym.make(rl_id), gym.make(base, **settings)
    for name, value in settings.items():
        assert getattr(a.unwrapped.config, name) == value
    oa, _ = a.reset(seed=3)
    ob, _ = b.reset(seed=3)
    assert np.array_equal(oa, ob)
    rng = np.random.default_rng(0)
    for _ in range(30):
        act = rng.uniform(-0.3, 0.3, a.action_space.shape).astype(np.float32)
        ra, rb = a.step(act), b.step(act)
        assert np.array_equal(ra[0], rb[0]) and ra[1:4] == rb[1:4]
        if ra[2] or ra[3]:
            break
    assert gym.make(rl_id, time_cost=0.0).unwrapped.config.time_cost == 0.0
