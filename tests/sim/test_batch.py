"""simulate_batch: run i of a batch equals simulate() of run i, bit for bit."""

import math

import numba
import numpy as np
import pytest

from helpers import assert_identical, batch_on_one_and_all_threads
from hoprover_env import BatchRollout, RoverParams, simulate, simulate_batch
from hoprover_env.core.params import FIELDS, as_arrays, invalid_rows
from hoprover_env.sim import batch as batch_module
from hoprover_env.sim import randomize as rz
from hoprover_env.sim.simulate import make_state


def random_batch(rng, n, k, control_dt):
    sched = 5e-4 * rng.uniform(-1, 1, (n, k))
    sched[rng.random(n) < 0.5] *= 0.1  # some gentle, some violent
    targets = rng.uniform(-1, 1, n)
    return sched, targets


@pytest.mark.parametrize(
    "integrator, law", [("event", "contest"), ("event", "dissipative"), ("euler", "contest")]
)
def test_batch_runs_equal_simulate(integrator, law):
    rng = np.random.default_rng(5)
    n, control_dt = 12, 0.5
    sched, targets = random_batch(rng, n, 160, control_dt)
    initial = np.tile([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], (n, 1))
    initial[::3, 1] = 0.2  # some start in the air, spinning
    initial[::3, 5] = rng.uniform(-0.05, 0.05, len(initial[::3]))
    kw = dict(
        t_end=120.0, control_dt=control_dt, integrator=integrator, impact_law=law, euler_dt=1e-3
    )
    b = simulate_batch(
        sched,
        targets,
        initial_states=initial,
        randomize={"mu_static": 0.3, "gravity": 0.3, "inertia": 0.2},
        seed=3,
        **kw,
    )
    assert isinstance(b, BatchRollout) and len(b) == n
    assert len({p.gravity for p in b.params}) == n  # the parameters were drawn
    for i in range(n):
        ref = simulate(
            sched[i], target_x=targets[i], params=b.params[i], initial_state=initial[i], **kw
        )
        assert_identical(b.rollout(i), ref)
        assert b.ttrtp[i] == (math.nan if ref.ttrtp is None else ref.ttrtp) or (
            ref.ttrtp is None and math.isnan(b.ttrtp[i])
        )
        assert b.broken[i] == ref.broken and b.n_events[i] == ref.n_events
        m = b.n_samples[i]
        assert np.array_equal(b.x[i, :m], ref.x) and np.all(np.isnan(b.x[i, m:]))
        assert "".join(b.state[i, :m]) == "".join(ref.state)


def test_batch_with_sample_dt_and_parameter_list():
    rng = np.random.default_rng(8)
    sched, targets = random_batch(rng, 4, 40, 1.0)
    plist = [
        RoverParams(),
        {"mu_static": 0.4, "mu_dynamic": 0.3},
        RoverParams(gravity=2e-4),
        RoverParams(restitution_y=0.5),
    ]
    b = simulate_batch(sched, targets, t_end=50.0, control_dt=1.0, sample_dt=0.3, params=plist)
    for i in range(4):
        ref = simulate(
            sched[i],
            t_end=50.0,
            control_dt=1.0,
            sample_dt=0.3,
            target_x=targets[i],
            params=b.params[i],
        )
        assert_identical(b.rollout(i), ref)
    assert b.params[1] == RoverParams(mu_static=0.4, mu_dynamic=0.3)


@numba.njit
def launch_by_args(pos, vel, the, omg, posT, t, smt, state_code):
    """posT[2] = launch torque, posT[3] = launch window [s], posT[4:6] = hold gains."""
    if state_code == 0:
        th = (the + math.pi) % (2 * math.pi) - math.pi
        return -0.0017 * (posT[4] * th + posT[5] * omg)
    if t < posT[3]:
        return posT[2]
    return 0.0


