"""The wheels' cumulative angles of a recording: from its joint states, encoder counts or odometry.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.io.rosbag` (the recording's type).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from umbmark.io.rosbag import SelfcalBag
from umbmark.model.dataset import wheel_angles_from_poses
from umbmark.model.geometry import WheelGeometry

__all__ = ["recording_wheel_angles", "scan_wheel_angles"]

FloatArray = NDArray[np.float64]


def recording_wheel_angles(bag: SelfcalBag, nominal: WheelGeometry) -> tuple[FloatArray, FloatArray]:
    """The cumulative wheel angles of a recording at its wheel stamps [rad].

    Joint states and encoder counts as read (:func:`umbmark.io.rosbag.read_selfcal_bag` unwraps
    joint positions wrapped to one turn); from ``nav_msgs/Odometry`` they are made through the
    nominal geometry (:func:`umbmark.model.dataset.wheel_angles_from_poses`, the one inversion).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    nominal : WheelGeometry
        The nominal geometry (the odometry's, for ``nav_msgs/Odometry`` wheel data).

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``.
    """
    if bag.wheel_kind == "odom":
        assert bag.odom_pose is not None
        return wheel_angles_from_poses(bag.odom_pose, nominal)
    assert bag.left_rad is not None and bag.right_rad is not None
    return np.asarray(bag.left_rad, dtype=float), np.asarray(bag.right_rad, dtype=float)


def scan_wheel_angles(
    bag: SelfcalBag, nominal: WheelGeometry, scan_delay_s: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """The wheels' cumulative angles at the scans (their stamps less the delay), interpolated.

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    nominal : WheelGeometry
        The nominal geometry (that of ``nav_msgs/Odometry`` wheel data).
    scan_delay_s : float
        How late the scans are stamped [s].

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``, one value per scan.
    """
    left, right = recording_wheel_angles(bag, nominal)
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float) - float(scan_delay_s)
    return np.interp(st, wt, left), np.interp(st, wt, right)
