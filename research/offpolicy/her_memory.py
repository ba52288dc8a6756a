"""Where a HER run's memory goes: the process's resident size while SAC (or TQC) learns
with SB3's `HerReplayBuffer` on HopRoverGoal-v1, against the plain `DictReplayBuffer`.

    python -m research.offpolicy.her_memory --steps 16000 --every 4000 \\
        --out benchmarks/results/offpolicy/her_memory_her.json
    python -m research.offpolicy.her_memory --steps 16000 --every 4000 --no-her \\
        --out benchmarks/results/offpolicy/her_memory_plain.json

Every `--every` env steps after the first update: the resident size and the replay
buffer's size. The resident size is read with nothing else watching, because a watcher
costs memory of its own: tracemalloc keeps a trace for every live block, and each snapshot
holds all of them (an earlier version of this probe kept one snapshot per sample, about
50 MB each, and measured mostly itself). With `--trace` tracemalloc also reports the live
Python objects and the ten source lines whose live allocations grew most between the first
sample and the end; the resident size then includes tracemalloc's own traces. With
`--trim`, glibc is first asked to return the memory it holds freed (malloc_trim), so
that what remains resident is in use.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import resource
import sys
import tracemalloc
from pathlib import Path

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.util.files import atomic_write
from research.baselines import provenance


def resident_mb() -> float:
    """The process's current resident size [MB] (Linux: /proc/self/statm)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize() / 2**20


def where(frame) -> str:
    """A source line as its folder, file and line number (no machine's paths)."""
    path = Path(frame.filename)
    return f"{path.parent.name}/{path.name}:{frame.lineno}"


def growth_kb_per_step(samples: list[dict], key: str) -> float:
    """Growth of `key` [MB] between the first and the last sample, in KB per env step."""
    first, last = samples[0], samples[-1]
    return (last[key] - first[key]) * 1024 / (last["env_steps"] - first["env_steps"])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--algo", choices=("sac", "tqc"), default="sac")
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
    ap.add_argument(
        "--trace",
        action="store_true",
        help="also the live Python objects (tracemalloc; its traces add to the resident size)",
    )
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.steps < 3 * args.every:  # a sample every `every` steps after the start
        ap.error(
            "--steps must be at least 3 x --every: the growth over the run and over its "
            "second half need three samples"
        )

    import torch
    from stable_baselines3 import HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env

    from hoprover_env.training.sb3_agents import algo_class

    torch.set_num_threads(1)
    n_envs = 4  # the clock below steps by n_envs, and the buffer holds n_envs per row
    venv = make_vec_env("HopRoverGoal-v1", n_envs=n_envs, seed=0, env_kwargs={"keep_going": True})
    start = 1400  # an episode of up to 300 decisions must end before HER can sample
    model = algo_class(args.algo)(
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
    first_snapshot: list[tracemalloc.Snapshot] = []

    class Probe(BaseCallback):
        def _on_step(self) -> bool:
            t = self.num_timesteps
            if t >= start + n_envs and (t - start) % args.every < n_envs:
                if args.trim:
                    ctypes.CDLL("libc.so.6").malloc_trim(0)
                if args.trace and not first_snapshot:  # before the first reading, which
                    first_snapshot.append(tracemalloc.take_snapshot())  # then holds it
                sample = {
                    "env_steps": t,
                    "resident_mb": resident_mb(),
                    "buffer_transitions": int(self.model.replay_buffer.size()) * n_envs,
                }
                if args.trace:
                    sample["python_live_mb"] = tracemalloc.get_traced_memory()[0] / 2**20
                samples.append(sample)
                print(sample, flush=True)
            return True

    if args.trace:
        tracemalloc.start(8)
    model.learn(start + args.steps, callback=Probe())
    half = samples[(len(samples) - 1) // 2 :]
    commit, date = provenance()
    result = {
        "command": " ".join(["python -m research.offpolicy.her_memory", *(argv or sys.argv[1:])]),
        "commit": commit,
        "date": date,
        "algo": args.algo,
        "batch_size": args.batch_size,
        "malloc_trim": args.trim,
        "her": not args.no_her,
        "traced": args.trace,
        "samples": samples,
        "resident_kb_per_env_step": growth_kb_per_step(samples, "resident_mb"),
        "resident_kb_per_env_step_second_half": growth_kb_per_step(half, "resident_mb"),
    }
    if args.trace:
        top = tracemalloc.take_snapshot().compare_to(first_snapshot[0], "lineno")[:10]
        result["python_live_kb_per_env_step"] = growth_kb_per_step(samples, "python_live_mb")
        result["top_growth"] = [
            {"where": where(s.traceback[0]), "kb": s.size_diff / 1024} for s in top
        ]
    print(json.dumps({k: v for k, v in result.items() if k != "samples"}, indent=1))
    if args.out is not None:
        atomic_write(args.out, json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
