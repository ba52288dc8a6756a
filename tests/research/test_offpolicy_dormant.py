"""research/offpolicy/dormant.py: its counts are the actor's own. A unit turned off for
every state is counted never active and dormant, every never-active unit is dormant, and
the states are the episodes it says it played."""

import json

import pytest
import torch

from helpers import train_tiny
from hoprover_env.agents.policies import load_sb3
from hoprover_env.training.redo import hidden_activations
from research.offpolicy import dormant


@pytest.mark.slow  # trains a tiny SAC
def test_a_unit_switched_off_is_counted(tmp_path):
    model = train_tiny(tmp_path)
    out = tmp_path / "dormant.json"
    args = ["--models", str(model), "--envs", "4", "--steps", "3", "--out", str(out)]
    assert dormant.main(args) == 0
    (row,) = json.loads(out.read_text())
    assert row["states"] == 2 * 4 * (3 + 1)
    widths = [
        m.out_features for m in load_sb3(model).model.actor.latent_pi if hasattr(m, "out_features")
    ]
    assert [layer["units"] for layer in row["layers"]] == widths
    for layer in row["layers"]:
        assert 0 <= layer["never_active"] <= layer["dormant"] <= layer["units"]
        assert 0 <= layer["median_active_at_start"] <= layer["units"]

    # the same states with three units of the last hidden layer switched off
    policy = load_sb3(model)
    last = [m for m in policy.model.actor.latent_pi if isinstance(m, torch.nn.Linear)][-1]
    with torch.no_grad():
        last.bias[:3] = -1e6
    obs, at_start = dormant.states(policy, 4, 3, seed=1)
    h = hidden_activations(policy.model.actor, torch.as_tensor(policy.normalize(obs)))[-1]
    assert at_start.sum() == 4
    assert bool((h[:, :3] == 0).all())
    never = int(((h > 0).sum(dim=0) == 0).sum())
    assert never >= 3 and never >= row["layers"][-1]["never_active"]
