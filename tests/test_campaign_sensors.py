"""A campaign of sensor data read in the wrong unit or the wrong way round, run through the command
line as a user would: simulated drives of a differential drive, a tricycle and a mecanum robot
(lidar, joint states, encoder counts, gyro) and intervals files, each written once correctly and
once with one mistake (ranges in millimetres, joint positions in degrees, a lidar or an IMU upside
down, wheels exchanged or counted backwards, counters read per message and the reverse, gyro rates
in deg/s, intervals columns swapped or in other units), and the options of ``selfcal`` given
values no robot has.

Each mistaken case asserts: exit status 2, one line on stderr, no traceback, the real cause named
(the unit, the sign, the column, the option and its bound), and no driving advice in its place.
Each clean case asserts: exit 0 and no warning about the mistakes looked for.
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
from test_selfcal import TRUTH, mixed, simulate  # noqa: E402

from umbmark.cli import main  # noqa: E402
from umbmark.io.intervals_csv import write_intervals_csv  # noqa: E402
from umbmark.io.rosbag_write import write_drive_bag  # noqa: E402
from umbmark.model.drive import (  # noqa: E402
    Command,
    Program,
    SimRobot,
    WheelNoise,
    concatenate_drives,
    mixed_program,
    simulate_drive,
    simulate_gyro,
    skid_steer_robot,
    square_drive,
)
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.intervals import Intervals  # noqa: E402
from umbmark.model.kinematic_drive import (  # noqa: E402
    JointNoise,
    KinematicRobot,
    kinematic_program,
    simulate_kinematic_drive,
)
from umbmark.model.sensors import Gyro, Lidar, SensorPose  # noqa: E402

ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.008, eb=1.02, es=1.0),
    sensor_pose=SensorPose(0.10, 0.02, math.radians(-3.0)),
    lidar=Lidar(n_beams=180, range_noise_m=0.003),
)
GEO = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]
JOINTS = ["--joints", "left_wheel_joint,right_wheel_joint"]
PPR = 100
TICKS = ["--ticks-topic", "/wheel_ticks", "--left-field", "vector.x", "--right-field", "vector.y"]
TICKS += ["--pulses-per-wheel-rev", str(PPR)]
DRIVING_ADVICE = ("drive longer", "drive spins", "in view of walls", "do not move")


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    assert "Traceback" not in err.getvalue() + out.getvalue()
    return code, out.getvalue(), err.getvalue()


def refused(*args: str) -> str:
    """The one-line refusal of a command line (exit 2), with no driving advice in it."""
    code, out, err = run(*args)
    lines = err.strip().splitlines()
    assert code == 2, (code, err, out[-400:])
    assert len(lines) == 1 and lines[0].startswith("umbmark"), err
    assert not any(a in lines[0] for a in DRIVING_ADVICE), lines[0]
    return lines[0]


def accepted(*args: str) -> dict:
    code, out, err = run(*args, "--json")
    assert code == 0, err
    return json.loads(out)


# ------------------------------------------------------------------------------- the differential drive
@pytest.fixture(scope="module")
def drive():
    return simulate_drive(mixed_program(30.0, seed=2, robot=ROBOT), ROBOT, seed=3)


def _counts_per_message(log, ppr=PPR):
    """The drive with each wheel's angle replaced by the pulses counted in each message (times
    the pulse: the bag writer's counters are then the counts per message)."""
    pulse = 2 * math.pi / ppr
    per = [np.diff(np.floor(a / pulse + 1e-9), prepend=0.0) * pulse for a in (log.left_rad, log.right_rad)]
    return dataclasses.replace(log, left_rad=per[0], right_rad=per[1])


