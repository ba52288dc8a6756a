"""The frozen test suites and their replayable best-known references."""

import shutil

import numpy as np
import pytest

from hoprover_env.evaluation import suites

IDS = ("HopRover-v0", "HopRoverHop-v0", "HopRoverTerrain-v0", "HopRoverContest-v0")


@pytest.mark.parametrize("env_id", IDS)
def test_every_task_has_a_versioned_suite(env_id):
    s = suites.load(env_id)
    assert s.version >= 1 and len(s.checksum) == 64
    assert len(s) == {"level": 200, "terrain": 200, "contest": 1}[s.name]
    ep = s[0]
    assert ep.control_dt == 0.5 and ep.reference_schedule.dtype == np.float64
    assert np.all(np.isfinite(s.reference_ttrtp)) and np.all(s.reference_ttrtp >= 5.0)
    # the stored episodes are the ones the suite's seed draws
    drawn = suites.draw_episodes(s.name)
    np.testing.assert_array_equal(s.targets, drawn["target_x"])
    np.testing.assert_array_equal(s.column("terrain_seed"), drawn["terrain_seed"])


def test_hop_task_shares_the_level_episodes():
    a, b = suites.load("HopRover-v0"), suites.load("HopRoverHop-v0")
    assert a.checksum == b.checksum


def test_terrain_suite_draws_slopes_and_seeds():
    s = suites.load("HopRoverTerrain-v0")
    slopes = s.column("slope")
    assert np.all(np.abs(slopes) <= 0.2) and slopes.std() > 0.05
    assert np.all(s.column("roughness") == 0.05)
    assert len(set(s.column("terrain_seed").tolist())) == len(s)


@pytest.mark.parametrize("env_id", ["HopRover-v0", "HopRoverTerrain-v0", "HopRoverContest-v0"])
def test_references_replay_bit_for_bit(env_id):
    s = suites.load(env_id)
    rng = np.random.default_rng(0)
    for i in rng.choice(len(s), size=min(4, len(s)), replace=False):
        ep = s[int(i)]
        assert ep.replay().ttrtp == ep.reference_ttrtp, (env_id, i)


def test_suites_are_disjoint_from_validation_and_evaluation_targets():
    """train.py validates on seeded_targets(n, 7) (and the terrain task's slopes drawn
    beside them); evaluate.py without --suite on seed 2015: no suite target is one of
    theirs."""
    validation = np.random.default_rng(7).uniform(-1, 1, 10_000)
    evaluation = np.random.default_rng(2015).uniform(-1, 1, 10_000)
    for env_id in IDS:
        t = suites.load(env_id).targets
        assert not np.isin(t, validation).any() and not np.isin(t, evaluation).any()


def test_unknown_id_or_version_is_named():
    with pytest.raises(ValueError, match="'HopRover-v9'"):
        suites.load("HopRover-v9")
    with pytest.raises(ValueError, match="unknown version 99"):
        suites.load("HopRover-v0", version=99)


def test_a_modified_file_fails_its_checksum(tmp_path):
    src = suites.path_of("contest", suites.versions("contest")[-1])
    with np.load(src) as z:
        data = {k: z[k] for k in z.files}
    data["reference_ttrtp"] = data["reference_ttrtp"] - 1.0  # a "better" reference
    bad = tmp_path / src.name
    np.savez(bad, **data)
    with pytest.raises(ValueError, match="checksum mismatch"):
        suites._read(bad, "contest", 1)
    shutil.copy(src, tmp_path / "ok.npz")
    assert suites._read(tmp_path / "ok.npz", "contest", 1).checksum


def test_evaluate_suite_prints_scores_and_writes_the_fields(tmp_path, capsys):
    import json

    from hoprover_env.training import evaluate

    out = tmp_path / "rows.json"
    assert (
        evaluate.main(
            [
                "--suite",
                "--env",
                "HopRoverContest-v0",
                "--policy",
                "scripted",
                "--no-progress",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "contest-v1 suite" in text and "median regret" in text and "IQM score" in text
    row = json.loads(out.read_text())["episodes"][0]
    ref = suites.load("HopRoverContest-v0")[0].reference_ttrtp
    assert row["reference_ttrtp"] == ref
    assert row["regret"] == row["ttrtp"] / ref and row["score"] == ref / row["ttrtp"]
    assert row["ttrtp"] >= ref  # the reference beats the scripted hopper


def test_evaluate_suite_bad_input(capsys):
    from hoprover_env.training import evaluate

    assert evaluate.main(["--suite", "7", "--policy", "scripted"]) == 2
    assert "unknown version 7" in capsys.readouterr().err
    assert evaluate.main(["--suite", "--policy", "no-such-agent"]) == 2
    assert "unknown policy 'no-such-agent'" in capsys.readouterr().err
    assert evaluate.main(["--suite", "--targets", "0.5"]) == 2
    assert "--suite fixes the episodes" in capsys.readouterr().err


@pytest.mark.parametrize("env_id", ["HopRoverTerrain-v0", "HopRover-v0"])
def test_agents_play_the_references_ground(env_id):
    """An agent run on a suite (suites.run's path: run_episodes with the suite's ground)
    meets the bumps its reference was searched on: a policy that plays the reference
    schedule as actions reaches the reference TTRTP."""
    from hoprover_env import RoverParams
    from hoprover_env.agents.policies import torque_to_action
    from hoprover_env.evaluation.episodes import run_episodes

    suite = suites.load(env_id)
    pick = [0, 1, 2]
    eps = [suite[i] for i in pick]
    steps = {"k": 0}

    class Schedule:  # the reference plan, one interval per step
        env_kwargs = {"control_dt": 0.5}
        env_id = suites.task_of(suite.name)

        def reset(self, n):
            steps["k"] = 0

        def act(self, obs, venv):
            k = steps["k"]
            steps["k"] += 1
            out = np.zeros((len(eps), 1))
            for i, ep in enumerate(eps):
                torque = ep.reference_schedule[k] if k < len(ep.reference_schedule) else 0.0
                params = RoverParams(slope=ep.slope, roughness=ep.roughness)
                out[i, 0] = torque_to_action(torque, params)
            return out

    ground = {k: v[pick] for k, v in suite.terrain().items()}
    if suite.name == "terrain":
        assert ground["terrain_seed"].dtype.kind == "i" and ground["terrain_seed"].max() > 2**53
    res = run_episodes(
        Schedule(), suite.targets[pick], env_kwargs={"episode_time": 600.0}, terrain=ground
    )
    for r, ep in zip(res, eps):
        assert r.success
        assert r.ttrtp == pytest.approx(ep.reference_ttrtp, rel=1e-6, abs=1e-6)
