"""Where a HER run's memory goes: the process's resident size against what Python's
allocator holds in live objects (tracemalloc), while SAC learns with SB3's
`HerReplayBuffer` on HopRoverGoal-v1.

    python -m research.offpolicy.her_memory --steps 3000 --batch-size 256 \\
        --out benchmarks/results/offpolicy/her_memory_256.json

A learner with HER grew by tens of KB per env step (docs/studies/off-policy.md): far more
than the transitions it stores. If the live Python objects grow as fast as the resident
size, something keeps them (and the largest growth by line says what); if they do not,
the memory is held below Python's objects (freed blocks the allocator does not return,
or torch's own). Every `--every` env steps after the first update: resident size,
tracemalloc's current size, and the replay buffer's size; with `--trim`, glibc is
first asked to return the memory it holds freed (malloc_trim), so that what remains
resident is in use. Then the ten source lines whose
live allocations grew most between the first and the last sample.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import resource
import tracemalloc
from pathlib import Path

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.util.files import atomic_write


def resident_mb() -> float:
    """The process's current resident size [MB] (Linux: /proc/self/statm)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize() / 2**20


def where(frame) -> str:
    """A source line as its folder, file and line number (no machine's paths)."""
    path = Path(frame.filename)
    return f"{path.parent.name}/{path.name}:{frame.lineno}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=3000, help="env steps after learning starts")
    ap.add_argument("--batch-size", type=int, default=256)
    ap.add_argument("--every", type=int, default=500)
    ap.add_argument(
        "--trim",
        action="store_true",
        help="ask glibc to return its freed memory (malloc_trim) before each sample",
    )
    ap.add_argument(
        "--no-her",
        action="store_true",
        help="the control: SB3's plain DictReplayBuffer in place of HerReplayBuffer",
    )
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    import torch
    from stable_baselines3 import SAC, HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)
    n_envs = 4  # the clock below steps by n_envs, and the buffer holds n_envs per row
    venv = make_vec_env("HopRoverGoal-v1", n_envs=n_envs, seed=0, env_kwargs={"keep_going": True})
    start = 1400  # an episode of up to 300 decisions must end before HER can sample
    model = SAC(
        "MultiInputPolicy",
        venv,
        replay_buffer_class=None if args.no_her else HerReplayBuffer,
        replay_buffer_kwargs=None if args.no_her else {"n_sampled_goal": 4, "copy_info_dict": True},
        learning_starts=start,
        batch_size=args.batch_size,
        gradient_steps=2,
        gamma=0.995,
        ent_coef="auto_0.01",
        policy_kwargs={"net_arch": [256, 256]},
        seed=0,
        device="cpu",
    )
    samples: list[dict] = []
    snapshots = []

    class Probe(BaseCallback):
        def _on_step(self) -> bool:
            t = self.num_timesteps
            if t >= start + n_envs and (t - start) % args.every < n_envs:
                if args.trim:
                    ctypes.CDLL("libc.so.6").malloc_trim(0)
                current, _ = tracemalloc.get_traced_memory()
                samples.append(
                    {
                        "env_steps": t,
                        "resident_mb": resident_mb(),
                        "python_live_mb": current / 2**20,
                        "buffer_transitions": int(self.model.replay_buffer.size()) * n_envs,
                    }
                )
                snapshots.append(tracemalloc.take_snapshot())
                print(samples[-1], flush=True)
            return True

    tracemalloc.start(8)
    model.learn(start + args.steps, callback=Probe())
    first, last = samples[0], samples[-1]
    steps = last["env_steps"] - first["env_steps"]
    top = snapshots[-1].compare_to(snapshots[0], "lineno")[:10]
    result = {
        "batch_size": args.batch_size,
        "malloc_trim": args.trim,
        "her": not args.no_her,
        "samples": samples,
        "resident_kb_per_env_step": (last["resident_mb"] - first["resident_mb"]) * 1024 / steps,
        "python_live_kb_per_env_step": (last["python_live_mb"] - first["python_live_mb"])
        * 1024
        / steps,
        "top_growth": [{"where": where(s.traceback[0]), "kb": s.size_diff / 1024} for s in top],
    }
    print(json.dumps({k: v for k, v in result.items() if k != "samples"}, indent=1))
    if args.out is not None:
        atomic_write(args.out, json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
