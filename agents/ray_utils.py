"""Starting or joining Ray for sweep.py, evaluate.py --ray and examples/rllib_ppo.py."""
from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# what a cluster job does not need shipped with the project's code
EXCLUDES = ["runs/", ".venv/", ".git/", "benchmarks/figures/", "**/__pycache__/"]


def init_ray(address: str | None = None, num_cpus: int | None = None):
    """Join the cluster at `address` (or RAY_ADDRESS), shipping this checkout as the job's
    working directory (hoprover itself must be installed on the nodes: pip install
    'hoprover[ray]'); or start a local Ray on this machine, whose workers import the
    checkout directly (its numba cache included). Returns the ray module."""
    import ray
    if ray.is_initialized():
        return ray
    address = address or os.environ.get("RAY_ADDRESS")
    if address:
        ray.init(address=address, runtime_env={"working_dir": str(ROOT), "excludes": EXCLUDES})
    else:
        path = os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])
        ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False,
                 runtime_env={"env_vars": {"PYTHONPATH": path}})
    return ray
