"""The families of runs of the stability stress benchmark (benchmarks/bench_stress.py).

Each builder takes a numpy Generator and `quick` and returns the RunSpecs of one family
(research/stress/drivers.py runs them); tests/sim/test_rollout.py replays the scheduled ones through
`simulate`.
"""

from __future__ import annotations

import math

import numpy as np

from hoprover_env import RoverParams
from hoprover_env.sim.simulate import make_state
from research.stress.controllers import CTRL_HOPPER, CTRL_SCHEDULE, controller_params
from research.stress.drivers import (
    HOPPER_FREE,
    HOPPER_HOLD,
    TARGET_X,
    RunSpec,
    flight_state_at,
    state_from,
    upright,
)

DEFAULT = RoverParams()
T_MAX = DEFAULT.torque_max
LAWS = ("contest", "dissipative")
LANDING_TIMES = (1.0, 100.0)  # control dt and horizon of the landing families [s]


def variants(
    family,
    params,
    state,
    kind,
    ctrl,
    sched,
    rand,
    control_dt,
    t_end,
    label="",
    initial=None,
    integrators=("event", "euler"),
) -> list:
    """The runs of one set-up (a RunSpec's fields) under each integrator and impact law."""
    return [
        RunSpec(
            family,
            integrator,
            law,
            params,
            state.copy(),
            kind,
            ctrl,
            sched,
            rand,
            control_dt,
            t_end,
            label=label,
            initial=initial,
        )
        for integrator in integrators
        for law in LAWS
    ]


def family_long_horizon(rng, quick):
    """1. A hopper relaunching from rest with random torques for 1e5 s (quick: 1e4 s)
    of simulated time per run: holding its attitude in flight (the PD law), or free
    (no torque in flight: it keeps its launch spin and lands at any attitude)."""
    t_end = 1e4 if quick else 1e5
    seeds = 1 if quick else 4
    specs = []
    for hold, name in ((True, HOPPER_HOLD), (False, HOPPER_FREE)):
        for rep in range(seeds):
            rand = rng.random(4096)
            # Euler: one seed (1e8 steps a run)
            specs += variants(
                "1 long horizon",
                DEFAULT,
                state_from(DEFAULT, upright(DEFAULT)),
                CTRL_HOPPER,
                controller_params(hold=hold),
                np.zeros(1),
                rand,
                0.1,
                t_end,
                f"{name}, seed {rep}",
                upright(DEFAULT),
                ("event", "euler") if rep == 0 else ("event",),
            )
    return specs


def family_extreme_torques(rng, quick):
    """2. +-T_max alternating, +-T_max with random signs, and uniform random torques in
    [-T_max, T_max], switching every control step, from rest."""
    t_end = 300.0 if quick else 3000.0
    periods = (0.01, 0.1, 1.0)
    specs = []
    for dt in periods:
        n = int(math.ceil(t_end / dt))
        schedules = {
            "alternating +-Tmax": T_MAX * (1 - 2 * (np.arange(n) % 2)),
            "random-sign +-Tmax": T_MAX * rng.choice([-1.0, 1.0], n),
            "uniform random": T_MAX * rng.uniform(-1, 1, n),
        }
        for name, sched in schedules.items():
            specs += variants(
                "2 extreme torques",
                DEFAULT,
                state_from(DEFAULT, upright(DEFAULT)),
                CTRL_SCHEDULE,
                controller_params(hold=False),
                sched,
                np.zeros(1),
                dt,
                t_end,
                label=f"{name}, control dt {dt:g} s",
                initial=upright(DEFAULT),
            )
    return specs


