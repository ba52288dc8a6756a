"""Train an SB3 agent on the native batched HopRover environment.

    python train.py --algo ppo --config configs/ppo.yaml --env HopRover-v0 \\
        --timesteps 2000000 --seed 0 --n-envs 32 --out runs/ppo1
    python train.py --config configs/ppo.yaml --out runs/ppo1 --resume   # continue

The run directory gets: config.yaml (the resolved config), TensorBoard logs (tb/),
evaluations.csv (the contest judge on a fixed target set every evaluation.freq steps),
best_model.zip (+ _vecnormalize.pkl, .json), final_model.zip, and checkpoints/last.*
(model, VecNormalize statistics, the replay buffer of an off-policy learner: SAC, TD3,
TQC, CrossQ; progress), all written atomically. A checkpoint is taken every
checkpoint.freq steps and every checkpoint.seconds of wall time (default 300 s,
--checkpoint-seconds), so a killed run loses at most that. --resume continues from the
last checkpoint to the requested total; Ctrl-C saves a checkpoint before exiting.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

import yaml

from hoprover_env.agents.policies import SB3Policy
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.training.pretraining import Pretraining, _score
from hoprover_env.training.sb3_agents import (
    ALGOS,
    ConfigError,
    algo_class,
    env_kwargs,
    load_config,
    make_agent,
    pretrain_settings,
)
from hoprover_env.util.buildinfo import git_commit
from hoprover_env.util.files import atomic_write, write_json

EVAL_FIELDS = ["timesteps", "wall_s", "success_rate", "median_ttrtp", "p90_ttrtp", "broken"]


def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n", 2)[2],
    )
    ap.add_argument(
        "--algo",
        choices=ALGOS,
        default=None,
        help="the config's algo by default (tqc, crossq, recurrentppo: sb3-contrib)",
    )
    ap.add_argument(
        "--config",
        type=str,
        default=None,
        help="YAML config: a path, or a packaged config by name (ppo_hop)",
    )
    from hoprover_env.envs.registry import ENVS

    ap.add_argument(
        "--env",
        type=str,
        default=None,
        help=f"environment id: {', '.join(ENVS)} (default: the config's env_id)",
    )
    ap.add_argument("--timesteps", type=int, default=None, help="total environment steps")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--n-envs", type=int, default=None, help="sub-envs of the batched env")
    ap.add_argument(
        "--checkpoint-seconds",
        type=float,
        default=None,
        help="wall-clock seconds between checkpoints (config checkpoint.seconds, default 300)",
    )
    ap.add_argument("--out", type=str, required=True, help="run directory")
    ap.add_argument("--resume", action="store_true", help="continue from the last checkpoint")
    ap.add_argument("--device", type=str, default="cpu")
    ap.add_argument(
        "--torch-threads",
        type=int,
        default=None,
        help="torch's CPU threads (default: torch's own, every core: the env "
        "and the updates take turns, so each can use all of them; give 1 "
        "per run when several runs share the cores)",
    )
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    ap.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run of the config in a few minutes: 20k steps (unless "
        "--timesteps), 10 evaluation episodes, cloning cut to 16 episodes, "
        "2 epochs and one DAgger round",
    )
    args = ap.parse_args(argv)
    if args.torch_threads is not None and args.torch_threads < 1:
        ap.error(f"--torch-threads must be a positive integer, got {args.torch_threads}")
    return args


def smoke_config(cfg: dict, timesteps_given: bool) -> dict:
    """The same config at a budget that checks the whole pipeline in about a minute."""
    cfg = {
        **cfg,
        "evaluation": {
            **cfg["evaluation"],
            "episodes": 10,
            "freq": min(cfg["evaluation"]["freq"], 10_000),
        },
        "checkpoint": {**cfg["checkpoint"], "freq": min(cfg["checkpoint"]["freq"], 10_000)},
    }
    if not timesteps_given:
        cfg["timesteps"] = 20_000
    if cfg.get("pretrain"):
        pt = dict(cfg["pretrain"])
        pt.update(
            episodes=16, epochs=2, value_epochs=min(pretrain_settings(cfg)["value_epochs"], 1)
        )
        if pt.get("dagger_rounds"):
            pt.update(dagger_rounds=1, dagger_episodes=8)
        cfg["pretrain"] = pt
    return cfg


# ---- files --------------------------------------------------------------------------
def has_replay_buffer(model) -> bool:
    """An off-policy learner (SAC, TD3, TQC, CrossQ): its experience lives in a replay
    buffer, which checkpoints keep; an on-policy one (PPO, RecurrentPPO) has none."""
    return getattr(model, "replay_buffer", None) is not None


def save_model(model, venv, stem: Path, meta: dict, replay: bool = False) -> None:
    """model.zip, _vecnormalize.pkl, .json (and _replay_buffer.pkl) next to `stem`,
    each written to a temporary name first and renamed, so a crash leaves either the
    old set or the new file, never half a file."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    tmp = stem.with_name(f".tmp-{stem.name}")
    model.save(str(tmp) + ".zip")
    venv.save(str(tmp) + "_vecnormalize.pkl")
    if replay and hasattr(model, "save_replay_buffer"):
        model.save_replay_buffer(str(tmp) + "_replay_buffer.pkl")
        os.replace(str(tmp) + "_replay_buffer.pkl", str(stem) + "_replay_buffer.pkl")
    os.replace(str(tmp) + ".zip", str(stem) + ".zip")
    os.replace(str(tmp) + "_vecnormalize.pkl", str(stem) + "_vecnormalize.pkl")
    write_json(stem.with_suffix(".json"), meta)


