"""The physics of the hopping rover: one jitted kernel over flat float arrays.

Everything that moves the rover lives here, once: contact forces of the seven states,
the instantaneous transitions between them (`settle`), the impact laws
(`resolve_impact`), the judge, and the two integrators over this one model:

* ``event`` -- flight in closed form (a parabola and a quadratic attitude), the
  single-contact phases B-E by an adaptive DOP853 (order 8) with every guard located
  as an event by re-taking the step with a shorter length, G in closed form, F free.
  Its cost grows with the number of events, not with simulated time.
* ``euler`` -- the contest-style fixed-step explicit Euler baseline: the same forces,
  transitions and impact law, but guards are only checked at the end of each step.

State vector ``S`` (float64, layout ``S_*``): the c.m. state, time, contact mode,
slide direction, applied torque, target, judge and diagnostics. Parameter vector
``P`` (layout ``P_*`` of :mod:`hoprover_env.params`). Options ``O`` (layout ``O_*``).
The kernel takes no Python objects, so the vector env loops it over rows of 2-D
arrays in one jitted call.

Conventions (docs/MODEL.md section 2): x right, y up, theta clockwise-positive, positive T
clockwise. A body point with world offset d = (dx, dy) from the c.m. moves with
v + w (dy, -dx); a force f there has the clockwise moment dy fx - dx fy. Corner k has
body coordinates (bx, by): A = (r, -h), B = (-r, -h), TR = (r, h), TL = (-r, h), and
world offset dx = bx cos(th) + by sin(th), dy = -bx sin(th) + by cos(th).

Decisions beyond docs/MODEL.md are documented in docs/PHYSICS.md and marked "Decision" here.
The kernel allocates nothing: scratch space comes in a workspace row ``W`` (N_WORK floats).
All kernels use numba's numpy error model: a float division never raises (every divisor
here is a positive physical quantity), which keeps calls cheap (the Python model costs
~70 ns per call through its exception path).
"""
import math

import numpy as np
from numba import njit, types as nt
from numba.core.registry import CPUDispatcher

from ._dop853_tableau import A as _RK_A, B as _RK_B, E3 as _RK_E3, E5 as _RK_E5
from .params import (P_M, P_I, P_R, P_H, P_G, P_MUS, P_MUD, P_EX, P_EY, P_VXMIN,
                     P_VYMIN, P_TMIN, P_TMAX, P_BAND, P_DWELL)

# How every kernel function is compiled: cached on disk, numpy's error model (a division
# by zero gives inf/nan, which the callers check, instead of raising) and no reference
# counting (no function allocates). Functions only ever called from other jitted code get
# no Python and C entry wrappers (INNER): numba would otherwise build each one, optimise it
# and link it again into every caller, about 2 s of the cold start. The integrator's entry
# (advance, _advance_event) is inlined into its callers, so that the env's step does not
# pay for linking the whole kernel twice more (numba re-optimises every callee's code in
# each jitted caller). Calling an INNER function from Python raises a TypeError
# (guard_jit_only, at the end of each kernel module).
JIT = dict(cache=True, error_model="numpy", _nrt=False)
INNER = dict(JIT, no_cpython_wrapper=True, no_cfunc_wrapper=True)
JIT_INLINE = dict(JIT, inline="always")
INNER_INLINE = dict(INNER, inline="always")


class _JitOnlyDispatcher(CPUDispatcher):
    """An INNER function seen from Python. It has no Python entry: numba would jump to a
    null one and crash the interpreter (a segmentation fault), so the call raises."""

    def __call__(self, *args, **kwargs):
        f = self.py_func
        raise TypeError(f"{f.__module__}.{f.__qualname__} is compiled for calls from jitted "
                        "code only (core.INNER): call it from an @njit function, or compile "
                        "it with core.JIT to call it from Python")


def guard_jit_only(namespace: dict) -> None:
    """Make the INNER functions of a module raise TypeError when Python calls them.
    Called at the end of each kernel module; jitted callers are unaffected."""
    for obj in list(namespace.values()):
        if type(obj) is CPUDispatcher and obj.targetoptions.get("no_cpython_wrapper"):
            obj.__class__ = _JitOnlyDispatcher

# Explicit signatures for the helpers that take small integers: without them numba
# compiles a separate copy for every literal corner or event number it is called with.
_V = nt.float64[::1]
_M = nt.float64[:, ::1]
_F = nt.float64
_I = nt.int64
_F2 = nt.UniTuple(_F, 2)
_F4 = nt.UniTuple(_F, 4)
_F5 = nt.UniTuple(_F, 5)

# ----------------------------------------------------------------------------------
# Layouts
# ----------------------------------------------------------------------------------
S_X, S_Y, S_TH, S_VX, S_VY, S_W = 0, 1, 2, 3, 4, 5
S_T = 6          # simulation time [s]
S_MODE = 7       # contact state 0..6 = A..G
S_SIGMA = 8      # slide direction of the contact point (+1, -1; 0 when not sliding)
S_TORQUE = 9     # applied (clipped) torque, held until the next control instant
S_XT = 10        # target x
S_BROKEN = 11    # 1 once a top corner touched the ground
S_INBAND = 12    # judge: 1 while a contact point is in the band
S_TIN = 13       # judge: time the current stay in the band began
S_TTRTP = 14     # judge: time to reach the target point (NaN until reached)
S_HSTEP = 15     # last accepted DOP853 step (a warm start for the next phase)
S_NEVENTS = 16   # events so far (transitions, impacts, band crossings)
S_NIMPACT = 17   # impacts so far
S_NGAIN = 18     # impacts that raised the kinetic energy
S_MAXGAIN = 19   # largest relative kinetic-energy gain of one impact
S_ERROR = 20     # 0 = fine; 1 = event budget of one advance exhausted; 2 = bad torque
S_STOP_ON = 21   # event kind that ends `advance` early (-1: none), for look-ahead tools
S_STOPPED = 22   # set when that event happened in the last `advance`
S_MIN_HEIGHT = 23  # diagnostics: lowest bottom-corner height seen after any event
S_PHI = 24       # the RL reward's potential at the current state (NaN: not computed)
N_STATE = 25

MODE_A, MODE_B, MODE_C, MODE_D, MODE_E, MODE_F, MODE_G = 0, 1, 2, 3, 4, 5, 6
MODE_LETTERS = "ABCDEFG"

O_INTEGRATOR, O_LAW, O_RTOL, O_EULER_DT = 0, 1, 2, 3
N_OPTIONS = 4
INTEGRATOR_EVENT, INTEGRATOR_EULER = 0, 1
LAW_CONTEST, LAW_DISSIPATIVE = 0, 1

# Event kinds written to the log (column 1) -- names in EVENT_NAMES.
EV_LIFTOFF, EV_SLIP, EV_STICK, EV_REVERSE, EV_IMPACT, EV_RESUME, EV_TIP, EV_STOP, \
    EV_BAND_IN, EV_BAND_OUT, EV_BROKEN, EV_TTRTP = range(12)
EVENT_NAMES = ("liftoff", "slip", "stick", "reverse", "impact", "resume", "tip", "stop",
               "band_in", "band_out", "broken", "ttrtp")
EV_COLS = 5      # t, kind, mode before, mode after, value (impacts: KE after / KE before)

# Budget of events in one call of `advance` (one control interval). A bounce sequence
# is finite (each bounce keeps e_y of the vertical speed, v_ymin ends it), so hitting
# this means a modelling failure; the run stops with S_ERROR = 1 instead of hanging.
MAX_EVENTS = 2000

# Scratch memory. The kernel allocates nothing and runs without numba's reference-counted
# runtime (_nrt=False): with it, every call that passes arrays pays atomic increments and
# decrements (~50 ns a call, and contention between threads). Callers pass a row of
# N_WORK floats per thread (RoverSim and the environments own theirs).
N_WORK = 192
W_IMP = 0        # impacts: 22 floats
W_FLT = 24       # flight: 8
W_RK = 32        # contact phases: 134
W_WORK = 176     # integration steps (flight + DOP853) taken in the current advance

# ----------------------------------------------------------------------------------
# Tolerances. Round-off must not make a contact state chatter (docs/MODEL.md section 5).
# Scales: lengths ~0.05 m, speeds 1e-6..1e-2 m/s, accelerations ~1e-4 m/s^2.
# ----------------------------------------------------------------------------------
H_TOL = 1e-12     # m: a corner this close to the ground is on it
V_TOL = 1e-12     # m/s: a corner this slow (vertically / sliding) is at rest
A_TOL = 1e-13     # m/s^2: acceleration sign tolerance (resting corner driven down?)
F_TOL = 1e-12     # x m g: force sign tolerance (lift-off, slip)
CA_TOL = 1e-15    # m: conservative advancement stops this close to a touchdown
# m: at an impact, a bottom corner this close to the ground takes part too. Simultaneous
# and sequential impacts of a nearly flat body differ discontinuously (rigid-body
# impacts are ill-posed there); a controller that lands flat leaves theta ~ 1e-14 or
# ~1e-11 rad depending on round-off, so the switch must sit well above round-off.
H_IMPACT = 1e-9
MAX_CA_ITER = 20000
FLIGHT_WINDOW_MAX = 1e6  # s: longest stretch of a flight one curvature bound covers
RK_SAFETY = 0.9
RK_MIN_FACTOR = 0.2
# Error codes in S[S_ERROR] (0 = fine): the event budget of one advance exhausted, a
# non-finite torque, the integrator unable to go on (step-size underflow, a non-finite
# state, or the step / phase bounds below), each ending the loop it happened in.
ERR_BUDGET, ERR_TORQUE, ERR_STEP, ERR_WORK = 1.0, 2.0, 3.0, 4.0
MAX_RK_STEPS = 10_000_000       # DOP853 steps in one contact phase
# Integration steps (flight + DOP853) in one advance, all phases together: about a
# second of CPU. A contest interval takes tens to thousands; only inputs far outside the
# rover's range (a torque of 1e10 N m spinning it at 1e12 rad/s) come near, and those
# would otherwise run MAX_PHASES x MAX_CA_ITER flight steps, i.e. hours (ERR_WORK).
MAX_WORK = 10_000_000
MAX_PHASES = 100_000            # phases in one advance (each normally logs an event)
RK_MAX_FACTOR = 10.0
TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------------
# Geometry
# ----------------------------------------------------------------------------------
@njit(_F2(_V, _I), **JIT)
def corner_body(P, k):
    """Body coordinates (bx, by) of corner k: 0 A, 1 B (bottom), 2 TR, 3 TL (top)."""
    bx = P[P_R] if (k == 0 or k == 2) else -P[P_R]
    by = -P[P_H] if k < 2 else P[P_H]
    return bx, by


