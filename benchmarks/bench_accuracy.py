"""Run time against error (work-precision): the `event` integrator against `euler`.

    PYTHONPATH=. python -m benchmarks --only accuracy [--quick]

What is measured, in the order the code does it:

1. The scenario. From rest, a constant launch torque (several levels) is held until
   the rover lifts off; a PD attitude hold T = -I (kp wrap(theta) + kd omega) runs at
   control instants 0.1 s apart during the flight; the torque is zero from the first
   touchdown on, through the bounces and the final slide, until the rover rests (F)
   and the judge has decided. The whole run is one call of a small numba driver
   (`run_scenario`) that loops `core.advance` itself, so the wall time is the
   integrators' and not Python's (a Python controller costs ~8 us per control step,
   more than the event integrator's whole flight step).
2. The reference: `event` at rtol REFERENCE_RTOL, cross-checked against an
   independent solution: tests/reference.py (MODEL.md section 4 integrated by scipy's
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
"""
from __future__ import annotations

import dataclasses
import importlib.util
import math
import os
import time

import numpy as np
from numba import njit
from scipy.optimize import brentq
from scipy.stats import wasserstein_distance

from benchmarks.report import Section, table
from hoprover_env import RoverParams, RoverSim, simulate
from hoprover_env import core
from hoprover_env.params import P_I
from hoprover_env.simulate import make_options, make_state


# ----------------------------------------------------------------------------------
# The scenario: launch, attitude hold in flight, idle once landed
# ----------------------------------------------------------------------------------
KP, KD = 0.15, 0.9          # PD attitude hold in flight [1/s^2, 1/s]
CONTROL_DT = 0.1            # s between control instants
T_END = 600.0               # s, a cap; a run ends once the rover rests and is judged
TARGET_OFFSET = 0.02        # m: target = reference rest x + this (rests inside the band)

# Launch torques of the point-by-point comparison [N m], and how many evenly spread
# ones the statistics use.
TORQUES = {"quick": (3e-5, 2e-4, 5e-4), "full": (3e-5, 6e-5, 1e-4, 2e-4, 3.5e-4, 5e-4)}
STAT_TORQUES = {"quick": 12, "full": 40}
EULER_DTS = {"quick": (1e-2, 3e-3, 1e-3, 3e-4, 1e-4),
             "full": (1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6)}
EVENT_RTOLS = {"quick": (1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12),
               "full": (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13)}
STAT_EULER_DTS = {"quick": (1e-2, 1e-3, 1e-4), "full": (1e-2, 1e-3, 1e-4, 1e-5)}
STAT_EVENT_RTOLS = (1e-6, 1e-11)
GRID_METHODS = (("event", 1e-4), ("event", 1e-8), ("event", 1e-11), ("euler", 1e-3))
# The reference. 1e-15, the API's floor, moves the landing times by ~1e-13 s only
# (round-off); 1e-14 keeps a margin from it.
REFERENCE_RTOL = 1e-14
DEFAULT_RTOL = 1e-11        # simulate()'s default, quoted in the headline

# Slots of the result vector the driver fills (NaN until the thing happens).
R_LIFTOFF_T = 0     # first lift-off
R_LAND_T = 1        # first touchdown after it
R_LAND_X = 2        # c.m. x at that touchdown (an impact changes velocities, not x;
                    # the attitude hold lands the body flat, so the contact points
                    # are x -+ r there)
R_REST_T = 3        # when it came to rest (state F) after landing
R_REST_X = 4        # c.m. x at rest
R_TTRTP = 5         # the judge's time to reach the target point
R_END_T = 6         # simulated time when the driver stopped
R_N_IMPACTS = 7
R_N_SEQ = 8         # mode-sequence codes written into `seq` (may exceed its length)
R_FLAG = 9          # 0 fine, 1 broken, 2 kernel error, 3 hit T_END before resting
N_RESULT = 10
SEQ_LEN = 256       # codes kept: kind * 8 + mode after, for every non-judge event

PHASE_LAUNCH, PHASE_FLIGHT, PHASE_LANDED = 0, 1, 2

# When the controller switches torque.
# TIMING_GRID: at the contest's control instants k * CONTROL_DT only, as simulate()
#   does: the launch torque until an instant finds the rover flying, the attitude hold
#   while flying, zero from the first instant that finds it on the ground again.
#   Every DOP853 step is then cut at an instant, 0.1 s apart.
# TIMING_EVENTS: the launch torque is held in one interval that the lift-off ends, the
#   attitude hold runs on a grid lift-off + k * CONTROL_DT, and zero torque starts at
#   the first impact. Only the integrator decides its steps during the launch, so its
#   tolerance shows; and every switch is a smooth function of the state, so the errors
#   converge cleanly.
TIMING_GRID, TIMING_EVENTS = 0, 1
IDLE_CHUNK = 1.0            # s: after landing, how often the driver checks for rest
TIMING_BUDGET = 0.2         # s of repeats per cheap timed run (best of them is kept)
MAX_REPEATS = 30


@njit(cache=True, error_model="numpy", _nrt=False)
def pd_hold_torque(inertia, kp, kd, theta, omega):
    """The attitude hold, written exactly as the Python controller below writes it, so
    that both produce the same float."""
    th = (theta + math.pi) % (2.0 * math.pi) - math.pi
    return -inertia * (kp * th + kd * omega)


@njit(cache=True, error_model="numpy", _nrt=False)
def _advance_and_record(S, P, O, torque, t_stop, ev, W, res, seq, n_seq):
    """One `core.advance` call, then the bookkeeping: mode-sequence codes from the
    event log, the rest time, and the first lift-off / first landing if `advance`
    stopped on them (S_STOP_ON names the one awaited). Returns the new code count."""
    n = core.advance(S, P, O, torque, t_stop, ev, W)
    if S[core.S_STOPPED] != 0.0:
        if S[core.S_STOP_ON] == core.EV_LIFTOFF:
            res[R_LIFTOFF_T] = S[core.S_T]
            S[core.S_STOP_ON] = core.EV_IMPACT     # next: the first touchdown
        elif S[core.S_STOP_ON] == core.EV_IMPACT:
            res[R_LAND_T] = S[core.S_T]
            res[R_LAND_X] = S[core.S_X]
            S[core.S_STOP_ON] = -1.0
    for i in range(min(n, ev.shape[0])):
        kind = int(ev[i, 1])
        if kind == core.EV_BAND_IN or kind == core.EV_BAND_OUT or kind == core.EV_TTRTP:
            continue                   # judge bookkeeping, not a change of mode
        after = int(ev[i, 3])
        if n_seq < seq.shape[0]:
            seq[n_seq] = kind * 8 + after
        n_seq += 1
        if after == core.MODE_F and not math.isnan(res[R_LAND_T]):
            res[R_REST_T] = ev[i, 0]
    return n_seq


