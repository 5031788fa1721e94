"""Checking a calibration on a real log (umbmark.realrobot.validate, umbmark validate).

A simulated drive whose truth is known: a LabMate (wheels 150 mm, wheelbase 340 mm nominal) with
E_d 1.01, E_b 1.03, E_s 0.99, its lidar 120 mm ahead, 30 mm right, turned 2 deg, while the bag's
/tf_static says 100 mm ahead, centred, straight; 90 s of straights, arcs and spins, joint states
and /odom at 100 Hz, scans at 10 Hz (4 ms after the wheel samples). The relations and the
trajectories are made from the true lidar poses. The true geometry scores scales of 1 and no
error; a geometry wrong by a known factor scores that factor. And the real MIT CSAIL log of the
SLAM benchmark: the nominal odometry's figures recomputed here in a few lines.
"""

import dataclasses
import json
import math

import numpy as np
import pytest
from conftest import REPO
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")
from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.relations import Relations, read_relations, write_relations  # noqa: E402
from umbmark.io.rosbag import read_selfcal_bag  # noqa: E402
from umbmark.io.rosbag_write import EPOCH_S, JOINT_NAMES, write_drive_bag  # noqa: E402
from umbmark.io.tum import Trajectory, format_tum, read_tum, write_tum  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.jsonutil import dumps  # noqa: E402
from umbmark.model import se2  # noqa: E402
from umbmark.model.drive import SimRobot, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.validate import (  # noqa: E402
    MIN_DISTANCE_M,
    MIN_TURN_RAD,
    OdometryFigures,
    judge,
    magnitude_scale,
    read_calibration,
    relations_from_trajectory,
    validate_log,
)

MIT = REPO / "data" / "slam2d"
ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
    sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
    lidar=Lidar(n_beams=360, range_noise_m=0.0),
)
URDF = SensorPose(0.10, 0.0, 0.0)
JOINTS = ",".join(JOINT_NAMES)
DELAY_S = 0.08


def _selfcal_json(wheels, pose, delay=None):
    """A calibration as umbmark selfcal saves it (the keys validate reads)."""
    d = {
        "method": "selfcal",
        "wheel_diameter_left_mm": wheels[0] * 1e3,
        "wheel_diameter_right_mm": wheels[1] * 1e3,
        "wheelbase_mm": wheels[2] * 1e3,
        "sensor_pose": {"x_mm": pose[0] * 1e3, "y_mm": pose[1] * 1e3, "yaw_deg": math.degrees(pose[2])},
        "nominal_wheel_diameter_mm": LABMATE.wheel_diameter_m * 1e3,
        "nominal_wheelbase_mm": LABMATE.wheelbase_m * 1e3,
        "nominal_sensor_pose": {
            "x_mm": URDF.x_m * 1e3,
            "y_mm": URDF.y_m * 1e3,
            "z_mm": 0.0,
            "roll_deg": 0.0,
            "pitch_deg": 0.0,
            "yaw_deg": 0.0,
            "source": "/tf_static base_link -> laser",
        },
    }
    if delay is not None:
        d["scan_delay"] = [{"bag": "drive.bag", "requested": f"{delay:g}", "applied_s": delay}]
    return d


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scan pairs like the benchmark's: short (0.5 and 2 s) and long (25 and 60 s)."""
    a, b = [], []
    for every, ahead in ((3, 5), (3, 20), (50, 250), (50, 600)):
        i = np.arange(0, n - ahead, every)
        a.append(i)
        b.append(i + ahead)
    return np.concatenate(a), np.concatenate(b)


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    root = tmp_path_factory.mktemp("validate")
    log = simulate_drive(mixed_program(90.0, seed=5, robot=ROBOT), ROBOT, seed=6, scan_offset_s=0.004)
    urdf_log = dataclasses.replace(log, sensor_pose=URDF)
    write_drive_bag(urdf_log, root / "drive.bag", odom=True)
    # the same drive with its scans stamped DELAY_S late
    write_drive_bag(dataclasses.replace(urdf_log, scan_t_s=log.scan_t_s + DELAY_S), root / "late.bag", odom=True)
    lidar = log.sensor_world_pose  # the true lidar poses at the scans
    stamps = EPOCH_S + log.scan_t_s
    a, b = _pairs(len(stamps))
    truth = Relations(stamps[a], stamps[b], se2.between(lidar[a], lidar[b]))
    write_relations(truth, root / "drive.relations")
    write_relations(Relations(truth.t1_s + DELAY_S, truth.t2_s + DELAY_S, truth.pose), root / "late.relations")
    # a SLAM's trajectory of the base frame, at the scans: the lidar's poses through /tf_static's pose
    base = se2.compose(lidar, se2.inverse(URDF.as_array()))
    write_tum(Trajectory(stamps, base), root / "base.tum")
    # the lidar's trajectory at the wheel samples (100 Hz, not at the scans: interpolated)
    write_tum(
        Trajectory(EPOCH_S + log.t_s, se2.compose(log.true_pose, ROBOT.sensor_pose.as_array())), root / "lidar.tum"
    )
    true, nominal = log.true_geometry, log.nominal_geometry
    wheels = (true.diameter_left_m, true.diameter_right_m, true.wheelbase_m)
    pose = tuple(ROBOT.sensor_pose.as_array())
    k = 1.03  # every size 3 % large: the lidar's relative motion 3 % long, its turns right
    cals = {
        "true": _selfcal_json(wheels, pose),
        "scaled": _selfcal_json(tuple(k * w for w in wheels), (k * pose[0], k * pose[1], pose[2])),
        "turning": _selfcal_json((wheels[0], wheels[1], wheels[2] / 1.04), pose),  # turns 4 % too much
        "nominal": _selfcal_json(
            (nominal.diameter_left_m, nominal.diameter_right_m, nominal.wheelbase_m), tuple(URDF.as_array())
        ),
        "late": _selfcal_json(wheels, pose, delay=DELAY_S),
    }
    for name, d in cals.items():
        (root / f"{name}.json").write_text(json.dumps(d))
    return root


