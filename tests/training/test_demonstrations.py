"""Demonstrations in an off-policy learner's replay buffer (training/demonstrations.py):
the transitions the buffer holds before the first update are the demonstrator's episodes
as the offline datasets' collector records them, stored as SB3 stores its own (the raw
observations, the action, the reward, a truncation that bootstraps), and the config
refuses them where they cannot apply."""

import numpy as np
import pytest
from stable_baselines3.common.buffers import ReplayBuffer

from helpers import TINY_SAC_V1, train_run, write_config
from hoprover_env.training import train

pytest.importorskip("minari", reason="demonstrations record episodes with Minari's buffers")

CFG = {
    **TINY_SAC_V1,
    "hyperparams": {
        "learning_starts": 10_000,
        "batch_size": 16,
        "gamma": 0.995,
        "buffer_size": 5_000,
        "n_steps": 3,  # n-step returns read a column's consecutive rows as one episode
    },
    "demonstrations": {"policy": "scripted", "steps": 150, "seed": 3},
}


@pytest.mark.slow  # trains (64 steps), after collecting the demonstrations
def test_the_buffer_starts_with_the_demonstrators_episodes(tmp_path):
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.datasets import collect

    out = train_run(tmp_path, CFG)
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
        ({"demonstrations": {"policy": "scripted", "batch_share": 1.0}}, "batch_share"),
    ],
)
def test_bad_demonstrations_are_refused_by_name(tmp_path, capsys, change, words):
    assert (
        train.main(
            [
                "--config",
                write_config(tmp_path, {**CFG, **change}),
                "--out",
                str(tmp_path / "run"),
                "--no-progress",
            ]
        )
        == 2
    )
    assert words in capsys.readouterr().err


@pytest.mark.parametrize("n_steps", [1, 3])
def test_a_batch_share_draws_that_share_of_every_batch_from_the_demonstrations(n_steps):
    """Symmetric sampling: the demonstrations' store gives half of each batch however
    much the learner's own data outnumbers them (rewards tell the two apart here)."""
    from gymnasium import spaces

    from hoprover_env.training.demonstrations import (
        DemonstrationNStepReplayBuffer,
        DemonstrationReplayBuffer,
    )

    obs_space = spaces.Box(-1, 1, (3,), np.float32)
    act_space = spaces.Box(-1, 1, (1,), np.float32)
    cls, extra = DemonstrationReplayBuffer, {}
    if n_steps > 1:
        cls, extra = DemonstrationNStepReplayBuffer, {"n_steps": n_steps, "gamma": 0.9}
    buf = cls(1000, obs_space, act_space, n_envs=2, batch_share=0.5, **extra)

    def fill(target, rows, reward):
        for r in range(rows):
            o = np.full((2, 3), r, np.float32)
            info = [{"TimeLimit.truncated": False}] * 2
            done = np.array([r == rows - 1] * 2)
            target.add(o, o + 1, np.zeros((2, 1)), np.full(2, reward), done, info)

    fill(buf, 400, 0.0)  # the learner's own: 800 transitions
    store = buf.demonstration_store(10)
    fill(store, 10, 1.0)  # 20 demonstrated ones
    assert store.size() == 10 and buf.size() == 400
    batch = buf.sample(64)
    assert batch.rewards.shape == (64, 1)
    # an n-step return of demonstrations sums their rewards 1 + 0.9 + 0.81 (or fewer at
    # the episode's end); the learner's own are all 0
    from_demos = (batch.rewards > 0).sum().item()
    assert from_demos == 32
    assert batch.observations.shape == (64, 3)
    if n_steps > 1:
        assert batch.discounts is not None and batch.discounts.shape == (64, 1)
    with pytest.raises(ValueError, match="batch_share"):
        DemonstrationReplayBuffer(100, obs_space, act_space, batch_share=1.0)


@pytest.mark.slow  # trains (64 steps), after collecting the demonstrations
def test_a_run_with_a_batch_share_keeps_the_demonstrations_apart(tmp_path):
    cfg = {**CFG, "demonstrations": {**CFG["demonstrations"], "batch_share": 0.5}}
    out = train_run(tmp_path, cfg)
    import pickle

    from hoprover_env.training.demonstrations import DemonstrationNStepReplayBuffer

    with open(out / "checkpoints" / "last_replay_buffer.pkl", "rb") as fh:
        buf = pickle.load(fh)
    assert isinstance(buf, DemonstrationNStepReplayBuffer)  # CFG asks for 3-step returns
    assert buf.n_steps == 3 and buf.demonstrations.n_steps == 3
    assert buf.pos == 32  # only the learner's own 64 steps
    import json

    recorded = json.loads((out / "checkpoints" / "last.json").read_text())["demonstrations"]
    assert buf.demonstrations.size() * 2 == recorded["transitions"] > 0
    assert buf.demonstrations.dones[buf.demonstrations.size() - 1].all()
    # and a resumed run carries on with them
    assert (
        train.main(
            [
                "--config",
                write_config(tmp_path, {**cfg, "timesteps": 96}),
                "--out",
                str(out),
                "--resume",
                "--no-progress",
            ]
        )
        == 0
    )
    with open(out / "checkpoints" / "last_replay_buffer.pkl", "rb") as fh:
        resumed = pickle.load(fh)
    assert resumed.pos == 48 and resumed.demonstrations.size() == buf.demonstrations.size()