@pytest.fixture(scope="module")
def bags(drive, tmp_path_factory):
    root = tmp_path_factory.mktemp("sensors")
    lidar = drive.lidar
    mm_lidar = dataclasses.replace(lidar, max_range_m=lidar.max_range_m * 1e3, min_range_m=lidar.min_range_m * 1e3)
    variants = {
        "ok": drive,
        "ranges_mm": dataclasses.replace(drive, ranges_m=drive.ranges_m * 1e3, lidar=mm_lidar),
        "ranges_mm_max_m": dataclasses.replace(drive, ranges_m=drive.ranges_m * 1e3),
        "ranges_cm": dataclasses.replace(drive, ranges_m=drive.ranges_m * 1e2, lidar=mm_lidar),
        "mirrored": dataclasses.replace(drive, ranges_m=drive.ranges_m[:, ::-1].copy()),
        "degrees": dataclasses.replace(
            drive, left_rad=np.degrees(drive.left_rad), right_rad=np.degrees(drive.right_rad)
        ),
        "swapped": dataclasses.replace(drive, left_rad=drive.right_rad, right_rad=drive.left_rad),
        "backwards": dataclasses.replace(drive, left_rad=-drive.left_rad, right_rad=-drive.right_rad),
        "per_message": _counts_per_message(drive),
    }
    return {
        k: write_drive_bag(v, root / k, storage="mcap", odom=False, truth=True, ticks_per_rev=PPR)
        for k, v in variants.items()
    }


@pytest.mark.parametrize("wheels", ["joints", "ticks"])
def test_a_clean_drive_is_calibrated_without_a_word(bags, wheels):
    d = accepted("selfcal", str(bags["ok"]), *GEO, *(JOINTS if wheels == "joints" else TICKS))
    assert d["warnings"] == [] and 340 < d["wheelbase_mm"] < 355 and abs(d["sensor_pose"]["yaw_deg"] + 3) < 0.3


def test_counts_per_message_read_as_such_are_calibrated(bags):
    d = accepted("selfcal", str(bags["per_message"]), *GEO, *TICKS, "--ticks", "incremental")
    assert d["warnings"] == [] and 340 < d["wheelbase_mm"] < 355


@pytest.mark.parametrize(
    "variant, words",
    [
        ("ranges_mm", ("look like millimetres", "median", "range_max 12000")),
        ("ranges_mm_max_m", ("look like millimetres", "range_max 12", "beyond range_max")),
        ("ranges_cm", ("(or centimetres)", "median is 465")),
    ],
)
@pytest.mark.parametrize("wheels", ["joints", "ticks"])
def test_lidar_ranges_in_millimetres_are_named(bags, variant, words, wheels):
    line = refused("selfcal", str(bags[variant]), *GEO, *(JOINTS if wheels == "joints" else TICKS))
    assert all(w in line for w in words), line


@pytest.mark.parametrize("wheels", ["joints", "ticks"])
def test_lidar_ranges_in_millimetres_are_named_as_a_ground_truth_too(bags, wheels):
    """replay --gt-scan-topic reads the same scans."""
    line = refused(
        "replay", str(bags["ranges_mm"]), *GEO, *(JOINTS if wheels == "joints" else TICKS),
        "--gt-scan-topic", "/scan", "--split-stops", "--side-mm", "2000",
    )  # fmt: skip
    assert "look like millimetres" in line


@pytest.mark.parametrize("wheels", ["joints", "ticks"])
@pytest.mark.parametrize("variant", ["mirrored", "swapped"])
def test_a_lidar_upside_down_or_wheels_exchanged_are_named_not_answered(bags, wheels, variant):
    """The two move the robot alike: both are named; wheel joints with the order to give them in."""
    line = refused("selfcal", str(bags[variant]), *GEO, *(JOINTS if wheels == "joints" else TICKS))
    assert "the lidar turns the other way from the wheels" in line and "upside down" in line and "mirrored" in line
    assert "right before left" in line
    if wheels == "joints":
        assert "--joints right_wheel_joint,left_wheel_joint (in this order: left, right)" in line


def test_wheels_counted_backwards_are_named(bags):
    line = refused("selfcal", str(bags["backwards"]), *GEO, *JOINTS)
    assert "count backwards" in line and "negate" in line and "upside down" not in line


