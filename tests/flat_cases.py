"""Runs on flat ground whose results must not move by a single bit when terrain is added
(slope 0 and roughness 0 equal the contest model). The arrays they gave before
terrain existed are stored in tests/data/flat_baseline.npz, made by
tests/data/make_flat_baseline.py from commit 6fc532c; tests/sim/test_terrain_flat.py replays
them. Only the public API of that commit is used here."""

import math

import numpy as np

from hoprover_env import RoverParams

OTHER = dict(
    mass=1.7,
    inertia=0.004,
    half_width=0.07,
    half_height=0.04,
    gravity=2e-4,
    mu_static=0.4,
    mu_dynamic=0.3,
    restitution_x=0.6,
    restitution_y=0.4,
)


class RandomHopper:
    """A closed-loop hopper with random choices (drawn at phase changes, so the draws
    follow the trajectory): launch torques of either sign, a biased attitude hold in
    flight (tilted landings: corner impacts, bounces), a pressing torque after landing
    (pivots, slides) and random rests."""

    def __init__(self, seed):
        self.rng = np.random.default_rng(seed)
        self.phase, self.t_mark, self.launch, self.bias, self.press = "rest", 0.0, 0.0, 0.0, 0.0
        self.rest = 1.0

    def __call__(self, pos, vel, the, omg, posT, t, smt, state):
        rng = self.rng
        if state == "A":
            if self.phase != "fly":
                self.phase = "fly"
                self.bias = rng.choice([0.0, 0.0, 1.0]) * rng.uniform(-2e-6, 2e-6)
                self.press = rng.choice([0.0, 1.0]) * rng.uniform(-4e-5, 4e-5)
            th = (the + math.pi) % (2 * math.pi) - math.pi
            return -0.0017 * (0.8 * omg + 0.1 * (th - 40.0 * self.bias)) + self.bias
        if self.phase == "fly":
            if state == "F":
                self.phase, self.t_mark = "rest", t
                self.rest = rng.uniform(0.5, 5.0)
                return 0.0
            return self.press
        if self.phase == "rest":
            if t - self.t_mark >= self.rest:
                self.phase = "launch"
                self.launch = rng.choice([-1.0, 1.0]) * rng.uniform(6e-5, 5e-4)
            return 0.0
        return self.launch


class HopSequence:
    """Hop back and forth (benchmarks/scenarios.py's controller, copied so that the
    baseline commit's tests can run it): launch until lift-off, PD attitude hold in
    flight, rest 5 s after stopping, repeat with the next torque."""

    def __init__(self, torques=(3e-4, 1.5e-4, 4e-4, 2e-4), inertia=0.0017):
        self.torques, self.inertia = torques, inertia
        self.k, self.phase, self.t_mark = 0, "rest", 0.0

    def __call__(self, pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            self.phase = "fly"
            th = (the + math.pi) % (2 * math.pi) - math.pi
            return -self.inertia * (0.8 * omg + 0.1 * th)
        if self.phase == "fly":
            if state == "F":
                self.phase, self.t_mark = "rest", t
            return 0.0
        if self.phase == "rest":
            if t - self.t_mark >= 5.0:
                self.phase = "launch"
                self.k += 1
            return 0.0
        torque = self.torques[self.k % len(self.torques)]
        return torque if self.k % 2 else -torque


def cases():
    """name -> (controller, simulate keyword arguments)."""
    p = RoverParams()
    other = RoverParams(**OTHER)
    c = {
        "hop_event_contest": (HopSequence(), dict(t_end=200.0, control_dt=0.2, target_x=0.4)),
        "hop_event_dissipative": (
            HopSequence((2e-4, 5e-4)),
            dict(t_end=200.0, control_dt=0.2, impact_law="dissipative"),
        ),
        "hop_event_sampled": (
            HopSequence((1e-4, 3.5e-4)),
            dict(t_end=80.0, sample_dt=0.05, target_x=-0.3),
        ),
        "slide_g_band": (
            np.zeros(300),
            dict(
                t_end=30.0, target_x=0.12, initial_state=(0.0, p.half_height, 0.0, 3e-3, 0.0, 0.0)
            ),
        ),
        "other_params_euler": (
            RandomHopper(8),
            dict(t_end=100.0, params=other, integrator="euler", impact_law="dissipative"),
        ),
        "other_params_euler_contest": (
            HopSequence(inertia=other.inertia),
            dict(t_end=100.0, params=other, integrator="euler", euler_dt=5e-4),
        ),
    }
    for seed in range(6):
        law = "contest" if seed % 2 == 0 else "dissipative"
        c[f"random{seed}_event_{law}"] = (
            RandomHopper(seed),
            dict(
                t_end=200.0,
                control_dt=0.25,
                impact_law=law,
                target_x=0.1 * seed - 0.2,
                params=other if seed >= 4 else p,
            ),
        )
    c["random9_euler"] = (RandomHopper(9), dict(t_end=150.0, integrator="euler"))
    th = 0.3
    dx, dy = (
        p.half_width * math.cos(th) - p.half_height * math.sin(th),
        -p.half_width * math.sin(th) - p.half_height * math.cos(th),
    )
    w = -0.01
    c["slide_c_start"] = (
        RandomHopper(10),
        dict(t_end=60.0, initial_state=(0.0, -dy, th, 2e-3 - w * dy, w * dx, w)),
    )
    pivot = np.r_[np.full(30, 1.5e-5), np.zeros(170)]
    c["pivot_b"] = (pivot, dict(t_end=20.0, target_x=0.05))
    c["pivot_d_dissipative"] = (-pivot, dict(t_end=20.0, impact_law="dissipative"))
    c["pivot_d_euler"] = (-pivot, dict(t_end=20.0, integrator="euler"))
    c["spin_flight"] = (
        np.full(200, 2e-5),
        dict(t_end=20.0, initial_state=(0.0, 0.2, 0.1, -2e-3, 1e-3, 0.05)),
    )
    return c


def record(roll) -> dict:
    """The arrays of a Rollout, as they are compared bit for bit."""
    ev = roll.events
    return dict(
        t=roll.t,
        x=roll.x,
        y=roll.y,
        theta=roll.theta,
        vx=roll.vx,
        vy=roll.vy,
        omega=roll.omega,
        sigma=roll.sigma,
        torque=roll.torque,
        torque_cmd=roll.torque_cmd,
        state=np.array(["ABCDEFG".index(s) for s in roll.state]),
        ev_t=np.array([e[0] for e in ev], dtype=float),
        ev_kind=np.array([e[1] for e in ev], dtype="U8"),
        ev_modes=np.array([e[2] + e[3] for e in ev], dtype="U2"),
        ratios=roll.impact_energy_ratios,
        summary=np.array(
            [
                np.nan if roll.ttrtp is None else roll.ttrtp,
                float(roll.broken),
                float(roll.n_events),
                roll.min_corner_height,
            ]
        ),
    )
