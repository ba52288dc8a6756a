"""The "Numerical stability stress" section of BENCHMARKS.md, written from what
benchmarks/bench_stress.py `measure` returns (no simulation here): tables, the energy
histogram, the notes on each violation mechanism still seen, and the headline."""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from benchmarks.report import Section, table
from hoprover_env import RoverParams, core
from hoprover_env.sim.invariants import (
    KINEMATICS_OTHER,
    N_VIOLATION_KINDS,
    PEN_AT_BREAK,
    RECORD_NAMES,
    V_BUDGET,
    V_KINEMATICS,
    V_PEN_EVENT,
    V_PEN_SAMPLE,
    VIOLATION_NAMES,
    WRONG_TILT_ONLY,
)
from research.stress.drivers import (
    B_STATE,
    B_STEP,
    B_TORQUE,
    B_TSTOP,
    HOPPER_FREE,
    HOPPER_HOLD,
    R_BREAKS,
    R_DRIFT_CORNER_VY,
    R_DRIFT_CORNER_Y,
    R_DRIFT_FG_TH,
    R_DRIFT_FG_VY,
    R_DRIFT_FG_W,
    R_DRIFT_FG_Y,
    R_DRIFT_PIVOT_VX,
    R_EVENTS,
    R_IMPACT_SAMPLES,
    R_IMPACTS,
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
)
from research.stress.families import DEFAULT

RUNS_HEADER = (
    [
        "family",
        "integrator",
        "runs",
        "simulated s",
        "control steps",
        "events",
        "impacts",
        "restarts after break",
        "max events / interval",
    ]
    + list(VIOLATION_NAMES[: V_KINEMATICS + 1])
    + ["(wrong tilt)"]
    + list(VIOLATION_NAMES[V_KINEMATICS + 1 :])
    + ["wall s"]
)
DRIFT_HEADER = [
    "family",
    "integrator",
    "single-contact states",
    "max abs y_P",
    "max abs vy_P",
    "pivot max abs vx_P",
    "F/G states",
    "max abs(y - h)",
    "max abs theta",
    "max abs vy",
    "max abs omega",
    "lowest corner m",
]
ENERGY_HEADER = [
    "impacts of",
    "integrator",
    "law",
    "impacts",
    "gaining",
    "fraction",
    "gain p50",
    "p90",
    "p99",
    "max",
    "kernel S_NGAIN",
]
VIOLATIONS_HEADER = ["violation", "control intervals", "runs", "family / integrator / law"]
# the energy histogram's curves: label -> family-name prefixes
HISTOGRAM_FAMILIES = (
    ("1 random hopping", ("1 ",)),
    ("2 extreme torques", ("2 ",)),
    ("3-5 landings", ("3 ", "4", "5 ")),
    ("6 edge parameters", ("6 ",)),
    ("7 control periods", ("7 ",)),
    ("9 terrain", ("9 ",)),
)

