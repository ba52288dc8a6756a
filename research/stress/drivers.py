"""The checking driver of the stability stress benchmark (its stress controllers:
research/stress/controllers.py).

`drive` runs one rover under a stress controller with `core.advance`, and checks the
state (hoprover_env.sim.invariants.check_state) after every control interval and, optionally,
right after every impact: it lets `core.advance` stop at each impact, through the
kernel's stop-on-event slot, checks, and resumes (the physics is unchanged:
benchmarks/bench_stress.py cross-checks the driver against `simulate`). Some stress
runs take 1e7 control steps, which a Python loop through `simulate` and a Python
controller would make minutes long; the driver runs them in compiled code.

The controllers (`control_torque`, controllers.py): a torque schedule, optionally with
the attitude hold in flight, and a randomised hopper that rests, launches, flies, lands
and may press its bouncing corner into the ground. `contest_controller` wraps the same
jitted controller behind the contest signature, for `simulate`. `execute(RunSpec)` runs one
spec; `replay` re-runs the control interval of a recorded violation.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from hoprover_env import RoverParams, core
from hoprover_env.core.params import P_H
from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.invariants import (
    D_CORNER_VY,
    D_CORNER_Y,
    D_FG_TH,
    D_FG_VY,
    D_FG_W,
    D_FG_Y,
    D_MIN_HEIGHT,
    D_PIVOT_VX,
    D_SAMPLES_DOUBLE,
    D_SAMPLES_SINGLE,
    KINEMATIC_TOL,
    KINEMATICS_OTHER,
    N_DRIFT,
    N_RECORDS,
    N_VIOLATION_KINDS,
    PEN_AT_BREAK,
    PENETRATION_TOL,
    V_BUDGET,
    V_ENERGY,
    V_NAN,
    V_PEN_EVENT,
    V_TIME,
    WRONG_TILT_ONLY,
    check_state,
    finite_state,
    gained_energy,
    new_drift,
)
from hoprover_env.sim.simulate import make_options, make_state
from research.stress.controllers import (
    M_PHASE,
    M_REST,
    M_T_MARK,
    N_MEM,
    PHASE_REST,
    control_torque,
)

# Result slots of one driver call (R_*), a flat float vector: counters, then the drift
# record of hoprover_env.sim.invariants (D_* slots, from R_DRIFT on), then more counters and
# one count per violation kind.
R_STEPS, R_SIM_SECONDS, R_EVENTS, R_IMPACTS, R_GAINS, R_KERNEL_GAINS, R_BREAKS = range(7)
R_DRIFT = 7
(
    R_GAINS_STORED,
    R_MAX_EVENTS_PER_STEP,
    R_IMPACT_SAMPLES,
    R_WRONG_TILT,
    R_KINEMATICS_OTHER,
    R_PEN_AT_BREAK,
    R_VIOLATIONS,
) = range(R_DRIFT + N_DRIFT, R_DRIFT + N_DRIFT + 7)
(
    R_SAMPLES_SINGLE,
    R_SAMPLES_DOUBLE,
    R_MIN_HEIGHT,
    R_DRIFT_CORNER_Y,
    R_DRIFT_CORNER_VY,
    R_DRIFT_PIVOT_VX,
    R_DRIFT_FG_Y,
    R_DRIFT_FG_TH,
    R_DRIFT_FG_VY,
    R_DRIFT_FG_W,
) = (
    R_DRIFT + d
    for d in (
        D_SAMPLES_SINGLE,
        D_SAMPLES_DOUBLE,
        D_MIN_HEIGHT,
        D_CORNER_Y,
        D_CORNER_VY,
        D_PIVOT_VX,
        D_FG_Y,
        D_FG_TH,
        D_FG_VY,
        D_FG_W,
    )
)
N_RESULTS = R_VIOLATIONS + N_VIOLATION_KINDS

# The first violation of each kind in a run (a row per RECORD_NAMES entry), enough to
# replay it with core.advance: (found?, torque command, t_stop, control step, the
# state S before that control interval).
B_FOUND, B_TORQUE, B_TSTOP, B_STEP, B_STATE = range(5)
N_BAD = B_STATE + core.N_STATE


@kernel
def _restart_upright(S, P, stop_on):
    """After a break: the rover at rest upright where it broke, at the same time.
    init_state clears the kernel's counters; the caller has banked them."""
    t = S[core.S_T]
    core.init_state(S, P, S[core.S_X], P[P_H], 0.0, 0.0, 0.0, 0.0, S[core.S_XT])
    S[core.S_T] = t
    S[core.S_STOP_ON] = stop_on


