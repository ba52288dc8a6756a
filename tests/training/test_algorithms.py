"""train.py's algorithms from sb3-contrib (TQC, CrossQ, RecurrentPPO): a tiny run of each
trains, checkpoints, resumes and loads back to play judged episodes; their own config
keys are checked; a recurrent policy keeps its memory per episode slot."""

import json
import math
import shutil

import numpy as np
import pytest
import yaml

pytest.importorskip("sb3_contrib")

from hoprover_env.agents.policies import SB3Policy, load_sb3  # noqa: E402
from hoprover_env.evaluation.episodes import run_episodes  # noqa: E402
from hoprover_env.training import train  # noqa: E402
from hoprover_env.training.sb3_agents import ConfigError, load_config, make_agent, validate  # noqa: E402

# the fast tier (pytest -m "not slow") leaves this file out:
# trains, resumes and evaluates TQC, CrossQ and RecurrentPPO
pytestmark = pytest.mark.slow

ENV = {"control_dt": 1.0, "episode_time": 30.0, "target_range": [-0.3, 0.3]}
TINY = {
    "env_id": "HopRover-v0",
    "n_envs": 2,
    "timesteps": 300,
    "seed": 0,
    "env": ENV,
    "evaluation": {"freq": 200, "episodes": 2, "seed": 1},
    "checkpoint": {"freq": 100},
}
OFF_POLICY = {"learning_starts": 50, "buffer_size": 1000, "batch_size": 32}
# each algorithm with some of its own keys set
OWN = {
    "tqc": {
        "policy": {"net_arch": [32, 32], "n_quantiles": 5, "n_critics": 2},
        "hyperparams": {**OFF_POLICY, "top_quantiles_to_drop_per_net": 1, "action_noise": 0.1},
    },
    "crossq": {
        "policy": {"net_arch": [32, 32], "batch_norm_momentum": 0.02, "renorm_warmup_steps": 100},
        "hyperparams": {**OFF_POLICY, "policy_delay": 2},
    },
    "recurrentppo": {
        "policy": {
            "net_arch": [32],
            "lstm_hidden_size": 16,
            "n_lstm_layers": 1,
            "enable_critic_lstm": True,
        },
        "hyperparams": {"n_steps": 32, "batch_size": 32, "n_epochs": 1},
    },
}
CLASSES = {"tqc": "TQC", "crossq": "CrossQ", "recurrentppo": "RecurrentPPO"}


