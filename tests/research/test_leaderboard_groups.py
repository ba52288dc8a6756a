"""The leaderboard groups its agents by how they were made (research/yardstick/leaderboard.py):
every row of benchmarks/results/leaderboard.json carries one of four groups, read from
the bundled models' .json files, and an imitation names its hand-written parts."""

import json
from pathlib import Path

import pytest

from hoprover_env.agents.policies import BUNDLED, BUNDLED_DIR, BUNDLED_NETS

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results" / "leaderboard.json"
GROUPS = (
    "RL from reward",
    "Imitation of a planner",
    "Planners that use the simulator as their model",
    "References",
)
MODEL_FILES = {**BUNDLED, **BUNDLED_NETS}


@pytest.fixture(scope="module")
def results():
    return json.loads(RESULTS.read_text())["results"]


def model_meta(name: str) -> dict:
    return json.loads((BUNDLED_DIR / f"{MODEL_FILES[name]}.json").read_text())


def test_every_agent_on_the_leaderboard_has_one_of_the_four_groups(results):
    for suite, res in results.items():
        assert res["agents"], suite
        for agent, row in res["agents"].items():
            assert row.get("group") in GROUPS, (suite, agent, row.get("group"))
            assert row.get("how_made"), (suite, agent)


def test_plan_clone_names_its_hand_written_parts(results):
    for suite, res in results.items():
        row = res["agents"]["plan_clone"]
        assert row["group"] == "Imitation of a planner" and row["teacher"]
        parts = " ".join(row["hand_written"])
        for part in ("gate", "0.115 m", "0.01 rad", "zero torque", "mirror", "dead zone"):
            assert part in parts, (suite, part)


def test_every_bundled_model_says_its_group_and_the_rows_agree(results):
    for name in MODEL_FILES:
        meta = model_meta(name)
        assert meta.get("group") in GROUPS, name
        if meta["group"] == "Imitation of a planner":
            assert isinstance(meta["hand_written"], list) and meta["teacher"], name
    for res in results.values():
        for agent, row in res["agents"].items():
            if agent in MODEL_FILES:
                assert row["group"] == model_meta(agent)["group"], agent
    # `bundled` was cloned from the scripted hopper before its PPO fine-tuning
    assert model_meta("bundled")["group"] == "Imitation of a planner"
    assert model_meta("mission")["group"] == "RL from reward"


def test_the_page_has_one_heading_per_group_in_order():
    from research.yardstick.leaderboard import GROUPS as BUILDER

    assert tuple(BUILDER) == GROUPS
    page = (ROOT / "docs" / "leaderboard.md").read_text()
    at = [page.index(f"### {heading}\n") for heading, _ in BUILDER.values()]
    assert at == sorted(at)


def test_baselines_are_tabled_under_their_own_group(tmp_path):
    """A recorded baseline with demonstrations sits under "RL from reward and
    demonstrations", one without (or recorded before groups were) under RL from reward;
    each line names its command, and its commit and date when recorded."""
    from research.yardstick.leaderboard import DEMOS_GROUP, baseline_tables

    row = {"agent": "x", "runs": 3, "episodes": 200}
    for m in ("success", "median_regret", "mean_score", "iqm_score"):
        row.update({m: 0.5, m + "_low": 0.4, m + "_high": 0.6})

    def record(name, **extra):
        res = {
            "name": name,
            "suite": "level-v1",
            "env_id": "HopRoverRL-v1",
            "summary": {**row, "agent": name},
            "command": f"train {name}",
            **extra,
        }
        (tmp_path / f"{name}.json").write_text(json.dumps(res))

    record("old")
    record("plain", group="RL from reward", commit="abc1234", date="2026-11-28")
    record("demos", group=DEMOS_GROUP, commit="def5678", date="2026-11-28")
    rl = baseline_tables(tmp_path)
    demos = baseline_tables(tmp_path, group=DEMOS_GROUP)
    assert "`train old`" in rl and "`train plain` (commit abc1234, 2026-11-28)" in rl
    assert "demos" not in rl
    assert "`train demos` (commit def5678, 2026-11-28)" in demos
    assert "plain" not in demos and "old" not in demos
    assert baseline_tables(tmp_path, group="nobody") == ""