def test_compiled_controller_batch_and_controller_args():
    n = 6
    args = np.array(
        [
            [3e-4, 4.0, 0.15, 0.9],
            [-2e-4, 6.0, 0.1, 0.8],
            [4e-4, 2.0, 0.2, 1.0],
            [1e-4, 10.0, 0.15, 0.9],
            [-5e-4, 3.0, 0.15, 0.9],
            [0.0, 0.0, 0.1, 0.5],
        ]
    )
    targets = np.linspace(-0.8, 0.8, n)
    b = simulate_batch(launch_by_args, targets, t_end=300.0, control_dt=0.1, controller_args=args)
    assert np.all(b.torque_cmd[:, 0] == args[:, 0])  # posT[2] reached run i's controller
    for i in range(n):
        a0, a1, kp, kd = args[i]

        def python_twin(pos, vel, the, omg, posT, t, smt, state, a=args[i]):
            full = np.concatenate([posT, a])
            return launch_by_args.py_func(pos, vel, the, omg, full, t, smt, "ABCDEFG".index(state))

        assert_identical(
            b.rollout(i), simulate(python_twin, t_end=300.0, control_dt=0.1, target_x=targets[i])
        )
    # without arguments a compiled controller batch equals simulate of the same function
    from test_rollout import hold_then_launch

    b2 = simulate_batch(hold_then_launch, targets[:3], t_end=200.0, control_dt=0.2)
    for i in range(3):
        assert_identical(
            b2.rollout(i),
            simulate(hold_then_launch, t_end=200.0, control_dt=0.2, target_x=targets[i]),
        )


def test_threads_and_record_do_not_change_results():
    rng = np.random.default_rng(1)
    sched, targets = random_batch(rng, 16, 100, 0.5)
    kw = dict(t_end=100.0, control_dt=0.5)
    one, many = batch_on_one_and_all_threads(sched, targets, **kw)
    summary = simulate_batch(sched, targets, record=False, **kw)
    for other in (many, summary):
        assert np.array_equal(one.ttrtp, other.ttrtp, equal_nan=True)
        assert np.array_equal(one.final, other.final)
        assert np.array_equal(one.n_events, other.n_events)
    assert np.array_equal(one.x, many.x, equal_nan=True)
    assert summary.x.shape == (16, 0)
    assert_identical(summary.rollout(7), one.rollout(7))


@numba.njit
def nan_in_run_two(pos, vel, the, omg, posT, t, smt, state_code):
    return math.nan if posT[0] == 2.0 and t > 1.0 else 0.0


@pytest.mark.parametrize(
    "call, error, words",
    [
        (lambda: simulate_batch(np.zeros((3, 4)), np.zeros(2)), ValueError, "3 rows for 2"),
        (lambda: simulate_batch(np.zeros(4), np.zeros(4)), ValueError, r"shape \(N, K\)"),
        (
            lambda: simulate_batch(
                np.where(np.arange(12).reshape(3, 4) == 9, np.nan, 0.0), np.zeros(3)
            ),
            ValueError,
            "run 2: torque schedule element 1",
        ),
        (lambda: simulate_batch(np.zeros((3, 2)), [0.0, np.inf, 0.0]), ValueError, "run 1"),
        (
            lambda: simulate_batch(
                np.zeros((3, 2)),
                np.zeros(3),
                params=[RoverParams(), RoverParams(), {"mu_static": 2.0}],
            ),
            ValueError,
            "run 2: RoverParams.mu_static",
        ),
        (
            lambda: simulate_batch(np.zeros((3, 2)), np.zeros(3), params=[RoverParams()] * 2),
            ValueError,
            "2 entries for 3 runs",
        ),
        (
            lambda: simulate_batch(
                np.zeros((2, 2)),
                np.zeros(2),
                initial_states=[(0, 0.05, 0, 0, 0, 0), (0, 0.01, 0, 0, 0, 0)],
            ),
            ValueError,
            "run 1: initial_state",
        ),
        (
            lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), initial_states=np.zeros((2, 5))),
            ValueError,
            "initial_states must have shape",
        ),
        (
            lambda: simulate_batch(nan_in_run_two, np.arange(4.0), t_end=5.0, control_dt=1.0),
            ValueError,
            "run 2: the controller's torque must be finite",
        ),
        (lambda: simulate_batch(lambda *a: 0.0, np.zeros(2)), TypeError, "numba-compiled"),
        (
            lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), controller_args=np.zeros((2, 1))),
            ValueError,
            "controller_args",
        ),
        (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=-1.0), ValueError, "t_end"),
        (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=True), ValueError, "t_end"),
        (lambda: simulate_batch(np.zeros((2, 2)), ["0.1", "0.2"]), ValueError, "targets must hold"),
        (
            lambda: simulate_batch(np.zeros((2, 2), bool), np.zeros(2)),
            ValueError,
            "torque schedules must hold",
        ),
        (
            lambda: simulate_batch(np.zeros((2, 2), complex), np.zeros(2)),
            ValueError,
            "torque schedules must hold",
        ),
        (
            lambda: simulate_batch([[0.0, 1e-4], [0.0, 1e-4], [1e-4]], np.zeros(3)),
            ValueError,
            "run 2: torque schedules row has 1 entries",
        ),
        (
            lambda: simulate_batch(
                np.zeros((2, 2)),
                np.zeros(2),
                initial_states=[(0, 0.05, 0, 0, 0, 0), (0, 0.05, 0, 0, 0)],
            ),
            ValueError,
            "run 1: initial_states row has 5",
        ),
        (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=1e300), ValueError, "at most"),
        (
            lambda: simulate_batch(
                np.zeros((5000, 2)), np.zeros(5000), t_end=600.0, control_dt=0.001
            ),
            ValueError,
            "record=False",
        ),
    ],
)
def test_bad_input_names_the_run(call, error, words):
    with pytest.raises(error, match=words):
        call()


