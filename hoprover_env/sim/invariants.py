"""Invariant checks of a simulated rover, shared by the tests and the benchmarks.

One home for the rules a correct state obeys (docs/MODEL.md section 4), so that the
property tests (tests/sim/test_stress.py, tests/sim/test_regressions.py) and the stability
stress benchmark (benchmarks/bench_stress.py, through research/stress/drivers.py's driver) judge
states by the same code:

* `check_state` -- one kernel state vector: finite, no bottom corner under the ground,
  and the contact letter agrees with the kinematics. Jitted, so a driver can call it
  after every impact of millions of runs.
* `kinematic_violations` -- the same rules over the samples of a `Rollout`.
* `gained_energy` -- an impact's kinetic-energy ratio shows a gain (which the
  `dissipative` law must never produce).
The independent scipy solution of launches and flights is hoprover_env/sim/reference.py.
"""

from __future__ import annotations

import math

import numpy as np

from hoprover_env import core
from hoprover_env.core import MODE_A, MODE_B, MODE_C, MODE_D, MODE_F, MODE_G
from hoprover_env.core.params import P_H
from hoprover_env.jit.compiler import kernel

PENETRATION_TOL = 1e-9  # m: a bottom corner lower than -this is under the ground
KINEMATIC_TOL = 1e-9  # default tolerance of the kinematic rules
ENERGY_TOL = 1e-12  # relative: the kernel's own threshold for "gained energy"

# Violation kinds: bits of the masks `check_state` returns (and of the stress
# benchmark's counters, which add the kinds only a driver can see).
V_NAN, V_PEN_EVENT, V_PEN_SAMPLE, V_KINEMATICS, V_ENERGY, V_TIME, V_BUDGET = range(7)
VIOLATION_NAMES = ("nan", "pen_event", "pen_sample", "kinematics", "energy", "time", "budget")
N_VIOLATION_KINDS = len(VIOLATION_NAMES)
# Details (bits after the kinds): of `kinematics`, a single-contact state whose only
# fault is the sign of theta (tilted toward the free corner, which is then under the
# ground by less than the tolerance), and every other kinematic fault; of `pen_event`,
# those in a control interval that ended with the rover broken.
WRONG_TILT_ONLY = N_VIOLATION_KINDS
KINEMATICS_OTHER = N_VIOLATION_KINDS + 1
PEN_AT_BREAK = N_VIOLATION_KINDS + 2
N_RECORDS = N_VIOLATION_KINDS + 3
RECORD_NAMES = VIOLATION_NAMES + (
    "kinematics: wrong tilt only",
    "kinematics: other",
    "pen_event: at a break",
)

# How far the checked states strayed from their constraints (slots of a `drift` vector
# that `check_state` updates): counts of single-contact (B-E) and F/G states, the lowest
# bottom corner, the contact corner's |y| and |vy|, a pivot's |vx|, and F/G's distance
# from upright rest.
(
    D_SAMPLES_SINGLE,
    D_SAMPLES_DOUBLE,
    D_MIN_HEIGHT,
    D_CORNER_Y,
    D_CORNER_VY,
    D_PIVOT_VX,
    D_FG_Y,
    D_FG_TH,
    D_FG_VY,
    D_FG_W,
) = range(10)
N_DRIFT = 10


def new_drift() -> np.ndarray:
    d = np.zeros(N_DRIFT)
    d[D_MIN_HEIGHT] = np.inf
    return d


@kernel
def finite_state(S):
    """The c.m. state and the time are finite."""
    for i in range(core.S_T + 1):
        if not math.isfinite(S[i]):
            return False
    return True


@kernel
def gained_energy(ratio):
    """An impact's KE after / KE before shows a gain (or is not a number)."""
    return ratio > 1.0 + ENERGY_TOL or not math.isfinite(ratio)


