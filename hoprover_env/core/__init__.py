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

The package is split along the kernel's own sections, one module each:

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
``_jit``           how every function is compiled, and the guard for jit-only ones
=================  ==================================================================

Everything public is re-exported here, so callers write ``core.settle``, ``core.S_T``.
"""
from ._jit import *  # noqa: F401,F403
from ._jit import _DeclaredSignature, _JitOnlyDispatcher  # noqa: F401
from .layout import *  # noqa: F401,F403
from .forces import *  # noqa: F401,F403
from .flight import *  # noqa: F401,F403
from .judge import *  # noqa: F401,F403
from .terrain import *  # noqa: F401,F403
from .transitions import *  # noqa: F401,F403
from .impacts import *  # noqa: F401,F403
from .contact_phases import *  # noqa: F401,F403
from .phase_end import *  # noqa: F401,F403
from .euler import *  # noqa: F401,F403
from .euler import _advance_euler  # noqa: F401
from .integrator import *  # noqa: F401,F403
