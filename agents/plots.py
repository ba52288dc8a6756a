"""The contest sample program's nine figures of one run, as PNG files."""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def nine_figures(rec, out_dir: str) -> list[str]:
    """The contest sample program's nine figures of the recording `rec`
    (`agents.replay.record_episode`) as PNG files in `out_dir` (created if missing):
    position, attitude, velocity, rate, corner A, corner B, state, forces, torque.
    Returns the nine paths, in that order (file names 1_position.png ... 9_torque.png)."""
    os.makedirs(out_dir, exist_ok=True)
    r = rec.rollout
    t = r.t
    xa, ya, vxa, vya = r.corner("A")
    xb, yb, vxb, vyb = r.corner("B")
    forces = r.contact_forces()
    title = (f"{rec.policy}, target {rec.target_x:+.3f} m, TTRTP "
             f"{'-' if rec.ttrtp is None else f'{rec.ttrtp:.2f} s'}")
    figs = [
        ("1_position", [("x [m]", r.x), ("y [m]", r.y)]),
        ("2_attitude", [("theta [rad]", r.theta)]),
        ("3_velocity", [("vx [m/s]", r.vx), ("vy [m/s]", r.vy)]),
        ("4_rate", [("omega [rad/s]", r.omega)]),
        ("5_corner_A", [("x_A [m]", xa), ("y_A [m]", ya), ("vx_A [m/s]", vxa), ("vy_A [m/s]", vya)]),
        ("6_corner_B", [("x_B [m]", xb), ("y_B [m]", yb), ("vx_B [m/s]", vxb), ("vy_B [m/s]", vyb)]),
        ("7_state", None),
        ("8_contact_forces", [("f_Ax [N]", forces[:, 0]), ("f_Ay [N]", forces[:, 1]),
                              ("f_Bx [N]", forces[:, 2]), ("f_By [N]", forces[:, 3])]),
        ("9_torque", None),
    ]
    paths = []
    for name, panels in figs:
        if name == "7_state":
            fig, ax = plt.subplots(figsize=(8, 3))
            codes = np.array(["ABCDEFG".index(s) for s in r.state])
            ax.step(t, codes, where="post", label="contact state A-G (docs/PHYSICS.md)")
            ax.legend(loc="upper right", fontsize=8)
            ax.set_yticks(range(7), list("ABCDEFG"))
            ax.set_ylabel("state")
            axes = [ax]
        elif name == "9_torque":
            fig, ax = plt.subplots(figsize=(8, 3))
            # policies clip before the env sees the command, so command and applied torque
            # are one curve: draw it once
            ax.step(t, r.torque, where="post", label="applied")
            ax.set_ylabel("torque [N m]")
            ax.legend()
            axes = [ax]
        else:
            fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 * len(panels)), sharex=True)
            axes = np.atleast_1d(axes)
            for ax, (label, data) in zip(axes, panels):
                ax.plot(t, data, lw=1)
                ax.set_ylabel(label)
        if name == "1_position":
            axes[0].axhspan(rec.target_x - r.params.band_half_width,
                            rec.target_x + r.params.band_half_width, color="g", alpha=0.15)
        for ax in axes:
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel("t [s]")
        axes[0].set_title(f"{name[2:].replace('_', ' ')} -- {title}", fontsize=9)
        fig.tight_layout()
        path = os.path.join(out_dir, f"{name}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
