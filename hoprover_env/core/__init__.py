"""The physics of the hopping rover: jitted functions over flat float arrays.

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
slide direction, applied torque, target, judge and diagnostics: physics only (an RL
reward keeps its own memory, hoprover_env/tasks/reward.py). Parameter vector ``P`` (layout
``P_*`` of :mod:`hoprover_env.core.params`). Options ``O`` (layout ``O_*``). The kernel takes
no Python objects, so the vector env loops it over rows of 2-D arrays in one jitted call.

Conventions (docs/MODEL.md section 2): x right, y up, theta clockwise-positive, positive T
clockwise. A body point with world offset d = (dx, dy) from the c.m. moves with
v + w (dy, -dx); a force f there has the clockwise moment dy fx - dx fy. Corner k has
body coordinates (bx, by): A = (r, -h), B = (-r, -h), TR = (r, h), TL = (-r, h), and
world offset dx = bx cos(th) + by sin(th), dy = -bx sin(th) + by cos(th).

Decisions beyond docs/MODEL.md are documented in docs/PHYSICS.md and marked "Decision" here.
The kernel allocates nothing: scratch space comes in a workspace row ``W`` (N_WORK floats).

One module per section of the kernel (docs/ARCHITECTURE.md has the whole map):

=================  ==================================================================
``layout``         the S / O / W / event-log layouts, tolerances, budgets, error codes
``forces``         corner geometry, contact forces of every state, contact setters
``flight``         state A in closed form, touchdown location, the flight phase
``judge``          the event log and the judge
``transitions``    the instantaneous transitions between contact states (``settle``)
``terrain``        rough-terrain bounces: the counter-based draw of each impact's tilt
``impacts``        the impact laws and the post-impact classification
``contact_phases`` state G in closed form, states B-E by DOP853 with located events
``phase_end``      what happens when a phase ends (either integrator)
``euler``          the fixed-step Euler baseline
``integrator``     the event integrator's loop, ``advance``, ``advance_event``,
                   ``init_state``
``smooth``         the event integrator built for smooth ground: no rough-terrain code
=================  ==================================================================

The names below are the core's public surface: callers write ``core.settle``,
``core.S_T``. Each comes from the one module that defines it.
"""
from hoprover_env.core import smooth
from hoprover_env.core.contact_phases import contact_phase, g_phase
from hoprover_env.core.euler import advance_euler, event_budget
from hoprover_env.core.flight import (
    flight_at,
    flight_phase,
    flight_rise,
    resting_corner_driven_down,
)
from hoprover_env.core.forces import (
    contact_corner,
    contact_forces,
    corner_body,
    corner_offset,
    corner_offset_cs,
    double_contact_forces,
    kinetic_energy,
    pin_corner,
    pin_or_slide,
    pinned_mode,
    pivot_dynamics,
    set_double_contact,
    set_single_contact,
    slide_dynamics,
    sliding_mode,
    total_energy,
    turn_flat_about,
    wrap_angle,
)
from hoprover_env.core.impacts import (
    contest_impulses,
    frictionless_impulses,
    impact_event,
    resolve_impact,
    resolve_impact_tilted,
)
from hoprover_env.core.integrator import (
    INIT_GROUND_TOL,
    INIT_MOVING_DOWN,
    INIT_NOT_FLAT,
    INIT_OK,
    INIT_PENETRATION,
    INIT_TOP_DOWN,
    advance,
    advance_event,
    advance_event_loop,
    init_state,
)
from hoprover_env.core.judge import in_band, judge_check, judge_set, judge_update, log_event
from hoprover_env.core.layout import (
    A_TOL,
    CA_TOL,
    ERR_BUDGET,
    ERR_STEP,
    ERR_TORQUE,
    ERR_WORK,
    EV_BAND_IN,
    EV_BAND_OUT,
    EV_BROKEN,
    EV_COLS,
    EV_IMPACT,
    EV_LIFTOFF,
    EV_RESUME,
    EV_REVERSE,
    EV_SLIP,
    EV_STICK,
    EV_STOP,
    EV_TIP,
    EV_TTRTP,
    EVENT_NAMES,
    F_TOL,
    FLIGHT_WINDOW_MAX,
    H_IMPACT,
    H_TOL,
    INTEGRATOR_EULER,
    INTEGRATOR_EVENT,
    LAW_CONTEST,
    LAW_DISSIPATIVE,
    MAX_CA_ITER,
    MAX_EVENTS,
    MAX_PHASES,
    MAX_RK_STEPS,
    MAX_WORK,
    MODE_A,
    MODE_B,
    MODE_C,
    MODE_D,
    MODE_E,
    MODE_F,
    MODE_G,
    MODE_LETTERS,
    N_OPTIONS,
    N_STATE,
    N_WORK,
    O_EULER_DT,
    O_INTEGRATOR,
    O_LAW,
    O_RTOL,
    PH_BAND,
    PH_BROKEN,
    PH_LIFTOFF,
    PH_NONE,
    PH_SLIP,
    PH_STICK,
    PH_STOP,
    PH_TOUCH,
    RK_MAX_FACTOR,
    RK_MIN_FACTOR,
    RK_SAFETY,
    S_BROKEN,
    S_ERROR,
    S_HSTEP,
    S_INBAND,
    S_MAXGAIN,
    S_MIN_HEIGHT,
    S_MODE,
    S_NDRAW,
    S_NEVENTS,
    S_NGAIN,
    S_NIMPACT,
    S_ROVER,
    S_SEED_HI,
    S_SEED_LO,
    S_SIGMA,
    S_STOP_ON,
    S_STOPPED,
    S_T,
    S_TH,
    S_TIN,
    S_TORQUE,
    S_TTRTP,
    S_VX,
    S_VY,
    S_W,
    S_X,
    S_XT,
    S_Y,
    TWO_PI,
    V_TOL,
    W_FLT,
    W_IMP,
    W_RK,
    W_WORK,
)
from hoprover_env.core.phase_end import after_phase, track_min_height
from hoprover_env.core.terrain import (
    MAX_ATTEMPTS,
    TRUNCATION,
    impact_tilt,
    philox4x64,
    truncated_normal,
)
from hoprover_env.core.transitions import settle

