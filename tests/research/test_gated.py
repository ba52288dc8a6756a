"""research.plan_clone.gated: the two-branch torque network and the bundled `plan_clone`."""

import json

import numpy as np
import pytest
import torch

from hoprover_env.agents.policies import load_policy
from research.plan_clone import gated
from research.plan_clone.clone_study import _model, _policy
from research.plan_clone.features import set_statistics


def _random_obs(rng, n=400):
    obs = rng.normal(0.0, 0.5, size=(n, 19)).astype(np.float32)
    obs[:, 7:14] = np.eye(7)[rng.integers(0, 7, n)]
    near = rng.random(n) < 0.5  # half of them still and near the edge
    obs[near, 0] = rng.uniform(-0.12, 0.12, near.sum())
    obs[near, 2] = rng.normal(0.0, 0.05, near.sum())
    obs[near, 4] = rng.normal(0.0, 0.005, near.sum())
    return obs


def _branches(rng):
    cfg, venv, model = _model("linear", activation="relu")
    venv.obs_rms.mean = rng.normal(0.0, 0.1, 19)
    venv.obs_rms.var = rng.uniform(0.05, 1.0, 19)
    cfg2, venv2, model2 = _model("linear", activation="relu", features="micro")
    venv2.obs_rms.mean = rng.normal(0.0, 0.1, 19)
    venv2.obs_rms.var = rng.uniform(0.05, 1.0, 19)
    set_statistics(model2.policy, venv2)
    return _policy(cfg, venv, model), _policy(cfg2, venv2, model2)


def test_the_gate_is_the_same_in_numpy_and_torch():
    obs = _random_obs(np.random.default_rng(0))
    mask = gated.near_edge(obs)
    assert 0 < mask.sum() < len(obs)
    np.testing.assert_array_equal(gated.near_edge(torch.as_tensor(obs)).numpy(), mask)


@pytest.mark.slow  # a sweep of states through the network
def test_the_network_is_the_main_branch_with_a_dead_zone_and_the_nudge_branch_near_the_edge():
    rng = np.random.default_rng(1)
    main, nudge = _branches(rng)
    net = gated.GatedNet(gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=0.05)
    obs = _random_obs(rng)
    want = main.act(obs, None)
    want[np.abs(want) < 0.05] = 0.0
    mask = gated.near_edge(obs)
    want[mask] = nudge.act(obs[mask], None)
    got = gated.GatedPolicy(net).act(obs, None)
    np.testing.assert_allclose(got, np.clip(want, -1, 1), atol=2e-6)
    assert (got[~mask] == 0.0).any()  # the dead zone did act