@kernel
def _scan_impacts(ev, n, law, R, gains, n_stored):
    """Count the impacts in the first n rows of the event log (value = KE after / KE
    before) and keep the relative gains. Returns (n_stored, energy violation?)."""
    gained_under_dissipative = False
    for j in range(min(n, ev.shape[0])):
        if int(ev[j, 1]) == core.EV_IMPACT:
            R[R_IMPACTS] += 1.0
            ratio = ev[j, 4]
            if gained_energy(ratio):
                R[R_GAINS] += 1.0
                if n_stored < gains.shape[0]:
                    gains[n_stored] = ratio - 1.0
                    n_stored += 1
                if law == core.LAW_DISSIPATIVE:
                    gained_under_dissipative = True
    return n_stored, gained_under_dissipative


@kernel
def drive(
    S,
    P,
    O,
    kind,
    C,
    sched,
    rand,
    mem,
    control_dt,
    t_end,
    restart_on_break,
    sample_impacts,
    ev,
    W,
    S_before,
    R,
    gains,
    bad,
):
    """Run one rover from S to t_end under controller `kind`, checking every sample.

    The control instants are those of `simulate` (k control_dt, the last one clipped to
    t_end). With `sample_impacts` each control interval is advanced in pieces that end
    right after every impact (the kernel's stop-on-event mechanism), and the
    post-impact state is checked too; the event budget of the interval (the kernel's
    `event_budget`, which then sees only one piece) is enforced here.
    R receives the counters (R_* slots, added to what is there), `gains` the relative
    energy gains (ratio - 1) of the impacts that gained energy (as many as fit), row k
    of `bad` the first violation of kind k (B_* slots). Returns the number of gains
    stored. Stops early only when a violation makes going on meaningless (nan, event
    budget).
    """
    law = int(O[core.O_LAW])
    n_ctrl = max(1, int(math.ceil(t_end / control_dt - 1e-9)))
    n_stored = int(R[R_GAINS_STORED])
    for k in range(N_RECORDS):
        bad[k, B_FOUND] = 0.0
    stop_on = float(core.EV_IMPACT) if sample_impacts else -1.0
    S[core.S_STOP_ON] = stop_on
    drift = R[R_DRIFT : R_DRIFT + N_DRIFT]
    mask = check_state(S, P, KINEMATIC_TOL, drift)
    for step in range(n_ctrl):
        t_stop = min((step + 1) * control_dt, t_end)
        cmd = control_torque(
            kind,
            S[core.S_X],
            S[core.S_Y],
            S[core.S_TH],
            S[core.S_VX],
            S[core.S_VY],
            S[core.S_W],
            int(S[core.S_MODE]),
            S[core.S_T],
            step,
            P,
            C,
            sched,
            rand,
            mem,
        )
        for i in range(core.N_STATE):
            S_before[i] = S[i]
        t_before = S[core.S_T]
        n_interval = 0
        while True:
            t_piece = S[core.S_T]
            n = core.advance(S, P, O, cmd, t_stop, ev, W)
            n_interval += n
            n_stored, gained = _scan_impacts(ev, n, law, R, gains, n_stored)
            if gained:
                mask |= 1 << V_ENERGY
            if S[core.S_MIN_HEIGHT] < R[R_MIN_HEIGHT]:
                R[R_MIN_HEIGHT] = S[core.S_MIN_HEIGHT]
            if S[core.S_ERROR] != 0.0 or n_interval > core.event_budget(O, t_stop - t_before):
                mask |= 1 << V_BUDGET
                break
            if S[core.S_T] < t_piece:
                mask |= 1 << V_TIME
            if S[core.S_STOPPED] == 0.0 or S[core.S_BROKEN] != 0.0:
                break
            # stopped right after an impact: check that state as a sample too
            R[R_IMPACT_SAMPLES] += 1.0
            mask |= check_state(S, P, KINEMATIC_TOL, drift)
            if S[core.S_T] >= t_stop:
                S[core.S_STOPPED] = 0.0
                break
        R[R_STEPS] += 1.0
        if n_interval > R[R_MAX_EVENTS_PER_STEP]:
            R[R_MAX_EVENTS_PER_STEP] = n_interval
        broken = S[core.S_BROKEN] != 0.0
        if S[core.S_MIN_HEIGHT] < -PENETRATION_TOL:
            mask |= 1 << V_PEN_EVENT
            if broken:
                mask |= 1 << PEN_AT_BREAK
        if not (S[core.S_T] > t_before and (broken or S[core.S_T] == t_stop)):
            if not mask & (1 << V_BUDGET):
                mask |= 1 << V_TIME
        if broken:
            # the breaking instant: a top corner on the ground, no contact letter applies
            if not finite_state(S):
                mask |= 1 << V_NAN
        else:
            mask |= check_state(S, P, KINEMATIC_TOL, drift)
        if mask != 0:
            for v in range(N_VIOLATION_KINDS):
                if mask & (1 << v):
                    R[R_VIOLATIONS + v] += 1.0
            if mask & (1 << WRONG_TILT_ONLY):
                R[R_WRONG_TILT] += 1.0
            if mask & (1 << KINEMATICS_OTHER):
                R[R_KINEMATICS_OTHER] += 1.0
            if mask & (1 << PEN_AT_BREAK):
                R[R_PEN_AT_BREAK] += 1.0
            for k in range(N_RECORDS):
                if mask & (1 << k) and bad[k, B_FOUND] == 0.0:
                    bad[k, B_FOUND] = 1.0
                    bad[k, B_TORQUE] = cmd
                    bad[k, B_TSTOP] = t_stop
                    bad[k, B_STEP] = step
                    for i in range(core.N_STATE):
                        bad[k, B_STATE + i] = S_before[i]
            if mask & ((1 << V_NAN) | (1 << V_BUDGET)):
                break  # the state is unusable: end the run here
            mask = 0
            S[core.S_MIN_HEIGHT] = np.inf  # report each penetration once
        if broken:
            if not restart_on_break:
                break
            R[R_BREAKS] += 1.0
            R[R_EVENTS] += S[core.S_NEVENTS]
            R[R_KERNEL_GAINS] += S[core.S_NGAIN]
            _restart_upright(S, P, stop_on)
            mem[M_PHASE] = PHASE_REST
            mem[M_T_MARK] = S[core.S_T]
            mem[M_REST] = 0.0
    R[R_SIM_SECONDS] += S[core.S_T]
    R[R_EVENTS] += S[core.S_NEVENTS]
    R[R_KERNEL_GAINS] += S[core.S_NGAIN]
    R[R_GAINS_STORED] = n_stored
    return n_stored


