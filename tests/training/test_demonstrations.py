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
        "n_steps": 3,  # n-step returns read a column's consecutive rows as one episode
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
    # every episode lies whole down one env column, its decisions in consecutive rows (an
    # n-step return reads them so), until the columns are cut to the shortest
    where = {
        np.asarray(e.observations[t], np.float32).tobytes(): (i, t)
        for i, e in enumerate(episodes)
        for t in range(len(e.actions))
    }
    rows = buf.pos - 32  # then the learner's own 64 steps (32 calls of 2 envs)
    assert rows * 2 >= 150 - 2 * max(len(e.actions) for e in episodes)
    seen = set()
    for c in range(2):
        for r in range(rows):
            i, t = where[buf.observations[r, c].tobytes()]
            ep = episodes[i]
            seen.add((i, t))
            assert np.array_equal(buf.next_observations[r, c], ep.observations[t + 1])
            assert buf.actions[r, c, 0] == np.float32(ep.actions[t][0])
            assert buf.rewards[r, c] == np.float32(ep.rewards[t])
            ended = bool(ep.terminations[t] or ep.truncations[t])
            last = r == rows - 1
            # a truncation bootstraps; so does the cut at the end of a column
            assert buf.dones[r, c] == (ended or last)
            assert buf.timeouts[r, c] == (
                bool(ep.truncations[t] and not ep.terminations[t]) or (last and not ended)
            )
            if not ended and not last:
                assert where[buf.observations[r + 1, c].tobytes()] == (i, t + 1)
    assert len(seen) == rows * 2  # no decision twice
    # the learner's own steps follow in every column, after a row that ends the demonstrations
    assert buf.dones[rows - 1].all()
    term = np.concatenate([e.terminations for e in episodes])
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
