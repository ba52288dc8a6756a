"""The event integrator against closed forms: flight, rest, tipping, slip, G, pivots."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from hoprover_env import RoverParams, RoverSim, simulate

P = RoverParams()
G, R, H, M = P.gravity, P.half_width, P.half_height, P.mass


def test_flat_flight_lands_where_the_parabola_says():
    y0, vx, vy = 0.3, 1e-3, 2e-3
    sim = RoverSim(target_x=0.0, initial_state=(0.1, y0, 0.0, vx, vy, 0.0))
    ev = sim.advance(0.0, 500.0, stop_on="impact")
    t_land = (vy + math.sqrt(vy * vy + 2 * G * (y0 - H))) / G
    assert ev[-1][1] == "impact" and sim.t == pytest.approx(t_land, rel=1e-14, abs=1e-12)
    # flat: both corners take part; the vertical speed keeps e_y, horizontal e_x
    v_land = math.sqrt(vy * vy + 2 * G * (y0 - H))
    assert sim.state[0] == pytest.approx(0.1 + vx * t_land, abs=1e-13)
    assert sim.state[4] == pytest.approx(P.restitution_y * v_land, rel=1e-12)
    assert sim.state[3] == pytest.approx(P.restitution_x * vx, rel=1e-12)
    assert sim.state[5] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("omega0, torque", [(0.01, 0.0), (-0.02, 0.0), (0.0, 2e-5), (0.05, -3e-5)])
def test_spinning_flight_first_touchdown_matches_root_of_closed_form(omega0, torque):
    x0, y0, th0, vx, vy = 0.0, 0.25, 0.1, -2e-3, 1e-3
    sim = RoverSim(target_x=0.0, initial_state=(x0, y0, th0, vx, vy, omega0))
    sim.advance(torque, 800.0, stop_on="impact")
    beta = torque / P.inertia

    def lowest(t):  # the lowest of the four corners, in closed form
        th = th0 + omega0 * t + 0.5 * beta * t * t
        y = y0 + vy * t - 0.5 * G * t * t
        return min(
            y - bx * math.sin(th) + by * math.cos(th)
            for bx, by in ((R, -H), (-R, -H), (R, H), (-R, H))
        )

    ts = np.linspace(0.0, 800.0, 800001)
    vals = np.array([lowest(t) for t in ts[::10]])
    i = int(np.argmax(vals <= 0.0))
    t_ref = brentq(lowest, ts[10 * (i - 1)], ts[10 * i], xtol=1e-14, rtol=1e-15)
    if sim.broken:
        assert sim.t == pytest.approx(t_ref, abs=1e-9)
    else:
        assert sim.t == pytest.approx(t_ref, abs=1e-9)
        assert sim.state[0] == pytest.approx(x0 + vx * t_ref, abs=1e-11)


@pytest.mark.parametrize("torque", [0.0, 2e-6, -4.5e-6, 4.8e-6])
def test_rest_forces_balance(torque):
    sim = RoverSim(target_x=0.0)
    sim.advance(torque, 1.0)
    assert sim.mode == "F"
    fax, fay, fbx, fby = sim.contact_forces()
    assert (fax, fbx) == (0.0, 0.0)
    assert fay + fby == pytest.approx(M * G, rel=1e-14)
    assert fay - fby == pytest.approx(torque / R, rel=1e-12, abs=1e-20)
    # moment about the c.m.: T - r fAy + r fBy = 0
    assert torque - R * fay + R * fby == pytest.approx(0.0, abs=1e-20)


def test_rest_costs_nothing_and_holds_exactly():
    roll = simulate(np.full(6000, 4.8e-6), t_end=600.0, control_dt=0.1, target_x=3.0)
    assert set(roll.state) == {"F"} and roll.n_events == 0
    assert np.all(roll.x == 0.0) and np.all(roll.y == H) and np.all(roll.theta == 0.0)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_tipping_torque_is_m_g_r(sign):
    below, above = RoverSim(target_x=5.0), RoverSim(target_x=5.0)
    assert below.advance(sign * M * G * R * (1 - 1e-9), 100.0) == []
    assert below.mode == "F"
    ev = above.advance(sign * M * G * R * (1 + 1e-6), 1e-3)
    assert [e[1:4] for e in ev] == [("tip", "F", "B" if sign > 0 else "D")]
    assert above.mode == ("B" if sign > 0 else "D")


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_straight_to_slide_above_the_slip_torque(sign):
    # derived in RoverParams.slip_torque: T = m g r + J mu_s g / (h - mu_s r) = 2.4598e-5
    t_slip = P.slip_torque
    below, above = RoverSim(target_x=0.0), RoverSim(target_x=0.0)
    ev = below.advance(sign * t_slip * (1 - 1e-6), 1e-4)
    assert [e[1] for e in ev] == ["tip"]
    ev = above.advance(sign * t_slip * (1 + 1e-6), 1e-4)
    assert [(e[0], e[1]) for e in ev] == [(0.0, "tip"), (0.0, "slip")]
    assert above.mode == ("C" if sign > 0 else "E")
    # the corner slides backwards (friction would have had to push the rover forward)
    assert above.s[8] == -sign


def test_pivot_conserves_its_energy_integral():
    # in B, J thdd = T - m g l cos(theta + alpha): 1/2 J w^2 - T th + m g l sin(th + a) is constant
    torque = 1.2e-5
    sim = RoverSim(target_x=0.0)
    sim.advance(torque, 1e-9)
    assert sim.mode == "B"
    ell, alpha = P.corner_distance, P.alpha
    j = P.inertia + M * ell**2

    def integral(s):
        return 0.5 * j * s[5] ** 2 - torque * s[2] + M * G * ell * math.sin(s[2] + alpha)

    e0 = integral(sim.state)
    for t in (1.0, 3.0, 7.0):
        sim.advance(torque, t, stop_on="slip")
        assert sim.mode == "B"
        assert integral(sim.state) == pytest.approx(e0, rel=1e-12)
        # the pivot corner stays where it was
        assert sim.state[0] + ell * math.cos(sim.state[2] + alpha) == pytest.approx(R, abs=1e-15)


@pytest.mark.parametrize("vx", [1e-3, -2.5e-3])
def test_double_slide_decelerates_at_mu_d_g_and_stops(vx):
    sim = RoverSim(target_x=5.0, initial_state=(0.0, H, 0.0, vx, 0.0, 0.0))
    assert sim.mode == "G"
    sim.advance(0.0, 500.0, stop_on="stop")
    a = P.mu_dynamic * G
    assert sim.t == pytest.approx(abs(vx) / a, rel=1e-14)
    assert sim.state[0] == pytest.approx(math.copysign(vx * vx / (2 * a), vx), rel=1e-13)
    assert sim.mode == "F" and sim.state[3] == 0.0


def test_double_slide_forces_and_tipping_during_slide():
    sim = RoverSim(target_x=5.0, initial_state=(0.0, H, 0.0, 1e-3, 0.0, 0.0))
    sim.advance(1e-6, 1.0)
    assert sim.mode == "G"
    fax, fay, fbx, fby = sim.contact_forces()
    mu = P.mu_dynamic
    assert fay + fby == pytest.approx(M * G, rel=1e-14)
    assert fay - fby == pytest.approx((1e-6 + mu * M * G * H) / R, rel=1e-12)
    assert (fax, fbx) == (pytest.approx(-mu * fay), pytest.approx(-mu * fby))
    # f_By = 0 at T = m g r - mu_d m g h (sliding forward lowers the tipping torque)
    t_tip = M * G * R - mu * M * G * H
    sim2 = RoverSim(target_x=5.0, initial_state=(0.0, H, 0.0, 1e-3, 0.0, 0.0))
    ev = sim2.advance(t_tip * (1 + 1e-6), 1e-6)
    assert [e[1:4] for e in ev] == [("tip", "G", "C")]