def family_press_bounces(rng, quick):
    """3. Torques that press a bouncing corner down: (a) the hopper with low launches,
    pressing the lowest corner after every touchdown; (b) drops onto a corner from a
    few mm with a constant pressing torque for the first seconds."""
    specs = []
    t_end = 300.0 if quick else 2000.0
    n_hop = 2 if quick else 8
    for rep in range(n_hop):
        dt = (1e-3, 1e-2, 0.1, 1.0)[rep % 4]
        ctrl = controller_params(
            launch=(0.05, 0.6),
            rest=(0.5, 5.0),
            press=rng.uniform(0.2, 1.0),
            press_time=rng.uniform(2.0, 60.0),
            press_height=10 ** rng.uniform(-5, -2),
        )
        rand = rng.random(4096)
        specs += variants(
            "3 pressed bounces",
            DEFAULT,
            state_from(DEFAULT, upright(DEFAULT)),
            CTRL_HOPPER,
            ctrl,
            np.zeros(1),
            rand,
            dt,
            t_end,
            label=f"pressing hopper, control dt {dt:g} s",
            initial=upright(DEFAULT),
        )
    n_drop = 8 if quick else 60
    for _rep in range(n_drop):
        p = DEFAULT
        th = rng.choice([-1, 1]) * rng.uniform(0.005, 0.6)
        k = 0 if th > 0 else 1  # the lower corner at this attitude
        dx, dy = offset(p, k, th)
        h0 = 10 ** rng.uniform(-6, -2.5)
        vy = -(10 ** rng.uniform(-6, -3))
        vx = rng.uniform(-3e-3, 3e-3)
        initial = (0.0, h0 - dy, th, vx, vy, 0.0)
        dt = 10 ** rng.uniform(-3, 1)
        press_steps = max(1, int(rng.uniform(1.0, 20.0) / dt))
        sign = 1.0 if dx > 0 else -1.0
        sched = np.zeros(int(math.ceil(60.0 / dt)) + 1)
        sched[:press_steps] = sign * T_MAX * rng.uniform(0.3, 1.0)
        specs += variants(
            "3 pressed bounces",
            p,
            state_from(p, initial),
            CTRL_SCHEDULE,
            controller_params(hold=False),
            sched,
            np.zeros(1),
            dt,
            60.0,
            label="drop on a corner, pressed",
            initial=initial,
        )
    return specs


def offset(p: RoverParams, k, th):
    """World offset (dx, dy) of bottom corner k (0 A, 1 B) at attitude th."""
    bx = p.half_width if k == 0 else -p.half_width
    by = -p.half_height
    return bx * math.cos(th) + by * math.sin(th), -bx * math.sin(th) + by * math.cos(th)


def _fall_time(params: RoverParams, height, vy):
    """Time for a body falling at vy (< 0) to drop by `height` (no rotation)."""
    return (vy + math.sqrt(vy * vy + 2.0 * params.gravity * height)) / params.gravity


def _after_landing_schedule(rng, n, first_zero_steps):
    """Zero torque until the landing, then zero, random or +-T_max torques."""
    choice = rng.integers(3)
    sched = np.zeros(n)
    if choice == 1:
        sched[first_zero_steps:] = T_MAX * rng.uniform(-1, 1, n - first_zero_steps)
    elif choice == 2:
        sched[first_zero_steps:] = T_MAX * rng.choice([-1.0, 1.0], n - first_zero_steps)
    return sched, ("zero", "random", "+-Tmax")[choice]


def family_grazing(rng, quick):
    """4a. A bottom corner arriving at the ground with a vertical speed of 1e-9..1e-5
    m/s: states set at the touchdown instant (height 0 or a few 1e-13 m), or at the
    apex of a tiny fall (1e-16..1e-9 m above the ground), tilted and turning slowly."""
    n = 40 if quick else 400
    specs, p, (dt, t_end) = [], DEFAULT, LANDING_TIMES
    for rep in range(n):
        th = rng.choice([-1, 1]) * 10 ** rng.uniform(-4, -0.3)
        k = 0 if th > 0 else 1
        dx, dy = offset(p, k, th)
        w = rng.choice([0.0, 1.0]) * rng.uniform(-1e-4, 1e-4)
        vx = rng.choice([0.0, 1.0]) * rng.uniform(-3e-3, 3e-3)
        if rep % 2 == 0:  # at the touchdown instant, moving down slowly
            v_td = 10 ** rng.uniform(-9, -5)
            height = rng.choice([0.0, 10 ** rng.uniform(-14, -12)])
            vy = -v_td + w * dx  # the corner's vertical speed is vy - w dx = -v_td
            label = f"touchdown, corner speed {v_td:.1e} m/s, height {height:.1e} m"
        else:  # at the apex of a tiny fall
            height = 10 ** rng.uniform(-16, -9)
            vy = w * dx
            label = f"apex {height:.1e} m above the ground"
        state = flight_state_at(p, 0.0, height - dy, th, vx, vy, w)
        sched, after = _after_landing_schedule(rng, int(t_end / dt), 1)
        specs += variants(
            "4a grazing landings",
            p,
            state,
            CTRL_SCHEDULE,
            controller_params(hold=False),
            sched,
            np.zeros(1),
            dt,
            t_end,
            label=f"{label}, then {after} torques",
        )
    return specs


