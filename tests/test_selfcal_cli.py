"""`umbmark selfcal`: its JSON and table, the export of its result (diff_drive_controller
multipliers, the lidar's URDF origin and static_transform_publisher line), the history record,
and bad input (one line on stderr, exit status 2, the bag's topics named)."""

import dataclasses
import json
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
from umbmark.cli import main  # noqa: E402
from umbmark.io.rosbag_write import EPOCH_S, write_drive_bag  # noqa: E402
from umbmark.model.drive import Command, SimRobot, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402

ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.008, eb=1.02, es=1.0),
    sensor_pose=SensorPose(0.10, 0.02, math.radians(-3.0)),
    lidar=Lidar(n_beams=180, range_noise_m=0.003),
)
GEO = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]
JOINTS = ["--joints", "left_wheel_joint,right_wheel_joint"]
PINNED = [
    "wheel_diameter_left_mm",
    "wheel_diameter_right_mm",
    "wheelbase_mm",
    "Ed",
    "Eb",
    "sensor_pose",
    "intervals_used",
    "intervals_rejected",
    "warnings",
    "scans_read",
    "pairs_matched",
    "pairs_failed",
    "keyframe_rule",
    "time_span_s",
]


@pytest.fixture(scope="module")
def log():
    return simulate_drive(mixed_program(60.0, seed=2, robot=ROBOT), ROBOT, seed=3)


@pytest.fixture(scope="module")
def bag(log, tmp_path_factory):
    return write_drive_bag(log, tmp_path_factory.mktemp("cli") / "drive", storage="mcap", odom=True)


@pytest.fixture(scope="module")
def result(bag, tmp_path_factory):
    """The JSON of `umbmark selfcal BAG --json --save`, and the saved file."""
    save = tmp_path_factory.mktemp("save") / "selfcal.json"
    out = run(["selfcal", str(bag), *JOINTS, *GEO, "--save", str(save), "--json"])
    return json.loads(out), save


def run(args, code=0):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    assert rc == code, (rc, err.getvalue(), out.getvalue()[-500:])
    if code == 0:
        assert err.getvalue() == ""  # no progress bar off a terminal
        return out.getvalue()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("umbmark: error: ") and "Traceback" not in err.getvalue()
    return lines[0]


def test_json_has_the_pinned_keys(result, log):
    d, save = result
    for key in PINNED:
        assert key in d, key
    for key in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm", "Ed", "Eb"):
        lo, hi = d[key + "_ci95"]
        assert lo < d[key] < hi
    for key in ("x_mm", "y_mm", "yaw_deg"):
        lo, hi = d["sensor_pose"][key + "_ci95"]
        assert lo < d["sensor_pose"][key] < hi
    assert d["sensor_pose"]["x_mm"] == pytest.approx(100.0, abs=5.0)
    assert d["sensor_pose"]["yaw_deg"] == pytest.approx(-3.0, abs=0.3)
    assert d["Ed"] == pytest.approx(1.008, abs=0.001)
    assert d["c_left"] == pytest.approx(d["wheel_diameter_left_mm"] / 150.0)
    assert d["scans_read"] == len(log.scan_t_s) and d["pairs_failed"] == 0
    assert (
        d["method"] == "selfcal"
        and d["keyframe_rule"]["description"] == "every 100 mm or 10 deg or 2 s, at least 0.5 s apart"
    )
    assert json.loads(save.read_text()) == d


def test_ros_units_give_the_same(bag, result):
    d, _ = result
    out = json.loads(
        run(["selfcal", str(bag), *JOINTS, "--wheel-radius-m", "0.075", "--wheel-separation-m", "0.34", "--json"])
    )
    assert out["wheelbase_mm"] == pytest.approx(d["wheelbase_mm"], rel=1e-12)
    for key in ("x_mm", "y_mm", "yaw_deg"):
        assert out["sensor_pose"][key] == pytest.approx(d["sensor_pose"][key], rel=1e-12)


