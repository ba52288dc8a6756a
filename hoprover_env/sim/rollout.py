"""Whole runs of `simulate`: `run_rollout` drives the compiled control loop
(control_loop.py: the loop, the compiled controllers, the kernel layout) and calls a
plain Python controller whenever the loop returns for a command; `build_rollout` turns a
finished run's arrays into the `Rollout` it produces (each run of `simulate_batch` too),
and `check_status` and `budget_error` the status of a run that stopped into the
exception `simulate` raises.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hoprover_env import core
from hoprover_env.core.params import RoverParams
from hoprover_env.sim import control_loop
from hoprover_env.sim.control_loop import (
    CTRL_COMPILED,
    CTRL_PYTHON,
    CTRL_SCHEDULE,
    G_CMD,
    G_CMD_K,
    G_K,
    G_LOG,
    G_ROWS,
    G_STATUS,
    ST_BAD_TORQUE,
    ST_BUDGET,
    ST_NEED_COMMAND,
    ST_ROOM,
    Buffers,
    control_function,
    is_compiled,
    kernel_one,
    loop_kind,
    scratch,
)
from hoprover_env.util.validate import check_torque


def budget_error(t: float, code: float = core.ERR_BUDGET) -> Exception:
    """The exception for a kernel that stopped on one of its bounds (S[S_ERROR])."""
    if code == core.ERR_WORK:
        # a ValueError: the call asked for more than one call may do (like a grid of too
        # many samples), not a failure of the integrator
        return ValueError(
            f"the control interval ending after t = {t:.9g} s needs more than "
            f"{core.MAX_WORK:.0e} integration steps (control_dt / t_stop too long for "
            "the torque: held for that long it spins the rover at up to millions of "
            "rad/s); shorten control_dt / t_stop or lower the torque (torque_max)"
        )
    if code == core.ERR_STEP:
        return RuntimeError(
            f"the integrator could not continue at t = {t:.9g} s (step-size underflow, a "
            "non-finite state or an iteration bound): the motion is too stiff to integrate, "
            "e.g. parameters close to the Painleve limit of a slide; please report this state"
        )
    return RuntimeError(
        f"event budget of one control interval exhausted at t = {t:.9g} s "
        f"(more than {core.MAX_EVENTS} events); please report this state"
    )


STATE_LETTERS = np.array(list(core.MODE_LETTERS))


def check_status(prog: np.ndarray, S: np.ndarray, where: str = "") -> None:
    """Turn a run's error status into the exception `simulate` raises."""
    status = prog[G_STATUS]
    if status == ST_BUDGET:
        err = budget_error(float(S[core.S_T]), float(S[core.S_ERROR]))
        raise type(err)(where + str(err))
    if status == ST_BAD_TORQUE:
        try:
            check_torque(prog[G_CMD], "the controller's torque")
        except ValueError as err:
            raise ValueError(where + str(err)) from None


@dataclasses.dataclass
class SampledStates:
    """Sampled states of one run (1-D arrays) or of N runs (2-D, a row per run): time t
    [s], c.m. position x, y [m], attitude theta [rad], velocities vx, vy [m/s] and omega
    [rad/s], contact state letters 'A'..'G', slide direction sigma of the contact point
    (+1/-1 in C, E, G, else 0)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    omega: np.ndarray
    state: np.ndarray
    sigma: np.ndarray


@dataclasses.dataclass
class Rollout(SampledStates):
    """A simulated run. Arrays are sampled at t = 0, at every control instant (the state
    the controller saw, before its new torque acts) and at the end of the run."""

    torque: np.ndarray  # applied torque from each sample on (clipped)
    torque_cmd: np.ndarray  # what the controller asked for
    events: list  # (time, kind, state before, state after)
    ttrtp: float | None
    broken: bool
    target_x: float
    params: RoverParams
    impact_energy_ratios: np.ndarray  # KE after / KE before, one per impact
    n_events: int
    min_corner_height: float  # lowest bottom-corner height after any event or interval
    seed: int | None = None  # key of the rough-terrain draws (None: smooth ground)
    rover: int = 0  # the run's rover index, the other half of that key
    # what replays this run: simulate(**rollout.replay_args) gives it again, bit for bit
    replay_args: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)

    @property
    def success(self) -> bool:
        """Whether the judge's TTRTP was reached."""
        return self.ttrtp is not None

    def corner(self, which: str):
        """World position (x, y) and velocity (vx, vy) arrays of corner 'A' or 'B'."""
        k = {"A": 0, "B": 1}[which]
        bx = self.params.half_width * (1.0 if k == 0 else -1.0)
        by = -self.params.half_height
        c, s = np.cos(self.theta), np.sin(self.theta)
        dx, dy = bx * c + by * s, -bx * s + by * c
        return (self.x + dx, self.y + dy, self.vx + self.omega * dy, self.vy - self.omega * dx)

    def contact_forces(self):
        """(fAx, fAy, fBx, fBy) arrays at the samples, under the torque then applied.

        A sample at a control instant holds the state before the new torque acts; when
        that torque ends the state at once (a corner of state F unloaded by a tipping
        torque), the forces are those of the state the kernel switches to, not the
        negative normal force the old state would need."""
        p = self.params.as_array()
        out = np.zeros((len(self.t), 4))
        s = np.zeros(core.N_STATE)
        no_log = np.zeros((0, core.EV_COLS))
        for i in range(len(self.t)):
            s[:] = 0.0
            s[:6] = (self.x[i], self.y[i], self.theta[i], self.vx[i], self.vy[i], self.omega[i])
            s[core.S_T] = self.t[i]
            s[core.S_MODE] = core.MODE_LETTERS.index(self.state[i])
            s[core.S_TORQUE] = self.torque[i]
            s[core.S_SIGMA] = self.sigma[i]
            core.settle(s, p, no_log, 0)
            out[i] = core.contact_forces(s, p)
        return out


