"""The stress controllers of the stability stress benchmark (research/stress/drivers.py
runs them): `control_torque` decides the torque at a control instant, a torque schedule
(optionally with the attitude hold in flight) or a randomised hopper that rests,
launches, flies, lands and may press its bouncing corner into the ground;
`controller_params` fills its parameter vector."""

from __future__ import annotations

import numpy as np

from hoprover_env import core
from hoprover_env.core import MODE_A, MODE_B, MODE_C, MODE_D, MODE_E, MODE_F, MODE_G
from hoprover_env.core.params import P_I, P_TMAX
from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold

# Controllers. Both take their numbers from a parameter vector C (C_* slots) and keep
# their memory in a small array (M_* slots), so the same jitted function drives the
# bulk runs and, through a Python wrapper, `simulate` for the cross-check.
CTRL_SCHEDULE, CTRL_HOPPER = 0, 1
(
    C_KP,
    C_KD,
    C_HOLD,
    C_LAUNCH_LO,
    C_LAUNCH_HI,
    C_REST_LO,
    C_REST_HI,
    C_LAUNCH_TIMEOUT,
    C_SETTLE_TIMEOUT,
    C_PRESS,
    C_PRESS_TIME,
    C_PRESS_HEIGHT,
) = range(12)
N_CTRL = 12
PHASE_REST, PHASE_LAUNCH, PHASE_FLY, PHASE_LAND = range(4)
M_PHASE, M_T_MARK, M_RAND_INDEX, M_LAUNCH_TORQUE, M_REST = range(5)
N_MEM = 5

HOLD_KP, HOLD_KD = 0.15, 0.9  # the attitude PD law: torque = -I (kp theta + kd w)


@kernel
def _next_uniform(rand, mem):
    """The next number of the run's pre-drawn uniform [0, 1) stream (cyclic)."""
    i = int(mem[M_RAND_INDEX])
    mem[M_RAND_INDEX] = (i + 1) % rand.shape[0]
    return rand[i]


@kernel
def _press_torque(P, C, mode, th):
    """Torque that pushes the lowest bottom corner (or the contact corner) down.

    A corner with world offset dx from the c.m. is pressed by a torque of the sign of
    dx: in flight its vertical acceleration is -g - (T/I) dx - w^2 dy; in contact its
    normal force grows by m dx / J per unit torque.
    """
    if mode == MODE_B or mode == MODE_C:
        k = 0
    elif mode == MODE_D or mode == MODE_E:
        k = 1
    else:
        _, dya = core.corner_offset(P, 0, th)
        _, dyb = core.corner_offset(P, 1, th)
        k = 0 if dya <= dyb else 1
    dx, _ = core.corner_offset(P, k, th)
    return C[C_PRESS] * P[P_TMAX] * (1.0 if dx > 0.0 else -1.0)


@kernel
def _lowest_height(P, th, y):
    """Height of the lower bottom corner."""
    _, dya = core.corner_offset(P, 0, th)
    _, dyb = core.corner_offset(P, 1, th)
    return y + min(dya, dyb)


