"""Small shared pieces of the tests (controllers, state checks)."""
import math

import numpy as np


def wrap(th):
    return (np.asarray(th) + np.pi) % (2 * np.pi) - np.pi


def attitude_hold(the, omg, inertia=0.0017, kp=0.1, kd=0.8):
    """A PD torque that brings theta to 0 and omega to 0 in flight."""
    th = (the + math.pi) % (2 * math.pi) - math.pi
    return -inertia * (kd * omg + kp * th)


def launch_then_hold(torque, t_start=0.0, t_stop=None):
    """Contest controller: `torque` from t_start until the first flight (or t_stop),
    attitude hold in flight, idle afterwards."""
    mem = {"flown": False}

    def control(pos, vel, the, omg, posT, t, smt, state):
        if state == "A":
            mem["flown"] = True
            return attitude_hold(the, omg)
        if mem["flown"] or t < t_start or (t_stop is not None and t >= t_stop):
            return 0.0
        return torque

    return control


def kinematic_violations(roll, tol=1e-9):
    """Samples whose state letter contradicts the kinematics (MODEL.md section 4)."""
    p = roll.params
    th = wrap(roll.theta)
    _, ya, _, vya = roll.corner("A")
    _, yb, _, vyb = roll.corner("B")
    bad = []
    last = len(roll.state) - 1
    for i, st in enumerate(roll.state):
        if roll.broken and i == last:
            continue            # the breaking instant: a top corner is on the ground
        ok = True
        if st == "A":
            ok = ya[i] >= -tol and yb[i] >= -tol
        elif st in "BC":
            ok = (abs(ya[i]) <= tol and abs(vya[i]) <= tol and yb[i] >= -tol
                  and -tol <= th[i] < np.pi / 2)
        elif st in "DE":
            ok = (abs(yb[i]) <= tol and abs(vyb[i]) <= tol and ya[i] >= -tol
                  and -np.pi / 2 < th[i] <= tol)
        elif st == "F":
            ok = (th[i] == 0.0 and roll.y[i] == p.half_height and roll.vx[i] == 0.0
                  and roll.vy[i] == 0.0 and roll.omega[i] == 0.0)
        elif st == "G":
            ok = (th[i] == 0.0 and roll.y[i] == p.half_height and roll.vx[i] != 0.0
                  and roll.vy[i] == 0.0 and roll.omega[i] == 0.0)
        if st in "BD":
            cx = "A" if st == "B" else "B"
            ok = ok and abs(roll.corner(cx)[2][i]) <= tol
        if not ok:
            bad.append((i, roll.t[i], st))
    return bad
