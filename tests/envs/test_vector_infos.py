"""The vector env's infos, written by its step kernel row by row (tasks/common.py
close_row) and at resets (HopRoverVectorEnv._note_info), equal those read from the state
rows after the step, as the env built them before: same keys, dtypes, values and masks,
through autoresets (NextStep and SameStep, final_info included), a step limit, masked
resets and sub-envs never reset, on the serial loop and the threaded one on 1 and 2
threads."""

import numba
import numpy as np
import pytest

from hoprover_env import HopRoverVectorEnv, core
from hoprover_env.core.params import P_SLOPE
from hoprover_env.envs.parts import full_info
from hoprover_env.envs.parts import info as make_info

N = 12
STEPS = 40
ENV_KW = dict(control_dt=5.0, episode_time=60.0)  # 12 steps per episode by the clock
AT_TARGET = np.arange(N) % 4 == 0  # idle at the target: success at 5 s
UPSIDE_DOWN = (0.0, 0.2, np.pi, 0.0, 0.0, 0.0)  # dropped on its top: it breaks


def infos_from_rows(venv, nev, mask=None) -> dict:
    """The infos of the vector env's current rows, computed as the env computed them
    before the step kernel wrote them: strided reads of the state and parameter rows."""
    n = venv.num_envs
    mask = np.ones(n, dtype=np.bool_) if mask is None else mask.copy()
    ttrtp = venv.S[:, core.S_TTRTP].copy()
    reached = ~np.isnan(ttrtp)
    ttrtp[~reached] = -1.0  # the documented value before it is reached
    info = make_info(
        reached,
        ttrtp,
        venv.S[:, core.S_MODE].astype(np.int64),
        venv.targets.copy(),
        venv.S[:, core.S_BROKEN] != 0.0,
        nev.astype(np.int64),
        venv.P[:, P_SLOPE].copy(),
        venv.terrain_seeds.copy(),
    )
    if venv.config.info_level == "full":
        info.update(full_info(venv.S, venv.P, venv._rm))
        if venv.task.hidden_info is not None:
            info.update(venv.task.hidden_info(venv.M))
    for key in list(info):
        info["_" + key] = mask
    return info


def assert_same_info(got: dict, want: dict, where: str) -> None:
    assert sorted(got) == sorted(want), where
    for key, value in want.items():
        if isinstance(value, dict):
            assert_same_info(got[key], value, f"{where}, {key}")
            continue
        if value.dtype == object:  # final_obs: one row or None per sub-env
            assert [None if v is None else v.tolist() for v in got[key]] == [
                None if v is None else v.tolist() for v in value
            ], (where, key)
            continue
        assert got[key].dtype == value.dtype and got[key].shape == value.shape, (where, key)
        assert np.array_equal(got[key], value, equal_nan=value.dtype.kind == "f"), (where, key)


def actions(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1.0, 1.0, (STEPS, N, 1)) * (rng.random((STEPS, N, 1)) < 0.3)
    a[:, AT_TARGET] = 0.0
    return a


