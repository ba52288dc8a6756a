"""What a new user hits -- CLI arguments, config errors, file modes, resume, pickling."""

import copy
import json
import os
import pickle
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hoprover_env.agents.policies import BUNDLED_DIR
from hoprover_env.training import evaluate
from hoprover_env.util.files import atomic_write, write_json

ROOT = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- evaluate.py arguments
def test_negative_first_target_is_accepted(capsys):
    assert evaluate.main(["--policy", "scripted", "--targets", "-0.5,0.3", "--no-progress"]) == 0
    assert "2 targets" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--targets="], "--targets must be comma-separated numbers, got ''"),
        (["--targets=nan"], "--targets must be finite"),
        (["--targets", "0.2,inf"], "--targets must be finite"),
        (["--target-range", "1", "-1"], "--target-range wants finite LOW < HIGH"),
        (["--control-dt", "0"], "--control-dt must be a finite number > 0"),
        (["--control-dt", "nan"], "--control-dt must be a finite number > 0"),
        (["--episodes", "0"], "--episodes must be at least 1"),
        (["--targets", "0.5", "--plot-episode", "3"], "--plot-episode 3 is not a target index"),
    ],
)
def test_bad_arguments_are_argparse_errors(argv, words, capsys, monkeypatch):
    # checked before any policy is loaded or episode run
    monkeypatch.setattr(evaluate, "run_episodes", lambda *a, **k: pytest.fail("evaluated"))
    assert evaluate.main(["--policy", "scripted", *argv]) == 2
    assert words in capsys.readouterr().err


def test_ctrl_c_exits_with_one_line(monkeypatch, capsys):
    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(evaluate, "run_episodes", interrupted)
    assert evaluate.main(["--policy", "scripted", "--targets", "0.5"]) == 130
    err = capsys.readouterr().err.strip()
    assert err == "interrupted"


def _fake_run(tmp_path, name):
    run = tmp_path / name
    run.mkdir()
    for suffix in (".zip", ".json", "_vecnormalize.pkl"):
        shutil.copy(BUNDLED_DIR / f"ppo_hop{suffix}", run / f"best_model{suffix}")
    return run


@pytest.mark.slow  # two training runs
def test_two_run_directories_get_two_rows(tmp_path, capsys):
    a, b = _fake_run(tmp_path, "runA"), _fake_run(tmp_path, "runB")
    out = tmp_path / "res.json"
    assert (
        evaluate.main(
            [
                "--policy",
                str(a),
                "--policy",
                str(b),
                "--targets",
                "0.5",
                "--json",
                str(out),
                "--no-progress",
            ]
        )
        == 0
    )
    table = capsys.readouterr().out
    assert "runA" in table and "runB" in table and "best_model" not in table
    res = json.loads(out.read_text())
    assert set(res["summary"]) == {"runA", "runB"}
    assert {e["policy"] for e in res["episodes"]} == {"runA", "runB"}


