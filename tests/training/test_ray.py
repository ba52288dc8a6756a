"""Ray: RLlib on the native vector env, evaluate.py --ray, a warm numba cache in a new
worker, and the checks of the code a cluster runs. A local Ray limited to 2 CPUs and
tiny budgets; sweeps and lost nodes are in test_ray_cluster.py. Skipped, with the
reason, where Ray is not installed (pip install 'hoprover[ray]'); CI installs it."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'hoprover[ray]'")
pytest.importorskip("ray.rllib", reason="RLlib is not installed: pip install 'hoprover[ray]'")
pytest.importorskip("optuna", reason="Optuna is not installed: pip install 'hoprover[ray]'")

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def local_ray():
    sys.path.insert(0, str(ROOT))
    from hoprover_env.training.ray_utils import init_ray

    init_ray(num_cpus=2)
    yield ray
    ray.shutdown()


def test_rllib_ppo_trains_an_iteration_on_the_native_vector_env(local_ray):
    sys.path.insert(0, str(ROOT / "examples"))
    import rllib_ppo

    from hoprover_env import HopRoverVectorEnv
    from hoprover_env.envs.rllib import make_env

    # what the EnvRunners build in vector_entry_point mode: the native vector env
    assert isinstance(make_env({"num_envs": 3, "control_dt": 2.0}), HopRoverVectorEnv)
    # 10 s episodes at a 2 s control period: 5 steps, so episodes end within the iteration
    config = rllib_ppo.build_config(
        env_runners=2,
        envs_per_runner=4,
        env_config={"episode_time": 10.0},
        train_batch=64,
        minibatch=32,
        epochs=1,
    )
    assert config.gym_env_vectorize_mode == "vector_entry_point"
    algo = config.build_algo()
    try:
        result = algo.train()
        kinds = algo.env_runner_group.foreach_env_runner(
            lambda r: type(r.env.unwrapped).__name__, local_env_runner=False
        )
    finally:
        algo.stop()
    assert kinds == ["HopRoverVectorEnv", "HopRoverVectorEnv"]
    s = rllib_ppo.summary(result)
    assert s["iteration"] == 1 and s["env_steps"] >= 64
    assert s["episodes"] > 0 and math.isfinite(s["return_mean"])
    assert 0.0 <= s["success"] <= 1.0  # the judge's verdict, as an RLlib metric


def _fresh_worker_evaluates():
    """In a Ray worker: evaluate every kind of policy, then count numba's compiles."""
    import numba

    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets
    from hoprover_env.training.warm_cache import compile_counts

    for name in ("scratch", "hop", "scripted", "random"):
        run_episodes(load_policy(name, control_dt=0.5), seeded_targets(3, 5), batch=2)
    counts = compile_counts()

    @numba.njit
    def never_cached(x):  # the count sees a compile in this process
        return x + 1

    never_cached(1)
    return counts, compile_counts()[0], os.getpid()


