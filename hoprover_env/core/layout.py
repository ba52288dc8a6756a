"""Layouts of the flat arrays the kernel works on (state S, options O, event log,
workspace W), event kinds, tolerances and budgets."""

import math

# ----------------------------------------------------------------------------------
# Layouts
# ----------------------------------------------------------------------------------
S_X, S_Y, S_TH, S_VX, S_VY, S_W = 0, 1, 2, 3, 4, 5
S_T = 6  # simulation time [s]
S_MODE = 7  # contact state 0..6 = A..G
S_SIGMA = 8  # slide direction of the contact point (+1, -1; 0 when not sliding)
S_TORQUE = 9  # applied (clipped) torque, held until the next control instant
S_XT = 10  # target x
S_BROKEN = 11  # 1 once a top corner touched the ground
S_INBAND = 12  # judge: 1 while a contact point is in the band
S_TIN = 13  # judge: time the current stay in the band began
S_TTRTP = 14  # judge: time to reach the target point (NaN until reached)
S_HSTEP = 15  # last accepted DOP853 step (a warm start for the next phase)
S_NEVENTS = 16  # events so far (transitions, impacts, band crossings)
S_NIMPACT = 17  # impacts so far
S_NGAIN = 18  # impacts that raised the kinetic energy
S_MAXGAIN = 19  # largest relative kinetic-energy gain of one impact
S_ERROR = 20  # 0 = fine; 1 = event budget of one advance exhausted; 2 = bad torque
S_STOP_ON = 21  # event kind that ends `advance` early (-1: none), for look-ahead tools
S_STOPPED = 22  # set when that event happened in the last `advance`
S_MIN_HEIGHT = 23  # diagnostics: lowest bottom-corner height seen after any event
# Rough-terrain bounces (docs/PHYSICS.md, "Terrain"): the key of the counter-based
# generator that tilts each impact's normal is (seed, rover), the counter the impact
# count S_NIMPACT. The 64-bit seed is kept as two exact 32-bit halves (a float64 holds
# integers exactly only up to 2^53).
S_SEED_LO = 24  # seed mod 2^32
S_SEED_HI = 25  # seed // 2^32
S_ROVER = 26  # rover index (run i of simulate_batch, env i of a vector env)
S_NDRAW = 27  # tilts drawn so far (stays 0 with roughness 0: no draw is made)
N_STATE = 28

MODE_A, MODE_B, MODE_C, MODE_D, MODE_E, MODE_F, MODE_G = 0, 1, 2, 3, 4, 5, 6
MODE_LETTERS = "ABCDEFG"

O_INTEGRATOR, O_LAW, O_RTOL, O_EULER_DT = 0, 1, 2, 3
N_OPTIONS = 4
INTEGRATOR_EVENT, INTEGRATOR_EULER = 0, 1
LAW_CONTEST, LAW_DISSIPATIVE = 0, 1

# Event kinds written to the log (column 1) -- names in EVENT_NAMES.
(
    EV_LIFTOFF,
    EV_SLIP,
    EV_STICK,
    EV_REVERSE,
    EV_IMPACT,
    EV_RESUME,
    EV_TIP,
    EV_STOP,
    EV_BAND_IN,
    EV_BAND_OUT,
    EV_BROKEN,
    EV_TTRTP,
) = range(12)
EVENT_NAMES = (
    "liftoff",
    "slip",
    "stick",
    "reverse",
    "impact",
    "resume",
    "tip",
    "stop",
    "band_in",
    "band_out",
    "broken",
    "ttrtp",
)
EV_COLS = 5  # t, kind, mode before, mode after, value (impacts: KE after / KE before)

# Budget of events in one call of `advance` (one control interval). A bounce sequence
# is finite (each bounce keeps e_y of the vertical speed, v_ymin ends it), so hitting
# this means a modelling failure; the run stops with S_ERROR = 1 instead of hanging.
MAX_EVENTS = 2000

# Scratch memory. The kernel allocates nothing and runs without numba's reference-counted
# runtime (_nrt=False): with it, every call that passes arrays pays atomic increments and
# decrements (~50 ns a call, and contention between threads). Callers pass a row of
# N_WORK floats per thread (RoverSim and the environments own theirs).
N_WORK = 192
W_IMP = 0  # impacts: 22 floats
W_FLT = 24  # flight: 8
W_RK = 32  # contact phases: 134 (sub-layout W_U ... below)
W_WORK = 176  # integration steps (flight + DOP853) taken in the current advance

