"""One table of train.py runs: validation success and breaks at each evaluation, beside
the share of the training episodes that succeeded then (SB3's `rollout/success_rate`, the
last 100 episodes, read from the run's TensorBoard log).

    python -m research.offpolicy.exploration.summarize runs/probe/* \\
        --out benchmarks/results/offpolicy/exploration_probe.csv

A learner whose exploring episodes never succeed cannot learn what keeping still in the
band is worth; this puts that number beside what its deterministic actor reaches.
Writes one CSV (atomically) and prints it.
"""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from hoprover_env.util.files import atomic_write

FIELDS = ("run", "timesteps", "success_rate", "broken", "median_ttrtp", "train_success_rate")


def training_success(run: Path) -> list[tuple[int, float]]:
    """(step, rollout/success_rate) from every TensorBoard file of the run, by step."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    points = []
    for events in sorted(run.glob("tb/**/events.out.tfevents.*")):
        acc = EventAccumulator(str(events), size_guidance={"scalars": 0})
        acc.Reload()
        if "rollout/success_rate" in acc.Tags()["scalars"]:
            points += [(e.step, e.value) for e in acc.Scalars("rollout/success_rate")]
    return sorted(points)


def rows(run: Path) -> list[dict]:
    train = training_success(run)
    out = []
    with open(run / "evaluations.csv") as fh:
        for ev in csv.DictReader(fh):
            step = int(float(ev["timesteps"]))
            before = [v for s, v in train if s <= step]
            out.append(
                {
                    "run": run.name,
                    "timesteps": step,
                    "success_rate": ev["success_rate"],
                    "broken": ev["broken"],
                    "median_ttrtp": ev["median_ttrtp"],
                    # the last logged value at or before the evaluation
                    "train_success_rate": f"{before[-1]:.3f}" if before else "",
                }
            )
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="train.py run directories")
    ap.add_argument("--out", type=Path, default=None, help="CSV to write")
    args = ap.parse_args(argv)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, FIELDS)
    writer.writeheader()
    for run in sorted(r for r in args.runs if (r / "evaluations.csv").exists()):
        writer.writerows(rows(run))
    print(buf.getvalue(), end="")
    if args.out is not None:
        atomic_write(args.out, buf.getvalue())


if __name__ == "__main__":
    main()