def test_rollout_index_checked():
    b = simulate_batch(np.zeros((2, 1)), np.zeros(2), t_end=1.0, control_dt=1.0)
    with pytest.raises(IndexError):
        b.rollout(2)
    assert_identical(b.rollout(-1), b.rollout(1))


def test_threaded_kernels_leave_the_callers_openmp_threads_alone():
    """numba's OpenMP layer sets the calling thread's OpenMP thread count at each
    threaded launch; torch shares that runtime, so an unguarded threaded step turned a
    training script's torch.set_num_threads(1) into 2 (and its updates 5x slower).
    simulate_batch and the threaded vector env must leave it as the caller set it."""
    torch = pytest.importorskip("torch")
    from hoprover_env import HopRoverVectorEnv

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        venv = HopRoverVectorEnv(64, threads=True)
        venv.reset(seed=0)
        venv.step(np.zeros((64, 1)))
        assert torch.get_num_threads() == 1
        sched, targets = random_batch(np.random.default_rng(2), 8, 20, 0.5)
        simulate_batch(sched, targets, t_end=20.0, control_dt=0.5)  # always threaded
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


# ---- the setup of a batch as arrays: the same numbers as the per-run path ----------------

NEAR_PAINLEVE = RoverParams(inertia=5e-4, mu_static=0.6, mu_dynamic=0.6)  # many redraws


def per_run_reference(n, targets, params=None, randomize=None, seed=None, initial_states=None):
    """What simulate_batch handed the kernel before it built its setup as arrays: one
    draw_params / RoverParams / make_state / as_array per run (its old Python loop)."""
    per_run = isinstance(seed, (np.ndarray, list, tuple))
    seeds = [int(s) for s in seed] if per_run else [seed] * n
    if randomize is not None:
        base = params if params is not None else RoverParams()
        rng = np.random.default_rng([int(s) for s in seed] if per_run else seed)
        rand = rz.check_randomize(randomize)
        plist = [rz.draw_params(base, rand, rng) for _ in range(n)]
    elif params is None or isinstance(params, RoverParams):
        plist = [params or RoverParams()] * n
    else:
        plist = [p if isinstance(p, RoverParams) else RoverParams(**p) for p in params]
    init = np.asarray(initial_states, float) if initial_states is not None else None
    S = np.array(
        [
            make_state(
                plist[i],
                float(targets[i]),
                None if init is None else (init if init.ndim == 1 else init[i]),
                seeds[i],
                0 if per_run else i,
            )
            for i in range(n)
        ]
    )
    P = np.array([p.as_array() for p in plist])
    return plist, S, P


