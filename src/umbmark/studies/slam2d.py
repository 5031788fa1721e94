"""The lidar self-calibration on real logs, checked against the SLAM benchmark's ground truth.

A log (a ROS bag with laser scans and the robot's ``nav_msgs/Odometry``) and its relations file
(:mod:`umbmark.io.relations`: ground-truth relative poses of the laser between pairs of scans,
Kümmerle et al., "On measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009)
are split in two halves by time. The self-calibration (:mod:`umbmark.realrobot.selfcal`) runs on
each half and on the whole log; the odometry is then compared with the relations that lie inside
the **other** half:

* ``recorded``: the robot's own odometry as recorded (poses interpolated to the scan stamps);
* ``nominal``: the odometry recomputed from the wheel travel with the nominal geometry. The wheel
  travel comes from the odometry's increments through the nominal geometry
  (:func:`umbmark.realrobot.wheels.scan_wheel_angles`, interpolated to the scans as the pipeline
  does), so this reproduces the recorded odometry wherever its increments are
  arcs; it is the "before" of the comparison;
* ``calibrated``: the odometry recomputed from the same wheel travel with the estimated wheel
  radii and wheelbase (the "after").

A relation compares **laser** poses, so an odometry's relative pose ``q`` (robot frame) is seen
from the laser at a mounting pose ``l``: ``l^-1 (+) q (+) l``. Each odometry is evaluated with
``l`` from ``/tf_static`` and with the estimated ``l`` of the calibration (the calibrated
geometry goes with the estimated ``l``: they were estimated together).

The odometry is read at the scans' stamps, as recorded; or, when the scans are stamped late
against the odometry's clock (a laser scan is stamped when it arrives, after the sweep and the
transfer), at ``stamp - scan_delay_s``: given, or estimated on each calibration part from the
correlation of the scan-matched turns with the odometry's
(:func:`umbmark.realrobot.selfcal.estimate_scan_delay`).

The error of one relation is ``e = r^-1 (+) p`` (``r`` the relation, ``p`` the prediction);
the metric (Kümmerle et al.) is the mean of ``|e_xy|^2`` and of ``e_yaw^2`` (translation and
rotation apart), with the mean absolute errors, over all relations and split by the time a
relation spans: **short** ones (a few scans apart) measure the odometry's error over a short
drive, where a systematic error shows as a distance, turn or drift bias; **long** ones (spanning
loops) are dominated by the integration of every error over minutes. The short relations also
give the odometry's systematic errors directly (:class:`SystematicErrors`: distance scale, turn
scale, heading drift per metre, fitted against the relations).

:func:`study_log` runs it; :class:`Slam2dStudy` is its result (SI inside; ``to_dict()`` in mm,
deg). :func:`relation_errors` is the metric. :class:`ScanMatchCheck` measures the scan matcher
itself against the short relations. The metric, its statistics and the odometry helpers
(:func:`relation_errors`, :class:`ErrorStats`, :class:`SystematicErrors`, :func:`in_sensor_frame`,
:func:`odometry_from_wheels`, :func:`recorded_odometry_at_scans`, :data:`SHORT_MAX_S`) live in
:mod:`umbmark.realrobot.validate` and are imported here under the same names.

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io` (the bag and relations readers),
:mod:`umbmark.realrobot.selfcal` (the pipeline), :mod:`umbmark.realrobot.validate` (the metric)
and :mod:`umbmark.realrobot.scanmatch`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError
from umbmark.io.relations import Relations, read_relations
from umbmark.io.rosbag import SelfcalBag, read_selfcal_bag
from umbmark.io.wheels import WheelSource
from umbmark.model import se2
from umbmark.model.geometry import WheelGeometry
from umbmark.model.se2 import Pose
from umbmark.realrobot.scanmatch import ICPConfig, match_scan_pairs
from umbmark.realrobot.selfcal import (
    DEFAULT_KEYFRAMES,
    IntervalOptions,
    KeyframeRule,
    ScanDelay,
    SelfcalReport,
    bag_intervals,
    selfcal_report,
    sensor_pose_from_tf,
)
from umbmark.realrobot.validate import (
    SHORT_MAX_S,
    ErrorStats,
    StageNotice,
    SystematicErrors,
    in_sensor_frame,
    odometry_from_wheels,
    recorded_odometry_at_scans,
    relation_errors,
)
from umbmark.realrobot.wheels import scan_wheel_angles

__all__ = [
    "SHORT_MAX_S",
    "relation_errors",
    "odometry_from_wheels",
    "recorded_odometry_at_scans",
    "in_sensor_frame",
    "ErrorStats",
    "SystematicErrors",
    "ScanMatchCheck",
    "PartCalibration",
    "RelationEvaluation",
    "HalfTest",
    "Slam2dStudy",
    "study_log",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ScanMatchCheck:
    """The scan matcher measured against the short relations: the matches are what the calibration fits.

    The two scans of each short relation are matched (:func:`umbmark.realrobot.scanmatch.match_scan_pairs`,
    starting from the nominal odometry seen from the ``/tf_static`` laser pose, as the pipeline
    starts) and the converged matches compared with the relations, next to the nominal odometry
    on the same relations.

    Parameters
    ----------
    relations : int
        Short relations tried.
    converged : int
        Matches that converged.
    matcher, odometry : ErrorStats
        Errors of the converged matches and of the nominal odometry on the same relations.
    matcher_systematic, odometry_systematic : SystematicErrors
        Their systematic errors on those relations.
    """

    relations: int
    converged: int
    matcher: ErrorStats
    odometry: ErrorStats
    matcher_systematic: SystematicErrors
    odometry_systematic: SystematicErrors

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``relations``, ``converged``, ``matcher``, ``odometry`` (:meth:`ErrorStats.to_dict`),
            ``matcher_systematic``, ``odometry_systematic``.
        """
        return {
            "relations": self.relations,
            "converged": self.converged,
            "matcher": self.matcher.to_dict(),
            "odometry": self.odometry.to_dict(),
            "matcher_systematic": self.matcher_systematic.to_dict(),
            "odometry_systematic": self.odometry_systematic.to_dict(),
        }


