"""Car-like robots: the bicycle-model car and the four-wheel Ackermann car.

Their forward kinematics against the ros2 controllers' equations, their odometry (vesc_to_odom)
turned back into speed and steering, the simulator's cars calibrated by the command from their
joint states and from their /odom within the targets, and their exports: the controllers'
parameters with the joints' names, and the user's vesc.yaml with its gains calibrated and every
other line kept."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re

import numpy as np
import pytest
import yaml

from umbmark.errors import InputError
from umbmark.io.param_file import edit_parameter_file, number_text
from umbmark.kinds import KINDS, Ackermann, Bicycle
from umbmark.kinds.bicycle import speed_and_steering, vesc_values
from umbmark.model.kinematic_drive import KinematicRobot, Move, kinematic_program, simulate_kinematic_drive
from umbmark.model.sensors import Lidar, SensorPose

F1 = (Bicycle(0.110, 0.33), Bicycle(0.1115, 0.33, math.radians(1.2), 1.04))
TARGET = {
    "wheel_diameter_mm": ("rel", 0.003),
    "steering_scale": ("rel", 0.005),
    "steering_offset_deg": ("abs", 0.1),
    "sensor_pose.x_mm": ("abs", 5.0),
    "sensor_pose.y_mm": ("abs", 5.0),
    "sensor_pose.yaw_deg": ("abs", 0.3),
}


def run(args, code=0):
    from umbmark.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    assert rc == code, (rc, err.getvalue()[-800:], out.getvalue()[-300:])
    if code == 0:
        return out.getvalue()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err.getvalue(), err.getvalue()
    return lines[0]


# ---------------------------------------------------------------- the kinematics
def test_the_bicycle_is_the_controllers_forward_kinematics():
    """bicycle_steering_controller: linear = traction_wheel_vel * radius, angular = tan(steer) * linear / L."""
    rng = np.random.default_rng(1)
    g = Bicycle(0.11, 0.33, 0.02, 1.05)
    vals = np.column_stack([rng.uniform(-2, 2, 50), rng.uniform(-0.4, 0.4, 50)])
    steer = g.steering_scale * vals[:, 1] + g.steering_offset_rad
    linear = vals[:, 0] * 0.5 * g.wheel_diameter_m
    want = np.column_stack([linear, 0 * linear, np.tan(steer) * linear / g.wheelbase_m])
    np.testing.assert_allclose(g.twist(vals), want, rtol=1e-12, atol=1e-15)


def _ackermann_controller(g: Ackermann, right_vel, left_vel, right_steer, left_steer):
    """ackermann_steering_controller's update_from_velocity, written out step by step."""
    length, ws, wt, r = g.wheelbase_m, g.steering_track_m, g.traction_track_m, 0.5 * g.wheel_diameter_m
    right_est = math.atan(length * math.tan(right_steer) / (length - ws / 2 * math.tan(right_steer)))
    left_est = math.atan(length * math.tan(left_steer) / (length + ws / 2 * math.tan(left_steer)))
    steer = (right_est + left_est) * 0.5
    turning = length / math.tan(steer) if steer != 0 else math.inf
    if math.isinf(turning):
        linear = (right_vel * r + left_vel * r) * 0.5
    else:
        linear = (right_vel * r * turning / (turning + wt * 0.5) + left_vel * r * turning / (turning - wt * 0.5)) * 0.5
    return linear, math.tan(steer) * linear / length


def test_the_ackermann_car_is_the_controllers_forward_kinematics():
    rng = np.random.default_rng(2)
    g = Ackermann(0.2, 0.6, 0.45, 0.42, -0.01, 0.97)
    for _ in range(30):
        left, right = rng.uniform(-5, 5, 2)
        sl, sr = rng.uniform(-0.5, 0.5, 2)
        true_l, true_r = g.steering_scale * sl + g.steering_offset_rad, g.steering_scale * sr + g.steering_offset_rad
        v, w = _ackermann_controller(g, right, left, true_r, true_l)
        np.testing.assert_allclose(g.twist([[left, right, sl, sr]])[0], [v, 0.0, w], rtol=1e-12, atol=1e-15)
    zero = -g.steering_offset_rad / g.steering_scale  # the reading of a true 0
    assert g.twist([[1.0, 1.0, zero, zero]])[0] == pytest.approx([0.1, 0.0, 0.0], abs=1e-15)