def kernel_inputs(monkeypatch, *args, **kw):
    """simulate_batch(*args, **kw) and the state and parameter arrays it handed the
    kernel (copied before the runs)."""
    seen = {}
    real = batch_module._run_threaded

    def spy(run_many, buf, S, P, *rest):
        seen["S"], seen["P"] = S.copy(), P.copy()
        return real(run_many, buf, S, P, *rest)

    monkeypatch.setattr(batch_module, "_run_threaded", spy)
    b = simulate_batch(*args, **kw)
    monkeypatch.setattr(batch_module, "_run_threaded", real)
    return b, seen["S"], seen["P"]


def same_bits(a, b):
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


SETUPS = [
    dict(),
    dict(params=RoverParams(gravity=2e-4, slope=-0.1)),
    dict(randomize={"mass": 0.1, "mu_static": 0.2, "inertia": 0.1}, seed=7),
    dict(
        params=NEAR_PAINLEVE,
        randomize={"inertia": 0.5, "mu_dynamic": 0.3, "mu_static": 0.3},
        seed=11,
    ),
    dict(
        params=NEAR_PAINLEVE,
        randomize={"inertia": 0.9, "half_height": 0.5, "restitution_x": 0.5, "mu_dynamic": 0.5},
        seed=np.arange(300, dtype=np.uint64) * 7919 + 2**40,
    ),
    dict(randomize={"gravity": 0.3, "restitution_y": 0.9}, seed=list(range(300))),
    dict(
        params=[
            RoverParams(),
            {"mu_static": 0.4, "mu_dynamic": 0.3},
            RoverParams(slope=0.2, roughness=0.05),
        ]
        * 100,
        seed=5,
    ),
    dict(
        params=RoverParams(roughness=0.1),
        seed=2**64 - 1,
        initial_states=(0.1, 0.3, 0.4, 0.0, 0.01, -0.02),
    ),
    dict(seed=np.arange(300) + 3, initial_states="per run"),
]


@pytest.mark.parametrize("setup", SETUPS, ids=range(len(SETUPS)))
def test_batch_setup_equals_the_per_run_path(monkeypatch, setup):
    """Every state and parameter row simulate_batch hands the kernel, and every run's
    RoverParams, equal the old per-run loop's bit for bit: randomize (Painleve redraws
    included, one seed or one per run), parameter sequences, initial states, seeds."""
    n = 300
    rng = np.random.default_rng(4)
    targets = rng.uniform(-1, 1, n)
    setup = dict(setup)
    if isinstance(setup.get("initial_states"), str):
        init = np.tile([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], (n, 1))
        init[::2, 1] = rng.uniform(0.06, 0.3, len(init[::2]))  # in flight
        init[::2, 5] = rng.uniform(-0.1, 0.1, len(init[::2]))
        setup["initial_states"] = init
    b, S, P = kernel_inputs(
        monkeypatch, np.zeros((n, 2)), targets, t_end=1.0, control_dt=0.5, record=False, **setup
    )
    plist, S_ref, P_ref = per_run_reference(n, targets, **setup)
    assert same_bits(P, P_ref) and same_bits(S, S_ref)
    assert len(b.params) == n and list(b.params) == plist
    assert same_bits(as_arrays(b.params), P_ref)


def test_randomized_batch_runs_equal_simulate():
    """Runs of a randomised batch (one seed per run, per-run initial states, Painleve
    redraws) equal simulate() of each run with its parameters and seed."""
    n = 10
    rng = np.random.default_rng(9)
    sched, targets = random_batch(rng, n, 60, 0.5)
    init = np.tile([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], (n, 1))
    init[::2, 1] = 0.15
    seeds = rng.integers(0, 2**63, n).astype(np.uint64)
    kw = dict(t_end=30.0, control_dt=0.5)
    b = simulate_batch(
        sched,
        targets,
        params=NEAR_PAINLEVE,
        initial_states=init,
        randomize={"inertia": 0.5, "mu_dynamic": 0.3, "mu_static": 0.3},
        seed=seeds,
        **kw,
    )
    ref_rng = np.random.default_rng(seeds.tolist())
    rand = rz.check_randomize({"inertia": 0.5, "mu_dynamic": 0.3, "mu_static": 0.3})
    for i in range(n):
        assert b.params[i] == rz.draw_params(NEAR_PAINLEVE, rand, ref_rng)
        assert_identical(
            b.rollout(i),
            simulate(
                sched[i],
                target_x=targets[i],
                params=b.params[i],
                initial_state=init[i],
                seed=int(seeds[i]),
                **kw,
            ),
        )