@dataclass(frozen=True, eq=False)
class PartCalibration:
    """One self-calibration of the study: on a half of the log, or on all of it.

    Parameters
    ----------
    label : str
        ``first half``, ``second half`` or ``full log``.
    t_start_s, t_end_s : float
        The first and last scan used, from the log's first scan [s].
    scans : int
        Scans in that span.
    report : SelfcalReport
        The pipeline's result.
    elapsed_s : float
        Wall time of the pipeline (intervals, scan matching, estimate) [s].
    scan_delay : ScanDelay or None
        The scans' delay estimated on this part
        (:func:`umbmark.realrobot.selfcal.estimate_scan_delay`), or None.
    scan_delay_s : float
        The delay applied to this part's odometry before calibrating [s].
    """

    label: str
    t_start_s: float
    t_end_s: float
    scans: int
    report: SelfcalReport
    elapsed_s: float
    scan_delay: ScanDelay | None = None
    scan_delay_s: float = 0.0

    @property
    def geometry(self) -> tuple[float, float, float]:
        """``(r_left_m, r_right_m, wheelbase_m)`` estimated."""
        r = self.report.result
        return (r.r_left_m, r.r_right_m, r.wheelbase_m)

    @property
    def sensor_pose(self) -> Pose:
        """``(x_m, y_m, yaw_rad)`` estimated."""
        x, y, yaw = self.report.result.sensor_pose
        return (float(x), float(y), float(yaw))

    def turn_regression(self) -> tuple[float, float, float]:
        """How the sensor's turn follows the wheels' turn over the intervals the estimate used.

        With the nominal geometry, each interval's wheel rotations turn the robot by
        ``o = r_nom (phi_R - phi_L) / b_nom``; the scan matching measured the sensor's turn
        ``s``. If the wheel data were exact and all the noise in ``s`` (the estimator's
        model), the least-squares slope ``sum s o / sum o^2`` would be the true turn per
        nominal turn; if instead ``s`` were exact and the wheel data noisy, the inverse of the
        other regression, ``sum s^2 / sum s o``, would be. Far apart, they say the wheel data
        carry noise comparable to the turns of one interval, and the estimated ``E_b`` is biased
        upwards by that regression dilution.

        Returns
        -------
        tuple of float
            ``(sensor_on_wheels, inverse_wheels_on_sensor, correlation)``.
        """
        iv = self.report.intervals
        keep = np.ones(len(iv), dtype=bool)
        keep[list(self.report.result.intervals_rejected)] = False
        res = self.report.result
        o = 0.5 * res.nominal_wheel_diameter_m * (iv.right_rad - iv.left_rad)[keep] / res.nominal_wheelbase_m
        s = np.asarray(iv.sensor, dtype=float)[keep, 2]
        so, oo, ss = float(s @ o), float(o @ o), float(s @ s)
        if not (oo > 0 and ss > 0 and so != 0):
            return (math.nan, math.nan, math.nan)
        return (so / oo, ss / so, so / math.sqrt(oo * ss))

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``label``, ``t_start_s``, ``t_end_s``, ``scans``, ``elapsed_s``,
            ``scan_delay_s``, ``scan_delay`` (:meth:`ScanDelay.to_dict` or null),
            ``turn_regression`` {``sensor_on_wheels``, ``inverse_wheels_on_sensor``,
            ``correlation``} (:meth:`turn_regression`) and the report's JSON
            (:meth:`SelfcalReport.to_dict`) without ``covariance`` and ``inputs``, with
            ``intervals_rejected`` as a count.
        """
        k1, k2, rho = self.turn_regression()
        d = self.report.to_dict()
        d.pop("covariance", None)
        d.pop("inputs", None)
        d["intervals_rejected"] = len(d.get("intervals_rejected", []))
        return {
            "label": self.label,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "scans": self.scans,
            "elapsed_s": self.elapsed_s,
            "scan_delay_s": self.scan_delay_s,
            "scan_delay": None if self.scan_delay is None else self.scan_delay.to_dict(),
            "turn_regression": {"sensor_on_wheels": k1, "inverse_wheels_on_sensor": k2, "correlation": rho},
            **d,
        }


@dataclass(frozen=True)
class RelationEvaluation:
    """One odometry compared with a set of relations.

    Parameters
    ----------
    odometry : str
        ``recorded``, ``nominal`` or ``calibrated``.
    calibration : str or None
        The label of the :class:`PartCalibration` whose geometry (``calibrated``) or sensor pose
        was used.
    sensor_pose : tuple of float
        ``(x_m, y_m, yaw_rad)``: the laser pose the relative poses were seen from.
    sensor_pose_source : str
        ``/tf_static`` or ``estimated``.
    all, short, long : ErrorStats
        The metric over all relations, the short ones and the long ones.
    systematic : SystematicErrors
        Fitted on the short relations.
    """

    odometry: str
    calibration: str | None
    sensor_pose: Pose
    sensor_pose_source: str
    all: ErrorStats
    short: ErrorStats
    long: ErrorStats
    systematic: SystematicErrors

    @property
    def key(self) -> str:
        """A short name: e.g. ``calibrated(first half)@estimated``."""
        cal = f"({self.calibration})" if self.odometry == "calibrated" else ""
        return f"{self.odometry}{cal}@{self.sensor_pose_source}"

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``key``, ``odometry``, ``calibration``, ``sensor_pose`` {``x_mm``, ``y_mm``,
            ``yaw_deg``, ``source``}, ``all``, ``short``, ``long`` (:meth:`ErrorStats.to_dict`)
            and ``systematic``.
        """
        x, y, yaw = self.sensor_pose
        return {
            "key": self.key,
            "odometry": self.odometry,
            "calibration": self.calibration,
            "sensor_pose": {
                "x_mm": x * 1e3,
                "y_mm": y * 1e3,
                "yaw_deg": math.degrees(yaw),
                "source": self.sensor_pose_source,
            },
            "all": self.all.to_dict(),
            "short": self.short.to_dict(),
            "long": self.long.to_dict(),
            "systematic": self.systematic.to_dict(),
        }


