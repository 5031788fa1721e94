"""What a self-calibration's report draws: the scans placed by the odometry (a map), before and
after calibration, and each interval's residual over time.

* **The map** of a bag: scans spread over the recording (keyframes, at most
  :data:`MAP_SCANS`, each thinned to at most :data:`MAP_POINTS` points), the robot's pose at
  each from the wheel data (the scans' delay applied) integrated with the nominal geometry and
  with the calibrated one, and the lidar's pose on the robot, nominal and estimated. A
  calibration that is right makes the walls of this map sharp; its **spread**
  (:func:`map_spread`) measures how sharp.
* **The residuals**: the measured minus the predicted sensor displacement of every interval
  (the estimate's prediction), with its time in its input and whether it was rejected.

Both are JSON (:func:`selfcal_figures`; arrays as :func:`umbmark.jsonutil.encode_array`), so a
saved result or a history record can be reported without its bags.

Pure numpy and scipy: imports the model, the estimate's model and the bag reader's types.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal import SelfcalResult
from umbmark.correct.selfcal.model import residuals
from umbmark.jsonutil import decode_array, encode_array
from umbmark.model import se2
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry
from umbmark.model.intervals import Intervals
from umbmark.realrobot.wheels import scan_wheel_angles

__all__ = [
    "MAP_SCANS",
    "MAP_POINTS",
    "MAP_RANGE_M",
    "SPREAD_NEAR_M",
    "scan_map",
    "map_keys",
    "encode_map",
    "interval_residuals",
    "encode_residuals",
    "map_points",
    "map_spread",
    "selfcal_figures",
    "decode_map",
    "decode_residuals",
]

MAP_SCANS = 240
"""At most this many scans in a bag's map (spread evenly over its keyframes)."""
MAP_POINTS = 90
"""At most this many points per scan of a map (every k-th valid beam)."""
MAP_RANGE_M = 30.0
"""Ranges beyond this are left out of the map (the points are stored in millimetres as int16)."""
SPREAD_NEAR_M = 0.3
"""A point counts towards the map's spread when a point of another scan lies within this."""

FloatArray = NDArray[np.float64]


def _scan_points(ranges: FloatArray, angles: FloatArray, max_points: int) -> FloatArray:
    """``(P, 2)`` points of one scan in the sensor frame [m]: valid ranges, thinned evenly."""
    ok = np.isfinite(ranges) & (ranges > 0) & (ranges < MAP_RANGE_M)
    idx = np.flatnonzero(ok)
    if idx.size > max_points:
        idx = idx[np.linspace(0, idx.size - 1, max_points).round().astype(np.intp)]
    r, a = ranges[idx], angles[idx]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def map_keys(pairs: ArrayLike, max_scans: int = MAP_SCANS) -> NDArray[np.intp]:
    """The scans of a bag's map: its keyframes (the scans of its matched pairs), at most ``max_scans``
    spread evenly over them."""
    keys = np.unique(np.asarray(pairs, dtype=np.intp))
    if keys.size > max_scans:
        keys = keys[np.linspace(0, keys.size - 1, max_scans).round().astype(np.intp)]
    return keys


def encode_map(
    bag: Any,
    keys: ArrayLike,
    bases: tuple[ArrayLike, ArrayLike],
    sensor_poses: tuple[ArrayLike, ArrayLike],
    max_points: int = MAP_POINTS,
) -> dict[str, Any]:
    """The map of a bag's scans ``keys`` placed by two odometries (any kind of robot's).

    Parameters
    ----------
    bag : SelfcalBag
        Its scans (``ranges_m``, ``angles_rad``, ``scan_t_s``, ``source``).
    keys : array_like
        ``(n,)`` the scans drawn (:func:`map_keys`).
    bases : tuple of array_like
        ``(nominal, calibrated)``: ``(n, 3)`` the robot's poses at those scans, from the first.
    sensor_poses : tuple of array_like
        ``(nominal, calibrated)``: ``(x_m, y_m, yaw_rad)`` the lidar on the robot.
    max_points : int
        At most this many points per scan.

    Returns
    -------
    dict
        As :func:`scan_map`.
    """
    keys = np.asarray(keys, dtype=np.intp)
    nominal, calibrated = (np.asarray(b, dtype=float) for b in bases)
    angles = np.asarray(bag.angles_rad, dtype=float)
    ranges = np.asarray(bag.ranges_m, dtype=float)
    clouds = [_scan_points(ranges[k], angles, max_points) for k in keys]
    counts = np.array([len(c) for c in clouds], dtype=np.int64)
    pts = np.concatenate(clouds) if clouds else np.zeros((0, 2))
    pts_mm = np.round(pts * 1e3)
    l_nom, l_cal = (np.asarray(p, dtype=float).reshape(3) for p in sensor_poses)
    scan_t = np.asarray(bag.scan_t_s, dtype=float)
    spread = {
        "nominal": map_spread(map_points(nominal, l_nom, pts_mm * 1e-3, counts)) * 1e3,
        "calibrated": map_spread(map_points(calibrated, l_cal, pts_mm * 1e-3, counts)) * 1e3,
    }
    return {
        "bag": bag.source,
        "scans": int(keys.size),
        "t_s": encode_array(scan_t[keys] - scan_t[0], "<f8"),
        "base_nominal": encode_array(nominal, "<f8"),
        "base_calibrated": encode_array(calibrated, "<f8"),
        "sensor_nominal": [float(v) for v in l_nom],
        "sensor_calibrated": [float(v) for v in l_cal],
        "counts": encode_array(counts, "<u2"),
        "points_mm": encode_array(pts_mm, "<i2"),
        "spread_mm": spread,
    }


