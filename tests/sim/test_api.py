"""The `simulate` / `RoverSim` API: inputs, outputs and errors."""

import math

import numpy as np
import pytest

from hoprover_env import RoverParams, RoverSim, simulate


def test_rollout_shape_and_samples():
    roll = simulate(np.full(30, 3e-4), t_end=10.0, control_dt=0.5, target_x=0.5)
    n = 21  # t = 0, 20 control instants... and the end
    assert roll.t.shape == (n,) and roll.t[0] == 0.0 and roll.t[-1] == 10.0
    np.testing.assert_allclose(roll.t, np.arange(n) * 0.5)
    for a in (roll.x, roll.y, roll.theta, roll.vx, roll.vy, roll.omega, roll.torque, roll.state):
        assert a.shape == (n,)
    assert roll.state[0] == "F" and set(roll.state) <= set("ABCDEFG")
    assert all(len(e) == 4 and isinstance(e[0], float) for e in roll.events)
    assert roll.events[0] == (0.0, "tip", "F", "B")


def test_torque_is_clipped_and_zero_after_the_schedule():
    roll = simulate([1.0, -1.0], t_end=3.0, control_dt=1.0, target_x=0.5)
    assert list(roll.torque[:3]) == [5e-4, -5e-4, 0.0]
    assert list(roll.torque_cmd[:3]) == [1.0, -1.0, 0.0]


def test_contest_controller_signature():
    seen = []

    def control(pos, vel, the, omg, posT, t, smt, state):
        seen.append((pos.shape, vel.shape, type(the), type(omg), tuple(posT), t, smt, state))
        return 0.0

    simulate(control, t_end=2.0, control_dt=1.0, target_x=0.7)
    assert seen[0] == ((2,), (2,), float, float, (0.7, 0.0), 0.0, 2.0, "F")
    assert [s[5] for s in seen] == [0.0, 1.0]


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), "x", None])
def test_bad_controller_torque_raises(bad):
    with pytest.raises(ValueError, match="the controller's torque must be"):
        simulate(lambda *a: bad, t_end=1.0, control_dt=0.5)


def test_bad_schedule_raises():
    with pytest.raises(ValueError, match="element 2 is nan"):
        simulate([0.0, 1e-4, float("nan")], t_end=5.0, control_dt=1.0)
    with pytest.raises(ValueError, match="1-D"):
        simulate(np.zeros((2, 2)), t_end=1.0)


def test_nan_torque_never_reaches_the_state():
    sim = RoverSim()
    before = sim.s.copy()
    with pytest.raises(ValueError):
        sim.advance(float("nan"), 1.0)
    assert np.array_equal(sim.s, before, equal_nan=True)


@pytest.mark.parametrize(
    "state, words",
    [
        ((0.0, 0.04, 0.0, 0.0, 0.0, 0.0), "below the ground"),
        ((0.0, 0.05, math.pi, 0.0, 0.0, 0.0), "top corner"),
        ((0.0, 0.05, 0.0, 0.0, -1e-3, 0.0), "moving down"),
        ((0.0, 0.05, 0.0, 0.0, 0.0, 0.0, 1.0), "6 finite numbers"),
        ((0.0, float("nan"), 0.0, 0.0, 0.0, 0.0), "6 finite numbers"),
    ],
)
def test_inconsistent_initial_state_raises(state, words):
    with pytest.raises(ValueError, match=words):
        simulate(np.zeros(1), t_end=1.0, initial_state=state)


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"integrator": "rk4"}, "integrator must be one of"),
        ({"impact_law": "newton"}, "impact_law must be one of"),
        ({"t_end": -1.0}, "t_end must be"),
        ({"control_dt": 0.0}, "control_dt must be"),
        ({"euler_dt": 0.0}, "euler_dt must be"),
        ({"rtol": 1.0}, "rtol must lie"),
        ({"target_x": float("nan")}, "target_x must be finite"),
    ],
)
def test_bad_arguments_raise(kw, words):
    with pytest.raises(ValueError, match=words):
        simulate(np.zeros(1), **{"t_end": 1.0, **kw})


