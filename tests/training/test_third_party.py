"""Third-party front-ends: RL Baselines3 Zoo's hyperparameter files (hyperparams/*.yml)
name registered ids and build and train SB3's PPO the way the zoo builds it, the zoo
itself trains, evaluates and enjoys with them as its users run it (no env arguments on
the command line) where rl_zoo3 is installed, and CleanRL's wrapper stack (gymnasium
1.x signatures) runs on HopRover-v0 and reports episode statistics."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import hoprover_env  # noqa: F401  (registers the envs)
from hoprover_env.tasks.config import TRAINING_STARTS

# the fast tier (pytest -m "not slow") leaves this file out:
# trains with the RL Zoo and CleanRL's wrappers
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
HYPERPARAMS = ROOT / "hyperparams"
ZOO_FILE = HYPERPARAMS / "ppo.yml"
# keys the zoo consumes itself; everything else goes to the algorithm's constructor
ZOO_ONLY = {
    "n_envs",
    "n_timesteps",
    "policy",
    "env_kwargs",
    "normalize",
    "env_wrapper",
    "policy_kwargs",
}


# env arguments that shape only the training episodes' starts (evaluation starts at rest)
TRAINING_ONLY = set(TRAINING_STARTS)


def zoo_hyperparams() -> dict:
    return yaml.safe_load(ZOO_FILE.read_text())["HopRoverRL-v0"]


@pytest.mark.parametrize("path", sorted(HYPERPARAMS.glob("*.yml")), ids=lambda p: p.stem)
def test_hyperparams_files_name_registered_ids_and_carry_no_env_kwargs(path):
    """The zoo gives a file's env_kwargs to its training envs only, never to the env it
    evaluates and picks the best model on; so each entry's settings must be its id's
    defaults, and env_kwargs may hold only a training start distribution (flight_start),
    which evaluation must not have."""
    entries = yaml.safe_load(path.read_text())
    assert entries
    for env_id, hp in entries.items():
        assert env_id in gym.registry, f"{path.name}: {env_id} is not a registered id"
        if "env_kwargs" in hp:
            kwargs = dict(hp["env_kwargs"])
            assert set(kwargs) <= TRAINING_ONLY, f"{path.name}: {env_id} passes {kwargs}"
        assert {"n_timesteps", "policy"} <= set(hp)
        if "gamma" in hp:  # the shaping's discount must be the learner's
            assert gym.spec(env_id).kwargs.get("gamma") == hp["gamma"], (path.name, env_id)


def test_zoo_file_trains_sb3_ppo_as_the_zoo_would(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize
    from torch import nn

    hp = zoo_hyperparams()
    assert hp["policy"] == "MlpPolicy" and "env_wrapper" not in hp
    # the zoo evaluates these two strings (policy_kwargs with torch.nn in scope)
    norm = ast.literal_eval(hp["normalize"])
    policy_kwargs = eval(hp["policy_kwargs"], {"nn": nn, "dict": dict})  # noqa: S307
    algo_kwargs = {k: v for k, v in hp.items() if k not in ZOO_ONLY}
    algo_kwargs.update(n_steps=64, batch_size=128)  # a tiny budget, same code path
    venv = VecNormalize(make_vec_env("HopRoverRL-v0", n_envs=2), **norm)
    assert venv.venv.envs[0].unwrapped.config.control_dt == 2.0
    model = PPO(hp["policy"], venv, policy_kwargs=policy_kwargs, seed=0, **algo_kwargs)
    model.learn(256)
    assert model.num_timesteps >= 256
    assert np.isclose(float(model.policy.log_std.detach().mean()), -2.0, atol=0.1)
    act, _ = model.predict(venv.reset(), deterministic=True)
    assert act.shape == (2, 1) and np.all(np.isfinite(act))


def _zoo_runs():
    """(algorithm, id) for each hyperparams file: its torque-level entry where it has one
    (where the zoo's evaluation env would otherwise differ in control period), else its
    first."""
    for path in sorted(HYPERPARAMS.glob("*.yml")):
        ids = list(yaml.safe_load(path.read_text()))
        torque = [i for i in ids if i.startswith("HopRoverRL-")]
        yield path.stem, torque[0] if torque else ids[0]


@pytest.mark.parametrize("algo, env_id", list(_zoo_runs()))
def test_zoo_trains_evaluates_and_enjoys_as_its_users_run_it(tmp_path, algo, env_id):
    """The zoo's commands as hyperparams/*.yml give them, on a short budget: no env
    arguments on the command line. On HopRoverRL-v0 the zoo's evaluation env
    (EvalCallback: the best model and its evaluations) must be the training env, i.e.
    the id's defaults: a 2 s control period, so at most 300 steps in the 600 s episode
    (HopRover-v0's default 0.5 s would allow 1200)."""
    pytest.importorskip("rl_zoo3", reason="RL Baselines3 Zoo is not installed: pip install rl_zoo3")
    common = [
        "--algo",
        algo,
        "--env",
        env_id,
        "--gym-packages",
        "hoprover_env",
        "-f",
        str(tmp_path / "logs"),
    ]
    # a short budget: the zoo's own options, no change to the file's hyperparameters
    # beyond when off-policy learning starts (so that this budget trains at all)
    short = ["-n", "1024", "--eval-freq", "512", "--eval-episodes", "2", "--seed", "0"]
    if algo != "ppo":
        short += ["-params", "learning_starts:256"]
    subprocess.run(
        [
            sys.executable,
            "-m",
            "rl_zoo3.train",
            *common,
            "--conf-file",
            str(HYPERPARAMS / f"{algo}.yml"),
            *short,
        ],
        check=True,
        cwd=tmp_path,
        timeout=600,
    )
    run = tmp_path / "logs" / algo / f"{env_id}_1"
    evals = np.load(run / "evaluations.npz")
    assert evals["ep_lengths"].size and (run / "best_model.zip").exists()
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "rl_zoo3.enjoy",
            *common,
            "--exp-id",
            "1",
            "--load-best",
            "-n",
            "400",
            "--no-render",
        ],
        check=True,
        cwd=tmp_path,
        timeout=600,
        capture_output=True,
        text=True,
    )
    lengths = [
        int(line.split()[-1])
        for line in out.stdout.splitlines()
        if line.startswith("Episode Length")
    ]
    assert lengths
    if env_id.startswith("HopRoverRL-"):
        assert evals["ep_lengths"].max() <= 300 and max(lengths) <= 300


