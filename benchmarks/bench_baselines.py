"""Baselines over seeds: every algorithm that learns from reward, scored on the frozen
suites with rliable's intervals over seeds, with its learning curves against environment
steps and against wall time.

This section trains nothing: it reads what `python -m research.baselines ... --record`
wrote into benchmarks/results/baselines/ (one `NAME.json` with the score matrix summary,
the per-seed rows and the command; `NAME.png`, the curves). One
table per suite and task, then each baseline's per-seed table and curves. Rerun a row
with the command printed under its table. The curves are linked where they were
recorded, relative to the repository root (where BENCHMARKS.md is).

    python -m benchmarks --only baselines
"""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.report import Section

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "baselines"


def run(quick: bool = False, fig_dir: str = "benchmarks/figures") -> Section:
    from research.baselines import seed_table
    from research.yardstick.leaderboard import baseline_tables

    names = sorted(p.stem for p in RESULTS.glob("*.json"))
    if not names:
        return Section(
            "Baselines over seeds",
            "None recorded yet: `python -m research.baselines "
            "--config CONFIG --seeds 0-4 --out runs/baselines/NAME --record`.",
        )
    md = [
        "Each row: one config trained from scratch with several seeds (`python -m "
        "research.baselines`), each seed's best model (chosen on train.py's validation "
        "targets, which the suites never share) playing its task's frozen suite. Success, "
        "median regret (TTRTP over the best-known reference's), mean and IQM normalised "
        "score, each with a 95 % stratified-bootstrap interval over seeds (rliable). "
        "docs/studies/baselines.md and docs/studies/off-policy.md read them.",
        baseline_tables(RESULTS),
    ]
    for name in names:
        res = json.loads((RESULTS / f"{name}.json").read_text())
        part = f"### {name}\n\n`{res.get('command', '?')}`\n\n{seed_table(res['runs'])}"
        if (RESULTS / f"{name}.png").exists():  # the recorded curves, linked where they are
            part += (
                f"\n\n![{name}: validation success against steps and wall time]"
                f"(benchmarks/results/baselines/{name}.png)"
            )
        md.append(part)
    return Section("Baselines over seeds", "\n\n".join(md))