# The impacts' part (impacts.py), from W_IMP: per bottom corner (2 floats each) its
# offset, point velocity, flags (1.0 / 0.0), restitution target and impulse.
W_IMP_DX = W_IMP  # offsets (dx, dy) of corners A, B (in the impact frame)
W_IMP_DY = W_IMP_DX + 2
W_IMP_VPX = W_IMP_DY + 2  # point velocities before the impact
W_IMP_VPY = W_IMP_VPX + 2
W_IMP_ON = W_IMP_VPY + 2  # on the ground (within H_IMPACT)
W_IMP_PART = W_IMP_ON + 2  # on the ground and not separating: takes part
W_IMP_DV = W_IMP_PART + 2  # velocity change the law asks of each corner (x, y)
W_IMP_TGT_Y = W_IMP_DV + 4  # normal target speed after the impact
W_IMP_LX = W_IMP_TGT_Y + 2  # impulses (x, y) at each corner
W_IMP_LY = W_IMP_LX + 2
W_IMP_END = W_IMP_LY + 2
assert W_IMP_END <= W_FLT

# The contact phases' part (contact_phases.py, contact_steps.py), from W_RK: vectors of
# the reduced state u = (theta, omega, x, vx) (N_U floats) and of the guards (N_GUARDS
# floats).
N_U = 4
N_GUARDS = 6
RK_STAGES = 13  # DOP853 stages kept for the error estimate
W_U = W_RK  # u at the start of the current step
W_ATOL = W_U + N_U  # absolute tolerances per component of u
W_GV = W_ATOL + N_U  # guard values at the step's start
W_GNEW = W_GV + N_GUARDS  # guard values at the step's end
W_LEVEL = W_GNEW + N_GUARDS  # level each guard fires at (0, or below a start on it)
W_GTOL = W_LEVEL + N_GUARDS  # how far a guard must be clear of its level to arm
W_ARMED = W_GTOL + N_GUARDS  # 1.0 once a guard has been clear of its level
W_F0 = W_ARMED + N_GUARDS  # f(u) at the step's start
W_KST = W_F0 + N_U  # the stages, RK_STAGES x N_U
W_YTMP = W_KST + RK_STAGES * N_U  # a stage's argument
W_UNEW = W_YTMP + N_U  # u at the step's end
W_UTRY = W_UNEW + N_U  # u at a trial length (event location)
W_F1 = W_UTRY + N_U  # f(u) at the step's end
W_RATE0 = W_F1 + N_U  # guard rates at the step's start
W_RATE1 = W_RATE0 + N_GUARDS  # guard rates at the step's end
W_GTRY = W_RATE1 + N_GUARDS  # guards at a trial length (dip check)
W_GTMP = W_GTRY + N_GUARDS  # guards at a trial length (root finding)
W_RK_END = W_GTMP + N_GUARDS
assert W_RK_END <= W_WORK

# Guards of a single-contact phase (positive = no event yet), contact_steps._guards
GUARD_LIFTOFF = 0  # normal force f_y / (m g)
GUARD_FRICTION = 1  # pivot: friction-cone margin (slip); slide: sigma v_Px (stick)
GUARD_TOUCH = 2  # the other bottom corner's height (impact)
GUARD_TOP_R = 3  # the top corners' heights (broken)
GUARD_TOP_L = 4
GUARD_BAND = 5  # slide only: distance to the next band boundary ahead

# ----------------------------------------------------------------------------------
# Tolerances. Round-off must not make a contact state chatter (docs/MODEL.md section 5).
# Scales: lengths ~0.05 m, speeds 1e-6..1e-2 m/s, accelerations ~1e-4 m/s^2.
# ----------------------------------------------------------------------------------
H_TOL = 1e-12  # m: a corner this close to the ground is on it
V_TOL = 1e-12  # m/s: a corner this slow (vertically / sliding) is at rest
A_TOL = 1e-13  # m/s^2: acceleration sign tolerance (resting corner driven down?)
F_TOL = 1e-12  # x m g: force sign tolerance (lift-off, slip)
CA_TOL = 1e-15  # m: conservative advancement stops this close to a touchdown
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
MAX_RK_STEPS = 10_000_000  # DOP853 steps in one contact phase
# Integration steps (flight + DOP853) in one advance, all phases together: about a
# second of CPU. A contest interval takes tens to thousands; only inputs far outside the
# rover's range (a torque of 1e10 N m spinning it at 1e12 rad/s) come near, and those
# would otherwise run MAX_PHASES x MAX_CA_ITER flight steps, i.e. hours (ERR_WORK).
MAX_WORK = 10_000_000
MAX_PHASES = 100_000  # phases in one advance (each normally logs an event)
RK_MAX_FACTOR = 10.0
TWO_PI = 2.0 * math.pi

PH_NONE, PH_LIFTOFF, PH_SLIP, PH_STICK, PH_TOUCH, PH_BROKEN, PH_BAND, PH_STOP = range(8)
