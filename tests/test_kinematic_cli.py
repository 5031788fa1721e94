"""`umbmark selfcal --kinematics tricycle|mecanum` on simulated bags: the pinned flags and JSON keys,
accuracy within the targets with the truth inside the intervals, the joint reader, and bad input
(one line, exit status 2)."""

from __future__ import annotations

import contextlib
import io
import json
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
from umbmark.cli import main  # noqa: E402
from umbmark.cli.kinematic_args import selfcal_args  # noqa: E402
from umbmark.io.rosbag import read_selfcal_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.studies.kinematic import JOINTS, draw_robot, estimate_of, simulated_bag, truth_of  # noqa: E402

PINNED = {
    "tricycle": ["kinematics", "wheel_diameter_mm", "wheelbase_mm", "steering_offset_deg", "sensor_pose", "warnings"],
    "mecanum": ["kinematics", "wheel_diameters_mm", "lx_plus_ly_mm", "sensor_pose", "warnings"],
}
TARGET = {"rel": 0.003, "steering_offset_deg": 0.1, "sensor_x_mm": 5.0, "sensor_y_mm": 5.0, "sensor_yaw_deg": 0.3}


def run(args, code=0):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    assert rc == code, (rc, err.getvalue(), out.getvalue()[-500:])
    if code == 0:
        return out.getvalue()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("umbmark: error: ") and "Traceback" not in err.getvalue()
    return lines[0]


@pytest.fixture(scope="module", params=["tricycle", "mecanum"])
def case(request, tmp_path_factory):
    drawn = draw_robot(request.param, seed=11)
    bag = simulated_bag(drawn, tmp_path_factory.mktemp(request.param) / "drive.bag")
    return drawn, bag, json.loads(run(selfcal_args(drawn, bag)))


def test_the_json_has_the_pinned_keys_each_estimate_with_its_interval(case):
    drawn, _, d = case
    for key in PINNED[drawn.kind]:
        assert key in d
    assert d["kinematics"] == drawn.kind
    assert d["joints"] == dict(zip(drawn.robot.nominal.joint_roles, JOINTS[drawn.kind]))  # what an export names
    for k in ("x_mm", "y_mm", "yaw_deg"):
        assert len(d["sensor_pose"][f"{k}_ci95"]) == 2
    if drawn.kind == "mecanum":
        assert set(d["wheel_diameters_mm"]) == {"front_left", "front_right", "rear_left", "rear_right"}
        assert set(d["wheel_diameters_mm_ci95"]) == set(d["wheel_diameters_mm"])
        assert len(d["lx_plus_ly_mm_ci95"]) == 2
    else:
        for k in ("wheel_diameter_mm", "wheelbase_mm", "steering_offset_deg"):
            assert len(d[f"{k}_ci95"]) == 2
        assert d["steering_scale"] == 1.0 and d["steering_scale_ci95"] is None  # not estimated unless asked


def test_the_truth_is_found_within_the_targets_and_inside_the_intervals(case):
    drawn, _, d = case
    assert d["warnings"] == []
    for key, truth in truth_of(drawn).items():
        est, (lo, hi) = estimate_of(d, key)
        if key in TARGET:
            assert abs(est - truth) <= TARGET[key], key
        else:
            assert abs(est - truth) <= TARGET["rel"] * truth, key
        # the truth inside, allowing the 5 % the intervals leave out a little room
        assert lo - 0.5 * (hi - lo) <= truth <= hi + 0.5 * (hi - lo), key


def test_the_table_names_the_kind_and_what_to_do_next(case):
    drawn, bag, _ = case
    args = [a for a in selfcal_args(drawn, bag) if a != "--json"]
    out = run(args)
    assert "Self-calibration of a " in out and drawn.kind in out and "umbmark export" in out
    assert ("steering offset" in out) == (drawn.kind == "tricycle")
    assert ("lx + ly" in out) == (drawn.kind == "mecanum")