def test_joint_positions_in_degrees_are_named(bags):
    line = refused("selfcal", str(bags["degrees"]), *GEO, *JOINTS)
    assert "look like degrees" in line and "times as far as the lidar" in line


@pytest.mark.parametrize("factor", [4.0, 0.25, 10.0])
def test_a_wrong_encoder_resolution_is_named_by_its_factor(bags, factor):
    ppr = f"{PPR * factor:g}"
    line = refused("selfcal", str(bags["ok"]), *GEO, *TICKS[:-1], ppr)
    assert "times as far as the lidar" in line and "--pulses-per-wheel-rev" in line


def test_a_counter_read_per_message_is_not_called_a_reset(bags):
    line = refused("selfcal", str(bags["ok"]), *GEO, *TICKS, "--ticks", "incremental")
    assert "look cumulative" in line and "--ticks cumulative" in line and "reset" not in line


def test_counts_per_message_read_as_a_counter_are_named(bags):
    line = refused("selfcal", str(bags["per_message"]), *GEO, *TICKS)
    assert "counts per message" in line and "--ticks incremental" in line


@pytest.mark.parametrize("truth", [("--gt-scan-topic", "/scan"), ("--gt-topic", "/scan")])
def test_a_counter_read_per_message_is_named_in_replay_too(bags, truth):
    line = refused("replay", str(bags["ok"]), *GEO, *TICKS, "--ticks", "incremental", *truth, "--side-mm", "2000")
    assert "look cumulative" in line and "--ticks cumulative" in line


REPLAY = ["--gt-topic", "/ground_truth", "--method", "lsq", "--no-heldout"]


def test_a_clean_drive_replays_against_its_ground_truth_without_a_word(bags):
    d = accepted("replay", str(bags["ok"]), *GEO, *JOINTS, *REPLAY)
    assert d["warnings"] == [] and abs(d["Eb"] - 1.02) < 1e-3


def test_wheel_angles_in_degrees_against_a_ground_truth_are_named(bags):
    line = refused("replay", str(bags["degrees"]), *GEO, *JOINTS, *REPLAY)
    assert "turn 5" in line and "times as far as the ground truth" in line and "look like degrees" in line


def test_a_refusal_names_its_check_and_the_flag_that_lets_the_recording_through(bags):
    """A plausibility check judges from evidence: its refusal names it, and --skip-check lets a
    recording its owner knows to be right through (here wheel angles that are degrees indeed)."""
    line = refused("replay", str(bags["degrees"]), *GEO, *JOINTS, *REPLAY)
    assert "(the check degree_turns; if the recording is right, --skip-check degree_turns lets it through)" in line
    # skipped, the degrees go on as radians (as asked) and the fit then fails on its own terms
    line = refused("replay", str(bags["degrees"]), *GEO, *JOINTS, *REPLAY, "--skip-check", "degree_turns")
    assert "degree_turns" not in line and "did not converge" in line
    line = refused("selfcal", str(bags["mirrored"]), *GEO, *JOINTS)
    assert "--skip-check turn_direction lets it through" in line
    line = refused("replay", str(bags["ok"]), *GEO, *JOINTS, *REPLAY, "--skip-check", "no_such_check")
    assert "--skip-check" in line and "degree_turns" in line  # the choices listed


def test_wheels_exchanged_against_a_ground_truth_are_named(bags):
    d = accepted("replay", str(bags["swapped"]), *GEO, *JOINTS, *REPLAY)
    assert any("the wheels turn the other way from the ground truth" in w and "swapped" in w for w in d["warnings"])


