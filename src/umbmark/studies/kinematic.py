"""Simulated tricycle and mecanum robots with a lidar: random robots and drives that meet a known truth.

:func:`draw_robot` draws a seeded robot of a kind (nominal geometry, a true geometry off it, a
lidar pose and the URDF's guess of it, noise); :func:`simulated_bag` drives it in the test room
(:func:`umbmark.model.kinematic_drive.kinematic_program`, every move the kind can make both ways)
and writes the bag that the self-calibration of its kind reads
(:func:`umbmark.cli.kinematic_args.selfcal_args` gives the command's arguments). The coverage
benchmark (``benchmarks/kinematic_coverage.py``) and the tests share them.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.io` (the bag writer).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.io.rosbag_write import write_drive_bag
from umbmark.model.kinematic_drive import (
    JointDriveLog,
    JointNoise,
    KinematicRobot,
    kinematic_program,
    simulate_kinematic_drive,
)
from umbmark.model.kinematics import Kinematics, Mecanum, Tricycle
from umbmark.model.sensors import Lidar, SensorPose

__all__ = [
    "KINDS",
    "JOINTS",
    "DrawnRobot",
    "draw_robot",
    "simulated_drive",
    "simulated_bag",
    "truth_of",
    "estimate_of",
]

KINDS = ("tricycle", "mecanum")
"""The kinds of robot drawn."""

JOINTS = {
    "tricycle": ("traction_wheel_joint", "steering_joint"),
    "mecanum": ("front_left_wheel_joint", "front_right_wheel_joint", "rear_left_wheel_joint", "rear_right_wheel_joint"),
}
"""The joint names the simulated bags carry, in each kind's roles' order."""


@dataclass(frozen=True)
class DrawnRobot:
    """A drawn robot and how it drives.

    Attributes
    ----------
    robot : KinematicRobot
        Nominal and true geometry, the lidar and its true pose.
    urdf_pose : tuple of float
        ``(x_m, y_m, yaw_rad)`` the URDF's guess of the lidar's pose (off the truth).
    noise : JointNoise
    duration_s : float
        About how long it drives [s].
    seed : int
    """

    robot: KinematicRobot
    urdf_pose: tuple[float, float, float]
    noise: JointNoise
    duration_s: float
    seed: int

    @property
    def kind(self) -> str:
        """``tricycle`` or ``mecanum``."""
        return self.robot.kind


def draw_robot(kind: str, seed: int, *, range_noise_m: float = 0.005, n_beams: int = 360) -> DrawnRobot:
    """A seeded random robot of a kind.

    Tricycle: nominal traction wheel 150-300 mm and wheelbase 400-1000 mm (whole millimetres);
    the true diameter off by up to +-3 %, the wheelbase by +-5 %, the steering offset up to +-3
    deg. Mecanum: nominal wheels 70-150 mm and ``lx + ly`` 200-500 mm; each true diameter off by
    up to +-2 %, ``lx + ly`` by +-5 %. Both: the lidar at x +-200 mm, y +-100 mm, yaw +-5 deg, the
    URDF's guess off by up to +-20 mm and +-2 deg; a 360-beam lidar at 10 Hz with
    ``range_noise_m`` noise and 0.5 % dropouts; 0.5-2 % joint-speed jitter, slip of 1e-4 to 3e-4
    m per sqrt(m), steering readings with 0.05 deg noise; 2-3 minutes of driving.

    Parameters
    ----------
    kind : str
        ``tricycle`` or ``mecanum``.
    seed : int
    range_noise_m : float
        The lidar's range noise [m].
    n_beams : int
        Its beams (full circle).

    Returns
    -------
    DrawnRobot
    """
    rng = np.random.default_rng([seed, KINDS.index(kind)])
    u = lambda a, b: float(rng.uniform(a, b))  # noqa: E731
    nominal: Kinematics
    true: Kinematics
    if kind == "tricycle":
        d, length = round(u(150, 300)) * 1e-3, round(u(400, 1000)) * 1e-3
        nominal = Tricycle(d, length)
        true = Tricycle(d * (1 + u(-0.03, 0.03)), length * (1 + u(-0.05, 0.05)), math.radians(u(-3, 3)))
    else:
        d, k = round(u(70, 150)) * 1e-3, round(u(200, 500)) * 1e-3
        nominal = Mecanum.uniform(d, k)
        dd = tuple(d * (1 + u(-0.02, 0.02)) for _ in range(4))
        true = Mecanum((dd[0], dd[1], dd[2], dd[3]), k * (1 + u(-0.05, 0.05)))
    pose = SensorPose(u(-0.2, 0.2), u(-0.1, 0.1), math.radians(u(-5, 5)))
    urdf = (pose.x_m + u(-0.02, 0.02), pose.y_m + u(-0.02, 0.02), pose.yaw_rad + math.radians(u(-2, 2)))
    lidar = Lidar(n_beams=n_beams, range_noise_m=range_noise_m, dropout_prob=0.005)
    noise = JointNoise(speed_rel_sd=u(0.005, 0.02), slip_m_per_sqrt_m=u(1e-4, 3e-4), steer_sd_rad=math.radians(0.05))
    robot = KinematicRobot(nominal, true, pose, lidar)
    return DrawnRobot(robot, urdf, noise, u(120, 180), seed)


def simulated_drive(drawn: DrawnRobot, kinds: Sequence[str] | None = None) -> JointDriveLog:
    """The drawn robot's drive in the test room (moves of ``kinds``, default all of its kind)."""
    moves, start = kinematic_program(drawn.robot, drawn.duration_s, seed=drawn.seed, kinds=kinds)
    return simulate_kinematic_drive(
        moves, drawn.robot, start_pose=start, joint_names=JOINTS[drawn.kind], noise=drawn.noise, seed=drawn.seed
    )