def family_near_flat(rng, quick):
    """4b. Landings with |theta| = 1e-14..1e-6 rad (and omega 0 or tiny): the two
    corners arrive within 1e-15..1e-7 m of each other, around the 1e-9 m switch between
    one simultaneous and two sequential impacts."""
    n = 40 if quick else 400
    specs, p, (dt, t_end) = [], DEFAULT, LANDING_TIMES
    for _rep in range(n):
        th = rng.choice([-1, 1]) * 10 ** rng.uniform(-14, -6)
        w = rng.choice([0.0, 1.0]) * rng.choice([-1, 1]) * 10 ** rng.uniform(-14, -8)
        vx = rng.choice([0.0, 1.0]) * rng.uniform(-3e-3, 3e-3)
        vy = -(10 ** rng.uniform(-6, -2))
        k = 0 if th > 0 else 1
        _, dy = offset(p, k, th)
        h0 = 10 ** rng.uniform(-8, -3)
        initial = (0.0, h0 - dy, th, vx, vy, w)
        # no torque until a control instant after the landing: it would tilt the rover
        landed = int(_fall_time(p, h0, vy) / dt) + 1
        sched, after = _after_landing_schedule(rng, int(t_end / dt), landed)
        specs += variants(
            "4b near-flat landings",
            p,
            state_from(p, initial),
            CTRL_SCHEDULE,
            controller_params(hold=False),
            sched,
            np.zeros(1),
            dt,
            t_end,
            label=f"theta {th:.1e}, omega {w:.1e}, vy {vy:.1e}, vx {vx:.1e}, then {after} torques",
            initial=initial,
        )
    return specs


def family_flat(rng, quick):
    """5. Flat two-corner landings: theta = 0, omega = 0, falling at 1e-8..1e-2 m/s,
    with horizontal speeds from 0 to 3e-3 m/s; from a height or set at the instant of
    touchdown."""
    n = 30 if quick else 300
    specs, p, (dt, t_end) = [], DEFAULT, LANDING_TIMES
    for rep in range(n):
        vy = -(10 ** rng.uniform(-8, -2))
        vx = rng.choice([0.0, 1.0]) * rng.choice([-1, 1]) * 10 ** rng.uniform(-7, -2.5)
        h0 = 0.0 if rep % 3 == 0 else 10 ** rng.uniform(-9, -3)
        if h0 == 0.0:
            state = flight_state_at(p, 0.0, p.half_height, 0.0, vx, vy, 0.0)
            initial, label = None, "set at touchdown"
        else:
            initial = (0.0, p.half_height + h0, 0.0, vx, vy, 0.0)
            state, label = state_from(p, initial), "falling from a height"
        landed = int(_fall_time(p, h0, vy) / dt) + 1  # no torque before the landing
        sched, after = _after_landing_schedule(rng, int(t_end / dt), landed)
        specs += variants(
            "5 flat landings",
            p,
            state,
            CTRL_SCHEDULE,
            controller_params(hold=False),
            sched,
            np.zeros(1),
            dt,
            t_end,
            label=f"{label}, vy {vy:.1e}, vx {vx:.1e}, then {after}",
            initial=initial,
        )
    return specs


def _edge(rng, lo, hi, log=False):
    """A value at the low end, the high end, or (half the time) inside [lo, hi]."""
    u = rng.random()
    if u < 0.25:
        return lo
    if u < 0.5:
        return hi
    if log:
        return float(10 ** rng.uniform(math.log10(lo), math.log10(hi)))
    return float(rng.uniform(lo, hi))


