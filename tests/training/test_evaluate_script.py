"""evaluate.py end to end, in-process (the kernels are already compiled): every kind of
policy and a contest controller, its errors, --workers, and the bundled policy it
loads. train.py's runs: test_scripts.py, whose tiny config and helpers these share."""

import csv
import json

import pytest
from test_scripts import TINY, strict_json, write_cfg

from hoprover_env.agents.policies import BUNDLED_DIR, BUNDLED_NAME
from hoprover_env.training import evaluate, train

# the fast tier (pytest -m "not slow") leaves this file out, as test_scripts.py
pytestmark = pytest.mark.slow


CONTROLLER = '''
import math
def Control(pos, vel, the, omg, posT, t, smt, state):
    """A contest entry: a short launch toward the target, then hold attitude."""
    if state == "A":
        th = (the + math.pi) % (2 * math.pi) - math.pi
        return -0.0017 * (0.15 * th + 0.9 * omg)
    return 3e-5 if (posT[0] > pos[0] and t < 40) else 0.0
'''


def test_evaluate_every_policy_kind(tmp_path, capsys):
    run = tmp_path / "run"
    assert (
        train.main(
            [
                "--config",
                write_cfg(tmp_path, {**TINY, "pretrain": None}),
                "--out",
                str(run),
                "--no-progress",
            ]
        )
        == 0
    )
    ctrl = tmp_path / "entry.py"
    ctrl.write_text(CONTROLLER)
    js, cs = tmp_path / "r.json", tmp_path / "r.csv"
    figs, vid = tmp_path / "figs", tmp_path / "v.gif"
    code = evaluate.main(
        [
            "--policy",
            "bundled",
            "--policy",
            "scripted",
            "--policy",
            "random",
            "--policy",
            str(run),
            "--controller",
            f"{ctrl}:Control",
            "--episodes",
            "3",
            "--json",
            str(js),
            "--csv",
            str(cs),
            "--plot",
            str(figs),
            "--video",
            str(vid),
            "--no-progress",
        ]
    )
    assert code == 0
    out = capsys.readouterr().out
    for name in ("bundled", "scripted", "random", "run", "entry:Control"):  # run dir names its row
        assert name in out
    data = strict_json(js)
    assert data["summary"]["random"]["success_rate"] == 0.0
    assert data["summary"]["random"]["median_ttrtp"] is None
    assert len(data["episodes"]) == 15 and set(data["summary"]) >= {"scripted", "random"}
    rows = list(csv.DictReader(open(cs)))
    assert len(rows) == 15 and {"target_x", "success", "ttrtp", "broken"} <= set(rows[0])
    assert len(list(figs.glob("*.png"))) == 9
    assert vid.stat().st_size > 10_000


def test_evaluate_errors(tmp_path, capsys):
    assert evaluate.main(["--policy", "nonsense", "--episodes", "1"]) == 2
    assert "unknown policy 'nonsense'" in capsys.readouterr().err
    assert evaluate.main(["--policy", str(tmp_path / "missing.zip"), "--episodes", "1"]) == 2
    assert "model file not found" in capsys.readouterr().err
    assert evaluate.main(["--policy", str(tmp_path / "no_such_run"), "--episodes", "1"]) == 2
    assert "not found" in capsys.readouterr().err
    assert evaluate.main(["--controller", str(tmp_path / "none.py") + ":Control"]) == 2
    assert "controller module not found" in capsys.readouterr().err
    assert evaluate.main(["--policy", "scripted", "--targets", "0.5,x"]) == 2
    assert "--targets must be comma-separated" in capsys.readouterr().err


def test_bundled_policy_is_shipped():
    assert (BUNDLED_DIR / f"{BUNDLED_NAME}.zip").exists()
    assert (BUNDLED_DIR / f"{BUNDLED_NAME}_vecnormalize.pkl").exists()
    meta = json.loads((BUNDLED_DIR / f"{BUNDLED_NAME}.json").read_text())
    assert meta["algo"] == "ppo" and "control_dt" in meta["env_kwargs"]


def test_evaluate_workers_flag(capsys):
    """--workers reaches run_episodes (mpc spreads its episodes over that many processes;
    other policies play in this one); a count below 1 is refused by name."""
    assert evaluate.main(["--policy", "random", "--episodes", "2", "--workers", "0"]) == 2
    assert "--workers must be at least 1, got 0" in capsys.readouterr().err
    assert (
        evaluate.main(["--policy", "random", "--episodes", "2", "--workers", "1", "--no-progress"])
        == 0
    )
