"""The contest sample program's nine figures of one run, as PNG files.

Positions are in the ground frame (x along the surface, y along its normal, docs/MODEL.md
section 11); the path panel of the position figure turns them by the slope into the
world frame, so an inclined ground shows inclined.
"""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def contact_point_x(roll) -> np.ndarray:
    """x [m] of the contact point the judge uses at each sample of the Rollout `roll`
    (docs/MODEL.md section 8): corner A in B and C, corner B in D and E, the corner nearer
    the target in F and G (x +- r), NaN in flight (A), where there is none."""
    state = np.asarray(roll.state)
    xa, xb = roll.corner("A")[0], roll.corner("B")[0]
    r, xt = roll.params.half_width, roll.target_x
    out = np.full(len(state), np.nan)
    pivot_a, pivot_b = np.isin(state, ("B", "C")), np.isin(state, ("D", "E"))
    out[pivot_a], out[pivot_b] = xa[pivot_a], xb[pivot_b]
    both = np.isin(state, ("F", "G"))
    ra, rb = roll.x + r, roll.x - r
    nearer = np.where(np.abs(ra - xt) <= np.abs(rb - xt), ra, rb)
    out[both] = nearer[both]
    return out


def _ground_text(params) -> str:
    """', slope +0.300 rad (+17.2 deg)' (and the roughness) on terrain, '' on the
    contest's flat, smooth ground."""
    text = ""
    if params.slope:
        text += f", slope {params.slope:+.3f} rad ({math.degrees(params.slope):+.1f} deg)"
    if params.roughness:
        text += f", roughness {params.roughness:.3f} rad"
    return text


def _title(rec) -> str:
    """'scripted, target +0.600 m, TTRTP 12.34 s' and the ground (_ground_text)."""
    return (
        f"{rec.policy}, target {rec.target_x:+.3f} m, TTRTP "
        f"{'-' if rec.ttrtp is None else f'{rec.ttrtp:.2f} s'}"
        f"{_ground_text(rec.rollout.params)}"
    )


def _world(params, x, y):
    """Ground-frame (x, y) turned by the slope into the world frame (gravity down)."""
    c, s = math.cos(params.slope), math.sin(params.slope)
    return x * c - y * s, x * s + y * c


def _draw_path(ax, rec) -> None:
    """The c.m. path over the inclined ground, the target band on the ground and the
    rover's outline at the start and the end, in the world frame at equal scales."""
    r, p = rec.rollout, rec.rollout.params
    w, xt = p.band_half_width, rec.target_x
    px, py = _world(p, r.x, r.y)
    bx, by = _world(p, np.array([xt - w, xt + w]), np.zeros(2))
    span = max(float(np.ptp(np.r_[px, bx])), float(np.ptp(np.r_[py, by])), 0.3)
    # the view: path and band with a margin, widened to the panel's shape by
    # _fill_panel; the ground is drawn far beyond it on both sides
    xs, ys = np.r_[px, bx], np.r_[py, by, _world(p, np.r_[r.x, xt], 0.0 * np.r_[r.x, xt])[1]]
    ax.set_xlim(xs.min() - 0.1 * span, xs.max() + 0.1 * span)
    ax.set_ylim(ys.min() - 0.1 * span, ys.max() + 0.1 * span)
    ends = np.array([xt - 20.0 * span, xt + 20.0 * span])
    gx, gy = _world(p, ends, np.zeros(2))
    ax.fill_between(gx, gy, np.min(gy) - 40.0 * span, color=(0.78, 0.74, 0.67), lw=0, zorder=0)
    ax.plot(gx, gy, color=(0.35, 0.31, 0.24), lw=1.5, label="ground")
    ax.plot(
        bx,
        by,
        color="g",
        lw=6,
        alpha=0.5,
        solid_capstyle="butt",
        label=f"target band {xt:+.3f} +- {w:g} m",
    )
    mx, my = _world(p, np.array([xt, xt]), np.array([0.0, 2.0 * p.half_height]))
    ax.plot(mx, my, color="g", lw=1)
    ax.plot(px, py, lw=1, color="C0", label="c.m. path")
    hw, hh = p.half_width, p.half_height
    for i, style in ((0, ":"), (len(r.t) - 1, "-")):
        c, s = math.cos(r.theta[i]), math.sin(r.theta[i])
        body = np.array(
            [
                (bx_ * c + by_ * s, -bx_ * s + by_ * c)
                for bx_, by_ in ((hw, -hh), (hw, hh), (-hw, hh), (-hw, -hh), (hw, -hh))
            ]
        )
        ax.plot(
            *_world(p, r.x[i] + body[:, 0], r.y[i] + body[:, 1]),
            style,
            color="k",
            lw=1,
            label=f"rover at t = {r.t[i]:.1f} s" if i else "rover at the start",
        )
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("world x [m] (gravity points down)")
    ax.set_ylabel("world y [m]")
    ax.legend(
        loc="lower left",
        bbox_to_anchor=(0.0, 1.0),
        ncol=3,
        fontsize=7,
        frameon=False,
        borderaxespad=0.2,
    )


