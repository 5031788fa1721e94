"""Keyframes and the planning of a recording's intervals (steps 1-2 of
:mod:`umbmark.realrobot.selfcal`): when a scan becomes the next keyframe (:class:`KeyframeRule`,
:data:`DEFAULT_KEYFRAMES`), how a recording becomes intervals (:class:`IntervalOptions`), the
scans with wheel data (:func:`usable_scans`) and the intervals to match, before matching
(:func:`plan_intervals`, :class:`IntervalPlan`).

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports these
names). Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io.rosbag` (the bag's type),
:class:`~umbmark.realrobot.scanmatch.ICPConfig`, the recording's wheel angles
(:mod:`umbmark.realrobot.wheels`), the sensor pose (:mod:`umbmark.realrobot.selfcal_tf`) and the
delay's parsing (:mod:`umbmark.realrobot.selfcal_delay`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag
from umbmark.model import se2
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry
from umbmark.model.intervals import IntervalSteps
from umbmark.realrobot.scanmatch import ICPConfig
from umbmark.realrobot.selfcal_delay import parse_scan_delay
from umbmark.realrobot.selfcal_tf import nominal_sensor_pose_of
from umbmark.realrobot.wheels import recording_wheel_angles

__all__ = [
    "STILL_M",
    "DEFAULT_KEYFRAMES_M",
    "DEFAULT_KEYFRAMES_RAD",
    "DEFAULT_KEYFRAMES_MIN_S",
    "DEFAULT_KEYFRAMES_S",
    "StepProgress",
    "KeyframeRule",
    "DEFAULT_KEYFRAMES",
    "IntervalOptions",
    "IntervalPlan",
    "usable_scans",
    "plan_intervals",
]

STILL_M = 1e-4
"""An interval in which neither wheel rolled more than this (nominal radius) [m] is still."""

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
