"""The example tricycle and mecanum bags of the documentation (docs/tricycle.md, docs/mecanum.md).

A tricycle AGV (traction wheel 250 mm, wheelbase 800 mm nominal; truly 252.5 mm, 790 mm and a
steering offset of 1.5 deg) and a mecanum robot (wheels 100 mm, lx + ly 400 mm nominal; truly
101.0, 99.5, 100.3 and 99.8 mm, 405 mm), each with a 360-beam lidar (5 mm range noise, 10 Hz)
mounted 20 mm and 1 deg off its drawing, driving every move of its kind both ways for 2.5 minutes
with 1 % joint-speed jitter and slip: a ROS 1 bag with /joint_states, /scan, /tf_static (the
drawing's lidar pose) and /ground_truth (the robot's true pose).
"""

from __future__ import annotations

import dataclasses
import math

from umbmark.io.rosbag_write import write_drive_bag
from umbmark.kinds import Mecanum, Tricycle
from umbmark.model.kinematic_drive import JointNoise, KinematicRobot, kinematic_program, simulate_kinematic_drive
from umbmark.model.sensors import Lidar, SensorPose

ROBOTS = {
    "tricycle": dict(
        nominal=Tricycle(0.25, 0.80),
        true=Tricycle(0.2525, 0.79, math.radians(1.5)),
        joints=("traction_wheel_joint", "steering_joint"),
        lidar=SensorPose(0.42, -0.03, math.radians(1.0)),
        drawing=SensorPose(0.40, 0.0, 0.0),
    ),
    "mecanum": dict(
        nominal=Mecanum.uniform(0.10, 0.40),
        true=Mecanum((0.1010, 0.0995, 0.1003, 0.0998), 0.405),
        joints=("front_left_wheel_joint", "front_right_wheel_joint", "rear_left_wheel_joint", "rear_right_wheel_joint"),
        lidar=SensorPose(0.22, 0.02, math.radians(-1.0)),
        drawing=SensorPose(0.20, 0.0, 0.0),
    ),
}


def write_example_bag(path, kind: str, seed: int = 7):
    """Write the example bag of a kind (``tricycle`` or ``mecanum``) to ``path``."""
    spec = ROBOTS[kind]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=360, range_noise_m=0.005))
    moves, start = kinematic_program(robot, 150.0, seed=seed)
    noise = JointNoise(speed_rel_sd=0.01, slip_m_per_sqrt_m=2e-4, steer_sd_rad=math.radians(0.05))
    log = simulate_kinematic_drive(moves, robot, start_pose=start, joint_names=spec["joints"], noise=noise, seed=seed)
    drawn = dataclasses.replace(log, sensor_pose=spec["drawing"])  # /tf_static: the drawing
    return write_drive_bag(drawn, path, truth=True, odom=False)
