"""Normalised scores and their bootstrap intervals (hoprover_env/evaluation/scores.py)."""

import numpy as np
import pytest
from scipy import stats

from hoprover_env.evaluation.scores import (
    METRICS,
    Summary,
    episode_regrets,
    episode_scores,
    format_table,
    summarize,
)


def test_score_and_regret_per_episode():
    ref = np.array([100.0, 50.0, 80.0, 5.0])
    tt = [125.0, None, 40.0, np.nan]
    s = episode_scores(tt, ref)
    np.testing.assert_array_equal(s, [0.8, 0.0, 2.0, 0.0])
    g = episode_regrets(tt, ref)
    np.testing.assert_array_equal(g, [1.25, np.inf, 0.5, np.inf])


def test_bad_reference_is_refused():
    with pytest.raises(ValueError, match="reference"):
        episode_scores([1.0], [0.0])
    with pytest.raises(ValueError, match="reference"):
        episode_scores([1.0], [np.nan])


def test_point_estimates_match_their_definitions():
    rng = np.random.default_rng(3)
    s = rng.uniform(0.7, 1.0, 200)
    s[:10] = 0.0  # ten failures
    out = summarize("a", s, reps=200)
    assert out.point["success"] == pytest.approx(0.95)
    assert out.point["mean_score"] == pytest.approx(s.mean())
    assert out.point["iqm_score"] == pytest.approx(stats.trim_mean(s, 0.25))
    with np.errstate(divide="ignore"):
        regret = np.where(s > 0, 1 / np.where(s > 0, s, 1), np.inf)
        assert out.point["median_regret"] == pytest.approx(np.median(regret))
    for m in METRICS:
        assert out.low[m] <= out.point[m] <= out.high[m]
    # a real interval, narrower than the data's range
    assert 0 < out.high["iqm_score"] - out.low["iqm_score"] < 0.1


def test_intervals_shrink_with_more_seeds_and_are_reproducible():
    rng = np.random.default_rng(0)
    base = rng.uniform(0.8, 1.0, 100)
    two = np.array([base * rng.uniform(0.9, 1.0, 100) for _ in range(2)])
    ten = np.array([base * rng.uniform(0.9, 1.0, 100) for _ in range(10)])
    a, b = summarize("2", two, reps=500), summarize("10", ten, reps=500)
    assert a.runs == 2 and b.runs == 10 and a.episodes == 100
    assert (b.high["mean_score"] - b.low["mean_score"]) < (
        a.high["mean_score"] - a.low["mean_score"]
    )
    again = summarize("10", ten, reps=500)
    assert again.low == b.low and again.high == b.high


def test_table_and_bad_shape():
    s = summarize("agent x", np.full(20, 0.9), reps=100)
    table = format_table([s])
    assert "| agent x | 1 | 20 | 100.0 % [100.0, 100.0] | 1.111" in table
    with pytest.raises(ValueError, match="runs, episodes"):
        summarize("bad", np.zeros((2, 2, 2)))


def test_a_summary_read_back_from_its_row_is_the_same():
    """Results files keep `row()`; `from_row` rebuilds the summary, its table the same."""
    s = summarize("agent y", np.random.default_rng(1).uniform(0, 1, (3, 40)), reps=100)
    back = Summary.from_row(s.row())
    assert back == s and format_table([back]) == format_table([s])


def test_failures_make_the_median_regret_infinite_never_nan():
    """A failure's regret is infinite: a median regret that is a failure's, or a
    bootstrap bound that reaches one, is inf, not NaN."""
    s = np.zeros((3, 200))
    s[:, :50] = 0.5  # 75 % failures in every run
    out = summarize("mostly failing", s, reps=200)
    assert out.point["median_regret"] == np.inf
    assert out.low["median_regret"] == out.high["median_regret"] == np.inf
    mixed = np.full(200, 0.5)
    mixed[:100] = 0.0  # exactly half: the median straddles
    out = summarize("half", mixed, reps=500)
    assert out.low["median_regret"] == pytest.approx(2.0) and out.high["median_regret"] == np.inf
    for m in ("success", "median_regret", "mean_score", "iqm_score"):
        assert not np.isnan([out.point[m], out.low[m], out.high[m]]).any(), m