def simulated_bag(drawn: DrawnRobot, path: str | Path, kinds: Sequence[str] | None = None) -> Path:
    """Write the drawn robot's drive as a bag (joint states, scans, the true pose on ``/ground_truth``;
    no ``/tf_static``: the URDF's guess goes to the command)."""
    return write_drive_bag(simulated_drive(drawn, kinds), path, truth=True, tf_static=False, odom=False)


def truth_of(drawn: DrawnRobot) -> dict[str, float]:
    """The true values under the JSON keys of ``umbmark selfcal --kinematics`` (mm, deg): the
    kind's geometry and ``sensor_x_mm``, ``sensor_y_mm``, ``sensor_yaw_deg``."""
    t = drawn.robot.true
    p = drawn.robot.sensor_pose
    out: dict[str, float] = {}
    if isinstance(t, Tricycle):
        out.update(
            wheel_diameter_mm=t.wheel_diameter_m * 1e3,
            wheelbase_mm=t.wheelbase_m * 1e3,
            steering_offset_deg=math.degrees(t.steering_offset_rad),
        )
    else:
        assert isinstance(t, Mecanum)
        for role, dia in zip(("front_left", "front_right", "rear_left", "rear_right"), t.wheel_diameters_m):
            out[f"wheel_diameters_mm.{role}"] = dia * 1e3
        out["lx_plus_ly_mm"] = t.lx_plus_ly_m * 1e3
    out.update(sensor_x_mm=p.x_m * 1e3, sensor_y_mm=p.y_m * 1e3, sensor_yaw_deg=math.degrees(p.yaw_rad))
    return out


def estimate_of(d: dict, key: str) -> tuple[float, list[float]]:
    """The estimate and its 95 % interval under a key of :func:`truth_of` in a self-calibration's JSON.

    Parameters
    ----------
    d : dict
        The JSON of the self-calibration of a tricycle or mecanum robot.
    key : str
        A key of :func:`truth_of` (``sensor_x_mm``: ``sensor_pose.x_mm``; ``a.b``: nested).

    Returns
    -------
    tuple
        ``(estimate, [low, high])``.
    """
    if key.startswith("sensor_"):
        k = key.removeprefix("sensor_")
        return d["sensor_pose"][k], d["sensor_pose"][f"{k}_ci95"]
    if "." in key:
        a, b = key.split(".")
        return d[a][b], d[f"{a}_ci95"][b]
    return d[key], d[f"{key}_ci95"]
