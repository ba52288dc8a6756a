"""Training cost: SB3 PPO on the native batched env against PPO on a DummyVecEnv of
single envs (the usual SB3 setup), same hyperparameters, same number of steps, one run;
and the share of wall time spent stepping the environment. Also reports the recorded
training time of the bundled policy (hoprover_env/agents/policies/*.json).

    python -m benchmarks.bench_training [--quick]
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.report import Section, table


class TimedDummyVecEnv:
    """A DummyVecEnv whose step_wait time is accumulated (the env's share)."""

    @staticmethod
    def make(n_envs: int, seed: int):
        import gymnasium as gym
        from stable_baselines3.common.monitor import Monitor
        from stable_baselines3.common.vec_env import DummyVecEnv

        import hoprover_env  # noqa: F401

        class Timed(DummyVecEnv):
            step_seconds = 0.0

            def step_wait(self):
                t0 = time.perf_counter()
                try:
                    return super().step_wait()
                finally:
                    Timed.step_seconds += time.perf_counter() - t0

        venv = Timed([lambda i=i: Monitor(gym.make("HopRover-v0")) for i in range(n_envs)])
        venv.seed(seed)
        return venv, lambda: Timed.step_seconds


def ppo_run(kind: str, n_envs: int, steps: int) -> tuple[float, float]:
    """(wall seconds, env seconds) of PPO.learn(steps) on the given vectorization."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    torch.set_num_threads(1)
    if kind == "native":
        from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

        base = HopRoverSB3VecEnv(n_envs, seed=0)
        inner = VecMonitor(base)
        env_time = lambda: base.step_seconds  # noqa: E731
    else:
        inner, env_time = TimedDummyVecEnv.make(n_envs, 0)
    venv = VecNormalize(inner)
    model = PPO(
        "MlpPolicy", venv, n_steps=256, batch_size=2048, n_epochs=5, seed=0, verbose=0, device="cpu"
    )
    model.learn(min(steps, n_envs * 256))  # warm up: compile, allocate
    e0 = env_time()
    t0 = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    return time.perf_counter() - t0, env_time() - e0


# PPO settings tried for training speed (the aim: as fast as SB3 allows on 2 cores).
# (label, torch threads, numba threads, n_envs, n_steps, batch, epochs, net)
SPEED_GRID = [
    ("SB3 defaults (64x64, 2048/64, 10 epochs)", 1, 2, 8, 256, 64, 10, [64, 64]),
    ("old configs/ppo.yaml (32 envs, batch 2048)", 1, 2, 32, 256, 2048, 5, [128, 128]),
    ("128 envs, batch 4096, 5 epochs", 1, 2, 128, 256, 4096, 5, [128, 128]),
    ("128 envs, batch 4096, 5 epochs, torch 2 threads", 2, 2, 128, 256, 4096, 5, [128, 128]),
    ("128 envs, batch 4096, 5 epochs, numba 1 thread", 1, 1, 128, 256, 4096, 5, [128, 128]),
    ("256 envs, batch 8192, 5 epochs", 1, 2, 256, 128, 8192, 5, [128, 128]),
    ("128 envs, batch 8192, 3 epochs", 1, 2, 128, 256, 8192, 3, [128, 128]),
]


def ppo_speed(
    torch_threads, numba_threads, n_envs, n_steps, batch, epochs, net, rollouts, env_kwargs=None
) -> tuple[float, float]:
    """(steps/s, env share) of PPO on the native env with these settings, after one
    warm-up rollout; the thread counts are restored afterwards."""
    import numba
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    old = torch.get_num_threads(), numba.get_num_threads()
    torch.set_num_threads(torch_threads)
    numba.set_num_threads(min(numba_threads, numba.config.NUMBA_NUM_THREADS))
    try:
        base = HopRoverSB3VecEnv(
            n_envs, seed=0, threads=numba_threads > 1, **(env_kwargs or {"control_dt": 2.0})
        )
        venv = VecNormalize(VecMonitor(base))
        model = PPO(
            "MlpPolicy",
            venv,
            n_steps=n_steps,
            batch_size=batch,
            n_epochs=epochs,
            policy_kwargs={"net_arch": net},
            seed=0,
            verbose=0,
            device="cpu",
        )
        model.learn(n_envs * n_steps)
        steps = n_envs * n_steps * rollouts
        e0, t0 = base.step_seconds, time.perf_counter()
        model.learn(steps, reset_num_timesteps=False)
        wall = time.perf_counter() - t0
        return steps / wall, (base.step_seconds - e0) / wall
    finally:
        torch.set_num_threads(old[0])
        numba.set_num_threads(old[1])


def speed_table(quick: bool) -> tuple[str, dict]:
    rows = []
    grid = SPEED_GRID[:2] if quick else SPEED_GRID
    for label, tt, nt, n_envs, n_steps, batch, epochs, net in grid:
        rollouts = 1 if quick else max(2, 200_000 // (n_envs * n_steps))
        sps, share = ppo_speed(
            tt,
            nt,
            n_envs,
            n_steps if not quick else 32,
            min(batch, n_envs * (n_steps if not quick else 32)),
            epochs,
            net,
            rollouts,
        )
        rows.append([label, sps, share])
    base = rows[0][1]
    for r in rows:
        r.append(r[1] / base)
    md = table(
        ["settings", "steps/s", "env share", "vs SB3 defaults"],
        rows,
        {"steps/s": ",.0f", "env share": ".0%", "vs SB3 defaults": ".2f"},
    )
    return md, {"speed_rows": rows}


def bundled_training_record() -> list:
    """Phases of the bundled policy's training, from the metadata train.py wrote."""
    rows = []
    for meta_path in sorted(
        Path(__file__).resolve().parent.parent.glob("hoprover_env/agents/policies/*.json")
    ):
        meta = json.loads(meta_path.read_text())
        if "wall_s" not in meta:
            continue
        nan = float("nan")
        rows.append(
            [
                meta_path.stem,
                "behaviour cloning (expert + DAgger rollouts, fitting)",
                "-",
                meta.get("pretrain_s", nan),
                meta.get("pretrain_collect_s", nan),
            ]
        )
        rows.append(
            [
                meta_path.stem,
                "PPO fine-tuning",
                meta.get("timesteps", "?"),
                meta["wall_s"],
                meta.get("env_s", nan),
            ]
        )
        if "total_wall_s" in meta:
            rows.append(
                [meta_path.stem, "whole `train.py` command", "-", meta["total_wall_s"], nan]
            )
    return rows


def run(quick: bool = False, fig_dir: str = "benchmarks/figures") -> Section:
    n_envs = 32
    steps = n_envs * 256 * (2 if quick else 12)
    rows, res = [], {}
    for kind in ("native", "dummy"):
        wall, env_s = ppo_run(kind, n_envs, steps)
        res[kind] = steps / wall
        rows.append(
            [
                {
                    "native": "HopRoverSB3VecEnv (one jitted call)",
                    "dummy": "DummyVecEnv of 32 HopRoverEnv + Monitor",
                }[kind],
                steps,
                wall,
                steps / wall,
                env_s / wall,
            ]
        )
    md = [
        f"PPO (MlpPolicy 64x64, n_steps 256, batch 2048, 5 epochs, torch 1 thread), "
        f"{n_envs} envs, {steps} steps after a warm-up, one run:",
        table(
            ["vectorization", "steps", "wall s", "steps/s", "env share of wall"],
            rows,
            {"wall s": ".1f", "steps/s": ",.0f", "env share of wall": ".1%"},
        ),
        f"Native / DummyVecEnv training throughput: {res['native'] / res['dummy']:.2f}x. "
        "With the native env, PPO's own updates dominate the wall time.",
    ]
    speed_md, speed = speed_table(quick)
    md += [
        "PPO settings on the native env (HopRover-v0, control_dt 2, MlpPolicy, one run "
        "each, same process, ~200 k steps after a warm-up rollout). The configs use the "
        "fastest row that keeps a batch of at least 4096:",
        speed_md,
    ]
    rec = bundled_training_record()
    if rec:
        md += [
            "Recorded training of the bundled policy (`python train.py --config "
            "configs/ppo.yaml`, from its metadata; 'env s' is the time spent running "
            "the simulator: for cloning, the scripted expert's look-ahead planning and "
            "the rollouts; for PPO, stepping the batched env):",
            table(
                ["policy", "phase", "RL steps", "wall s", "env s"],
                rec,
                {"wall s": ".0f", "env s": ".0f"},
            ),
        ]
    return Section(
        "Training cost",
        "\n\n".join(md),
        [],
        {
            "ppo_native_steps_per_s": res["native"],
            "ppo_dummy_steps_per_s": res["dummy"],
            "native_vs_dummy": res["native"] / res["dummy"],
        },
    )


if __name__ == "__main__":
    sec = run(quick="--quick" in sys.argv, fig_dir=tempfile.mkdtemp())
    print(sec.markdown)
