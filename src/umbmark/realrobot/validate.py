"""Check a calibration on a real log: the odometry before and after it, against a reference.

A robot with a SLAM run and no motion capture checks a calibration here: the JSON that
``umbmark selfcal``, ``umbmark replay`` or ``umbmark export`` (format json) save
(:func:`read_calibration`), evaluated on a log (a bag with laser scans and the robot's wheel
data, read as the self-calibration reads it: :func:`umbmark.io.rosbag.read_selfcal_bag`)
against a reference: the relations of the SLAM benchmark (:mod:`umbmark.io.relations`,
Kümmerle et al., "On measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4),
2009), or a planar trajectory (:mod:`umbmark.io.tum`) from which relations are made
(:func:`relations_from_trajectory`). :func:`validate` computes, :func:`validate_log` reads the
files first; :class:`Validation` is the result (SI inside; ``to_dict()`` in mm, deg and the
benchmark's m^2, deg^2).

The procedure:

1. **Odometry at the scans.** With ``nav_msgs/Odometry`` wheel data, the recorded poses are
   interpolated linearly (heading unwrapped) at ``scan stamp - scan delay``
   (:func:`recorded_odometry_at_scans`) and each increment between consecutive scans is turned
   into wheel travel through the NOMINAL geometry, as an exact arc
   (:func:`umbmark.model.dataset.wheel_angles_from_poses`: the arc length from the chord and
   the heading change; left and right travel ``ds -/+ dth b / 2``, over the nominal radius).
   With joint states or encoder counts the wheel angles are interpolated at
   ``scan stamp - scan delay`` directly. The wheel angles are integrated again as exact arcs
   (:func:`odometry_from_wheels`): *before* with the nominal geometry, *after* with the
   calibration's diameters and wheelbase. The delay is the calibration's (a
   self-calibration's ``scan_delay[0].applied_s``, else 0) unless given; both use it.
2. **Relations.** Each relation's two stamps are matched to scans (the nearest, within
   ``tolerance_s``); relations with a stamp that matches no scan, or whose scans have no wheel
   data, are counted, not used. Inside a tested span (both stamps in it) the odometry's
   relative pose ``q`` between the two scans, seen from the lidar, ``l^-1 (+) q (+) l``
   (:func:`in_sensor_frame`: *before* with the nominal sensor pose, *after* with the
   calibration's), is compared with the relation (:func:`relation_errors`). Short: spanning
   less than ``short_max_s``; long: the rest.
3. **Figures** (:class:`OdometryFigures`): the translation MSE [m^2] and rotation MSE [deg^2]
   over the short relations, the same over the long ones, with the mean absolute errors
   (:class:`ErrorStats`); the **distance scale** ``sum |t_odo| |t_rel| / sum |t_rel|^2`` over
   the short relations longer than :data:`MIN_DISTANCE_M`; the **turn scale**, the same with
   the turns, over the short relations turning more than :data:`MIN_TURN_RAD`
   (:func:`magnitude_scale`; a relation's turn is counted in whole turns as the odometry's is:
   the one nearest to it); the heading drift per metre as :class:`SystematicErrors` fits it.
4. **Rules** (:func:`judge`, :class:`Rule`): the short translation and rotation MSE after at
   most :data:`SHORT_MSE_TOLERANCE` (2 %) above before; the long translation MSE after not
   above before; each scale after within :data:`SCALE_TOLERANCE` (1.5 %) of 1, or no farther
   from 1 than before. A rule without relations does not apply. A span passes when no rule
   fails and at least one applies (:attr:`SpanCheck.verdict`).

The spans: the whole log, a window (seconds from the log's first scan), or the two halves of
either (split at the middle time; a relation with a stamp in each half is in neither).

The parts live in modules of their own, every public name importable from here too:

* :mod:`umbmark.realrobot.validate_calibration`: the calibration read (:func:`read_calibration`);
* :mod:`umbmark.realrobot.validate_reference`: the reference's relations, matched to scans
  (:func:`relations_from_trajectory`);
* :mod:`umbmark.realrobot.validate_odometry`: the odometry at the scans, before and after;
* :mod:`umbmark.realrobot.validate_figures`: the metric, the figures and the rules (:func:`judge`);
* :mod:`umbmark.realrobot.validate_mistakes`: the refusals of mistaken references.

This module checks the options, the window and the scan delay, runs the check (:func:`validate`,
:class:`Validation`) and reads its files (:func:`validate_log`). The metric and the odometry
helpers (:func:`relation_errors`, :class:`ErrorStats`, :class:`SystematicErrors`,
:func:`in_sensor_frame`, :func:`odometry_from_wheels`, :func:`recorded_odometry_at_scans`) are
also those of :mod:`umbmark.studies.slam2d`.

Imports numpy, :mod:`umbmark.io` (the bag, relations and trajectory readers, the wheel source),
:mod:`umbmark.model.kinematics`, :mod:`umbmark.realrobot.kinematic` (a robot of another kind's
log, when called) and those parts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError
from umbmark.io.relations import Relations, read_relations
from umbmark.io.rosbag import SelfcalBag
from umbmark.io.tum import Trajectory, read_tum
from umbmark.io.wheels import WheelSource
from umbmark.model.kinematics import Kinematics
from umbmark.model.se2 import Pose
from umbmark.realrobot.validate_calibration import CheckedCalibration, calibration_kind, read_calibration
from umbmark.realrobot.validate_figures import (
    MIN_DISTANCE_M,
    MIN_TURN_RAD,
    SCALE_TOLERANCE,
    SHORT_MSE_TOLERANCE,
    ErrorStats,
    OdometryFigures,
    Rule,
    SpanCheck,
    SystematicErrors,
    in_sensor_frame,
    judge,
    magnitude_scale,
    relation_errors,
)
from umbmark.realrobot.validate_mistakes import MISTAKE_FLOOR_M2 as MISTAKE_FLOOR_M2
from umbmark.realrobot.validate_mistakes import MISTAKE_RATIO as MISTAKE_RATIO
from umbmark.realrobot.validate_mistakes import TRUE_BASE_RATIO as TRUE_BASE_RATIO
from umbmark.realrobot.validate_mistakes import _alternatives, _plausibility, _read_base, _refuse_mistakes
from umbmark.realrobot.validate_odometry import (
    _Odometries,
    _odometries,
    _sensor_poses,
    odometry_from_wheels,
    recorded_odometry_at_scans,
    wheel_angles_at_scans,
)
from umbmark.realrobot.validate_reference import (
    REFERENCE_FRAMES,
    SHORT_MAX_S,
    STAMP_TOLERANCE_S,
    TRAJECTORY_MAX_GAP_S,
    ReferenceSummary,
    _match_relations,
    _reference_relations,
    _reference_summary,
    relations_from_trajectory,
)

__all__ = [
    "SHORT_MAX_S",
    "STAMP_TOLERANCE_S",
    "MIN_DISTANCE_M",
    "MIN_TURN_RAD",
    "SHORT_MSE_TOLERANCE",
    "SCALE_TOLERANCE",
    "TRAJECTORY_MAX_GAP_S",
    "REFERENCE_FRAMES",
    "relation_errors",
    "in_sensor_frame",
    "odometry_from_wheels",
    "recorded_odometry_at_scans",
    "wheel_angles_at_scans",
    "magnitude_scale",
    "ErrorStats",
    "SystematicErrors",
    "CheckedCalibration",
    "read_calibration",
    "calibration_kind",
    "relations_from_trajectory",
    "OdometryFigures",
    "Rule",
    "judge",
    "SpanCheck",
    "ReferenceSummary",
    "Validation",
    "validate",
    "validate_log",
]

_MAX_DELAY_S = 1.0  # a scan delay beyond this is more likely milliseconds given as seconds

FloatArray = NDArray[np.float64]
StageNotice = Callable[[str], None]
"""``say(stage)``: a stage of a check starts."""


def _pose_dict(p: Pose, source: str) -> dict[str, Any]:
    return {"x_mm": p[0] * 1e3, "y_mm": p[1] * 1e3, "yaw_deg": math.degrees(p[2]), "source": source}


@dataclass(frozen=True, eq=False)
class Validation:
    """A calibration checked on a log (:func:`validate`).

    Parameters
    ----------
    log : str
        The bag.
    wheel_data : str
        Where the wheel data came from, in words.
    scans : int
        Scans in the log.
    log_duration_s : float
        From its first scan to its last [s].
    window_s : tuple of float or None
        The window checked, from the log's first scan [s] (None: the whole log).
    reference : ReferenceSummary
        The reference and its relations.
    calibration : CheckedCalibration
        The calibration.
    nominal_sensor_pose, sensor_pose : tuple of float
        ``(x_m, y_m, yaw_rad)`` of the lidar before and after the calibration.
    nominal_sensor_pose_source, sensor_pose_source : str
        Where they came from.
    scan_delay_s : float
        The scans' delay applied to both odometries [s].
    scan_delay_source : str
        ``given``, ``calibration`` or ``none``.
    short_max_s : float
        Relations spanning less than this are short [s].
    spans : tuple of SpanCheck
        The spans checked.
    relations_crossing : int
        With halves: relations with a stamp in each half (in neither).
    warnings : list of str
        What the check noticed.
    """

    log: str
    wheel_data: str
    scans: int
    log_duration_s: float
    window_s: tuple[float, float] | None
    reference: ReferenceSummary
    calibration: CheckedCalibration
    nominal_sensor_pose: Pose
    nominal_sensor_pose_source: str
    sensor_pose: Pose
    sensor_pose_source: str
    scan_delay_s: float
    scan_delay_source: str
    short_max_s: float
    spans: tuple[SpanCheck, ...]
    relations_crossing: int = 0
    warnings: list[str] = field(default_factory=list)

    @property
    def verdict(self) -> str:
        """``fail`` when a span fails, else ``pass`` when one passes, else ``undetermined``."""
        states = [s.verdict for s in self.spans]
        if "fail" in states:
            return "fail"
        return "pass" if "pass" in states else "undetermined"

    def to_dict(self) -> dict[str, Any]:
        """As JSON (mm, deg, and the benchmark's m^2, deg^2).

        Returns
        -------
        dict
            ``log``, ``wheel_data``, ``scans``, ``log_duration_s``, ``window_s`` (null: the
            whole log), ``reference`` (:meth:`ReferenceSummary.to_dict`), ``calibration``
            (:meth:`CheckedCalibration.to_dict` with ``nominal_sensor_pose`` and
            ``sensor_pose``: ``x_mm``, ``y_mm``, ``yaw_deg``, ``source``), ``scan_delay_s``,
            ``scan_delay_source``, ``short_max_s``, ``spans`` (:meth:`SpanCheck.to_dict`),
            ``relations_crossing``, ``verdict``, ``warnings``.
        """
        cal = self.calibration.to_dict()
        cal["nominal_sensor_pose"] = _pose_dict(self.nominal_sensor_pose, self.nominal_sensor_pose_source)
        cal["sensor_pose"] = _pose_dict(self.sensor_pose, self.sensor_pose_source)
        return {
            "log": self.log,
            "wheel_data": self.wheel_data,
            "scans": self.scans,
            "log_duration_s": self.log_duration_s,
            "window_s": None if self.window_s is None else list(self.window_s),
            "reference": self.reference.to_dict(),
            "calibration": cal,
            "scan_delay_s": self.scan_delay_s,
            "scan_delay_source": self.scan_delay_source,
            "short_max_s": self.short_max_s,
            "spans": [s.to_dict() for s in self.spans],
            "relations_crossing": self.relations_crossing,
            "verdict": self.verdict,
            "warnings": list(self.warnings),
        }


# -- the check ------------------------------------------------------------------------------------


def _window(st: FloatArray, window_s: tuple[float, float] | None, src: str) -> tuple[float, float, list[str]]:
    """The window [s from the first scan], clipped to the log, and a warning when it was."""
    end = float(st[-1] - st[0])
    if window_s is None:
        return 0.0, end, []
    try:
        lo, hi = (float(v) for v in window_s)
    except (TypeError, ValueError):
        raise InputError(f"`window_s` must be two numbers (start, end) [s], got {window_s!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InputError(f"`window_s` must be (start, end) with end after start, got {lo:g} to {hi:g} s")
    if hi < 0 or lo > end:
        hint = " (seconds from the log's first scan, not time stamps)" if abs(lo) > 1e6 else ""
        raise InputError(
            f"the window {lo:.10g} to {hi:.10g} s lies outside the log: its scans span 0 to {end:.3f} s from "
            f"the first{hint}",
            src,
        )
    warnings = []
    if lo < 0 or hi > end:
        warnings.append(
            f"the window {lo:g} to {hi:g} s reaches beyond the log (0 to {end:.3f} s from the first scan): "
            f"checked from {max(lo, 0.0):g} to {min(hi, end):.3f} s"
        )
    return max(lo, 0.0), min(hi, end), warnings


def _check_tolerance(st: FloatArray, tol: float) -> None:
    """Refuse a stamp tolerance beyond half the scans' period: a stamp would match a scan it is not at."""
    period = float(np.median(np.diff(st))) if len(st) > 1 else math.inf
    if tol > 0.5 * period:
        raise InputError(
            f"`tolerance_s` is {tol:g} s, more than half the scans' period ({period:.3g} s): a relation's stamp would "
            "match a scan it is not at; it is in seconds (1 ms is 0.001)"
        )


def _check_number(name: str, v: Any, positive: bool = True) -> float:
    ok = isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) and math.isfinite(v)
    if not ok or (positive and not v > 0):
        raise InputError(f"`{name}` must be a {'positive' if positive else 'finite'} number of seconds, got {v!r}")
    return float(v)