def test_a_worker_started_after_the_warm_up_compiles_nothing(local_ray):
    warm = subprocess.run(
        [sys.executable, "-m", "hoprover_env.training.warm_cache"],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert warm.returncode == 0, warm.stderr[-3000:]
    assert "compiled" in warm.stdout and "loaded" in warm.stdout
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    # a runtime_env of its own: Ray starts a new worker process for this task
    fresh = ray.remote(num_cpus=1)(_fresh_worker_evaluates).options(
        runtime_env={
            "env_vars": {"PYTHONPATH": str(ROOT), "HOPROVER_TEST_WORKER": str(time.time())}
        }
    )
    (compiled, loaded), then, pid = ray.get(fresh.remote())
    assert pid != os.getpid()
    assert list(then) == [f"{__name__}._fresh_worker_evaluates.<locals>.never_cached"]
    assert compiled == {}, f"the worker compiled {compiled}"
    assert loaded > 0  # it ran the kernels, from the cache


def test_evaluate_on_ray_equals_the_local_run_episode_for_episode(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    common = [
        sys.executable,
        str(ROOT / "evaluate.py"),
        "--policy",
        "scripted",
        "--policy",
        "random",
        "--policy",
        "scratch",
        "--episodes",
        "24",
        "--batch",
        "8",
        "--no-progress",
    ]
    outs = {}
    for label, extra in (("local", []), ("ray", ["--ray"])):
        path = tmp_path / f"{label}.json"
        r = subprocess.run(
            common + ["--json", str(path)] + extra,
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
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
    from hoprover_env.evaluation.episodes import seeded_targets
    from hoprover_env.training.ray_eval import evaluate_on_ray

    targets = seeded_targets(10, 3)
    seen = []
    res = evaluate_on_ray(
        [("policy", "random", "random")],
        targets,
        0.5,
        0,
        batch=4,
        progress=lambda name, k: seen.append(k),
    )
    assert len(seen) == 3 and max(seen) == 10  # ceil(10 / 4) tasks, all counted
    assert [r.episode for r in res["random"]] == list(range(10))
    assert np.allclose([r.target_x for r in res["random"]], targets)


def test_a_node_with_other_code_is_refused_by_name(local_ray):
    from hoprover_env.training.ray_utils import ClusterCodeError, check_nodes
    from hoprover_env.util.buildinfo import build_info

    seen = check_nodes(ray)  # this checkout everywhere: accepted
    assert [p["source"] for p in seen.values()] == [build_info()["source"]]
    other = {**build_info(), "source": "0123456789ab", "commit": "feedbeef"}
    with pytest.raises(ClusterCodeError, match="--ship-code") as err:
        check_nodes(ray, other)
    assert build_info()["source"] in str(err.value) and "0123456789ab" in str(err.value)


def test_trials_get_the_seeds_in_turn():
    # trial k trains with SEEDS[k mod n]; Tune's directory names count from 1 with a search
    # algorithm and from 0 without one (the names below are Ray 2.60's)
    from hoprover_env.training.sweep import trial_index

    searched = [
        "trainable_715df97f_2_learning_rate=0.0003_2026-11-23_21-47-55",
        "trainable_afe486ee_1_learning_rate=0.0001_2026-11-23_21-47-52",
    ]
    assert [trial_index(d, d.split("_")[1], 1) for d in searched] == [1, 0]
    plain = [
        "trainable_5e0a1_00000_0_2026-11-23_21-47-52",
        "trainable_5e0a1_00001_1_2026-11-23_21-47-53",
    ]
    assert [trial_index(d, "_".join(d.split("_")[1:3]), 0) for d in plain] == [0, 1]


def test_asha_stops_no_trial_on_its_untrained_evaluation():
    # the evaluation at step 0 is reported as iteration 1 and scores the untrained policy,
    # which differs by seed alone: ASHA's first rung must come after a trained one
    from hoprover_env.training.sweep import asha_grace, parse_args

    assert [asha_grace(g, 10) for g in (1, 2, 9, 20)] == [2, 3, 10, 10]
    with pytest.raises(SystemExit):
        parse_args(["--config", "configs/ppo_hop.yaml", "--grace", "0"])


def test_policy_files_travel_with_the_tasks(tmp_path):
    # a run directory on the driver only: its model files are read here, rebuilt there
    from hoprover_env.agents.policies import BUNDLED, BUNDLED_DIR
    from hoprover_env.training.ray_eval import _materialize, policy_files

    run = tmp_path / "myrun"
    run.mkdir()
    stem = BUNDLED_DIR / BUNDLED["scratch"]
    for suffix in (".zip", ".json", "_vecnormalize.pkl"):
        src = stem.with_name(stem.name + suffix)
        if src.exists():
            (run / f"best_model{suffix}").write_bytes(src.read_bytes())
    (run / "evaluations.csv").write_text("not a model")
    assert policy_files("policy", "scratch") is None
    relspec, files = policy_files("policy", str(run))
    assert relspec == "myrun" and "myrun/evaluations.csv" not in files
    where = _materialize((relspec, files))
    assert Path(where).name == "myrun" and Path(where) != run
    from hoprover_env.agents.policies import load_policy

    a, b = load_policy(str(run)), load_policy(where)
    assert a.name == b.name == "myrun"
    obs = np.zeros((2, a.model.observation_space.shape[0]), dtype=np.float32)
    assert np.array_equal(
        a.model.predict(obs, deterministic=True)[0], b.model.predict(obs, deterministic=True)[0]
    )


def test_rllib_creator_builds_every_registered_task():
    import gymnasium as gym

    from hoprover_env import ENVS, env_class, vector_env_class
    from hoprover_env.envs.rllib import make_env

    for env_id, spec in ENVS.items():
        single = make_env({"env_id": env_id})
        vec = make_env({"env_id": env_id, "num_envs": 2})
        assert type(single) is env_class(env_id) and type(vec) is vector_env_class(env_id)
        assert single.observation_space == gym.make(env_id).observation_space
        for key, value in spec.kwargs.items():  # the contest's fixed target
            assert getattr(single.config, key) == value
    with pytest.raises(ValueError, match="unknown hoprover env id 'HopRover-v9'"):
        make_env({"env_id": "HopRover-v9"})
