"""The "Run time against error (work-precision)" section of BENCHMARKS.md, written from
what benchmarks/bench_accuracy.py `measure` returns (no simulation here): the prose
(TEXT, filled by `fields`), the tables, the two figures and the headline."""

from __future__ import annotations

import math
import os
import time

from benchmarks.report import Section, table
from hoprover_env import core

# The prose of the section, paragraph by paragraph; `fields(m)` fills it, the tables
# go between the paragraphs (`markdown`).
SCENARIO = (
    "**Scenario.** Launch torques {torques} N m, each held from rest until the lift-off; "
    "then a PD attitude hold T = -I (kp wrap(theta) + kd omega), kp = {kp}, kd = {kd}, at "
    "control instants {control_dt} s apart from the lift-off on; zero torque from the "
    "first touchdown through the bounces and the slide to rest. The target is the "
    "reference rest position + {target_offset} m, so that the rover stops inside the band "
    "and TTRTP exists. Each run is one call of a numba driver (`run_scenario` in "
    "research/launch_land.py) that loops `core.advance` and computes the PD torque itself: "
    "the wall times are the integrators', not Python's (simulate() with the same "
    "controller in Python takes {python_wall} per run on the contest grid, the driver "
    "{driver_grid_wall}). The driver reproduces simulate() (contest grid) and a RoverSim "
    "loop (event-triggered switches) with a Python controller: largest difference "
    "{check_max:g} over {n_checks} runs (bit for bit). Wall time = the best of up to "
    "{max_runs} runs (a cheap run is repeated for ~{timing_budget} s; runs over 1 s are "
    "timed once), averaged over the launch torques; 'launch wall' is the launch alone "
    "(rest to lift-off), where all of the event integrator's DOP853 stepping happens; a "
    "whole run also has {flight_min:.0f} to {flight_max:.0f} control intervals of flight "
    "(closed form in `event`, Euler steps in `euler`) and the bounces and slide. Machine: "
    "2 cores shared with other work (expect ~10-20 % noise on wall times). Numba "
    "load/compile of the driver: {compile_s:.1f} s (not counted)."
)
REFERENCE = (
    "**Reference and cross-check.** The reference is `event` at rtol {reference_rtol:.0e}; "
    "the API's floor, 1e-15, differs from it by at most {floor_liftoff_t} s in lift-off "
    "time, {floor_land_t} s in landing time, {floor_land_x} m in landing point, "
    "{floor_rest_x} m in rest position and {floor_ttrtp} s in TTRTP (its noise). "
    "Independently, hoprover_env.sim.reference.Ref integrates MODEL.md section 4's corner-A "
    "equations with scipy's DOP853 (rtol 1e-13, atol 1e-16, located events) to the "
    "lift-off; from there the flight is closed form (parabola; theta quadratic between "
    "control instants, the PD torque recomputed at each) and the touchdown is the first "
    "root of the lowest corner's height (Brent). Differences, reference minus scipy:"
)
REFERENCE_RUNS = (
    "The reference runs (c.m. x at the first touchdown; rest position and time; TTRTP for "
    "the target above; the mode sequence, repeats compressed):"
)
WORK_PRECISION = (
    "**Work-precision.** Worst absolute error over the launch torques against the "
    "reference. Lift-off and landing are compared for every run: up to the first impact "
    "the mode sequence is the reference's in {same_early} of {n_runs} runs. Rest position, "
    "rest time and TTRTP are compared only for runs whose whole mode sequence (every "
    "transition and impact, in order) equals the reference's ('same modes'); a '-' means "
    "no run qualified."
)
ORDERS = (
    "**Observed orders.** Least-squares slopes of log(worst error) against log(dt) or "
    "log(rtol) (event: only errors 100x above the reference noise; rest and TTRTP: only "
    "settings where every run kept the reference's mode sequence). `euler` converges at "
    "first order, as explicit Euler with events seen at step ends must: halving dt halves "
    "every error, from the lift-off through the rest position. For 1 mm in the landing "
    "point it needs dt = {dt_1mm_land:.1e} s, for 1 mm in the rest position dt = "
    "{dt_1mm_rest:.1e} s. TTRTP errors are large next to the position errors because the "
    "band is entered while the rover slides slowly on both corners (a position error "
    "divided by a speed of a few mm/s). `event`'s errors fall about in proportion to rtol "
    "(the usual tolerance proportionality of an error-controlled DOP853), down to the "
    "reference noise near rtol 1e-13. Its launch costs {launch_min} to {launch_max} over "
    "the whole rtol range (an 8th-order method's step count grows only like rtol^(-1/8), "
    "and locating the slip and lift-off costs a few re-taken steps at any rtol), and a "
    "whole run costs about the same at every rtol: its wall time is the control intervals "
    "of the flight, each a few closed-form conservative-advancement iterations. At its "
    "default rtol {default_rtol:.0e}, `event` is {speedup:.0f}x faster than `euler` at "
    "dt 1e-4 and its landing-point error is {error_ratio:.0e} times smaller; at first "
    "order `euler` would need dt ~1e-10 s to land within 1e-10 m."
)
STATISTICS = (
    "**Past the first impact: statistics, not points.** After the first impact the mode "
    "sequences of different methods may differ, and then point-by-point errors compare "
    "different stories. Here they differ by extra bounces: a bounce sequence ends when an "
    "impact leaves less than v_ymin = 1e-6 m/s of vertical speed, and Euler, which sees a "
    "touchdown only at the end of the step in which the corner went under the ground, "
    "reads its speed up to g dt too high (~1e-6 m/s at dt = 1e-2, the size of the cut-off "
    "itself), so the last bounce can survive. Vertical speed after each impact [m/s], "
    "launch torque {bounce_torque:g} N m: reference {bounce_ref}; euler dt "
    "{bounce_dt:.0e}: {bounce_euler}. Over {n_stat} launch torques evenly spread in "
    "[3e-5, 5e-4] N m (target 0.5 m), the distribution of rest positions (= hop distance "
    "plus slide; the rover starts at x = 0) against the reference's: W1 is the "
    "Wasserstein-1 distance between the two empirical distributions (no pairing by "
    "torque); the pointwise columns are given for scale."
)
GRID = (
    "**On the contest's control grid.** The same launches, but with every torque switch "
    "at a control instant k 0.1 s (the launch torque until an instant finds the rover "
    "flying, idle from the first instant that finds it on the ground), as simulate() with "
    "a contest controller does. Each DOP853 step is then cut at the next instant, and at "
    "h <= 0.1 s the 8th-order method is at round-off on these slow dynamics (time scales "
    "of seconds): the step-size controller grows the step tenfold per step up to the "
    "0.1 s cap at any of these tolerances, so rtol has no effect there (the runs at rtol "
    "{grid_rtols} are {grid_identical}). Errors against `event` rtol {reference_rtol:.0e} "
    "on the same grid (target 0.5 m):"
)
FIGURES = (
    "_Figures: error against wall time (left to right, top to bottom: lift-off time "
    "against the launch's wall time; landing time, landing point and rest position "
    "against a whole run's), and error against dt / rtol. Measured in {seconds:.0f} s._"
)