def test_the_reader_takes_the_joints_of_the_kind_and_unwraps_only_the_wheels(case):
    drawn, bag, _ = case
    names = JOINTS[drawn.kind]
    steer = names[1:] if drawn.kind == "tricycle" else ()
    b = read_selfcal_bag(bag, wheels=WheelSource.robot_joints(names, steer), two_wheels=False)
    assert b.joint_positions is not None and b.joint_positions.shape[1] == len(names)
    assert b.left_rad is None and b.joint_names == names
    if drawn.kind == "tricycle":
        assert np.abs(b.joint_positions[:, 1]).max() < 2.0  # an angle, not unwrapped into turns


def _args(case, drop=(), add=()):
    drawn, bag, _ = case
    args = selfcal_args(drawn, bag)
    out = []
    skip = 0
    for i, a in enumerate(args):
        if skip:
            skip -= 1
            continue
        if a in drop:
            skip = 0 if args[i + 1 : i + 2] and args[i + 1].startswith("--") else 1
            continue
        out.append(a)
    return out + list(add)


def test_missing_or_foreign_flags_are_one_line_errors(case):
    drawn = case[0]
    if drawn.kind == "tricycle":
        assert "--drive-joint" in run(_args(case, drop=("--drive-joint",)), 2)
        assert "--lx-plus-ly-mm is a mecanum" in run(_args(case, add=("--lx-plus-ly-mm", "300")), 2)
        assert "--wheelbase-mm" in run(_args(case, drop=("--wheelbase-mm",)), 2)
        assert "not --joints" in run(_args(case, add=("--joints", "a,b")), 2)
    else:
        assert "FL,FR,RL,RR" in run(_args(case, drop=("--joints",), add=("--joints", "a,b,c")), 2)
        assert "--lx-plus-ly-mm" in run(_args(case, drop=("--lx-plus-ly-mm",)), 2)
        assert "a tricycle's" in run(_args(case, add=("--steer-joint", "s")), 2)
    assert "--odom-topic" in run(_args(case, add=("--odom-topic", "/odom")), 2)


def test_a_joint_the_bag_lacks_is_named_with_the_joints_it_has(case):
    drawn = case[0]
    if drawn.kind == "tricycle":
        args = _args(case, drop=("--steer-joint",), add=("--steer-joint", "no_such_joint"))
    else:
        args = _args(case, drop=("--joints",), add=("--joints", "a,b,c,d"))
    msg = run(args, 2)
    assert "no JointState message" in msg and JOINTS[drawn.kind][0] in msg


