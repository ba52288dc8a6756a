import dataclasses
import math

import numpy as np
import pytest

from hoprover_env import RoverParams


def test_contest_defaults():
    p = RoverParams()
    assert (p.mass, p.inertia, p.gravity) == (1.0, 0.0017, 9.8e-5)
    assert p.corner_distance == pytest.approx(math.sqrt(0.05**2 + 0.05**2))
    assert p.alpha == pytest.approx(math.pi / 4)
    assert p.tipping_torque == pytest.approx(4.9e-6)
    assert p.as_array().shape == (19,)
    assert (p.slope, p.roughness) == (0.0, 0.0)


@pytest.mark.parametrize(
    "field, value, words",
    [
        ("mass", 0.0, "mass must be positive"),
        ("inertia", -1e-3, "inertia must be positive"),
        ("half_width", 0.0, "half_width must be positive"),
        ("half_height", -0.1, "half_height must be positive"),
        ("gravity", 0.0, "gravity must be positive"),
        ("mu_static", 1.2, "mu_static must lie in [0, 1]"),
        ("mu_dynamic", -0.1, "mu_dynamic must lie in [0, 1]"),
        ("restitution_x", 1.5, "restitution_x must lie in [0, 1]"),
        ("restitution_y", -0.2, "restitution_y must lie in [0, 1]"),
        ("v_ymin", -1e-6, "v_ymin must be positive"),
        ("v_ymin", 0.0, "v_ymin must be positive"),
        ("v_xmin", -1e-6, "v_xmin must be >= 0"),
        ("mass", float("nan"), "mass must be finite"),
        ("torque_max", float("inf"), "torque_max must be finite"),
        ("gravity", "9.8e-5", "gravity must be a real number"),
        ("slope", 0.5000001, "slope must lie in"),
        ("slope", -0.6, "slope must lie in"),
        ("slope", float("nan"), "slope must be finite"),
        ("roughness", -1e-3, "roughness must be >= 0"),
        ("roughness", float("inf"), "roughness must be finite"),
        ("roughness", float("nan"), "roughness must be finite"),
        ("roughness", "0.1", "roughness must be a real number"),
    ],
)
def test_invalid_field_is_named(field, value, words):
    with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]")):
        RoverParams(**{field: value})


def test_terrain_slots_of_the_kernel_vector():
    from hoprover_env.core.params import P_GC, P_GS, P_ROUGH, P_SLOPE

    flat = RoverParams().as_array()
    assert flat[P_GC] == 9.8e-5 and flat[P_GS] == 0.0 and not np.signbit(flat[P_GS])
    assert not np.signbit(RoverParams(slope=-0.0).as_array()[P_GS])
    p = RoverParams(slope=-0.3, roughness=0.05)
    a = p.as_array()
    assert (a[P_SLOPE], a[P_ROUGH]) == (-0.3, 0.05)
    assert a[P_GS] == pytest.approx(9.8e-5 * math.sin(-0.3), rel=1e-15)
    assert a[P_GC] == pytest.approx(9.8e-5 * math.cos(-0.3), rel=1e-15)
    assert RoverParams(slope=0.5).slope == 0.5 and RoverParams(slope=-0.5).slope == -0.5


def test_torque_limits_order():
    with pytest.raises(ValueError, match="torque_min .* exceeds torque_max"):
        RoverParams(torque_min=1e-4, torque_max=-1e-4)


def test_kinetic_friction_above_static_rejected():
    with pytest.raises(ValueError, match="mu_dynamic .* must not exceed mu_static"):
        RoverParams(mu_static=0.3, mu_dynamic=0.5)


def test_painleve_regime_rejected():
    # a light body with high friction: I + m dx (dx + sigma mu dy) changes sign
    with pytest.raises(ValueError, match="Painleve"):
        RoverParams(inertia=1e-4, mu_static=1.0, mu_dynamic=1.0)


def brute_force_min_denominator(p, n=200001):
    th = np.linspace(0.0, np.pi / 2, n)
    r, h, m, mu = p.half_width, p.half_height, p.mass, p.mu_dynamic
    dx = r * np.cos(th) - h * np.sin(th)
    dy = -r * np.sin(th) - h * np.cos(th)
    return min(np.min(p.inertia + m * dx * (dx + s * mu * dy)) for s in (-1.0, 1.0))


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"mu_dynamic": 1.0, "mu_static": 1.0},
        {"half_width": 0.08, "half_height": 0.03},
        {"half_width": 0.03, "half_height": 0.08, "inertia": 0.01},
        {"inertia": 5e-3, "mass": 2.0, "mu_dynamic": 0.2},
    ],
)
def test_min_slide_denominator_matches_brute_force(kw):
    p = RoverParams(**kw)
    assert p.min_slide_denominator() == pytest.approx(
        brute_force_min_denominator(p), rel=1e-8, abs=1e-12
    )


def test_slip_torque_closed_form():
    p = RoverParams()
    j = p.inertia + p.mass * p.corner_distance**2
    # thdd_max = mu_s g / (h - mu_s r) = 2.94e-3 rad/s^2; T = m g r + J thdd_max
    assert p.slip_torque == pytest.approx(4.9e-6 + j * 0.6 * 9.8e-5 / 0.02, rel=1e-12)
    assert p.slip_torque == pytest.approx(2.4598e-5, rel=1e-4)


def test_frozen_and_replace_revalidates():
    p = RoverParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.mass = 2.0
    with pytest.raises(ValueError, match="mass"):
        dataclasses.replace(p, mass=-1.0)
