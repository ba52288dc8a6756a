"""Ray on a real multi-node cluster inside this process (ray.cluster_utils.Cluster, as
Ray's own tests do): every node is a raylet of its own, and losing one kills its
workers as a machine failure would. The head has no CPUs, so all work runs on the
worker nodes the tests add and remove. Each node imports this checkout (PYTHONPATH
set before the nodes start), as a node with hoprover installed would."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'hoprover[ray]'")
pytest.importorskip("optuna", reason="Optuna is not installed: pip install 'hoprover[ray]'")

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow

TINY = """\
algo: ppo
env_id: HopRover-v0
n_envs: 4
timesteps: {timesteps}
env: {{control_dt: 2.0, episode_time: 60.0}}
policy: {{net_arch: [16, 16], log_std_init: -2.0}}
hyperparams: {{n_steps: 32, batch_size: 64, n_epochs: 1}}
evaluation: {{freq: 128, episodes: {episodes}, seed: 7}}
checkpoint: {{freq: 128}}
"""


@pytest.fixture(scope="module")
def cluster():
    from ray.cluster_utils import Cluster

    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([old] if old else []))
    sys.path.insert(0, str(ROOT))
    c = Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
    try:
        yield c
    finally:
        ray.shutdown()
        c.shutdown()
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old


def _workers(c):
    return [n for n in c.worker_nodes]


def _ensure_workers(c, n):
    while len(_workers(c)) < n:
        c.add_node(num_cpus=1)
    c.wait_for_nodes()


def _strip(results):
    """The results' fields that do not depend on where or when they ran."""
    drop = ("wall_time", "policy")
    return [{k: v for k, v in r.as_dict().items() if k not in drop} for r in results]


def test_evaluation_that_loses_a_node_gives_the_local_table(cluster):
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets
    from hoprover_env.training.ray_eval import evaluate_on_ray

    _ensure_workers(cluster, 2)
    targets = seeded_targets(24, 11)
    jobs = [("policy", "scratch", "scratch"), ("policy", "random", "random")]
    lost = []

    def progress(name, done):  # the first chunk back: a node dies mid-way
        if not lost:
            lost.append(_workers(cluster)[0])
            cluster.remove_node(lost[0], allow_graceful=False)

    res = evaluate_on_ray(
        jobs, targets, 0.5, 3, batch=4, address=cluster.address, progress=progress
    )
    assert lost  # a node was lost mid-way
    for spec, name in (("scratch", "scratch"), ("random", "random")):
        local = run_episodes(load_policy(spec, control_dt=0.5, seed=3), targets, batch=4)
        assert _strip(res[name]) == _strip(local)


def _sweep(cfg: Path, out: Path, name: str, address: str, *extra):
    return [
        sys.executable,
        str(ROOT / "sweep.py"),
        "--config",
        str(cfg),
        "--name",
        name,
        "--out",
        str(out),
        "--address",
        address,
        *extra,
    ]


def _results(trial_dir: Path) -> list[dict]:
    path = trial_dir / "result.json"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def _wait_for(pred, proc, timeout=400, what="the sweep"):
    deadline = time.time() + timeout
    while time.time() < deadline:
        found = pred()
        if found:
            return found
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"{what} ended early ({proc.returncode}): {err[-3000:]}")
        time.sleep(0.2)
    pytest.fail(f"timed out waiting for {what}")