def test_table_explains_and_ends_with_the_export(bag, result):
    d, _ = result
    text = run(["selfcal", str(bag), *JOINTS, *GEO])
    assert f"{d['scans_read']} scans on /scan (frame laser)" in text
    assert "D_L [mm]" in text and "lidar yaw [deg]" in text and "95 % interval" in text
    assert f"{d['wheel_diameter_left_mm']:.3f}" in text and f"{d['sensor_pose']['x_mm']:.2f}" in text
    assert "x forward, y left" in text
    last = text.strip().splitlines()[-3:]
    assert last[0].strip().startswith(f"umbmark selfcal {bag} --joints left_wheel_joint,right_wheel_joint")
    assert last[0].strip().endswith("--save selfcal.json")
    assert last[1].strip() == "umbmark export selfcal.json --format ros2 --out params.yaml"
    assert last[2].strip() == "umbmark export selfcal.json --format urdf"
    assert run(["-q", "selfcal", str(bag), *JOINTS, *GEO]) == ""


def test_export_of_a_selfcal_result(result, tmp_path):
    d, save = result
    sp = d["sensor_pose"]
    x, y, yaw = sp["x_mm"] / 1e3, sp["y_mm"] / 1e3, math.radians(sp["yaw_deg"])
    ros2 = run(["export", str(save), "--format", "ros2"])
    import yaml

    params = yaml.safe_load(ros2)["diff_drive_controller"]["ros__parameters"]
    assert params["left_wheel_radius_multiplier"] == pytest.approx(d["wheel_diameter_left_mm"] / 150.0, rel=1e-12)
    assert params["right_wheel_radius_multiplier"] == pytest.approx(d["wheel_diameter_right_mm"] / 150.0, rel=1e-12)
    assert params["wheel_separation_multiplier"] == pytest.approx(d["Eb"], rel=1e-12)
    origin = f'<origin xyz="{x:.6f} {y:.6f} 0" rpy="0 0 {yaw:.6f}"/>'
    assert f"#   {origin}\n" in ros2
    tf2 = (
        f"ros2 run tf2_ros static_transform_publisher --x {x:.6f} --y {y:.6f} --z 0 --roll 0 --pitch 0 "
        f"--yaw {yaw:.6f} --frame-id base_link --child-frame-id laser"
    )
    assert f"#   {tf2}\n" in ros2
    urdf = run(["export", str(save), "--format", "urdf"])
    assert urdf.splitlines()[1] == origin and urdf.startswith("<!-- umbmark calibration")
    tf = run(["export", str(save), "--format", "tf"])
    assert tf.splitlines()[-1] == tf2
    ros1 = run(["export", str(save), "--format", "ros1", "--left-multiplier", "1.01"])
    p1 = yaml.safe_load(ros1)["diff_drive_controller"]
    assert p1["left_wheel_radius_multiplier"] == pytest.approx(1.01 * d["c_left"], rel=1e-12)
    assert f"rosrun tf2_ros static_transform_publisher {x:.6f} {y:.6f} 0 {yaw:.6f} 0 0 base_link laser" in ros1
    j = json.loads(run(["export", str(save), "--format", "json"]))
    assert j["sensor_pose"]["x_mm"] == pytest.approx(sp["x_mm"], rel=1e-12) and j["diameter_left_mm"] == pytest.approx(
        d["wheel_diameter_left_mm"]
    )
    out = tmp_path / "lidar.urdf"
    run(["export", str(save), "--format", "urdf", "--out", str(out)])
    assert out.read_text() == urdf


def test_urdf_export_needs_a_sensor_pose():
    line = run(["export", "--c-left", "1", "--c-right", "1.01", "--eb", "1", "--format", "urdf"], code=2)
    assert "lidar's mounting pose" in line and "umbmark selfcal" in line


def test_record_in_the_history(bag, tmp_path):
    db = tmp_path / "h.sqlite"
    d = json.loads(run(["selfcal", str(bag), *JOINTS, *GEO, "--robot", "r1", "--record", "--db", str(db), "--json"]))
    assert d["history"]["robot"] == "r1"
    h = json.loads(run(["history", "r1", "--db", str(db), "--json"]))
    (rec,) = h["records"]
    assert rec["method"] == "selfcal" and rec["Ed"] == pytest.approx(d["Ed"])
    assert rec["wheelbase_mm"] == pytest.approx(d["wheelbase_mm"])
    assert rec["parameters"]["sensor_pose"]["x_mm"] == pytest.approx(d["sensor_pose"]["x_mm"])
    assert rec["input_sha256"]


