"""The covariance of errors shared within a recording: merged blocks, the larger of two
covariances, and halves of a recording with a slowly changing error that agree within their
intervals."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.correct.selfcal import estimate, selfcal
from umbmark.model.intervals import Intervals, intervals_from_motion


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(1, 30), min_size=1, max_size=40), st.integers(1, 12))
def test_merged_blocks_are_neighbours_of_about_equal_counts(sizes, n):
    labels = np.repeat(np.arange(len(sizes)) * 3 + 7, sizes)  # labels need not start at 0 or be consecutive
    merged = estimate.merge_blocks(labels, n)
    assert merged.shape == labels.shape
    assert np.all(np.diff(merged) >= 0)  # neighbours stay neighbours
    g = len(sizes)
    assert len(np.unique(merged)) == min(n, g)
    # every block goes whole into one merged block, and the merged blocks hold as many blocks
    # as each other to within one
    per_block = [np.unique(merged[labels == lab]) for lab in np.unique(labels)]
    assert all(len(u) == 1 for u in per_block)
    counts = np.bincount(np.array([u[0] for u in per_block]))
    assert counts.max() - counts.min() <= 1


def _spd(rng, n, scale):
    a = rng.normal(size=(n, n)) * scale
    return a @ a.T + 1e-6 * np.eye(n)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 6), st.floats(1e-4, 1e4))
def test_the_larger_covariance_bounds_both_in_every_direction(seed, n, scale):
    rng = np.random.default_rng(seed)
    a, b = _spd(rng, n, 1.0), _spd(rng, n, scale)
    m = estimate.loewner_max(a, b)
    assert np.allclose(m, m.T)
    for other in (a, b):
        gap = np.linalg.eigvalsh(m - other)
        assert gap.min() >= -1e-9 * max(np.abs(np.linalg.eigvalsh(m)).max(), 1e-300)
    # the least such bound: where b is smaller in every direction, a itself
    # (to the precision of the largest entry: an eigen-decomposition's rounding is not per entry)
    tol = 1e-9 * np.abs(a).max()
    assert np.allclose(estimate.loewner_max(a, 0.5 * a), a, rtol=1e-9, atol=tol)
    assert np.allclose(estimate.loewner_max(a, 2.0 * a), 2.0 * a, rtol=1e-9, atol=2 * tol)


R, B = 0.05, 0.3
TRUTH = np.array([0.0502, 0.0499, 0.305, 0.12, -0.04, 0.3])


def _recording(seed, k=1200, dt=0.5, shared_sd=0.003, tau_s=20.0):
    """Mixed driving for ``k * dt`` seconds whose sensor displacements carry a scale error
    shared over about ``tau_s`` (a first-order autoregressive process of standard deviation
    ``shared_sd``: a floor, a load, a matcher's bias in one part of a building), besides
    independent noise of 1 mm, 1 mm, 0.05 deg."""
    rng = np.random.default_rng([11, seed])
    kind = rng.integers(0, 3, k)
    ds = np.where(kind == 1, 0.0, 0.3 * dt * rng.uniform(0.2, 1.0, k))
    dth = np.where(kind == 0, 0.0, 1.0 * dt * rng.uniform(-1.0, 1.0, k))
    fl, fr = (ds - 0.5 * B * dth) / R, (ds + 0.5 * B * dth) / R
    iv = intervals_from_motion(fl, fr, dt, TRUTH[0], TRUTH[1], TRUTH[2], TRUTH[3:])
    a = math.exp(-dt / tau_s)
    shared = np.zeros(k)
    shared[0] = rng.normal() * shared_sd
    for i in range(1, k):
        shared[i] = a * shared[i - 1] + math.sqrt(1.0 - a * a) * shared_sd * rng.normal()
    sensor = iv.sensor.copy()
    sensor[:, :2] *= (1.0 + shared)[:, None]
    sensor += rng.normal(size=sensor.shape) * np.array([1e-3, 1e-3, math.radians(0.05)])
    return Intervals(iv.dt_s, fl, fr, sensor)


def _halves_apart(iv):
    """Each half calibrated apart: the wheel radii's difference over the combined half-width
    of their 95 % intervals (the larger of the two radii's; at most 1: they agree)."""
    k = len(iv)
    fits = [selfcal(iv.subset(np.arange(a, b)), 2 * R, B) for a, b in ((0, k // 2), (k // 2, k))]
    assert all(f.covariance_blocks == 15 for f in fits)  # 300 s: 15 blocks of 20 s
    z = []
    for name in ("r_left_m", "r_right_m"):
        (lo1, hi1), (lo2, hi2) = (f.ci95[name] for f in fits)
        v1, v2 = (getattr(f, name) for f in fits)
        z.append(abs(v1 - v2) / math.hypot(0.5 * (hi1 - lo1), 0.5 * (hi2 - lo2)))
    return max(z)


@pytest.mark.slow
def test_halves_with_an_error_shared_over_tens_of_seconds_agree_within_their_intervals(monkeypatch):
    recordings = [_recording(seed) for seed in range(20)]
    agree = sum(_halves_apart(iv) <= 1.0 for iv in recordings)
    # 95 % intervals: about 19 of 20 (neighbouring blocks still share some of the error)
    assert agree >= 16
    # the short blocks alone (15 of 20 s per half) miss the shared error: too narrow
    monkeypatch.setattr(estimate, "LONG_BLOCKS", 10**6)
    agree_short = sum(_halves_apart(iv) <= 1.0 for iv in recordings)
    assert agree_short <= agree - 3


def test_the_long_blocks_only_widen_the_intervals_by_about_a_third_without_a_shared_error(monkeypatch):
    iv = _recording(3, shared_sd=0.0)
    names = ("r_left_m", "r_right_m", "wheelbase_m", "sensor_x_m", "sensor_y_m", "sensor_yaw_rad")
    both = selfcal(iv, 2 * R, B)
    monkeypatch.setattr(estimate, "LONG_BLOCKS", 10**6)
    short = selfcal(iv, 2 * R, B)
    ratio = np.array([np.subtract(*both.ci95[n][::-1]) / np.subtract(*short.ci95[n][::-1]) for n in names])
    assert np.all(ratio >= 1.0 - 1e-12) and np.all(ratio < 2.0) and np.median(ratio) < 1.5, ratio
    assert np.array_equal(both.params, short.params)
