"""Joints found from the data: the joints given in another order or role are named with the flags
to give, the right order never refused, ``bag-info`` says the order each kind's flags want, and the
exports name the joints.

Small simulated drives of each kind (30 s, a 180-beam lidar; ``tests/kinematic_bags.py``'s robots):
the command line on the few cases the issue pins (a mecanum robot's front and rear exchanged, a
tricycle's drive and steering joints exchanged), the library's check on the rest with the lidar's
motion matched once per bag.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
from kinematic_bags import ROBOTS  # noqa: E402

from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import read_selfcal_bag  # noqa: E402
from umbmark.io.rosbag_write import write_drive_bag  # noqa: E402
from umbmark.kinds import DiffDrive, Reading, joint_flags_for, kind_named  # noqa: E402
from umbmark.model.kinematic_drive import (  # noqa: E402
    JointNoise,
    KinematicRobot,
    kinematic_program,
    simulate_kinematic_drive,
)
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.kinematic import check_joint_readings, joint_source  # noqa: E402

DIFF = dict(
    nominal=DiffDrive(0.15, 0.15, 0.34),
    true=DiffDrive(0.151, 0.1495, 0.345),
    joints=("left_wheel_joint", "right_wheel_joint"),
    lidar=SensorPose(0.10, 0.02, math.radians(-3.0)),
    drawing=SensorPose(0.12, 0.0, 0.0),
)
SPECS = {**ROBOTS, "diff_drive": DIFF}
MECANUM = ROBOTS["mecanum"]["joints"]
TRICYCLE = ROBOTS["tricycle"]["joints"]
NOT_SIDEWAYS = ["straight", "back", "arc+", "arc-", "spin+", "spin-"]


def _log(kind: str, moves=None):
    spec = SPECS[kind]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=180, range_noise_m=0.005))
    program, start = kinematic_program(robot, 30.0, seed=7, kinds=moves)
    log = simulate_kinematic_drive(
        program, robot, start_pose=start, joint_names=spec["joints"], noise=JointNoise(speed_rel_sd=0.01), seed=7
    )
    return dataclasses.replace(log, sensor_pose=spec["drawing"])  # /tf_static: the drawing


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """kind -> (bag path, the bag read, the lidar's motion): each kind's drive, and the mecanum
    robot's without sideways motion."""
    root = tmp_path_factory.mktemp("joint_order")
    out = {}
    for name, kind, moves in [*((k, k, None) for k in SPECS), ("mecanum_not_sideways", "mecanum", NOT_SIDEWAYS)]:
        path = write_drive_bag(_log(kind, moves), root / name, storage="mcap", odom=False)
        nominal = SPECS[kind]["nominal"]
        bag = read_selfcal_bag(
            path, wheels=joint_source(nominal, SPECS[kind]["joints"]), scan_topic="/scan", two_wheels=False
        )
        out[name] = (path, bag, check_joint_readings(bag, nominal))  # the right order: not refused
    return out


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


def refused(*args: str) -> str:
    code, out, err = run(*args)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    return lines[0]


def _read_as(bags, name: str, order, shift=None) -> str | None:
    """The library's refusal of a bag's joints given in another order (a column per role), or None."""
    path, bag, motion = bags[name]
    kind = name if name in SPECS else "mecanum"
    pos = bag.joint_positions[:, list(order)] + (0.0 if shift is None else np.asarray(shift))
    other = dataclasses.replace(bag, joint_positions=pos, joint_names=tuple(bag.joint_names[i] for i in order))
    try:
        check_joint_readings(other, SPECS[kind]["nominal"], motion=motion)
    except InputError as err:
        return err.message
    return None


def test_the_right_order_is_never_refused(bags):
    """Every kind's drive read as recorded passes (the fixture checks each); so does a mecanum robot's
    drive without sideways motion, where front and rear cannot be told apart, and the diagonal
    exchange that is the same motion there."""
    assert set(bags) == {*SPECS, "mecanum_not_sideways"}
    assert _read_as(bags, "mecanum_not_sideways", (2, 3, 0, 1)) is None


def test_mecanum_joints_with_front_and_rear_exchanged_are_refused_naming_the_order(bags):
    path = bags["mecanum"][0]
    given = ",".join(MECANUM[i] for i in (2, 3, 0, 1))
    line = refused(
        "selfcal", str(path), "--kinematics", "mecanum", "--joints", given, "--wheel-diameter-mm", "100",
        "--lx-plus-ly-mm", "400",
    )  # fmt: skip
    want = f"the joints look like they are in another order: --joints {','.join(MECANUM)} (in this order: "
    assert want + "front_left, front_right, rear_left, rear_right)" in line, line
    assert "--skip-check joint_order" in line and "poorly determined" not in line


@pytest.mark.parametrize("order", [(1, 0, 2, 3), (0, 2, 1, 3), (3, 2, 1, 0), (1, 2, 3, 0), (2, 1, 0, 3)])
def test_every_wrong_order_tried_is_named(bags, order):
    """Wheels exchanged in pairs, diagonally, in a cycle: the order that fits is named (the joints
    as the bag names them, put back in the roles' order)."""
    msg = _read_as(bags, "mecanum", order)
    assert msg is not None and f"`joints={','.join(MECANUM)}` (in this order: front_left" in msg, msg
    if order in ((1, 0, 2, 3), (2, 1, 0, 3), (1, 2, 3, 0)):
        assert "the joints as given move the robot otherwise than the lidar" in msg and "upside down" not in msg


def test_tricycle_drive_and_steering_exchanged_are_named_as_such(bags):
    path = bags["tricycle"][0]
    line = refused(
        "selfcal", str(path), "--kinematics", "tricycle", "--drive-joint", TRICYCLE[1], "--steer-joint",
        TRICYCLE[0], "--wheel-diameter-mm", "250", "--wheelbase-mm", "800",
    )  # fmt: skip
    assert f"the drive and steering joints look exchanged: --drive-joint {TRICYCLE[0]} --steer-joint" in line
    assert "degrees" not in line


@pytest.mark.parametrize("turn", [0.5 * math.pi, -0.5 * math.pi])
def test_a_steering_zero_a_quarter_turn_off_is_named_an_offset(bags, turn):
    msg = _read_as(bags, "tricycle", (0, 1), (0.0, turn))
    assert msg is not None and "its zero is a quarter turn off (an offset, not degrees)" in msg, msg
    assert f"reads {math.degrees(turn):+.0f} deg" in msg and f"<offset> {-turn:+.6f} rad more" in msg


def test_wheels_exchanged_are_named_beside_a_lidar_upside_down(bags):
    msg = _read_as(bags, "diff_drive", (1, 0))
    assert msg is not None and "the lidar turns the other way" in msg and "upside down" in msg
    assert "the wheels given right before left: `joints=left_wheel_joint,right_wheel_joint`" in msg


def test_bag_info_says_the_order_each_kinds_flags_want(bags):
    code, out, _ = run("bag-info", str(bags["mecanum"][0]))
    text = " ".join(out.split())
    assert code == 0
    want = f"mecanum robot: --kinematics mecanum --joints {','.join(MECANUM)} (in this order: front_left, front_right"
    assert want in text and "found by their names" in text
    assert "tricycle: --kinematics tricycle --drive-joint NAME --steer-joint NAME; the names do not tell" in text
    code, out, _ = run("bag-info", str(bags["tricycle"][0]))
    text = " ".join(out.split())
    assert f"--kinematics tricycle --drive-joint {TRICYCLE[0]} --steer-joint {TRICYCLE[1]}; found" in text
    assert "mecanum robot" not in text  # two joints cannot be a mecanum robot's four


def test_the_names_words_give_the_roles():
    names = ["BackRightWheel", "wheel_fl", "imu_joint", "front_right_wheel", "rear_left_wheel"]
    found = {k.name: (flags, ok) for k, flags, ok in joint_flags_for(names)}
    assert found["mecanum"] == (
        "`joints=wheel_fl,front_right_wheel,rear_left_wheel,BackRightWheel` (in this order: front_left, "
        "front_right, rear_left, rear_right)",
        True,
    )
    assert found["tricycle"] == ("`drive_joint=NAME` `steer_joint=NAME`", False)
    assert kind_named("tricycle").guess_joints(["front_steering_joint", "front_wheel_joint"]) == (
        "front_wheel_joint",
        "front_steering_joint",
    )
    assert kind_named("diff_drive").guess_joints(["left_wheel", "front_left_caster", "right_wheel"]) is None


def test_a_reading_unwraps_a_joint_that_rolls_only_read_so():
    wrapped = (np.arange(50) * 0.3 + np.pi) % (2 * np.pi) - np.pi  # a wheel the reader took for a steering angle
    pos = np.column_stack([np.linspace(0, 0.2, 50), wrapped])
    read = Reading((1, 0)).apply(pos, (True, False))
    np.testing.assert_allclose(np.diff(read[:, 0]), 0.3, atol=1e-12)
    np.testing.assert_allclose(read[:, 1], pos[:, 0])


# ---------------------------------------------------------------- the exports name the joints
def _cal(kind: str, **extra) -> dict:
    sp = {"x_mm": 200.0, "y_mm": 0.0, "yaw_deg": 0.0}
    geo = (
        {"wheel_diameter_mm": 252.0, "wheelbase_mm": 790.0, "steering_offset_deg": 1.5, "steering_scale": 1.0}
        if kind == "tricycle"
        else {"wheel_diameters_mm": dict.fromkeys(("front_left", "front_right", "rear_left", "rear_right"), 100.0),
              "lx_plus_ly_mm": 400.0}
    )  # fmt: skip
    return {"kinematics": kind, **geo, "sensor_pose": sp, "warnings": [], **extra}


def test_the_exports_load_as_yaml_with_the_joint_names(tmp_path):
    import yaml

    from umbmark.io.export_kinematic import format_kinematic_export, kinematic_calibration_from_dict

    tri = _cal("tricycle", joints={"drive": "front_wheel", "steer": "front_steer"})
    text = format_kinematic_export(kinematic_calibration_from_dict(tri), "ros2")
    params = yaml.safe_load(text)["tricycle_controller"]["ros__parameters"]
    assert params["traction_joint_name"] == "front_wheel" and params["steering_joint_name"] == "front_steer"
    assert '<joint name="front_steer" role="joint1">' in text and "loadable alone" in text
    mec = _cal("mecanum", joints=dict(zip(("front_left", "front_right", "rear_left", "rear_right"), "abcd")))
    doc = json.loads(format_kinematic_export(kinematic_calibration_from_dict(mec), "json"))
    assert doc["parameters"]["rear_left_wheel_command_joint_name"] == "c"
    # a calibration of an older umbmark names its joints in its bag's description only
    old = _cal("tricycle", inputs=[{"wheel_data": "JointState drive_j, steer_j on /joint_states"}])
    params = yaml.safe_load(format_kinematic_export(kinematic_calibration_from_dict(old), "ros2"))
    assert params["tricycle_controller"]["ros__parameters"]["steering_joint_name"] == "steer_j"
    # none named: the calibrated values, to merge, and the transmission's placeholder said so
    text = format_kinematic_export(kinematic_calibration_from_dict(_cal("tricycle")), "ros2")
    assert "the calibrated values only (the calibration names no joints): merge them" in text
    assert "put its name for STEERING_JOINT" in text
    with pytest.raises(InputError, match="'joints' must name the joint of each of drive, steer"):
        kinematic_calibration_from_dict(_cal("tricycle", joints={"drive": "a b", "steer": "c"}))