def test_export_records_a_selfcal_result(result, tmp_path):
    d, save = result
    db = tmp_path / "h.sqlite"
    out = tmp_path / "lidar.urdf"
    run(["export", str(save), "--format", "urdf", "--out", str(out), "--robot", "r2", "--record", "--db", str(db)])
    assert "<origin" in out.read_text()
    (rec,) = json.loads(run(["history", "r2", "--db", str(db), "--json"]))["records"]
    assert rec["kind"] == "selfcal" and rec["Eb"] == pytest.approx(d["Eb"])
    assert rec["parameters"]["sensor_pose"]["yaw_deg"] == pytest.approx(d["sensor_pose"]["yaw_deg"])
    # a calibration that is not a self-calibration is recorded by the command that made it
    other = tmp_path / "replay.json"
    other.write_text(json.dumps({"method": "bf", "Ed": 1.0, "Eb": 1.0, "c_left": 1.0, "c_right": 1.0}))
    err = run(["export", str(other), "--format", "ros2", "--robot", "r2", "--record", "--db", str(db)], code=2)
    assert "replay, analyze or calibrate" in err
    assert len(json.loads(run(["history", "r2", "--db", str(db), "--json"]))["records"]) == 1


# -- bad input ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def short():
    return simulate_drive(mixed_program(8.0, seed=4, robot=ROBOT), ROBOT, seed=5)


def test_topic_errors_list_the_bags_topics(bag):
    topics = "/joint_states (JointState), /odom (Odometry), /scan (LaserScan), /tf_static (TFMessage)"
    line = run(["selfcal", str(bag), *GEO], code=2)
    assert "give the wheel data: the wheel joints (--joints)" in line and "--odom-topic" in line and topics in line
    line = run(["selfcal", str(bag), *JOINTS, *GEO, "--scan-topic", "/laser"], code=2)
    assert "no topic '/laser' for the laser scans" in line and topics in line
    line = run(["selfcal", str(bag), *JOINTS, *GEO, "--scan-topic", "/odom"], code=2)
    assert "topic /odom has type nav_msgs/msg/Odometry, not LaserScan" in line and topics in line
    line = run(["selfcal", str(bag), "--odom-topic", "/odometry/filtered", *GEO], code=2)
    assert "no topic '/odometry/filtered' for the wheel odometry" in line and topics in line
    line = run(["selfcal", str(bag), "--joints", "wheel_l,wheel_r", *GEO], code=2)
    assert "names both joints 'wheel_l' and 'wheel_r' (joints there: left_wheel_joint, right_wheel_joint;" in line
    line = run(["selfcal", str(bag), *JOINTS, "--odom-topic", "/odom", *GEO], code=2)
    assert "not several" in line


def test_scans_in_another_frame(bag):
    line = run(["selfcal", str(bag), *JOINTS, *GEO, "--scan-frame", "base_scan"], code=2)
    assert "the scans on /scan are in frame 'laser', not --scan-frame 'base_scan'" in line


def test_no_motion(tmp_path):
    log = simulate_drive([Command(10.0)], ROBOT, seed=1)
    path = write_drive_bag(log, tmp_path / "still", storage="mcap")
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "the wheels do not move between the scans" in line


def test_all_infinite_scans(tmp_path, short):
    blind = dataclasses.replace(short, ranges_m=np.full_like(short.ranges_m, np.inf))
    path = write_drive_bag(blind, tmp_path / "blind", storage="sqlite3")
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "every range of the 81 scans on /scan is infinite" in line


def test_no_overlap_in_time(tmp_path, short):
    late = dataclasses.replace(short, t_s=short.t_s + 1000.0)
    path = write_drive_bag(late, tmp_path / "late", storage="sqlite3", odom=False)
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "the scans (" in line and "and the wheel data (" in line and "do not overlap in time" in line
    assert f"{EPOCH_S + 1000:.3f}" in line


