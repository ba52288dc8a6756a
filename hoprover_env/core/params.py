"""Physical parameters of the rover and the contest rules, as a frozen dataclass.

`RoverParams()` holds the contest values (docs/MODEL.md section 1). Every field can be set
(domain randomisation builds new instances with `dataclasses.replace`); the constructor
validates the set and raises `ValueError` naming the offending field.

The numba kernel never sees this object: `as_array()` packs it into a flat float64
vector whose layout is given by the `P_*` indices below.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Layout of the flat parameter vector used by the jitted kernel.
(
    P_M,
    P_I,
    P_R,
    P_H,
    P_G,
    P_MUS,
    P_MUD,
    P_EX,
    P_EY,
    P_VXMIN,
    P_VYMIN,
    P_TMIN,
    P_TMAX,
    P_BAND,
    P_DWELL,
) = range(15)
# Terrain (docs/MODEL.md section 11): the slope phi, the roughness s, and gravity's
# components in the ground frame, g sin(phi) along the surface and g cos(phi) along its
# normal, computed once here (at phi = 0 they are exactly 0 and g, so flat-ground
# arithmetic is untouched: the kernel uses P_GC where it used P_G for the weight).
P_SLOPE, P_ROUGH, P_GS, P_GC = range(15, 19)
N_PARAMS = 19
MAX_SLOPE = 0.5  # rad: |slope| accepted
PAINLEVE_MARGIN = 1e-6  # smallest slide denominator accepted, relative to I + m l^2


# Largest |value| of any parameter or initial-state component (SI units). The contest's
# values are 1e-6..1; 1e9 leaves squares (1e18) and the products of event location far
# from overflow, where 1e300 overflowed (a raw OverflowError, or a kernel that spun).
MAX_MAGNITUDE = 1e9


@dataclasses.dataclass(frozen=True)
class RoverParams:
    """Rover, ground and judge parameters (SI units). Defaults: the 2015 contest.

    Fields: `mass` m [kg], `inertia` I about the c.m. [kg m^2], `half_width` r and
    `half_height` h of the body [m], `gravity` g [m/s^2], `mu_static` and `mu_dynamic`
    (friction coefficients), `restitution_x` and `restitution_y` (of the contact point,
    horizontal and vertical), `v_xmin` and `v_ymin` (post-impact speeds zeroed below
    these [m/s]), `torque_min` and `torque_max` (the torquer's limits [N m]),
    `band_half_width` (the judge's band around the target [m]) and `dwell_time` (how
    long a contact point must stay in the band [s]).

    Raises ValueError naming the field for a value that is not a finite real number, out
    of its range (negative mass, mu_dynamic > mu_static, torque_min > torque_max, ...)
    or beyond 1e9 in magnitude, and for sets where the contact model has no unique
    solution (Painleve; docs/PHYSICS.md).
    """

    mass: float = 1.0  # m [kg]
    inertia: float = 0.0017  # I about the c.m. [kg m^2]
    half_width: float = 0.05  # r [m]
    half_height: float = 0.05  # h [m]
    gravity: float = 9.8e-5  # g [m/s^2]
    mu_static: float = 0.6  # mu_s
    mu_dynamic: float = 0.5  # mu_d
    restitution_x: float = 0.8  # e_x, horizontal, of the contact point
    restitution_y: float = 0.2  # e_y, vertical
    v_xmin: float = 1e-6  # post-impact horizontal speed zeroed below this [m/s]
    v_ymin: float = 1e-6  # post-impact vertical speed zeroed below this [m/s]
    torque_min: float = -5e-4  # T_min [N m]
    torque_max: float = 5e-4  # T_max [N m]
    band_half_width: float = 0.05  # judge: |x_P - x_T| <= this [m]
    dwell_time: float = 5.0  # judge: time the band must be held [s]
    slope: float = 0.0  # phi: ground inclination, rising toward +x [rad]
    roughness: float = 0.0  # s: std of the impact normal's tilt [rad]

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                raise ValueError(f"RoverParams.{f.name} must be a real number, got {v!r}")
            if not math.isfinite(float(v)):
                raise ValueError(f"RoverParams.{f.name} must be finite, got {v!r}")
            if abs(float(v)) > MAX_MAGNITUDE:
                raise ValueError(
                    f"RoverParams.{f.name} = {v!r} is beyond {MAX_MAGNITUDE:g} "
                    "in SI units: the kernel's squares and products of such "
                    "values overflow or lose all precision"
                )
            object.__setattr__(self, f.name, float(v))
        for name in (
            "mass",
            "inertia",
            "half_width",
            "half_height",
            "gravity",
            "band_half_width",
            "dwell_time",
        ):
            if getattr(self, name) <= 0.0:
                raise ValueError(
                    f"RoverParams.{name} must be positive, got {getattr(self, name)!r}"
                )
        for name in ("mu_static", "mu_dynamic", "restitution_x", "restitution_y"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"RoverParams.{name} must lie in [0, 1], got {v!r}")
        if self.mu_dynamic > self.mu_static:
            # Kinetic friction above static friction makes every slip stop at once and
            # restart: a stick-slip chatter with no physical meaning.
            raise ValueError(
                f"RoverParams.mu_dynamic ({self.mu_dynamic}) must not exceed "
                f"mu_static ({self.mu_static})"
            )
        if self.v_xmin < 0.0:
            raise ValueError(f"RoverParams.v_xmin must be >= 0, got {self.v_xmin!r}")
        if self.v_ymin <= 0.0:
            # it is what ends a bounce sequence: with 0 a landing bounces forever (Zeno)
            raise ValueError(f"RoverParams.v_ymin must be positive, got {self.v_ymin!r}")
        if abs(self.slope) > MAX_SLOPE:
            raise ValueError(
                f"RoverParams.slope must lie in [-{MAX_SLOPE}, {MAX_SLOPE}] rad, got {self.slope!r}"
            )
        if self.roughness < 0.0:
            raise ValueError(f"RoverParams.roughness must be >= 0 rad, got {self.roughness!r}")
        if self.torque_min > self.torque_max:
            raise ValueError(
                f"RoverParams.torque_min ({self.torque_min}) exceeds torque_max ({self.torque_max})"
            )
        d_min = self.min_slide_denominator()
        # PAINLEVE_MARGIN: slide accelerations scale as J / D; within 1e-6 of the limit
        # they are a million times their normal size and the slide is, in practice, a
        # jump the rigid model does not describe. (At 1e-12 the check let through sets
        # on which a slide's first integration step overflowed.)
        if d_min <= PAINLEVE_MARGIN * (self.inertia + self.mass * self.corner_distance**2):
            raise ValueError(
                "RoverParams: Painleve regime, the sliding-state denominator "
                f"I + m dx (dx + sigma mu_d dy) reaches {d_min:.3g}, within "
                f"{PAINLEVE_MARGIN:g} (I + m l^2) of 0, for some attitude "
                f"(mu_dynamic={self.mu_dynamic}, inertia={self.inertia}, mass={self.mass}, "
                f"half_width={self.half_width}, half_height={self.half_height}); the rigid "
                "model has no unique solution there"
            )

    # ---- derived quantities -------------------------------------------------------
    @property
    def corner_distance(self) -> float:
        """l = sqrt(r^2 + h^2): c.m. to any corner [m]."""
        return math.hypot(self.half_width, self.half_height)

    @property
    def alpha(self) -> float:
        """atan(h / r) [rad]: the angle of the corner diagonal."""
        return math.atan2(self.half_height, self.half_width)

    @property
    def tipping_torque(self) -> float:
        """Torque magnitude [N m] above which the rover at rest on both corners lifts one
        (m g r), on level ground (on a slope the thresholds are
        m g cos(phi) r +- m g sin(phi) h)."""
        return self.mass * self.gravity * self.half_width

    @property
    def slip_torque(self) -> float:
        """Torque magnitude [N m] above which the rover leaves F straight into a slide (C
        or E).

        At the tipping instant (theta = 0, omega = 0) the pivot needs
        f_x = m h thdd and f_y = m (g + r thdd) with thdd = (T - m g r) / J,
        J = I + m l^2. Slip when f_x > mu_s f_y, i.e. thdd (h - mu_s r) > mu_s g.
        Infinite when h <= mu_s r (the pivot never slips at the start).
        """
        denom = self.half_height - self.mu_static * self.half_width
        if denom <= 0.0:
            return math.inf
        j = self.inertia + self.mass * self.corner_distance**2
        return self.tipping_torque + j * self.mu_static * self.gravity / denom

    def min_slide_denominator(self) -> float:
        """Smallest D = I + m dx (dx + sigma mu_d dy) over the attitudes a single contact
        can take (theta in [0, pi/2] on corner A; B is its mirror) and both sigma.

        With dx = r cos t - h sin t, dy = -r sin t - h cos t, D is
        I + m l^2 / 2 + m (a cos 2t + b sin 2t); its minimum over 2t in [0, pi] is taken
        at an end point or at the stationary point of the sinusoid.
        """
        r, h, mu = self.half_width, self.half_height, self.mu_dynamic
        base = self.inertia + self.mass * (r * r + h * h) / 2.0
        best = math.inf
        for sigma in (-1.0, 1.0):
            a = (r * r - h * h) / 2.0 - sigma * mu * r * h
            b = -r * h - sigma * mu * (r * r - h * h) / 2.0
            cands = [a, -a]  # psi = 0 and psi = pi
            psi = math.atan2(-b, -a) % (2 * math.pi)  # minimiser of a cos + b sin
            if psi <= math.pi:
                cands.append(-math.hypot(a, b))
            best = min(best, base + self.mass * min(cands))
        return best

    def as_array(self) -> np.ndarray:
        """Flat float64 vector for the kernel (layout: the P_* indices)."""
        return np.array(
            [
                self.mass,
                self.inertia,
                self.half_width,
                self.half_height,
                self.gravity,
                self.mu_static,
                self.mu_dynamic,
                self.restitution_x,
                self.restitution_y,
                self.v_xmin,
                self.v_ymin,
                self.torque_min,
                self.torque_max,
                self.band_half_width,
                self.dwell_time,
                self.slope,
                self.roughness,
                self.gravity * math.sin(self.slope) + 0.0,  # -0.0 -> 0.0
                self.gravity * math.cos(self.slope),
            ],
            dtype=np.float64,
        )


# ---- many parameter sets at once ----------------------------------------------------------
# The fields in the order of the kernel vector (P_M .. P_ROUGH): a (n, N_FIELDS) array of
# field values is the first N_FIELDS columns of the kernel's (n, N_PARAMS) rows.
FIELDS = (
    "mass",
    "inertia",
    "half_width",
    "half_height",
    "gravity",
    "mu_static",
    "mu_dynamic",
    "restitution_x",
    "restitution_y",
    "v_xmin",
    "v_ymin",
    "torque_min",
    "torque_max",
    "band_half_width",
    "dwell_time",
    "slope",
    "roughness",
)
N_FIELDS = len(FIELDS)
FIELD_INDEX = {name: k for k, name in enumerate(FIELDS)}
# how close to the Painleve limit (relative to I + m l^2) the vectorised check hands a row
# to the constructor: its arithmetic differs from min_slide_denominator's by a few ulps
_PAINLEVE_SLACK = 1e-10


def kernel_rows(fields: np.ndarray) -> np.ndarray:
    """(n, N_PARAMS) kernel vectors of n parameter sets given as (n, N_FIELDS) field values:
    row i equals RoverParams(**fields of row i).as_array() bit for bit (the derived
    gravity components take math.sin/cos of each distinct slope, as as_array does)."""
    fields = np.asarray(fields, dtype=np.float64)
    out = np.empty((fields.shape[0], N_PARAMS))
    out[:, :N_FIELDS] = fields
    g = fields[:, FIELD_INDEX["gravity"]]
    slope = fields[:, FIELD_INDEX["slope"]]
    if slope.size and np.all(slope == slope[0]):  # one slope (-0.0 == 0.0 gives the same)
        sin, cos = math.sin(float(slope[0])), math.cos(float(slope[0]))
    else:
        uniq, inv = np.unique(slope.view(np.int64), return_inverse=True)
        vals = uniq.view(np.float64)
        sin = np.array([math.sin(v) for v in vals])[inv]
        cos = np.array([math.cos(v) for v in vals])[inv]
    out[:, P_GS] = g * sin + 0.0  # -0.0 -> 0.0, as as_array
    out[:, P_GC] = g * cos
    return out


def as_arrays(params) -> np.ndarray:
    """(n, N_PARAMS): the as_array() of each of a sequence of n RoverParams, called once
    per distinct object (a batch of n runs often shares a few)."""
    params = list(params)
    ids = np.fromiter(map(id, params), dtype=np.uint64, count=len(params))
    _, first, inv = np.unique(ids, return_index=True, return_inverse=True)
    rows = np.array([params[j].as_array() for j in first]).reshape(-1, N_PARAMS)
    return rows[inv.reshape(-1)]


def from_fields(row) -> RoverParams:
    """The RoverParams of one row of field values (validated by the constructor)."""
    return RoverParams(**dict(zip(FIELDS, map(float, row[:N_FIELDS]))))


def invalid_rows(fields: np.ndarray) -> np.ndarray:
    """(n,) bool: which rows of (n, N_FIELDS) field values RoverParams refuses.

    The constructor's checks, on whole columns: each is the same comparison of the same
    doubles, except the Painleve limit, whose vectorised arithmetic may differ from
    min_slide_denominator's by a few ulps; the rare rows within a hair of that limit are
    built as RoverParams, which decides. So the answer is the constructor's, at the cost
    of a few array operations per row."""
    F = np.asarray(fields, dtype=np.float64).reshape(-1, N_FIELDS)
    C = np.ascontiguousarray(F.T)  # one contiguous array per field
    col = dict(zip(FIELDS, C))
    with np.errstate(invalid="ignore", over="ignore"):
        ok = (np.abs(C) <= MAX_MAGNITUDE).all(axis=0)  # finite, and within 1e9
        ok &= (C[[FIELD_INDEX[name] for name in _POSITIVE]] > 0.0).all(axis=0)
        unit = C[[FIELD_INDEX[name] for name in _UNIT]]
        ok &= ((unit >= 0.0) & (unit <= 1.0)).all(axis=0)
        ok &= col["mu_dynamic"] <= col["mu_static"]
        ok &= (col["v_xmin"] >= 0.0) & (col["v_ymin"] > 0.0)
        ok &= (np.abs(col["slope"]) <= MAX_SLOPE) & (col["roughness"] >= 0.0)
        ok &= col["torque_min"] <= col["torque_max"]
        d_min, scale = _min_slide_denominators(col)
        limit = PAINLEVE_MARGIN * scale
        bad = ~ok | (d_min <= limit - _PAINLEVE_SLACK * scale)
        unsure = ~bad & ~(d_min > limit + _PAINLEVE_SLACK * scale)
    for i in np.flatnonzero(unsure):
        try:
            from_fields(F[i])
        except ValueError:
            bad[i] = True
    return bad


_POSITIVE = (
    "mass",
    "inertia",
    "half_width",
    "half_height",
    "gravity",
    "band_half_width",
    "dwell_time",
)
_UNIT = ("mu_static", "mu_dynamic", "restitution_x", "restitution_y")


def _min_slide_denominators(col):
    """min_slide_denominator() of every row, and I + m l^2, on columns (see there)."""
    r, h, mu = col["half_width"], col["half_height"], col["mu_dynamic"]
    m, inertia = col["mass"], col["inertia"]
    base = inertia + m * (r * r + h * h) / 2.0
    best = np.full(r.shape, np.inf)
    for sigma in (-1.0, 1.0):
        a = (r * r - h * h) / 2.0 - sigma * mu * r * h
        b = -r * h - sigma * mu * (r * r - h * h) / 2.0
        # the stationary point lies in [0, pi] where atan2(-b, -a) % 2 pi <= pi: >= 0
        cand = np.minimum(a, -a)
        cand = np.where(np.arctan2(-b, -a) >= 0.0, np.minimum(cand, -np.hypot(a, b)), cand)
        best = np.minimum(best, base + m * cand)
    return best, inertia + m * np.hypot(r, h) ** 2