def test_the_flags_of_another_kind_need_their_kind(tmp_path):
    msg = run(
        ["selfcal", str(tmp_path), "--steer-joint", "s", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"], 2
    )
    assert "--kinematics" in msg


def test_a_tricycle_from_intervals_files_is_refused(tmp_path):
    f = tmp_path / "iv.csv"
    f.write_text("dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad\n0.1,1,1,0.1,0,0\n")
    msg = run(
        ["selfcal", str(f), "--kinematics", "tricycle", "--drive-joint", "d", "--steer-joint", "s"]
        + ["--wheel-diameter-mm", "200", "--wheelbase-mm", "600"],
        2,
    )
    assert "ROS bags" in msg


def test_the_scale_of_the_steering_is_estimated_on_request(case):
    drawn = case[0]
    if drawn.kind != "tricycle":
        assert "tricycle" in run(_args(case, add=("--fit-steering-scale",)), 2)
        return
    d = json.loads(run(_args(case, add=("--fit-steering-scale",))))
    assert d["steering_scale_ci95"] is not None
    assert d["steering_scale"] == pytest.approx(1.0, abs=0.01)
    assert math.isfinite(d["wheelbase_mm"])


# the parameters the controllers require as ros2_controllers defines them: name -> (type, must be
# positive, or the joint it names in the simulated bag)
SCHEMA = {
    "tricycle": {
        "traction_joint_name": (str, JOINTS["tricycle"][0]),
        "steering_joint_name": (str, JOINTS["tricycle"][1]),
        "wheelbase": (float, True),
        "wheel_radius": (float, True),
    },
    "mecanum": {
        **{
            f"{r}_wheel_command_joint_name": (str, n)
            for r, n in zip(("front_left", "front_right", "rear_left", "rear_right"), JOINTS["mecanum"])
        },
        "kinematics.wheels_radius": (float, True),
        "kinematics.sum_of_robot_center_projection_on_X_Y_axis": (float, False),
    },
}
CONTROLLER = {"tricycle": "tricycle_controller", "mecanum": "mecanum_drive_controller"}


def _flat(d, prefix=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[prefix + k] = v
    return out


def test_the_ros2_export_is_the_controllers_parameter_file(case, tmp_path):
    import yaml

    drawn, bag, d = case
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(d))
    out = tmp_path / "params.yaml"
    run(["export", str(cal), "--format", "ros2", "--out", str(out)])
    doc = yaml.safe_load(out.read_text())
    params = _flat(doc[CONTROLLER[drawn.kind]]["ros__parameters"])
    assert set(params) == set(SCHEMA[drawn.kind])  # every parameter the controller requires: loadable alone
    for key, (kind, want) in SCHEMA[drawn.kind].items():
        assert isinstance(params[key], kind)
        assert params[key] == want if kind is str else (params[key] > 0 or not want)
    truth = truth_of(drawn)
    text = out.read_text()
    assert f"a complete {CONTROLLER[drawn.kind]} block, loadable alone" in text and "STEERING_JOINT" not in text
    if drawn.kind == "tricycle":
        assert params["wheel_radius"] == pytest.approx(0.5e-3 * truth["wheel_diameter_mm"], rel=0.003)
        assert params["wheelbase"] == pytest.approx(1e-3 * truth["wheelbase_mm"], rel=0.003)
        assert f'<joint name="{JOINTS["tricycle"][1]}" role="joint1">' in text  # the transmission names its joint
        offset = float(text.split("<offset>")[1].split("<")[0])
        assert math.degrees(offset) == pytest.approx(truth["steering_offset_deg"], abs=0.1)
    else:
        mean = np.mean(
            [truth[f"wheel_diameters_mm.{r}"] for r in ("front_left", "front_right", "rear_left", "rear_right")]
        )
        assert params["kinematics.wheels_radius"] == pytest.approx(0.5e-3 * mean, rel=0.003)
        assert params["kinematics.sum_of_robot_center_projection_on_X_Y_axis"] == pytest.approx(
            1e-3 * truth["lx_plus_ly_mm"], rel=0.003
        )
        assert "differ beyond their 95 % intervals" in text  # the drawn wheels differ by up to 2 %
    assert "<origin xyz=" in text and "static_transform_publisher" in text


def test_the_urdf_export_is_the_lidars_origin_and_ros1_is_refused(case, tmp_path):
    drawn, _, d = case
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(d))
    urdf = run(["export", str(cal), "--format", "urdf"])
    sp = d["sensor_pose"]
    xyz = [float(v) for v in urdf.split('xyz="')[1].split('"')[0].split()]
    assert xyz[0] == pytest.approx(sp["x_mm"] * 1e-3, abs=1e-6) and xyz[1] == pytest.approx(sp["y_mm"] * 1e-3, abs=1e-6)
    assert "ros2" in run(["export", str(cal), "--format", "ros1"], 2)
    assert "differential drive" in run(["export", str(cal), "--format", "ros2", "--c-left", "1.01"], 2)


# ---------------------------------------------------------------- against a ground truth
MARKER = (0.15, 0.03, math.radians(5.0))


@pytest.fixture(scope="module", params=["tricycle", "mecanum"])
def tracked(request, tmp_path_factory):
    """A drawn robot's bag whose ground truth tracks a marker 150 mm ahead, 30 mm left, turned 5 deg."""
    import dataclasses

    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model import se2
    from umbmark.studies.kinematic import simulated_drive

    drawn = draw_robot(request.param, seed=21)
    log = simulated_drive(drawn)
    marker = se2.compose(log.true_pose, np.array(MARKER))
    marker[:, 2] = log.true_pose[:, 2] + MARKER[2]
    bag = tmp_path_factory.mktemp("gt") / "drive.bag"
    write_drive_bag(dataclasses.replace(log, true_pose=marker), bag, truth=True, tf_static=False, odom=False)
    return drawn, bag, log


