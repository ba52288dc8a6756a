"""Argument validators: one of each, for every public entry point.

Each returns the value in the form the kernel wants (a float, a float64 array) or raises
with a message that names the argument. Numpy scalars are welcome; booleans, strings and
complex numbers are refused rather than converted.
"""

from __future__ import annotations

import math
import numbers
import secrets

import numpy as np


class ArgumentTypeError(TypeError, ValueError):
    """An argument that is not a number where one is needed: a TypeError (it is one), and
    a ValueError for callers that catch bad values of any kind."""


def is_real(v) -> bool:
    """A real number, numpy scalars included; booleans are not numbers here."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def finite_real(name: str, v) -> float:
    """A finite real number as float; ArgumentTypeError for what is not a real number,
    ValueError for inf/NaN."""
    if not is_real(v):
        raise ArgumentTypeError(f"{name} must be a real number, got {type(v).__name__} {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v!r}")
    return v


def positive_real(name: str, v) -> float:
    """A positive finite real number as float (see finite_real)."""
    v = finite_real(name, v)
    if not v > 0:
        raise ValueError(f"{name} must be a positive finite number, got {v!r}")
    return v


def non_negative_real(name: str, v) -> float:
    """A finite real number >= 0 as float; ValueError otherwise."""
    if not (is_real(v) and math.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a non-negative number, got {v!r}")
    return float(v)


def check_torque(torque, what="torque") -> float:
    """A finite torque [N m] as float, or ValueError naming the bad value. One-element
    real arrays (what a policy's predict returns) are welcome."""
    if isinstance(torque, np.ndarray) and torque.size == 1 and torque.dtype.kind in "iuf":
        torque = torque.reshape(()).item()
    if not is_real(torque):
        raise ValueError(f"{what} must be a real number, got {type(torque).__name__} {torque!r}")
    value = float(torque)
    if not math.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return value


def real_array(name: str, value) -> np.ndarray:
    """A contiguous float64 array of `value`, refusing what is not real numbers (strings,
    booleans, complex numbers, objects, ragged rows) with an error naming the argument."""
    if (
        isinstance(value, (list, tuple))
        and value
        and all(isinstance(row, (list, tuple, np.ndarray)) for row in value)
    ):
        lengths = [len(row) for row in value]
        for i, length in enumerate(lengths):
            if length != lengths[0]:
                raise ValueError(
                    f"run {i}: {name} row has {length} entries, run 0 has {lengths[0]}"
                )
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):  # ragged deeper down
        raise ValueError(f"{name} must be a rectangular array of real numbers") from None
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{name} must hold real numbers, got dtype {raw.dtype}")
    return np.ascontiguousarray(raw, dtype=np.float64)


def check_seed(seed, rough: bool = False):
    """The seed of the rough-terrain draws: an integer in [0, 2^64), or None. None on
    rough ground (`rough`) becomes a seed from fresh entropy, which the caller records
    so that the run can be replayed; on smooth ground it stays None (nothing is drawn)."""
    if seed is None:
        return secrets.randbits(64) if rough else None
    if (
        isinstance(seed, (bool, np.bool_))
        or not isinstance(seed, numbers.Integral)
        or not 0 <= int(seed) < 2**64
    ):
        raise ValueError(
            f"seed must be None or an integer in [0, 2**64), got {type(seed).__name__} {seed!r}"
        )
    return int(seed)


def check_rover(rover) -> int:
    """A rover index (the run's place in a batch, the sub-env of a vector env)."""
    if (
        isinstance(rover, (bool, np.bool_))
        or not isinstance(rover, numbers.Integral)
        or not 0 <= int(rover) < 2**53
    ):
        raise ValueError(f"rover must be an integer in [0, 2**53), got {rover!r}")
    return int(rover)


# ---- per-run arrays: checked as arrays, the first bad run named --------------------------
def first_true(mask) -> int:
    """Index of the first True of a 1-D boolean array, or -1."""
    mask = np.asarray(mask, dtype=bool)
    return int(np.argmax(mask)) if mask.any() else -1


def seed_array(seed, n: int) -> np.ndarray:
    """One seed per run as a uint64 array of shape (n,): integers in [0, 2^64). ValueError
    for another shape or dtype, or naming the first run whose seed is out of range (with
    check_seed's message)."""
    a = np.asarray(seed)
    if a.shape != (n,) or a.dtype.kind not in "iuO":
        raise ValueError(
            f"seed must be None, one integer, or an integer array of shape "
            f"({n},) (one per run), got {a.dtype} array of shape {a.shape}"
        )
    if a.dtype.kind == "u":
        return a.astype(np.uint64)
    if a.dtype.kind == "i":
        bad = first_true(a < 0)
    else:  # Python objects: each one looked at
        values = a.tolist()
        bad = next(
            (
                i
                for i, v in enumerate(values)
                if v is None
                or isinstance(v, (bool, np.bool_))
                or not isinstance(v, numbers.Integral)
                or not 0 <= int(v) < 2**64
            ),
            -1,
        )
    if bad >= 0:
        v = a[bad].item() if a.dtype.kind != "O" else a[bad]
        try:
            check_seed(v)
        except ValueError as err:
            raise ValueError(f"run {bad}: {err}") from None
        raise ValueError(f"run {bad}: seed must be an integer in [0, 2**64), got {v!r}")
    return (
        a.astype(np.uint64)
        if a.dtype.kind == "i"
        else np.array([int(v) for v in a.tolist()], dtype=np.uint64)
    )


def run_rows(name: str, value, n: int, width: int) -> np.ndarray | None:
    """None, one row of `width` numbers for every run, or one row per run: None, or a
    float64 array of shape (1, width) or (n, width) (see real_array)."""
    if value is None:
        return None
    a = real_array(name, value)
    if a.shape == (width,):
        return a.reshape(1, width)
    if a.ndim != 2 or a.shape[1] != width:
        raise ValueError(f"{name} must have shape ({width},) or (N, {width}), got {a.shape}")
    if a.shape[0] != n:
        raise ValueError(f"{name} has {a.shape[0]} rows for {n} runs")
    return a