def test_too_few_intervals(tmp_path):
    short = simulate_drive(mixed_program(0.6, seed=4, robot=ROBOT), ROBOT, seed=5)
    path = write_drive_bag(short, tmp_path / "tiny", storage="sqlite3", odom=False)
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "usable intervals (fewer than 10)" in line and "drive longer" in line


def _write_ros2(path, scans, joints, positions=True):
    """A ROS 2 bag with LaserScan messages ``(header_s, bag_s)`` and JointState ``(t_s, left, right)``
    (without positions, only velocities, when not ``positions``)."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types

    def header(t, frame):
        sec = int(t)
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9))), frame_id=frame
        )

    with Writer(path, version=9) as w:
        cs = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        cj = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for t, left, right in joints:
            js = T["sensor_msgs/msg/JointState"](
                header=header(t, ""),
                name=["left_wheel_joint", "right_wheel_joint"],
                position=np.array([left, right] if positions else [], float),
                velocity=np.array([] if positions else [0.1, 0.1], float),
                effort=np.array([], float),
            )
            w.write(cj, int(t * 1e9), ts.serialize_cdr(js, "sensor_msgs/msg/JointState"))
        for stamp, t in scans:
            msg = T["sensor_msgs/msg/LaserScan"](
                header=header(stamp, "laser"),
                angle_min=-math.pi,
                angle_max=math.pi - 2 * math.pi / 90,
                angle_increment=2 * math.pi / 90,
                time_increment=0.0,
                scan_time=0.1,
                range_min=0.05,
                range_max=10.0,
                ranges=np.full(90, 2.0, dtype=np.float32),
                intensities=np.array([], dtype=np.float32),
            )
            w.write(cs, int(t * 1e9), ts.serialize_cdr(msg, "sensor_msgs/msg/LaserScan"))


def test_stamps_that_go_backwards(tmp_path):
    t0 = 1_700_000_000.0
    stamps = [t0 + 0.1 * k for k in range(20)]
    stamps[7], stamps[8] = stamps[8], stamps[7]
    path = tmp_path / "back"
    _write_ros2(
        path,
        [(s, t0 + 0.1 * k) for k, s in enumerate(stamps)],
        [(t0 + 0.01 * k, 0.01 * k, 0.02 * k) for k in range(200)],
    )
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert (
        "the stamps of the scans on /scan go backwards at message 9: 1700000000.700000 s after 1700000000.800000 s"
        in line
    )


def test_geometry_and_input_flags(bag, tmp_path, result):
    line = run(
        [
            "selfcal",
            str(bag),
            *JOINTS,
            "--wheel-diameter-mm",
            "150",
            "--wheel-radius-m",
            "0.075",
            "--wheelbase-mm",
            "340",
        ],
        code=2,
    )
    assert "one of them" in line
    line = run(["selfcal", str(bag), *JOINTS, "--wheelbase-mm", "340"], code=2)
    assert "--wheel-diameter-mm D or --wheel-radius-m R" in line
    line = run(["selfcal", str(bag), *JOINTS, *GEO, "--sensor-pose", "100,20"], code=2)
    assert "--sensor-pose needs 3 numbers X_MM,Y_MM,YAW_DEG" in line
    line = run(["selfcal", str(bag), *JOINTS, *GEO, "--keyframe-mm", "-1"], code=2)
    assert "--keyframe-mm must be a number >= 0" in line
    csv = tmp_path / "iv.csv"
    csv.write_text("dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad\n0.1,0.1,0.1,0.01,0,0\n")
    line = run(["selfcal", str(csv), *JOINTS, *GEO], code=2)
    assert "--joints reads bags; the inputs are intervals files" in line
    line = run(["selfcal", str(csv), *GEO], code=2)
    assert "at least 3 intervals" in line
    line = run(["selfcal", str(tmp_path / "missing.bag"), *JOINTS, *GEO], code=2)
    assert "missing.bag: not found" in line


def test_sensor_pose_start_and_keyframe_options(bag, result):
    """A given start pose (far from the true one) and keyframes by distance and angle: the same
    lidar pose, and the options in the next-step command."""
    d, _ = result
    out = json.loads(
        run(
            [
                "selfcal",
                str(bag),
                *JOINTS,
                *GEO,
                "--sensor-pose",
                "0,0,0",
                "--keyframe-mm",
                "40",
                "--keyframe-deg",
                "4",
                "--json",
            ]
        )
    )
    assert out["nominal_sensor_pose"]["source"] == "given"
    assert out["keyframe_rule"]["description"] == "every 40 mm or 4 deg or 2 s, at least 0.5 s apart"
    assert out["sensor_pose"]["x_mm"] == pytest.approx(d["sensor_pose"]["x_mm"], abs=3.0)
    assert out["sensor_pose"]["yaw_deg"] == pytest.approx(d["sensor_pose"]["yaw_deg"], abs=0.2)
    text = run(["selfcal", str(bag), *JOINTS, *GEO, "--keyframe-mm", "40", "--keyframe-deg", "4"])
    assert "--keyframe-mm 40 --keyframe-deg 4" in text


def test_keyframes_default_to_the_library_s_and_every_scan_is_an_option(bag, result):
    """The command's keyframe defaults are the library's DEFAULT_KEYFRAMES; all four at 0 is every
    scan (and is shown in the next-step command)."""
    from umbmark.realrobot.selfcal import DEFAULT_KEYFRAMES

    d, _ = result
    assert d["keyframe_rule"] == DEFAULT_KEYFRAMES.to_dict()
    every = ["--keyframe-mm", "0", "--keyframe-deg", "0", "--keyframe-s", "0", "--keyframe-min-s", "0"]
    out = json.loads(run(["selfcal", str(bag), *JOINTS, *GEO, *every, "--json"]))
    assert out["keyframe_rule"]["description"] == "every scan"
    assert out["pairs_matched"] + out["intervals_still"] == out["scans_read"] - 1
    text = run(["selfcal", str(bag), *JOINTS, *GEO, *every])
    assert "--keyframe-mm 0 --keyframe-deg 0 --keyframe-s 0 --keyframe-min-s 0" in text


def test_a_wrong_urdf_pose_is_pointed_out(log, tmp_path):
    """/tf_static says the lidar sits at the robot's centre, the scans say 100 mm ahead: a warning."""
    wrong = dataclasses.replace(log, sensor_pose=SensorPose(0.0, 0.0, 0.0))
    path = write_drive_bag(wrong, tmp_path / "wrong_tf", storage="sqlite3", odom=False)
    d = json.loads(run(["selfcal", str(path), *JOINTS, *GEO, "--json"]))
    assert d["sensor_pose"]["x_mm"] == pytest.approx(100.0, abs=5.0)
    (w,) = [w for w in d["warnings"] if "differs from" in w]
    assert w.startswith("the estimated sensor pose differs from /tf_static base_link -> laser of wrong_tf by 10")
    assert "check the URDF" in w