def write_evaluations(out: Path, rows: list[dict]) -> None:
    """out/evaluations.csv (EVAL_FIELDS, one row per evaluation), replaced whole."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=EVAL_FIELDS)
    w.writeheader()
    w.writerows(rows)
    atomic_write(out / "evaluations.csv", buf.getvalue())


# ---- the training loop ---------------------------------------------------------------
def build_env(cfg: dict, stats_path: Path | None = None):
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    base = VecMonitor(
        HopRoverSB3VecEnv(cfg["n_envs"], seed=cfg["seed"], env_id=cfg["env_id"], **env_kwargs(cfg)),
        info_keywords=("broken",),
    )
    if stats_path is not None:
        venv = VecNormalize.load(str(stats_path), base)
        # statistics read from a file (a checkpoint, init_from) stay as they are where the
        # config says so (normalize.update: false)
        venv.training = cfg["normalize"].get("update", True)
        return venv
    norm = cfg["normalize"]
    gamma = cfg["hyperparams"].get("gamma", 0.99)
    return VecNormalize(
        base,
        norm_obs=norm.get("obs", True),
        norm_reward=norm.get("reward", True),
        clip_obs=norm.get("clip_obs", 10.0),
        clip_reward=norm.get("clip_reward", 10.0),
        gamma=gamma,
    )


def tensorboard_dir(out: Path) -> str | None:
    """The run's TensorBoard directory, or None (and a note) without the tensorboard extra."""
    import importlib.util

    if importlib.util.find_spec("tensorboard") is None:
        print(
            "note: no TensorBoard logs (tensorboard is not installed: pip install "
            "'hoprover[tensorboard]'); evaluations.csv has the learning curve",
            file=sys.stderr,
        )
        return None
    return str(out / "tb")