def test_evaluate_cli_errors_are_one_line(tmp_path):
    proc = subprocess.run(
        [sys.executable, "evaluate.py", "--targets=nan"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("evaluate.py: error: --targets")


# ---------------------------------------------------------------- file modes
@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_atomic_write_follows_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        atomic_write(tmp_path / "a.csv", "x\n")
        write_json(tmp_path / "b.json", {"a": 1})
        with open(tmp_path / "plain", "w") as fh:
            fh.write("x")
    finally:
        os.umask(old)
    want = stat.S_IMODE(os.stat(tmp_path / "plain").st_mode)
    assert want == 0o666 & ~mask
    for f in ("a.csv", "b.json"):
        assert stat.S_IMODE(os.stat(tmp_path / f).st_mode) == want, f
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]


# ---------------------------------------------------------------- env pickling, RoverSim
def test_env_deepcopy_and_pickle_after_render():
    pytest.importorskip("pygame")
    from hoprover_env.envs.env import HopRoverEnv

    env = HopRoverEnv(render_mode="rgb_array")
    env.reset(seed=3)
    env.step(np.array([0.0], dtype=np.float32))
    frame = env.render()
    assert env._renderer is not None
    for clone in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        assert clone._renderer is None
        np.testing.assert_array_equal(clone._s, env._s)
        again = clone.render()  # rebuilt lazily, same picture
        np.testing.assert_array_equal(again, frame)
        clone.close()
    env.close()


def test_advance_names_the_valid_event_kinds():
    from hoprover_env import core
    from hoprover_env.sim.simulate import RoverSim

    sim = RoverSim()
    with pytest.raises(ValueError, match="stop_on must be None or one of liftoff, slip"):
        sim.advance(3e-4, 1.0, stop_on="liftof")
    assert sim.t == 0.0
    sim.advance(3e-4, 10.0, stop_on="liftoff")  # a valid kind still works
    assert sim.t < 10.0 and "liftoff" in core.EVENT_NAMES


# ---------------------------------------------------------------- config validation
TINY_CFG = {
    "algo": "ppo",
    "n_envs": 4,
    "timesteps": 2048,
    "seed": 0,
    "env": {"control_dt": 1.0, "episode_time": 60.0, "target_range": [-0.3, 0.3]},
    "hyperparams": {"n_steps": 128, "batch_size": 256, "n_epochs": 2},
    "evaluation": {"freq": 1024, "episodes": 4, "seed": 1},
    "checkpoint": {"freq": 512},
}


@pytest.mark.parametrize(
    "section, key, value, expected",
    [
        ("hyperparams", "learning_rate", "abc", "a finite number > 0"),
        ("hyperparams", "learning_rate", "3e-4", "write 3.0e-4"),
        ("hyperparams", "batch_size", 64.5, "a positive integer"),
        ("hyperparams", "gamma", 1.5, "a number in (0, 1]"),
        ("hyperparams", "n_epochs", True, "a positive integer"),
        ("evaluation", "freq", "fifty", "a positive integer"),
        ("checkpoint", "freq", 0, "a positive integer"),
        ("checkpoint", "keep", "yes", "true or false"),
        ("policy", "net_arch", "big", "a list of positive layer sizes"),
        ("policy", "net_arch", [64, -1], "a list of positive layer sizes"),
        ("normalize", "obs", "yes please", "true or false"),
        ("pretrain", "epochs", 2.5, "a positive integer"),
    ],
)
def test_config_values_are_type_checked(tmp_path, section, key, value, expected):
    import yaml

    from hoprover_env.training.sb3_agents import ConfigError, load_config

    cfg = copy.deepcopy(TINY_CFG)
    cfg.setdefault(section, {})[key] = value
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    with pytest.raises(ConfigError) as exc:
        load_config(path)
    msg = str(exc.value)
    assert f"'{section}.{key}'" in msg and repr(value) in msg and expected in msg
    assert "\n" not in msg


def test_broken_yaml_and_env_id_are_one_line_errors(tmp_path):
    from hoprover_env.training.sb3_agents import ConfigError, load_config

    path = tmp_path / "c.yaml"
    path.write_text("algo: ppo\nhyperparams: {n_steps: 8\n")
    with pytest.raises(ConfigError, match=r"not valid YAML \(line \d+, column \d+\)"):
        load_config(path)
    path.write_text("algo: ppo\nenv_id: HopRover-v1\n")
    with pytest.raises(ConfigError, match="'env_id' must be one of"):
        load_config(path)


def test_train_cli_refuses_a_bad_value_before_any_work(tmp_path):
    import yaml

    cfg = copy.deepcopy(TINY_CFG)
    cfg["hyperparams"]["learning_rate"] = "abc"
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    proc = subprocess.run(
        [
            sys.executable,
            "train.py",
            "--config",
            str(path),
            "--out",
            str(tmp_path / "run"),
            "--no-progress",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "hyperparams.learning_rate" in proc.stderr.strip().splitlines()[-1]
    assert not (tmp_path / "run").exists()


# ---------------------------------------------------------------- train.py --resume
def _rows(run):
    import csv

    return list(csv.DictReader(open(run / "evaluations.csv")))


def _check_run_files(run):
    from hoprover_env.training.sb3_agents import load_config  # noqa: F401 - same import path as train

    rows = _rows(run)
    steps = [int(r["timesteps"]) for r in rows]
    assert steps == sorted(set(steps)), steps  # every evaluation exactly once
    meta = json.loads((run / "checkpoints" / "last.json").read_text())
    assert [e["timesteps"] for e in meta["evaluations"]] == steps  # last.json holds them all
    assert meta["timesteps"] == steps[-1]  # the final evaluation is in it
    return rows, meta


@pytest.mark.slow  # trains a tiny SAC
def test_checkpoint_keep_keeps_each_frequency_checkpoint_as_a_model(tmp_path):
    """With `checkpoint.keep`, each checkpoint due by `freq` is also kept as
    checkpoints/model_STEPS.* (no replay buffer), loadable as any model with its steps;
    last.* stays the one to resume from."""
    from helpers import TINY_SAC_V1, train_tiny
    from hoprover_env.agents.policies import _algo_class, load_sb3

    cfg = {**TINY_SAC_V1, "checkpoint": {"freq": 32, "keep": True, "seconds": 3600.0}}
    last = train_tiny(tmp_path, cfg)
    kept = sorted(p.name for p in last.parent.glob("model_*.zip"))
    assert kept == ["model_32.zip", "model_64.zip"]
    assert not list(last.parent.glob("model_*_replay_buffer.pkl"))
    assert (last.parent / "last_replay_buffer.pkl").exists()
    model = _algo_class("sac").load(last.parent / "model_32.zip", device="cpu")
    assert model.num_timesteps == 32
    policy = load_sb3(last.parent / "model_32.zip")
    assert policy.env_id == "HopRoverRL-v1" and policy.obs_rms is not None


@pytest.mark.slow  # trains, resumes, and trains uninterrupted
def test_resume_keeps_every_evaluation_once_and_matches_uninterrupted(tmp_path, monkeypatch):
    import yaml

    from hoprover_env.training import train

    cfg = dict(TINY_CFG)
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    whole, split = tmp_path / "whole", tmp_path / "split"
    assert (
        train.main(
            ["--config", str(path), "--out", str(whole), "--timesteps", "2048", "--no-progress"]
        )
        == 0
    )
    # interrupt during the rollout after the first in-learning evaluation
    calls = {"n": 0}
    orig = train.Trainer.evaluate

    def evaluate_then_interrupt(self):
        orig(self)
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(train.Trainer, "evaluate", evaluate_then_interrupt)
    assert (
        train.main(
            ["--config", str(path), "--out", str(split), "--timesteps", "2048", "--no-progress"]
        )
        == 130
    )
    monkeypatch.setattr(train.Trainer, "evaluate", orig)
    best_before = json.loads((split / "checkpoints" / "last.json").read_text())["best"]
    assert (
        train.main(["--config", str(path), "--out", str(split), "--resume", "--no-progress"]) == 0
    )
    rows_w, meta_w = _check_run_files(whole)
    rows_s, meta_s = _check_run_files(split)
    assert [r["timesteps"] for r in rows_s] == [r["timesteps"] for r in rows_w]
    assert tuple(meta_s["best"]) >= tuple(best_before)  # best only ever improves
    # then more steps: the old final evaluation stays, the new ones follow
    assert (
        train.main(
            [
                "--config",
                str(path),
                "--out",
                str(whole),
                "--resume",
                "--timesteps",
                "3072",
                "--no-progress",
            ]
        )
        == 0
    )
    rows_w2, meta_w2 = _check_run_files(whole)
    assert rows_w2[: len(rows_w)] == rows_w and int(rows_w2[-1]["timesteps"]) >= 3072
    assert tuple(meta_w2["best"]) >= tuple(meta_w["best"])


# ---------------------------------------------------------------- plots and overlay
def test_torque_overlay_text():
    from hoprover_env.envs.rendering import _torque_text

    assert _torque_text(-1e-9) == "0" and _torque_text(0.0) == "0"
    assert _torque_text(3e-4) == "+3.00e-4" and _torque_text(-2.5e-4) == "-2.50e-4"


def test_recording_of_a_success_has_its_ttrtp(tmp_path):
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.plots import nine_figures
    from hoprover_env.evaluation.replay import record_episode

    rec = record_episode(load_policy("scripted"), 0.5)
    assert rec.ttrtp is not None and rec.ttrtp > 0
    assert len(nine_figures(rec, tmp_path)) == 9


def test_recording_of_a_hop_level_policy_flies_its_hops():
    # the hop policy acts once per hop in HopRoverHop-v0; recorded in HopRover-v0 (as it
    # was) its actions became torques and the episode failed
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes
    from hoprover_env.evaluation.replay import record_episode

    policy = load_policy("hop")
    rec = record_episode(policy, 0.7)
    env_result = run_episodes(policy, [0.7])[0]
    assert env_result.success and rec.ttrtp == env_result.ttrtp
    # the dense replay (scripted hopper's launch/hold/settle with the policy's launch
    # torques) reaches the same verdict to integrator precision
    assert rec.rollout.ttrtp == pytest.approx(env_result.ttrtp, abs=1e-6)
    assert not rec.broken and (rec.rollout.state == "A").any()


# ---------------------------------------------------------------- the model is in the repository
def test_model_is_documented_in_the_repository():
    text = (ROOT / "docs" / "MODEL.md").read_text()
    for heading in (
        "Parameters",
        "Frame",
        "seven contact states",
        "Transitions",
        "Impacts",
        "judge",
        "Decision",
    ):
        assert heading in text, heading
    for state in "ABCDEFG":
        assert f"\n| {state} |" in text, state
    files = [
        ROOT / "README.md",
        ROOT / "docs" / "PHYSICS.md",
        *sorted((ROOT / "hoprover_env").glob("*.py")),
    ]
    for f in files:
        assert "shared/spec" not in f.read_text(), f
    assert "must come to rest" not in (ROOT / "README.md").read_text()


def test_readme_example_prints_a_ttrtp(tmp_path):
    text = (ROOT / "README.md").read_text()
    block = text.split("## Using it\n\n```python\n", 1)[1].split("```", 1)[0]
    script = tmp_path / "example.py"
    script.write_text(block)
    proc = subprocess.run(
        [sys.executable, str(script)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    ttrtp = float(lines[0].split()[1])
    assert 0 < ttrtp < 600 and "broken: False" in lines[0]
    assert f"TTRTP {ttrtp}" in proc.stdout  # the schedule replays the same run
    assert "last contact state (letters A-G): F" in proc.stdout


def test_contact_forces_at_a_control_instant_are_those_of_the_state_that_holds():
    """A tipping torque applied at rest (state F) switches the state at once: the forces
    sampled at t = 0 are the new state's, not F's with a pulling normal force."""
    from hoprover_env import simulate

    roll = simulate(np.full(20, 5e-4), t_end=10, control_dt=0.5, target_x=0.5)
    assert roll.state[0] == "F" and roll.state[1] != "F"
    forces = roll.contact_forces()
    assert forces[:, [1, 3]].min() >= 0.0
    assert forces[0, 3] == 0.0 and forces[0, 1] > 0.0  # all the load on corner A
    assert np.isclose(forces[0, 1], forces[1, 1], rtol=0.1)  # continuous with the next sample


def test_quick_train_shrinks_cloning_and_budget():
    from hoprover_env.training import train

    cfg = {
        "timesteps": 5_000_000,
        "evaluation": {"freq": 50_000, "episodes": 100, "seed": 7},
        "checkpoint": {"freq": 50_000},
        "pretrain": {
            "episodes": 300,
            "epochs": 25,
            "value_epochs": 5,
            "dagger_rounds": 4,
            "dagger_episodes": 200,
        },
    }
    q = train.smoke_config(cfg, timesteps_given=False)
    assert q["timesteps"] == 20_000 and q["evaluation"]["episodes"] == 10
    assert q["pretrain"]["episodes"] == 16 and q["pretrain"]["dagger_rounds"] == 1
    assert cfg["pretrain"]["episodes"] == 300  # the caller's config untouched
    assert train.smoke_config(cfg, timesteps_given=True)["timesteps"] == 5_000_000
