"""Simulated robots of the drawable kinds (:mod:`umbmark.kinds`: tricycle, mecanum) with a lidar:
random robots and drives that meet a known truth.

:func:`draw_robot` draws a seeded robot of a kind (nominal geometry, a true geometry off it,
:meth:`umbmark.kinds.Kind.draw`; a lidar pose and the URDF's guess of it, noise);
:func:`simulated_bag` drives it in the test room
(:func:`umbmark.model.kinematic_drive.kinematic_program`, every move the kind can make both ways)
and writes the bag that the self-calibration of its kind reads
(:func:`umbmark.cli.kinematic_args.selfcal_args` gives the command's arguments). The coverage
benchmark (``benchmarks/kinematic_coverage.py``) and the tests share them.

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.kinds` and :mod:`umbmark.io` (the bag writer).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io.rosbag_write import write_drive_bag
from umbmark.kinds import KINDS as _ALL_KINDS
from umbmark.kinds import kind_named, kind_of
from umbmark.model.kinematic_drive import (
    JointDriveLog,
    JointNoise,
    KinematicRobot,
    kinematic_program,
    simulate_kinematic_drive,
)
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

KINDS = tuple(k.name for k in _ALL_KINDS.values() if k.drawable)
"""The kinds of robot drawn (:attr:`umbmark.kinds.Kind.drawable`, in the registry's order)."""

JOINTS = {name: _ALL_KINDS[name].sim_joints for name in KINDS}
"""The joint names the simulated bags carry, in each kind's roles' order
(:attr:`umbmark.kinds.Kind.sim_joints`)."""


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
        """The kind's name (one of :data:`KINDS`)."""
        return self.robot.kind


def draw_robot(kind: str, seed: int, *, range_noise_m: float = 0.005, n_beams: int = 360) -> DrawnRobot:
    """A seeded random robot of a kind.

    The geometries as the kind draws them (:meth:`umbmark.kinds.Kind.draw`; a tricycle: nominal
    traction wheel 150-300 mm and wheelbase 400-1000 mm (whole millimetres); the true diameter
    off by up to +-3 %, the wheelbase by +-5 %, the steering offset up to +-3 deg; a mecanum
    robot: nominal wheels 70-150 mm and ``lx + ly`` 200-500 mm; each true diameter off by up to
    +-2 %, ``lx + ly`` by +-5 %). Every kind: the lidar at x +-200 mm, y +-100 mm, yaw +-5 deg, the
    URDF's guess off by up to +-20 mm and +-2 deg; a 360-beam lidar at 10 Hz with
    ``range_noise_m`` noise and 0.5 % dropouts; 0.5-2 % joint-speed jitter, slip of 1e-4 to 3e-4
    m per sqrt(m), steering readings with 0.05 deg noise; 2-3 minutes of driving.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    seed : int
    range_noise_m : float
        The lidar's range noise [m].
    n_beams : int
        Its beams (full circle).

    Returns
    -------
    DrawnRobot
    """
    which = kind_named(kind)
    if kind not in KINDS:
        raise InputError(f"the studies draw no random {which.noun} (they draw {', '.join(KINDS)})")
    rng = np.random.default_rng([seed, KINDS.index(kind)])
    u = lambda a, b: float(rng.uniform(a, b))  # noqa: E731
    nominal, true = which.draw(u)
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
    kind's geometry as its self-calibration estimates it by default (:meth:`umbmark.kinds.Kind.truth`)
    and ``sensor_x_mm``, ``sensor_y_mm``, ``sensor_yaw_deg``."""
    t = drawn.robot.true
    p = drawn.robot.sensor_pose
    out = kind_of(t).truth(t)
    out.update(sensor_x_mm=p.x_m * 1e3, sensor_y_mm=p.y_m * 1e3, sensor_yaw_deg=math.degrees(p.yaw_rad))
    return out


def estimate_of(d: dict, key: str) -> tuple[float, list[float]]:
    """The estimate and its 95 % interval under a key of :func:`truth_of` in a self-calibration's JSON.

    Parameters
    ----------
    d : dict
        The JSON of the self-calibration of a robot of a drawable kind.
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
