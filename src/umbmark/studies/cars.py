"""Simulated cars with a known truth: an F1TENTH-sized car with a 270-degree lidar, a larger car, a
four-wheel Ackermann car; their drives written as the bags their owners record.

Each car (:data:`CARS`) has a nominal geometry (what its software believes), a true one (its
wheels a little off, its steering read with an offset and a scale), a lidar where its drawing
does not quite say, and its joints' names. :func:`car_bag` drives it in the test room
(:func:`umbmark.model.kinematic_drive.kinematic_program`: straights, backing up, figure-eights
near full lock, reversing arcs; the larger cars in a room 1.6 times as large) and writes a ROS 1
bag with the joint states, the scans, the true pose on ``/ground_truth`` and the car's own
odometry on ``/odom`` integrated as F1TENTH's ``vesc_to_odom`` does it with the nominal values.
:func:`umbmark.cli.kinematic_args.car_selfcal_args` gives the command that calibrates it from its
joints or from ``/odom``; :func:`truth` the values the calibration must find under its JSON keys;
:func:`vesc_truth` the vesc driver's gains the truth implies.

The tests (``tests/test_cars.py``) and ``benchmarks/car_accuracy.py`` share them.

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.kinds` and :mod:`umbmark.io` (the bag writer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from umbmark.errors import InputError
from umbmark.io.rosbag_write import write_drive_bag
from umbmark.kinds import Ackermann, Bicycle, kind_of
from umbmark.kinds.bicycle import vesc_values
from umbmark.model.kinematic_drive import JointNoise, KinematicRobot, kinematic_program, simulate_kinematic_drive
from umbmark.model.kinematics import Kinematics
from umbmark.model.sensors import Lidar, Room, SensorPose

__all__ = ["Car", "CARS", "VESC_IN_USE", "VESC_YAML", "car_bag", "car_named", "truth", "vesc_truth", "SOURCES"]

SOURCES = ("joints", "odom")
"""What a car's calibration reads: its joint states, or its own odometry (``/odom``)."""


@dataclass(frozen=True)
class Car:
    """A simulated car.

    Attributes
    ----------
    name : str
    nominal, true : Kinematics
        The geometry its software believes and the one it has.
    sensor_pose : SensorPose
        Where its lidar truly sits.
    lidar : Lidar
    joints : tuple of str
        Its joints' names, in the kind's roles' order.
    describe : str
    room_scale : float
        The test room (:meth:`umbmark.model.sensors.Room.default`, about 10 x 8 m) this many times
        as large: room for a larger car's loops.
    """

    name: str
    nominal: Kinematics
    true: Kinematics
    sensor_pose: SensorPose
    lidar: Lidar
    joints: tuple[str, ...]
    describe: str
    room_scale: float = 1.0

    @property
    def room(self) -> Room:
        """The room it drives in."""
        r = Room.default()
        return Room(r.segments * self.room_scale, None if r.outline is None else r.outline * self.room_scale)

    @property
    def reads_odometry(self) -> bool:
        """Whether it is calibrated from its ``/odom`` too (a bicycle-model car)."""
        return kind_of(self.nominal).reads_odometry


CARS = {
    c.name: c
    for c in (
        Car(
            "f1tenth",
            Bicycle(0.110, 0.330),
            Bicycle(0.1115, 0.330, math.radians(1.2), 1.04),
            SensorPose(0.27, 0.01, math.radians(0.6)),
            Lidar(n_beams=271, fov_rad=math.radians(270.0), max_range_m=10.0, range_noise_m=0.005),
            ("rear_wheel_joint", "steering_joint"),
            "an F1TENTH-sized car (wheels 110 mm, wheelbase 330 mm) with a 270-degree lidar",
        ),
        Car(
            "large",
            Bicycle(0.250, 0.650),
            Bicycle(0.2475, 0.650, math.radians(-0.8), 0.96),
            SensorPose(0.45, -0.02, math.radians(-0.7)),
            Lidar(n_beams=240, range_noise_m=0.005),
            ("rear_wheel_joint", "steering_joint"),
            "a larger car (wheels 250 mm, wheelbase 650 mm) with a 360-degree lidar",
            1.6,
        ),
        Car(
            "ackermann",
            Ackermann(0.200, 0.600, 0.450, 0.420),
            Ackermann(0.2025, 0.600, 0.450, 0.420, math.radians(1.0), 1.03),
            SensorPose(0.40, 0.015, math.radians(0.8)),
            Lidar(n_beams=240, range_noise_m=0.005),
            (
                "rear_left_wheel_joint",
                "rear_right_wheel_joint",
                "front_left_steering_joint",
                "front_right_steering_joint",
            ),
            "a four-wheel Ackermann car (wheels 200 mm, wheelbase 600 mm, tracks 450 and 420 mm)",
            1.6,
        ),
    )
}
"""The simulated cars by name."""

