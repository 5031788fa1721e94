"""The example tricycle and mecanum bags of the documentation (docs/tricycle.md, docs/mecanum.md).

A tricycle AGV (traction wheel 250 mm, wheelbase 800 mm nominal; truly 252.5 mm, 790 mm and a
steering offset of 1.5 deg) and a mecanum robot (wheels 100 mm, lx + ly 400 mm nominal; truly
101.0, 99.5, 100.3 and 99.8 mm, 405 mm), each with a 360-beam lidar (5 mm range noise, 10 Hz)
mounted 20 mm and 1 deg off its drawing, driving every move of its kind both ways for 2.5 minutes
with 1 % joint-speed jitter and slip: a ROS 1 bag with /joint_states, /scan, /tf_static (the
drawing's lidar pose) and /ground_truth (the robot's true pose).

:func:`write_short_drive` writes a shorter drive of the same robot with the files a check of its
calibration needs: the base's true trajectory (TUM) and the lidar's true relations.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from umbmark.io.relations import Relations, write_relations
from umbmark.io.rosbag_write import EPOCH_S, write_drive_bag
from umbmark.io.tum import Trajectory, write_tum
from umbmark.kinds import Mecanum, Tricycle
from umbmark.model import se2
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


def write_example_bag(path, kind: str, seed: int = 7, tum=None):
    """Write the example bag of a kind (``tricycle`` or ``mecanum``) to ``path`` (and with ``tum`` the
    base's true poses at the scans there, a TUM trajectory)."""
    spec = ROBOTS[kind]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=360, range_noise_m=0.005))
    moves, start = kinematic_program(robot, 150.0, seed=seed)
    noise = JointNoise(speed_rel_sd=0.01, slip_m_per_sqrt_m=2e-4, steer_sd_rad=math.radians(0.05))
    log = simulate_kinematic_drive(moves, robot, start_pose=start, joint_names=spec["joints"], noise=noise, seed=seed)
    drawn = dataclasses.replace(log, sensor_pose=spec["drawing"])  # /tf_static: the drawing
    if tum is not None:
        write_tum(Trajectory(EPOCH_S + log.scan_stamps_s, log.scan_pose), tum)
    return write_drive_bag(drawn, path, truth=True, odom=False)


def write_short_drive(folder, kind: str, duration_s: float = 40.0, seed: int = 3) -> dict:
    """A short drive of a kind's example robot (a 180-beam lidar) in ``folder``: ``drive.bag``,
    ``true.tum`` (the base's true poses at the scans) and ``true.relations`` (the lidar's true
    relative poses between scans 0.5 s and 20 s apart). Returns their paths, the joint names and
    the nominal sizes' flags of ``umbmark selfcal``."""
    spec = ROBOTS[kind]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=180, range_noise_m=0.005))
    moves, start = kinematic_program(robot, duration_s, seed=seed)
    noise = JointNoise(speed_rel_sd=0.01, slip_m_per_sqrt_m=2e-4, steer_sd_rad=math.radians(0.05))
    log = simulate_kinematic_drive(moves, robot, start_pose=start, joint_names=spec["joints"], noise=noise, seed=seed)
    drawn = dataclasses.replace(log, sensor_pose=spec["drawing"])  # /tf_static: the drawing
    bag = write_drive_bag(drawn, folder / "drive.bag", truth=True, odom=False)
    stamps = EPOCH_S + log.scan_stamps_s
    write_tum(Trajectory(stamps, log.scan_pose), folder / "true.tum")
    lidar = se2.compose(log.scan_pose, spec["lidar"].as_array())
    a = np.concatenate([np.arange(0, len(stamps) - k, 3) for k in (5, 200)])
    b = np.concatenate([np.arange(k, len(stamps), 3) for k in (5, 200)])
    write_relations(Relations(stamps[a], stamps[b], se2.between(lidar[a], lidar[b])), folder / "true.relations")
    return {"bag": bag, "tum": folder / "true.tum", "relations": folder / "true.relations", **_flags(kind)}


def _flags(kind: str) -> dict:
    """The joints' and the nominal sizes' flags of ``umbmark selfcal`` for a kind's example robot."""
    from umbmark.cli.options import flag
    from umbmark.kinds import kind_named

    k, spec = kind_named(kind), ROBOTS[kind]
    names = iter(spec["joints"])
    joints = [a for j in k.joints for a in (flag(j.option), ",".join(next(names) for _ in j.roles))]
    values = dict(zip(spec["nominal"].parameter_names, spec["nominal"].vector()))
    sizes = [a for sz in k.sizes for a in (flag(sz.option), f"{values[sz.parameters[0]] * 1e3:g}")]
    return {"joints": joints, "sizes": sizes}
