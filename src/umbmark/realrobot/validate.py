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

The metric and the odometry helpers here (:func:`relation_errors`, :class:`ErrorStats`,
:class:`SystematicErrors`, :func:`in_sensor_frame`, :func:`odometry_from_wheels`,
:func:`recorded_odometry_at_scans`) are also those of :mod:`umbmark.studies.slam2d`.

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io` (the bag, relations, trajectory and
calibration readers) and :mod:`umbmark.realrobot.selfcal` (the odometry's wheel travel, the
``/tf_static`` sensor pose).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.io._text import parse_json, read_text
from umbmark.io.relations import Relations, read_relations
from umbmark.io.rosbag import SelfcalBag
from umbmark.io.tum import Trajectory, read_tum
from umbmark.io.wheels import WheelSource
from umbmark.kinds import DEFAULT_KIND, KINDS, Kind, kind_in
from umbmark.model import se2
from umbmark.model.dataset import wheel_angles_from_poses
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry, nominal_slip, unit_slip
from umbmark.model.kinematics import Kinematics
from umbmark.model.se2 import Pose
from umbmark.realrobot.selfcal import nominal_sensor_pose_of
from umbmark.realrobot.wheels import scan_wheel_angles

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

SHORT_MAX_S = 10.0
"""A relation spanning less than this is short [s] (the benchmark's are 0.1 to 10 s, or loops)."""

STAMP_TOLERANCE_S = 1e-3
"""How far a relation's stamp may be from its scan's [s] (the benchmark's are to 5 us)."""

MIN_DISTANCE_M = 0.2
"""The distance scale is measured on short relations longer than this [m]."""

MIN_TURN_RAD = math.radians(10.0)
"""The turn scale is measured on short relations turning more than this [rad]."""

SHORT_MSE_TOLERANCE = 0.02
"""A short-relation MSE after the calibration may be this fraction above the one before."""

SCALE_TOLERANCE = 0.015
"""A scale after the calibration within this of 1 passes (else it must be no farther from 1 than before)."""

TRAJECTORY_MAX_GAP_S = 1.0
"""A trajectory is not interpolated across a gap between its poses longer than this [s]."""

REFERENCE_FRAMES = ("base", "sensor")
"""Whose poses a trajectory holds: the robot's base frame (as a SLAM publishes them) or the lidar's."""

# a relations file whose turns are about this many times the odometry's is in degrees
_DEG = math.degrees(1.0)
_MAX_DELAY_S = 1.0  # a scan delay beyond this is more likely milliseconds given as seconds

FloatArray = NDArray[np.float64]
StageNotice = Callable[[str], None]
"""``say(stage)``: a stage of a check starts."""


def _wrap(a: ArrayLike) -> FloatArray:
    return np.remainder(np.asarray(a, dtype=float) + math.pi, 2 * math.pi) - math.pi


def relation_errors(predicted: ArrayLike, reference: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The benchmark's error of each relation: ``e = reference^-1 (+) predicted``.

    Parameters
    ----------
    predicted, reference : array_like
        ``(K, 3)`` relative poses ``(x_m, y_m, yaw_rad)``.

    Returns
    -------
    tuple of numpy.ndarray
        ``(translation_m, rotation_rad)``, each ``(K,)``: ``|e_xy|`` and ``|e_yaw|`` (wrapped to
        at most pi).

    Raises
    ------
    InputError
        If the shapes are not ``(K, 3)`` alike.
    """
    p = np.asarray(predicted, dtype=float)
    r = np.asarray(reference, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape != r.shape:
        raise InputError(f"`predicted` and `reference` must both be (K, 3), got {p.shape} and {r.shape}")
    e = se2.between(r, p)
    return np.hypot(e[:, 0], e[:, 1]), np.abs(_wrap(e[:, 2]))


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


def in_sensor_frame(q: ArrayLike, sensor_pose: ArrayLike) -> FloatArray:
    """Robot-frame relative poses seen from a sensor mounted at ``sensor_pose``: ``l^-1 (+) q (+) l``.

    Parameters
    ----------
    q : array_like
        ``(K, 3)`` relative poses of the robot.
    sensor_pose : array_like
        ``(x_m, y_m, yaw_rad)`` of the sensor in the robot frame.

    Returns
    -------
    numpy.ndarray
        ``(K, 3)``.
    """
    lp = np.asarray(sensor_pose, dtype=float).reshape(3)
    return se2.compose(se2.inverse(lp), se2.compose(np.asarray(q, dtype=float), lp))


@dataclass(frozen=True)
class ErrorStats:
    """The benchmark's error statistics over a set of relations.

    Parameters
    ----------
    count : int
        Relations.
    mae_translation_m, sd_translation_m : float
        Mean and standard deviation of ``|e_xy|`` [m].
    mse_translation_m2, sd_sq_translation_m2 : float
        Mean and standard deviation of ``|e_xy|^2`` [m^2].
    mae_rotation_rad, sd_rotation_rad : float
        Mean and standard deviation of ``|e_yaw|`` [rad].
    mse_rotation_rad2, sd_sq_rotation_rad2 : float
        Mean and standard deviation of ``e_yaw^2`` [rad^2].
    """

    count: int
    mae_translation_m: float
    sd_translation_m: float
    mse_translation_m2: float
    sd_sq_translation_m2: float
    mae_rotation_rad: float
    sd_rotation_rad: float
    mse_rotation_rad2: float
    sd_sq_rotation_rad2: float

    @classmethod
    def from_errors(cls, translation_m: ArrayLike, rotation_rad: ArrayLike) -> ErrorStats:
        """The statistics of per-relation errors (NaN for an empty set).

        Parameters
        ----------
        translation_m, rotation_rad : array_like
            ``(K,)`` ``|e_xy|`` and ``|e_yaw|`` of :func:`relation_errors`.

        Returns
        -------
        ErrorStats
        """
        t = np.abs(np.asarray(translation_m, dtype=float).reshape(-1))
        r = np.abs(np.asarray(rotation_rad, dtype=float).reshape(-1))
        if t.size == 0:
            return cls(0, *([math.nan] * 8))
        sd = lambda v: float(np.std(v, ddof=1)) if v.size > 1 else math.nan  # noqa: E731
        return cls(
            int(t.size),
            float(t.mean()),
            sd(t),
            float((t * t).mean()),
            sd(t * t),
            float(r.mean()),
            sd(r),
            float((r * r).mean()),
            sd(r * r),
        )

    def to_dict(self) -> dict[str, Any]:
        """As JSON, in the benchmark's units (m, m^2, deg, deg^2).

        Returns
        -------
        dict
            ``count``, ``translation`` {``mae_m``, ``mae_sd_m``, ``mse_m2``, ``mse_sd_m2``},
            ``rotation`` {``mae_deg``, ``mae_sd_deg``, ``mse_deg2``, ``mse_sd_deg2``}.
        """
        d = math.degrees(1.0)
        return {
            "count": self.count,
            "translation": {
                "mae_m": self.mae_translation_m,
                "mae_sd_m": self.sd_translation_m,
                "mse_m2": self.mse_translation_m2,
                "mse_sd_m2": self.sd_sq_translation_m2,
            },
            "rotation": {
                "mae_deg": self.mae_rotation_rad * d,
                "mae_sd_deg": self.sd_rotation_rad * d,
                "mse_deg2": self.mse_rotation_rad2 * d * d,
                "mse_sd_deg2": self.sd_sq_rotation_rad2 * d * d,
            },
        }


@dataclass(frozen=True)
class SystematicErrors:
    """An odometry's systematic errors over short relations, fitted against the ground truth.

    ``distance_scale``: least squares of the predicted translations on the relations'
    (``sum p_xy . r_xy / sum |r_xy|^2``). ``turn_scale`` and ``drift_rad_per_m``: least squares
    of the heading error on the relation's turn and forward travel,
    ``p_yaw - r_yaw = (turn_scale - 1) r_yaw + drift r_x`` (a drift is a heading error that
    grows with the distance driven: unequal wheels). A perfectly calibrated odometry has 1, 1
    and 0. The intervals assume independent relations.

    Parameters
    ----------
    count : int
        Relations fitted.
    distance_scale, turn_scale, drift_rad_per_m : float
        The estimates.
    distance_scale_ci95, turn_scale_ci95, drift_rad_per_m_ci95 : tuple of float
        Their 95 % intervals.
    """

    count: int
    distance_scale: float
    distance_scale_ci95: tuple[float, float]
    turn_scale: float
    turn_scale_ci95: tuple[float, float]
    drift_rad_per_m: float
    drift_rad_per_m_ci95: tuple[float, float]

    @classmethod
    def fit(cls, predicted: ArrayLike, reference: ArrayLike) -> SystematicErrors:
        """Fit the three systematic errors (NaN with fewer than three relations).

        Parameters
        ----------
        predicted, reference : array_like
            ``(K, 3)`` relative poses.

        Returns
        -------
        SystematicErrors
        """
        p = np.asarray(predicted, dtype=float).reshape(-1, 3)
        r = np.asarray(reference, dtype=float).reshape(-1, 3)
        k = len(r)
        nan2 = (math.nan, math.nan)
        if k < 3 or not np.any(r[:, :2]) or not np.any(r[:, 2]):
            return cls(k, math.nan, nan2, math.nan, nan2, math.nan, nan2)
        z = 1.959963984540054
        # distance: p_xy ~ s r_xy (both components, one scale)
        rr = r[:, :2].reshape(-1)
        pp = p[:, :2].reshape(-1)
        s = float(rr @ pp / (rr @ rr))
        res = pp - s * rr
        se_s = math.sqrt(float(res @ res) / max(len(rr) - 1, 1) / float(rr @ rr))
        # heading: e_yaw ~ a r_yaw + c r_x
        ey = _wrap(p[:, 2] - r[:, 2])
        a_mat = np.column_stack([r[:, 2], r[:, 0]])
        coef, *_ = np.linalg.lstsq(a_mat, ey, rcond=None)
        res2 = ey - a_mat @ coef
        cov = np.linalg.pinv(a_mat.T @ a_mat) * float(res2 @ res2) / max(k - 2, 1)
        se = np.sqrt(np.diag(cov))
        turn, drift = 1.0 + float(coef[0]), float(coef[1])
        return cls(
            k,
            s,
            (s - z * se_s, s + z * se_s),
            turn,
            (turn - z * float(se[0]), turn + z * float(se[0])),
            drift,
            (drift - z * float(se[1]), drift + z * float(se[1])),
        )

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``count``, ``distance_scale``, ``turn_scale``, ``drift_deg_per_m`` and their
            ``_ci95``.
        """
        d = math.degrees(1.0)
        return {
            "count": self.count,
            "distance_scale": self.distance_scale,
            "distance_scale_ci95": list(self.distance_scale_ci95),
            "turn_scale": self.turn_scale,
            "turn_scale_ci95": list(self.turn_scale_ci95),
            "drift_deg_per_m": self.drift_rad_per_m * d,
            "drift_deg_per_m_ci95": [self.drift_rad_per_m_ci95[0] * d, self.drift_rad_per_m_ci95[1] * d],
        }


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


def magnitude_scale(predicted: ArrayLike, reference: ArrayLike) -> float:
    """How much larger the predicted magnitudes are than the reference's, by least squares:
    ``sum |p| |r| / sum |r|^2`` (1: right; NaN without relations).

    Parameters
    ----------
    predicted, reference : array_like
        ``(K,)`` distances [m] or turns [rad] (signs ignored).

    Returns
    -------
    float
    """
    p = np.abs(np.asarray(predicted, dtype=float).reshape(-1))
    r = np.abs(np.asarray(reference, dtype=float).reshape(-1))
    den = float(r @ r)
    return float(p @ r) / den if p.size and den > 0 else math.nan


# -- the calibration ------------------------------------------------------------------------------

_EXPECTED = (
    "a calibration is the JSON that umbmark selfcal or umbmark replay save, or that umbmark export writes "
    "in the json format"
)


# a lidar further than this from the robot's origin [mm], or turned beyond a turn [deg], is no mounting
_MAX_SENSOR_MM = 1e4
_MAX_SENSOR_DEG = 360.0


def _pose_mm_deg(d: Any, key: str, src: str) -> Pose:
    """``(x_m, y_m, yaw_rad)`` of a JSON object ``{x_mm, y_mm, yaw_deg}``."""
    if not isinstance(d, dict):
        raise InputError(f"{key!r} must be an object with x_mm, y_mm, yaw_deg, got {d!r}", src)
    vals = []
    for k, most, unit in (
        ("x_mm", _MAX_SENSOR_MM, "mm"),
        ("y_mm", _MAX_SENSOR_MM, "mm"),
        ("yaw_deg", _MAX_SENSOR_DEG, "deg"),
    ):
        v = d.get(k)
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
            raise InputError(f"{key!r} {k} must be a finite number, got {v!r}", src)
        if abs(v) > most:
            what = f"{most:g} mm from the robot's origin" if unit == "mm" else f"a turn, {most:g} deg"
            raise InputError(f"{key!r} {k} is {v:g} {unit}: no lidar is mounted beyond {what} ({unit} expected)", src)
        vals.append(float(v))
    return (vals[0] * 1e-3, vals[1] * 1e-3, math.radians(vals[2]))


def _positive_mm(d: dict, key: str, src: str) -> float | None:
    """The value of ``key`` [mm] in metres (None when absent); a size no robot has is refused."""
    v = d.get(key)
    if v is None:
        return None
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
        raise InputError(f"{key!r} must be a positive number of millimetres, got {v!r}", src)
    slip = unit_slip("wheelbase" if "wheelbase" in key else "diameter", float(v) * 1e-3, "mm")
    if slip is not None:
        raise InputError(f"{key!r}: {slip}", src)
    return float(v) * 1e-3


_SIZE_KINDS = (("left wheel diameter", "diameter"), ("right wheel diameter", "diameter"), ("wheelbase", "wheelbase"))


def _check_sizes(
    factors: tuple[float, float, float], nominal: WheelGeometry, calibrated: WheelGeometry, src: str
) -> None:
    """Refuse sizes no robot has, and a calibration whose factor on its own nominal size no
    correction makes (:func:`umbmark.model.geometry.nominal_slip`: a size in another unit, a
    radius for a diameter)."""
    sizes = lambda g: (g.diameter_left_m, g.diameter_right_m, g.wheelbase_m)  # noqa: E731
    for (name, kind), f, n, c in zip(_SIZE_KINDS, factors, sizes(nominal), sizes(calibrated)):
        for what, v in (("nominal", n), ("calibrated", c)):
            slip = unit_slip(kind, v, "mm")
            if slip is not None:
                raise InputError(f"the {what} {name}: {slip}", src)
        slip = nominal_slip(kind, f)
        if slip is not None:
            raise InputError(
                f"the calibrated {name} is {f:.3g} times the calibration's nominal one: no calibration corrects a "
                f"robot's size that much ({slip})",
                src,
            )


@dataclass(frozen=True)
class CheckedCalibration:
    """A calibration to check: the nominal and the calibrated geometry and sensor pose, the scan delay.

    Parameters
    ----------
    kind : str
        What the JSON was: ``selfcal``, ``replay``, ``export``, ``analyze``, ``calibrate`` or
        ``history`` (a history export).
    nominal, calibrated : WheelGeometry or Kinematics
        The geometry the odometry was computed with, and the calibration's: a differential
        drive's, or the geometry of a robot of another kind (:mod:`umbmark.kinds`: its joints'
        odometry is replayed with each).
    nominal_sensor_pose : tuple of float or None
        ``(x_m, y_m, yaw_rad)`` of the lidar the calibration started from (a
        self-calibration's); None: the log's ``/tf_static``.
    nominal_sensor_pose_source : str or None
        Where the calibration's nominal sensor pose came from.
    sensor_pose : tuple of float or None
        The calibration's lidar pose; None: it calibrates the wheels only (the nominal pose
        is used after it too).
    scan_delay_s : float
        The scans' delay the calibration applied [s] (0 when it applied none).
    scan_delay_source : str
        ``calibration`` (``scan_delay[0].applied_s``) or ``none``.
    method : str or None
        The calibration method.
    source : str or None
        The JSON file.
    warnings : tuple of str
        What the reading noticed.
    """

    kind: str
    nominal: WheelGeometry | Kinematics
    calibrated: WheelGeometry | Kinematics
    nominal_sensor_pose: Pose | None = None
    nominal_sensor_pose_source: str | None = None
    sensor_pose: Pose | None = None
    scan_delay_s: float = 0.0
    scan_delay_source: str = "none"
    method: str | None = None
    source: str | None = None
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """As JSON (mm).

        Returns
        -------
        dict
            ``path``, ``kind``, ``method``, ``nominal`` and ``calibrated`` (``diameter_left_mm``,
            ``diameter_right_mm``, ``wheelbase_mm``), ``Ed``, ``Eb``, ``c_left``, ``c_right``
            (the calibrated geometry against the nominal), ``scan_delay_s``,
            ``scan_delay_source``. Another kind of robot: ``kinematics`` (its name) and its
            ``nominal`` and ``calibrated`` geometry under its JSON keys (a tricycle's
            ``wheel_diameter_mm``, ``wheelbase_mm``, ...) in place of the differential drive's
            sizes and factors.
        """
        both = self.kinematics
        if both is not None:
            own = self.robot_kind
            return {
                "path": self.source,
                "kind": self.kind,
                "method": self.method,
                "kinematics": own.name,
                "nominal": own.geometry_json(both[0]),
                "calibrated": own.geometry_json(both[1]),
                "scan_delay_s": self.scan_delay_s,
                "scan_delay_source": self.scan_delay_source,
            }
        assert isinstance(self.nominal, WheelGeometry) and isinstance(self.calibrated, WheelGeometry)
        rel = self.calibrated.relative_to(self.nominal)
        return {
            "path": self.source,
            "kind": self.kind,
            "method": self.method,
            "nominal": self.nominal.to_dict(),
            "calibrated": self.calibrated.to_dict(),
            **{k: rel[k] for k in ("Ed", "Eb", "c_left", "c_right")},
            "scan_delay_s": self.scan_delay_s,
            "scan_delay_source": self.scan_delay_source,
        }

    @property
    def kinematics(self) -> tuple[Kinematics, Kinematics] | None:
        """``(nominal, calibrated)`` of a robot of a kind of its own; None for a differential drive's."""
        nom, cal = self.nominal, self.calibrated
        if isinstance(nom, WheelGeometry) or isinstance(cal, WheelGeometry):
            return None
        return nom, cal

    @property
    def robot_kind(self) -> Kind:
        """The kind of robot (:data:`umbmark.kinds.KINDS`): the differential drive's for its geometry."""
        return KINDS[getattr(self.nominal, "kind", DEFAULT_KIND)]


def _load_json(path: str | Path) -> dict:
    src = str(path)
    d = parse_json(read_text(path), src, _EXPECTED)
    if not isinstance(d, dict):
        raise InputError(f"a JSON {type(d).__name__}, not an object; {_EXPECTED}", src)
    return d


def _kind(d: dict) -> str | None:
    """What a JSON object is (None: nothing umbmark writes as a calibration)."""
    if "spans" in d and "reference" in d and "calibration" in d:
        return "validate"
    if "topics" in d and "messages" in d:
        return "bag-info"
    if "wheel_diameter_left_mm" in d and "sensor_pose" in d:
        return "selfcal"
    if "scale_observed" in d and "c_left" in d and not {"nominal", "dataset", "datasets", "record_id"} & set(d):
        return "export"
    if "record_id" in d:
        return "history"
    if "final_calibration" in d:
        return "calibrate"
    if "dataset" in d or "datasets" in d or d.get("pooled") is True:
        return "replay"
    if "c_left" in d and "c_right" in d:
        return "analyze"
    return None


def _selfcal_delay(d: dict, src: str) -> tuple[float, str, list[str]]:
    """``scan_delay[0].applied_s`` of a self-calibration's JSON (0 without one)."""
    delays = d.get("scan_delay")
    if delays is None:
        return 0.0, "none", []
    if not isinstance(delays, list) or not all(isinstance(x, dict) for x in delays):
        raise InputError(f"'scan_delay' must be a list of objects (one per bag, with applied_s), got {delays!r}", src)
    applied = []
    for x in delays:
        v = x.get("applied_s")
        if v is None:
            continue
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
            raise InputError(f"'scan_delay' applied_s must be a finite number of seconds, got {v!r}", src)
        applied.append(float(v))
    if not delays or delays[0].get("applied_s") is None:
        return 0.0, "none", []
    warnings = []
    if len(set(applied)) > 1:
        warnings.append(
            f"the calibration applied {len(applied)} scan delays (one per bag: "
            f"{', '.join(f'{v:g}' for v in applied)} s): the first, {applied[0]:g} s, is used; give `scan_delay_s`"
        )
    return applied[0], "calibration", warnings


_Sizes = tuple[float | None, float | None, float | None]  # left and right wheel diameters, wheelbase [m]


def _geometry(
    kind: str,
    src: str,
    factors: tuple[float, float, float],
    nominal: _Sizes,
    calibrated: _Sizes,
    wheel_diameter_m: float | None,
    wheelbase_m: float | None,
) -> tuple[WheelGeometry, WheelGeometry, list[str]]:
    """The nominal geometry (given, else the calibration's) and the calibrated one (the
    calibration's absolute sizes, else its factors on its nominal geometry, else on the given one)."""
    given = (wheel_diameter_m, wheel_diameter_m, wheelbase_m)
    names = ("left wheel diameter", "right wheel diameter", "wheelbase")
    params = ("wheel_diameter_m", "wheel_diameter_m", "wheelbase_m")
    nom: list[float] = []
    cal: list[float] = []
    warnings: list[tuple[str, str]] = []
    for name, param, f, n, c, g in zip(names, params, factors, nominal, calibrated, given):
        if n is None and g is None:
            raise InputError(
                f"the calibration ({kind}) does not hold the nominal {name}: give `{param}` (the geometry the "
                "odometry was computed with)",
                src,
            )
        if g is not None and n is not None and abs(g / n - 1) > 1e-6 and param not in [w[0] for w in warnings]:
            warnings.append(
                (
                    param,
                    f"the nominal {name} given ({g * 1e3:g} mm) is not the calibration's ({n * 1e3:g} mm): the "
                    f"odometry is turned into wheel travel with {g * 1e3:g} mm and the calibration keeps its own",
                )
            )
        nom.append(g if g is not None else n)
        cal.append(c if c is not None else f * (n if n is not None else g))
    return WheelGeometry(*nom), WheelGeometry(*cal), [w for _, w in warnings]


def read_calibration(
    path: str | Path,
    *,
    dataset: str | None = None,
    wheel_diameter_m: float | None = None,
    wheelbase_m: float | None = None,
) -> CheckedCalibration:
    """Read the calibration to check from its JSON.

    * ``umbmark selfcal``: ``wheel_diameter_left_mm``, ``wheel_diameter_right_mm``,
      ``wheelbase_mm``, ``sensor_pose`` (``x_mm``, ``y_mm``, ``yaw_deg``),
      ``nominal_wheel_diameter_mm``, ``nominal_wheelbase_mm``, ``nominal_sensor_pose``,
      ``scan_delay`` (one per bag; the first's ``applied_s``).
    * ``umbmark export`` (format json): ``c_left``, ``c_right``, ``Eb`` and, when the nominal
      geometry was known, the calibrated ``diameter_left_mm``, ``diameter_right_mm``,
      ``wheelbase_mm`` (the nominal one is these over the factors); a self-calibration's
      ``sensor_pose``.
    * ``umbmark replay`` (one data set, one of several with ``dataset``, or a pooled fit), and
      also ``umbmark analyze``, ``umbmark calibrate`` and a history export: the factors
      ``c_left``, ``c_right``, ``E_b`` on the nominal geometry
      (:func:`umbmark.io.export.calibration_from_json`).

    Parameters
    ----------
    path : str or Path
        The JSON file.
    dataset : str, optional
        The data set to take from a replay of several.
    wheel_diameter_m, wheelbase_m : float, optional
        The nominal geometry [m], for a calibration that does not hold it, or instead of the
        calibration's (the calibrated geometry stays the calibration's).

    Returns
    -------
    CheckedCalibration

    Raises
    ------
    InputError
        A missing or unreadable file, not JSON, a JSON that is no calibration (what it is
        named), bad values, a nominal geometry neither in the JSON nor given.
    """
    src = str(path)
    for name, v in (("wheel_diameter_m", wheel_diameter_m), ("wheelbase_m", wheelbase_m)):
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise InputError(f"`{name}` must be a positive number, got {v!r}")
    d = _load_json(path)
    own = kind_in(d)
    if own is not None:
        return _kind_calibration(d, own, src, wheel_diameter_m, wheelbase_m)
    kind = _kind(d)
    if kind == "validate":
        raise InputError(f"this is the output of umbmark validate, a report, not a calibration; {_EXPECTED}", src)
    if kind == "bag-info":
        raise InputError(f"this is the output of umbmark bag-info, not a calibration; {_EXPECTED}", src)
    if kind is None:
        keys = ", ".join(sorted(map(str, d))[:8]) or "none"
        raise InputError(f"a JSON object without the figures of a calibration (its keys: {keys}); {_EXPECTED}", src)
    nominal: _Sizes
    cal_w: _Sizes
    pose: Pose | None
    npose: Pose | None
    nsrc: str | None
    method: str | None
    if kind == "selfcal":
        dl, dr, b = (
            _positive_mm(d, k, src) for k in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm")
        )
        if dl is None or dr is None or b is None:
            raise InputError(
                "a self-calibration without wheel_diameter_left_mm, wheel_diameter_right_mm, wheelbase_mm", src
            )
        dn, bn = _positive_mm(d, "nominal_wheel_diameter_mm", src), _positive_mm(d, "nominal_wheelbase_mm", src)
        factors = (dl / dn if dn else 1.0, dr / dn if dn else 1.0, b / bn if bn else 1.0)
        nominal, cal_w = (dn, dn, bn), (dl, dr, b)
        pose = _pose_mm_deg(d["sensor_pose"], "sensor_pose", src)
        nsp = d.get("nominal_sensor_pose")
        npose = None if nsp is None else _pose_mm_deg(nsp, "nominal_sensor_pose", src)
        nsrc = None if not isinstance(nsp, dict) else str(nsp.get("source") or "the calibration")
        delay, delay_src, warnings = _selfcal_delay(d, src)
        method = str(d.get("method") or "selfcal")
    elif kind == "export":
        factors = (
            positive("'c_left'", d.get("c_left"), source=src),
            positive("'c_right'", d.get("c_right"), source=src),
            positive("'Eb'", d.get("Eb"), source=src),
        )
        dl, dr, b = (_positive_mm(d, k, src) for k in ("diameter_left_mm", "diameter_right_mm", "wheelbase_mm"))
        cal_w = (dl, dr, b)
        n_dl, n_dr, n_b = (None if v is None else v / f for v, f in zip(cal_w, factors))
        nominal = (n_dl, n_dr, n_b)
        sp = d.get("sensor_pose")
        pose = None if sp is None else _pose_mm_deg(sp, "sensor_pose", src)
        npose, nsrc, delay, delay_src, warnings = None, None, 0.0, "none", []
        method = None if d.get("method") is None else str(d["method"])
    else:
        from umbmark.io.export import calibration_from_json

        cal = calibration_from_json(path, dataset)
        factors = (cal.c_left, cal.c_right, cal.eb)
        nominal = (cal.nominal_diameter_left_m, cal.nominal_diameter_right_m, cal.nominal_wheelbase_m)
        cal_w = (None, None, None)
        pose, npose, nsrc, delay, delay_src, warnings = cal.sensor_pose, None, None, 0.0, "none", []
        method = cal.method
    nom_g, cal_g, geo_warnings = _geometry(kind, src, factors, nominal, cal_w, wheel_diameter_m, wheelbase_m)
    _check_sizes(factors, nom_g, cal_g, src)
    return CheckedCalibration(
        kind=kind,
        nominal=nom_g,
        calibrated=cal_g,
        nominal_sensor_pose=npose,
        nominal_sensor_pose_source=nsrc,
        sensor_pose=pose,
        scan_delay_s=delay,
        scan_delay_source=delay_src,
        method=method,
        source=src,
        warnings=tuple(warnings + geo_warnings),
    )


def calibration_kind(path: str | Path) -> Kind:
    """The kind of robot of a calibration's JSON (its ``kinematics``): another kind's, else the
    differential drive's.

    Raises
    ------
    InputError
        A file that is missing, unreadable or not a JSON object (as :func:`read_calibration`).
    """
    return kind_in(_load_json(path)) or KINDS[DEFAULT_KIND]


def _kind_calibration(
    d: dict, own: Kind, src: str, wheel_diameter_m: float | None, wheelbase_m: float | None
) -> CheckedCalibration:
    """The calibration of a robot of a kind of its own: the JSON of its self-calibration
    (``umbmark selfcal --kinematics KIND --save``) or of its replay against a ground truth (whose
    ``sensor_pose`` is the marker's: the lidar keeps its nominal pose)."""
    given = [n for n, v in (("wheel_diameter_m", wheel_diameter_m), ("wheelbase_m", wheelbase_m)) if v is not None]
    if given:
        raise InputError(
            f"a {own.noun}'s calibration holds its own nominal geometry: `{given[0]}` is a differential drive's", src
        )
    if not isinstance(d.get("nominal"), dict):
        what = "export" if "parameters" in d else "calibration"
        raise InputError(
            f"a {own.noun}'s {what} without the nominal geometry the odometry ran with ('nominal'): check the JSON "
            "that its self-calibration (umbmark selfcal) saved",
            src,
        )
    calibrated, _ = own.geometry_from_json(d, src)
    nominal, _ = own.geometry_from_json(d["nominal"], src)
    for size in own.sizes:
        idx = [own.geometry.parameter_names.index(p) for p in size.parameters]
        n, c = (float(sum(g.vector()[i] for i in idx)) / len(idx) for g in (nominal, calibrated))
        for what, v in (("nominal", n), ("calibrated", c)):
            slip = unit_slip(size.quantity, v, "mm")
            if slip is not None:
                raise InputError(f"the {what} {size.label}: {slip}", src)
        slip = nominal_slip(size.quantity, c / n)
        if slip is not None:
            raise InputError(
                f"the calibrated {size.label} is {c / n:.3g} times the calibration's nominal one: no calibration "
                f"corrects a robot's size that much ({slip})",
                src,
            )
    replay = "marker_pose" in d
    inputs = [i for i in d.get("inputs") or [] if isinstance(i, dict)]
    nsp = inputs[0].get("nominal_sensor_pose") if inputs else None
    delay, delay_src, warnings = _selfcal_delay(d, src)
    return CheckedCalibration(
        kind="replay" if replay else "selfcal",
        nominal=nominal,
        calibrated=calibrated,
        nominal_sensor_pose=None if not isinstance(nsp, dict) else _pose_mm_deg(nsp, "nominal_sensor_pose", src),
        nominal_sensor_pose_source=None if not isinstance(nsp, dict) else str(nsp.get("source") or "the calibration"),
        sensor_pose=None if replay else _pose_mm_deg(d.get("sensor_pose"), "sensor_pose", src),
        scan_delay_s=delay,
        scan_delay_source=delay_src,
        method=str(d.get("method") or "selfcal"),
        source=src,
        warnings=tuple(warnings),
    )


# -- the reference --------------------------------------------------------------------------------


def _nearest(stamps: FloatArray, times: FloatArray) -> tuple[NDArray[np.int64], FloatArray]:
    """The index of the nearest stamp to each time, and how far it is."""
    if len(stamps) == 1:
        k = np.zeros(len(times), dtype=np.int64)
    else:
        k = np.clip(np.searchsorted(stamps, times), 1, len(stamps) - 1)
        k = np.where(np.abs(stamps[k - 1] - times) <= np.abs(stamps[k] - times), k - 1, k).astype(np.int64)
    return k, np.abs(stamps[k] - times)


def _ladder(short_max_s: float, span_s: float) -> list[float]:
    """The time steps of the relations made from a trajectory: four short ones (a half to a
    sixteenth of ``short_max_s``) and long ones (twice, four times ... ``short_max_s``, up to the span)."""
    steps = [short_max_s / 2**k for k in (1, 2, 3, 4)]
    k = 1
    while short_max_s * 2**k <= span_s:
        steps.append(short_max_s * 2**k)
        k += 1
    return steps


def relations_from_trajectory(
    trajectory: Trajectory,
    scan_t_s: ArrayLike,
    *,
    sensor_pose: ArrayLike | None = None,
    short_max_s: float = SHORT_MAX_S,
    tolerance_s: float = STAMP_TOLERANCE_S,
    max_gap_s: float = TRAJECTORY_MAX_GAP_S,
) -> tuple[Relations, str, int]:
    """Relations between scans, made from a trajectory: the reference poses at the scans, then
    pairs of them.

    **Poses at the scans.** When at least half of the trajectory's poses within the scans' time
    span have a scan within ``tolerance_s`` (a SLAM's poses at its scans), those poses are the
    scans' (``matched``); otherwise the trajectory is interpolated linearly (heading
    unwrapped) at every scan between two of its poses at most ``max_gap_s`` apart
    (``interpolated``). With ``sensor_pose`` (a trajectory of the robot's base frame) each pose
    becomes the lidar's, ``p (+) l``.

    **Pairs.** From each of those scans to the one nearest to ``short_max_s / 2``, ``/ 4``,
    ``/ 8`` and ``/ 16`` later (short relations) and ``2``, ``4``, ``8`` ... times
    ``short_max_s`` later up to the trajectory's span (long ones), when it is within a quarter
    of that step. A relation is the later lidar pose in the frame of the earlier.

    Parameters
    ----------
    trajectory : Trajectory
        The reference poses (:func:`umbmark.io.tum.read_tum`).
    scan_t_s : array_like
        ``(M,)`` the scans' stamps [s], increasing.
    sensor_pose : array_like, optional
        ``(x_m, y_m, yaw_rad)``: the lidar on the robot, for a trajectory of the base frame;
        None: the trajectory is the lidar's.
    short_max_s : float
        Relations spanning less than this are short [s].
    tolerance_s : float
        How far a trajectory stamp may be from its scan's [s].
    max_gap_s : float
        The longest gap between poses interpolated across [s].

    Returns
    -------
    tuple
        ``(relations, mode, scans)``: the :class:`~umbmark.io.relations.Relations` (stamped with
        the scans' stamps), ``matched`` or ``interpolated``, and the number of scans with a
        reference pose.

    Raises
    ------
    InputError
        A trajectory that does not overlap the scans in time (both spans named; stamps in
        nanoseconds named), or too short to make a relation.
    """
    st = np.asarray(scan_t_s, dtype=float).reshape(-1)
    t, p = trajectory.t_s, trajectory.pose
    src = trajectory.source
    for name, v in (("short_max_s", short_max_s), ("tolerance_s", tolerance_s), ("max_gap_s", max_gap_s)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise InputError(f"`{name}` must be a positive number of seconds, got {v!r}")
    inside = (t >= st[0] - tolerance_s) & (t <= st[-1] + tolerance_s)
    if not inside.any() and (t[-1] < st[0] or t[0] > st[-1]) or len(t) < 2:
        hint = " (stamps in nanoseconds? TUM stamps are seconds)" if t[0] > 1e15 else ""
        raise InputError(
            f"the trajectory ({t[0]:.3f} to {t[-1]:.3f} s, {len(t)} poses) does not overlap the scans "
            f"({st[0]:.3f} to {st[-1]:.3f} s){hint}: is it the trajectory of this log?",
            src,
        )
    k, off = _nearest(st, t)
    matched = inside & (off <= tolerance_s)
    if matched.sum() >= max(1, 0.5 * inside.sum()):
        mode = "matched"
        scans, first = np.unique(k[matched], return_index=True)
        ref = p[np.flatnonzero(matched)[first]]
    else:
        mode = "interpolated"
        j = np.clip(np.searchsorted(t, st, side="right"), 1, len(t) - 1)
        ok = (st >= t[0]) & (st <= t[-1]) & ((t[j] - t[j - 1] <= max_gap_s) | np.isin(st, t))
        scans = np.flatnonzero(ok)
        yaw = np.unwrap(p[:, 2])
        ts = st[scans]
        ref = np.column_stack([np.interp(ts, t, p[:, 0]), np.interp(ts, t, p[:, 1]), np.interp(ts, t, yaw)])
    if len(scans) < 2:
        raise InputError(
            f"only {len(scans)} scans have a pose of the trajectory ({mode}): too few to make relations", src
        )
    if sensor_pose is not None:
        ref = se2.compose(ref, np.asarray(sensor_pose, dtype=float).reshape(3))
    ts = st[scans]
    pairs = []
    for step in _ladder(float(short_max_s), float(ts[-1] - ts[0])):
        jj, off2 = _nearest(ts, ts + step)
        ii = np.arange(len(ts))
        keep = (jj > ii) & (np.abs(ts[jj] - ts - step) <= 0.25 * step) & (off2 <= 0.25 * step)
        pairs.append(np.column_stack([ii[keep], jj[keep]]))
    pp = np.unique(np.concatenate(pairs), axis=0) if pairs else np.zeros((0, 2), dtype=np.int64)
    if not len(pp):
        raise InputError(
            f"the trajectory's poses at the scans span {ts[-1] - ts[0]:.2f} s: too short to make relations "
            f"(the shortest are {short_max_s / 16:g} s)",
            src,
        )
    a, b = pp[:, 0], pp[:, 1]
    rel = Relations(ts[a], ts[b], se2.between(ref[a], ref[b]), source=src)
    return rel, mode, int(len(scans))


@dataclass(frozen=True)
class ReferenceSummary:
    """The reference of a validation and what became of its relations.

    Parameters
    ----------
    kind : str
        ``relations`` (a relations file) or ``trajectory`` (relations made from one).
    source : str or None
        The file.
    relations : int
        Relations in the reference (made from the trajectory).
    unmatched : int
        Relations with a stamp that matches no scan within the tolerance.
    without_wheel_data : int
        Relations whose scans lie outside the wheel data (with the scan delay).
    outside_window : int
        Relations of the log outside the window.
    frame : str or None
        A trajectory's frame (``base`` or ``sensor``).
    poses : int or None
        A trajectory's poses.
    scans_with_pose : int or None
        The scans a trajectory gave a pose to.
    mode : str or None
        ``matched`` or ``interpolated`` (:func:`relations_from_trajectory`).
    base_trajectory : str or None
        How a trajectory of the base frame was read (:func:`_read_base`): ``slam`` (a SLAM's,
        made with the nominal lidar pose: turned into the lidar's with it) or ``true`` (the
        robot's own, a motion capture's or a simulation's: each odometry compared with it
        through its own lidar pose).
    """

    kind: str
    source: str | None
    relations: int
    unmatched: int = 0
    without_wheel_data: int = 0
    outside_window: int = 0
    frame: str | None = None
    poses: int | None = None
    scans_with_pose: int | None = None
    mode: str | None = None
    base_trajectory: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            The fields (``path`` for ``source``); the trajectory's only for a trajectory.
        """
        d: dict[str, Any] = {
            "kind": self.kind,
            "path": self.source,
            "relations": self.relations,
            "unmatched": self.unmatched,
            "without_wheel_data": self.without_wheel_data,
            "outside_window": self.outside_window,
        }
        if self.kind == "trajectory":
            d.update(
                {"frame": self.frame, "poses": self.poses, "scans_with_pose": self.scans_with_pose, "mode": self.mode}
            )
            if self.base_trajectory is not None:
                d["base_trajectory"] = self.base_trajectory
        return d


# -- the figures ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class OdometryFigures:
    """One odometry against the relations of one span (step 3 of the module docstring).

    Parameters
    ----------
    short, long : ErrorStats
        The errors over the short and the long relations.
    distance_scale : float
        ``sum |t_odo| |t_rel| / sum |t_rel|^2`` over the short relations longer than
        :data:`MIN_DISTANCE_M` (NaN without any).
    distance_relations : int
        Those relations.
    turn_scale : float
        The same with the turns, over the short relations turning more than :data:`MIN_TURN_RAD`.
    turn_relations : int
        Those relations.
    drift_rad_per_m : float
        Heading drift per metre driven (:class:`SystematicErrors` on the short relations).
    drift_rad_per_m_ci95 : tuple of float
        Its 95 % interval.
    """

    short: ErrorStats
    long: ErrorStats
    distance_scale: float
    distance_relations: int
    turn_scale: float
    turn_relations: int
    drift_rad_per_m: float
    drift_rad_per_m_ci95: tuple[float, float]

    @classmethod
    def compute(
        cls,
        odometry: ArrayLike,
        i1: ArrayLike,
        i2: ArrayLike,
        reference: ArrayLike,
        sensor_pose: ArrayLike,
        short: ArrayLike,
    ) -> OdometryFigures:
        """The figures of an odometry on relations.

        Parameters
        ----------
        odometry : array_like
            ``(M, 3)`` poses at the scans, heading accumulated (:func:`odometry_from_wheels`).
        i1, i2 : array_like
            ``(K,)`` the scans each relation joins.
        reference : array_like
            ``(K, 3)`` the relations (the lidar's pose at ``i2`` in its frame at ``i1``).
        sensor_pose : array_like
            ``(x_m, y_m, yaw_rad)`` of the lidar the odometry is seen from.
        short : array_like
            ``(K,)`` booleans: the short relations.

        Returns
        -------
        OdometryFigures
        """
        odo = np.asarray(odometry, dtype=float)
        a, b = np.asarray(i1, dtype=np.int64), np.asarray(i2, dtype=np.int64)
        ref = np.asarray(reference, dtype=float).reshape(-1, 3)
        s = np.asarray(short, dtype=bool)
        q = in_sensor_frame(se2.between(odo[a], odo[b]), sensor_pose)
        turn = odo[b, 2] - odo[a, 2]  # accumulated: whole turns counted
        et, er = relation_errors(q, ref)
        dist = np.hypot(ref[:, 0], ref[:, 1])
        ref_turn = turn + _wrap(ref[:, 2] - turn)  # the relation's turn nearest to the odometry's
        dsel = s & (dist > MIN_DISTANCE_M)
        tsel = s & (np.abs(ref_turn) > MIN_TURN_RAD)
        sys_err = SystematicErrors.fit(q[s], ref[s])
        return cls(
            ErrorStats.from_errors(et[s], er[s]),
            ErrorStats.from_errors(et[~s], er[~s]),
            magnitude_scale(np.hypot(q[dsel, 0], q[dsel, 1]), dist[dsel]),
            int(dsel.sum()),
            magnitude_scale(turn[tsel], ref_turn[tsel]),
            int(tsel.sum()),
            sys_err.drift_rad_per_m,
            sys_err.drift_rad_per_m_ci95,
        )

    def to_dict(self) -> dict[str, Any]:
        """As JSON (the benchmark's m, m^2, deg, deg^2).

        Returns
        -------
        dict
            ``short``, ``long`` (:meth:`ErrorStats.to_dict`), ``distance_scale``,
            ``distance_relations``, ``turn_scale``, ``turn_relations``,
            ``heading_drift_deg_per_m`` and its ``_ci95``.
        """
        return {
            "short": self.short.to_dict(),
            "long": self.long.to_dict(),
            "distance_scale": self.distance_scale,
            "distance_relations": self.distance_relations,
            "turn_scale": self.turn_scale,
            "turn_relations": self.turn_relations,
            "heading_drift_deg_per_m": math.degrees(self.drift_rad_per_m),
            "heading_drift_deg_per_m_ci95": [math.degrees(v) for v in self.drift_rad_per_m_ci95],
        }


@dataclass(frozen=True)
class Rule:
    """One pass rule of a span (:func:`judge`).

    Parameters
    ----------
    key : str
        ``short_translation_mse``, ``short_rotation_mse``, ``long_translation_mse``,
        ``distance_scale`` or ``turn_scale``.
    before, after : float
        The figure before and after the calibration (SI: m^2, rad^2, or a ratio).
    passed : bool or None
        Whether the rule holds; None when it does not apply (no relations for it).
    """

    key: str
    before: float
    after: float
    passed: bool | None

    @property
    def test(self) -> str:
        """The rule in words."""
        if self.key.startswith("short"):
            return f"after <= before + {SHORT_MSE_TOLERANCE:.0%}"
        if self.key.startswith("long"):
            return "after <= before"
        return f"|after - 1| <= {SCALE_TOLERANCE:.1%} or <= |before - 1|"

    def to_dict(self) -> dict[str, Any]:
        """As JSON: ``rule`` (the key), ``test``, ``before``, ``after`` (m^2, deg^2 or the
        ratio: the key's unit), ``passed``.

        Returns
        -------
        dict
        """
        k = _DEG * _DEG if self.key == "short_rotation_mse" else 1.0
        unit = {"short_rotation_mse": "deg2", "short_translation_mse": "m2", "long_translation_mse": "m2"}
        return {
            "rule": self.key,
            "unit": unit.get(self.key, ""),
            "test": self.test,
            "before": self.before * k,
            "after": self.after * k,
            "passed": self.passed,
        }


def judge(before: OdometryFigures, after: OdometryFigures) -> tuple[Rule, ...]:
    """The pass rules of a span (step 4 of the module docstring).

    Parameters
    ----------
    before, after : OdometryFigures
        The nominal and the calibrated odometry on the span's relations.

    Returns
    -------
    tuple of Rule
        Short translation MSE, short rotation MSE, long translation MSE, distance scale, turn
        scale.
    """

    def finite(*v: float) -> bool:
        return all(math.isfinite(x) for x in v)

    def mse(key: str, b: float, a: float, slack: float) -> Rule:
        return Rule(key, b, a, bool(a <= b * (1 + slack)) if finite(a, b) else None)

    def scale(key: str, b: float, a: float) -> Rule:
        ok = abs(a - 1) <= SCALE_TOLERANCE or abs(a - 1) <= abs(b - 1)
        return Rule(key, b, a, bool(ok) if finite(a, b) else None)

    return (
        mse(
            "short_translation_mse",
            before.short.mse_translation_m2,
            after.short.mse_translation_m2,
            SHORT_MSE_TOLERANCE,
        ),
        mse("short_rotation_mse", before.short.mse_rotation_rad2, after.short.mse_rotation_rad2, SHORT_MSE_TOLERANCE),
        mse("long_translation_mse", before.long.mse_translation_m2, after.long.mse_translation_m2, 0.0),
        scale("distance_scale", before.distance_scale, after.distance_scale),
        scale("turn_scale", before.turn_scale, after.turn_scale),
    )


@dataclass(frozen=True)
class SpanCheck:
    """The check of one span of the log.

    Parameters
    ----------
    label : str
        ``whole log``, ``window``, ``first half`` or ``second half``.
    t_start_s, t_end_s : float
        The span, from the log's first scan [s].
    scans : int
        Scans in it.
    before, after : OdometryFigures
        The nominal and the calibrated odometry on the relations inside it.
    rules : tuple of Rule
        :func:`judge`.
    """

    label: str
    t_start_s: float
    t_end_s: float
    scans: int
    before: OdometryFigures
    after: OdometryFigures
    rules: tuple[Rule, ...]

    @property
    def verdict(self) -> str:
        """``fail`` when a rule fails, else ``pass`` when one applies, else ``undetermined``."""
        states = [r.passed for r in self.rules]
        if False in states:
            return "fail"
        return "pass" if True in states else "undetermined"

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``label``, ``t_start_s``, ``t_end_s``, ``scans``, ``relations_short``,
            ``relations_long``, ``before``, ``after`` (:meth:`OdometryFigures.to_dict`),
            ``rules``, ``verdict``.
        """
        return {
            "label": self.label,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "scans": self.scans,
            "relations_short": self.before.short.count,
            "relations_long": self.before.long.count,
            "before": self.before.to_dict(),
            "after": self.after.to_dict(),
            "rules": [r.to_dict() for r in self.rules],
            "verdict": self.verdict,
        }


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


def _plausibility(
    odometry: FloatArray,
    i1: NDArray[np.int64],
    i2: NDArray[np.int64],
    reference: FloatArray,
    sensor_pose: Pose,
    fig: OdometryFigures,
    kind: str,
    src: str | None,
) -> list[str]:
    """Errors for a reference whose angles look like degrees or translations like millimetres (the
    RMS of its turns or translations about 57 or 1000 times the nominal odometry's); warnings
    for a nominal odometry whose scale is far from 1."""
    q = in_sensor_frame(se2.between(odometry[i1], odometry[i2]), sensor_pose)
    turn = odometry[i2, 2] - odometry[i1, 2]
    for name, mine, theirs, factor, unit, want in (
        ("turn", turn, reference[:, 2], _DEG, "degrees", "radians"),
        ("move", np.hypot(q[:, 0], q[:, 1]), np.hypot(reference[:, 0], reference[:, 1]), 1e3, "millimetres", "metres"),
    ):
        den = float(mine @ mine)
        if len(mine) < 5 or not den > 0:
            continue
        ratio = math.sqrt(float(theirs @ theirs) / den)
        if factor / 3 < ratio < 3 * factor:
            what = "angles" if unit == "degrees" else "translations"
            raise InputError(
                f"the {kind} {name} about {ratio:.0f} times as much as the odometry: their {what} look like "
                f"{unit}; {want} are expected",
                src,
            )
    out = []
    for name, v in (("distance", fig.distance_scale), ("turn", fig.turn_scale)):
        if math.isfinite(v) and not 0.5 <= v <= 2.0:
            hint = " (wheel angles in degrees?)" if 30 < v < 120 else ""
            out.append(
                f"the nominal odometry's {name} scale against the {kind} is {v:.4g}: a wrong nominal geometry "
                f"(`wheel_diameter_m`, `wheelbase_m`), wheel data in other units{hint}, or a reference of another log?"
            )
    return out


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


def _reference_relations(
    reference: Relations | Trajectory,
    scan_t_s: FloatArray,
    reference_frame: str,
    nominal_pose: Pose,
    short_max_s: float,
    tolerance_s: float,
    span_s: float,
) -> tuple[Relations, str | None, int | None, str, list[str]]:
    """The relations (a trajectory's made at the window's scans), their mode, scans with a pose, kind, warnings."""
    if not isinstance(reference, Trajectory):
        return reference, None, None, "relations", []
    rel, mode, with_pose = relations_from_trajectory(
        reference,
        scan_t_s,
        sensor_pose=nominal_pose if reference_frame == "base" else None,
        short_max_s=short_max_s,
        tolerance_s=tolerance_s,
    )
    covered = (rel.t2_s.max() - rel.t1_s.min()) if len(rel) else 0.0
    warnings: list[str] = []
    if covered < 0.9 * span_s:
        warnings.append(
            f"the trajectory covers {covered:.1f} s of the {span_s:.1f} s checked: the rest has no relations"
        )
    return rel, mode, with_pose, "trajectory", warnings


# a trajectory of the base frame that agrees this many times better (mean squared error of the short
# relations, as MISTAKE_RATIO's) with the calibrated odometry as the robot's true base trajectory than
# as a SLAM's is read as the robot's true base trajectory
TRUE_BASE_RATIO = 2.0


def _read_base(odo: _Odometries, sel: NDArray[np.bool_]) -> tuple[_Odometries, str, list[str]]:
    """How to read a trajectory of the base frame: a SLAM's (its poses the lidar's through the nominal
    lidar pose it ran with: turned back with it, for both odometries) or the robot's true base
    trajectory (a motion capture's or a simulation's: each odometry compared with it through its own
    lidar pose, the calibrated one after), whichever the calibrated odometry agrees with
    :data:`TRUE_BASE_RATIO` times better (a SLAM's when they agree alike); the odometries with the
    reference after, ``slam`` or ``true``, and a note of the latter."""
    if int(sel.sum()) < 5 or odo.poses.after == odo.poses.nominal:
        return odo, "slam", []
    base = in_sensor_frame(odo.reference, se2.inverse(np.asarray(odo.poses.nominal, dtype=float)))
    truth = in_sensor_frame(base, odo.poses.after)
    q = in_sensor_frame(se2.between(odo.after[odo.k1[sel]], odo.after[odo.k2[sel]]), odo.poses.after)

    def mse(reference: FloatArray) -> float:
        et, er = relation_errors(q, reference[sel])
        return float(np.mean(et**2 + er**2))

    if TRUE_BASE_RATIO * mse(truth) < mse(odo.reference):
        note = (
            "the trajectory agrees with the calibrated odometry as the robot's true base trajectory (a motion "
            "capture's or a simulation's), not as a SLAM's made with the nominal lidar pose: each odometry is "
            "compared with it through its own lidar pose"
        )
        return replace(odo, reference_after=truth), "true", [note]
    return odo, "slam", []


# a reference that agrees with the odometry this many times better (mean squared error of the
# short relations, translation plus rotation at 1 m per radian) after undoing a likely mistake
# than as given, and misses it by more than MISTAKE_FLOOR_M2 as given, is refused as that mistake
MISTAKE_RATIO = 10.0
MISTAKE_FLOOR_M2 = 1e-4


def _alternatives(
    reference: Relations | Trajectory,
    rel: Relations,
    scan_t_s: FloatArray,
    reference_frame: str,
    nominal_pose: Pose,
    short_max_s: float,
    tolerance_s: float,
) -> list[tuple[str, str, FloatArray]]:
    """The relations (the same pairs) as the likely mistakes would have them: what was undone,
    the mistake, the relations' poses."""
    if isinstance(reference, Relations):
        return [
            (
                "inverted",
                "timestamp1 and timestamp2 look exchanged (a relation is the pose at timestamp2 in the frame of the "
                "pose at timestamp1)",
                se2.inverse(rel.pose),
            ),
            (
                "mirrored",
                "they look mirrored: y and the yaw negated (a frame with y to the right?)",
                rel.pose * np.array([1.0, -1.0, -1.0]),
            ),
        ]
    lp = np.asarray(nominal_pose, dtype=float)
    other = "sensor" if reference_frame == "base" else "base"
    out = [
        (
            f"made as the {other} frame's poses",
            f"the trajectory looks like the {other} frame's, not the {reference_frame} frame's: give "
            f"`reference_frame` {other}",
            in_sensor_frame(rel.pose, se2.inverse(lp) if reference_frame == "base" else lp),
        )
    ]
    p = reference.pose
    for undone, mistake, pose in (
        (
            "made with x and y exchanged",
            "the trajectory's x and y look exchanged (it is mirrored; a TUM line is timestamp x y z qx qy qz qw)",
            p[:, [1, 0, 2]],
        ),
        ("made with y negated", "the trajectory's y looks negated (it is mirrored)", p * np.array([1.0, -1.0, 1.0])),
        (
            "made mirrored back",
            "the trajectory looks mirrored: y and the heading negated (a frame with y to the right?)",
            p * np.array([1.0, -1.0, -1.0]),
        ),
    ):
        alt, _, _ = relations_from_trajectory(
            Trajectory(reference.t_s, pose, reference.source),
            scan_t_s,
            sensor_pose=lp if reference_frame == "base" else None,
            short_max_s=short_max_s,
            tolerance_s=tolerance_s,
        )
        if len(alt) == len(rel) and np.array_equal(alt.t1_s, rel.t1_s) and np.array_equal(alt.t2_s, rel.t2_s):
            out.append((undone, mistake, alt.pose))
    return out


def _refuse_mistakes(
    odo: _Odometries,
    sel: NDArray[np.bool_],
    alternatives: list[tuple[str, str, FloatArray]],
    what: str,
    src: str | None,
) -> None:
    """Refuse a reference that agrees with the odometry (before or after the calibration,
    whichever agrees better) :data:`MISTAKE_RATIO` times better with a likely mistake undone."""
    if int(sel.sum()) < 5:
        return

    def mse(reference: FloatArray) -> float:
        best = math.inf
        for o, pose in ((odo.before, odo.poses.nominal), (odo.after, odo.poses.after)):
            q = in_sensor_frame(se2.between(o[odo.k1[sel]], o[odo.k2[sel]]), pose)
            et, er = relation_errors(q, reference[sel])
            best = min(best, float(np.mean(et**2 + er**2)))
        return best

    given = mse(odo.reference)
    if not given > MISTAKE_FLOOR_M2:
        return
    for undone, mistake, alt in alternatives:
        other = mse(alt)
        if MISTAKE_RATIO * other < given:
            raise InputError(
                f"the {what} disagree with the odometry {math.sqrt(given / max(other, 1e-300)):,.0f} times more as "
                f"given than {undone} (RMS over {int(sel.sum())} short relations): {mistake}",
                src,
            )


@dataclass(frozen=True)
class _Matched:
    """The scans each relation joins, the relations used (inside the window, with wheel data) and the others' counts."""

    k1: NDArray[np.int64]
    k2: NDArray[np.int64]
    inside: NDArray[np.bool_]
    unmatched: int
    without_wheel_data: int
    outside_window: int


def _match_relations(
    rel: Relations,
    st: FloatArray,
    wheel_t_s: FloatArray,
    in_win: NDArray[np.bool_],
    delay: float,
    tol: float,
    window: tuple[float, float],
    src: str,
) -> tuple[_Matched, list[str]]:
    """Each relation's stamps matched to scans; those without scans, without wheel data or outside the window."""
    k1, off1 = _nearest(st, rel.t1_s)
    k2, off2 = _nearest(st, rel.t2_s)
    matched = (off1 <= tol) & (off2 <= tol) & (k1 != k2)
    n_rel = len(rel)
    if not matched.any():
        j = int(np.argmin(np.minimum(off1, off2)))
        raise InputError(
            f"none of the {n_rel} relations has scans at its stamps (within `tolerance_s` {tol:g} s; the nearest "
            f"scan to a relation's stamp is {min(off1[j], off2[j]):.3f} s away; the scans span {st[0]:.3f} to "
            f"{st[-1]:.3f} s): are these the relations of this log?",
            rel.source,
        )
    warnings: list[str] = []
    unmatched = int((~matched).sum())
    if unmatched:
        bad = int(np.flatnonzero(~matched)[0])
        line = f" (the first on line {int(rel.lines[bad])})" if rel.lines is not None else ""
        warnings.append(
            f"{unmatched} of {n_rel} relations have a stamp without a scan within `tolerance_s` {tol:g} s{line}: "
            "not used"
        )
    wt = wheel_t_s
    has_wheels = (st - delay >= wt[0]) & (st - delay <= wt[-1])
    wheeled = matched & has_wheels[k1] & has_wheels[k2]
    without = int((matched & ~wheeled).sum())
    if without:
        warnings.append(
            f"{without} relations join scans outside the wheel data's time span ({wt[0]:.3f} to {wt[-1]:.3f} s, "
            f"with the scan delay {delay:g} s): not used"
        )
    inside = wheeled & in_win[k1] & in_win[k2]
    outside = int((wheeled & ~inside).sum())
    if not inside.any():
        lo, hi = window
        raise InputError(
            f"no relation with wheel data lies inside the window {lo:g} to {hi:g} s ({int(wheeled.sum())} outside it)",
            src,
        )
    return _Matched(k1, k2, inside, unmatched, without, outside), warnings


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


def _reference_summary(
    kind: str,
    reference: Relations | Trajectory,
    rel: Relations,
    matched: _Matched,
    reference_frame: str,
    with_pose: int | None,
    mode: str | None,
) -> ReferenceSummary:
    """The reference and what became of its relations (a trajectory's frame and poses for a trajectory)."""
    return ReferenceSummary(
        kind,
        rel.source if kind == "relations" else reference.source,
        len(rel),
        matched.unmatched,
        matched.without_wheel_data,
        matched.outside_window,
        reference_frame if kind == "trajectory" else None,
        len(reference) if kind == "trajectory" else None,
        with_pose,
        mode,
    )


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