def _replay_args(drawn, bag):
    args = selfcal_args(drawn, bag)
    args[0] = "replay"
    i = args.index("--sensor-pose")
    del args[i : i + 2]
    return args + ["--gt-topic", "/ground_truth", "--method", "lsq"]


def test_replay_against_a_ground_truth_finds_the_geometry_and_the_marker(tracked):
    drawn, bag, _ = tracked
    d = json.loads(run(_replay_args(drawn, bag)))
    assert d["kinematics"] == drawn.kind and d["method"] == "lsq"
    for key, truth in truth_of(drawn).items():
        if key.startswith("sensor_"):
            continue
        est, _ = estimate_of(d, key)
        limit = TARGET.get(key, TARGET["rel"] * truth)
        assert abs(est - truth) <= limit, key
    mp = d["marker_pose"]
    assert mp["x_mm"] == pytest.approx(150.0, abs=5.0) and mp["y_mm"] == pytest.approx(30.0, abs=5.0)
    assert mp["yaw_deg"] == pytest.approx(5.0, abs=0.3)
    e = d["relative_pose_error"]
    assert e["after_mm"] < 0.5 * e["before_mm"]  # the calibrated odometry drifts less


def test_replay_of_another_method_or_without_a_ground_truth_is_refused(tracked):
    drawn, bag, _ = tracked
    args = _replay_args(drawn, bag)
    assert "--method lsq" in run([a if a != "lsq" else "bf" for a in args], 2)
    i = args.index("--gt-topic")
    assert "--gt-topic" in run(args[:i] + args[i + 2 :], 2)
    assert "--split-stops" in run(args + ["--split-stops"], 2)


def test_the_ground_truths_delay_is_estimated(tracked):
    import dataclasses

    from umbmark.io.rosbag import read_joint_truth_bag
    from umbmark.realrobot.kinematic import joint_source
    from umbmark.realrobot.kinematic_replay import kinematic_replay

    drawn, bag, _ = tracked
    src = joint_source(drawn.robot.nominal, JOINTS[drawn.kind])
    b = read_joint_truth_bag(bag, wheels=src, gt_topic="/ground_truth")
    late = b.truth.copy()
    late[:, 0] += 0.08
    r = kinematic_replay(dataclasses.replace(b, truth=late), drawn.robot.nominal)
    assert r.time_offset_s == pytest.approx(0.08, abs=0.005)


# ---------------------------------------------------------------- bags as other publishers write them
@pytest.fixture(scope="module")
def tricycle_log():
    from umbmark.studies.kinematic import simulated_drive

    drawn = draw_robot("tricycle", seed=31)
    return drawn, simulated_drive(drawn)


def test_joints_in_separate_messages_are_joined(tricycle_log, tmp_path):
    from umbmark.io.rosbag_write import write_drive_bag

    drawn, log = tricycle_log
    bag = write_drive_bag(log, tmp_path / "apart.bag", tf_static=False, odom=False, separate_joints=True)
    d = json.loads(run(selfcal_args(drawn, bag)))
    assert any("separate JointState messages" in w for w in d["warnings"])
    truth = truth_of(drawn)
    assert d["wheel_diameter_mm"] == pytest.approx(truth["wheel_diameter_mm"], rel=0.003)
    assert d["steering_offset_deg"] == pytest.approx(truth["steering_offset_deg"], abs=0.1)


def test_a_joint_that_counts_backwards_is_named(tricycle_log, tmp_path):
    import dataclasses

    from umbmark.io.rosbag_write import write_drive_bag

    drawn, log = tricycle_log
    flipped = log.positions.copy()
    flipped[:, 0] *= -1.0  # the traction wheel's joint counts backwards
    bag = write_drive_bag(dataclasses.replace(log, positions=flipped), tmp_path / "back.bag", tf_static=False)
    msg = run(selfcal_args(drawn, bag), 2)
    assert "traction joint turns backwards" in msg