@pytest.mark.parametrize("g", [F1[1], Ackermann(0.2, 0.6, 0.45, 0.42, 0.02, 1.03)])
def test_a_car_drives_the_twist_it_commands_and_neither_spins_nor_slides(g):
    vx, w = np.array([0.5, -0.4, 1.0, 0.3, 0.0]), np.array([0.3, 0.2, -0.8, 0.0, 0.0])
    tw = g.twist(g.joint_motion(vx, 0 * vx, w, 0.01)) / 0.01
    np.testing.assert_allclose(tw, np.column_stack([vx, 0 * vx, w]), atol=1e-12)
    with pytest.raises(InputError, match="cannot turn on the spot"):
        g.joint_motion(0.0, 0.0, 0.5, 0.01)
    with pytest.raises(InputError, match="cannot move sideways"):
        g.joint_motion(0.1, 0.1, 0.0, 0.01)


def test_a_vesc_odometry_is_turned_back_into_its_speed_and_steering():
    """The odometry vesc_to_odom integrates (Euler steps, the steering at each step's end) of a drive
    with reversing gives back the joints it was made of, through the nominal geometry."""
    robot = KinematicRobot(*F1, SensorPose(0.27, 0.0, 0.0), Lidar(n_beams=8, range_noise_m=0.0))
    moves = [Move(3.0, 0.6, 0.0, 0.9), Move(2.0, -0.3, 0.0, 0.4), Move(1.0), Move(2.0, 0.5, 0.0, -1.0)]
    log = simulate_kinematic_drive(moves, robot)
    pos = KINDS["bicycle"].joints_from_odometry(F1[0], log.odometry(scheme="euler"))
    np.testing.assert_allclose(pos[:, 0], log.positions[:, 0], atol=1e-9)
    moving = np.abs(np.diff(log.positions[:, 0])) > 1e-6
    np.testing.assert_allclose(pos[1:, 1][moving], log.positions[1:, 1][moving], atol=1e-9)
    still = np.column_stack([np.linspace(0, 5, 50), np.zeros(50), np.zeros(50)])
    with pytest.raises(InputError, match="use_servo_cmd_to_calc_angular_velocity: true"):
        speed_and_steering(still, 0.33)
    with pytest.raises(InputError, match="odometry is a bicycle.s"):
        KINDS["ackermann"].joints_from_odometry(Ackermann(0.2, 0.6, 0.45, 0.45), still)


def test_a_held_steering_scale_the_drive_contradicts_is_named():
    from umbmark.correct.selfcal.kinematic import kinematic_selfcal
    from umbmark.model.kinematics import JointIntervals, JointSteps, joint_intervals_from_motion
    from umbmark.realrobot.kinematic import unfitted_notes

    pose = SensorPose(0.27, 0.01, math.radians(0.6))
    for true, named in ((F1[1], True), (Bicycle(0.1115, 0.33, math.radians(1.2)), False)):
        robot = KinematicRobot(F1[0], true, pose, Lidar(n_beams=8, range_noise_m=0.0))
        moves, start = kinematic_program(robot, 60.0, seed=2)
        log = simulate_kinematic_drive(moves, robot, start_pose=start)
        t = log.scan_t_s[::3]
        grid = np.unique(np.concatenate([log.t_s, t]))
        js, b = log.joint_steps(grid), np.searchsorted(grid, t)
        steps = JointSteps(js.values[b[0] : b[-1]], b - b[0], js.dt_s[b[0] : b[-1]])
        iv = joint_intervals_from_motion(steps, true, pose.as_array())
        noise = np.random.default_rng(1).normal(0.0, 1.0, iv.sensor.shape) * [0.001, 0.001, 0.001]
        iv = JointIntervals(iv.dt_s, iv.steps, iv.sensor + noise)
        notes = unfitted_notes(iv, F1[0], None)
        assert bool(notes) == named, notes
        if named:
            assert notes[0].endswith("run again with `fit_steering_scale`")
            assert re.search(r"`steering_scale` comes out 1\.0[34]", notes[0])
            r = kinematic_selfcal(iv, F1[0], fit=KINDS["bicycle"].fit_of(["fit_steering_scale"]))
            assert r.kinematics.steering_scale == pytest.approx(1.04, rel=0.005)


