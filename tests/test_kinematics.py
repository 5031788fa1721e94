"""Tricycle and mecanum kinematics, their simulated drives and their self-calibration (without bags)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.correct.selfcal import selfcal
from umbmark.correct.selfcal.kinematic import KinematicProblem, kinematic_selfcal
from umbmark.errors import InputError
from umbmark.kinds import DiffDrive, Mecanum, Tricycle
from umbmark.model import se2
from umbmark.model.intervals import Intervals
from umbmark.model.kinematic_drive import JointNoise, KinematicRobot, kinematic_program, simulate_kinematic_drive
from umbmark.model.kinematics import (
    JointIntervals,
    JointSteps,
    compose_steps,
    integrate_steps,
    joint_intervals_from_motion,
    twist_displacement,
)
from umbmark.model.sensors import Lidar, SensorPose

TRICYCLE = (Tricycle(0.25, 0.6), Tricycle(0.2525, 0.59, math.radians(1.5)))
MECANUM = (Mecanum.uniform(0.1, 0.4), Mecanum((0.101, 0.0995, 0.1003, 0.0998), 0.405))
POSE = SensorPose(0.3, -0.05, math.radians(2.0))
speeds = st.floats(-1.0, 1.0, allow_nan=False)


# ---------------------------------------------------------------- conventions
def test_a_tricycle_steered_left_turns_left_and_an_offset_curves_a_straight_command():
    t = Tricycle(0.2, 0.5)
    tw = t.twist([[1.0, math.radians(20)]])[0]
    assert tw[0] > 0 and tw[2] > 0 and tw[1] == 0
    off = Tricycle(0.2, 0.5, math.radians(1.0))
    assert off.twist([[1.0, 0.0]])[0, 2] > 0  # a measured 0 steers left by the offset
    # a quarter turn of the steering spins the robot about the rear axle's midpoint
    spin = t.twist([[1.0, math.pi / 2]])[0]
    assert abs(spin[0]) < 1e-12 and spin[2] == pytest.approx(0.1 / 0.5)


def test_a_bigger_front_right_mecanum_wheel_drifts_left_and_turns_left():
    m = Mecanum((0.1, 0.102, 0.1, 0.1), 0.4)
    tw = m.twist([[1.0, 1.0, 1.0, 1.0]])[0]
    assert tw[0] > 0 and tw[1] > 0 and tw[2] > 0


def test_the_mecanum_forward_kinematics_is_the_controllers():
    """ros2_controllers' mecanum odometry: vx = r/4 (FL + BL + BR + FR), vy = r/4 (-FL + BL - BR + FR),
    wz = r/(4 k) (-FL - BL + BR + FR)."""
    r, k = 0.05, 0.3
    w = np.array([0.3, -1.1, 2.0, 0.7])  # FL, FR, RL, RR
    fl, fr, rl, rr = w
    want = [r / 4 * (fl + rl + rr + fr), r / 4 * (-fl + rl - rr + fr), r / (4 * k) * (-fl - rl + rr + fr)]
    np.testing.assert_allclose(Mecanum.uniform(2 * r, k).twist(w[None])[0], want, rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(speeds, speeds, speeds)
def test_each_kind_drives_the_twist_its_inverse_kinematics_commands(vx, vy, w):
    dt = 0.01
    for k, lateral in (
        (Tricycle(0.2, 0.6, math.radians(2.0), 1.03), False),
        (Mecanum((0.1, 0.11, 0.09, 0.1), 0.35), True),
        (DiffDrive(0.15, 0.152, 0.34), False),
    ):
        y = vy if lateral else 0.0
        if isinstance(k, Tricycle) and vx == 0 and w == 0:
            continue
        tw = k.twist(k.joint_motion(vx, y, w, dt))
        np.testing.assert_allclose(tw, np.array([vx, y, w]) * dt, atol=1e-12)


def test_a_kind_without_sideways_motion_refuses_a_sideways_command():
    with pytest.raises(InputError, match="sideways"):
        Tricycle(0.2, 0.6).joint_motion(0.1, 0.1, 0.0, 0.01)
    with pytest.raises(InputError, match="sideways"):
        DiffDrive(0.1, 0.1, 0.3).joint_motion(0.1, 0.1, 0.0, 0.01)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Tricycle(-0.2, 0.6),
        lambda: Tricycle(0.2, 0.6, math.radians(120.0)),
        lambda: Mecanum((0.1, 0.1, 0.1), 0.3),
        lambda: Mecanum.uniform(0.1, float("nan")),
        lambda: DiffDrive(0.1, 0.1, 0.0),
    ],
)
def test_impossible_geometry_is_refused(make):
    with pytest.raises(InputError):
        make()


@settings(max_examples=80, deadline=None)
@given(st.floats(-2, 2), st.floats(-2, 2), st.floats(-7, 7))
def test_the_displacement_of_a_twist_is_two_halves_composed(a, b, th):
    whole = twist_displacement([a, b, th])
    half = twist_displacement([a / 2, b / 2, th / 2])
    two = se2.compose(half, half)
    np.testing.assert_allclose(two[:2], whole[:2], atol=1e-9)
    assert se2.between(np.r_[0, 0, th], np.r_[0, 0, two[2]])[2] == pytest.approx(0.0, abs=1e-9)


def test_a_twist_without_sideways_motion_is_the_differential_drive_arc():
    d = np.array([0.3, -0.2, 0.0, 1.0])
    dth = np.array([0.5, 1e-9, 2.0, -3.0])
    np.testing.assert_allclose(twist_displacement(np.c_[d, 0 * d, dth]), se2.arc(d - dth / 2, d + dth / 2, 1.0))


def test_composed_steps_are_the_integrated_path_between_the_intervals_ends():
    rng = np.random.default_rng(0)
    local = twist_displacement(rng.normal(0, 0.1, (30, 3)))
    start = np.array([0, 4, 5, 17, 30])
    q = compose_steps(local, start)
    path = integrate_steps(local)
    for k in range(4):
        rel = se2.between(path[start[k]], path[start[k + 1]])
        np.testing.assert_allclose(rel[:2], q[k, :2], atol=1e-12)
        assert path[start[k + 1], 2] - path[start[k], 2] == pytest.approx(q[k, 2])


def test_joint_steps_refuse_offsets_and_values_that_do_not_fit():
    with pytest.raises(InputError, match="start"):
        JointSteps(np.zeros((3, 2)), [0, 2])
    with pytest.raises(InputError, match="finite"):
        JointSteps(np.array([[0.0, np.nan]]), [0, 1])
    with pytest.raises(InputError, match="dt_s"):
        JointSteps(np.zeros((2, 2)), [0, 2], [0.1])


# ---------------------------------------------------------------- simulation
@pytest.mark.parametrize("pair", [TRICYCLE, MECANUM], ids=["tricycle", "mecanum"])
def test_the_true_geometrys_odometry_of_a_noise_free_drive_is_its_true_path(pair):
    nominal, true = pair
    robot = KinematicRobot(nominal, true, POSE, Lidar(n_beams=90))
    moves, start = kinematic_program(robot, 40, seed=2)
    log = simulate_kinematic_drive(moves, robot, start_pose=start, seed=1)
    odo = log.odometry(true)
    rel = se2.between(log.true_pose[0], log.true_pose)
    np.testing.assert_allclose(odo[:, :2], rel[:, :2], atol=1e-9)
    # and the nominal geometry's drifts (the systematic errors are there to find)
    assert np.hypot(*(log.odometry()[-1, :2] - rel[-1, :2])) > 0.01


def test_a_simulated_drive_stays_in_the_room_and_scans_it():
    robot = KinematicRobot(*MECANUM, POSE, Lidar(n_beams=90))
    moves, start = kinematic_program(robot, 60, seed=5)
    log = simulate_kinematic_drive(moves, robot, start_pose=start, seed=1)
    assert np.all(log.room.distance_to_walls(log.true_pose[:, :2]) > 0.5)
    assert np.isfinite(log.ranges_m).mean() > 0.9
    assert {m.vy_mps > 0 for m in moves if abs(m.vy_mps) > 0.05} == {True, False}  # sideways both ways


def test_a_noisy_drive_needs_a_seed():
    robot = KinematicRobot(*TRICYCLE, POSE, Lidar(n_beams=90, range_noise_m=0.0, dropout_prob=0.0))
    moves, start = kinematic_program(robot, 20, seed=1)
    with pytest.raises(InputError, match="seed"):
        simulate_kinematic_drive(moves, robot, start_pose=start, noise=JointNoise(speed_rel_sd=0.01))


def test_a_robot_of_two_kinds_is_refused():
    with pytest.raises(InputError, match="one kind"):
        KinematicRobot(Tricycle(0.2, 0.6), Mecanum.uniform(0.1, 0.3))


# ---------------------------------------------------------------- self-calibration
def _intervals(log, sd_m=0.0, seed=0, every=5):
    """Intervals of ``every`` scans with the true sensor motion (plus noise), steps at the joint samples."""
    t_scan = log.scan_t_s[::every]
    t = np.unique(np.concatenate([log.t_s, t_scan]))
    js = log.joint_steps(t)
    b = np.searchsorted(t, t_scan)
    steps = JointSteps(js.values[b[0] : b[-1]], b - b[0], js.dt_s[b[0] : b[-1]])
    iv = joint_intervals_from_motion(steps, log.true, log.sensor_pose.as_array())
    if sd_m:
        rng = np.random.default_rng(seed)
        noise = rng.normal(0.0, 1.0, iv.sensor.shape) * np.array([sd_m, sd_m, sd_m / 0.5])
        iv = JointIntervals(iv.dt_s, iv.steps, iv.sensor + noise)
    return iv


def _drive(pair, seed=1, kinds=None, duration=120.0, noise=None):
    nominal, true = pair
    robot = KinematicRobot(nominal, true, POSE, Lidar(n_beams=30))
    moves, start = kinematic_program(robot, duration, seed=seed, kinds=kinds)
    return simulate_kinematic_drive(moves, robot, start_pose=start, noise=noise, seed=seed)


@pytest.mark.parametrize("pair", [TRICYCLE, MECANUM], ids=["tricycle", "mecanum"])
def test_a_noise_free_robot_is_recovered_exactly(pair):
    log = _drive(pair)
    r = kinematic_selfcal(_intervals(log), pair[0])
    np.testing.assert_allclose(r.kinematics.vector(), pair[1].vector(), rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(r.sensor_pose, POSE.as_array(), atol=1e-8)
    assert r.warnings == []


def test_the_steering_scale_is_recovered_when_asked():
    true = Tricycle(0.2525, 0.59, math.radians(1.5), 1.04)
    log = _drive((TRICYCLE[0], true))
    fit = ("wheel_diameter_m", "wheelbase_m", "steering_offset_rad", "steering_scale")
    r = kinematic_selfcal(_intervals(log), TRICYCLE[0], fit=fit)
    assert r.kinematics.steering_scale == pytest.approx(1.04, rel=1e-7)
    assert "steering_scale" in r.ci95


@pytest.mark.parametrize("pair", [TRICYCLE, MECANUM], ids=["tricycle", "mecanum"])
def test_the_jacobian_is_the_residuals_derivative(pair):
    iv = _intervals(_drive(pair, duration=30.0))
    prob = KinematicProblem(iv, pair[0], [n != "steering_scale" for n in pair[0].parameter_names])
    p = np.concatenate([pair[1].vector()[prob.free], POSE.as_array()]) * 1.001
    j = prob.jac(p, prob.all)
    num = np.zeros_like(j)
    for i in range(len(p)):
        e = np.zeros(len(p))
        e[i] = 1e-6 * prob.param_scale(p)[i]
        num[:, :, i] = -(prob.res(p + e, prob.all) - prob.res(p - e, prob.all)) / (2 * e[i])
    np.testing.assert_allclose(j, num, atol=1e-6 * np.abs(num).max())


def test_the_general_estimator_of_a_differential_drive_is_the_differential_drives():
    nominal, true = DiffDrive(0.15, 0.15, 0.34), DiffDrive(0.151, 0.1495, 0.35)
    log = _drive((nominal, true), duration=90.0, noise=JointNoise(speed_rel_sd=0.01))
    iv = _intervals(log, sd_m=0.002, seed=3)
    general = kinematic_selfcal(iv, nominal, reject_outliers=False)
    left, right = (np.add.reduceat(iv.steps.values[:, j], iv.steps.start[:-1]) for j in (0, 1))
    from umbmark.model.intervals import IntervalSteps

    steps = IntervalSteps(iv.steps.values[:, 0], iv.steps.values[:, 1], iv.steps.start)
    own = selfcal(
        Intervals(iv.dt_s, left, right, iv.sensor, steps=steps), 0.15, 0.34, reject_outliers=False, time_jitter=False
    )
    mine = general.kinematics.vector()
    np.testing.assert_allclose(mine, [own.diameter_left_m, own.diameter_right_m, own.wheelbase_m], rtol=1e-6)
    np.testing.assert_allclose(general.sensor_pose, own.sensor_pose, atol=1e-6)


@pytest.mark.parametrize("pair", [TRICYCLE, MECANUM], ids=["tricycle", "mecanum"])
def test_the_intervals_cover_the_truth(pair):
    """Coverage over noisy drives: the truth inside the 95 % intervals for most parameters and robots
    (``benchmarks/kinematic_coverage.py`` measures it over 50 robots from bags)."""
    inside, total = 0, 0
    for seed in range(8):
        log = _drive(pair, seed=seed, noise=JointNoise(speed_rel_sd=0.01))
        r = kinematic_selfcal(_intervals(log, sd_m=0.002, seed=seed), pair[0])
        truth = np.concatenate(
            [pair[1].vector()[[n != "steering_scale" for n in pair[0].parameter_names]], POSE.as_array()]
        )
        for name, v in zip(r.parameters, truth):
            lo, hi = r.ci95[name]
            inside += lo <= v <= hi
            total += 1
    assert inside / total >= 0.85


def test_a_mecanum_robot_that_never_moves_sideways_is_told_to():
    kinds = ("straight", "back", "arc+", "arc-", "spin+", "spin-")
    log = _drive(MECANUM, kinds=kinds, noise=JointNoise(speed_rel_sd=0.01))
    try:
        r = kinematic_selfcal(_intervals(log, sd_m=0.001), MECANUM[0])
        text = " ".join(r.warnings)
    except InputError as err:
        text = str(err)
    assert "sideways" in text and "lx_plus_ly_m" in text


def test_a_tricycle_that_steers_one_way_only_is_told_to_steer_both_ways():
    log = _drive(TRICYCLE, kinds=("straight", "back", "arc+", "spin+"), noise=JointNoise(speed_rel_sd=0.01))
    r = kinematic_selfcal(_intervals(log, sd_m=0.001), TRICYCLE[0])
    assert any("steer both ways" in w for w in r.warnings)


@pytest.mark.parametrize("pair", [TRICYCLE, MECANUM], ids=["tricycle", "mecanum"])
def test_a_drive_of_every_move_draws_no_warning(pair):
    log = _drive(pair, noise=JointNoise(speed_rel_sd=0.01))
    assert kinematic_selfcal(_intervals(log, sd_m=0.002), pair[0]).warnings == []


def test_intervals_of_another_kind_are_refused():
    iv = _intervals(_drive(TRICYCLE, duration=20.0))
    with pytest.raises(InputError, match="mecanum has 4"):
        kinematic_selfcal(iv, MECANUM[0])
    with pytest.raises(InputError, match="unknown parameter"):
        kinematic_selfcal(iv, TRICYCLE[0], fit=("wheel_radius_m",))


def test_quantised_joints_report_whole_pulses_and_still_calibrate():
    noise = JointNoise(speed_rel_sd=0.01, pulses_per_wheel_rev=1024)
    log = _drive(TRICYCLE, noise=noise)
    pulses = log.positions[:, 0] / (2 * math.pi / 1024)
    np.testing.assert_allclose(pulses, np.round(pulses), atol=1e-6)
    r = kinematic_selfcal(_intervals(log), TRICYCLE[0])
    assert r.kinematics.wheel_diameter_m == pytest.approx(TRICYCLE[1].wheel_diameter_m, rel=1e-3)
    with pytest.raises(InputError, match="whole number"):
        JointNoise(pulses_per_wheel_rev=0)
