"""The gyro as a rotation reference (`replay --imu-topic`, umbmark.realrobot.gyro): simulated
ROS 2 bags of a skid-steer robot (effective wheelbase 1.6 x its track) and of a LabMate with a
gyro of known bias, noise and scale; the simulator's true wheelbase as the reference."""

import contextlib
import io
import json
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")
from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import read_gyro_bag  # noqa: E402
from umbmark.io.rosbag_write import write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import (  # noqa: E402
    Command,
    Program,
    SimRobot,
    WheelNoise,
    concatenate_drives,
    simulate_drive,
    simulate_gyro,
    skid_steer_robot,
    square_drive,
)
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.sensors import Gyro, Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.gyro import gyro_reference, still_periods  # noqa: E402

TRACK, DIAMETER, FACTOR = 0.40, 0.20, 1.6
SKID = skid_steer_robot(TRACK, DIAMETER, FACTOR, ed=1.01, lidar=Lidar(range_noise_m=0.005))
BIAS, NOISE = 0.01, 0.005  # rad/s: 0.57 deg/s of bias, 0.3 deg/s of noise per reading at 100 Hz
JOINTS = ["--joints", "left_wheel_joint,right_wheel_joint"]
SKID_GEO = ["--wheel-diameter-mm", "200", "--wheelbase-mm", "400"]


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


def spins(turn_rad, signs, omega=0.8, rest_s=1.5):
    """Spins on the spot (the nominal odometry's angle ``turn_rad``), resting before and after each."""
    cmds = [Command(2.0)]
    for s in signs:
        cmds += [Command(turn_rad / omega, 0.0, s * omega), Command(rest_s)]
    return Program(tuple(cmds))


def bag_of(log, path, gyro, seed=2, **kw):
    t, w = simulate_gyro(log, gyro, seed=seed)
    return write_drive_bag(log, path, gyro=(t, w), **{"odom": False, **kw})


@pytest.fixture(scope="module")
def skid_bag(tmp_path_factory):
    """Commanded 360 deg spins both ways: the skid-steer robot turns 225 deg each."""
    log = simulate_drive(spins(2 * math.pi, [1, -1] * 3), SKID, seed=1)
    return bag_of(log, tmp_path_factory.mktemp("gyro") / "skid", Gyro(100.0, 1.0, BIAS, NOISE))