class Trainer(Pretraining):
    def __init__(self, cfg: dict, out: Path, resume: bool, device: str, progress: bool):
        self.cfg, self.out, self.device, self.progress = cfg, out, device, progress
        self.ckpt = out / "checkpoints" / "last"
        # how the model was trained: enough to reproduce it with train.py --config
        self.meta_base = {
            "algo": cfg["algo"],
            "env_id": cfg["env_id"],
            "env_kwargs": env_kwargs(cfg),
            "seed": cfg["seed"],
            "config": {k: v for k, v in cfg.items() if v is not None},
            "git_commit": git_commit(),
        }
        if cfg.get("init_from"):  # the model a fine-tuning run started from
            self.meta_base["init_from"] = str(cfg["init_from"])
        ev = cfg["evaluation"]
        self.eval_targets = seeded_targets(
            ev["episodes"], ev["seed"], *env_kwargs(cfg).get("target_range", (-1.0, 1.0))
        )
        self.evals: list[dict] = []
        self.on_eval = None  # called with each evaluation row (sweep.py reports it)
        self.pretrain: dict = {}
        self.best = (-1.0, -math.inf)
        self.wall0 = 0.0
        self.env0 = 0.0
        if resume:
            self._load_checkpoint()
        else:
            self._fresh()

    def _fresh(self):
        if (self.ckpt.with_suffix(".json")).exists():
            raise SystemExit(
                f"error: {self.out} already has a checkpoint; use --resume to "
                "continue it or choose another --out"
            )
        self.out.mkdir(parents=True, exist_ok=True)
        atomic_write(self.out / "config.yaml", yaml.safe_dump(self.cfg, sort_keys=False))
        if self.cfg.get("init_from"):
            self._init_from(self.cfg["init_from"])
            return
        self.venv = build_env(self.cfg)
        self.model = make_agent(self.cfg, self.venv, tensorboard_dir(self.out), self.device)
        if self.cfg.get("pretrain"):
            self._pretrain()
        if self.cfg.get("demonstrations"):
            self._demonstrate()

    def _demonstrate(self):
        """The config's demonstrations into the replay buffer (training/demonstrations.py)."""
        from hoprover_env.training.demonstrations import collect_demonstrations, prefill

        t0 = time.perf_counter()
        added = prefill(
            self.model, self.venv, collect_demonstrations(self.cfg, env_kwargs(self.cfg))
        )
        self.meta_base["demonstrations"] = added
        print(
            f"demonstrations: {added['transitions']} transitions of {added['episodes']} "
            f"episodes in the replay buffer ({time.perf_counter() - t0:.0f} s)",
            file=sys.stderr,
        )

    def _init_from(self, spec: str):
        """A fresh run (this config's hyperparameters, schedule and env) that starts from
        another model's weights, exploration noise and VecNormalize statistics: a
        fine-tuning stage as one command, where --resume would keep the old run's
        hyperparameters (SB3 restores them from the .zip)."""
        from hoprover_env.agents.policies import model_files

        try:
            zip_path, stats = model_files(spec)
        except FileNotFoundError as exc:
            raise SystemExit(f"error: init_from {spec!r}: {exc}") from None
        if stats is None and self.cfg["normalize"].get("obs", True):
            raise SystemExit(
                f"error: init_from {spec!r} has no VecNormalize statistics "
                f"beside {zip_path}, but this config normalises observations"
            )
        self.venv = build_env(self.cfg, stats)
        self.model = make_agent(self.cfg, self.venv, tensorboard_dir(self.out), self.device)
        try:
            self.model.set_parameters(str(zip_path), exact_match=True, device=self.device)
        except (RuntimeError, ValueError) as exc:
            raise SystemExit(
                f"error: init_from {spec!r} ({zip_path}) does not fit this "
                f"config's policy (algo, policy.net_arch): {exc}"
            ) from None
        print(f"starting from {zip_path} (init_from)", file=sys.stderr)

    def _load_checkpoint(self):
        meta_path = self.ckpt.with_suffix(".json")
        if not meta_path.exists():
            raise SystemExit(f"error: nothing to resume: {meta_path} does not exist")
        meta = json.loads(meta_path.read_text())
        self.evals = meta.get("evaluations", [])
        self.best = tuple(meta.get("best", self.best))
        self.wall0 = meta.get("wall_s", 0.0)
        self.env0 = meta.get("env_s", 0.0)
        self.pretrain = {k: v for k, v in meta.items() if k.startswith("pretrain")}
        self.venv = build_env(self.cfg, Path(str(self.ckpt) + "_vecnormalize.pkl"))
        cls = algo_class(self.cfg["algo"])
        self.model = cls.load(
            str(self.ckpt) + ".zip",
            env=self.venv,
            device=self.device,
            tensorboard_log=tensorboard_dir(self.out),
        )
        rb = Path(str(self.ckpt) + "_replay_buffer.pkl")
        if rb.exists() and has_replay_buffer(self.model):
            self.model.load_replay_buffer(str(rb))
        print(f"resuming {self.out} at {self.model.num_timesteps} steps", file=sys.stderr)

    def _judge(self, label: str) -> dict:
        """The contest judge's summary of the current policy on the validation targets,
        with the observation statistics frozen as they are now."""
        import copy

        norm = self.venv
        policy = SB3Policy(
            self.model,
            copy.deepcopy(norm.obs_rms),
            norm.clip_obs,
            epsilon=norm.epsilon,
            name=label,
            env_kwargs=env_kwargs(self.cfg),
            env_id=self.cfg["env_id"],
        )
        return summarize(run_episodes(policy, self.eval_targets, env_kwargs(self.cfg)))

    # ---- evaluation and checkpoints ----------------------------------------------------
    def evaluate(self):
        res = self._judge("current")
        row = {
            "timesteps": int(self.model.num_timesteps),
            "wall_s": round(self.wall(), 1),
            "success_rate": res["success_rate"],
            "median_ttrtp": res["median_ttrtp"],
            "p90_ttrtp": res["p90_ttrtp"],
            "broken": res["broken"],
        }
        self.evals.append(row)
        if getattr(self.model, "_logger", None) is not None:  # set once learning runs
            for key in ("success_rate", "median_ttrtp", "broken"):
                if not math.isnan(row[key]):
                    self.model.logger.record(f"eval/{key}", row[key])
            self.model.logger.dump(self.model.num_timesteps)
        write_evaluations(self.out, self.evals)
        score = _score(row)
        improved = score > tuple(self.best)
        if improved:
            self.best = score
            save_model(
                self.model,
                self.venv,
                self.out / "best_model",
                {
                    **self.meta_base,
                    **self.pretrain,
                    "timesteps": row["timesteps"],
                    "wall_s": self.wall(),
                    "env_s": self.env_seconds(),
                    "evaluation": row,
                },
            )
        print(
            f"  eval @ {row['timesteps']:>9d}: success {row['success_rate']:.1%}, median TTRTP "
            f"{row['median_ttrtp']:.1f} s, broken {row['broken']}"
            f"{'  (best)' if improved else ''}",
            file=sys.stderr,
        )
        if self.on_eval is not None:
            self.on_eval(row)

    def wall(self):
        return self.wall0 + (time.perf_counter() - self.t_start)

    def env_seconds(self) -> float:
        """Wall time spent stepping the environment (the batched core) so far."""
        return self.env0 + self.venv.venv.venv.step_seconds

    def checkpoint(self, keep: bool = False):
        """checkpoints/last.* (the replay buffer too); with `keep`, also the model, its
        statistics and meta as checkpoints/model_STEPS.* (`checkpoint.keep`), which later
        diagnostics load like any model (research.offpolicy.actors --model)."""
        # on-policy (PPO, RecurrentPPO): a checkpoint taken inside a rollout counts only the
        # steps trained on, so that --resume collects the unfinished rollout again
        # (off-policy steps live in the replay buffer, which is saved with the checkpoint)
        steps = self.model.num_timesteps
        replay = has_replay_buffer(self.model)
        if not replay:
            self.model.num_timesteps = self.trained_steps
        try:
            # evaluations of steps the checkpoint does not count are redone by --resume:
            # keeping them too would list those steps twice
            done = [e for e in self.evals if e["timesteps"] <= self.model.num_timesteps]
            meta = {
                **self.meta_base,
                **self.pretrain,
                "timesteps": int(self.model.num_timesteps),
                "evaluations": done,
                "best": list(self.best),
                "wall_s": self.wall(),
                "env_s": self.env_seconds(),
            }
            save_model(self.model, self.venv, self.ckpt, meta, replay=replay)
            if keep:
                stem = self.ckpt.with_name(f"model_{meta['timesteps']}")
                save_model(self.model, self.venv, stem, meta)
            return meta["timesteps"]
        finally:
            self.model.num_timesteps = steps

    # ---- run -----------------------------------------------------------------------------
    def run(self) -> int:
        from stable_baselines3.common.callbacks import BaseCallback

        trainer = self
        total = self.cfg["timesteps"]
        ev_freq, ck_freq = self.cfg["evaluation"]["freq"], self.cfg["checkpoint"]["freq"]
        ck_seconds = self.cfg["checkpoint"].get("seconds", 300.0)
        ck_keep = bool(self.cfg["checkpoint"].get("keep", False))

        class Hooks(BaseCallback):
            def _on_rollout_start(self):
                # steps of a rollout count only once trained on: an interrupt mid-rollout
                # checkpoints this count, so --resume collects that rollout again
                trainer.trained_steps = self.num_timesteps

            def _on_training_start(self):
                self.next_eval = (self.num_timesteps // ev_freq + 1) * ev_freq
                self.next_ckpt = (self.num_timesteps // ck_freq + 1) * ck_freq
                self.ckpt_due = time.monotonic() + ck_seconds
                self.bar = None
                if trainer.progress:
                    from tqdm import tqdm

                    self.bar = tqdm(
                        total=total,
                        initial=self.num_timesteps,
                        unit="step",
                        unit_scale=True,
                        desc="train",
                        dynamic_ncols=True,
                    )

            def _on_step(self):
                if self.bar is not None:
                    self.bar.update(self.num_timesteps - self.bar.n)
                if self.num_timesteps >= self.next_eval:
                    self.next_eval += ev_freq
                    trainer.evaluate()
                if self.num_timesteps >= self.next_ckpt or time.monotonic() >= self.ckpt_due:
                    keep = False
                    if self.num_timesteps >= self.next_ckpt:
                        self.next_ckpt += ck_freq
                        keep = ck_keep
                    # a wall-clock deadline too: a kill -9 loses minutes, not 500 k steps
                    self.ckpt_due = time.monotonic() + ck_seconds
                    trainer.checkpoint(keep)
                return True

            def _on_training_end(self):  # learn() returned: all trained on
                trainer.trained_steps = self.num_timesteps
                if self.bar is not None:
                    self.bar.close()

        callbacks: list[BaseCallback] = [Hooks()]
        if self.cfg.get("redo"):
            from hoprover_env.training import redo

            callbacks.append(redo.RecycleDormant(**redo.settings(self.cfg)))
        self.t_start = time.perf_counter()
        self.trained_steps = self.model.num_timesteps
        if self.model.num_timesteps == 0 and not self.evals:
            self.evaluate()  # the starting point (e.g. after cloning)
            self.checkpoint()  # cloning is never redone on --resume
        remaining = total - self.model.num_timesteps
        interrupted = False
        # SIGTERM saves a checkpoint like Ctrl-C; signals can only be handled in the main
        # thread (a Ray Tune trial runs this in a worker thread: Tune stops it itself)
        main_thread = threading.current_thread() is threading.main_thread()
        if main_thread:
            previous = signal.getsignal(signal.SIGTERM)
            signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
        try:
            if remaining > 0:
                self.model.learn(
                    remaining, callback=callbacks, reset_num_timesteps=False, tb_log_name="run"
                )
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if main_thread:
                signal.signal(signal.SIGTERM, previous)
        if interrupted:
            saved = self.checkpoint()
            print(
                f"\ninterrupted; checkpoint saved at {saved} trained steps. "
                f"Continue with: python train.py --config {self.out / 'config.yaml'} "
                f"--out {self.out} --resume",
                file=sys.stderr,
            )
            return 130
        if not self.evals or self.evals[-1]["timesteps"] != self.model.num_timesteps:
            self.evaluate()
        self.checkpoint()  # after the last evaluation: --resume must know it and its best
        save_model(
            self.model,
            self.venv,
            self.out / "final_model",
            {
                **self.meta_base,
                **self.pretrain,
                "timesteps": int(self.model.num_timesteps),
                "wall_s": self.wall(),
                "env_s": self.env_seconds(),
            },
        )
        print(
            f"done: {self.model.num_timesteps} RL steps in {self.wall():.0f} s wall, of which "
            f"{self.env_seconds():.0f} s ({self.env_seconds() / self.wall():.0%}) stepping "
            f"the environment; best {self.out / 'best_model.zip'}",
            file=sys.stderr,
        )
        return 0


def main(argv=None) -> int:
    args = parse_args(argv)
    out = Path(args.out)
    config = args.config
    if args.resume and config is None and (out / "config.yaml").exists():
        config = out / "config.yaml"
    try:
        cfg = load_config(
            config,
            {
                "algo": args.algo,
                "env_id": args.env,
                "timesteps": args.timesteps,
                "seed": args.seed,
                "n_envs": args.n_envs,
            },
            {"checkpoint": {"seconds": args.checkpoint_seconds}},
        )
    except (ConfigError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.quick:
        cfg = smoke_config(cfg, args.timesteps is not None)
    if args.torch_threads is not None:
        import torch

        torch.set_num_threads(args.torch_threads)
    try:
        trainer = Trainer(cfg, out, args.resume, args.device, not args.no_progress)
    except KeyboardInterrupt:
        print(
            "\ninterrupted before RL training began (during set-up or behaviour cloning, "
            "which keeps no checkpoint of its own): nothing to resume; the same command "
            "starts the run over",
            file=sys.stderr,
        )
        return 130
    return trainer.run()


if __name__ == "__main__":
    sys.exit(main())
