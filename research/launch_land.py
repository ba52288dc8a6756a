"""One launch-and-land run as a single compiled call, for timing the integrators.

The scenario: from rest, a constant launch torque held until the rover lifts off; the
PD attitude hold (hoprover_env.sim.controllers.attitude_hold) in flight at control
instants; zero torque from the first touchdown on, through the bounces and the slide,
until the rover rests (F) and the judge has decided. `run_scenario` loops
`core.advance` itself, so a run's wall time is the integrator's and not Python's (a
Python controller costs ~8 us per control step, more than the event integrator's
whole flight step); benchmarks/bench_accuracy.py times it and checks it bit for bit
against `simulate` with `contest_controller` (the same controller in Python) and
against a loop over `RoverSim`.
"""

from __future__ import annotations

import math

import numpy as np

from hoprover_env import core
from hoprover_env.core.params import P_I
from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold

# Slots of the result vector the driver fills (NaN until the thing happens).
R_LIFTOFF_T = 0  # first lift-off
R_LAND_T = 1  # first touchdown after it
R_LAND_X = 2  # c.m. x at that touchdown (an impact changes velocities, not x;
# the attitude hold lands the body flat, so the contact points
# are x -+ r there)
R_REST_T = 3  # when it came to rest (state F) after landing
R_REST_X = 4  # c.m. x at rest
R_TTRTP = 5  # the judge's time to reach the target point
R_END_T = 6  # simulated time when the driver stopped
R_N_IMPACTS = 7
R_N_SEQ = 8  # mode-sequence codes written into `seq` (may exceed its length)
R_FLAG = 9  # 0 fine, 1 broken, 2 kernel error, 3 hit T_END before resting
N_RESULT = 10
SEQ_LEN = 256  # codes kept: kind * 8 + mode after, for every non-judge event

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
IDLE_CHUNK = 1.0  # s: after landing, how often the driver checks for rest


@kernel
def _advance_and_record(S, P, O, torque, t_stop, ev, W, res, seq, n_seq):
    """One `core.advance` call, then the bookkeeping: mode-sequence codes from the
    event log, the rest time, and the first lift-off / first landing if `advance`
    stopped on them (S_STOP_ON names the one awaited). Returns the new code count."""
    n = core.advance(S, P, O, torque, t_stop, ev, W)
    if S[core.S_STOPPED] != 0.0:
        if S[core.S_STOP_ON] == core.EV_LIFTOFF:
            res[R_LIFTOFF_T] = S[core.S_T]
            S[core.S_STOP_ON] = core.EV_IMPACT  # next: the first touchdown
        elif S[core.S_STOP_ON] == core.EV_IMPACT:
            res[R_LAND_T] = S[core.S_T]
            res[R_LAND_X] = S[core.S_X]
            S[core.S_STOP_ON] = -1.0
    for i in range(min(n, ev.shape[0])):
        kind = int(ev[i, 1])
        if kind == core.EV_BAND_IN or kind == core.EV_BAND_OUT or kind == core.EV_TTRTP:
            continue  # judge bookkeeping, not a change of mode
        after = int(ev[i, 3])
        if n_seq < seq.shape[0]:
            seq[n_seq] = kind * 8 + after
        n_seq += 1
        if after == core.MODE_F and not math.isnan(res[R_LAND_T]):
            res[R_REST_T] = ev[i, 0]
    return n_seq


@kernel
def _healthy(S):
    return S[core.S_BROKEN] == 0.0 and S[core.S_ERROR] == 0.0


@kernel
def _at_rest_and_judged(S, res):
    """Landed, at rest on both corners (nothing moves again under zero torque), and
    the judge has either given its TTRTP or can never give one (out of the band)."""
    return (
        not math.isnan(res[R_LAND_T])
        and int(S[core.S_MODE]) == core.MODE_F
        and (S[core.S_INBAND] == 0.0 or not math.isnan(S[core.S_TTRTP]))
    )


@kernel
def run_scenario(S, P, O, timing, launch_torque, kp, kd, control_dt, t_end, ev, W, res, seq):
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
                torque = (
                    0.0
                    if phase == PHASE_LANDED
                    else attitude_hold(S[core.S_TH], S[core.S_W], inertia, kp, kd)
                )
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
            torque = attitude_hold(S[core.S_TH], S[core.S_W], inertia, kp, kd)
            n_seq = _advance_and_record(
                S, P, O, torque, min(t_liftoff + k * control_dt, t_end), ev, W, res, seq, n_seq
            )
        # idle from the touchdown on, in chunks only to notice the rest
        while _healthy(S) and not _at_rest_and_judged(S, res) and S[core.S_T] < t_end:
            n_seq = _advance_and_record(
                S, P, O, 0.0, min(S[core.S_T] + IDLE_CHUNK, t_end), ev, W, res, seq, n_seq
            )
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


@kernel
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


def contest_controller(launch_torque: float, inertia: float, kp: float, kd: float):
    """TIMING_GRID's controller in Python, with the contest signature, for simulate()."""
    phase = ["launch"]

    def control(pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            if phase[0] == "launch":
                phase[0] = "flight"
            if phase[0] == "landed":
                return 0.0
            return attitude_hold(float(the), float(omg), inertia, kp, kd)
        if phase[0] == "launch":
            return launch_torque
        phase[0] = "landed"
        return 0.0

    return control
