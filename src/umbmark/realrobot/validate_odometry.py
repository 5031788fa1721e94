"""The odometry at the scans (step 1 of :mod:`umbmark.realrobot.validate`): a recorded odometry
read at the scans (:func:`recorded_odometry_at_scans`), the wheel angles at the scans
(:func:`wheel_angles_at_scans`), integrated as exact arcs (:func:`odometry_from_wheels`); the
lidar's pose before and after the calibration, and the odometries before and after it on the
matched relations (a robot of another kind: its joints' odometry with each geometry).

Part of the check of a calibration on a real log (:mod:`umbmark.realrobot.validate`, which
re-exports these names; also :mod:`umbmark.studies.slam2d`'s). Imports numpy, :mod:`umbmark.model`,
:mod:`umbmark.io.rosbag` (the bag's type), the wheel angles of a recording
(:mod:`umbmark.realrobot.wheels`), the lidar's pose from ``/tf_static``
(:mod:`umbmark.realrobot.selfcal_tf`), the joints' odometry (:mod:`umbmark.realrobot.kinematic`,
when called) and the other parts of the check (:mod:`~umbmark.realrobot.validate_figures`,
:mod:`~umbmark.realrobot.validate_calibration`, :mod:`~umbmark.realrobot.validate_reference`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.relations import Relations
from umbmark.io.rosbag import SelfcalBag
from umbmark.model.dataset import wheel_angles_from_poses
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry
from umbmark.model.se2 import Pose
from umbmark.realrobot.selfcal_tf import nominal_sensor_pose_of
from umbmark.realrobot.validate_calibration import CheckedCalibration
from umbmark.realrobot.validate_figures import OdometryFigures
from umbmark.realrobot.validate_reference import _Matched
from umbmark.realrobot.wheels import scan_wheel_angles

__all__ = ["odometry_from_wheels", "recorded_odometry_at_scans", "wheel_angles_at_scans"]

FloatArray = NDArray[np.float64]


def odometry_from_wheels(
    left_rad: ArrayLike, right_rad: ArrayLike, r_left_m: float, r_right_m: float, wheelbase_m: float
) -> FloatArray:
    """Odometry poses from cumulative wheel angles: exact arcs between samples.

    Parameters
    ----------
    left_rad, right_rad : array_like
        ``(M,)`` cumulative wheel angles [rad].
    r_left_m, r_right_m, wheelbase_m : float
        The geometry [m].

    Returns
    -------
    numpy.ndarray
        ``(M, 3)`` poses from ``(0, 0, 0)`` at the first sample (heading accumulated).
    """
    left = np.asarray(left_rad, dtype=float)
    right = np.asarray(right_rad, dtype=float)
    return integrate_wheels(r_left_m * np.diff(left), r_right_m * np.diff(right), wheelbase_m)


def recorded_odometry_at_scans(bag: SelfcalBag, scan_delay_s: float = 0.0) -> FloatArray:
    """The recorded odometry poses interpolated linearly to the scan stamps (heading unwrapped).

    Parameters
    ----------
    bag : SelfcalBag
        A recording with ``nav_msgs/Odometry`` wheel data.
    scan_delay_s : float
        How late the scans are stamped [s]: the odometry is read at ``stamp - scan_delay_s``.

    Returns
    -------
    numpy.ndarray
        ``(M, 3)`` poses at the scans.

    Raises
    ------
    InputError
        If the bag's wheel data are not odometry.
    """
    if bag.odom_pose is None:
        raise InputError("the bag's wheel data are not an odometry: no recorded odometry to compare", bag.source)
    p = np.asarray(bag.odom_pose, dtype=float)
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float) - float(scan_delay_s)
    yaw = np.unwrap(p[:, 2])
    return np.column_stack([np.interp(st, wt, p[:, 0]), np.interp(st, wt, p[:, 1]), np.interp(st, wt, yaw)])


def wheel_angles_at_scans(
    bag: SelfcalBag,
    nominal: WheelGeometry,
    scan_delay_s: float = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """Cumulative wheel angles at ``scan stamp - scan_delay_s`` (step 1 of the module docstring).

    From ``nav_msgs/Odometry``: the recorded poses interpolated at the scans
    (:func:`recorded_odometry_at_scans`), each increment turned into wheel travel through the
    nominal geometry (exact arcs) and over each nominal radius. From joints or encoders: the
    recorded angles interpolated at the scans.

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    nominal : WheelGeometry
        The nominal geometry (the odometry's, for ``nav_msgs/Odometry``).
    scan_delay_s : float
        How late the scans are stamped [s].

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``: ``(M,)`` angles for the ``M`` scans.
    """
    if bag.wheel_kind == "odom":
        return wheel_angles_from_poses(recorded_odometry_at_scans(bag, scan_delay_s), nominal)
    return scan_wheel_angles(bag, nominal, scan_delay_s)


@dataclass(frozen=True)
class _SensorPoses:
    """The lidar's pose before the calibration and after it, with where each came from."""

    nominal: Pose
    nominal_source: str
    after: Pose
    after_source: str


def _sensor_poses(
    bag: SelfcalBag, calibration: CheckedCalibration, base_frame: str | None
) -> tuple[_SensorPoses, list[str]]:
    """The sensor poses: the calibration's nominal one, else /tf_static; the calibration's after it."""
    warnings: list[str] = []
    tf, tf_src, _, tf_warn = nominal_sensor_pose_of(bag, None, base_frame)
    tf_pose = (tf[0], tf[1], tf[5])
    nominal_pose: Pose
    if calibration.nominal_sensor_pose is not None:
        nominal_pose = calibration.nominal_sensor_pose
        nominal_src = f"calibration ({calibration.nominal_sensor_pose_source})"
        dpos = math.hypot(nominal_pose[0] - tf_pose[0], nominal_pose[1] - tf_pose[1])
        dyaw = abs(math.remainder(nominal_pose[2] - tf_pose[2], 2 * math.pi))
        if tf_src != "none" and (dpos > 1e-3 or dyaw > math.radians(0.1)):
            warnings.append(
                f"the calibration's nominal sensor pose differs from {tf_src} of this log by {dpos * 1e3:.1f} mm "
                f"and {math.degrees(dyaw):.2f} deg: the calibration's is used before it"
            )
    else:
        nominal_pose, nominal_src = tf_pose, ("no transform to the scans' frame: zero" if tf_src == "none" else tf_src)
        warnings += tf_warn
    if calibration.sensor_pose is not None:
        after_pose, after_src = calibration.sensor_pose, "calibration"
    else:
        after_pose, after_src = nominal_pose, "nominal (the calibration has no sensor pose)"
    return _SensorPoses(nominal_pose, nominal_src, after_pose, after_src), warnings


@dataclass(frozen=True)
class _Odometries:
    """The odometries at the scans before and after the calibration, and the matched relations they are checked on."""

    before: FloatArray
    after: FloatArray
    poses: _SensorPoses
    k1: NDArray[np.int64]
    k2: NDArray[np.int64]
    reference: FloatArray
    short: NDArray[np.bool_]
    reference_after: FloatArray | None = None

    def figures(self, sel: NDArray[np.bool_]) -> tuple[OdometryFigures, OdometryFigures]:
        """The figures before and after the calibration on the selected relations (after: against
        :attr:`reference_after` when the reference is the robot's true base trajectory)."""
        k1, k2, short = self.k1[sel], self.k2[sel], self.short[sel]
        after = self.reference if self.reference_after is None else self.reference_after
        return (
            OdometryFigures.compute(self.before, k1, k2, self.reference[sel], self.poses.nominal, short),
            OdometryFigures.compute(self.after, k1, k2, after[sel], self.poses.after, short),
        )


def _odometries(
    bag: SelfcalBag,
    calibration: CheckedCalibration,
    delay: float,
    poses: _SensorPoses,
    matched: _Matched,
    rel: Relations,
    short_max_s: float,
) -> _Odometries:
    """The odometries (step 1): the wheel angles at the scans integrated with each geometry (another
    kind of robot: its joints on the grid of their stamps and the scans', with each geometry)."""
    both = calibration.kinematics
    if both is not None:
        from umbmark.realrobot.kinematic import scan_odometry

        if bag.joint_positions is None or bag.joint_positions.shape[1] != len(both[0].joint_roles):
            raise InputError(f"the log's joint data are not a {calibration.robot_kind.noun}'s", bag.source)
        before, after = scan_odometry(bag, both, delay)
        return _Odometries(before, after, poses, matched.k1, matched.k2, rel.pose, rel.span_s < short_max_s)
    nom, cal = calibration.nominal, calibration.calibrated
    assert isinstance(nom, WheelGeometry) and isinstance(cal, WheelGeometry)
    left, right = wheel_angles_at_scans(bag, nom, delay)
    before_odo = odometry_from_wheels(
        left, right, 0.5 * nom.diameter_left_m, 0.5 * nom.diameter_right_m, nom.wheelbase_m
    )
    after_odo = odometry_from_wheels(
        left, right, 0.5 * cal.diameter_left_m, 0.5 * cal.diameter_right_m, cal.wheelbase_m
    )
    return _Odometries(before_odo, after_odo, poses, matched.k1, matched.k2, rel.pose, rel.span_s < short_max_s)
