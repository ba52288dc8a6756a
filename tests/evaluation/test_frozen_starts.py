"""Frozen episode starts: a suite's start conditions as reset options, and their checks."""

import json

import numpy as np
import pytest

from hoprover_env.envs.registry import ENVS, env_class, vector_env_class
from hoprover_env.evaluation import suites
from hoprover_env.tasks import mission

MISSION = "HopRoverMission-v0"
GROUND = ("mu_dynamic", "mu_static", "restitution_x", "restitution_y")


def test_the_terrain_suite_freezes_the_missions_starts():
    suite = suites.load(MISSION)
    assert suite.meta["format"] == suites.FORMAT and suite.start_ids() == [MISSION]
    assert sorted(suite.meta["start"][MISSION]) == sorted(GROUND + ("actuator_draw", "sensor_seed"))
    cond = suite.conditions(MISSION)
    assert cond["sensor_seed"].dtype == np.int64 and cond["sensor_seed"].max() > 2**53
    assert np.all(np.abs(cond["actuator_draw"]) <= 1.0)
    for key, rel in mission.MISSION_GROUND.items():  # within the ranges drawn from
        base = getattr(suite[0].params, key)
        assert np.all(np.abs(cond[key] / base - 1.0) <= rel + 1e-12), key
    # the ids that draw nothing beyond the episode's columns have no conditions
    assert suite.conditions("HopRoverTerrain-v0").keys() == suite.terrain().keys()
    assert "sensor_seed" not in suite[0].reset_options("HopRoverTerrain-v0")


@pytest.mark.parametrize("env_id", [MISSION, "HopRoverTerrain-v0", "HopRover-v0"])
def test_an_env_given_an_episodes_conditions_starts_that_episode(env_id):
    """Whatever the seed, a single env given episode e's reset options starts the same
    rover rows as sub-env e of a vector env given the suite's conditions."""
    suite = suites.load(env_id)
    pick = [0, 3, len(suite) - 1]
    kw = dict(ENVS[env_id].kwargs, episode_time=suites.EPISODE_TIME, info_level="full")
    venv = vector_env_class(env_id)(len(pick), **kw)
    cond = {k: v[pick] for k, v in suite.conditions(env_id).items()}
    obs, info = venv.reset(seed=0, options={"target_x": suite.targets[pick], **cond})
    env = env_class(env_id)(**kw)
    for j, e in enumerate(pick):
        for seed in (e, 999):
            o, inf = env.reset(seed=seed, options=suite[e].reset_options(env_id))
            assert np.array_equal(o, obs[j]) and np.array_equal(env._p, venv.P[j])
            assert np.array_equal(env._s, venv.S[j], equal_nan=True)
            assert np.array_equal(env._m, venv.M[j])
            assert inf["terrain_seed"] == info["terrain_seed"][j] == suite[e].terrain_seed
    if env_id == MISSION:
        ep = suite[pick[0]].start[MISSION]
        seed = int(venv.M[0, mission.M_SEED_LO]) | (int(venv.M[0, mission.M_SEED_HI]) << 32)
        assert seed == ep["sensor_seed"]
        assert venv.M[0, mission.M_ACT_SCALE] == 1.0 + 0.05 * ep["actuator_draw"]
        assert all(getattr(venv.params[0], k) == ep[k] for k in GROUND)


def test_start_options_replace_the_draws_only():
    """The mission's start options fix what they name and leave the rest to the seed;
    the seeded stream stays aligned (the next episode is the one it always was)."""
    Env = env_class(MISSION)
    a, b = Env(), Env()
    a.reset(seed=4, options={"actuator_draw": -0.5, "mu_static": 1.0})
    _, info = b.reset(seed=4)
    assert a._m[mission.M_ACT_SCALE] == 1.0 - 0.05 * 0.5
    assert a.params.mu_static == 1.0 and a.params.restitution_x == b.params.restitution_x
    assert np.array_equal(a._m[:2], b._m[:2])  # the sensor seed: drawn
    assert a.reset()[1]["target_x"] == b.reset()[1]["target_x"]
    assert np.array_equal(a._m, b._m) and a.params == b.params


@pytest.mark.parametrize(
    "options, words",
    [
        ({"sensor_seed": -1}, r"options\['sensor_seed'\] must be an integer in \[0, 2\*\*63\)"),
        ({"sensor_seed": 2**63}, r"options\['sensor_seed'\]"),
        ({"sensor_seed": 1.5}, r"options\['sensor_seed'\] must be integers"),
        ({"actuator_draw": 1.5}, r"options\['actuator_draw'\] must be in \[-1, 1\]"),
        ({"actuator_draw": np.nan}, r"options\['actuator_draw'\] must be in \[-1, 1\]"),
        ({"mu_static": np.inf}, r"options\['mu_static'\] must be finite"),
        ({"mass": "heavy"}, r"options\['mass'\] must be real numbers"),
        ({"mu_static": 0.1, "mu_dynamic": 0.3}, "mu_dynamic"),  # RoverParams' own check
        (
            {"actuator_drew": 0.1},
            r"unknown reset option\(s\) \['actuator_drew'\]; valid: .*"
            r"'actuator_draw'",
        ),
    ],
)
def test_bad_start_options_are_refused_by_name(options, words):
    with pytest.raises(ValueError, match=words):
        env_class(MISSION)().reset(seed=0, options=options)
    with pytest.raises(ValueError, match=words):
        vector_env_class(MISSION)(2).reset(seed=0, options=options)


