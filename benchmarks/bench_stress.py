"""Numerical stability stress: many long, hard runs, every sample checked.

    PYTHONPATH=. python -m benchmarks --only stress [--quick]

Seven families of runs try to break the kernel (hoprover_env/core/) where hybrid
simulators usually break: very long horizons, torques that flip sign every control step,
torques that press a bouncing corner back into the ground, landings that graze the
ground or arrive almost flat, flat two-corner landings, parameter sets at the edges of
their ranges, and control periods from 1e-4 s to 10 s. Each family runs with the `event`
integrator and, where affordable, the contest-style `euler` (dt 1e-3 s), under both
impact laws.

The driver (research/stress/drivers.py `drive`, with the stress controllers of
research/stress/controllers.py and the families of runs in research/stress/families.py)
checks the state after every control interval (a "sample", what `simulate`
records) and also right after every impact (it lets `core.advance` stop at each impact,
through the kernel's stop-on-event slot, checks, and resumes; the physics is unchanged,
the cross-check below confirms it). Per control interval it counts:

* nan        -- a non-finite c.m. state or time;
* pen_event  -- a bottom corner below -1e-9 m at some event (the kernel tracks the
                lowest height after every event in S_MIN_HEIGHT);
* pen_sample -- a bottom corner below -1e-9 m in a checked state;
* kinematics -- the state letter contradicts the kinematics
                (hoprover_env.sim.invariants `check_state`, tolerance 1e-9);
* energy     -- an impact raised the kinetic energy by more than 1e-12 under the
                `dissipative` law (which must never do so);
* time       -- the interval did not end at its stop time, or time went backwards;
* budget     -- the event budget of one control interval ran out (the kernel's
                S_ERROR = 1; `simulate` raises RuntimeError there).

The runs are driven by a jitted loop over `core.advance`: some families take 1e7
control steps, which a Python loop through `simulate` and a Python controller would
make minutes long. The driver is cross-checked against `simulate` plus
`hoprover_env.sim.invariants.kinematic_violations` on the first runs of every family (identical
final states, events and energy gains, the same verdicts), and its checker on hand-made
states.

This module measures; benchmarks/stress_report.py writes the section from what it
measured.

A run whose rover breaks (a top corner touches the ground: a legal end, not an error) is
restarted upright at rest where it broke, so every run covers its whole horizon; the
restarts are counted.

The section also measures how much kinetic energy the `contest` impact law adds in
random hopping (MODEL.md section 6 reports about one impact in six gaining up to ~20 %).
"""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

from benchmarks import stress_report
from benchmarks.report import Section
from hoprover_env import RoverParams, core, simulate
from hoprover_env.sim.invariants import (
    ENERGY_TOL,
    KINEMATIC_TOL,
    N_RECORDS,
    PENETRATION_TOL,
    V_BUDGET,
    V_KINEMATICS,
    V_NAN,
    V_PEN_EVENT,
    V_PEN_SAMPLE,
    check_state,
    kinematic_violations,
    new_drift,
)
from hoprover_env.sim.simulate import make_state
from research.stress.drivers import (
    B_FOUND,
    R_BREAKS,
    R_DRIFT_CORNER_VY,
    R_DRIFT_CORNER_Y,
    R_DRIFT_FG_TH,
    R_DRIFT_FG_VY,
    R_DRIFT_FG_W,
    R_DRIFT_FG_Y,
    R_DRIFT_PIVOT_VX,
    R_EVENTS,
    R_GAINS,
    R_IMPACT_SAMPLES,
    R_IMPACTS,
    R_KERNEL_GAINS,
    R_KINEMATICS_OTHER,
    R_MAX_EVENTS_PER_STEP,
    R_MIN_HEIGHT,
    R_PEN_AT_BREAK,
    R_SAMPLES_DOUBLE,
    R_SAMPLES_SINGLE,
    R_SIM_SECONDS,
    R_STEPS,
    R_VIOLATIONS,
    R_WRONG_TILT,
    TARGET_X,
    RunResult,
    RunSpec,
    contest_controller,
    execute,
    new_results,
    replay,
    upright,
)
from research.stress.families import DEFAULT, FAMILIES, family_random_params, offset