def test_cleanrl_wrapper_stack_runs_on_gymnasium_1():
    """CleanRL's ppo_continuous_action wraps each env like this; on gymnasium 1.x the
    observation clip needs the observation space as a third argument, and episode
    statistics arrive as arrays with a mask (infos['final_info'] under SAME_STEP)."""

    def make():
        env = gym.make("HopRover-v0", control_dt=10.0)
        env = gym.wrappers.FlattenObservation(env)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        env = gym.wrappers.TransformObservation(
            env, lambda obs: np.clip(obs, -10, 10), env.observation_space
        )
        env = gym.wrappers.NormalizeReward(env, gamma=0.99)
        return gym.wrappers.TransformReward(env, lambda r: np.clip(r, -10, 10))

    envs = gym.vector.SyncVectorEnv([make, make], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
    envs.reset(seed=1)
    rng = np.random.default_rng(0)
    returns = []
    for _ in range(200):
        obs, rew, term, trunc, infos = envs.step(rng.uniform(-0.02, 0.02, (2, 1)))
        assert np.all(np.abs(obs) <= 10) and np.all(np.isfinite(rew))
        if "final_info" in infos:
            done = np.nonzero(infos["final_info"]["_episode"])[0]
            returns.extend(infos["final_info"]["episode"]["r"][done])
        if len(returns) >= 2:
            break
    assert len(returns) >= 2 and np.all(np.isfinite(returns))


def _zoo_entry_as_config(algo: str, env_id: str, hp: dict) -> dict:
    """A zoo entry in train.py's terms: what the two must agree on."""
    from torch import nn

    from hoprover_env.training.sb3_agents import ACTIVATIONS

    hp = dict(hp)
    hp.pop("env_kwargs", None)  # compared with the config's env above
    norm = ast.literal_eval(hp.pop("normalize", "{}"))
    pk = eval(hp.pop("policy_kwargs", "dict()"), {"nn": nn, "dict": dict})  # noqa: S307
    if "activation_fn" in pk:
        names = {getattr(nn, v): k for k, v in ACTIVATIONS.items()}
        pk["activation_fn"] = names[pk["activation_fn"]]
    if "noise_std" in hp:  # the zoo's Gaussian action noise
        assert hp.pop("noise_type") == "normal"
        hp["action_noise"] = hp.pop("noise_std")
    return {
        "algo": algo,
        "n_envs": hp.pop("n_envs"),
        "timesteps": int(hp.pop("n_timesteps")),
        "policy": pk,
        "obs": norm.get("norm_obs", True),
        "reward": norm.get("norm_reward", True),
        "hyperparams": {k: v for k, v in hp.items() if k != "policy"},
    }


def _config_of(path) -> dict:
    from hoprover_env.training.sb3_agents import load_config

    cfg = load_config(path)
    return {
        "algo": cfg["algo"],
        "n_envs": cfg["n_envs"],
        "timesteps": cfg["timesteps"],
        "policy": cfg["policy"],
        "obs": cfg["normalize"]["obs"],
        "reward": cfg["normalize"]["reward"],
        "hyperparams": dict(cfg["hyperparams"]),
    }


def _rollout_size(cfg: dict) -> dict:
    """PPO's settings with the rollout as its size: the zoo steps single envs in a
    DummyVecEnv, so its files use fewer envs for more steps each (32 x 1024 for
    train.py's 128 x 256); an off-policy learner's envs per update must match."""
    if cfg["algo"] in ("ppo", "recurrentppo"):
        cfg = {**cfg, "hyperparams": dict(cfg["hyperparams"])}
        cfg["n_envs"] *= cfg["hyperparams"].pop("n_steps")
    return cfg


@pytest.mark.parametrize("path", sorted(HYPERPARAMS.glob("*.yml")), ids=lambda p: p.stem)
def test_each_zoo_entry_is_a_train_py_config(path):
    """hyperparams/ALGO.yml and configs/ hold the same settings twice, in the zoo's words
    and in train.py's: each zoo entry must equal a config of that algorithm whose env is
    the entry's id, its defaults included."""
    from hoprover_env.envs.registry import config_class, task
    from hoprover_env.training.sb3_agents import env_kwargs, load_config

    configs = [
        p
        for p in (ROOT / "configs").glob("*.yaml")
        if yaml.safe_load(p.read_text()).get("algo") == path.stem
    ]
    for env_id, hp in yaml.safe_load(path.read_text()).items():
        training = dict(hp.get("env_kwargs", {}))
        want = config_class(env_id)(**{**task(env_id).kwargs, **training})
        matches = []
        for p in configs:
            cfg = load_config(p)
            if (
                config_class(cfg["env_id"]) is type(want)
                and config_class(cfg["env_id"])(**env_kwargs(cfg)) == want
            ):
                matches.append(p)
        assert matches, f"{path.name}: no configs/*.yaml trains {path.stem} on {env_id}'s settings"
        assert _rollout_size(_zoo_entry_as_config(path.stem, env_id, hp)) in [
            _rollout_size(_config_of(p)) for p in matches
        ], f"{path.name}: {env_id} differs from {[p.name for p in matches]}"