TEXT = """{size} Every run is checked after every control interval and right after every impact (the driver stops `core.advance` at each impact and resumes it: {impact_samples:.0f} post-impact states besides {steps:.0f} control-instant samples). Violation kinds, counted once per control interval: **nan** non-finite state; **pen_event** a bottom corner below -1e-9 m at an event (the kernel's S_MIN_HEIGHT); **pen_sample** the same in a checked state; **kinematics** the state letter contradicts the kinematics (`hoprover_env.sim.invariants.check_state`, tolerance 1e-9; "(wrong tilt)" counts those whose only fault is the sign of theta); **energy** an impact gained kinetic energy (ratio > 1 + 1e-12) under `dissipative`; **time** an interval did not end at its stop time; **budget** the event budget of a control interval (`core.event_budget`: {max_events} events for `event`, more for `euler`) ran out. A rover that breaks is restarted upright where it broke. Euler runs use `euler_dt` 1e-3 s.

Families (seeded, family i draws from `numpy.random.default_rng([2015, i])`; {runs} runs): 1 a hopper (random launch torque in [-T_max, T_max] held to lift-off, random rests) for {hop_horizon} s per run at control 0.1 s, holding its attitude in flight with -I (0.15 theta + 0.9 omega), or with no torque in flight; 2 torques +-T_max alternating, random-sign +-T_max and uniform random, switching every control step (0.01, 0.1, 1 s); 3 a hopper pressing the bouncing corner down after each touchdown (control 1e-3..1 s) and drops onto a corner under a pressing torque (control 1e-3..10 s); 4a a corner reaching the ground at 1e-9..1e-5 m/s (set at the touchdown instant, height 0..1e-12 m) or falling from an apex 1e-16..1e-9 m high; 4b landings with theta 1e-14..1e-6 rad; 5 flat landings at 1e-8..1e-2 m/s, sliding or not; 6 random valid parameter sets at the edges of their ranges ({skipped} Painleve sets skipped); 7 control periods 1e-4, 1e-3, 0.01, 0.1, 1, 10 s; 8 the four cases found by this section when it was written (below), replayed every time; 9 terrain: random slopes in [-0.5, 0.5] rad and roughness in [0, 0.3] rad (docs/MODEL.md section 11), each set with its own seeded bumps, a hopper (attitude hold) and uniform random torques. Landings are followed by zero, random or +-T_max torques.

**Checking the checker.** `check_state` passes {good_passed}/{good_total} hand-made consistent states (A-G) and flags {bad_flagged}/{bad_total} states spoiled on purpose. The driver, with and without the stops at impacts, reproduces `simulate` on {checked} runs (up to {max_steps} control steps each; every family `make_state` can start): {agreement} ({cross_wall:.0f} s).

### Runs and violations

{runs_table}

### Worst constraint drift over all checked states

Single contact (B-E): the contact corner's height y_P and vertical velocity vy_P, and a pivot's horizontal velocity vx_P; F/G: the deviation from upright rest. The lowest bottom-corner height includes the kernel's event-time tracking.

{drift_table}

### Energy added by impacts

`KE after / KE before - 1` of the impacts that gained more than 1e-12 (from the event log; the kernel's own count S_NGAIN agrees); quantiles over the gaining impacts. Random hopping (family 1):

{hopping_table}

The `contest` law in every family (and both laws over all runs).{biggest}

{family_table}

### Violations found

{violation_summary}

The first violation of each kind in a run is recorded with the state before its control interval; examples (from different families where possible), replayed:

{violation_examples}

### Notes

{notes}
"""  # noqa: E501 (the report's Markdown, one line a paragraph as it is written out)

# The diagnosis of each mechanism seen while this section was written, printed only
# while its violations still occur (fields filled by `notes`).
NOTE_WRONG_TILT = (
    "**Wrong tilt ({n:.0f} intervals).** After an impact with both bottom corners within "
    "the kernel's H_IMPACT = 1e-9 m of the ground, one corner ends at rest (in contact) and "
    "the other bounces up; `resolve_impact` then puts the resting corner exactly on the "
    "ground (`_set_single_contact`). When the resting corner is the higher one, that lowers "
    "the body by up to 1e-9 m and leaves the rising corner up to 1e-9 m under the ground: a "
    "B/C state with theta < 0 or a D/E state with theta > 0. It lasts microseconds to "
    "milliseconds (until the free corner has risen out), so the control-instant samples of "
    "`tests/sim/test_stress.py` rarely see it; the checks after each impact do."
)
NOTE_SNAPS = (
    "**Penetration below -1e-9 m by repeated snaps ({runs} runs, lowest {lowest:.3g} m).** "
    "The same snap, repeated: a corner left under the ground by one impact (wrong tilt) and "
    "not yet risen out takes part in the next impact of the other corner, whose snap lowers "
    "the body again, so the depths add up. In flight, a corner that starts under the ground "
    "is not armed and may sink further before its touchdown guard fires. The `kinematics: "
    "other` cases are these states (a corner more than 1e-9 m under the ground)."
)
NOTE_AT_BREAK = (
    "**Penetration at a break ({n:.0f} intervals, {integrators}; lowest {lowest:.3g} m).** "
    "The Euler step that carries a top corner to the ground ends the run as broken before "
    "the bottom corners are put back on the ground (`_euler_ground_check` tests the top "
    "corners first), so at the breaking instant a bottom corner can be one step's motion "
    "under the ground (a tall rover falling on its side). `tests/sim/test_stress.py` would see "
    "it through `Rollout.min_corner_height`."
)
NOTE_BUDGET_EVENT = (
    "**Event budget, `event` integrator ({n:.0f} intervals).** A corner that bounces is "
    "armed for its next touchdown only after rising above H_TOL = 1e-12 m. When a torque "
    "presses it down hard (acceleration a) and the bounce is slow, the hop's apex v^2 / 2a "
    "is a few 1e-12 m, and the conservative-advancement steps can jump over the part of the "
    "hop above H_TOL (in one step when their bound K is close to a, as on a wide, flat "
    "rover); the corner is then never armed and touches down at -1e-12 m, gaining 2 a H_TOL "
    "of vertical kinetic energy. The bounce speed no longer tends to 0 but to at most "
    "v* = e_y sqrt(2 a H_TOL / (1 - e_y^2)); above v_ymin the sequence never ends (an "
    "impact every ~1e-5 s) and the interval runs out of events. It needs a of order "
    "v_ymin^2 / (2 H_TOL) = 0.5 m/s^2 and a high e_y: seen only with edge parameter sets "
    "(light rovers, large T/I, e_y 0.8 and more)."
)
NOTE_EULER = (
    "**Euler micro-bounces{budget}.** The `euler` baseline needs up to {euler:.0f} events "
    "in one control interval (`event`: {event:.0f}; runs that ran out left out). A corner "
    "pressed down (acceleration a, by a torque or the rotation) bounces every other Euler "
    "step: rising at v after a bounce, it moves at v - a dt one step later and is under the "
    "ground the next, where the impact returns e_y (2 a dt - v). The bounce speed tends to "
    "2 e_y a dt / (1 + e_y), which for dt = 1e-3 s, e_y = 0.2 exceeds v_ymin once "
    "a > 3e-3 m/s^2 (|T| above ~1e-4 N m on a corner 0.05 m from the c.m.): the corner "
    "never comes to rest, 500 impacts per simulated second until the rover lifts or tips; "
    "Euler's event budget per control interval therefore grows with its steps "
    "({max_events} + 4 per step, `core.event_budget`)."
)
NOTE_RESTARTS = (
    "Simulated time counts the whole horizon of every run; a rover that broke "
    "was restarted upright at rest ({n:.0f} restarts in all)."
)


