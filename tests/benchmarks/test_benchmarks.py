"""The benchmark suite's quick mode runs end to end (its numbers are not asserted:
speed targets live in BENCHMARKS.md, not in timed unit tests)."""

import math

import pytest

import benchmarks.bench_core as bench_core
import benchmarks.bench_oracle as bench_oracle
from benchmarks.__main__ import main

# the fast tier (pytest -m "not slow") leaves this file out:
# the benchmark suite's quick mode, end to end
pytestmark = pytest.mark.slow


def test_benchmark_suite_quick(tmp_path):
    out = tmp_path / "BENCHMARKS.md"
    assert main(["--quick", "--out", str(out)]) == 0
    text = out.read_text()
    for title in (
        "Throughput and scaling",
        "Training cost",
        "Optimal-control reference (best-known hop plans)",
        "Whole runs in the kernel: simulate, batches, cold start",
        "Threads: simulate_batch and the vector env on 1 to all cores",
    ):
        assert f"## {title}" in text
    assert text.count("## ") >= 4
    assert list((tmp_path / "figures").glob("*.png"))


def test_regenerating_one_section_keeps_every_other_line(tmp_path):
    """BENCHMARKS.md is the generator's alone: a run of one section rewrites that section
    and leaves every other heading and line of the file as it was."""
    from pathlib import Path

    original = (Path(__file__).resolve().parents[2] / "BENCHMARKS.md").read_text()
    out = tmp_path / "BENCHMARKS.md"
    out.write_text(original)
    assert main(["--quick", "--only", "scaling", "--out", str(out)]) == 0
    text = out.read_text()
    headings = [line for line in original.splitlines() if line.startswith("#")]
    assert headings and all(h in text.splitlines() for h in headings)
    kept = original.split("<!-- section: runs -->")[0]
    assert text.startswith(kept.split("\n", 3)[0])  # the title line
    for name in ("accuracy", "env", "stress", "training", "oracle", "learning", "runs"):
        block = original.split(f"<!-- section: {name} -->")[1].split(
            f"<!-- end of section: {name} -->"
        )[0]
        assert block in text, name  # not rerun: byte for byte
    assert "## Threads: simulate_batch and the vector env on 1 to all cores" in text


def test_bench_core_runs(capsys):
    bench_core.main(["--repeat", "1", "--t-end", "120", "--no-compile"])
    out = capsys.readouterr().out
    assert "event" in out and "euler dt=1e-4" in out and "open loop" in out


def test_bench_oracle_quick():
    sec = bench_oracle.run(quick=True)
    text = sec.markdown
    assert "not a proof of optimality" in text and "scripted regret" in text
    assert sec.headline["oracle_targets"] == 3
    # the contest target is reachable by one hop: the search must find a plan, and each
    # found TTRTP was re-simulated through simulate() inside the benchmark
    assert sec.headline["oracle_found"] == 3
    assert 5.0 <= sec.headline["oracle_contest_ttrtp"] < 600.0
    assert math.isfinite(sec.headline["regret_median_scripted"])


def test_cold_compare_times_a_checkout_cold_then_cached(capsys):
    # one round on this checkout, in one process: the cold run compiles, the second run
    # of the same cache loads; the summary line names the checkout and its ratio
    import os
    import re

    from benchmarks import cold_compare

    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    cold_compare.main([here, "--rounds", "1", "--one-process"])
    out = capsys.readouterr().out
    cold, cached = map(
        float, re.search(r"round 0: .*: cold ([0-9.]+) s, cached ([0-9.]+) s", out).groups()
    )
    assert cold > cached > 0.0
    assert f"{here}: cold" in out and "x base per round 1.000-1.000" in out


def test_cold_breakdown_counts_the_outermost_span_of_nested_locks():
    """numba's lock events nest (a compile inside a compile); held() counts each
    outermost span once: here 1-4 s and 10-10.5 s."""
    from numba.core import event as ev

    from benchmarks.cold_breakdown import held

    rec = ev.RecordingListener()
    start, end = ev.EventStatus.START, ev.EventStatus.END
    for ts, status in (
        (1.0, start),
        (2.0, start),
        (3.0, end),
        (4.0, end),
        (10.0, start),
        (10.5, end),
    ):
        rec.buffer.append((ts, ev.Event("numba:compiler_lock", status)))
    assert held(rec) == 3.5
