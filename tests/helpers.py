"""Small shared pieces of the tests (contest-signature controllers). The state checks
live in hoprover_env.testing, shared with the benchmarks."""
from hoprover_env import controllers


def attitude_hold(the, omg, inertia=0.0017, kp=0.1, kd=0.8):
    """A PD torque that brings theta to 0 and omega to 0 in flight
    (hoprover_env.controllers.attitude_hold with the tests' default gains)."""
    return controllers.attitude_hold(float(the), float(omg), inertia, kp, kd)


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
