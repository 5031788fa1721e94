"""umbmark.model.geometry (the robot types, wrap_angle) and the physics of umbmark.model.odometry's integrators."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.model import dataset
from umbmark.model.geometry import (
    LABMATE,
    Calibration,
    ErrorParams,
    Geometry,
    OdometryParams,
    WheelGeometry,
    wrap_angle,
)
from umbmark.model.odometry import KERNELS, integrate, integrate_end, integrate_pulses
from umbmark.model.runs import RunsTable


def test_mm_per_pulse_is_eq_2_1():
    g = Geometry(wheel_diameter_m=0.084, wheelbase_m=0.2, pulses_per_motor_rev=64, gear_ratio=43.7)
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


def test_true_wheels_and_odometry_of_an_error_model():
    g = Geometry(0.084, 0.2, 64, 43.7)
    e = ErrorParams(1.003, 0.97, 1.01)
    w = e.wheels(g)
    assert (w.diameter_left_m, w.diameter_right_m) == e.diameters_m(g)
    assert w.wheelbase_m == 0.97 * 0.2
    assert g.pulses_per_wheel_rev == 43.7 * 64
    p = e.true_params(g)
    k = math.pi / (43.7 * 64)
    assert (p.left_m_per_pulse, p.right_m_per_pulse, p.wheelbase_m) == (
        k * w.diameter_left_m,
        k * w.diameter_right_m,
        w.wheelbase_m,
    )
    assert p == w.params(g.pulses_per_wheel_rev)
    nominal = g.wheels()
    assert (nominal.diameter_left_m, nominal.diameter_right_m, nominal.wheelbase_m) == (0.084, 0.084, 0.2)
    assert nominal.params(g.pulses_per_wheel_rev).left_m_per_pulse == pytest.approx(g.m_per_pulse, rel=1e-15)


def test_wheel_geometry_conversions():
    nominal = WheelGeometry(0.1, 0.1, 0.3)
    cal = Calibration(0.99, 1.01, 0.29)
    g = nominal.calibrated(cal)
    assert (g.diameter_left_m, g.diameter_right_m, g.wheelbase_m) == (0.099, 0.101, 0.29)
    back = g.calibration_from(nominal)
    assert back.c_left == pytest.approx(0.99) and back.c_right == pytest.approx(1.01) and back.wheelbase_m == 0.29
    rel = g.relative_to(nominal)
    assert rel["Ed"] == pytest.approx(1.01 / 0.99) and rel["Eb"] == pytest.approx(0.29 / 0.3)
    assert rel["Es"] == pytest.approx(1.0) and rel["wheelbase_corrected_mm"] == pytest.approx(290.0)
    assert g.to_dict() == pytest.approx({"diameter_left_mm": 99.0, "diameter_right_mm": 101.0, "wheelbase_mm": 290.0})
    with pytest.raises(InputError, match="wheelbase_m"):
        WheelGeometry(0.1, 0.1, 0.0)


def test_wheel_geometry_is_one_type_importable_from_the_dataset_module():
    assert dataset.WheelGeometry is WheelGeometry


def test_ideal_calibration_makes_the_odometry_exact():
    e = ErrorParams(ed=1.004, eb=0.98)
    odo = OdometryParams.from_geometry(LABMATE, e.ideal_calibration(LABMATE))
    true = e.true_params(LABMATE)
    assert odo.right_m_per_pulse / odo.left_m_per_pulse == pytest.approx(true.right_m_per_pulse / true.left_m_per_pulse)
    assert odo.wheelbase_m == true.wheelbase_m


@pytest.mark.parametrize("kernel", KERNELS)
def test_straight_line(kernel):
    d = np.full(100, 0.01)
    x, y, th = integrate(d, d, 0.3, kernel=kernel)
    assert x[-1] == pytest.approx(1.0)
    assert np.all(y == 0) and np.all(th == 0)


@pytest.mark.parametrize("kernel", KERNELS)
def test_bigger_right_wheel_turns_left(kernel):
    x, y, th = integrate_pulses(np.full(50, 100), np.full(50, 101), OdometryParams(1e-4, 1e-4, 0.3), kernel=kernel)
    assert th[-1] > 0 and y[-1] > 0


@settings(max_examples=60, deadline=None)
@given(
    radius=st.floats(0.2, 20.0),
    arc=st.floats(0.05, 10.0),
    k=st.integers(1, 400),
    sign=st.sampled_from([-1.0, 1.0]),
    kernel=st.sampled_from(KERNELS),
)
def test_exact_arcs_land_on_the_circle_for_any_sampling(radius, arc, k, sign, kernel):
    b = 0.3
    # constant curvature 1/radius: wheel travel ratio (R + b/2) / (R - b/2)
    du = np.full(k, arc / k)
    dth = sign * du / radius
    dl, dr = du - dth * b / 2, du + dth * b / 2
    x, y, th = integrate_end(dl, dr, b, kernel=kernel)
    phi = sign * arc / radius
    assert th == pytest.approx(phi, abs=1e-9)
    assert x == pytest.approx(radius * math.sin(arc / radius), abs=1e-9)
    assert y == pytest.approx(sign * radius * (1 - math.cos(arc / radius)), abs=1e-9)


@pytest.mark.parametrize("kernel", KERNELS)
def test_midpoint_converges_to_exact(kernel):
    b = 0.3
    errs = []
    for k in (10, 100, 1000):
        dl, dr = np.full(k, 1.0 / k), np.full(k, 1.2 / k)
        xe, ye, _ = integrate_end(dl, dr, b, integrator="exact", kernel=kernel)
        xm, ym, _ = integrate_end(dl, dr, b, integrator="midpoint", kernel=kernel)
        errs.append(math.hypot(xe - xm, ye - ym))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-6


@settings(max_examples=40, deadline=None)
@given(
    runs=st.integers(1, 4),
    k=st.integers(1, 50),
    seed=st.integers(0, 2**31),
    method=st.sampled_from(["exact", "midpoint", "euler"]),
    kernel=st.sampled_from(KERNELS),
)
def test_integrate_end_equals_last_pose(runs, k, seed, method, kernel):
    rng = np.random.default_rng(seed)
    dl, dr = rng.normal(0.01, 0.005, (2, runs, k))
    b = rng.uniform(0.1, 0.5, runs)
    pose0 = tuple(rng.normal(size=(3, runs)))
    full = integrate(dl, dr, b, pose0, method, kernel=kernel)
    end = integrate_end(dl, dr, b, pose0, method, kernel=kernel)
    for a, e in zip(full, end):
        np.testing.assert_allclose(a[:, -1], e, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kernel", KERNELS)
def test_unknown_method(kernel):
    with pytest.raises(InputError, match="unknown integrator"):
        integrate([0.1], [0.1], 0.3, integrator="rk4", kernel=kernel)


def test_unknown_kernel():
    with pytest.raises(InputError, match="unknown odometry kernel"):
        integrate([0.1], [0.1], 0.3, kernel="gpu")


@given(st.floats(-1e4, 1e4))
def test_wrap_angle_range(a):
    w = float(wrap_angle(a))
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)


def test_wrap_angle_boundary_is_plus_pi():
    """(-pi, pi]: every odd multiple of pi maps to +pi; elsewhere it is the plain modulo."""
    odd = np.array([np.pi, -np.pi, 3 * np.pi, -3 * np.pi])
    np.testing.assert_array_equal(wrap_angle(odd), np.full(4, np.pi))
    rng = np.random.default_rng(0)
    a = rng.uniform(-100, 100, 10_000)
    np.testing.assert_array_equal(wrap_angle(a), np.mod(a + np.pi, 2 * np.pi) - np.pi)


def test_wrap_angle_keeps_the_kind_of_its_input():
    w = wrap_angle(4.0)
    assert isinstance(w, np.float64) and w == pytest.approx(4.0 - 2 * math.pi)
    assert wrap_angle(np.zeros((2, 3))).shape == (2, 3)
    assert wrap_angle([7.0]).shape == (1,)


def test_runs_heading_error_uses_the_same_convention():
    t = RunsTable.from_columns(["cw", "ccw"], [0, 0], [0, 0], [0, 0], [0, 0], [np.pi, 0.25], [0.0, -0.25])
    np.testing.assert_array_equal(t.eps_theta, [np.pi, 0.5])


def test_the_model_package_exports_its_public_names():
    import importlib

    import umbmark.model as model

    for name in model.__all__:
        module = importlib.import_module(model._LAZY[name])
        assert name in module.__all__, f"{name} is not public in {module.__name__}"
        assert getattr(model, name) is getattr(module, name)
    with pytest.raises(AttributeError):
        model.no_such_name  # noqa: B018