def run(mode: str, info_level: str, threads, max_episode_steps=None) -> list:
    """Every output of a scripted run (reset, steps, a masked reset, autoresets), each
    infos checked against infos_from_rows on the way. `threads`: False (the serial
    loop) or the numba thread count of the threaded one."""
    before = numba.get_num_threads()
    if threads:
        numba.set_num_threads(threads)
    try:
        venv = HopRoverVectorEnv(
            N,
            autoreset_mode=mode,
            threads=bool(threads),
            info_level=info_level,
            max_episode_steps=max_episode_steps,
            **ENV_KW,
        )
        finals = []  # (info, observations) read just before a SameStep reset
        reset_rows = venv._autoreset_rows

        def autoreset_rows(rows):
            if mode == "SameStep":
                finals.append(
                    (infos_from_rows(venv, venv._nev, venv._term | venv._trunc), venv._obs.copy())
                )
            reset_rows(rows)

        venv._autoreset_rows = autoreset_rows

        # first a masked reset: the sub-envs never reset report their all-zero rows
        first = np.arange(N) % 3 == 0
        obs, info = venv.reset(seed=5, options={"reset_mask": first})
        assert_same_info(info, infos_from_rows(venv, np.zeros(N, np.int64)), "first reset")
        assert info["is_success"][~first].all()  # a zero TTRTP slot is not NaN
        obs, info = venv.reset(seed=5, options={"target_x": np.where(AT_TARGET, 0.0, 0.6)})
        out = [obs, info]
        assert_same_info(info, infos_from_rows(venv, np.zeros(N, np.int64)), "reset")
        pending = np.zeros(N, dtype=np.bool_)  # NextStep: reset at the next step
        count = np.zeros(N, dtype=np.int64)  # steps of each episode, counted here
        for k, a in enumerate(actions(7)):
            if k == 25:  # a masked reset part way through, onto a break
                mask = np.arange(N) % 2 == 1
                obs, info = venv.reset(options={"reset_mask": mask, "initial_state": UPSIDE_DOWN})
                assert_same_info(
                    info,
                    infos_from_rows(venv, np.zeros(N, np.int64)),
                    f"masked reset before step {k}",
                )
                out += [obs, info]
                pending[mask] = False
                count[mask] = 0
            obs, r, te, tr, info = venv.step(a)
            count = np.where(pending, 0, count + 1)
            if pending.any():  # NextStep: these rows were reset
                assert (r[pending] == 0.0).all() and not (te | tr)[pending].any()
                assert (info["n_events"][pending] == 0).all()
            if max_episode_steps is not None:
                assert np.array_equal(tr, (count >= max_episode_steps) & ~te), k
            ended = te | tr
            want = infos_from_rows(venv, venv._nev)
            if mode == "SameStep" and ended.any():
                final_info, last_obs = finals.pop()
                final_obs = np.full(N, None, dtype=object)
                for i in np.flatnonzero(ended):
                    final_obs[i] = last_obs[i]
                want.update(
                    final_obs=final_obs, _final_obs=ended, final_info=final_info, _final_info=ended
                )
                count[ended] = 0
            else:
                pending = ended if mode == "NextStep" else pending
            assert not finals
            assert_same_info(info, want, f"step {k}")
            out += [obs, r, te, tr, info]
        return out
    finally:
        numba.set_num_threads(before)


def flat(outputs: list) -> list:
    """The arrays of a run's outputs, in order (infos by sorted key, nested too)."""
    items = []
    for o in outputs:
        if isinstance(o, dict):
            for key in sorted(o):
                items += flat([o[key]])
        elif o.dtype == object:
            items += [np.asarray([] if v is None else v) for v in o]
        else:
            items.append(o)
    return items


@pytest.mark.parametrize("info_level", ["basic", "full"])
@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_vector_infos_equal_those_read_from_the_rows(mode, info_level):
    two = min(2, numba.config.NUMBA_NUM_THREADS)
    runs = [run(mode, info_level, threads) for threads in (False, 1, two)]
    for other in runs[1:]:  # the same bits on every loop and thread count
        a, b = flat(runs[0]), flat(other)
        assert len(a) == len(b)
        assert all(
            x.dtype == y.dtype and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")
            for x, y in zip(a, b)
        )
    # the run saw what the info columns carry: successes, breaks, several states
    infos = [o for o in runs[0] if isinstance(o, dict)]
    infos += [o["final_info"] for o in infos if "final_info" in o]
    assert any(i["is_success"].any() for i in infos) and any(i["broken"].any() for i in infos)
    assert len(set(np.concatenate([i["state"] for i in infos]).tolist())) >= 4


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_vector_infos_with_a_step_limit(mode):
    run(mode, "basic", min(2, numba.config.NUMBA_NUM_THREADS), max_episode_steps=11)
