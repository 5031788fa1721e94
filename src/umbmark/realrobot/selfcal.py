"""From a ROS bag to a lidar self-calibration: keyframes, scan matching, intervals, the estimate.

The method is that of Censi, Franchi, Marchionni, Oriolo, "Simultaneous calibration of odometry
and sensor parameters for mobile robots" (IEEE T-RO 29(2), 2013), estimated by
:func:`umbmark.correct.selfcal.selfcal`. This module makes its intervals from a recording
(:class:`umbmark.io.rosbag.SelfcalBag`, from :func:`umbmark.io.rosbag.read_selfcal_bag`):

1. **Wheel angles at the scans.** The cumulative wheel angles (JointState positions, or encoder
   counts) are interpolated linearly to the scans' header stamps. From ``nav_msgs/Odometry``
   they are made first: per increment of the odometry, the pose change gives the arc length
   ``ds`` and the heading change ``dth`` of the exact arc, the wheels rolled
   ``ds -/+ b dth / 2`` (``b`` the NOMINAL wheelbase) and turned that travel over the NOMINAL
   radius (:func:`wheel_angles_from_odometry`). Joint positions that jump by more than half a
   turn between samples (wrapped to one turn) are unwrapped, with a warning. Scans outside the
   wheel data, or inside a gap of it longer than ``max_wheel_gap_s``, are not used.
2. **Keyframes** (:class:`KeyframeRule`): by default every scan; or the next keyframe once the
   nominal odometry has moved a distance or turned an angle, or a time has passed. An
   interval joins two consecutive keyframes; those in which neither wheel moved are set aside
   (they say nothing about the geometry).
3. **Scan matching** (:func:`umbmark.realrobot.scanmatch.match_scan_pairs`) of the two scans of
   each interval, starting from the nominal odometry's displacement seen from the sensor at
   its nominal pose ``l0`` (``l0^-1 (+) q (+) l0``). ``l0`` is the ``/tf_static`` chain from
   the base frame to the scan frame when the bag has it, else given, else zero (the matching
   needs a start, the calibration does not). Failed matches are dropped and counted.
4. :func:`umbmark.correct.selfcal.selfcal` on the intervals of all bags together.

:func:`plan_intervals` does 1-2, :func:`match_intervals` 3 (:func:`bag_intervals` both),
:func:`selfcal_report` 4 and its report (:class:`SelfcalReport`, the JSON of
``umbmark selfcal``). :func:`selfcal_from_bags` and :func:`selfcal_from_intervals` run
everything from files.

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io` (the bag and intervals readers),
:mod:`umbmark.correct.selfcal` and :mod:`umbmark.realrobot.scanmatch`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal import SelfcalResult, selfcal
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag, StaticTransform
from umbmark.model import se2
from umbmark.model.drive import integrate_wheels
from umbmark.model.intervals import Intervals
from umbmark.realrobot.scanmatch import ICPConfig, match_scan_pairs

__all__ = [
    "selfcal_history_fields",
    "KeyframeRule",
    "IntervalPlan",
    "ScanIntervals",
    "SelfcalReport",
    "wheel_angles_from_odometry",
    "sensor_pose_from_tf",
    "plan_intervals",
    "match_intervals",
    "bag_intervals",
    "selfcal_report",
    "selfcal_from_bags",
    "selfcal_from_intervals",
    "BASE_FRAMES",
    "STILL_M",
    "MAX_TILT_RAD",
    "POSE_WARN_M",
    "POSE_WARN_RAD",
]

BASE_FRAMES = ("base_link", "base_footprint")
"""The robot frames looked up in ``/tf_static`` when no base frame is given, in this order."""

STILL_M = 1e-4
"""An interval in which neither wheel rolled more than this (nominal radius) [m] is still."""

MAX_TILT_RAD = math.radians(10.0)
"""The largest roll or pitch of the lidar in ``/tf_static`` the planar model accepts."""

POSE_WARN_M, POSE_WARN_RAD = 0.01, math.radians(1.0)
"""An estimated sensor pose further than these from the ``/tf_static`` one is reported."""

_CHUNK = 500  # scan pairs per call of the matcher (the progress steps)

FloatArray = NDArray[np.float64]
Progress = Callable[[int, int], None]


def _positive(name: str, v: float, allow_zero: bool = False, allow_inf: bool = False) -> float:
    ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and not math.isnan(v)
    ok = ok and (v >= 0 if allow_zero else v > 0) and (allow_inf or math.isfinite(v))
    if not ok:
        raise InputError(f"`{name}` must be a {'non-negative' if allow_zero else 'positive'} number, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class KeyframeRule:
    """When a scan becomes the next keyframe (the end of one interval, the start of the next).

    A scan ``j`` after the keyframe ``a`` is the next keyframe when at least ``min_interval_s``
    have passed since ``a`` and one of: the nominal odometry moved ``min_distance_m`` or
    turned ``min_rotation_rad`` since ``a``, or ``max_interval_s`` have passed. A threshold of
    0 (``max_interval_s`` infinite) is no condition; with none set, every scan is a keyframe
    (the default).

    Parameters
    ----------
    min_distance_m : float
        Distance the robot moved (straight line, nominal odometry) [m].
    min_rotation_rad : float
        Heading change of the robot (nominal odometry) [rad].
    min_interval_s : float
        Least time between keyframes [s].
    max_interval_s : float
        Most time between keyframes [s] (``inf``: no limit).

    Raises
    ------
    InputError
        A negative or non-number threshold, or ``max_interval_s`` below ``min_interval_s``.
    """

    min_distance_m: float = 0.0
    min_rotation_rad: float = 0.0
    min_interval_s: float = 0.0
    max_interval_s: float = math.inf

    def __post_init__(self) -> None:
        for name in ("min_distance_m", "min_rotation_rad", "min_interval_s"):
            _positive(name, getattr(self, name), allow_zero=True)
        _positive("max_interval_s", self.max_interval_s, allow_inf=True)
        if self.max_interval_s < self.min_interval_s:
            raise InputError(
                f"`max_interval_s` {self.max_interval_s:g} is below `min_interval_s` {self.min_interval_s:g}"
            )

    @property
    def every_scan(self) -> bool:
        """True when every scan is a keyframe."""
        return (
            self.min_distance_m == 0
            and self.min_rotation_rad == 0
            and self.min_interval_s == 0
            and math.isinf(self.max_interval_s)
        )

    def describe(self) -> str:
        """The rule in words, e.g. ``every scan`` or ``every 50 mm or 5 deg or 1 s``.

        Returns
        -------
        str
        """
        if self.every_scan:
            return "every scan"
        parts = []
        if self.min_distance_m > 0:
            parts.append(f"{self.min_distance_m * 1e3:g} mm")
        if self.min_rotation_rad > 0:
            parts.append(f"{math.degrees(self.min_rotation_rad):g} deg")
        if math.isfinite(self.max_interval_s):
            parts.append(f"{self.max_interval_s:g} s")
        text = ("every " + " or ".join(parts)) if parts else "every scan"
        if self.min_interval_s > 0:
            text += f", at least {self.min_interval_s:g} s apart"
        return text

    def to_dict(self) -> dict[str, Any]:
        """The rule as JSON: ``description``, ``min_distance_mm``, ``min_rotation_deg``,
        ``min_interval_s``, ``max_interval_s`` (null when unlimited).

        Returns
        -------
        dict
        """
        return {
            "description": self.describe(),
            "min_distance_mm": self.min_distance_m * 1e3,
            "min_rotation_deg": math.degrees(self.min_rotation_rad),
            "min_interval_s": self.min_interval_s,
            "max_interval_s": None if math.isinf(self.max_interval_s) else self.max_interval_s,
        }

    def select(self, t_s: ArrayLike, odom: ArrayLike, usable: ArrayLike) -> list[tuple[int, int]]:
        """The intervals ``(a, b)`` (scan indices) of consecutive keyframes.

        Parameters
        ----------
        t_s : array_like
            ``(M,)`` scan stamps [s], increasing.
        odom : array_like
            ``(M, 3)`` nominal odometry poses at the scans (heading accumulated).
        usable : array_like
            ``(M,)`` booleans: the scans with wheel data; an interval never starts, ends or
            passes over another scan.

        Returns
        -------
        list of (int, int)
        """
        t = np.asarray(t_s, dtype=float)
        p = np.asarray(odom, dtype=float)
        ok = np.asarray(usable, dtype=bool)
        if self.every_scan:
            a = np.flatnonzero(ok[:-1] & ok[1:])
            return [(int(i), int(i) + 1) for i in a]
        out: list[tuple[int, int]] = []
        anchor = -1
        thresholds = self.min_distance_m > 0 or self.min_rotation_rad > 0 or math.isfinite(self.max_interval_s)
        for j in range(len(t)):
            if not ok[j]:
                anchor = -1
                continue
            if anchor < 0:
                anchor = j
                continue
            dt = t[j] - t[anchor]
            if dt < self.min_interval_s:
                continue
            d = math.hypot(p[j, 0] - p[anchor, 0], p[j, 1] - p[anchor, 1])
            turn = abs(p[j, 2] - p[anchor, 2])
            if (
                not thresholds
                or (self.min_distance_m > 0 and d >= self.min_distance_m)
                or (self.min_rotation_rad > 0 and turn >= self.min_rotation_rad)
                or dt >= self.max_interval_s
            ):
                out.append((anchor, j))
                anchor = j
        return out


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


@dataclass(frozen=True, eq=False)
class IntervalPlan:
    """The intervals of one bag before scan matching (:func:`plan_intervals`).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    pairs : numpy.ndarray
        ``(K, 2)`` scan indices (start, end) of the intervals to match.
    dt_s, left_rad, right_rad : numpy.ndarray
        ``(K,)`` durations and wheel rotations of those intervals.
    initial : numpy.ndarray
        ``(K, 3)`` the nominal odometry's displacement seen from the sensor at its nominal pose.
    keyframe_rule : KeyframeRule
        The rule that chose the keyframes.
    keyframes : int
        Keyframes chosen (on usable scans).
    scans_usable : int
        Scans with wheel data (inside the wheel data's time span and not in a gap of it).
    intervals_still : int
        Intervals set aside because neither wheel moved.
    nominal_sensor_pose : tuple of float
        ``(x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad)`` the matching started from.
    sensor_pose_source : str
        Where it came from (``/tf_static base_link -> laser``, ``given``, ``none``).
    base_frame : str
        The robot frame the sensor pose refers to.
    time_span_s : float
        From the first to the last usable scan [s].
    warnings : tuple of str
        What the planning noticed (scans without wheel data, a missing transform).
    """

    bag: SelfcalBag
    pairs: NDArray[np.int64]
    dt_s: FloatArray
    left_rad: FloatArray
    right_rad: FloatArray
    initial: FloatArray
    keyframe_rule: KeyframeRule
    keyframes: int
    scans_usable: int
    intervals_still: int
    nominal_sensor_pose: tuple[float, float, float, float, float, float]
    sensor_pose_source: str
    base_frame: str
    time_span_s: float
    warnings: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.dt_s)


def _wheel_angles(bag: SelfcalBag, r_nom: float, b_nom: float) -> tuple[FloatArray, FloatArray, list[str]]:
    """Cumulative wheel angles at the wheel stamps; joint positions wrapped to a turn are unwrapped."""
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


def _span(t: FloatArray) -> str:
    return f"{t[0]:.3f} to {t[-1]:.3f} s"


def _nominal_sensor_pose(
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


def plan_intervals(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    keyframes: KeyframeRule | None = None,
    sensor_pose: ArrayLike | None = None,
    base_frame: str | None = None,
    max_wheel_gap_s: float = 0.5,
) -> IntervalPlan:
    """Wheel angles at the scans, keyframes, and the intervals to match (steps 1-2 of the module docstring).

    Parameters
    ----------
    bag : SelfcalBag
        The recording (:func:`umbmark.io.rosbag.read_selfcal_bag`).
    wheel_diameter_m : float
        Nominal wheel diameter [m] (the odometry's, for ``nav_msgs/Odometry`` wheel data).
    wheelbase_m : float
        Nominal wheelbase [m] (the odometry's, for ``nav_msgs/Odometry`` wheel data).
    keyframes : KeyframeRule, optional
        Default: every scan.
    sensor_pose : array_like, optional
        The nominal sensor pose ``(x_m, y_m, yaw_rad)`` the matching starts from; default the
        ``/tf_static`` chain from the base frame to the scan frame, else zero.
    base_frame : str, optional
        The robot frame of ``/tf_static``; default the odometry's child frame, then
        :data:`BASE_FRAMES`.
    max_wheel_gap_s : float
        A scan between two wheel samples further apart than this has no wheel data.

    Returns
    -------
    IntervalPlan

    Raises
    ------
    InputError
        A geometry or threshold that is not positive; scans and wheel data that do not
        overlap in time (both spans named); no motion; a tilted lidar in ``/tf_static``.
    """
    d_nom = _positive("wheel_diameter_m", wheel_diameter_m)
    b_nom = _positive("wheelbase_m", wheelbase_m)
    gap = _positive("max_wheel_gap_s", max_wheel_gap_s)
    rule = KeyframeRule() if keyframes is None else keyframes
    if not isinstance(rule, KeyframeRule):
        raise InputError(f"`keyframes` must be a KeyframeRule, got {type(rule).__name__}")
    src = bag.source
    r_nom = 0.5 * d_nom
    left, right, unwrapped = _wheel_angles(bag, r_nom, b_nom)
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float)
    warnings: list[str] = list(bag.warnings) + unwrapped
    inside = (st >= wt[0]) & (st <= wt[-1])
    if inside.sum() < 2:
        raise InputError(
            f"the scans ({_span(st)}) and the wheel data ({_span(wt)}) do not overlap in time: "
            "record both in one bag, stamped by one clock",
            src,
        )
    k = np.clip(np.searchsorted(wt, st, side="right"), 1, len(wt) - 1)
    gaps = wt[k] - wt[k - 1]
    exact = np.isin(st, wt)
    usable = inside & ((gaps <= gap) | exact)
    outside, in_gap = int((~inside).sum()), int((inside & ~usable).sum())
    if outside:
        warnings.append(f"{outside} of {len(st)} scans lie outside the wheel data's time span ({_span(wt)}): not used")
    if in_gap:
        warnings.append(
            f"{in_gap} scans fall in gaps of the wheel data longer than `max_wheel_gap_s` {gap:g} s: not used"
        )
    if usable.sum() < 2:
        raise InputError(f"fewer than two scans have wheel data around them (gaps over {gap:g} s)", src)
    sl = np.interp(st, wt, left)
    sr = np.interp(st, wt, right)
    odo = integrate_wheels(r_nom * np.diff(sl), r_nom * np.diff(sr), b_nom)
    pairs = np.array(rule.select(st, odo, usable), dtype=np.int64).reshape(-1, 2)
    a, b = pairs[:, 0], pairs[:, 1]
    phi_l, phi_r = sl[b] - sl[a], sr[b] - sr[a]
    moving = (np.abs(phi_l) * r_nom > STILL_M) | (np.abs(phi_r) * r_nom > STILL_M)
    if not moving.any():
        raise InputError(
            f"the wheels do not move between the scans ({bag.wheel_description}): nothing to calibrate from; "
            "record while the robot drives straights, arcs and spins",
            src,
        )
    pose, pose_src, base, pose_warn = _nominal_sensor_pose(bag, sensor_pose, base_frame)
    warnings += pose_warn
    l0 = np.array([pose[0], pose[1], pose[5]])
    q = se2.between(odo[a[moving]], odo[b[moving]])
    initial = se2.compose(se2.inverse(l0), se2.compose(q, l0))
    keyframe_count = int(np.unique(pairs).size)
    idx = np.flatnonzero(usable)
    return IntervalPlan(
        bag=bag,
        pairs=pairs[moving],
        dt_s=(st[b] - st[a])[moving],
        left_rad=phi_l[moving],
        right_rad=phi_r[moving],
        initial=initial,
        keyframe_rule=rule,
        keyframes=keyframe_count,
        scans_usable=int(usable.sum()),
        intervals_still=int((~moving).sum()),
        nominal_sensor_pose=pose,
        sensor_pose_source=pose_src,
        base_frame=base,
        time_span_s=float(st[idx[-1]] - st[idx[0]]),
        warnings=tuple(warnings),
    )


@dataclass(frozen=True, eq=False)
class ScanIntervals:
    """The intervals of one bag, matched (:func:`match_intervals`), and how they were made.

    Parameters
    ----------
    intervals : Intervals
        The intervals whose scans matched (source: the bag; the planning's warnings).
    plan : IntervalPlan
        The plan they came from.
    pairs_matched, pairs_failed : int
        Scan pairs that matched, and that failed (dropped).
    failure_reasons : dict
        Why the failed ones failed: reason -> count.
    match_rms_m : float
        Median root-mean-square point-to-line residual of the matched pairs [m].
    """

    intervals: Intervals
    plan: IntervalPlan
    pairs_matched: int
    pairs_failed: int
    failure_reasons: dict[str, int] = field(default_factory=dict)
    match_rms_m: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """What the pipeline did with the bag, as JSON.

        Returns
        -------
        dict
            ``path``, ``kind`` (``bag``), ``scan_topic``, ``scan_frame``, ``base_frame``,
            ``wheel_data``, ``scans_read``, ``scans_usable``, ``keyframes``, ``intervals_still``,
            ``pairs_matched``, ``pairs_failed``, ``failure_reasons``, ``match_rms_mm``,
            ``time_span_s``, ``nominal_sensor_pose`` (``x_mm``, ``y_mm``, ``z_mm``,
            ``roll_deg``, ``pitch_deg``, ``yaw_deg``, ``source``).
        """
        p = self.plan
        x, y, z, roll, pitch, yaw = p.nominal_sensor_pose
        return {
            "path": p.bag.source,
            "kind": "bag",
            "scan_topic": p.bag.scan_topic,
            "scan_frame": p.bag.scan_frame,
            "base_frame": p.base_frame,
            "wheel_data": p.bag.wheel_description,
            "scans_read": p.bag.n_scans,
            "scans_usable": p.scans_usable,
            "keyframes": p.keyframes,
            "intervals_still": p.intervals_still,
            "pairs_matched": self.pairs_matched,
            "pairs_failed": self.pairs_failed,
            "failure_reasons": dict(self.failure_reasons),
            "match_rms_mm": self.match_rms_m * 1e3,
            "time_span_s": p.time_span_s,
            "nominal_sensor_pose": {
                "x_mm": x * 1e3,
                "y_mm": y * 1e3,
                "z_mm": z * 1e3,
                "roll_deg": math.degrees(roll),
                "pitch_deg": math.degrees(pitch),
                "yaw_deg": math.degrees(yaw),
                "source": p.sensor_pose_source,
            },
        }


def match_intervals(
    plan: IntervalPlan,
    *,
    icp: ICPConfig | None = None,
    min_intervals: int = 10,
    progress: Progress | None = None,
) -> ScanIntervals:
    """Match the two scans of every planned interval; keep those that matched (step 3).

    Parameters
    ----------
    plan : IntervalPlan
        From :func:`plan_intervals`.
    icp : ICPConfig, optional
        Scan-matcher settings (default :class:`~umbmark.realrobot.scanmatch.ICPConfig`;
        ``coarse=True`` when the odometry is far off or the scans far apart).
    min_intervals : int
        Fewest matched intervals accepted.
    progress : callable, optional
        Called as ``progress(pairs_done, pairs_total)`` after each batch.

    Returns
    -------
    ScanIntervals

    Raises
    ------
    InputError
        Fewer than ``min_intervals`` intervals matched (the counts and the failures' reasons
        named).
    """
    bag = plan.bag
    n = len(plan)
    poses = np.empty((n, 3))
    ok = np.zeros(n, dtype=bool)
    rms = np.full(n, math.nan)
    reasons: Counter[str] = Counter()
    for s in range(0, n, _CHUNK):
        e = min(s + _CHUNK, n)
        a, b = plan.pairs[s:e, 0], plan.pairs[s:e, 1]
        m = match_scan_pairs(bag.ranges_m[a], bag.ranges_m[b], bag.angles_rad, plan.initial[s:e], icp)
        poses[s:e] = m.poses
        ok[s:e] = m.converged
        rms[s:e] = m.rms_m
        reasons.update(r.split(" (")[0] for r, c in zip(m.reasons, m.converged) if not c)
        if progress is not None:
            progress(e, n)
    matched = int(ok.sum())
    if matched < min_intervals:
        why = "; ".join(f"{c} {r}" for r, c in reasons.most_common(3)) or "none failed"
        raise InputError(
            f"only {matched} usable intervals (fewer than {min_intervals}): {n} scan pairs with motion, "
            f"{n - matched} failed to match ({why}), {plan.intervals_still} without wheel motion; "
            "drive longer, in view of walls and objects",
            bag.source,
        )
    warnings = list(plan.warnings)
    if n - matched > 0.2 * n:
        warnings.append(
            f"{n - matched} of {n} scan pairs ({100 * (n - matched) / n:.0f} %) did not match "
            f"({'; '.join(f'{c} {r}' for r, c in reasons.most_common(2))}): drive slower, or near more structure"
        )
    iv = Intervals(
        plan.dt_s[ok], plan.left_rad[ok], plan.right_rad[ok], poses[ok], source=bag.source, warnings=tuple(warnings)
    )
    return ScanIntervals(
        intervals=iv,
        plan=plan,
        pairs_matched=matched,
        pairs_failed=n - matched,
        failure_reasons=dict(reasons.most_common()),
        match_rms_m=float(np.median(rms[ok])),
    )


def bag_intervals(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    keyframes: KeyframeRule | None = None,
    sensor_pose: ArrayLike | None = None,
    base_frame: str | None = None,
    max_wheel_gap_s: float = 0.5,
    icp: ICPConfig | None = None,
    min_intervals: int = 10,
    progress: Progress | None = None,
) -> ScanIntervals:
    """:func:`plan_intervals` then :func:`match_intervals`.

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    keyframes, sensor_pose, base_frame, max_wheel_gap_s
        As :func:`plan_intervals`.
    icp, min_intervals, progress
        As :func:`match_intervals`.

    Returns
    -------
    ScanIntervals

    Raises
    ------
    InputError
        As the two steps.
    """
    plan = plan_intervals(
        bag,
        wheel_diameter_m,
        wheelbase_m,
        keyframes=keyframes,
        sensor_pose=sensor_pose,
        base_frame=base_frame,
        max_wheel_gap_s=max_wheel_gap_s,
    )
    return match_intervals(plan, icp=icp, min_intervals=min_intervals, progress=progress)


@dataclass(frozen=True, eq=False)
class SelfcalReport:
    """A self-calibration from bags or intervals files, and how its intervals were made.

    Parameters
    ----------
    result : SelfcalResult
        The estimate.
    parts : tuple
        Per input: a :class:`ScanIntervals` (a bag) or the path of an intervals file.
    intervals : Intervals
        The intervals of all inputs, pooled (what the estimate was made from; the indices of
        ``result.intervals_rejected`` refer to them).
    """

    result: SelfcalResult
    parts: tuple[ScanIntervals | str, ...]
    intervals: Intervals

    @property
    def bags(self) -> list[ScanIntervals]:
        """The inputs that were bags."""
        return [p for p in self.parts if isinstance(p, ScanIntervals)]

    @property
    def base_frame(self) -> str:
        """The robot frame of the sensor pose (the first bag's; ``base_link`` without bags)."""
        b = self.bags
        return b[0].plan.base_frame if b else BASE_FRAMES[0]

    @property
    def sensor_frame(self) -> str:
        """The lidar's frame (the first bag's scan frame; ``laser`` without bags)."""
        b = self.bags
        return b[0].plan.bag.scan_frame if b else "laser"

    @property
    def c_left(self) -> float:
        """Factor on the left wheel's travel: estimated over nominal diameter."""
        return self.result.diameter_left_m / self.result.nominal_wheel_diameter_m

    @property
    def c_right(self) -> float:
        """Factor on the right wheel's travel: estimated over nominal diameter."""
        return self.result.diameter_right_m / self.result.nominal_wheel_diameter_m

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``umbmark selfcal`` (the input of ``umbmark export``).

        Returns
        -------
        dict
            :meth:`SelfcalResult.to_dict` (diameters, wheelbase, ``Ed``, ``Eb``,
            ``sensor_pose``, their ``_ci95``, ``intervals_used``, ``intervals_rejected``,
            ``warnings``, ...) and: ``method`` (``selfcal``), ``c_left``, ``c_right``,
            ``base_frame``, ``sensor_frame``, ``nominal_sensor_pose`` (of the first bag, or
            null), the totals over the bags ``scans_read``, ``pairs_matched``,
            ``pairs_failed``, ``intervals_still``, ``time_span_s`` (null without bags),
            ``keyframe_rule`` and ``inputs`` (one object per input: a bag's
            :meth:`ScanIntervals.to_dict`, or ``path`` and ``kind`` ``intervals``).
        """
        bags = self.bags
        out = self.result.to_dict()
        total = (lambda key: sum(getattr(b, key) for b in bags)) if bags else (lambda key: None)  # noqa: E731
        out.update(
            {
                "method": "selfcal",
                "c_left": self.c_left,
                "c_right": self.c_right,
                "base_frame": self.base_frame,
                "sensor_frame": self.sensor_frame,
                "nominal_sensor_pose": bags[0].to_dict()["nominal_sensor_pose"] if bags else None,
                "scans_read": sum(b.plan.bag.n_scans for b in bags) if bags else None,
                "pairs_matched": total("pairs_matched"),
                "pairs_failed": total("pairs_failed"),
                "intervals_still": sum(b.plan.intervals_still for b in bags) if bags else None,
                "time_span_s": sum(b.plan.time_span_s for b in bags) if bags else None,
                "keyframe_rule": bags[0].plan.keyframe_rule.to_dict() if bags else None,
                "inputs": [
                    p.to_dict() if isinstance(p, ScanIntervals) else {"path": p, "kind": "intervals"}
                    for p in self.parts
                ],
            }
        )
        return out

    def history_fields(self, kind: str = "selfcal", file_hash: Callable[[str], str] | None = None) -> dict[str, Any]:
        """The keyword arguments of :func:`umbmark.history.record_result` for this result.

        Parameters
        ----------
        kind : str
            The record's kind.
        file_hash : callable, optional
            The content hash of an input file or folder (:func:`umbmark.history.file_sha256`),
            applied to the first input; None: no hash.

        Returns
        -------
        dict
            ``kind``, ``method`` (``selfcal``), ``results`` (:meth:`to_dict`), ``parameters``
            (``c_left``, ``c_right``, ``wheelbase_mm``, ``Ed``, ``Eb``, ``sensor_pose``),
            ``parameters_in_use`` (the nominal geometry and sensor pose), ``source``,
            ``input_sha256`` and ``inputs`` (the paths).
        """
        return selfcal_history_fields(self.to_dict(), kind, file_hash)


def selfcal_history_fields(
    d: dict[str, Any], kind: str = "selfcal", file_hash: Callable[[str], str] | None = None
) -> dict[str, Any]:
    """The keyword arguments of :func:`umbmark.history.record_result` for a self-calibration
    given as its JSON (:meth:`SelfcalReport.to_dict`, the output of ``umbmark selfcal --json``).

    Parameters
    ----------
    d : dict
        The self-calibration's JSON.
    kind : str
        The record's kind.
    file_hash : callable, optional
        The content hash of an input file or folder, applied to the first input; None: no hash.

    Returns
    -------
    dict
        As :meth:`SelfcalReport.history_fields`.

    Raises
    ------
    InputError
        If ``d`` is not a self-calibration's JSON.
    """
    missing = [k for k in ("c_left", "c_right", "wheelbase_mm", "Ed", "Eb", "sensor_pose") if k not in d]
    if missing or not isinstance(d.get("sensor_pose"), dict):
        raise InputError("not the JSON of a self-calibration (missing " + ", ".join(missing or ["sensor_pose"]) + ")")
    paths = [i["path"] for i in d.get("inputs", []) if isinstance(i, dict) and "path" in i]
    sp = d["sensor_pose"]
    first = Path(paths[0]) if paths else None
    return {
        "kind": kind,
        "method": "selfcal",
        "results": d,
        "parameters": {
            "c_left": d["c_left"],
            "c_right": d["c_right"],
            "wheelbase_mm": d["wheelbase_mm"],
            "Ed": d["Ed"],
            "Eb": d["Eb"],
            "sensor_pose": {k: sp.get(k) for k in ("x_mm", "y_mm", "yaw_deg")},
        },
        "parameters_in_use": {
            "wheel_diameter_mm": d.get("nominal_wheel_diameter_mm"),
            "wheelbase_mm": d.get("nominal_wheelbase_mm"),
            "sensor_pose": d.get("nominal_sensor_pose"),
        },
        "source": None if first is None else str(first.resolve() if first.exists() else first),
        "input_sha256": file_hash(str(first)) if first is not None and first.exists() and file_hash else None,
        "inputs": {"paths": paths},
    }


def _pose_warnings(parts: Sequence[ScanIntervals | str], result: SelfcalResult) -> list[str]:
    """A warning when the estimated sensor pose is further from the one of /tf_static than
    :data:`POSE_WARN_M` or :data:`POSE_WARN_RAD`."""
    out = []
    for p in parts:
        if not isinstance(p, ScanIntervals) or not p.plan.sensor_pose_source.startswith("/tf_static"):
            continue
        x, y, _, _, _, yaw = p.plan.nominal_sensor_pose
        ex, ey, eyaw = result.sensor_pose
        dpos = math.hypot(ex - x, ey - y)
        dyaw = abs(math.remainder(eyaw - yaw, 2 * math.pi))
        if dpos > POSE_WARN_M or dyaw > POSE_WARN_RAD:
            out.append(
                f"the estimated sensor pose differs from {p.plan.sensor_pose_source} of {Path(p.plan.bag.source).name} "
                f"by {dpos * 1e3:.0f} mm and {math.degrees(dyaw):.1f} deg: check the URDF, or the wheel data"
            )
    return out


def selfcal_report(
    parts: Sequence[ScanIntervals | tuple[str, Intervals]],
    wheel_diameter_m: float,
    wheelbase_m: float,
    **options: Any,
) -> SelfcalReport:
    """Pool the intervals of several inputs and self-calibrate (step 4).

    Parameters
    ----------
    parts : sequence
        Per input: a :class:`ScanIntervals` (a bag), or ``(path, Intervals)`` (an intervals
        file).
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    **options
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal` (``reject_outliers``,
        ``sensor_covariance`` ...).

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        No inputs, or what :func:`umbmark.correct.selfcal.selfcal` refuses.
    """
    if not parts:
        raise InputError("no inputs to self-calibrate from")
    several = len(parts) > 1
    ivs: list[Intervals] = []
    kept: list[ScanIntervals | str] = []
    for p in parts:
        iv = p.intervals if isinstance(p, ScanIntervals) else p[1]
        name = str(iv.source) if isinstance(p, ScanIntervals) else str(p[0])
        if several:
            iv = Intervals(
                iv.dt_s,
                iv.left_rad,
                iv.right_rad,
                iv.sensor,
                iv.source,
                tuple(f"{Path(name).name}: {w}" for w in iv.warnings),
            )
        ivs.append(iv)
        kept.append(p if isinstance(p, ScanIntervals) else str(p[0]))
    if several:
        frames = {p.plan.bag.scan_frame for p in kept if isinstance(p, ScanIntervals)}
        extra = () if len(frames) <= 1 else (f"the bags' scans are in different frames ({', '.join(sorted(frames))})",)
        pooled = Intervals(
            np.concatenate([iv.dt_s for iv in ivs]),
            np.concatenate([iv.left_rad for iv in ivs]),
            np.concatenate([iv.right_rad for iv in ivs]),
            np.concatenate([iv.sensor for iv in ivs]),
            " + ".join(str(iv.source) for iv in ivs),
            tuple(w for iv in ivs for w in iv.warnings) + extra,
        )
    else:
        pooled = ivs[0]
    res = selfcal(pooled, wheel_diameter_m, wheelbase_m, **options)
    extra_w = _pose_warnings(kept, res)
    if extra_w:
        res = replace(res, warnings=list(res.warnings) + extra_w)
    return SelfcalReport(res, tuple(kept), pooled)


def selfcal_from_bags(
    paths: str | Path | Sequence[str | Path],
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    keyframes: KeyframeRule | None = None,
    sensor_pose: ArrayLike | None = None,
    base_frame: str | None = None,
    max_wheel_gap_s: float = 0.5,
    icp: ICPConfig | None = None,
    min_intervals: int = 10,
    selfcal_options: dict[str, Any] | None = None,
    **read_options: Any,
) -> SelfcalReport:
    """Self-calibrate from one or several bags (their intervals pooled).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The bags.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    keyframes, sensor_pose, base_frame, max_wheel_gap_s
        As :func:`plan_intervals`.
    icp, min_intervals
        As :func:`match_intervals`.
    selfcal_options : dict, optional
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.
    **read_options
        Keyword arguments of :func:`umbmark.io.rosbag.read_selfcal_bag` (``scan_topic``,
        ``joints``, ``ticks_topic``, ``odom_topic`` ...).

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        As the reader and the steps.
    """
    from umbmark.io.rosbag import read_selfcal_bag

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    parts = []
    for p in items:
        bag = read_selfcal_bag(p, **read_options)
        parts.append(
            bag_intervals(
                bag,
                wheel_diameter_m,
                wheelbase_m,
                keyframes=keyframes,
                sensor_pose=sensor_pose,
                base_frame=base_frame,
                max_wheel_gap_s=max_wheel_gap_s,
                icp=icp,
                min_intervals=min_intervals,
            )
        )
    return selfcal_report(parts, wheel_diameter_m, wheelbase_m, **(selfcal_options or {}))


def selfcal_from_intervals(
    paths: str | Path | Sequence[str | Path],
    wheel_diameter_m: float,
    wheelbase_m: float,
    **options: Any,
) -> SelfcalReport:
    """Self-calibrate from one or several intervals files (pooled).

    Parameters
    ----------
    paths : str, Path or sequence of them
        Intervals files (:mod:`umbmark.io.intervals_csv`).
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    **options
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        A bad file, or what :func:`umbmark.correct.selfcal.selfcal` refuses.
    """
    from umbmark.io.intervals_csv import read_intervals_csv

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    return selfcal_report([(str(p), read_intervals_csv(p)) for p in items], wheel_diameter_m, wheelbase_m, **options)