def _sci(v: float) -> str:
    return "0" if v == 0 else f"{v:.1e}"


def quantiles(gains: np.ndarray):
    if gains.size == 0:
        return ["-"] * 4
    q = np.quantile(gains, [0.5, 0.9, 0.99, 1.0])
    return [f"{100 * v:.3g} %" for v in q]


def energy_histogram(gains_by_label: dict, path: str):
    """Histogram of log10(relative kinetic-energy gain) of the gaining impacts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4))
    top = max([1.0] + [float(np.log10(g.max())) + 0.25 for g in gains_by_label.values() if g.size])
    bins = np.arange(-12.0, top + 0.25, 0.25)
    for label, gains in gains_by_label.items():
        if gains.size:
            ax.hist(
                np.log10(np.clip(gains, 1e-12, None)),
                bins=bins,
                histtype="step",
                linewidth=1.5,
                label=f"{label} ({gains.size} impacts)",
            )
    ax.set_yscale("log")
    ax.axvline(0.0, color="grey", linewidth=0.8, linestyle=":")
    ax.set_xlabel("log10(KE after / KE before - 1), impacts that gained energy")
    ax.set_ylabel("impacts")
    ax.set_title("Energy added by the contest impact law (event integrator)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def runs_table(groups) -> str:
    rows = []
    for (family, integ), g in groups:
        r = g.r
        v = [f"{r[R_VIOLATIONS + k]:.0f}" for k in range(N_VIOLATION_KINDS)]
        rows.append(
            [
                family,
                integ,
                g.runs,
                f"{r[R_SIM_SECONDS]:.3g}",
                f"{r[R_STEPS]:.3g}",
                f"{r[R_EVENTS]:.0f}",
                f"{r[R_IMPACTS]:.0f}",
                f"{r[R_BREAKS]:.0f}",
                f"{r[R_MAX_EVENTS_PER_STEP]:.0f}",
            ]
            + v[: V_KINEMATICS + 1]
            + [f"{r[R_WRONG_TILT]:.0f}"]
            + v[V_KINEMATICS + 1 :]
            + [f"{g.wall:.1f}"]
        )
    return table(RUNS_HEADER, rows)


def drift_table(groups) -> str:
    rows = []
    for (family, integ), g in groups:
        r = g.r
        rows.append(
            [
                family,
                integ,
                f"{r[R_SAMPLES_SINGLE]:.3g}",
                _sci(r[R_DRIFT_CORNER_Y]),
                _sci(r[R_DRIFT_CORNER_VY]),
                _sci(r[R_DRIFT_PIVOT_VX]),
                f"{r[R_SAMPLES_DOUBLE]:.3g}",
                _sci(r[R_DRIFT_FG_Y]),
                _sci(r[R_DRIFT_FG_TH]),
                _sci(r[R_DRIFT_FG_VY]),
                _sci(r[R_DRIFT_FG_W]),
                f"{r[R_MIN_HEIGHT]:.4g}",
            ]
        )
    return table(DRIFT_HEADER, rows)


def _energy_row(what, integ, law, acc):
    n_imp, n_gain, n_kernel, gain_list = acc
    gains = np.concatenate(gain_list) if gain_list else np.zeros(0)
    return (
        [what, integ, law, f"{n_imp:.0f}", f"{n_gain:.0f}", f"{100 * n_gain / max(n_imp, 1):.2f} %"]
        + quantiles(gains)
        + [f"{n_kernel:.0f}"]
    )


def gain_histogram_data(by_family: dict) -> dict:
    """label -> the gains of the `event`, `contest` runs of those families."""
    return {
        name: np.concatenate(
            [np.zeros(0)]
            + [
                g
                for (fam, integ, law), acc in by_family.items()
                if fam.startswith(prefixes) and integ == "event" and law == "contest"
                for g in acc[3]
            ]
        )
        for name, prefixes in HISTOGRAM_FAMILIES
    }


def _reproducer(res, kind: int, replayed: list) -> str:
    """A replayable description of a run's first violation of record `kind`."""
    spec, record = res.spec, res.bad[kind]
    state = ", ".join(repr(float(v)) for v in record[B_STATE:])
    params = {
        f.name: getattr(spec.params, f.name)
        for f in dataclasses.fields(RoverParams)
        if getattr(spec.params, f.name) != getattr(DEFAULT, f.name)
    }
    found = [f for f in replayed if f[2] & (1 << kind)]
    seen = (
        "; ".join(
            f"at t = {t!r} s after {', '.join(ev[-3:]) or 'no event'}"
            f"{' (and ' + str(len(ev) - 3) + ' more events)' if len(ev) > 3 else ''}"
            f": {text}"
            for t, ev, m, text in found[:1]
        )
        or "not reproduced"
    )
    return (
        f"  * {spec.family}, {spec.integrator}, {spec.law} ({spec.label}), control step "
        f"{int(record[B_STEP])}. Replay {seen}.\n"
        f"    Reproducer: `S = np.array([{state}])`; params "
        f"{params or 'contest defaults'}; then `core.advance(S, P, "
        f"make_options({spec.integrator!r}, {spec.law!r}), {float(record[B_TORQUE])!r}, "
        f"{float(record[B_TSTOP])!r}, ev, W)`, called again while S[S_STOPPED] "
        "(S[S_STOP_ON] = 4: each call stops after an impact)."
    )