@njit(cache=True, error_model="numpy", _nrt=False)
def _healthy(S):
    return S[core.S_BROKEN] == 0.0 and S[core.S_ERROR] == 0.0


@njit(cache=True, error_model="numpy", _nrt=False)
def _at_rest_and_judged(S, res):
    """Landed, at rest on both corners (nothing moves again under zero torque), and
    the judge has either given its TTRTP or can never give one (out of the band)."""
    return (not math.isnan(res[R_LAND_T]) and int(S[core.S_MODE]) == core.MODE_F and
            (S[core.S_INBAND] == 0.0 or not math.isnan(S[core.S_TTRTP])))


@njit(cache=True, error_model="numpy", _nrt=False)
def run_scenario(S, P, O, timing, launch_torque, kp, kd, control_dt, t_end, ev, W, res,
                 seq):
    """One launch-and-land run, entirely in compiled code (see TIMING_* for the two
    ways the controller switches). Fills `res` (R_* slots, NaN when a thing did not
    happen) and `seq` (mode-sequence codes). `ev` is the event log, `W` the kernel's
    scratch row; nothing is allocated.

    `advance` is asked to stop at the first lift-off and at the first impact after
    it, so that their exact times and the landing x can be read from S. With
    TIMING_GRID the interval is then resumed with the same torque; that continues the
    very same trajectory (every phase of the kernel starts from the state alone), as
    the check against simulate() shows bit for bit.
    """
    inertia = P[P_I]
    for i in range(res.shape[0]):
        res[i] = np.nan
    n_seq = 0
    flag = 0.0
    S[core.S_STOP_ON] = core.EV_LIFTOFF
    if timing == TIMING_GRID:
        phase = PHASE_LAUNCH
        k = 0
        while _healthy(S) and not _at_rest_and_judged(S, res):
            t_k = k * control_dt
            if t_k >= t_end - 1e-9 * control_dt:
                break
            t_next = min((k + 1) * control_dt, t_end)
            # the contest controller: it sees the state at the instant only
            if int(S[core.S_MODE]) == core.MODE_A:
                if phase == PHASE_LAUNCH:
                    phase = PHASE_FLIGHT
                torque = 0.0 if phase == PHASE_LANDED else \
                    pd_hold_torque(inertia, kp, kd, S[core.S_TH], S[core.S_W])
            elif phase == PHASE_LAUNCH:
                torque = launch_torque
            else:
                phase = PHASE_LANDED
                torque = 0.0
            while S[core.S_T] < t_next and _healthy(S):
                n_seq = _advance_and_record(S, P, O, torque, t_next, ev, W, res, seq, n_seq)
            k += 1
    else:
        # the launch torque in one hold, ended by the lift-off event
        n_seq = _advance_and_record(S, P, O, launch_torque, t_end, ev, W, res, seq, n_seq)
        t_liftoff = S[core.S_T]
        k = 0
        # attitude hold on a control grid that starts at the lift-off, to the touchdown
        while _healthy(S) and math.isnan(res[R_LAND_T]) and S[core.S_T] < t_end:
            k += 1
            torque = pd_hold_torque(inertia, kp, kd, S[core.S_TH], S[core.S_W])
            n_seq = _advance_and_record(S, P, O, torque, min(t_liftoff + k * control_dt,
                                                                t_end), ev, W, res, seq, n_seq)
        # idle from the touchdown on, in chunks only to notice the rest
        while _healthy(S) and not _at_rest_and_judged(S, res) and S[core.S_T] < t_end:
            n_seq = _advance_and_record(S, P, O, 0.0, min(S[core.S_T] + IDLE_CHUNK, t_end),
                                        ev, W, res, seq, n_seq)
    if S[core.S_BROKEN] != 0.0:
        flag = 1.0
    elif S[core.S_ERROR] != 0.0:
        flag = 2.0
    elif not _at_rest_and_judged(S, res):
        flag = 3.0
    else:
        res[R_REST_X] = S[core.S_X]
    res[R_TTRTP] = S[core.S_TTRTP]
    res[R_END_T] = S[core.S_T]
    res[R_N_IMPACTS] = S[core.S_NIMPACT]
    res[R_N_SEQ] = n_seq
    res[R_FLAG] = flag


@njit(cache=True, error_model="numpy", _nrt=False)
def repeat_launch(S0, S, P, O, torque, t_end, ev, W, repeats):
    """The launch alone, `repeats` times (one Python call for many, so that timing it
    does not time the call): from the state S0, hold `torque` until the lift-off.
    Returns the lift-off time."""
    for _ in range(repeats):
        for i in range(S0.shape[0]):
            S[i] = S0[i]
        S[core.S_STOP_ON] = core.EV_LIFTOFF
        core.advance(S, P, O, torque, t_end, ev, W)
    return S[core.S_T]


# ----------------------------------------------------------------------------------
# Python side: methods, runs, timing
# ----------------------------------------------------------------------------------
JUDGE_EVENTS = ("band_in", "band_out", "ttrtp")


@dataclasses.dataclass(frozen=True)
class Method:
    """An integrator and its accuracy knob: rtol for `event`, the step for `euler`."""
    integrator: str
    value: float

    @property
    def label(self) -> str:
        knob = "rtol" if self.integrator == "event" else "dt"
        return f"{self.integrator} {knob} {self.value:.0e}"

    def kwargs(self) -> dict:
        """Keyword arguments of simulate() / RoverSim()."""
        if self.integrator == "event":
            return {"integrator": "event", "rtol": self.value}
        return {"integrator": "euler", "euler_dt": self.value}

    def options(self) -> np.ndarray:
        return make_options(**self.kwargs())