@pytest.fixture(scope="module")
def square_bags(tmp_path_factory):
    """Two 2 m squares (cw, ccw) of a LabMate whose lidar is the ground truth; and the same with
    the scans mirrored (the lidar upside down)."""
    root = tmp_path_factory.mktemp("squares")
    robot = SimRobot(LABMATE, ErrorParams(ed=1.004, eb=1.03), SensorPose(0.035, 0.0, 0.0), Lidar(range_noise_m=0.005))
    runs = [
        simulate_drive(square_drive(d), robot, start_pose=(4.0, 4.0, 0.0), noise=WheelNoise(0.01), seed=20 + i)
        for i, d in enumerate(["cw", "ccw"])
    ]
    log = concatenate_drives(runs)
    mirrored = dataclasses.replace(log, ranges_m=log.ranges_m[:, ::-1].copy())
    return {
        k: write_drive_bag(v, root / k, odom=False, tf_static=False) for k, v in (("ok", log), ("mirrored", mirrored))
    }


SQUARE = [*JOINTS, "--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--side-mm", "2000", "--split-stops"]
SQUARE += ["--method", "exact", "--no-heldout", "--sensor-pose", "35,0,0", "--gt-scan-topic", "/scan"]


def test_a_lidar_ground_truth_upside_down_is_named_not_answered(square_bags):
    d = accepted("replay", str(square_bags["ok"]), *SQUARE)
    assert abs(d["Eb"] - 1.03) < 3e-3
    line = refused("replay", str(square_bags["mirrored"]), *SQUARE)
    assert "the lidar turns the other way from the wheels" in line and "upside down" in line


# ------------------------------------------------------------------------------- tricycle and mecanum
def _kinematic_log(kind):
    spec = ROBOTS[kind]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=180, range_noise_m=0.005))
    moves, start = kinematic_program(robot, 30.0, seed=7)
    log = simulate_kinematic_drive(
        moves, robot, start_pose=start, joint_names=spec["joints"], noise=JointNoise(speed_rel_sd=0.01), seed=7
    )
    return dataclasses.replace(log, sensor_pose=spec["drawing"])


KIND_ARGS = {
    "tricycle": ["--drive-joint", "traction_wheel_joint", "--steer-joint", "steering_joint"]
    + ["--wheel-diameter-mm", "250", "--wheelbase-mm", "800"],
    "mecanum": ["--joints", ",".join(ROBOTS["mecanum"]["joints"]), "--wheel-diameter-mm", "100"]
    + ["--lx-plus-ly-mm", "400"],
}


@pytest.fixture(scope="module")
def kinematic_bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("kinds")
    out = {}
    for kind in ("tricycle", "mecanum"):
        log = _kinematic_log(kind)
        pos = log.positions
        roll = np.array(ROBOTS[kind]["nominal"].rolling)
        deg = pos.copy()
        deg[:, roll] = np.degrees(pos[:, roll])
        variants = {
            "ok": log,
            "degrees": dataclasses.replace(log, positions=deg),
            "mirrored": dataclasses.replace(log, ranges_m=log.ranges_m[:, ::-1].copy()),
            "ranges_mm": dataclasses.replace(log, ranges_m=log.ranges_m * 1e3),
        }
        if kind == "tricycle":
            steer_deg, steer_neg = pos.copy(), pos.copy()
            steer_deg[:, 1] = np.degrees(pos[:, 1])
            steer_neg[:, 1] = -pos[:, 1]
            variants["steering_degrees"] = dataclasses.replace(log, positions=steer_deg)
            variants["steering_clockwise"] = dataclasses.replace(log, positions=steer_neg)
        else:
            variants["order"] = dataclasses.replace(log, positions=pos[:, [1, 0, 3, 2]].copy())
        for name, lg in variants.items():
            out[(kind, name)] = write_drive_bag(lg, root / f"{kind}_{name}", storage="mcap", odom=False)
    return out


# the mecanum robot's joints with left and right exchanged (a lidar upside down moves it the same way)
SWAPPED = ",".join(ROBOTS["mecanum"]["joints"][i] for i in (1, 0, 3, 2))


def kind_run(bags, kind, name):
    return ("selfcal", str(bags[(kind, name)]), "--kinematics", kind, *KIND_ARGS[kind])


