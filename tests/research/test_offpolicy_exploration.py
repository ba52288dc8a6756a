"""research/offpolicy/noise_at_rest.py and exploration/summarize.py: the measurements
behind "Exploration noise at rest" in docs/studies/off-policy/exploration.md."""

from __future__ import annotations

import csv
import json

import pytest

from research.offpolicy import noise_at_rest
from research.offpolicy.exploration import summarize


def test_without_noise_a_start_succeeds_exactly_when_it_begins_in_the_band(tmp_path):
    """Zero torque keeps a resting rover still: it never breaks, and it succeeds where
    its first decision already finds it in the band. Noise far above the tipping torque
    (the same starts, seeded) breaks some of them."""
    out = tmp_path / "noise.json"
    noise_at_rest.main(["--episodes", "12", "--stds", "0", "0.3", "--out", str(out)])
    quiet, loud = json.loads(out.read_text())["rows"]
    assert quiet["std"] == 0.0 and quiet["broken"] == 0.0
    assert quiet["success"] == quiet["in_band_after_first_decision"]
    assert loud["broken"] > 0.0


def test_each_validation_sits_beside_the_training_success_logged_before_it(tmp_path):
    """The training success next to an evaluation is the last value logged at or before
    its step, read from the run's TensorBoard log."""
    tb = pytest.importorskip("torch.utils.tensorboard")
    run = tmp_path / "run_a"
    (run / "tb" / "run_0").mkdir(parents=True)
    writer = tb.SummaryWriter(str(run / "tb" / "run_0"))
    for step, value in ((1000, 0.0), (20000, 0.25), (30000, 0.5)):
        writer.add_scalar("rollout/success_rate", value, step)
    writer.close()
    with open(run / "evaluations.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["timesteps", "wall_s", "success_rate", "median_ttrtp", "p90_ttrtp", "broken"])
        w.writerow([0, 1.0, 0.05, 5.0, 5.0, 3])
        w.writerow([25000, 9.0, 0.4, 120.0, 300.0, 0])
    out = tmp_path / "table.csv"
    summarize.main([str(run), "--out", str(out)])
    rows = list(csv.DictReader(open(out)))
    assert [r["run"] for r in rows] == ["run_a", "run_a"]
    assert rows[0]["train_success_rate"] == ""  # nothing logged before step 0
    assert float(rows[1]["train_success_rate"]) == 0.25  # 20 k, not 30 k
    assert rows[1]["success_rate"] == "0.4" and rows[1]["broken"] == "0"