@dataclasses.dataclass
class Run:
    """What one run_scenario call found (times in s, positions in m)."""
    liftoff_t: float
    land_t: float
    land_x: float
    rest_t: float
    rest_x: float
    ttrtp: float
    end_t: float
    n_impacts: int
    flag: int                  # 0 fine, 1 broken, 2 kernel error, 3 no rest by T_END
    seq: tuple                 # mode-sequence codes (event kind * 8 + mode after)
    final: np.ndarray          # (x, y, theta, vx, vy, omega) when the driver stopped
    wall: float = math.nan     # best wall time of the run [s]


class Driver:
    """Owns the arrays run_scenario works in (allocated once, reused by every run)."""

    def __init__(self, params: RoverParams):
        self.params = params
        self.p = params.as_array()
        self.ev = np.zeros((core.MAX_EVENTS + 64, core.EV_COLS))
        self.w = np.zeros(core.N_WORK)
        self.res = np.zeros(N_RESULT)
        self.seq = np.zeros(SEQ_LEN, dtype=np.int64)

    def run(self, method: Method, torque: float, target_x: float,
            timing: int = TIMING_EVENTS, repeats: int = 1) -> Run:
        """Run the scenario `repeats` times (it is deterministic); wall = the best."""
        o = method.options()
        s0 = make_state(self.params, target_x)
        best = math.inf
        for _ in range(repeats):
            s = s0.copy()
            t0 = time.perf_counter()
            run_scenario(s, self.p, o, timing, torque, KP, KD, CONTROL_DT, T_END, self.ev,
                         self.w, self.res, self.seq)
            best = min(best, time.perf_counter() - t0)
        r = self.res
        n_seq = int(r[R_N_SEQ])
        if n_seq > SEQ_LEN:
            raise RuntimeError(f"{method.label}, torque {torque:g}: {n_seq} mode changes, "
                               f"more than SEQ_LEN = {SEQ_LEN} can be compared")
        return Run(liftoff_t=r[R_LIFTOFF_T], land_t=r[R_LAND_T], land_x=r[R_LAND_X],
                   rest_t=r[R_REST_T], rest_x=r[R_REST_X], ttrtp=r[R_TTRTP],
                   end_t=r[R_END_T], n_impacts=int(r[R_N_IMPACTS]), flag=int(r[R_FLAG]),
                   seq=tuple(int(c) for c in self.seq[:n_seq]), final=s[:6].copy(),
                   wall=best)

    def timed_run(self, method: Method, torque: float, target_x: float,
                  timing: int = TIMING_EVENTS) -> Run:
        """Best of several runs: the machine is shared, so a cheap run is repeated for
        ~TIMING_BUDGET s (at most 1 + MAX_REPEATS runs), one under a second 3 times,
        a longer one once."""
        run = self.run(method, torque, target_x, timing)
        more = 0 if run.wall >= 1.0 else \
            max(2, min(MAX_REPEATS, int(TIMING_BUDGET / max(run.wall, 1e-9))))
        if more:
            again = self.run(method, torque, target_x, timing, repeats=more)
            assert again.seq == run.seq and np.array_equal(again.final, run.final)
            run.wall = min(run.wall, again.wall)
        return run

    def launch_wall(self, method: Method, torque: float) -> float:
        """Wall time of the launch alone (rest to lift-off), per launch, best of 3
        batches; a batch repeats the launch inside compiled code for >= ~20 ms."""
        o = method.options()
        s0 = make_state(self.params, 0.5)
        s = s0.copy()
        t0 = time.perf_counter()
        repeat_launch(s0, s, self.p, o, torque, T_END, self.ev, self.w, 1)
        one = time.perf_counter() - t0
        reps = int(min(2000, max(1, 0.02 / max(one, 1e-7))))
        best = one
        for _ in range(3 if one < 1.0 else 0):
            t0 = time.perf_counter()
            repeat_launch(s0, s, self.p, o, torque, T_END, self.ev, self.w, reps)
            best = min(best, (time.perf_counter() - t0) / reps)
        return best


def seq_of_events(events) -> tuple:
    """The driver's mode-sequence codes from a Rollout's / RoverSim's event list."""
    return tuple(core.EVENT_NAMES.index(e[1]) * 8 + core.MODE_LETTERS.index(e[3])
                 for e in events if e[1] not in JUDGE_EVENTS)


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


# ----------------------------------------------------------------------------------
# The driver against the public API (run before anything is timed)
# ----------------------------------------------------------------------------------
def wrapped(theta: float) -> float:
    return (theta + math.pi) % (2.0 * math.pi) - math.pi


