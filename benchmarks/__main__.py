"""Regenerate BENCHMARKS.md: `python -m benchmarks` (full, for the report) or
`python -m benchmarks --quick` (small sizes; the test suite runs it so the suite never
rots). Each section is one run on this machine; comparisons are ratios within it.

    python -m benchmarks [--quick] [--out BENCHMARKS.md] [--only env,accuracy,...]
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import tempfile
import time

from benchmarks.report import machine

SECTIONS = [("accuracy", "benchmarks.bench_accuracy"), ("env", "benchmarks.bench_env"),
            ("stress", "benchmarks.bench_stress"), ("training", "benchmarks.bench_training"),
            ("oracle", "benchmarks.bench_oracle"), ("learning", "benchmarks.bench_learning"),
            ("runs", "benchmarks.bench_runs"), ("terrain", "benchmarks.bench_terrain")]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="hoprover benchmark suite")
    ap.add_argument("--quick", action="store_true", help="small sizes (seconds, not minutes)")
    ap.add_argument("--out", default=None, help="report file (default BENCHMARKS.md, or a "
                    "temporary file with --quick)")
    ap.add_argument("--only", default=None, help="comma-separated sections: "
                    + ",".join(name for name, _ in SECTIONS))
    args = ap.parse_args(argv)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = args.out or (os.path.join(tempfile.mkdtemp(), "BENCHMARKS.md") if args.quick
                       else os.path.join(root, "BENCHMARKS.md"))
    fig_dir = os.path.join(os.path.dirname(os.path.abspath(out)), "benchmarks", "figures") \
        if not args.quick else os.path.join(os.path.dirname(out), "figures")
    if not args.quick and args.out is None:
        fig_dir = os.path.join(root, "benchmarks", "figures")
    os.makedirs(fig_dir, exist_ok=True)
    wanted = set(args.only.split(",")) if args.only else {n for n, _ in SECTIONS}
    unknown = wanted - {n for n, _ in SECTIONS}
    if unknown:
        ap.error(f"unknown section(s) {sorted(unknown)}")
    parts = [f"# hoprover benchmarks\n\n{'Quick run' if args.quick else 'Full run'}: "
             f"{machine()}.\nRegenerate with `python -m benchmarks`"
             f"{' --quick' if args.quick else ''}.\n"]
    for name, modname in SECTIONS:
        if name not in wanted:
            continue
        t0 = time.perf_counter()
        print(f"[benchmarks] {name} ...", file=sys.stderr, flush=True)
        section = importlib.import_module(modname).run(quick=args.quick, fig_dir=fig_dir)
        rel = os.path.relpath(fig_dir, os.path.dirname(os.path.abspath(out)))
        figs = "\n".join(f"![{os.path.basename(f)}]({rel}/{os.path.basename(f)})"
                         for f in section.figures)
        parts.append(f"## {section.title}\n\n{section.markdown}\n\n{figs}\n\n"
                     f"_Section time {time.perf_counter() - t0:.0f} s._\n")
        print(f"[benchmarks] {name} done in {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)
    text = "\n".join(parts)
    tmp = out + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(text)
    os.replace(tmp, out)
    print(f"[benchmarks] wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