HOPPER_HOLD = "hopper, attitude hold"
HOPPER_FREE = "hopper, no attitude control"
TARGET_X = 0.3  # band crossings add judge events to every family
GAIN_CAPACITY = 200_000  # energy gains kept per run (for the quantiles)


@dataclasses.dataclass
class RunSpec:
    """Everything one run needs; `state` is a full kernel state vector at t = 0."""

    family: str
    integrator: str
    law: str
    params: RoverParams
    state: np.ndarray
    kind: int
    ctrl: np.ndarray
    sched: np.ndarray
    rand: np.ndarray
    control_dt: float
    t_end: float
    euler_dt: float = 1e-3
    label: str = ""  # what is special about this run (for reproducers)
    initial: tuple | None = None  # (x, y, th, vx, vy, w) when make_state accepts it

    def options(self) -> np.ndarray:
        return make_options(self.integrator, self.law, euler_dt=self.euler_dt)

    def seed(self) -> int | None:
        """The seed of the run's rough-terrain bumps (None on smooth ground), read back
        from the state's two 32-bit halves (for a `simulate` replay)."""
        if self.params.roughness == 0.0:
            return None
        return int(self.state[core.S_SEED_LO]) + (int(self.state[core.S_SEED_HI]) << 32)

    def fresh_memory(self) -> np.ndarray:
        mem = np.zeros(N_MEM)
        mem[M_PHASE] = PHASE_REST
        return mem


@dataclasses.dataclass
class RunResult:
    spec: RunSpec
    r: np.ndarray  # R_* counters
    gains: np.ndarray  # ratio - 1 of the impacts that gained energy
    bad: np.ndarray  # the first violation of each kind (rows, B_* slots)
    final: np.ndarray  # the kernel state at the end
    wall: float


def new_results() -> np.ndarray:
    r = np.zeros(N_RESULTS)
    r[R_MIN_HEIGHT] = np.inf
    return r


