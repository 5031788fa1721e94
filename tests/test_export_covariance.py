"""The odometry's measured noise exported as diff_drive_controller's ``pose_covariance_diagonal``
and ``twist_covariance_diagonal``: a self-calibration of a simulated robot with known wheel noise
is exported, and the twist covariance written is checked against the speed errors of a held-out
drive the way the controller would compute its speeds."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from umbmark.cli import main
from umbmark.correct.noise import step_covariance
from umbmark.errors import InputError
from umbmark.io.export import ExportCalibration, format_export
from umbmark.model import se2
from umbmark.model.drive import EXAMPLE_ROBOT, WheelNoise, mixed_program, simulate_drive, straight_only
from umbmark.model.intervals import Intervals
from umbmark.realrobot.selfcal import selfcal_report

K_LEFT = 8e-5  # the left wheel's travel variance per metre [m^2/m]; the right's 1.5 times
NOISE = WheelNoise(slip_m_per_sqrt_m=math.sqrt(K_LEFT), slip_right_m_per_sqrt_m=math.sqrt(1.5 * K_LEFT))
SPEED_MPS, WINDOW_S = 0.3, 0.1


@pytest.fixture(scope="module")
def selfcal_json(tmp_path_factory):
    """A self-calibration's JSON of a 10-minute drive with noisy wheels and a 1 mm lidar."""
    log = simulate_drive(mixed_program(600.0, seed=10), EXAMPLE_ROBOT, seed=11, noise=NOISE)
    iv = log.intervals()
    sensor = iv.sensor + np.random.default_rng(3).normal(0.0, 0.001, iv.sensor.shape)
    nominal = EXAMPLE_ROBOT.nominal_wheels
    rep = selfcal_report(
        [("drive", Intervals(iv.dt_s, iv.left_rad, iv.right_rad, sensor, "simulated drive"))],
        nominal.diameter_left_m,
        nominal.wheelbase_m,
    )
    path = tmp_path_factory.mktemp("cov") / "selfcal.json"
    path.write_text(json.dumps(rep.to_dict()))
    return path


def _ros2(path, capsys, *extra):
    assert main(["export", str(path), "--format", "ros2", *extra]) == 0
    text = capsys.readouterr().out
    return text, yaml.safe_load(text)["diff_drive_controller"]["ros__parameters"]


def test_the_twist_covariance_matches_a_held_out_drive(selfcal_json, capsys):
    """The forward speed and turn rate of a held-out straight drive, measured over 0.1 s as the
    controller does, are off by what the exported twist covariance says (variance ratio within
    [0.8, 1.25]); the unobserved axes are large, y's small but not zero."""
    text, params = _ros2(
        selfcal_json, capsys, "--covariance-speed-mps", str(SPEED_MPS), "--velocity-window-s", str(WINDOW_S)
    )
    twist = params["twist_covariance_diagonal"]
    pose = params["pose_covariance_diagonal"]
    assert len(twist) == len(pose) == 6
    assert min(twist[2:5] + pose[2:5]) >= 1e6
    assert 0 < twist[1] < twist[0] and 0 < pose[1]
    assert "odom0_config" in text and "/diff_drive_controller/odom" in text

    log = simulate_drive(straight_only(300.0, speed_mps=SPEED_MPS, length_m=3.0), EXAMPLE_ROBOT, seed=21, noise=NOISE)
    t = np.arange(0.0, log.duration_s - WINDOW_S, WINDOW_S)
    truth = se2.between(log.true_pose_at(t[:-1]), log.true_pose_at(t[1:]))
    left, right = log.wheel_angles_at(t)
    d = json.loads(selfcal_json.read_text())
    sl = np.diff(left) * 0.5e-3 * d["wheel_diameter_left_mm"]
    sr = np.diff(right) * 0.5e-3 * d["wheel_diameter_right_mm"]
    speed_error = (0.5 * (sl + sr) - truth[:, 0]) / WINDOW_S
    turn_error = ((sr - sl) / (1e-3 * d["wheelbase_mm"]) - truth[:, 2]) / WINDOW_S
    moving = np.abs(0.5 * (sl + sr)) > 0.9 * SPEED_MPS * WINDOW_S  # (not the windows where a leg reverses)
    assert moving.sum() > 2500
    assert 0.8 < np.var(speed_error[moving]) / twist[0] < 1.25
    assert 0.8 < np.var(turn_error[moving]) / twist[5] < 1.25


