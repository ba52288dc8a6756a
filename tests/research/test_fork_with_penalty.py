"""research/offpolicy/fork_with_penalty.py: the fork holds the run's weights, replay
buffer and statistics under the penalised policy class, train.py resumes it, and the
run itself is left as it was."""

import pytest
import torch

from helpers import train_tiny
from hoprover_env.agents.policies import _algo_class
from hoprover_env.training import train
from research.offpolicy import fork_with_penalty


@pytest.mark.slow  # trains a tiny SAC twice
def test_the_fork_continues_the_run_with_the_penalty(tmp_path):
    last = train_tiny(tmp_path)
    run = last.parent.parent
    config_before = (run / "config.yaml").read_text()
    out = tmp_path / "fork"
    assert (
        fork_with_penalty.main(["--run", str(run), "--out", str(out), "--actor-mean-reg", "1e-3"])
        == 0
    )

    sac = _algo_class("sac")
    original = sac.load(last, device="cpu")
    forked = sac.load(out / "checkpoints" / "last.zip", device="cpu")
    assert type(forked.policy).__name__ == "MeanPenaltySACPolicy"
    assert forked.policy.actor_mean_reg == 1e-3
    assert forked.num_timesteps == original.num_timesteps
    for (name, a), b in zip(
        original.policy.state_dict().items(), forked.policy.state_dict().values(), strict=True
    ):
        assert torch.equal(a, b), name
    assert (out / "checkpoints" / "last_replay_buffer.pkl").read_bytes() == (
        run / "checkpoints" / "last_replay_buffer.pkl"
    ).read_bytes()
    assert (run / "config.yaml").read_text() == config_before

    assert train.main(["--out", str(out), "--resume", "--timesteps", "96", "--no-progress"]) == 0
    resumed = sac.load(out / "checkpoints" / "last.zip", device="cpu")
    assert resumed.num_timesteps >= 96
    assert type(resumed.policy).__name__ == "MeanPenaltySACPolicy"
    # a second fork into the same directory is refused, naming it
    with pytest.raises(SystemExit, match="already holds a run"):
        fork_with_penalty.main(["--run", str(run), "--out", str(out), "--actor-mean-reg", "1e-3"])