VESC_IN_USE = {
    "speed_to_erpm_gain": 4614.0,
    "speed_to_erpm_offset": 0.0,
    "steering_angle_to_servo_gain": -1.2135,
    "steering_angle_to_servo_offset": 0.5304,
}
"""The vesc driver's gains of F1TENTH's stock parameter file (the values in use of the examples)."""

VESC_YAML = """\
/**:
  # the parameters every vesc node reads
  ros__parameters:
    # erpm = speed_to_erpm_gain * speed [m/s] + speed_to_erpm_offset
    speed_to_erpm_gain: 4614.0
    speed_to_erpm_offset: 0.0
    # servo position (0 to 1) = steering_angle_to_servo_gain * angle [rad] + steering_angle_to_servo_offset
    steering_angle_to_servo_gain: -1.2135
    steering_angle_to_servo_offset: 0.5304
    port: /dev/sensors/vesc
    servo_min: 0.15
    servo_max: 0.85

vesc_to_odom_node:
  ros__parameters:
    odom_frame: odom
    base_frame: base_link
    use_servo_cmd_to_calc_angular_velocity: true   # the odometry turns with the steering
    wheelbase: 0.33
"""
"""A vesc driver's parameter file of the examples (ROS 2), with :data:`VESC_IN_USE`."""

_NOISE = JointNoise(speed_rel_sd=0.01, slip_m_per_sqrt_m=2e-4, steer_sd_rad=math.radians(0.05))


def car_bag(
    name: str, path: str | Path, duration_s: float = 45.0, seed: int = 2, tum: str | Path | None = None
) -> Path:
    """Drive a car of :data:`CARS` for about ``duration_s`` and write its bag (see the module docstring),
    and with ``tum`` the car's true poses at the scans there (a TUM trajectory of its base frame).

    Raises
    ------
    InputError
        An unknown car, or what the simulator and the bag writer refuse.
    """
    car = car_named(name)
    robot = KinematicRobot(car.nominal, car.true, car.sensor_pose, car.lidar)
    room = car.room
    moves, start = kinematic_program(robot, duration_s, seed=seed, room=room)
    log = simulate_kinematic_drive(
        moves, robot, room, start_pose=start, joint_names=car.joints, noise=_NOISE, seed=seed
    )
    if tum is not None:
        from umbmark.io.rosbag_write import EPOCH_S
        from umbmark.io.tum import Trajectory, write_tum

        write_tum(Trajectory(EPOCH_S + log.scan_stamps_s, log.scan_pose), tum)
    return write_drive_bag(log, path, truth=True, odom=True, odom_scheme="euler")


def car_named(name: str) -> Car:
    """A car of :data:`CARS` by name (an unknown one: one line naming them)."""
    if name not in CARS:
        raise InputError(f"unknown car {name!r} (choose from {', '.join(CARS)})")
    return CARS[name]


def truth(name: str) -> dict[str, float]:
    """What a car's calibration must find, under the JSON's keys (``sensor_pose.x_mm`` nested with a dot)."""
    car = car_named(name)
    values = dict(zip(car.true.parameter_names, car.true.vector()))
    p = car.sensor_pose
    return {
        "wheel_diameter_mm": values["wheel_diameter_m"] * 1e3,
        "steering_scale": values["steering_scale"],
        "steering_offset_deg": math.degrees(values["steering_offset_rad"]),
        "sensor_pose.x_mm": p.x_m * 1e3,
        "sensor_pose.y_mm": p.y_m * 1e3,
        "sensor_pose.yaw_deg": math.degrees(p.yaw_rad),
    }


def vesc_truth(name: str, in_use: dict[str, float] | None = None) -> dict[str, float]:
    """The vesc driver's gains the truth of a bicycle-model car implies, from those in use."""
    car = car_named(name)
    if not isinstance(car.true, Bicycle) or not isinstance(car.nominal, Bicycle):
        raise InputError(f"the {name} car has no vesc")
    return vesc_values(car.true, car.nominal, VESC_IN_USE if in_use is None else in_use)
