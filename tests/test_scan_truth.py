"""The robot's lidar as the ground truth of a UMBmark test (`replay --gt-scan-topic`,
umbmark.realrobot.scan_truth): simulated ROS 2 bags of square runs with joint states and laser
scans only, the true end poses of the simulator as the reference."""

import contextlib
import io
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")
from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag_write import write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.metrics import umbmark_figures  # noqa: E402
from umbmark.model.drive import (  # noqa: E402
    SimRobot,
    WheelNoise,
    concatenate_drives,
    simulate_drive,
    square_drive,
)
from umbmark.model.geometry import ErrorParams, Geometry  # noqa: E402
from umbmark.model.runs import RunsTable  # noqa: E402
from umbmark.model.se2 import between, compose  # noqa: E402
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.scan_truth import parse_sensor_pose, read_sensor_pose, robot_displacement  # noqa: E402

ED, EB = 1.004, 1.03
ROBOT = SimRobot(
    nominal=Geometry(wheel_diameter_m=0.150, wheelbase_m=0.340, pulses_per_motor_rev=500.0, gear_ratio=20.0),
    errors=ErrorParams(ed=ED, eb=EB, es=1.0),
    sensor_pose=SensorPose(0.035, 0.0, 0.0),  # 35 mm ahead of the axle
    lidar=Lidar(range_noise_m=0.005),
)
DIRECTIONS = ("cw", "cw", "cw", "ccw", "ccw", "ccw")
START = (4.0, 4.0, 0.0)
NOISE = WheelNoise(speed_rel_sd=0.01)
JOINTS = ["--joints", "left_wheel_joint,right_wheel_joint"]
GEO = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--side-mm", "2000", "--split-stops"]


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


def truth_of(drives):
    """The true end pose of each drive in its start frame, and the odometry's end pose."""
    true = np.array([between(d.true_pose[0], d.true_pose[-1]) for d in drives])
    odo = np.array([d.odometry()[-1] for d in drives])
    return true, odo


def truth_emax(drives, directions):
    true, odo = truth_of(drives)
    return umbmark_figures(
        RunsTable.from_columns(list(directions), true[:, 0], true[:, 1], odo[:, 0], odo[:, 1])
    ).emax_syst


@pytest.fixture(scope="module")
def put_back(tmp_path_factory):
    """Six runs, the robot put back on its mark before each (JointState and LaserScan only)."""
    drives = [
        simulate_drive(square_drive(d), ROBOT, start_pose=START, noise=NOISE, seed=10 + i)
        for i, d in enumerate(DIRECTIONS)
    ]
    bag = write_drive_bag(
        concatenate_drives(drives), tmp_path_factory.mktemp("scan") / "squares", odom=False, tf_static=False
    )
    return drives, bag


def test_bag_holds_joint_states_and_scans_only(put_back):
    out = json.loads(run(["bag-info", str(put_back[1]), "--json"]))
    assert sorted(t["topic"] for t in out["topics"]) == ["/joint_states", "/scan"]


def test_lidar_ground_truth_recovers_the_test(put_back):
    """The pinned command: E_max,syst before within 5 mm of the truth; exact's E_d within 5e-4 and
    E_b within 3e-3 of the robot's."""
    drives, bag = put_back
    cmd = ["replay", str(bag), "--gt-scan-topic", "/scan", *JOINTS, *GEO, "--sensor-pose", "35,0,0"]
    d = json.loads(run([*cmd, "--method", "exact", "--json"]))
    true_emax = truth_emax(drives, DIRECTIONS)
    assert true_emax > 0.3  # return errors of several hundred mm before calibration
    assert abs(d["before"]["emax_syst_mm"] - true_emax * 1e3) < 5.0
    assert abs(d["Ed"] - ED) < 5e-4
    assert abs(d["Eb"] - EB) < 3e-3
    assert [r["direction"] for r in d["runs"]] == list(DIRECTIONS)
    assert d["after"]["emax_syst_mm"] < 0.1 * d["before"]["emax_syst_mm"]
    assert d["warnings"] == []
    # every run measured, each against its own start, to a few mm and a tenth of a degree
    block = d["scan_truth"]
    assert block["sensor_pose"] == {"x_mm": 35.0, "y_mm": 0.0, "yaw_deg": 0.0}
    assert block["sensor_pose_source"] == "given"
    assert block["runs_dropped"] == 0
    true, odo = truth_of(drives)
    for r, t, o in zip(block["runs"], true, odo):
        p = r["displacement"]
        assert math.hypot(p["x_mm"] - t[0] * 1e3, p["y_mm"] - t[1] * 1e3) < 4.0
        assert abs(math.radians(p["theta_deg"]) - (t[2] + 2 * math.pi * round((o[2] - t[2]) / (2 * math.pi)))) < 2e-3
        assert (
            r["converged"]
            and r["end_scan_s"] >= r["motion_s"][1]
            and r["start_scan_s"] + 0.1 <= r["motion_s"][0] + 1e-6
        )
    # bf: the paper's correction from the same runs, a smaller but real improvement
    b = json.loads(run([*cmd, "--method", "bf", "--json"]))
    assert b["before"]["emax_syst_mm"] == pytest.approx(d["before"]["emax_syst_mm"], rel=1e-9)
    assert b["after"]["emax_syst_mm"] < 0.5 * b["before"]["emax_syst_mm"]


