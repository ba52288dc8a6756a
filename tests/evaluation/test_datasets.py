"""Offline-RL datasets (hoprover_env.evaluation.datasets): built by the command into an empty
directory, loaded with Minari, every episode replayed in the env bit for bit from its
recorded seed (for any number of sub-envs), the reference scores, and bad input."""

import os

import numpy as np
import pytest

from hoprover_env.evaluation import datasets

# the fast tier (pytest -m "not slow") leaves this file out:
# builds offline-RL datasets with Minari and replays every episode
pytestmark = pytest.mark.slow

minari = pytest.importorskip("minari", reason="pip install 'hoprover[offline]'")


@pytest.fixture
def root(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    return tmp_path


def _replay_all(ds):
    """Reset the recovered env with each episode's seed and options, step its actions:
    the observations, rewards, terminations and truncations must be the recorded ones."""
    env = ds.recover_environment()
    ids = list(ds.episode_indices)
    meta = {int(m["id"]): m for m in ds.storage.get_episode_metadata(ids)}
    for ep in ds.iterate_episodes():
        m = meta[int(ep.id)]
        obs, _ = env.reset(seed=int(m["seed"]), options=m.get("options") or None)
        assert np.array_equal(obs, ep.observations[0]), ep.id
        for k, a in enumerate(ep.actions):
            obs, r, te, tr, _ = env.step(a)
            assert np.array_equal(obs, ep.observations[k + 1]), (ep.id, k)
            assert r == ep.rewards[k] and te == ep.terminations[k] and tr == ep.truncations[k], (
                ep.id,
                k,
            )
    return len(ids)


@pytest.mark.parametrize(
    "task, level, num_envs",
    [
        ("HopRover-v0", "expert", 7),
        ("HopRover-v0", "random", 1),
        ("HopRover-v0", "mixed", 4),
        ("HopRoverHop-v0", "expert", 3),
        ("HopRoverTerrain-v0", "expert", 5),
    ],
)
def test_a_built_dataset_loads_and_every_episode_replays_bit_for_bit(root, task, level, num_envs):
    assert (
        datasets.main(
            [
                "--task",
                task,
                "--level",
                level,
                "--steps",
                "400",
                "--out",
                str(root),
                "--num-envs",
                str(num_envs),
            ]
        )
        == 0
    )
    ds = minari.load_dataset(datasets.dataset_id(task, level))
    assert ds.total_steps >= 400
    assert _replay_all(ds) == ds.total_episodes
    # seeds are the episodes' own, in order from --seed
    ids = list(ds.episode_indices)
    seeds = [int(m["seed"]) for m in ds.storage.get_episode_metadata(ids)]
    assert seeds == list(range(len(ids)))


def test_reference_scores_normalise_random_and_expert(root):
    _, report = datasets.build("HopRover-v0", "expert", 300, root)
    ds = minari.load_dataset("hoprover/HopRover-v0/expert-v0")
    lo, hi = report["ref_min_score"], report["ref_max_score"]
    assert lo < hi
    assert np.allclose(minari.get_normalized_score(ds, np.array([lo, hi])), [0.0, 1.0])
    # the expert's own episodes (whole: the budget lets running episodes finish) score
    # near 1
    returns = np.array([ep.rewards.sum() for ep in ds.iterate_episodes()])
    assert np.median(minari.get_normalized_score(ds, returns)) > 0.8
    env = ds.recover_environment()
    assert env.spec.id == "HopRover-v0" and env.unwrapped.config.control_dt == 2.0


def test_bad_input_is_refused_by_name_and_nothing_is_overwritten(root, capsys):
    assert datasets.main(["--task", "HopRover-v9", "--level", "expert", "--out", str(root)]) == 2
    assert "unknown task 'HopRover-v9'" in capsys.readouterr().err
    assert datasets.main(["--task", "HopRover-v0", "--level", "pro", "--out", str(root)]) == 2
    assert "unknown level 'pro'" in capsys.readouterr().err
    assert (
        datasets.main(
            ["--task", "HopRover-v0", "--level", "random", "--steps", "200", "--out", str(root)]
        )
        == 0
    )
    where = root / "hoprover" / "HopRover-v0" / "random-v0"
    before = {p: p.stat().st_mtime_ns for p in where.rglob("*") if p.is_file()}
    assert (
        datasets.main(
            ["--task", "HopRover-v0", "--level", "random", "--steps", "200", "--out", str(root)]
        )
        == 2
    )
    assert "holds hoprover/HopRover-v0/random-v0 already" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in where.rglob("*") if p.is_file()} == before
    assert os.listdir(root) == ["hoprover"]
