"""The property test of tests/sim/test_stress.py on random slopes and roughness: never NaN,
never under the ground, states consistent with the kinematics, bit-reproducible from the
seed, and no energy gain at an impact under the dissipative law."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_stress import run, scenario

from hoprover_env.sim.invariants import kinematic_violations


@st.composite
def terrain_scenario(draw):
    p, state, control_dt, torques, hold, integrator, law, t_end = draw(scenario())
    p = dataclasses.replace(
        p, slope=draw(st.floats(-0.5, 0.5)), roughness=draw(st.sampled_from([0.0, 0.05, 0.3]))
    )
    seed = draw(st.integers(0, 2**64 - 1))
    return p, state, control_dt, torques, hold, integrator, law, min(t_end, 600.0), seed


@pytest.mark.slow  # hypothesis: random whole runs
@given(terrain_scenario())
def test_terrain_never_nan_never_under_ground_consistent_and_reproducible(sc):
    roll = run(*sc)
    arr = np.c_[roll.t, roll.x, roll.y, roll.theta, roll.vx, roll.vy, roll.omega]
    assert np.all(np.isfinite(arr))
    assert np.all(np.diff(roll.t) > 0)
    assert roll.min_corner_height >= -1e-9
    for which in "AB":
        assert roll.corner(which)[1].min() >= -1e-9
    assert kinematic_violations(roll) == []
    assert roll.seed == (sc[-1] if sc[0].roughness > 0 else None)
    again = run(*sc)
    assert (
        arr.tobytes()
        == np.c_[again.t, again.x, again.y, again.theta, again.vx, again.vy, again.omega].tobytes()
    )
    assert again.events == roll.events and again.ttrtp == roll.ttrtp
    if sc[6] == "dissipative":
        assert np.all(roll.impact_energy_ratios <= 1.0 + 1e-12)