def random_edge_params(rng):
    """A RoverParams with every field drawn at or near the edge of its range, or None
    for a Painleve set (RoverParams raises ValueError: no unique rigid-body solution)."""
    mass = _edge(rng, 0.1, 10.0, log=True)
    r = _edge(rng, 0.01, 0.1, log=True)
    h = _edge(rng, 0.01, 0.1, log=True)
    mu_s = _edge(rng, 0.0, 1.0)
    try:
        return RoverParams(
            mass=mass,
            half_width=r,
            half_height=h,
            inertia=mass * (r * r + h * h) * _edge(rng, 0.02, 1.0, log=True),
            gravity=_edge(rng, 1e-5, 1e-3, log=True),
            mu_static=mu_s,
            mu_dynamic=mu_s * _edge(rng, 0.0, 1.0),
            restitution_x=_edge(rng, 0.0, 1.0),
            restitution_y=_edge(rng, 0.0, 1.0),
        )
    except ValueError:
        return None


def _hopper_or_random_torques(i, p, rng, t_end, dt):
    """Set i's controller: the hopper for even i, uniform random torques (drawn here)
    for odd i. Returns (kind, schedule, label)."""
    if i % 2 == 0:
        return CTRL_HOPPER, np.zeros(1), "hopper"
    return (
        CTRL_SCHEDULE,
        p.torque_max * rng.uniform(-1, 1, int(t_end / dt)),
        "uniform random torques",
    )


def family_random_params(rng, quick):
    """6. Random valid parameter sets at the edges of their ranges (mass 0.1..10 kg,
    I 0.02..1 m l^2, r and h 0.01..0.1 m, g 1e-5..1e-3, mu_s, mu_d/mu_s, e_x, e_y in
    [0, 1]); Painleve sets are skipped. Half hop (random launches, attitude hold), half
    take uniform random torques."""
    n_sets = 16 if quick else 200
    t_end = 300.0 if quick else 2000.0
    specs, skipped = [], 0
    while len(specs) < 4 * n_sets:
        p = random_edge_params(rng)
        if p is None:
            skipped += 1
            continue
        i = len(specs) // 4
        dt = 0.1
        kind, sched, label = _hopper_or_random_torques(i, p, rng, t_end, dt)
        rand = rng.random(4096)
        desc = (
            f"{label}; m {p.mass:.3g}, I {p.inertia:.3g}, r {p.half_width:.3g}, "
            f"h {p.half_height:.3g}, g {p.gravity:.3g}, mu_s {p.mu_static:.3g}, "
            f"mu_d {p.mu_dynamic:.3g}, e_x {p.restitution_x:.3g}, "
            f"e_y {p.restitution_y:.3g}"
        )
        specs += variants(
            "6 edge parameters",
            p,
            state_from(p, upright(p)),
            kind,
            controller_params(),
            sched,
            rand,
            dt,
            t_end,
            label=desc,
            initial=upright(p),
        )
    family_random_params.skipped = skipped  # reported in the section's text
    return specs


def family_control_periods(rng, quick):
    """7. Control periods 1e-4..10 s: the hopper and uniform random torques with
    attitude hold in flight (the hold is unstable at the longest periods: tumbling,
    breaking and restarting is part of the stress)."""
    periods = (1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0)
    specs = []
    for dt in periods:
        # 1000..4000 s, 1e7 control steps at most (quick: 100..1000 s)
        if quick:
            t_end = min(max(2e4 * dt, 100.0), 1000.0)
        else:
            t_end = min(max(1e6 * dt, 1000.0), 4000.0)
        rand = rng.random(4096)
        sched = T_MAX * rng.uniform(-1, 1, 4096)
        for kind, label in ((CTRL_HOPPER, "hopper"), (CTRL_SCHEDULE, "random torques")):
            specs += variants(
                "7 control periods",
                DEFAULT,
                state_from(DEFAULT, upright(DEFAULT)),
                kind,
                controller_params(),
                sched,
                rand,
                dt,
                t_end,
                label=f"{label}, control dt {dt:g} s",
                initial=upright(DEFAULT),
            )
    return specs