def execute(spec: RunSpec, restart_on_break=True, sample_impacts=True) -> RunResult:
    """Run one spec through the jitted driver."""
    s = spec.state.copy()
    r = new_results()
    gains = np.zeros(GAIN_CAPACITY)
    bad = np.zeros((N_RECORDS, N_BAD))
    ev = np.zeros((core.MAX_EVENTS + 64, core.EV_COLS))
    t0 = time.perf_counter()
    n = drive(
        s,
        spec.params.as_array(),
        spec.options(),
        spec.kind,
        spec.ctrl,
        spec.sched,
        spec.rand,
        spec.fresh_memory(),
        spec.control_dt,
        spec.t_end,
        restart_on_break,
        sample_impacts,
        ev,
        np.zeros(core.N_WORK),
        np.zeros(core.N_STATE),
        r,
        gains,
        bad,
    )
    return RunResult(spec, r, gains[:n].copy(), bad, s, time.perf_counter() - t0)


def upright(params: RoverParams) -> tuple:
    """MODEL.md section 9: at rest on both corners."""
    return (0.0, params.half_height, 0.0, 0.0, 0.0, 0.0)


def state_from(params: RoverParams, initial) -> np.ndarray:
    return make_state(params, TARGET_X, initial)


def flight_state_at(params: RoverParams, x, y, th, vx, vy, w) -> np.ndarray:
    """A flight (state A) kernel state set directly, for the grazing cases make_state
    refuses on purpose (a corner within 1e-9 m of the ground moving down is an impact,
    not a state): built high in the air, then moved into place."""
    s = make_state(params, TARGET_X, (x, y + 1.0, th, vx, vy, w))
    s[core.S_Y] = y
    return s


def contest_controller(spec: RunSpec):
    """The run's controller behind the contest signature, for `simulate`."""
    pa = spec.params.as_array()
    mem = spec.fresh_memory()
    step = [0]

    def control(pos, vel, the, omg, posT, t, smt, state):
        cmd = control_torque(
            spec.kind,
            float(pos[0]),
            float(pos[1]),
            float(the),
            float(vel[0]),
            float(vel[1]),
            float(omg),
            core.MODE_LETTERS.index(state),
            float(t),
            step[0],
            pa,
            spec.ctrl,
            spec.sched,
            spec.rand,
            mem,
        )
        step[0] += 1
        return cmd

    return control


def explain_sample(s: np.ndarray, p: RoverParams) -> str:
    """A state's contact letter and corner kinematics, in words."""
    pa = p.as_array()
    th = s[core.S_TH]
    mode = core.MODE_LETTERS[int(s[core.S_MODE])]
    (dxa, dya), (dxb, dyb) = core.corner_offset(pa, 0, th), core.corner_offset(pa, 1, th)
    ya, yb = s[core.S_Y] + dya, s[core.S_Y] + dyb
    vya, vyb = s[core.S_VY] - s[core.S_W] * dxa, s[core.S_VY] - s[core.S_W] * dxb
    wth = core.wrap_angle(th)
    return (
        f"state {mode}, theta {wth:.3e} rad, omega {s[core.S_W]:.3e} rad/s, "
        f"corner A at {ya:.3e} m moving {vya:+.3e} m/s, corner B at {yb:.3e} m "
        f"moving {vyb:+.3e} m/s"
    )


def replay(spec: RunSpec, record: np.ndarray):
    """Re-run the control interval of a recorded violation (a row of RunResult.bad)
    with core.advance, stopping after every impact as the driver does. Returns a list
    of (time, event names since the last check, mask, explanation) for each checked
    state that fails."""
    s = record[B_STATE:].copy()
    pa, opts = spec.params.as_array(), spec.options()
    ev = np.zeros((core.MAX_EVENTS + 64, core.EV_COLS))
    w = np.zeros(core.N_WORK)
    found = []
    n_interval = 0
    budget = core.event_budget(opts, float(record[B_TSTOP]) - float(s[core.S_T]))
    for _ in range(budget + 2):
        n = core.advance(s, pa, opts, float(record[B_TORQUE]), float(record[B_TSTOP]), ev, w)
        n_interval += n
        names = [core.EVENT_NAMES[int(ev[i, 1])] for i in range(min(n, len(ev)))]
        mask = check_state(s, pa, KINEMATIC_TOL, new_drift())
        if s[core.S_MIN_HEIGHT] < -PENETRATION_TOL:
            mask |= 1 << V_PEN_EVENT
        if s[core.S_ERROR] != 0.0 or n_interval > budget:
            mask |= 1 << V_BUDGET
        if mask:
            found.append((float(s[core.S_T]), names, mask, explain_sample(s, spec.params)))
        if (
            not s[core.S_STOPPED]
            or s[core.S_BROKEN]
            or s[core.S_ERROR]
            or s[core.S_T] >= record[B_TSTOP]
        ):
            break
    return found
