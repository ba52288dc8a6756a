"""Slope 0 and roughness 0 give the contest model's results bit for bit: the
runs of tests/flat_cases.py against the arrays the code before terrain gave
(tests/data/flat_baseline.npz, made by tests/data/make_flat_baseline.py at 6fc532c)."""

import os

import numpy as np
import pytest

from flat_cases import cases, record
from hoprover_env import simulate

BASELINE = np.load(
    os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "flat_baseline.npz")
)
CASES = cases()


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f" or b.dtype.kind == "f":
        # bit patterns, so that -0.0 vs 0.0 or two NaN payloads would count as a change
        return (
            a.shape == b.shape and a.astype(np.float64).tobytes() == b.astype(np.float64).tobytes()
        )
    return a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("name", sorted(CASES))
def test_flat_ground_equals_the_contest_model_bit_for_bit(name):
    ctrl, kw = CASES[name]
    got = record(simulate(ctrl, **kw))
    for key, value in got.items():
        want = BASELINE[f"{name}/{key}"]
        assert same_bits(value, want), (name, key)
