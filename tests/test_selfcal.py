"""The lidar self-calibration against known truth: exact recovery, interval coverage, outliers,
the mirror and swapped-wheel cases, identifiability warnings, plausibility, the CSV path."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.correct.selfcal import (
    PARAMETERS,
    ClosedFormFailed,
    Limits,
    SelfcalResult,
    closed_form,
    fisher_information,
    jacobian,
    mirror,
    predict,
    residuals,
    selfcal,
)
from umbmark.errors import InputError
from umbmark.io.intervals_csv import format_intervals_csv, parse_intervals_csv, read_intervals_csv, write_intervals_csv
from umbmark.jsonutil import dumps
from umbmark.model import se2
from umbmark.model.intervals import Intervals, IntervalSteps, intervals_from_motion, step_motion

SIGMA = np.array([1e-3, 1e-3, math.radians(0.05)])  # a scan matcher's: 1 mm, 1 mm, 0.05 deg


def wheels(ds, dth, r, b):
    """Wheel rotations for robot-centre travel ``ds`` and heading change ``dth`` per interval."""
    return (ds - 0.5 * b * dth) / r, (ds + 0.5 * b * dth) / r


def mixed(rng, k, r, b, v=0.3, w=1.0, dt=0.1):
    """Straights, spins on the spot and arcs both ways, 0.1 s intervals."""
    kind = rng.integers(0, 3, k)
    ds = np.where(kind == 1, 0.0, v * dt * rng.uniform(0.2, 1.0, k))
    dth = np.where(kind == 0, 0.0, w * dt * rng.uniform(-1.0, 1.0, k))
    return wheels(ds, dth, r, b)


def random_truth(rng):
    d = rng.uniform(0.08, 0.2)
    b = rng.uniform(0.2, 0.6)
    p = np.array(
        [
            0.5 * d * rng.uniform(0.98, 1.02),
            0.5 * d * rng.uniform(0.98, 1.02),
            b * rng.uniform(0.97, 1.03),
            rng.uniform(-0.2, 0.2),
            rng.uniform(-0.2, 0.2),
            rng.uniform(-math.pi, math.pi),
        ]
    )
    return d, b, p


def simulate(rng, p, fl, fr, sigma=SIGMA):
    iv = intervals_from_motion(fl, fr, 0.1, p[0], p[1], p[2], p[3:])
    return Intervals(iv.dt_s, fl, fr, iv.sensor + rng.normal(size=iv.sensor.shape) * sigma)


def angle_diff(a, b):
    return float(np.angle(np.exp(1j * (a - b))))


TRUTH = np.array([0.0502, 0.0499, 0.305, 0.12, -0.04, 0.3])


def fit_kind(ds, dth, seed=5, k=300, noise=True):
    rng = np.random.default_rng(seed)
    fl, fr = wheels(ds, dth, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr, SIGMA if noise else 0.0)
    return selfcal(iv, 0.1, 0.3)


# ---- the model


params = st.tuples(
    st.floats(0.02, 0.2),
    st.floats(0.02, 0.2),
    st.floats(0.1, 1.0),
    st.floats(-0.5, 0.5),
    st.floats(-0.5, 0.5),
    st.floats(-math.pi, math.pi),
).map(np.array)
rotations = st.lists(st.floats(-20.0, 20.0), min_size=2, max_size=2)


@settings(max_examples=60, deadline=None)
@given(params, st.lists(rotations, min_size=1, max_size=8))
def test_jacobian_matches_central_differences(p, rot):
    a = np.array(rot)
    fl, fr = a[:, 0], a[:, 1]
    jac = jacobian(p, fl, fr)
    for j in range(6):
        h = 1e-6 * max(abs(p[j]), 0.05)
        e = np.zeros(6)
        e[j] = h
        d = predict(p + e, fl, fr) - predict(p - e, fl, fr)
        d[:, 2] = np.angle(np.exp(1j * d[:, 2]))
        np.testing.assert_allclose(jac[:, :, j], d / (2 * h), atol=2e-5 * max(1.0, np.abs(jac).max()))


@settings(max_examples=60, deadline=None)
@given(params, st.lists(st.lists(rotations, min_size=1, max_size=5), min_size=1, max_size=6))
def test_steps_compose_their_arcs_and_their_jacobian_matches_central_differences(p, intervals):
    """An interval of several steps moves by its steps' arcs composed (against se2.compose of
    se2.arc step by step); the Jacobian of that motion seen from the sensor is exact; one step
    per interval is the arc model."""
    steps = IntervalSteps(
        np.array([r[0] for iv in intervals for r in iv]),
        np.array([r[1] for iv in intervals for r in iv]),
        np.concatenate([[0], np.cumsum([len(iv) for iv in intervals])]),
    )
    fl, fr = steps.totals
    motion, _ = step_motion(steps, p[0], p[1], p[2])
    for k, iv in enumerate(intervals):
        pose = np.zeros(3)
        for a, b in iv:
            pose = se2.compose(pose, se2.arc(p[0] * a, p[1] * b, p[2]))
        np.testing.assert_allclose(motion[k, :2], pose[:2], atol=1e-9 * (1 + np.abs(pose).max()))
        assert abs(np.angle(np.exp(1j * (motion[k, 2] - pose[2])))) < 1e-9  # se2.compose wraps the heading
    jac = jacobian(p, fl, fr, steps)
    for j in range(6):
        h = 1e-6 * max(abs(p[j]), 0.05)
        e = np.zeros(6)
        e[j] = h
        d = predict(p + e, fl, fr, steps) - predict(p - e, fl, fr, steps)
        d[:, 2] = np.angle(np.exp(1j * d[:, 2]))
        np.testing.assert_allclose(jac[:, :, j], d / (2 * h), atol=2e-5 * max(1.0, np.abs(jac).max()))
    one = IntervalSteps.one_each(fl, fr)
    np.testing.assert_allclose(predict(p, fl, fr, one), predict(p, fl, fr), atol=1e-12)
    np.testing.assert_allclose(jacobian(p, fl, fr, one), jacobian(p, fl, fr), atol=1e-9)


def test_steps_are_checked_and_follow_subsets():
    steps = IntervalSteps(np.arange(6.0), -np.arange(6.0), [0, 1, 3, 6])
    np.testing.assert_array_equal(steps.totals[0], [0.0, 3.0, 12.0])
    sub = steps.subset([2, 0])
    np.testing.assert_array_equal(sub.left_rad, [3.0, 4.0, 5.0, 0.0])
    np.testing.assert_array_equal(sub.start, [0, 3, 4])
    both = IntervalSteps.concatenate([steps, sub])
    assert len(both) == 5 and both.start[-1] == 10
    iv = Intervals(np.ones(3), steps.totals[0], steps.totals[1], np.zeros((3, 3)), steps=steps)
    np.testing.assert_array_equal(iv.subset(np.array([False, True, True])).steps.start, [0, 2, 5])
    for bad in ([0, 1, 1, 6], [1, 3, 6], [0, 3, 5]):
        with pytest.raises(InputError, match="`start` must rise"):
            IntervalSteps(np.arange(6.0), np.arange(6.0), bad)
    with pytest.raises(InputError, match="do not add up"):
        Intervals(np.ones(3), steps.totals[0] + 1.0, steps.totals[1], np.zeros((3, 3)), steps=steps)
    with pytest.raises(InputError, match="`steps` are of 3 intervals, there are 2"):
        Intervals(np.ones(2), np.ones(2), np.ones(2), np.zeros((2, 3)), steps=steps)


def test_noise_free_intervals_of_several_steps_recover_the_truth():
    """Intervals whose wheel speeds change inside (keyframes several scans apart): with their steps
    the truth comes back exactly (one arc each would not describe them)."""
    rng = np.random.default_rng(3)
    fl, fr = mixed(rng, 600, 0.05, 0.3)
    counts = rng.integers(1, 8, 120)
    counts[-1] += 600 - counts.sum()
    start = np.concatenate([[0], np.cumsum(counts)])
    steps = IntervalSteps(fl[: start[-1]], fr[: start[-1]], start)
    tl, tr = steps.totals
    s = predict(TRUTH, tl, tr, steps)
    exact = selfcal(Intervals(np.full(len(tl), 0.5), tl, tr, s, steps=steps), 0.1, 0.3)
    np.testing.assert_allclose(exact.params[:3], TRUTH[:3], rtol=1e-7)
    np.testing.assert_allclose(exact.params[3:5], TRUTH[3:5], atol=1e-7)
    # one arc per interval is not that motion: millimetres off at the truth
    assert np.abs(residuals(TRUTH, tl, tr, s)[:, :2]).max() > 1e-3


def test_jacobian_is_smooth_through_straight_motion():
    p = np.array([0.05, 0.05, 0.3, 0.1, 0.2, 0.5])
    eps = np.array([0.0, 1e-12, 1e-8, 1e-4, 0.2])
    jac = jacobian(p, np.full(5, 10.0), 10.0 + eps)
    assert np.all(np.isfinite(jac))
    np.testing.assert_allclose(jac[0], jac[1], atol=1e-9)
    np.testing.assert_allclose(jac[0], jac[3], atol=1e-3)


@settings(max_examples=100, deadline=None)
@given(params, st.lists(rotations, min_size=1, max_size=8))
def test_mirror_predicts_the_same_displacements(p, rot):
    a = np.array(rot)
    s1 = predict(p, a[:, 0], a[:, 1])
    s2 = predict(mirror(p), a[:, 0], a[:, 1])
    np.testing.assert_allclose(s1[:, :2], s2[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (s1[:, 2] - s2[:, 2]))), 0, atol=1e-12)
    np.testing.assert_allclose(mirror(mirror(p))[:5], p[:5])


# ---- noise-free intervals: the truth exactly


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_noise_free_intervals_recover_the_truth(seed):
    rng = np.random.default_rng(seed)
    d, b, p = random_truth(rng)
    fl, fr = mixed(rng, 60, 0.5 * d, b)
    iv = intervals_from_motion(fl, fr, 0.1, p[0], p[1], p[2], p[3:])
    cf = closed_form(fl, fr, iv.sensor)
    res = selfcal(iv, d, b)
    for est in (cf, res.params):
        np.testing.assert_allclose(est[:3], p[:3], rtol=1e-6)
        np.testing.assert_allclose(est[3:5], p[3:5], rtol=0, atol=1e-6 * b)
        assert abs(angle_diff(est[5], p[5])) < 1e-6
    assert res.intervals_rejected == ()
    assert res.intervals_used == 60
    assert res.warnings == []
    assert res.ed == pytest.approx(p[1] / p[0], rel=1e-6)
    assert res.eb == pytest.approx(p[2] / b, rel=1e-6)


# ---- noisy intervals: the 95 % intervals cover the truth


def test_intervals_cover_the_truth_over_100_simulated_robots():
    hits, z = [], []
    derived = []
    for seed in range(100):
        rng = np.random.default_rng([7, seed])
        d, b, p = random_truth(rng)
        fl, fr = mixed(rng, 200, 0.5 * d, b)
        res = selfcal(simulate(rng, p, fl, fr), d, b)
        lo = np.array([res.ci95[n][0] for n in PARAMETERS])
        hi = np.array([res.ci95[n][1] for n in PARAMETERS])
        err = res.params - p
        err[5] = angle_diff(res.params[5], p[5])
        hits.append((lo - res.params <= -err) & (-err <= hi - res.params))
        z.append(err / res.sd)
        ed_lo, ed_hi = res.interval("ed")
        eb_lo, eb_hi = res.interval("eb")
        derived.append([ed_lo <= p[1] / p[0] <= ed_hi, eb_lo <= p[2] / b <= eb_hi])
        assert res.warnings == []
    cover = np.mean(hits, axis=0)
    assert np.all((cover >= 0.90) & (cover <= 0.99)), cover
    assert 0.90 <= np.mean(derived) <= 0.99
    # the standard deviations are the errors' (neither too wide nor too narrow); pooled, as
    # the errors of the radii and the wheelbase are strongly correlated
    assert 0.85 < np.sqrt(np.mean(np.square(z))) < 1.15


@pytest.mark.slow
def test_given_covariances_weigh_each_interval():
    """Noise that differs per interval: given covariances give intervals that cover the truth
    and smaller errors than a common noise estimate."""
    hits, err_given, err_common = [], [], []
    for seed in range(40):
        rng = np.random.default_rng([11, seed])
        d, b, p = random_truth(rng)
        fl, fr = mixed(rng, 200, 0.5 * d, b)
        scale = np.where(rng.random(200) < 0.5, 1.0, 5.0)  # half the scan matches 5 x worse
        sig = scale[:, None] * SIGMA
        iv = simulate(rng, p, fl, fr, sig)
        cov = np.einsum("ki,ij->kij", sig**2, np.eye(3))
        res = selfcal(iv, d, b, sensor_covariance=cov)
        lo = np.array([res.ci95[n][0] for n in PARAMETERS])
        hi = np.array([res.ci95[n][1] for n in PARAMETERS])
        hits.append((lo <= p) & (p <= hi))
        err_given.append((res.params - p)[:3] / p[:3])
        err_common.append((selfcal(iv, d, b).params - p)[:3] / p[:3])
    assert 0.88 <= np.mean(hits) <= 1.0
    assert np.sqrt(np.mean(np.square(err_given))) < np.sqrt(np.mean(np.square(err_common)))


def test_the_intervals_own_covariances_are_added_to_the_estimated_noise():
    """Intervals whose measurement is poor in one direction (a corridor: the matcher's covariance
    says so): with their covariances, added to the noise the fit estimates, those directions
    weigh less and the estimate is better than without them; the intervals still cover."""
    hits, err_with, err_without = [], [], []
    for seed in range(30):
        rng = np.random.default_rng([13, seed])
        d, b, p = random_truth(rng)
        fl, fr = mixed(rng, 300, 0.5 * d, b)
        weak = rng.random(300) < 0.4  # 40 % of the matches 20 mm uncertain along x
        sig = np.tile(np.diag(SIGMA**2), (300, 1, 1))
        sig[weak, 0, 0] = 0.02**2
        noise = rng.normal(size=(300, 3)) * SIGMA
        noise[weak, 0] = rng.normal(size=weak.sum()) * 0.02
        iv = intervals_from_motion(fl, fr, 0.1, p[0], p[1], p[2], p[3:])
        iv = Intervals(iv.dt_s, fl, fr, iv.sensor + noise, covariance=sig)
        res = selfcal(iv, d, b)
        lo = np.array([res.ci95[n][0] for n in PARAMETERS])
        hi = np.array([res.ci95[n][1] for n in PARAMETERS])
        hits.append((lo[:5] <= p[:5]) & (p[:5] <= hi[:5]))
        err_with.append((res.params - p)[:3] / p[:3])
        bare = Intervals(iv.dt_s, fl, fr, iv.sensor)
        err_without.append((selfcal(bare, d, b).params - p)[:3] / p[:3])
    assert 0.88 <= np.mean(hits) <= 1.0
    assert np.sqrt(np.mean(np.square(err_with))) < 0.8 * np.sqrt(np.mean(np.square(err_without)))


def test_bad_covariances_are_refused():
    rng = np.random.default_rng(1)
    fl, fr = mixed(rng, 50, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    with pytest.raises(InputError, match="`sensor_covariance` must be positive definite"):
        selfcal(iv, 0.1, 0.3, sensor_covariance=-np.eye(3))
    with pytest.raises(InputError, match="`sensor_covariance`"):
        selfcal(iv, 0.1, 0.3, sensor_covariance=np.eye(2))


# ---- outliers


def test_failed_scan_matches_are_rejected():
    rng = np.random.default_rng(21)
    fl, fr = mixed(rng, 400, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    bad = rng.choice(400, 20, replace=False)
    s = iv.sensor.copy()
    s[bad] += rng.uniform(-1, 1, (20, 3)) * [0.3, 0.3, 0.35] + np.sign(rng.uniform(-1, 1, (20, 3))) * [0.02, 0.02, 0.02]
    res = selfcal(Intervals(iv.dt_s, fl, fr, s), 0.1, 0.3)
    assert set(bad.tolist()) <= set(res.intervals_rejected)
    assert len(res.intervals_rejected) <= 22
    assert res.intervals_used == 400 - len(res.intervals_rejected)
    assert np.all(np.abs((res.params - TRUTH) / res.sd) < 4)
    # Gaussian noise without rejection: the same data give a far worse answer
    raw = selfcal(Intervals(iv.dt_s, fl, fr, s), 0.1, 0.3, reject_outliers=False, loss="gaussian")
    assert raw.intervals_rejected == ()
    assert np.abs(raw.params - TRUTH)[2] > 5 * np.abs(res.params - TRUTH)[2]


def test_many_outliers_are_reported():
    rng = np.random.default_rng(4)
    fl, fr = mixed(rng, 200, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    s = iv.sensor.copy()
    bad = rng.choice(200, 60, replace=False)
    s[bad] += rng.normal(size=(60, 3)) * [0.2, 0.2, 0.3]
    res = selfcal(Intervals(iv.dt_s, fl, fr, s), 0.1, 0.3)
    assert len(res.intervals_rejected) >= 50
    assert any("rejected as outliers" in w for w in res.warnings)


# ---- mirror, swapped and reversed wheels, units


def test_sensor_mounted_backwards_at_the_rear():
    # the mirror of (r, b, l) is (-r, -b, -l_xy, l_yaw + pi): this truth sits where a
    # wrong sign choice would put the physical one
    p = np.array([0.05, 0.0502, 0.3, -0.15, 0.02, math.pi - 0.01])
    rng = np.random.default_rng(8)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    res = selfcal(simulate(rng, p, fl, fr), 0.1, 0.3)
    assert res.r_left_m > 0 and res.r_right_m > 0 and res.wheelbase_m > 0
    assert np.all(np.abs((res.params[:5] - p[:5]) / res.sd[:5]) < 4)
    assert abs(angle_diff(res.params[5], p[5])) < 4 * res.sd[5]
    assert res.warnings == []


def test_swapped_wheels_are_detected_and_named():
    rng = np.random.default_rng(9)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    res = selfcal(Intervals(iv.dt_s, iv.right_rad, iv.left_rad, iv.sensor), 0.1, 0.3)
    w = " ".join(res.warnings)
    assert "swapped" in w and "`left_rad` and `right_rad`" in w
    # radii positive: the data fit with the wheels exchanged and a negative wheelbase
    assert res.r_left_m > 0 and res.r_right_m > 0 and res.wheelbase_m < 0
    assert res.r_left_m == pytest.approx(TRUTH[1], rel=0.02)
    assert res.r_right_m == pytest.approx(TRUTH[0], rel=0.02)
    assert abs(res.wheelbase_m) == pytest.approx(TRUTH[2], rel=0.03)


def test_both_wheels_backwards_give_the_mirror_with_positive_radii():
    rng = np.random.default_rng(10)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    res = selfcal(Intervals(iv.dt_s, -iv.left_rad, -iv.right_rad, iv.sensor), 0.1, 0.3)
    assert res.r_left_m > 0 and res.r_right_m > 0 and res.wheelbase_m < 0
    np.testing.assert_allclose(res.params[:3], [TRUTH[0], TRUTH[1], -TRUTH[2]], rtol=0.03)
    np.testing.assert_allclose(res.params[3:5], -TRUTH[3:5], atol=0.01)
    assert "both counted backwards" in " ".join(res.warnings)


def test_one_wheel_backwards_is_named():
    rng = np.random.default_rng(12)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    res = selfcal(Intervals(iv.dt_s, -iv.left_rad, iv.right_rad, iv.sensor), 0.1, 0.3)
    w = " ".join(res.warnings)
    assert "opposite signs" in w and "negate `left_rad`" in w


def test_wheel_angles_in_degrees_are_flagged():
    rng = np.random.default_rng(13)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    res = selfcal(Intervals(iv.dt_s, np.degrees(fl), np.degrees(fr), iv.sensor), 0.1, 0.3)
    w = " ".join(res.warnings)
    assert "x the nominal `wheel_diameter_m`" in w and "not in radians" in w
    assert res.r_left_m == pytest.approx(TRUTH[0] * math.pi / 180, rel=0.02)


def test_a_nominal_wheelbase_in_millimetres_is_flagged():
    rng = np.random.default_rng(14)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    res = selfcal(simulate(rng, TRUTH, fl, fr), 0.1, 300.0)
    assert any("x the nominal `wheelbase_m`" in w for w in res.warnings)


# ---- identifiability


def test_straight_only_driving_warns_about_the_wheelbase_and_sensor_position():
    rng = np.random.default_rng(1)
    res = fit_kind(0.03 * rng.uniform(0.3, 1, 300), rng.normal(0, 0.003, 300))
    (w,) = res.warnings
    assert "poorly determined" in w and "`wheelbase_m`" in w and "`sensor_x_m`" in w
    assert "hardly turns" in w and "drive spins on the spot" in w


def test_spins_only_driving_warns_about_the_scale():
    rng = np.random.default_rng(2)
    res = fit_kind(rng.normal(0, 0.001, 300), 0.1 * rng.uniform(-1, 1, 300))
    (w,) = res.warnings
    assert "`r_left_m`" in w and "`wheelbase_m`" in w and "`sensor_yaw_rad`" in w
    assert "hardly moves forward" in w and "drive straight lines" in w


def test_circles_one_way_warn_to_turn_both_ways():
    rng = np.random.default_rng(3)
    res = fit_kind(0.03 * (1 + rng.normal(0, 0.02, 300)), 0.05 * (1 + rng.normal(0, 0.02, 300)))
    (w,) = res.warnings
    assert "poorly determined" in w
    assert "turns one way only" in w and "drive turns the other way too" in w
    assert "arcs of a single radius" in w


def test_the_same_circles_both_ways_are_well_determined():
    rng = np.random.default_rng(3)
    sign = np.where(np.arange(300) < 150, 1.0, -1.0)
    res = fit_kind(0.03 * (1 + rng.normal(0, 0.02, 300)), sign * 0.05 * (1 + rng.normal(0, 0.02, 300)))
    assert res.warnings == []


def test_arcs_of_several_radii_one_way_are_determined():
    """Turning one way with arcs of different radii determines every parameter (the Fisher
    information says so, and the fit agrees): no warning."""
    rng = np.random.default_rng(4)
    res = fit_kind(0.03 * rng.uniform(0.3, 1, 300), 0.1 * rng.uniform(0.1, 1, 300))
    assert res.warnings == []
    assert np.all(np.abs((res.params - TRUTH) / res.sd) < 4)


def test_exactly_straight_driving_is_an_error_naming_the_cause():
    rng = np.random.default_rng(1)
    with pytest.raises(InputError) as e:
        fit_kind(0.03 * rng.uniform(0.3, 1, 300), np.zeros(300))
    msg = str(e.value)
    assert "cannot determine" in msg and "`wheelbase_m`" in msg and "hardly turns" in msg


def test_exact_spins_are_an_error_naming_the_cause():
    rng = np.random.default_rng(1)
    with pytest.raises(InputError, match="hardly moves forward"):
        fit_kind(np.zeros(300), 0.1 * rng.uniform(-1, 1, 300))


def test_too_few_intervals():
    rng = np.random.default_rng(6)
    fl, fr = mixed(rng, 12, 0.05, 0.3)
    res = selfcal(simulate(rng, TRUTH, fl, fr, SIGMA * 1e-3), 0.1, 0.3)
    assert any(w.startswith("only 12 intervals") for w in res.warnings)
    with pytest.raises(InputError, match="at least 3 intervals"):
        selfcal(simulate(rng, TRUTH, fl[:2], fr[:2]), 0.1, 0.3)


def test_limits_are_options():
    rng = np.random.default_rng(6)
    fl, fr = mixed(rng, 300, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    assert selfcal(iv, 0.1, 0.3).warnings == []
    strict = selfcal(iv, 0.1, 0.3, limits=Limits(relative_sd=1e-5))
    assert "`r_left_m`" in strict.warnings[0]


def test_unusable_inputs():
    iv = Intervals(np.full(5, 0.1), np.zeros(5), np.zeros(5), np.zeros((5, 3)), source="z.csv")
    with pytest.raises(InputError, match="z.csv: the wheels do not turn"):
        selfcal(iv, 0.1, 0.3)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(InputError, match="`wheelbase_m` must be a positive number"):
            selfcal(iv, 0.1, bad)
        with pytest.raises(InputError, match="`wheel_diameter_m` must be a positive number"):
            selfcal(iv, bad, 0.3)
    with pytest.raises(InputError, match="`intervals` must be an Intervals"):
        selfcal(np.zeros((5, 6)), 0.1, 0.3)
    with pytest.raises(InputError, match="`outlier_tail`"):
        selfcal(iv, 0.1, 0.3, outlier_tail=2.0)
    with pytest.raises(ClosedFormFailed):
        closed_form(np.ones(5), np.ones(5), np.zeros((5, 3)))


# ---- the result and the file path


def test_to_dict_has_the_pinned_keys_and_is_json():
    rng = np.random.default_rng(15)
    fl, fr = mixed(rng, 200, 0.05, 0.3)
    res = selfcal(simulate(rng, TRUTH, fl, fr), 0.1, 0.3)
    assert isinstance(res, SelfcalResult)
    d = json.loads(dumps(res.to_dict()))
    for key in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm", "Ed", "Eb"):
        assert isinstance(d[key], float)
        lo, hi = d[key + "_ci95"]
        assert lo < d[key] < hi
    for key in ("x_mm", "y_mm", "yaw_deg"):
        lo, hi = d["sensor_pose"][key + "_ci95"]
        assert lo < d["sensor_pose"][key] < hi
    assert d["wheel_diameter_left_mm"] == pytest.approx(2e3 * res.r_left_m)
    assert d["Ed"] == pytest.approx(res.r_right_m / res.r_left_m)
    assert d["Eb"] == pytest.approx(res.wheelbase_m / 0.3)
    assert d["sensor_pose"]["yaw_deg"] == pytest.approx(math.degrees(res.sensor_pose[2]))
    assert d["intervals_used"] == 200 and d["intervals_rejected"] == [] and d["warnings"] == []
    lo, hi = d["wheelbase_mm_ci95"]
    assert (hi - lo) / 2 == pytest.approx(1e3 * res.t_quantile * res.sd[2])
    assert np.allclose(d["covariance"], res.covariance)


def test_csv_end_to_end(tmp_path):
    rng = np.random.default_rng(16)
    fl, fr = mixed(rng, 250, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    path = tmp_path / "intervals.csv"
    write_intervals_csv(iv, path)
    back = read_intervals_csv(path)
    direct, via_file = selfcal(iv, 0.1, 0.3), selfcal(back, 0.1, 0.3)
    np.testing.assert_array_equal(via_file.params, direct.params)
    assert np.all(np.abs((via_file.params - TRUTH) / via_file.sd) < 4)
    # a reader's warning reaches the result; an error names the file
    text = path.read_text().splitlines()
    text[3] = "0" + text[3][text[3].index(",") :]
    res = selfcal(parse_intervals_csv("\n".join(text) + "\n", "edited.csv"), 0.1, 0.3)
    assert any(w.startswith("edited.csv: 1 interval (line 4) of zero duration") for w in res.warnings)
    zero = Intervals(np.full(3, 0.1), np.zeros(3), np.zeros(3), np.zeros((3, 3)), source=str(path))
    with pytest.raises(InputError, match=str(path)):
        selfcal(zero, 0.1, 0.3)


def test_fisher_information_is_the_inverse_covariance_at_the_solution():
    rng = np.random.default_rng(17)
    fl, fr = mixed(rng, 200, 0.05, 0.3)
    res = selfcal(simulate(rng, TRUTH, fl, fr), 0.1, 0.3, loss="gaussian")
    info = fisher_information(res.params, fl, fr, np.array(res.noise_sd))
    np.testing.assert_allclose(np.linalg.inv(info), res.covariance, rtol=1e-6)
    assert res.noise_dof == math.inf and res.covariance_blocks == 0


def test_gaussian_noise_gives_the_student_fit_many_degrees_of_freedom():
    """On Gaussian noise the Student t fit is the least-squares fit: its degrees of freedom come
    out large and its estimate and standard deviations are the Gaussian fit's."""
    rng = np.random.default_rng(17)
    fl, fr = mixed(rng, 400, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    t, g = selfcal(iv, 0.1, 0.3), selfcal(iv, 0.1, 0.3, loss="gaussian")
    assert t.noise_dof > 30
    assert np.all(np.abs(t.params - g.params) < 0.2 * g.sd)
    np.testing.assert_allclose(t.sd, g.sd, rtol=0.1)


def test_heavy_tailed_noise_is_fitted_with_few_degrees_of_freedom():
    """Noise with heavy tails (Student t, 2.5 degrees of freedom, as the residuals of real
    recordings): the Student fit finds the tails, its errors are smaller than least squares'
    and its intervals cover the truth."""
    hits, err_t, err_g, dofs = [], [], [], []
    for seed in range(30):
        rng = np.random.default_rng([23, seed])
        d, b, p = random_truth(rng)
        fl, fr = mixed(rng, 300, 0.5 * d, b)
        iv = intervals_from_motion(fl, fr, 0.1, p[0], p[1], p[2], p[3:])
        # multivariate Student t: Gaussian noise over the square root of a chi-square per interval
        noise = rng.normal(size=(300, 3)) * SIGMA / np.sqrt(rng.chisquare(2.5, (300, 1)) / 2.5)
        iv = Intervals(iv.dt_s, fl, fr, iv.sensor + noise)
        t = selfcal(iv, d, b, reject_outliers=False)
        g = selfcal(iv, d, b, reject_outliers=False, loss="gaussian")
        lo = np.array([t.ci95[n][0] for n in PARAMETERS])
        hi = np.array([t.ci95[n][1] for n in PARAMETERS])
        hits.append((lo[:5] <= p[:5]) & (p[:5] <= hi[:5]))
        err_t.append((t.params - p)[:3] / p[:3])
        err_g.append((g.params - p)[:3] / p[:3])
        dofs.append(t.noise_dof)
    assert 1.5 < np.median(dofs) < 5
    assert 0.88 <= np.mean(hits) <= 1.0
    assert np.sqrt(np.mean(np.square(err_t))) < 0.8 * np.sqrt(np.mean(np.square(err_g)))


# ---- errors in the wheel data: stamps off by a jitter


def _shifted_motion(p, fl, fr, rate_s, rate_e, d_s, d_e):
    """The sensor displacement of each interval with its start moved ``d_s`` and its end ``d_e``
    seconds later (the wheels' motion over that time at their rates there removed or added)."""
    head = se2.arc(-d_s * p[0] * rate_s[:, 0], -d_s * p[1] * rate_s[:, 1], p[2])
    tail = se2.arc(d_e * p[0] * rate_e[:, 0], d_e * p[1] * rate_e[:, 1], p[2])
    q = se2.compose(head, se2.compose(se2.arc(p[0] * fl, p[1] * fr, p[2]), tail))
    return se2.compose(se2.inverse(p[3:6]), se2.compose(q, p[3:6]))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_time_shift_derivatives_are_those_of_the_shifted_motion(seed):
    """The analytic derivatives of the prediction by the ends' time shifts, and theirs by the
    parameters, equal central differences of the shifted motion."""
    from umbmark.correct.selfcal.model import time_shift_derivatives

    rng = np.random.default_rng(seed)
    _, _, p = random_truth(rng)
    fl, fr = rng.normal(0, 3, 20), rng.normal(0, 3, 20)
    rs, re = rng.normal(0, 5, (20, 2)), rng.normal(0, 5, (20, 2))
    a_s, a_e, dj_s, dj_e = time_shift_derivatives(p, fl, fr, rs, re)

    def diff(u, v, eps):
        d = u - v
        d[:, 2] = np.angle(np.exp(1j * d[:, 2]))
        return d / (2 * eps)

    eps = 1e-6
    f = lambda q, s, e: _shifted_motion(q, fl, fr, rs, re, s, e)  # noqa: E731
    assert np.allclose(a_s, diff(f(p, eps, 0), f(p, -eps, 0), eps), atol=1e-6)
    assert np.allclose(a_e, diff(f(p, 0, eps), f(p, 0, -eps), eps), atol=1e-6)
    for j in range(6):
        e = np.zeros(6)
        e[j] = 1e-6
        up, dn = time_shift_derivatives(p + e, fl, fr, rs, re), time_shift_derivatives(p - e, fl, fr, rs, re)
        assert np.allclose(dj_s[:, :, j], (up[0] - dn[0]) / 2e-6, atol=1e-5)
        assert np.allclose(dj_e[:, :, j], (up[1] - dn[1]) / 2e-6, atol=1e-5)


def _jittered(rng, p, k, jitter_s, dt=0.2):
    """Intervals of a robot whose wheel data are read at stamps off by ``jitter_s`` (standard
    deviation, one error per stamp, shared by the two intervals it ends and starts): two steps
    per interval (to its middle, from it), their durations from the stamps; the wheels turn at
    a constant rate over each interval, so its rotation gains that rate times the shifts of its
    ends; the rates at the ends as the bag pipeline reads them (from the wheel data around the
    stamps)."""
    fl, fr = mixed(rng, k, p[0], p[2], v=0.5, w=1.5, dt=dt)
    iv = intervals_from_motion(fl, fr, dt, p[0], p[1], p[2], p[3:])
    delta = rng.normal(0.0, jitter_s, k + 1)
    d1, d2 = 0.5 * dt - delta[:-1], 0.5 * dt + delta[1:]  # the steps' durations
    sl = np.column_stack([fl * d1 / dt, fl * d2 / dt]).ravel()
    sr = np.column_stack([fr * d1 / dt, fr * d2 / dt]).ravel()
    steps = IntervalSteps(sl, sr, np.arange(0, 2 * k + 1, 2), np.column_stack([d1, d2]).ravel())
    sensor = iv.sensor + rng.normal(size=iv.sensor.shape) * SIGMA
    left, right = steps.totals
    rates = np.column_stack([fl, fr, fl, fr]) / dt  # the wheels' rates around each stamp, as a wheel sensor has them
    return Intervals(d1 + d2, left, right, sensor, steps=steps, end_rates=rates)


def test_jittered_wheel_stamps_no_longer_make_the_wheels_small():
    """Wheel data read 20 ms off at random (0.2 s intervals: 10 % of each interval's motion at
    each end): taken as exact, the wheels and the wheelbase come out percents small; with the
    jitter modelled (the default) the estimates are within their intervals and the jitter is
    found."""
    err_plain, err_eiv, hits, found = [], [], [], []
    for seed in range(8):
        rng = np.random.default_rng([31, seed])
        d, b, p = random_truth(rng)
        iv = _jittered(rng, p, 600, 0.02)
        plain = selfcal(iv, d, b, time_jitter=False)
        eiv = selfcal(iv, d, b)
        err_plain.append(plain.params[:3] / p[:3] - 1)
        err_eiv.append(eiv.params[:3] / p[:3] - 1)
        lo = np.array([eiv.ci95[n][0] for n in PARAMETERS[:3]])
        hi = np.array([eiv.ci95[n][1] for n in PARAMETERS[:3]])
        hits.append((lo <= p[:3]) & (p[:3] <= hi))
        found.append(eiv.wheel_jitter_s)
        assert math.isnan(plain.wheel_jitter_s)
    assert np.mean(err_plain) < -0.005  # regression dilution: half a percent small and more
    assert abs(np.mean(err_eiv)) < 0.2 * abs(np.mean(err_plain))
    assert np.mean(hits) >= 0.8
    assert np.median(found) == pytest.approx(0.02, rel=0.25)


def test_without_jitter_none_is_found():
    """Exact wheel data: the jitter estimated is nil and the estimate that of the plain fit."""
    rng = np.random.default_rng(5)
    d, b, p = random_truth(rng)
    iv = _jittered(rng, p, 400, 0.0)
    res, plain = selfcal(iv, d, b), selfcal(iv, d, b, time_jitter=False)
    assert res.wheel_jitter_s < 1e-3
    assert np.allclose(res.params, plain.params, rtol=2e-3, atol=1e-4)
    assert res.to_dict()["wheel_jitter_ms"] == pytest.approx(res.wheel_jitter_s * 1e3)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), with_cov=st.booleans())
