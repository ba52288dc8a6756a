"""Scripted scenarios shared by the benchmarks (deterministic, contest signature)."""

import numpy as np

from hoprover_env import RoverParams
from hoprover_env.sim.controllers import attitude_hold

HOLD_KP, HOLD_KD = 0.1, 0.8  # the PD attitude hold's gains in flight


class HopSequence:
    """Hop back and forth: from rest, a launch torque (alternating sign, cycling through
    `torques`) held until lift-off, attitude hold in flight, rest 5 s after stopping."""

    def __init__(
        self, torques=(3e-4, 1.5e-4, 4e-4, 2e-4), rest=5.0, params: RoverParams | None = None
    ):
        self.torques = torques
        self.rest = rest
        self.inertia = (params or RoverParams()).inertia
        self.reset()

    def reset(self):
        self.k = 0
        self.phase = "rest"
        self.t_mark = 0.0

    def __call__(self, pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            self.phase = "fly"
            return attitude_hold(float(the), float(omg), self.inertia, HOLD_KP, HOLD_KD)
        if self.phase == "fly":  # landed: bouncing, sliding
            if state == "F":
                self.phase, self.t_mark = "rest", t
            return 0.0
        if self.phase == "rest":
            if t - self.t_mark >= self.rest:
                self.phase = "launch"
                self.k += 1
            return 0.0
        torque = self.torques[self.k % len(self.torques)]
        return torque if self.k % 2 else -torque


def hop_schedule(control_dt=0.1, t_end=600.0):
    """The torque schedule the HopSequence produces under the event integrator: an
    open-loop input for kernel-only timings."""
    from hoprover_env import simulate

    roll = simulate(HopSequence(), t_end=t_end, control_dt=control_dt, target_x=0.0)
    return np.asarray(roll.torque_cmd[:-1])