@kernel
def control_torque(kind, x, y, th, vx, vy, w, mode, t, step, P, C, sched, rand, mem):
    """The torque command at a control instant (clipping is the kernel's job).

    CTRL_SCHEDULE: sched[step % len(sched)], or with C_HOLD the attitude PD in flight.
    CTRL_HOPPER: rest in F for a random time, launch with a random torque held until
    lift-off (or a timeout), hold the attitude in flight with the PD law
    -I (kp wrap(theta) + kd omega) (hoprover_env.sim.controllers.attitude_hold; without
    C_HOLD: no torque in flight, so it keeps the launch spin and lands at any attitude),
    land with zero torque -- or, with C_PRESS > 0, with a torque pressing the bouncing
    corner down for C_PRESS_TIME after the first touch (and in flight while the lowest
    corner is below C_PRESS_HEIGHT) -- and rest again.
    """
    hold = 0.0
    if C[C_HOLD] != 0.0:
        hold = attitude_hold(th, w, P[P_I], C[C_KP], C[C_KD])
    if kind == CTRL_SCHEDULE:
        if C[C_HOLD] != 0.0 and mode == MODE_A:
            return hold
        return sched[step % sched.shape[0]]
    phase = int(mem[M_PHASE])
    if phase == PHASE_REST:
        if mode == MODE_A:
            mem[M_PHASE] = PHASE_FLY
            return hold
        if mode != MODE_F:
            if t - mem[M_T_MARK] < C[C_SETTLE_TIMEOUT]:
                return 0.0  # still settling: wait (a timeout relaunches)
        elif t - mem[M_T_MARK] < mem[M_REST]:
            return 0.0
        u = _next_uniform(rand, mem)
        sign = 1.0 if _next_uniform(rand, mem) < 0.5 else -1.0
        mem[M_LAUNCH_TORQUE] = (
            sign * P[P_TMAX] * (C[C_LAUNCH_LO] + (C[C_LAUNCH_HI] - C[C_LAUNCH_LO]) * u)
        )
        mem[M_PHASE] = PHASE_LAUNCH
        mem[M_T_MARK] = t
        phase = PHASE_LAUNCH
    if phase == PHASE_LAUNCH:
        if mode == MODE_A:
            mem[M_PHASE] = PHASE_FLY
            return hold
        if t - mem[M_T_MARK] < C[C_LAUNCH_TIMEOUT]:
            return mem[M_LAUNCH_TORQUE]
        phase = PHASE_LAND  # no lift-off: give up, settle, rest, relaunch
        mem[M_PHASE] = PHASE_LAND
        mem[M_T_MARK] = t
    if phase == PHASE_FLY:
        if mode == MODE_A:
            return hold
        mem[M_PHASE] = PHASE_LAND  # first touch
        mem[M_T_MARK] = t
        phase = PHASE_LAND
    # PHASE_LAND: bouncing, sliding, rocking until F
    if mode == MODE_F:
        mem[M_PHASE] = PHASE_REST
        mem[M_T_MARK] = t
        mem[M_REST] = C[C_REST_LO] + (C[C_REST_HI] - C[C_REST_LO]) * _next_uniform(rand, mem)
        return 0.0
    if t - mem[M_T_MARK] > C[C_SETTLE_TIMEOUT]:
        mem[M_PHASE] = PHASE_REST  # never settled (e.g. restitution 1): move on
        mem[M_T_MARK] = t - C[C_SETTLE_TIMEOUT]
        mem[M_REST] = 0.0
        return 0.0
    pressing = C[C_PRESS] > 0.0 and t - mem[M_T_MARK] < C[C_PRESS_TIME]
    if mode == MODE_A:
        if pressing and _lowest_height(P, th, y) < C[C_PRESS_HEIGHT]:
            return _press_torque(P, C, mode, th)
        return hold
    if pressing and mode != MODE_G:
        return _press_torque(P, C, mode, th)
    return 0.0


def controller_params(
    hold=True,
    launch=(0.0, 1.0),
    rest=(1.0, 20.0),
    launch_timeout=60.0,
    settle_timeout=1500.0,
    press=0.0,
    press_time=0.0,
    press_height=1e-3,
) -> np.ndarray:
    c = np.zeros(N_CTRL)
    c[C_KP], c[C_KD], c[C_HOLD] = HOLD_KP, HOLD_KD, float(hold)
    c[C_LAUNCH_LO], c[C_LAUNCH_HI] = launch
    c[C_REST_LO], c[C_REST_HI] = rest
    c[C_LAUNCH_TIMEOUT], c[C_SETTLE_TIMEOUT] = launch_timeout, settle_timeout
    c[C_PRESS], c[C_PRESS_TIME], c[C_PRESS_HEIGHT] = press, press_time, press_height
    return c