def test_progress_bars_on_a_terminal_only(bag, monkeypatch, capsys):
    """On a terminal the reading and the matching draw bars on stderr; --json and --quiet draw none."""
    import io

    from rich.console import Console

    from umbmark.cli import progress as prog

    buf = io.StringIO()
    monkeypatch.setattr(prog, "_console", lambda: Console(file=buf, force_terminal=True, width=100))
    assert main(["selfcal", str(bag), *JOINTS, *GEO]) == 0
    assert "reading drive" in buf.getvalue() and "matching scans of drive" in buf.getvalue()
    for extra in (["--json"], []):
        buf.seek(0)
        buf.truncate()
        args = ["selfcal", str(bag), *JOINTS, *GEO, *extra]
        assert main(args if extra else ["--quiet", *args]) == 0
        assert buf.getvalue() == ""
    out = capsys.readouterr()
    assert out.err == ""


def test_joint_states_without_positions(tmp_path):
    t0 = 1_700_000_000.0
    path = tmp_path / "velocities"
    _write_ros2(
        path,
        [(t0 + 0.1 * k, t0 + 0.1 * k) for k in range(20)],
        [(t0 + 0.01 * k, 0.0, 0.0) for k in range(200)],
        positions=False,
    )
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "name the joints 'left_wheel_joint' and 'right_wheel_joint' but carry no positions" in line
    assert "--odom-topic" in line


