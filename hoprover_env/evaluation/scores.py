"""Normalised scores against the suites' best-known references, with intervals.

Per episode, with the episode's best-known TTRTP (hoprover_env/evaluation/suites.py):

==============  ===================================================================
``score``       ``reference_ttrtp / ttrtp``: 1 is as fast as the best-known plan,
                above 1 beats it, a failure scores 0
``regret``      ``ttrtp / reference_ttrtp``: 1 is as fast, inf for a failure
==============  ===================================================================

Per agent (`summarize`): the success rate, the median regret, and the mean and the
interquartile mean (IQM, the mean of the middle 50 %) of the score, each with a 95 %
stratified bootstrap interval computed by rliable (Agarwal et al., 2021,
"Deep RL at the edge of the statistical precipice"). The score matrix is (runs,
episodes): with several runs (training seeds) the bootstrap resamples runs within each
episode (rliable's stratified bootstrap); with one run it resamples the episodes.
rliable is the `scores` extra (``pip install 'hoprover[scores]'``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

METRICS = ("success", "median_regret", "mean_score", "iqm_score")
FAILED_REGRET = 1e12


def episode_scores(ttrtp, reference) -> np.ndarray:
    """reference / ttrtp per episode; 0 where ttrtp is NaN or None (a failure)."""
    t = np.array([np.nan if v is None else v for v in np.ravel(ttrtp)], dtype=float)
    ref = np.broadcast_to(np.asarray(reference, dtype=float), t.shape)
    if np.any(~np.isfinite(ref)) or np.any(ref <= 0):
        raise ValueError("reference TTRTPs must be finite and positive")
    return np.where(np.isfinite(t) & (t > 0), ref / np.where(t > 0, t, 1.0), 0.0)


def episode_regrets(ttrtp, reference) -> np.ndarray:
    """ttrtp / reference per episode; inf for a failure."""
    s = episode_scores(ttrtp, reference)
    with np.errstate(divide="ignore"):
        return np.where(s > 0, 1.0 / np.where(s > 0, s, 1.0), np.inf)


def _metrics(scores: np.ndarray) -> np.ndarray:
    """The four METRICS of a score matrix (any shape)."""
    from rliable import metrics

    s = np.asarray(scores, dtype=float)
    # a failure's regret is infinite; the bootstrap's percentiles interpolate between
    # resamples, and inf - inf is NaN, so failures count as FAILED_REGRET here and any
    # median that large is reported as inf (`_infinite`)
    regret = np.where(s > 0, 1.0 / np.where(s > 0, s, 1.0), FAILED_REGRET)
    return np.array(
        [
            np.mean(s > 0),
            np.median(regret),
            np.mean(s),
            metrics.aggregate_iqm(s.reshape(s.shape[0], -1)),
        ]
    )


def _infinite(values) -> np.ndarray:
    """Metrics with a median regret at or beyond a failure's made infinite."""
    v = np.array(values, dtype=float)
    v[1] = np.inf if v[1] >= FAILED_REGRET / 1e6 else v[1]
    return v


@dataclasses.dataclass
class Summary:
    """An agent's metrics: point estimates and 95 % bootstrap intervals (low, high)."""

    name: str
    runs: int
    episodes: int
    point: dict
    low: dict
    high: dict

    def row(self) -> dict:
        out = {"agent": self.name, "runs": self.runs, "episodes": self.episodes}
        for m in METRICS:
            out[m] = self.point[m]
            out[m + "_low"] = self.low[m]
            out[m + "_high"] = self.high[m]
        return out

    @classmethod
    def from_row(cls, row: dict) -> Summary:
        """The summary a `row()` was made from (read back from a results file)."""
        return cls(
            row["agent"],
            row["runs"],
            row["episodes"],
            {m: row[m] for m in METRICS},
            {m: row[m + "_low"] for m in METRICS},
            {m: row[m + "_high"] for m in METRICS},
        )


def summarize(name: str, scores, reps: int = 2000, seed: int = 0) -> Summary:
    """Metrics of one agent from its score matrix (runs, episodes) or vector (episodes,),
    with 95 % stratified bootstrap intervals (rliable, `reps` resamples, seeded)."""
    try:
        from rliable import library as rly
    except ImportError as err:  # pragma: no cover - the extra
        raise ImportError("score intervals need rliable: pip install 'hoprover[scores]'") from err
    s = np.asarray(scores, dtype=float)
    if s.ndim == 1:
        s = s[None]
    if s.ndim != 2 or s.size == 0:
        raise ValueError(f"scores must be (runs, episodes), got shape {s.shape}")
    # one run: the episodes are the samples (one stratum); several: runs within episodes
    matrix = s.T.reshape(-1, 1) if s.shape[0] == 1 else s
    point = dict(zip(METRICS, _infinite(_metrics(s))))
    # rliable 1.x draws its resamples from numpy's global generator (its random_state
    # argument reaches arch but not the stratified resampling), so the global generator
    # is seeded for the call and restored after it: the same seed gives the same interval
    saved = np.random.get_state()
    np.random.seed(seed)
    try:
        _, intervals = rly.get_interval_estimates({name: matrix}, _metrics, reps=reps)
    finally:
        np.random.set_state(saved)
    lo, hi = intervals[name]
    return Summary(
        name,
        s.shape[0],
        s.shape[1],
        point,
        dict(zip(METRICS, _infinite(lo))),
        dict(zip(METRICS, _infinite(hi))),
    )


def format_table(summaries: list[Summary]) -> str:
    """A markdown table: success, median regret, mean and IQM score with intervals."""

    def iv(s, m, fmt):
        p, lo, hi = s.point[m], s.low[m], s.high[m]
        if m == "success":
            return f"{100 * p:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]"
        return f"{p:{fmt}} [{lo:{fmt}}, {hi:{fmt}}]"

    lines = [
        "| agent | runs | episodes | success | median regret | mean score | IQM score |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in summaries:
        lines.append(
            f"| {s.name} | {s.runs} | {s.episodes} | {iv(s, 'success', '')} | "
            f"{iv(s, 'median_regret', '.3f')} | {iv(s, 'mean_score', '.3f')} | "
            f"{iv(s, 'iqm_score', '.3f')} |"
        )
    return "\n".join(lines)
