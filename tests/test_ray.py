"""Ray: RLlib on the native vector env, Tune sweeps of train.py's trainer (with resume),
and evaluate.py --ray. A local Ray limited to 2 CPUs and tiny budgets. Skipped, with the
reason, where Ray is not installed (pip install 'hoprover[ray]'); CI installs it."""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'hoprover[ray]'")
pytest.importorskip("ray.rllib", reason="RLlib is not installed: pip install 'hoprover[ray]'")
pytest.importorskip("optuna", reason="Optuna is not installed: pip install 'hoprover[ray]'")

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def local_ray():
    sys.path.insert(0, str(ROOT))
    from agents.ray_utils import init_ray
    init_ray(num_cpus=2)
    yield ray
    ray.shutdown()


def test_rllib_ppo_trains_an_iteration_on_the_native_vector_env(local_ray):
    sys.path.insert(0, str(ROOT / "examples"))
    import rllib_ppo
    from hoprover_env import HopRoverVectorEnv
    from hoprover_env.rllib import make_env
    # what the EnvRunners build in vector_entry_point mode: the native vector env
    assert isinstance(make_env({"num_envs": 3, "control_dt": 2.0}), HopRoverVectorEnv)
    # 10 s episodes at a 2 s control period: 5 steps, so episodes end within the iteration
    config = rllib_ppo.build_config(env_runners=2, envs_per_runner=4,
                                    env_config={"episode_time": 10.0}, train_batch=64,
                                    minibatch=32, epochs=1)
    assert config.gym_env_vectorize_mode == "vector_entry_point"
    algo = config.build_algo()
    try:
        result = algo.train()
        kinds = algo.env_runner_group.foreach_env_runner(
            lambda r: type(r.env.unwrapped).__name__, local_env_runner=False)
    finally:
        algo.stop()
    assert kinds == ["HopRoverVectorEnv", "HopRoverVectorEnv"]
    s = rllib_ppo.summary(result)
    assert s["iteration"] == 1 and s["env_steps"] >= 64
    assert s["episodes"] > 0 and math.isfinite(s["return_mean"])
    assert 0.0 <= s["success"] <= 1.0            # the judge's verdict, as an RLlib metric


TINY = """\
algo: ppo
env_id: HopRover-v0
n_envs: 4
timesteps: 256
env: {control_dt: 2.0, episode_time: 60.0}
policy: {net_arch: [16, 16], log_std_init: -2.0}
hyperparams: {n_steps: 32, batch_size: 64, n_epochs: 1}
evaluation: {freq: 128, episodes: 4, seed: 7}
checkpoint: {freq: 128}
"""


def _sweep_cmd(cfg: Path, out: Path, samples: int = 4):
    return [sys.executable, str(ROOT / "sweep.py"), "--config", str(cfg), "--seeds", "0-1",
            "--search", "learning_rate=loguniform(1e-5,1e-3)", "--samples", str(samples),
            "--name", "tiny", "--out", str(out), "--num-cpus", "2", "--grace", "1"]


def _finished(trials: Path) -> dict:
    """trial dir -> (final model mtime, evaluations) of the trials that completed."""
    done = {}
    for d in sorted(trials.glob("*")) if trials.exists() else []:
        final = d / "final_model.json"
        if final.exists():
            done[d.name] = (final.stat().st_mtime_ns, (d / "evaluations.csv").read_text())
    return done


def test_sweep_resumes_after_a_kill_and_writes_a_best_config_train_accepts(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY)
    out = tmp_path / "sweeps"
    trials = out / "tiny" / "trials"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(_sweep_cmd(cfg, out), cwd=ROOT, env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 400
    try:
        while time.time() < deadline and proc.poll() is None and not _finished(trials):
            time.sleep(0.2)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    before = _finished(trials)
    assert before, "no trial finished before the kill"
    assert len(before) < 4, "the sweep ended before the kill: nothing left to resume"
    rerun = subprocess.run(_sweep_cmd(cfg, out), cwd=ROOT, env=env, capture_output=True,
                           text=True, timeout=600)
    assert rerun.returncode == 0, rerun.stderr[-3000:]
    after = _finished(trials)
    # finished trials were not run again: same files, untouched
    for name, state in before.items():
        assert after.get(name) == state, name
    assert len(after) == 4
    assert "trial" in rerun.stdout and "score" in rerun.stdout      # the table
    best = out / "tiny" / "best_config.yaml"
    from agents.sb3_agents import load_config
    loaded = load_config(best)
    assert loaded["timesteps"] == 256 and 1e-5 <= loaded["hyperparams"]["learning_rate"] <= 1e-3
    # train.py accepts it unchanged
    run = subprocess.run([sys.executable, str(ROOT / "train.py"), "--config", str(best),
                          "--out", str(tmp_path / "retrain"), "--timesteps", "128",
                          "--no-progress"], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]


def test_evaluate_on_ray_equals_the_local_run_episode_for_episode(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    common = [sys.executable, str(ROOT / "evaluate.py"), "--policy", "scripted", "--policy",
              "random", "--policy", "scratch", "--episodes", "24", "--batch", "8",
              "--no-progress"]
    outs = {}
    for label, extra in (("local", []), ("ray", ["--ray"])):
        path = tmp_path / f"{label}.json"
        r = subprocess.run(common + ["--json", str(path)] + extra, cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        outs[label] = (json.loads(path.read_text()), r.stdout)

    def strip(doc):
        return [{k: v for k, v in e.items() if k != "wall_time"} for e in doc["episodes"]]
    local, remote = outs["local"][0], outs["ray"][0]
    assert len(local["episodes"]) == 72
    assert strip(local) == strip(remote)
    for name in ("scripted", "random", "scratch"):
        a = {k: v for k, v in local["summary"][name].items() if k != "wall_per_episode"}
        b = {k: v for k, v in remote["summary"][name].items() if k != "wall_per_episode"}
        assert a == b


def test_evaluate_chunks_follow_the_local_batches(local_ray):
    # the split itself: chunks of one batch each, merged in target order
    from agents.ray_eval import evaluate_on_ray
    from agents.evaluation import seeded_targets
    targets = seeded_targets(10, 3)
    seen = []
    res = evaluate_on_ray([("policy", "random", "random")], targets, 0.5, 0, batch=4,
                          progress=lambda name, k: seen.append(k))
    assert len(seen) == 3 and max(seen) == 10       # ceil(10 / 4) tasks, all counted
    assert [r.episode for r in res["random"]] == list(range(10))
    assert np.allclose([r.target_x for r in res["random"]], targets)
