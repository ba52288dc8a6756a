"""Shared pieces of the benchmark suite: a Section of the report, tables, machine info,
and the markers that delimit each generated section of BENCHMARKS.md."""

from __future__ import annotations

import dataclasses
import os
import platform
import re
import subprocess
import time


@dataclasses.dataclass
class Section:
    """One part of BENCHMARKS.md: markdown text (tables, notes), figure files written
    under the figure directory, and headline numbers (for whoever quotes the section)."""

    title: str
    markdown: str
    figures: list = dataclasses.field(default_factory=list)
    headline: dict = dataclasses.field(default_factory=dict)


def table(header: list[str], rows: list[list], fmt: dict | None = None) -> str:
    """A markdown table; `fmt` maps a column name to a format spec."""
    fmt = fmt or {}

    def cell(text) -> str:  # a '|' inside a cell (|d x|) would split it
        return str(text).replace("|", "\\|")

    out = [
        "| " + " | ".join(cell(h) for h in header) + " |",
        "|" + "|".join("---" for _ in header) + "|",
    ]
    for row in rows:
        cells = []
        for h, v in zip(header, row):
            if isinstance(v, float) and h in fmt:
                cells.append(format(v, fmt[h]))
            elif isinstance(v, float):
                cells.append(f"{v:.4g}")
            else:
                cells.append(str(v))
        out.append("| " + " | ".join(cell(c) for c in cells) + " |")
    return "\n".join(out)


def machine() -> str:
    import numba
    import numpy

    cpu = platform.processor() or "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:  # "-dirty": the run had uncommitted changes in the working tree
        rev = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=7"],
            capture_output=True,
            text=True,
            cwd=os.path.dirname(__file__),
        ).stdout.strip()
    except OSError:
        rev = "?"
    return (
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, git {rev or '?'}, "
        f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {numpy.__version__}, numba {numba.__version__}, numba threads "
        f"{numba.config.NUMBA_NUM_THREADS}"
    )


def best_of(fn, repeat: int = 3):
    """(best wall time, last result) of `repeat` calls."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


# ---- the generated sections of the report ------------------------------------------------
# Each section of BENCHMARKS.md sits between two markers naming it, so that a run of some
# sections (`python -m benchmarks --only env`) rewrites those and keeps the others.
SECTION_START = "<!-- section: {name} -->"
SECTION_END = "<!-- end of section: {name} -->"
_SECTION = re.compile(
    r"^<!-- section: ([A-Za-z0-9_-]+) -->\n(.*?)^<!-- end of section: \1 -->$", re.S | re.M
)


def read_sections(text: str) -> dict[str, str]:
    """The generated sections of a report, {name: text between its markers}, in file order."""
    return {m.group(1): m.group(2).strip("\n") for m in _SECTION.finditer(text)}


def section_block(name: str, body: str) -> str:
    """A section's text between its markers, as read back by `read_sections`."""
    body = body.strip("\n")
    return f"{SECTION_START.format(name=name)}\n{body}\n{SECTION_END.format(name=name)}\n"
