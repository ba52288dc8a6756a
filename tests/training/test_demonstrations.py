"""Demonstrations in an off-policy learner's replay buffer (training/demonstrations.py):
the transitions the buffer holds before the first update are the demonstrator's episodes
as the offline datasets' collector records them, stored as SB3 stores its own (the raw
observations, the action, the reward, a truncation that bootstraps), and the config
refuses them where they cannot apply."""

import numpy as np
import pytest
import yaml
from stable_baselines3.common.buffers import ReplayBuffer

from hoprover_env.training import train

pytest.importorskip("minari", reason="demonstrations record episodes with Minari's buffers")

CFG = {
    "algo": "sac",
    "env_id": "HopRoverRL-v1",
    "n_envs": 2,
    "timesteps": 64,
    "seed": 0,
    "env": {"flight_start": 0.5},
    "normalize": {"obs": True, "reward": False},
    "policy": {"net_arch": [16, 16]},
    "hyperparams": {
        "learning_starts": 10_000,
        "batch_size": 16,
        "gamma": 0.995,
        "buffer_size": 5_000,
    },
    "evaluation": {"freq": 10_000, "episodes": 2, "seed": 7},
    "checkpoint": {"freq": 10_000},
    "demonstrations": {"policy": "scripted", "steps": 150, "seed": 3},
}


def _write(tmp_path, cfg):
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


@pytest.mark.slow  # trains (64 steps), after collecting the demonstrations
def test_the_buffer_starts_with_the_demonstrators_episodes(tmp_path):
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.datasets import collect

    out = tmp_path / "run"
    assert train.main(["--config", _write(tmp_path, CFG), "--out", str(out), "--no-progress"]) == 0
    import pickle

    with open(out / "checkpoints" / "last_replay_buffer.pkl", "rb") as fh:
        buf: ReplayBuffer = pickle.load(fh)
    # the same episodes, collected here: from rest (no flight starts), at the env's 2 s
    from hoprover_env.envs.registry import task

    episodes = collect(
        "HopRoverRL-v1",
        [load_policy("scripted", control_dt=2.0)],
        task("HopRoverRL-v1").kwargs,
        n_steps=150,
        num_envs=16,
        seed=3,
    )
    obs = np.concatenate([e.observations[:-1] for e in episodes])
    nxt = np.concatenate([e.observations[1:] for e in episodes])
    act = np.concatenate([e.actions for e in episodes]).reshape(-1, 1)
    rew = np.concatenate([e.rewards for e in episodes])
    term = np.concatenate([e.terminations for e in episodes])
    trunc = np.concatenate([e.truncations for e in episodes])
    n = len(obs) - len(obs) % 2
    assert n >= 150
    rows = n // 2
    # the buffer's first rows, env by env in SB3's layout (position, env)
    stored = buf.observations[:rows].reshape(n, -1)
    assert np.array_equal(stored, obs[:n].astype(np.float32))
    assert np.array_equal(buf.next_observations[:rows].reshape(n, -1), nxt[:n])
    assert np.array_equal(buf.actions[:rows].reshape(n, -1), act[:n])
    assert np.array_equal(buf.rewards[:rows].reshape(n), rew[:n].astype(np.float32))
    assert np.array_equal(buf.dones[:rows].reshape(n), (term | trunc)[:n].astype(np.float32))
    assert np.array_equal(buf.timeouts[:rows].reshape(n), (trunc & ~term)[:n])
    # then the learner's own 64 steps (32 calls of 2 envs)
    assert buf.pos == rows + 32
    # the demonstrator reached its targets: a success ends an episode by termination
    assert term.sum() >= len(episodes) // 2


@pytest.mark.parametrize(
    "change, words",
    [
        ({"algo": "ppo", "hyperparams": {}}, "off-policy"),
        ({"demonstrations": {"policy": "scripted", "episodes": 3}}, "episodes"),
        ({"demonstrations": {"policy": "scripted", "steps": 0}}, "positive integer"),
    ],
)
def test_bad_demonstrations_are_refused_by_name(tmp_path, capsys, change, words):
    assert (
        train.main(
            [
                "--config",
                _write(tmp_path, {**CFG, **change}),
                "--out",
                str(tmp_path / "run"),
                "--no-progress",
            ]
        )
        == 2
    )
    assert words in capsys.readouterr().err