# ----------------------------------------------------------------------------------
# Checking the checker: hand-made states, and the driver against simulate
# ----------------------------------------------------------------------------------
def _contact_state(p: RoverParams, corner, th, w, v_slide):
    """(x, y, th, vx, vy, w) on one bottom corner (0 A, 1 B), sliding at v_slide."""
    dx, dy = offset(p, corner, th)
    return (0.0, -dy, th, v_slide - w * dy, w * dx, w)


def checker_self_test():
    """check_state on states that are right and on states broken on purpose.
    Returns (good states passed, good total, bad states flagged, bad total)."""
    p = DEFAULT
    pa = p.as_array()
    good = [
        upright(p),
        (0.0, p.half_height, 0.0, 1e-3, 0.0, 0.0),
        (0.0, 0.2, 0.7, 1e-3, -1e-3, 0.1),
        _contact_state(p, 0, 0.3, 0.02, 0.0),
        _contact_state(p, 0, 0.3, 0.02, 1e-3),
        _contact_state(p, 1, -0.3, -0.02, 0.0),
        _contact_state(p, 1, -0.3, 0.01, -1e-3),
    ]
    good_states = [make_state(p, TARGET_X, g) for g in good]
    passed = sum(check_state(g, pa, KINEMATIC_TOL, new_drift()) == 0 for g in good_states)

    def spoil(state, **changes):
        s = state.copy()
        for name, value in changes.items():
            s[getattr(core, name)] = value
        return s

    f, g_slide, flight, pivot_a, slide_a, pivot_b = good_states[:6]
    bad = [
        (spoil(f, S_TH=1e-15), V_KINEMATICS),  # F tilted
        (spoil(g_slide, S_VX=0.0), V_KINEMATICS),  # G not sliding
        (spoil(g_slide, S_W=1e-14), V_KINEMATICS),  # G turning
        (spoil(pivot_a, S_Y=pivot_a[core.S_Y] + 1e-8), V_KINEMATICS),  # B off ground
        (spoil(slide_a, S_VY=slide_a[core.S_VY] - 1e-8), V_KINEMATICS),  # C sinking
        (spoil(pivot_a, S_VX=pivot_a[core.S_VX] + 1e-8), V_KINEMATICS),  # pivot slips
        (spoil(pivot_b, S_TH=1e-8, S_Y=-offset(p, 1, 1e-8)[1]), V_KINEMATICS),  # D tilted
        (spoil(flight, S_Y=-offset(p, 0, 0.7)[1] - 2e-9), V_PEN_SAMPLE),  # under ground
        (spoil(flight, S_VX=np.nan), V_NAN),
    ]
    flagged = sum(
        bool(check_state(s, pa, KINEMATIC_TOL, new_drift()) & (1 << kind)) for s, kind in bad
    )
    return passed, len(good_states), flagged, len(bad)


