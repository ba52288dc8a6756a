"""The reset options of every env, checked in one place.

An env's ``reset(options=...)`` may fix what the episode's draws (tasks/draws.py) would
otherwise decide. The draws are made all the same, so the seeded streams stay aligned;
the options replace their outcome:

=====================  ===============================================================
``target_x``           the target [m]
``initial_state``      the c.m. state (x, y, theta, vx, vy, omega) to start from
``slope``              the ground's inclination [rad]
``roughness``          the rough ground's bounces [rad]
``terrain_seed``       the seed of the bumps, an integer in [0, 2^63) (ignored on smooth
                       ground; -1, the info's "none", only there)
a randomised field     a parameter domain randomisation may scale (`PARAM_OPTIONS`:
                       mass, inertia, gravity, half_width, half_height, mu_static,
                       mu_dynamic, restitution_x, restitution_y), at this value: the
                       episode's rover whatever `randomize` draws
a task's own           the start options its TaskSpec declares (`StartOption`), such
                       as the mission task's sensor seed and actuator draw
=====================  ===============================================================

A vector env takes each as one value for all the sub-envs reset or one per sub-env (its
``reset_mask`` aside). `check` turns the options into one row per rover, or raises a
ValueError that names the option.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from hoprover_env.sim.randomize import RANDOMIZABLE

RESET_OPTIONS = ("target_x", "initial_state", "slope", "roughness", "terrain_seed")
PARAM_OPTIONS = tuple(sorted(RANDOMIZABLE))
SEED_LIMIT = 2**63  # seeds (terrain_seed, a task's "seed" options) below this
NO_SEED = -1  # terrain_seed: none (smooth ground)
KINDS = ("real", "unit", "seed")


@dataclasses.dataclass(frozen=True)
class StartOption:
    """A reset option a task declares (TaskSpec.start_options): it fixes one of the task's
    own draws at reset. `kind` says what it takes: "real" a finite number, "unit" a
    number in [-1, 1], "seed" an integer in [0, 2^63); `doc` says what it fixes."""

    name: str
    kind: str
    doc: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(
                f"StartOption {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}"
            )
        if self.name in RESET_OPTIONS + PARAM_OPTIONS + ("reset_mask",):
            raise ValueError(f"StartOption {self.name!r}: the name is an env's own reset option")


def names(task) -> tuple[str, ...]:
    """Every reset option an env of `task` takes."""
    return RESET_OPTIONS + PARAM_OPTIONS + tuple(o.name for o in task.start_options)


def _kind(task, name: str) -> str:
    if name == "terrain_seed":
        return "terrain_seed"
    if name == "initial_state":
        return "state"
    for o in task.start_options:
        if o.name == name:
            return o.kind
    return "real"


def _column(name: str, kind: str, value, n: int, per_rover: bool) -> np.ndarray:
    """One option as n rows (n values, or (n, 6) for a state)."""
    width = (6,) if kind == "state" else ()
    v = np.asarray(value)
    if v.shape != width and not (per_rover and v.shape == (n, *width)):
        shapes = f"{width or '()'}" + (f" or {(n, *width)} (one per sub-env)" if per_rover else "")
        raise ValueError(f"options[{name!r}] must have shape {shapes}, got {v.shape}")
    if kind in ("seed", "terrain_seed"):
        low = NO_SEED if kind == "terrain_seed" else 0
        if v.dtype == np.bool_ or v.dtype.kind not in "iu":
            raise ValueError(
                f"options[{name!r}] must be integers in [0, 2**63), got {value!r} (dtype {v.dtype})"
            )
        bad = (v < low) | (v >= SEED_LIMIT)
        if bad.any():
            raise ValueError(
                f"options[{name!r}] must be an integer in [0, 2**63), got "
                f"{v.ravel()[np.flatnonzero(bad.ravel())[0]]!r}"
            )
        return np.broadcast_to(v.astype(np.int64), (n, *width))
    if v.dtype.kind not in "iuf" or v.dtype == np.bool_:
        raise ValueError(f"options[{name!r}] must be real numbers, got {value!r}")
    v = v.astype(np.float64)
    bad = ~np.isfinite(v)
    if kind == "unit":
        bad |= np.abs(v) > 1.0
    if bad.any():
        what = "in [-1, 1]" if kind == "unit" else "finite"
        raise ValueError(
            f"options[{name!r}] must be {what}, got {v.ravel()[np.flatnonzero(bad.ravel())[0]]!r}"
        )
    return np.broadcast_to(v, (n, *width))


def check(
    task, options: Mapping | None, n: int = 1, per_rover: bool = False, also: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    """The reset `options` of an env of `task` as n rows each ({} for none): a value for
    all n rovers, or with `per_rover` one per rover. `also` names further options the
    caller took out before (a vector env's reset_mask), for the message. ValueError names
    an unknown option, one of the wrong shape or type, or a value out of its range."""
    options = dict(options or {})
    valid = names(task)
    bad = sorted(set(options) - set(valid))
    if bad:
        raise ValueError(f"unknown reset option(s) {bad}; valid: {sorted(valid + also)}")
    return {
        name: _column(name, _kind(task, name), value, n, per_rover)
        for name, value in options.items()
    }
