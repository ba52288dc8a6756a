"""How long recycled units of an off-policy actor stay alive, against the actor's learning
rate (SAC, TQC): from a run's last checkpoint (model, replay buffer, observation
statistics), recycle the actor's tau-dormant hidden units as ReDo does
(hoprover_env/training/redo.py), then train on the checkpoint's replay buffer alone
with SB3's own update and count, every `--every` updates, the units of the last hidden
layer that are dormant again, over a fixed batch of the buffer's states. One row per
actor learning rate; the critics keep the config's rate.

    python -m research.offpolicy.unit_survival --run runs/x_sac_redo_s6 \\
        --actor-lr 1e-3 3e-4 1e-4 --updates 300 \\
        --out benchmarks/results/offpolicy/unit_survival_sac_s6.json

`--moments keep` leaves the recycled weights' Adam moments as they were (ReDo sets them
to zero), and `--no-recycle` recycles nothing and counts the layer as it is. No env is
stepped: the question is what the updates do to the units, not what the new data does.
Writes one JSON (atomically) and prints a line per learning rate.
"""

from __future__ import annotations

import argparse
import copy
import json
from pathlib import Path

import torch

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.training import redo
from hoprover_env.util.files import atomic_write


def load_run(run: Path):
    """The run's last checkpoint as its algorithm, with its replay buffer, and its config."""
    from hoprover_env.training.sb3_agents import algo_class, load_config
    from hoprover_env.training.train import build_env

    cfg = load_config(str(run / "config.yaml"))
    stem = run / "checkpoints" / "last"
    venv = build_env(cfg, Path(f"{stem}_vecnormalize.pkl"))
    model = algo_class(cfg["algo"]).load(f"{stem}.zip", env=venv, device="cpu")
    model.load_replay_buffer(f"{stem}_replay_buffer.pkl")
    return model, cfg


def _last_layer(model, obs: torch.Tensor, tau: float) -> torch.Tensor:
    return redo.dormant_units(model.actor, obs, tau)[-1]


def survival(
    base,
    actor_lr: float,
    seed: int,
    updates: int,
    every: int,
    tau: float,
    moments: str,
    recycle: bool,
) -> dict:
    """One learning rate's row (module docstring); `seed` draws the batches."""
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.utils import update_learning_rate

    model = copy.deepcopy(base)
    model.set_logger(configure(None, [""]))
    set_rates = model._update_learning_rate
    # a policy with actor_lr_scale multiplies whatever rate its actor is given at each step
    given = actor_lr / getattr(model.policy, "actor_lr_scale", 1.0)

    def actor_rate_too(optimizers):
        set_rates(optimizers)
        update_learning_rate(model.actor.optimizer, given)

    model._update_learning_rate = actor_rate_too
    torch.manual_seed(seed)
    probe = model.replay_buffer.sample(4096, env=model._vec_normalize_env).observations
    batch = model.replay_buffer.sample(1024, env=model._vec_normalize_env).observations
    masks = redo.dormant_units(model.actor, batch, tau)
    marked, recycled = masks[-1], [0] * len(masks)
    if recycle:
        reset = moments == "zero"
        recycled = redo.recycle(model.actor, model.actor.optimizer, batch, tau, reset)
    else:
        marked = torch.zeros_like(marked)
    rows = []
    for k in range(0, updates + 1, every):
        if k:
            model.train(gradient_steps=every, batch_size=model.batch_size)
        dormant, dead = _last_layer(model, probe, tau), _last_layer(model, probe, 0.0)
        rows.append(
            {
                "updates": k,
                "dormant": int(dormant.sum()),
                "never_active": int(dead.sum()),
                "recycled_dormant": int((dormant & marked).sum()),
                "recycled_never_active": int((dead & marked).sum()),
            }
        )
    return {"actor_lr": actor_lr, "seed": seed, "recycled": recycled, "rows": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, required=True, help="a train.py run directory")
    ap.add_argument("--actor-lr", type=float, nargs="+", required=True)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="the batches' seeds")
    ap.add_argument("--updates", type=int, default=300)
    ap.add_argument("--every", type=int, default=100, help="updates between counts")
    ap.add_argument("--tau", type=float, default=0.1, help="ReDo's dormancy threshold")
    ap.add_argument("--moments", choices=("zero", "keep"), default="zero")
    ap.add_argument("--no-recycle", action="store_true")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    base, cfg = load_run(args.run)
    recycle = not args.no_recycle
    rows = [
        survival(base, lr, seed, args.updates, args.every, args.tau, args.moments, recycle)
        for lr in args.actor_lr
        for seed in args.seeds
    ]
    out = {
        "run": str(args.run),
        "timesteps": int(base.num_timesteps),
        "critic_lr": cfg["hyperparams"].get("learning_rate"),
        "tau": args.tau,
        "moments": args.moments,
        "recycle": recycle,
        "rows": rows,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps(out, indent=1) + "\n")
    for r in rows:
        last = r["rows"][-1]
        print(
            f"actor lr {r['actor_lr']:g}, seed {r['seed']}: recycled {r['recycled'][-1]}, after "
            f"{last['updates']} updates {last['recycled_dormant']} of them dormant again "
            f"({last['recycled_never_active']} never active); layer {last['dormant']} dormant"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
