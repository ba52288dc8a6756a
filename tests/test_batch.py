"""simulate_batch: run i of a batch equals simulate() of run i, bit for bit."""
import math

import numba
import numpy as np
import pytest

from hoprover_env import BatchRollout, RoverParams, simulate_batch, simulate
from helpers import batch_on_one_and_all_threads
from test_rollout import assert_identical


def random_batch(rng, n, k, control_dt):
    sched = 5e-4 * rng.uniform(-1, 1, (n, k))
    sched[rng.random(n) < 0.5] *= 0.1                     # some gentle, some violent
    targets = rng.uniform(-1, 1, n)
    return sched, targets


@pytest.mark.parametrize("integrator, law", [("event", "contest"), ("event", "dissipative"),
                                             ("euler", "contest")])
def test_batch_runs_equal_simulate(integrator, law):
    rng = np.random.default_rng(5)
    n, control_dt = 12, 0.5
    sched, targets = random_batch(rng, n, 160, control_dt)
    initial = np.tile([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], (n, 1))
    initial[::3, 1] = 0.2                                  # some start in the air, spinning
    initial[::3, 5] = rng.uniform(-0.05, 0.05, len(initial[::3]))
    kw = dict(t_end=120.0, control_dt=control_dt, integrator=integrator, impact_law=law,
              euler_dt=1e-3)
    b = simulate_batch(sched, targets, initial_states=initial,
                       randomize={"mu_static": 0.3, "gravity": 0.3, "inertia": 0.2}, seed=3,
                       **kw)
    assert isinstance(b, BatchRollout) and len(b) == n
    assert len({p.gravity for p in b.params}) == n          # the parameters were drawn
    for i in range(n):
        ref = simulate(sched[i], target_x=targets[i], params=b.params[i],
                       initial_state=initial[i], **kw)
        assert_identical(b.rollout(i), ref)
        assert b.ttrtp[i] == (math.nan if ref.ttrtp is None else ref.ttrtp) or \
            (ref.ttrtp is None and math.isnan(b.ttrtp[i]))
        assert b.broken[i] == ref.broken and b.n_events[i] == ref.n_events
        m = b.n_samples[i]
        assert np.array_equal(b.x[i, :m], ref.x) and np.all(np.isnan(b.x[i, m:]))
        assert "".join(b.state[i, :m]) == "".join(ref.state)


def test_batch_with_sample_dt_and_parameter_list():
    rng = np.random.default_rng(8)
    sched, targets = random_batch(rng, 4, 40, 1.0)
    plist = [RoverParams(), {"mu_static": 0.4, "mu_dynamic": 0.3}, RoverParams(gravity=2e-4),
             RoverParams(restitution_y=0.5)]
    b = simulate_batch(sched, targets, t_end=50.0, control_dt=1.0, sample_dt=0.3,
                       params=plist)
    for i in range(4):
        ref = simulate(sched[i], t_end=50.0, control_dt=1.0, sample_dt=0.3,
                       target_x=targets[i], params=b.params[i])
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
    args = np.array([[3e-4, 4.0, 0.15, 0.9], [-2e-4, 6.0, 0.1, 0.8], [4e-4, 2.0, 0.2, 1.0],
                     [1e-4, 10.0, 0.15, 0.9], [-5e-4, 3.0, 0.15, 0.9], [0.0, 0.0, 0.1, 0.5]])
    targets = np.linspace(-0.8, 0.8, n)
    b = simulate_batch(launch_by_args, targets, t_end=300.0, control_dt=0.1,
                       controller_args=args)
    assert np.all(b.torque_cmd[:, 0] == args[:, 0])      # posT[2] reached run i's controller
    for i in range(n):
        a0, a1, kp, kd = args[i]

        def python_twin(pos, vel, the, omg, posT, t, smt, state, a=args[i]):
            full = np.concatenate([posT, a])
            return launch_by_args.py_func(pos, vel, the, omg, full, t, smt,
                                          "ABCDEFG".index(state))

        assert_identical(b.rollout(i), simulate(python_twin, t_end=300.0, control_dt=0.1,
                                                target_x=targets[i]))
    # without arguments a compiled controller batch equals simulate of the same function
    from test_rollout import hold_then_launch
    b2 = simulate_batch(hold_then_launch, targets[:3], t_end=200.0, control_dt=0.2)
    for i in range(3):
        assert_identical(b2.rollout(i), simulate(hold_then_launch, t_end=200.0,
                                                 control_dt=0.2, target_x=targets[i]))


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


