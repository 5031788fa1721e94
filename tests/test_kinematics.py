import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.model.geometry import (
    Calibration,
    ErrorParams,
    Geometry,
    OdometryParams,
    integrate,
    integrate_end,
    odometry_from_pulses,
    wrap_angle,
)


def test_mm_per_pulse_is_eq_2_1():
    g = Geometry(wheel_diameter_m=0.084, wheelbase_m=0.2, pulses_per_rev=64, gear_ratio=43.7)
    assert g.m_per_pulse == pytest.approx(math.pi * 0.084 / (43.7 * 64), rel=1e-15)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_geometry_rejects_non_positive(bad):
    with pytest.raises(InputError):
        Geometry(wheel_diameter_m=bad, wheelbase_m=0.3)


def test_calibration_factors_scale_each_wheel():
    g = Geometry(0.15, 0.34, 500, 20)
    p = OdometryParams.from_geometry(g, Calibration(0.99, 1.01, 0.336))
    assert p.left_m_per_pulse == pytest.approx(0.99 * g.m_per_pulse)
    assert p.right_m_per_pulse == pytest.approx(1.01 * g.m_per_pulse)
    assert p.wheelbase_m == 0.336
    assert OdometryParams.from_geometry(g).wheelbase_m == 0.34


@given(ed=st.floats(0.9, 1.1), es=st.floats(0.9, 1.1))
def test_error_params_diameters(ed, es):
    g = Geometry(0.15, 0.34)
    dl, dr = ErrorParams(ed=ed, es=es).diameters_m(g)
    assert dr / dl == pytest.approx(ed, rel=1e-12)
    assert (dl + dr) / 2 == pytest.approx(es * 0.15, rel=1e-12)


def test_straight_line():
    d = np.full(100, 0.01)
    x, y, th = integrate(d, d, 0.3)
    assert x[-1] == pytest.approx(1.0)
    assert np.all(y == 0) and np.all(th == 0)


def test_bigger_right_wheel_turns_left():
    x, y, th = odometry_from_pulses(np.full(50, 100), np.full(50, 101), OdometryParams(1e-4, 1e-4, 0.3))
    assert th[-1] > 0 and y[-1] > 0


@settings(max_examples=60, deadline=None)
@given(
    radius=st.floats(0.2, 20.0),
    arc=st.floats(0.05, 10.0),
    k=st.integers(1, 400),
    sign=st.sampled_from([-1.0, 1.0]),
)
def test_exact_arcs_land_on_the_circle_for_any_sampling(radius, arc, k, sign):
    b = 0.3
    # constant curvature 1/radius: wheel travel ratio (R + b/2) / (R - b/2)
    du = np.full(k, arc / k)
    dth = sign * du / radius
    dl, dr = du - dth * b / 2, du + dth * b / 2
    x, y, th = integrate_end(dl, dr, b)
    phi = sign * arc / radius
    assert th == pytest.approx(phi, abs=1e-9)
    assert x == pytest.approx(radius * math.sin(arc / radius), abs=1e-9)
    assert y == pytest.approx(sign * radius * (1 - math.cos(arc / radius)), abs=1e-9)


def test_midpoint_converges_to_exact():
    b = 0.3
    errs = []
    for k in (10, 100, 1000):
        dl, dr = np.full(k, 1.0 / k), np.full(k, 1.2 / k)
        xe, ye, _ = integrate_end(dl, dr, b, method="exact")
        xm, ym, _ = integrate_end(dl, dr, b, method="midpoint")
        errs.append(math.hypot(xe - xm, ye - ym))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-6


@settings(max_examples=40, deadline=None)
@given(
    runs=st.integers(1, 4),
    k=st.integers(1, 50),
    seed=st.integers(0, 2**31),
    method=st.sampled_from(["exact", "midpoint", "euler"]),
)
def test_integrate_end_equals_last_pose(runs, k, seed, method):
    rng = np.random.default_rng(seed)
    dl, dr = rng.normal(0.01, 0.005, (2, runs, k))
    b = rng.uniform(0.1, 0.5, runs)
    pose0 = tuple(rng.normal(size=(3, runs)))
    full = integrate(dl, dr, b, pose0, method)
    end = integrate_end(dl, dr, b, pose0, method)
    for a, e in zip(full, end):
        np.testing.assert_allclose(a[:, -1], e, rtol=0, atol=1e-12)


def test_unknown_method():
    with pytest.raises(InputError):
        integrate([0.1], [0.1], 0.3, method="rk4")


@given(st.floats(-1e4, 1e4))
def test_wrap_angle_range(a):
    w = float(wrap_angle(a))
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)