def after(v, span=0):
    return v.spans[span].after


def before(v, span=0):
    return v.spans[span].before


def check_truth(f, tol_scale=2e-5, tol_mse=1e-8):
    assert f.distance_scale == pytest.approx(1.0, abs=tol_scale)
    assert f.turn_scale == pytest.approx(1.0, abs=tol_scale)
    assert f.short.mse_translation_m2 < tol_mse
    assert f.short.mse_rotation_rad2 < tol_mse
    assert f.long.mse_translation_m2 < 100 * tol_mse
    assert abs(f.drift_rad_per_m) < 1e-4


# -- the truth --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "wheels", [WheelSource(joints=JOINT_NAMES), WheelSource(odom_topic="/odom")], ids=["joints", "odom"]
)
def test_the_true_geometry_scores_scales_of_one_and_no_error(sim, wheels):
    v = validate_log(sim / "drive.bag", sim / "true.json", relations_path=sim / "drive.relations", wheels=wheels)
    (span,) = v.spans
    assert span.label == "whole log" and span.scans == 900
    n = len(read_relations(sim / "drive.relations"))
    assert span.before.short.count + span.before.long.count == n
    assert v.reference.unmatched == v.reference.without_wheel_data == 0
    check_truth(after(v))
    assert after(v).distance_relations > 100 and after(v).turn_relations > 50
    # the nominal odometry is off by the robot's errors, and the calibration passes every rule
    assert before(v).short.mse_translation_m2 > 1e4 * after(v).short.mse_translation_m2
    assert abs(before(v).turn_scale - 1) > 0.02
    assert [r.passed for r in span.rules] == [True] * 5
    assert v.verdict == "pass"
    assert v.nominal_sensor_pose == pytest.approx(tuple(URDF.as_array()))
    assert v.sensor_pose == pytest.approx(tuple(ROBOT.sensor_pose.as_array()))