def test_start_options_are_the_tasks_own():
    with pytest.raises(ValueError, match=r"unknown reset option\(s\) \['sensor_seed'\]"):
        env_class("HopRoverTerrain-v0")().reset(seed=0, options={"sensor_seed": 3})
    venv = vector_env_class(MISSION)(2)
    with pytest.raises(
        ValueError,
        match=r"options\['sensor_seed'\] must have shape "
        r"\(\) or \(2,\)",
    ):
        venv.reset(seed=0, options={"sensor_seed": np.arange(3)})
    venv.reset(seed=0, options={"sensor_seed": np.array([5, 2**62]), "actuator_draw": [0.25, -1.0]})
    assert venv.M[1, mission.M_SEED_HI] == 2**30 and venv.M[0, mission.M_SEED_LO] == 5
    assert list(venv.M[:, mission.M_ACT_SCALE]) == [1.0 + 0.05 * 0.25, 1.0 - 0.05]


def test_a_suite_run_refuses_to_redraw_the_frozen_ground():
    from hoprover_env.agents.policies import load_policy

    suite = suites.load(MISSION)
    head = suites.Suite(suite.name, suite.version, suite.checksum, suite.episodes[:2], suite.meta)
    policy = load_policy("scripted")
    policy.env_id = MISSION
    with pytest.raises(ValueError, match="randomize.*HopRoverMission-v0's own"):
        suites.run(policy, head, env_kwargs={"randomize": {"mass": 0.1}})
    with pytest.raises(ValueError, match="randomize"):
        suites.run(
            load_policy("scripted"),
            suites.load("HopRover-v0"),
            env_kwargs={"randomize": {"gravity": 0.1}},
        )
    # its own ranges, given again, change nothing: accepted
    suites.check_frozen(MISSION, {"randomize": dict(mission.MISSION_GROUND)})


def test_modified_start_conditions_fail_their_checksum(tmp_path):
    src = suites.path_of("terrain", suites.versions("terrain")[-1])
    with np.load(src) as z:
        data = {k: z[k] for k in z.files}
    key = f"start/{MISSION}/actuator_draw"
    data[key] = data[key] * 0.5  # a kinder actuator
    np.savez(tmp_path / "bad.npz", **data)
    with pytest.raises(ValueError, match="checksum mismatch of the start conditions"):
        suites._read(tmp_path / "bad.npz", "terrain", 1)
    data[key] = data[key] * 2.0
    data[f"start/{MISSION}/mass"] = np.ones(len(data["target_x"]))  # an unlisted one
    np.savez(tmp_path / "stray.npz", **data)
    with pytest.raises(ValueError, match="checksum mismatch of the start conditions"):
        suites._read(tmp_path / "stray.npz", "terrain", 1)


def test_save_and_read_back_start_conditions(tmp_path):
    cols = suites.draw_episodes("level", n=3)
    cols["reference_ttrtp"] = np.full(3, 10.0)
    start = {
        MISSION: {"sensor_seed": np.array([1, 2**62, 3]), "mu_static": np.array([0.3, 0.31, 0.32])}
    }
    path = suites.save("level", 9, cols, [np.zeros(2)] * 3, ["x"] * 3, {}, tmp_path, start=start)
    s = suites._read(path, "level", 9)
    assert s[1].start == {MISSION: {"sensor_seed": 2**62, "mu_static": 0.31}}
    assert json.loads(json.dumps(s.meta))["start"] == {MISSION: ["mu_static", "sensor_seed"]}
    assert s.conditions(MISSION)["sensor_seed"].dtype == np.int64


def test_a_new_version_of_the_same_episodes_carries_the_start_conditions_over(tmp_path):
    # what research/yardstick/references.py does when it saves new references
    suite = suites.load(MISSION)
    cols = {f: suite.column(f) for f in suites.FIELDS}
    meta = {k: v for k, v in suite.meta.items() if k not in ("sha256", "start_sha256")}
    path = suites.save(
        suite.name,
        9,
        cols,
        [e.reference_schedule for e in suite],
        [e.reference_source for e in suite],
        meta,
        directory=tmp_path,
        start=suite.start_conditions(),
    )
    again = suites._read(path, suite.name, 9)
    assert again.meta["start_sha256"] == suite.meta["start_sha256"]
    for k, v in suite.conditions(MISSION).items():
        assert np.array_equal(again.conditions(MISSION)[k], v), k
