"""The event integrator built for smooth ground (roughness 0): no rough-terrain code.

A scene without bumps never draws an impact tilt, so it needs neither the counter-based
generator (`terrain.py`) nor the tilted impact's rotations and its second, plastic impact
on the mean plane (`impacts.resolve_impact_tilted`). numba compiles every callee a
function could reach, whatever runs, so the general integrator carries them all. Here
the chain from `advance_event` down to `resolve_impact` is compiled a second time from
the same source with ``impacts.ROUGH = False`` (numba prunes the branches on it) and
each link bound to the next smooth one (`_compile.rebind`):

    advance_event -> advance_event_loop -> after_phase -> impact_event -> resolve_impact

Nothing else differs: on smooth ground both builds run the same code on the same numbers
(with roughness 0 the general one draws nothing and its tilt is exactly 0), so a
trajectory is the same bit for bit (tests/core/test_smooth_build.py). The envs use this build while
every rover of theirs is on smooth ground (`tasks.common.TaskSpec.kernels`); slopes are
smooth ground too (a slope turns gravity, docs/MODEL.md section 11).
"""

from hoprover_env.core import contact_phases, flight, impacts, integrator, phase_end
from hoprover_env.jit.compiler import rebind, register_warm

# each stored under the name it is compiled and cached as (a kernel pickles by reference)
resolve_impact_tilted_smooth = rebind(
    impacts.resolve_impact_tilted, "resolve_impact_tilted_smooth", __name__, inner=True, ROUGH=False
)
resolve_impact_smooth = rebind(
    impacts.resolve_impact,
    "resolve_impact_smooth",
    __name__,
    inner=True,
    ROUGH=False,
    resolve_impact_tilted=resolve_impact_tilted_smooth,
)
impact_event_smooth = rebind(
    impacts.impact_event, "impact_event_smooth", __name__, resolve_impact=resolve_impact_smooth
)
after_phase_smooth = rebind(
    phase_end.after_phase, "after_phase_smooth", __name__, impact_event=impact_event_smooth
)
advance_event_loop_smooth = rebind(
    integrator.advance_event_loop,
    "advance_event_loop_smooth",
    __name__,
    after_phase=after_phase_smooth,
)
advance_event_smooth = rebind(
    integrator.advance_event,
    "advance_event_smooth",
    __name__,
    advance_event_loop=advance_event_loop_smooth,
)

# what the parallel cold compile builds (jit/compiler.py, `prepare`): the end of a phase
# for the ground, then the rest, largest first
register_warm(
    after_phase={True: phase_end.after_phase, False: after_phase_smooth},
    queue=(contact_phases.contact_phase, flight.flight_phase),
    queue_end=(integrator.init_state, contact_phases.g_phase),
)
