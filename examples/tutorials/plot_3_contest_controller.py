"""
Writing a 2015-style contest controller, in Python and compiled
===============================================================

A contest entry was one function, called every control period with what the rover's
sensors gave:

``Control(pos, vel, the, omg, posT, t, smt, state) -> torque``

(position and velocity of the c.m. [m, m/s], attitude [rad] and rate [rad/s], the target
point, the time, the episode's time limit [s], and the contact state letter A-G).
``hoprover_env.simulate`` calls such a function, unchanged, at every control instant. A
function compiled with numba (the state then arrives as a code 0-6) runs inside the
kernel instead, and ``simulate_batch`` runs populations of
them. We write both: a compiled one-hop controller to calibrate the hop length against
the launch torque, then a Python entry with memory that uses the calibration.
"""

# %%
# A compiled controller: one hop
# ------------------------------
# Hold a launch torque while on the ground until a launch window closes; in flight, the
# PD attitude hold (:func:`hoprover_env.sim.controllers.attitude_hold`, the law every
# controller in the repository flies with) so that the rover lands flat. A numba
# function keeps no memory between calls, so it decides from the state and the time;
# ``simulate_batch(..., controller_args=A)`` hands it row i of A in ``posT[2:]``.
import time

import matplotlib.pyplot as plt
import numba
import numpy as np

from hoprover_env import RoverParams, simulate, simulate_batch
from hoprover_env.agents.policies import ControllerPolicy
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.sim.controllers import attitude_hold

P = RoverParams()  # the contest's rover
KP, KD = 0.15, 0.9  # attitude-hold gains [1/s^2, 1/s]
INERTIA = P.inertia  # [kg m^2]; numba freezes globals when it compiles
FLIGHT = 0  # state code of A


@numba.njit
def one_hop(pos, vel, the, omg, posT, t, smt, state_code):
    if state_code == FLIGHT:
        return attitude_hold(the, omg, INERTIA, KP, KD)
    if t < posT[3]:  # launch window (posT[2] = torque, posT[3] = end)
        return posT[2]
    return 0.0


# %%
# Calibrate: 96 launch torques from 1.1x the tipping torque to the limit, a 20 s launch
# window (strong launches lift off within 14 s and land after 60 s or more), all runs in
# one threaded call. The printout says which launches broke the rover (a top corner
# touched the ground); we drop those from the calibration.
torques = np.geomspace(1.1 * P.tipping_torque, P.torque_max, 96)
args = np.column_stack([torques, np.full_like(torques, 20.0)])
t0 = time.perf_counter()
batch = simulate_batch(
    one_hop,
    targets=np.full(len(torques), 1e3),
    t_end=600.0,
    control_dt=0.5,
    controller_args=args,
    record=False,
)
print(
    f"{len(torques)} hops in {time.perf_counter() - t0:.2f} s (compiling the loop with "
    f"this controller included); broken: {batch.broken.sum()}, launch torques "
    f"{np.round(torques[batch.broken], 7)} N m"
)
ok = ~batch.broken
torques, rest_x = torques[ok], batch.final[ok, 0]  # c.m. x where each hop came to rest [m]
n_impacts = batch.n_impacts[ok]

fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
ax[0].loglog(torques, rest_x, ".-")
ax[0].set(xlabel="launch torque [N m]", ylabel="rest position [m]")
ax[1].plot(rest_x, n_impacts, ".")
ax[1].set(xlabel="rest position [m]", ylabel="impacts in the hop")
for a in ax:
    a.grid(alpha=0.3, which="both")
fig.tight_layout()

# %%
# The hop length grows about like the torque, but not smoothly: the number of bounces
# changes, and with it where the rover stops. An entry that inverts this curve gets
# near the target in one hop and corrects with a second.
order = np.argsort(rest_x)


def launch_torque(distance):
    """The calibrated launch torque [N m] for a hop of `distance` [m] (> 0)."""
    return float(np.interp(distance, rest_x[order], torques[order]))


