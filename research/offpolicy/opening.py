"""A squashed-Gaussian actor's opening decision (SAC, TQC, CrossQ), model by model: at
rest, the contest's start, for a grid of targets, its pre-tanh mean mu, its action
tanh(mu), its standard deviation, and the action its critic values most.

    python -m research.offpolicy.opening --models runs/sac/checkpoints/model_*.zip \\
        --out benchmarks/results/offpolicy/opening_sac.json

Kept checkpoints (train.py's `checkpoint.keep`) give an opening's history over a run.
An opening whose |mu| runs past about 10 is frozen: tanh's slope is 0 in float32 there,
so no critic gradient reaches it (hoprover_env/training/actor_penalty.py). Per model:
the median and largest |mu| over the targets, the actions' range, their correlation with
the target (aiming), and the critic's argmax over ACTIONS per target. Writes one JSON
(atomically) and prints a line per model.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.agents.policies import load_sb3
from hoprover_env.envs.registry import vector_env_class
from hoprover_env.util.files import atomic_write
from research.offpolicy.actors import critic_value, env_arguments, gaussian_actor

ACTIONS = np.linspace(-1.0, 1.0, 9)


def critic_values(model, obs: torch.Tensor) -> np.ndarray:
    """(len(ACTIONS), n): the critic's value of each action in each state."""
    return np.asarray(
        [critic_value(model, obs, torch.full((len(obs), 1), float(a))) for a in ACTIONS]
    )


def opening(path: Path, targets: np.ndarray) -> dict:
    policy = load_sb3(path)
    venv = vector_env_class(policy.env_id)(len(targets), **env_arguments(policy))
    obs, _ = venv.reset(seed=0, options={"target_x": targets})
    venv.close()
    gaussian = gaussian_actor(policy, obs)
    if gaussian is None:
        raise SystemExit(f"error: {path}: not a squashed-Gaussian actor (SAC, TQC, CrossQ)")
    mu, sd = gaussian
    action = np.tanh(mu)
    o = torch.as_tensor(policy.normalize(obs), dtype=torch.float32)
    q = critic_values(policy.model, o)
    return {
        "model": str(path),
        "timesteps": int(policy.model.num_timesteps),
        "median_abs_mu": float(np.median(np.abs(mu))),
        "max_abs_mu": float(np.max(np.abs(mu))),
        "action_min": float(action.min()),
        "action_max": float(action.max()),
        "corr_action_target": (
            float(np.corrcoef(action, targets)[0, 1]) if np.std(action) > 0 else float("nan")
        ),
        "median_std": float(np.median(sd)),
        "critic_argmax": ACTIONS[q.argmax(0)].tolist(),
        "critic_range": np.ptp(q, axis=0).tolist(),
        "targets": targets.tolist(),
        "mu": mu.tolist(),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=Path, nargs="+", required=True, help="SB3 .zip files")
    ap.add_argument("--targets", type=int, default=21, help="targets evenly in [-1, 1] m")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    targets = np.linspace(-1.0, 1.0, args.targets)
    rows = [opening(p, targets) for p in args.models]
    rows.sort(key=lambda r: r["timesteps"])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps(rows, indent=1) + "\n")
    for r in rows:
        print(
            f"{r['timesteps']:>8} steps: |mu| median {r['median_abs_mu']:.3g}, max "
            f"{r['max_abs_mu']:.3g}; a {r['action_min']:+.3f} to {r['action_max']:+.3f}, "
            f"corr with target {r['corr_action_target']:+.2f}; critic's argmax "
            f"{min(r['critic_argmax']):+.2f} to {max(r['critic_argmax']):+.2f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
