"""Domain randomisation of the rover's parameters: which fields may be scaled, the check
of a `randomize` mapping, one draw (`draw_params`), and n draws at once as arrays
(`draw_fields`, the same numbers as n calls of draw_params on the same generator).

`randomize` maps a field of RoverParams to a relative half-range r: each draw scales the
field by U(1 - r, 1 + r), clipped to the field's bounds. The environments
(`EnvConfig.randomize`) and `simulate_batch(randomize=...)` share these.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from hoprover_env.core.params import FIELD_INDEX, FIELDS, N_FIELDS, RoverParams, invalid_rows
from hoprover_env.util.validate import is_real

# Parameters that domain randomisation may scale, and the bounds they are clipped to.
RANDOMIZABLE = {
    "mass": (1e-6, math.inf),
    "inertia": (1e-9, math.inf),
    "gravity": (1e-12, math.inf),
    "half_width": (1e-6, math.inf),
    "half_height": (1e-6, math.inf),
    "mu_static": (0.0, 1.0),
    "mu_dynamic": (0.0, 1.0),
    "restitution_x": (0.0, 1.0),
    "restitution_y": (0.0, 1.0),
}
MAX_DRAWS = 100  # draws of one run's parameters before its randomize ranges are refused


def check_randomize(randomize) -> dict:
    """`randomize` as a dict sorted by field (None: {}). ValueError names an unknown
    field or a half-range outside [0, 1)."""
    if randomize is not None and not isinstance(randomize, Mapping):
        raise ValueError(
            "randomize must map parameter names to relative half-ranges, "
            f"e.g. {{'mass': 0.1}}; got {randomize!r}"
        )
    rand = dict(randomize or {})
    for key, rel in rand.items():
        if key not in RANDOMIZABLE:
            raise ValueError(
                f"randomize: unknown parameter {key!r}; choose from {sorted(RANDOMIZABLE)}"
            )
        if not (is_real(rel) and 0.0 <= rel < 1.0):
            raise ValueError(
                f"randomize[{key!r}] must be a relative half-range in [0, 1), got {rel!r}"
            )
    return dict(sorted(rand.items()))


def draw_params(
    base: RoverParams, randomize: Mapping[str, float], rng: np.random.Generator
) -> RoverParams:
    """`base` with each field of `randomize` (checked) scaled by U(1 - r, 1 + r), in the
    mapping's order; a draw that breaks a physical constraint (mu_dynamic > mu_static
    is clipped; a Painleve draw is drawn again, up to 100 times)."""
    if not randomize:
        return base
    for _ in range(MAX_DRAWS):
        values = {}
        for key, rel in randomize.items():
            lo, hi = RANDOMIZABLE[key]
            values[key] = float(np.clip(getattr(base, key) * rng.uniform(1 - rel, 1 + rel), lo, hi))
        mu_s = values.get("mu_static", base.mu_static)
        if values.get("mu_dynamic", base.mu_dynamic) > mu_s:
            values["mu_dynamic"] = mu_s
        try:
            return dataclasses.replace(base, **values)
        except ValueError:  # a Painleve draw: draw again
            continue
    raise ValueError(
        f"randomize: {MAX_DRAWS} draws in a row gave invalid parameters; "
        f"narrow the ranges {dict(randomize)}"
    )


def draw_fields(
    base: RoverParams, randomize: Mapping[str, float], rng: np.random.Generator, n: int
) -> np.ndarray:
    """n draws of `draw_params(base, randomize, rng)` as (n, N_FIELDS) field values
    (core.params.FIELDS): bit for bit the numbers of n calls in a row on the same
    generator, which is left where those calls leave it (ValueError where they raise).

    draw_params takes one rng.uniform(1 - r, 1 + r) per field, in the mapping's order,
    which numpy computes as low + (high - low) * U from the generator's next double U, and
    draws a run again from the next k doubles while RoverParams refuses it (a Painleve
    set, a value beyond 1e9). Every k doubles of the stream are thus one candidate, and
    the base is the same for all runs: run i is the i-th candidate RoverParams accepts.
    Here the candidates come from rng.random((m, k)) blocks, are scaled and checked as
    arrays (params.invalid_rows), and the first n accepted are the runs."""
    keys = list(randomize)
    k = len(keys)
    base_row = np.array([getattr(base, name) for name in FIELDS])
    out = np.empty((n, N_FIELDS))
    out[:] = base_row
    if not k or n == 0:
        return out
    cols = [FIELD_INDEX[key] for key in keys]
    # numpy's uniform(low, high): low + range * U, range = high - low, both taken as
    # doubles from the arguments draw_params passes (1 - r and 1 + r, in r's own type)
    low = np.array([float(1 - randomize[key]) for key in keys])
    span = np.array([float(1 + randomize[key]) for key in keys]) - low
    scale = np.array([getattr(base, key) for key in keys])
    lo = np.array([RANDOMIZABLE[key][0] for key in keys])
    hi = np.array([RANDOMIZABLE[key][1] for key in keys])
    mus, mud = FIELD_INDEX["mu_static"], FIELD_INDEX["mu_dynamic"]
    start = rng.bit_generator.state
    done, drawn, streak = 0, 0, 0
    while done < n:
        # enough candidates for the runs left at the acceptance rate seen so far
        rate = done / drawn if drawn else 1.0
        m = int(min(max((n - done) / max(rate, 0.01) * 1.05 + 16, 16), 10 * n + 1000))
        cand = np.empty((m, N_FIELDS))
        cand[:] = base_row
        cand[:, cols] = np.clip(scale * (low + span * rng.random((m, k))), lo, hi)
        np.copyto(cand[:, mud], cand[:, mus], where=cand[:, mud] > cand[:, mus])
        ok = ~invalid_rows(cand)
        # a run drawn MAX_DRAWS times in a row without success raises, as draw_params does
        where = np.flatnonzero(ok)
        gaps = np.diff(where, prepend=-1 - streak) - 1
        need = n - done
        if len(where) >= need:
            gaps, where = gaps[:need], where[:need]
        elif len(where) == 0:
            gaps = np.array([streak + m])
        else:
            gaps = np.append(gaps, m - 1 - where[-1])
        if gaps.size and gaps.max() >= MAX_DRAWS:
            raise ValueError(
                f"randomize: {MAX_DRAWS} draws in a row gave invalid "
                f"parameters; narrow the ranges {dict(randomize)}"
            )
        take = cand[where]
        out[done : done + len(take)] = take
        done += len(take)
        if done == n:
            drawn += where[-1] + 1
        else:
            streak = (m - 1 - where[-1]) if len(where) else streak + m
            drawn += m
    # the generator where n calls of draw_params leave it: past the last run's draw
    rng.bit_generator.state = start
    rng.random(drawn * k)
    return out


def rng_for_seeds(seeds: np.ndarray) -> np.random.Generator:
    """np.random.default_rng(list of the seeds) without a Python step per seed: the
    SeedSequence of a list of integers mixes each integer's 32-bit words (one word for
    a seed below 2**32, zero included, two above), which are built here as one array."""
    seeds = np.asarray(seeds, dtype=np.uint64)
    words = np.stack([seeds & np.uint64(0xFFFFFFFF), seeds >> np.uint64(32)], axis=1)
    keep = np.ones(words.shape, dtype=bool)
    keep[:, 1] = words[:, 1] != 0
    return np.random.default_rng(np.random.SeedSequence(words[keep].astype(np.uint32)))
