"""The wheels' cumulative angles of a recording: from its joint states, encoder counts or odometry.

Imports numpy, :mod:`umbmark.model.se2` and :mod:`umbmark.io.rosbag` (the recording's type).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag
from umbmark.model import se2

__all__ = ["wheel_angles_from_odometry", "recording_wheel_angles", "scan_wheel_angles"]

FloatArray = NDArray[np.float64]


def _positive(name: str, v: float, allow_zero: bool = False, allow_inf: bool = False) -> float:
    """``v`` as a float, or an InputError naming ``name`` (positive, or non-negative; finite unless
    ``allow_inf``)."""
    ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and not math.isnan(v)
    ok = ok and (v >= 0 if allow_zero else v > 0) and (allow_inf or math.isfinite(v))
    if not ok:
        raise InputError(f"`{name}` must be a {'non-negative' if allow_zero else 'positive'} number, got {v!r}")
    return float(v)


def wheel_angles_from_odometry(
    pose: ArrayLike, wheel_radius_m: float, wheelbase_m: float
) -> tuple[FloatArray, FloatArray]:
    """Cumulative wheel angles that reproduce an odometry through a nominal geometry.

    Per increment, the pose change ``(dx, dy, dth)`` in the frame of the earlier pose is taken
    as an exact arc: its length is ``ds = (dx cos(dth/2) + dy sin(dth/2)) / sinc(dth/2)``
    (signed: negative backwards), the wheels rolled ``ds - b dth / 2`` and ``ds + b dth / 2``
    and turned that travel over the radius.

    Parameters
    ----------
    pose : array_like
        ``(K, 3)`` odometry poses ``(x_m, y_m, yaw_rad)`` in time order.
    wheel_radius_m : float
        The nominal wheel radius [m].
    wheelbase_m : float
        The wheelbase the odometry was computed with [m].

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``, each ``(K,)``, 0 at the first pose.

    Raises
    ------
    InputError
        If ``pose`` is not ``(K, 3)`` or the geometry is not positive.
    """
    r = _positive("wheel_radius_m", wheel_radius_m)
    b = _positive("wheelbase_m", wheelbase_m)
    p = np.asarray(pose, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"`pose` must have shape (K, 3), got {p.shape}")
    d = se2.between(p[:-1], p[1:])
    half = 0.5 * d[:, 2]
    ds = (d[:, 0] * np.cos(half) + d[:, 1] * np.sin(half)) / se2.sinc(half)
    zero = np.zeros(1)
    left = np.concatenate([zero, np.cumsum(ds - 0.5 * b * d[:, 2])]) / r
    right = np.concatenate([zero, np.cumsum(ds + 0.5 * b * d[:, 2])]) / r
    return left, right


def recording_wheel_angles(bag: SelfcalBag, r_nom: float, b_nom: float) -> tuple[FloatArray, FloatArray, list[str]]:
    """The cumulative wheel angles of a recording at its wheel stamps.

    Joint positions wrapped to one turn are unwrapped (with a warning); from
    ``nav_msgs/Odometry`` they are made by :func:`wheel_angles_from_odometry`.

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    r_nom, b_nom : float
        The nominal wheel radius and wheelbase [m] (those of odometry wheel data).

    Returns
    -------
    tuple
        ``(left_rad, right_rad, warnings)``.
    """
    if bag.wheel_kind == "odom":
        assert bag.odom_pose is not None
        left, right = wheel_angles_from_odometry(bag.odom_pose, r_nom, b_nom)
        return left, right, []
    assert bag.left_rad is not None and bag.right_rad is not None
    left, right = np.asarray(bag.left_rad, dtype=float), np.asarray(bag.right_rad, dtype=float)
    if bag.wheel_kind != "joints":
        return left, right, []
    jumps = int((np.abs(np.diff(left)) > math.pi).sum() + (np.abs(np.diff(right)) > math.pi).sum())
    if not jumps:
        return left, right, []
    warning = (
        f"the wheel positions jump by more than half a turn {jumps} times between joint states (wrapped to one "
        "turn?): unwrapped"
    )
    return np.unwrap(left), np.unwrap(right), [warning]


def scan_wheel_angles(
    bag: SelfcalBag, wheel_diameter_m: float, wheelbase_m: float, scan_delay_s: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """The wheels' cumulative angles at the scans (their stamps less the delay), interpolated.

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry (that of ``nav_msgs/Odometry`` wheel data).
    scan_delay_s : float
        How late the scans are stamped [s].

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``, one value per scan.
    """
    left, right, _ = recording_wheel_angles(bag, 0.5 * wheel_diameter_m, wheelbase_m)
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float) - float(scan_delay_s)
    return np.interp(st, wt, left), np.interp(st, wt, right)