@kernel
def check_state(S, P, tol, drift):
    """Check one kernel state S (parameters P); update the `drift` maxima (D_* slots).
    Returns a bit mask of violations: V_NAN, V_PEN_SAMPLE (a bottom corner below
    -PENETRATION_TOL), V_KINEMATICS with its detail WRONG_TILT_ONLY or KINEMATICS_OTHER.

    Kinematic rules, tolerance `tol`: in A both bottom corners at or above the ground;
    in B/C (D/E) corner A (B) on the ground at rest vertically, the other above, theta
    in [0, pi/2) ((-pi/2, 0]); a pivot's (B, D) corner at rest horizontally too; F and G
    exactly upright and still, F at rest, G sliding.
    """
    if not finite_state(S):
        return 1 << V_NAN
    bad = 0
    mode = int(S[core.S_MODE])
    th = S[core.S_TH]
    y = S[core.S_Y]
    w = S[core.S_W]
    dxa, dya = core.corner_offset(P, 0, th)
    dxb, dyb = core.corner_offset(P, 1, th)
    ya = y + dya
    yb = y + dyb
    low = min(ya, yb)
    if low < drift[D_MIN_HEIGHT]:
        drift[D_MIN_HEIGHT] = low
    if low < -PENETRATION_TOL:
        bad |= 1 << V_PEN_SAMPLE
    wth = core.wrap_angle(th)
    ok = True
    if mode == MODE_A:
        ok = ya >= -tol and yb >= -tol
    elif mode == MODE_F or mode == MODE_G:
        drift[D_SAMPLES_DOUBLE] += 1.0
        drift[D_FG_Y] = max(drift[D_FG_Y], abs(y - P[P_H]))
        drift[D_FG_TH] = max(drift[D_FG_TH], abs(wth))
        drift[D_FG_VY] = max(drift[D_FG_VY], abs(S[core.S_VY]))
        drift[D_FG_W] = max(drift[D_FG_W], abs(w))
        ok = wth == 0.0 and y == P[P_H] and S[core.S_VY] == 0.0 and w == 0.0
        if mode == MODE_F:
            ok = ok and S[core.S_VX] == 0.0
        else:
            ok = ok and S[core.S_VX] != 0.0
    else:
        drift[D_SAMPLES_SINGLE] += 1.0
        on_a = mode == MODE_B or mode == MODE_C
        dx = dxa if on_a else dxb
        dy = dya if on_a else dyb
        yc = ya if on_a else yb
        y_other = yb if on_a else ya
        vyc = S[core.S_VY] - w * dx
        vxc = S[core.S_VX] + w * dy
        drift[D_CORNER_Y] = max(drift[D_CORNER_Y], abs(yc))
        drift[D_CORNER_VY] = max(drift[D_CORNER_VY], abs(vyc))
        ok = abs(yc) <= tol and abs(vyc) <= tol and y_other >= -tol
        if mode == MODE_B or mode == MODE_D:
            drift[D_PIVOT_VX] = max(drift[D_PIVOT_VX], abs(vxc))
            ok = ok and abs(vxc) <= tol
        tilt_ok = (-tol <= wth < 0.5 * math.pi) if on_a else (-0.5 * math.pi < wth <= tol)
        if ok and not tilt_ok:
            # everything holds but the sign of theta: the free corner is (less than
            # `tol`) under the contact corner, i.e. under the ground
            return bad | (1 << V_KINEMATICS) | (1 << WRONG_TILT_ONLY)
    if not ok:
        bad |= (1 << V_KINEMATICS) | (1 << KINEMATICS_OTHER)
    return bad


def rollout_states(roll):
    """Kernel state vectors (c.m. state, time, mode) of a Rollout's samples."""
    s = np.zeros((len(roll.t), core.N_STATE))
    s[:, : core.S_T + 1] = np.c_[roll.x, roll.y, roll.theta, roll.vx, roll.vy, roll.omega, roll.t]
    s[:, core.S_MODE] = [core.MODE_LETTERS.index(st) for st in roll.state]
    return s


def kinematic_violations(roll, tol: float = KINEMATIC_TOL) -> list:
    """(index, t, state letter) of the samples of a Rollout whose state letter
    contradicts the kinematics (or that are not finite), by `check_state`'s rules. The
    last sample of a broken run is skipped: at the breaking instant a top corner is on
    the ground and no contact letter applies."""
    p = roll.params.as_array()
    drift = new_drift()
    flags = (1 << V_KINEMATICS) | (1 << V_NAN)
    last = len(roll.t) - 1
    return [
        (i, roll.t[i], roll.state[i])
        for i, s in enumerate(rollout_states(roll))
        if not (roll.broken and i == last) and check_state(s, p, tol, drift) & flags
    ]
