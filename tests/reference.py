"""An independent reference for the contact phases: MODEL.md section 4's corner-A
formulas (phi_A = theta + alpha, c, s), integrated by scipy's DOP853 at tight
tolerance with located events. It shares no code with hoprover_env.core.

`launch(T)` starts upright at rest (state F) under a constant torque T > m g r and
follows B (pivot on A) / C (slide on A) until lift-off.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp

RTOL, ATOL = 1e-13, 1e-16


class Ref:
    def __init__(self, m=1.0, I=0.0017, r=0.05, h=0.05, g=9.8e-5, mus=0.6, mud=0.5):
        self.m, self.I, self.r, self.h, self.g, self.mus, self.mud = m, I, r, h, g, mus, mud
        self.l = math.hypot(r, h)
        self.alpha = math.atan2(h, r)

    # --- state B: pivot on A ---------------------------------------------------
    def pivot(self, T, th, w):
        m, I, l, g = self.m, self.I, self.l, self.g
        c, s = math.cos(th + self.alpha), math.sin(th + self.alpha)
        thdd = (T - m * g * l * c) / (I + m * l * l)
        fax = m * l * (thdd * s + w * w * c)
        fay = m * l * (thdd * c - w * w * s) + m * g
        return thdd, fax, fay

    # --- state C: slide on A ----------------------------------------------------
    def slide(self, T, th, w, sigma):
        m, I, l, g, mud = self.m, self.I, self.l, self.g, self.mud
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
        m, g, r = self.m, self.g, self.r
        assert T > m * g * r, "below the tipping torque the rover stays in F"
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
                sol = solve_ivp(rhs, (t, t_max), [th, w], method="DOP853", rtol=RTOL,
                                atol=ATOL, events=(liftoff, slip))
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

                def rhs(_t, y):
                    thdd, fx, _ = self.slide(T, y[0], y[1], sg)
                    return [y[1], thdd, y[3], fx / m]

                def liftoff(_t, y):
                    return self.slide(T, y[0], y[1], sg)[2]

                def stick(_t, y):
                    # sigma * (xdot_A): the sliding speed of corner A
                    return sg * (y[3] - self.l * y[1] * math.sin(y[0] + self.alpha))

                liftoff.terminal, liftoff.direction = True, -1
                stick.terminal, stick.direction = True, -1
                # the slide starts from rest: integrate a hair before arming 'stick'
                sol = solve_ivp(rhs, (t, t_max), [th, w, x, vx], method="DOP853",
                                rtol=RTOL, atol=ATOL, events=(liftoff, stick))
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