@pytest.fixture(autouse=True)
def one_torch_thread():
    """One torch thread (as train.py --torch-threads 1): tiny networks on a busy machine
    run many times faster than with a thread per core."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def config(algo: str, **changes) -> dict:
    return {**TINY, "algo": algo, **OWN[algo], **changes}


def run_train(args) -> int:
    return train.main([*args, "--no-progress", "--torch-threads", "1"])


@pytest.mark.parametrize("algo", list(OWN))
def test_trains_resumes_and_plays(tmp_path, algo):
    path, out = tmp_path / "cfg.yaml", tmp_path / algo
    path.write_text(yaml.safe_dump(config(algo)))
    assert run_train(["--config", str(path), "--out", str(out)]) == 0
    ckpt = out / "checkpoints"
    first = json.loads((ckpt / "last.json").read_text())["timesteps"]
    assert first >= 300
    # the replay buffer is kept for the off-policy learners only
    assert (ckpt / "last_replay_buffer.pkl").exists() == (algo != "recurrentppo")
    assert (
        run_train(["--config", str(path), "--out", str(out), "--timesteps", "500", "--resume"]) == 0
    )
    meta = json.loads((ckpt / "last.json").read_text())
    assert meta["algo"] == algo and meta["timesteps"] >= 500 > first
    policy = load_sb3(out)
    assert type(policy.model).__name__ == CLASSES[algo]
    assert policy.recurrent == (algo == "recurrentppo")
    results = run_episodes(policy, [-0.25, 0.1, 0.3], policy.env_kwargs)
    assert len(results) == 3
    for r in results:
        assert math.isfinite(r.final_x) and r.steps > 0
        assert r.ttrtp is None or math.isfinite(r.ttrtp)
    # a bare .zip (no metadata beside it) is read as its own algorithm: SAC would load a
    # TQC model and PPO a RecurrentPPO one
    shutil.copy(out / "final_model.zip", tmp_path / "bare.zip")
    assert type(load_sb3(tmp_path / "bare.zip").model).__name__ == CLASSES[algo]


def test_algo_flag_takes_every_algorithm():
    for algo in ("ppo", "sac", "td3", "tqc", "crossq", "recurrentppo"):
        assert train.parse_args(["--algo", algo, "--out", "r"]).algo == algo


@pytest.mark.parametrize(
    "algo, section, key, value",
    [
        ("tqc", "policy", "n_quantilez", 5),
        ("tqc", "hyperparams", "top_quantiles_to_drop", 2),
        ("tqc", "policy", "lstm_hidden_size", 16),  # RecurrentPPO's, not TQC's
        ("crossq", "policy", "batch_norm_momentun", 0.01),
        ("crossq", "hyperparams", "tau", 0.005),  # CrossQ has no target network
        ("crossq", "policy", "n_quantiles", 5),
        ("recurrentppo", "policy", "lstm_hidden_sizes", 16),
        ("recurrentppo", "hyperparams", "n_step", 32),
        ("recurrentppo", "hyperparams", "action_noise", 0.1),  # on-policy: no action noise
    ],
)
def test_unknown_keys_are_named(algo, section, key, value):
    cfg = load_config(None, {"algo": algo})
    cfg[section] = {key: value}
    with pytest.raises(ConfigError, match=f"unknown config key '{section}.{key}'"):
        validate(cfg)


@pytest.mark.parametrize(
    "algo, section, key, value",
    [
        ("tqc", "policy", "n_quantiles", 2.5),
        ("tqc", "hyperparams", "top_quantiles_to_drop_per_net", -1),
        ("crossq", "policy", "renorm_warmup_steps", "many"),
        ("crossq", "policy", "batch_norm_momentum", 0),
        ("recurrentppo", "policy", "lstm_hidden_size", 0),
        ("recurrentppo", "policy", "shared_lstm", "yes"),
        ("recurrentppo", "policy", "shared_lstm", True),  # needs enable_critic_lstm: false
    ],
)
def test_bad_values_are_named(algo, section, key, value):
    cfg = load_config(None, {"algo": algo})
    cfg[section] = {key: value}
    with pytest.raises(ConfigError, match=f"'{section}.{key}'"):
        validate(cfg)


def test_action_noise_is_a_gaussian_std_where_the_algorithm_takes_it():
    from stable_baselines3.common.noise import NormalActionNoise

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    for algo in ("td3", "tqc", "crossq"):
        cfg = load_config(None, {"algo": algo, "n_envs": 2})
        cfg["hyperparams"] = {"action_noise": 0.2}
        noise = make_agent(cfg, HopRoverSB3VecEnv(2)).action_noise
        assert isinstance(noise, NormalActionNoise) and np.allclose(noise._sigma, 0.2)


@pytest.fixture(scope="module")
def recurrent_policy():
    """An untrained RecurrentPPO policy with large random weights: its actions depend
    on what it remembers."""
    import torch

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv

    cfg = load_config(None, {"algo": "recurrentppo", "n_envs": 2})
    cfg["policy"] = {"net_arch": [16], "lstm_hidden_size": 8}
    torch.set_num_threads(1)
    model = make_agent(cfg, HopRoverSB3VecEnv(2))
    gen = torch.Generator().manual_seed(0)
    with torch.no_grad():
        for p in model.policy.parameters():
            p.copy_(0.3 * torch.randn(p.shape, generator=gen))
    return SB3Policy(model, name="lstm", env_kwargs={"control_dt": 1.0, "episode_time": 30.0})


def test_recurrent_policy_remembers_per_slot_and_forgets_on_reset(recurrent_policy):
    pol = recurrent_policy
    obs = np.zeros((2, 19), np.float32)
    pol.reset(2)
    first = pol.act(obs, None)
    second = pol.act(obs, None)
    assert not np.allclose(first, second)  # the same observation, another memory
    pol.restart([1])  # slot 1 starts a new episode
    third = pol.act(obs, None)
    assert third[1] == pytest.approx(first[1], abs=1e-6)
    assert not np.allclose(third[0], second[0])  # slot 0 goes on remembering
    pol.reset(2)
    np.testing.assert_allclose(pol.act(obs, None), first, atol=1e-6)


def test_recurrent_batch_plays_each_episode_as_alone(recurrent_policy):
    """Four targets side by side give each episode's result alone (episode e seeded e):
    the memory is per slot, and every batch starts it afresh."""
    targets = [-0.6, -0.2, 0.3, 0.8]
    batch = run_episodes(recurrent_policy, targets)
    again = run_episodes(recurrent_policy, targets)
    alone = [run_episodes(recurrent_policy, [t], first_episode=e)[0] for e, t in enumerate(targets)]
    assert [r.as_dict() | {"wall_time": 0} for r in again] == [
        r.as_dict() | {"wall_time": 0} for r in batch
    ]
    assert len({round(r.final_x, 6) for r in batch}) == len(targets)
    for b, a in zip(batch, alone):
        # the LSTM's float32 sums differ in the last bit between batch sizes
        assert (b.episode, b.success, b.broken, b.steps) == (
            a.episode,
            a.success,
            a.broken,
            a.steps,
        )
        assert b.final_x == pytest.approx(a.final_x, abs=1e-6)
        assert (b.ttrtp is None) == (a.ttrtp is None)
        if b.ttrtp is not None:
            assert b.ttrtp == pytest.approx(a.ttrtp, abs=1e-6)
