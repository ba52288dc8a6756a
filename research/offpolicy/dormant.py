"""Dormant units in an off-policy actor's hidden layers, model by model (SAC, TQC, CrossQ):
per layer, the units never active over a set of states, the tau-dormant ones of Sokar et
al. (2023, "The dormant neuron phenomenon in deep reinforcement learning": a unit whose
mean |activation| over the states is at most tau times the layer's mean), and how many
units a state has active, the median over all states and over the starts at rest.

    python -m research.offpolicy.dormant --models runs/sac/checkpoints/model_*.zip \\
        --out benchmarks/results/offpolicy/dormant_sac.json

The states: `--envs` episodes started as training starts them (the env's `flight_start`
share of them in flight) and as the contest does (at rest), each played `--steps`
decisions by the actor itself, deterministically. A ReLU actor whose last hidden layer
has few units left active expresses its action with those few and its output bias: where
none is active, as at the contest's start in every SAC actor measured on HopRoverRL-v1,
the action is that bias for every state (docs/studies/off-policy.md). Writes one JSON
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
from hoprover_env.tasks.config import TRAINING_STARTS
from hoprover_env.training.redo import dormant_mask, hidden_activations
from hoprover_env.util.files import atomic_write
from research.offpolicy.actors import env_arguments

TAU = 0.025  # Sokar et al.'s threshold for the actor and critic of their SAC runs


def states(policy, envs: int, steps: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(observations, whether each is an episode's start at rest): `envs` episodes started
    at rest and `envs` as training starts them, played `steps` decisions by the actor."""
    kw = env_arguments(policy)  # the contest's start: env_arguments drops TRAINING_STARTS
    starts = {k: v for k, v in policy.env_kwargs.items() if k in TRAINING_STARTS}
    training = {**kw, **starts}
    targets = np.random.default_rng(seed).uniform(-1.0, 1.0, envs)
    rows, at_start = [], []
    for arguments in (kw, training):
        venv = vector_env_class(policy.env_id)(envs, **arguments)
        obs, _ = venv.reset(seed=seed, options={"target_x": targets})
        policy.reset(envs)
        rows.append(obs)
        at_start.append(np.full(envs, arguments is kw))
        for _ in range(steps):
            obs, *_ = venv.step(np.asarray(policy.act(obs, venv), dtype=np.float32))
            rows.append(obs)
            at_start.append(np.zeros(envs, bool))
        venv.close()
    return np.concatenate(rows), np.concatenate(at_start)


def dormant(path: Path, envs: int, steps: int, seed: int) -> dict:
    policy = load_sb3(path)
    obs, at_start = states(policy, envs, steps, seed)
    o = torch.as_tensor(policy.normalize(obs), dtype=torch.float32)
    layers = []
    for h in hidden_activations(policy.model.actor, o):
        active = (h > 0).sum(dim=1).numpy()
        layers.append(
            {
                "units": int(h.shape[1]),
                "never_active": int(((h > 0).sum(dim=0) == 0).sum()),
                "dormant": int(dormant_mask(h, TAU).sum()),
                "median_active_per_state": float(np.median(active)),
                "median_active_at_start": float(np.median(active[at_start])),
            }
        )
    return {
        "model": str(path),
        "timesteps": int(policy.model.num_timesteps),
        "states": len(o),
        "tau": TAU,
        "layers": layers,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=Path, nargs="+", required=True, help="SB3 .zip files")
    ap.add_argument("--envs", type=int, default=128, help="episodes per start distribution")
    ap.add_argument("--steps", type=int, default=20, help="decisions played from each start")
    ap.add_argument("--seed", type=int, default=1, help="the targets' and starts' seed")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    rows = [dormant(p, args.envs, args.steps, args.seed) for p in args.models]
    rows.sort(key=lambda r: r["timesteps"])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps(rows, indent=1) + "\n")
    for r in rows:
        last = r["layers"][-1]
        print(
            f"{r['timesteps']:>8} steps: last hidden layer {last['dormant']}/{last['units']} "
            f"dormant, {last['never_active']} never active; active per state "
            f"{last['median_active_per_state']:.0f}, at the start at rest "
            f"{last['median_active_at_start']:.0f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
