"""umbmark.model.odometry: the "fast" kernels against the "trig" kernel and the per-sample loop."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from umbmark.errors import InputError
from umbmark.model import odometry
from umbmark.model.geometry import OdometryParams
from umbmark.studies import reference

PARAMS = OdometryParams(4.7e-5, 4.72e-5, 0.34)


def trig(dl, dr, b, pose0=(0.0, 0.0, 0.0), method="exact"):
    """The "trig" kernel: one numpy cos and sin per sample, the vectorised reference of the fast kernels."""
    return odometry.integrate(dl, dr, b, pose0, method, kernel="trig")


def trig_pulses(nl, nr, params, pose0=(0.0, 0.0, 0.0), method="exact"):
    return odometry.integrate_pulses(nl, nr, params, pose0, method, kernel="trig")


def _close(a, b, tol):
    for u, v in zip(a, b):
        np.testing.assert_allclose(np.asarray(u), np.asarray(v), rtol=0, atol=tol)


@pytest.mark.parametrize("method", odometry.INTEGRATORS)
def test_matches_numpy_integrator_with_large_turns(method):
    rng = np.random.default_rng(0)
    dl = rng.normal(0.0, 0.05, (3, 3000))  # up to ~0.5 rad per sample: exercises the exact fallback
    dr = rng.normal(0.0, 0.05, (3, 3000))
    b = np.array([0.3, 0.4, 0.5])
    pose0 = (np.array([1.0, 2.0, 3.0]), 0.5, np.array([0.1, -2.0, 7.0]))
    want = trig(dl, dr, b, pose0, method)
    _close(odometry.integrate(dl, dr, b, pose0, method, chunk=700), want, 1e-12)
    _close(odometry.integrate_end(dl, dr, b, pose0, method), [w[:, -1] for w in want], 1e-12)


@settings(max_examples=40, deadline=None)
@given(
    dl=arrays(np.float64, st.integers(1, 300), elements=st.floats(-0.02, 0.05)),
    dr_scale=st.floats(0.5, 1.5),
    dr_off=st.floats(-0.002, 0.002),
    b=st.floats(0.05, 1.0),
    th0=st.floats(-10, 10),
    method=st.sampled_from(odometry.INTEGRATORS),
    chunk=st.integers(1, 200),
)
def test_property_same_poses_as_numpy(dl, dr_scale, dr_off, b, th0, method, chunk):
    dr = dl * dr_scale + dr_off
    want = trig(dl, dr, b, (0.3, -0.2, th0), method)
    got = odometry.integrate(dl, dr, b, (0.3, -0.2, th0), method, chunk=chunk)
    _close(got, want, 1e-11)
    end = odometry.integrate_end(dl, dr, b, (0.3, -0.2, th0), method, chunk=chunk)
    _close(end, [w[-1] for w in want], 1e-11)


@pytest.mark.parametrize("method", odometry.INTEGRATORS)
def test_pulses_table_kernel(method):
    rng = np.random.default_rng(1)
    nl = rng.integers(-3, 12, 200_000)
    nr = rng.integers(0, 12, 200_000)
    want = trig_pulses(nl, nr, PARAMS, (0.1, 0.2, 0.3), method)
    got = odometry.integrate_pulses(nl, nr, PARAMS, (0.1, 0.2, 0.3), method)
    _close(got, want, 1e-10)  # the numpy cumsum of headings drifts by ~1e-11 here
    end = odometry.integrate_pulses_end(nl, nr, PARAMS, (0.1, 0.2, 0.3), method)
    _close(end, [w[-1] for w in want], 1e-10)


def test_pulses_many_distinct_increments_fall_back_to_float_kernel():
    rng = np.random.default_rng(2)
    nl = rng.integers(-5000, 5000, 5000)  # too many distinct pairs for a table
    nr = rng.integers(-5000, 5000, 5000)
    want = trig_pulses(nl, nr, PARAMS)
    _close(odometry.integrate_pulses(nl, nr, PARAMS), want, 1e-11)
    # float (non-integer) increments too
    _close(odometry.integrate_pulses(nl + 0.25, nr, PARAMS), trig_pulses(nl + 0.25, nr, PARAMS), 1e-11)


def test_runs_axis_with_pulses():
    rng = np.random.default_rng(3)
    nl = rng.integers(0, 8, (2, 3, 1000))
    nr = rng.integers(0, 8, (2, 3, 1000))
    want = trig_pulses(nl, nr, PARAMS)
    got = odometry.integrate_pulses(nl, nr, PARAMS)
    assert got[0].shape == (2, 3, 1000)
    _close(got, want, 1e-11)


def test_matches_per_sample_reference_loop():
    rng = np.random.default_rng(4)
    nl = rng.integers(2, 7, 20_000)
    nr = rng.integers(2, 7, 20_000)
    for method in odometry.INTEGRATORS:
        _close(
            odometry.integrate_pulses(nl, nr, PARAMS, integrator=method),
            reference.integrate_pulses(nl, nr, PARAMS, integrator=method),
            1e-10,
        )


@pytest.mark.slow
def test_streaming_chunk_boundaries_1e6_samples():
    """Streaming with arbitrary chunk boundaries gives the poses of one pass, to 1e-9 m."""
    n = 10**6
    rng = np.random.default_rng(5)
    t = np.arange(n) * 1e-3
    base = 4.25 + 1.5 * np.sin(2 * np.pi * t / 20.0)
    nl = np.rint(base + rng.uniform(-1, 1, n)).astype(np.int64)
    nr = np.rint(base[::-1] + rng.uniform(-1, 1, n)).astype(np.int64)
    one = odometry.integrate_pulses(nl, nr, PARAMS)
    cuts = np.sort(rng.choice(np.arange(1, n), 40, replace=False))
    cuts = np.r_[0, cuts, 1, 2, 3, n]  # includes 1- and 2-sample chunks
    cuts = np.unique(cuts)
    for pulses in (True, False):
        odo = odometry.Odometer(params=PARAMS)
        parts = []
        for a, b in zip(cuts[:-1], cuts[1:]):
            if pulses:
                parts.append(odo.update_pulses(nl[a:b], nr[a:b]))
            else:
                parts.append(odo.update(nl[a:b] * PARAMS.left_m_per_pulse, nr[a:b] * PARAMS.right_m_per_pulse))
        got = [np.concatenate([p[i] for p in parts]) for i in range(3)]
        assert np.max(np.hypot(got[0] - one[0], got[1] - one[1])) < 1e-9
        assert np.max(np.abs(got[2] - one[2])) < 1e-9
        assert odo.samples == n
    # and the per-sample loop agrees with both
    ref = reference.integrate_pulses(nl, nr, PARAMS)
    assert np.max(np.hypot(ref[0] - one[0], ref[1] - one[1])) < 1e-9


def test_replay_stream_end_and_decimation():
    rng = np.random.default_rng(6)
    chunks = [(rng.integers(0, 9, k), rng.integers(0, 9, k)) for k in (5, 1000, 1, 333)]
    nl = np.concatenate([c[0] for c in chunks])
    nr = np.concatenate([c[1] for c in chunks])
    one = odometry.integrate_pulses(nl, nr, PARAMS, pose0=(1.0, 2.0, 0.5))
    res = odometry.replay_stream(iter(chunks), params=PARAMS, pose0=(1.0, 2.0, 0.5), decimate=7)
    assert res.samples == nl.size
    assert res.x == pytest.approx(one[0][-1], abs=1e-12)
    assert res.theta == pytest.approx(one[2][-1], abs=1e-12)
    np.testing.assert_array_equal(res.kept["sample"], np.arange(7, nl.size + 1, 7))
    np.testing.assert_allclose(res.kept["y"], one[1][6::7], atol=1e-12)
    # wheel travel instead of pulses, end pose only
    res2 = odometry.replay_stream(
        ((a * PARAMS.left_m_per_pulse, b * PARAMS.right_m_per_pulse) for a, b in chunks),
        wheelbase_m=PARAMS.wheelbase_m,
        pose0=(1.0, 2.0, 0.5),
        pulses=False,
    )
    assert res2.kept is None
    assert res2.y == pytest.approx(one[1][-1], abs=1e-12)


def test_empty_chunk_and_pose_state():
    odo = odometry.Odometer(0.3, pose0=(1.0, 2.0, 0.0))
    x, y, th = odo.update(np.empty(0), np.empty(0))
    assert x.shape == (0,)
    assert odo.pose == (1.0, 2.0, 0.0)
    odo.update([0.1], [0.1])
    assert odo.pose[0] == pytest.approx(1.1)


def test_bad_input():
    with pytest.raises(InputError, match="unknown integrator"):
        odometry.integrate([0.1], [0.1], 0.3, integrator="rk4")
    with pytest.raises(InputError, match="same|one shape"):
        odometry.integrate([0.1, 0.2], [0.1], 0.3)
    with pytest.raises(InputError, match="K >= 1"):
        odometry.integrate_end([], [], 0.3)
    with pytest.raises(InputError, match="params"):
        odometry.Odometer(0.3).update_pulses([1], [1])
    with pytest.raises(InputError, match="wheelbase"):
        odometry.Odometer(-0.3)
    with pytest.raises(InputError, match="shape"):
        odometry.Odometer(0.3, shape=(2,)).update(np.zeros(3), np.zeros(3))
    with pytest.raises(InputError, match="decimate"):
        odometry.replay_stream([], params=PARAMS, decimate=0)


@settings(max_examples=40, deadline=None)
@given(
    nl=arrays(np.int64, st.integers(1, 400), elements=st.integers(-20, 40)),
    shift=st.integers(-3, 3),
    th0=st.floats(-10, 10),
    method=st.sampled_from(odometry.INTEGRATORS),
    chunk=st.integers(1, 300),
)
def test_property_pulses_same_poses_as_numpy(nl, shift, th0, method, chunk):
    nr = np.roll(nl, 1) + shift
    want = trig_pulses(nl, nr, PARAMS, (0.3, -0.2, th0), method)
    _close(odometry.integrate_pulses(nl, nr, PARAMS, (0.3, -0.2, th0), method, chunk=chunk), want, 1e-12)
    end = odometry.integrate_pulses_end(nl, nr, PARAMS, (0.3, -0.2, th0), method, chunk=chunk)
    _close(end, [w[-1] for w in want], 1e-12)


@pytest.mark.parametrize("method", odometry.INTEGRATORS)
def test_trig_kernel_matches_per_sample_loop(method):
    rng = np.random.default_rng(7)
    nl = rng.integers(-2, 9, 5000)
    nr = rng.integers(-2, 9, 5000)
    want = reference.integrate_pulses(nl, nr, PARAMS, (0.1, 0.2, 0.3), method)
    _close(trig_pulses(nl, nr, PARAMS, (0.1, 0.2, 0.3), method), want, 1e-11)
    end = odometry.integrate_pulses_end(nl, nr, PARAMS, (0.1, 0.2, 0.3), method, kernel="trig")
    _close(end, [w[-1] for w in want], 1e-11)


def test_end_pose_types_agree_between_kernels():
    """One log: numpy floats from every end-pose function and kernel; runs: arrays of the leading shape."""
    for kernel in odometry.KERNELS:
        for end in (
            odometry.integrate_end([0.1, 0.2], [0.1, 0.3], 0.3, kernel=kernel),
            odometry.integrate_pulses_end([1, 2], [1, 3], PARAMS, kernel=kernel),
        ):
            assert all(isinstance(v, np.float64) for v in end)
        x, y, th = odometry.integrate_end(np.ones((2, 4)), np.ones((2, 4)), 0.3, kernel=kernel)
        assert x.shape == y.shape == th.shape == (2,)


def test_bad_kernel_and_shapes_with_the_trig_kernel():
    with pytest.raises(InputError, match="unknown odometry kernel"):
        odometry.integrate_pulses([1], [1], PARAMS, kernel="numpy")
    with pytest.raises(InputError, match="one shape"):
        odometry.integrate([0.1, 0.2], [0.1], 0.3, kernel="trig")
    with pytest.raises(InputError, match="K >= 1"):
        odometry.integrate_pulses_end([], [], PARAMS, kernel="trig")