def cross_check(spec: RunSpec, max_steps: int):
    """Run `spec` (shortened to max_steps control steps, no restart after a break)
    through the driver -- with and without the stops after impacts -- and through
    `simulate`; compare final state, events, energy gains and the verdicts of
    hoprover_env.sim.invariants.kinematic_violations and Rollout.min_corner_height.
    Returns a list of disagreements (empty when all agree)."""
    spec = dataclasses.replace(spec, t_end=min(spec.t_end, max_steps * spec.control_dt))
    plain = execute(spec, restart_on_break=False, sample_impacts=False)
    stopped = execute(spec, restart_on_break=False, sample_impacts=True)
    problems = []
    try:
        roll = simulate(
            contest_controller(spec),
            t_end=spec.t_end,
            control_dt=spec.control_dt,
            target_x=TARGET_X,
            integrator=spec.integrator,
            impact_law=spec.law,
            params=spec.params,
            initial_state=spec.initial,
            euler_dt=spec.euler_dt,
            seed=spec.seed(),
        )
    except RuntimeError:
        if not plain.r[R_VIOLATIONS + V_BUDGET]:
            problems.append("simulate ran out of events, the driver did not")
        return problems
    last = np.array(
        [
            roll.x[-1],
            roll.y[-1],
            roll.theta[-1],
            roll.vx[-1],
            roll.vy[-1],
            roll.omega[-1],
            roll.t[-1],
        ]
    )
    for name, res in (("driver", plain), ("driver stopping at impacts", stopped)):
        if not np.array_equal(res.final[: core.S_T + 1], last):
            problems.append(f"{name}: final state differs from simulate")
        if res.r[R_EVENTS] != roll.n_events:
            problems.append(f"{name}: {res.r[R_EVENTS]:.0f} events, simulate {roll.n_events}")
        gained = roll.impact_energy_ratios[roll.impact_energy_ratios > 1 + ENERGY_TOL] - 1
        if not np.array_equal(res.gains, gained):
            problems.append(f"{name}: energy gains differ from simulate")
    kin = len(kinematic_violations(roll, tol=KINEMATIC_TOL))
    if kin != plain.r[R_VIOLATIONS + V_KINEMATICS]:
        problems.append(
            f"kinematic verdicts differ: Rollout {kin}, driver "
            f"{plain.r[R_VIOLATIONS + V_KINEMATICS]:.0f}"
        )
    if (roll.min_corner_height < -PENETRATION_TOL) != bool(plain.r[R_VIOLATIONS + V_PEN_EVENT]):
        problems.append("penetration verdicts differ")
    return problems


# ----------------------------------------------------------------------------------
# Summaries
# ----------------------------------------------------------------------------------
SUMMED = (
    R_STEPS,
    R_SIM_SECONDS,
    R_EVENTS,
    R_IMPACTS,
    R_GAINS,
    R_KERNEL_GAINS,
    R_BREAKS,
    R_SAMPLES_SINGLE,
    R_SAMPLES_DOUBLE,
    R_IMPACT_SAMPLES,
    R_WRONG_TILT,
    R_KINEMATICS_OTHER,
    R_PEN_AT_BREAK,
)
MAXED = (
    R_DRIFT_CORNER_Y,
    R_DRIFT_CORNER_VY,
    R_DRIFT_PIVOT_VX,
    R_DRIFT_FG_Y,
    R_DRIFT_FG_TH,
    R_DRIFT_FG_VY,
    R_DRIFT_FG_W,
    R_MAX_EVENTS_PER_STEP,
)


@dataclasses.dataclass
class Group:
    """Sums, maxima and minima over the runs of one (family, integrator) group."""

    runs: int = 0
    runs_with_violations: int = 0
    wall: float = 0.0
    r: np.ndarray = dataclasses.field(default_factory=new_results)

    def add(self, res: RunResult):
        self.runs += 1
        self.wall += res.wall
        self.runs_with_violations += bool(res.r[R_VIOLATIONS:].any())
        for i in SUMMED:
            self.r[i] += res.r[i]
        for i in MAXED:
            self.r[i] = max(self.r[i], res.r[i])
        self.r[R_MIN_HEIGHT] = min(self.r[R_MIN_HEIGHT], res.r[R_MIN_HEIGHT])
        self.r[R_VIOLATIONS:] += res.r[R_VIOLATIONS:]


