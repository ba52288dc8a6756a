"""`euler` approaches `event` as its step shrinks (MODEL.md section 11)."""

import numpy as np
import pytest

from helpers import first_landing


@pytest.mark.parametrize("torque", [3e-4, 1e-4])
def test_euler_converges_to_event_at_first_order(torque, capsys):
    t_ref, x_ref = first_landing("event", torque=torque)
    dts = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4]
    errs = []
    for dt in dts:
        t, x = first_landing("euler", dt, torque=torque)
        errs.append((abs(t - t_ref), abs(x - x_ref)))
    errs = np.array(errs)
    orders = np.log(errs[:-1] / errs[1:]) / np.log(np.array(dts[:-1]) / np.array(dts[1:]))[:, None]
    with capsys.disabled():
        print(
            f"\n  first landing, launch torque {torque:g} N m: event t = {t_ref:.9f} s, "
            f"x = {x_ref:.9f} m"
        )
        for dt, (et, ex) in zip(dts, errs):
            print(f"    euler dt {dt:7.0e}: |dt_land| {et:9.2e} s  |dx_land| {ex:9.2e} m")
        print(f"    observed orders (time, point): {np.round(orders, 2).tolist()}")
    assert np.all(np.diff(errs[:, 0]) < 0) and np.all(np.diff(errs[:, 1]) < 0)
    # first order overall: the error falls ~ dt across the two decades
    overall = np.log(errs[0] / errs[-1]) / np.log(dts[0] / dts[-1])
    assert np.all((overall > 0.8) & (overall < 1.3)), overall
    assert errs[-1, 0] < 1e-2 * t_ref and errs[-1, 1] < 5e-3
