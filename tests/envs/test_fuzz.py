"""Property-based fuzzing of the public API.

Every call -- `simulate`, `RoverSim` and its `advance`, `RoverParams`, `gym.make` with
arbitrary keyword arguments, `env.step` and the vector env's `step` -- given values of the
wrong type, shape, sign or magnitude must either return a valid result within a time
bound or raise ValueError / TypeError whose message names the argument at fault.

nopython code cannot be interrupted, so each case runs in a worker process; a case that
does not answer within CASE_TIMEOUT seconds kills the worker and fails the test. One
worker serves all cases (it imports hoprover once); it is restarted after a hang.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

CASE_TIMEOUT = 60.0  # s: generous for a loaded 2-core CI machine; real hangs are forever


# ---------------------------------------------------------------------------------
# The worker: runs one call and reports ("ok", summary) or ("error", type, message)
# ---------------------------------------------------------------------------------
def _check_rollout(r, t_end):
    arrays = [r.t, r.x, r.y, r.theta, r.vx, r.vy, r.omega, r.torque]
    assert all(np.all(np.isfinite(a)) for a in arrays), "non-finite rollout"
    # a run goes to t_end, unless the rover broke (a top corner down ends it)
    assert r.broken or abs(r.t[-1] - t_end) <= 1e-9 * max(1.0, t_end), (r.t[-1], t_end)
    return f"rollout of {len(r.t)} samples"


def _run_case(case):
    import gymnasium as gym

    import hoprover_env  # noqa: F401 (registers the envs)
    from hoprover_env import RoverParams, RoverSim, simulate

    kind, args = case
    if kind == "simulate":
        r = simulate(args.pop("controller"), **args)
        return _check_rollout(r, float(args.get("t_end", 600.0)))
    if kind == "params":
        p = RoverParams(**args)
        assert all(math.isfinite(v) for v in p.as_array())
        return "params"
    if kind == "advance":
        sim = RoverSim(**args.pop("init"))
        t0 = sim.t
        ev = sim.advance(**args)
        assert math.isfinite(sim.t) and sim.t >= t0
        assert np.all(np.isfinite(sim.state))
        return f"{len(ev)} events"
    if kind == "make":
        env = gym.make("HopRover-v0", **args)
        obs, _ = env.reset(seed=0)
        obs, rew, term, trunc, info = env.step(np.zeros(1, dtype=np.float32))
        assert np.all(np.isfinite(obs)) and math.isfinite(rew)
        return "env"
    if kind == "step":
        env = gym.make("HopRover-v0")
        env.reset(seed=0)
        obs, rew, term, trunc, info = env.step(args["action"])
        assert np.all(np.isfinite(obs)) and math.isfinite(rew)
        return "step"
    if kind == "vstep":
        envs = gym.make_vec(
            "HopRover-v0", num_envs=args["num_envs"], vectorization_mode="vector_entry_point"
        )
        envs.reset(seed=0)
        obs, rew, term, trunc, info = envs.step(args["actions"])
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rew))
        assert obs.shape[0] == rew.shape[0] == envs.num_envs
        return "vstep"
    raise AssertionError(kind)


def _worker(conn):
    import warnings

    warnings.simplefilter("ignore")
    while True:
        case = conn.recv()
        if case is None:
            return
        try:
            conn.send(("ok", _run_case(case)))
        except (ValueError, TypeError) as e:
            conn.send(("error", type(e).__name__, str(e)))
        except Exception as e:  # noqa: BLE001 (reported to the test, which fails)
            conn.send(("other", type(e).__name__, str(e)))


class _Pool:
    def __init__(self):
        self.proc = None
        self.conn = None

    def start(self):
        ctx = mp.get_context("spawn")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker, args=(child,), daemon=True)
        self.proc.start()

    def call(self, case):
        if self.proc is None or not self.proc.is_alive():
            self.start()
        self.conn.send(case)
        if not self.conn.poll(CASE_TIMEOUT + 60.0 * (self._first())):
            self.proc.kill()
            self.proc.join()
            self.proc = None
            pytest.fail(f"no answer within {CASE_TIMEOUT} s (a hang) for {case!r}")
        return self.conn.recv()

    def _first(self):
        # the worker's first call also imports hoprover (numba's cache, or a compile)
        first = not getattr(self, "_warm", False)
        self._warm = True
        return first

    def close(self):
        if self.proc is not None and self.proc.is_alive():
            self.conn.send(None)
            self.proc.join(5)


@pytest.fixture(scope="module")
def pool():
    sys.path.insert(0, os.path.dirname(__file__))
    p = _Pool()
    yield p
    p.close()


# ---------------------------------------------------------------------------------
# Values: good ones of each kind, and bad ones of every type, sign and magnitude
# ---------------------------------------------------------------------------------
BAD_SCALARS = st.sampled_from(
    [
        float("nan"),
        float("inf"),
        -float("inf"),
        0.0,
        -1.0,
        1e300,
        -1e300,
        1e-300,
        5e-324,
        True,
        False,
        None,
        "1",
        "abc",
        1 + 2j,
        [1.0],
        [],
        (1.0, 2.0),
        {"a": 1},
        np.float32(np.nan),
        np.bool_(True),
        np.array([1.0, 2.0]),
        object(),
    ]
)


def mixed(good):
    return st.one_of(good, good, BAD_SCALARS)


def positive(lo, hi):
    return st.one_of(
        st.floats(lo, hi), st.sampled_from([np.float32(lo * 2), np.int64(max(1, hi // 2))])
    )


def names_an_argument(message, names):
    return any(n in message for n in names)


def check_outcome(outcome, names, case):
    status = outcome[0]
    if status == "ok":
        return
    assert status == "error", f"{outcome[1]}: {outcome[2]} (not ValueError/TypeError) for {case!r}"
    assert names_an_argument(outcome[2], names), (
        f"message does not name the argument: {outcome[1]}: {outcome[2]} for {case!r}"
    )


PARAM_FIELDS = [
    "mass",
    "inertia",
    "half_width",
    "half_height",
    "gravity",
    "mu_static",
    "mu_dynamic",
    "restitution_x",
    "restitution_y",
    "v_xmin",
    "v_ymin",
    "torque_min",
    "torque_max",
    "band_half_width",
    "dwell_time",
]
GOOD_PARAM = {
    "mass": positive(0.1, 10.0),
    "inertia": positive(1e-3, 1e-2),
    "mu_static": st.floats(0.5, 1.0),
    "mu_dynamic": st.floats(0.0, 0.5),
    "restitution_x": st.floats(0.0, 1.0),
    "restitution_y": st.floats(0.0, 1.0),
    "torque_max": st.floats(1e-5, 1e-2),
    "gravity": positive(1e-5, 1e-3),
}


@st.composite
def param_kwargs(draw):
    keys = draw(st.lists(st.sampled_from(PARAM_FIELDS), max_size=3, unique=True))
    return {k: draw(mixed(GOOD_PARAM.get(k, positive(1e-3, 1.0)))) for k in keys}


@settings(max_examples=2 * settings.default.max_examples)
@given(kw=param_kwargs())
def test_fuzz_rover_params(pool, kw):
    case = ("params", kw)
    check_outcome(pool.call(case), list(kw) + ["RoverParams", "Painleve"], case)


@st.composite
def simulate_cases(draw):
    controller = draw(
        st.one_of(
            st.lists(mixed(st.floats(-1e-3, 1e-3)), min_size=0, max_size=4),
            st.sampled_from(
                [
                    np.zeros((2, 2)),
                    np.array(["1e-4"]),
                    np.array([True]),
                    np.array([1e-4 + 1j]),
                    np.full(3, 1e10),
                    np.full(2, -1e300),
                ]
            ),
            st.sampled_from(["1e-4", None, 3.0]),
        )
    )
    kw = {"controller": controller}
    for key, good in (
        ("t_end", positive(0.5, 200.0)),
        ("control_dt", positive(0.05, 50.0)),
        ("target_x", st.floats(-2.0, 2.0)),
        ("sample_dt", positive(0.1, 10.0)),
        (
            "initial_state",
            st.sampled_from([(0.0, 0.05, 0.0, 0.0, 0.0, 0.0), (0.0, 0.05, 0.0, 1e-3, 0.0, 0.0)]),
        ),
        ("params", st.builds(dict)),
        ("impact_law", st.sampled_from(["contest", "dissipative"])),
        ("rtol", st.floats(1e-12, 1e-8)),
    ):
        if draw(st.booleans()):
            v = draw(mixed(good))
            if key == "params" and isinstance(v, dict):
                continue
            kw[key] = v
    return kw


@settings(max_examples=3 * settings.default.max_examples)
@given(kw=simulate_cases())
def test_fuzz_simulate(pool, kw):
    case = ("simulate", dict(kw))
    names = [k for k in kw if k != "controller"] + [
        "torque",
        "schedule",
        "controller",
        "t_end / control_dt",
    ]
    check_outcome(pool.call(case), names, case)


@st.composite
def advance_cases(draw):
    init = {}
    if draw(st.booleans()):
        init["target_x"] = draw(mixed(st.floats(-2.0, 2.0)))
    return {
        "init": init,
        "torque": draw(mixed(st.floats(-1e-3, 1e-3))),
        "t_stop": draw(mixed(st.floats(0.0, 300.0))),
        "stop_on": draw(st.sampled_from([None, "liftoff", "impact", "ttrtp", "liftof", 3, None])),
    }


@settings(max_examples=2 * settings.default.max_examples)
@given(kw=advance_cases())
def test_fuzz_rover_sim_advance(pool, kw):
    case = ("advance", kw)
    check_outcome(pool.call(case), ["target_x", "torque", "t_stop", "stop_on"], case)


ENV_KEYS = {
    "control_dt": positive(0.1, 5.0),
    "episode_time": positive(10.0, 600.0),
    "target_x": st.floats(-1.0, 1.0),
    "target_range": st.sampled_from([(-1, 1), (0, 0.5)]),
    "randomize": st.sampled_from([{"mass": 0.1}, {}]),
    "time_cost": st.floats(0, 0.1),
    "gamma": st.floats(0.5, 1.0),
    "action_map": st.sampled_from(["linear", "cubic"]),
    "action_scale": st.floats(0.1, 1.0),
    "shaping": st.sampled_from(["landing", "none"]),
    "params": st.sampled_from([{"mass": 2.0}, {"mass": -1.0}, {"massive": 1.0}]),
    "integrator": st.sampled_from(["event", "euler", "rk4"]),
    "nonsense_key": st.just(1),
}


@st.composite
def make_cases(draw):
    keys = draw(st.lists(st.sampled_from(sorted(ENV_KEYS)), max_size=3, unique=True))
    return {k: draw(mixed(ENV_KEYS[k])) for k in keys}


@settings(max_examples=2 * settings.default.max_examples)
@given(kw=make_cases())
def test_fuzz_gym_make(pool, kw):
    case = ("make", kw)
    check_outcome(pool.call(case), list(kw) + ["RoverParams"], case)


ACTIONS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    BAD_SCALARS,
    st.sampled_from(
        [
            np.zeros(1),
            np.zeros((1, 1)),
            np.zeros(2),
            np.array([0.5 + 1j]),
            np.array(["0.5"]),
            np.array([True]),
            np.zeros(1, np.float32),
            np.full(1, 1e300),
            np.array([np.nan]),
            np.zeros(1, np.int64),
            [0.2],
            np.zeros(0),
        ]
    ),
)


@settings(max_examples=2 * settings.default.max_examples)
@given(action=ACTIONS)
def test_fuzz_env_step(pool, action):
    case = ("step", {"action": action})
    check_outcome(pool.call(case), ["action"], case)


@st.composite
def vector_cases(draw):
    n = draw(st.sampled_from([1, 4, 4, True, 0, -2, 2.5, "4"]))
    m = n if isinstance(n, int) and not isinstance(n, bool) and n > 0 else 4
    actions = draw(
        st.one_of(
            st.sampled_from(
                [
                    np.zeros((m, 1)),
                    np.zeros(m),
                    np.zeros((1, m)),
                    np.zeros((m, 2)),
                    np.zeros((m, 1), np.float32),
                    np.full((m, 1), np.nan),
                    np.zeros((m, 1), complex),
                    np.zeros((m, 1), bool),
                    [[0.1]] * m,
                    np.zeros((2, 2)),
                    "0.5",
                    None,
                ]
            ),
            BAD_SCALARS,
        )
    )
    return {"num_envs": n, "actions": actions}


@settings(max_examples=2 * settings.default.max_examples)
@given(kw=vector_cases())
def test_fuzz_vector_step(pool, kw):
    case = ("vstep", kw)
    check_outcome(pool.call(case), ["num_envs", "actions"], case)
