"""Run time against error (work-precision): the `event` integrator against `euler`.

    PYTHONPATH=. python -m benchmarks --only accuracy [--quick]

What is measured, in the order the code does it:

1. The scenario. From rest, a constant launch torque (several levels) is held until
   the rover lifts off; a PD attitude hold T = -I (kp wrap(theta) + kd omega) runs at
   control instants 0.1 s apart during the flight; the torque is zero from the first
   touchdown on, through the bounces and the final slide, until the rover rests (F)
   and the judge has decided. The whole run is one call of a small numba driver
   (research/launch_land.py `run_scenario`) that loops `core.advance` itself: the wall time is the
   integrators' and not Python's (a Python controller costs ~8 us per control step,
   more than the event integrator's whole flight step).
2. The reference: `event` at rtol REFERENCE_RTOL, cross-checked against an
   independent solution: hoprover_env.sim.reference.Ref (MODEL.md section 4 by scipy's
   DOP853 with located events) up to the lift-off, then the flight in closed form
   (parabola; theta quadratic between control instants) with the touchdown found by
   root finding.
3. The sweeps: `euler` over euler_dt, `event` over rtol. Errors against the
   reference: first lift-off time, first landing time and c.m. x at landing (the mode
   sequence cannot differ before the first impact), and after the bounce sequence
   the rest position, rest time and TTRTP (target = reference rest x + 0.02 m), only
   where the run's mode sequence equals the reference's.
4. Past the first impact, sequences can differ (Euler sees events only at step ends),
   so over many launch torques the distributions of rest positions are compared,
   not points.
5. The same launch on the contest's control grid (every torque switch at a 0.1 s
   instant, as simulate() does): there every DOP853 step is cut at 0.1 s and rtol
   stops mattering.

The driver is checked against simulate() (contest grid) and against a Python loop over
RoverSim (event-triggered switches) bit for bit before anything is timed.

This module measures (benchmarks/accuracy_driver.py runs the scenario);
benchmarks/accuracy_report.py writes the section from what it measured.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from scipy.stats import wasserstein_distance

from benchmarks import accuracy_report
from benchmarks.accuracy_driver import (
    CONTROL_DT,
    KD,
    KP,
    MAX_REPEATS,
    T_END,
    TIMING_BUDGET,
    Driver,
    Method,
    Run,
    seq_of_events,
)
from benchmarks.accuracy_reference import scipy_launch_and_landing
from benchmarks.report import Section, best_of
from hoprover_env import RoverParams, RoverSim, core, simulate
from hoprover_env.sim.controllers import attitude_hold
from hoprover_env.sim.simulate import make_state
from research.launch_land import (
    IDLE_CHUNK,
    TIMING_EVENTS,
    TIMING_GRID,
    contest_controller,
    repeat_launch,
)

# ----------------------------------------------------------------------------------
# The scenario: launch, attitude hold in flight, idle once landed (the hold, the control
# grid and the driver that runs it: benchmarks/accuracy_driver.py)
# ----------------------------------------------------------------------------------
TARGET_OFFSET = 0.02  # m: target = reference rest x + this (rests inside the band)

# Launch torques of the point-by-point comparison [N m], and how many evenly spread
# ones the statistics use.
TORQUES = {"quick": (3e-5, 2e-4, 5e-4), "full": (3e-5, 6e-5, 1e-4, 2e-4, 3.5e-4, 5e-4)}
STAT_TORQUES = {"quick": 12, "full": 40}
EULER_DTS = {
    "quick": (1e-2, 3e-3, 1e-3, 3e-4, 1e-4),
    "full": (1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6),
}
EVENT_RTOLS = {
    "quick": (1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12),
    "full": (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13),
}
STAT_EULER_DTS = {"quick": (1e-2, 1e-3, 1e-4), "full": (1e-2, 1e-3, 1e-4, 1e-5)}
STAT_EVENT_RTOLS = (1e-6, 1e-11)
GRID_METHODS = (("event", 1e-4), ("event", 1e-8), ("event", 1e-11), ("euler", 1e-3))
# The reference. 1e-15, the API's floor, moves the landing times by ~1e-13 s only
# (round-off); 1e-14 keeps a margin from it.
REFERENCE_RTOL = 1e-14
DEFAULT_RTOL = 1e-11  # simulate()'s default, quoted in the headline

BOUNCE_TORQUE, BOUNCE_DT = 5e-4, 1e-2  # the bounce sequence shown in the text
# what the report quotes of the set-up
SETTINGS = {
    "kp": KP,
    "kd": KD,
    "control_dt": CONTROL_DT,
    "target_offset": TARGET_OFFSET,
    "reference_rtol": REFERENCE_RTOL,
    "default_rtol": DEFAULT_RTOL,
    "max_repeats": MAX_REPEATS,
    "timing_budget": TIMING_BUDGET,
    "bounce_torque": BOUNCE_TORQUE,
    "bounce_dt": BOUNCE_DT,
}


# ----------------------------------------------------------------------------------
# The driver against the public API (run before anything is timed)
# ----------------------------------------------------------------------------------
def check_grid_against_simulate(
    driver: Driver, method: Method, torque: float, target_x: float
) -> float:
    """Largest difference (state, lift-off and landing times, TTRTP) between the driver
    on the contest grid and simulate() with the same controller in Python; raises if
    the mode sequences differ."""
    run = driver.run(method, torque, target_x, TIMING_GRID)
    roll = simulate(
        contest_controller(torque, driver.params.inertia, KP, KD),
        t_end=run.end_t,
        control_dt=CONTROL_DT,
        target_x=target_x,
        params=driver.params,
        **method.kwargs(),
    )
    if seq_of_events(roll.events) != run.seq:
        raise AssertionError(
            f"driver and simulate() differ in mode sequence ({method.label}, torque {torque:g})"
        )
    final = np.array(
        [roll.x[-1], roll.y[-1], roll.theta[-1], roll.vx[-1], roll.vy[-1], roll.omega[-1]]
    )
    liftoff = next(e[0] for e in roll.events if e[1] == "liftoff")
    landing = next(e[0] for e in roll.events if e[1] == "impact" and e[0] >= liftoff)
    ttrtp = math.nan if roll.ttrtp is None else roll.ttrtp
    return max(
        float(np.max(np.abs(final - run.final))),
        abs(liftoff - run.liftoff_t),
        abs(landing - run.land_t),
        _nan_diff(ttrtp, run.ttrtp),
    )


def check_events_against_roversim(
    driver: Driver, method: Method, torque: float, target_x: float
) -> float:
    """Largest difference between the driver with event-triggered switches and the
    same schedule written in Python over RoverSim.advance(stop_on=...)."""
    run = driver.run(method, torque, target_x, TIMING_EVENTS)
    inertia = driver.params.inertia
    sim = RoverSim(driver.params, target_x=target_x, **method.kwargs())
    events = sim.advance(torque, T_END, stop_on="liftoff")
    t_liftoff = sim.t
    k = 0
    while not (k > 0 and sim.stopped) and sim.t < T_END:
        k += 1
        cmd = attitude_hold(sim.s[core.S_TH], sim.s[core.S_W], inertia, KP, KD)
        events += sim.advance(cmd, min(t_liftoff + k * CONTROL_DT, T_END), stop_on="impact")
    t_land, x_land = sim.t, sim.state[0]
    while (
        not (sim.mode == "F" and (sim.s[core.S_INBAND] == 0.0 or sim.ttrtp is not None))
        and sim.t < T_END
    ):
        events += sim.advance(0.0, min(sim.t + IDLE_CHUNK, T_END))
    if seq_of_events(events) != run.seq:
        raise AssertionError(
            f"driver and RoverSim differ in mode sequence ({method.label}, torque {torque:g})"
        )
    ttrtp = math.nan if sim.ttrtp is None else sim.ttrtp
    return max(
        float(np.max(np.abs(sim.state - run.final))),
        abs(t_liftoff - run.liftoff_t),
        abs(t_land - run.land_t),
        abs(x_land - run.land_x),
        _nan_diff(ttrtp, run.ttrtp),
    )


def _nan_diff(a: float, b: float) -> float:
    """|a - b|, 0 when both are NaN (neither happened), inf when only one is."""
    if math.isnan(a) and math.isnan(b):
        return 0.0
    if math.isnan(a) or math.isnan(b):
        return math.inf
    return abs(a - b)


def warm_up(driver: Driver) -> float:
    """Compile (or load from numba's cache) the driver kernels; returns the seconds."""
    t0 = time.perf_counter()
    for m in (Method("event", DEFAULT_RTOL), Method("euler", 1e-2)):
        driver.run(m, 3e-4, 0.5)
        repeat_launch(
            make_state(driver.params, 0.5),
            np.zeros(core.N_STATE),
            driver.p,
            m.options(),
            3e-4,
            T_END,
            driver.ev,
            driver.w,
            1,
        )
    return time.perf_counter() - t0


# ----------------------------------------------------------------------------------
# The independent reference (benchmarks/accuracy_reference.py) against the simulator
# ----------------------------------------------------------------------------------
def launch_modes(events) -> str:
    """'FBCA'-style letters of the launch, as tests/sim/test_reference.py writes them."""
    return "".join(
        [events[0][2]] + [e[3] for e in events if e[1] in ("tip", "slip", "stick", "liftoff")]
    )


def cross_check(driver: Driver, torques, reference_runs, targets) -> list:
    """Reference (event at REFERENCE_RTOL) against scipy + closed form, per torque."""
    rows = []
    for torque in torques:
        sp = scipy_launch_and_landing(driver.params, torque, KP, KD, CONTROL_DT, T_END)
        sim = RoverSim(driver.params, target_x=targets[torque], rtol=REFERENCE_RTOL)
        events = sim.advance(torque, T_END, stop_on="liftoff")
        ref = reference_runs[torque]
        rows.append(
            {
                "torque": torque,
                "modes": sp["modes"],
                "same_modes": launch_modes(events) == sp["modes"],
                "liftoff_t": sp["liftoff_t"],
                "land_t": sp["land_t"],
                "land_x": sp["land_x"],
                "d_liftoff_t": abs(sim.t - sp["liftoff_t"]),
                "d_liftoff_pos": float(np.max(np.abs(sim.state[:3] - sp["liftoff_state"][:3]))),
                "d_liftoff_vel": float(np.max(np.abs(sim.state[3:] - sp["liftoff_state"][3:]))),
                "d_land_t": abs(ref.land_t - sp["land_t"]),
                "d_land_x": abs(ref.land_x - sp["land_x"]),
            }
        )
    return rows


# ----------------------------------------------------------------------------------
# Errors against the reference
# ----------------------------------------------------------------------------------
# (key, column title, unit): before the first impact every run has the reference's
# mode sequence, so these are compared point by point for every run ...
EARLY = (
    ("liftoff_t", "lift-off t", "s"),
    ("land_t", "landing t", "s"),
    ("land_x", "landing x", "m"),
)
# ... after it, only runs whose whole mode sequence equals the reference's.
LATE = (("rest_x", "rest x", "m"), ("rest_t", "rest t", "s"), ("ttrtp", "TTRTP", "s"))


@dataclasses.dataclass
class SweepPoint:
    """One method setting over the launch torques: worst errors and mean wall times."""

    method: Method
    errors: dict  # key -> largest |error| over the torques (NaN: none compared)
    same_seq: int  # runs whose mode sequence equals the reference's
    n_runs: int
    wall: float  # mean over the torques of a whole run's best wall time [s]
    launch_wall: float  # mean over the torques of the launch's wall time [s]
    runs: dict  # torque -> Run
    same_early: int = 0  # runs whose mode sequence up to the first impact is the ref's


def errors_of(run: Run, ref: Run) -> dict:
    same = run.seq == ref.seq and run.flag == 0
    out = {key: _nan_diff(getattr(run, key), getattr(ref, key)) for key, _, _ in EARLY}
    for key, _, _ in LATE:
        out[key] = _nan_diff(getattr(run, key), getattr(ref, key)) if same else math.nan
    return out


def sweep_point(
    driver: Driver, method: Method, torques, refs, targets, timing: int = TIMING_EVENTS
) -> SweepPoint:
    """Run `method` on every torque (best-of wall times) and compare with `refs`."""
    runs, errs = {}, []
    for torque in torques:
        runs[torque] = driver.timed_run(method, torque, targets[torque], timing)
        errs.append(errors_of(runs[torque], refs[torque]))
    worst = {}
    for key in [k for k, _, _ in EARLY + LATE]:
        vals = [e[key] for e in errs if not math.isnan(e[key])]
        worst[key] = max(vals) if vals else math.nan
    same = sum(runs[t].seq == refs[t].seq and runs[t].flag == 0 for t in torques)
    same_early = sum(
        _to_first_impact(runs[t].seq) == _to_first_impact(refs[t].seq) for t in torques
    )
    return SweepPoint(
        method,
        worst,
        same,
        len(torques),
        float(np.mean([runs[t].wall for t in torques])),
        float(np.mean([driver.launch_wall(method, t) for t in torques]))
        if timing == TIMING_EVENTS
        else math.nan,
        runs,
        same_early,
    )


def _to_first_impact(seq: tuple) -> tuple:
    """The mode-sequence codes up to and including the first impact."""
    first = [i for i, c in enumerate(seq) if c // 8 == core.EV_IMPACT]
    return seq[: first[0] + 1] if first else seq


def comparable(points, key: str) -> list:
    """Worst errors of `key` along a sweep, NaN where a late quantity's worst case is
    over fewer runs than the others (some mode sequence differed): the worst case of a
    smaller set would bend the fitted slope."""
    late = key in [k for k, _, _ in LATE]
    return [p.errors[key] if (not late or p.same_seq == p.n_runs) else math.nan for p in points]


def fitted_order(steps, errors, floor: float = 0.0) -> float:
    """Least-squares slope of log(error) against log(step or rtol), over the points whose
    error stands clear (100x) of the reference's own noise `floor`; NaN if < 3 points."""
    pts = [
        (s, e)
        for s, e in zip(steps, errors)
        if e is not None and math.isfinite(e) and e > max(100.0 * floor, 0.0) and e > 0
    ]
    if len(pts) < 3:
        return math.nan
    x = np.log10([p[0] for p in pts])
    y = np.log10([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def step_for_error(steps, errors, wanted: float) -> float:
    """The step at which the (log-log interpolated) worst error equals `wanted`: the
    largest step that meets it. inf if every step meets it, NaN if none does."""
    pairs = sorted((s, e) for s, e in zip(steps, errors) if math.isfinite(e))
    pairs.reverse()  # large steps first
    if all(e <= wanted for _, e in pairs):
        return math.inf
    for (s0, e0), (s1, e1) in zip(pairs, pairs[1:]):
        if e0 > wanted >= e1:
            f = math.log(wanted / e0) / math.log(e1 / e0)
            return 10 ** (math.log10(s0) + f * (math.log10(s1) - math.log10(s0)))
    return math.nan


# ----------------------------------------------------------------------------------
# Past the first impact: statistics over many launch torques
# ----------------------------------------------------------------------------------
def bounce_speeds(params: RoverParams, method: Method, torque: float) -> str:
    """The c.m. vertical speed after each impact of the landing, to the first impact
    that leaves the rover on the ground: the same schedule as run_scenario's, written
    over RoverSim so that it can stop at every impact."""
    sim = RoverSim(params, target_x=0.5, **method.kwargs())
    sim.advance(torque, T_END, stop_on="liftoff")
    t_liftoff, k = sim.t, 0
    while not (k > 0 and sim.stopped) and sim.t < T_END:
        k += 1
        cmd = attitude_hold(sim.s[core.S_TH], sim.s[core.S_W], params.inertia, KP, KD)
        sim.advance(cmd, min(t_liftoff + k * CONTROL_DT, T_END), stop_on="impact")
    speeds = [sim.state[4]]
    while sim.mode == "A" and sim.t < T_END:
        sim.advance(0.0, T_END, stop_on="impact")
        speeds.append(sim.state[4])
    return ", ".join(f"{v:.2e}" for v in speeds[:-1]) + f", then {sim.mode}"


def statistics(driver: Driver, methods, n_torques: int) -> tuple:
    """Rest positions (hop distances: the rover starts at x = 0) over evenly spread
    launch torques, for the reference and each method. Returns (torques, table rows,
    rest x arrays by label)."""
    torques = np.linspace(3e-5, 5e-4, n_torques)
    ref_method = Method("event", REFERENCE_RTOL)
    refs = [driver.run(ref_method, t, 0.5) for t in torques]
    ref_x = np.array([r.rest_x for r in refs])
    rows, rest = [], {ref_method.label + " (reference)": ref_x}
    for method in methods:
        runs = [driver.run(method, t, 0.5) for t in torques]
        xs = np.array([r.rest_x for r in runs])
        ok = np.isfinite(xs)
        same = np.array([r.seq == q.seq for r, q in zip(runs, refs)])
        diff = np.abs(xs - ref_x)
        # how the differing sequences differ: extra (or missing) impacts, counted
        extra = {}
        for r, q in zip(runs, refs):
            if r.seq != q.seq:
                d = r.n_impacts - q.n_impacts
                extra[d] = extra.get(d, 0) + 1
        extra_txt = ", ".join(f"{d:+d}: {c}" for d, c in sorted(extra.items())) or "-"
        rows.append(
            [
                method.integrator,
                method.label.split(" ", 1)[1],
                f"{same.sum()}/{n_torques}",
                float(np.mean(xs[ok])),
                float(np.std(xs[ok])),
                float(wasserstein_distance(xs[ok], ref_x)),
                float(np.median(diff[ok])),
                float(np.max(diff[ok])),
                float(np.max(diff[~same & ok])) if np.any(~same & ok) else "-",
                float(np.mean([r.n_impacts for r in runs])),
                extra_txt,
                int(np.sum(~ok)),
            ]
        )
        rest[method.label] = xs
    rows.insert(
        0,
        [
            "event",
            f"{REFERENCE_RTOL:.0e} (reference)",
            "-",
            float(np.mean(ref_x)),
            float(np.std(ref_x)),
            0.0,
            0.0,
            0.0,
            "-",
            float(np.mean([r.n_impacts for r in refs])),
            "-",
            0,
        ],
    )
    return torques, rows, rest


def measure(quick: bool) -> dict:
    """Every number of the section, in the order the module docstring lists them."""
    size = "quick" if quick else "full"
    params = RoverParams()
    driver = Driver(params)
    m = {
        "compile_s": warm_up(driver),
        "torques": TORQUES[size],
        "settings": SETTINGS,
        "early": EARLY,
        "late": LATE,
    }
    torques = m["torques"]
    ref_method = Method("event", REFERENCE_RTOL)
    default = Method("event", DEFAULT_RTOL)

    # 1. The compiled driver must be the public API's physics, bit for bit.
    m["check_max"], m["n_checks"] = 0.0, 0
    for torque in torques:
        for method in (default, Method("euler", 1e-3)):
            m["check_max"] = max(
                m["check_max"],
                check_grid_against_simulate(driver, method, torque, 0.5),
                check_events_against_roversim(driver, method, torque, 0.5),
            )
            m["n_checks"] += 2
    # What the Python controller would have cost: simulate() on the contest grid with
    # it, against the driver on the same grid.
    m["python_wall"] = np.mean(
        [
            best_of(
                lambda t=t: simulate(
                    contest_controller(t, params.inertia, KP, KD),
                    t_end=driver.run(default, t, 0.5, TIMING_GRID).end_t,
                    control_dt=CONTROL_DT,
                    target_x=0.5,
                    params=params,
                    **default.kwargs(),
                )
            )[0]
            for t in torques
        ]
    )
    m["driver_grid_wall"] = np.mean(
        [driver.timed_run(default, t, 0.5, TIMING_GRID).wall for t in torques]
    )

    # 2. The reference: find where each launch comes to rest, put the target 2 cm
    #    beyond it (so that the rover stops inside the band and TTRTP exists), rerun.
    targets, refs = {}, {}
    for torque in torques:
        targets[torque] = driver.run(ref_method, torque, 0.5).rest_x + TARGET_OFFSET
        refs[torque] = driver.timed_run(ref_method, torque, targets[torque])
        if refs[torque].flag != 0 or math.isnan(refs[torque].ttrtp):
            raise RuntimeError(f"reference run failed for torque {torque:g}: {refs[torque]}")
    m["refs"], m["targets"] = refs, targets
    # its own noise: the API's tightest rtol against it
    tightest = [
        errors_of(driver.run(Method("event", 1e-15), t, targets[t]), refs[t]) for t in torques
    ]
    m["floors"] = {k: float(np.nanmax([e[k] for e in tightest])) for k, _, _ in EARLY + LATE}
    m["xcheck"] = cross_check(driver, torques, refs, targets)
    m["flight_intervals"] = [(refs[t].land_t - refs[t].liftoff_t) / CONTROL_DT for t in torques]

    # 3. The sweeps, and the orders of convergence they show.
    m["euler"] = [
        sweep_point(driver, Method("euler", dt), torques, refs, targets) for dt in EULER_DTS[size]
    ]
    m["event"] = [
        sweep_point(driver, Method("event", rtol), torques, refs, targets)
        for rtol in EVENT_RTOLS[size]
    ]
    dts = [p.method.value for p in m["euler"]]
    rtols = [p.method.value for p in m["event"]]
    m["euler_order"] = {k: fitted_order(dts, comparable(m["euler"], k)) for k, _, _ in EARLY + LATE}
    m["event_order"] = {
        k: fitted_order(rtols, comparable(m["event"], k), m["floors"][k])
        for k, _, _ in EARLY + LATE
    }
    m["comparable"] = {
        name: {k: comparable(m[name], k) for k, _, _ in EARLY + LATE} for name in ("euler", "event")
    }
    m["dt_1mm_land"] = step_for_error(dts, comparable(m["euler"], "land_x"), 1e-3)
    m["dt_1mm_rest"] = step_for_error(dts, comparable(m["euler"], "rest_x"), 1e-3)

    # 4. Past the first impact: distributions over many torques.
    stat_methods = [Method("event", r) for r in STAT_EVENT_RTOLS] + [
        Method("euler", dt) for dt in STAT_EULER_DTS[size]
    ]
    m["stat_torques"], m["stat_rows"], _ = statistics(driver, stat_methods, STAT_TORQUES[size])
    m["bounce_ref"] = bounce_speeds(params, ref_method, BOUNCE_TORQUE)
    m["bounce_euler"] = bounce_speeds(params, Method("euler", BOUNCE_DT), BOUNCE_TORQUE)

    # 5. The contest's control grid: every switch at a 0.1 s instant.
    grid_refs = {t: driver.run(ref_method, t, 0.5, TIMING_GRID) for t in torques}
    m["grid"] = [
        sweep_point(
            driver, Method(i, v), torques, grid_refs, {t: 0.5 for t in torques}, TIMING_GRID
        )
        for i, v in GRID_METHODS
    ]
    by_label = {p.method.label: p for p in m["euler"] + m["event"]}
    m["default_point"] = by_label[default.label]
    m["euler_1e4_point"] = by_label[Method("euler", 1e-4).label]
    grid_event = [p for p in m["grid"] if p.method.integrator == "event"]
    m["grid_event_rtols"] = [p.method.value for p in grid_event]
    m["grid_identical"] = all(
        np.array_equal(p.runs[t].final, grid_event[0].runs[t].final)
        and p.runs[t].seq == grid_event[0].runs[t].seq
        for p in grid_event
        for t in torques
    )
    return m


def run(quick: bool, fig_dir: str) -> Section:
    t0 = time.perf_counter()
    return accuracy_report.section(measure(quick), fig_dir, t0)
