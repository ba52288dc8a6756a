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
from hoprover_env.core.layout import (S_X, S_Y, S_TH, S_VX, S_VY, S_W, S_T, S_MODE, S_SIGMA, S_TORQUE, S_XT,
                     S_BROKEN, S_INBAND, S_TIN, S_TTRTP, S_HSTEP, S_NEVENTS, S_NIMPACT,
                     S_NGAIN, S_MAXGAIN, S_ERROR, S_STOP_ON, S_STOPPED, S_MIN_HEIGHT,
                     S_SEED_LO, S_SEED_HI, S_ROVER, S_NDRAW, N_STATE, MODE_A, MODE_B,
                     MODE_C, MODE_D, MODE_E, MODE_F, MODE_G, MODE_LETTERS, O_INTEGRATOR,
                     O_LAW, O_RTOL, O_EULER_DT, N_OPTIONS, INTEGRATOR_EVENT,
                     INTEGRATOR_EULER, LAW_CONTEST, LAW_DISSIPATIVE, EV_LIFTOFF, EV_SLIP,
                     EV_STICK, EV_REVERSE, EV_IMPACT, EV_RESUME, EV_TIP, EV_STOP,
                     EV_BAND_IN, EV_BAND_OUT, EV_BROKEN, EV_TTRTP, EVENT_NAMES, EV_COLS,
                     MAX_EVENTS, N_WORK, W_IMP, W_FLT, W_RK, W_WORK, H_TOL, V_TOL, A_TOL,
                     F_TOL, CA_TOL, H_IMPACT, MAX_CA_ITER, FLIGHT_WINDOW_MAX, RK_SAFETY,
                     RK_MIN_FACTOR, ERR_BUDGET, ERR_TORQUE, ERR_STEP, ERR_WORK,
                     MAX_RK_STEPS, MAX_WORK, MAX_PHASES, RK_MAX_FACTOR, TWO_PI, PH_NONE,
                     PH_LIFTOFF, PH_SLIP, PH_STICK, PH_TOUCH, PH_BROKEN, PH_BAND, PH_STOP)
from hoprover_env.core.forces import (corner_body, corner_offset_cs, corner_offset, wrap_angle,
                     kinetic_energy, total_energy, contact_corner, pivot_dynamics,
                     slide_dynamics, double_contact_forces, contact_forces,
                     set_single_contact, pin_corner, pinned_mode, sliding_mode, pin_or_slide,
                     turn_flat_about, set_double_contact)
from hoprover_env.core.flight import flight_at, flight_rise, resting_corner_driven_down, flight_phase
from hoprover_env.core.judge import log_event, in_band, judge_check, judge_set, judge_update
from hoprover_env.core.transitions import settle
from hoprover_env.core.terrain import (philox4x64, truncated_normal, impact_tilt, TRUNCATION, MAX_ATTEMPTS)
from hoprover_env.core.impacts import (contest_impulses, frictionless_impulses, resolve_impact,
                      resolve_impact_tilted, impact_event)
from hoprover_env.core.contact_phases import g_phase, contact_phase
from hoprover_env.core.phase_end import track_min_height, after_phase
from hoprover_env.core.euler import event_budget, advance_euler
from hoprover_env.core.integrator import (advance_event_loop, advance, advance_event, init_state,
                         INIT_GROUND_TOL, INIT_OK, INIT_PENETRATION, INIT_TOP_DOWN,
                         INIT_MOVING_DOWN, INIT_NOT_FLAT)
from hoprover_env.core import smooth
