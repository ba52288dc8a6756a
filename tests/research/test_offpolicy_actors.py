"""research/offpolicy/actors.py: what a trained actor does per contact state. Its counts
must add up: every decision in one contact state, every break traced to the contact
state of the decision before it."""

import json

import pytest
import yaml

from helpers import TINY_SAC_V1
from hoprover_env.training import train
from research.offpolicy import actors


@pytest.mark.slow  # trains a tiny SAC, then plays whole episodes
def test_the_report_accounts_for_every_decision_and_every_break(tmp_path):
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(TINY_SAC_V1))
    out = tmp_path / "run"
    assert train.main(["--config", str(path), "--out", str(out), "--no-progress"]) == 0
    report_path = tmp_path / "actors.json"
    model = out / "checkpoints" / "last.zip"
    assert (
        actors.main(
            [
                "--model",
                str(model),
                "--episodes",
                "6",
                "--gap-states",
                "2",
                "--out",
                str(report_path),
            ]
        )
        == 0
    )
    report = json.loads(report_path.read_text())
    assert report["episodes"] == 6
    assert sum(report["broken_from"].values()) == report["broken"]
    assert report["broken"] + report["success"] <= 6
    states = report["per_state"]
    assert set(states) == {"rest", "contact", "flight"}
    assert sum(s["decisions"] for s in states.values()) > 0
    assert states["rest"]["decisions"] >= 6  # every episode starts at rest
    if states["flight"]["decisions"] > 2:
        assert 0.0 <= states["flight"]["p90_abs_theta_deg"] <= 180.0