def family_found_cases(rng, quick):
    """8. The cases this section found in the kernel when it was written, replayed every
    time (from `make_state`-able states, so each is also a `simulate` reproducer):
    wrong tilt after a near-flat landing; a corner pushed 1.7e-9 m under the ground by
    repeated snaps (a wide, flat, frictionless rover); a pressed bounce that never ends
    (a light, wide, flat rover with e_y = 0.8); Euler micro-bounces that never end
    (contest parameters, a corner pressed down for a 4.2 s control interval)."""
    deep = RoverParams(
        mass=7.917033223160445,
        inertia=0.0007843822739184555,
        half_width=0.059897583228545104,
        half_height=0.01,
        gravity=0.001,
        mu_static=0.0,
        mu_dynamic=0.0,
        restitution_x=0.45237039302774695,
        restitution_y=0.4083367981428754,
    )
    endless = RoverParams(
        mass=0.4,
        inertia=6.6e-5,
        half_width=0.08,
        half_height=0.01,
        gravity=1e-3,
        mu_static=0.1,
        mu_dynamic=0.0,
        restitution_x=0.9,
        restitution_y=0.8,
    )
    th = 1e-3
    cases = [
        (
            "wrong tilt: near-flat landing, dissipative",
            DEFAULT,
            (
                0.0,
                0.05000414186453813,
                1.1672600724199145e-08,
                -0.0015462824529916227,
                -6.167918008154045e-05,
                3.172066852200424e-13,
            ),
            0.0,
            0.06391457114538655,
            1.0,
        ),
        (
            "deeper than 1e-9 m: repeated snaps",
            deep,
            (
                -4.1210468773629811e-05,
                1.0000000726722429e-02,
                -1.2132750461299240e-08,
                -1.5395796538378596e-07,
                -5.8108087961116235e-07,
                9.7012408425732076e-06,
            ),
            0.00017767875814184676,
            0.1,
            10.0,
        ),
        (
            "endless pressed bounce",
            endless,
            (0.0, 0.08 * math.sin(th) + 0.01 * math.cos(th), th, 0.0, 1e-5, 0.0),
            3e-4,
            0.1,
            10.0,
        ),
        (
            "Euler micro-bounces: a drop on a corner, pressed",
            DEFAULT,
            (
                0.0,
                0.050667766580636306,
                -0.013401712023356667,
                -0.0008537434721861206,
                -4.256916749950787e-05,
                0.0,
            ),
            -0.0002273978004155527,
            4.157780733212458,
            4.157780733212458,
        ),
    ]
    specs = []
    for label, p, initial, torque, dt, t_end in cases:
        specs += variants(
            "8 found cases",
            p,
            state_from(p, initial),
            CTRL_SCHEDULE,
            controller_params(hold=False),
            np.full(1, torque),
            np.zeros(1),
            dt,
            t_end,
            label=label,
            initial=initial,
        )
    return specs


def family_terrain(rng, quick):
    """9. Terrain: random slopes in [-0.5, 0.5] rad (the model's range) and roughness in
    [0, 0.3] rad, each set with its own seeded bumps: the hopper (attitude hold, random
    launches) and uniform random torques."""
    n_sets = 8 if quick else 100
    t_end = 300.0 if quick else 2000.0
    dt = 0.1
    specs = []
    for i in range(n_sets):
        p = RoverParams(slope=float(rng.uniform(-0.5, 0.5)), roughness=float(rng.uniform(0.0, 0.3)))
        seed = int(rng.integers(2**63))
        kind, sched, label = _hopper_or_random_torques(i, p, rng, t_end, dt)
        rand = rng.random(4096)
        specs += variants(
            "9 terrain",
            p,
            make_state(p, TARGET_X, upright(p), seed=seed),
            kind,
            controller_params(),
            sched,
            rand,
            dt,
            t_end,
            label=f"{label}; slope {p.slope:.3f} rad, roughness {p.roughness:.3f} rad, seed {seed}",
            initial=upright(p),
        )
    return specs


FAMILIES = (
    family_long_horizon,
    family_extreme_torques,
    family_press_bounces,
    family_grazing,
    family_near_flat,
    family_flat,
    family_random_params,
    family_control_periods,
    family_found_cases,
    family_terrain,
)
