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
   radius (:func:`umbmark.realrobot.wheels.recording_wheel_angles`). Joint positions wrapped to
   one turn were unwrapped by the reader. Scans outside the wheel data (by more than half a
   wheel sample), or inside a gap of it longer than ``max_wheel_gap_s``, are not used.
2. **Keyframes** (:class:`KeyframeRule`): the next keyframe once the nominal odometry has moved
   a distance or turned an angle, or a time has passed (by default :data:`DEFAULT_KEYFRAMES`:
   at least 0.5 s apart and 100 mm, 10 deg or 2 s; or every scan). An
   interval joins two consecutive keyframes; those in which neither wheel moved are set aside
   (they say nothing about the geometry).
3. **Scan matching** (:func:`umbmark.realrobot.scanmatch.match_scan_pairs`) of the two scans of
   each interval, starting from the nominal odometry's displacement seen from the sensor at
   its nominal pose ``l0`` (``l0^-1 (+) q (+) l0``). ``l0`` is the ``/tf_static`` chain from
   the base frame to the scan frame when the bag has it, else given, else zero (the matching
   needs a start, the calibration does not). Failed matches are dropped and counted.
4. **The scans' delay** (:func:`estimate_scan_delay`, by default): a scan is stamped when it
   arrives, after its sweep and the transfer, while the wheel data are stamped when read, so
   the scans are often late against the wheels by a fraction of a sweep. The matched turns are
   correlated with the wheels' turns read at ``stamp - d`` for trial delays ``d`` (on a sample
   of the intervals); the best ``d`` is applied and 1-3 run again.
5. :func:`umbmark.correct.selfcal.selfcal` on the intervals of all bags together (blocks of
   time per bag, :func:`interval_blocks`, for the covariance of errors shared within a
   recording).

