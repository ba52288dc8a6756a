"""An independent reference for the contact phases: MODEL.md section 4's corner-A
formulas (phi_A = theta + alpha, c, s), integrated by scipy's DOP853 at tight
tolerance with located events. It shares no code with hoprover_env.core.

On a slope (MODEL.md section 11) the weight m g (0, -1) of section 3 becomes
m g (-sin(slope), -cos(slope)) in the ground frame: the formulas below are section 4's
with g replaced by gc = g cos(slope) in the normal direction and the along-surface part
gs = g sin(slope) added to the pivot's friction force (fAx = m l (...) + m gs) and to the
slide's x'' = fAx / m - gs.

`launch(T)` starts upright at rest (state F) under a constant torque T above the
tipping torque and follows B (pivot on A) / C (slide on A) until lift-off.
`flight(state, T)` follows the flight (x'' = -gs, y'' = -gc, theta'' = T / I) to the
first time a corner reaches the ground.
"""

import math

import numpy as np

RTOL, ATOL = 1e-13, 1e-16  # scipy DOP853's tolerances (scipy: a test dependency)


class Ref:
    """The reference solver (module docstring); parameters as RoverParams' fields."""

    RTOL, ATOL = RTOL, ATOL

    def __init__(self, m=1.0, I=0.0017, r=0.05, h=0.05, g=9.8e-5, mus=0.6, mud=0.5, slope=0.0):
        self.m, self.I, self.r, self.h, self.g, self.mus, self.mud = m, I, r, h, g, mus, mud
        self.gs, self.gc = g * math.sin(slope), g * math.cos(slope)
        self.l = math.hypot(r, h)
        self.alpha = math.atan2(h, r)

    # --- state B: pivot on A ---------------------------------------------------
    def pivot(self, T, th, w):
        m, I, l, g, gs = self.m, self.I, self.l, self.gc, self.gs
        c, s = math.cos(th + self.alpha), math.sin(th + self.alpha)
        # moment of the corner force about the c.m. balances gravity's (c.m.) pull:
        # (I + m l^2) thdd = T - m l (gc c + gs s)
        thdd = (T - m * l * (g * c + gs * s)) / (I + m * l * l)
        fax = m * l * (thdd * s + w * w * c) + m * gs
        fay = m * l * (thdd * c - w * w * s) + m * g
        return thdd, fax, fay

    # --- state C: slide on A ----------------------------------------------------
    def slide(self, T, th, w, sigma):
        m, I, l, g, mud = self.m, self.I, self.l, self.gc, self.mud
        c, s = math.cos(th + self.alpha), math.sin(th + self.alpha)
        dc = I + m * l * l * c * (c - sigma * mud * s)
        thdd = (T - m * l * (g - l * w * w * s) * (c - sigma * mud * s)) / dc
        fay = m * l * (thdd * c - w * w * s) + m * g
        fax = -sigma * mud * fay
        return thdd, fax, fay

    def full_state(self, th, w, x, vx):
        l, pa = self.l, th + self.alpha
        return np.array([x, l * math.sin(pa), th, vx, l * w * math.cos(pa), w])

    def launch(self, T, t_max=200.0):
        """Follow F -> B/C -> ... -> lift-off. Returns (t, state6, modes)."""
        from scipy.integrate import solve_ivp

        m, r = self.m, self.r
        assert T > m * (self.gc * r + self.gs * self.h), (
            "below the tipping torque the rover stays in F"
        )
        t, th, w, x, vx = 0.0, 0.0, 0.0, 0.0, 0.0
        modes = ["F", "B"]
        sigma = 0.0
        _, fax, fay = self.pivot(T, th, w)
        if abs(fax) > self.mus * fay:
            modes.append("C")
            sigma = -math.copysign(1.0, fax)
        for _ in range(50):
            if modes[-1] == "B":
                xa = x + self.l * math.cos(th + self.alpha)

                def rhs(_t, y):
                    return [y[1], self.pivot(T, y[0], y[1])[0]]

                def liftoff(_t, y):
                    return self.pivot(T, y[0], y[1])[2]

                def slip(_t, y):
                    _, fx, fy = self.pivot(T, y[0], y[1])
                    return self.mus * fy - abs(fx)

                for e in (liftoff, slip):
                    e.terminal, e.direction = True, -1
                sol = solve_ivp(
                    rhs,
                    (t, t_max),
                    [th, w],
                    method="DOP853",
                    rtol=RTOL,
                    atol=ATOL,
                    events=(liftoff, slip),
                )
                th, w = sol.y[0, -1], sol.y[1, -1]
                t = sol.t[-1]
                x = xa - self.l * math.cos(th + self.alpha)
                vx = self.l * w * math.sin(th + self.alpha)
                if sol.t_events[0].size:
                    modes.append("A")
                    return t, self.full_state(th, w, x, vx), modes
                assert sol.t_events[1].size, "the pivot must end in lift-off or slip"
                _, fx, _ = self.pivot(T, th, w)
                sigma = -math.copysign(1.0, fx)
                modes.append("C")
            else:
                sg = sigma

                def slide_rhs(_t, y, sg=sg):
                    thdd, fx, _ = self.slide(T, y[0], y[1], sg)
                    return [y[1], thdd, y[3], fx / m - self.gs]

                def slide_liftoff(_t, y, sg=sg):
                    return self.slide(T, y[0], y[1], sg)[2]

                def stick(_t, y, sg=sg):
                    # sigma * (xdot_A): the sliding speed of corner A
                    return sg * (y[3] - self.l * y[1] * math.sin(y[0] + self.alpha))

                slide_liftoff.terminal, slide_liftoff.direction = True, -1
                stick.terminal, stick.direction = True, -1
                # the slide starts from rest: integrate a hair before arming 'stick'
                sol = solve_ivp(
                    slide_rhs,
                    (t, t_max),
                    [th, w, x, vx],
                    method="DOP853",
                    rtol=RTOL,
                    atol=ATOL,
                    events=(slide_liftoff, stick),
                )
                th, w, x, vx = sol.y[:, -1]
                t = sol.t[-1]
                if sol.t_events[0].size:
                    modes.append("A")
                    return t, self.full_state(th, w, x, vx), modes
                assert sol.t_events[1].size, "the slide must end in lift-off or stick"
                _, fxp, fyp = self.pivot(T, th, w)
                if abs(fxp) <= self.mus * fyp:
                    modes.append("B")
                    vx = self.l * w * math.sin(th + self.alpha)
                else:
                    sigma = -math.copysign(1.0, fxp)
                    modes.append("C")
        raise AssertionError("no lift-off")

    def corners(self, st):
        """Heights (y) and x positions of A, B, top-right, top-left of a state."""
        x, y, th = st[0], st[1], st[2]
        out = []
        for bx, by in ((self.r, -self.h), (-self.r, -self.h), (self.r, self.h), (-self.r, self.h)):
            out.append(
                (
                    x + bx * math.cos(th) + by * math.sin(th),
                    y - bx * math.sin(th) + by * math.cos(th),
                )
            )
        return out

    def flight(self, st, T, t0, t_max=2000.0):
        """Flight from the state st = (x, y, theta, vx, vy, omega) at t0 under the torque
        T, to the first time a corner comes down to the ground (a corner starting on it,
        as at a lift-off, counts once it has risen 1e-9 m). Returns (t, state, corner)."""
        from scipy.integrate import solve_ivp
        from scipy.optimize import brentq

        gs, gc, beta = self.gs, self.gc, T / self.I

        def rhs(_t, y):
            return [y[3], y[4], y[5], -gs, -gc, beta]

        def height(k):
            start = self.corners(st)[k][1]

            def ev(_t, y):
                return self.corners(y)[k][1] - (1e-9 if start < 1e-9 else 0.0)

            ev.terminal, ev.direction = False, -1
            return ev

        evs = [height(k) for k in range(4)]
        # events are only seen as sign changes between steps, and DOP853 takes huge steps
        # on this polynomial motion: limit them to 1/50 turn at the fastest spin
        spin = abs(st[5]) + abs(beta) * (t_max - t0) + 1e-3
        sol = solve_ivp(
            rhs,
            (t0, t_max),
            list(st),
            method="DOP853",
            rtol=RTOL,
            atol=ATOL,
            events=evs,
            dense_output=True,
            max_step=min(1.0, 2 * math.pi / 50 / spin),
        )
        hits = []
        for k in range(4):
            start = self.corners(st)[k][1]
            for t in sol.t_events[k]:
                if start < 1e-9:
                    # a corner starting on the ground: its touchdown is where it returns
                    # to the ground, found from the 1e-9 m crossing on the way down
                    f = lambda tt, k=k: self.corners(sol.sol(tt))[k][1]  # noqa: E731
                    a, b = t, t + 1.0
                    while f(b) > 0.0:
                        b += 1.0
                    t = brentq(f, a, b, xtol=1e-14, rtol=1e-15)
                hits.append((t, k))
                break
        assert hits, "no touchdown before t_max"
        t, k = min(hits)
        return t, sol.sol(t), k