def test_draw_fields_is_the_stream_of_draw_params(monkeypatch):
    """n draws as arrays give the numbers of n draw_params calls, leave the generator
    where they leave it, and raise where they raise (a run refused MAX_DRAWS times in a
    row; MAX_DRAWS lowered so that it happens, on a base where 7 draws in 8 fail)."""

    def one_by_one(base, rand, rng, n):
        return np.array(
            [
                [getattr(p, f) for f in FIELDS]
                for p in (rz.draw_params(base, rand, rng) for _ in range(n))
            ]
        )

    cases = [
        (RoverParams(), {"mass": 0.2, "mu_dynamic": 0.5, "mu_static": 0.5}),
        (NEAR_PAINLEVE, {"inertia": 0.9, "half_height": 0.5, "mu_dynamic": 0.5}),
        (RoverParams(gravity=1e9), {"gravity": 0.9, "mass": np.float32(0.3), "inertia": 0}),
        (RoverParams(), {}),
    ]
    for base, rand in cases:
        rand = rz.check_randomize(rand)
        for seed in range(8):
            a, b = np.random.default_rng(seed), np.random.default_rng(seed)
            assert same_bits(rz.draw_fields(base, rand, a, 200), one_by_one(base, rand, b, 200))
            assert a.random() == b.random()
    base = RoverParams(gravity=1e9, mass=1e9, inertia=1e9)
    rand = rz.check_randomize({"gravity": 0.5, "mass": 0.5, "inertia": 0.5})
    outcomes = set()
    for limit in (9, 14, 25):
        monkeypatch.setattr(rz, "MAX_DRAWS", limit)
        for seed in range(30):
            got = []
            for fn in (rz.draw_fields, one_by_one):
                try:
                    got.append(fn(base, rand, np.random.default_rng(seed), 12))
                except ValueError as err:
                    got.append(str(err))
            if isinstance(got[0], str):
                assert got[0] == got[1] and f"{limit} draws in a row" in got[0]
            else:
                assert same_bits(*got)
            outcomes.add(isinstance(got[0], str))
    assert outcomes == {True, False}


def test_invalid_rows_is_the_constructors_verdict():
    """The vectorised check of parameter rows agrees with RoverParams on rows around
    every limit, the Painleve one included."""
    rng = np.random.default_rng(3)
    base = np.array([getattr(NEAR_PAINLEVE, f) for f in FIELDS])
    rows = np.tile(base, (4000, 1))
    rows[:, :9] *= rng.uniform(0.3, 1.7, (4000, 9))
    rows[::7, 9] = -1e-9  # v_xmin < 0
    rows[::11, 15] = rng.uniform(-0.6, 0.6, len(rows[::11]))  # slopes beyond 0.5
    rows[::13, 0] = 2e9  # beyond 1e9
    rows[::17, 16] = np.nan
    verdict = np.array([_refused(r) for r in rows])
    assert 0.2 < verdict.mean() < 0.9
    assert np.array_equal(invalid_rows(rows), verdict)
    # within ulps of the Painleve limit, where the constructor decides
    at_limit = []
    for _ in range(40):
        kw = dict(
            mass=rng.uniform(0.1, 10),
            half_width=rng.uniform(0.01, 0.2),
            half_height=rng.uniform(0.01, 0.2),
            mu_static=1.0,
            mu_dynamic=rng.uniform(0.2, 1.0),
        )
        lo, hi = 1e-12, 10.0  # the smallest inertia RoverParams accepts
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            try:
                RoverParams(inertia=mid, **kw)
                hi = mid
            except ValueError:
                lo = mid
        row = np.array([getattr(RoverParams(inertia=hi, **kw), f) for f in FIELDS])
        for d in np.concatenate([np.arange(-4, 5) * 1e-16, rng.uniform(-1e-9, 1e-9, 4)]):
            at_limit.append(row.copy())
            at_limit[-1][FIELDS.index("inertia")] = hi * (1.0 + d)
    at_limit = np.array(at_limit)
    verdict = np.array([_refused(r) for r in at_limit])
    assert 0.2 < verdict.mean() < 0.8
    assert np.array_equal(invalid_rows(at_limit), verdict)


