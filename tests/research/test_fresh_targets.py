"""research/yardstick/fresh_targets.py: a policy against a reference on freshly drawn targets."""

import json
import math

import numpy as np
import pytest

from research.yardstick import fresh_targets


def test_draw_is_seeded_in_range_and_puts_the_edge_set_beyond_the_band():
    a, b = fresh_targets.draw(7, 50, 20), fresh_targets.draw(7, 50, 20)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, fresh_targets.draw(8, 50, 20))
    assert np.all(np.abs(a[:50]) <= 1.0)
    edge = np.abs(a[50:])
    assert np.all((edge >= 0.1) & (edge <= 0.125))
    assert {-1.0, 1.0} <= set(np.sign(a[50:]))  # both sides (20 draws)


def test_summary_counts_misses_as_inf_and_a_rover_tipped_out_of_the_band():
    targets = [0.05, 0.3, -0.5, 0.7, -0.9, 0.102, -0.07]
    policy = [5.0, 13.0, 40.0, math.inf, math.inf, 30.0, 20.0]
    reference = [5.0, 10.0, 40.0, 50.0, math.inf, 10.0, 5.0]
    s = fresh_targets.summarise(targets, policy, reference, bound=1.30)
    assert s["in_band"] == 2  # 0.05 and -0.07 m start in the band
    assert s["policy_success"] == 5 / 7 and s["reference_success"] == 6 / 7
    # ratios: 1.0 (both stay still), 1.3 (not above), 1.0, inf (a miss), 1.0 (both
    # miss), 3.0, and 4.0 where the policy tipped the rover out of the band
    assert s["above_bound"] == 3
    assert [w["target"] for w in s["worst"]] == [0.7, -0.07, 0.102]
    assert s["worst_ratio"] == math.inf and s["median_ratio"] == 1.3


@pytest.mark.slow  # whole episodes of two agents
def test_the_same_agent_as_its_own_reference_is_at_one(tmp_path, capsys):
    out = tmp_path / "fresh.json"
    assert (
        fresh_targets.main(
            ["--policy", "scripted", "--seed", "3", "--n", "6", "--edge", "2", "--out", str(out)]
        )
        == 0
    )
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


def test_terrain_episodes_are_drawn_as_the_suites_are():
    from hoprover_env.evaluation import suites

    suite = suites.load("HopRoverTerrain-v0")
    same = fresh_targets.draw_terrain(suites.SUITE_SEEDS["terrain"], len(suite))
    np.testing.assert_array_equal(same["targets"], suite.targets)
    for key, column in suite.terrain().items():
        np.testing.assert_array_equal(same["terrain"][key], column)
    other = fresh_targets.draw_terrain(4242, 50)
    assert not np.isin(other["targets"], suite.targets).any()
    assert np.all(np.abs(other["terrain"]["slope"]) <= 0.2)


@pytest.mark.slow  # whole episodes of two agents
def test_terrain_task_flies_both_agents_on_each_episodes_ground(tmp_path, capsys):
    out = tmp_path / "fresh.json"
    assert (
        fresh_targets.main(
            [
                "--task",
                "terrain",
                "--policy",
                "terrain",
                "--seed",
                "5",
                "--n",
                "2",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    saved = json.loads(out.read_text())
    assert saved["task"] == "terrain" and "edge" not in saved
    np.testing.assert_array_equal(saved["targets"], fresh_targets.draw_terrain(5, 2)["targets"])
    assert saved["uniform"]["reference_success"] == 1.0
    # without the drawn grounds the task draws its own, and the times differ: the
    # episodes were flown on the grounds drawn
    from hoprover_env.agents.policies import load_policy

    level = fresh_targets.times(load_policy("terrain"), np.array(saved["targets"]))
    assert not np.array_equal(level, saved["policy_ttrtp"])
    with pytest.raises(SystemExit):  # edge targets are a level-ground set
        fresh_targets.main(
            ["--task", "terrain", "--policy", "terrain", "--seed", "5", "--edge", "3"]
        )
    assert "--edge is for level ground" in capsys.readouterr().err