@dataclass(frozen=True)
class HalfTest:
    """The odometries compared with the relations inside one part of the log.

    Parameters
    ----------
    label : str
        The part tested (``first half``, ``second half``, ``full log``).
    calibrated_on : str or None
        The calibration tested out of sample on it (the other half), None for the full log.
    t_start_s, t_end_s : float
        The part's span, from the log's first scan [s].
    relations_short, relations_long : int
        Relations with both stamps inside it.
    evaluations : tuple of RelationEvaluation
        The odometries compared.
    scan_delay_s : float
        The scans' delay applied to every odometry of the test (that of the calibration tested
        out of sample) [s].
    """

    label: str
    calibrated_on: str | None
    t_start_s: float
    t_end_s: float
    relations_short: int
    relations_long: int
    evaluations: tuple[RelationEvaluation, ...]
    scan_delay_s: float = 0.0

    def get(self, key: str) -> RelationEvaluation:
        """The evaluation of a :attr:`RelationEvaluation.key`.

        Parameters
        ----------
        key : str
            E.g. ``nominal@/tf_static``.

        Returns
        -------
        RelationEvaluation

        Raises
        ------
        KeyError
            No such evaluation.
        """
        for e in self.evaluations:
            if e.key == key:
                return e
        raise KeyError(f"{key!r}: not among {[e.key for e in self.evaluations]}")

    @property
    def before(self) -> RelationEvaluation:
        """The nominal odometry seen from the ``/tf_static`` laser pose."""
        return self.get("nominal@/tf_static")

    @property
    def after(self) -> RelationEvaluation:
        """The odometry calibrated on :attr:`calibrated_on` (the full log when None), seen from the estimated pose."""
        return self.get(f"calibrated({self.calibrated_on or 'full log'})@estimated")

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            The fields, ``before`` and ``after`` (keys of evaluations) and ``evaluations``.
        """
        return {
            "label": self.label,
            "calibrated_on": self.calibrated_on,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "relations_short": self.relations_short,
            "relations_long": self.relations_long,
            "scan_delay_s": self.scan_delay_s,
            "before": self.before.key,
            "after": self.after.key,
            "evaluations": [e.to_dict() for e in self.evaluations],
        }


@dataclass(frozen=True, eq=False)
class Slam2dStudy:
    """The study of one log (:func:`study_log`).

    Parameters
    ----------
    name : str
        The log's name (the bag's stem).
    bag, relations : str
        The files.
    nominal_wheel_diameter_m, nominal_wheelbase_m : float
        The nominal geometry assumed [m].
    scans : int
        Scans in the window studied.
    t_start_s, t_end_s, split_s : float
        The window and the split between the halves, from the log's first scan [s].
    short_max_s : float
        Relations spanning less than this are short [s].
    scan_delay_mode : str
        ``recorded`` (the stamps as recorded), ``given`` or ``estimated`` (per calibration part,
        :func:`umbmark.realrobot.selfcal.estimate_scan_delay`).
    tf_sensor_pose : tuple of float
        The laser pose of ``/tf_static`` ``(x_m, y_m, yaw_rad)``.
    calibrations : tuple of PartCalibration
        ``first half``, ``second half``, ``full log``.
    tests : tuple of HalfTest
        ``second half`` (calibrated on the first), ``first half`` (calibrated on the second),
        ``full log`` (calibrated on itself).
    relations_crossing : int
        Relations of the window with one stamp in each half (in neither half's test).
    scan_matching : ScanMatchCheck
        The scan matcher against the short relations of the window.
    timings_s : dict
        Wall times [s]: ``read_bag``, ``read_relations``, ``calibrate_<label>`` for each
        calibration, ``evaluate``, ``scan_matching_check``, ``total``.
    warnings : list of str
        What the study noticed.
    """

    name: str
    bag: str
    relations: str
    nominal_wheel_diameter_m: float
    nominal_wheelbase_m: float
    scans: int
    t_start_s: float
    t_end_s: float
    split_s: float
    short_max_s: float
    scan_delay_mode: str
    tf_sensor_pose: Pose
    calibrations: tuple[PartCalibration, ...]
    tests: tuple[HalfTest, ...]
    relations_crossing: int
    scan_matching: ScanMatchCheck
    timings_s: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def calibration(self, label: str) -> PartCalibration:
        """The calibration of a label (``first half``, ``second half``, ``full log``).

        Parameters
        ----------
        label : str

        Returns
        -------
        PartCalibration

        Raises
        ------
        KeyError
            No such calibration.
        """
        for c in self.calibrations:
            if c.label == label:
                return c
        raise KeyError(label)

    def test(self, label: str) -> HalfTest:
        """The test of a part (``first half``, ``second half``, ``full log``).

        Parameters
        ----------
        label : str

        Returns
        -------
        HalfTest

        Raises
        ------
        KeyError
            No such test.
        """
        for t in self.tests:
            if t.label == label:
                return t
        raise KeyError(label)

    def to_dict(self) -> dict[str, Any]:
        """As JSON (mm, deg, and the benchmark's m, m^2, deg, deg^2).

        Returns
        -------
        dict
            ``name``, ``bag``, ``relations``, ``nominal`` {``wheel_diameter_mm``,
            ``wheelbase_mm``}, ``scans``, ``t_start_s``, ``t_end_s``, ``split_s``,
            ``short_max_s``, ``scan_delay_mode``, ``tf_sensor_pose``, ``calibrations``, ``tests``,
            ``relations_crossing``, ``scan_matching``, ``timings_s``, ``warnings``.
        """
        x, y, yaw = self.tf_sensor_pose
        return {
            "name": self.name,
            "bag": self.bag,
            "relations": self.relations,
            "nominal": {
                "wheel_diameter_mm": self.nominal_wheel_diameter_m * 1e3,
                "wheelbase_mm": self.nominal_wheelbase_m * 1e3,
            },
            "scans": self.scans,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "split_s": self.split_s,
            "short_max_s": self.short_max_s,
            "scan_delay_mode": self.scan_delay_mode,
            "tf_sensor_pose": {"x_mm": x * 1e3, "y_mm": y * 1e3, "yaw_deg": math.degrees(yaw)},
            "calibrations": [c.to_dict() for c in self.calibrations],
            "tests": [t.to_dict() for t in self.tests],
            "relations_crossing": self.relations_crossing,
            "scan_matching": self.scan_matching.to_dict(),
            "timings_s": dict(self.timings_s),
            "warnings": list(self.warnings),
        }


def _slice_bag(bag: SelfcalBag, scans: NDArray[np.bool_]) -> SelfcalBag:
    """The bag with only the selected scans, and the wheel samples that enclose them."""
    st = bag.scan_t_s[scans]
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    k0 = max(int(np.searchsorted(wt, st[0], side="right")) - 1, 0)
    k1 = min(int(np.searchsorted(wt, st[-1], side="left")) + 1, len(wt))
    w = slice(k0, k1)
    pick = lambda a: None if a is None else a[w]  # noqa: E731
    return replace(
        bag,
        scan_t_s=st,
        ranges_m=bag.ranges_m[scans],
        wheel_t_s=wt[w],
        left_rad=pick(bag.left_rad),
        right_rad=pick(bag.right_rad),
        odom_pose=pick(bag.odom_pose),
    )


def _delayed(bag: SelfcalBag, scan_delay_s: float) -> SelfcalBag:
    """The bag with its wheel data re-stamped so that a scan stamped ``t`` sees them at ``t - scan_delay_s``."""
    if scan_delay_s == 0:
        return bag
    return replace(bag, wheel_t_s=np.asarray(bag.wheel_t_s, dtype=float) + scan_delay_s)


def _tf_pose(bag: SelfcalBag, base_frame: str | None) -> Pose:
    """The laser pose of ``/tf_static`` from the robot frame (the first of the candidates found), else zero."""
    frames = [base_frame] if base_frame else [f for f in (bag.odom_child_frame, "base_link", "base_footprint") if f]
    for f in frames:
        tf = sensor_pose_from_tf(bag.static_transforms, f, bag.scan_frame)
        if tf is not None:
            return (tf[0], tf[1], tf[5])
    return (0.0, 0.0, 0.0)


def _check_options(short_max_s: float, scan_delay_s: float | str | None) -> tuple[str, float | str]:
    """Check ``short_max_s`` and ``scan_delay_s``; the ``scan_delay_mode`` and the pipeline's ``scan_delay`` for it."""
    if not (isinstance(short_max_s, (int, float)) and short_max_s > 0):
        raise InputError(f"`short_max_s` must be a positive number of seconds, got {short_max_s!r}")
    if scan_delay_s is None:
        return "recorded", 0.0
    if isinstance(scan_delay_s, str):
        if scan_delay_s != "estimate":
            raise InputError(f"`scan_delay_s` must be None, a number of seconds or 'estimate', got {scan_delay_s!r}")
        return "estimated", "auto"
    if isinstance(scan_delay_s, (int, float)) and math.isfinite(scan_delay_s):
        return "given", float(scan_delay_s)
    raise InputError(f"`scan_delay_s` must be None, a number of seconds or 'estimate', got {scan_delay_s!r}")


def _read_log(
    bag_path: str | Path,
    relations_path: str | Path,
    scan_topic: str,
    odom_topic: str,
    say: StageNotice,
    timings: dict[str, float],
) -> tuple[SelfcalBag, Relations]:
    """Read the bag and its relations file, timed into ``timings`` (``read_bag``, ``read_relations``)."""
    say("read bag")
    t0 = time.perf_counter()
    bag = read_selfcal_bag(bag_path, scan_topic=scan_topic, wheels=WheelSource(odom_topic=odom_topic))
    timings["read_bag"] = time.perf_counter() - t0
    say("read relations")
    t0 = time.perf_counter()
    relations = read_relations(relations_path)
    timings["read_relations"] = time.perf_counter() - t0
    return bag, relations


def _window(bag: SelfcalBag, window_s: tuple[float, float] | None, bag_path: str | Path) -> tuple[SelfcalBag, float]:
    """The bag cut to the window studied, and the log's first scan stamp (the origin of the study's times) [s]."""
    st_all = np.asarray(bag.scan_t_s, dtype=float)
    origin = float(st_all[0])
    if window_s is None:
        in_win = np.ones(len(st_all), dtype=bool)
    else:
        lo, hi = (float(v) for v in window_s)
        if not hi > lo:
            raise InputError(f"`window_s` must be (start, end) with end after start, got {window_s!r}")
        in_win = (st_all >= origin + lo) & (st_all <= origin + hi)
    if in_win.sum() < 20:
        raise InputError(f"the window {window_s!r} holds {int(in_win.sum())} scans: too few to study", str(bag_path))
    return (_slice_bag(bag, in_win) if window_s is not None else bag), origin


def _window_relations(
    relations: Relations, st: FloatArray, tolerance_s: float, relations_path: str | Path
) -> Relations:
    """The relations with both stamps within the scans studied (stamps ``st``); InputError when none."""
    keep = (np.minimum(relations.t1_s, relations.t2_s) >= st[0] - tolerance_s) & (
        np.maximum(relations.t1_s, relations.t2_s) <= st[-1] + tolerance_s
    )
    if not keep.any():
        raise InputError(
            f"none of the {len(relations)} relations lies within the scans studied ({st[0]:.3f} to {st[-1]:.3f} s): "
            "are these the relations of this log?",
            str(relations_path),
        )
    return relations.subset(keep)


def _halves(st: FloatArray) -> tuple[float, dict[str, NDArray[np.bool_]]]:
    """The split between the halves (the middle of the scans' time) and the scans of each part of the study."""
    split = float(st[0] + 0.5 * (st[-1] - st[0]))
    first = st < split
    return split, {"first half": first, "second half": ~first, "full log": np.ones(len(st), dtype=bool)}


def _span(stamps_s: FloatArray, origin: float) -> tuple[float, float]:
    """The first and the last of the stamps, from the origin [s]."""
    return (float(stamps_s[0] - origin), float(stamps_s[-1] - origin))


@dataclass(frozen=True)
class _Calibrator:
    """How each part of the log is self-calibrated: the nominal geometry and the pipeline's settings."""

    wheel_diameter_m: float
    wheelbase_m: float
    keyframes: KeyframeRule | None
    base_frame: str | None
    icp: ICPConfig | None
    scan_delay: float | str
    selfcal_options: dict[str, Any] | None

    def calibrate(
        self, bag: SelfcalBag, mask: NDArray[np.bool_], label: str, origin: float, say: StageNotice
    ) -> PartCalibration:
        """Self-calibrate on the scans of ``mask``, timed from the cut of the bag on."""
        t0 = time.perf_counter()
        part = _slice_bag(bag, mask) if not mask.all() else bag
        say(f"calibrate: {label}")
        opts = IntervalOptions(
            keyframes=DEFAULT_KEYFRAMES if self.keyframes is None else self.keyframes,
            base_frame=self.base_frame,
            icp=self.icp,
            scan_delay=self.scan_delay,
        )
        si = bag_intervals(part, self.wheel_diameter_m, self.wheelbase_m, opts)
        delay, d_s = si.scan_delay, si.plan.scan_delay_s
        report = selfcal_report([si], self.wheel_diameter_m, self.wheelbase_m, **(self.selfcal_options or {}))
        elapsed = time.perf_counter() - t0
        ts = part.scan_t_s
        return PartCalibration(label, *_span(ts, origin), len(ts), report, elapsed, delay, d_s)


@dataclass(eq=False)
class _Evaluator:
    """What the evaluations share: the log, the geometries, the relations and the odometries computed so far."""

    bag: SelfcalBag
    wheel_diameter_m: float
    wheelbase_m: float
    calibrations: dict[str, PartCalibration]
    tf_pose: Pose
    relations: Relations
    i1: NDArray[np.int64]
    i2: NDArray[np.int64]
    short: NDArray[np.bool_]
    cache: dict[float, dict[str, FloatArray]] = field(default_factory=dict)

    def odometries(self, d_s: float) -> dict[str, FloatArray]:
        """The odometries at the scans read ``d_s`` earlier: recorded, nominal, each calibration's (computed once)."""
        if d_s not in self.cache:
            r_nom = 0.5 * self.wheel_diameter_m
            b = _delayed(self.bag, d_s)
            geometry = WheelGeometry(self.wheel_diameter_m, self.wheel_diameter_m, self.wheelbase_m)
            left, right = scan_wheel_angles(b, geometry)
            odo = {
                "recorded": recorded_odometry_at_scans(b),
                "nominal": odometry_from_wheels(left, right, r_nom, r_nom, self.wheelbase_m),
            }
            for lab, cal in self.calibrations.items():
                odo[f"calibrated({lab})"] = odometry_from_wheels(left, right, *cal.geometry)
            self.cache[d_s] = odo
        return self.cache[d_s]

    def evaluate(
        self, sel: NDArray[np.bool_], d_s: float, odometry: str, cal: PartCalibration | None, pose_src: str
    ) -> RelationEvaluation:
        """One odometry, seen from the laser pose of ``pose_src``, against the selected relations."""
        name = f"calibrated({cal.label})" if odometry == "calibrated" and cal is not None else odometry
        lp = self.tf_pose if pose_src == "/tf_static" or cal is None else cal.sensor_pose
        p = self.odometries(d_s)[name]
        ref = self.relations.pose[sel]
        q = in_sensor_frame(se2.between(p[self.i1[sel]], p[self.i2[sel]]), lp)
        et, er = relation_errors(q, ref)
        s = self.short[sel]
        return RelationEvaluation(
            odometry,
            cal.label if cal is not None else None,
            lp,
            pose_src,
            ErrorStats.from_errors(et, er),
            ErrorStats.from_errors(et[s], er[s]),
            ErrorStats.from_errors(et[~s], er[~s]),
            SystematicErrors.fit(q[s], ref[s]),
        )


def _inside_halves(relations: Relations, split: float) -> dict[str, NDArray[np.bool_]]:
    """The relations with both stamps inside the first half, and inside the second."""
    lo_t, hi_t = np.minimum(relations.t1_s, relations.t2_s), np.maximum(relations.t1_s, relations.t2_s)
    return {"first half": hi_t < split, "second half": lo_t >= split}


def _half_test(ev: _Evaluator, label: str, other: str, sel: NDArray[np.bool_], span: tuple[float, float]) -> HalfTest:
    """The test of one half (relations ``sel``), calibrated out of sample on the ``other`` half."""
    cal_o, cal_h, cal_f = ev.calibrations[other], ev.calibrations[label], ev.calibrations["full log"]
    d_s = cal_o.scan_delay_s
    evals = (
        ev.evaluate(sel, d_s, "recorded", None, "/tf_static"),
        ev.evaluate(sel, d_s, "nominal", None, "/tf_static"),
        ev.evaluate(sel, d_s, "nominal", cal_o, "estimated"),
        ev.evaluate(sel, d_s, "calibrated", cal_o, "estimated"),
        ev.evaluate(sel, d_s, "calibrated", cal_o, "/tf_static"),
        ev.evaluate(sel, d_s, "calibrated", cal_h, "estimated"),
        ev.evaluate(sel, d_s, "calibrated", cal_f, "estimated"),
    )
    return HalfTest(label, other, *span, int((sel & ev.short).sum()), int((sel & ~ev.short).sum()), evals, d_s)


def _full_log_test(ev: _Evaluator, span: tuple[float, float]) -> HalfTest:
    """The test of the full log on all the relations, calibrated on itself."""
    every = np.ones(len(ev.relations), dtype=bool)
    cal_f = ev.calibrations["full log"]
    d_f = cal_f.scan_delay_s
    evals = (
        ev.evaluate(every, d_f, "recorded", None, "/tf_static"),
        ev.evaluate(every, d_f, "nominal", None, "/tf_static"),
        ev.evaluate(every, d_f, "nominal", cal_f, "estimated"),
        ev.evaluate(every, d_f, "calibrated", cal_f, "estimated"),
        ev.evaluate(every, d_f, "calibrated", cal_f, "/tf_static"),
    )
    return HalfTest("full log", None, *span, int(ev.short.sum()), int((~ev.short).sum()), evals, d_f)


def _tests(
    ev: _Evaluator,
    inside: dict[str, NDArray[np.bool_]],
    parts: dict[str, NDArray[np.bool_]],
    st: FloatArray,
    origin: float,
) -> tuple[HalfTest, ...]:
    """The tests: each half calibrated out of sample on the other, then the full log calibrated on itself."""
    tests = [
        _half_test(ev, label, other, inside[label], _span(st[parts[label]], origin))
        for label, other in (("second half", "first half"), ("first half", "second half"))
    ]
    return (*tests, _full_log_test(ev, _span(st, origin)))


def _scan_matching_check(ev: _Evaluator, d_s: float, icp: ICPConfig | None) -> ScanMatchCheck:
    """Match the scans of each short relation from the nominal odometry seen from ``/tf_static``; compare both."""
    i1, i2, ref = ev.i1, ev.i2, ev.relations.pose
    js = np.flatnonzero(ev.short)
    nominal = ev.odometries(d_s)["nominal"]
    q0 = in_sensor_frame(se2.between(nominal[i1[js]], nominal[i2[js]]), ev.tf_pose)
    m = match_scan_pairs(ev.bag.ranges_m[i1[js]], ev.bag.ranges_m[i2[js]], ev.bag.angles_rad, q0, icp)
    ok = np.asarray(m.converged, dtype=bool)
    poses = np.asarray(m.poses, dtype=float)[ok]
    et_m, er_m = relation_errors(poses, ref[js[ok]])
    et_o, er_o = relation_errors(q0[ok], ref[js[ok]])
    return ScanMatchCheck(
        int(js.size),
        int(ok.sum()),
        ErrorStats.from_errors(et_m, er_m),
        ErrorStats.from_errors(et_o, er_o),
        SystematicErrors.fit(poses, ref[js[ok]]),
        SystematicErrors.fit(q0[ok], ref[js[ok]]),
    )


def _study_warnings(
    crossing: int, relations: int, inside: dict[str, NDArray[np.bool_]], short: NDArray[np.bool_]
) -> list[str]:
    """What the study notices: relations across the halves, a half without short relations."""
    warnings = []
    if crossing:
        warnings.append(
            f"{crossing} of {relations} relations have one stamp in each half: in neither half's test "
            "(they are in the full log's)"
        )
    for label in ("first half", "second half"):
        if not (inside[label] & short).any():
            warnings.append(f"no short relations inside the {label}: its test has no short-relation figures")
    return warnings


def study_log(
    bag_path: str | Path,
    relations_path: str | Path,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    scan_topic: str = "/scan",
    odom_topic: str = "/odom",
    window_s: tuple[float, float] | None = None,
    short_max_s: float = SHORT_MAX_S,
    scan_delay_s: float | str | None = None,
    keyframes: KeyframeRule | None = None,
    icp: ICPConfig | None = None,
    selfcal_options: dict[str, Any] | None = None,
    base_frame: str | None = None,
    tolerance_s: float = 1e-3,
    progress: StageNotice | None = None,
) -> Slam2dStudy:
    """Calibrate on each half of a log and on all of it; compare the odometries with the relations.

    Parameters
    ----------
    bag_path : str or Path
        The log: a bag with laser scans and ``nav_msgs/Odometry``.
    relations_path : str or Path
        Its relations file (:mod:`umbmark.io.relations`), stamped with the scans' stamps.
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry assumed [m] (the odometry's increments become wheel travel
        through it).
    scan_topic, odom_topic : str
        The topics.
    window_s : (float, float), optional
        Study only the scans from ``window_s[0]`` to ``window_s[1]`` seconds after the log's
        first scan (and the relations inside); default the whole log.
    short_max_s : float
        Relations spanning less than this are short [s].
    scan_delay_s : float or str, optional
        How late the scans are stamped behind the odometry's clock [s]: the odometry is read at
        ``stamp - scan_delay_s``. None: the stamps as recorded; a number: that delay
        everywhere; ``"estimate"``: estimated on each calibration part
        (:func:`umbmark.realrobot.selfcal.estimate_scan_delay`), and each half's test uses the delay
        estimated on the other half (the full log's test, the full log's).
    keyframes, icp
        As :func:`umbmark.realrobot.selfcal.bag_intervals` (default: every scan, the matcher's
        defaults).
    selfcal_options : dict, optional
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.
    base_frame : str, optional
        The robot frame of ``/tf_static`` (default the odometry's child frame, then
        ``base_link``, ``base_footprint``).
    tolerance_s : float
        How far a relation's time stamp may be from its scan's [s].
    progress : callable, optional
        Called with the name of each stage as it starts.

    Returns
    -------
    Slam2dStudy

    Raises
    ------
    InputError
        Unreadable files; no relations within the scans, or relations without scans at their
        stamps; a window with too few scans; a bad ``scan_delay_s``; what the self-calibration
        refuses (e.g. too few matched intervals in a half).
    """
    t_total = time.perf_counter()
    say = progress or (lambda stage: None)
    mode, delay = _check_options(short_max_s, scan_delay_s)
    timings: dict[str, float] = {}
    full_bag, rel_all = _read_log(bag_path, relations_path, scan_topic, odom_topic, say, timings)
    bag, origin = _window(full_bag, window_s, bag_path)
    st = np.asarray(bag.scan_t_s, dtype=float)
    # relations inside the window, and the scans they join
    rel = _window_relations(rel_all, st, tolerance_s, relations_path)
    i1, i2 = rel.indices(st, tolerance_s)
    short = rel.span_s < short_max_s
    split, parts = _halves(st)

    calibrator = _Calibrator(wheel_diameter_m, wheelbase_m, keyframes, base_frame, icp, delay, selfcal_options)
    calibrations: dict[str, PartCalibration] = {}
    for label, mask in parts.items():
        calibrations[label] = calibrator.calibrate(bag, mask, label, origin, say)
        timings[f"calibrate_{label.replace(' ', '_')}"] = calibrations[label].elapsed_s

    say("evaluate")
    t0 = time.perf_counter()
    tf_pose = _tf_pose(bag, base_frame)
    ev = _Evaluator(bag, wheel_diameter_m, wheelbase_m, calibrations, tf_pose, rel, i1, i2, short)
    inside = _inside_halves(rel, split)
    crossing = int((~inside["first half"] & ~inside["second half"]).sum())
    tests = _tests(ev, inside, parts, st, origin)
    timings["evaluate"] = time.perf_counter() - t0

    say("scan matching against the relations")
    t0 = time.perf_counter()
    check = _scan_matching_check(ev, calibrations["full log"].scan_delay_s, icp)
    timings["scan_matching_check"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_total
    return Slam2dStudy(
        name=Path(bag_path).stem,
        bag=str(bag_path),
        relations=str(relations_path),
        nominal_wheel_diameter_m=float(wheel_diameter_m),
        nominal_wheelbase_m=float(wheelbase_m),
        scans=len(st),
        t_start_s=float(st[0] - origin),
        t_end_s=float(st[-1] - origin),
        split_s=float(split - origin),
        short_max_s=float(short_max_s),
        scan_delay_mode=mode,
        tf_sensor_pose=tf_pose,
        calibrations=tuple(calibrations.values()),
        tests=tests,
        relations_crossing=crossing,
        scan_matching=check,
        timings_s=timings,
        warnings=_study_warnings(crossing, len(rel), inside, short),
    )