def test_the_covariances_follow_the_wheel_noise_and_the_options(selfcal_json, capsys):
    """The twist's variances are each wheel's over the averaging window, divided by its square;
    doubling the window halves them; the JSON export carries the same figures."""
    d = json.loads(selfcal_json.read_text())
    k_l = d["odometry_noise"]["wheel_variance_left_m2_per_m"]
    k_r = d["odometry_noise"]["wheel_variance_right_m2_per_m"]
    assert k_l == pytest.approx(K_LEFT, rel=0.2) and k_r == pytest.approx(1.5 * K_LEFT, rel=0.2)
    b = 1e-3 * d["wheelbase_mm"]
    s = 0.5 * 0.1
    q = step_covariance([s], [s], b, k_l, k_r)[0]
    _, params = _ros2(selfcal_json, capsys)  # defaults: 0.5 m/s averaged over 0.1 s
    assert params["twist_covariance_diagonal"][0] == pytest.approx(q[0, 0] / 0.01, rel=1e-9)
    assert params["twist_covariance_diagonal"][0] == pytest.approx((k_l + k_r) * s / 4 / 0.01, rel=1e-6)
    assert params["twist_covariance_diagonal"][5] == pytest.approx((k_l + k_r) * s / b**2 / 0.01, rel=1e-3)
    _, wider = _ros2(selfcal_json, capsys, "--velocity-window-s", "0.2")
    assert wider["twist_covariance_diagonal"][0] == pytest.approx(params["twist_covariance_diagonal"][0] / 2)
    assert main(["export", str(selfcal_json), "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["odometry_covariances"]["twist_covariance_diagonal"] == params["twist_covariance_diagonal"]
    assert out["odometry_covariances"]["pose_covariance_diagonal"] == params["pose_covariance_diagonal"]


def test_no_noise_no_covariances_and_bad_options_refused(selfcal_json, tmp_path, capsys):
    """A calibration without the odometry's noise writes no covariance (a guess is worse than the
    controller's own); speeds and windows no robot has are refused in one line, exit 2; a
    covariance that is not six variances is refused by the writer."""
    d = json.loads(selfcal_json.read_text())
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps({**d, "odometry_noise": None}))
    text, params = _ros2(bare, capsys)
    assert "twist_covariance_diagonal" not in params and "odom0_config" not in text
    for flag, value in (
        ("--covariance-speed-mps", "500"),
        ("--velocity-window-s", "0"),
        ("--velocity-window-s", "nan"),
    ):
        assert main(["export", str(selfcal_json), "--format", "ros2", flag, value]) == 2
        err = capsys.readouterr().err
        assert flag in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps({**d, "odometry_noise": {"wheel_variance_left_m2_per_m": -1.0}}))
    assert main(["export", str(broken), "--format", "ros2"]) == 2
    assert "odometry_noise" in capsys.readouterr().err
    cal = ExportCalibration(1.0, 1.0, 1.0, source="x")
    with pytest.raises(InputError, match="six non-negative"):
        format_export(
            cal, "ros2", covariances={"pose_covariance_diagonal": [1.0] * 5, "twist_covariance_diagonal": [1.0] * 6}
        )
    with pytest.raises(InputError, match="variances per metre"):
        ExportCalibration(1.0, 1.0, 1.0, odometry_noise_m=(-1e-5, 1e-5))