def test_wheel_rates_round_trip_through_the_intervals_file(seed, with_cov):
    """The wheels' rates at the ends are written on each interval's row and read back exactly,
    with or without covariances and steps."""
    rng = np.random.default_rng(seed)
    _, _, p = random_truth(rng)
    iv = _jittered(rng, p, 7, 0.01)
    if with_cov:
        cov = np.tile(np.diag(SIGMA**2), (len(iv), 1, 1))
        iv = Intervals(
            iv.dt_s, iv.left_rad, iv.right_rad, iv.sensor, steps=iv.steps, covariance=cov, end_rates=iv.end_rates
        )
    back = parse_intervals_csv(format_intervals_csv(iv))
    assert np.array_equal(back.end_rates, iv.end_rates)
    assert np.array_equal(back.sensor, iv.sensor)
    assert (back.covariance is not None) == with_cov


def test_some_wheel_rate_columns_are_refused():
    text = "dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad,rate_left_start_rad_s,rate_left_end_rad_s\n"
    with pytest.raises(InputError, match="without rate_right_start_rad_s, rate_right_end_rad_s: give all four"):
        parse_intervals_csv(text + "0.1,1,1,0.1,0,0,10,10\n", "iv.csv")
    with pytest.raises(InputError, match=r"`end_rates` must be \(2, 4\)"):
        Intervals(np.ones(2), np.ones(2), np.ones(2), np.zeros((2, 3)), end_rates=np.ones((2, 3)))


