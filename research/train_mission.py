"""Train the hop policy of the mission task (hoprover_env/agents/mission_hop.py) with PPO.

    python -m research.train_mission --config configs/ppo_mission_hop.yaml --seed 0 --out runs/mh0
    python -m research.baselines --config configs/ppo_mission_hop.yaml --seeds 0-2 \\
        --out runs/baselines/ppo_mission_hop          # several seeds, scored on the suite

One environment step is one hop (`MissionHopEnv`: HopRoverMission-v0 under the estimator
and the scripted hopper's flight controller), so the budget `timesteps` counts hops.
The run directory gets what train.py writes, so research.baselines scores and plots it
alike: config.yaml, evaluations.csv (validation success every evaluation.freq hops, on
episodes the suite never uses), best_model.zip with its .json (what
`hoprover_env.agents.mission_hop.load_mission_policy` and `load_policy` read),
final_model.zip, and checkpoints/last.zip with progress.json, all written atomically.
--resume continues from the last checkpoint to the requested total.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from hoprover_env.agents.mission_hop import MissionHopEnv
from hoprover_env.util.buildinfo import git_commit
from hoprover_env.util.files import atomic_write, write_json

ENV_ID = "HopRoverMission-v0"
KEYS = {
    "trainer",
    "env_id",
    "env",
    "n_envs",
    "timesteps",
    "policy",
    "hyperparams",
    "evaluation",
    "seed",
}
VALIDATION_SEED = 1_000_000  # validation episode k is seeded with this + k
TRAIN_SEED = 10_000_000  # sub-env i of seed s starts from this + 1000 s + i


def load_config(path: str) -> dict:
    """The YAML config; ValueError names an unknown key."""
    cfg = yaml.safe_load(Path(path).read_text()) or {}
    unknown = set(cfg) - KEYS
    if unknown:
        raise ValueError(
            f"unknown config key(s) {sorted(unknown)} in {path}; valid: {sorted(KEYS)}"
        )
    if cfg.get("env_id", ENV_ID) != ENV_ID:
        raise ValueError(f"{path}: this trainer trains on {ENV_ID}, not {cfg['env_id']!r}")
    return cfg


def save(model, stem: Path, meta: dict) -> None:
    """The model and its metadata, each written atomically."""
    buf = io.BytesIO()
    model.save(buf)
    atomic_write(stem.with_suffix(".zip"), buf.getvalue())
    write_json(stem.with_suffix(".json"), meta)


def validate(model, env_kwargs: dict, episodes: int) -> tuple:
    """The deterministic policy on the validation episodes: (success rate, median and
    90th-percentile TTRTP of the successes [s], NaN without any)."""
    env = MissionHopEnv(**env_kwargs)
    wins = []
    for k in range(episodes):
        obs, _ = env.reset(seed=VALIDATION_SEED + k)
        done = False
        while not done:
            action = model.predict(obs, deterministic=True)[0]
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        if info.get("is_success"):
            wins.append(float(info["ttrtp"]))
    if not wins:
        return 0.0, math.nan, math.nan
    return len(wins) / episodes, float(np.median(wins)), float(np.percentile(wins, 90))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", required=True)
    ap.add_argument("--timesteps", type=int, default=None, help="hops (default: the config's)")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--no-progress", action="store_true", help="accepted for research.baselines")
    args = ap.parse_args(argv)
    try:
        cfg = load_config(args.config)
    except (OSError, ValueError) as err:
        ap.error(str(err))
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)
    out = Path(args.out)
    (out / "checkpoints").mkdir(parents=True, exist_ok=True)
    total = args.timesteps or int(cfg["timesteps"])
    env_kwargs = dict(cfg.get("env") or {})
    ev = cfg.get("evaluation", {})
    cfg = {**cfg, "seed": args.seed, "timesteps": total}  # as resolved for this run
    atomic_write(out / "config.yaml", yaml.safe_dump(cfg))
    venv = make_vec_env(
        MissionHopEnv,
        n_envs=int(cfg.get("n_envs", 8)),
        seed=TRAIN_SEED + 1000 * args.seed,
        env_kwargs=env_kwargs,
        monitor_kwargs={"info_keywords": ("is_success",)},
    )
    last = out / "checkpoints" / "last.zip"
    progress_path = out / "checkpoints" / "progress.json"
    if args.resume and last.exists():
        model = PPO.load(str(last), env=venv, device="cpu")
        progress = json.loads(progress_path.read_text())
        for row in progress["evals"]:  # strict JSON wrote NaN as null
            row.update({k: math.nan for k, v in row.items() if v is None})
        print(f"resuming at {model.num_timesteps} hops", file=sys.stderr)
    else:
        pol = dict(cfg.get("policy") or {})
        pol["activation_fn"] = getattr(
            torch.nn, {"tanh": "Tanh", "relu": "ReLU"}[pol.get("activation_fn", "tanh")]
        )
        model = PPO(
            "MlpPolicy",
            venv,
            seed=args.seed,
            device="cpu",
            policy_kwargs=pol,
            verbose=0,
            **(cfg.get("hyperparams") or {}),
        )
        progress = {"evals": [], "best": -1.0, "wall_s": 0.0}
    meta = {
        "algo": "ppo",
        "policy": "mission_hop",
        "env_id": ENV_ID,
        "env_kwargs": env_kwargs,
        "seed": args.seed,
        "config": cfg,
        "git_commit": git_commit(),
        "command": "python -m research.train_mission "
        + " ".join(sys.argv[1:] if argv is None else argv),
    }
    t0 = time.perf_counter()
    wall0 = progress["wall_s"]

    def evaluate():
        wall = wall0 + time.perf_counter() - t0
        rate, median, p90 = validate(model, env_kwargs, int(ev.get("episodes", 100)))
        row = {
            "timesteps": int(model.num_timesteps),
            "wall_s": round(wall, 1),
            "success_rate": rate,
            "median_ttrtp": median,
            "p90_ttrtp": p90,
        }
        progress["evals"].append(row)
        if rate > progress["best"]:
            progress["best"] = rate
            save(
                model,
                out / "best_model",
                {**meta, "timesteps": row["timesteps"], "wall_s": row["wall_s"], "evaluation": row},
            )
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(row))
        w.writeheader()
        w.writerows(progress["evals"])
        atomic_write(out / "evaluations.csv", buf.getvalue())
        progress["wall_s"] = wall
        save(model, last.with_suffix(""), meta)
        write_json(progress_path, progress)
        print(
            f"  eval @ {row['timesteps']:>8d} hops, {wall:6.0f} s: success {rate:.1%}",
            file=sys.stderr,
            flush=True,
        )

    class Every(BaseCallback):
        def _on_step(self):
            done = progress["evals"][-1]["timesteps"] if progress["evals"] else -1
            if self.num_timesteps - max(done, 0) >= int(ev.get("freq", 10_000)) or done < 0:
                evaluate()
            return True

    if model.num_timesteps < total:
        model.learn(
            total - model.num_timesteps,
            callback=Every(),
            reset_num_timesteps=not (args.resume and last.exists()),
        )
        if progress["evals"][-1]["timesteps"] != model.num_timesteps:
            evaluate()
    save(
        model,
        out / "final_model",
        {**meta, "timesteps": int(model.num_timesteps), "wall_s": progress["wall_s"]},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