# ---------------------------------------------------------------- the vesc driver's parameter file
def test_the_vesc_gains_follow_the_formulas_and_refuse_what_cannot_be_calibrated():
    nominal, true = F1
    got = vesc_values(true, nominal, {"speed_to_erpm_gain": 4614.0, "steering_angle_to_servo_gain": -1.2135,
                                      "steering_angle_to_servo_offset": 0.5304})  # fmt: skip
    assert got["speed_to_erpm_gain"] == pytest.approx(4614.0 * 110 / 111.5)
    assert got["steering_angle_to_servo_gain"] == pytest.approx(-1.2135 / 1.04)
    assert got["steering_angle_to_servo_offset"] == pytest.approx(0.5304 + math.radians(1.2) * 1.2135 / 1.04)
    with pytest.raises(InputError, match="`steering_angle_to_servo_gain` in use is 0"):
        vesc_values(true, nominal, {**got, "steering_angle_to_servo_gain": 0.0})


VESC_NODE = """\
# my car
vesc_driver_node:   # the driver
  ros__parameters:
    speed_to_erpm_gain: 4614.0
    speed_to_erpm_offset: 0.0   # erpm at rest
    steering_angle_to_servo_gain: -1.2135
    steering_angle_to_servo_offset: 0.5304
    servo_min: 0.15
    topics: [a, b]
"""


def _edit(text: str):
    def compute(in_use):
        return vesc_values(F1[1], F1[0], in_use)

    keys = KINDS["bicycle"].edited_files[0].keys
    return edit_parameter_file(text, "vesc.yaml", keys, compute, "a vesc.yaml", "calibrated")


@pytest.mark.parametrize(
    "text",
    [
        VESC_NODE,
        VESC_NODE.replace("vesc_driver_node:   # the driver", "/**:"),
        "\n".join(line[4:] for line in VESC_NODE.splitlines() if line.startswith("    ")) + "\n",  # ROS 1
        "/**: {ros__parameters: {speed_to_erpm_gain: 4614.0, steering_angle_to_servo_gain: -1.2135, "
        "steering_angle_to_servo_offset: 0.5304, port: /dev/vesc}}\n",
        VESC_NODE + "other_node:\n  ros__parameters:\n    speed_to_erpm_gain: 4000.0\n"
        "    steering_angle_to_servo_gain: -1.0\n    steering_angle_to_servo_offset: 0.5\n",
        "# ROS 1, loaded under the vesc namespace\nspeed_to_erpm_gain: -2000\nspeed_to_erpm_offset: 0.0\n"
        "steering_angle_to_servo_gain: -1.2135\nsteering_angle_to_servo_offset: 0.55\n"
        "vesc_to_odom/publish_tf: true\nwheelbase: .225\nvesc_driver:\n  port: /dev/vesc\n  servo_min: 0.15\n",
    ],
    ids=["node", "wildcard", "ros1", "flow", "two-nodes", "mushr"],
)
def test_a_vesc_yaml_keeps_every_other_line(text):
    new, edits = _edit(text)
    old, got = yaml.safe_load(text), yaml.safe_load(new)
    changed = {e.key for e in edits}
    assert changed == set(KINDS["bicycle"].edited_files[0].changed)

    def strip(d):
        if isinstance(d, dict):
            return {k: strip(v) for k, v in d.items() if k not in changed}
        return d

    assert strip(got) == strip(old)  # every other key and value as it was
    for block in {e.block for e in edits}:
        mine = {e.key: e for e in edits if e.block == block}
        want = vesc_values(F1[1], F1[0], {k: e.old for k, e in mine.items()})
        assert {k: e.new for k, e in mine.items()} == pytest.approx(want)
    body = [line for line in new.splitlines() if not line.startswith("# calibrated") and not line.startswith("#   ")]
    assert len(body) == len(text.splitlines())  # every line kept, comments and order too ...
    for a, b in zip(text.splitlines(), body):
        assert a == b or any(k in a for k in changed)  # ... but those of the changed values
    assert all("." in number_text(e.new) for e in edits)


