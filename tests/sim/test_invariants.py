"""hoprover_env.sim.invariants's checks flag what they must: the property tests and the stress
benchmark trust an empty list from them."""

import dataclasses

import numpy as np

from helpers import launch_then_hold
from hoprover_env import simulate
from hoprover_env.sim.invariants import (
    V_KINEMATICS,
    V_NAN,
    V_PEN_SAMPLE,
    check_state,
    gained_energy,
    kinematic_violations,
    new_drift,
    rollout_states,
)


def hop():
    roll = simulate(launch_then_hold(3e-4), t_end=200.0, control_dt=0.1, target_x=0.3)
    assert set("ACF") <= set(roll.state)  # rest, launch slide, flight
    return roll


def spoiled(roll, index, **arrays):
    """The rollout with sample `index` of the named arrays shifted by the given amounts."""
    changes = {}
    for name, delta in arrays.items():
        a = getattr(roll, name).copy()
        a[index] += delta
        changes[name] = a
    return dataclasses.replace(roll, **changes)


def test_a_simulated_hop_is_consistent():
    assert kinematic_violations(hop()) == []


def test_spoiled_samples_are_flagged_where_they_are():
    roll = hop()
    letters = list(roll.state)
    for letter, change in (
        ("C", {"y": 1e-8}),  # the contact corner off the ground
        ("F", {"theta": 1e-15}),  # at rest but tilted
        ("A", {"y": -1.0}),
    ):  # flying under the ground
        i = letters.index(letter)
        assert [v[0] for v in kinematic_violations(spoiled(roll, i, **change))] == [i]


def test_check_state_kinds():
    roll = hop()
    p = roll.params.as_array()
    states = rollout_states(roll)
    i = list(roll.state).index("A")
    assert check_state(states[i], p, 1e-9, new_drift()) == 0
    low = states[i].copy()
    low[1] -= 1.0
    assert check_state(low, p, 1e-9, new_drift()) & (1 << V_PEN_SAMPLE)
    assert check_state(low, p, 1e-9, new_drift()) & (1 << V_KINEMATICS)
    bad = states[i].copy()
    bad[3] = np.nan
    assert check_state(bad, p, 1e-9, new_drift()) == 1 << V_NAN


def test_gained_energy():
    assert not gained_energy(1.0) and not gained_energy(1.0 + 1e-13)
    assert gained_energy(1.0 + 1e-11) and gained_energy(np.nan)