def _refused(row):
    try:
        RoverParams(**dict(zip(FIELDS, map(float, row))))
    except ValueError:
        return True
    return False


def test_per_seed_generator_is_default_rngs():
    for seeds in (
        np.arange(40, dtype=np.uint64),
        np.array([0, 1, 2**32 - 1, 2**32, 2**64 - 1], dtype=np.uint64),
        np.random.default_rng(1).integers(0, 2**63, 500).astype(np.uint64),
    ):
        assert same_bits(
            rz.rng_for_seeds(seeds).random(20), np.random.default_rng(seeds.tolist()).random(20)
        )


def test_run_params_are_built_on_demand():
    b = simulate_batch(
        np.zeros((5, 1)),
        np.zeros(5),
        t_end=1.0,
        control_dt=1.0,
        randomize={"mass": 0.1},
        seed=3,
        record=False,
    )
    assert isinstance(b.params, batch_module.RunParams) and len(b.params) == 5
    ref = [
        rz.draw_params(RoverParams(), {"mass": 0.1}, rng)
        for rng in [np.random.default_rng(3)]
        for _ in range(5)
    ]
    assert b.params == ref and b.params[-1] == ref[4] and b.params[1:3] == ref[1:3]
    assert b.params[2] is b.params[2]
    with pytest.raises(IndexError):
        b.params[5]
    one = RoverParams(gravity=2e-4)
    b = simulate_batch(np.zeros((3, 1)), np.zeros(3), t_end=1.0, params=one, record=False)
    assert all(p is one for p in b.params)


REST = np.tile([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], (4, 1))


@pytest.mark.parametrize(
    "kw, words",
    [
        (dict(seed=np.array([1, 2, -3, 4])), r"run 2: seed must be None or an integer"),
        (dict(seed=[1, 2, 3, 2**64]), r"run 3: seed must be None or an integer"),
        (dict(seed=[1, 2, None, 4]), r"run 2: seed must be"),
        (dict(seed=np.array([1.0, 2.0, 3.0, 4.0])), r"integer array of shape \(4,\)"),
        (dict(seed=np.arange(3)), r"integer array of shape \(4,\)"),
        (
            dict(params=[RoverParams(), RoverParams(), "x", RoverParams()]),
            r"run 2: params must be a RoverParams",
        ),
        (
            dict(params=[RoverParams(), {"mass": -1.0}, RoverParams(), RoverParams()]),
            r"run 1: RoverParams.mass must be positive",
        ),
        (
            dict(initial_states=np.where(np.arange(24).reshape(4, 6) == 13, np.nan, REST)),
            r"run 2: initial_state must be 6 finite numbers",
        ),
        (
            dict(initial_states=np.where(np.arange(24).reshape(4, 6) == 18, 2e9, REST)),
            r"run 3: initial_state .* beyond",
        ),
        (dict(targets=np.array([0.0, 2e9, 0.0, 0.0])), r"run 1: initial_state .* target_x"),
        (
            dict(initial_states=(0.0, 0.01, 0.0, 0.0, 0.0, 0.0)),
            r"run 0: initial_state .* not consistent",
        ),
    ],
)
def test_per_run_arrays_name_the_first_bad_run(kw, words):
    kw = dict(kw)
    targets = kw.pop("targets", np.zeros(4))
    with pytest.raises((TypeError, ValueError), match=words):
        simulate_batch(np.zeros((4, 1)), targets, t_end=1.0, record=False, **kw)