def test_mounting_pose_matters(put_back):
    """The lidar taken at the robot's centre (no pose, no /tf_static): a warning, and the
    displacements are those of a point 35 mm ahead of the axle."""
    drives, bag = put_back
    d = json.loads(run(["replay", str(bag), "--gt-scan-topic", "/scan", *JOINTS, *GEO, "--json", "--no-heldout"]))
    assert any("--sensor-pose" in w and "centre" in w for w in d["warnings"])
    assert d["scan_truth"]["sensor_pose_source"] == "none"
    true, _ = truth_of(drives)
    sensor_true = np.array(
        [between(compose(dr.true_pose[0], [0.035, 0, 0]), compose(dr.true_pose[-1], [0.035, 0, 0])) for dr in drives]
    )
    got = np.array([[r["displacement"]["x_mm"], r["displacement"]["y_mm"]] for r in d["scan_truth"]["runs"]]) * 1e-3
    assert np.max(np.hypot(*(got - sensor_true[:, :2]).T)) < 4e-3
    assert np.max(np.hypot(*(got - true[:, :2]).T)) > 5e-3  # the robot centre moved otherwise


def test_pose_from_tf_static_and_from_a_selfcal_json(put_back, tmp_path):
    drives, _ = put_back
    bag = write_drive_bag(concatenate_drives(drives[:1] + drives[3:4]), tmp_path / "tf", odom=False)
    d = json.loads(run(["replay", str(bag), "--gt-scan-topic", "/scan", *JOINTS, *GEO, "--json", "--no-heldout"]))
    assert d["scan_truth"]["sensor_pose_source"] == "/tf_static base_link -> laser"
    assert d["scan_truth"]["sensor_pose"]["x_mm"] == pytest.approx(35.0)
    cal = tmp_path / "selfcal.json"
    cal.write_text(json.dumps({"sensor_pose": {"x_mm": 35.0, "y_mm": 0.0, "yaw_deg": 0.0}}))
    e = json.loads(
        run(
            [
                "replay",
                str(bag),
                "--gt-scan-topic",
                "/scan",
                *JOINTS,
                *GEO,
                "--sensor-pose",
                str(cal),
                "--json",
                "--no-heldout",
            ]
        )
    )
    assert e["scan_truth"]["sensor_pose_source"] == str(cal)
    assert e["before"]["emax_syst_mm"] == pytest.approx(d["before"]["emax_syst_mm"], abs=1e-6)
    true, _ = truth_of([drives[0], drives[3]])
    got = [[r["displacement"]["x_mm"], r["displacement"]["y_mm"]] for r in e["scan_truth"]["runs"]]
    assert np.max(np.hypot(*(np.array(got) * 1e-3 - true[:, :2]).T)) < 4e-3