def _scans_in_window(
    st: FloatArray, window_s: tuple[float, float] | None, src: str
) -> tuple[float, float, NDArray[np.bool_], list[str]]:
    """The window [s from the first scan], the scans inside it (at least two), and the window's warnings."""
    origin = float(st[0])
    lo, hi, warnings = _window(st, window_s, src)
    in_win = (st - origin >= lo - 1e-9) & (st - origin <= hi + 1e-9)
    if in_win.sum() < 2:
        raise InputError(f"the window {lo:g} to {hi:g} s holds {int(in_win.sum())} scans: too few to check", src)
    return lo, hi, in_win, warnings


def _scan_delay(
    calibration: CheckedCalibration, scan_delay_s: float | None, log_s: float = math.inf
) -> tuple[float, str, list[str]]:
    """The scans' delay (given, else the calibration's), where it came from, and a warning for an
    unlikely one; one longer than the log (``log_s``) is refused."""
    if scan_delay_s is not None:
        delay, delay_src = _check_number("scan_delay_s", scan_delay_s, positive=False), "given"
    else:
        delay, delay_src = calibration.scan_delay_s, calibration.scan_delay_source
    if abs(delay) > log_s:
        where = "`scan_delay_s`" if delay_src == "given" else f"the calibration's scan delay ({calibration.source})"
        raise InputError(
            f"{where}: a scan delay of {delay:g} s is longer than the log ({log_s:.1f} s of scans): no scan would "
            "have wheel data; the delay is in seconds (50 ms is 0.05)"
        )
    warnings: list[str] = []
    if abs(delay) > _MAX_DELAY_S:
        warnings.append(
            f"a scan delay of {delay:g} s: the scans and the wheel data are usually within 0.3 s (seconds are "
            "expected: 50 ms is 0.05)"
        )
    return delay, delay_src, warnings


