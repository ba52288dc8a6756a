"""A copy of a train.py run, from its last checkpoint (replay buffer, observation
statistics, evaluations and best model included), whose actor's pre-tanh mean is
penalised from then on (`policy.actor_mean_reg`, hoprover_env/training/actor_penalty.py).

    python -m research.offpolicy.fork_with_penalty --run runs/baselines/sac_torque/s6 \\
        --out runs/x_sac_s6_fork --actor-mean-reg 1e-3
    python train.py --config runs/x_sac_s6_fork/config.yaml --out runs/x_sac_s6_fork \\
        --resume --torch-threads 1 --no-progress

Resuming the run itself beside the fork (`python train.py --config RUN/config.yaml --out
RUN --resume`) is the control: both continue from the same weights and the same replay
buffer, and differ only in the penalty. The run is left untouched.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import yaml

from hoprover_env.training.sb3_agents import ConfigError, algo_class, load_config, policy_kwargs
from hoprover_env.util.files import atomic_write

# what a run directory holds besides its checkpoint and tensorboard logs
KEPT = ("evaluations.csv", "best_model.zip", "best_model.json", "best_model_vecnormalize.pkl")
CHECKPOINT = ("last.json", "last_vecnormalize.pkl", "last_replay_buffer.pkl")


def fork(run: Path, out: Path, weight: float) -> Path:
    """Write the fork into `out`; its config's path."""
    if (out / "checkpoints").exists():
        raise SystemExit(f"error: {out} already holds a run; choose another --out")
    if not (run / "checkpoints" / "last.zip").exists():
        raise SystemExit(f"error: {run} has no checkpoint (checkpoints/last.zip)")
    cfg = yaml.safe_load((run / "config.yaml").read_text())
    cfg["policy"] = {**cfg.get("policy", {}), "actor_mean_reg": weight}
    (out / "checkpoints").mkdir(parents=True)
    atomic_write(out / "config.yaml", yaml.safe_dump(cfg, sort_keys=False))
    try:
        cfg = load_config(out / "config.yaml")
    except ConfigError as exc:
        shutil.rmtree(out / "checkpoints")
        raise SystemExit(f"error: {exc}") from None
    from hoprover_env.training.actor_penalty import ACTOR_OPTION_POLICIES

    cls = algo_class(cfg["algo"])
    # the penalised policy class with the checkpoint's weights: SB3 rebuilds the policy
    # from the class and kwargs saved in the zip, which these replace
    policy_class = ACTOR_OPTION_POLICIES[
        (cfg["algo"], bool(cfg["policy"].get("critic_layer_norm")))
    ]
    model = cls.load(
        str(run / "checkpoints" / "last.zip"),
        device="cpu",
        custom_objects={"policy_class": policy_class, "policy_kwargs": policy_kwargs(cfg)},
    )
    model.save(str(out / "checkpoints" / "last.zip"))
    for name in CHECKPOINT:
        if (run / "checkpoints" / name).exists():
            shutil.copy2(run / "checkpoints" / name, out / "checkpoints" / name)
    for name in KEPT:
        if (run / name).exists():
            shutil.copy2(run / name, out / name)
    return out / "config.yaml"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, required=True, help="a train.py run directory")
    ap.add_argument("--out", type=Path, required=True, help="the fork's run directory")
    ap.add_argument("--actor-mean-reg", type=float, required=True, help="the penalty's weight")
    args = ap.parse_args(argv)
    config = fork(args.run, args.out, args.actor_mean_reg)
    print(
        f"forked {args.run} into {args.out}; continue it with: python train.py --config "
        f"{config} --out {args.out} --resume"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