def test_a_scan_topic_without_messages(tmp_path):
    t0 = 1_700_000_000.0
    path = tmp_path / "no_scans"
    _write_ros2(path, [], [(t0 + 0.01 * k, 0.01 * k, 0.02 * k) for k in range(200)])
    line = run(["selfcal", str(path), *JOINTS, *GEO], code=2)
    assert "topic /scan holds no messages for the laser scans" in line
    assert "(topics: /joint_states (JointState), /scan (LaserScan))" in line


def test_lidar_height_from_the_command_line(result, tmp_path):
    """Without /tf_static the calibration knows no lidar height: urdf and tf warn, and
    --sensor-z-mm sets it; with /tf_static (this bag) there is no warning."""
    d, save = result
    urdf = run(["export", str(save), "--format", "urdf", "--sensor-z-mm", "250"])
    assert ' 0.25" rpy=' in urdf.splitlines()[1]
    nom = {**d["nominal_sensor_pose"], "source": "none", "z_mm": 0.0}
    blind = tmp_path / "no_tf.json"
    blind.write_text(json.dumps({**d, "nominal_sensor_pose": nom}))
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(["export", str(blind), "--format", "tf"]) == 0
    assert "warning: the lidar's height is 0 mm" in err.getvalue() and "--sensor-z-mm" in err.getvalue()
    assert "--z 0.25 " in run(["export", str(blind), "--format", "tf", "--sensor-z-mm", "250"])
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(["export", str(save), "--format", "tf"]) == 0
    assert "height" not in err.getvalue()
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(["export", str(save), "--format", "urdf", "--sensor-z-mm", "0.25"]) == 0
    assert "the option is in millimetres" in err.getvalue()
    line = run(["export", "--c-left", "1", "--c-right", "1", "--eb", "1", "--format", "json", "--sensor-z-mm", "5"], 2)
    assert "needs a self-calibration" in line


def test_wheel_data_jitter_printed_and_switched_off(bag, result):
    """The table shows the wheel data jitter the fit estimated (JSON wheel_jitter_ms);
    --no-wheel-jitter takes the wheel data as exact: null in the JSON, no row, and the command
    offered to save the result keeps the flag."""
    d, _ = result
    assert d["wheel_jitter_ms"] is not None and d["wheel_jitter_ms"] >= 0
    text = run(["selfcal", str(bag), *JOINTS, *GEO])
    assert "wheel data jitter [ms]" in text
    off = json.loads(run(["selfcal", str(bag), *JOINTS, *GEO, "--no-wheel-jitter", "--json"]))
    assert off["wheel_jitter_ms"] is None
    text = run(["selfcal", str(bag), *JOINTS, *GEO, "--no-wheel-jitter"])
    assert "wheel data jitter [ms]" not in text
    assert "--no-wheel-jitter" in " ".join(text.split())


def test_no_static_transform_is_said_in_words(log, tmp_path):
    """A bag without /tf_static: the matching starts from zero, and the table says so plainly."""
    bare = write_drive_bag(log, tmp_path / "bare", storage="mcap", odom=False, tf_static=False)
    text = " ".join(run(["selfcal", str(bare), *JOINTS, *GEO]).split())
    assert "(no transform to the scans' frame: zero)" in text
    assert "(none" not in text


def test_ros_sizes_in_another_unit_are_named(result):
    """export --wheel-separation-m in millimetres is refused naming the slip; a diameter given as
    --wheel-radius-m (a size a wheel can have) is warned of; the nominal sizes give neither."""
    import contextlib
    import io

    _, save = result

    def warnings(*extra, code=0):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            assert main(["export", str(save), "--format", "ros2", *extra]) == code
        return err.getvalue()

    refused = warnings("--wheel-separation-m", "340", code=2)
    assert refused.count("\n") == 1 and "given in millimetres? 340 mm is 0.34 m" in refused
    assert "a diameter given as the radius?" in warnings("--wheel-radius-m", "0.15")
    quiet = warnings("--wheel-radius-m", "0.075", "--wheel-separation-m", "0.34")
    assert "--wheel-radius-m" not in quiet and "--wheel-separation-m" not in quiet
