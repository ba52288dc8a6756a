"""research/plan_clone/nudge.py: the nudge at the band's edge as a law of the observed state."""

import numpy as np
import pytest

from hoprover_env.tasks.observation import (
    OBS_DX,
    OBS_MODE,
    OBS_RATE,
    OBS_SIN,
    OBS_VX,
    RATE_SCALE,
    mirror,
)
from research.plan_clone import nudge
from research.plan_clone.plan_table import PlanTableTeacher, load_table

TABLE = "benchmarks/results/plan_clone_retry/table.npz"


def _obs(offset, mode, theta=0.0, omega=0.0, vx=0.0):
    o = np.zeros(19)
    o[OBS_DX] = -offset
    o[OBS_MODE + mode] = 1.0
    o[OBS_SIN], o[5] = np.sin(theta), np.cos(theta)
    o[OBS_RATE] = omega / RATE_SCALE
    o[OBS_VX] = vx / 0.01
    return o


def test_the_law_pushes_from_rest_brakes_beyond_the_tilt_and_is_mirror_symmetric():
    push, tilt, brake = 0.05, 0.001, 0.03
    rows = [
        (_obs(0.102, 5), push),  # at rest, out of the band
        (_obs(0.098, 5), 0.0),  # at rest in the band
        (_obs(0.102, 3, 0.0005, 0.001), push),  # tipping on, below the tilt
        (_obs(0.102, 3, 0.002, 0.001), -brake),  # beyond it: brake
        (_obs(0.102, 3, 0.002, -0.001), 0.0),  # rocking back
        (_obs(0.102, 3, -0.002, -0.001), 0.0),  # tilted away from the target
        (_obs(0.102, 0, 0.002, 0.001), 0.0),
    ]  # in flight
    obs = np.array([r[0] for r in rows])
    want = np.array([r[1] for r in rows])
    np.testing.assert_allclose(nudge.nudge_actions(obs, push, tilt, brake), want)
    np.testing.assert_allclose(nudge.nudge_actions(mirror(obs), push, tilt, brake), -want)


def test_only_nearly_still_rovers_near_the_edge_are_covered():
    obs = np.array(
        [
            _obs(0.105, 5),
            _obs(0.105, 3, 0.003, 0.001),
            _obs(0.105, 2, 0.003, 0.0, vx=0.003),  # a short hop sliding by
            _obs(0.105, 3, 0.05, 0.01),  # tilted far: not a nudge
            _obs(0.13, 5),
            _obs(0.105, 0),
        ]
    )
    np.testing.assert_array_equal(nudge.near_edge(obs), [True, True, False, False, False, False])


def test_choose_prefers_a_broad_basin_to_a_sharp_minimum():
    shape = (len(nudge.PUSH_GRID), len(nudge.TILT_GRID), len(nudge.BRAKE_GRID))
    grid = np.full(shape, 50.0)
    grid[2, 2, 2] = 9.0  # sharp: its neighbours miss badly
    grid[10:15, 5:10, 20:25] = 10.0  # broad: 10 s around it
    fam = nudge.choose({0.102: grid})
    assert fam["ttrtp"][0] == 10.0 and fam["robust"][0] == pytest.approx(10.0 / 9.0)
    # a point whose neighbours are all in the basin
    assert fam["push"][0] in nudge.PUSH_GRID[11:14]
    assert fam["tilt"][0] in nudge.TILT_GRID[6:9]
    assert fam["brake"][0] in nudge.BRAKE_GRID[21:24]


def test_a_wider_margin_gives_up_a_narrow_basin_for_a_broad_one():
    shape = (len(nudge.PUSH_GRID), len(nudge.TILT_GRID), len(nudge.BRAKE_GRID))
    grid = np.full(shape, 50.0)
    grid[2:5, 2:5, 2:5] = 9.5  # narrow: 9.5 s within +-1 step of its
    grid[3, 3, 3] = 9.0  # middle, 50 s two steps out
    grid[10:17, 5:12, 20:27] = 10.0  # broad: 10 s within +-3 steps
    narrow, broad = nudge.choose({0.102: grid}), nudge.choose({0.102: grid}, margin=2)
    # +-1 step: the middle of the narrow basin, whose worst neighbour takes 9.5 s
    assert (narrow["push"][0], narrow["ttrtp"][0]) == (nudge.PUSH_GRID[3], 9.0)
    assert narrow["robust"][0] == pytest.approx(9.5 / 9.0)
    assert broad["ttrtp"][0] == 10.0 and broad["robust"][0] == pytest.approx(10.0 / 9.0)
    assert broad["push"][0] in nudge.PUSH_GRID[12:15]


def test_a_teacher_with_a_nudge_family_flies_the_family_s_time(monkeypatch):
    from hoprover_env.evaluation.episodes import run_episodes

    # a small grid around the nudges that work at 0.102 m
    monkeypatch.setattr(nudge, "PUSH_GRID", np.array([0.06, 0.065, 0.07, 0.075, 0.08]))
    monkeypatch.setattr(nudge, "TILT_GRID", np.array([8.9e-4, 1.17e-3, 1.53e-3]))
    monkeypatch.setattr(nudge, "BRAKE_GRID", np.array([0.045, 0.05, 0.055, 0.06, 0.065]))
    grid = nudge.search((0.102,), log=lambda m: None)
    assert np.isfinite(grid[0.102]).any()
    fam = nudge.choose(grid)
    table = load_table(TABLE)
    table.update({f"nudge_{k}": v for k, v in fam.items()})
    teacher = PlanTableTeacher(table)
    res = run_episodes(teacher, np.array([0.102, -0.102]), {"control_dt": 0.5})
    for r in res:
        assert r.success
        np.testing.assert_allclose(r.ttrtp, fam["ttrtp"][0], rtol=1e-9)
    assert teacher.decisions == 0  # the law acted; mpc never searched


def test_the_branch_fit_with_mirror_also_fits_the_mirror_images(tmp_path, monkeypatch):
    """`fit_branch(mirror=True)` hands the fit each edge state and its mirror image with
    the negated action, and nothing from off the edge."""
    from hoprover_env.training import warm_start as imitation

    obs = np.array(
        [_obs(0.105, 5), _obs(-0.104, 3, -0.003, -0.001), _obs(0.3, 0)], dtype=np.float32
    )
    path = tmp_path / "c.npz"
    np.savez(path, obs=obs, act=np.array([[0.1], [-0.05], [0.7]]), ret=np.zeros(3))
    seen = {}

    def fake_clone(model, venv, o, a, r, **kw):
        seen.update(obs=o, act=a)

    monkeypatch.setattr(imitation, "clone", fake_clone)
    nudge.fit_branch([str(path)], mirror=True, log=lambda m: None)
    np.testing.assert_array_equal(seen["obs"], np.concatenate([obs[:2], mirror(obs[:2])]))
    np.testing.assert_array_equal(seen["act"], [[0.1], [-0.05], [-0.1], [0.05]])
    nudge.fit_branch([str(path)], log=lambda m: None)
    assert len(seen["obs"]) == 2
