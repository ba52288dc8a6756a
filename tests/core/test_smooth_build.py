"""The smooth-ground build (hoprover_env/core/smooth.py): the envs step rovers on smooth
ground with an integrator compiled without rough-terrain code, and switch to the general
one when bumps appear. On smooth ground both give the same trajectories, bit for bit."""

import gymnasium as gym
import numpy as np
import pytest

from hoprover_env import HopRoverEnv, HopRoverVectorEnv
from hoprover_env.core import S_NIMPACT
from hoprover_env.core.params import P_ROUGH


def _episode(env, seed, actions, kernel=None):
    obs, _ = env.reset(seed=seed)
    if kernel is not None:
        env._step_kernel = kernel
    out = [obs]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append(np.append(obs, [r, *info["rover_state"], info["n_events"]]))
        if term or trunc:
            break
    return np.concatenate(out)


@pytest.mark.parametrize("params", [{}, {"slope": 0.15}])
def test_smooth_and_general_builds_step_alike_on_smooth_ground(params):
    rng = np.random.default_rng(7)
    env = HopRoverEnv(params=params, control_dt=2.0, info_level="full")
    general = env.task.kernels(env.config.integrator, rough=True).step
    impacts = 0
    for seed in range(4):
        actions = rng.uniform(-1, 1, (150, 1)).astype(np.float32)
        smooth = _episode(env, seed, actions)
        assert env._step_kernel is env.task.kernels(env.config.integrator, rough=False).step
        assert np.array_equal(smooth, _episode(env, seed, actions, kernel=general))
        impacts += env.unwrapped._s[S_NIMPACT]
    assert impacts > 0  # the episodes hopped and landed: impacts were resolved


def test_the_envs_choose_the_build_by_the_ground():
    env = HopRoverEnv()
    env.reset(seed=0)
    assert env._step_kernel is env.task.kernels("event", rough=False).step
    env.reset(seed=0, options={"roughness": 0.05})  # bumps for this episode
    assert env._step_kernel is env.task.kernels("event", rough=True).step
    venv = HopRoverVectorEnv(3)
    venv.reset(seed=0)
    assert venv._rough is False
    # one sub-env on rough ground: the whole batch steps with the general build
    venv.reset(seed=0, options={"roughness": np.array([0.0, 0.05, 0.0])})
    assert venv._rough is True and venv.P[1, P_ROUGH] == 0.05
    venv.reset(seed=0)
    assert venv._rough is False
    terrain = gym.make_vec(
        "HopRoverTerrain-v0", num_envs=2, vectorization_mode="vector_entry_point"
    )
    terrain.reset(seed=0)
    assert terrain.unwrapped._rough is True


def test_a_vector_env_that_autoresets_onto_bumps_switches_build():
    venv = HopRoverVectorEnv(2, control_dt=30.0, episode_time=60.0)
    venv.reset(seed=0)
    assert venv._rough is False
    venv.config = type(venv.config).from_kwargs(  # later episodes on bumps
        "test", control_dt=30.0, episode_time=60.0, params={"roughness": 0.05}
    )
    for _ in range(3):
        venv.step(np.zeros((2, 1)))
    assert venv._rough is True and (venv.P[:, P_ROUGH] > 0).any()


def test_the_smooth_kernels_are_found_by_the_name_they_pickle_under():
    # a declared kernel not yet compiled in this process (its callers loaded from the
    # cache) pickles by reference, module and qualified name: deepcopying an env that
    # holds the smooth build must find each of them again
    import pickle

    from hoprover_env.core import smooth
    from hoprover_env.jit.compiler import _module_attribute

    kernels = [v for k, v in vars(smooth).items() if k.endswith("_smooth")]
    assert len(kernels) == 6
    for k in kernels:
        f = k.py_func
        assert _module_attribute(f.__module__, f.__qualname__) is k
    declared = [k for k in kernels if k.kernel_options["signature"] is not None]
    assert declared
    for k in declared:
        assert pickle.loads(pickle.dumps(k)) is not None
