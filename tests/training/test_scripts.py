"""train.py end to end, in-process (the kernels are already compiled); evaluate.py:
test_evaluate_script.py."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from hoprover_env.training import evaluate, train

# the fast tier (pytest -m "not slow") leaves this file out:
# train.py and evaluate.py end to end: training runs, resumes, sweeps
pytestmark = pytest.mark.slow


TINY = {
    "algo": "ppo",
    "n_envs": 4,
    "timesteps": 2048,
    "seed": 0,
    "env": {"control_dt": 1.0, "episode_time": 60.0, "target_range": [-0.3, 0.3]},
    "hyperparams": {"n_steps": 128, "batch_size": 256, "n_epochs": 2},
    "pretrain": {"episodes": 8, "epochs": 2, "value_epochs": 1},
    "evaluation": {"freq": 1024, "episodes": 4, "seed": 1},
    "checkpoint": {"freq": 512},
}


def strict_json(path):
    """Parse like a strict JSON reader: NaN and Infinity are not JSON."""

    def reject(token):
        raise AssertionError(f"{token} in {path} is not valid JSON")

    return json.loads(path.read_text(), parse_constant=reject)


def write_cfg(tmp_path, cfg, name="cfg.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


def test_train_tiny_then_resume(tmp_path):
    out = tmp_path / "run"
    cfg = write_cfg(tmp_path, TINY)
    assert train.main(["--config", cfg, "--out", str(out), "--no-progress"]) == 0
    meta = strict_json(out / "checkpoints" / "last.json")
    assert meta["timesteps"] >= 2048 and meta["env_s"] > 0
    strict_json(out / "best_model.json")
    for f in (
        "best_model.zip",
        "best_model_vecnormalize.pkl",
        "best_model.json",
        "final_model.zip",
        "config.yaml",
        "evaluations.csv",
    ):
        assert (out / f).exists(), f
    rows = list(csv.DictReader(open(out / "evaluations.csv")))
    assert int(rows[0]["timesteps"]) == 0 and len(rows) >= 3
    # a fresh start into the same directory is refused, a resume continues
    with pytest.raises(SystemExit, match="already has a checkpoint"):
        train.main(["--config", cfg, "--out", str(out), "--no-progress"])
    assert (
        train.main(
            ["--config", cfg, "--out", str(out), "--timesteps", "4096", "--resume", "--no-progress"]
        )
        == 0
    )
    meta2 = json.loads((out / "checkpoints" / "last.json").read_text())
    assert meta2["timesteps"] >= 4096
    assert len(meta2["evaluations"]) > len(meta["evaluations"])
    assert meta2["wall_s"] > meta["wall_s"]


def test_terrain_yaml_sets_its_ground_and_trains(tmp_path):
    """The env section is the task's config class (TerrainEnvConfig here): steeper,
    rougher ground than the default trains, and the run records what it trained on."""
    cfg = {
        **TINY,
        "env_id": "HopRoverTerrain-v0",
        "pretrain": None,
        "env": {**TINY["env"], "slope_range": [-0.3, 0.3], "roughness": 0.1},
    }
    out = tmp_path / "run"
    assert (
        train.main(
            [
                "--config",
                write_cfg(tmp_path, cfg),
                "--out",
                str(out),
                "--timesteps",
                "1024",
                "--no-progress",
            ]
        )
        == 0
    )
    saved = yaml.safe_load((out / "config.yaml").read_text())
    assert saved["env_id"] == "HopRoverTerrain-v0"
    assert saved["env"]["slope_range"] == [-0.3, 0.3] and saved["env"]["roughness"] == 0.1
    from hoprover_env import vector_env_class
    from hoprover_env.training.sb3_agents import env_kwargs

    venv = vector_env_class(saved["env_id"])(4, **env_kwargs(saved))
    assert venv.config.slope_range == (-0.3, 0.3) and venv.config.roughness == 0.1


@pytest.mark.parametrize(
    "env_id, bad, words",
    [
        ("HopRoverTerrain-v0", {"slope_range": [0.3, -0.3]}, "slope_range must be (low, high)"),
        ("HopRover-v0", {"roughness": 0.1}, "env.roughness"),  # not a key of EnvConfig
        ("HopRoverHop-v0", {"slope_range": [0, 0.1]}, "env.slope_range"),
    ],
)
def test_env_keys_are_the_tasks(tmp_path, capsys, env_id, bad, words):
    cfg = {**TINY, "env_id": env_id, "pretrain": None, "env": {**TINY["env"], **bad}}
    assert (
        train.main(
            ["--config", write_cfg(tmp_path, cfg), "--out", str(tmp_path / "r"), "--no-progress"]
        )
        == 2
    )
    assert words in capsys.readouterr().err


def test_train_interrupted_saves_a_checkpoint(tmp_path, monkeypatch):
    out = tmp_path / "run"
    cfg = write_cfg(tmp_path, {**TINY, "pretrain": None})
    calls = {"n": 0}
    orig = train.Trainer.evaluate

    def evaluate_then_interrupt(self):
        orig(self)
        calls["n"] += 1
        if calls["n"] == 2:  # the first evaluation during learning
            raise KeyboardInterrupt

    monkeypatch.setattr(train.Trainer, "evaluate", evaluate_then_interrupt)
    assert train.main(["--config", cfg, "--out", str(out), "--no-progress"]) == 130
    meta = json.loads((out / "checkpoints" / "last.json").read_text())
    # interrupted on the last step of the second rollout (4 envs x 128 steps each), before
    # PPO trained on it: the checkpoint counts only the first, trained rollout
    assert meta["timesteps"] == 512
    monkeypatch.setattr(train.Trainer, "evaluate", orig)
    assert train.main(["--config", cfg, "--out", str(out), "--resume", "--no-progress"]) == 0
    assert json.loads((out / "checkpoints" / "last.json").read_text())["timesteps"] >= 2048


@pytest.mark.parametrize(
    "bad, words",
    [
        ({"hyperparams": {"n_stepz": 8}}, "hyperparams.n_stepz"),
        ({"env": {"contol_dt": 0.1}}, "env.contol_dt"),
        ({"polcy": {}}, "unknown config key 'polcy'"),
        ({"algo": "dqn"}, "algo must be one of"),
        ({"pretrain": {"expert": "scripted", "epochz": 3}}, "pretrain.epochz"),
        ({"env": {"control_dt": -1}}, "control_dt must be a positive finite number"),
        # the shaping's discount is not the learner's: a bonus for staying away
        (
            {"env": {"gamma": 0.995}, "hyperparams": {"gamma": 0.99}},
            "'env.gamma' (0.995) and 'hyperparams.gamma' (0.99) differ",
        ),
        ({"env": {"gamma": 0.995}}, "'env.gamma' (0.995) and 'hyperparams.gamma' (0.99) differ"),
    ],
)
def test_bad_config_keys_are_named(tmp_path, capsys, bad, words):
    cfg = write_cfg(tmp_path, {**TINY, **bad})
    assert train.main(["--config", cfg, "--out", str(tmp_path / "r"), "--no-progress"]) == 2
    assert words in capsys.readouterr().err


def test_torch_threads_flag(tmp_path, capsys):
    """--torch-threads sets torch's threads for the run (default: torch's own); a count
    below 1 is refused by name before anything starts."""
    with pytest.raises(SystemExit):
        train.main(["--config", "ppo_hop", "--out", str(tmp_path / "r"), "--torch-threads", "0"])
    assert "--torch-threads must be a positive integer, got 0" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    try:
        cfg = write_cfg(tmp_path, TINY)
        assert (
            train.main(
                [
                    "--config",
                    cfg,
                    "--out",
                    str(tmp_path / "t"),
                    "--no-progress",
                    "--torch-threads",
                    "1",
                ]
            )
            == 0
        )
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


def test_missing_config_file(tmp_path, capsys):
    assert train.main(["--config", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "r")]) == 2
    assert "config file not found" in capsys.readouterr().err


def test_killed_run_resumes_from_its_wall_clock_checkpoint(tmp_path, capsys):
    """kill -9 gives no chance to save: what survives is the last checkpoint, taken here
    by the wall clock (checkpoint.seconds) long before checkpoint.freq steps."""
    out = tmp_path / "run"
    never = 10_000_000
    cfg = write_cfg(
        tmp_path,
        {
            **TINY,
            "pretrain": None,
            "timesteps": never,
            "evaluation": {"freq": never, "episodes": 2, "seed": 1},
            "checkpoint": {"freq": never},
        },
    )
    root = Path(__file__).resolve().parents[2]  # the checkout: train.py
    proc = subprocess.Popen(
        [
            sys.executable,
            str(root / "train.py"),
            "--config",
            cfg,
            "--out",
            str(out),
            "--no-progress",
            "--checkpoint-seconds",
            "1",
        ],
        cwd=root,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    meta_path = out / "checkpoints" / "last.json"
    try:
        deadline = time.monotonic() + 300
        while not (meta_path.exists() and json.loads(meta_path.read_text())["timesteps"] > 0):
            assert proc.poll() is None, "train.py ended before its first timed checkpoint"
            assert time.monotonic() < deadline, "no timed checkpoint within 300 s"
            time.sleep(0.2)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    saved = json.loads(meta_path.read_text())["timesteps"]  # checkpoints are atomic
    assert 0 < saved < never
    capsys.readouterr()
    assert (
        train.main(
            [
                "--config",
                cfg,
                "--out",
                str(out),
                "--timesteps",
                str(saved + 512),
                "--resume",
                "--no-progress",
            ]
        )
        == 0
    )
    assert f"at {saved} steps" in capsys.readouterr().err
    assert strict_json(meta_path)["timesteps"] >= saved + 512


def test_resume_without_checkpoint(tmp_path):
    cfg = write_cfg(tmp_path, TINY)
    with pytest.raises(SystemExit, match="nothing to resume"):
        train.main(["--config", cfg, "--out", str(tmp_path / "none"), "--resume"])


def test_interrupt_during_cloning_is_reported(tmp_path, monkeypatch, capsys):
    def interrupt(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(train.Trainer, "_pretrain", interrupt)
    out, cfg = tmp_path / "run", write_cfg(tmp_path, {**TINY, "timesteps": 512})
    assert train.main(["--config", cfg, "--out", str(out), "--no-progress"]) == 130
    assert "interrupted before RL training began" in capsys.readouterr().err
    monkeypatch.undo()  # the same command starts the run over
    assert train.main(["--config", cfg, "--out", str(out), "--no-progress"]) == 0
    assert strict_json(out / "checkpoints" / "last.json")["timesteps"] >= 512


def test_a_restarted_pretraining_reuses_its_collections(tmp_path, monkeypatch, capsys):
    # collecting from the expert is the slow part of cloning: a run interrupted during its
    # pretraining starts again from the collections it kept, unless its settings changed
    from hoprover_env.training import warm_start as imitation

    cfg = {
        **TINY,
        "timesteps": 512,
        "pretrain": {
            "episodes": 4,
            "epochs": 1,
            "value_epochs": 0,
            "dagger_rounds": 1,
            "dagger_episodes": 2,
        },
    }
    out = tmp_path / "run"
    real_clone, real_collect, calls = imitation.clone, imitation.collect, []

    def clone_then_stop(*args, **kwargs):
        real_clone(*args, **kwargs)
        if len(calls) == 2:  # the DAgger round's fit: stop there
            raise KeyboardInterrupt

    monkeypatch.setattr(imitation, "clone", clone_then_stop)
    monkeypatch.setattr(
        imitation, "collect", lambda *a, **k: calls.append(k) or real_collect(*a, **k)
    )
    path = write_cfg(tmp_path, cfg)
    assert train.main(["--config", path, "--out", str(out), "--no-progress"]) == 130
    assert len(calls) == 2
    kept = {f.name for f in (out / "pretrain").glob("*.npz")}
    assert kept == {"demonstrations.npz", "dagger_1.npz"}
    monkeypatch.setattr(imitation, "clone", real_clone)
    assert train.main(["--config", path, "--out", str(out), "--no-progress"]) == 0
    assert len(calls) == 2  # nothing collected again
    assert capsys.readouterr().err.count("reusing") == 2
    # other settings: collected again (a DAgger round depends on everything before it)
    other = tmp_path / "other"
    cfg["pretrain"]["epochs"] = 2
    cfg_path = write_cfg(tmp_path, cfg, "other.yaml")
    (other / "pretrain").mkdir(parents=True)
    for f in (out / "pretrain").iterdir():
        (other / "pretrain" / f.name).write_bytes(f.read_bytes())
    assert train.main(["--config", cfg_path, "--out", str(other), "--no-progress"]) == 0
    assert len(calls) == 3  # the demonstrations kept, the round again
    with np.load(other / "pretrain" / "demonstrations.npz") as f:
        assert len(f["obs"]) > 0
    # another discount: the stored returns were discounted with the old one
    cfg["hyperparams"] = {**cfg.get("hyperparams", {}), "gamma": 0.9}
    cfg["env"] = {**cfg.get("env", {}), "gamma": 0.9}
    cfg_path = write_cfg(tmp_path, cfg, "gamma.yaml")
    third = tmp_path / "third"
    (third / "pretrain").mkdir(parents=True)
    for f in (other / "pretrain").iterdir():
        (third / "pretrain" / f.name).write_bytes(f.read_bytes())
    assert train.main(["--config", cfg_path, "--out", str(third), "--no-progress"]) == 0
    assert len(calls) == 5  # demonstrations and the round again


@pytest.mark.parametrize("algo", ["sac", "td3", "tqc"])
def test_off_policy_configs_train_and_resume(tmp_path, algo):
    cfg = yaml.safe_load(open(f"configs/{algo}.yaml"))
    cfg.update(
        {
            "n_envs": 2,
            "timesteps": 300,
            "evaluation": {"freq": 200, "episodes": 2, "seed": 1},
            "checkpoint": {"freq": 100},
        }
    )
    cfg["env"] = {**cfg.get("env", {}), "episode_time": 30.0, "control_dt": 1.0}
    cfg["hyperparams"].update({"learning_starts": 50, "buffer_size": 1000, "batch_size": 32})
    out = tmp_path / algo
    path = write_cfg(tmp_path, cfg)
    assert train.main(["--config", path, "--out", str(out), "--no-progress"]) == 0
    assert (out / "checkpoints" / "last_replay_buffer.pkl").exists()
    assert (
        train.main(
            ["--config", path, "--out", str(out), "--timesteps", "500", "--resume", "--no-progress"]
        )
        == 0
    )
    meta = json.loads((out / "checkpoints" / "last.json").read_text())
    assert meta["algo"] == algo and meta["timesteps"] >= 500
    # evaluate.py loads it back (the algorithm is read from the metadata)
    assert evaluate.main(["--policy", str(out), "--episodes", "2", "--no-progress"]) == 0


def test_init_from_starts_a_fresh_run_from_a_models_weights_and_statistics(tmp_path):
    """`init_from`: the model's weights (exploration noise included) and VecNormalize
    statistics, with this config's hyperparameters (here a falling learning rate), which
    --resume cannot change (SB3 restores them from the .zip)."""
    import pickle

    import torch
    from stable_baselines3 import PPO

    base = {**TINY, "pretrain": None}
    first = tmp_path / "first"
    assert (
        train.main(
            [
                "--config",
                write_cfg(tmp_path, base),
                "--out",
                str(first),
                "--timesteps",
                "1024",
                "--no-progress",
            ]
        )
        == 0
    )
    cfg = {
        **base,
        "init_from": str(first),
        "hyperparams": {**base["hyperparams"], "learning_rate": 1e-4, "learning_rate_end": 1e-5},
    }
    from hoprover_env.training.sb3_agents import load_config

    trainer = train.Trainer(
        load_config(write_cfg(tmp_path, cfg, "fine.yaml")), tmp_path / "fine", False, "cpu", False
    )
    want = PPO.load(str(first / "best_model.zip"), device="cpu").policy.state_dict()
    got = trainer.model.policy.state_dict()
    assert want.keys() == got.keys()
    assert all(torch.equal(want[k], got[k]) for k in want)
    with open(first / "best_model_vecnormalize.pkl", "rb") as fh:
        stats = pickle.load(fh)
    np.testing.assert_array_equal(trainer.venv.obs_rms.mean, stats.obs_rms.mean)
    np.testing.assert_array_equal(trainer.venv.ret_rms.var, stats.ret_rms.var)
    assert trainer.model.lr_schedule(1.0) == pytest.approx(1e-4)
    assert trainer.model.lr_schedule(0.0) == pytest.approx(1e-5)
    # and it trains, recording where it started
    out = tmp_path / "fine_run"
    assert (
        train.main(
            [
                "--config",
                str(tmp_path / "fine.yaml"),
                "--out",
                str(out),
                "--timesteps",
                "1024",
                "--no-progress",
            ]
        )
        == 0
    )
    assert strict_json(out / "best_model.json")["init_from"] == str(first)


@pytest.mark.parametrize(
    "change, words",
    [
        ({"policy": {"net_arch": [8]}}, "does not fit this config's policy"),
        ({"init_from": "no/such/run"}, "model file not found"),
    ],
)
def test_init_from_errors_name_the_model(tmp_path, change, words):
    cfg = {**TINY, "pretrain": None, "init_from": "scratch", **change}
    with pytest.raises(SystemExit, match=words):
        train.main(
            ["--config", write_cfg(tmp_path, cfg), "--out", str(tmp_path / "r"), "--no-progress"]
        )


def test_init_from_and_pretrain_exclude_each_other(tmp_path, capsys):
    cfg = {**TINY, "init_from": "scratch"}
    assert (
        train.main(
            ["--config", write_cfg(tmp_path, cfg), "--out", str(tmp_path / "r"), "--no-progress"]
        )
        == 2
    )
    assert "'init_from' and 'pretrain'" in capsys.readouterr().err


def test_the_terrain_fine_tuning_config_starts_from_the_bundled_base_policy(tmp_path):
    import torch

    from hoprover_env.agents.policies import load_policy
    from hoprover_env.training.sb3_agents import load_config

    cfg = load_config("ppo_terrain_fine", {"n_envs": 16})
    assert cfg["init_from"] == "terrain_base" and cfg["env_id"] == "HopRoverTerrain-v0"
    trainer = train.Trainer(cfg, tmp_path / "fine", False, "cpu", False)
    want = load_policy("terrain_base").model.policy.state_dict()
    got = trainer.model.policy.state_dict()
    assert all(torch.equal(want[k], got[k]) for k in want)


def test_learning_rate_end_falls_from_the_algorithms_own_default(tmp_path):
    """Without `learning_rate` the schedule starts at the algorithm's default (TD3's is
    1e-3, PPO's 3e-4), not at one number for all."""
    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from hoprover_env.training.sb3_agents import load_config, make_agent

    for algo, start in (("ppo", 3e-4), ("td3", 1e-3)):
        cfg = load_config(None, {"algo": algo, "n_envs": 2})
        cfg["hyperparams"] = {"learning_rate_end": 1e-6}
        model = make_agent(cfg, HopRoverSB3VecEnv(2))
        assert model.lr_schedule(1.0) == pytest.approx(start)
        assert model.lr_schedule(0.0) == pytest.approx(1e-6)
