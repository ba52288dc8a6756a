"""Frames and figures draw the inclined ground, the target on it, and the
judge's contact point beside the c.m."""

import math

import gymnasium as gym
import numpy as np
import pytest

import hoprover_env  # noqa: F401  (registers the env ids)
from hoprover_env import RoverParams, simulate
from tests.helpers import launch_then_hold

pytest.importorskip("pygame")

GROUND_LINE = (90, 80, 60)  # hoprover_env/envs/rendering.py's colours
BAND = (120, 200, 120)
TARGET_MARK = (40, 120, 40)
CORNER_A, CORNER_B = (20, 20, 20), (255, 255, 255)
TEXT_ROWS = 70  # the overlay text (and its box) lies above this row


def _pixels(frame, colour, below=TEXT_ROWS):
    """(rows, cols) of the pixels of exactly `colour` below the overlay text."""
    rows, cols = np.nonzero(np.all(frame == np.array(colour, np.uint8), axis=-1))
    keep = rows >= below
    return rows[keep].astype(float), cols[keep].astype(float)


def _ground_fit(frame):
    """Least-squares line row = a col + b through the ground line's pixels (the mean row
    of its pixels in each column; columns the rover or band hide have none)."""
    rows, cols = _pixels(frame, GROUND_LINE)
    ucols = np.unique(cols)
    mean_rows = np.array([rows[cols == c].mean() for c in ucols])
    assert len(ucols) > 0.6 * frame.shape[1], "the ground line crosses the picture"
    return np.polyfit(ucols, mean_rows, 1)


def _draw(slope, target=0.6, state=None, letter="F"):
    from hoprover_env.envs.rendering import Renderer

    params = RoverParams(slope=slope)
    state = (0.0, params.half_height, 0.0) if state is None else state
    return Renderer().draw(state, params, target, [tuple(state[:2])], 3.0, letter, 0.0)


@pytest.mark.parametrize("slope", [-0.3, 0.2, 0.45])
def test_frame_ground_band_target_and_rover_follow_the_slope(slope):
    frame, flat = _draw(slope), _draw(0.0)
    assert not np.array_equal(frame, flat)
    # the ground rises toward +x for slope > 0: rows (downward) fall with the column
    a, b = _ground_fit(frame)
    assert a == pytest.approx(-math.tan(slope), abs=0.01)
    # the target band lies across that line (band pixels above and below the line in
    # its columns), and is inclined with it
    rows, cols = _pixels(frame, BAND)
    assert rows.size > 20
    line_rows, line_cols = _pixels(frame, GROUND_LINE)
    across = [
        rows[cols == c].min() < line_rows[line_cols == c].min()
        and rows[cols == c].max() > line_rows[line_cols == c].max()
        for c in np.unique(cols)
        if np.any(line_cols == c)
    ]
    assert len(across) > 10 and np.mean(across) > 0.8
    assert np.polyfit(cols, rows, 1)[0] == pytest.approx(-math.tan(slope), abs=0.1)
    # the target mark stands along the ground's normal: d col / d row = tan(slope)
    rows, cols = _pixels(frame, TARGET_MARK)
    assert np.ptp(rows) > 30
    assert np.polyfit(rows, cols, 1)[0] == pytest.approx(math.tan(slope), abs=0.03)
    # the rover at rest on the ground: its bottom corners B -> A run along the ground
    ra, ca = _pixels(frame, CORNER_A)
    rb, cb = _pixels(frame, CORNER_B)
    direction = (ra.mean() - rb.mean()) / (ca.mean() - cb.mean())
    assert direction == pytest.approx(-math.tan(slope), abs=0.1)
    assert abs(ra.mean() - (a * ca.mean() + b)) < 3.0


def test_flat_frame_keeps_the_level_ground_row():
    # level ground is the 2-pixel row at 0.88 of the height, as before the slope came
    frame = _draw(0.0)
    rows, cols = _pixels(frame, GROUND_LINE)
    ground = int(0.88 * frame.shape[0])
    assert set(rows) == {ground, ground + 1} and len(set(cols)) > 0.9 * frame.shape[1]
    # a slope of -0.0 is level ground (the kernel normalises it too)
    assert np.array_equal(frame, _draw(-0.0))