def _check_spans(
    odo: _Odometries,
    inside: NDArray[np.bool_],
    t: FloatArray,
    in_win: NDArray[np.bool_],
    window: tuple[float, float],
    halves: bool,
    whole_label: str,
) -> tuple[tuple[SpanCheck, ...], int, list[str]]:
    """The spans (the whole log or window, or its halves) checked, the relations crossing the halves, warnings."""
    lo, hi = window
    if halves:
        mid = 0.5 * (lo + hi)
        parts = [("first half", lo, mid, in_win & (t < mid)), ("second half", mid, hi, in_win & (t >= mid))]
    else:
        parts = [(whole_label, lo, hi, in_win)]
    spans = []
    warnings: list[str] = []
    crossing = 0
    in_some = np.zeros(len(inside), dtype=bool)
    for label, a, b, scans in parts:
        sel = inside & scans[odo.k1] & scans[odo.k2]
        in_some |= sel
        before, after = odo.figures(sel)
        spans.append(SpanCheck(label, float(a), float(b), int(scans.sum()), before, after, judge(before, after)))
        if before.short.count == 0:
            warnings.append(f"no short relations inside the {label}: its short-relation rules do not apply")
    if halves:
        crossing = int((inside & ~in_some).sum())
        if crossing:
            warnings.append(f"{crossing} relations have a stamp in each half: in neither half's figures")
    return tuple(spans), crossing, warnings