XCHECK_HEADER = [
    "torque [N m]",
    "modes",
    "same modes",
    "lift-off t [s]",
    "|d lift-off t| [s]",
    "|d lift-off pos| [m, rad]",
    "|d lift-off vel| [m/s, rad/s]",
    "landing t [s]",
    "|d landing t| [s]",
    "|d landing x| [m]",
]
REFERENCE_HEADER = [
    "torque [N m]",
    "landing x [m]",
    "rest x [m]",
    "rest t [s]",
    "target [m]",
    "TTRTP [s]",
    "mode sequence",
]
ORDER_HEADER = ["quantity", "euler: slope vs dt", "event: slope vs rtol"]
STAT_HEADER = [
    "method",
    "setting",
    "same modes",
    "mean rest x [m]",
    "std [m]",
    "W1 to reference [m]",
    "median |d x| [m]",
    "max |d x| [m]",
    "max |d x|, other modes [m]",
    "impacts/run",
    "differing runs by extra impacts",
    "failed",
]


# ----------------------------------------------------------------------------------
# Figures
# ----------------------------------------------------------------------------------
def _positive(values, floor=1e-16):
    """Errors for a log axis: an exact 0 (bitwise equal results) drawn at `floor`."""
    return [max(v, floor) if math.isfinite(v) else math.nan for v in values]