def test_a_wrong_geometry_scores_its_known_scale(sim):
    v = validate_log(
        sim / "drive.bag",
        sim / "scaled.json",
        relations_path=sim / "drive.relations",
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert after(v).distance_scale == pytest.approx(1.03, rel=2e-5)
    assert after(v).turn_scale == pytest.approx(1.0, abs=2e-6)
    rules = {r.key: r.passed for r in v.spans[0].rules}
    assert rules["distance_scale"] is False and rules["turn_scale"] is True
    assert v.verdict == "fail"
    v = validate_log(
        sim / "drive.bag",
        sim / "turning.json",
        relations_path=sim / "drive.relations",
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert after(v).turn_scale == pytest.approx(1.04, rel=2e-6)
    # the nominal geometry against itself: the before figures, twice
    v = validate_log(
        sim / "drive.bag",
        sim / "nominal.json",
        relations_path=sim / "drive.relations",
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert after(v) == before(v)
    assert v.verdict == "pass"  # nothing worse (the scales are no farther from 1 than before)


def test_a_trajectory_of_the_base_frame_at_the_scans_and_of_the_lidar_at_its_own_stamps(sim):
    v = validate_log(
        sim / "drive.bag", sim / "true.json", reference_path=sim / "base.tum", wheels=WheelSource(joints=JOINT_NAMES)
    )
    ref = v.reference
    assert (ref.kind, ref.frame, ref.mode, ref.poses, ref.scans_with_pose) == (
        "trajectory",
        "base",
        "matched",
        900,
        900,
    )
    assert ref.unmatched == 0
    check_truth(after(v))
    assert before(v).short.count > 3000 and before(v).long.count > 1000
    assert v.verdict == "pass"
    v = validate_log(
        sim / "drive.bag",
        sim / "true.json",
        reference_path=sim / "lidar.tum",
        reference_frame="sensor",
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert (v.reference.mode, v.reference.frame) == ("interpolated", "sensor")
    check_truth(after(v), tol_mse=1e-7)
    # the same trajectory read as the base frame's is not the truth: named, not scored
    with pytest.raises(InputError, match="the trajectory looks like the sensor frame's, not the base frame's"):
        validate_log(
            sim / "drive.bag",
            sim / "true.json",
            reference_path=sim / "lidar.tum",
            wheels=WheelSource(joints=JOINT_NAMES),
        )


def test_halves_and_a_window(sim):
    v = validate_log(
        sim / "drive.bag",
        sim / "true.json",
        relations_path=sim / "drive.relations",
        halves=True,
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    first, second = v.spans
    assert (first.label, second.label) == ("first half", "second half")
    assert first.t_end_s == second.t_start_s == pytest.approx(0.5 * v.log_duration_s)
    assert first.scans + second.scans == 900
    n = len(read_relations(sim / "drive.relations"))
    counted = sum(s.before.short.count + s.before.long.count for s in v.spans)
    assert counted + v.relations_crossing == n and v.relations_crossing > 0
    for s in v.spans:
        check_truth(s.after)
    v = validate_log(
        sim / "drive.bag",
        sim / "true.json",
        relations_path=sim / "drive.relations",
        window_s=(10.0, 40.0),
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    (span,) = v.spans
    assert span.label == "window" and (span.t_start_s, span.t_end_s) == (10.0, 40.0)
    assert 300 <= span.scans <= 301
    assert v.reference.outside_window == n - span.before.short.count - span.before.long.count > 0
    check_truth(span.after)


def test_the_calibrations_scan_delay_is_applied_to_both(sim):
    rel = sim / "late.relations"
    v = validate_log(sim / "late.bag", sim / "late.json", relations_path=rel, wheels=WheelSource(joints=JOINT_NAMES))
    assert (v.scan_delay_s, v.scan_delay_source) == (DELAY_S, "calibration")
    check_truth(after(v), tol_mse=1e-7)
    assert v.reference.without_wheel_data == v.reference.unmatched == 0
    v0 = validate_log(
        sim / "late.bag",
        sim / "late.json",
        relations_path=rel,
        scan_delay_s=0.0,
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert (v0.scan_delay_s, v0.scan_delay_source) == (0.0, "given")
    assert after(v0).short.mse_rotation_rad2 > 1e3 * after(v).short.mse_rotation_rad2
    vt = validate_log(sim / "late.bag", sim / "true.json", relations_path=rel, wheels=WheelSource(joints=JOINT_NAMES))
    assert (vt.scan_delay_s, vt.scan_delay_source) == (0.0, "none")


# -- the command line -------------------------------------------------------------------------------


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_json_round_trip_through_the_command_line(sim, capsys):
    code, out, err = run(
        capsys, "validate", sim / "drive.bag", sim / "true.json", "--joints", JOINTS, "--relations",
        sim / "drive.relations", "--halves", "--json",
    )  # fmt: skip
    assert code == 0, err
    d = json.loads(out)
    v = validate_log(
        sim / "drive.bag",
        sim / "true.json",
        relations_path=sim / "drive.relations",
        halves=True,
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert d == json.loads(dumps(v.to_dict()))
    assert d["verdict"] == "pass" and [s["label"] for s in d["spans"]] == ["first half", "second half"]
    span = d["spans"][0]
    assert set(span) >= {"before", "after", "rules", "verdict", "relations_short", "relations_long"}
    assert span["after"]["distance_scale"] == pytest.approx(1.0, abs=2e-5)
    assert span["after"]["short"]["translation"]["mse_m2"] < 1e-8
    assert d["calibration"]["calibrated"]["wheelbase_mm"] == pytest.approx(340 * 1.03)
    assert d["calibration"]["sensor_pose"]["x_mm"] == pytest.approx(120.0)
    # the table
    code, out, err = run(
        capsys, "validate", sim / "drive.bag", sim / "true.json", "--joints", JOINTS, "--relations",
        sim / "drive.relations",
    )  # fmt: skip
    assert code == 0 and "short translation MSE" in out and "whole log: pass" in out and "turn scale" in out


def test_fail_on_worse_is_exit_status_3(sim, capsys):
    args = [
        "validate",
        sim / "drive.bag",
        sim / "scaled.json",
        "--joints",
        JOINTS,
        "--relations",
        sim / "drive.relations",
    ]
    code, out, _ = run(capsys, *args)
    assert code == 0 and "FAIL" in out and "whole log: fail" in out
    code, out, _ = run(capsys, *args, "--fail-on-worse", "--json")
    assert code == 3 and json.loads(out)["verdict"] == "fail"
    code, _, _ = run(capsys, *args[:2], sim / "true.json", *args[3:], "--fail-on-worse")
    assert code == 0


def test_a_self_calibration_checked_on_its_log(sim, tmp_path, capsys):
    """selfcal --save, then validate on the same drive: its estimate is within 0.3 % of the truth."""
    cal = tmp_path / "cal.json"
    code, _, err = run(
        capsys, "-q", "selfcal", sim / "drive.bag", "--joints", JOINTS, "--wheel-diameter-mm", "150",
        "--wheelbase-mm", "340", "--save", cal,
    )  # fmt: skip
    assert code == 0, err
    code, out, err = run(
        capsys, "validate", sim / "drive.bag", cal, "--joints", JOINTS, "--reference", sim / "base.tum", "--json"
    )
    assert code == 0, err
    d = json.loads(out)
    assert d["calibration"]["kind"] == "selfcal" and d["verdict"] == "pass"
    a = d["spans"][0]["after"]
    assert abs(a["distance_scale"] - 1) < 0.003 and abs(a["turn_scale"] - 1) < 0.003


def test_other_calibrations_map_to_geometries(sim, tmp_path, capsys):
    # export --format json: the calibrated sizes, the nominal ones are these over the factors
    out = tmp_path / "export.json"
    code, _, err = run(
        capsys, "-q", "export", "--c-left", "0.99", "--c-right", "1.01", "--eb", "1.05", "--wheel-diameter-mm",
        "150", "--wheelbase-mm", "340", "--format", "json", "--out", out,
    )  # fmt: skip
    assert code == 0, err
    c = read_calibration(out)
    assert c.kind == "export" and c.sensor_pose is None and c.scan_delay_s == 0
    assert (c.nominal.diameter_left_m, c.nominal.wheelbase_m) == pytest.approx((0.150, 0.340))
    assert (c.calibrated.diameter_left_m, c.calibrated.diameter_right_m) == pytest.approx((0.1485, 0.1515))
    assert c.calibrated.wheelbase_m == pytest.approx(0.357)
    # an export of a self-calibration keeps its lidar pose
    code, _, err = run(capsys, "-q", "export", sim / "true.json", "--format", "json", "--out", tmp_path / "e2.json")
    assert code == 0, err
    c = read_calibration(tmp_path / "e2.json")
    assert c.sensor_pose == pytest.approx(tuple(ROBOT.sensor_pose.as_array()))
    v = validate_log(
        sim / "drive.bag",
        tmp_path / "e2.json",
        relations_path=sim / "drive.relations",
        wheels=WheelSource(joints=JOINT_NAMES),
    )
    assert v.nominal_sensor_pose_source.startswith("/tf_static")  # the export has no nominal pose: the log's
    check_truth(after(v))
    # a replay: the factors on its nominal geometry
    code, _, err = run(
        capsys, "-q", "replay", REPO / "data" / "optiodom" / "square" / "230620202144", "--method", "lsq",
        "--no-heldout", "--save", tmp_path / "replay.json",
    )  # fmt: skip
    assert code == 0, err
    rep = json.loads((tmp_path / "replay.json").read_text())
    c = read_calibration(tmp_path / "replay.json")
    assert c.kind == "replay"
    assert c.nominal.to_dict() == pytest.approx({k: rep["nominal"][k] for k in c.nominal.to_dict()})
    assert c.calibrated.diameter_left_m * 1e3 == pytest.approx(rep["diameter_left_mm"])
    assert c.calibrated.wheelbase_m * 1e3 == pytest.approx(rep["wheelbase_corrected_mm"])
    # a nominal geometry given instead of the calibration's: used, with a warning
    c = read_calibration(sim / "true.json", wheel_diameter_m=0.152)
    true = json.loads((sim / "true.json").read_text())
    assert c.nominal.diameter_left_m == 0.152
    assert c.calibrated.diameter_left_m * 1e3 == pytest.approx(true["wheel_diameter_left_mm"])
    assert any("nominal left wheel diameter given (152 mm)" in w for w in c.warnings)


def test_a_calibration_without_its_nominal_geometry_asks_for_it(sim, tmp_path, capsys):
    runs = tmp_path / "runs.csv"
    assert main(["-q", "simulate", "--seed", "3", "--out", str(runs)]) == 0
    code, out, _ = run(capsys, "analyze", runs, "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    (tmp_path / "analyze.json").write_text(out)
    args = ["validate", sim / "drive.bag", tmp_path / "analyze.json", "--joints", JOINTS, "--relations"]
    code, _, err = run(capsys, *args, sim / "drive.relations")
    assert code == 2 and "does not hold the nominal left wheel diameter: give --wheel-diameter-mm" in err
    code, out, err = run(capsys, *args, sim / "drive.relations", "--wheel-diameter-mm", "150", "--json")
    assert code == 0, err
    assert json.loads(out)["calibration"]["kind"] == "analyze"


@pytest.fixture(scope="module")
def bad(sim, tmp_path_factory):
    """Inputs that are wrong in one way each."""
    d = tmp_path_factory.mktemp("bad")
    rel = read_relations(sim / "drive.relations")
    write_relations(Relations(rel.t1_s + 1000.0, rel.t2_s + 1000.0, rel.pose), d / "other.relations")
    small = np.abs(rel.pose[:, 2]) < math.radians(3.0)  # in degrees, still below half a turn in radians
    deg = rel.subset(small)
    write_relations(Relations(deg.t1_s, deg.t2_s, np.column_stack([deg.pose[:, :2], np.degrees(deg.pose[:, 2])])),
                    d / "small_degrees.relations")  # fmt: skip
    write_relations(Relations(rel.t1_s, rel.t2_s, np.column_stack([rel.pose[:, :2], np.degrees(rel.pose[:, 2])])),
                    d / "degrees.relations")  # fmt: skip
    sh = rel.subset(rel.span_s < 10.0)
    write_relations(Relations(sh.t1_s, sh.t2_s, np.column_stack([sh.pose[:, :2] * 1e3, sh.pose[:, 2]])),
                    d / "millimetres.relations")  # fmt: skip
    text = (sim / "base.tum").read_text().splitlines()
    seven = " ".join(text[5].split()[:4] + ["0", "0", "0.1"])
    (d / "seven.tum").write_text("\n".join(text[:5] + [seven] + text[6:]) + "\n")
    cells = text[7].split()
    (d / "unnormalised.tum").write_text("\n".join(text[:7] + [" ".join(cells[:7] + ["2"])] + text[8:]) + "\n")
    traj = Trajectory(EPOCH_S + 5000.0 + np.arange(10.0), np.zeros((10, 3)))
    (d / "other.tum").write_text(format_tum(traj))
    seconds = format_tum(Trajectory(EPOCH_S + np.arange(10.0) * 0.1, np.zeros((10, 3)))).splitlines()
    ns = [
        f"{float(r.split()[0]) * 1e9:.0f} " + " ".join(r.split()[1:]) if r and not r.startswith("#") else r
        for r in seconds
    ]
    (d / "ns.tum").write_text("\n".join(ns) + "\n")
    (d / "broken.json").write_text('{"c_left": 1,\n "c_right": }\n')
    (d / "array.json").write_text("[1, 2]\n")
    (d / "other.json").write_text('{"name": "x", "value": 3}\n')
    (d / "baginfo.json").write_text('{"bag": "b", "duration_s": 1, "messages": 3, "topics": []}\n')
    (d / "report.json").write_text('{"log": "b", "reference": {}, "calibration": {}, "spans": []}\n')
    # well formed, and meaning something else: each relation's stamps exchanged, a trajectory mirrored
    write_relations(Relations(rel.t2_s, rel.t1_s, rel.pose), d / "exchanged.relations")
    write_relations(Relations(rel.t1_s, rel.t2_s, rel.pose * [1, -1, -1]), d / "mirrored.relations")
    base = read_tum(sim / "base.tum")
    write_tum(Trajectory(base.t_s, base.pose[:, [1, 0, 2]]), d / "mirrored.tum")
    write_tum(Trajectory(base.t_s, base.pose * [1, -1, 1]), d / "y_negated.tum")
    write_tum(Trajectory(base.t_s, base.pose * [1, -1, -1]), d / "right_handed.tum")
    # calibrations with a size no robot has, or no correction makes
    true = json.loads((sim / "true.json").read_text())
    for name, key, k in (
        ("metres", "wheelbase_mm", 1e-3),
        ("huge", "wheel_diameter_left_mm", None),
        ("tripled", "wheelbase_mm", 3.0),
        ("nominal_metres", "nominal_wheel_diameter_mm", 1e-3),
    ):
        (d / f"{name}.json").write_text(json.dumps({**true, key: 1e308 if k is None else true[key] * k}))
    (d / "far_lidar.json").write_text(json.dumps({**true, "sensor_pose": {**true["sensor_pose"], "x_mm": 1e308}}))
    return d


CAL, REL = "{sim}/true.json", "{sim}/drive.relations"
BAD_CASES = {
    "missing log": (["{sim}/none.bag", CAL, "--relations", REL], "none.bag", "not found"),
    "missing calibration": (["{sim}/drive.bag", "{sim}/none.json", "--relations", REL], "none.json", "not found"),
    "missing relations": (
        ["{sim}/drive.bag", CAL, "--relations", "{sim}/none.relations"],
        "none.relations",
        "not found",
    ),
    "missing trajectory": (["{sim}/drive.bag", CAL, "--reference", "{sim}/none.tum"], "none.tum", "not found"),
    "not JSON": (["{sim}/drive.bag", "{bad}/broken.json", "--relations", REL], "broken.json:2:", "not valid JSON"),
    "a JSON array": (["{sim}/drive.bag", "{bad}/array.json", "--relations", REL], "array.json", "a JSON list"),
    "another JSON": (["{sim}/drive.bag", "{bad}/other.json", "--relations", REL], "other.json", "keys: name, value"),
    "bag-info's JSON": (["{sim}/drive.bag", "{bad}/baginfo.json", "--relations", REL], "baginfo.json", "bag-info"),
    "validate's JSON": (["{sim}/drive.bag", "{bad}/report.json", "--relations", REL], "report.json", "a report"),
    "relations of another log": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/other.relations"],
        "other.relations",
        "are these the relations of this log?",
    ),
    "relations in degrees": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/degrees.relations"],
        "degrees.relations:",
        "angles are in radians",
    ),
    "small turns in degrees": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/small_degrees.relations"],
        "small_degrees.relations",
        "look like degrees",
    ),
    "relations in millimetres": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/millimetres.relations"],
        "millimetres.relations",
        "look like millimetres",
    ),
    "a TUM file of 7 columns": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/seven.tum"],
        "seven.tum:6:",
        "has 7 fields, a TUM trajectory has 8",
    ),
    "a quaternion not normalised": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/unnormalised.tum"],
        "unnormalised.tum:8:",
        "not 1",
    ),
    "a trajectory of another log": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/other.tum"],
        "other.tum",
        "does not overlap the scans",
    ),
    "a trajectory in nanoseconds": (["{sim}/drive.bag", CAL, "--reference", "{bad}/ns.tum"], "ns.tum", "nanoseconds"),
    "a window outside the log": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--window", "100:200"],
        "drive.bag",
        "lies outside the log",
    ),
    "a window of time stamps": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--window", "1700000010:1700000020"],
        "drive.bag",
        "not time stamps",
    ),
    "a window without its end": (["{sim}/drive.bag", CAL, "--relations", REL, "--window", "10"], "--window", "START_S"),
    "a window backwards": (["{sim}/drive.bag", CAL, "--relations", REL, "--window", "20:10"], "--window", "after"),
    "two references": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--reference", "{sim}/base.tum"],
        "--relations",
        "give one reference",
    ),
    "no reference": (["{sim}/drive.bag", CAL], "--reference", "give one reference"),
    "a frame for relations": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--reference-frame", "base"],
        "--reference-frame",
        "the relations are the lidar's",
    ),
    "two wheel sizes": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--wheel-diameter-mm", "150", "--wheel-radius-m", "0.075"],
        "--wheel-diameter-mm",
        "not both",
    ),
    "a missing topic": (["{sim}/drive.bag", CAL, "--relations", REL, "--odom-topic", "/nope"], "drive.bag", "/nope"),
    "relations with their stamps exchanged": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/exchanged.relations"],
        "exchanged.relations",
        "times more as given than inverted (RMS over 593 short relations): timestamp1 and timestamp2 look exchanged",
    ),
    "a mirrored trajectory": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/mirrored.tum"],
        "mirrored.tum",
        "than made with x and y exchanged (RMS over 3528 short relations): the trajectory's x and y look exchanged",
    ),
    "a trajectory with y negated": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/y_negated.tum"],
        "y_negated.tum",
        "than made with y negated (RMS over 3528 short relations): the trajectory's y looks negated",
    ),
    "a trajectory in a frame with y to the right": (
        ["{sim}/drive.bag", CAL, "--reference", "{bad}/right_handed.tum"],
        "right_handed.tum",
        "than made mirrored back (RMS over 3528 short relations): the trajectory looks mirrored: y and the heading",
    ),
    "mirrored relations": (
        ["{sim}/drive.bag", CAL, "--relations", "{bad}/mirrored.relations"],
        "mirrored.relations",
        "than mirrored (RMS over 593 short relations): they look mirrored: y and the yaw negated",
    ),
    "a lidar 1e308 mm ahead": (
        ["{sim}/drive.bag", "{bad}/far_lidar.json", "--relations", REL],
        "far_lidar.json",
        "'sensor_pose' x_mm is 1e+308 mm: no lidar is mounted beyond 10000 mm from the robot's origin",
    ),
    "a stamp tolerance of 1e9 s": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--stamp-tolerance-s", "1e9"],
        "--stamp-tolerance-s",
        "--stamp-tolerance-s is 1e+09 s, more than half the scans' period (0.1 s)",
    ),
    "a base frame's trajectory given as the sensor's": (
        ["{sim}/drive.bag", CAL, "--reference", "{sim}/base.tum", "--reference-frame", "sensor"],
        "base.tum",
        "the trajectory looks like the base frame's, not the sensor frame's: give --reference-frame base",
    ),
    "a sensor's trajectory read as the base frame's": (
        ["{sim}/drive.bag", CAL, "--reference", "{sim}/lidar.tum"],
        "lidar.tum",
        "the trajectory looks like the sensor frame's, not the base frame's: give --reference-frame sensor",
    ),
    "a wheelbase in metres": (
        ["{sim}/drive.bag", "{bad}/metres.json", "--relations", REL],
        "metres.json",
        "'wheelbase_mm': 0.3502 mm is no wheelbase (a robot's is 20 to 10000 mm): given in metres?",
    ),
    "a nominal diameter in metres": (
        ["{sim}/drive.bag", "{bad}/nominal_metres.json", "--relations", REL],
        "nominal_metres.json",
        "'nominal_wheel_diameter_mm': 0.15 mm is no wheel's diameter",
    ),
    "a diameter of 1e308": (
        ["{sim}/drive.bag", "{bad}/huge.json", "--relations", REL],
        "huge.json",
        "'wheel_diameter_left_mm': 1e+308 mm is no wheel's diameter",
    ),
    "a wheelbase three times the nominal": (
        ["{sim}/drive.bag", "{bad}/tripled.json", "--relations", REL],
        "tripled.json",
        "the calibrated wheelbase is 3.09 times the calibration's nominal one: no calibration corrects",
    ),
    "a scan delay of 1e9 s": (
        ["{sim}/drive.bag", CAL, "--relations", REL, "--scan-delay", "1e9"],
        "--scan-delay",
        "a scan delay of 1e+09 s is longer than the log (89.9 s of scans)",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_input_is_one_line_and_exit_status_2(sim, bad, capsys, case):
    args, where, what = BAD_CASES[case]
    wheels = [] if "--odom-topic" in args else ["--joints", JOINTS]
    code, out, err = run(capsys, "validate", *[a.format(sim=sim, bad=bad) for a in args], *wheels)
    assert code == 2, (case, out, err)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert where in lines[0] and what in lines[0], lines[0]


def test_well_formed_input_that_likely_means_something_else_is_a_warning(sim, tmp_path, capsys):
    rel = read_relations(sim / "drive.relations")
    t1, t2 = np.append(rel.t1_s, rel.t1_s[0] + 0.05), np.append(rel.t2_s, rel.t2_s[0])  # between two scans
    write_relations(Relations(t1, t2, np.vstack([rel.pose, rel.pose[:1]])), tmp_path / "one_more.relations")
    base = ["validate", sim / "drive.bag", sim / "true.json", "--joints", JOINTS, "--json"]
    code, out, err = run(capsys, *base, "--relations", tmp_path / "one_more.relations")
    d = json.loads(out)
    assert code == 0 and d["reference"]["unmatched"] == 1
    assert any(f"1 of {len(rel) + 1} relations have a stamp without a scan" in w and "line" in w for w in d["warnings"])
    code, out, err = run(capsys, *base, "--relations", sim / "drive.relations", "--window", "-5:1000")
    d = json.loads(out)
    assert code == 0 and any("reaches beyond the log" in w for w in d["warnings"])
    assert d["window_s"] == [0.0, pytest.approx(d["log_duration_s"])]
    code, out, err = run(capsys, *base, "--relations", sim / "drive.relations", "--scan-delay", "50")
    d = json.loads(out)
    assert code == 0 and any("a scan delay of 50 s" in w for w in d["warnings"])
    assert d["reference"]["without_wheel_data"] > 0
    code, out, err = run(capsys, *base, "--relations", sim / "drive.relations", "--wheel-diameter-mm", "50")
    d = json.loads(out)
    assert code == 0 and any("distance scale against the relations is 0.33" in w for w in d["warnings"])
    assert any("--wheel-diameter-mm" in w for w in d["warnings"])  # flags, not the library's names


def test_the_real_relations_of_the_mit_csail_log_with_their_stamps_exchanged_are_refused(tmp_path, capsys):
    """The benchmark's own relations are taken as given (test below); exchanged, each relation
    inverted, they disagree with the robot's odometry ten times more than inverted: refused."""
    rel = read_relations(MIT / "mit-csail.relations")
    write_relations(Relations(rel.t2_s, rel.t1_s, rel.pose), tmp_path / "exchanged.relations")
    cal = tmp_path / "nominal.json"
    assert main(["-q", "export", "--c-left", "1", "--c-right", "1", "--eb", "1", "--wheel-diameter-mm", "200",
                 "--wheelbase-mm", "400", "--format", "json", "--out", str(cal)]) == 0  # fmt: skip
    code, out, err = run(capsys, "validate", MIT / "mit-csail.bag", cal, "--odom-topic", "/odom", "--relations",
                         tmp_path / "exchanged.relations")  # fmt: skip
    assert code == 2 and out == "" and "Traceback" not in err
    assert "exchanged.relations: the relations disagree with the odometry 10 times more as given than inverted" in err


# -- the maths --------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(1e-3, 1e3), min_size=1, max_size=30),
    st.floats(0.1, 10.0),
    st.lists(st.booleans(), min_size=30, max_size=30),
)
def test_magnitude_scale_of_a_scaled_reference(ref, k, signs):
    r = np.array(ref)
    p = k * r * np.where(np.array(signs[: len(r)]), 1.0, -1.0)
    assert magnitude_scale(p, r) == pytest.approx(k, rel=1e-12)
    assert math.isnan(magnitude_scale([], []))


