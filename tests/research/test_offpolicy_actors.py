"""research/offpolicy/actors.py: what a trained actor does per contact state. Its counts
must add up: every decision in one contact state, every break traced to the contact
state of the decision before it."""

import json

import pytest

from helpers import train_tiny
from research.offpolicy import actors


@pytest.mark.slow  # trains a tiny SAC, then plays whole episodes
def test_the_report_accounts_for_every_decision_and_every_break(tmp_path):
    model = train_tiny(tmp_path)
    report_path = tmp_path / "actors.json"
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
