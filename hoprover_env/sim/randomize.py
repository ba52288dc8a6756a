"""Domain randomisation of the rover's parameters: which fields may be scaled, the check
of a `randomize` mapping, and one draw.

`randomize` maps a field of RoverParams to a relative half-range r: each draw scales the
field by U(1 - r, 1 + r), clipped to the field's bounds. The environments
(`EnvConfig.randomize`) and `simulate_batch(randomize=...)` share these.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np

from hoprover_env.core.params import RoverParams
from hoprover_env.util.validate import is_real

# Parameters that domain randomisation may scale, and the bounds they are clipped to.
RANDOMIZABLE = {
    "mass": (1e-6, math.inf), "inertia": (1e-9, math.inf), "gravity": (1e-12, math.inf),
    "half_width": (1e-6, math.inf), "half_height": (1e-6, math.inf),
    "mu_static": (0.0, 1.0), "mu_dynamic": (0.0, 1.0),
    "restitution_x": (0.0, 1.0), "restitution_y": (0.0, 1.0),
}


def check_randomize(randomize) -> dict:
    """`randomize` as a dict sorted by field (None: {}). ValueError names an unknown
    field or a half-range outside [0, 1)."""
    if randomize is not None and not isinstance(randomize, Mapping):
        raise ValueError("randomize must map parameter names to relative half-ranges, "
                         f"e.g. {{'mass': 0.1}}; got {randomize!r}")
    rand = dict(randomize or {})
    for key, rel in rand.items():
        if key not in RANDOMIZABLE:
            raise ValueError(f"randomize: unknown parameter {key!r}; choose from "
                             f"{sorted(RANDOMIZABLE)}")
        if not (is_real(rel) and 0.0 <= rel < 1.0):
            raise ValueError(f"randomize[{key!r}] must be a relative half-range in "
                             f"[0, 1), got {rel!r}")
    return dict(sorted(rand.items()))


def draw_params(base: RoverParams, randomize: Mapping[str, float],
                rng: np.random.Generator) -> RoverParams:
    """`base` with each field of `randomize` (checked) scaled by U(1 - r, 1 + r), in the
    mapping's order; a draw that breaks a physical constraint (mu_dynamic > mu_static
    is clipped; a Painleve draw is drawn again, up to 100 times)."""
    if not randomize:
        return base
    for _ in range(100):
        values = {}
        for key, rel in randomize.items():
            lo, hi = RANDOMIZABLE[key]
            values[key] = float(np.clip(getattr(base, key) * rng.uniform(1 - rel, 1 + rel),
                                        lo, hi))
        mu_s = values.get("mu_static", base.mu_static)
        if values.get("mu_dynamic", base.mu_dynamic) > mu_s:
            values["mu_dynamic"] = mu_s
        try:
            return dataclasses.replace(base, **values)
        except ValueError:                  # a Painleve draw: draw again
            continue
    raise ValueError("randomize: 100 draws in a row gave invalid parameters; narrow the "
                     f"ranges {dict(randomize)}")
