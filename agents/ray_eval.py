"""evaluate.py --ray: the episodes of each policy split into chunks that Ray tasks run.

A chunk is a slice of the target list starting at a multiple of the local batch size
and one batch long, so each task runs exactly the batch a local `run_episodes` would
(same sub-env grouping, same policy batches, same random streams): the merged results
equal the local run episode for episode (tests/test_ray.py), wall times aside. Each
task rebuilds its policy from its spec (a bundled name, a model path, a controller
file), which every node must be able to read.
"""
from __future__ import annotations

import os

import numpy as np

from agents.evaluation import EpisodeResult


def _spec_for_workers(spec: str) -> str:
    """Paths made absolute: a task does not run in the driver's working directory."""
    path = spec.rsplit(":", 1)[0] if ".py:" in spec else spec
    if os.path.exists(path):
        return spec.replace(path, os.path.abspath(path), 1)
    return spec


def _run_chunk(kind: str, spec: str, targets, first: int, control_dt: float, seed: int,
               batch: int):
    from agents.evaluation import run_episodes
    from agents.policies import load_controller, load_policy
    policy = load_controller(spec, control_dt) if kind == "controller" else \
        load_policy(spec, control_dt=control_dt, seed=seed)
    return [r.as_dict() for r in run_episodes(policy, targets, batch=batch,
                                              first_episode=first)]


def evaluate_on_ray(jobs: list[tuple[str, str, str]], targets, control_dt: float, seed: int,
                    batch: int = 256, address: str | None = None,
                    num_cpus: int | None = None, progress=None) -> dict[str, list]:
    """jobs: (kind 'policy' | 'controller', spec, row name). Returns row name -> the
    EpisodeResults in target order. `progress(name, episodes_done)` after each chunk."""
    from agents.ray_utils import init_ray
    ray = init_ray(address, num_cpus)
    task = ray.remote(num_cpus=1)(_run_chunk)
    targets = np.asarray(targets, dtype=float)
    pending = {}
    for kind, spec, name in jobs:
        for first in range(0, len(targets), batch):
            ref = task.remote(kind, _spec_for_workers(spec), targets[first:first + batch],
                              first, control_dt, seed, batch)
            pending[ref] = (name, first)
    chunks: dict[str, dict[int, list]] = {name: {} for _, _, name in jobs}
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            name, first = pending.pop(ref)
            rows = ray.get(ref)
            for r in rows:
                r["policy"] = name
            chunks[name][first] = [EpisodeResult(**r) for r in rows]
            if progress is not None:
                progress(name, sum(len(c) for c in chunks[name].values()))
    return {name: [r for first in sorted(c) for r in c[first]] for name, c in chunks.items()}
