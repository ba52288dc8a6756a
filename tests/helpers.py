"""Small shared pieces of the tests (contest-signature controllers). The state checks
live in hoprover_env.sim.invariants, shared with the benchmarks."""

import dataclasses
import math

import numpy as np

from hoprover_env import RoverSim
from hoprover_env.sim import controllers


def attitude_hold(the, omg, inertia=0.0017, kp=0.1, kd=0.8):
    """A PD torque that brings theta to 0 and omega to 0 in flight
    (hoprover_env.sim.controllers.attitude_hold with the tests' default gains)."""
    return controllers.attitude_hold(float(the), float(omg), inertia, kp, kd)


def launch_then_hold(torque, t_start=0.0, t_stop=None):
    """Contest controller: `torque` from t_start until the first flight (or t_stop),
    attitude hold in flight, idle afterwards."""
    mem = {"flown": False}

    def control(pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            mem["flown"] = True
            return attitude_hold(the, omg)
        if mem["flown"] or t < t_start or (t_stop is not None and t >= t_stop):
            return 0.0
        return torque

    return control


def first_landing(integrator, euler_dt=1e-3, torque=3e-4, control_dt=0.1, params=None):
    """Time and contact-point x of the first touchdown after a launch + attitude hold
    (contest parameters, or `params`: a slope, say)."""
    sim = RoverSim(params=params, target_x=0.5, integrator=integrator, euler_dt=euler_dt)
    control = launch_then_hold(torque)
    for k in range(10000):
        s = sim.s
        cmd = control(s[0:2], s[3:5], s[2], s[5], np.array([0.5, 0.0]), sim.t, 600.0, sim.mode)
        sim.advance(cmd, (k + 1) * control_dt, stop_on="impact")
        if sim.stopped:
            x, y, th = sim.state[:3]
            # the corner that touched: the lower one (A for th > 0)
            bx = 0.05 if th >= 0 else -0.05
            return sim.t, x + bx * math.cos(th) - 0.05 * math.sin(th)
    raise AssertionError("no landing")


def batch_on_one_and_all_threads(*args, **kw):
    """simulate_batch(*args, **kw) run on one numba thread and on all of them: the two
    BatchRollouts, to compare (the thread count must not change a bit)."""
    import numba

    from hoprover_env import simulate_batch

    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = simulate_batch(*args, **kw)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = simulate_batch(*args, **kw)
    finally:
        numba.set_num_threads(before)
    return one, many


def replay(schedule):
    """A Python controller that returns schedule[k] at the k-th control instant."""
    step = [0]

    def control(pos, vel, the, omg, posT, t, smt, state):
        k = step[0]
        step[0] += 1
        return float(schedule[k]) if k < len(schedule) else 0.0

    return control


def assert_identical(a, b):
    for f in dataclasses.fields(a):
        if not f.compare:  # replay_args: how to run it again, not the run
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, f.name
            # bit for bit: compare the raw bytes (NaN and -0.0 included)
            assert np.ascontiguousarray(x).tobytes() == np.ascontiguousarray(y).tobytes(), f.name
        else:
            assert x == y, f.name


# A SAC run of HopRoverRL-v1 small enough to train in seconds (64 steps of 2 envs, 16-unit
# layers), for tests of what surrounds training; each test changes what it checks.
TINY_SAC_V1 = {
    "algo": "sac",
    "env_id": "HopRoverRL-v1",
    "n_envs": 2,
    "timesteps": 64,
    "seed": 0,
    "env": {"flight_start": 0.5},
    "normalize": {"obs": True, "reward": False},
    "policy": {"net_arch": [16, 16]},
    "hyperparams": {"learning_starts": 32, "batch_size": 16, "gamma": 0.995},
    "evaluation": {"freq": 10_000, "episodes": 2, "seed": 7},
    "checkpoint": {"freq": 10_000},
}


def tiny_config(algo: str, policy: dict) -> dict:
    """TINY_SAC_V1 for another algorithm with this `policy` section (PPO takes none of
    its off-policy hyperparameters)."""
    cfg = {**TINY_SAC_V1, "algo": algo, "policy": policy}
    if algo == "ppo":
        cfg["hyperparams"] = {}
    return cfg


def write_config(tmp_path, cfg: dict) -> str:
    """`cfg` written as tmp_path/cfg.yaml; its path."""
    import yaml

    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


def train_run(tmp_path, cfg: dict = TINY_SAC_V1):
    """Train `cfg` with train.py into tmp_path/run; the run's directory."""
    from hoprover_env.training import train

    out = tmp_path / "run"
    args = ["--config", write_config(tmp_path, cfg), "--out", str(out), "--no-progress"]
    assert train.main(args) == 0
    return out


def train_tiny(tmp_path, cfg: dict = TINY_SAC_V1):
    """Train `cfg` with train.py into tmp_path/run; its last checkpoint's model path."""
    return train_run(tmp_path, cfg) / "checkpoints" / "last.zip"