def contest_controller(launch_torque: float, inertia: float):
    """TIMING_GRID's controller in Python, with the contest signature, for simulate()."""
    phase = ["launch"]

    def control(pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            if phase[0] == "launch":
                phase[0] = "flight"
            if phase[0] == "landed":
                return 0.0
            return -inertia * (KP * wrapped(the) + KD * omg)
        if phase[0] == "launch":
            return launch_torque
        phase[0] = "landed"
        return 0.0

    return control


def check_grid_against_simulate(driver: Driver, method: Method, torque: float,
                                target_x: float) -> float:
    """Largest difference (state, lift-off and landing times, TTRTP) between the driver
    on the contest grid and simulate() with the same controller in Python; raises if
    the mode sequences differ."""
    run = driver.run(method, torque, target_x, TIMING_GRID)
    roll = simulate(contest_controller(torque, driver.params.inertia), t_end=run.end_t,
                    control_dt=CONTROL_DT, target_x=target_x, params=driver.params,
                    **method.kwargs())
    if seq_of_events(roll.events) != run.seq:
        raise AssertionError(f"driver and simulate() differ in mode sequence "
                             f"({method.label}, torque {torque:g})")
    final = np.array([roll.x[-1], roll.y[-1], roll.theta[-1], roll.vx[-1], roll.vy[-1],
                      roll.omega[-1]])
    liftoff = next(e[0] for e in roll.events if e[1] == "liftoff")
    landing = next(e[0] for e in roll.events if e[1] == "impact" and e[0] >= liftoff)
    ttrtp = math.nan if roll.ttrtp is None else roll.ttrtp
    return max(float(np.max(np.abs(final - run.final))), abs(liftoff - run.liftoff_t),
               abs(landing - run.land_t), _nan_diff(ttrtp, run.ttrtp))


def check_events_against_roversim(driver: Driver, method: Method, torque: float,
                                  target_x: float) -> float:
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
        cmd = -inertia * (KP * wrapped(sim.s[core.S_TH]) + KD * sim.s[core.S_W])
        events += sim.advance(cmd, min(t_liftoff + k * CONTROL_DT, T_END), stop_on="impact")
    t_land, x_land = sim.t, sim.state[0]
    while not (sim.mode == "F" and (sim.s[core.S_INBAND] == 0.0 or sim.ttrtp is not None)) \
            and sim.t < T_END:
        events += sim.advance(0.0, min(sim.t + IDLE_CHUNK, T_END))
    if seq_of_events(events) != run.seq:
        raise AssertionError(f"driver and RoverSim differ in mode sequence "
                             f"({method.label}, torque {torque:g})")
    ttrtp = math.nan if sim.ttrtp is None else sim.ttrtp
    return max(float(np.max(np.abs(sim.state - run.final))), abs(t_liftoff - run.liftoff_t),
               abs(t_land - run.land_t), abs(x_land - run.land_x),
               _nan_diff(ttrtp, run.ttrtp))


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
        repeat_launch(make_state(driver.params, 0.5), np.zeros(core.N_STATE), driver.p,
                      m.options(), 3e-4, T_END, driver.ev, driver.w, 1)
    return time.perf_counter() - t0


# ----------------------------------------------------------------------------------
# The independent reference: scipy to the lift-off, closed form to the touchdown
# ----------------------------------------------------------------------------------
def load_scipy_reference():
    """tests/reference.py's Ref class (MODEL.md section 4 by scipy DOP853, rtol 1e-13,
    atol 1e-16, with located events; it shares no code with the kernel)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.path.join(root, "tests", "reference.py")
    spec = importlib.util.spec_from_file_location("hoprover_scipy_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.Ref


def scipy_launch_and_landing(params: RoverParams, torque: float) -> dict:
    """Lift-off by scipy, then the flight under the attitude hold in closed form.

    Between control instants (lift-off + k CONTROL_DT) the torque is constant, so the
    c.m. follows one parabola from the lift-off and theta a quadratic in t per
    interval. The touchdown is the first root of the lowest bottom corner's height,
    y - l max(sin(theta + alpha), sin(alpha - theta)), found by Brent's method in the
    first interval (past the apex) whose end is below the ground.
    """
    ref = load_scipy_reference()(m=params.mass, I=params.inertia, r=params.half_width,
                                 h=params.half_height, g=params.gravity,
                                 mus=params.mu_static, mud=params.mu_dynamic)
    t_lo, s_lo, modes = ref.launch(torque)
    x0, y0, theta, vx, vy0, omega = (float(v) for v in s_lo)
    g, inertia, ell, alpha = ref.g, ref.I, ref.l, ref.alpha
    t_apex = t_lo + vy0 / g

    def y_at(t):
        tau = t - t_lo
        return y0 + vy0 * tau - 0.5 * g * tau * tau

    t_a = t_lo
    for k in range(1, int(T_END / CONTROL_DT)):
        t_b = t_lo + k * CONTROL_DT
        cmd = -inertia * (KP * wrapped(theta) + KD * omega)
        beta = min(max(cmd, params.torque_min), params.torque_max) / inertia

        def lowest_corner(t, th0=theta, w0=omega, t0=t_a, beta=beta):
            th = th0 + w0 * (t - t0) + 0.5 * beta * (t - t0) ** 2
            return y_at(t) - ell * max(math.sin(th + alpha), math.sin(alpha - th))

        if t_b > t_apex and lowest_corner(t_b) < 0.0:
            t_land = brentq(lowest_corner, t_a, t_b, xtol=1e-15, rtol=8.9e-16)
            return {"liftoff_t": t_lo, "liftoff_state": np.asarray(s_lo, float),
                    "modes": "".join(modes), "land_t": t_land,
                    "land_x": x0 + vx * (t_land - t_lo)}
        theta = theta + omega * (t_b - t_a) + 0.5 * beta * (t_b - t_a) ** 2
        omega = omega + beta * (t_b - t_a)
        t_a = t_b
    raise RuntimeError(f"scipy reference: no touchdown by T_END (torque {torque:g})")


def launch_modes(events) -> str:
    """'FBCA'-style letters of the launch, as tests/test_reference.py writes them."""
    return "".join([events[0][2]] + [e[3] for e in events
                                     if e[1] in ("tip", "slip", "stick", "liftoff")])


def cross_check(driver: Driver, torques, reference_runs, targets) -> list:
    """Reference (event at REFERENCE_RTOL) against scipy + closed form, per torque."""
    rows = []
    for torque in torques:
        sp = scipy_launch_and_landing(driver.params, torque)
        sim = RoverSim(driver.params, target_x=targets[torque], rtol=REFERENCE_RTOL)
        events = sim.advance(torque, T_END, stop_on="liftoff")
        ref = reference_runs[torque]
        rows.append({
            "torque": torque, "modes": sp["modes"],
            "same_modes": launch_modes(events) == sp["modes"],
            "liftoff_t": sp["liftoff_t"], "land_t": sp["land_t"], "land_x": sp["land_x"],
            "d_liftoff_t": abs(sim.t - sp["liftoff_t"]),
            "d_liftoff_pos": float(np.max(np.abs(sim.state[:3] - sp["liftoff_state"][:3]))),
            "d_liftoff_vel": float(np.max(np.abs(sim.state[3:] - sp["liftoff_state"][3:]))),
            "d_land_t": abs(ref.land_t - sp["land_t"]),
            "d_land_x": abs(ref.land_x - sp["land_x"]),
        })
    return rows


# ----------------------------------------------------------------------------------
# Errors against the reference
# ----------------------------------------------------------------------------------
# (key, column title, unit): before the first impact every run has the reference's
# mode sequence, so these are compared point by point for every run ...
EARLY = (("liftoff_t", "lift-off t", "s"), ("land_t", "landing t", "s"),
         ("land_x", "landing x", "m"))
# ... after it, only runs whose whole mode sequence equals the reference's.
LATE = (("rest_x", "rest x", "m"), ("rest_t", "rest t", "s"), ("ttrtp", "TTRTP", "s"))


@dataclasses.dataclass
class SweepPoint:
    """One method setting over the launch torques: worst errors and mean wall times."""
    method: Method
    errors: dict               # key -> largest |error| over the torques (NaN: none compared)
    same_seq: int              # runs whose mode sequence equals the reference's
    n_runs: int
    wall: float                # mean over the torques of a whole run's best wall time [s]
    launch_wall: float         # mean over the torques of the launch's wall time [s]
    runs: dict                 # torque -> Run
    same_early: int = 0        # runs whose mode sequence up to the first impact is the ref's


def errors_of(run: Run, ref: Run) -> dict:
    same = run.seq == ref.seq and run.flag == 0
    out = {key: _nan_diff(getattr(run, key), getattr(ref, key)) for key, _, _ in EARLY}
    for key, _, _ in LATE:
        out[key] = _nan_diff(getattr(run, key), getattr(ref, key)) if same else math.nan
    return out


def sweep_point(driver: Driver, method: Method, torques, refs, targets,
                timing: int = TIMING_EVENTS) -> SweepPoint:
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
    same_early = sum(_to_first_impact(runs[t].seq) == _to_first_impact(refs[t].seq)
                     for t in torques)
    return SweepPoint(method, worst, same, len(torques),
                      float(np.mean([runs[t].wall for t in torques])),
                      float(np.mean([driver.launch_wall(method, t) for t in torques]))
                      if timing == TIMING_EVENTS else math.nan, runs, same_early)


def _to_first_impact(seq: tuple) -> tuple:
    """The mode-sequence codes up to and including the first impact."""
    first = [i for i, c in enumerate(seq) if c // 8 == core.EV_IMPACT]
    return seq[:first[0] + 1] if first else seq


def comparable(points, key: str) -> list:
    """Worst errors of `key` along a sweep, NaN where a late quantity's worst case is
    over fewer runs than the others (some mode sequence differed): the worst case of a
    smaller set would bend the fitted slope."""
    late = key in [k for k, _, _ in LATE]
    return [p.errors[key] if (not late or p.same_seq == p.n_runs) else math.nan
            for p in points]


def fitted_order(steps, errors, floor: float = 0.0) -> float:
    """Least-squares slope of log(error) against log(step or rtol), over the points whose
    error stands clear (100x) of the reference's own noise `floor`; NaN if < 3 points."""
    pts = [(s, e) for s, e in zip(steps, errors)
           if e is not None and math.isfinite(e) and e > max(100.0 * floor, 0.0) and e > 0]
    if len(pts) < 3:
        return math.nan
    x = np.log10([p[0] for p in pts])
    y = np.log10([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def step_for_error(steps, errors, wanted: float) -> float:
    """The step at which the (log-log interpolated) worst error equals `wanted`: the
    largest step that meets it. inf if every step meets it, NaN if none does."""
    pairs = sorted((s, e) for s, e in zip(steps, errors) if math.isfinite(e))
    pairs.reverse()                                         # large steps first
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
BOUNCE_TORQUE, BOUNCE_DT = 5e-4, 1e-2     # the bounce sequence shown in the text


def bounce_speeds(params: RoverParams, method: Method, torque: float) -> str:
    """The c.m. vertical speed after each impact of the landing, to the first impact
    that leaves the rover on the ground: the same schedule as run_scenario's, written
    over RoverSim so that it can stop at every impact."""
    sim = RoverSim(params, target_x=0.5, **method.kwargs())
    sim.advance(torque, T_END, stop_on="liftoff")
    t_liftoff, k = sim.t, 0
    while not (k > 0 and sim.stopped) and sim.t < T_END:
        k += 1
        cmd = -params.inertia * (KP * wrapped(sim.s[core.S_TH]) + KD * sim.s[core.S_W])
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
        rows.append([method.integrator, method.label.split(" ", 1)[1],
                     f"{same.sum()}/{n_torques}", float(np.mean(xs[ok])), float(np.std(xs[ok])),
                     float(wasserstein_distance(xs[ok], ref_x)),
                     float(np.median(diff[ok])), float(np.max(diff[ok])),
                     float(np.max(diff[~same & ok])) if np.any(~same & ok) else "-",
                     float(np.mean([r.n_impacts for r in runs])), extra_txt,
                     int(np.sum(~ok))])
        rest[method.label] = xs
    rows.insert(0, ["event", f"{REFERENCE_RTOL:.0e} (reference)", "-", float(np.mean(ref_x)),
                    float(np.std(ref_x)), 0.0, 0.0, 0.0, "-",
                    float(np.mean([r.n_impacts for r in refs])), "-", 0])
    return torques, rows, rest


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
    panels = [("liftoff_t", "launch_wall", "lift-off time error [s]",
               "wall time of the launch alone [s]"),
              ("land_t", "wall", "first landing time error [s]", "wall time per run [s]"),
              ("land_x", "wall", "first landing point error [m]", "wall time per run [s]"),
              ("rest_x", "wall", "rest position error [m]\n(same mode sequence only)",
               "wall time per run [s]")]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    for ax, (key, wall_attr, ylabel, xlabel) in zip(axes.flat, panels):
        for pts, style, name in ((euler_pts, "o-", "euler (label: dt)"),
                                 (event_pts, "s-", "event (label: rtol)")):
            xs = [getattr(p, wall_attr) for p in pts]
            ys = _positive([p.errors[key] for p in pts])
            ax.loglog(xs, ys, style, label=name)
            for x, y, p in zip(xs, ys, pts):
                if math.isfinite(y):
                    ax.annotate(f"{p.method.value:.0e}", (x, y), fontsize=7,
                                textcoords="offset points", xytext=(4, 3))
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Work-precision: worst error over the launch torques against wall time "
                 "(numba driver, no Python in the loop)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def convergence_figure(euler_pts, event_pts, floors, path: str) -> str:
    """Error against the accuracy knob: euler_dt (expect slope 1) and rtol."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax_e, ax_r) = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, pts, xlabel in ((ax_e, euler_pts, "euler_dt [s]"), (ax_r, event_pts, "rtol")):
        knobs = [p.method.value for p in pts]
        for key, title, unit in EARLY + LATE[:1]:
            line, = ax.loglog(knobs, _positive(comparable(pts, key)), "o-",
                              label=f"{title} [{unit}]")
            if ax is ax_r:          # the reference's own noise in this quantity
                ax.axhline(max(floors[key], 1e-16), color=line.get_color(), ls="--", lw=0.7)
        # a slope-1 guide through the middle of the landing-point curve
        mid = len(pts) // 2
        y_mid = max(pts[mid].errors["land_x"], 1e-16)
        ax.loglog(knobs, [y_mid * k / knobs[mid] for k in knobs], "k:", label="slope 1")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("worst error over the launch torques")
        ax.grid(True, which="both", alpha=0.3)
    ax_e.legend(fontsize=8)
    ax_e.set_title("euler", fontsize=10)
    ax_r.set_title("event (dashed: the reference's own noise, rtol 1e-15 against it)",
                   fontsize=10)
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


def _sweep_rows(points) -> list:
    rows = []
    for p in points:
        rows.append([p.method.integrator, p.method.label.split(" ", 1)[1], _fmt_s(p.wall),
                     _fmt_s(p.launch_wall)] +
                    [_fmt_e(p.errors[k]) for k, _, _ in EARLY + LATE] +
                    [f"{p.same_seq}/{p.n_runs}"])
    return rows


SWEEP_HEADER = (["method", "setting", "wall/run", "launch wall"] +
                [f"{title} [{unit}]" for _, title, unit in EARLY + LATE] + ["same modes"])


def _best_wall(fn, repeats: int = 3) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(quick: bool) -> dict:
    """Every number of the section, in the order the module docstring lists them."""
    size = "quick" if quick else "full"
    params = RoverParams()
    driver = Driver(params)
    m = {"compile_s": warm_up(driver), "torques": TORQUES[size]}
    torques = m["torques"]
    ref_method = Method("event", REFERENCE_RTOL)
    default = Method("event", DEFAULT_RTOL)

    # 1. The compiled driver must be the public API's physics, bit for bit.
    m["check_max"], m["n_checks"] = 0.0, 0
    for torque in torques:
        for method in (default, Method("euler", 1e-3)):
            m["check_max"] = max(m["check_max"],
                                 check_grid_against_simulate(driver, method, torque, 0.5),
                                 check_events_against_roversim(driver, method, torque, 0.5))
            m["n_checks"] += 2
    # What the Python controller would have cost: simulate() on the contest grid with
    # it, against the driver on the same grid.
    m["python_wall"] = np.mean([_best_wall(lambda: simulate(
        contest_controller(t, params.inertia),
        t_end=driver.run(default, t, 0.5, TIMING_GRID).end_t, control_dt=CONTROL_DT,
        target_x=0.5, params=params, **default.kwargs())) for t in torques])
    m["driver_grid_wall"] = np.mean([driver.timed_run(default, t, 0.5, TIMING_GRID).wall
                                     for t in torques])

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
    tightest = [errors_of(driver.run(Method("event", 1e-15), t, targets[t]), refs[t])
                for t in torques]
    m["floors"] = {k: float(np.nanmax([e[k] for e in tightest])) for k, _, _ in EARLY + LATE}
    m["xcheck"] = cross_check(driver, torques, refs, targets)
    m["flight_intervals"] = [(refs[t].land_t - refs[t].liftoff_t) / CONTROL_DT
                             for t in torques]

    # 3. The sweeps, and the orders of convergence they show.
    m["euler"] = [sweep_point(driver, Method("euler", dt), torques, refs, targets)
                  for dt in EULER_DTS[size]]
    m["event"] = [sweep_point(driver, Method("event", rtol), torques, refs, targets)
                  for rtol in EVENT_RTOLS[size]]
    dts = [p.method.value for p in m["euler"]]
    rtols = [p.method.value for p in m["event"]]
    m["euler_order"] = {k: fitted_order(dts, comparable(m["euler"], k))
                        for k, _, _ in EARLY + LATE}
    m["event_order"] = {k: fitted_order(rtols, comparable(m["event"], k), m["floors"][k])
                        for k, _, _ in EARLY + LATE}
    m["dt_1mm_land"] = step_for_error(dts, comparable(m["euler"], "land_x"), 1e-3)
    m["dt_1mm_rest"] = step_for_error(dts, comparable(m["euler"], "rest_x"), 1e-3)

    # 4. Past the first impact: distributions over many torques.
    stat_methods = [Method("event", r) for r in STAT_EVENT_RTOLS] + \
        [Method("euler", dt) for dt in STAT_EULER_DTS[size]]
    m["stat_torques"], m["stat_rows"], _ = statistics(driver, stat_methods,
                                                      STAT_TORQUES[size])
    m["bounce_ref"] = bounce_speeds(params, ref_method, BOUNCE_TORQUE)
    m["bounce_euler"] = bounce_speeds(params, Method("euler", BOUNCE_DT), BOUNCE_TORQUE)

    # 5. The contest's control grid: every switch at a 0.1 s instant.
    grid_refs = {t: driver.run(ref_method, t, 0.5, TIMING_GRID) for t in torques}
    m["grid"] = [sweep_point(driver, Method(i, v), torques, grid_refs,
                             {t: 0.5 for t in torques}, TIMING_GRID)
                 for i, v in GRID_METHODS]
    grid_event = [p for p in m["grid"] if p.method.integrator == "event"]
    m["grid_event_rtols"] = [p.method.value for p in grid_event]
    m["grid_identical"] = all(
        np.array_equal(p.runs[t].final, grid_event[0].runs[t].final) and
        p.runs[t].seq == grid_event[0].runs[t].seq for p in grid_event for t in torques)
    return m


def headline(m: dict) -> dict:
    by_label = {p.method.label: p for p in m["euler"] + m["event"]}
    ev_default = by_label[Method("event", DEFAULT_RTOL).label]
    eu_1e4 = by_label[Method("euler", 1e-4).label]
    return {
        "reference vs scipy (worst, landing t / landing x)":
            f"{max(r['d_land_t'] for r in m['xcheck']):.1e} s / "
            f"{max(r['d_land_x'] for r in m['xcheck']):.1e} m",
        "euler order (lift-off t, landing x, rest x)":
            f"{m['euler_order']['liftoff_t']:.2f}, {m['euler_order']['land_x']:.2f}, "
            f"{m['euler_order']['rest_x']:.2f}",
        "euler_dt for 1 mm landing-point error": f"{m['dt_1mm_land']:.1e} s",
        "euler_dt for 1 mm rest-position error": f"{m['dt_1mm_rest']:.1e} s",
        f"event rtol {DEFAULT_RTOL:.0e}: wall per run, landing-point error":
            f"{_fmt_s(ev_default.wall)}, {_fmt_e(ev_default.errors['land_x'])} m",
        "euler dt 1e-4: wall per run, landing-point error":
            f"{_fmt_s(eu_1e4.wall)}, {_fmt_e(eu_1e4.errors['land_x'])} m",
        f"wall ratio euler dt 1e-4 / event rtol {DEFAULT_RTOL:.0e}":
            f"{eu_1e4.wall / ev_default.wall:.0f}x",
    }


def markdown(m: dict) -> str:
    by_label = {p.method.label: p for p in m["euler"] + m["event"]}
    ev_default = by_label[Method("event", DEFAULT_RTOL).label]
    eu_1e4 = by_label[Method("euler", 1e-4).label]
    sweep = m["euler"] + m["event"]
    floors, refs = m["floors"], m["refs"]
    md = [
        f"**Scenario.** Launch torques {', '.join(f'{t:g}' for t in m['torques'])} N m, "
        "each held from rest until the lift-off; then a PD attitude hold "
        f"T = -I (kp wrap(theta) + kd omega), kp = {KP}, kd = {KD}, at control instants "
        f"{CONTROL_DT} s apart from the lift-off on; zero torque from the first touchdown "
        "through the bounces and the slide to rest. The target is the reference rest "
        f"position + {TARGET_OFFSET} m, so that the rover stops inside the band and TTRTP "
        "exists. Each run is one call of a numba driver (`run_scenario` in "
        "benchmarks/bench_accuracy.py) that loops `core.advance` and computes the PD "
        "torque itself: the wall times are the integrators', not Python's (simulate() "
        f"with the same controller in Python takes {_fmt_s(m['python_wall'])} per run on "
        f"the contest grid, the driver {_fmt_s(m['driver_grid_wall'])}). The driver "
        "reproduces simulate() (contest grid) and a RoverSim loop (event-triggered "
        f"switches) with a Python controller: largest difference {m['check_max']:g} over "
        f"{m['n_checks']} runs (bit for bit). Wall time = the best of up to "
        f"{MAX_REPEATS + 1} runs (a cheap run is repeated for ~{TIMING_BUDGET} s; runs over "
        "1 s are timed once), averaged over the launch torques; 'launch wall' is the "
        "launch alone (rest to lift-off), where all of the event integrator's DOP853 "
        f"stepping happens; a whole run also has {min(m['flight_intervals']):.0f} to "
        f"{max(m['flight_intervals']):.0f} control intervals of flight (closed form in "
        "`event`, Euler steps in `euler`) and the bounces and slide. Machine: 2 cores "
        "shared with other work (expect ~10-20 % noise on wall times). Numba load/compile "
        f"of the driver: {m['compile_s']:.1f} s (not counted).",

        f"**Reference and cross-check.** The reference is `event` at rtol "
        f"{REFERENCE_RTOL:.0e}; the API's floor, 1e-15, differs from it by at most "
        f"{_fmt_e(floors['liftoff_t'])} s in lift-off time, {_fmt_e(floors['land_t'])} s in "
        f"landing time, {_fmt_e(floors['land_x'])} m in landing point, "
        f"{_fmt_e(floors['rest_x'])} m in rest position and {_fmt_e(floors['ttrtp'])} s in "
        "TTRTP (its noise). Independently, tests/reference.py integrates MODEL.md "
        "section 4's corner-A equations with scipy's DOP853 (rtol 1e-13, atol 1e-16, "
        "located events) to the lift-off; from there the flight is closed form "
        "(parabola; theta quadratic between control instants, the PD torque recomputed "
        "at each) and the touchdown is the first root of the lowest corner's height "
        "(Brent). Differences, reference minus scipy:",

        table(["torque [N m]", "modes", "same modes", "lift-off t [s]", "|d lift-off t| [s]",
               "|d lift-off pos| [m, rad]", "|d lift-off vel| [m/s, rad/s]",
               "landing t [s]", "|d landing t| [s]", "|d landing x| [m]"],
              [[f"{r['torque']:g}", r["modes"], "yes" if r["same_modes"] else "NO",
                f"{r['liftoff_t']:.6f}", _fmt_e(r["d_liftoff_t"]), _fmt_e(r["d_liftoff_pos"]),
                _fmt_e(r["d_liftoff_vel"]), f"{r['land_t']:.6f}", _fmt_e(r["d_land_t"]),
                _fmt_e(r["d_land_x"])] for r in m["xcheck"]]),

        "The reference runs (c.m. x at the first touchdown; rest position and time; "
        "TTRTP for the target above; the mode sequence, repeats compressed):",

        table(["torque [N m]", "landing x [m]", "rest x [m]", "rest t [s]", "target [m]",
               "TTRTP [s]", "mode sequence"],
              [[f"{t:g}", f"{refs[t].land_x:.6f}", f"{refs[t].rest_x:.6f}",
                f"{refs[t].rest_t:.4f}", f"{m['targets'][t]:.6f}", f"{refs[t].ttrtp:.4f}",
                describe_seq(refs[t].seq)] for t in m["torques"]]),

        "**Work-precision.** Worst absolute error over the launch torques against the "
        "reference. Lift-off and landing are compared for every run: up to the first "
        f"impact the mode sequence is the reference's in {sum(p.same_early for p in sweep)} "
        f"of {sum(p.n_runs for p in sweep)} runs. Rest position, rest time and TTRTP are "
        "compared only for runs whose whole mode sequence (every transition and impact, "
        "in order) equals the reference's ('same modes'); a '-' means no run qualified.",

        table(SWEEP_HEADER, _sweep_rows(sweep)),

        table(["quantity", "euler: slope vs dt", "event: slope vs rtol"],
              [[title, f"{m['euler_order'][k]:.2f}", f"{m['event_order'][k]:.2f}"]
               for k, title, _ in EARLY + LATE]),

        f"**Observed orders.** Least-squares slopes of log(worst error) against log(dt) "
        f"or log(rtol) (event: only errors 100x above the reference noise; rest and TTRTP: "
        f"only settings where every run kept the reference's mode sequence). `euler` "
        f"converges at first order, as explicit Euler with events seen at step ends "
        f"must: halving dt halves every error, from the lift-off through the rest "
        f"position. For 1 mm in the landing point it needs dt = {m['dt_1mm_land']:.1e} s, "
        f"for 1 mm in the rest position dt = {m['dt_1mm_rest']:.1e} s. TTRTP errors are "
        f"large next to the position errors because the band is entered while the rover "
        f"slides slowly on both corners (a position error divided by a speed of a few "
        f"mm/s). `event`'s errors fall about in proportion to rtol (the usual tolerance "
        f"proportionality of an error-controlled DOP853), down to the reference noise near "
        f"rtol 1e-13. Its launch costs {_fmt_s(min(p.launch_wall for p in m['event']))} to "
        f"{_fmt_s(max(p.launch_wall for p in m['event']))} over the whole rtol range (an "
        f"8th-order method's step count grows only like rtol^(-1/8), and locating the "
        f"slip and lift-off costs a few re-taken steps at any rtol), and a whole run "
        f"costs about the same at every rtol: its wall time is the control intervals of "
        f"the flight, each a few closed-form conservative-advancement iterations. At its "
        f"default rtol {DEFAULT_RTOL:.0e}, `event` is {eu_1e4.wall / ev_default.wall:.0f}x "
        f"faster than `euler` at dt 1e-4 and its landing-point error is "
        f"{eu_1e4.errors['land_x'] / max(ev_default.errors['land_x'], 1e-300):.0e} times "
        f"smaller; at first order `euler` would need dt ~1e-10 s to land within 1e-10 m.",

        f"**Past the first impact: statistics, not points.** After the first impact the "
        f"mode sequences of different methods may differ, and then point-by-point errors "
        f"compare different stories. Here they differ by extra bounces: a bounce sequence "
        f"ends when an impact leaves less than v_ymin = 1e-6 m/s of vertical speed, and "
        f"Euler, which sees a touchdown only at the end of the step in which the corner "
        f"went under the ground, reads its speed up to g dt too high (~1e-6 m/s at "
        f"dt = 1e-2, the size of the cut-off itself), so the last bounce can survive. "
        f"Vertical speed after each impact [m/s], launch torque {BOUNCE_TORQUE:g} N m: "
        f"reference {m['bounce_ref']}; euler dt {BOUNCE_DT:.0e}: {m['bounce_euler']}. "
        f"Over {len(m['stat_torques'])} launch torques evenly spread in [3e-5, 5e-4] N m "
        f"(target 0.5 m), the distribution of rest positions (= hop distance plus slide; "
        f"the rover starts at x = 0) against the reference's: W1 is the Wasserstein-1 "
        f"distance between the two empirical distributions (no pairing by torque); the "
        f"pointwise columns are given for scale.",

        table(["method", "setting", "same modes", "mean rest x [m]", "std [m]",
               "W1 to reference [m]", "median |d x| [m]", "max |d x| [m]",
               "max |d x|, other modes [m]", "impacts/run",
               "differing runs by extra impacts", "failed"],
              [[r[0], r[1], r[2]] + [_fmt_e(v) if isinstance(v, float) else v
                                     for v in r[3:]] for r in m["stat_rows"]]),

        "**On the contest's control grid.** The same launches, but with every torque "
        "switch at a control instant k 0.1 s (the launch torque until an instant finds "
        "the rover flying, idle from the first instant that finds it on the ground), as "
        "simulate() with a contest controller does. Each DOP853 step is then cut at the "
        "next instant, and at h <= 0.1 s the 8th-order method is at round-off on these "
        "slow dynamics (time scales of seconds): the step-size controller grows the step "
        "tenfold per step up to the 0.1 s cap at any of these tolerances, so rtol has no "
        f"effect there (the runs at rtol "
        f"{', '.join(f'{v:.0e}' for v in m['grid_event_rtols'])} are "
        f"{'bit-identical' if m['grid_identical'] else 'NOT bit-identical'}). Errors "
        f"against `event` rtol {REFERENCE_RTOL:.0e} on the same grid (target 0.5 m):",

        table(SWEEP_HEADER[:3] + SWEEP_HEADER[4:],
              [r[:3] + r[4:] for r in _sweep_rows(m["grid"])]),
    ]
    return "\n\n".join(md)


def run(quick: bool, fig_dir: str) -> Section:
    t0 = time.perf_counter()
    m = measure(quick)
    figures = [work_precision_figure(m["euler"], m["event"],
                                     os.path.join(fig_dir, "accuracy_work_precision.png")),
               convergence_figure(m["euler"], m["event"], m["floors"],
                                  os.path.join(fig_dir, "accuracy_convergence.png"))]
    text = markdown(m) + (
        "\n\n_Figures: error against wall time (left to right, top to bottom: lift-off "
        "time against the launch's wall time; landing time, landing point and rest "
        "position against a whole run's), and error against dt / rtol. Measured in "
        f"{time.perf_counter() - t0:.0f} s._")
    return Section(title="Run time against error (work-precision)", markdown=text,
                   figures=figures, headline=headline(m))