def energy_by(results) -> tuple[dict, dict]:
    """Impacts, energy-gaining impacts (event log and the kernel's S_NGAIN) and the
    gains, accumulated [impacts, gaining, kernel gaining, [gain arrays]]: of random
    hopping (family 1) by (hopper, integrator, law), and of every family by (family,
    integrator, law) plus ("**all**", integrator, law)."""

    def accumulate(store, key, res):
        acc = store.setdefault(key, [0.0, 0.0, 0.0, []])
        acc[0] += res.r[R_IMPACTS]
        acc[1] += res.r[R_GAINS]
        acc[2] += res.r[R_KERNEL_GAINS]
        acc[3].append(res.gains)

    hopping, by_family = {}, {}
    for res in results:
        sp = res.spec
        if sp.family.startswith("1 "):
            hopper = sp.label.rsplit(", seed", 1)[0]  # HOPPER_HOLD or HOPPER_FREE
            accumulate(hopping, (hopper, sp.integrator, sp.law), res)
        accumulate(by_family, (sp.family, sp.integrator, sp.law), res)
        accumulate(by_family, ("**all**", sp.integrator, sp.law), res)
    return hopping, by_family


def violation_records(results, per_kind: int = 2) -> list:
    """Per record kind that occurred (hoprover_env.sim.invariants RECORD_NAMES): the runs that
    hit it, and up to `per_kind` of them (from different families first) with their
    replayed violating interval (research.stress.replay)."""
    out = []
    for k in range(N_RECORDS):
        if k == V_KINEMATICS:
            continue  # shown through its two details
        hit = [res for res in results if res.bad[k, B_FOUND]]
        if not hit:
            continue
        examples, families = [], set()
        for res in hit:
            if res.spec.family not in families:
                examples.append(res)
                families.add(res.spec.family)
        out.append((k, hit, [(res, replay(res.spec, res.bad[k])) for res in examples[:per_kind]]))
    return out


def measure(quick: bool) -> dict:
    """Every number of the section: runs, cross-checks, summaries, violations."""
    t_start = time.perf_counter()
    m = {"quick": quick, "self_test": checker_self_test()}

    # every family, in order, each with its own random stream (changing one family
    # leaves the runs of the others as they were)
    specs_by_family = [
        (fam, fam(np.random.default_rng([2015, i]), quick)) for i, fam in enumerate(FAMILIES)
    ]
    results = []
    for fam, specs in specs_by_family:
        t0 = time.perf_counter()
        for spec in specs:
            results.append(execute(spec))
        print(
            f"[stress] {fam.__name__}: {len(specs)} runs in {time.perf_counter() - t0:.1f} s",
            file=sys.stderr,
            flush=True,
        )

    # cross-check: the first run of each (integrator, law) of every family that
    # simulate can start (make_state refuses the hand-built grazing states)
    t0 = time.perf_counter()
    checked, disagreements = 0, []
    max_steps = 2000 if quick else 10000
    for _fam, specs in specs_by_family:
        picks = {}
        for spec in specs:
            if spec.initial is not None:
                picks.setdefault((spec.integrator, spec.law), spec)
        for spec in picks.values():
            checked += 1
            disagreements += [
                f"{spec.family} {spec.integrator} {spec.law}: {p}"
                for p in cross_check(spec, max_steps)
            ]
    m.update(
        checked=checked,
        disagreements=disagreements,
        max_steps=max_steps,
        cross_wall=time.perf_counter() - t0,
    )

    groups: dict = {}
    total = Group()
    for res in results:
        groups.setdefault((res.spec.family, res.spec.integrator), Group()).add(res)
        total.add(res)
    m["results"], m["total"] = results, total
    m["groups"] = list(groups.items()) + [(("**all**", ""), total)]
    m["hopping"], m["by_family"] = energy_by(results)
    m["violations"] = violation_records(results)
    m["skipped"] = getattr(family_random_params, "skipped", 0)  # Painleve sets
    m["wall"] = time.perf_counter() - t_start
    return m


def run(quick: bool, fig_dir: str) -> Section:
    return stress_report.section(measure(quick), fig_dir)