def test_event_logs_grow_per_batch():
    # a stress case with thousands of Euler events in one run, next to quiet runs
    from agents.stress import families as stress_families
    from agents.stress.drivers import TARGET_X
    spec = next(s for s in stress_families.family_found_cases(np.random.default_rng(0), True)
                if s.integrator == "euler" and s.label.startswith("Euler micro-bounces"))
    init = np.array([spec.initial, (0, 0.05, 0, 0, 0, 0), spec.initial])
    sched = np.array([[spec.sched[0]], [0.0], [0.5 * spec.sched[0]]])
    kw = dict(t_end=spec.t_end, control_dt=spec.control_dt, integrator="euler",
              impact_law=spec.law)
    b = simulate_batch(sched, np.full(3, TARGET_X), initial_states=init, **kw)
    assert b.n_logged[0] > 1000 and b.event_log.shape[1] >= b.n_logged.max()
    for i in range(3):
        assert_identical(b.rollout(i), simulate(sched[i], target_x=TARGET_X,
                                                initial_state=init[i], **kw))


@numba.njit
def nan_in_run_two(pos, vel, the, omg, posT, t, smt, state_code):
    return math.nan if posT[0] == 2.0 and t > 1.0 else 0.0


@pytest.mark.parametrize("call, error, words", [
    (lambda: simulate_batch(np.zeros((3, 4)), np.zeros(2)), ValueError, "3 rows for 2"),
    (lambda: simulate_batch(np.zeros(4), np.zeros(4)), ValueError, r"shape \(N, K\)"),
    (lambda: simulate_batch(np.where(np.arange(12).reshape(3, 4) == 9, np.nan, 0.0),
                            np.zeros(3)), ValueError, "run 2: torque schedule element 1"),
    (lambda: simulate_batch(np.zeros((3, 2)), [0.0, np.inf, 0.0]), ValueError, "run 1"),
    (lambda: simulate_batch(np.zeros((3, 2)), np.zeros(3),
                            params=[RoverParams(), RoverParams(), {"mu_static": 2.0}]),
     ValueError, "run 2: RoverParams.mu_static"),
    (lambda: simulate_batch(np.zeros((3, 2)), np.zeros(3), params=[RoverParams()] * 2),
     ValueError, "2 entries for 3 runs"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2),
                            initial_states=[(0, 0.05, 0, 0, 0, 0), (0, 0.01, 0, 0, 0, 0)]),
     ValueError, "run 1: initial_state"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), initial_states=np.zeros((2, 5))),
     ValueError, "initial_states must have shape"),
    (lambda: simulate_batch(nan_in_run_two, np.arange(4.0), t_end=5.0, control_dt=1.0),
     ValueError, "run 2: the controller's torque must be finite"),
    (lambda: simulate_batch(lambda *a: 0.0, np.zeros(2)), TypeError, "numba-compiled"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), controller_args=np.zeros((2, 1))),
     ValueError, "controller_args"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=-1.0), ValueError, "t_end"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=True), ValueError, "t_end"),
    (lambda: simulate_batch(np.zeros((2, 2)), ["0.1", "0.2"]), ValueError, "targets must hold"),
    (lambda: simulate_batch(np.zeros((2, 2), bool), np.zeros(2)), ValueError,
     "torque schedules must hold"),
    (lambda: simulate_batch(np.zeros((2, 2), complex), np.zeros(2)), ValueError,
     "torque schedules must hold"),
    (lambda: simulate_batch([[0.0, 1e-4], [0.0, 1e-4], [1e-4]], np.zeros(3)), ValueError,
     "run 2: torque schedules row has 1 entries"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2),
                            initial_states=[(0, 0.05, 0, 0, 0, 0), (0, 0.05, 0, 0, 0)]),
     ValueError, "run 1: initial_states row has 5"),
    (lambda: simulate_batch(np.zeros((2, 2)), np.zeros(2), t_end=1e300), ValueError,
     "at most"),
    (lambda: simulate_batch(np.zeros((5000, 2)), np.zeros(5000), t_end=600.0,
                            control_dt=0.001), ValueError, "record=False"),
])
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
        simulate_batch(sched, targets, t_end=20.0, control_dt=0.5)     # always threaded
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)