def _float_pose(p: Pose) -> Pose:
    """A pose as three Python floats."""
    return (float(p[0]), float(p[1]), float(p[2]))


def validate(
    bag: SelfcalBag,
    calibration: CheckedCalibration,
    reference: Relations | Trajectory,
    *,
    reference_frame: str = "base",
    window_s: tuple[float, float] | None = None,
    halves: bool = False,
    short_max_s: float = SHORT_MAX_S,
    scan_delay_s: float | None = None,
    base_frame: str | None = None,
    tolerance_s: float = STAMP_TOLERANCE_S,
) -> Validation:
    """Check a calibration on a log against a reference (the module docstring's procedure).

    Parameters
    ----------
    bag : SelfcalBag
        The log (:func:`umbmark.io.rosbag.read_selfcal_bag`).
    calibration : CheckedCalibration
        The calibration (:func:`read_calibration`).
    reference : Relations or Trajectory
        Relations between scans (the lidar's relative poses), or a trajectory to make them from
        (:func:`relations_from_trajectory`).
    reference_frame : str
        A trajectory's frame: ``base`` (the robot's, as a SLAM publishes it: turned into the
        lidar's with the nominal sensor pose, the one the SLAM ran with) or ``sensor`` (the
        lidar's).
    window_s : (float, float), optional
        Check only from ``window_s[0]`` to ``window_s[1]`` seconds after the log's first scan.
    halves : bool
        Check the two halves (of the window) apart.
    short_max_s : float
        Relations spanning less than this are short [s].
    scan_delay_s : float, optional
        How late the scans are stamped [s], instead of the calibration's.
    base_frame : str, optional
        The robot frame of ``/tf_static`` (default the odometry's child frame, then
        ``base_link``, ``base_footprint``).
    tolerance_s : float
        How far a relation's stamp may be from its scan's [s].

    Returns
    -------
    Validation

    Raises
    ------
    InputError
        A bad option; a window outside the log; relations of which none has scans at its stamps
        (not of this log); no relation with wheel data inside the window; a reference whose
        angles look like degrees or translations like millimetres.
    """
    src = bag.source
    short_max = _check_number("short_max_s", short_max_s)
    tol = _check_number("tolerance_s", tolerance_s)
    if reference_frame not in REFERENCE_FRAMES:
        raise InputError(f"`reference_frame` must be one of {', '.join(REFERENCE_FRAMES)}, got {reference_frame!r}")
    if not isinstance(reference, (Relations, Trajectory)):
        raise InputError(f"`reference` must be Relations or a Trajectory, got {type(reference).__name__}")
    warnings: list[str] = list(bag.warnings) + list(calibration.warnings)
    st = np.asarray(bag.scan_t_s, dtype=float)
    origin = float(st[0])
    _check_tolerance(st, tol)
    lo, hi, in_win, w = _scans_in_window(st, window_s, src)
    warnings += w
    delay, delay_src, w = _scan_delay(calibration, scan_delay_s, float(st[-1] - st[0]))
    warnings += w
    poses, w = _sensor_poses(bag, calibration, base_frame)
    warnings += w
    # the relations
    rel, mode, with_pose, kind, w = _reference_relations(
        reference, st[in_win], reference_frame, poses.nominal, short_max, tol, hi - lo
    )
    warnings += w
    matched, w = _match_relations(rel, st, np.asarray(bag.wheel_t_s, dtype=float), in_win, delay, tol, (lo, hi), src)
    warnings += w
    # the odometries (step 1)
    odo = _odometries(bag, calibration, delay, poses, matched, rel, short_max)
    k1, k2, inside = matched.k1, matched.k2, matched.inside
    sel = inside & odo.short
    what = "relations" if kind == "relations" else "relations made from the trajectory"
    alternatives = _alternatives(reference, rel, st[in_win], reference_frame, poses.nominal, short_max, tol)
    _refuse_mistakes(odo, sel, alternatives, what, rel.source)  # a likely mistake in the reference, named
    base_read = None
    if kind == "trajectory" and reference_frame == "base":
        odo, base_read, w = _read_base(odo, sel)
        warnings += w
    warnings += _plausibility(
        odo.before, k1[sel], k2[sel], rel.pose[sel], poses.nominal, odo.figures(inside)[0], what, rel.source
    )
    # the spans
    whole = "whole log" if window_s is None else "window"
    spans, crossing, w = _check_spans(odo, inside, st - origin, in_win, (lo, hi), halves, whole)
    warnings += w
    summary = replace(
        _reference_summary(kind, reference, rel, matched, reference_frame, with_pose, mode), base_trajectory=base_read
    )
    return Validation(
        log=src,
        wheel_data=bag.wheel_description,
        scans=int(len(st)),
        log_duration_s=float(st[-1] - origin),
        window_s=None if window_s is None else (float(lo), float(hi)),
        reference=summary,
        calibration=calibration,
        nominal_sensor_pose=_float_pose(poses.nominal),
        nominal_sensor_pose_source=poses.nominal_source,
        sensor_pose=_float_pose(poses.after),
        sensor_pose_source=poses.after_source,
        scan_delay_s=float(delay),
        scan_delay_source=delay_src,
        short_max_s=short_max,
        spans=spans,
        relations_crossing=crossing,
        warnings=warnings,
    )