def work_precision_figure(euler_pts, event_pts, path: str) -> str:
    """Error against wall time, both integrators on each panel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [
        (
            "liftoff_t",
            "launch_wall",
            "lift-off time error [s]",
            "wall time of the launch alone [s]",
        ),
        ("land_t", "wall", "first landing time error [s]", "wall time per run [s]"),
        ("land_x", "wall", "first landing point error [m]", "wall time per run [s]"),
        (
            "rest_x",
            "wall",
            "rest position error [m]\n(same mode sequence only)",
            "wall time per run [s]",
        ),
    ]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    for ax, (key, wall_attr, ylabel, xlabel) in zip(axes.flat, panels):
        for pts, style, name in (
            (euler_pts, "o-", "euler (label: dt)"),
            (event_pts, "s-", "event (label: rtol)"),
        ):
            xs = [getattr(p, wall_attr) for p in pts]
            ys = _positive([p.errors[key] for p in pts])
            ax.loglog(xs, ys, style, label=name)
            for x, y, p in zip(xs, ys, pts):
                if math.isfinite(y):
                    ax.annotate(
                        f"{p.method.value:.0e}",
                        (x, y),
                        fontsize=7,
                        textcoords="offset points",
                        xytext=(4, 3),
                    )
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        "Work-precision: worst error over the launch torques against wall time "
        "(numba driver, no Python in the loop)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def convergence_figure(m: dict, path: str) -> str:
    """Error against the accuracy knob: euler_dt (expect slope 1) and rtol; the errors
    of m["comparable"] (bench_accuracy.comparable)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_e, ax_r) = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, name, xlabel in ((ax_e, "euler", "euler_dt [s]"), (ax_r, "event", "rtol")):
        pts = m[name]
        knobs = [p.method.value for p in pts]
        for key, title, unit in m["early"] + m["late"][:1]:
            (line,) = ax.loglog(
                knobs, _positive(m["comparable"][name][key]), "o-", label=f"{title} [{unit}]"
            )
            if ax is ax_r:  # the reference's own noise in this quantity
                ax.axhline(max(m["floors"][key], 1e-16), color=line.get_color(), ls="--", lw=0.7)
        # a slope-1 guide through the middle of the landing-point curve
        mid = len(pts) // 2
        y_mid = max(pts[mid].errors["land_x"], 1e-16)
        ax.loglog(knobs, [y_mid * k / knobs[mid] for k in knobs], "k:", label="slope 1")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("worst error over the launch torques")
        ax.grid(True, which="both", alpha=0.3)
    ax_e.legend(fontsize=8)
    ax_e.set_title("euler", fontsize=10)
    ax_r.set_title("event (dashed: the reference's own noise, rtol 1e-15 against it)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ----------------------------------------------------------------------------------
# The section
# ----------------------------------------------------------------------------------
def _fmt_s(seconds: float) -> str:
    """A wall time in a readable unit."""
    if not math.isfinite(seconds):
        return "-"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.1f} us"
    if seconds < 1.0:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds:.2f} s"


def _fmt_e(value) -> str:
    if isinstance(value, str):
        return value
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if value == 0.0:
        return "0"
    if math.isinf(value):
        return "inf"
    return f"{value:.2e}"


def describe_seq(seq: tuple) -> str:
    """'tip>B slip>C liftoff>A impact>A ...', run-length compressed."""
    words = [f"{core.EVENT_NAMES[c // 8]}>{core.MODE_LETTERS[c % 8]}" for c in seq]
    out = []
    for w in words:
        if out and out[-1][0] == w:
            out[-1][1] += 1
        else:
            out.append([w, 1])
    return " ".join(w if n == 1 else f"{w} x{n}" for w, n in out)


def sweep_table(points, quantities, with_launch: bool = True) -> str:
    """Worst errors and wall times of each method setting (SweepPoints)."""
    header = (
        ["method", "setting", "wall/run"]
        + (["launch wall"] if with_launch else [])
        + [f"{title} [{unit}]" for _, title, unit in quantities]
        + ["same modes"]
    )
    rows = [
        [p.method.integrator, p.method.label.split(" ", 1)[1], _fmt_s(p.wall)]
        + ([_fmt_s(p.launch_wall)] if with_launch else [])
        + [_fmt_e(p.errors[k]) for k, _, _ in quantities]
        + [f"{p.same_seq}/{p.n_runs}"]
        for p in points
    ]
    return table(header, rows)


def xcheck_table(xcheck) -> str:
    return table(
        XCHECK_HEADER,
        [
            [
                f"{r['torque']:g}",
                r["modes"],
                "yes" if r["same_modes"] else "NO",
                f"{r['liftoff_t']:.6f}",
                _fmt_e(r["d_liftoff_t"]),
                _fmt_e(r["d_liftoff_pos"]),
                _fmt_e(r["d_liftoff_vel"]),
                f"{r['land_t']:.6f}",
                _fmt_e(r["d_land_t"]),
                _fmt_e(r["d_land_x"]),
            ]
            for r in xcheck
        ],
    )


def reference_table(m) -> str:
    refs = m["refs"]
    return table(
        REFERENCE_HEADER,
        [
            [
                f"{t:g}",
                f"{refs[t].land_x:.6f}",
                f"{refs[t].rest_x:.6f}",
                f"{refs[t].rest_t:.4f}",
                f"{m['targets'][t]:.6f}",
                f"{refs[t].ttrtp:.4f}",
                describe_seq(refs[t].seq),
            ]
            for t in m["torques"]
        ],
    )


def order_table(m, quantities) -> str:
    return table(
        ORDER_HEADER,
        [
            [title, f"{m['euler_order'][k]:.2f}", f"{m['event_order'][k]:.2f}"]
            for k, title, _ in quantities
        ],
    )


