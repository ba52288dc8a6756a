"""Rough-terrain bounces (docs/MODEL.md section 11, docs/PHYSICS.md "Terrain"): the
generator, the tilted impact law, seeds and bit-reproducibility."""

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from flat_cases import HopSequence
from helpers import assert_identical, batch_on_one_and_all_threads
from hoprover_env import RoverParams, RoverSim, core, simulate, simulate_batch
from hoprover_env.sim.simulate import make_state

U = np.uint64
ROUGH = RoverParams(roughness=0.1, slope=0.15)


@pytest.mark.parametrize(
    "counter, key",
    [
        ((0, 0, 0, 0), (0, 0)),
        ((10, 3, 0, 0), (5, 7)),
        ((2**64 - 2, 2**64 - 1, 17, 2**63), (2**64 - 1, 12345)),
        ((123456789, 0, 0, 0), (0xDEADBEEFCAFEF00D, 1)),
    ],
)
def test_philox_is_numpys_bit_for_bit(counter, key):
    # numpy's Philox (4x64-10) increments its 256-bit counter before the first block
    got = core.philox4x64(*(U(v) for v in counter), U(key[0]), U(key[1]))
    value = sum(v << (64 * i) for i, v in enumerate(counter))
    key_value = key[0] + (key[1] << 64)
    want = np.random.Philox(counter=(value - 1) % 2**256, key=key_value).random_raw(4)
    assert [int(v) for v in got] == [int(v) for v in want]


def test_tilts_are_a_normal_truncated_at_three_sigma():
    z = np.array(
        [core.truncated_normal(U(2024), U(r), U(n)) for r in range(4) for n in range(5000)]
    )
    assert np.max(np.abs(z)) <= 3.0 and np.max(np.abs(z)) > 2.5
    ks = stats.kstest(z, stats.truncnorm(-3.0, 3.0).cdf)
    assert ks.pvalue > 1e-3, ks
    # a pure function of (seed, rover, count): the same key gives the same draw
    assert core.truncated_normal(U(2024), U(3), U(77)) == z[3 * 5000 + 77]
    assert len(set(z.tolist())) == z.size


def hop_state(params, seed=None, rover=0):
    sim = RoverSim(params=params, target_x=0.3, seed=seed, rover=rover)
    ctrl = HopSequence()
    for k in range(3000):
        s = sim.s
        sim.advance(ctrl(s[0:2], s[3:5], s[2], s[5], None, sim.t, 300.0, sim.mode), (k + 1) * 0.1)
    return sim


def test_roughness_zero_makes_no_draw_and_rough_ground_one_per_impact():
    smooth = hop_state(RoverParams(slope=0.15), seed=5)
    assert smooth.s[core.S_NIMPACT] > 3 and smooth.s[core.S_NDRAW] == 0
    assert smooth.seed is None  # nothing was drawn: no seed to record
    rough = hop_state(ROUGH, seed=5)
    assert rough.s[core.S_NIMPACT] > 3 and rough.s[core.S_NDRAW] == rough.s[core.S_NIMPACT]
    assert rough.seed == 5


def test_tilt_zero_is_the_flat_law_and_the_law_acts_in_the_tilted_frame():
    p = RoverParams()
    pa = p.as_array()
    th = 0.3
    dx, dy = core.corner_offset(pa, 0, th)
    vx, vy, w = 4e-4, -1e-3, 0.002
    s0 = np.zeros(core.N_STATE)
    s0[:6] = (0.0, -dy, th, vx, vy, w)
    a, b = s0.copy(), s0.copy()
    wa, wb = np.zeros(core.N_WORK), np.zeros(core.N_WORK)
    assert core.resolve_impact(a, pa, core.LAW_CONTEST, wa) == core.resolve_impact_tilted(
        b, pa, core.LAW_CONTEST, wb, 0.0
    )
    assert a.tobytes() == b.tobytes()
    psi = 0.25
    c = s0.copy()
    core.resolve_impact_tilted(c, pa, core.LAW_CONTEST, np.zeros(core.N_WORK), psi)
    c_, s_ = math.cos(psi), math.sin(psi)

    def local(v):  # contact-point velocity along / normal to the facet
        px, py = v[3] + v[5] * dy, v[4] - v[5] * dx
        return c_ * px + s_ * py, -s_ * px + c_ * py

    t0, n0 = local(s0)
    t1, n1 = local(c)
    assert n0 < 0 and t1 == pytest.approx(p.restitution_x * t0, rel=1e-12)
    assert n1 == pytest.approx(-p.restitution_y * n0, rel=1e-12)
    assert a[3] != pytest.approx(c[3], rel=1e-3)


