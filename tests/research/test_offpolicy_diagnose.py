"""research/offpolicy/diagnose.py: the measurement behind docs/studies/off-policy.md runs
for SAC and TD3 and writes finite, consistent rows."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
import yaml

pytest.importorskip("torch")
from research.offpolicy import diagnose  # noqa: E402

# the fast tier (pytest -m "not slow") leaves this file out:
# SAC and TD3 runs
pytestmark = pytest.mark.slow

TINY = {
    "n_envs": 2,
    "seed": 0,
    "env": {"control_dt": 4.0, "episode_time": 40.0, "gamma": 0.99, "action_map": "cubic"},
    "normalize": {"obs": True, "reward": False},
    "policy": {"net_arch": [16, 16]},
    "evaluation": {"freq": 1000, "episodes": 4, "seed": 1},
}


@pytest.mark.parametrize(
    "algo, extra", [("sac", {"ent_coef": "auto_0.01"}), ("td3", {"action_noise": 0.1})]
)
def test_diagnose_writes_a_row_per_checkpoint(tmp_path, algo, extra):
    import torch

    threads = torch.get_num_threads()
    cfg = {
        **TINY,
        "algo": algo,
        "hyperparams": {"learning_starts": 50, "batch_size": 32, "gamma": 0.99, **extra},
    }
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    try:
        assert (
            diagnose.main(
                [
                    "--config",
                    str(path),
                    "--steps",
                    "200",
                    "--every",
                    "100",
                    "--out",
                    str(tmp_path / "d"),
                ]
            )
            == 0
        )
    finally:
        torch.set_num_threads(threads)
    rows = list(csv.DictReader(open(tmp_path / "d" / "diagnosis.csv")))
    assert [int(r["timesteps"]) for r in rows] == [0, 100, 200]
    for r in rows:
        for key in ("q_pred", "q_mc", "reward_min", "reward_max", "return_mean"):
            assert abs(float(r[key])) < 1e6
        assert 0.0 <= float(r["tip_frac_rest"]) <= 1.0
        # every exploring episode opens at rest: at least one decision there each
        split = [int(r[f"decisions_{k}"]) for k in ("rest", "contact", "flight")]
        assert split[0] >= 32 and sum(split) >= 32
        assert abs(float(r["q_bias"]) - (float(r["q_pred"]) - float(r["q_mc"]))) < 1e-6
        assert float(r["reward_min"]) <= float(r["reward_max"])
        # 40 s episodes at 4 s: every exploring episode ends by the time limit or before
        assert 0 <= int(r["truncated"]) <= 32


def test_the_tipping_action_follows_the_action_map():
    lin = diagnose.tipping_action({"env_id": "HopRover-v0", "env": {}})
    cub = diagnose.tipping_action({"env_id": "HopRover-v0", "env": {"action_map": "cubic"}})
    assert lin == pytest.approx(4.9e-6 / 5e-4)  # m g r / T_max
    assert cub == pytest.approx(lin ** (1 / 3))


def _train_py_configs():
    """research/offpolicy's train.py configs and those of its exploration probe (her.py's,
    with a section `her`, are its own: tests/research/test_offpolicy_her.py checks them)."""
    here = Path(diagnose.__file__).parent
    paths = sorted([*here.glob("*.yaml"), *(here / "exploration").glob("*.yaml")])
    return [p for p in paths if "her" not in yaml.safe_load(p.read_text())]


@pytest.mark.parametrize("path", _train_py_configs(), ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_every_recorded_variant_is_a_config_train_py_accepts(path):
    """The configs behind the recorded CSVs stay runnable: keys, the learner's own
    arguments (target_entropy, top_quantiles_to_drop_per_net, ...) and the discount
    check are the same validation train.py applies."""
    from hoprover_env.training.sb3_agents import load_config

    assert load_config(path)["algo"] in {"sac", "td3", "tqc", "crossq"}


def test_the_landscape_holds_still_below_the_tipping_torque_and_flies_with_the_hold(tmp_path):
    """research/offpolicy/landscape.py: an opening torque of zero leaves the rover at rest
    where it started for the whole episode under either rule, and under the attitude
    hold no opening of the three (-1, 0, 1) breaks it."""
    from research.offpolicy import landscape

    out = tmp_path / "landscape.csv"
    assert landscape.main(["--out", str(out), "--points", "3"]) == 0
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 2 * 2 * 3 and list(rows[0]) == landscape.FIELDS
    for r in rows:
        if float(r["action"]) == 0.0:
            assert r["broken"] == "False" and r["success"] == "False"
            assert float(r["final_offset_m"]) == pytest.approx(-0.5)  # never moved
            assert int(r["steps"]) == 300  # 600 s at 2 s
        if r["rule"] == "hold":
            assert r["broken"] == "False"
