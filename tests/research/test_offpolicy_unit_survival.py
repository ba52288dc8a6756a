"""research/offpolicy/unit_survival.py: from a run's last checkpoint it recycles the
actor's dormant units, trains on the replay buffer and counts them again; the counts are
consistent with one another, a seed gives the same counts twice, and without recycling
nothing is marked."""

import json

import pytest

from helpers import TINY_SAC_V1, train_run
from research.offpolicy import unit_survival


@pytest.mark.slow  # trains a tiny SAC
def test_counts_are_consistent_and_reproducible(tmp_path):
    run = train_run(tmp_path, {**TINY_SAC_V1, "timesteps": 96})
    outs = []
    for name, extra in (("a", []), ("b", []), ("c", ["--no-recycle"])):
        out = tmp_path / f"{name}.json"
        args = ["--run", str(run), "--actor-lr", "1e-3", "1e-5", "--updates", "4"]
        assert (
            unit_survival.main([*args, "--every", "2", "--tau", "0.5", "--out", str(out), *extra])
            == 0
        )
        outs.append(json.loads(out.read_text()))
    a, b, c = outs
    assert a == b and a["timesteps"] == 96 and a["critic_lr"] is None
    assert [r["actor_lr"] for r in a["rows"]] == [1e-3, 1e-5]
    for row in a["rows"]:
        assert [x["updates"] for x in row["rows"]] == [0, 2, 4]
        assert row["recycled"][-1] > 0  # tau 0.5 marks some of 16 units
        for x in row["rows"]:
            assert x["recycled_never_active"] <= x["recycled_dormant"] <= row["recycled"][-1]
            assert x["never_active"] <= x["dormant"] <= 16
            assert x["recycled_dormant"] <= x["dormant"]
    assert c["recycle"] is False
    for row in c["rows"]:
        assert row["recycled"] == [0, 0]
        assert all(x["recycled_dormant"] == 0 for x in row["rows"])