@pytest.mark.parametrize("kind", ["tricycle", "mecanum"])
def test_a_clean_kinematic_drive_is_calibrated_without_a_word(kinematic_bags, kind):
    d = accepted(*kind_run(kinematic_bags, kind, "ok"))
    assert d["warnings"] == []


@pytest.mark.parametrize(
    "kind, name, words",
    [
        ("tricycle", "degrees", ("look like degrees", "times as far as the lidar")),
        ("mecanum", "degrees", ("look like degrees", "times as far as the lidar")),
        ("tricycle", "mirrored", ("turns the other way", "upside down", "steering joint's angle clockwise")),
        ("mecanum", "mirrored", ("turns the other way", "upside down", f"another order: --joints {SWAPPED} (in")),
        ("tricycle", "steering_clockwise", ("turns the other way", "clockwise positive")),
        ("mecanum", "order", ("turns the other way", f"another order: --joints {SWAPPED} (in this order: front_left")),
        ("tricycle", "ranges_mm", ("look like millimetres",)),
        ("mecanum", "ranges_mm", ("look like millimetres",)),
        ("tricycle", "steering_degrees", ("steering joint steering_joint reaches", "look like degrees")),
    ],
)
def test_kinematic_sensor_mistakes_are_named(kinematic_bags, kind, name, words):
    line = refused(*kind_run(kinematic_bags, kind, name))
    assert all(w in line for w in words), line


# ------------------------------------------------------------------------------- the gyro
TRACK, DIAMETER, FACTOR = 0.40, 0.20, 1.6
SKID = skid_steer_robot(TRACK, DIAMETER, FACTOR, ed=1.01, lidar=Lidar(range_noise_m=0.005))
SKID_GEO = ["--wheel-diameter-mm", "200", "--wheelbase-mm", "400"]


@pytest.fixture(scope="module")
def gyro_bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("gyro")
    cmds = [Command(2.0)]
    for s in [1, -1, 1, -1]:
        cmds += [Command(2 * math.pi / 0.8, 0.0, s * 0.8), Command(1.5)]
    log = simulate_drive(Program(tuple(cmds)), SKID, seed=1)
    t, w = simulate_gyro(log, Gyro(100.0, 1.0, 0.01, 0.005), seed=2)
    w = np.asarray(w)
    deg = math.degrees(1.0)
    out = {}
    for name, rates, lg in (
        ("ok", w, log),
        ("deg_per_s", w * deg, log),
        ("upside_down", -w, log),
        ("upside_down_deg_per_s", -w * deg, log),
        ("divided", w / deg, log),
        (
            "wheels_degrees",
            w,
            dataclasses.replace(log, left_rad=np.degrees(log.left_rad), right_rad=np.degrees(log.right_rad)),
        ),
        ("biased", w + math.radians(30.0), log),
        ("lidar_mirrored", w, dataclasses.replace(log, ranges_m=log.ranges_m[:, ::-1].copy())),
    ):
        out[name] = write_drive_bag(lg, root / name, gyro=(t, rates), odom=False)
    return out


def gyro_run(bags, name, *extra):
    return ("replay", str(bags[name]), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, *extra)


@pytest.mark.parametrize("extra", [(), ("--full-turns",), ("--gt-scan-topic", "/scan")])
def test_a_clean_gyro_gives_its_wheelbase_without_a_word(gyro_bags, extra):
    d = accepted(*gyro_run(gyro_bags, "ok", *extra))
    g = d["gyro"]
    if "--full-turns" not in extra:  # the spins are 225 deg: not whole turns
        assert abs(g["wheelbase_m"] / (FACTOR * TRACK) - 1) < 0.01 and d["warnings"] == []
    assert not any("deg/s" in w for w in d["warnings"])