def test_robot_left_where_it_stopped(tmp_path):
    """Not put back: each run starts where the one before stopped; each is measured against its own start."""
    directions = ("cw", "ccw", "cw", "ccw")
    prog = [square_drive(d) for d in directions]
    from umbmark.model.drive import Program

    whole = simulate_drive(
        Program(tuple(c for p in prog for c in p.commands)), ROBOT, start_pose=START, noise=NOISE, seed=3
    )
    bag = write_drive_bag(whole, tmp_path / "continuous", odom=False, tf_static=False)
    d = json.loads(
        run(
            [
                "replay",
                str(bag),
                "--gt-scan-topic",
                "/scan",
                *JOINTS,
                *GEO,
                "--sensor-pose",
                "35,0,0",
                "--json",
                "--no-heldout",
            ]
        )
    )
    # the true end of each run: the pose where the wheels stop, in the pose where they started
    n = [round(p.duration_s * 100) for p in prog]
    ends = np.cumsum(n)
    starts = ends - n
    true = np.array([between(whole.true_pose[a], whole.true_pose[b]) for a, b in zip(starts, ends)])
    got = np.array([[r["displacement"]["x_mm"], r["displacement"]["y_mm"]] for r in d["scan_truth"]["runs"]]) * 1e-3
    assert len(got) == 4
    assert np.max(np.hypot(*(got - true[:, :2]).T)) < 4e-3
    assert np.max(np.hypot(*true[:, :2].T)) > 0.1


def test_failed_registration_drops_the_run_with_a_warning(put_back, tmp_path):
    """The scans at rest after run 2 see almost nothing: that run is dropped and named, the rest are used."""
    drives, _ = put_back
    blind = drives[1]
    ranges = blind.ranges_m.copy()
    rest = blind.scan_t_s >= blind.duration_s - 3.0 - 1e-6  # the rest after the run
    keep = np.zeros(ranges.shape[1], dtype=bool)
    keep[::30] = True
    ranges[np.ix_(rest, ~keep)] = np.inf
    import dataclasses

    drives = [drives[0], dataclasses.replace(blind, ranges_m=ranges), *drives[2:]]
    bag = write_drive_bag(concatenate_drives(drives), tmp_path / "blind", odom=False, tf_static=False)
    d = json.loads(
        run(
            [
                "replay",
                str(bag),
                "--gt-scan-topic",
                "/scan",
                *JOINTS,
                *GEO,
                "--sensor-pose",
                "35,0,0",
                "--method",
                "exact",
                "--json",
            ]
        )
    )
    runs = d["scan_truth"]["runs"]
    failed = [r for r in runs if not r["converged"]]
    assert len(failed) == 1 and failed[0]["displacement"] is None and failed[0]["reason"]
    assert failed[0]["run"] == runs[1]["run"]
    assert d["scan_truth"]["runs_dropped"] == 1
    assert any(failed[0]["run"] in w and "dropped" in w for w in d["warnings"])
    assert len(d["runs"]) == 5
    assert abs(d["Ed"] - ED) < 5e-4 and abs(d["Eb"] - EB) < 3e-3


def test_bad_options_are_one_line(put_back, tmp_path):
    bag = str(put_back[1])
    base = ["replay", bag, "--gt-scan-topic", "/scan", *JOINTS, *GEO]
    assert "--sensor-pose" in run([*base, "--sensor-pose", "35,0"], code=2)
    assert "--sensor-pose" in run([*base, "--sensor-pose", str(tmp_path / "missing.json")], code=2)
    bad = tmp_path / "bad.json"
    bad.write_text('{"Ed": 1.0}')
    assert "sensor_pose" in run([*base, "--sensor-pose", str(bad)], code=2)
    line = run(["replay", bag, "--gt-scan-topic", "/laser", *JOINTS, *GEO], code=2)
    assert "/laser" in line and "/scan" in line  # the topics the bag has
    line = run([*base, "--gt-topic", "/ground_truth"], code=2)
    assert "--gt-scan-topic" in line
    line = run(["replay", bag, "--sensor-pose", "35,0,0", *JOINTS, *GEO], code=2)
    assert "--gt-scan-topic" in line


def test_parse_sensor_pose(tmp_path):
    assert parse_sensor_pose("35,-10,90") == ((0.035, -0.01, math.pi / 2), "given")
    f = tmp_path / "cal.json"
    f.write_text(json.dumps({"sensor_pose": {"x_mm": 120.0, "y_mm": -40.0, "yaw_deg": 3.0}}))
    assert read_sensor_pose(f) == pytest.approx((0.12, -0.04, math.radians(3.0)))
    for text in ("1,2", "a,b,c", "1,2,nan"):
        with pytest.raises(InputError, match="sensor_pose"):
            parse_sensor_pose(text)


poses = st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-math.pi, math.pi)).map(np.array)


