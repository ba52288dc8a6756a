"""The mission hop trainer (research/train_mission.py) and the baselines driver running it
(research/baselines.py): a tiny run resumes, its model loads as the mission policy, a
broken config key is named. The hop env and the policy: tests/agents/test_mission_hop.py."""

import numpy as np
import pytest

from hoprover_env.agents.policies import ControllerPolicy
from hoprover_env.envs.registry import HopRoverMissionVectorEnv


def _tiny_config(tmp_path, **extra):
    from pathlib import Path

    import yaml

    config = Path(__file__).resolve().parents[2] / "configs" / "ppo_mission_hop.yaml"
    cfg = yaml.safe_load(open(config))
    cfg.update(n_envs=2, timesteps=32, evaluation={"freq": 16, "episodes": 2})
    cfg["hyperparams"].update(n_steps=16, batch_size=16, n_epochs=1)
    cfg.update(extra)
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


@pytest.mark.slow  # trains and resumes
def test_the_trainer_resumes_and_its_model_loads_as_the_mission_policy(tmp_path):
    import csv

    from hoprover_env.agents.policies import load_policy
    from research import train_mission

    cfg, out = _tiny_config(tmp_path), tmp_path / "run"
    assert train_mission.main(["--config", cfg, "--out", str(out)]) == 0
    first = list(csv.DictReader(open(out / "evaluations.csv")))
    assert int(first[-1]["timesteps"]) == 32
    assert (
        train_mission.main(["--config", cfg, "--out", str(out), "--resume", "--timesteps", "64"])
        == 0
    )
    rows = list(csv.DictReader(open(out / "evaluations.csv")))
    assert rows[: len(first)] == first and int(rows[-1]["timesteps"]) == 64
    policy = load_policy(str(out))
    assert isinstance(policy, ControllerPolicy) and policy.env_id == "HopRoverMission-v0"
    venv = HopRoverMissionVectorEnv(2, control_dt=0.5)
    policy.reset(2)
    obs, _ = venv.reset(seed=0)
    act = policy.act(obs, venv)
    assert act.shape == (2, 1) and np.all(np.isfinite(act))


def test_the_trainer_names_an_unknown_config_key(tmp_path, capsys):
    from research import train_mission

    with pytest.raises(SystemExit):
        train_mission.main(
            ["--config", _tiny_config(tmp_path, n_env=3), "--out", str(tmp_path / "run")]
        )
    assert "n_env" in capsys.readouterr().err


@pytest.mark.slow  # trains through the baselines driver
def test_baselines_run_a_config_through_the_trainer_it_names(tmp_path):
    import json

    from research import baselines

    out = tmp_path / "runs"
    out.mkdir()
    baselines.train(_tiny_config(tmp_path), [0], out, timesteps=16)
    assert (out / "s0" / "done").exists()
    assert json.loads((out / "s0" / "best_model.json").read_text())["policy"] == "mission_hop"