# %%
# A Python entry with memory
# --------------------------
# The contest's form: an object called every control period. At rest outside the band it
# launches towards the target; it flies with the attitude hold, lets the rover settle,
# and hops again if it stopped outside. The band accepts a bottom corner within 0.05 m
# of the target, so the c.m. may rest up to r + 0.05 = 0.1 m from it.
class Entry:
    def __init__(self):
        self.launching = False
        self.torque = 0.0
        self.hops = 0

    def __call__(self, pos, vel, the, omg, posT, t, smt, state):
        if state == "A":  # in flight
            self.launching = False
            return attitude_hold(the, omg, P.inertia, KP, KD)
        if self.launching:  # tipping or sliding towards lift-off
            return self.torque
        if state != "F":  # landed: bouncing or sliding
            return 0.0
        d = posT[0] - pos[0]
        if abs(d) <= P.half_width + P.band_half_width - 0.01:
            return 0.0  # a corner is in the band: wait 5 s
        self.torque = np.sign(d) * launch_torque(abs(d))
        self.launching, self.hops = True, self.hops + 1
        return self.torque


entry = Entry()
t0 = time.perf_counter()
run = simulate(entry, t_end=600.0, control_dt=0.5, target_x=0.5)
print(
    f"target 0.5 m (the contest's): TTRTP {run.ttrtp:.2f} s in {entry.hops} hop(s), "
    f"{len(run.events)} events, {time.perf_counter() - t0:.2f} s of wall time"
)

# %%
# The run is a :class:`~hoprover_env.Rollout`: sampled arrays and the event log.
fig, ax = plt.subplots(2, 1, figsize=(9, 4.5), sharex=True)
ax[0].plot(run.t, run.x, label="c.m. x")
ax[0].axhspan(0.5 - 0.05, 0.5 + 0.05, color="g", alpha=0.2, label="band")
ax[0].set_ylabel("x [m]")
ax[0].legend()
ax[1].step(run.t, run.torque, where="post")
ax[1].set(xlabel="t [s]", ylabel="torque [N m]")
for a in ax:
    a.grid(alpha=0.3)
ax[0].axvline(run.ttrtp, color="k", lw=0.8)
fig.tight_layout()

# %%
# Scored like any policy
# ----------------------
# ``ControllerPolicy`` makes one entry per episode and feeds it the simulator state, so
# ``run_episodes`` scores it on the evaluation targets with the judge (the same as
# ``python evaluate.py --controller my_entry.py:Entry``):
results = run_episodes(
    ControllerPolicy(Entry, name="calibrated entry"), seeded_targets(40, seed=2015)
)
s = summarize(results)
print(
    f"success {s['success_rate']:.0%}, median TTRTP {s['median_ttrtp']:.1f} s, "
    f"p90 {s['p90_ttrtp']:.1f} s, broken {s['broken']}"
)

# %%
# Python against compiled: the same hop
# -------------------------------------
# The compiled controller runs inside the kernel's loop; a Python one costs a call per
# control instant. Same physics, same result:
one_hop_py = one_hop.py_func
posT_args = np.array([2e-4, 20.0])


def python_one_hop(pos, vel, the, omg, posT, t, smt, state):
    return one_hop_py(
        pos, vel, the, omg, np.r_[posT[:2], posT_args], t, smt, "ABCDEFG".index(state)
    )


compiled = simulate_batch(
    one_hop, targets=[0.6], control_dt=0.5, controller_args=posT_args[None]
).rollout(0)
t0 = time.perf_counter()
slow = simulate(python_one_hop, t_end=600.0, control_dt=0.5, target_x=0.6)
t_py = time.perf_counter() - t0
t0 = time.perf_counter()
simulate_batch(
    one_hop,
    targets=np.full(100, 0.6),
    control_dt=0.5,
    controller_args=np.tile(posT_args, (100, 1)),
    record=False,
)
t_nb = (time.perf_counter() - t0) / 100
print(f"rest x: compiled {compiled.x[-1]:.12f} m, Python {slow.x[-1]:.12f} m")
print(
    f"wall time per run: Python controller {t_py * 1e3:.1f} ms, compiled "
    f"{t_nb * 1e3:.2f} ms (100 runs in one simulate_batch call)"
)
