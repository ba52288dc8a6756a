"""
Monte Carlo over parameters with ``simulate_batch``
===================================================

How sure is a hop? The contest fixed the rover's parameters; a real one would know its
friction, restitution and gravity only roughly. ``simulate_batch`` runs N whole episodes
in one threaded kernel call, each with its own parameters, and run i equals
``simulate`` of run i bit for bit. Here: one hop plan, 2000 rovers with randomised
parameters, and where they come to rest.
"""

# %%
# One hop plan, 2000 parameter draws
# ----------------------------------
# The controller is the repository's compiled hop plan
# (:func:`hoprover_env.agents.compiled.planned_hops`): a launch torque held on the ground during a
# time window, the PD attitude hold in flight, zero torque otherwise. Its plan arrives
# per run through ``controller_args``: (inertia, kp, kd) and then (start, duration,
# torque) per hop. One hop: 2.3e-4 N m from t = 0 for at most 20 s. ``randomize`` scales
# each listed parameter of run i by U(1 - r, 1 + r), drawn from ``seed``.
import time

import matplotlib.pyplot as plt
import numpy as np

from hoprover_env import RoverParams, simulate, simulate_batch
from hoprover_env.agents.compiled import hop_plan, planned_hops

N = 2000
base = RoverParams()
plan = np.array([base.inertia, 0.15, 0.9, 0.0, 20.0, 2.3e-4])
spread = {
    "mu_static": 0.2,
    "mu_dynamic": 0.2,
    "restitution_x": 0.1,
    "restitution_y": 0.3,
    "gravity": 0.1,
}
first = simulate_batch(
    planned_hops, targets=[0.6], control_dt=0.5, controller_args=plan[None], t_end=600.0
)  # compiles the loop
t0 = time.perf_counter()
batch = simulate_batch(
    planned_hops,
    targets=np.full(N, 0.6),
    t_end=600.0,
    control_dt=0.5,
    controller_args=np.tile(plan, (N, 1)),
    randomize=spread,
    seed=1,
    record=False,
)
wall = time.perf_counter() - t0
print(
    f"{N} runs of up to 600 s in {wall:.2f} s ({wall / N * 1e3:.2f} ms per run, "
    f"{batch.n_events.sum()} events, {batch.n_impacts.sum()} impacts)"
)
print(f"broken: {batch.broken.mean():.1%}, target 0.6 m reached: {batch.success.mean():.1%}")

# %%
# The nominal rover for comparison, and the run-i-equals-simulate check:
fixed = hop_plan(plan)  # the same plan, compiled into a controller
nominal = simulate(fixed, t_end=600.0, control_dt=0.5, target_x=0.6)
again = simulate(fixed, t_end=600.0, control_dt=0.5, target_x=0.6, params=batch.params[7])
print(f"nominal rest x {nominal.x[-1]:.4f} m, TTRTP {nominal.ttrtp}")
print(f"run 7: batch x {batch.final[7, 0]:.15f}, simulate x {again.x[-1]:.15f}")

# %%
# Where the rovers stop
# ---------------------
# The spread of the rest position over the runs that did not break:
ok = ~batch.broken
x_rest = batch.final[ok, 0]
fig, ax = plt.subplots(figsize=(7, 3.3))
ax.hist(x_rest, bins=60)
ax.axvline(nominal.x[-1], color="k", lw=1, label="nominal parameters")
ax.axvspan(0.6 - 0.1, 0.6 + 0.1, color="g", alpha=0.15, label="c.m. within r + w of 0.6 m")
ax.set(xlabel="rest position of the c.m. [m]", ylabel="runs")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# Each parameter's relative draw against the rest position, with the rank correlation:


def rank(a):
    return np.argsort(np.argsort(a))


fig, axes = plt.subplots(1, len(spread), figsize=(12, 2.8), sharey=True)
for ax, name in zip(axes, spread):
    rel = np.array([getattr(p, name) for p in batch.params])[ok] / getattr(base, name)
    rho = np.corrcoef(rank(rel), rank(x_rest))[0, 1]
    ax.plot(rel, x_rest, ".", ms=1.5, alpha=0.5)
    ax.set(xlabel=f"{name} / nominal", title=f"rank corr. {rho:+.2f}")
    ax.grid(alpha=0.3)
axes[0].set_ylabel("rest x [m]")
fig.tight_layout()

# %%
# Per-run parameters can also be given explicitly (``params=[RoverParams(...), ...]``)
# and so can initial states (see also :doc:`plot_3_contest_controller`). With
# ``record=False``, as above, a batch keeps only the per-run summaries; a recorded batch
# (the default) keeps every sample and event, and ``rollout(i)`` gives run i as a
# :class:`~hoprover_env.Rollout`:
r = first.rollout(0)
print(
    f"{len(r.events)} events, states in order of first visit: "
    f"{''.join(dict.fromkeys(r.state))}, TTRTP {r.ttrtp:.2f} s"
)
