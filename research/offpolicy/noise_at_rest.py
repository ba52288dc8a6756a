"""What exploration noise alone does to a rover that starts at rest near its target.

    python -m research.offpolicy.noise_at_rest --episodes 200 \\
        --out benchmarks/results/offpolicy/noise_at_rest.json

Plays HopRoverRL-v1 episodes from its training option `near_start` (every episode upright
at rest within 0.5 m of the target) with zero-mean Gaussian actions of each standard
deviation in `--stds`: what an off-policy learner's exploration adds to an actor that has
learnt to keep still. On the linear action map a torque above |a| = 0.0098 tips a rover
at rest, and SB3's default exploration is 0.1 (TD3's action noise) or about 0.09 (SAC's
target entropy of -1 nats for one action).

Per standard deviation: the share of episodes that succeed, that break, and that are in
the band after their first decision (the starts that needed no move at all). The same
episodes (seeds 0 .. episodes - 1) for every standard deviation; the noise is drawn from
a generator of its own (`--seed`).

Writes one JSON (atomically) and prints a table.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import gymnasium as gym
import numpy as np

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.tasks.torque_rl import OBS_DWELL
from hoprover_env.util.files import atomic_write


def play(std: float, episodes: int, seed: int) -> dict:
    env = gym.make("HopRoverRL-v1", near_start=1.0)
    rng = np.random.default_rng(seed)
    success = broken = in_band = 0
    for ep in range(episodes):
        env.reset(seed=ep)
        first, done = True, False
        while not done:
            a = np.clip(rng.normal(0.0, std, 1), -1.0, 1.0) if std > 0 else np.zeros(1)
            obs, _, terminated, truncated, info = env.step(a.astype(np.float32))
            if first:
                in_band += bool(obs[OBS_DWELL] > 0)
                first = False
            done = terminated or truncated
        success += bool(info["is_success"])
        broken += bool(info["broken"])
    env.close()
    return {
        "std": std,
        "success": success / episodes,
        "broken": broken / episodes,
        "in_band_after_first_decision": in_band / episodes,
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument(
        "--stds", type=float, nargs="+", default=[0.0, 0.005, 0.01, 0.02, 0.05, 0.09, 0.3]
    )
    ap.add_argument("--seed", type=int, default=0, help="the noise generator's seed")
    ap.add_argument("--out", type=Path, default=None, help="JSON of the results")
    args = ap.parse_args(argv)
    rows = []
    print("std     success  broken  in band after the first decision")
    for std in args.stds:
        row = play(std, args.episodes, args.seed)
        rows.append(row)
        print(
            f"{std:<7g} {row['success']:>6.0%}  {row['broken']:>6.0%}  "
            f"{row['in_band_after_first_decision']:>6.0%}",
            flush=True,
        )
    if args.out is not None:
        result = {
            "env": "HopRoverRL-v1",
            "near_start": 1.0,
            "episodes": args.episodes,
            "noise_seed": args.seed,
            "rows": rows,
        }
        atomic_write(args.out, json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
