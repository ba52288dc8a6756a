"""evaluate.py --ray: the episodes of each policy split into chunks that Ray tasks run.

A chunk is a slice of the target list starting at a multiple of the local batch size
and one batch long, so each task runs exactly the batch a local `run_episodes` would
(same sub-env grouping, same policy batches, same random streams): the merged results
equal the local run episode for episode (tests/training/test_ray.py), wall times aside. A task
whose node dies is run again elsewhere by Ray (its retries), with the same result.

Each task rebuilds its policy from its spec. A bundled name, `scripted` and `random`
come with the installed hoprover; a model file, a run directory or a controller file
is read once on the driver and travels with the tasks through Ray's object store, so
a path on the driver is enough: the nodes need not see it.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from hoprover_env.evaluation.episodes import EpisodeResult


def policy_files(kind: str, spec: str) -> tuple[str, dict[str, bytes]] | None:
    """The files a policy spec names, read on the driver: (spec relative to the folder
    they will be written to, {relative name: bytes}); None for a spec that names no
    file (bundled, scripted, random)."""
    from hoprover_env.agents.policies import BUNDLED

    if kind == "policy" and (spec in BUNDLED or spec in ("scripted", "random")):
        return None
    if kind == "controller" or spec.endswith(".py") or ".py:" in spec:
        file, _, attr = spec.rpartition(":") if ".py:" in spec else (spec, "", "")
        path = Path(file)
        return (f"{path.name}:{attr}" if attr else path.name), {path.name: path.read_bytes()}
    path = Path(spec)
    if path.is_dir():  # a run directory: its models, not its checkpoints or logs
        files = {
            f"{path.resolve().name}/{p.name}": p.read_bytes()
            for p in path.iterdir()
            if p.is_file()
            and (p.name.startswith(("best_model", "final_model")) or p.name == "vecnormalize.pkl")
        }
        return path.resolve().name, files
    if not path.exists():
        raise FileNotFoundError(f"model file not found: {path}")
    # a model .zip with its metadata and normalisation statistics beside it
    sibs = [
        path.with_suffix(".json"),
        path.with_name(path.stem + "_vecnormalize.pkl"),
        path.parent / "vecnormalize.pkl",
    ]
    files = {path.name: path.read_bytes()}
    files.update({p.name: p.read_bytes() for p in sibs if p.exists()})
    return path.name, files


def _materialize(shipped) -> str:
    """Write shipped policy files once per worker process; returns their folder."""
    relspec, files = shipped
    digest = hashlib.sha256(b"".join(k.encode() + v for k, v in sorted(files.items())))
    folder = (
        Path(tempfile.gettempdir()) / f"hoprover-policy-{os.getpid()}-{digest.hexdigest()[:16]}"
    )
    if not folder.exists():
        tmp = Path(tempfile.mkdtemp(dir=folder.parent))
        for name, data in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_bytes(data)
        os.replace(tmp, folder)
    return str(folder / relspec)


def _run_chunk(
    kind: str,
    spec: str,
    shipped,
    targets,
    first: int,
    control_dt: float,
    seed: int,
    batch: int,
    expected: dict,
):
    from hoprover_env.util.buildinfo import require

    require(expected)
    from hoprover_env.agents.policies import load_controller, load_policy
    from hoprover_env.evaluation.episodes import run_episodes

    if shipped is not None:
        spec = _materialize(shipped)
    policy = (
        load_controller(spec, control_dt)
        if kind == "controller"
        else load_policy(spec, control_dt=control_dt, seed=seed)
    )
    return [r.as_dict() for r in run_episodes(policy, targets, batch=batch, first_episode=first)]


def evaluate_on_ray(
    jobs: list[tuple[str, str, str]],
    targets,
    control_dt: float,
    seed: int,
    batch: int = 256,
    address: str | None = None,
    num_cpus: int | None = None,
    progress=None,
    ship_code: bool = False,
) -> dict[str, list]:
    """jobs: (kind 'policy' | 'controller', spec, row name). Returns row name -> the
    EpisodeResults in target order. `progress(name, episodes_done)` after each chunk."""
    from hoprover_env.training.ray_utils import init_ray
    from hoprover_env.util.buildinfo import build_info

    ray = init_ray(address, num_cpus, ship_code)
    expected = build_info()
    task = ray.remote(num_cpus=1)(_run_chunk)
    targets = np.asarray(targets, dtype=float)
    pending = {}
    for kind, spec, name in jobs:
        files = policy_files(kind, spec)
        shipped = None if files is None else ray.put(files)
        for first in range(0, len(targets), batch):
            ref = task.remote(
                kind,
                spec,
                shipped,
                targets[first : first + batch],
                first,
                control_dt,
                seed,
                batch,
                expected,
            )
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
