"""SE(2) helpers: group laws, broadcasting, the arc against a fine integration and its limits."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.model import se2

coord = st.floats(-10.0, 10.0, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
pose = st.tuples(coord, coord, angle).map(np.array)


def close_pose(a, b, atol=1e-9):
    a, b = np.asarray(a), np.asarray(b)
    np.testing.assert_allclose(a[..., :2], b[..., :2], atol=atol, rtol=0)
    dth = np.angle(np.exp(1j * (a[..., 2] - b[..., 2])))
    np.testing.assert_allclose(dth, 0.0, atol=atol)


@settings(max_examples=200, deadline=None)
@given(pose, pose, pose)
def test_compose_is_associative(a, b, c):
    close_pose(se2.compose(se2.compose(a, b), c), se2.compose(a, se2.compose(b, c)))


@settings(max_examples=200, deadline=None)
@given(pose)
def test_inverse_gives_identity_both_sides(a):
    close_pose(se2.compose(a, se2.inverse(a)), [0, 0, 0])
    close_pose(se2.compose(se2.inverse(a), a), [0, 0, 0])
    close_pose(se2.inverse(se2.inverse(a)), a)


@settings(max_examples=200, deadline=None)
@given(pose, pose)
def test_between_undoes_compose(a, b):
    close_pose(se2.between(a, se2.compose(a, b)), b)
    close_pose(se2.between(a, b), se2.compose(se2.inverse(a), b))
    close_pose(se2.compose([0, 0, 0], a), a)


def test_compose_example_and_wrapping():
    # a quarter turn: the x axis of frame b points along the parent's y
    np.testing.assert_allclose(se2.compose([1, 0, math.pi / 2], [2, 0, 0]), [1, 2, math.pi / 2], atol=1e-15)
    assert se2.compose([0, 0, 3.0], [0, 0, 3.0])[2] == pytest.approx(6.0 - 2 * math.pi)
    assert se2.inverse([0, 0, math.pi])[2] == pytest.approx(math.pi)  # -pi maps to +pi


def test_broadcasting_matches_loops():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(4, 1, 3))
    b = rng.normal(size=(5, 3))
    out = se2.compose(a, b)
    assert out.shape == (4, 5, 3)
    for i in range(4):
        for j in range(5):
            np.testing.assert_allclose(out[i, j], se2.compose(a[i, 0], b[j]))
    assert se2.arc(np.ones((2, 3)), 2.0, 0.5).shape == (2, 3, 3)


def test_bad_shape_is_refused():
    with pytest.raises(ValueError, match="last axis"):
        se2.compose(np.zeros(2), np.zeros(3))


def integrate_arc(dl, dr, b, n=20000):
    """Midpoint integration of the wheel motion in n steps (error O(1/n^2))."""
    x = y = th = 0.0
    ds, dth = 0.5 * (dl + dr) / n, (dr - dl) / b / n
    for _ in range(n):
        x += ds * math.cos(th + 0.5 * dth)
        y += ds * math.sin(th + 0.5 * dth)
        th += dth
    return np.array([x, y, th])


@settings(max_examples=25, deadline=None)
@given(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(0.1, 1.0))
def test_arc_matches_a_fine_integration(dl, dr, b):
    np.testing.assert_allclose(se2.arc(dl, dr, b), integrate_arc(dl, dr, b, n=4000), atol=1e-6)


@settings(max_examples=200, deadline=None)
@given(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(0.1, 1.0))
def test_arc_composes_with_its_halves(dl, dr, b):
    # constant wheel speeds: the second half of the motion is the same arc as the first
    half = se2.arc(dl / 2, dr / 2, b)
    close_pose(se2.arc(dl, dr, b), se2.compose(half, half), atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.floats(-2.0, 2.0), st.floats(0.1, 1.0))
def test_arc_of_a_spin_stays_in_place(d, b):
    p = se2.arc(-d, d, b)
    np.testing.assert_allclose(p[:2], 0.0, atol=1e-15)
    assert p[2] == pytest.approx(2 * d / b, rel=1e-15)


def test_arc_straight_and_nearly_straight_is_stable():
    np.testing.assert_allclose(se2.arc(1.5, 1.5, 0.4), [1.5, 0, 0])
    eps = np.array([1e-12, 1e-9, 1e-6, 1e-4])
    dl, dr = 1.0 - eps, 1.0 + eps
    d, dth = 0.5 * (dl + dr), (dr - dl) / 0.5  # the distances as rounded
    p = se2.arc(dl, dr, 0.5)
    # series of sin(t)/t and (1 - cos t)/t
    np.testing.assert_allclose(p[:, 0], d * (1 - dth**2 / 6), rtol=1e-14)
    np.testing.assert_allclose(p[:, 1], d * (dth / 2 - dth**3 / 24), rtol=1e-12)
    np.testing.assert_allclose(p[:, 2], dth, rtol=1e-15)


def test_arc_full_circle_returns_to_start_unwrapped():
    b = 0.3
    # right wheel on a circle of radius b (left wheel fixed): 2 pi turned
    p = se2.arc(0.0, 2 * math.pi * b, b)
    np.testing.assert_allclose(p[:2], 0.0, atol=1e-15)
    assert p[2] == pytest.approx(2 * math.pi)