@pytest.mark.parametrize("extra", [(), ("--full-turns",), ("--gt-scan-topic", "/scan")])
@pytest.mark.parametrize(
    "name, words",
    [
        ("deg_per_s", ("deg/s published as rad/s", "bias at rest 32.7 deg/s")),
        ("upside_down", ("the other way from the wheels", "upside down")),
        ("upside_down_deg_per_s", ("upside down", "deg/s published as rad/s")),
        ("divided", ("divided by 57.3", "look like degrees")),
        ("wheels_degrees", ("look like degrees",)),
    ],
)
def test_gyro_mistakes_are_named_whatever_gives_its_scale(gyro_bags, name, words, extra):
    line = refused(*gyro_run(gyro_bags, name, *extra))
    assert all(w in line for w in words), line


def test_a_lidar_upside_down_beside_a_gyro_is_named(gyro_bags):
    line = refused(*gyro_run(gyro_bags, "lidar_mirrored", "--gt-scan-topic", "/scan"))
    assert "the lidar turns the other way from the wheels" in line and "upside down" in line


def test_a_bias_no_gyro_has_is_named(gyro_bags):
    """30 deg/s at rest (the turns are right, the bias is removed): named, not passed over."""
    d = accepted(*gyro_run(gyro_bags, "biased"))
    assert any("more than any gyro's bias" in w and "30" in w for w in d["warnings"]), d["warnings"]


# ------------------------------------------------------------------------------- intervals files
@pytest.fixture(scope="module")
def interval_files(tmp_path_factory):
    root = tmp_path_factory.mktemp("intervals")
    rng = np.random.default_rng(16)
    fl, fr = mixed(rng, 200, 0.05, 0.3)
    iv = simulate(rng, TRUTH, fl, fr)
    s, left, right = iv.sensor, iv.left_rad, iv.right_rad
    variants = {
        "ok": (left, right, s),
        "yaw_degrees": (left, right, np.column_stack([s[:, 0], s[:, 1], np.degrees(s[:, 2])])),
        "wheels_degrees": (np.degrees(left), np.degrees(right), s),
        "millimetres": (left, right, np.column_stack([s[:, :2] * 1e3, s[:, 2]])),
        "yaw_negated": (left, right, s * [1, 1, -1]),
        "mirrored": (left, right, s * [1, -1, -1]),
        "wheels_swapped": (right, left, s),
        "wheels_backwards": (-left, -right, s),
        "left_backwards": (-left, right, s),
        "odometry_and_sensor_exchanged": (s[:, 0], s[:, 1], np.column_stack([left, right, s[:, 2]])),
        "dx_and_dyaw_exchanged": (left, right, s[:, [2, 1, 0]]),
    }
    out = {}
    for name, (a, b, c) in variants.items():
        out[name] = root / f"{name}.csv"
        write_intervals_csv(Intervals(iv.dt_s, a, b, c), out[name])
    return out


IV_GEO = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]


def test_clean_intervals_are_calibrated_without_a_word(interval_files):
    d = accepted("selfcal", str(interval_files["ok"]), *IV_GEO)
    assert d["warnings"] == []


@pytest.mark.parametrize(
    "name, words",
    [
        ("yaw_degrees", ("sensor_dyaw_rad looks like degrees",)),
        ("wheels_degrees", ("left_rad and right_rad look like degrees",)),
        ("millimetres", ("sensor_dx_m and sensor_dy_m look like millimetres",)),
        ("yaw_negated", ("sensor turns against the wheels", "sensor_dyaw_rad negated")),
        ("mirrored", ("sensor turns against the wheels", "upside down")),
        ("wheels_swapped", ("left_rad and right_rad are swapped",)),
        ("wheels_backwards", ("both wheels counted backwards",)),
        ("left_backwards", ("negate left_rad",)),
        ("odometry_and_sensor_exchanged", ("the columns are not what their names say",)),
        ("dx_and_dyaw_exchanged", ("the columns are not what their names say",)),
    ],
)
def test_intervals_columns_misread_are_named(interval_files, name, words):
    line = refused("selfcal", str(interval_files[name]), *IV_GEO)
    assert all(w in line for w in words), line


