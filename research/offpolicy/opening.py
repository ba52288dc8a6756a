"""A squashed-Gaussian actor's opening decision (SAC, TQC, CrossQ), model by model: at
rest, the contest's start, for a grid of targets, its pre-tanh mean mu, its action
tanh(mu), its standard deviation, the actor's hidden units that are active there, and
the action its critic values most.

    python -m research.offpolicy.opening --models runs/sac/checkpoints/model_*.zip \\
        --out benchmarks/results/offpolicy/opening_sac.json

Kept checkpoints (train.py's `checkpoint.keep`) give an opening's history over a run.
An opening whose |mu| runs past about 10 is frozen: tanh's slope is 0 in float32 there,
so no critic gradient reaches it (hoprover_env/training/actor_penalty.py). Per model:
the median and largest |mu| over the targets, the actions' range, their correlation with
the target (aiming), and the critic's argmax over ACTIONS per target. Writes one JSON
(atomically) and prints a line per model.

Active units: per hidden layer of the actor, how many units have a positive
pre-activation at each target's start. For a ReLU actor these are the only paths from the
observation to mu: with none active in the last hidden layer, mu at rest is the output
layer's bias, the same for every target and moved by the gradient of every state the
actor is trained on. The critic's slope dQ/da at the actor's own action says where the
critic would move it.
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
from hoprover_env.training.redo import hidden_activations
from hoprover_env.util.files import atomic_write
from research.offpolicy.actors import (
    critic_tensor,
    critic_value,
    env_arguments,
    gaussian_actor,
)

ACTIONS = np.linspace(-1.0, 1.0, 9)


def critic_values(model, obs: torch.Tensor) -> np.ndarray:
    """(len(ACTIONS), n): the critic's value of each action in each state."""
    return np.asarray(
        [critic_value(model, obs, torch.full((len(obs), 1), float(a))) for a in ACTIONS]
    )


def active_units(actor, obs: torch.Tensor) -> list[list[int]]:
    """Per hidden layer of the actor, per state: the units whose pre-activation is
    positive (module docstring; after the layer's LayerNorm where it has one)."""
    return [(h > 0).sum(dim=1).tolist() for h in hidden_activations(actor, obs)]


def critic_slope(model, obs: torch.Tensor, action: np.ndarray) -> np.ndarray:
    """Per state: d(critic value)/da at `action` (critic_value's minimum over twins, or
    TQC's mean over quantiles)."""
    a = torch.as_tensor(action[:, None], dtype=torch.float32).requires_grad_(True)
    (grad,) = torch.autograd.grad(critic_tensor(model, obs, a).sum(), a)
    return grad[:, 0].numpy()


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
    units = active_units(policy.model.actor, o)
    return {
        "model": str(path),
        "timesteps": int(policy.model.num_timesteps),
        "median_abs_mu": float(np.median(np.abs(mu))),
        "max_abs_mu": float(np.max(np.abs(mu))),
        "action_min": float(action.min()),
        "action_max": float(action.max()),
        # an opening that is the output bias alone differs between targets by float noise
        "corr_action_target": (
            float(np.corrcoef(action, targets)[0, 1]) if np.ptp(action) > 1e-6 else float("nan")
        ),
        "median_std": float(np.median(sd)),
        "critic_argmax": ACTIONS[q.argmax(0)].tolist(),
        "critic_range": np.ptp(q, axis=0).tolist(),
        "critic_slope": critic_slope(policy.model, o, action).tolist(),
        "active_units": units,
        "last_layer_active_max": int(max(units[-1])),
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
            f"{min(r['critic_argmax']):+.2f} to {max(r['critic_argmax']):+.2f}; last hidden "
            f"layer's active units at most {r['last_layer_active_max']}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