def violations_report(records) -> tuple[str, str]:
    """(summary table, reproducers) of bench_stress.violation_records."""
    rows, text = [], []
    for k, hit, examples in records:
        count = {
            WRONG_TILT_ONLY: R_WRONG_TILT,
            KINEMATICS_OTHER: R_KINEMATICS_OTHER,
            PEN_AT_BREAK: R_PEN_AT_BREAK,
        }.get(k, R_VIOLATIONS + k)
        where = sorted({f"{r.spec.family} / {r.spec.integrator} / {r.spec.law}" for r in hit})
        rows.append(
            [RECORD_NAMES[k], f"{sum(r.r[count] for r in hit):.0f}", len(hit), "; ".join(where)]
        )
        text.append(
            f"* **{RECORD_NAMES[k]}** ({len(hit)} runs):\n"
            + "\n".join(_reproducer(res, k, found) for res, found in examples)
        )
    if not rows:
        return "None: every checked state of every run was consistent.", ""
    return table(VIOLATIONS_HEADER, rows), "\n".join(text)


def notes(results, r) -> list:
    """The notes that apply to these results (r: the totals)."""
    out = []
    if r[R_WRONG_TILT]:
        out.append(NOTE_WRONG_TILT.format(n=r[R_WRONG_TILT]))
    pen_snap = [
        res
        for res in results
        if res.r[R_KINEMATICS_OTHER]
        or res.r[R_VIOLATIONS + V_PEN_SAMPLE]
        or res.r[R_VIOLATIONS + V_PEN_EVENT] > res.r[R_PEN_AT_BREAK]
    ]
    if pen_snap:
        out.append(
            NOTE_SNAPS.format(
                runs=len(pen_snap), lowest=min(res.r[R_MIN_HEIGHT] for res in pen_snap)
            )
        )
    if r[R_PEN_AT_BREAK]:
        at_break = [res for res in results if res.r[R_PEN_AT_BREAK]]
        out.append(
            NOTE_AT_BREAK.format(
                n=r[R_PEN_AT_BREAK],
                lowest=min(res.r[R_MIN_HEIGHT] for res in at_break),
                integrators=", ".join(sorted({res.spec.integrator for res in at_break})),
            )
        )

    def budget(integrator):
        return sum(
            res.r[R_VIOLATIONS + V_BUDGET] for res in results if res.spec.integrator == integrator
        )

    def max_events(integrator):
        return max(
            (
                res.r[R_MAX_EVENTS_PER_STEP]
                for res in results
                if res.spec.integrator == integrator and not res.r[R_VIOLATIONS + V_BUDGET]
            ),
            default=0,
        )

    if budget("event"):
        out.append(NOTE_BUDGET_EVENT.format(n=budget("event")))
    budget_euler = budget("euler")
    out.append(
        NOTE_EULER.format(
            budget=f" and event budget ({budget_euler:.0f} intervals)" if budget_euler else "",
            euler=max_events("euler"),
            event=max_events("event"),
            max_events=core.MAX_EVENTS,
        )
    )
    out.append(NOTE_RESTARTS.format(n=r[R_BREAKS]))
    return out