:func:`plan_intervals` does 1-2, :func:`match_intervals` 3 (:func:`bag_intervals` 1-4),
:func:`selfcal_report` 5 and its report (:class:`SelfcalReport`, the JSON of
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
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import positive
from umbmark._files import check_distinct_inputs, inputs_sha256
from umbmark._numbers import strict_float
from umbmark.correct.noise import OdometryNoise
from umbmark.correct.selfcal import SelfcalResult, selfcal
from umbmark.correct.selfcal.estimate import BLOCK_S, MAX_BLOCKS
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag, StaticTransform
from umbmark.io.wheels import WheelSource
from umbmark.kinds import DEFAULT_KIND, Kind, kind_in, kind_named
from umbmark.model import se2
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry
from umbmark.model.intervals import Intervals, IntervalSteps
from umbmark.realrobot.motion_check import check_readings, check_wheels_against_scans, lidar_motion
from umbmark.realrobot.scanmatch import ICPConfig, match_scan_pairs
from umbmark.realrobot.wheels import recording_wheel_angles

__all__ = [
    "selfcal_history_fields",
    "KeyframeRule",
    "IntervalOptions",
    "DEFAULT_KEYFRAMES",
    "DEFAULT_KEYFRAMES_M",
    "DEFAULT_KEYFRAMES_RAD",
    "DEFAULT_KEYFRAMES_MIN_S",
    "DEFAULT_KEYFRAMES_S",
    "IntervalPlan",
    "ScanIntervals",
    "ScanDelay",
    "estimate_scan_delay",
    "check_bag_motion",
    "delay_from_turns",
    "parse_scan_delay",
    "match_pairs",
    "PairMatches",
    "composed_matches",
    "matched_motion",
    "SelfcalReport",
    "sensor_pose_from_tf",
    "plan_intervals",
    "match_intervals",
    "bag_intervals",
    "interval_blocks",
    "selfcal_report",
    "selfcal_from_bags",
    "StageProgress",
    "selfcal_from_intervals",
    "BASE_FRAMES",
    "STILL_M",
    "MAX_TILT_RAD",
    "POSE_WARN_M",
    "POSE_WARN_RAD",
    "SCAN_DELAY_SEARCH_S",
    "MAX_SCAN_DELAY_S",
]

BASE_FRAMES = ("base_link", "base_footprint")
"""The robot frames looked up in ``/tf_static`` when no base frame is given, in this order."""

STILL_M = 1e-4
"""An interval in which neither wheel rolled more than this (nominal radius) [m] is still."""

MAX_TILT_RAD = math.radians(10.0)
"""The largest roll or pitch of the lidar in ``/tf_static`` the planar model accepts."""

POSE_WARN_M, POSE_WARN_RAD = 0.01, math.radians(1.0)
"""An estimated sensor pose further than these from the ``/tf_static`` one is reported."""

SCAN_DELAY_SEARCH_S = 0.3
"""How far either way the scans' delay is searched [s] (:func:`estimate_scan_delay`)."""

MAX_SCAN_DELAY_S = 1.0
"""The largest scan delay accepted when given [s]: a scan is stamped within a sweep of when it was
taken, and more points to milliseconds given as seconds."""

_CHUNK = 500  # scan pairs per call of the matcher (the progress steps)

DEFAULT_KEYFRAMES_M, DEFAULT_KEYFRAMES_RAD = 0.1, math.radians(10.0)
DEFAULT_KEYFRAMES_MIN_S, DEFAULT_KEYFRAMES_S = 0.5, 2.0
"""The default keyframes: at least 0.5 s apart, the next after 100 mm of travel or 10 deg of
turn, or 2 s (:data:`DEFAULT_KEYFRAMES`)."""

FloatArray = NDArray[np.float64]
StepProgress = Callable[[int, int], None]
"""``progress(done, total)``: a step of a pipeline moved to ``done`` of ``total``."""


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
            positive(f"`{name}`", getattr(self, name), allow_zero=True)
        positive("`max_interval_s`", self.max_interval_s, allow_inf=True)
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


DEFAULT_KEYFRAMES = KeyframeRule(
    min_distance_m=DEFAULT_KEYFRAMES_M,
    min_rotation_rad=DEFAULT_KEYFRAMES_RAD,
    min_interval_s=DEFAULT_KEYFRAMES_MIN_S,
    max_interval_s=DEFAULT_KEYFRAMES_S,
)
"""The keyframes of a self-calibration unless told otherwise: at least 0.5 s apart, and every
100 mm or 10 deg or 2 s.

Intervals from one scan to the next are short; the errors of the wheel data at their ends (a
scan stamped a few milliseconds off the moment it was taken, a wheel sample a little early or
late, the matcher's error in each scan) are then a large part of each interval's motion, and a
fit that takes the wheels as exact turns them into a wheel scale or a turn a few per cent
small (regression dilution; ``benchmarks/results/selfcal_keyframes.md``). Such errors come
with the speed, so the least time between keyframes divides their weight for every motion;
100 mm or 10 deg make each interval a motion worth measuring, and the scans of an interval
still overlap for the matcher. The motion inside an interval is its scan-to-scan steps
composed (:class:`umbmark.model.intervals.IntervalSteps`), and the keyframes are chosen on the
scan matches, not on the wheel data (:func:`bag_intervals`)."""


@dataclass(frozen=True)
class IntervalOptions:
    """How a recording's scans and wheel data become matched intervals (steps 1-4 of the module
    docstring): :func:`plan_intervals`, :func:`bag_intervals`, :func:`selfcal_from_bags`.

    Parameters
    ----------
    keyframes : KeyframeRule
        When a scan becomes the next keyframe (default :data:`DEFAULT_KEYFRAMES`;
        ``KeyframeRule()``: every scan).
    sensor_pose : (float, float, float), optional
        The nominal sensor pose ``(x_m, y_m, yaw_rad)`` the matching starts from; default the
        ``/tf_static`` chain from the base frame to the scan frame, else zero.
    base_frame : str, optional
        The robot frame of ``/tf_static``; default the odometry's child frame, then
        :data:`BASE_FRAMES`.
    max_wheel_gap_s : float
        A scan between two wheel samples further apart than this has no wheel data [s].
    icp : ICPConfig, optional
        The scan matcher's settings (default :class:`~umbmark.realrobot.scanmatch.ICPConfig`).
    min_intervals : int
        The fewest matched intervals (at least 3).
    scan_delay : float or str
        How late the scans are stamped against the wheel data: ``"auto"`` (estimated,
        :func:`estimate_scan_delay`), ``"off"`` or a number of seconds (:func:`parse_scan_delay`).

    Raises
    ------
    InputError
        A keyframe rule that is not a :class:`KeyframeRule`, a gap that is not positive, fewer
        than 3 intervals, a bad sensor pose or delay.
    """

    keyframes: KeyframeRule = DEFAULT_KEYFRAMES
    sensor_pose: tuple[float, float, float] | None = None
    base_frame: str | None = None
    max_wheel_gap_s: float = 0.5
    icp: ICPConfig | None = None
    min_intervals: int = 10
    scan_delay: float | str = "auto"

    def __post_init__(self) -> None:
        if not isinstance(self.keyframes, KeyframeRule):
            raise InputError(f"`keyframes` must be a KeyframeRule, got {type(self.keyframes).__name__}")
        positive("`max_wheel_gap_s`", self.max_wheel_gap_s)
        if not isinstance(self.min_intervals, (int, np.integer)) or isinstance(self.min_intervals, bool):
            raise InputError(f"`min_intervals` must be a whole number, got {self.min_intervals!r}")
        if self.min_intervals < 3:
            raise InputError(f"`min_intervals` must be at least 3, got {self.min_intervals}")
        if self.icp is not None and not isinstance(self.icp, ICPConfig):
            raise InputError(f"`icp` must be an ICPConfig, got {type(self.icp).__name__}")
        if self.sensor_pose is not None:
            p = np.asarray(self.sensor_pose, dtype=float).reshape(-1)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise InputError("`sensor_pose` must be three finite numbers (x_m, y_m, yaw_rad)")
            object.__setattr__(self, "sensor_pose", (float(p[0]), float(p[1]), float(p[2])))
        object.__setattr__(self, "scan_delay", parse_scan_delay(self.scan_delay))


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
    scan_delay_s : float
        The delay of the scans' stamps the wheel angles were read with [s].
    pairs : numpy.ndarray
        ``(K, 2)`` scan indices (start, end) of the intervals to match.
    steps : IntervalSteps or None
        The wheels' rotations from scan to scan inside each interval (keyframes more than one
        scan apart; the robot's motion is then those arcs composed), or None (every scan).
    chained : numpy.ndarray or None
        ``(K,)`` booleans: ``initial`` is the matches of consecutive scans composed over the
        whole interval, and stands for its displacement when its two scans do not match; or
        None.
    chained_covariance : numpy.ndarray or None
        ``(K, 3, 3)`` the covariance of those composed matches (their covariances summed).
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
    end_rates : numpy.ndarray or None
        ``(K, 4)`` the wheels' rates at each interval's two stamps [rad/s] (left, right at the
        start; left, right at the end), from the wheel data a sample period either side.
    """

    bag: SelfcalBag
    scan_delay_s: float
    pairs: NDArray[np.int64]
    steps: IntervalSteps | None
    chained: NDArray[np.bool_] | None
    chained_covariance: FloatArray | None
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
    end_rates: FloatArray | None = None

    def __len__(self) -> int:
        return len(self.dt_s)


def _span(t: FloatArray) -> str:
    return f"{t[0]:.3f} to {t[-1]:.3f} s"


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


def _options(options: IntervalOptions | None) -> IntervalOptions:
    if options is None:
        return IntervalOptions()
    if not isinstance(options, IntervalOptions):
        raise InputError(f"`options` must be IntervalOptions, got {type(options).__name__}")
    return options


def usable_scans(
    st: FloatArray, wt: FloatArray, period: float, gap: float, src: str, warnings: list[str]
) -> NDArray[np.bool_]:
    """The scans with wheel data around them: within half a wheel sample of the wheel data's span
    (a scan there takes the end's angles) and not in a gap of it longer than ``gap``; a warning
    for those left out, an error when fewer than two are left."""
    edge = 0.5 * period
    inside = (st >= wt[0] - edge) & (st <= wt[-1] + edge)
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
        t0 = min(float(st[0]), float(wt[0]))
        warnings.append(
            f"{outside} of {len(st)} scans lie outside the wheel data's time span (the wheel data from "
            f"{wt[0] - t0:.3f} to {wt[-1] - t0:.3f} s, the scans from {st[0] - t0:.3f} to {st[-1] - t0:.3f} s "
            "after the first stamp): not used"
        )
    if in_gap:
        warnings.append(
            f"{in_gap} scans fall in gaps of the wheel data longer than `max_wheel_gap_s` {gap:g} s: not used"
        )
    if usable.sum() < 2:
        raise InputError(f"fewer than two scans have wheel data around them (gaps over {gap:g} s)", src)
    return np.asarray(usable)


def _chained(
    kept: NDArray[np.int64], motion_links: ArrayLike, motion_covariance: ArrayLike | None, n_scans: int, src: str
) -> tuple[NDArray[np.bool_], FloatArray]:
    """For each interval ``kept`` (its two scans): whether every step of the motion between them is
    a match, and the summed covariance of those steps."""
    links = np.asarray(motion_links, dtype=bool).reshape(-1)
    if links.shape != (n_scans - 1,):
        raise InputError(f"`motion_links` must hold {n_scans - 1} booleans, got {links.shape}", src)
    a, b = kept[:, 0], kept[:, 1]
    bad = np.concatenate([[0], np.cumsum(~links)])
    c = np.zeros((n_scans - 1, 3, 3)) if motion_covariance is None else np.asarray(motion_covariance, float)
    cum = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(np.nan_to_num(c), axis=0)])
    return bad[b] - bad[a] == 0, cum[b] - cum[a]


def _end_rates(
    kept: NDArray[np.int64], st: FloatArray, wt: FloatArray, period: float, angles: tuple[FloatArray, FloatArray]
) -> FloatArray:
    """``(K, 4)``: the wheels' rates at the two stamps of each interval (left, right at its start,
    then at its end), from the wheel data a wheel sample period either side: independent of where
    in a sample period a stamp falls (a rate from the interval's own rotation would carry the
    stamps' errors)."""
    rates = np.zeros((len(st), 2))
    if period > 0:
        for c, ang in enumerate(angles):
            rates[:, c] = (np.interp(st + period, wt, ang) - np.interp(st - period, wt, ang)) / (2.0 * period)
    return np.column_stack([rates[kept[:, 0]], rates[kept[:, 1]]])


def _interval_steps(kept: NDArray[np.int64], sl: FloatArray, sr: FloatArray, st: FloatArray) -> IntervalSteps | None:
    """The wheels' rotations from scan to scan inside each interval (None when every interval is
    one step)."""
    counts = kept[:, 1] - kept[:, 0]
    if not np.any(counts > 1):
        return None
    j = np.repeat(kept[:, 0], counts) + np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    dl, dr = np.diff(sl), np.diff(sr)
    return IntervalSteps(dl[j], dr[j], np.concatenate([[0], np.cumsum(counts)]), np.diff(st)[j])


def plan_intervals(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    options: IntervalOptions | None = None,
    *,
    scan_delay_s: float = 0.0,
    motion: ArrayLike | None = None,
    motion_links: ArrayLike | None = None,
    motion_covariance: ArrayLike | None = None,
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
    options : IntervalOptions, optional
        Its keyframes, sensor pose, base frame and wheel gap (default :class:`IntervalOptions`).
    scan_delay_s : float
        How late the scans are stamped against the wheel data [s]: a scan stamped ``t`` takes
        the wheel angles at ``t - scan_delay_s``.
    motion : array_like, optional
        ``(M, 3)`` the sensor's poses at the scans in one frame, e.g. the matches of
        consecutive scans composed (:func:`matched_motion`): the keyframes are chosen on this
        motion instead of the nominal odometry's (keyframes chosen where the wheel data's own
        errors reach a threshold would bias the intervals' wheel rotations), and the matching
        of each interval starts from it.
    motion_links : array_like, optional
        ``(M - 1,)`` booleans: the step of ``motion`` from each scan to the next is a match (or
        no motion); an interval whose steps all are may take ``motion`` itself as its
        displacement when its two scans do not match (:attr:`IntervalPlan.chained`).
    motion_covariance : array_like, optional
        ``(M - 1, 3, 3)`` the covariance of each step of ``motion`` (default zero).

    Returns
    -------
    IntervalPlan

    Raises
    ------
    InputError
        A geometry or threshold that is not positive; scans and wheel data that do not
        overlap in time (both spans named); no motion; a tilted lidar in ``/tf_static``.
    """
    d_nom = positive("`wheel_diameter_m`", wheel_diameter_m)
    b_nom = positive("`wheelbase_m`", wheelbase_m)
    opts = _options(options)
    gap, rule = opts.max_wheel_gap_s, opts.keyframes
    src = bag.source
    r_nom = 0.5 * d_nom
    left, right = recording_wheel_angles(bag, WheelGeometry(d_nom, d_nom, b_nom))
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    if not (isinstance(scan_delay_s, (int, float, np.floating)) and math.isfinite(scan_delay_s)):
        raise InputError(f"`scan_delay_s` must be a finite number of seconds, got {scan_delay_s!r}")
    st = np.asarray(bag.scan_t_s, dtype=float) - float(scan_delay_s)
    warnings: list[str] = list(bag.warnings)
    period = float(np.median(np.diff(wt))) if len(wt) > 1 else 0.0  # of the wheel data
    usable = usable_scans(st, wt, period, gap, src, warnings)
    sl = np.interp(st, wt, left)
    sr = np.interp(st, wt, right)
    odo = integrate_wheels(r_nom * np.diff(sl), r_nom * np.diff(sr), b_nom)
    seen = None if motion is None else np.asarray(motion, dtype=float)
    if seen is not None and seen.shape != (len(st), 3):
        raise InputError(f"`motion` must be ({len(st)}, 3), one pose per scan; got {seen.shape}", src)
    pairs = np.array(rule.select(st, odo if seen is None else seen, usable), dtype=np.int64).reshape(-1, 2)
    a, b = pairs[:, 0], pairs[:, 1]
    phi_l, phi_r = sl[b] - sl[a], sr[b] - sr[a]
    moving = (np.abs(phi_l) * r_nom > STILL_M) | (np.abs(phi_r) * r_nom > STILL_M)
    if not moving.any():
        raise InputError(
            f"the wheels do not move between the scans ({bag.wheel_description}): nothing to calibrate from; "
            "record while the robot drives straights, arcs and spins",
            src,
        )
    pose, pose_src, base, pose_warn = nominal_sensor_pose_of(bag, opts.sensor_pose, opts.base_frame)
    warnings += pose_warn
    l0 = np.array([pose[0], pose[1], pose[5]])
    q = se2.between(odo[a[moving]], odo[b[moving]])
    initial = se2.compose(se2.inverse(l0), se2.compose(q, l0))
    chained = chained_cov = None
    kept = pairs[moving]
    if seen is not None:
        initial = se2.between(seen[kept[:, 0]], seen[kept[:, 1]])
        if motion_links is not None:
            chained, chained_cov = _chained(kept, motion_links, motion_covariance, len(st), src)
    keyframe_count = int(np.unique(pairs).size)
    idx = np.flatnonzero(usable)
    return IntervalPlan(
        bag=bag,
        scan_delay_s=float(scan_delay_s),
        pairs=kept,
        steps=_interval_steps(kept, sl, sr, st),
        chained=chained,
        chained_covariance=chained_cov,
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
        end_rates=_end_rates(kept, st, wt, period, (left, right)),
    )


@dataclass(frozen=True)
class ScanDelay:
    """The delay of the scans' stamps behind the wheel data's clock (:func:`estimate_scan_delay`).

    Parameters
    ----------
    delay_s : float
        The estimate [s]: a scan stamped ``t`` was taken when the wheel data say ``t - delay_s``.
    correlation : float
        Correlation of the scan-matched turns with the wheels' turns at that delay.
    correlation_at_zero : float
        The same with the stamps as recorded.
    pairs : int
        Matched scan pairs it was estimated from.
    search_s : float
        The delays searched: ``-search_s`` to ``search_s`` [s].
    """

    delay_s: float
    correlation: float
    correlation_at_zero: float
    pairs: int
    search_s: float

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``delay_s``, ``correlation``, ``correlation_at_zero``, ``pairs``, ``search_s``.
        """
        return {
            "delay_s": self.delay_s,
            "correlation": self.correlation,
            "correlation_at_zero": self.correlation_at_zero,
            "pairs": self.pairs,
            "search_s": self.search_s,
        }


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
        Scan pairs that matched (or were chained), and that failed (dropped).
    failure_reasons : dict
        Why the failed ones failed: reason -> count.
    match_rms_m : float
        Median root-mean-square point-to-line residual of the matched pairs [m].
    pairs_chained : int
        Of ``pairs_matched``, the keyframe pairs whose two scans did not match but the
        consecutive scans between them did: their displacement is those matches composed.
    matched : numpy.ndarray
        ``(K,)`` booleans, one per planned pair: it matched (its interval is in ``intervals``).
    poses : numpy.ndarray
        ``(K, 3)`` the matcher's answer for every planned pair (also those that failed).
    covariances : numpy.ndarray
        ``(K, 3, 3)`` its covariance (of the composed matches for a chained pair).
    scan_delay : ScanDelay or None
        The delay estimated from this bag (:func:`estimate_scan_delay`), or None when it was
        given or not looked for.
    scan_delay_requested : str
        ``auto``, or the delay given in seconds (``0``: stamps as recorded).
    """

    intervals: Intervals
    plan: IntervalPlan
    pairs_matched: int
    pairs_failed: int
    failure_reasons: dict[str, int] = field(default_factory=dict)
    match_rms_m: float = math.nan
    pairs_chained: int = 0
    matched: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    poses: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    covariances: FloatArray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    scan_delay: ScanDelay | None = None
    scan_delay_requested: str = "0"

    @property
    def start_s(self) -> FloatArray:
        """``(K_matched,)`` the stamps of the intervals' first scans, delay applied [s]."""
        st = np.asarray(self.plan.bag.scan_t_s, dtype=float) - self.plan.scan_delay_s
        return np.asarray(st[self.plan.pairs[self.matched, 0]], dtype=float)

    def delay_dict(self) -> dict[str, Any]:
        """The scan delay of this bag as JSON (an element of ``scan_delay`` in the report).

        Returns
        -------
        dict
            ``bag``, ``requested`` (``auto`` or seconds), ``applied_s`` and, when estimated,
            :meth:`ScanDelay.to_dict`'s keys.
        """
        out: dict[str, Any] = {"bag": self.plan.bag.source, "requested": self.scan_delay_requested}
        if self.scan_delay is not None:
            out.update(self.scan_delay.to_dict())
        out["applied_s"] = self.plan.scan_delay_s
        return out

    def to_dict(self) -> dict[str, Any]:
        """What the pipeline did with the bag, as JSON.

        Returns
        -------
        dict
            ``path``, ``kind`` (``bag``), ``scan_topic``, ``scan_frame``, ``base_frame``,
            ``wheel_data``, ``scans_read``, ``scans_usable``, ``keyframes``, ``intervals_still``,
            ``pairs_matched``, ``pairs_chained``, ``pairs_failed``, ``failure_reasons``, ``match_rms_mm``,
            ``time_span_s``, ``wheel_stream`` (what the check of the wheel data found and did:
            :meth:`umbmark.model.wheel_stream.StreamReport.to_dict`), ``scan_delay``
            (:meth:`delay_dict`), ``nominal_sensor_pose``
            (``x_mm``, ``y_mm``, ``z_mm``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``, ``source``).
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
            "pairs_chained": self.pairs_chained,
            "pairs_failed": self.pairs_failed,
            "failure_reasons": dict(self.failure_reasons),
            "match_rms_mm": self.match_rms_m * 1e3,
            "time_span_s": p.time_span_s,
            "wheel_stream": None if p.bag.wheel_stream is None else p.bag.wheel_stream.to_dict(),
            "scan_delay": self.delay_dict(),
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
    progress: StepProgress | None = None,
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
    m = match_pairs(bag, plan.pairs, plan.initial, plan.chained, plan.chained_covariance, icp=icp, progress=progress)
    n, ok, poses, covs = len(plan), m.ok, m.poses, m.covariances
    matched = int(ok.sum())
    warnings = m.judge(min_intervals, plan.intervals_still, plan.warnings, bag.source)
    iv = Intervals(
        plan.dt_s[ok],
        plan.left_rad[ok],
        plan.right_rad[ok],
        poses[ok],
        source=bag.source,
        warnings=tuple(warnings),
        steps=None if plan.steps is None else plan.steps.subset(np.flatnonzero(ok)),
        covariance=0.5 * (covs[ok] + np.swapaxes(covs[ok], 1, 2)),
        end_rates=None if plan.end_rates is None else plan.end_rates[ok],
    )
    return ScanIntervals(
        intervals=iv,
        plan=plan,
        pairs_matched=matched,
        pairs_failed=n - matched,
        pairs_chained=m.chained,
        failure_reasons=dict(m.reasons.most_common()),
        match_rms_m=float(np.median(m.rms_m[ok])),
        matched=ok,
        poses=poses,
        covariances=covs,
    )


@dataclass(frozen=True, eq=False)
class PairMatches:
    """The matches of planned scan pairs (:func:`match_pairs`).

    Attributes
    ----------
    poses : numpy.ndarray
        ``(K, 3)`` the matcher's answer (a chained pair's: the composed matches).
    covariances : numpy.ndarray
        ``(K, 3, 3)``.
    ok : numpy.ndarray
        ``(K,)`` matched, or chained.
    rms_m : numpy.ndarray
        ``(K,)`` root-mean-square point-to-line residual [m].
    reasons : collections.Counter
        Why the failed ones failed: reason -> count.
    chained : int
        Pairs that did not match but were chained.
    """

    poses: FloatArray
    covariances: FloatArray
    ok: NDArray[np.bool_]
    rms_m: FloatArray
    reasons: Counter[str]
    chained: int

    def judge(self, min_intervals: int, still: int, warnings: Sequence[str], source: str) -> list[str]:
        """The planning's warnings and one for many failures; an error when fewer than
        ``min_intervals`` matched (``still``: the pairs set aside without wheel motion)."""
        n, matched = len(self.ok), int(self.ok.sum())
        if matched < min_intervals:
            causes = "; ".join(f"{c} {r}" for r, c in self.reasons.most_common(3)) or "none failed"
            raise InputError(
                f"only {matched} usable intervals (fewer than {min_intervals}): {n} scan pairs with motion, "
                f"{n - matched} failed to match ({causes}), {still} without wheel motion; "
                "drive longer, in view of walls and objects",
                source,
            )
        out = list(warnings)
        if n - matched > 0.2 * n:
            out.append(
                f"{n - matched} of {n} scan pairs ({100 * (n - matched) / n:.0f} %) did not match "
                f"({'; '.join(f'{c} {r}' for r, c in self.reasons.most_common(2))}): drive slower, or near more "
                "structure"
            )
        return out


def match_pairs(
    bag: SelfcalBag,
    pairs: NDArray[np.int64],
    initial: FloatArray,
    chained: NDArray[np.bool_] | None = None,
    chained_covariance: FloatArray | None = None,
    *,
    icp: ICPConfig | None = None,
    progress: StepProgress | None = None,
) -> PairMatches:
    """Match the scans of each pair from its initial displacement; a pair that fails but is
    ``chained`` takes ``initial`` (the composed matches) with ``chained_covariance``.

    Parameters
    ----------
    bag : SelfcalBag
        The scans.
    pairs : numpy.ndarray
        ``(K, 2)`` scan indices.
    initial : numpy.ndarray
        ``(K, 3)`` the matcher's starts.
    chained, chained_covariance : numpy.ndarray, optional
        ``(K,)`` and ``(K, 3, 3)`` (:attr:`IntervalPlan.chained`).
    icp : ICPConfig, optional
    progress : callable, optional
        Called as ``progress(pairs_done, pairs_total)`` after each batch.

    Returns
    -------
    PairMatches
    """
    n = len(pairs)
    poses = np.empty((n, 3))
    covs = np.full((n, 3, 3), np.nan)
    ok = np.zeros(n, dtype=bool)
    rms = np.full(n, math.nan)
    why = [""] * n
    for s0 in range(0, n, _CHUNK):
        e = min(s0 + _CHUNK, n)
        a, b = pairs[s0:e, 0], pairs[s0:e, 1]
        m = match_scan_pairs(bag.ranges_m[a], bag.ranges_m[b], bag.angles_rad, initial[s0:e], icp)
        poses[s0:e] = m.poses
        covs[s0:e] = m.covariances
        ok[s0:e] = m.converged
        rms[s0:e] = m.rms_m
        why[s0:e] = [r.split(" (")[0] for r in m.reasons]
        if progress is not None:
            progress(e, n)
    direct = ok.copy()
    if chained is not None:
        assert chained_covariance is not None
        use = ~ok & chained
        poses[use] = initial[use]
        covs[use] = chained_covariance[use]
        ok |= use
    reasons: Counter[str] = Counter(r for r, c in zip(why, ok) if not c)
    return PairMatches(poses, covs, ok, rms, reasons, int((ok & ~direct).sum()))


def estimate_scan_delay(
    matches: ScanIntervals,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    search_s: float = SCAN_DELAY_SEARCH_S,
    step_s: float = 0.005,
) -> ScanDelay:
    """Estimate how late the scans are stamped against the wheel data, from the turns.

    For each trial delay ``d`` on a grid, the robot's turn between ``t_a - d`` and ``t_b - d``
    by the wheel data (the odometry's heading, or the wheel angles through the nominal
    geometry; interpolated linearly) is correlated with the matched turn between the scans
    stamped ``t_a``, ``t_b`` (the matches' intervals; the delay they were planned with is
    added back). The delay of the highest correlation, refined by a parabola through its
    neighbours, is the estimate. A turn's scale error does not move it (a correlation ignores
    scale); a delay shows because the wheels' turn of an interval is then partly that of its
    neighbours.

    Parameters
    ----------
    matches : ScanIntervals
        Matched intervals of one bag (:func:`match_intervals`).
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry [m].
    search_s : float
        The largest delay searched, either way [s], around the delay the matches were planned
        with.
    step_s : float
        The grid step [s].

    Returns
    -------
    ScanDelay

    Raises
    ------
    InputError
        A search range or step that is not positive, or fewer than 10 matched pairs that turn.
    """
    if not (isinstance(search_s, (int, float)) and search_s > 0 and isinstance(step_s, (int, float)) and step_s > 0):
        raise InputError(f"`search_s` and `step_s` must be positive, got {search_s!r} and {step_s!r}")
    plan = matches.plan
    bag = plan.bag
    ok = matches.matched
    turn = matches.poses[ok, 2]
    if ok.sum() < 10 or not np.any(turn):
        raise InputError(f"only {int(ok.sum())} matched scan pairs that turn: too few to estimate a delay", bag.source)
    if bag.wheel_kind == "odom":
        assert bag.odom_pose is not None
        heading = np.unwrap(np.asarray(bag.odom_pose, dtype=float)[:, 2])
    else:
        assert bag.left_rad is not None and bag.right_rad is not None
        left, right = recording_wheel_angles(bag, WheelGeometry(wheel_diameter_m, wheel_diameter_m, wheelbase_m))
        heading = 0.5 * wheel_diameter_m * (right - left) / wheelbase_m
    st = np.asarray(bag.scan_t_s, dtype=float)
    return delay_from_turns(
        np.asarray(bag.wheel_t_s, dtype=float),
        heading,
        st[plan.pairs[ok, 0]],
        st[plan.pairs[ok, 1]],
        turn,
        plan.scan_delay_s,
        search_s=search_s,
        step_s=step_s,
        source=bag.source,
    )


def delay_from_turns(
    wt: FloatArray,
    heading: FloatArray,
    ta: FloatArray,
    tb: FloatArray,
    turn: FloatArray,
    around_s: float,
    *,
    search_s: float = SCAN_DELAY_SEARCH_S,
    step_s: float = 0.005,
    source: str | None = None,
) -> ScanDelay:
    """The delay of the scans' stamps that best lines the wheels' turns up with the matched ones
    (the method of :func:`estimate_scan_delay`).

    Parameters
    ----------
    wt, heading : numpy.ndarray
        ``(W,)`` the wheel data's stamps and the heading they make [rad].
    ta, tb : numpy.ndarray
        ``(K,)`` the stamps of each matched pair's scans [s].
    turn : numpy.ndarray
        ``(K,)`` the matched turns [rad].
    around_s : float
        The centre of the delays searched [s].
    search_s, step_s : float
        The largest delay searched either way from ``around_s``, and the grid step [s].
    source : str, optional
        For messages.

    Returns
    -------
    ScanDelay

    Raises
    ------
    InputError
        The wheels do not turn between the matched scans.
    """
    n = int(math.floor(search_s / step_s + 1e-9))
    grid = around_s + np.arange(-n, n + 1) * step_s

    def corr(d: float) -> float:
        o = np.interp(tb - d, wt, heading) - np.interp(ta - d, wt, heading)
        if not np.any(o):
            return math.nan
        return float(np.corrcoef(o, turn)[0, 1])

    c = np.array([corr(float(d)) for d in grid])
    if not np.any(np.isfinite(c)):
        raise InputError("the wheels do not turn between the matched scans: no delay to estimate", source)
    k = int(np.nanargmax(c))
    best = float(grid[k])
    if 0 < k < len(grid) - 1 and np.all(np.isfinite(c[k - 1 : k + 2])):
        den = c[k - 1] - 2 * c[k] + c[k + 1]
        if den < 0:
            best += float(0.5 * (c[k - 1] - c[k + 1]) / den * step_s)
    return ScanDelay(best + 0.0, corr(best), corr(0.0), len(turn), float(search_s))


def parse_scan_delay(value: float | str | None) -> float | str:
    """``auto`` or a delay in seconds, from what a user gives (``None``: auto; ``off``: 0).

    Parameters
    ----------
    value : float, str or None
        ``auto``, ``off``/``none`` (the stamps as recorded), or seconds.

    Returns
    -------
    float or str
        ``"auto"`` or the delay [s].

    Raises
    ------
    InputError
        Anything else, or a delay beyond :data:`MAX_SCAN_DELAY_S`.
    """
    if value is None:
        return "auto"
    if isinstance(value, str):
        v = value.strip().lower()
        if v == "auto":
            return "auto"
        if v in ("off", "none"):
            return 0.0
        try:
            value = strict_float(v)
        except ValueError:
            raise InputError(f"`scan_delay` must be auto, off or seconds, got {value!r}") from None
    if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value)):
        raise InputError(f"`scan_delay` must be auto, off or seconds, got {value!r}")
    if abs(value) > MAX_SCAN_DELAY_S:
        raise InputError(
            f"`scan_delay` {value:g} s is beyond +-{MAX_SCAN_DELAY_S:g} s: a scan is stamped within a sweep of "
            "when it was taken (is it in milliseconds?)"
        )
    return float(value)


def check_bag_motion(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike,
    *,
    delay_s: float = 0.0,
    max_wheel_gap_s: float = 0.5,
) -> None:
    """The nominal odometry of a differential drive's recording at its scans against the lidar's
    own motion (:func:`umbmark.realrobot.motion_check.check_wheels_against_scans`; encoder
    counts read as a running counter are also tried as counts per message; wheel joints, in the
    other order: :func:`umbmark.realrobot.motion_check.check_readings`).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry [m].
    sensor_pose : array_like
        ``(x_m, y_m, yaw_rad)``: the lidar's nominal mounting pose.
    delay_s : float
        How late the scans are stamped [s].
    max_wheel_gap_s : float
        Scans in longer gaps of the wheel data are left out [s].

    Raises
    ------
    InputError
        As :func:`~umbmark.realrobot.motion_check.check_wheels_against_scans`.
    """
    d_nom, b_nom = positive("`wheel_diameter_m`", wheel_diameter_m), positive("`wheelbase_m`", wheelbase_m)
    left, right = recording_wheel_angles(bag, WheelGeometry(d_nom, d_nom, b_nom))
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float) - delay_s
    period = float(np.median(np.diff(wt))) if len(wt) > 1 else 0.0
    usable = usable_scans(st, wt, period, max_wheel_gap_s, bag.source, [])
    r = 0.5 * d_nom

    def odometry(left: FloatArray, right: FloatArray) -> FloatArray:
        return integrate_wheels(r * np.diff(np.interp(st, wt, left)), r * np.diff(np.interp(st, wt, right)), b_nom)

    other = {}
    if bag.wheel_kind == "ticks" and "(cumulative" in bag.wheel_description:
        other['counts per message (`ticks="incremental"`)'] = odometry(np.cumsum(left), np.cumsum(right))
    seen = lidar_motion(bag, usable, sensor_pose)
    given = odometry(left, right)
    if bag.wheel_kind == "joints" and len(bag.joint_names) == 2:
        kind, wheels = kind_named(DEFAULT_KIND), (left, right)
        readings = [
            (kind.reading_cause(r, bag.joint_names), odometry(wheels[r.order[0]], wheels[r.order[1]]))
            for r in kind.readings()
        ]
        check_readings(seen, given, readings, bag.source)
    check_wheels_against_scans(bag, st, usable, given, sensor_pose, alternatives=other, motion=seen)


def bag_intervals(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    options: IntervalOptions | None = None,
    *,
    progress: StepProgress | None = None,
) -> ScanIntervals:
    """The intervals of a bag, matched: steps 1-4 of the module docstring.

    1. Every pair of consecutive scans is planned (:func:`plan_intervals`, the stamps as
       recorded, or the delay given) and matched (:func:`match_intervals`).
    2. With ``options.scan_delay`` ``"auto"`` the scans' delay is estimated from those matches
       (:func:`estimate_scan_delay`).
    3. The keyframes are chosen on the matches composed (:func:`matched_motion`), not on the
       wheel data, whose errors would choose them; each interval's wheel rotations are read at
       the delayed stamps, and its two keyframes matched starting from the composed matches.
       Every scan a keyframe, the pairs are matched again from the delayed odometry when the
       delay moved it (the matcher stops within a small fraction of a standard deviation of
       the optimum on the side it started from, so a start off by the delay would pull every
       match a little the same way).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    options : IntervalOptions, optional
        The keyframes, sensor pose, base frame, wheel gap, matcher, fewest intervals and the
        scans' delay (default :class:`IntervalOptions`: the delay estimated).
    progress : callable, optional
        As :func:`match_intervals`.

    Returns
    -------
    ScanIntervals
        With the delay applied and, when estimated, :attr:`ScanIntervals.scan_delay`.

    Raises
    ------
    InputError
        As the two steps and :func:`estimate_scan_delay`.
    """
    opts = _options(options)
    want, rule, icp, min_intervals = opts.scan_delay, opts.keyframes, opts.icp, opts.min_intervals
    first = 0.0 if want == "auto" else float(want)
    pose = nominal_sensor_pose_of(bag, opts.sensor_pose, opts.base_frame)[0]
    check_bag_motion(
        bag,
        wheel_diameter_m,
        wheelbase_m,
        (pose[0], pose[1], pose[5]),
        delay_s=first,
        max_wheel_gap_s=opts.max_wheel_gap_s,
    )
    # every pair of consecutive scans matched: the scans' delay and the motion the keyframes are chosen on
    every = replace(opts, keyframes=KeyframeRule())
    plan = plan_intervals(bag, wheel_diameter_m, wheelbase_m, every, scan_delay_s=first)
    n0 = len(plan)
    pass1 = None if progress is None else (lambda done, total: progress(done, 2 * n0))  # noqa: E731
    si = match_intervals(plan, icp=icp, min_intervals=1 if not rule.every_scan else min_intervals, progress=pass1)
    est: ScanDelay | None = None
    delay = first
    if want == "auto":
        try:
            est = estimate_scan_delay(si, wheel_diameter_m, wheelbase_m)
            delay = est.delay_s
        except InputError as err:
            note = f"the scans' delay is not estimated ({err.message}): stamps as recorded"
            si = replace(si, plan=replace(si.plan, warnings=si.plan.warnings + (note,)))
    motion, links, link_cov = (None, None, None) if rule.every_scan else matched_motion(si)
    if rule.every_scan and delay == first:
        if len(si.intervals) < min_intervals:
            match_intervals(si.plan, icp=icp, min_intervals=min_intervals)  # raises, naming the failures
        return replace(si, scan_delay=est, scan_delay_requested="auto" if want == "auto" else f"{first:g}")
    plan2 = plan_intervals(
        bag,
        wheel_diameter_m,
        wheelbase_m,
        opts,
        scan_delay_s=delay,
        motion=motion,
        motion_links=links,
        motion_covariance=link_cov,
    )
    if est is None and want == "auto":
        plan2 = replace(plan2, warnings=si.plan.warnings)
    n1 = len(plan2)
    pass2 = None if progress is None else (lambda done, total: progress(n0 + round(done * n0 / max(n1, 1)), 2 * n0))  # noqa: E731
    out = match_intervals(plan2, icp=icp, min_intervals=min_intervals, progress=pass2)
    return replace(out, scan_delay=est, scan_delay_requested="auto" if want == "auto" else f"{first:g}")


def matched_motion(matches: ScanIntervals) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """The sensor's poses at every scan from matches of consecutive scans, composed.

    A pair that did not match moves by the nominal odometry's displacement seen from the sensor
    (the matcher's start); a pair the plan left out (no wheel motion, or no wheel data) by
    nothing. Keyframes never span a scan without wheel data, so the poses between two
    keyframes are always those of the matches between them.

    Parameters
    ----------
    matches : ScanIntervals
        Matches of consecutive scans (every scan a keyframe).

    Returns
    -------
    poses : numpy.ndarray
        ``(M, 3)`` poses in the frame of the first scan (heading accumulated).
    links : numpy.ndarray
        ``(M - 1,)`` booleans: the step from each scan to the next is a match, or the wheels
        did not move.
    covariance : numpy.ndarray
        ``(M - 1, 3, 3)`` each step's covariance (the match's; zero without one).
    """
    plan = matches.plan
    st = np.asarray(plan.bag.scan_t_s, dtype=float) - plan.scan_delay_s
    return composed_matches(
        st,
        np.asarray(plan.bag.wheel_t_s, dtype=float),
        plan.pairs,
        matches.matched,
        matches.poses,
        plan.initial,
        matches.covariances,
    )


def composed_matches(
    st: FloatArray,
    wt: FloatArray,
    pairs: NDArray[np.int64],
    matched: NDArray[np.bool_],
    poses: FloatArray,
    initial: FloatArray,
    covariances: FloatArray,
) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """:func:`matched_motion` of matches of consecutive scans: ``st`` the scans' stamps (delay
    applied), ``wt`` the wheel data's, ``pairs`` ``(K, 2)`` consecutive scan indices, then per
    pair whether it matched, the match, the matcher's start and the match's covariance."""
    n = len(st) - 1
    step = np.zeros((n, 3))
    step[pairs[:, 0]] = np.where(matched[:, None], poses, initial)
    links = np.ones(n, dtype=bool)
    links[pairs[:, 0]] = matched
    cov = np.zeros((n, 3, 3))
    cov[pairs[matched, 0]] = covariances[matched]
    links &= (st[1:] >= wt[0]) & (st[:-1] <= wt[-1])  # the wheels' data cover the step
    th = np.concatenate([[0.0], np.cumsum(step[:, 2])])
    c, s = np.cos(th[:-1]), np.sin(th[:-1])
    x = np.concatenate([[0.0], np.cumsum(c * step[:, 0] - s * step[:, 1])])
    y = np.concatenate([[0.0], np.cumsum(s * step[:, 0] + c * step[:, 1])])
    return np.column_stack([x, y, th]), links, cov


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
    sizes : tuple of int
        The number of intervals of each input, in the pooled order (default: one input).
    """

    result: SelfcalResult
    parts: tuple[ScanIntervals | str, ...]
    intervals: Intervals
    sizes: tuple[int, ...] = ()

    @cached_property
    def figures(self) -> dict[str, Any]:
        """The data of the report's figures: the residuals over time and a map per bag
        (:func:`umbmark.realrobot.selfcal_map.selfcal_figures`)."""
        from umbmark.realrobot.selfcal_map import selfcal_figures

        sizes = self.sizes or (len(self.intervals.dt_s),)
        return selfcal_figures(self.parts, sizes, self.intervals, self.result)

    @cached_property
    def odometry_noise(self) -> OdometryNoise | None:
        """Each wheel's travel variance per metre, fitted to the residuals of the intervals kept
        (:func:`umbmark.correct.noise.estimate_odometry_noise`); None where the drive is too
        short for it."""
        from umbmark.correct.noise import estimate_odometry_noise

        r = self.result
        keep = np.ones(len(self.intervals.dt_s), dtype=bool)
        keep[list(r.intervals_rejected)] = False
        iv = self.intervals
        try:
            return estimate_odometry_noise(
                iv.left_rad[keep],
                iv.right_rad[keep],
                iv.sensor[keep],
                r.r_left_m,
                r.r_right_m,
                r.wheelbase_m,
                r.sensor_pose,
            )
        except InputError:
            return None

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
            ``pairs_chained``, ``pairs_failed``, ``intervals_still``, ``time_span_s`` (null without bags),
            ``keyframe_rule``, ``scan_delay`` (per bag :meth:`ScanIntervals.delay_dict`: the
            delay of its scans' stamps, ``applied_s``; null without bags) and ``inputs`` (one
            object per input: a bag's
            :meth:`ScanIntervals.to_dict`, or ``path`` and ``kind`` ``intervals``) and ``figures``
            (:attr:`figures`: what ``umbmark report`` draws) and ``odometry_noise``
            (:attr:`odometry_noise` as :meth:`OdometryNoise.to_dict`, or null).
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
                "pairs_chained": total("pairs_chained"),
                "pairs_failed": total("pairs_failed"),
                "intervals_still": sum(b.plan.intervals_still for b in bags) if bags else None,
                "time_span_s": sum(b.plan.time_span_s for b in bags) if bags else None,
                "keyframe_rule": bags[0].plan.keyframe_rule.to_dict() if bags else None,
                "scan_delay": [b.delay_dict() for b in bags] if bags else None,
                "inputs": [
                    p.to_dict() if isinstance(p, ScanIntervals) else {"path": p, "kind": "intervals"}
                    for p in self.parts
                ],
                "figures": self.figures,
                "odometry_noise": None if self.odometry_noise is None else self.odometry_noise.to_dict(),
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
            The content hash of an input file or folder (:func:`umbmark.history.file_sha256`);
            several inputs are hashed together (:func:`umbmark._files.inputs_sha256`); None: no hash.

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
    given as its JSON (:meth:`SelfcalReport.to_dict`, the output of ``umbmark selfcal --json``), of
    any kind of robot: a differential drive's ``parameters`` are ``c_left``, ``c_right``,
    ``wheelbase_mm``, ``Ed``, ``Eb``; another kind's (its JSON's ``kinematics``) are ``kinematics``
    and its geometry under its JSON keys (a tricycle's ``wheel_diameter_mm``, ``wheelbase_mm``,
    ``steering_offset_deg``, ``steering_scale``), and ``parameters_in_use`` its nominal geometry;
    both with ``sensor_pose``.

    Parameters
    ----------
    d : dict
        The self-calibration's JSON.
    kind : str
        The record's kind.
    file_hash : callable, optional
        The content hash of an input file or folder; several inputs are hashed together
        (:func:`umbmark._files.inputs_sha256`); None: no hash.

    Returns
    -------
    dict
        As :meth:`SelfcalReport.history_fields`.

    Raises
    ------
    InputError
        If ``d`` is not a self-calibration's JSON.
    """
    own = kind_in(d)
    if own is not None:
        parameters, in_use = _kind_parameters(d, own)
    else:
        missing = [k for k in ("c_left", "c_right", "wheelbase_mm", "Ed", "Eb", "sensor_pose") if k not in d]
        if missing or not isinstance(d.get("sensor_pose"), dict):
            raise InputError(
                "not the JSON of a self-calibration (missing " + ", ".join(missing or ["sensor_pose"]) + ")"
            )
        parameters = {k: d[k] for k in ("c_left", "c_right", "wheelbase_mm", "Ed", "Eb")}
        in_use = {
            "wheel_diameter_mm": d.get("nominal_wheel_diameter_mm"),
            "wheelbase_mm": d.get("nominal_wheelbase_mm"),
            "sensor_pose": d.get("nominal_sensor_pose"),
        }
    paths = [i["path"] for i in d.get("inputs", []) if isinstance(i, dict) and "path" in i]
    sp = d["sensor_pose"]
    parameters["sensor_pose"] = {k: sp.get(k) for k in ("x_mm", "y_mm", "yaw_deg")}
    first = Path(paths[0]) if paths else None
    return {
        "kind": kind,
        "method": "selfcal",
        "results": d,
        "parameters": parameters,
        "parameters_in_use": in_use,
        "source": None if first is None else str(first.resolve() if first.exists() else first),
        "input_sha256": (
            inputs_sha256(paths, file_hash) if paths and file_hash and all(Path(p).exists() for p in paths) else None
        ),
        "inputs": {"paths": paths},
    }


def _kind_parameters(d: dict[str, Any], own: Kind) -> tuple[dict[str, Any], dict[str, Any]]:
    """The recommended parameters and those in use of the self-calibration of a robot of a kind of
    its own: ``kinematics`` and its geometry under the kind's JSON keys (the calibrated geometry,
    and the nominal one with the first bag's nominal sensor pose).

    Raises
    ------
    InputError
        No sensor pose, or a geometry that is not the kind's.
    """
    if not isinstance(d.get("sensor_pose"), dict):
        raise InputError(f"not the JSON of a {own.noun}'s self-calibration (missing sensor_pose)")
    own.geometry_from_json(d, "the self-calibration")
    got = d.get("nominal")
    nominal: dict[str, Any] = got if isinstance(got, dict) else {}
    inputs = [i for i in d.get("inputs") or [] if isinstance(i, dict)]
    keys = dict.fromkeys(p.key[0] for p in own.parameters)
    parameters: dict[str, Any] = {"kinematics": own.name}
    for k in keys:  # each estimate and its 95 % interval (null: not estimated)
        parameters.update({k: d[k], f"{k}_ci95": d.get(f"{k}_ci95")})
    in_use = {
        "kinematics": own.name,
        **{k: nominal.get(k) for k in keys},
        "sensor_pose": inputs[0].get("nominal_sensor_pose") if inputs else None,
    }
    return parameters, in_use


# an estimated sensor yaw beyond this, with no transform to compare it with, is named (a sensor
# mounted sideways, or displacements with their axes exchanged)
SIDEWAYS_RAD = math.radians(45.0)


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
    with_tf = any(isinstance(p, ScanIntervals) and p.plan.sensor_pose_source.startswith("/tf_static") for p in parts)
    yaw = result.sensor_pose[2]
    if not with_tf and abs(math.remainder(yaw, 2 * math.pi)) > SIDEWAYS_RAD:
        files = any(isinstance(p, str) for p in parts)
        cause = (
            "the intervals' sensor displacements with `dx` and `dy` exchanged or one of them negated (dx is along "
            "the sensor's forward axis, dy to its left)"
            if files
            else "scans in a frame turned against the sensor's"
        )
        out.append(
            f"the sensor's yaw comes out {math.degrees(yaw):.1f} deg against the robot's forward axis: a sensor "
            f"mounted that far turned, or {cause}; check before using the calibration"
        )
    return out


# another reading of an intervals file whose fit costs less than this share of the file's as
# read names the file's columns as misread
MISREAD_COST = 0.3


def _alternative_readings(iv: Intervals) -> dict[str, Intervals]:
    """The intervals as other column mistakes would have them: dx and dy exchanged, the turns
    in degrees."""
    out = {}
    swapped = iv.sensor[:, [1, 0, 2]]
    out["`sensor_dx_m` and `sensor_dy_m` look swapped (dx is along the sensor's forward axis, dy to its left)"] = (
        swapped
    )
    if np.max(np.abs(iv.sensor[:, 2])) > 0.5 * math.pi:
        degrees = iv.sensor.copy()
        degrees[:, 2] = np.radians(degrees[:, 2])
        out["`sensor_dyaw_rad` looks like degrees"] = degrees
    return {k: replace(iv, sensor=v, covariance=None) for k, v in out.items()}


MISREAD_SIZE = (0.2, 5.0)
"""A fitted wheel diameter or wheelbase beyond these times the nominal is refused: a nominal size
is within a factor of two of the true one, so the columns or their units are wrong."""


def _refuse_unit_ratios(d_ratio: float, b_ratio: float, source: str | None) -> None:
    """Refuse fitted sizes at a unit's factor from the nominal ones (degrees, millimetres) or
    beyond :data:`MISREAD_SIZE`."""
    deg = math.degrees(1.0)

    def near(x: float, k: float) -> bool:
        return abs(x / k - 1.0) < 0.35

    sizes = f"the wheel diameters come out {d_ratio:.3g} x the nominal and the wheelbase {b_ratio:.3g} x"
    if near(d_ratio, 1 / deg):
        cause = "`left_rad` and `right_rad` look like degrees (57.3 times radians)"
    elif near(d_ratio, 1e3) and near(b_ratio, 1e3):
        cause = "`sensor_dx_m` and `sensor_dy_m` look like millimetres"
    elif near(b_ratio, 1 / deg) and 0.5 <= d_ratio <= 2.0:
        cause = "`sensor_dyaw_rad` looks like degrees (57.3 times radians)"
    elif not (MISREAD_SIZE[0] <= d_ratio <= MISREAD_SIZE[1] and MISREAD_SIZE[0] <= b_ratio <= MISREAD_SIZE[1]):
        cause = (
            "no robot is that far from its nominal sizes: the columns are not what their names say, or in other "
            "units (dt_s, left_rad, right_rad, sensor_dx_m, sensor_dy_m, sensor_dyaw_rad: seconds, radians, metres), "
            "or the nominal `wheel_diameter_mm` and `wheelbase_mm` are"
        )
    else:
        return
    raise InputError(f"{sizes}: {cause}", source)


def _refuse_misread_intervals(
    iv: Intervals, res: SelfcalResult, wheel_diameter_m: float, wheelbase_m: float, options: dict[str, Any]
) -> None:
    """Refuse intervals files whose columns the fit shows misread: the wheels' turns against the
    sensor's (a mirror: a negative wheelbase with positive radii), wheel angles in degrees (the
    diameters 1/57.3 of nominal), or another reading (:func:`_alternative_readings`) that fits at
    a fraction of the cost."""
    rl, rr, b = res.r_left_m, res.r_right_m, res.wheelbase_m
    if rl > 0 and rr > 0 and b < 0:
        raise InputError(
            f"the intervals fit only with the wheels exchanged (positive radii need a negative wheelbase, "
            f"{1e3 * b:.1f} mm): the sensor turns against the wheels; `left_rad` and `right_rad` are swapped, or "
            "the sensor's turns counted clockwise (`sensor_dyaw_rad` negated; a sensor upside down mirrors "
            "`sensor_dy_m` too), or both wheels counted backwards",
            iv.source,
        )
    lo, hi = MISREAD_SIZE
    if rl * rr < 0 and all(lo <= 2 * abs(r) / wheel_diameter_m <= hi for r in (rl, rr)):
        which = "left" if rl < 0 else "right"
        raise InputError(
            f"the wheel radii come out with opposite signs ({1e3 * rl:.1f} mm, {1e3 * rr:.1f} mm): the {which} "
            f"wheel's angle is counted backwards: negate `{which}_rad`",
            iv.source,
        )
    ratio = (abs(rl) + abs(rr)) / wheel_diameter_m
    b_ratio = abs(b) / wheelbase_m
    _refuse_unit_ratios(ratio, b_ratio, iv.source)
    yaw = abs(math.remainder(res.sensor_pose[2], 2 * math.pi))
    odd = yaw > SIDEWAYS_RAD or len(res.intervals_rejected) > 0.1 * len(iv.dt_s)
    if not (odd or not 0.5 <= ratio <= 2.0 or not 0.5 <= b_ratio <= 2.0) or not math.isfinite(res.cost):
        return
    for reading, other in _alternative_readings(iv).items():
        try:
            alt = selfcal(other, wheel_diameter_m, wheelbase_m, **options)
        except InputError:
            continue
        if alt.cost < MISREAD_COST * res.cost and len(alt.intervals_rejected) <= len(res.intervals_rejected):
            raise InputError(
                f"{reading}: read so the intervals fit at {alt.cost / res.cost:.2g} of the cost "
                f"({len(alt.intervals_rejected)} outliers instead of {len(res.intervals_rejected)}, the sensor's "
                f"yaw {math.degrees(alt.sensor_pose[2]):.1f} deg instead of {math.degrees(res.sensor_pose[2]):.1f})",
                iv.source,
            )


def interval_blocks(parts: Sequence[Any]) -> NDArray[np.intp]:
    """Block labels of the pooled intervals of several inputs, for the covariance of shared errors.

    Each input's intervals are cut into equal stretches of time (a bag's by its scans' stamps,
    an intervals file's by its summed durations) of about ``max(BLOCK_S, T / MAX_BLOCKS)``,
    ``T`` the inputs' total time; no block spans two inputs.

    Parameters
    ----------
    parts : sequence
        Per input: a :class:`ScanIntervals` (or any bag's matched intervals with their
        ``start_s``) or the :class:`Intervals` of a file.

    Returns
    -------
    numpy.ndarray
        One label per pooled interval, in the order of the inputs.
    """
    times = []
    for p in parts:
        if hasattr(p, "start_s"):  # a bag's matched intervals (of any kind of robot)
            t = np.asarray(p.start_s, dtype=float)
            t = t - t[0] if t.size else t
        else:
            dt = np.asarray(p.dt_s, dtype=float)
            t = np.cumsum(dt) - dt
        times.append(np.asarray(t, dtype=float))
    total = sum(float(t[-1] - t[0]) for t in times if t.size)
    span = max(BLOCK_S, total / MAX_BLOCKS)
    labels, base = [], 0
    for t in times:
        length = float(t[-1]) if t.size else 0.0
        n = max(1, int(round(length / span)))
        lab = np.minimum(np.floor(t / length * n), n - 1).astype(np.intp) if length > 0 else np.zeros(t.size, np.intp)
        labels.append(base + lab)
        base += n
    return np.concatenate(labels) if labels else np.zeros(0, dtype=np.intp)


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
        ``loss``, ``sensor_covariance`` ...); the blocks of time of the covariance are the
        inputs' (:func:`interval_blocks`).

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
                iv.steps,
                iv.covariance,
                iv.end_rates,
            )
        ivs.append(iv)
        kept.append(p if isinstance(p, ScanIntervals) else str(p[0]))
    if several:
        frames = {p.plan.bag.scan_frame for p in kept if isinstance(p, ScanIntervals)}
        extra = () if len(frames) <= 1 else (f"the bags' scans are in different frames ({', '.join(sorted(frames))})",)
        steps = None
        if any(iv.steps is not None for iv in ivs):
            steps = IntervalSteps.concatenate(
                [
                    iv.steps if iv.steps is not None else IntervalSteps.one_each(iv.left_rad, iv.right_rad, iv.dt_s)
                    for iv in ivs
                ]
            )
        pooled = Intervals(
            np.concatenate([iv.dt_s for iv in ivs]),
            np.concatenate([iv.left_rad for iv in ivs]),
            np.concatenate([iv.right_rad for iv in ivs]),
            np.concatenate([iv.sensor for iv in ivs]),
            " + ".join(str(iv.source) for iv in ivs),
            tuple(w for iv in ivs for w in iv.warnings) + extra,
            steps,
            None
            if any(iv.covariance is None for iv in ivs)
            else np.concatenate([np.asarray(iv.covariance) for iv in ivs]),
            None
            if any(iv.end_rates is None for iv in ivs)
            else np.concatenate([np.asarray(iv.end_rates) for iv in ivs]),
        )
    else:
        pooled = ivs[0]
    blocks = interval_blocks([p if isinstance(p, ScanIntervals) else p[1] for p in parts])
    res = selfcal(pooled, wheel_diameter_m, wheelbase_m, blocks=blocks, **options)
    if all(isinstance(p, str) for p in kept):
        _refuse_misread_intervals(pooled, res, wheel_diameter_m, wheelbase_m, dict(options, blocks=blocks))
    extra_w = _pose_warnings(kept, res)
    if extra_w:
        res = replace(res, warnings=list(res.warnings) + extra_w)
    return SelfcalReport(res, tuple(kept), pooled, tuple(len(iv.dt_s) for iv in ivs))


StageProgress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: a stage of a pipeline (``reading NAME``, ``matching scans of
NAME``, ``self-calibrating``) moved to ``done`` of ``total`` steps (``total`` 0: a stage without
steps has started)."""