@settings(max_examples=60, deadline=None)
@given(poses, poses, st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-math.pi, math.pi)).map(np.array))
def test_sensor_to_robot_displacement(a, b, mount):
    """The robot's displacement from the sensor's: the sensor at robot pose x mount."""
    sensor = between(compose(a, mount), compose(b, mount))
    want = between(a, b)
    got = robot_displacement(sensor, mount)
    assert np.allclose(got[:2], want[:2], atol=1e-9)
    assert abs(math.remainder(got[2] - want[2], 2 * math.pi)) < 1e-9


@pytest.mark.parametrize("ed, eb", [(1.01, 1.08), (0.99, 0.93)])
def test_return_errors_of_a_metre_and_forty_degrees(tmp_path, ed, eb):
    """Large return errors (up to 1 m and 40 deg) are found by the coarse stage."""
    from umbmark.io.load import LogOptions, load_logs
    from umbmark.realrobot.scan_truth import attach_scan_truth

    robot = SimRobot(ROBOT.nominal, ErrorParams(ed=ed, eb=eb), ROBOT.sensor_pose, ROBOT.lidar)
    drives = [simulate_drive(square_drive(d), robot, start_pose=START, seed=1 + i) for i, d in enumerate(("cw", "ccw"))]
    bag = write_drive_bag(concatenate_drives(drives), tmp_path / "big", odom=False, tf_static=False)
    wheels = WheelSource(joints=("left_wheel_joint", "right_wheel_joint"))
    opts = LogOptions(0.15, 0.15, 0.34, wheels=wheels, split_stops=True, side_m=2.0)
    ds = load_logs([bag], "bag", opts)
    sets, truth = attach_scan_truth(
        [ds], "/scan", sensor_pose=(0.035, 0, 0), wheels=WheelSource(joints=JOINTS[1].split(","))
    )
    true, odo = truth_of(drives)
    assert (
        np.max(np.hypot(*true[:, :2].T)) > 0.5
        and np.max(np.abs(np.degrees(np.remainder(true[:, 2] + np.pi, 2 * np.pi) - np.pi))) > 30
    )
    got = np.array([r.displacement for r in truth.runs])
    assert np.max(np.hypot(*(got[:, :2] - true[:, :2]).T)) < 4e-3
    assert (
        np.max(np.abs(got[:, 2] - odo[:, 2] - np.remainder(true[:, 2] - odo[:, 2] + np.pi, 2 * np.pi) + np.pi)) < 2e-3
    )
    assert [r.gt_end.tolist() for r in sets[0].runs] == got.tolist()


def test_odometry_as_the_wheels(put_back, tmp_path):
    """The robot's nav_msgs/Odometry instead of the joint states: the same runs, the same truth."""
    drives, _ = put_back
    bag = write_drive_bag(concatenate_drives(drives), tmp_path / "odom", odom=True, tf_static=False)
    geo = ["--odom-topic", "/odom", *GEO, "--sensor-pose", "35,0,0"]
    d = json.loads(run(["replay", str(bag), "--gt-scan-topic", "/scan", *geo, "--method", "exact", "--json"]))
    assert abs(d["before"]["emax_syst_mm"] - truth_emax(drives, DIRECTIONS) * 1e3) < 5.0
    assert abs(d["Ed"] - ED) < 5e-4 and abs(d["Eb"] - EB) < 3e-3
    text = run(["replay", str(bag), "--gt-scan-topic", "/scan", *geo, "--no-heldout"])
    assert "lidar ground truth (/scan): 6 of 6 runs measured" in text and "(given)" in text


def test_one_bag_per_run(put_back, tmp_path):
    """Six one-run bags given together are one test; each run measured in its own bag, the
    mounting pose from their /tf_static."""
    drives, _ = put_back
    bags = [str(write_drive_bag(d, tmp_path / f"run{i + 1}", odom=False)) for i, d in enumerate(drives)]
    geo = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--side-mm", "2000"]
    d = json.loads(run(["replay", *bags, "--gt-scan-topic", "/scan", *JOINTS, *geo, "--method", "exact", "--json"]))
    assert [r["source"] for r in d["scan_truth"]["runs"]] == bags
    assert d["scan_truth"]["sensor_pose_source"] == "/tf_static base_link -> laser"
    assert abs(d["before"]["emax_syst_mm"] - truth_emax(drives, DIRECTIONS) * 1e3) < 5.0
    assert abs(d["Ed"] - ED) < 5e-4 and abs(d["Eb"] - EB) < 3e-3