def test_initial_states_are_classified():
    p = RoverParams()
    assert RoverSim(initial_state=(0.0, 0.3, 0.2, 0.0, 0.0, 0.0)).mode == "A"
    assert RoverSim(initial_state=(0.0, p.half_height, 0.0, 1e-3, 0.0, 0.0)).mode == "G"
    th = 0.3
    dy = -p.half_width * math.sin(th) - p.half_height * math.cos(th)
    assert RoverSim(initial_state=(0.0, -dy, th, 0.0, 0.0, 0.0)).mode == "B"
    assert RoverSim(initial_state=(0.0, -dy, th, 1e-3, 0.0, 0.0)).mode == "C"
    assert RoverSim(initial_state=(0.0, -dy, -th, 0.0, 0.0, 0.0)).mode == "D"  # mirror
    assert RoverSim(initial_state=(0.0, -dy + 1e-3, th, 0.0, 0.0, 0.0)).mode == "A"


def test_sample_dt_adds_samples_not_physics():
    a = simulate(np.full(40, 3e-4), t_end=200.0, control_dt=0.1, target_x=0.5)
    b = simulate(np.full(40, 3e-4), t_end=200.0, control_dt=0.1, target_x=0.5, sample_dt=0.025)
    assert len(b.t) == 4 * (len(a.t) - 1) + 1
    np.testing.assert_allclose(b.x[::4], a.x, atol=1e-12)
    np.testing.assert_allclose(b.t[::4], a.t, atol=1e-12)


def test_roversim_copy_is_independent_and_stop_on():
    sim = RoverSim(target_x=0.5)
    ev = sim.advance(3e-4, 100.0, stop_on="liftoff")
    assert sim.stopped and ev[-1][1] in ("liftoff", "band_out") and sim.mode == "A"
    twin = sim.copy()
    twin.advance(0.0, 50.0)
    assert twin.t == 50.0 and sim.t < 5.0
    with pytest.raises(ValueError):
        sim.advance(3e-4, 10.0, stop_on="nonsense")


def test_jit_only_kernel_functions_raise_instead_of_crashing():
    # Kernel helpers compiled without a Python entry (core.INNER) crashed the interpreter
    # with a segmentation fault when called from Python; they raise a TypeError instead.
    import importlib
    import pkgutil
    import subprocess
    import sys

    from numba.core.registry import CPUDispatcher

    from hoprover_env import core, tasks
    from hoprover_env.jit import compiler as _compile
    from hoprover_env.tasks import reward

    kernel_modules = (
        [
            importlib.import_module(f"hoprover_env.core.{m.name}")
            for m in pkgutil.iter_modules(core.__path__)
        ]
        + [
            importlib.import_module(f"hoprover_env.tasks.{m.name}")
            for m in pkgutil.iter_modules(tasks.__path__)
        ]
        + [reward]
    )
    inner = [
        o
        for m in kernel_modules
        for o in vars(m).values()
        if isinstance(o, CPUDispatcher) and o.targetoptions.get("no_cpython_wrapper")
    ]
    assert len(inner) > 40
    # guarded, or compiled on first use (declared signature) and guarded then
    assert all(isinstance(o, (_compile._JitOnly, _compile._Declared)) for o in inner)
    code = (
        "import numpy as np\nfrom hoprover_env import core\n"
        "try:\n    core.kinetic_energy(np.zeros(core.N_STATE), np.ones(32))\n"
        "except TypeError as e:\n    print(e)\n"
        "try:\n    core.contact_corner(1)\n"
        "except TypeError as e:\n    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.returncode
    assert "core.forces.kinetic_energy is compiled for calls from jitted code only" in out.stdout
    assert "core.forces.contact_corner is compiled for calls from jitted code only" in out.stdout


def test_declared_signature_functions_pickle_by_reference():
    # Ray and multiprocessing pickle what they ship; a function compiled on first use must
    # come back as the same function, compiled or not
    import pickle

    from hoprover_env import core

    for f in (core.flight.flight_phase, core.corner_offset, core.settle):
        assert pickle.loads(pickle.dumps(f)) is f


def test_every_subpackage_is_shipped():
    # a package missing from pyproject's list installs fine in editable mode and breaks
    # every non-editable install (the core became a package)
    import pathlib

    import tomllib

    root = pathlib.Path(__file__).resolve().parents[2]
    listed = set(
        tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        ".".join(p.parent.relative_to(root).parts)
        for p in (root / "hoprover_env").rglob("__init__.py")
    }
    assert found <= listed, sorted(found - listed)
