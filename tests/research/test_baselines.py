"""research/baselines.py: seeds trained one after another, resumed, and scored on the
suite with intervals over seeds."""

import json

import pytest
import yaml

from research import baselines

# the fast tier (pytest -m "not slow") leaves this file out:
# trains seeds one after another
pytestmark = pytest.mark.slow

TINY = {
    "algo": "ppo",
    "env_id": "HopRoverHop-v0",
    "n_envs": 4,
    "timesteps": 512,
    "seed": 0,
    "env": {"control_dt": 0.5},
    # gamma: the hop task's shaping discount (train.py refuses a learner's other than it)
    "hyperparams": {"n_steps": 64, "batch_size": 128, "n_epochs": 1, "gamma": 0.98},
    "evaluation": {"freq": 256, "episodes": 4, "seed": 1},
    "checkpoint": {"freq": 256},
}


@pytest.mark.parametrize(
    "text, seeds",
    [("0-4", [0, 1, 2, 3, 4]), ("3", [3]), ("0,2,5", [0, 2, 5]), ("1-2,7", [1, 2, 7])],
)
def test_seed_specs(text, seeds):
    assert baselines.parse_seeds(text) == seeds


def test_a_config_with_demonstrations_is_its_own_group():
    assert baselines.group_of({"demonstrations": {"policy": "scripted"}}) == baselines.DEMOS
    assert baselines.group_of({"algo": "sac"}) == baselines.RL == "RL from reward"


@pytest.mark.parametrize("text", ["", "a-b", "0-1,1", "-1", "2-x"])
def test_bad_seed_specs_are_named(text):
    with pytest.raises(ValueError, match="--seeds"):
        baselines.parse_seeds(text)


def test_two_seeds_train_then_score_on_the_suite(tmp_path, capsys):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(yaml.safe_dump(TINY))
    out = tmp_path / "runs"
    assert (
        baselines.main(
            ["--config", str(cfg), "--seeds", "0-1", "--out", str(out), "--name", "tiny"]
        )
        == 0
    )
    for seed in (0, 1):
        assert (out / f"s{seed}" / "done").exists()
        assert yaml.safe_load((out / f"s{seed}" / "config.yaml").read_text())["seed"] == seed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["suite"] == "level-v1" and summary["env_id"] == "HopRoverHop-v0"
    assert summary["summary"]["runs"] == 2 and summary["summary"]["episodes"] == 200
    s = summary["summary"]
    for m in ("success", "mean_score", "iqm_score"):
        assert s[m + "_low"] <= s[m] <= s[m + "_high"]
    assert [r["seed"] for r in summary["runs"]] == [0, 1]
    # its group (no demonstrations in TINY), and the commit and date it was scored at
    assert summary["group"] == "RL from reward"
    assert summary["commit"] and len(summary["date"]) == 10
    assert (out / "curves.png").stat().st_size > 0 and "| 1 |" in (out / "summary.md").read_text()
    # a second call trains nothing (both done) and scores the same
    capsys.readouterr()
    assert (
        baselines.main(
            ["--config", str(cfg), "--seeds", "0-1", "--out", str(out), "--name", "tiny"]
        )
        == 0
    )
    assert "done already" in capsys.readouterr().out
    assert json.loads((out / "summary.json").read_text())["summary"] == summary["summary"]


def test_torch_threads_reach_train_py_and_a_custom_trainer_refuses_them(tmp_path, monkeypatch):
    calls = []

    def fake_call(cmd, **kwargs):  # train.py would make the run directory
        calls.append(cmd)
        (tmp_path / "runs" / f"s{cmd[cmd.index('--seed') + 1]}").mkdir()
        return 0

    monkeypatch.setattr(baselines.subprocess, "call", fake_call)
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(yaml.safe_dump(TINY))
    (tmp_path / "runs").mkdir()
    baselines.train(str(cfg), [0], tmp_path / "runs", None, torch_threads=1)
    assert calls[0][calls[0].index("--torch-threads") + 1] == "1"
    baselines.train(str(cfg), [1], tmp_path / "runs", None)
    assert "--torch-threads" not in calls[1]
    cfg.write_text(yaml.safe_dump({**TINY, "trainer": "research.train_mission"}))
    with pytest.raises(SystemExit, match="--torch-threads is train.py's flag"):
        baselines.train(str(cfg), [2], tmp_path / "runs", None, torch_threads=1)
