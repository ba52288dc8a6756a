"""The benchmark suite's quick mode runs end to end (its numbers are not asserted:
speed targets live in BENCHMARKS.md, not in timed unit tests)."""
import benchmarks.bench_core as bench_core
from benchmarks.__main__ import main


def test_benchmark_suite_quick(tmp_path):
    out = tmp_path / "BENCHMARKS.md"
    assert main(["--quick", "--out", str(out)]) == 0
    text = out.read_text()
    for title in ("Throughput and scaling", "Training cost"):
        assert f"## {title}" in text
    assert text.count("## ") >= 4
    assert list((tmp_path / "figures").glob("*.png"))


def test_bench_core_runs(capsys):
    bench_core.main(["--repeat", "1", "--t-end", "120", "--no-compile"])
    out = capsys.readouterr().out
    assert "event" in out and "euler dt=1e-4" in out and "open loop" in out