def hop_stats(hopping: dict, name: str) -> tuple:
    """(% of impacts gaining energy, largest gain in %) of a hopper, `event`, `contest`."""
    accs = [
        acc
        for (label, integ, law), acc in hopping.items()
        if label == name and integ == "event" and law == "contest"
    ]
    n_imp = sum(a[0] for a in accs)
    n_gain = sum(a[1] for a in accs)
    gains = np.concatenate([g for a in accs for g in a[3]] or [np.zeros(0)])
    return 100 * n_gain / max(n_imp, 1), 100 * (gains.max() if gains.size else 0.0)


def section(m: dict, fig_dir: str) -> Section:
    """The section from bench_stress.measure's dict."""
    results, total = m["results"], m["total"]
    r = total.r
    os.makedirs(fig_dir, exist_ok=True)
    fig_path = os.path.join(fig_dir, "stress_energy_gain.png")
    energy_histogram(gain_histogram_data(m["by_family"]), fig_path)
    biggest = max(
        (res for res in results if res.spec.law == "contest" and res.gains.size),
        key=lambda res: res.gains.max(),
        default=None,
    )
    summary, examples = violations_report(m["violations"])
    passed, n_good, flagged, n_bad = m["self_test"]
    agreement = (
        "identical final states, event counts and energy gains, and the same "
        "kinematic and penetration verdicts as `hoprover_env.sim.invariants`"
        if not m["disagreements"]
        else "**disagreements**: " + "; ".join(m["disagreements"])
    )
    md = TEXT.format(
        size="Quick sizes (the test suite runs this)." if m["quick"] else "Full sizes.",
        impact_samples=r[R_IMPACT_SAMPLES],
        steps=r[R_STEPS],
        max_events=core.MAX_EVENTS,
        runs=total.runs,
        hop_horizon="1e4" if m["quick"] else "1e5",
        skipped=m["skipped"],
        good_passed=passed,
        good_total=n_good,
        bad_flagged=flagged,
        bad_total=n_bad,
        checked=m["checked"],
        max_steps=m["max_steps"],
        agreement=agreement,
        cross_wall=m["cross_wall"],
        runs_table=runs_table(m["groups"]),
        drift_table=drift_table(m["groups"]),
        hopping_table=table(
            ENERGY_HEADER, [_energy_row(*k, acc) for k, acc in sorted(m["hopping"].items())]
        ),
        biggest=""
        if biggest is None
        else (
            f" The largest gain, x{1 + biggest.gains.max():.3g} in kinetic energy, came in "
            f"{biggest.spec.family} ({biggest.spec.integrator}; {biggest.spec.label})."
        ),
        family_table=table(
            ENERGY_HEADER,
            [
                _energy_row(*k, acc)
                for k, acc in m["by_family"].items()
                if k[2] == "contest" or k[0] == "**all**"
            ],
        ),
        violation_summary=summary,
        violation_examples=examples,
        notes="\n".join(f"* {n}" for n in notes(results, r)),
    )
    hold_frac, hold_max = hop_stats(m["hopping"], HOPPER_HOLD)
    free_frac, free_max = hop_stats(m["hopping"], HOPPER_FREE)
    headline = {
        "stress runs": total.runs,
        "stress simulated s": float(f"{r[R_SIM_SECONDS]:.3g}"),
        "stress events": int(r[R_EVENTS]),
        "stress violations": int(r[R_VIOLATIONS:].sum()),
        "stress violations by kind": {
            name: int(r[R_VIOLATIONS + v]) for v, name in enumerate(VIOLATION_NAMES)
        },
        "contest law, hopping with attitude hold: impacts gaining energy": (
            f"{hold_frac:.1f} % (max +{hold_max:.1f} %)"
        ),
        "contest law, hopping without attitude control: impacts gaining energy": (
            f"{free_frac:.1f} % (max +{free_max:.1f} %)"
        ),
        "stress wall s": round(m["wall"]),
    }
    return Section("Numerical stability stress", md, [fig_path], headline)