def test_skid_steer_wheelbase_from_spins_alone(skid_bag):
    """Acceptance: the effective wheelbase (1.6 x the track) within 0.5 % from the spins and the
    gyro alone, its bias estimated and removed at rest; no ground truth in the bag."""
    d = json.loads(run(["replay", str(skid_bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, "--json"]))
    g = d["gyro"]
    true_b = FACTOR * TRACK
    assert abs(g["wheelbase_m"] / true_b - 1) < 0.005
    lo, hi = g["wheelbase_m_ci95"]
    assert lo < true_b < hi and hi - lo < 0.01 * true_b
    assert g["wheel_separation_multiplier"] == pytest.approx(g["wheelbase_m"] / TRACK)
    assert g["gyro_scale"] == 1.0 and g["gyro_scale_source"] == "assumed" and g["gyro_scale_ci95"] is None
    assert abs(g["bias_rad_per_s"] - BIAS) < 0.1 * BIAS
    assert abs(g["noise_rad_per_s"] - NOISE) < 0.2 * NOISE
    assert g["turns_used"] == 6 and all(t["on_the_spot"] for t in g["turns"] if t["used"])
    assert d["warnings"] == []
    text = run(["replay", str(skid_bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO])
    assert "wheel_separation_multiplier" in text and f"{g['wheelbase_m'] * 1e3:.2f}" in text


def test_a_gyro_result_is_recorded_reported_and_listed(skid_bag, tmp_path):
    """``--robot NAME --record``: the gyro's wheelbase in the history (wheel factors 1, no E_d),
    its page by record id, and the robot's history page."""
    db = str(tmp_path / "h.sqlite")
    base = ["replay", str(skid_bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO]
    d = json.loads(run([*base, "--robot", "r1", "--record", "--db", db, "--json"]))
    rid = d["history"]["record_id"]
    h = json.loads(run(["history", "r1", "--db", db, "--json"]))
    (r,) = h["records"]
    assert r["kind"] == "gyro" and r["Eb"] == pytest.approx(d["gyro"]["Eb"]) and r["Ed"] is None
    assert r["wheelbase_mm"] == pytest.approx(1e3 * d["gyro"]["wheelbase_m"])
    page = tmp_path / "g.html"
    run(["-q", "report", "--id", str(rid), "--db", db, "--out", str(page)])
    text = page.read_text()
    assert f"{1e3 * d['gyro']['wheelbase_m']:.2f}" in text and "The turns" in text
    run(["-q", "report", "--robot", "r1", "--db", db, "--out", str(tmp_path / "h.html")])
    assert "gyro" in (tmp_path / "h.html").read_text()
    # printed, the record is named; the same bag again in r1's history is refused, naming the record
    assert f"recorded as #{rid + 1} in the history of r2" in run([*base, "--robot", "r2", "--record", "--db", db])
    line = run([*base, "--robot", "r1", "--record", "--db", db], code=2)
    assert f"holds this recording already: record #{rid} (gyro" in line


def test_a_turn_is_named_by_its_time_in_its_bag(tmp_path):
    """Whole turns counted with a gyro reading 5 % high: each turn's warning says where it is in
    seconds from its bag's start (not a time stamp since 1970)."""
    log = simulate_drive(spins(2 * math.pi * FACTOR, [1, -1]), SKID, seed=5)
    bag = bag_of(log, tmp_path / "high", Gyro(100.0, 1.05, BIAS, NOISE), seed=6)
    d = json.loads(run(["replay", str(bag), "--imu-topic", "/imu", "--full-turns", *JOINTS, *SKID_GEO, "--json"]))
    found = [re.search(r"in the turn at ([0-9.]+) s in high", w) for w in d["warnings"]]
    times = [float(m.group(1)) for m in found if m]
    assert len(times) == 2 and all(0 < t < log.t_s[-1] - log.t_s[0] for t in times), d["warnings"]


@pytest.mark.parametrize(
    "factor, words",
    [
        (math.degrees(1.0), ("deg/s published as rad/s",)),
        (-1.0, ("the other way from the wheels in 4 of 4 turns", "upside down")),
    ],
)
def test_a_gyro_in_deg_per_s_or_upside_down_is_refused_naming_it(tmp_path, factor, words):
    """The rates of a gyro publishing deg/s, or mounted z down, would give a wheelbase of a few mm
    or a negative one: refused with the likely cause, exit 2."""
    log = simulate_drive(spins(2 * math.pi, [1, -1] * 2), SKID, seed=1)
    t, w = simulate_gyro(log, Gyro(100.0, 1.0, BIAS, NOISE), seed=2)
    bag = write_drive_bag(log, tmp_path / "imu", gyro=(t, np.asarray(w) * factor), odom=False)
    err = run(["replay", str(bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, "--json"], code=2)
    assert all(x in err for x in words) and len(err.strip().splitlines()) == 1, err


def test_a_nominal_wheelbase_in_the_wrong_unit_is_refused(skid_bag):
    err = run(["replay", str(skid_bag), "--imu-topic", "/imu", *JOINTS, "--wheel-diameter-mm", "200",
               "--wheelbase-mm", "40"], code=2)  # fmt: skip
    assert "E_b" in err and "units" in err, err


def test_a_gyro_result_exports_its_wheelbase_multiplier_only(skid_bag, tmp_path):
    """``export gyro.json --format ros2``: the gyro's E_b as wheel_separation_multiplier, the wheel
    radius multipliers left at 1, and a warning that the wheels were not measured."""
    save = tmp_path / "gyro.json"
    run(["-q", "replay", str(skid_bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, "--save", str(save)])
    eb = json.loads(save.read_text())["gyro"]["Eb"]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert main(["export", str(save), "--format", "ros2"]) == 0
    text = out.getvalue()
    assert f"wheel_separation_multiplier: {eb!r}" in text
    assert "left_wheel_radius_multiplier: 1.0" in text and "right_wheel_radius_multiplier: 1.0" in text
    assert "wheels not measured: a gyro sees the turns only" in err.getvalue()
    assert run(["export", str(save), "--format", "firmware"], code=2).count("nominal wheel diameters") == 1


def test_bias_is_removed_from_still_periods(tmp_path):
    """Spins one way only, so the bias does not cancel between directions: left in, its 0.57 deg/s
    over each 7.9 s spin of 225 deg would put the wheelbase 2 % off."""
    log = simulate_drive(spins(2 * math.pi, [1] * 4), SKID, seed=3)
    bag = bag_of(log, tmp_path / "oneway", Gyro(100.0, 1.0, BIAS, NOISE), seed=4)
    gb = read_gyro_bag(
        bag, imu_topic="/imu", nominal=SKID.nominal_wheels, wheels=WheelSource(joints=JOINTS[1].split(","))
    )
    r = gyro_reference([gb], SKID.nominal_wheels)
    assert abs(r.wheelbase_m / (FACTOR * TRACK) - 1) < 0.005
    assert any("one way" in w for w in r.warnings)


def test_gyro_scale_from_counted_full_turns(tmp_path):
    """Spins of whole true revolutions (counted): the gyro's own scale factor, and the wheelbase with it."""
    log = simulate_drive(spins(2 * math.pi * FACTOR, [1, -1, 1, -1]), SKID, seed=5)
    bag = bag_of(log, tmp_path / "turns", Gyro(100.0, 1.02, BIAS, NOISE), seed=6)
    base = ["replay", str(bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, "--json"]
    g = json.loads(run([*base, "--full-turns"]))["gyro"]
    assert g["gyro_scale_source"] == "full turns"
    assert abs(g["gyro_scale"] - 1.02) < 2e-3
    assert abs(g["wheelbase_m"] / (FACTOR * TRACK) - 1) < 0.005
    assert all(
        t["true_deg"] == pytest.approx(360.0 * math.copysign(1, t["wheels_deg"])) for t in g["turns"] if t["used"]
    )
    # without the counted turns the gyro's 2 % scale error is the wheelbase's
    h = json.loads(run(base))["gyro"]
    assert h["wheelbase_m"] / g["wheelbase_m"] == pytest.approx(1 / 1.02, rel=2e-3)


def test_gyro_scale_from_the_lidar(tmp_path):
    log = simulate_drive(spins(2 * math.pi, [1, -1, 1, -1]), SKID, seed=7)
    bag = bag_of(log, tmp_path / "lidar", Gyro(100.0, 0.97, -BIAS, NOISE), seed=8)
    g = json.loads(
        run(["replay", str(bag), "--imu-topic", "/imu", "--gt-scan-topic", "/scan", *JOINTS, *SKID_GEO, "--json"])
    )["gyro"]
    assert g["gyro_scale_source"] == "lidar"
    assert abs(g["gyro_scale"] - 0.97) < 2e-3
    assert abs(g["wheelbase_m"] / (FACTOR * TRACK) - 1) < 0.005
    assert all(abs(t["true_deg"] - t["gyro_deg"] / 0.97) < 0.5 for t in g["turns"] if t["used"])


def test_gyro_beside_a_lidar_square_test(tmp_path):
    """The turns of the UMBmark squares give the wheelbase too, beside the lidar's calibration."""
    robot = SimRobot(LABMATE, ErrorParams(ed=1.004, eb=1.03), SensorPose(0.035, 0.0, 0.0), Lidar(range_noise_m=0.005))
    drives = [
        simulate_drive(square_drive(d), robot, start_pose=(4.0, 4.0, 0.0), noise=WheelNoise(0.01), seed=20 + i)
        for i, d in enumerate(["cw", "ccw", "cw", "ccw"])
    ]
    # the gyro of each run on its own (the robot is carried between runs: no gyro reading spans it)
    readings = [simulate_gyro(d, Gyro(100.0, 1.0, BIAS, NOISE), seed=30 + i) for i, d in enumerate(drives)]
    log = concatenate_drives(drives)
    offsets = np.concatenate([[0.0], np.cumsum([d.duration_s + 0.01 for d in drives])[:-1]])
    gt = np.concatenate([t + o for (t, _), o in zip(readings, offsets)])
    gw = np.concatenate([w for _, w in readings])
    bag = write_drive_bag(log, tmp_path / "squares", gyro=(gt, gw), odom=False, tf_static=False)
    geo = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--side-mm", "2000", "--split-stops"]
    d = json.loads(
        run(
            ["replay", str(bag), "--gt-scan-topic", "/scan", "--sensor-pose", "35,0,0", "--imu-topic", "/imu"]
            + [*JOINTS, *geo, "--method", "exact", "--json", "--no-heldout"]
        )
    )
    g = d["gyro"]
    assert g["gyro_scale_source"] == "lidar"
    assert g["turns_used"] == 16  # four turns on the spot per run
    assert abs(g["Eb"] - 1.03) < 0.005 * 1.03
    assert abs(d["Eb"] - 1.03) < 3e-3  # the square test's own E_b, as without the gyro


def test_gyro_errors_are_one_line(skid_bag, tmp_path):
    base = ["replay", str(skid_bag), *JOINTS, *SKID_GEO]
    assert "--imu-topic" in run([*base, "--full-turns"], code=2)
    line = run([*base, "--imu-topic", "/gyro"], code=2)
    assert "/gyro" in line and "/imu" in line
    # a robot that never rests: no bias, and no turn between two still periods
    log = simulate_drive(Program((Command(10.0, 0.0, 0.8),)), SKID, seed=1)
    bag = bag_of(log, tmp_path / "restless", Gyro(100.0, 1.0, BIAS, NOISE))
    line = run(["replay", str(bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO], code=2)
    assert "still" in line and "spin" in line


def test_gyro_readings_integrate_to_the_heading():
    """Noise free, the readings over each sample period add up to the true turn, times the scale."""
    log = simulate_drive(spins(3.0, [1, -1]), SKID, seed=1)
    t, w = simulate_gyro(log, Gyro(50.0, 1.05, 0.0, 0.0))
    yaw = log.true_pose_at(np.concatenate([[0.0], t]))[:, 2]
    assert np.allclose(np.cumsum(w) / 50.0, 1.05 * (yaw[1:] - yaw[0]), atol=1e-12)
    with pytest.raises(InputError, match="seed"):
        simulate_gyro(log, Gyro(noise_radps=0.01))


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.integers(1, 40)), min_size=1, max_size=12), st.integers(1, 20))
def test_still_periods(pattern, min_samples):
    """Every stretch of at least ``min_samples`` sample periods without wheel motion, from the last
    moving sample before it to the sample before the next motion, and nothing else."""
    dt = 0.1
    steps = np.concatenate([np.full(n, 1.0 if moving else 0.0) for moving, n in pattern])
    left = np.concatenate([[0.0], np.cumsum(steps)])
    t = np.arange(left.size) * dt
    got = still_periods(t, left, np.zeros_like(left), min_samples * dt - 1e-9)
    want, a, m = [], 0, 0  # a: the sample before the current still block, m: its steps
    for k, moving in enumerate(steps != 0, start=1):
        if moving:
            if m >= min_samples:
                want.append((t[a], t[a + m]))
            a, m = k, 0
        else:
            m += 1
    if m >= min_samples:
        want.append((t[a], t[a + m]))
    assert len(got) == len(want)
    assert np.allclose(np.reshape(got, (-1, 2)), np.reshape(want, (-1, 2)), atol=1e-12)


def test_ros1_bag_with_odometry_as_the_wheels(tmp_path):
    """A ROS 1 bag, the wheels from nav_msgs/Odometry: the same wheelbase."""
    log = simulate_drive(spins(2 * math.pi, [1, -1] * 2), SKID, seed=11)
    bag = bag_of(log, tmp_path / "spins.bag", Gyro(100.0, 1.0, BIAS, NOISE), seed=12, storage="ros1", odom=True)
    d = json.loads(run(["replay", str(bag), "--imu-topic", "/imu", "--odom-topic", "/odom", *SKID_GEO, "--json"]))
    assert abs(d["gyro"]["wheelbase_m"] / (FACTOR * TRACK) - 1) < 0.005
    assert d["gyro"]["turns_used"] == 4


def test_robot_turned_by_hand_while_the_wheels_rest(tmp_path):
    """Lifted and turned 40 deg by hand for 2 s of an 8 s rest (the wheels still): neither the
    bias nor the turns take it in."""
    cmds = [Command(2.0)]
    for i, sign in enumerate([1, -1, 1, -1]):
        cmds += [Command(2 * math.pi / 0.8, 0.0, sign * 0.8), Command(8.0 if i == 1 else 1.5)]
    log = simulate_drive(Program(tuple(cmds)), SKID, seed=13)
    t, w = simulate_gyro(log, Gyro(100.0, 1.0, BIAS, NOISE), seed=14)
    rest = 2.0 + 2 * (2 * math.pi / 0.8) + 1.5  # where the long rest begins
    hand = (t > rest + 2.0) & (t <= rest + 4.0)
    w = w + np.where(hand, math.radians(40.0) / 2.0 * (1 - np.cos(np.pi * (t - rest - 2.0))), 0.0)
    bag = write_drive_bag(log, tmp_path / "carried", gyro=(t, w), odom=False)
    g = json.loads(run(["replay", str(bag), "--imu-topic", "/imu", *JOINTS, *SKID_GEO, "--json"]))["gyro"]
    assert abs(g["wheelbase_m"] / (FACTOR * TRACK) - 1) < 0.005
    assert abs(g["bias_rad_per_s"] - BIAS) < 0.1 * BIAS
    # the hand's turn is there, outside every turn the fit uses
    assert all(not (u["t_s"][0] < rest + 3.0 < u["t_s"][1]) for u in g["turns"])