def scan_map(
    plan: Any,
    result: SelfcalResult,
    *,
    max_scans: int = MAP_SCANS,
    max_points: int = MAP_POINTS,
) -> dict[str, Any]:
    """The map of one bag, with the nominal and the calibrated odometry.

    Parameters
    ----------
    plan : IntervalPlan
        The bag's plan (:func:`umbmark.realrobot.selfcal.plan_intervals`): its scans, wheel data,
        keyframes, the delay and the nominal sensor pose.
    result : SelfcalResult
        The calibration.
    max_scans, max_points : int
        At most this many scans, and points per scan.

    Returns
    -------
    dict
        ``t_s`` (the scans' stamps since the bag's first scan), ``base_nominal`` and
        ``base_calibrated`` (``(n, 3)`` robot poses ``x_m, y_m, yaw_rad`` at the scans, from the
        first), ``sensor_nominal`` and ``sensor_calibrated`` (the lidar's pose on the robot),
        ``counts`` (points per scan) and ``points_mm`` (``(P, 2)`` int16, sensor frame) as
        encoded arrays; ``spread_mm`` (``nominal``, ``calibrated``: :func:`map_spread`).
    """
    bag = plan.bag
    keys = map_keys(plan.pairs, max_scans)
    r_nom = 0.5 * result.nominal_wheel_diameter_m
    d_nom = result.nominal_wheel_diameter_m
    sl, sr = scan_wheel_angles(bag, WheelGeometry(d_nom, d_nom, result.nominal_wheelbase_m), plan.scan_delay_s)
    first, last = int(keys[0]), int(keys[-1])
    dl, dr = np.diff(sl[first : last + 1]), np.diff(sr[first : last + 1])
    nominal = integrate_wheels(r_nom * dl, r_nom * dr, result.nominal_wheelbase_m)[keys - first]
    calibrated = integrate_wheels(result.r_left_m * dl, result.r_right_m * dr, result.wheelbase_m)[keys - first]
    x, y, _, _, _, yaw = plan.nominal_sensor_pose
    return encode_map(bag, keys, (nominal, calibrated), ((x, y, yaw), result.sensor_pose), max_points)


def map_points(base: ArrayLike, sensor_pose: ArrayLike, points_m: ArrayLike, counts: ArrayLike) -> FloatArray:
    """The scans' points in the map's frame.

    Parameters
    ----------
    base : array_like
        ``(n, 3)`` robot poses at the scans.
    sensor_pose : array_like
        ``(x_m, y_m, yaw_rad)`` the lidar on the robot.
    points_m : array_like
        ``(P, 2)`` the scans' points in the sensor frame, scan after scan.
    counts : array_like
        ``(n,)`` points per scan.

    Returns
    -------
    numpy.ndarray
        ``(P, 3)``: ``x_m, y_m`` and the scan's index.
    """
    sensors = se2.compose(np.asarray(base, dtype=float), np.asarray(sensor_pose, dtype=float))
    counts = np.asarray(counts, dtype=np.intp)
    which = np.repeat(np.arange(len(counts)), counts)
    p = np.asarray(points_m, dtype=float).reshape(-1, 2)
    x, y, th = sensors[which, 0], sensors[which, 1], sensors[which, 2]
    c, s = np.cos(th), np.sin(th)
    return np.column_stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1], which.astype(float)])


