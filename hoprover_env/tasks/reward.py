"""The reward of the RL tasks, in one place: its parameters and their validation, the
potential it keeps, and the terms it pays.

    r = gamma Phi(s') - Phi(s) - time_cost dt + success_bonus [success] - break_penalty [broke]
        - energy_weight * integral over the step of |T| / T_limit dt
        - attitude_cost * a(s') [s' in flight, not broken]

Phi(s) = -w_dist min(|x_ref - x_T|, cap) / 1 m - w_att a(s) - w_band (1 - d(s)), a sum
of three bounded potentials (so Phi >= phi_min):

* distance: x_ref is the contact point (or the bottom corner nearest the target in
  flight), or with shaping="landing" the ballistic landing point in flight (constant
  along a flight, so a hop is credited at its launch);
* attitude, in flight only: a(s) = (1 - cos theta) + U_Q ln(1 + min(u, U_MAX) / U_Q),
  u = (omega / 0.3)^2 / 2: the quadratic attitude cost up to spins of about 2 rad/s, a
  pull back at any faster spin, bounded by ATT_MAX;
* band: d(s) is the judge's dwell fraction (time in the band / 5 s, 0 out of it), so
  settling in the band pays before the success bonus and hovering next to it does not.

The attitude potential pays only differences: once a critic has learnt Q for its
policy, it shows no attitude credit as a difference between actions (potential shaping
is an initialisation of Q, Wiewiora 2003), and with tens of decisions in a flight any
torque can be corrected later, so the action gap it leaves is tiny. `attitude_cost`
charges a(s') of every decision that ends in flight instead (0 by default): a cost, not
a potential, so it does change which policy is optimal -- toward upright, still flights,
which is what a landing that does not break needs.

Termination values of Phi: 0 on success (the top of Phi); Phi(s) / gamma when the rover
breaks, so that the shaping of a breaking step is exactly 0: breaking cannot release a
potential (Phi = 0 there paid up to +142 for spinning into the ground) and an episode
that breaks keeps every potential it lost on the way down (Phi = phi_min instead made a
landing so costly that PPO from scratch learned to launch and never come down).

Arrays: the parameters ``RW`` (layout ``RW_*``, one vector per env) and the memory
``RM`` (layout ``RM_*``, one row per rover): the potential's terms at the current state
(NaN before an episode's first step) and what each term paid in the last step, so that
``info_level="full"`` reports the reward's breakdown (TERMS), which sums to the reward
up to rounding. The physics state S holds no reward.

A term may charge what the whole step accumulates, not only the state it ends in: the
hop task changes the torque many times inside one step (launch, attitude hold, rest) and
ends it at 0, so the torque at the end says nothing of its effort. Every task's step calls
`charge` after each advance of the physics with the torque it held and for how long;
`begin` clears the accumulator and `pay` pays it (the energy term).

Adding a term: a weight field in RewardConfig (validated in __post_init__) and its RW
slot, its potential in `potential_terms` (or its payment in `pay`), an RM slot and a
name in TERMS -- this module and its test (docs/ARCHITECTURE.md walks through it).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hoprover_env.core.layout import MODE_A, S_MODE, S_TH, S_W, S_XT
from hoprover_env.core.params import P_TMAX, P_TMIN
from hoprover_env.jit.compiler import BOOL, F64, VEC, kernel
from hoprover_env.tasks.observation import (
    POS_SCALE,
    RATE_SCALE,
    dwell_fraction,
    landing_x,
    reference_point,
)
from hoprover_env.util.validate import is_real, non_negative_real

(
    RW_W_DIST,
    RW_W_TIME,
    RW_SUCCESS,
    RW_BREAK,
    RW_GAMMA,
    RW_SHAPING,
    RW_W_ATT,
    RW_W_BAND,
    RW_DIST_CAP,
    RW_W_ENERGY,
    RW_ATT_COST,
) = range(11)
N_RW = 11
SHAPING_CONTACT, SHAPING_LANDING = 0, 1
SHAPINGS = {"contact": SHAPING_CONTACT, "landing": SHAPING_LANDING}

RM_PHI, RM_PHI_DIST, RM_PHI_ATT, RM_PHI_BAND = range(4)  # potential at the state
RM_DISTANCE, RM_ATTITUDE, RM_BAND, RM_TIME, RM_BONUS, RM_PENALTY, RM_ENERGY, RM_ATTITUDE_COST = (
    range(4, 12)
)
RM_EFFORT = 12  # accumulated in the current step: integral of |T| / T_limit dt [s]
N_RM = 13
TERMS = (
    "distance",
    "attitude",
    "band",
    "time",
    "bonus",
    "penalty",
    "energy",
    "attitude_cost",
)  # RM_DISTANCE on

# The spin term of a(s): quadratic up to u = U_Q (3 rad/s), logarithmic beyond, constant
# past U_MAX (30 rad/s). A pull that weakens early lets PPO settle for spinning flights:
# with ln(1 + u) (twenty times weaker at 3 rad/s) it spun the rover at 1-4 rad/s for
# whole episodes; with a term saturating at 1.3 rad/s, at 30 rad/s.
U_Q = 50.0
U_MAX = 5000.0
ATT_MAX = 2.0 + U_Q * math.log1p(U_MAX / U_Q)  # bound of a(s): (1 - cos theta) <= 2


@dataclasses.dataclass(frozen=True)
class RewardConfig:
    """The reward's arguments (the env tables list them; all validated here). An env
    config holds one as its `reward` field (hoprover_env/tasks/config.py); a task that
    changes a default subclasses it (the hop task's gamma)."""

    dist_weight: float = 1.0
    time_cost: float = 1.0 / 600.0
    success_bonus: float = 10.0
    break_penalty: float = 10.0
    gamma: float = 0.99
    shaping: str = "contact"
    attitude_weight: float = 0.0
    band_weight: float = 0.5
    dist_cap: float = 5.0
    energy_weight: float = 0.0
    attitude_cost: float = 0.0

    def __post_init__(self):
        for name in (
            "dist_weight",
            "time_cost",
            "success_bonus",
            "break_penalty",
            "attitude_weight",
            "band_weight",
            "energy_weight",
            "attitude_cost",
        ):
            non_negative_real(name, getattr(self, name))
        if not (is_real(self.gamma) and 0.0 < self.gamma <= 1.0):
            raise ValueError(f"gamma must lie in (0, 1], got {self.gamma!r}")
        if self.shaping not in SHAPINGS:
            raise ValueError(f"shaping must be one of {sorted(SHAPINGS)}, got {self.shaping!r}")
        if not (is_real(self.dist_cap) and math.isfinite(self.dist_cap) and self.dist_cap > 0):
            raise ValueError(f"dist_cap must be a positive number [m], got {self.dist_cap!r}")

    def reward_vector(self) -> np.ndarray:
        """The RW vector the kernels read."""
        rw = np.zeros(N_RW)
        rw[RW_W_DIST] = self.dist_weight
        rw[RW_W_TIME] = self.time_cost
        rw[RW_SUCCESS] = self.success_bonus
        rw[RW_BREAK] = self.break_penalty
        rw[RW_GAMMA] = self.gamma
        rw[RW_SHAPING] = SHAPINGS[self.shaping]
        rw[RW_W_ATT] = self.attitude_weight
        rw[RW_W_BAND] = self.band_weight
        rw[RW_DIST_CAP] = self.dist_cap
        rw[RW_W_ENERGY] = self.energy_weight
        rw[RW_ATT_COST] = self.attitude_cost
        return rw


# the reward's options, by name: what an env config takes flat and passes to its reward
OPTIONS = tuple(f.name for f in dataclasses.fields(RewardConfig))


def new_memory(n: int | None = None) -> np.ndarray:
    """Reward memory for a new episode (one row, or n rows): no potential computed yet
    (NaN), nothing paid or accumulated (0)."""
    m = np.zeros(N_RM if n is None else (n, N_RM))
    m[..., :RM_DISTANCE] = np.nan
    return m


def terms_info(rm: np.ndarray) -> dict:
    """The last step's reward terms as info entries ``reward_<term>`` (floats, or arrays
    for a 2-D memory)."""
    return {
        f"reward_{name}": (
            rm[..., RM_DISTANCE + i].copy() if rm.ndim > 1 else float(rm[RM_DISTANCE + i])
        )
        for i, name in enumerate(TERMS)
    }


@kernel(inner=True)
def attitude_error(S):
    """a(s) of a flying rover: (1 - cos theta) plus the bounded spin term (module
    docstring); what the attitude potential and the per-decision attitude cost weigh."""
    w = S[S_W] / RATE_SCALE
    u = 0.5 * w * w
    spin = U_Q * math.log1p(min(u, U_MAX) / U_Q)
    return (1.0 - math.cos(S[S_TH])) + spin


@kernel(inner=True)
def potential_terms(S, P, RW, RM):
    """Write the potential's terms at state S into RM[RM_PHI..RM_PHI_BAND]."""
    flying = int(S[S_MODE]) == MODE_A
    if int(RW[RW_SHAPING]) == SHAPING_LANDING and flying:
        x = landing_x(S, P)
    else:
        x = reference_point(S, P)
    dist = -RW[RW_W_DIST] * min(abs(x - S[S_XT]), RW[RW_DIST_CAP]) / POS_SCALE
    phi = dist
    att = 0.0
    if flying:
        att = RW[RW_W_ATT] * attitude_error(S)
        phi -= att
    band = 0.0
    if RW[RW_W_BAND] != 0.0:
        band = RW[RW_W_BAND] * (1.0 - dwell_fraction(S, P))
        phi -= band
    RM[RM_PHI] = phi
    RM[RM_PHI_DIST] = dist
    RM[RM_PHI_ATT] = -att
    RM[RM_PHI_BAND] = -band


@kernel(F64(VEC, VEC, VEC, VEC))
def potential(S, P, RW, RM):
    """Phi(s) (see the module docstring); RM receives its terms."""
    potential_terms(S, P, RW, RM)
    return RM[RM_PHI]


@kernel
def phi_min(RW):
    """The lowest value the potential can take (every term is bounded)."""
    return -(RW[RW_W_DIST] * RW[RW_DIST_CAP] / POS_SCALE + RW[RW_W_ATT] * ATT_MAX + RW[RW_W_BAND])


@kernel(F64(VEC, VEC, VEC, VEC), inner=True)
def begin(S, P, RW, RM):
    """Phi at the start of a step: kept from the last step, computed on the first. The
    step's accumulators start empty."""
    RM[RM_EFFORT] = 0.0
    if math.isnan(RM[RM_PHI]):
        potential_terms(S, P, RW, RM)
    return RM[RM_PHI]


@kernel(inner=True)
def charge(P, RM, torque, seconds):
    """Accumulate what the rover spent while it held `torque` [N m] for `seconds`: the
    torque as a fraction of its limit in that direction, integrated over time. A task's
    step calls it after every advance of the physics."""
    limit = P[P_TMAX] if torque >= 0.0 else -P[P_TMIN]
    if limit > 0.0:
        RM[RM_EFFORT] += abs(torque) / limit * seconds


@kernel(F64(VEC, VEC, VEC, VEC, F64, BOOL, BOOL, F64), inner=True)
def pay(S, P, RW, RM, phi0, success, broken, elapsed):
    """The reward of a step that started at potential phi0 (its terms in RM as `begin`
    left them) and lasted `elapsed` seconds; RM then holds the new state's potential
    and the step's terms."""
    gamma = RW[RW_GAMMA]
    d0 = RM[RM_PHI_DIST]
    a0 = RM[RM_PHI_ATT]
    b0 = RM[RM_PHI_BAND]
    if broken:
        phi1 = phi0 / gamma
        RM[RM_PHI] = phi1
        RM[RM_PHI_DIST] = d0 / gamma
        RM[RM_PHI_ATT] = a0 / gamma
        RM[RM_PHI_BAND] = b0 / gamma
    elif success:
        phi1 = 0.0
        RM[RM_PHI] = 0.0
        RM[RM_PHI_DIST] = 0.0
        RM[RM_PHI_ATT] = 0.0
        RM[RM_PHI_BAND] = 0.0
    else:
        potential_terms(S, P, RW, RM)
        phi1 = RM[RM_PHI]
    reward = gamma * phi1 - phi0 - RW[RW_W_TIME] * elapsed
    RM[RM_DISTANCE] = gamma * RM[RM_PHI_DIST] - d0
    RM[RM_ATTITUDE] = gamma * RM[RM_PHI_ATT] - a0
    RM[RM_BAND] = gamma * RM[RM_PHI_BAND] - b0
    RM[RM_TIME] = -RW[RW_W_TIME] * elapsed
    RM[RM_BONUS] = 0.0
    RM[RM_PENALTY] = 0.0
    if success:
        reward += RW[RW_SUCCESS]
        RM[RM_BONUS] = RW[RW_SUCCESS]
    if broken:
        reward -= RW[RW_BREAK]
        RM[RM_PENALTY] = -RW[RW_BREAK]
    RM[RM_ENERGY] = 0.0
    if RW[RW_W_ENERGY] != 0.0:  # a zero weight leaves the reward's bits untouched
        RM[RM_ENERGY] = -RW[RW_W_ENERGY] * RM[RM_EFFORT]
        reward += RM[RM_ENERGY]
    RM[RM_ATTITUDE_COST] = 0.0
    if RW[RW_ATT_COST] != 0.0 and not broken and int(S[S_MODE]) == MODE_A:
        RM[RM_ATTITUDE_COST] = -RW[RW_ATT_COST] * attitude_error(S)
        reward += RM[RM_ATTITUDE_COST]
    return reward