def test_intervals_with_dx_and_dy_exchanged_are_named(tmp_path):
    """An intervals file whose sensor_dx_m and sensor_dy_m headers are exchanged: the lidar's yaw
    comes out near -90 deg (or beyond), which a warning names with the columns as the likely
    cause; the right file gives no warning."""
    from umbmark.realrobot.selfcal import selfcal_from_intervals

    rng = np.random.default_rng(16)
    fl, fr = mixed(rng, 250, 0.05, 0.3)
    path = tmp_path / "iv.csv"
    write_intervals_csv(simulate(rng, TRUTH, fl, fr), path)
    head, body = path.read_text().split("\n", 1)
    head = head.replace("sensor_dx_m", "@").replace("sensor_dy_m", "sensor_dx_m").replace("@", "sensor_dy_m")
    swapped = tmp_path / "swapped.csv"
    swapped.write_text(head + "\n" + body)
    assert selfcal_from_intervals(path, 0.1, 0.3).result.warnings == []
    res = selfcal_from_intervals(swapped, 0.1, 0.3).result
    (note,) = [w for w in res.warnings if "the sensor's yaw comes out" in w]
    assert "`dx` and `dy` exchanged" in note and abs(math.degrees(res.sensor_pose[2])) > 45


def test_intervals_with_the_sensor_turning_the_other_way_are_named(tmp_path):
    """sensor_dyaw_rad negated (the sensor's turns counted clockwise): the fit needs a negative
    wheelbase; from a file that is refused, naming that column among the causes (the library's
    fit itself warns)."""
    from umbmark.realrobot.selfcal import selfcal_from_intervals

    rng = np.random.default_rng(16)
    fl, fr = mixed(rng, 250, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    flipped = Intervals(iv.dt_s, iv.left_rad, iv.right_rad, iv.sensor * np.array([1.0, 1.0, -1.0]), "neg.csv")
    path = tmp_path / "neg.csv"
    write_intervals_csv(flipped, path)
    with pytest.raises(InputError, match="`sensor_dyaw_rad` negated"):
        selfcal_from_intervals(path, 0.1, 0.3)
    res = selfcal(flipped, 0.1, 0.3)
    assert res.wheelbase_m < 0
    assert any("`sensor_dyaw_rad` negated" in w for w in res.warnings)