# the core's public surface (the module docstring): every name above, re-exported
__all__ = [
    "smooth", "contact_phase", "g_phase", "advance_euler", "event_budget", "flight_at",
    "flight_phase", "flight_rise", "resting_corner_driven_down", "contact_corner",
    "contact_forces", "corner_body", "corner_offset", "corner_offset_cs",
    "double_contact_forces", "kinetic_energy", "pin_corner", "pin_or_slide", "pinned_mode",
    "pivot_dynamics", "set_double_contact", "set_single_contact", "slide_dynamics",
    "sliding_mode", "total_energy", "turn_flat_about", "wrap_angle", "contest_impulses",
    "frictionless_impulses", "impact_event", "resolve_impact", "resolve_impact_tilted",
    "INIT_GROUND_TOL", "INIT_MOVING_DOWN", "INIT_NOT_FLAT", "INIT_OK", "INIT_PENETRATION",
    "INIT_TOP_DOWN", "advance", "advance_event", "advance_event_loop", "init_state", "in_band",
    "judge_check", "judge_set", "judge_update", "log_event", "A_TOL", "CA_TOL", "ERR_BUDGET",
    "ERR_STEP", "ERR_TORQUE", "ERR_WORK", "EV_BAND_IN", "EV_BAND_OUT", "EV_BROKEN", "EV_COLS",
    "EV_IMPACT", "EV_LIFTOFF", "EV_RESUME", "EV_REVERSE", "EV_SLIP", "EV_STICK", "EV_STOP",
    "EV_TIP", "EV_TTRTP", "EVENT_NAMES", "F_TOL", "FLIGHT_WINDOW_MAX", "H_IMPACT", "H_TOL",
    "INTEGRATOR_EULER", "INTEGRATOR_EVENT", "LAW_CONTEST", "LAW_DISSIPATIVE", "MAX_CA_ITER",
    "MAX_EVENTS", "MAX_PHASES", "MAX_RK_STEPS", "MAX_WORK", "MODE_A", "MODE_B", "MODE_C",
    "MODE_D", "MODE_E", "MODE_F", "MODE_G", "MODE_LETTERS", "N_OPTIONS", "N_STATE", "N_WORK",
    "O_EULER_DT", "O_INTEGRATOR", "O_LAW", "O_RTOL", "PH_BAND", "PH_BROKEN", "PH_LIFTOFF",
    "PH_NONE", "PH_SLIP", "PH_STICK", "PH_STOP", "PH_TOUCH", "RK_MAX_FACTOR", "RK_MIN_FACTOR",
    "RK_SAFETY", "S_BROKEN", "S_ERROR", "S_HSTEP", "S_INBAND", "S_MAXGAIN", "S_MIN_HEIGHT",
    "S_MODE", "S_NDRAW", "S_NEVENTS", "S_NGAIN", "S_NIMPACT", "S_ROVER", "S_SEED_HI",
    "S_SEED_LO", "S_SIGMA", "S_STOP_ON", "S_STOPPED", "S_T", "S_TH", "S_TIN", "S_TORQUE",
    "S_TTRTP", "S_VX", "S_VY", "S_W", "S_X", "S_XT", "S_Y", "TWO_PI", "V_TOL", "W_FLT",
    "W_IMP", "W_RK", "W_WORK", "after_phase", "track_min_height", "MAX_ATTEMPTS", "TRUNCATION",
    "impact_tilt", "philox4x64", "truncated_normal", "settle",
]