@settings(max_examples=40, deadline=None)
@given(
    st.integers(30, 300),
    st.floats(0.05, 0.5),
    st.integers(0, 2**32 - 1),
    st.floats(1.0, 20.0),
)
def test_relations_from_a_trajectory_are_its_relative_poses(n, dt, seed, short_max_s):
    rng = np.random.default_rng(seed)
    t = 1000.0 + dt * np.arange(n)
    pose = np.cumsum(rng.normal(0, 0.1, (n, 3)), axis=0)
    rel, mode, scans = relations_from_trajectory(Trajectory(t, pose), t, short_max_s=short_max_s)
    assert (mode, scans) == ("matched", n)
    k1, k2 = (np.searchsorted(t, s) for s in (rel.t1_s, rel.t2_s))
    assert np.all(k2 > k1) and np.array_equal(t[k1], rel.t1_s) and np.array_equal(t[k2], rel.t2_s)
    assert np.allclose(rel.pose, se2.between(pose[k1], pose[k2]))
    span = rel.span_s
    assert not np.any((span >= 0.625 * short_max_s) & (span < 1.5 * short_max_s))  # short ones, long ones
    # a lidar on the robot: the relations of the lidar's poses
    lp = np.array([0.2, -0.1, 0.3])
    rel2, _, _ = relations_from_trajectory(Trajectory(t, pose), t, sensor_pose=lp, short_max_s=short_max_s)
    lidar = se2.compose(pose, lp)
    assert np.allclose(rel2.pose, se2.between(lidar[k1], lidar[k2]))


