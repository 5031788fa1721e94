"""The odometry's random error (umbmark.correct.noise): each wheel's travel variance per metre
recovered from a self-calibration's residuals on simulated drives with known wheel noise at three
levels, and the covariance it predicts checked by the NEES of held-out drives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.correct.noise import (
    OdometryNoise,
    controller_covariances,
    estimate_odometry_noise,
    nees,
    step_covariance,
    window_covariance,
    window_errors,
)
from umbmark.errors import InputError
from umbmark.model import se2
from umbmark.model.drive import EXAMPLE_ROBOT, WheelNoise, mixed_program, simulate_drive
from umbmark.model.intervals import Intervals
from umbmark.realrobot.selfcal import selfcal_report

ROBOT = EXAMPLE_ROBOT
SENSOR_SD = (0.001, 0.001, 0.001)  # the lidar's matching noise per interval: 1 mm, 1 mm, 1 mrad
LEVELS = [2e-5, 8e-5, 3.2e-4]  # the left wheel's variance per metre [m^2/m]; the right's 1.5 times


def _drive(k_left, seed, minutes=10.0):
    noise = WheelNoise(slip_m_per_sqrt_m=math.sqrt(k_left), slip_right_m_per_sqrt_m=math.sqrt(1.5 * k_left))
    return simulate_drive(mixed_program(60.0 * minutes, seed=seed), ROBOT, seed=seed + 1, noise=noise)


def _noisy(log, seed):
    iv = log.intervals()
    sensor = iv.sensor + np.random.default_rng(seed).normal(0.0, SENSOR_SD, iv.sensor.shape)
    return Intervals(iv.dt_s, iv.left_rad, iv.right_rad, sensor, "simulated drive")


@pytest.fixture(scope="module", params=LEVELS, ids=lambda k: f"k={k:g}")
def level(request):
    k = request.param
    log = _drive(k, seed=10)
    nominal = ROBOT.nominal_wheels
    rep = selfcal_report([("drive", _noisy(log, 3))], nominal.diameter_left_m, nominal.wheelbase_m)
    return k, rep, _drive(k, seed=20)


def test_each_wheel_s_variance_within_20_percent(level):
    k, rep, _ = level
    est = rep.odometry_noise
    assert est is not None
    for got, truth, ci in ((est.k_left_m, k, est.k_left_ci95), (est.k_right_m, 1.5 * k, est.k_right_ci95)):
        assert got == pytest.approx(truth, rel=0.2)
        assert ci[0] < truth < ci[1]
    # the lidar's own noise is told apart from the wheels'
    assert est.sensor_sd == pytest.approx(SENSOR_SD, rel=0.2)
    d = rep.to_dict()["odometry_noise"]
    assert d["wheel_variance_left_m2_per_m"] == est.k_left_m
    assert d["wheel_sd_right_mm_per_sqrt_m"] == pytest.approx(1e3 * math.sqrt(est.k_right_m))


def test_held_out_drives_nees(level):
    # the covariance the estimate predicts for 2-second stretches of odometry of ANOTHER drive,
    # against the robot's true motion: NEES 1 when it is right
    k, rep, held_out = level
    est, r = rep.odometry_noise, rep.result
    left, right = held_out.wheel_angles_at(held_out.scan_t_s)
    dl, dr = np.diff(left) * r.r_left_m, np.diff(right) * r.r_right_m
    odo = se2.arc(dl, dr, r.wheelbase_m)
    truth = se2.between(*(lambda p: (p[:-1], p[1:]))(held_out.true_pose_at(held_out.scan_t_s)))
    window = 20
    cov = window_covariance(odo, step_covariance(dl, dr, r.wheelbase_m, est.k_left_m, est.k_right_m), window)
    e = window_errors(odo, truth, window)
    assert len(e) > 200
    assert 0.8 <= nees(e, cov) <= 1.25
    # a covariance four times too small is caught
    assert nees(e, cov / 4) > 2.5


def test_no_wheel_noise_gives_next_to_none():
    log = simulate_drive(mixed_program(120.0, seed=5), ROBOT, seed=6)
    rep = selfcal_report([("drive", _noisy(log, 4))], 0.15, 0.34)
    est = rep.odometry_noise
    # under 1.5 mm per square-root metre, the intervals' upper ends included (the single-arc model
    # of a 0.1 s interval of changing speeds leaves a trace)
    assert est.k_left_ci95[1] < 2e-6 and est.k_right_ci95[1] < 2e-6
    assert min(est.k_left_ci95[0], est.k_right_ci95[0]) == 0.0


def test_too_little_data_is_refused():
    with pytest.raises(InputError, match="at least 20 intervals"):
        estimate_odometry_noise(np.ones(5), np.ones(5), np.zeros((5, 3)), 0.05, 0.05, 0.3)
    with pytest.raises(InputError, match="drive of metres"):
        estimate_odometry_noise(np.full(30, 0.01), np.full(30, 0.01), np.zeros((30, 3)), 0.05, 0.05, 0.3)


@settings(max_examples=40, deadline=None)
@given(
    s=st.floats(0.01, 0.5),
    turn=st.floats(-0.2, 0.2),
    kl=st.floats(1e-6, 1e-3),
    kr=st.floats(1e-6, 1e-3),
    b=st.floats(0.2, 1.0),
)
def test_step_covariance_is_the_linearised_arc(s, turn, kl, kr, b):
    # against sampling: many wheel errors, each a random walk along the step (m pieces, each off on
    # its own), pushed through the exact arcs
    sl, sr = s - turn * b / 2, s + turn * b / 2
    q = step_covariance([sl], [sr], b, kl, kr)[0]
    rng = np.random.default_rng(0)
    n, m = 20000, 40
    samples = np.zeros((n, 3))
    for _ in range(m):
        el = rng.standard_normal(n) * math.sqrt(kl * abs(sl) / m)
        er = rng.standard_normal(n) * math.sqrt(kr * abs(sr) / m)
        samples = se2.compose(samples, se2.arc(sl / m + el, sr / m + er, b))
    emp = np.cov(samples.T)
    scale = np.sqrt(np.outer(np.diag(q), np.diag(q)))
    assert np.all(np.abs(emp - q) <= 0.08 * scale + 1e-12)


def test_window_covariance_matches_sampling():
    rng = np.random.default_rng(1)
    b, kl, kr, m = 0.34, 1e-4, 2e-4, 30
    sl = rng.uniform(0.0, 0.05, m)
    sr = rng.uniform(0.0, 0.05, m)
    steps = se2.arc(sl, sr, b)
    cov = window_covariance(steps, step_covariance(sl, sr, b, kl, kr), m)[0]
    n = 4000
    end = np.zeros((n, 3))
    for j in range(m):
        noisy = se2.arc(
            sl[j] + rng.standard_normal(n) * math.sqrt(kl * sl[j]),
            sr[j] + rng.standard_normal(n) * math.sqrt(kr * sr[j]),
            b,
        )
        end = se2.compose(end, noisy)
    ref = np.zeros(3)
    for j in range(m):
        ref = se2.compose(ref, steps[j])
    err = se2.between(np.broadcast_to(ref, end.shape), end)
    emp = np.cov(err.T)
    assert np.allclose(np.diag(emp), np.diag(cov), rtol=0.1)


def test_controller_covariances():
    noise = OdometryNoise(1e-4, 1e-4, (0, 1), (0, 1), (0.001, 0.001, 0.001), 100, 10.0)
    c = controller_covariances(noise, wheelbase_m=0.34, speed_mps=0.5, period_s=0.02)
    pose, twist = c["pose_covariance_diagonal"], c["twist_covariance_diagonal"]
    assert len(pose) == len(twist) == 6 and all(v > 0 for v in pose + twist)
    # straight, equal wheels: x variance k d / 2 after d = 1 m; yaw 2 k d / b^2
    assert pose[0] == pytest.approx(1e-4 / 2, rel=1e-3)
    assert pose[5] == pytest.approx(2 * 1e-4 / 0.34**2, rel=1e-3)
    # the speed over one period: each wheel's travel variance k v T, per T^2
    assert twist[0] == pytest.approx(1e-4 * 0.5 * 0.02 / 2 / 0.02**2, rel=1e-3)
    assert pose[2] == twist[2] == 1e6
    with pytest.raises(InputError):
        controller_covariances(noise, 0.34, 0.0, 0.02)


def test_a_real_log_s_halves_agree_that_its_wheels_hide_under_the_matching_noise(capsys):
    """ACES (data/slam2d): each half self-calibrated on its own. The scan matching's noise (1 to 2
    cm per interval) hides the wheels': each wheel's variance is below 1e-5 m^2/m in both halves,
    the intervals start at 0 and overlap, and the matching noise agrees between the halves."""
    import json
    from pathlib import Path

    from umbmark.cli import main

    bag = Path(__file__).resolve().parents[1] / "data" / "slam2d" / "aces.bag"
    args = ["selfcal", str(bag), "--odom-topic", "/odom", "--wheel-diameter-mm", "200", "--wheelbase-mm", "400"]
    assert main([*args, "--window", "683s", "--json"]) == 0
    halves = [w["result"]["odometry_noise"] for w in json.loads(capsys.readouterr().out)["windows"]]
    assert len(halves) == 2
    for side in ("left", "right"):
        lo, hi = zip(*(h[f"wheel_variance_{side}_m2_per_m_ci95"] for h in halves))
        assert max(hi) < 1e-5 and max(lo) < min(hi)
    for axis in ("dx_mm", "dy_mm"):
        a, b = (h["sensor_sd"][axis] for h in halves)
        assert 5.0 < a < 30.0 and 5.0 < b < 30.0 and abs(a - b) < 0.3 * max(a, b)
