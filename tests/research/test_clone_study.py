"""Clones of research/plan_clone/clone_study.py leave as run directories that load_policy reads."""

import numpy as np
import pytest

from hoprover_env.agents.policies import load_policy
from research.plan_clone.clone_study import _model, _policy, export


@pytest.mark.slow  # fits a clone
def test_an_exported_clone_loads_and_acts_as_it_was_fitted(tmp_path):
    cfg, venv, model = _model("linear", activation="relu")
    rng = np.random.default_rng(0)
    venv.obs_rms.mean = rng.normal(size=19)  # statistics a fit would set
    venv.obs_rms.var = rng.uniform(0.5, 2.0, size=19)
    export(cfg, venv, model, tmp_path / "run")
    loaded = load_policy(str(tmp_path / "run"))
    assert loaded.env_kwargs["control_dt"] == 0.5
    assert type(loaded.model.policy.mlp_extractor.policy_net[1]).__name__ == "ReLU"
    obs = rng.normal(size=(6, 19)).astype(np.float32)
    np.testing.assert_array_equal(loaded.act(obs, None), _policy(cfg, venv, model).act(obs, None))


def test_a_warm_start_keeps_the_statistics_its_weights_were_fitted_to():
    from hoprover_env.training.warm_start import clone

    cfg, venv, model = _model("linear")
    rng = np.random.default_rng(1)
    obs = rng.normal(2.0, 3.0, size=(64, 19)).astype(np.float32)
    act, ret = rng.uniform(-1, 1, size=(64, 1)), rng.normal(size=64)
    old = rng.normal(size=19)
    venv.obs_rms.mean = old.copy()
    clone(
        model,
        venv,
        obs,
        act,
        ret,
        epochs=1,
        value_epochs=0,
        log=lambda m: None,
        fit_statistics=False,
    )
    np.testing.assert_array_equal(venv.obs_rms.mean, old)
    clone(model, venv, obs, act, ret, epochs=1, value_epochs=0, log=lambda m: None)
    np.testing.assert_allclose(venv.obs_rms.mean, obs.mean(axis=0), rtol=1e-6)