def test_a_corner_the_facet_sends_into_the_mean_plane_meets_it_plastically():
    """Decision: falling slowly while sliding fast, the corner moves away from a facet
    tilted against its motion; the tilted law does nothing, the corner still moves into
    the mean plane, and a plastic frictionless impact there stops its normal motion."""
    p = RoverParams()
    pa = p.as_array()
    th = 0.3
    dx, dy = core.corner_offset(pa, 0, th)
    s = np.zeros(core.N_STATE)
    s[:6] = (0.0, -dy, th, 1e-3, -1e-4, 0.0)
    px0 = s[3]
    ke0 = 0.5 * (s[3] ** 2 + s[4] ** 2)
    psi = -0.3
    assert -math.sin(psi) * s[3] + math.cos(psi) * s[4] > 0  # leaving the facet
    ratio = core.resolve_impact_tilted(s, pa, core.LAW_CONTEST, np.zeros(core.N_WORK), psi)
    vpy = s[4] - s[5] * core.corner_offset(pa, 0, s[2])[0]
    assert vpy == 0.0 and core.MODE_LETTERS[int(s[core.S_MODE])] == "C"
    assert ratio < 1.0 and s[3] + s[5] * core.corner_offset(pa, 0, s[2])[1] > 0.0
    # frictionless: the mean-plane impulse is normal, vx is kept; energy is lost
    assert 0.5 * (s[3] ** 2 + s[4] ** 2) + 0.5 * p.inertia * s[5] ** 2 < ke0
    assert s[3] == px0


@pytest.mark.parametrize("law", [core.LAW_CONTEST, core.LAW_DISSIPATIVE])
def test_tilted_impacts_never_leave_a_corner_moving_into_the_mean_plane(law):
    rng = np.random.default_rng(3)
    p = RoverParams()
    pa = p.as_array()
    for _ in range(3000):
        th = rng.uniform(-1.2, 1.2) if rng.random() < 0.8 else rng.uniform(-1e-12, 1e-12)
        k = 0 if th >= 0 else 1
        dx, dy = core.corner_offset(pa, k, th)
        w = rng.uniform(-0.05, 0.05)
        s = np.zeros(core.N_STATE)  # the touching corner k moves down at up to 3 mm/s
        s[:6] = (0.0, -dy, th, rng.uniform(-3e-3, 3e-3), w * dx - rng.uniform(1e-6, 3e-3), w)
        ke0 = 0.5 * (s[3] ** 2 + s[4] ** 2) + 0.5 * p.inertia * s[5] ** 2
        ratio = core.resolve_impact_tilted(
            s, pa, law, np.zeros(core.N_WORK), rng.uniform(-0.9, 0.9)
        )
        for c in range(2):
            dxc, dyc = core.corner_offset(pa, c, s[2])
            if s[1] + dyc <= 1e-9:
                assert s[4] - s[5] * dxc >= -1e-12
            assert s[1] + dyc >= -1e-15
        if law == core.LAW_DISSIPATIVE:
            ke1 = 0.5 * (s[3] ** 2 + s[4] ** 2) + 0.5 * p.inertia * s[5] ** 2
            assert ratio <= 1.0 + 1e-12 and ke1 <= ke0 * (1 + 1e-12)