def test_a_saved_network_loads_with_the_same_actions_and_refuses_a_foreign_file(tmp_path):
    rng = np.random.default_rng(2)
    main, nudge = _branches(rng)
    net = gated.GatedNet(gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge))
    gated.save(net, tmp_path / "net.pt", {"made_from": "test"})
    loaded = gated.load_policy(tmp_path / "net.pt")
    obs = _random_obs(rng)
    np.testing.assert_array_equal(loaded.act(obs, None), gated.GatedPolicy(net).act(obs, None))
    assert loaded.name == "net" and loaded.env_kwargs == {"control_dt": 0.5}
    meta = json.loads((tmp_path / "net.json").read_text())
    meta["kind"] = "sb3"
    (tmp_path / "net.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="not describe a gated network"):
        gated.load_policy(tmp_path / "net.pt")
    with pytest.raises(FileNotFoundError, match="missing"):
        gated.load_policy(tmp_path / "other.pt")


def test_the_flight_gate_adds_the_slow_flights_near_the_target_and_nothing_else(tmp_path):
    from hoprover_env.core.layout import MODE_A
    from hoprover_env.tasks.observation import OBS_DX, OBS_SIN, OBS_VX, POS_SCALE, VEL_SCALE

    rng = np.random.default_rng(5)
    obs = _random_obs(rng, 4000)
    ground, both = gated.near_edge(obs), gated.near_edge(obs, flight=True)
    aloft = gated.observed_mode(obs) == MODE_A
    np.testing.assert_array_equal(both[~aloft], ground[~aloft])  # the ground: as before
    assert not ground[aloft].any()
    extra = both & ~ground
    assert extra.any() and aloft[extra].all()
    assert np.all(np.abs(obs[extra, OBS_SIN]) < gated.FLIGHT_TILT)
    assert np.all(np.abs(obs[extra, OBS_VX]) * VEL_SCALE < gated.STILL_SPEED)
    assert np.all(np.abs(obs[extra, OBS_DX]) * POS_SCALE <= gated.NUDGE_MAX)
    # a slow flight tilted beyond the ground's bound but within the flight's is gated
    assert (extra & (np.abs(obs[:, OBS_SIN]) > gated.STILL_TILT)).any()
    np.testing.assert_array_equal(gated.near_edge(torch.as_tensor(obs), flight=True).numpy(), both)
    main, nudge = _branches(rng)
    net = gated.GatedNet(
        gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=0.0, flight=True
    )
    got = gated.GatedPolicy(net).act(obs, None)
    np.testing.assert_allclose(got[extra], np.clip(nudge.act(obs[extra], None), -1, 1), atol=2e-6)
    gated.save(net, tmp_path / "net.pt")
    loaded = gated.load_policy(tmp_path / "net.pt")
    assert loaded.net.flight
    np.testing.assert_array_equal(loaded.act(obs, None), got)


def test_the_hold_zeroes_exactly_the_rests_on_a_face_in_the_band(tmp_path):
    from hoprover_env.core.layout import MODE_F
    from hoprover_env.tasks.observation import OBS_REF

    rng = np.random.default_rng(6)
    obs = _random_obs(rng, 4000)
    obs[:, OBS_REF] = rng.uniform(-1.5, 1.5, len(obs))
    obs[:8, 7:14] = np.eye(7)[MODE_F]
    obs[:8, OBS_REF] = [1.0, -1.0, 1.0 - 2e-6, -(1.0 - 2e-6), 0.0, 1.00001, -1.2, 0.5]
    rest = gated.at_rest_in_band(obs)
    want = (gated.observed_mode(obs) == MODE_F) & (np.abs(obs[:, OBS_REF]) < gated.HOLD_REF)
    np.testing.assert_array_equal(rest, want)
    # the edge itself and anything beyond it is not held (float32 round-off must never
    # hold a rover just outside the band); 2e-6 half-widths (1e-7 m) inside is
    np.testing.assert_array_equal(rest[:8], [False, False, True, True, True, False, False, True])
    assert 0 < rest.sum() < (gated.observed_mode(obs) == MODE_F).sum()
    np.testing.assert_array_equal(gated.at_rest_in_band(torch.as_tensor(obs)).numpy(), rest)
    main, nudge = _branches(rng)
    free = gated.GatedNet(
        gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=0.0, flight=True
    )
    held = gated.GatedNet(free.main, free.nudge, deadzone=0.0, flight=True, hold=True)
    a, b = gated.GatedPolicy(free).act(obs, None), gated.GatedPolicy(held).act(obs, None)
    assert np.all(b[rest] == 0.0) and np.any(a[rest] != 0.0)
    np.testing.assert_array_equal(b[~rest], a[~rest])
    gated.save(held, tmp_path / "held.pt")
    loaded = gated.load_policy(tmp_path / "held.pt")
    assert loaded.net.hold
    np.testing.assert_array_equal(loaded.act(obs, None), b)


def test_the_bundled_plan_clone_stays_still_when_it_starts_just_inside_the_band():
    from hoprover_env.evaluation.episodes import run_episodes

    # starts 0.26 mm and 0.04 mm inside the band's edge that the network without the
    # hold nudged out of the band (9.7 s and 8.2 s: docs/studies/plan-clone.md, section 10)
    res = run_episodes(load_policy("plan_clone"), np.array([-0.09974, 0.09996]))
    for r in res:
        assert r.success and r.ttrtp == 5.0, (r.target_x, r.ttrtp)


def test_the_mirror_of_an_episode_is_observed_as_the_mirror_of_its_observations():
    """Fly a rover to +x with torques u and its mirror image to -x with -u: at every
    step the second observation is mirror() of the first (level ground's symmetry)."""
    from hoprover_env.envs.vector_env import HopRoverVectorEnv
    from hoprover_env.tasks.observation import mirror

    venv = HopRoverVectorEnv(2, control_dt=0.5)
    obs, _ = venv.reset(seed=0, options={"target_x": np.array([0.37, -0.37])})
    rng = np.random.default_rng(3)
    modes = set()
    for step in range(400):
        u = 0.0 if step < 6 else rng.choice([0.0] * 6 + [0.04, -0.04, 0.3])
        obs, _, term, trunc, _ = venv.step(np.array([[u], [-u]]))
        if term.any() or trunc.any():
            break
        np.testing.assert_allclose(obs[1], mirror(obs[:1])[0], atol=1e-5)
        modes.add(int(np.argmax(obs[0, 7:14])))
    assert len(modes) >= 3  # flight, pivots and rests were compared
    o = _random_obs(rng)
    np.testing.assert_array_equal(mirror(mirror(o)), o)
    np.testing.assert_array_equal(mirror(torch.as_tensor(o)).numpy(), mirror(o))


def test_a_symmetric_network_is_odd_under_the_mirror_and_keeps_it_when_saved(tmp_path):
    from hoprover_env.tasks.observation import mirror

    rng = np.random.default_rng(4)
    main, nudge = _branches(rng)
    obs = _random_obs(rng)
    plain = gated.GatedNet(gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=1e-4)
    sym = gated.GatedNet(
        gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=1e-4, symmetric=True
    )
    a, am = (gated.GatedPolicy(sym).act(o, None) for o in (obs, mirror(obs)))
    np.testing.assert_allclose(am, -a, atol=1e-6)
    p, pm = (gated.GatedPolicy(plain).act(o, None) for o in (obs, mirror(obs)))
    assert np.abs(pm + p).max() > 1e-3  # a fit alone is not odd
    # off the edge: the main branch's odd part with the dead zone after it
    off = ~gated.near_edge(obs)
    want = 0.5 * (main.act(obs, None) - main.act(mirror(obs), None))
    want[np.abs(want) < sym.deadzone] = 0.0
    np.testing.assert_allclose(a[off], np.clip(want, -1, 1)[off], atol=2e-6)
    gated.save(sym, tmp_path / "sym.pt")
    loaded = gated.load_policy(tmp_path / "sym.pt")
    assert loaded.net.symmetric
    np.testing.assert_array_equal(loaded.act(obs, None), a)


@pytest.mark.slow  # whole episodes against the planner
def test_the_bundled_plan_clone_nudges_at_the_band_edge_within_the_regret_bound():
    from hoprover_env.evaluation import suites
    from hoprover_env.evaluation.episodes import run_episodes

    suite = suites.load("HopRover-v0")
    # level-v1's targets just beyond the band's edge (a nudge of 0.4-6 mm) and a long hop
    pick = [int(np.argmin(np.abs(suite.targets - x))) for x in (-0.1004, -0.1061, 0.1056, -0.6144)]
    res = run_episodes(load_policy("plan_clone"), suite.targets[pick])
    for r, k in zip(res, pick):
        assert r.success, suite.targets[k]
        assert r.ttrtp <= 1.30 * suite.reference_ttrtp[k], (suite.targets[k], r.ttrtp)


def _pivot_observations(target, torque, steps=6):
    """Observations of a rover pushed with `torque` (of T_max) from rest toward `target`."""
    from hoprover_env.envs.vector_env import HopRoverVectorEnv

    venv = HopRoverVectorEnv(1, control_dt=0.5)
    obs, _ = venv.reset(seed=0, options={"target_x": np.array([target])})
    out = [obs[0]]
    for _ in range(steps):
        obs, *_ = venv.step(np.array([[torque * np.sign(target)]]))
        out.append(obs[0])
    return np.array(out)


def test_the_rest_offset_is_the_c_m_at_rest_and_the_corner_stood_on_in_a_pivot():
    from hoprover_env.core.layout import MODE_F
    from hoprover_env.core.params import RoverParams
    from hoprover_env.tasks.observation import OBS_DX, OBS_SIN

    p = RoverParams()
    obs = np.concatenate(
        [_pivot_observations(x, u) for x in (0.3, -0.3, 0.11503, -0.6) for u in (0.06, 0.25)]
    )
    rest, dx = gated.rest_offset(obs), obs[:, OBS_DX].astype(np.float64)
    mode = gated.observed_mode(obs)
    face = mode == MODE_F
    assert face.any() and (~face & (mode != 0)).any()
    np.testing.assert_allclose(rest[face], dx[face], atol=1e-7)
    # on a corner, the c.m. stands off the corner's rest position by the body's turn
    # about it: r (1 - cos th) + h |sin th| at most
    th = np.arcsin(obs[:, OBS_SIN].astype(np.float64))
    pivot = ~face & (mode != 0) & (np.abs(th) < 0.02)
    assert pivot.sum() >= 4
    bound = p.half_width * (1 - np.cos(th)) + p.half_height * np.abs(np.sin(th)) + 1e-7
    assert np.all(np.abs(rest - dx)[pivot] <= bound[pivot])
    assert np.all(np.abs(rest - dx)[pivot & (np.abs(th) > 2e-3)] > 1e-5)
    np.testing.assert_allclose(gated.rest_offset(torch.as_tensor(obs)).numpy(), rest, atol=1e-9)


def test_the_rest_gate_keeps_a_launch_from_beyond_the_reach_off_the_nudge_branch(tmp_path):
    from hoprover_env.tasks.observation import OBS_DX, OBS_REF

    # a hop launched from 0.03 mm beyond nudge_max: half a second later the c.m. is
    # within the reach (the c.m. gate hands it to the nudge branch), the corner is not
    obs = _pivot_observations(0.11503, 0.2542, steps=1)
    assert abs(obs[1, 0]) < gated.NUDGE_MAX < abs(obs[0, 0])
    np.testing.assert_array_equal(gated.near_edge(obs), [False, True])
    np.testing.assert_array_equal(gated.near_edge(obs, rest=True), [False, False])
    np.testing.assert_array_equal(
        gated.near_edge(torch.as_tensor(obs), rest=True).numpy(), [False, False]
    )
    # at rest, and in flight, the two gates are one
    rng = np.random.default_rng(8)
    o = _random_obs(rng, 4000)
    # the contact point at rest on a face: the corner nearer the target
    corner = o[:, OBS_DX] - np.sign(o[:, OBS_DX]) * gated.HALF_WIDTH
    o[:, OBS_REF] = corner / gated.BAND_HALF_WIDTH
    from hoprover_env.core.layout import MODE_A, MODE_F

    keep = np.isin(gated.observed_mode(o), [MODE_A, MODE_F])
    np.testing.assert_array_equal(
        gated.near_edge(o[keep], flight=True, rest=True), gated.near_edge(o[keep], flight=True)
    )
    main, nudge = _branches(rng)
    net = gated.GatedNet(
        gated.Branch.from_sb3(main), gated.Branch.from_sb3(nudge), deadzone=0.0, rest=True
    )
    gated.save(net, tmp_path / "rest.pt")
    loaded = gated.load_policy(tmp_path / "rest.pt")
    assert loaded.net.rest
    np.testing.assert_array_equal(loaded.act(obs, None), gated.GatedPolicy(net).act(obs, None))


def test_the_bundled_plan_clone_hops_from_just_beyond_the_nudge_reach_without_a_detour():
    from hoprover_env.evaluation.episodes import run_episodes

    # 0.01-0.07 mm beyond 0.115 m the network with the c.m. gate took 41 s (the nudge
    # branch took over the launch); a hop from 0.1153 m takes 31
    x = np.array([0.11503, -0.11503, 0.11506, 0.1153])
    t = np.array([r.ttrtp for r in run_episodes(load_policy("plan_clone"), x)])
    assert np.all(t[:3] <= 1.05 * t[3]), t


def test_the_exported_module_acts_as_the_network_and_loads_with_no_research_code(tmp_path):
    """gated.export writes the package's generic policy file: the gate, hold and mirror
    travel inside it, so load_policy runs it as a TorchPolicy, action for action."""
    from hoprover_env.agents.base import TorchPolicy

    rng = np.random.default_rng(11)
    main, nudge = _branches(rng)
    net = gated.GatedNet(
        gated.Branch.from_sb3(main),
        gated.Branch.from_sb3(nudge),
        symmetric=True,
        flight=True,
        hold=True,
        rest=True,
    )
    gated.save(net, tmp_path / "net.pt", {"made_from": "test"})
    loaded_net, meta = gated.load(tmp_path / "net.pt")
    gated.export(loaded_net, tmp_path / "net.pt2", meta)
    loaded = load_policy(str(tmp_path / "net.pt2"))
    assert isinstance(loaded, TorchPolicy) and loaded.env_kwargs == {"control_dt": 0.5}
    assert loaded.meta["made_by"] == "imitation of a planner" and loaded.meta["hand_written"]
    for n in (1, 7, 300):
        obs = _random_obs(rng, n)
        np.testing.assert_array_equal(loaded.act(obs, None), gated.GatedPolicy(net).act(obs, None))


@pytest.mark.slow  # rebuilds and compares the research network
def test_the_bundled_plan_clone_is_the_research_network_exported():
    """The package's plan_clone.pt2 acts exactly as the state-dict network the pipeline
    made (research/plan_clone/plan_clone.pt), on observations of real episodes."""
    import gymnasium as gym

    bundled = load_policy("plan_clone")
    research = gated.load_policy(
        gated.Path(__file__).parents[2] / "research" / "plan_clone" / "plan_clone.pt"
    )
    envs = gym.make_vec("HopRover-v0", num_envs=32)
    obs, _ = envs.reset(seed=4)
    for _ in range(60):
        a = bundled.act(obs, envs)
        np.testing.assert_array_equal(a, research.act(obs, envs))
        obs, *_ = envs.step(a)