@pytest.fixture(scope="module")
def matched_intervals(bags, tmp_path_factory):
    """The intervals a bag's scan matching gives (steps, covariances, wheel rates), as written by
    --intervals-out, and the same with the dx and dy columns' names exchanged."""
    root = tmp_path_factory.mktemp("matched")
    ok = root / "ok.csv"
    accepted("selfcal", str(bags["ok"]), *GEO, *JOINTS, "--intervals-out", str(ok))
    head, *rows = ok.read_text().splitlines()
    cols = head.split(",")
    i, j = cols.index("sensor_dx_m"), cols.index("sensor_dy_m")
    cols[i], cols[j] = cols[j], cols[i]
    swapped = root / "swapped.csv"
    swapped.write_text("\n".join([",".join(cols), *rows]) + "\n")
    return ok, swapped


def test_matched_intervals_with_dx_and_dy_swapped_are_named(matched_intervals):
    ok, swapped = matched_intervals
    assert accepted("selfcal", str(ok), *GEO)["warnings"] == []
    line = refused("selfcal", str(swapped), *GEO)
    assert "sensor_dx_m and sensor_dy_m look swapped" in line and "of the cost" in line


# ------------------------------------------------------------------------------- options no robot has
BOUNDED = [
    ("--scan-delay", "10", "beyond +-1 s"),
    ("--scan-delay", "-5", "beyond +-1 s"),
    ("--scan-delay", "250", "milliseconds"),
    ("--keyframe-min-s", "1e9", "--keyframe-min-s 1e+09 is beyond 60"),
    ("--keyframe-min-s", "100", "beyond 60"),
    ("--keyframe-s", "1e9", "--keyframe-s 1e+09 is beyond 60"),
    ("--keyframe-mm", "1e9", "is beyond 5000"),
    ("--keyframe-mm", "6000", "is beyond 5000"),
    ("--keyframe-deg", "400", "--keyframe-deg 400 is beyond 180"),
    ("--keyframe-deg", "1e9", "beyond 180"),
    ("--max-wheel-gap-s", "1e9", "outside 0.001 to 10 s"),
    ("--max-wheel-gap-s", "500", "outside 0.001 to 10 s"),
    ("--max-wheel-gap-s", "1e-9", "outside 0.001 to 10 s"),
    ("--sensor-pose", "1e9,0,0", "within 10000 mm"),
    ("--sensor-pose", "0,1e9,0", "within 10000 mm"),
    ("--sensor-pose", "0,0,1e9", "within +-360 deg"),
    ("--sensor-pose", "0,0,-400", "within +-360 deg"),
    ("--min-intervals", "1000000", "--min-intervals 1000000 is beyond 100000"),
]
NOT_NUMBERS = ["nan", "-inf", "inf", "1e308", "-1e308", "9" * 5001, "1_0", "0x10"]
NUMERIC = ["--scan-delay", "--keyframe-mm", "--keyframe-deg", "--keyframe-s", "--keyframe-min-s"]
NUMERIC += ["--max-wheel-gap-s", "--min-intervals", "--pulses-per-wheel-rev", "--lx-plus-ly-mm"]


@pytest.mark.parametrize("kind", ["diff_drive", "tricycle"])
@pytest.mark.parametrize("flag, value, words", BOUNDED)
def test_selfcal_options_no_robot_has_are_bounded(bags, kinematic_bags, kind, flag, value, words):
    args = ("selfcal", str(bags["ok"]), *GEO, *JOINTS)
    if kind == "tricycle":
        args = kind_run(kinematic_bags, "tricycle", "ok")
    line = refused(*args, flag, value)
    assert words in line and flag in line, line


@pytest.mark.parametrize("flag", NUMERIC)
@pytest.mark.parametrize("value", NOT_NUMBERS)
def test_selfcal_options_that_are_no_numbers_are_one_line(bags, flag, value):
    line = refused("selfcal", str(bags["ok"]), *GEO, *JOINTS, flag, value)
    assert flag in line and len(line) < 400, line