def _fill_panel(ax) -> None:
    """Widen the x or y limits of the equal-scale Axes `ax` to the shape of its panel,
    so that it fills the panel rather than shrinking to the data's shape."""
    box = ax.get_position(original=True)  # the panel, not the box the aspect shrank
    fw, fh = ax.figure.get_size_inches()
    shape = (box.width * fw) / (box.height * fh)  # panel width / height
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    if (x1 - x0) / (y1 - y0) < shape:
        half = 0.5 * (y1 - y0) * shape
        ax.set_xlim(0.5 * (x0 + x1) - half, 0.5 * (x0 + x1) + half)
    else:
        half = 0.5 * (x1 - x0) / shape
        ax.set_ylim(0.5 * (y0 + y1) - half, 0.5 * (y0 + y1) + half)


def position_figure(rec):
    """The position figure of the recording `rec`: x(t) of the c.m. and of the judge's
    contact point against the target band, y(t), and the path over the (inclined)
    ground. Returns the matplotlib Figure; its first Axes is the x(t) panel."""
    r, p = rec.rollout, rec.rollout.params
    w, xt = p.band_half_width, rec.target_x
    fig = plt.figure(figsize=(8, 7.2), layout="constrained")
    grid = fig.add_gridspec(3, 1, height_ratios=(1.3, 1, 1.3))
    ax_x = fig.add_subplot(grid[0])
    ax_y = fig.add_subplot(grid[1], sharex=ax_x)
    ax_path = fig.add_subplot(grid[2])
    along = " along the ground" if p.slope else ""
    ax_x.axhspan(xt - w, xt + w, color="g", alpha=0.15, label=f"band {xt:+.3f} +- {w:g} m")
    ax_x.plot(r.t, r.x, lw=1, label="c.m. x")
    ax_x.plot(
        r.t,
        contact_point_x(r),
        lw=1.2,
        color="C3",
        label="judge's contact point x (none in flight)",
    )
    if rec.ttrtp is not None:  # the judge's last 5 s, all in the band
        ax_x.axvspan(
            rec.ttrtp - p.dwell_time,
            rec.ttrtp,
            color="0.5",
            alpha=0.15,
            label=f"last {p.dwell_time:g} s before the TTRTP",
        )
    ax_x.set_ylabel(f"x [m]{along}")
    ax_x.legend(loc="best", fontsize=7)
    ax_y.plot(r.t, r.y, lw=1)
    ax_y.set_ylabel("y [m]" + (" normal to the ground" if p.slope else ""))
    ax_y.set_xlabel("t [s]")
    plt.setp(ax_x.get_xticklabels(), visible=False)
    _draw_path(ax_path, rec)
    ax_x.set_title(f"position -- {_title(rec)}", fontsize=9)
    for ax in fig.axes:
        ax.grid(alpha=0.3)
    fig.draw_without_rendering()  # lay the panels out, then fill the path panel
    _fill_panel(ax_path)
    return fig


def nine_figures(rec, out_dir: str) -> list[str]:
    """The contest sample program's nine figures of the recording `rec`
    (`hoprover_env.evaluation.replay.record_episode`) as PNG files in `out_dir` (created if
    missing): position, attitude, velocity, rate, corner A, corner B, state, forces, torque.
    Returns the nine paths, in that order (file names 1_position.png ... 9_torque.png).
    On a slope, titles give it and positions are along / normal to the ground."""
    os.makedirs(out_dir, exist_ok=True)
    r = rec.rollout
    t = r.t
    xa, ya, vxa, vya = r.corner("A")
    xb, yb, vxb, vyb = r.corner("B")
    forces = r.contact_forces()
    title = _title(rec)
    figs = [
        ("1_position", None),
        ("2_attitude", [("theta [rad]", r.theta)]),
        ("3_velocity", [("vx [m/s]", r.vx), ("vy [m/s]", r.vy)]),
        ("4_rate", [("omega [rad/s]", r.omega)]),
        (
            "5_corner_A",
            [("x_A [m]", xa), ("y_A [m]", ya), ("vx_A [m/s]", vxa), ("vy_A [m/s]", vya)],
        ),
        (
            "6_corner_B",
            [("x_B [m]", xb), ("y_B [m]", yb), ("vx_B [m/s]", vxb), ("vy_B [m/s]", vyb)],
        ),
        ("7_state", None),
        (
            "8_contact_forces",
            [
                ("f_Ax [N]", forces[:, 0]),
                ("f_Ay [N]", forces[:, 1]),
                ("f_Bx [N]", forces[:, 2]),
                ("f_By [N]", forces[:, 3]),
            ],
        ),
        ("9_torque", None),
    ]
    paths = []
    for name, panels in figs:
        if name == "1_position":
            fig = position_figure(rec)
            axes = fig.axes
        elif name == "7_state":
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
            assert panels is not None  # every figure without panels is drawn above
            fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 * len(panels)), sharex=True)
            axes = np.atleast_1d(axes)
            for ax, (label, data) in zip(axes, panels):
                ax.plot(t, data, lw=1)
                ax.set_ylabel(label)
        for ax in axes:
            ax.grid(alpha=0.3)
        if name != "1_position":  # its last panel is the path in space
            axes[-1].set_xlabel("t [s]")
        axes[0].set_title(f"{name[2:].replace('_', ' ')} -- {title}", fontsize=9)
        if name != "1_position":  # laid out by matplotlib's constrained layout
            fig.tight_layout()
        path = os.path.join(out_dir, f"{name}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
