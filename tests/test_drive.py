"""umbmark.model.drive: the simulated lidar robot against exact kinematics (umbmark.model.se2)."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.model.drive import (
    EXAMPLE_ROBOT,
    Command,
    Program,
    SimRobot,
    WheelNoise,
    integrate_wheels,
    mixed_program,
    one_way_turns,
    simulate_drive,
    spins_only,
    straight_only,
)
from umbmark.model.geometry import LABMATE, ErrorParams, wrap_angle
from umbmark.model.intervals import sensor_motion
from umbmark.model.se2 import arc, between, compose, inverse
from umbmark.model.sensors import Lidar, Room, SensorPose, cast_rays

QUIET = dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(n_beams=90, range_noise_m=0.0))
ROUGH = SimRobot(LABMATE, ErrorParams(ed=0.985, eb=0.95, es=1.02), SensorPose(-0.05, 0.08, -0.4), Lidar(n_beams=90))
TINY = Lidar(n_beams=4, range_noise_m=0.0)
REALISTIC = WheelNoise(speed_rel_sd=0.02, slip_m_per_sqrt_m=3.35e-4)


@pytest.fixture(scope="module")
def mixed():
    return simulate_drive(mixed_program(120.0, seed=7, robot=QUIET), QUIET)


def test_a_noise_free_straight_gives_the_exact_distance():
    robot = SimRobot(LABMATE, ErrorParams(ed=1.0, eb=1.03, es=0.98), lidar=Lidar(n_beams=8, range_noise_m=0.0))
    log = simulate_drive([Command(10.0, 0.3)], robot, start_pose=(2.0, 3.0, 0.5))
    d = between(log.true_pose[0], log.true_pose[-1])
    assert d[0] == pytest.approx(0.98 * 0.3 * 10.0, rel=1e-12)  # E_s of the commanded 3 m
    assert abs(d[1]) < 1e-12 and abs(d[2]) < 1e-15
    assert log.left_rad[-1] == pytest.approx(3.0 / (0.5 * LABMATE.wheel_diameter_m), rel=1e-12)
    assert len(log.t_s) == 1001 and log.t_s[-1] == pytest.approx(10.0)


def test_a_straight_with_unequal_wheels_is_the_true_arc():
    log = simulate_drive([Command(8.0, 0.25)], QUIET)
    true = QUIET.true_wheels
    w = 0.25 / (0.5 * LABMATE.wheel_diameter_m)
    want = arc(0.5 * true.diameter_left_m * w * 8.0, 0.5 * true.diameter_right_m * w * 8.0, true.wheelbase_m)
    np.testing.assert_allclose(between(log.true_pose[0], log.true_pose[-1]), want, atol=1e-12)
    assert want[2] > 0.01  # E_d > 1: the right wheel is larger, the robot drifts left


@pytest.mark.parametrize("omega", [0.7, -1.1])
def test_a_spin_turns_the_angle_of_the_true_wheelbase(omega):
    robot = SimRobot(LABMATE, ErrorParams(ed=1.0, eb=1.04, es=0.99), lidar=Lidar(n_beams=8, range_noise_m=0.0))
    log = simulate_drive([Command(5.0, 0.0, omega)], robot)
    # commanded: omega * 5 s with the nominal wheelbase; turned: times E_s / E_b
    assert log.true_pose[-1, 2] - log.true_pose[0, 2] == pytest.approx(omega * 5.0 * 0.99 / 1.04, rel=1e-12)
    np.testing.assert_allclose(log.true_pose[-1, :2], log.true_pose[0, :2], atol=1e-12)


def test_every_sample_is_the_true_arc_of_the_wheel_angles(mixed):
    true = mixed.true_geometry
    dl = 0.5 * true.diameter_left_m * np.diff(mixed.left_rad)
    dr = 0.5 * true.diameter_right_m * np.diff(mixed.right_rad)
    want = arc(dl, dr, true.wheelbase_m)
    got = between(mixed.true_pose[:-1], mixed.true_pose[1:])
    np.testing.assert_allclose(got[:, :2], want[:, :2], atol=1e-12)
    np.testing.assert_allclose(got[:, 2], wrap_angle(want[:, 2]), atol=1e-12)
    np.testing.assert_allclose(np.diff(mixed.true_pose[:, 2]), want[:, 2], atol=1e-15)


def test_wheel_speeds_come_from_the_nominal_geometry():
    robot = QUIET
    log = simulate_drive([Command(2.0, 0.2, 0.5)], robot)
    r, b = 0.5 * LABMATE.wheel_diameter_m, LABMATE.wheelbase_m
    np.testing.assert_allclose(np.diff(log.left_rad) * 100.0, (0.2 - 0.5 * b / 2) / r, rtol=1e-12)
    np.testing.assert_allclose(np.diff(log.right_rad) * 100.0, (0.2 + 0.5 * b / 2) / r, rtol=1e-12)
    # the nominal odometry is what the robot believes: exactly the commanded arc
    odo = log.odometry()
    np.testing.assert_allclose(odo[-1], [*(arc(0.2 * 2 - 0.5 * b, 0.2 * 2 + 0.5 * b, b)[:2]), 1.0], atol=1e-12)


def test_the_odometry_of_the_true_geometry_is_the_true_path(mixed):
    odo = mixed.odometry(mixed.true_geometry)
    rel = between(mixed.true_pose[0], mixed.true_pose)
    np.testing.assert_allclose(odo[:, :2], rel[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(odo[:, 2]), rel[:, 2], atol=1e-9)
    nominal = mixed.odometry()
    assert np.max(np.hypot(*(nominal[:, :2] - rel[:, :2]).T)) > 0.05  # the nominal one drifts


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)), min_size=1, max_size=30),
    st.floats(0.1, 1.0),
    st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-4, 4)),
)
def test_integrate_wheels_composes_the_arcs(steps, b, start):
    dl, dr = np.array(steps).T
    got = integrate_wheels(dl, dr, b, start)
    pose = np.array(start)
    assert np.allclose(got[0], pose)
    for k in range(len(dl)):
        pose = compose(pose, arc(dl[k], dr[k], b))
        np.testing.assert_allclose(got[k + 1, :2], pose[:2], atol=1e-12)
        assert wrap_angle(got[k + 1, 2] - pose[2]) == pytest.approx(0.0, abs=1e-12)


def test_a_scan_is_the_ray_cast_from_the_true_sensor_pose(mixed):
    m = 123
    assert mixed.scan_t_s[m] == pytest.approx(12.3)
    np.testing.assert_allclose(mixed.scan_pose[m], mixed.true_pose[1230], atol=1e-12)
    sensor = compose(mixed.true_pose[1230], QUIET.sensor_pose.as_array())
    np.testing.assert_allclose(mixed.sensor_world_pose[m], sensor, atol=1e-12)
    want = cast_rays(mixed.room, sensor, QUIET.lidar.angles_rad, QUIET.lidar.max_range_m)
    np.testing.assert_allclose(mixed.ranges_m[m], want, rtol=1e-12)
    assert mixed.ranges_m.shape == (1201, 90) and np.isfinite(mixed.ranges_m).mean() > 0.95


def test_scan_intervals_follow_the_calibration_model(mixed):
    """Noise free, with commands on the scan grid: s_k = l^-1 (+) q_k (+) l exactly (the design's model)."""
    dt, left, right, sensor = mixed.scan_intervals()
    true = mixed.true_geometry
    q = arc(0.5 * true.diameter_left_m * left, 0.5 * true.diameter_right_m * right, true.wheelbase_m)
    q[:, 2] = wrap_angle(q[:, 2])
    mount = mixed.sensor_pose.as_array()
    want = compose(compose(inverse(mount), q), mount)
    np.testing.assert_allclose(dt, 0.1, atol=1e-12)
    np.testing.assert_allclose(sensor[:, :2], want[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(sensor[:, 2] - want[:, 2]), 0.0, atol=1e-12)
    assert len(sensor) == 1200


def test_the_intervals_are_the_estimators_model(mixed):
    """The drive's true sensor motion against umbmark.model.intervals.sensor_motion, written independently."""
    iv = mixed.intervals()
    true = mixed.true_geometry
    model = sensor_motion(
        iv.left_rad,
        iv.right_rad,
        0.5 * true.diameter_left_m,
        0.5 * true.diameter_right_m,
        true.wheelbase_m,
        mixed.sensor_pose.as_array(),
    )
    assert len(iv) == 1200 and iv.source == "simulated drive"
    np.testing.assert_allclose(iv.sensor[:, :2], model[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(iv.sensor[:, 2] - model[:, 2]), 0.0, atol=1e-12)
    # with slip the model no longer holds exactly, by about the slip
    noisy = simulate_drive(mixed_program(30.0, seed=7, robot=QUIET), QUIET, noise=REALISTIC, seed=1).intervals()
    gap = noisy.sensor - sensor_motion(
        noisy.left_rad,
        noisy.right_rad,
        0.5 * true.diameter_left_m,
        0.5 * true.diameter_right_m,
        true.wheelbase_m,
        mixed.sensor_pose.as_array(),
    )
    assert 1e-6 < np.abs(gap[:, :2]).max() < 5e-3


def test_poses_between_samples_are_exact():
    """Scans half-way through a sample: the 100 Hz drive's interpolated pose is the 200 Hz drive's sample."""
    prog = mixed_program(20.0, seed=3, robot=QUIET)
    a = simulate_drive(prog, QUIET, scan_offset_s=0.005)
    b = simulate_drive(prog, QUIET, wheel_rate_hz=200.0, scan_offset_s=0.005)
    np.testing.assert_allclose(a.scan_pose, b.scan_pose, atol=1e-12)
    np.testing.assert_allclose(b.scan_pose, b.true_pose[1::20][: len(b.scan_t_s)], atol=1e-12)
    t = np.array([0.0, 0.0025, 7.777, 20.0])
    np.testing.assert_allclose(a.true_pose_at(t), b.true_pose_at(t), atol=1e-12)
    la, ra = a.wheel_angles_at(t)
    lb, rb = b.wheel_angles_at(t)
    np.testing.assert_allclose([la, ra], [lb, rb], atol=1e-12)
    with pytest.raises(InputError, match="within the drive"):
        a.true_pose_at(20.5)


@pytest.mark.parametrize("robot", [EXAMPLE_ROBOT, ROUGH], ids=["example", "rough"])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_mixed_program_stays_in_the_room(robot, seed):
    room = Room.default()
    prog = mixed_program(120.0, seed=seed, robot=robot)
    assert prog.duration_s == pytest.approx(120.0)
    for noise, least in ((None, 0.59), (REALISTIC, 0.5)):
        log = simulate_drive(prog, dataclasses.replace(robot, lidar=TINY), noise=noise, seed=seed)
        xy = log.true_pose[:, :2]
        assert room.contains(xy).all()
        assert room.distance_to_walls(xy).min() >= least
    kinds = {(c.v_mps != 0.0, int(np.sign(c.omega_radps))) for c in prog.commands}
    # straights, arcs of both signs, spins both ways and pauses
    assert kinds == {(True, 0), (True, 1), (True, -1), (False, 1), (False, -1), (False, 0)}
    steps = np.array([c.duration_s for c in prog.commands]) / 0.1
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)


def test_the_mixed_program_covers_the_room():
    xy = simulate_drive(mixed_program(600.0, seed=5), dataclasses.replace(QUIET, lidar=TINY)).true_pose
    assert np.ptp(xy[:, 0]) > 5.0 and np.ptp(xy[:, 1]) > 4.0
    assert abs(np.diff(xy[:, 2])).sum() > 50.0  # many turns


def test_a_start_too_close_to_a_wall_is_refused():
    with pytest.raises(InputError, match="start_pose"):
        mixed_program(10.0, start_pose=(0.3, 4.0, 0.0))
    with pytest.raises(InputError, match="give `start_pose`"):
        simulate_drive([Command(1.0, 0.1)], QUIET, room=Room(np.array([[5.0, 0.0, 5.0, 8.0], [0.0, 0.0, 10.0, 0.0]])))


@pytest.mark.parametrize(
    "program, check, signs",
    [
        (straight_only(60.0), lambda c: c.omega_radps == 0.0 and c.v_mps != 0.0, {(1, 0), (-1, 0)}),
        (spins_only(60.0), lambda c: c.v_mps == 0.0 and c.omega_radps != 0.0, {(0, 1), (0, -1)}),
        (one_way_turns(60.0), lambda c: c.omega_radps > 0.0, {(1, 1), (0, 1)}),
    ],
    ids=["straight_only", "spins_only", "one_way_turns"],
)
def test_the_simple_programs(program, check, signs):
    assert all(check(c) for c in program.commands)
    assert {(int(np.sign(c.v_mps)), int(np.sign(c.omega_radps))) for c in program.commands} == signs
    assert program.duration_s == pytest.approx(60.0)
    room = Room.default()
    for robot in (EXAMPLE_ROBOT, ROUGH):
        log = simulate_drive(program, dataclasses.replace(robot, lidar=TINY), seed=1)
        assert room.distance_to_walls(log.true_pose[:, :2]).min() >= 0.5


def test_the_same_seed_gives_the_same_drive_and_the_streams_are_independent():
    prog = mixed_program(20.0, seed=2)
    a = simulate_drive(prog, EXAMPLE_ROBOT, noise=REALISTIC, seed=9)
    b = simulate_drive(prog, EXAMPLE_ROBOT, noise=REALISTIC, seed=9)
    c = simulate_drive(prog, EXAMPLE_ROBOT, noise=REALISTIC, seed=10)
    for name in ("left_rad", "right_rad", "true_pose", "ranges_m"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
        assert not np.array_equal(getattr(a, name), getattr(c, name))
    # the lidar's noise does not change the wheels' draws
    d = simulate_drive(prog, dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(dropout_prob=0.1)), noise=REALISTIC, seed=9)
    assert np.array_equal(a.left_rad, d.left_rad) and np.array_equal(a.true_pose, d.true_pose)
    assert not np.array_equal(a.ranges_m, d.ranges_m)
    with pytest.raises(InputError, match="seed"):
        simulate_drive(prog, EXAMPLE_ROBOT)


def test_slip_noise_has_its_random_walk_size():
    robot = dataclasses.replace(QUIET, lidar=TINY)
    k = 1e-3
    log = simulate_drive(straight_only(120.0), robot, noise=WheelNoise(slip_m_per_sqrt_m=k), seed=4)
    true = log.true_geometry
    ideal = 0.5 * true.diameter_left_m * np.diff(log.left_rad)
    z = (log.travel_left_m - ideal) / (k * np.sqrt(np.abs(ideal)))
    assert abs(z.mean()) < 5 / math.sqrt(z.size)
    assert z.std() == pytest.approx(1.0, rel=0.03)


def test_speed_noise_is_seen_by_the_encoders():
    """Wheel-speed jitter changes the path but not the odometry's accuracy: the true geometry still replays it."""
    robot = dataclasses.replace(QUIET, lidar=TINY)
    log = simulate_drive(straight_only(30.0), robot, noise=WheelNoise(speed_rel_sd=0.05), seed=4)
    rates = np.diff(log.left_rad) * 100.0
    nominal_rate = 0.3 / (0.5 * LABMATE.wheel_diameter_m)
    assert np.std(np.abs(rates) / nominal_rate) == pytest.approx(0.05, rel=0.05)
    odo = log.odometry(log.true_geometry)
    np.testing.assert_allclose(odo[:, :2], between(log.true_pose[0], log.true_pose)[:, :2], atol=1e-9)


def test_quantised_encoders_report_whole_pulses():
    robot = dataclasses.replace(QUIET, lidar=TINY)
    log = simulate_drive([Command(3.0, 0.2, 0.3)], robot, noise=WheelNoise(quantise=True))
    pulses = log.left_rad / (2 * math.pi / LABMATE.pulses_per_wheel_rev)
    np.testing.assert_allclose(pulses, np.round(pulses), atol=1e-6)
    exact = simulate_drive([Command(3.0, 0.2, 0.3)], robot)
    step = 2 * math.pi / LABMATE.pulses_per_wheel_rev
    assert np.all((exact.left_rad - log.left_rad >= -1e-9) & (exact.left_rad - log.left_rad < step))
    np.testing.assert_array_equal(log.true_pose, exact.true_pose)


def test_commands_are_whole_samples_and_programs_are_checked():
    log = simulate_drive([Command(0.104, 0.1), Command(0.2, 0.0, 0.5)], QUIET)
    assert len(log.t_s) == 31  # 10 + 20 samples
    with pytest.raises(InputError, match="duration_s"):
        Command(0.0, 0.1)
    with pytest.raises(InputError, match="no commands"):
        simulate_drive([], QUIET)
    with pytest.raises(InputError, match="wheel_rate_hz"):
        simulate_drive([Command(1.0)], QUIET, wheel_rate_hz=0.0)
    with pytest.raises(InputError, match="scan_offset_s"):
        simulate_drive([Command(1.0)], QUIET, scan_offset_s=0.1)
    with pytest.raises(InputError, match="more than"):
        simulate_drive([Command(1e6)], QUIET)
    assert isinstance(mixed_program(5.0), Program)
