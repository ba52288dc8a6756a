"""Contact phases against an independent scipy DOP853 solution (hoprover_env.sim.reference.Ref)."""

import numpy as np
import pytest

from hoprover_env import RoverParams, RoverSim
from hoprover_env.sim.reference import Ref

TORQUES = [1e-5, 2e-5, 2.4e-5, 2.5e-5, 5e-5, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4]


@pytest.fixture(scope="module")
def ref():
    return Ref()


def modes_of(events):
    return "".join(
        [events[0][2]] + [e[3] for e in events if e[1] in ("tip", "slip", "stick", "liftoff")]
    )


@pytest.mark.parametrize("torque", TORQUES)
def test_launch_matches_scipy(ref, torque):
    t_ref, s_ref, modes = ref.launch(torque)
    sim = RoverSim(target_x=0.5)  # default rtol
    ev = sim.advance(torque, 300.0, stop_on="liftoff")
    assert modes_of(ev) == "".join(modes)
    assert abs(sim.t - t_ref) <= 1e-9
    st = sim.state
    assert np.max(np.abs(st[3:] - s_ref[3:])) <= 1e-10  # m/s, rad/s
    assert np.max(np.abs(st[:3] - s_ref[:3])) <= 1e-10  # m, rad


@pytest.mark.parametrize("torque", [3e-5, 4e-4])
def test_mirror_symmetry(torque):
    a, b = RoverSim(target_x=0.0), RoverSim(target_x=0.0)
    a.advance(torque, 300.0, stop_on="liftoff")
    b.advance(-torque, 300.0, stop_on="liftoff")
    assert a.t == b.t
    sa, sb = a.state, b.state
    np.testing.assert_allclose(sb, sa * np.array([-1, 1, -1, -1, 1, -1]), rtol=0, atol=1e-15)


def test_other_parameters_match_scipy():
    kw = dict(
        mass=1.7,
        inertia=0.004,
        half_width=0.07,
        half_height=0.04,
        gravity=2e-4,
        mu_static=0.4,
        mu_dynamic=0.3,
    )
    p = RoverParams(**kw)
    ref = Ref(m=1.7, I=0.004, r=0.07, h=0.04, g=2e-4, mus=0.4, mud=0.3)
    for torque in (5e-5, 3e-4):
        t_ref, s_ref, modes = ref.launch(torque)
        sim = RoverSim(params=p, target_x=0.0)
        ev = sim.advance(torque, 300.0, stop_on="liftoff")
        assert modes_of(ev) == "".join(modes)
        assert abs(sim.t - t_ref) <= 1e-9
        assert np.max(np.abs(sim.state - s_ref)) <= 1e-10


def test_tolerance_converges(ref):
    t_ref, s_ref, _ = ref.launch(1e-4)
    errs = []
    for rtol in (1e-8, 1e-10, 1e-12):
        sim = RoverSim(target_x=0.0, rtol=rtol)
        sim.advance(1e-4, 300.0, stop_on="liftoff")
        errs.append(abs(sim.t - t_ref))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-11