def test_the_rules():
    def figures(t_mse, r_mse, long_mse, ds, ts):
        from umbmark.realrobot.validate import ErrorStats

        short = ErrorStats(5, 0, 0, t_mse, 0, 0, 0, r_mse, 0)
        long = ErrorStats(2, 0, 0, long_mse, 0, 0, 0, 0, 0)
        return OdometryFigures(short, long, ds, 5, ts, 5, 0.0, (0.0, 0.0))

    b = figures(1.0, 1.0, 1.0, 0.95, 1.10)
    ok = judge(b, figures(1.019, 1.02, 1.0, 0.985, 1.2 - 0.11))
    assert [r.passed for r in ok] == [True] * 5
    worse = judge(b, figures(1.021, 1.03, 1.001, 0.94, 1.15))
    assert [r.passed for r in worse] == [False] * 5
    inside = judge(figures(1, 1, 1, 1.0, 1.0), figures(1, 1, 1, 1.015, 0.9851))
    assert [r.passed for r in inside][3:] == [True, True]
    empty = judge(b, figures(1, 1, math.nan, math.nan, 1.0))
    assert [r.passed for r in empty] == [True, True, None, None, True]
    assert MIN_DISTANCE_M == 0.2 and MIN_TURN_RAD == pytest.approx(math.radians(10))


