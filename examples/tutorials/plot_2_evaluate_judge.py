"""
Evaluating a policy with the contest judge, and reading the nine figures
========================================================================

The contest scored one number, the *time to reach the target point* (TTRTP): the first
time a bottom corner has stayed on the ground within +-0.05 m of the target for 5 s. The
simulator's judge computes it exactly (every band crossing is a located event). This
tutorial scores policies on a fixed set of seeded targets, as ``python evaluate.py``
does, and then reads the nine figures the contest's sample program drew for one run
(``python evaluate.py --plot DIR``).
"""

# %%
# Score three policies on the same targets
# ----------------------------------------
# ``seeded_targets`` gives the fixed evaluation set (uniform in [-1, 1] m, seed 2015 is
# ``python evaluate.py``'s); ``run_episodes`` runs one episode per target side by side in
# one vector env; ``summarize`` gives ``evaluate.py``'s columns.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from hoprover_env.agents.policies import load_policy
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.evaluation.plots import nine_figures
from hoprover_env.evaluation.replay import record_episode
from hoprover_env.training.evaluate import format_table

targets = seeded_targets(60, seed=2015)
rows, by_name = [], {}
for spec in ("scratch", "bundled", "random"):
    policy = load_policy(spec)
    results = run_episodes(policy, targets)
    by_name[spec] = results
    rows.append((spec, summarize(results)))
print(format_table(rows))

# %%
# ``random`` (uniform random torques) never reaches the band and breaks the rover in most
# episodes: a floor. Each episode's
# record holds the target, success, TTRTP, whether the rover broke, the steps and the
# simulated time:
print(by_name["scratch"][0])

# %%
# The distribution of TTRTP over the targets, and against the distance to go:
fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
for spec in ("scratch", "bundled"):
    tt = np.array([r.ttrtp for r in by_name[spec] if r.success])
    ax[0].hist(tt, bins=np.arange(0, 601, 25), alpha=0.6, label=spec)
    ax[1].plot(
        [abs(r.target_x) for r in by_name[spec] if r.success], tt, "o", ms=4, alpha=0.7, label=spec
    )
ax[0].set(xlabel="TTRTP [s]", ylabel="episodes")
ax[1].set(xlabel="|target x| [m]", ylabel="TTRTP [s]")
for a in ax:
    a.grid(alpha=0.3)
    a.legend()
fig.tight_layout()

# %%
# One run, nine figures
# ---------------------
# ``record_episode`` runs the policy once and replays its torques with samples every
# 0.1 s (the same physics at plotting resolution); ``nine_figures`` writes the contest
# sample program's nine PNG files. Target 0.7 m, the ``scratch`` policy:
rec = record_episode(load_policy("scratch"), 0.7)
print(f"TTRTP {rec.ttrtp:.2f} s, broken {rec.broken}, {len(rec.rollout.events)} events")
out = Path(tempfile.mkdtemp())
paths = nine_figures(rec, str(out))


def show(*names):
    """The PNG files `names` as figures, at their own aspect ratio."""
    for name in names:
        image = plt.imread(out / f"{name}.png")
        height, width = image.shape[:2]
        fig = plt.figure(figsize=(9, 9 * height / width))
        fig.add_axes([0, 0, 1, 1]).imshow(image)
        fig.axes[0].axis("off")


# %%
# **1 position, 3 velocity.** The c.m. path: the launch (x barely moves while the rover
# tips and slides on a corner), one long ballistic flight (y a parabola of a few tens of
# centimetres over minutes: g is 1e-5 of Earth's), a few bounces, the slide to rest. The
# green band on the x panel is the target's +-0.05 m; the judge wants a *corner* in it, so
# the c.m. may rest up to a half-width (0.05 m) beyond the band.
show("1_position", "3_velocity")

# %%
# **2 attitude, 4 rate.** Theta grows during the launch while the rover pivots on a
# corner (to about 0.6 rad in this run), then the policy brings it back near zero in
# flight so that the rover lands flat on both bottom corners; a landing on a top corner
# breaks the rover and ends the episode.
show("2_attitude", "4_rate")

# %%
# **5 corner A, 6 corner B.** The bottom corners' positions and velocities (A right, B
# left). During the launch the rover pivots or slides on one of them (its height stays 0
# while the other lifts); at a bounce both touch at once.
show("5_corner_A", "6_corner_B")

# %%
# **7 state.** The contact state A-G of the contest guide: F at rest, B/D pivoting on
# corner A/B, C/E sliding on it, G sliding on both, A in flight. A typical hop reads
# F > B > C > A, bounces A > E/G, and back to F.
# **9 torque.** The applied torque: the launch torque (about 2e-4 N m in this run),
# torques of the other sign that stop the rotation after lift-off, small corrections in
# flight and while it bounces and settles.
show("7_state", "9_torque")

# %%
# **8 contact forces.** The ground's forces on corners A and B: the normal force falls
# as the launch torque tips the rover, and the rover leaves the ground when it reaches
# zero (the judge's band only counts contact).
show("8_contact_forces")

# %%
# The same figures from the command line:
# ``python evaluate.py --policy scratch --targets 0.7 --plot figs --video hop.gif``.