def stat_table(stat_rows) -> str:
    return table(
        STAT_HEADER,
        [
            [r[0], r[1], r[2]] + [_fmt_e(v) if isinstance(v, float) else v for v in r[3:]]
            for r in stat_rows
        ],
    )


def fields(m: dict) -> dict:
    """The values the prose quotes, formatted where the prose wants a unit chosen."""
    s, floors = m["settings"], m["floors"]
    ev_default, eu_1e4 = m["default_point"], m["euler_1e4_point"]
    sweep = m["euler"] + m["event"]
    return dict(
        s,
        torques=", ".join(f"{t:g}" for t in m["torques"]),
        python_wall=_fmt_s(m["python_wall"]),
        driver_grid_wall=_fmt_s(m["driver_grid_wall"]),
        check_max=m["check_max"],
        n_checks=m["n_checks"],
        max_runs=s["max_repeats"] + 1,
        flight_min=min(m["flight_intervals"]),
        flight_max=max(m["flight_intervals"]),
        compile_s=m["compile_s"],
        **{
            f"floor_{k}": _fmt_e(floors[k])
            for k in ("liftoff_t", "land_t", "land_x", "rest_x", "ttrtp")
        },
        same_early=sum(p.same_early for p in sweep),
        n_runs=sum(p.n_runs for p in sweep),
        dt_1mm_land=m["dt_1mm_land"],
        dt_1mm_rest=m["dt_1mm_rest"],
        launch_min=_fmt_s(min(p.launch_wall for p in m["event"])),
        launch_max=_fmt_s(max(p.launch_wall for p in m["event"])),
        speedup=eu_1e4.wall / ev_default.wall,
        error_ratio=eu_1e4.errors["land_x"] / max(ev_default.errors["land_x"], 1e-300),
        bounce_ref=m["bounce_ref"],
        bounce_euler=m["bounce_euler"],
        n_stat=len(m["stat_torques"]),
        grid_rtols=", ".join(f"{v:.0e}" for v in m["grid_event_rtols"]),
        grid_identical="bit-identical" if m["grid_identical"] else "NOT bit-identical",
    )


def markdown(m: dict) -> str:
    f = fields(m)
    quantities = m["early"] + m["late"]
    return "\n\n".join(
        [
            SCENARIO.format(**f),
            REFERENCE.format(**f),
            xcheck_table(m["xcheck"]),
            REFERENCE_RUNS,
            reference_table(m),
            WORK_PRECISION.format(**f),
            sweep_table(m["euler"] + m["event"], quantities),
            order_table(m, quantities),
            ORDERS.format(**f),
            STATISTICS.format(**f),
            stat_table(m["stat_rows"]),
            GRID.format(**f),
            sweep_table(m["grid"], quantities, with_launch=False),
        ]
    )


def headline(m: dict) -> dict:
    ev_default, eu_1e4 = m["default_point"], m["euler_1e4_point"]
    rtol = m["settings"]["default_rtol"]
    xcheck_t = max(r["d_land_t"] for r in m["xcheck"])
    xcheck_x = max(r["d_land_x"] for r in m["xcheck"])
    order = m["euler_order"]
    return {
        "reference vs scipy (worst, landing t / landing x)": f"{xcheck_t:.1e} s / {xcheck_x:.1e} m",
        "euler order (lift-off t, landing x, rest x)": (
            f"{order['liftoff_t']:.2f}, {order['land_x']:.2f}, {order['rest_x']:.2f}"
        ),
        "euler_dt for 1 mm landing-point error": f"{m['dt_1mm_land']:.1e} s",
        "euler_dt for 1 mm rest-position error": f"{m['dt_1mm_rest']:.1e} s",
        f"event rtol {rtol:.0e}: wall per run, landing-point error": (
            f"{_fmt_s(ev_default.wall)}, {_fmt_e(ev_default.errors['land_x'])} m"
        ),
        "euler dt 1e-4: wall per run, landing-point error": (
            f"{_fmt_s(eu_1e4.wall)}, {_fmt_e(eu_1e4.errors['land_x'])} m"
        ),
        f"wall ratio euler dt 1e-4 / event rtol {rtol:.0e}": (
            f"{eu_1e4.wall / ev_default.wall:.0f}x"
        ),
    }


def section(m: dict, fig_dir: str, t_start: float) -> Section:
    """The section from bench_accuracy.measure's dict (t_start: when measuring began)."""
    figures = [
        work_precision_figure(
            m["euler"], m["event"], os.path.join(fig_dir, "accuracy_work_precision.png")
        ),
        convergence_figure(m, os.path.join(fig_dir, "accuracy_convergence.png")),
    ]
    text = markdown(m) + "\n\n" + FIGURES.format(seconds=time.perf_counter() - t_start)
    return Section(
        title="Run time against error (work-precision)",
        markdown=text,
        figures=figures,
        headline=headline(m),
    )