@njit(_F2(_V, _I, _F, _F), **INNER)
def corner_offset_cs(P, k, c, s):
    """corner_offset with cos(th), sin(th) given: hot paths compute them once."""
    bx, by = corner_body(P, k)
    return bx * c + by * s, -bx * s + by * c


@njit(_F2(_V, _I, _F), **JIT)
def corner_offset(P, k, th):
    """World offset (dx, dy) of corner k from the c.m. at attitude th."""
    return corner_offset_cs(P, k, math.cos(th), math.sin(th))


@njit(**JIT)
def wrap_angle(th):
    """Attitude in (-pi, pi]."""
    w = th - TWO_PI * math.floor((th + math.pi) / TWO_PI)   # exact for th in range
    return math.pi if w == -math.pi else w


@njit(**INNER)
def kinetic_energy(S, P):
    return 0.5 * P[P_M] * (S[S_VX] ** 2 + S[S_VY] ** 2) + 0.5 * P[P_I] * S[S_W] ** 2


@njit(_I(_I), **INNER)
def contact_corner(mode):
    """Corner index in contact for the single-contact modes (A for B/C, B for D/E)."""
    return 0 if (mode == MODE_B or mode == MODE_C) else 1


# ----------------------------------------------------------------------------------
# Forces (docs/MODEL.md section 4), written once for a generic contact corner.
# ----------------------------------------------------------------------------------
@njit(_F5(_V, _I, _F, _F, _F), **INNER)
def pivot_dynamics(P, k, T, th, w):
    """Pivot on corner k (state B for A, D for B).

    The corner is fixed: c.m. acceleration a = -thdd (dy, -dx) + w^2 (dx, dy), so
    thdd = (T - m g dx) / (I + m l^2), f = m a + (0, m g).
    Returns (thdd, fx, fy, dx, dy).
    """
    m = P[P_M]
    g = P[P_G]
    dx, dy = corner_offset(P, k, th)
    thdd = (T - m * g * dx) / (P[P_I] + m * (dx * dx + dy * dy))
    fx = m * (-thdd * dy + w * w * dx)
    fy = m * (thdd * dx + w * w * dy + g)
    return thdd, fx, fy, dx, dy


@njit(_F5(_V, _I, _F, _F, _F, _F), **INNER)
def slide_dynamics(P, k, sigma, T, th, w):
    """Slide on corner k in direction sigma (state C for A, E for B).

    Only the normal constraint holds; friction f_x = -sigma mu_d f_y.
    D = I + m dx (dx + sigma mu_d dy) (> 0 outside the Painleve regime),
    thdd = [T - m (dx + sigma mu_d dy)(w^2 dy + g)] / D, f_y = m (thdd dx + w^2 dy + g).
    Returns (thdd, fx, fy, dx, dy).
    """
    m = P[P_M]
    g = P[P_G]
    dx, dy = corner_offset(P, k, th)
    q = dx + sigma * P[P_MUD] * dy
    thdd = (T - m * q * (w * w * dy + g)) / (P[P_I] + m * dx * q)
    fy = m * (thdd * dx + w * w * dy + g)
    fx = -sigma * P[P_MUD] * fy
    return thdd, fx, fy, dx, dy


@njit(**INNER)
def double_contact_forces(P, sigma, T):
    """States F (sigma = 0) and G: both corners on the ground, theta = 0, omega = 0.

    f_Ay + f_By = m g and, from the moment balance, f_Ay - f_By = (T + sigma mu_d m g h) / r.
    Returns (fAx, fAy, fBx, fBy).
    """
    m = P[P_M]
    g = P[P_G]
    diff = (T + sigma * P[P_MUD] * m * g * P[P_H]) / P[P_R]
    fay = 0.5 * (m * g + diff)
    fby = 0.5 * (m * g - diff)
    return -sigma * P[P_MUD] * fay, fay, -sigma * P[P_MUD] * fby, fby


@njit(**JIT)
def contact_forces(S, P):
    """Contact forces (fAx, fAy, fBx, fBy) of the current state and torque."""
    mode = int(S[S_MODE])
    T = S[S_TORQUE]
    if mode == MODE_F:
        return double_contact_forces(P, 0.0, T)
    if mode == MODE_G:
        return double_contact_forces(P, S[S_SIGMA], T)
    if mode == MODE_A:
        return 0.0, 0.0, 0.0, 0.0
    k = contact_corner(mode)
    if mode == MODE_B or mode == MODE_D:
        _, fx, fy, _, _ = pivot_dynamics(P, k, T, S[S_TH], S[S_W])
    else:
        _, fx, fy, _, _ = slide_dynamics(P, k, S[S_SIGMA], T, S[S_TH], S[S_W])
    if k == 0:
        return fx, fy, 0.0, 0.0
    return 0.0, 0.0, fx, fy


@njit(nt.void(_V, _V, _I), **INNER)
def _set_single_contact(S, P, k):
    """Make the c.m. state satisfy corner k's constraint exactly: y_k = 0, vy_k = 0.

    The height is snapped (a round-off-sized move); the vertical point velocity is
    removed by a vertical impulse at the corner (an energy-non-increasing projection).
    """
    dx, dy = corner_offset(P, k, S[S_TH])
    S[S_Y] = -dy
    vpy = S[S_VY] - S[S_W] * dx
    if vpy != 0.0:
        m = P[P_M]
        inv_i = 1.0 / P[P_I]
        lam = -vpy / (1.0 / m + dx * dx * inv_i)
        S[S_VY] += lam / m
        S[S_W] += -dx * lam * inv_i


@njit(nt.void(_V, _V, _I), **INNER)
def _pin_corner(S, P, k):
    """Bring corner k's whole velocity to zero by one impulse there (a projection)."""
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    dx, dy = corner_offset(P, k, S[S_TH])
    vpx = S[S_VX] + S[S_W] * dy
    vpy = S[S_VY] - S[S_W] * dx
    # K = I2/m + u u^T / I with u = (dy, -dx)
    k11 = 1.0 / m + dy * dy * inv_i
    k12 = -dy * dx * inv_i
    k22 = 1.0 / m + dx * dx * inv_i
    det = k11 * k22 - k12 * k12
    lx = (-vpx * k22 + vpy * k12) / det
    ly = (-vpy * k11 + vpx * k12) / det
    S[S_VX] += lx / m
    S[S_VY] += ly / m
    S[S_W] += (dy * lx - dx * ly) * inv_i
    S[S_Y] = -dy


@njit(nt.void(_V, _V, _I), **INNER)
def _turn_flat_about(S, P, k):
    """Turn the body about contact corner k to theta = 0, where the other bottom corner
    touches too: the projection used when that corner ended (round-off or a finite step)
    under the ground. Keeps corner k's position and its contact constraint."""
    dx, _ = corner_offset(P, k, S[S_TH])
    xpiv = S[S_X] + dx
    S[S_TH] = 0.0
    dx, dy = corner_offset(P, k, 0.0)
    S[S_X] = xpiv - dx
    S[S_Y] = -dy
    S[S_VY] = S[S_W] * dx


@njit(**INNER)
def _set_double_contact(S, P):
    """Both corners on the ground: theta = 0, omega = 0, vy = 0, y = h; F or G.

    Decision: the horizontal velocity kept is the c.m.'s. The residual vertical and
    angular velocities (below v_ymin) are removed by vertical impulses at A and B, which
    leave vx unchanged and cannot add energy; with omega = 0 the contact points then
    move with vx, the common horizontal contact velocity.
    """
    S[S_TH] = 0.0
    S[S_W] = 0.0
    S[S_Y] = P[P_H]
    S[S_VY] = 0.0
    if abs(S[S_VX]) < P[P_VXMIN] or S[S_VX] == 0.0:
        S[S_VX] = 0.0
        S[S_MODE] = MODE_F
        S[S_SIGMA] = 0.0
    else:
        S[S_MODE] = MODE_G
        S[S_SIGMA] = 1.0 if S[S_VX] > 0.0 else -1.0


# ----------------------------------------------------------------------------------
# Flight (state A) in closed form
# ----------------------------------------------------------------------------------
@njit(**INNER)
def flight_at(S, P, tau):
    """State after a flight of duration tau under the held torque."""
    g = P[P_G]
    beta = S[S_TORQUE] / P[P_I]
    x = S[S_X] + S[S_VX] * tau
    y = S[S_Y] + S[S_VY] * tau - 0.5 * g * tau * tau
    th = S[S_TH] + S[S_W] * tau + 0.5 * beta * tau * tau
    return x, y, th, S[S_VX], S[S_VY] - g * tau, S[S_W] + beta * tau


@njit(_F(_V, _V, _I, _F), **INNER)
def flight_rise(S, P, k, tau):
    """Height gained by corner k after a flight of duration tau, h_k(tau) - h_k(0),
    computed as a difference (sin a - sin b = 2 cos((a+b)/2) sin((a-b)/2)): a corner
    that returns to the ground microseconds after a lift-off moves 1e-14 m, below the
    round-off of y + dy(theta) (~1e-17 m at y ~ 0.05 m, i.e. 1e-8 s at 1e-9 m/s)."""
    bx, by = corner_body(P, k)
    dth = S[S_W] * tau + 0.5 * S[S_TORQUE] / P[P_I] * tau * tau
    mid = S[S_TH] + 0.5 * dth
    sh = math.sin(0.5 * dth)
    d_sin = 2.0 * math.cos(mid) * sh
    d_cos = -2.0 * math.sin(mid) * sh
    return S[S_VY] * tau - 0.5 * P[P_G] * tau * tau - bx * d_sin + by * d_cos