def map_spread(points: ArrayLike, near_m: float = SPREAD_NEAR_M) -> float:
    """How thick the map's walls are: the median distance from a point to the nearest point of
    another scan, over the points that have one within ``near_m`` [m] (nan with none).

    Parameters
    ----------
    points : array_like
        ``(P, 3)`` of :func:`map_points`.
    near_m : float
        The neighbourhood that counts.

    Returns
    -------
    float
    """
    from scipy.spatial import cKDTree

    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return math.nan
    tree = cKDTree(p[:, :2])
    k = min(16, len(p))
    dist, idx = tree.query(p[:, :2], k=k, distance_upper_bound=near_m)
    dist, idx = np.atleast_2d(dist), np.atleast_2d(idx)
    valid = idx < len(p)
    other = np.zeros_like(valid)
    other[valid] = p[idx[valid], 2] != np.repeat(p[:, 2], k).reshape(-1, k)[valid]
    d = np.where(other, dist, np.inf).min(axis=1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else math.nan


def encode_residuals(r: ArrayLike, rejected: ArrayLike, t_s: ArrayLike, inputs: ArrayLike) -> dict[str, Any]:
    """Residuals of intervals as the report's JSON (any kind of robot's).

    Parameters
    ----------
    r : array_like
        ``(K, 3)`` measured minus predicted sensor displacements ``(dx_m, dy_m, dyaw_rad)``.
    rejected : array_like
        The indices of the intervals rejected as outliers.
    t_s, inputs : array_like
        ``(K,)`` each interval's start in its input [s], and the index of its input.

    Returns
    -------
    dict
        ``t_s``, ``input``, ``dx_mm``, ``dy_mm``, ``dyaw_deg``, ``rejected`` as encoded arrays.
    """
    r = np.asarray(r, dtype=float).reshape(-1, 3)
    bad = np.zeros(len(r), dtype=bool)
    bad[np.asarray(rejected, dtype=np.intp).reshape(-1)] = True
    return {
        "t_s": encode_array(t_s, "<f8"),
        "input": encode_array(inputs, "<u2"),
        "dx_mm": encode_array(r[:, 0] * 1e3, "<f4"),
        "dy_mm": encode_array(r[:, 1] * 1e3, "<f4"),
        "dyaw_deg": encode_array(np.degrees(r[:, 2]), "<f4"),
        "rejected": encode_array(bad, "|u1"),
    }


def interval_residuals(intervals: Intervals, result: SelfcalResult, t_s: ArrayLike, inputs: ArrayLike) -> dict:
    """Each interval's measured minus predicted sensor displacement, over time.

    Parameters
    ----------
    intervals : Intervals
        The pooled intervals the estimate was made from.
    result : SelfcalResult
        The estimate (its rejected intervals are marked).
    t_s : array_like
        ``(K,)`` each interval's start in its input [s].
    inputs : array_like
        ``(K,)`` the index of its input.

    Returns
    -------
    dict
        :func:`encode_residuals`.
    """
    r = residuals(result.params, intervals.left_rad, intervals.right_rad, intervals.sensor, intervals.steps)
    return encode_residuals(r, result.intervals_rejected, t_s, inputs)


def selfcal_figures(
    parts: Sequence[Any], sizes: Sequence[int], intervals: Intervals, result: SelfcalResult
) -> dict[str, Any]:
    """The report's data of a self-calibration (the ``figures`` of its JSON).

    Parameters
    ----------
    parts : sequence
        Per input: a :class:`~umbmark.realrobot.selfcal.ScanIntervals` (a bag) or a path
        (an intervals file).
    sizes : sequence of int
        The number of intervals of each input (in the pooled intervals, in this order).
    intervals : Intervals
        The pooled intervals.
    result : SelfcalResult
        The estimate.

    Returns
    -------
    dict
        ``residuals`` (:func:`interval_residuals`; a bag's times from its first scan, an
        intervals file's from its durations) and ``maps`` (one :func:`scan_map` per bag).
    """
    dt = np.asarray(intervals.dt_s, dtype=float)
    times, maps, start = [], [], 0
    for p, n in zip(parts, sizes):
        plan = getattr(p, "plan", None)
        if plan is not None:
            scan_t = np.asarray(plan.bag.scan_t_s, dtype=float)
            times.append(scan_t[plan.pairs[p.matched, 0]] - scan_t[0])
            maps.append(scan_map(plan, result))
        else:
            d = dt[start : start + n]
            times.append(np.cumsum(d) - d)
        start += n
    t_all = np.concatenate(times) if times else np.zeros(0)
    which = np.repeat(np.arange(len(sizes)), np.asarray(sizes, dtype=np.intp))
    return {"residuals": interval_residuals(intervals, result, t_all, which), "maps": maps}


def decode_map(d: dict[str, Any]) -> dict[str, Any]:
    """A map of :func:`scan_map` with its arrays decoded (points in metres).

    Raises
    ------
    ValueError
        If an array is missing or damaged.
    """
    out = dict(d)
    for key in ("t_s", "base_nominal", "base_calibrated", "counts"):
        out[key] = decode_array(d[key])
    out["points_m"] = decode_array(d["points_mm"]).astype(float).reshape(-1, 2) * 1e-3
    if int(out["counts"].sum()) != len(out["points_m"]) or len(out["base_nominal"]) != len(out["counts"]):
        raise ValueError("the map's points, counts and poses do not match")
    return out


def decode_residuals(d: dict[str, Any]) -> dict[str, NDArray[Any]]:
    """The residuals of :func:`interval_residuals` decoded.

    Raises
    ------
    ValueError
        If an array is missing, damaged or of another length.
    """
    out = {k: decode_array(d[k]) for k in ("t_s", "input", "dx_mm", "dy_mm", "dyaw_deg", "rejected")}
    if len({len(v) for v in out.values()}) != 1:
        raise ValueError("the residuals' arrays differ in length")
    out["rejected"] = out["rejected"].astype(bool)
    return out