@pytest.mark.parametrize(
    "text, message",
    [
        ("/**:\n  ros__parameters:\n    port: x\n", "no speed_to_erpm_gain, steering_angle_to_servo_gain"),
        (
            VESC_NODE.replace("    steering_angle_to_servo_gain: -1.2135\n", ""),
            "`steering_angle_to_servo_gain` missing",
        ),
        (
            VESC_NODE.replace("-1.2135", "true"),
            "`steering_angle_to_servo_gain` .vesc_driver_node's parameters. must be",
        ),
        (VESC_NODE.replace("4614.0", "0.0"), "`speed_to_erpm_gain` in use is 0: no gain the calibration can scale"),
        ("/**: [unclosed\n", "not a YAML parameter file"),
    ],
)
def test_a_vesc_yaml_without_usable_gains_is_refused_naming_the_key(text, message):
    with pytest.raises(InputError, match=message.replace("(", "\\(")):
        _edit(text)


# ---------------------------------------------------------------- the command on simulated bags
@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    pytest.importorskip("rosbags")
    from umbmark.studies.cars import CARS, car_bag

    d = tmp_path_factory.mktemp("cars")
    return {name: car_bag(name, d / f"{name}.bag") for name in CARS}


@pytest.fixture(scope="module")
def calibrations(bags, tmp_path_factory):
    """Each car's calibration from its joints, and the bicycle-model cars' from their /odom too."""
    from umbmark.cli.kinematic_args import car_selfcal_args
    from umbmark.studies.cars import CARS, SOURCES

    d = tmp_path_factory.mktemp("cal")
    out = {}
    for name, bag in bags.items():
        for source in SOURCES if CARS[name].reads_odometry else SOURCES[:1]:
            text = run(car_selfcal_args(name, bag, source))
            path = d / f"{name}-{source}.json"
            path.write_text(text)
            out[(name, source)] = (json.loads(text), path)
    return out


def test_every_car_is_found_within_the_targets_from_its_joints_and_its_odometry(calibrations):
    from umbmark.studies.cars import truth

    assert len(calibrations) == 5
    for (name, source), (d, _) in calibrations.items():
        assert d["warnings"] == [], (name, source)
        assert d["joints"] is None if source == "odom" else set(d["joints"].values()) == set(CARS_JOINTS[name])
        assert d["wheelbase_mm"] == pytest.approx(d["nominal"]["wheelbase_mm"])  # held
        for key, t in truth(name).items():
            a, _, b = key.partition(".")
            est = d[a][b] if b else d[a]
            how, tol = TARGET[key]
            err = (est - t) / t if how == "rel" else est - t
            assert abs(err) <= tol, (name, source, key, est, t)


CARS_JOINTS = {
    "f1tenth": ("rear_wheel_joint", "steering_joint"),
    "large": ("rear_wheel_joint", "steering_joint"),
    "ackermann": ("rear_left_wheel_joint", "rear_right_wheel_joint", "front_left_steering_joint",
                  "front_right_steering_joint"),
}  # fmt: skip