# -- a real log -------------------------------------------------------------------------------------


def test_the_mit_csail_log_with_its_nominal_geometry(tmp_path, capsys):
    """The before figures of the nominal odometry on the whole MIT CSAIL log (200 / 400 mm assumed),
    recomputed here: the recorded poses interpolated at the scans, each increment an exact arc
    (its arc length from the chord), the arcs composed, the relative poses of the relations' scans
    (the lidar at the robot's origin in /tf_static) against the relations."""
    cal = tmp_path / "nominal.json"
    code, _, err = run(
        capsys, "-q", "export", "--c-left", "1", "--c-right", "1", "--eb", "1", "--wheel-diameter-mm", "200",
        "--wheelbase-mm", "400", "--format", "json", "--out", cal,
    )  # fmt: skip
    assert code == 0, err
    code, out, err = run(
        capsys, "validate", MIT / "mit-csail.bag", cal, "--odom-topic", "/odom", "--relations",
        MIT / "mit-csail.relations", "--json",
    )  # fmt: skip
    assert code == 0, err
    d = json.loads(out)
    (span,) = d["spans"]
    got = span["before"]
    assert span["after"] == got  # the calibration is the nominal geometry

    bag = read_selfcal_bag(MIT / "mit-csail.bag", wheels=WheelSource(odom_topic="/odom"))
    rel = read_relations(MIT / "mit-csail.relations")
    s, w, p = bag.scan_t_s, bag.wheel_t_s, bag.odom_pose
    at = np.column_stack([np.interp(s, w, p[:, 0]), np.interp(s, w, p[:, 1]), np.interp(s, w, np.unwrap(p[:, 2]))])
    odo = [np.zeros(3)]
    for a, b in zip(at[:-1], at[1:]):
        c, sn = math.cos(a[2]), math.sin(a[2])
        dx, dy = c * (b[0] - a[0]) + sn * (b[1] - a[1]), -sn * (b[0] - a[0]) + c * (b[1] - a[1])
        dth = math.remainder(b[2] - a[2], 2 * math.pi)
        h = dth / 2
        sinc = math.sin(h) / h if h else 1.0
        ds = (dx * math.cos(h) + dy * math.sin(h)) / sinc
        x, y, th = odo[-1]
        odo.append(np.array([x + ds * sinc * math.cos(th + h), y + ds * sinc * math.sin(th + h), th + dth]))
    odo = np.array(odo)
    i1, i2 = np.abs(rel.t1_s[:, None] - s).argmin(1), np.abs(rel.t2_s[:, None] - s).argmin(1)
    assert np.abs(s[i1] - rel.t1_s).max() < 1e-3 and np.abs(s[i2] - rel.t2_s).max() < 1e-3
    q = se2.between(odo[i1], odo[i2])
    e = se2.between(rel.pose, q)
    et2, er2 = e[:, 0] ** 2 + e[:, 1] ** 2, np.degrees(e[:, 2]) ** 2
    short = rel.span_s < 10.0
    assert span["relations_short"] == short.sum() and span["relations_long"] == (~short).sum()
    assert got["short"]["translation"]["mse_m2"] == pytest.approx(et2[short].mean(), rel=1e-9)
    assert got["short"]["rotation"]["mse_deg2"] == pytest.approx(er2[short].mean(), rel=1e-9)
    assert got["long"]["translation"]["mse_m2"] == pytest.approx(et2[~short].mean(), rel=1e-9)
    assert got["long"]["rotation"]["mse_deg2"] == pytest.approx(er2[~short].mean(), rel=1e-9)
    dist, rt = np.hypot(rel.pose[:, 0], rel.pose[:, 1]), rel.pose[:, 2]
    turn = odo[i2, 2] - odo[i1, 2]
    rt = turn + np.remainder(rt - turn + math.pi, 2 * math.pi) - math.pi
    m = short & (dist > 0.2)
    ds = np.sum(np.hypot(q[m, 0], q[m, 1]) * dist[m]) / np.sum(dist[m] ** 2)
    m2 = short & (np.abs(rt) > math.radians(10))
    ts = np.sum(np.abs(turn[m2]) * np.abs(rt[m2])) / np.sum(rt[m2] ** 2)
    assert (got["distance_relations"], got["turn_relations"]) == (m.sum(), m2.sum())
    assert got["distance_scale"] == pytest.approx(ds, rel=1e-9)
    assert got["turn_scale"] == pytest.approx(ts, rel=1e-9)
    assert d["reference"]["unmatched"] == 0 and d["calibration"]["kind"] == "export"
    assert d["calibration"]["nominal_sensor_pose"]["source"] == "/tf_static base_link -> laser"