def _kind_log(
    bag_path: str | Path,
    cal: CheckedCalibration,
    nominal: Kinematics,
    joints: Sequence[str] | None,
    joint_topic: str,
    odom_topic: str | None,
    scan_topic: str,
) -> SelfcalBag:
    """The log of a robot of a kind of its own: its joints, or (a kind that reads one) its odometry
    turned into its joints with the nominal geometry."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.realrobot.kinematic import joint_source, odometry_joints

    own = cal.robot_kind
    if odom_topic is not None:
        if joints:
            raise InputError("give the joints or an odometry (`odom_topic`), not both")
        if not own.reads_odometry:
            raise InputError(own.odometry_refusal(), cal.source)
        bag = read_selfcal_bag(
            bag_path, wheels=WheelSource.odometry(odom_topic), scan_topic=scan_topic, two_wheels=False
        )
        return odometry_joints(bag, nominal)
    if not joints:
        wanted = " and ".join(f"`{j.option}` ({', '.join(j.roles)})" for j in own.joints)
        raise InputError(f"a {own.noun}'s calibration: give its joints, {wanted}", cal.source)
    return read_selfcal_bag(
        bag_path, wheels=joint_source(nominal, joints, joint_topic), scan_topic=scan_topic, two_wheels=False
    )


def validate_log(
    bag_path: str | Path,
    calibration_path: str | Path,
    *,
    relations_path: str | Path | None = None,
    reference_path: str | Path | None = None,
    reference_frame: str = "base",
    dataset: str | None = None,
    wheel_diameter_m: float | None = None,
    wheelbase_m: float | None = None,
    window_s: tuple[float, float] | None = None,
    halves: bool = False,
    short_max_s: float = SHORT_MAX_S,
    scan_delay_s: float | None = None,
    base_frame: str | None = None,
    tolerance_s: float = STAMP_TOLERANCE_S,
    progress: StageNotice | None = None,
    wheels: WheelSource | None = None,
    scan_topic: str = "/scan",
    joints: Sequence[str] | None = None,
    joint_topic: str = "/joint_states",
    odom_topic: str | None = None,
) -> Validation:
    """Read a log, a calibration and a reference, and :func:`validate`.

    Parameters
    ----------
    bag_path : str or Path
        The log: a ROS 1 or ROS 2 bag with laser scans and wheel data.
    calibration_path : str or Path
        The calibration's JSON (:func:`read_calibration`).
    relations_path, reference_path : str or Path, optional
        The reference, one of: a relations file (:mod:`umbmark.io.relations`), or a TUM
        trajectory (:mod:`umbmark.io.tum`) of the frame ``reference_frame``.
    reference_frame : str
        The trajectory's frame (``base`` or ``sensor``; see :func:`validate`).
    dataset, wheel_diameter_m, wheelbase_m
        As :func:`read_calibration`.
    window_s, halves, short_max_s, scan_delay_s, base_frame, tolerance_s
        As :func:`validate`.
    progress : callable, optional
        Called with the name of each stage as it starts.
    wheels : WheelSource, optional
        The log's wheel data (:mod:`umbmark.io.wheels`) of a differential drive's calibration.
    scan_topic : str
        The ``sensor_msgs/LaserScan`` topic.
    joints : sequence of str, optional
        The joint names of a calibration of another kind of robot, in its roles' order (a
        tricycle's drive and steering joints; a mecanum robot's front left, front right, rear
        left and rear right wheels: :attr:`umbmark.kinds.Kind.joints`).
    joint_topic : str
        Their ``sensor_msgs/JointState`` topic.
    odom_topic : str, optional
        In place of the joints of a kind that reads the robot's own odometry
        (:attr:`umbmark.kinds.Kind.reads_odometry`: a car's ``nav_msgs/Odometry``), turned into its
        joints with the calibration's nominal geometry.

    Returns
    -------
    Validation

    Raises
    ------
    InputError
        Not exactly one reference; no wheel data of the calibration's kind of robot (``wheels``
        for a differential drive's, ``joints`` for another kind's); what the readers and
        :func:`validate` refuse.
    """
    say = progress or (lambda stage: None)
    if (relations_path is None) == (reference_path is None):
        raise InputError("give one reference: relations (`relations_path`) or a trajectory (`reference_path`)")
    say("read calibration")
    cal = read_calibration(
        calibration_path, dataset=dataset, wheel_diameter_m=wheel_diameter_m, wheelbase_m=wheelbase_m
    )
    say("read reference")
    ref: Relations | Trajectory
    if relations_path is not None:
        ref = read_relations(relations_path)
    else:
        assert reference_path is not None  # exactly one reference, checked above
        ref = read_tum(reference_path)
    say("read log")
    from umbmark.io.rosbag import read_selfcal_bag

    both = cal.kinematics
    if both is not None:
        bag = _kind_log(bag_path, cal, both[0], joints, joint_topic, odom_topic, scan_topic)
    elif wheels is None:
        raise InputError("a differential drive's calibration: give the log's wheel data (`wheels`)", cal.source)
    else:
        bag = read_selfcal_bag(bag_path, wheels=wheels, scan_topic=scan_topic)
    say("validate")
    return validate(
        bag,
        cal,
        ref,
        reference_frame=reference_frame,
        window_s=window_s,
        halves=halves,
        short_max_s=short_max_s,
        scan_delay_s=scan_delay_s,
        base_frame=base_frame,
        tolerance_s=tolerance_s,
    )
