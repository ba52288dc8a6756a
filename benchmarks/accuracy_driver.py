"""The launch-and-land scenario of benchmarks/bench_accuracy.py and its Python side:
an integrator setting (`Method`), what one run found (`Run`), and `Driver`, which owns
the arrays of research/launch_land.py's compiled `run_scenario`, runs it and times it.
The PD attitude hold and the control grid of the flight are the scenario's (KP, KD,
CONTROL_DT, T_END); bench_accuracy.py chooses the torques, targets and sweeps."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from hoprover_env import RoverParams, core
from hoprover_env.sim.simulate import make_options, make_state
from research.launch_land import (
    N_RESULT,
    R_END_T,
    R_FLAG,
    R_LAND_T,
    R_LAND_X,
    R_LIFTOFF_T,
    R_N_IMPACTS,
    R_N_SEQ,
    R_REST_T,
    R_REST_X,
    R_TTRTP,
    SEQ_LEN,
    TIMING_EVENTS,
    repeat_launch,
    run_scenario,
)

# ----------------------------------------------------------------------------------
# The scenario: launch, attitude hold in flight, idle once landed
# ----------------------------------------------------------------------------------
KP, KD = 0.15, 0.9  # PD attitude hold in flight [1/s^2, 1/s]
CONTROL_DT = 0.1  # s between control instants
T_END = 600.0  # s, a cap; a run ends once the rover rests and is judged


# ----------------------------------------------------------------------------------
# Python side: methods, runs, timing
# ----------------------------------------------------------------------------------
TIMING_BUDGET = 0.2  # s of repeats per cheap timed run (best of them is kept)
MAX_REPEATS = 30
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
    flag: int  # 0 fine, 1 broken, 2 kernel error, 3 no rest by T_END
    seq: tuple  # mode-sequence codes (event kind * 8 + mode after)
    final: np.ndarray  # (x, y, theta, vx, vy, omega) when the driver stopped
    wall: float = math.nan  # best wall time of the run [s]


class Driver:
    """Owns the arrays run_scenario works in (allocated once, reused by every run)."""

    def __init__(self, params: RoverParams):
        self.params = params
        self.p = params.as_array()
        self.ev = np.zeros((core.MAX_EVENTS + 64, core.EV_COLS))
        self.w = np.zeros(core.N_WORK)
        self.res = np.zeros(N_RESULT)
        self.seq = np.zeros(SEQ_LEN, dtype=np.int64)

    def run(
        self,
        method: Method,
        torque: float,
        target_x: float,
        timing: int = TIMING_EVENTS,
        repeats: int = 1,
    ) -> Run:
        """Run the scenario `repeats` times (it is deterministic); wall = the best."""
        o = method.options()
        s0 = make_state(self.params, target_x)
        best = math.inf
        for _ in range(repeats):
            s = s0.copy()
            t0 = time.perf_counter()
            run_scenario(
                s,
                self.p,
                o,
                timing,
                torque,
                KP,
                KD,
                CONTROL_DT,
                T_END,
                self.ev,
                self.w,
                self.res,
                self.seq,
            )
            best = min(best, time.perf_counter() - t0)
        r = self.res
        n_seq = int(r[R_N_SEQ])
        if n_seq > SEQ_LEN:
            raise RuntimeError(
                f"{method.label}, torque {torque:g}: {n_seq} mode changes, "
                f"more than SEQ_LEN = {SEQ_LEN} can be compared"
            )
        return Run(
            liftoff_t=r[R_LIFTOFF_T],
            land_t=r[R_LAND_T],
            land_x=r[R_LAND_X],
            rest_t=r[R_REST_T],
            rest_x=r[R_REST_X],
            ttrtp=r[R_TTRTP],
            end_t=r[R_END_T],
            n_impacts=int(r[R_N_IMPACTS]),
            flag=int(r[R_FLAG]),
            seq=tuple(int(c) for c in self.seq[:n_seq]),
            final=s[:6].copy(),
            wall=best,
        )

    def timed_run(
        self, method: Method, torque: float, target_x: float, timing: int = TIMING_EVENTS
    ) -> Run:
        """Best of several runs: the machine is shared, so a cheap run is repeated for
        ~TIMING_BUDGET s (at most 1 + MAX_REPEATS runs), one under a second 3 times,
        a longer one once."""
        run = self.run(method, torque, target_x, timing)
        more = (
            0
            if run.wall >= 1.0
            else max(2, min(MAX_REPEATS, int(TIMING_BUDGET / max(run.wall, 1e-9))))
        )
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
    return tuple(
        core.EVENT_NAMES.index(e[1]) * 8 + core.MODE_LETTERS.index(e[3])
        for e in events
        if e[1] not in JUDGE_EVENTS
    )