def test_env_frames_draw_the_slope_of_their_params():
    env = gym.make("HopRover-v0", params={"slope": 0.2}, render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(6):
        env.step(np.array([0.9], np.float32))
        frames.append(env.render())
    env.close()
    for frame in (frames[0], frames[-1]):
        assert _ground_fit(frame)[0] == pytest.approx(-math.tan(0.2), abs=0.01)
    venv = hoprover_env.vector_env_class("HopRover-v0")(
        2, render_mode="rgb_array", params={"slope": -0.25}
    )
    venv.reset(seed=0)
    for frame in venv.render():
        assert _ground_fit(frame)[0] == pytest.approx(math.tan(0.25), abs=0.01)
    venv.close()


# ------------------------------------------------------------------ the figures
def _recording(roll, policy="test"):
    from hoprover_env.evaluation.replay import Recording

    return Recording(policy, roll.target_x, roll.ttrtp, roll.broken, 0.5, roll)


def _line(ax, label_start):
    found = [ln for ln in ax.get_lines() if ln.get_label().startswith(label_start)]
    assert len(found) == 1, [ln.get_label() for ln in ax.get_lines()]
    return found[0]


def test_position_figure_shows_the_contact_point_in_the_band_beside_the_cm():
    # at rest with the target 0.09 m ahead: the c.m. (x = 0) never enters the band
    # [0.04, 0.14], corner A (x = 0.05) is in it from the start, so TTRTP = 5 s
    import matplotlib.pyplot as plt

    from hoprover_env.evaluation.plots import position_figure

    roll = simulate(
        [0.0],
        t_end=8.0,
        control_dt=0.5,
        target_x=0.09,
        params=RoverParams(slope=0.2),
        sample_dt=0.25,
    )
    assert roll.ttrtp == pytest.approx(5.0)
    fig = position_figure(_recording(roll))
    try:
        ax = fig.axes[0]
        contact = _line(ax, "judge's contact point")
        cm = _line(ax, "c.m. x")
        t, xc = contact.get_data()
        np.testing.assert_array_equal(t, roll.t)
        np.testing.assert_allclose(xc, roll.x + 0.05, atol=1e-12)
        assert np.all(np.abs(xc - 0.09) <= 0.05) and np.all(np.abs(cm.get_ydata() - 0.09) > 0.05)
        assert "slope +0.200 rad" in ax.get_title()
        assert any("band" in p.get_label() for p in ax.patches)
        # the path panel draws the ground inclined by the slope
        gx, gy = _line(fig.axes[2], "ground").get_data()
        assert (gy[1] - gy[0]) / (gx[1] - gx[0]) == pytest.approx(math.tan(0.2), rel=1e-9)
    finally:
        plt.close(fig)


def test_contact_point_follows_the_judge_through_a_hop():
    # launch, fly, land, slide: the plotted contact point is in the band exactly when the
    # kernel's judge says so (its band_in / band_out events), and absent in flight
    from hoprover_env.evaluation.plots import contact_point_x

    roll = simulate(
        launch_then_hold(2e-4),
        t_end=250.0,
        control_dt=0.5,
        target_x=0.35,
        params=RoverParams(slope=0.1),
        sample_dt=0.5,
    )
    letters = set(roll.state)
    assert {"A", "C"} <= letters and letters & {"F", "G"}, letters
    xc = contact_point_x(roll)
    flight = roll.state == "A"
    assert np.all(np.isnan(xc[flight])) and np.all(np.isfinite(xc[~flight]))
    on_a = np.isin(roll.state, ("B", "C"))
    np.testing.assert_array_equal(xc[on_a], roll.corner("A")[0][on_a])
    band = [
        (t, kind == "band_in") for t, kind, *_ in roll.events if kind in ("band_in", "band_out")
    ]
    assert any(inside for _, inside in band), "the run reaches the band"
    in_band = np.abs(xc - roll.target_x) <= roll.params.band_half_width
    checked = 0
    for i, t in enumerate(roll.t):
        if any(abs(t - te) < 1e-6 for te, _ in band):
            continue  # a sample on a crossing: either side is right
        judge = ([inside for te, inside in band if te < t] or [False])[-1]
        assert bool(in_band[i]) == judge, (t, roll.state[i], xc[i])
        checked += 1
    assert checked > 0.9 * len(roll.t)


@pytest.mark.slow  # draws nine matplotlib figures
def test_nine_figures_on_a_slope(tmp_path):
    from hoprover_env.evaluation.plots import nine_figures

    roll = simulate(
        launch_then_hold(2e-4),
        t_end=200.0,
        control_dt=0.5,
        target_x=0.35,
        params=RoverParams(slope=-0.2),
        sample_dt=0.5,
    )
    paths = nine_figures(_recording(roll), str(tmp_path))
    assert [p.rsplit("/", 1)[1] for p in paths][:1] == ["1_position.png"] and len(paths) == 9


def test_replay_meets_the_episodes_bumps():
    # the dense replay of a rough-ground episode keys its draws with the env's seed, so it
    # flies the episode the env judged (not one with fresh bumps)
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.replay import record_episode

    rec = record_episode(
        load_policy("scripted"), -0.5, env_kwargs={"params": {"slope": 0.1, "roughness": 0.1}}
    )
    assert rec.ttrtp is not None and rec.rollout.seed is not None
    assert len(rec.rollout.impact_energy_ratios) > 0
    assert rec.rollout.ttrtp == pytest.approx(rec.ttrtp, abs=1e-6)


def test_record_episode_flies_the_ground_it_is_given():
    # evaluate.py's per-episode ground (run_episodes' `terrain`) reaches the recording:
    # the replay is on that slope and its contact point holds the band for the judge's
    # last 5 s before the env's TTRTP
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.plots import contact_point_x
    from hoprover_env.evaluation.replay import record_episode

    rec = record_episode(load_policy("scripted"), 0.6, terrain={"slope": -0.15, "roughness": 0.05})
    roll = rec.rollout
    assert (roll.params.slope, roll.params.roughness) == (-0.15, 0.05)
    assert rec.ttrtp is not None and roll.seed is not None
    last = roll.t > rec.ttrtp - roll.params.dwell_time + 1e-6
    assert np.all(np.abs(contact_point_x(roll)[last] - 0.6) <= roll.params.band_half_width)