def test_same_seed_same_bits_across_threads_batch_positions_and_simulate():
    n = 6
    rng = np.random.default_rng(0)
    sched = np.zeros((n, 1500))
    for i in range(n):
        sched[i, : int(rng.integers(8, 30))] = rng.choice([-1, 1]) * rng.uniform(1.5e-4, 4e-4)
    plist = [dataclasses.replace(ROUGH, slope=float(v)) for v in rng.uniform(-0.3, 0.3, n)]
    targets = np.linspace(-0.5, 0.5, n)
    kw = dict(t_end=150.0, params=plist, seed=2**63 + 12345)
    one, many = batch_on_one_and_all_threads(sched, targets, **kw)
    prefix = simulate_batch(
        sched[:3], targets[:3], t_end=150.0, params=plist[:3], seed=2**63 + 12345
    )
    assert one.seed == many.seed == 2**63 + 12345
    assert np.sum(one.n_impacts) > 10
    for i in range(n):
        ref = simulate(
            sched[i], t_end=150.0, params=plist[i], target_x=targets[i], seed=2**63 + 12345, rover=i
        )
        assert ref.seed == 2**63 + 12345
        assert_identical(one.rollout(i), ref)
        assert_identical(many.rollout(i), ref)
        if i < 3:
            assert_identical(prefix.rollout(i), ref)
    # the key matters: another rover index or seed bounces differently
    i = int(np.argmax(one.n_impacts))
    for seed, rover in ((2**63 + 12345, i + 1), (2**63 + 12346, i)):
        other = simulate(
            sched[i], t_end=150.0, params=plist[i], target_x=targets[i], seed=seed, rover=rover
        )
        assert not np.array_equal(other.x, one.rollout(i).x)


def test_fresh_seed_is_recorded_and_replays():
    sched = np.r_[np.full(20, 3e-4), np.zeros(1480)]
    a = simulate(sched, t_end=150.0, params=ROUGH)
    b = simulate(sched, t_end=150.0, params=ROUGH)
    assert isinstance(a.seed, int) and 0 <= a.seed < 2**64 and a.seed != b.seed
    again = simulate(sched, t_end=150.0, params=ROUGH, seed=a.seed)
    assert_identical(a, again)
    assert len(a.impact_energy_ratios) >= 1  # (the first touchdown draws)
    batch = simulate_batch(sched[None, :], [0.5], t_end=150.0, params=ROUGH)
    assert isinstance(batch.seed, int)
    assert_identical(
        batch.rollout(0), simulate(sched, t_end=150.0, params=ROUGH, seed=batch.seed, target_x=0.5)
    )
    assert simulate(sched[:5], t_end=1.0).seed is None


@pytest.mark.parametrize("seed", [1.5, 3.0, "7", True, -1, 2**64, [1, 2]])
def test_a_seed_that_is_not_an_integer_is_refused(seed):
    sched = np.zeros(10)
    for call in (
        lambda: simulate(sched, t_end=1.0, params=ROUGH, seed=seed),
        lambda: simulate(sched, t_end=1.0, seed=seed),
        lambda: simulate_batch(sched[None, :], [0.0], t_end=1.0, seed=seed),
        lambda: RoverSim(params=ROUGH, seed=seed),
        lambda: make_state(ROUGH, 0.0, seed=seed),
    ):
        with pytest.raises(ValueError, match="seed"):
            call()


@pytest.mark.parametrize("rover", [-1, 1.0, "0", 2**53])
def test_a_bad_rover_index_is_refused(rover):
    with pytest.raises(ValueError, match="rover"):
        simulate(np.zeros(10), t_end=1.0, params=ROUGH, seed=1, rover=rover)


def test_rough_euler_runs_and_reproduces():
    sched = np.r_[np.full(20, 3e-4), np.zeros(1480)]
    kw = dict(t_end=150.0, params=ROUGH, integrator="euler", seed=9)
    a, b = simulate(sched, **kw), simulate(sched, **kw)
    assert_identical(a, b)
    assert len(a.impact_energy_ratios) > 0