def build_rollout(rows, cmds, applied, log, prog, S, params, target_x):
    """The `Rollout` of one finished run from its kernel arrays."""
    nr = int(prog[G_ROWS])
    nl = int(prog[G_LOG])
    a = rows[:nr]
    ev = log[:nl]
    kinds = ev[:, 1].astype(np.int64).tolist()
    names = core.EVENT_NAMES
    letters = core.MODE_LETTERS
    events = [
        (t, names[kd], letters[b], letters[af])
        for t, kd, b, af in zip(
            ev[:, 0].tolist(),
            kinds,
            ev[:, 2].astype(np.int64).tolist(),
            ev[:, 3].astype(np.int64).tolist(),
        )
    ]
    ttrtp = S[core.S_TTRTP]
    return Rollout(
        t=a[:, core.S_T],
        x=a[:, core.S_X],
        y=a[:, core.S_Y],
        theta=a[:, core.S_TH],
        vx=a[:, core.S_VX],
        vy=a[:, core.S_VY],
        omega=a[:, core.S_W],
        state=STATE_LETTERS[a[:, core.S_MODE].astype(np.int64)],
        torque=applied[:nr].copy(),
        torque_cmd=cmds[:nr].copy(),
        events=events,
        ttrtp=None if math.isnan(ttrtp) else float(ttrtp),
        broken=bool(S[core.S_BROKEN]),
        target_x=float(target_x),
        params=params,
        impact_energy_ratios=ev[ev[:, 1] == core.EV_IMPACT, 4],
        n_events=int(S[core.S_NEVENTS]),
        sigma=a[:, core.S_SIGMA],
        min_corner_height=float(S[core.S_MIN_HEIGHT]),
    )


def run_rollout(
    S,
    P,
    O,
    schedule,
    controller,
    control_dt,
    t_end,
    n_ctrl,
    sub,
    target_x,
    params,
    controller_args=None,
):
    """`simulate`'s run: a torque schedule (1-D float64, checked finite), a compiled
    controller, or a Python controller (called here at every control instant with the
    contest's arguments), through the one compiled loop. Returns the `Rollout`."""
    run = kernel_one(loop_kind(O, P))
    if schedule is not None:
        source, ctrl = CTRL_SCHEDULE, control_loop.no_control
    elif is_compiled(controller):
        source, ctrl = CTRL_COMPILED, control_function(controller)
    else:
        source, ctrl = CTRL_PYTHON, control_loop.no_control
    sched = np.zeros(0) if schedule is None else np.ascontiguousarray(schedule, np.float64)
    buf = Buffers(1, n_ctrl * sub + 1, 256)
    prog = buf.prog[0]
    no_args = np.zeros(0) if controller_args is None else controller_args
    evbuf, w, backup, cbuf = scratch(1, len(no_args))
    pos_t = np.array([float(target_x), 0.0])
    while True:
        run(
            S,
            P,
            O,
            sched,
            ctrl,
            source,
            no_args,
            float(control_dt),
            float(t_end),
            n_ctrl,
            sub,
            True,
            buf.rows[0],
            buf.cmds[0],
            buf.applied[0],
            buf.log[0],
            prog,
            evbuf[0],
            w[0],
            backup[0],
            cbuf[0],
        )
        status = prog[G_STATUS]
        if status == ST_ROOM:
            buf.grow_log()
        elif status == ST_NEED_COMMAND:
            prog[G_CMD] = check_torque(
                controller(
                    S[0:2].copy(),
                    S[3:5].copy(),
                    float(S[core.S_TH]),
                    float(S[core.S_W]),
                    pos_t.copy(),
                    float(S[core.S_T]),
                    float(t_end),
                    core.MODE_LETTERS[int(S[core.S_MODE])],
                ),
                "the controller's torque",
            )
            prog[G_CMD_K] = prog[G_K]
        else:
            break
    check_status(prog, S)
    return build_rollout(
        buf.rows[0], buf.cmds[0], buf.applied[0], buf.log[0], prog, S, params, target_x
    )