def _stage(progress: StageProgress | None, stage: str) -> StepProgress | None:
    return None if progress is None else (lambda done, total: progress(stage, done, total))


def selfcal_from_bags(
    paths: str | Path | Sequence[str | Path],
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    wheels: WheelSource,
    scan_topic: str = "/scan",
    scan_frame: str | None = None,
    options: IntervalOptions | None = None,
    selfcal_options: dict[str, Any] | None = None,
    progress: StageProgress | None = None,
) -> SelfcalReport:
    """Self-calibrate from one or several bags (their intervals pooled): for each bag, read it
    (:func:`umbmark.io.rosbag.read_selfcal_bag`) and make its intervals (:func:`bag_intervals`),
    then estimate from all of them (:func:`selfcal_report`).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The bags.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    wheels : WheelSource
        The bags' wheel data (:mod:`umbmark.io.wheels`).
    scan_topic, scan_frame
        As :func:`umbmark.io.rosbag.read_selfcal_bag`.
    options : IntervalOptions, optional
        How each bag becomes intervals (:func:`bag_intervals`; the delay estimated per bag by
        default).
    selfcal_options : dict, optional
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.
    progress : callable, optional
        Told each stage's progress (:data:`StageProgress`).

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        One recording given twice; as the reader and the steps.
    """
    from umbmark.io.rosbag import read_selfcal_bag

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    check_distinct_inputs([p for p in items if Path(p).exists()])
    parts = []
    for p in items:
        name = Path(p).name
        bag = read_selfcal_bag(
            p, wheels=wheels, scan_topic=scan_topic, scan_frame=scan_frame, progress=_stage(progress, f"reading {name}")
        )
        progress_of = _stage(progress, f"matching scans of {name}")
        parts.append(bag_intervals(bag, wheel_diameter_m, wheelbase_m, options, progress=progress_of))
    if progress is not None:
        progress("self-calibrating", 0, 0)
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
