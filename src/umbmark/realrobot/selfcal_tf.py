"""The lidar's nominal mounting pose of a self-calibration: the ``/tf_static`` chain from the robot's
base frame to the scan frame (:func:`sensor_pose_from_tf`), and the pose the scan matching starts
from (:func:`nominal_sensor_pose_of`: given, else ``/tf_static``, else zero).

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports these
names). Imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.io.rosbag` (the bag's types).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag, StaticTransform

__all__ = ["BASE_FRAMES", "MAX_TILT_RAD", "sensor_pose_from_tf", "nominal_sensor_pose_of"]

BASE_FRAMES = ("base_link", "base_footprint")
"""The robot frames looked up in ``/tf_static`` when no base frame is given, in this order."""

MAX_TILT_RAD = math.radians(10.0)
"""The largest roll or pitch of the lidar in ``/tf_static`` the planar model accepts."""

FloatArray = NDArray[np.float64]


def _matrix(tr: StaticTransform) -> FloatArray:
    x, y, z, w = tr.rotation
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0:
        raise InputError(f"the /tf_static rotation of {tr.parent} -> {tr.child} is not a quaternion (all zero)")
    x, y, z, w = x / n, y / n, z / n, w / n
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    m[:3, 3] = tr.translation
    return m


def sensor_pose_from_tf(
    transforms: Sequence[StaticTransform], base_frame: str, sensor_frame: str
) -> tuple[float, float, float, float, float, float] | None:
    """The pose of ``sensor_frame`` in ``base_frame`` through a chain of static transforms.

    Parameters
    ----------
    transforms : sequence of StaticTransform
        The transforms of ``/tf_static``, each usable in either direction.
    base_frame, sensor_frame : str
        The robot's frame and the lidar's.

    Returns
    -------
    tuple of float or None
        ``(x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad)`` (roll, pitch, yaw as in URDF: fixed
        axes x, y, z), or None when no chain joins the frames.

    Raises
    ------
    InputError
        A transform whose rotation is not a quaternion.
    """
    edges: dict[str, list[tuple[str, FloatArray]]] = {}
    for tr in transforms:
        m = _matrix(tr)
        edges.setdefault(tr.parent, []).append((tr.child, m))
        edges.setdefault(tr.child, []).append((tr.parent, np.asarray(np.linalg.inv(m), dtype=float)))
    base, target = base_frame.lstrip("/"), sensor_frame.lstrip("/")
    seen = {base: np.eye(4)}
    queue = [base]
    while queue:
        f = queue.pop(0)
        for g, m in edges.get(f, []):
            if g not in seen:
                seen[g] = seen[f] @ m
                queue.append(g)
    if target not in seen:
        return None
    m = seen[target]
    rot = m[:3, :3]
    pitch = math.asin(max(-1.0, min(1.0, -rot[2, 0])))
    roll = math.atan2(rot[2, 1], rot[2, 2])
    yaw = math.atan2(rot[1, 0], rot[0, 0])
    # + 0.0: no negative zeros in reports
    return (float(m[0, 3]) + 0.0, float(m[1, 3]) + 0.0, float(m[2, 3]) + 0.0, roll + 0.0, pitch + 0.0, yaw + 0.0)


def nominal_sensor_pose_of(
    bag: SelfcalBag, sensor_pose: ArrayLike | None, base_frame: str | None
) -> tuple[tuple[float, float, float, float, float, float], str, str, list[str]]:
    """The pose the matching starts from, where it came from, the base frame, warnings."""
    warnings: list[str] = []
    frames = (
        [base_frame]
        if base_frame
        else ([bag.odom_child_frame] if bag.odom_child_frame else [])
        + [f for f in BASE_FRAMES if f != bag.odom_child_frame]
    )
    if sensor_pose is not None:
        p = np.asarray(sensor_pose, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InputError("`sensor_pose` must be three finite numbers (x_m, y_m, yaw_rad)", bag.source)
        return (float(p[0]), float(p[1]), 0.0, 0.0, 0.0, float(p[2])), "given", frames[0], warnings
    for f in frames:
        tf = sensor_pose_from_tf(bag.static_transforms, f, bag.scan_frame)
        if tf is None:
            continue
        roll, pitch = tf[3], tf[4]
        if abs(roll) > MAX_TILT_RAD or abs(pitch) > MAX_TILT_RAD:
            raise InputError(
                f"/tf_static puts the scan frame {bag.scan_frame!r} at roll {math.degrees(roll):.1f} deg, "
                f"pitch {math.degrees(pitch):.1f} deg in {f!r}: the self-calibration needs a level lidar, "
                "mounted upright",
                bag.source,
            )
        return tf, f"/tf_static {f} -> {bag.scan_frame}", f, warnings
    if bag.static_transforms:
        warnings.append(
            f"/tf_static has no transform chain from {' or '.join(frames)} to the scan frame {bag.scan_frame!r}: "
            "the scan matching starts from a sensor at the robot's centre (give `sensor_pose` or `base_frame`)"
        )
    return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), "none", frames[0], warnings
