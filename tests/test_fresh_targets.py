"""agents/fresh_targets.py: a policy against a reference on freshly drawn targets."""
import json
import math

import numpy as np

from agents import fresh_targets


def test_draw_is_seeded_in_range_and_puts_the_edge_set_beyond_the_band():
    a, b = fresh_targets.draw(7, 50, 20), fresh_targets.draw(7, 50, 20)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, fresh_targets.draw(8, 50, 20))
    assert np.all(np.abs(a[:50]) <= 1.0)
    edge = np.abs(a[50:])
    assert np.all((edge >= 0.1) & (edge <= 0.125))
    assert {-1.0, 1.0} <= set(np.sign(a[50:]))      # both sides (20 draws)


def test_summary_counts_misses_as_inf_and_leaves_the_band_out():
    targets = [0.05, 0.3, -0.5, 0.7, -0.9, 0.102]
    policy = [0.0, 13.0, 40.0, math.inf, math.inf, 30.0]
    reference = [0.0, 10.0, 40.0, 50.0, math.inf, 10.0]
    s = fresh_targets.summarise(targets, policy, reference, bound=1.30)
    assert s["scored"] == 5                          # 0.05 m starts in the band
    assert s["policy_success"] == 4 / 6 and s["reference_success"] == 5 / 6
    # ratios of the scored targets: 1.3 (not above), 1.0, inf (a miss), 1.0 (both miss), 3.0
    assert s["above_bound"] == 2
    assert [w["target"] for w in s["worst"]] == [0.7, 0.102]
    assert s["worst_ratio"] == math.inf and s["median_ratio"] == 1.3


def test_the_same_agent_as_its_own_reference_is_at_one(tmp_path, capsys):
    out = tmp_path / "fresh.json"
    assert fresh_targets.main(["--policy", "scripted", "--seed", "3", "--n", "6",
                               "--edge", "2", "--out", str(out)]) == 0
    # the scripted hopper against mpc is a real comparison; against itself it must be 1
    saved = json.loads(out.read_text())
    targets, t = saved["targets"], saved["policy_ttrtp"]
    np.testing.assert_array_equal(targets, fresh_targets.draw(3, 6, 2))
    s = fresh_targets.summarise(targets, t, t)
    assert s["above_bound"] == 0 and s["worst_ratio"] == 1.0
    assert saved["reference"] == "mpc" and len(saved["targets"]) == 8
    assert saved["uniform"]["targets"] == 6 and saved["edge"]["targets"] == 2
    assert "uniform:" in capsys.readouterr().out


def test_a_missing_policy_file_is_a_clear_error(tmp_path, capsys):
    assert fresh_targets.main(["--policy", str(tmp_path / "none.pt"), "--seed", "1"]) == 2
    assert "none.pt" in capsys.readouterr().err