def test_the_vesc_yaml_is_written_with_the_gains_the_truth_implies(calibrations, tmp_path):
    from umbmark.studies.cars import VESC_IN_USE, vesc_truth

    conf = tmp_path / "vesc.yaml"
    text = VESC_NODE.replace("vesc_driver_node:   # the driver", "/**:")
    conf.write_text(text)
    for name in ("f1tenth", "large"):
        new = tmp_path / f"{name}.yaml"
        run(["export", str(calibrations[(name, "odom")][1]), "--format", "vesc", "--vesc-config", str(conf),
             "--out", str(new)])  # fmt: skip
        got = yaml.safe_load(new.read_text())["/**"]["ros__parameters"]
        want = vesc_truth(name, VESC_IN_USE)
        assert got["speed_to_erpm_gain"] == pytest.approx(want["speed_to_erpm_gain"], rel=0.005)
        assert got["steering_angle_to_servo_gain"] == pytest.approx(want["steering_angle_to_servo_gain"], rel=0.005)
        assert got["steering_angle_to_servo_offset"] == pytest.approx(want["steering_angle_to_servo_offset"], abs=0.003)
        old = yaml.safe_load(text)["/**"]["ros__parameters"]
        assert {k: v for k, v in got.items() if k not in want} == {k: v for k, v in old.items() if k not in want}
    assert conf.read_text() == text  # the input untouched
    cal = str(calibrations[("f1tenth", "odom")][1])
    assert "replace" in run(["export", cal, "--format", "vesc", "--vesc-config", str(conf), "--out", str(conf)], 2)
    assert "give it, --vesc-config VESC.yaml" in run(["export", cal, "--format", "vesc"], 2)
    assert "--vesc-config is for --format vesc, not ros2" in run(["export", cal, "--format", "ros2",
                                                                  "--vesc-config", str(conf)], 2)  # fmt: skip
    assert conf.read_text() == text


def test_the_controllers_parameters_name_the_joints_the_bag_shows(calibrations):
    bike = run(["export", str(calibrations[("f1tenth", "joints")][1]), "--format", "ros2"])
    p = yaml.safe_load(bike)["bicycle_steering_controller"]["ros__parameters"]
    assert p["traction_joints_names"] == ["rear_wheel_joint"] and p["steering_joints_names"] == ["steering_joint"]
    assert p["wheelbase"] == pytest.approx(0.33) and p["traction_wheel_radius"] == pytest.approx(0.05575, rel=0.003)
    assert '<joint name="steering_joint"' in bike
    ack = run(["export", str(calibrations[("ackermann", "joints")][1]), "--format", "ros2"])
    p = yaml.safe_load(ack)["ackermann_steering_controller"]["ros__parameters"]
    assert p["traction_joints_names"] == ["rear_right_wheel_joint", "rear_left_wheel_joint"]  # right, then left
    assert p["steering_joints_names"] == ["front_right_steering_joint", "front_left_steering_joint"]
    assert (p["traction_track_width"], p["steering_track_width"]) == pytest.approx((0.45, 0.42))
    odom = run(["export", str(calibrations[("f1tenth", "odom")][1]), "--format", "ros2"])
    p = yaml.safe_load(odom)["bicycle_steering_controller"]["ros__parameters"]
    assert "traction_joints_names" not in p and "no joints' names in the recording" in odom


def test_a_cars_odometry_and_joints_are_one_line_errors_where_they_do_not_fit(bags):
    ack = ["selfcal", str(bags["ackermann"]), "--kinematics", "ackermann", "--wheel-diameter-mm", "200",
           "--wheelbase-mm", "600", "--traction-track-width-mm", "450"]  # fmt: skip
    assert "with --kinematics bicycle" in run([*ack, "--odom-topic", "/odom"], 2)
    assert "--traction-joints LEFT,RIGHT" in run(ack, 2)
    bike = ["selfcal", str(bags["f1tenth"]), "--kinematics", "bicycle", "--wheel-diameter-mm", "110",
            "--wheelbase-mm", "330", "--odom-topic", "/odom"]  # fmt: skip
    assert "or --odom-topic, not both" in run([*bike, "--drive-joint", "rear_wheel_joint"], 2)
    assert "--fit-wheelbase" in run(["selfcal", "--help"]) and "--traction-track-width-mm" in run(["selfcal", "--help"])