def test_sweep_that_loses_the_node_of_a_trial_restores_it_elsewhere(cluster, tmp_path):
    _ensure_workers(cluster, 2)
    cfg = tmp_path / "tiny.yaml"
    # long enough that the trial cannot finish between the checkpoint the test sees in
    # result.json and the loss of its node (at 1536 steps it did, 3 runs in 4, once the
    # compile cache was warm)
    cfg.write_text(TINY.format(timesteps=3072, episodes=8))
    out = tmp_path / "sweeps"
    proc = subprocess.Popen(
        _sweep(
            cfg, out, "lost", cluster.address, "--seeds", "3-4", "--samples", "1", "--grace", "20"
        ),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:

        def trial_with_checkpoint():  # the trial's node, once a checkpoint is stored
            # Tune has registered a checkpoint for certain once the row after it is in
            # result.json (the trial waits in tune.report until Tune has handled the save):
            # so the second-to-last checkpoint row counts. It must also hold trained steps:
            # the checkpoint reported at evaluation k is the trainer's from evaluation k-1,
            # and PPO's checkpoint counts only steps trained on (the one at 128 steps, taken
            # as the first rollout ends, holds 0), so the first checkpoint with steps is
            # reported at 384. Restored from an earlier one, the trial resumes at 0 steps
            # and the check below cannot tell a restore from a fresh start (1 CI run in 5
            # with two checkpoint rows).
            for d in (out / "lost").glob("trainable_*"):
                rows = [r for r in _results(d) if r.get("checkpoint_dir_name")]
                if len(rows) >= 2 and rows[-2]["timesteps"] >= 3 * 128:
                    return d, rows[-1]["node"]

        trial, node_id = _wait_for(trial_with_checkpoint, proc)
        node = next(n for n in _workers(cluster) if n.node_id == node_id)
        cluster.remove_node(node, allow_graceful=False)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr[-3000:]
    rows = _results(trial)
    every = list(range(0, 3073, 128))
    # the trial's own record, in its last checkpoint: every evaluation, once
    final = sorted(trial.glob("checkpoint_*"))[-1] / "run" / "evaluations.csv"
    assert [int(line.split(",")[0]) for line in final.read_text().splitlines()[1:]] == every
    # Tune counted each evaluation once (a restart continues its count) ...
    assert rows[-1]["training_iteration"] == len(every)
    assert {r["seed"] for r in rows} == {3}  # trial 0: SEEDS[0]
    assert rows[-1]["node"] != node_id  # it finished elsewhere
    lost_at = max(i for i, r in enumerate(rows) if r["node"] == node_id)
    # ... and its log lists each once, but for the one Tune delivers at least once: the
    # evaluation the lost node reported last, when the node died before Tune had stored
    # that report's checkpoint. Tune then restores the one before, the trial trains those
    # steps again and reports that evaluation anew, under the same iteration (seen once
    # in CI). The log may also lack the rows between its last sync to storage and the
    # node loss: Tune reloads result.json from storage on a restart.
    last = rows[lost_at]
    again = [r for r in rows[lost_at + 1 :] if r["timesteps"] <= last["timesteps"]]
    assert [(r["timesteps"], r["training_iteration"]) for r in again] in (
        [],
        [(last["timesteps"], last["training_iteration"])],
    )
    steps = [r["timesteps"] for r in rows[: lost_at + 1] + rows[lost_at + 1 + len(again) :]]
    assert steps == sorted(set(steps)) and set(steps) <= set(every) and steps[-1] == every[-1]
    resumed = [r["resumed_at"] for r in rows[lost_at + 1 :]]
    assert resumed[0] > 0 and resumed[0] in every  # from a checkpoint, not anew
    assert (out / "lost" / "best_config.yaml").exists()


def test_interrupted_and_resumed_sweep_matches_an_uninterrupted_one(cluster, tmp_path):
    _ensure_workers(cluster, 1)
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY.format(timesteps=512, episodes=4))
    out = tmp_path / "sweeps"
    common = [
        "--seeds",
        "0-1",
        "--search",
        "learning_rate=loguniform(1e-5,1e-3)",
        "--samples",
        "2",
        "--grace",
        "20",
    ]
    whole = subprocess.run(
        _sweep(cfg, out, "whole", cluster.address, *common),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert whole.returncode == 0, whole.stderr[-3000:]
    cmd = _sweep(cfg, out, "cut", cluster.address, *common)
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        _wait_for(lambda: list((out / "cut").glob("trainable_*/checkpoint_*")), proc)
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, stderr[-3000:]
    assert not (out / "cut" / "best_config.yaml").exists()
    assert "interrupted" in stderr and shlex.join(cmd[2:]) in stderr  # how to resume
    again = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]

    def record(name):
        """trial k -> (its evaluations.csv steps, Tune's count of its evaluations, the
        steps in Tune's log)"""
        by_index = {}
        for d in (out / name).glob("trainable_*"):
            rows = _results(d)
            k = rows[-1]["index"]
            assert {r["seed"] for r in rows} == {[0, 1][k % 2]}  # SEEDS[k mod n]
            final = sorted(d.glob("checkpoint_*"))[-1] / "run" / "evaluations.csv"
            csv = [int(line.split(",")[0]) for line in final.read_text().splitlines()[1:]]
            by_index[k] = (
                csv,
                rows[-1]["training_iteration"],
                sorted({r["timesteps"] for r in rows}),
            )
        return by_index

    every = [0, 128, 256, 384, 512]
    assert record("cut") == record("whole") == {0: (every, 5, every), 1: (every, 5, every)}
    best = out / "cut" / "best_config.yaml"
    from hoprover_env.training.sb3_agents import load_config

    loaded = load_config(best)
    assert loaded["timesteps"] == 512 and 1e-5 <= loaded["hyperparams"]["learning_rate"] <= 1e-3
    run = subprocess.run(
        [
            sys.executable,
            str(ROOT / "train.py"),
            "--config",
            str(best),
            "--out",
            str(tmp_path / "retrain"),
            "--timesteps",
            "128",
            "--no-progress",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]


def test_a_run_without_an_address_starts_a_ray_of_its_own_beside_a_running_one(cluster):
    # the cluster has written Ray's address file, as `ray start` does and as a killed
    # cluster leaves it behind: a run that asked for no address must not join it
    code = (
        "from hoprover_env.training.ray_utils import init_ray\n"
        "ray = init_ray(num_cpus=1)\n"
        "print(ray.get_runtime_context().gcs_address)\n"
        "ray.shutdown()\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    r = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.split()[-1] != cluster.address
