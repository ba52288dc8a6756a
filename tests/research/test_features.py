"""research.plan_clone.features: inputs at fine scales, part of the network."""

import pickle

import numpy as np
import pytest
import torch

from hoprover_env.agents.policies import load_policy
from hoprover_env.training.sb3_agents import ConfigError, load_config, validate
from research.plan_clone.clone_study import _load, _model, _policy, export
from research.plan_clone.features import (
    MicroStateFeatures,
    micro_features,
    n_features,
    set_statistics,
)


def test_the_layer_passes_the_observation_on_and_appends_the_numpy_features():
    cfg, venv, model = _model("linear", activation="relu", features="micro")
    rng = np.random.default_rng(0)
    venv.obs_rms.mean = rng.normal(0.0, 0.1, size=19)
    venv.obs_rms.var = rng.uniform(0.01, 2.0, size=19)
    set_statistics(model.policy, venv)
    # raw observations near rest: milliradians, sub-millimetre offsets from the edge
    raw = rng.normal(0.0, 1.0, size=(50, 19)) * 0.003
    raw[:, 16] = rng.choice([-1.0, 1.0], 50) * (1.0 + rng.uniform(-0.02, 0.05, 50))
    z = venv.normalize_obs(raw.astype(np.float32))
    out = model.policy.extract_features(torch.as_tensor(z), model.policy.features_extractor)
    out = out.detach().numpy()
    assert out.shape == (50, 19 + n_features())
    np.testing.assert_array_equal(out[:, :19], z)
    np.testing.assert_allclose(out[:, 19:], micro_features(raw), atol=2e-4)
    # they resolve what the normalised observation does not: 0.2 mm past the band's edge
    edge = micro_features(np.array([[0.0] * 16 + [1.004, 0.0, 0.0]]))[0, -3:]
    assert edge[0] > 0.3 and np.all(edge > 0)


def test_a_clone_without_them_loads_with_zero_weights_on_the_new_inputs(tmp_path):
    cfg, venv, model = _model("linear", activation="relu")
    rng = np.random.default_rng(2)
    venv.obs_rms.mean = rng.normal(size=19)
    venv.obs_rms.var = rng.uniform(0.5, 2.0, size=19)
    path = tmp_path / "plain.pkl"
    with open(path, "wb") as f:
        pickle.dump(
            {
                "policy": model.policy.state_dict(),
                "mean": venv.obs_rms.mean,
                "var": venv.obs_rms.var,
            },
            f,
        )
    cfg2, venv2, model2 = _model("linear", activation="relu", features="micro")
    _load(path, venv2, model2)
    w = model2.policy.mlp_extractor.policy_net[0].weight.detach().numpy()
    assert w.shape == (256, 19 + n_features())
    assert not w[:, 19:].any()
    obs = rng.normal(size=(8, 19)).astype(np.float32)
    np.testing.assert_allclose(
        _policy(cfg2, venv2, model2).act(obs, None),
        _policy(cfg, venv, model).act(obs, None),
        atol=1e-6,
    )
    ext = model2.policy.features_extractor
    np.testing.assert_allclose(ext.std.numpy(), np.sqrt(venv.obs_rms.var + venv.epsilon), rtol=1e-6)


def test_an_exported_clone_with_them_keeps_its_statistics_in_the_weights(tmp_path):
    cfg, venv, model = _model("linear", activation="relu", features="micro")
    rng = np.random.default_rng(3)
    venv.obs_rms.mean = rng.normal(size=19)
    venv.obs_rms.var = rng.uniform(0.5, 2.0, size=19)
    set_statistics(model.policy, venv)
    with torch.no_grad():  # weights on the new inputs, so that they matter
        model.policy.mlp_extractor.policy_net[0].weight[:, 19:].normal_()
    export(cfg, venv, model, tmp_path / "run")
    loaded = load_policy(str(tmp_path / "run"))
    assert isinstance(loaded.model.policy.features_extractor, MicroStateFeatures)
    obs = rng.normal(size=(6, 19)).astype(np.float32)
    np.testing.assert_array_equal(loaded.act(obs, None), _policy(cfg, venv, model).act(obs, None))


def test_a_config_asks_for_them_by_name_with_frozen_statistics():
    cfg = load_config("configs/ppo_mpc.yaml")
    micro = "research.plan_clone.features:MicroStateFeatures"
    cfg["policy"]["features_extractor"] = micro
    validate(cfg)
    for bad in ("research.plan_clone.features:Fourier", "micro", "numpy:ndarray"):
        cfg["policy"]["features_extractor"] = bad
        with pytest.raises(ConfigError, match="policy.features_extractor"):
            validate(cfg)
    cfg["policy"]["features_extractor"] = micro
    cfg["normalize"]["update"] = True
    with pytest.raises(ConfigError, match="normalize.update: false"):
        validate(cfg)
