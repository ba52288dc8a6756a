"""Starting or joining Ray for sweep.py, evaluate.py --ray and examples/rllib_ppo.py.

Which code the tasks run (docs/SCALING.md, "Running on a cluster"):

* No address: a new local Ray on this machine, whose workers import this checkout; never
  one already running here (join that one with `--address auto`).
* An address (`host:port`, `ray://host:10001`, `auto`, or RAY_ADDRESS), by default: the
  tasks import the hoprover installed on each node (an editable install of a checkout,
  in a container image or by a setup step), and that checkout's research/ and train.py.
  Before any work, one probe task per node reports its version and source hash
  (hoprover_env.util.buildinfo); a node that differs from the driver stops the run with a
  message naming it. The installed package's numba cache (its __pycache__, or
  NUMBA_CACHE_DIR) survives Ray restarts, so `python -m hoprover_env.training.warm_cache` once per
  node warms it for good.
* `--ship-code`: Ray ships this checkout to every node as the job's working directory
  and the tasks import that copy instead, whatever the nodes have installed. For trying
  out uncommitted changes; the copy lives in Ray's session directory, so numba compiles
  it again on every node for every change and every Ray session.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# what a cluster job does not need shipped with the project's code (--ship-code)
EXCLUDES = ["runs/", ".venv/", ".git/", "benchmarks/figures/", "**/__pycache__/"]
SETUP_HOOK = "hoprover_env.util.buildinfo.use_checkout"
SHIP_CODE_HELP = (
    "ship this checkout to the cluster's nodes and run that copy, instead of "
    "the hoprover installed on them (numba then compiles on every node)"
)


class ClusterCodeError(RuntimeError):
    """A node runs other code than the driver, or cannot run hoprover's tasks at all."""


def cluster_address(address: str | None) -> str | None:
    """The address given, else RAY_ADDRESS, else None (a local Ray)."""
    return address or os.environ.get("RAY_ADDRESS") or None


def is_client(address: str | None) -> bool:
    """A Ray Client connection (ray://): this process is not on the cluster."""
    address = cluster_address(address)
    return bool(address) and address.startswith("ray://")


def runtime_env(ship_code: bool) -> dict:
    """The job's runtime_env on a cluster: the shipped checkout, or the installed one."""
    if ship_code:
        return {"working_dir": str(ROOT), "excludes": EXCLUDES}
    return {"worker_process_setup_hook": SETUP_HOOK}


def init_ray(address: str | None = None, num_cpus: int | None = None, ship_code: bool = False):
    """Join the cluster at `address` (or RAY_ADDRESS) and check that every node runs
    the driver's hoprover (ClusterCodeError if not); or start a local Ray on this
    machine, whose workers import this checkout (its numba cache included). Returns
    the ray module."""
    import ray

    if ray.is_initialized():
        return ray
    address = cluster_address(address)
    if address:
        ray.init(address=address, runtime_env=runtime_env(ship_code))
        check_nodes(ray)
    else:
        path = os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])
        # "local", not None: with no address, ray.init joins whatever cluster Ray's
        # address file (ray_current_cluster, in Ray's temp directory) names, without
        # checking that it is alive, so a cluster that was killed or is still running
        # elsewhere on the machine would capture (or hang) a run that asked for a Ray
        # of its own
        ray.init(
            address="local",
            num_cpus=num_cpus,
            include_dashboard=False,
            log_to_driver=False,
            runtime_env={"env_vars": {"PYTHONPATH": path}},
        )
    return ray


def check_nodes(ray, expected: dict | None = None) -> dict:
    """Run hoprover_env.util.buildinfo.probe on every live node; raise ClusterCodeError naming
    the nodes whose hoprover differs from `expected` (the driver's build_info()).
    Returns node id -> probe."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    from hoprover_env.util.buildinfo import build_info, mismatch, probe

    expected = expected or build_info()
    task = ray.remote(num_cpus=0, max_retries=0)(probe)
    nodes = [n for n in ray.nodes() if n["Alive"]]
    refs = {
        n["NodeID"]: task.options(
            scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False)
        ).remote()
        for n in nodes
    }
    seen, problems = {}, []
    for node in nodes:
        where = f"{node.get('NodeManagerAddress', '?')} (id {node['NodeID'][:8]})"
        try:
            seen[node["NodeID"]] = info = ray.get(refs[node["NodeID"]], timeout=300)
        except Exception as exc:  # noqa: BLE001 - whatever stops a node importing it
            problems.append(
                f"  node {where}: its workers cannot load hoprover_env.util.buildinfo: hoprover "
                f"is not installed there, or is older than this driver's "
                f"({type(exc).__name__}: {str(exc).strip().splitlines()[-1]})"
            )
            continue
        why = mismatch(expected, info)
        if why:
            problems.append(f"  node {where} on {info['host']}: {why}")
    if problems:
        raise ClusterCodeError(
            "the cluster does not run this hoprover:\n"
            + "\n".join(problems)
            + f"\nthis driver: hoprover {expected['version']}, source {expected['source']}, "
            f"commit {expected['commit']}, at {expected['path']}.\nInstall the same "
            "checkout on every node (pip install -e '.[ray]'), or pass --ship-code to run "
            "this checkout's copy there."
        )
    return seen


def head_node_strategy(ray):
    """A scheduling strategy that pins a task to the head node (where a ray:// client's
    work would otherwise run in the client server)."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    for node in ray.nodes():
        if node["Alive"] and "node:__internal_head__" in node.get("Resources", {}):
            return NodeAffinitySchedulingStrategy(node["NodeID"], soft=False)
    return "DEFAULT"


class StorageError(RuntimeError):
    """A sweep's storage that some node cannot see."""


def _sees(path: str) -> bool:
    return os.path.exists(path)


def check_storage(ray, storage: str) -> None:
    """A sweep's storage must be the same for every node: a URI (checked by Tune when
    it writes), or a directory every node mounts at the same path. Writes a marker
    file there and asks every live node whether it sees it (StorageError if not)."""
    import uuid

    if "://" in storage:
        return
    nodes = [n for n in ray.nodes() if n["Alive"]]
    if len(nodes) < 2:
        return
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    os.makedirs(storage, exist_ok=True)
    marker = os.path.join(storage, f".hoprover-storage-check-{uuid.uuid4().hex}")
    Path(marker).write_text("every node of the cluster must see this file\n")
    try:
        task = ray.remote(num_cpus=0, max_retries=0)(_sees)
        refs = [
            (
                n,
                task.options(
                    scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False)
                ).remote(marker),
            )
            for n in nodes
        ]
        blind = [
            n.get("NodeManagerAddress", "?") for n, ref in refs if not ray.get(ref, timeout=300)
        ]
    finally:
        os.remove(marker)
    if blind:
        raise StorageError(
            f"--out {storage} is not shared: node(s) {', '.join(blind)} do not see it. A "
            "sweep on a cluster needs storage every node reaches: a shared mount at the "
            "same path on every node (NFS, ...), or a URI such as s3://bucket/sweeps"
        )