@njit(_F(_V, _V, _I, _F, _F, _F), **INNER)
def _bisect_touchdown(S, P, k, lo, hi, drop):
    """The time in [lo, hi] at which corner k has risen by `drop` (< 0: it is back at
    the level where it should touch), given rise(lo) >= drop > rise(hi). Bisection on
    the closed form: robust where Newton divides by a vanishing vertical speed."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if flight_rise(S, P, k, mid) >= drop:
            lo = mid
        else:
            hi = mid
    return hi


@njit(nt.boolean(_V, _V, _I), **INNER)
def _resting_corner_driven_down(S, P, k):
    """A corner on the ground at rest vertically, in flight: is it pressed down?

    Decided by the flight dynamics (docs/MODEL.md section 5): the sign of the corner's
    vertical acceleration h'' = -g - beta dx - w^2 dy, or when that vanishes (a lift-off
    instant) of its jerk h''' = -3 beta w dy + w^3 dx.
    """
    beta = S[S_TORQUE] / P[P_I]
    w = S[S_W]
    dx, dy = corner_offset(P, k, S[S_TH])
    acc = -P[P_G] - beta * dx - w * w * dy
    if acc < -A_TOL:
        return True
    if acc > A_TOL:
        return False
    jerk = -3.0 * beta * w * dy + w * w * w * dx
    return jerk < 0.0


# ----------------------------------------------------------------------------------
# Event log and judge (docs/MODEL.md section 8)
# ----------------------------------------------------------------------------------
@njit(_I(_V, _M, _I, _F, _F, _F, _F, _F), **JIT)
def _log(S, ev, n, t, kind, before, after, value):
    S[S_NEVENTS] += 1.0
    if kind == S[S_STOP_ON]:
        S[S_STOPPED] = 1.0
    if n < ev.shape[0]:
        ev[n, 0] = t
        ev[n, 1] = kind
        ev[n, 2] = before
        ev[n, 3] = after
        ev[n, 4] = value
    return n + 1


@njit(**JIT)
def in_band(S, P):
    """Is a contact point within the band? (A, B in F/G; none in flight)."""
    mode = int(S[S_MODE])
    if mode == MODE_A:
        return False
    xt = S[S_XT]
    w = P[P_BAND]
    # inclusive, with a few ulps of slack for round-off in the corner position
    tol = 8.0 * 2.220446049250313e-16 * (1.0 + abs(xt) + abs(S[S_X]))
    if mode == MODE_F or mode == MODE_G:
        xa = S[S_X] + P[P_R]
        xb = S[S_X] - P[P_R]
        return abs(xa - xt) <= w + tol or abs(xb - xt) <= w + tol
    dx, _ = corner_offset(P, contact_corner(mode), S[S_TH])
    return abs(S[S_X] + dx - xt) <= w + tol


@njit(_I(_V, _V, _M, _I), **INNER)
def _judge_check(S, P, ev, n):
    """Record TTRTP once the current stay in the band has lasted the dwell time."""
    if S[S_INBAND] == 1.0 and math.isnan(S[S_TTRTP]):
        t_star = S[S_TIN] + P[P_DWELL]
        if S[S_T] >= t_star:
            S[S_TTRTP] = t_star
            m = S[S_MODE]
            n = _log(S, ev, n, t_star, EV_TTRTP, m, m, 0.0)
    return n


@njit(_I(_V, _V, _M, _I, nt.boolean), **INNER)
def _judge_set(S, P, ev, n, status):
    """The band status becomes `status` at the current time."""
    if status and S[S_INBAND] == 0.0:
        S[S_INBAND] = 1.0
        S[S_TIN] = S[S_T]
        n = _log(S, ev, n, S[S_T], EV_BAND_IN, S[S_MODE], S[S_MODE], 0.0)
    elif (not status) and S[S_INBAND] == 1.0:
        n = _judge_check(S, P, ev, n)
        S[S_INBAND] = 0.0
        n = _log(S, ev, n, S[S_T], EV_BAND_OUT, S[S_MODE], S[S_MODE], 0.0)
    return n


@njit(_I(_V, _V, _M, _I), **INNER)
def _judge_update(S, P, ev, n):
    n = _judge_set(S, P, ev, n, in_band(S, P))
    return _judge_check(S, P, ev, n)


# ----------------------------------------------------------------------------------
# Instantaneous transitions (docs/MODEL.md section 5)
# ----------------------------------------------------------------------------------
@njit(_F(_V, _V, _I, _F), **INNER)
def _consistent_slide_direction(S, P, k, T):
    """A slide direction sigma of corner k, at rest horizontally, that is consistent:
    compressive normal force and the point accelerating along sigma (0 if none)."""
    m = P[P_M]
    ftol = F_TOL * m * P[P_G]
    w = S[S_W]
    for sigma in (1.0, -1.0):
        thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, S[S_TH], w)
        apx = fx / m + thdd * dy - w * w * dx
        if fy >= -ftol and sigma * apx > 0.0:
            return sigma
    return 0.0


@njit(_I(_V, _V, _M, _I), **JIT)
def settle(S, P, ev, n):
    """Resolve every transition due at the current instant, in a bounded loop.

    Each pass checks the current state's consistency conditions (contact forces
    compressive, friction inside its cone, a slide that is really sliding, a resting
    corner in flight not pressed down) and switches state when one fails. Signs within
    the tolerances are decided by the dynamics (the next derivative), never by
    round-off. Returns the updated log count.
    """
    m = P[P_M]
    g = P[P_G]
    ftol = F_TOL * m * g
    T = S[S_TORQUE]
    for _ in range(12):
        mode = int(S[S_MODE])
        t = S[S_T]
        if mode == MODE_F or mode == MODE_G:
            sigma = S[S_SIGMA] if mode == MODE_G else 0.0
            _, fay, _, fby = double_contact_forces(P, sigma, T)
            if fby < -ftol or fay < -ftol:
                # One corner lifts: the rover tips about the other (B/D pivot when at
                # rest, C/E slide when already sliding).
                k = 0 if fby < -ftol else 1
                if mode == MODE_F:
                    new = MODE_B if k == 0 else MODE_D
                    S[S_SIGMA] = 0.0
                else:
                    new = MODE_C if k == 0 else MODE_E
                S[S_MODE] = new
                n = _log(S, ev, n, t, EV_TIP, mode, new, 0.0)
                continue
            return n
        if mode == MODE_B or mode == MODE_D:
            k = contact_corner(mode)
            _, fx, fy, _, _ = pivot_dynamics(P, k, T, S[S_TH], S[S_W])
            if fy < -ftol:
                # Sticking would need a pull. If the free corner would rise, it lifts
                # off; if the flight dynamics still press it down (the pivot's
                # friction couples into the vertical through the rotation), neither
                # stick nor separation is consistent and the corner slides.
                sigma = 0.0
                if _resting_corner_driven_down(S, P, k):
                    sigma = _consistent_slide_direction(S, P, k, T)
                if sigma == 0.0:
                    S[S_MODE] = MODE_A
                    S[S_SIGMA] = 0.0
                    n = _log(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0)
                else:
                    new = MODE_C if k == 0 else MODE_E
                    S[S_MODE] = new
                    S[S_SIGMA] = sigma
                    n = _log(S, ev, n, t, EV_SLIP, mode, new, 0.0)
                continue
            if abs(fx) > P[P_MUS] * fy + ftol:
                new = MODE_C if k == 0 else MODE_E
                S[S_MODE] = new
                S[S_SIGMA] = -1.0 if fx > 0.0 else 1.0
                n = _log(S, ev, n, t, EV_SLIP, mode, new, 0.0)
                continue
            return n
        if mode == MODE_C or mode == MODE_E:
            k = contact_corner(mode)
            sigma = S[S_SIGMA]
            thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, S[S_TH], S[S_W])
            if fy < -ftol:
                S[S_MODE] = MODE_A
                S[S_SIGMA] = 0.0
                n = _log(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0)
                continue
            w = S[S_W]
            vpx = S[S_VX] + w * dy
            if abs(vpx) > V_TOL:
                if vpx * sigma < 0.0:       # cannot happen after an event; keep sigma honest
                    S[S_SIGMA] = 1.0 if vpx > 0.0 else -1.0
                    continue
                return n
            # The contact point is (momentarily) at rest: does it keep sliding?
            apx = fx / m + thdd * dy - w * w * dx
            if sigma * apx > A_TOL:
                return n                    # it accelerates in sigma: the slide goes on
            _, fxp, fyp, _, _ = pivot_dynamics(P, k, T, S[S_TH], w)
            if abs(fxp) <= P[P_MUS] * fyp + ftol and fyp >= -ftol:
                new = MODE_B if k == 0 else MODE_D
                _pin_corner(S, P, k)
                S[S_MODE] = new
                S[S_SIGMA] = 0.0
                n = _log(S, ev, n, t, EV_STICK, mode, new, 0.0)
                continue
            new_sigma = -1.0 if fxp > 0.0 else 1.0
            if new_sigma != sigma:
                S[S_SIGMA] = new_sigma
                n = _log(S, ev, n, t, EV_REVERSE, mode, mode, 0.0)
                continue
            return n
        # Flight: a bottom corner lying on the ground at rest vertically that the flight
        # dynamics would drive down resumes contact, without an impact.
        down0 = False
        down1 = False
        c = math.cos(S[S_TH])
        sn = math.sin(S[S_TH])
        for k in range(2):
            dx, dy = corner_offset_cs(P, k, c, sn)
            if abs(S[S_Y] + dy) <= H_TOL and abs(S[S_VY] - S[S_W] * dx) <= V_TOL:
                if _resting_corner_driven_down(S, P, k):
                    if k == 0:
                        down0 = True
                    else:
                        down1 = True
        if down0 and down1:
            S[S_TH] = wrap_angle(S[S_TH])
            _set_double_contact(S, P)
            n = _log(S, ev, n, t, EV_RESUME, MODE_A, S[S_MODE], 0.0)
            continue
        if down0 or down1:
            k = 0 if down0 else 1
            S[S_TH] = wrap_angle(S[S_TH])
            _set_single_contact(S, P, k)
            dx, dy = corner_offset(P, k, S[S_TH])
            vpx = S[S_VX] + S[S_W] * dy
            if abs(vpx) <= V_TOL:
                _pin_corner(S, P, k)
                new = MODE_B if k == 0 else MODE_D
                S[S_SIGMA] = 0.0
            else:
                new = MODE_C if k == 0 else MODE_E
                S[S_SIGMA] = 1.0 if vpx > 0.0 else -1.0
            S[S_MODE] = new
            n = _log(S, ev, n, t, EV_RESUME, MODE_A, new, 0.0)
            continue
        return n
    return n


# ----------------------------------------------------------------------------------
# Impacts (docs/MODEL.md section 6)
# ----------------------------------------------------------------------------------
@njit(**INNER)
def _solve_sym3(a00, a01, a02, a11, a12, a22, b0, b1, b2):
    """Solve a symmetric 3x3 system by Cramer's rule (well conditioned here)."""
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    return ((c00 * b0 + c01 * b1 + c02 * b2) / det,
            (c01 * b0 + c11 * b1 + c12 * b2) / det,
            (c02 * b0 + c12 * b1 + c22 * b2) / det)


@njit(**JIT)
def contest_impulses(P, dxs, dys, part, dv, lx, ly):
    """The contest law's impulses: K Lambda = dv over the taking-part corners.

    One corner: the 2x2 system with K = I2/m + u u^T / I, u = (dy, -dx).
    Two corners: K = J W J^T is 4x4 of rank 3 (the body has 3 degrees of freedom);
    the minimum-norm least-squares impulse is K^+ dv = J G W^-1 G J^T dv with
    G = (J^T J)^-1, J the 4x3 contact Jacobian (rows (1, 0, dy_k), (0, 1, -dx_k)) and
    W = diag(1/m, 1/m, 1/I). `dv[2k], dv[2k+1]` are the wanted changes of corner k's
    (vx, vy).
    """
    m = P[P_M]
    inertia = P[P_I]
    lx[0] = 0.0
    lx[1] = 0.0
    ly[0] = 0.0
    ly[1] = 0.0
    if part[0] != 0.0 and part[1] != 0.0:
        dxa, dya, dxb, dyb = dxs[0], dys[0], dxs[1], dys[1]
        # J^T J
        a02 = dya + dyb
        a12 = -dxa - dxb
        a22 = dxa * dxa + dya * dya + dxb * dxb + dyb * dyb
        # J^T dv
        b0 = dv[0] + dv[2]
        b1 = dv[1] + dv[3]
        b2 = dya * dv[0] - dxa * dv[1] + dyb * dv[2] - dxb * dv[3]
        z0, z1, z2 = _solve_sym3(2.0, 0.0, a02, 2.0, a12, a22, b0, b1, b2)
        y0, y1, y2 = _solve_sym3(2.0, 0.0, a02, 2.0, a12, a22, m * z0, m * z1, inertia * z2)
        lx[0] = y0 + dya * y2
        ly[0] = y1 - dxa * y2
        lx[1] = y0 + dyb * y2
        ly[1] = y1 - dxb * y2
        return
    for k in range(2):
        if part[k] != 0.0:
            dx = dxs[k]
            dy = dys[k]
            k11 = 1.0 / m + dy * dy / inertia
            k12 = -dy * dx / inertia
            k22 = 1.0 / m + dx * dx / inertia
            det = k11 * k22 - k12 * k12
            lx[k] = (dv[2 * k] * k22 - dv[2 * k + 1] * k12) / det
            ly[k] = (dv[2 * k + 1] * k11 - dv[2 * k] * k12) / det


@njit(**INNER)
def frictionless_impulses(P, dxs, on, vpy, target, ly):
    """Vertical impulses only, as a complementarity problem over the grounded corners.

    Each corner either takes a compressive impulse and ends with exactly its target
    vertical speed, or takes none and ends at or above it. With two corners: both
    active, then each alone (the 2x2 Delassus matrix is positive definite, so exactly
    one of the cases is consistent).
    """
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    ly[0] = 0.0
    ly[1] = 0.0
    # Delassus matrix of the vertical directions: 1/m + dx_j dx_k / I
    kaa = 1.0 / m + dxs[0] * dxs[0] * inv_i
    kbb = 1.0 / m + dxs[1] * dxs[1] * inv_i
    kab = 1.0 / m + dxs[0] * dxs[1] * inv_i
    ra = target[0] - vpy[0]
    rb = target[1] - vpy[1]
    tol = 1e-14 * (abs(ra) + abs(rb) + 1e-300)
    if on[0] != 0.0 and on[1] != 0.0:
        det = kaa * kbb - kab * kab
        la = (ra * kbb - rb * kab) / det
        lb = (rb * kaa - ra * kab) / det
        if la >= 0.0 and lb >= 0.0:
            ly[0] = la
            ly[1] = lb
            return
        la = ra / kaa
        if la >= 0.0 and vpy[1] + kab * la >= target[1] - tol:
            ly[0] = la
            return
        lb = rb / kbb
        if lb >= 0.0 and vpy[0] + kab * lb >= target[0] - tol:
            ly[1] = lb
            return
        return
    for k in range(2):
        if on[k] != 0.0:
            kk = kaa if k == 0 else kbb
            ly[k] = max(0.0, (target[k] - vpy[k]) / kk)


@njit(**INNER)
def _apply_impulses(S, P, dxs, dys, lx, ly):
    m = P[P_M]
    inv_i = 1.0 / P[P_I]
    S[S_VX] += (lx[0] + lx[1]) / m
    S[S_VY] += (ly[0] + ly[1]) / m
    S[S_W] += (dys[0] * lx[0] - dxs[0] * ly[0] + dys[1] * lx[1] - dxs[1] * ly[1]) * inv_i


@njit(**JIT)
def resolve_impact(S, P, law, W):
    """Apply the impact law at the current configuration and set the new contact state.

    Returns the kinetic energy ratio (after / before) of the impact, after the
    post-impact classification. See docs/MODEL.md section 6 and docs/PHYSICS.md.
    """
    S[S_TH] = wrap_angle(S[S_TH])
    th = S[S_TH]
    o = W_IMP
    dxs = W[o:o + 2]
    dys = W[o + 2:o + 4]
    vpx = W[o + 4:o + 6]
    vpy = W[o + 6:o + 8]
    on = W[o + 8:o + 10]          # 1.0 / 0.0 flags
    part = W[o + 10:o + 12]
    dv = W[o + 12:o + 16]
    tgt_y = W[o + 16:o + 18]
    lx = W[o + 18:o + 20]
    ly = W[o + 20:o + 22]
    for j in range(22):
        W[o + j] = 0.0
    for k in range(2):
        dx, dy = corner_offset(P, k, th)
        dxs[k] = dx
        dys[k] = dy
        on[k] = 1.0 if S[S_Y] + dy <= H_IMPACT else 0.0
        vpx[k] = S[S_VX] + S[S_W] * dy
        vpy[k] = S[S_VY] - S[S_W] * dx
        part[k] = 1.0 if (on[k] != 0.0 and vpy[k] <= V_TOL) else 0.0
        if part[k] != 0.0:
            tx = P[P_EX] * vpx[k]
            if abs(tx) < P[P_VXMIN]:
                tx = 0.0
            ty = -P[P_EY] * vpy[k] if vpy[k] < 0.0 else 0.0
            if abs(ty) < P[P_VYMIN]:
                ty = 0.0
            dv[2 * k] = tx - vpx[k]
            dv[2 * k + 1] = ty - vpy[k]
            tgt_y[k] = ty
    ke0 = kinetic_energy(S, P)
    if part[0] != 0.0 or part[1] != 0.0:
        v0x = S[S_VX]
        v0y = S[S_VY]
        w0 = S[S_W]
        contest_impulses(P, dxs, dys, part, dv, lx, ly)
        _apply_impulses(S, P, dxs, dys, lx, ly)
        lam_scale = abs(lx[0]) + abs(lx[1]) + abs(ly[0]) + abs(ly[1])
        ok = True
        for k in range(2):
            if part[k] != 0.0 and ly[k] < -1e-12 * lam_scale:
                ok = False               # the exact law would pull on the ground
            if on[k] != 0.0 and S[S_VY] - S[S_W] * dxs[k] < -V_TOL:
                ok = False               # a grounded corner would end moving down
            if law == LAW_DISSIPATIVE and part[k] != 0.0 and \
                    abs(lx[k]) > P[P_MUS] * ly[k] + 1e-12 * lam_scale:
                ok = False               # outside the friction cone
        if ok and law == LAW_DISSIPATIVE and kinetic_energy(S, P) > ke0:
            ok = False
        if not ok:
            S[S_VX] = v0x
            S[S_VY] = v0y
            S[S_W] = w0
            frictionless_impulses(P, dxs, on, vpy, tgt_y, ly)
            lx[0] = 0.0
            lx[1] = 0.0
            _apply_impulses(S, P, dxs, dys, lx, ly)
            if law == LAW_DISSIPATIVE and kinetic_energy(S, P) > ke0:
                # Multi-contact restitution can add energy; the perfectly inelastic
                # frictionless impact (an M-orthogonal projection) never does.
                S[S_VX] = v0x
                S[S_VY] = v0y
                S[S_W] = w0
                tgt_y[0] = 0.0
                tgt_y[1] = 0.0
                frictionless_impulses(P, dxs, on, vpy, tgt_y, ly)
                _apply_impulses(S, P, dxs, dys, lx, ly)
    # Post-impact classification: a grounded corner slower than v_ymin is in contact.
    c0 = on[0] != 0.0 and abs(S[S_VY] - S[S_W] * dxs[0]) < P[P_VYMIN]
    c1 = on[1] != 0.0 and abs(S[S_VY] - S[S_W] * dxs[1]) < P[P_VYMIN]
    if c0 and c1:
        _set_double_contact(S, P)
    elif c0 or c1:
        k = 0 if c0 else 1
        _set_single_contact(S, P, k)
        # the other corner, if it was within H_IMPACT, may now be a hair under the ground
        _, dyo = corner_offset(P, 1 - k, S[S_TH])
        if S[S_Y] + dyo < 0.0:
            _turn_flat_about(S, P, k)
        _, dyk = corner_offset(P, k, S[S_TH])
        vpk = S[S_VX] + S[S_W] * dyk
        if abs(vpk) < P[P_VXMIN]:
            _pin_corner(S, P, k)
            S[S_MODE] = MODE_B if k == 0 else MODE_D
            S[S_SIGMA] = 0.0
        else:
            S[S_MODE] = MODE_C if k == 0 else MODE_E
            S[S_SIGMA] = 1.0 if vpk > 0.0 else -1.0
    else:
        S[S_MODE] = MODE_A
        S[S_SIGMA] = 0.0
        # never leave a corner under the ground (a round-off-sized lift)
        low = min(S[S_Y] + dys[0], S[S_Y] + dys[1])
        if low < 0.0:
            S[S_Y] -= low
    ke1 = kinetic_energy(S, P)
    ratio = ke1 / ke0 if ke0 > 0.0 else 1.0
    S[S_NIMPACT] += 1.0
    if ratio > 1.0 + 1e-12:
        S[S_NGAIN] += 1.0
        if ratio - 1.0 > S[S_MAXGAIN]:
            S[S_MAXGAIN] = ratio - 1.0
    return ratio


@njit(_I(_V, _V, _V, _M, _I, _V), **INNER)
def _impact_event(S, P, O, ev, n, W):
    # a touchdown is only ever reported with a bottom corner on the ground
    if min(corner_offset(P, 0, S[S_TH])[1], corner_offset(P, 1, S[S_TH])[1]) \
            + S[S_Y] > H_IMPACT:
        return n
    before = S[S_MODE]
    ratio = resolve_impact(S, P, int(O[O_LAW]), W)
    return _log(S, ev, n, S[S_T], EV_IMPACT, before, S[S_MODE], ratio)


# ----------------------------------------------------------------------------------
# Event integrator: flight by conservative advancement on closed forms
# ----------------------------------------------------------------------------------
PH_NONE, PH_LIFTOFF, PH_SLIP, PH_STICK, PH_TOUCH, PH_BROKEN, PH_BAND, PH_STOP = range(8)


@njit(**INNER)
def _commit_flight(S, P, tau):
    x, y, th, vx, vy, w = flight_at(S, P, tau)
    S[S_X] = x
    S[S_Y] = y
    S[S_TH] = th
    S[S_VX] = vx
    S[S_VY] = vy
    S[S_W] = w
    S[S_T] += tau


@njit(_F(_V, _V, _I, _F, _F, _F, _F, _F, _F), **INNER)
def _polish_touchdown(S, P, k, tau, tau_end, level, armed, f, v):
    """Place a detected touchdown of corner k (at tau, height f above its trigger level,
    descending at v) on the closed form's root, safeguarded against small v."""
    c0 = math.cos(S[S_TH])
    s0 = math.sin(S[S_TH])
    h0 = S[S_Y] + corner_offset_cs(P, k, c0, s0)[1]
    if armed == 0.0:
        # back down before it ever rose above H_TOL (it triggered H_TOL under the
        # ground): the touchdown is where it returns to the level it left from
        target = level + H_TOL
        if h0 >= target:
            return _bisect_touchdown(S, P, k, 0.0, tau, target - h0)
        return tau
    if f <= 0.0 or v >= 0.0:
        return tau
    # CA_TOL is a height: at the 1e-9 m/s of a slow return it is still 1e-6 s from the
    # root, and one Newton step (f / v) can land anywhere. Bracket the root (from the
    # Newton step, doubled while the corner is still above ground) and bisect it.
    dt = f / (-v)
    for _ in range(64):
        hi = min(tau + dt, tau_end)
        if flight_rise(S, P, k, hi) + h0 < 0.0:
            return _bisect_touchdown(S, P, k, tau, hi, -h0)
        if hi >= tau_end:
            break
        dt *= 2.0
    return tau      # it curves away within CA_TOL of the ground: touching at tau


@njit(**INNER)
def flight_phase(S, P, t_stop, W):
    """Advance a flight under constant torque to t_stop or the first touchdown.

    Each corner height h_k(t) = y(t) + dy_k(theta(t)) is known in closed form, with
    |h_k''| <= K = g + l (|T|/I + w_max^2) over a window. Stepping by the smallest
    positive root of h + h' s - K s^2 / 2 = 0 (and no further than the window) can
    never pass a root (conservative advancement), converges quadratically at a
    transversal touchdown, and finishes a high flight in a few steps. The window is
    local, not the whole interval: under a torque held for minutes the spin rate at
    the end of the interval can be 100x the current one, and a bound built on it
    shrank steps to 1e-7 s right after a lift-off until the iteration budget ran out
    mid-air. The window grows 4x per step, so w_max follows the spin as it builds.
    A corner that starts on the ground (just lifted off or bounced) is only armed once
    it has risen above H_TOL; until then it triggers if it comes back below -H_TOL.
    Returns (kind, corner); (PH_NONE, -1) with t < t_stop when the iteration budget
    runs out away from the ground (the caller calls again).
    """
    tau_end = t_stop - S[S_T]
    if tau_end <= 0.0:
        return PH_NONE, -1
    g = P[P_G]
    beta = S[S_TORQUE] / P[P_I]
    ell = math.hypot(P[P_R], P[P_H])
    w0 = S[S_W]
    level = W[W_FLT:W_FLT + 4]
    armed = W[W_FLT + 4:W_FLT + 8]        # 1.0 / 0.0 flags
    for k in range(4):
        level[k] = 0.0
        armed[k] = 1.0
    c0 = math.cos(S[S_TH])
    s0 = math.sin(S[S_TH])
    for k in range(4):
        dx, dy = corner_offset_cs(P, k, c0, s0)
        hk = S[S_Y] + dy
        vk = S[S_VY] - S[S_W] * dx
        if k >= 2:
            if hk <= 0.0:
                return PH_BROKEN, k
        elif hk <= H_TOL:
            if vk < -V_TOL:
                return PH_TOUCH, k
            if vk <= V_TOL:
                # at rest vertically (a lift-off): it separates at third order, so its
                # height is round-off for a while; armed once clear of H_TOL
                armed[k] = 0.0
                level[k] = min(hk, 0.0) - H_TOL
            # else it leaves at first order (a bounce): armed at once. The conservative
            # step 2 v / K lands exactly on the earliest possible return; arming only
            # above H_TOL let a pressed corner touch down H_TOL low and gain energy.
    tau = 0.0
    # capped so that w_max^2 stays finite for a t_stop of 1e300 (an infinite K made
    # every step NaN, and the flight jumped to t_stop through the ground)
    window = min(tau_end, FLIGHT_WINDOW_MAX)
    for _ in range(MAX_CA_ITER):
        x, y, th, vx, vy, w = flight_at(S, P, tau)
        # |omega| is linear in time, so its bound over [tau, tau + window] is at an end
        window = min(window, tau_end - tau)
        W[W_WORK] += 1.0
        if W[W_WORK] > MAX_WORK:
            S[S_ERROR] = ERR_WORK
            _commit_flight(S, P, tau)
            return PH_NONE, -1
        wmax = max(abs(w), abs(w0 + beta * (tau + window)))
        kbound = g + ell * (abs(beta) + wmax * wmax)
        if not kbound < math.inf:
            S[S_ERROR] = ERR_STEP
            _commit_flight(S, P, tau)
            return PH_NONE, -1
        c = math.cos(th)
        s = math.sin(th)
        step = np.inf
        hit = -1
        hit_f = np.inf
        hit_v = 0.0
        for k in range(4):
            bx, by = corner_body(P, k)
            dx = bx * c + by * s
            hk = y - bx * s + by * c
            vk = vy - w * dx
            if armed[k] == 0.0 and hk > H_TOL:
                armed[k] = 1.0
                level[k] = 0.0
            fk = hk - level[k]
            if fk <= CA_TOL and vk <= V_TOL:
                if fk < hit_f:
                    hit = k
                    hit_f = fk
                    hit_v = vk
            else:
                fpos = max(fk, 0.0)
                sk = (vk + math.sqrt(vk * vk + 2.0 * kbound * fpos)) / kbound
                if sk < step:
                    step = sk
        if hit >= 0:
            tau = _polish_touchdown(S, P, hit, tau, tau_end, level[hit], armed[hit],
                                    hit_f, hit_v)
            _commit_flight(S, P, tau)
            return (PH_BROKEN if hit >= 2 else PH_TOUCH), hit
        step = min(step, window)
        if tau + step >= tau_end:
            _commit_flight(S, P, tau_end)
            S[S_T] = t_stop
            return PH_NONE, -1
        tau += step
        window = min(4.0 * step, FLIGHT_WINDOW_MAX)
    # Iteration budget spent. Creeping along a grazing approach, the lowest bottom
    # corner is within a round-off distance of the ground: it touches. Anywhere else
    # nothing happened: hand back the time reached (never report a touchdown that did
    # not happen; the caller's phase bound keeps this finite).
    _commit_flight(S, P, tau)
    h0 = S[S_Y] + corner_offset(P, 0, S[S_TH])[1]
    h1 = S[S_Y] + corner_offset(P, 1, S[S_TH])[1]
    if min(h0, h1) > H_IMPACT:
        return PH_NONE, -1
    return PH_TOUCH, 0 if h0 <= h1 else 1


# ----------------------------------------------------------------------------------
# Event integrator: state G in closed form
# ----------------------------------------------------------------------------------
@njit(**INNER)
def _next_band_boundary(xp, sigma, xt, w, offset):
    """Nearest boundary of the band (for a point at c.m. offset `offset`) strictly ahead
    of xp in direction sigma, as a c.m. position; NaN when none is ahead."""
    best = np.nan
    for b in (xt - w - offset, xt + w - offset):
        if sigma * (b - xp) > 1e-15 * (1.0 + abs(xp)):
            if math.isnan(best) or sigma * (b - best) < 0.0:
                best = b
    return best


@njit(**INNER)
def g_phase(S, P, t_stop):
    """Slide on both corners: x(t) quadratic, decelerating at mu_d g to a stop.

    Events: the stop (G -> F) and the next band boundary of either corner.
    """
    sigma = S[S_SIGMA]
    a = P[P_MUD] * P[P_G]
    u = sigma * S[S_VX]                    # speed, > 0
    tau_end = t_stop - S[S_T]
    tau_stop = u / a if a > 0.0 else np.inf
    kind = PH_NONE
    tau = tau_end
    if tau_stop <= tau_end:
        kind = PH_STOP
        tau = tau_stop
    # band boundaries for either corner (offsets +r for A, -r for B)
    x0 = S[S_X]
    for off in (P[P_R], -P[P_R]):
        b = _next_band_boundary(x0, sigma, S[S_XT], P[P_BAND], off)
        if not math.isnan(b):
            d = sigma * (b - x0)
            disc = u * u - 2.0 * a * d
            if disc >= 0.0:
                tb = 2.0 * d / (u + math.sqrt(disc))
                if tb < tau:
                    tau = tb
                    kind = PH_BAND
    S[S_X] = x0 + sigma * (u * tau - 0.5 * a * tau * tau)
    S[S_VX] = sigma * (u - a * tau)
    S[S_T] = t_stop if kind == PH_NONE else S[S_T] + tau
    if kind == PH_STOP:
        S[S_VX] = 0.0
    return kind


# ----------------------------------------------------------------------------------
# Event integrator: single-contact phases (B-E) by DOP853 with event location
# ----------------------------------------------------------------------------------
# Reduced state u = (theta, omega, x, vx); y and vy follow from the contact constraint.
N_GUARDS = 6


@njit(**INNER)
def _rhs(P, k, sliding, sigma, T, u, out):
    if sliding:
        thdd, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, u[0], u[1])
    else:
        thdd, fx, fy, dx, dy = pivot_dynamics(P, k, T, u[0], u[1])
    out[0] = u[1]
    out[1] = thdd
    out[2] = u[3]
    out[3] = fx / P[P_M]


@njit(**INNER)
def _finite4(u):
    return (math.isfinite(u[0]) and math.isfinite(u[1]) and math.isfinite(u[2])
            and math.isfinite(u[3]))


@njit(**INNER)
def _dop853_step(P, k, sliding, sigma, T, u, h, f0, kst, ytmp, unew, rtol, atol):
    """One DOP853 step of length h from u (f0 = f(u)); returns the scaled error norm."""
    for j in range(4):
        kst[0, j] = f0[j]
    for s in range(1, 12):
        for j in range(4):
            acc = 0.0
            for q in range(s):
                acc += _RK_A[s, q] * kst[q, j]
            ytmp[j] = u[j] + h * acc
        _rhs(P, k, sliding, sigma, T, ytmp, kst[s])
    for j in range(4):
        acc = 0.0
        for q in range(12):
            acc += _RK_B[q] * kst[q, j]
        unew[j] = u[j] + h * acc
    _rhs(P, k, sliding, sigma, T, unew, kst[12])
    e5 = 0.0
    e3 = 0.0
    for j in range(4):
        a5 = 0.0
        a3 = 0.0
        for q in range(13):
            a5 += _RK_E5[q] * kst[q, j]
            a3 += _RK_E3[q] * kst[q, j]
        sc = atol[j] + rtol * max(abs(u[j]), abs(unew[j]))
        e5 += (a5 / sc) ** 2
        e3 += (a3 / sc) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 4.0)


@njit(**INNER)
def _guards(P, k, sliding, sigma, T, xpiv, xt, u, gv):
    """Guard functions of a single-contact phase (positive = no event yet).

    0 lift-off: f_y / (m g)
    1 pivot: (mu_s f_y - |f_x|) / (m g) (slip); slide: sigma * v_Px (stick)
    2 the other bottom corner's height (it closes onto both corners: impact)
    3, 4 the top corners' heights (broken)
    5 slide only: distance to the next band boundary ahead (band crossing)
    """
    m = P[P_M]
    mg = m * P[P_G]
    th = u[0]
    w = u[1]
    if sliding:
        _, fx, fy, dx, dy = slide_dynamics(P, k, sigma, T, th, w)
    else:
        _, fx, fy, dx, dy = pivot_dynamics(P, k, T, th, w)
    gv[0] = fy / mg
    y = -dy
    if sliding:
        gv[1] = sigma * (u[3] + w * dy)
        xp = u[2] + dx
        b = _next_band_boundary(xpiv, sigma, xt, P[P_BAND], 0.0)
        gv[5] = np.inf if math.isnan(b) else sigma * (b - xp)
    else:
        gv[1] = (P[P_MUS] * fy - abs(fx)) / mg
        gv[5] = np.inf
    _, dyo = corner_offset(P, 1 - k, th)
    gv[2] = y + dyo
    _, dy2 = corner_offset(P, 2, th)
    _, dy3 = corner_offset(P, 3, th)
    gv[3] = y + dy2
    gv[4] = y + dy3


@njit(**INNER)
def _force_guards(P, k, sliding, sigma, T, th, w):
    """The two force guards (lift-off, slip) as functions of (theta, omega)."""
    mg = P[P_M] * P[P_G]
    if sliding:
        _, fx, fy, _, _ = slide_dynamics(P, k, sigma, T, th, w)
        return fy / mg, 0.0
    _, fx, fy, _, _ = pivot_dynamics(P, k, T, th, w)
    return fy / mg, (P[P_MUS] * fy - abs(fx)) / mg


@njit(**INNER)
def _guard_rates(P, k, sliding, sigma, T, u, du, gr):
    """Time derivatives of the guards at u (du = f(u)): analytic for the heights, the
    stick and the band guards, central differences in (theta, omega) for the forces."""
    th = u[0]
    w = u[1]
    eps_t = 1e-6
    eps_w = 1e-6 * (abs(w) + 1e-3)
    a_tp, b_tp = _force_guards(P, k, sliding, sigma, T, th + eps_t, w)
    a_tm, b_tm = _force_guards(P, k, sliding, sigma, T, th - eps_t, w)
    a_wp, b_wp = _force_guards(P, k, sliding, sigma, T, th, w + eps_w)
    a_wm, b_wm = _force_guards(P, k, sliding, sigma, T, th, w - eps_w)
    gr[0] = (a_tp - a_tm) / (2 * eps_t) * du[0] + (a_wp - a_wm) / (2 * eps_w) * du[1]
    dxk, dyk = corner_offset(P, k, th)
    if sliding:
        # sigma * d/dt v_Px = sigma * (ax + thdd dy - w^2 dx)
        gr[1] = sigma * (du[3] + du[1] * dyk - w * w * dxk)
        gr[5] = -sigma * (u[3] + w * dyk)
    else:
        gr[1] = (b_tp - b_tm) / (2 * eps_t) * du[0] + (b_wp - b_wm) / (2 * eps_w) * du[1]
        gr[5] = 0.0
    for c in range(3):
        dxc, _ = corner_offset(P, (1 - k) if c == 0 else c + 1, th)
        gr[2 + c] = w * (dxk - dxc)       # vertical speed of that corner (vy = w dx_k)


@njit(**INNER)
def _hermite_dip(g0, g1, d0, d1):
    """Where the cubic Hermite interpolant of a guard over a step (values g0, g1 and
    slopes d0, d1 per unit step) is lowest inside (0, 1): returns (tau, value)."""
    # p(t) = g0 h00 + d0 h10 + g1 h01 + d1 h11 ; p'(t) = a t^2 + b t + c
    a = 6.0 * g0 + 3.0 * d0 - 6.0 * g1 + 3.0 * d1
    b = -6.0 * g0 - 4.0 * d0 + 6.0 * g1 - 2.0 * d1
    c = d0
    best_t = 0.5
    best_v = np.inf
    if abs(a) > 1e-300:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            for r in ((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)):
                if 0.0 < r < 1.0:
                    t2 = r * r
                    t3 = t2 * r
                    v = (g0 * (2 * t3 - 3 * t2 + 1) + d0 * (t3 - 2 * t2 + r)
                         + g1 * (-2 * t3 + 3 * t2) + d1 * (t3 - t2))
                    if v < best_v:
                        best_v = v
                        best_t = r
    elif abs(b) > 1e-300:
        r = -c / b
        if 0.0 < r < 1.0:
            t2 = r * r
            t3 = t2 * r
            best_v = (g0 * (2 * t3 - 3 * t2 + 1) + d0 * (t3 - 2 * t2 + r)
                      + g1 * (-2 * t3 + 3 * t2) + d1 * (t3 - t2))
            best_t = r
    return best_t, best_v


@njit(**INNER)
def contact_phase(S, P, O, t_stop, W):
    """Advance a single-contact phase (B, C, D, E) to t_stop or its first event.

    Adaptive DOP853 on u = (theta, omega, x, vx). After each accepted step the guards
    are evaluated; a guard that crossed its level is located by root finding
    (Illinois) on the step length s, re-taking the step from its start with length s,
    so the event is as accurate as the step itself. A guard that starts on its
    switching surface (a slide starting from rest, a corner just lifted) is armed only
    after it has moved clear of it, so the search finds the *next* crossing.
    """
    mode = int(S[S_MODE])
    k = contact_corner(mode)
    sliding = mode == MODE_C or mode == MODE_E
    sigma = S[S_SIGMA]
    T = S[S_TORQUE]
    rtol = O[O_RTOL]
    xt = S[S_XT]
    dx0, dy0 = corner_offset(P, k, S[S_TH])
    xpiv = S[S_X] + dx0          # pivot point (fixed when pivoting)
    o = W_RK
    u = W[o:o + 4]
    atol = W[o + 4:o + 8]
    gv = W[o + 8:o + 14]
    gnew = W[o + 14:o + 20]
    level = W[o + 20:o + 26]
    tol = W[o + 26:o + 32]
    armed = W[o + 32:o + 38]               # 1.0 / 0.0 flags
    f0 = W[o + 38:o + 42]
    kst = W[o + 42:o + 94].reshape((13, 4))
    ytmp = W[o + 94:o + 98]
    unew = W[o + 98:o + 102]
    utry = W[o + 102:o + 106]
    f1 = W[o + 106:o + 110]
    rate0 = W[o + 110:o + 116]
    rate1 = W[o + 116:o + 122]
    gtry = W[o + 122:o + 128]
    gtmp = W[o + 128:o + 134]
    u[0] = S[S_TH]
    u[1] = S[S_W]
    u[2] = S[S_X]
    u[3] = S[S_VX]
    # absolute tolerances from the problem's natural scales
    atol[0] = rtol * 1.0
    atol[1] = rtol * 0.1
    atol[2] = rtol * 1.0
    atol[3] = rtol * 0.01
    tol[0] = F_TOL
    tol[1] = V_TOL if sliding else F_TOL
    tol[2] = H_TOL
    tol[3] = H_TOL
    tol[4] = H_TOL
    tol[5] = 0.0
    _guards(P, k, sliding, sigma, T, xpiv, xt, u, gv)
    # the other bottom corner already down and moving down: impact now
    dxo, dyo = corner_offset(P, 1 - k, u[0])
    vyo = S[S_W] * dx0 - S[S_W] * dxo      # vy = w dx_k, minus w dx_other
    if gv[2] <= H_TOL and vyo < -V_TOL:
        return PH_TOUCH
    if gv[3] <= 0.0 or gv[4] <= 0.0:
        return PH_BROKEN
    _rhs(P, k, sliding, sigma, T, u, f0)
    _guard_rates(P, k, sliding, sigma, T, u, f0, rate0)
    for i in range(N_GUARDS):
        armed[i] = 1.0 if gv[i] > tol[i] else 0.0
        level[i] = 0.0 if armed[i] != 0.0 else min(gv[i], 0.0) - tol[i]
    if armed[2] == 0.0 and rate0[2] > V_TOL:
        # the other corner leaves the ground at first order (it bounced): its next
        # touchdown is at the height it starts from, not H_TOL lower (see flight_phase)
        armed[2] = 1.0
        level[2] = min(gv[2], 0.0)
    h_prop = S[S_HSTEP]             # proposed step, remembered across phases
    if not (h_prop > 0.0 and h_prop < math.inf):
        h_prop = 1e-3
    t = S[S_T]
    kind = PH_NONE
    n_steps = 0
    while t < t_stop:
        h = h_prop
        last = False
        if h >= t_stop - t:
            h = t_stop - t
            last = True
        err = _dop853_step(P, k, sliding, sigma, T, u, h, f0, kst, ytmp, unew, rtol, atol)
        n_steps += 1
        if n_steps > MAX_RK_STEPS:
            S[S_ERROR] = ERR_STEP           # a bound on every loop: never a hang
            break
        W[W_WORK] += 1.0
        if W[W_WORK] > MAX_WORK:
            S[S_ERROR] = ERR_WORK
            break
        # written so that a NaN error (an overflowing trial step) is a rejection: with
        # `err > 1.0` it was accepted, and time crept towards a limit short of t_stop
        if not (err <= 1.0) or not _finite4(unew):
            if err > 1.0 and err < math.inf:
                h_prop = h * max(RK_MIN_FACTOR, RK_SAFETY * err ** (-1.0 / 8.0))
            else:
                h_prop = h * RK_MIN_FACTOR
            if h_prop < 1e-14 * (1.0 + abs(t)):
                S[S_ERROR] = ERR_STEP       # step-size underflow: the field is too stiff
                break
            continue
        for j in range(4):
            f1[j] = kst[12, j]          # kst is scratch for the searches below
        _guards(P, k, sliding, sigma, T, xpiv, xt, unew, gnew)
        _guard_rates(P, k, sliding, sigma, T, unew, f1, rate1)
        first = -1
        s_first = h
        for i in range(N_GUARDS):
            if gnew[i] - level[i] <= 0.0:
                s_i = _locate(P, k, sliding, sigma, T, xpiv, xt, u, h, f0, kst, ytmp,
                              utry, gtmp, rtol, atol, i, level[i], gv[i] - level[i],
                              gnew[i] - level[i])
                if first < 0 or s_i < s_first:
                    first = i
                    s_first = s_i
        # A guard positive at both ends may still have dipped through its level inside
        # the step (the body rocking through theta = 0 and back): look where its cubic
        # Hermite interpolant is lowest and confirm there with the step itself.
        for i in range(N_GUARDS):
            if gnew[i] - level[i] > 0.0 and rate0[i] * rate1[i] < 0.0 and rate0[i] < 0.0:
                tau, low = _hermite_dip(gv[i] - level[i], gnew[i] - level[i],
                                        rate0[i] * h, rate1[i] * h)
                if low < 0.0:
                    _dop853_step(P, k, sliding, sigma, T, u, tau * h, f0, kst, ytmp, utry,
                                 rtol, atol)
                    _guards(P, k, sliding, sigma, T, xpiv, xt, utry, gtry)
                    if gtry[i] - level[i] <= 0.0:
                        s_i = _locate(P, k, sliding, sigma, T, xpiv, xt, u, tau * h, f0, kst,
                                      ytmp, utry, gtmp, rtol, atol, i, level[i],
                                      gv[i] - level[i], gtry[i] - level[i])
                        if first < 0 or s_i < s_first:
                            first = i
                            s_first = s_i
        if first >= 0:
            _dop853_step(P, k, sliding, sigma, T, u, s_first, f0, kst, ytmp, unew, rtol, atol)
            for j in range(4):
                u[j] = unew[j]
            t += s_first
            if first == 0:
                kind = PH_LIFTOFF
            elif first == 1:
                kind = PH_STICK if sliding else PH_SLIP
            elif first == 2:
                kind = PH_TOUCH
            elif first == 5:
                kind = PH_BAND
            else:
                kind = PH_BROKEN
            break
        for j in range(4):
            u[j] = unew[j]
            f0[j] = f1[j]
        for i in range(N_GUARDS):
            gv[i] = gnew[i]
            rate0[i] = rate1[i]
            if armed[i] == 0.0 and gv[i] > tol[i]:
                armed[i] = 1.0
                level[i] = 0.0
        t = t_stop if last else t + h
        fac = RK_MAX_FACTOR if err == 0.0 else min(RK_MAX_FACTOR, max(
            RK_MIN_FACTOR, RK_SAFETY * err ** (-1.0 / 8.0)))
        if last and h < h_prop:
            h_prop = max(h_prop, h * fac)   # a step cut short by t_stop says little
        else:
            h_prop = h * fac
    S[S_HSTEP] = h_prop
    # write the reduced state back; the constraint gives y, vy (and x, vx if pivoting)
    th = u[0]
    w = u[1]
    dx, dy = corner_offset(P, k, th)
    S[S_TH] = th
    S[S_W] = w
    S[S_Y] = -dy
    S[S_VY] = w * dx
    if sliding:
        S[S_X] = u[2]
        S[S_VX] = u[3]
    else:
        S[S_X] = xpiv - dx
        S[S_VX] = -w * dy
    S[S_T] = t
    return kind


@njit(**INNER)
def _locate(P, k, sliding, sigma, T, xpiv, xt, u, h, f0, kst, ytmp, utry, gtmp, rtol, atol,
            gi, lev, fa, fb):
    """Smallest s in (0, h] where guard gi - lev changes sign: Illinois regula falsi on
    the step length (the DOP853 step re-taken from u). Returns the right end of the
    final bracket, so the event has happened at the returned length."""
    a = 0.0
    b = h
    side = 0
    stol = 4.0 * 2.220446049250313e-16 * h + 1e-300
    for _ in range(200):
        if b - a <= stol:
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        _dop853_step(P, k, sliding, sigma, T, u, c, f0, kst, ytmp, utry, rtol, atol)
        _guards(P, k, sliding, sigma, T, xpiv, xt, utry, gtmp)
        fc = gtmp[gi] - lev
        if fc <= 0.0:
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
            if fc == 0.0:
                break
        else:
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
    return b


# ----------------------------------------------------------------------------------
# Event integrator: the loop over phases
# ----------------------------------------------------------------------------------
@njit(**INNER)
def _track_min_height(S, P):
    c = math.cos(S[S_TH])
    sn = math.sin(S[S_TH])
    _, dy0 = corner_offset_cs(P, 0, c, sn)
    _, dy1 = corner_offset_cs(P, 1, c, sn)
    low = S[S_Y] + min(dy0, dy1)
    if low < S[S_MIN_HEIGHT]:
        S[S_MIN_HEIGHT] = low


@njit(**INNER)
def _band_status_ahead(S, P, sigma):
    """Band membership just past the current position in direction sigma: decides a
    crossing unambiguously even where two corners' intervals meet (r = w)."""
    mode = int(S[S_MODE])
    xt = S[S_XT]
    w = P[P_BAND]
    probe = sigma * 1e-12
    if mode == MODE_G or mode == MODE_F:
        xa = S[S_X] + P[P_R] + probe
        xb = S[S_X] - P[P_R] + probe
        return abs(xa - xt) <= w or abs(xb - xt) <= w
    dx, _ = corner_offset(P, contact_corner(mode), S[S_TH])
    return abs(S[S_X] + dx + probe - xt) <= w


@njit(_I(_V, _V, _V, _M, _I, _I, _V), **INNER)
def _after_phase(S, P, O, ev, n, kind, W):
    """Carry out the transition that ended a phase, then settle and update the judge."""
    mode = int(S[S_MODE])
    t = S[S_T]
    if kind == PH_NONE:
        return n
    _track_min_height(S, P)
    if kind == PH_BROKEN:
        S[S_BROKEN] = 1.0
        n = _judge_set(S, P, ev, n, False)
        return _log(S, ev, n, t, EV_BROKEN, mode, mode, 0.0)
    if kind == PH_BAND:
        return _judge_set(S, P, ev, n, _band_status_ahead(S, P, S[S_SIGMA]))
    if kind == PH_TOUCH:
        n = _impact_event(S, P, O, ev, n, W)
    elif kind == PH_LIFTOFF:
        S[S_MODE] = MODE_A
        S[S_SIGMA] = 0.0
        n = _log(S, ev, n, t, EV_LIFTOFF, mode, MODE_A, 0.0)
    elif kind == PH_SLIP:
        k = contact_corner(mode)
        _, fx, _, _, _ = pivot_dynamics(P, k, S[S_TORQUE], S[S_TH], S[S_W])
        new = MODE_C if k == 0 else MODE_E
        S[S_MODE] = new
        S[S_SIGMA] = -1.0 if fx > 0.0 else 1.0
        n = _log(S, ev, n, t, EV_SLIP, mode, new, 0.0)
    elif kind == PH_STICK:
        # the sliding velocity reached zero: settle decides stick or reversal
        _, dy = corner_offset(P, contact_corner(mode), S[S_TH])
        S[S_VX] = -S[S_W] * dy
    elif kind == PH_STOP:
        S[S_MODE] = MODE_F
        S[S_SIGMA] = 0.0
        n = _log(S, ev, n, t, EV_STOP, mode, MODE_F, 0.0)
    n = settle(S, P, ev, n)
    _track_min_height(S, P)
    return _judge_update(S, P, ev, n)


@njit(**INNER_INLINE)
def _advance_event(S, P, O, t_stop, ev, n, W):
    n_start = n
    phases = 0
    while S[S_T] < t_stop and S[S_BROKEN] == 0.0 and S[S_STOPPED] == 0.0:
        if n - n_start > MAX_EVENTS:
            S[S_ERROR] = ERR_BUDGET
            break
        if S[S_ERROR] != 0.0:
            break
        phases += 1
        if phases > MAX_PHASES:         # phases that log no event would otherwise spin
            S[S_ERROR] = ERR_STEP
            break
        mode = int(S[S_MODE])
        # a phase ends where the judge's dwell would complete, so that TTRTP is logged
        # (and `stop_on="ttrtp"` stops) at its time, in order with the other events
        t_lim = t_stop
        if S[S_INBAND] == 1.0 and math.isnan(S[S_TTRTP]):
            t_star = S[S_TIN] + P[P_DWELL]
            if S[S_T] < t_star < t_stop:
                t_lim = t_star
        if mode == MODE_F:
            S[S_T] = t_lim                  # at rest: nothing to integrate
            if t_lim < t_stop:
                n = _judge_check(S, P, ev, n)
                continue
            break
        if mode == MODE_A:
            kind, _ = flight_phase(S, P, t_lim, W)
        elif mode == MODE_G:
            kind = g_phase(S, P, t_lim)
        else:
            kind = contact_phase(S, P, O, t_lim, W)
        n = _after_phase(S, P, O, ev, n, kind, W)
        if kind == PH_NONE and t_lim < t_stop:
            n = _judge_check(S, P, ev, n)   # the phase ended at the judge's deadline
    return n


# ----------------------------------------------------------------------------------
# Euler integrator: the contest-style fixed-step baseline (docs/MODEL.md section 10)
# ----------------------------------------------------------------------------------
@njit(**INNER)
def _euler_contact_step(S, P, dt):
    """Explicit Euler on (theta, omega, x, vx) of a single-contact state; y, vy (and
    x, vx for a pivot) from the constraint."""
    mode = int(S[S_MODE])
    k = contact_corner(mode)
    T = S[S_TORQUE]
    th = S[S_TH]
    w = S[S_W]
    if mode == MODE_B or mode == MODE_D:
        thdd, fx, _, dx, _ = pivot_dynamics(P, k, T, th, w)
        xpiv = S[S_X] + dx
        th += w * dt
        w += thdd * dt
        dx, dy = corner_offset(P, k, th)
        S[S_X] = xpiv - dx
        S[S_VX] = -w * dy
    else:
        thdd, fx, _, dx, _ = slide_dynamics(P, k, S[S_SIGMA], T, th, w)
        S[S_X] += S[S_VX] * dt
        S[S_VX] += fx / P[P_M] * dt
        th += w * dt
        w += thdd * dt
        dx, dy = corner_offset(P, k, th)
    S[S_TH] = th
    S[S_W] = w
    S[S_Y] = -dy
    S[S_VY] = w * dx


@njit(**INNER)
def _euler_ground_check(S, P):
    """End-of-step geometry check of the Euler baseline (it locates no events).

    A bottom corner that a step carried under the ground is put back on it first (a top
    corner at or under the ground then breaks the rover), as the contest program re-derived the
    configuration from the kinematics: in flight the body is lifted, in a single
    contact it is turned about the contact corner to theta = 0 (where the other corner
    touches). If a grounded corner is then moving down, that is an impact.
    """
    mode = int(S[S_MODE])
    _, dy0 = corner_offset(P, 0, S[S_TH])
    _, dy1 = corner_offset(P, 1, S[S_TH])
    low = min(S[S_Y] + dy0, S[S_Y] + dy1)
    if low < 0.0:
        if mode == MODE_A:
            S[S_Y] -= low
        else:
            k = contact_corner(mode)
            _turn_flat_about(S, P, k)
            if mode == MODE_B or mode == MODE_D:
                _, dy = corner_offset(P, k, 0.0)
                S[S_VX] = -S[S_W] * dy
    for c in range(2, 4):
        _, dy = corner_offset(P, c, S[S_TH])
        if S[S_Y] + dy <= 0.0:
            return PH_BROKEN
    if low >= 0.0:
        return PH_NONE
    for c in range(2):
        dx, dy = corner_offset(P, c, S[S_TH])
        if S[S_Y] + dy <= H_TOL and S[S_VY] - S[S_W] * dx < -V_TOL:
            return PH_TOUCH
    return PH_NONE


@njit(**JIT)
def event_budget(O, duration):
    """Events one `advance` over `duration` may have: MAX_EVENTS for `event`. A corner
    pressed down bounces every other Euler step (it gains a dt of speed per step, an
    artefact of the fixed step), so for `euler` the budget grows with the steps taken."""
    if int(O[O_INTEGRATOR]) == INTEGRATOR_EULER:
        return MAX_EVENTS + 4 * int(duration / O[O_EULER_DT] + 1.0)
    return MAX_EVENTS


@njit(**INNER)
def _advance_euler(S, P, O, t_stop, ev, n, W):
    dt0 = O[O_EULER_DT]
    n_start = n
    budget = event_budget(O, t_stop - S[S_T])
    g = P[P_G]
    while S[S_BROKEN] == 0.0 and S[S_STOPPED] == 0.0:
        remaining = t_stop - S[S_T]
        if remaining <= 1e-9 * dt0:
            S[S_T] = t_stop
            break
        if n - n_start > budget:
            S[S_ERROR] = 1.0
            break
        dt = min(dt0, remaining)
        mode = int(S[S_MODE])
        if mode == MODE_A:
            S[S_X] += S[S_VX] * dt
            S[S_Y] += S[S_VY] * dt
            S[S_TH] += S[S_W] * dt
            S[S_VY] -= g * dt
            S[S_W] += S[S_TORQUE] / P[P_I] * dt
        elif mode == MODE_G:
            sigma = S[S_SIGMA]
            S[S_X] += S[S_VX] * dt
            S[S_VX] -= sigma * P[P_MUD] * g * dt
        elif mode != MODE_F:
            _euler_contact_step(S, P, dt)
        S[S_T] = t_stop if dt == remaining else S[S_T] + dt
        # guards, checked only at the end of the step (no event location)
        kind = PH_NONE
        if mode == MODE_G and S[S_SIGMA] * S[S_VX] <= 0.0:
            S[S_VX] = 0.0
            kind = PH_STOP
        elif mode != MODE_F and mode != MODE_G:
            kind = _euler_ground_check(S, P)
            if kind == PH_NONE and (mode == MODE_C or mode == MODE_E):
                _, dy = corner_offset(P, contact_corner(mode), S[S_TH])
                if S[S_SIGMA] * (S[S_VX] + S[S_W] * dy) <= 0.0:
                    kind = PH_STICK
        if kind != PH_NONE:
            n = _after_phase(S, P, O, ev, n, kind, W)
        else:
            n = settle(S, P, ev, n)
            n = _judge_update(S, P, ev, n)
    return n


# ----------------------------------------------------------------------------------
# Entry points
# ----------------------------------------------------------------------------------
@njit(**INNER)
def _advance_begin(S, P, torque_cmd, t_stop, ev, W):
    """What both integrators do first: refuse a non-finite torque, apply the clipped
    torque and resolve the transitions it causes at once. Returns (integrate?, events)."""
    if not math.isfinite(torque_cmd):
        S[S_ERROR] = 2.0
        return False, 0
    if S[S_BROKEN] != 0.0 or S[S_ERROR] != 0.0 or S[S_T] >= t_stop:
        return False, 0
    S[S_TORQUE] = min(max(torque_cmd, P[P_TMIN]), P[P_TMAX])
    S[S_STOPPED] = 0.0
    W[W_WORK] = 0.0
    n = settle(S, P, ev, 0)
    n = _judge_update(S, P, ev, n)
    return S[S_STOPPED] == 0.0, n


@njit(**INNER)
def _advance_end(S, P, ev, n):
    if n > 0:
        _track_min_height(S, P)         # between events no corner can sink
    return _judge_check(S, P, ev, n)


@njit(**JIT_INLINE)
def advance(S, P, O, torque_cmd, t_stop, ev, W):
    """Hold `torque_cmd` (clipped to [T_min, T_max]) from S[S_T] to t_stop.

    Resolves the transitions the new torque causes at once, integrates with the
    integrator O[O_INTEGRATOR], updates the judge, and writes events into `ev`
    (rows beyond its length are counted, not written); W is scratch (N_WORK floats).
    Returns the number of events.
    If S[S_STOP_ON] names an event kind, the call returns right after the first such
    event, with S[S_STOPPED] = 1 and the time S[S_T] of the event.
    A non-finite torque sets S[S_ERROR] = 2 and leaves the state untouched.
    """
    go, n = _advance_begin(S, P, torque_cmd, t_stop, ev, W)
    if not go:
        return n
    if int(O[O_INTEGRATOR]) == INTEGRATOR_EULER:
        n = _advance_euler(S, P, O, t_stop, ev, n, W)
    else:
        n = _advance_event(S, P, O, t_stop, ev, n, W)
    return _advance_end(S, P, ev, n)


@njit(**JIT_INLINE)
def advance_event(S, P, O, torque_cmd, t_stop, ev, W):
    """`advance` with the event integrator, whatever O[O_INTEGRATOR] says.

    The environments' step kernels call this one, so that numba compiles no Euler code
    for them (about 1 s of a cold start): a compiled function includes every function
    it can reach, whichever branch runs. Environments made with integrator="euler" use
    kernels that call `advance`.
    """
    go, n = _advance_begin(S, P, torque_cmd, t_stop, ev, W)
    if not go:
        return n
    return _advance_end(S, P, ev, _advance_event(S, P, O, t_stop, ev, n, W))


INIT_OK, INIT_PENETRATION, INIT_TOP_DOWN, INIT_MOVING_DOWN, INIT_NOT_FLAT = range(5)
INIT_GROUND_TOL = 1e-9   # m: how far a given initial corner may be from the ground


@njit(**JIT)
def init_state(S, P, x, y, th, vx, vy, w, xt):
    """Fill S from a c.m. state and classify its contact state from the kinematics.

    A bottom corner within INIT_GROUND_TOL of the ground and at rest vertically is in
    contact (then snapped onto it); one moving down is an inconsistent start. Returns
    an INIT_* code (0 = fine).
    """
    for i in range(N_STATE):
        S[i] = 0.0
    S[S_X] = x
    S[S_Y] = y
    S[S_TH] = wrap_angle(th)
    S[S_VX] = vx
    S[S_VY] = vy
    S[S_W] = w
    S[S_XT] = xt
    S[S_TTRTP] = np.nan
    S[S_STOP_ON] = -1.0
    S[S_MIN_HEIGHT] = np.inf
    S[S_PHI] = np.nan
    S[S_MODE] = MODE_A
    on0 = False
    on1 = False
    for c in range(4):
        dx, dy = corner_offset(P, c, S[S_TH])
        hc = y + dy
        if c >= 2:
            if hc <= INIT_GROUND_TOL:
                return INIT_TOP_DOWN
            continue
        if hc < -INIT_GROUND_TOL:
            return INIT_PENETRATION
        if hc <= INIT_GROUND_TOL:
            vpy = vy - w * dx
            if vpy < -INIT_GROUND_TOL:
                return INIT_MOVING_DOWN
            if vpy <= INIT_GROUND_TOL:
                if c == 0:
                    on0 = True
                else:
                    on1 = True
    if on0 and on1:
        if abs(S[S_TH]) > 1e-6 or abs(w) > 1e-6:
            return INIT_NOT_FLAT
        _set_double_contact(S, P)
    elif on0 or on1:
        k = 0 if on0 else 1
        _set_single_contact(S, P, k)
        _, dy = corner_offset(P, k, S[S_TH])
        vpx = S[S_VX] + S[S_W] * dy
        if abs(vpx) <= INIT_GROUND_TOL:
            _pin_corner(S, P, k)
            S[S_MODE] = MODE_B if k == 0 else MODE_D
        else:
            S[S_MODE] = MODE_C if k == 0 else MODE_E
            S[S_SIGMA] = 1.0 if vpx > 0.0 else -1.0
    S[S_INBAND] = 1.0 if in_band(S, P) else 0.0
    S[S_TIN] = 0.0
    return INIT_OK


guard_jit_only(globals())
