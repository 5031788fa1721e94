"""The figures and the rules of a calibration's check (steps 3-4 of :mod:`umbmark.realrobot.validate`):
the benchmark's error of a relation (:func:`relation_errors`, of an odometry seen from the lidar:
:func:`in_sensor_frame`), its statistics over a set of relations (:class:`ErrorStats`), the
systematic errors fitted on them (:class:`SystematicErrors`), the scales of distances and turns
(:func:`magnitude_scale`), one odometry's figures on a span (:class:`OdometryFigures`), the pass
rules (:class:`Rule`, :func:`judge`) and a span's check (:class:`SpanCheck`).

Part of the check of a calibration on a real log (:mod:`umbmark.realrobot.validate`, which
re-exports these names; also :mod:`umbmark.studies.slam2d`'s metric). Imports numpy,
:mod:`umbmark.errors` and :mod:`umbmark.model.se2`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2

__all__ = [
    "MIN_DISTANCE_M",
    "MIN_TURN_RAD",
    "SHORT_MSE_TOLERANCE",
    "SCALE_TOLERANCE",
    "relation_errors",
    "in_sensor_frame",
    "ErrorStats",
    "SystematicErrors",
    "magnitude_scale",
    "OdometryFigures",
    "Rule",
    "judge",
    "SpanCheck",
]

MIN_DISTANCE_M = 0.2
"""The distance scale is measured on short relations longer than this [m]."""

MIN_TURN_RAD = math.radians(10.0)
"""The turn scale is measured on short relations turning more than this [rad]."""

SHORT_MSE_TOLERANCE = 0.02
"""A short-relation MSE after the calibration may be this fraction above the one before."""

SCALE_TOLERANCE = 0.015
"""A scale after the calibration within this of 1 passes (else it must be no farther from 1 than before)."""

# a relations file whose turns are about this many times the odometry's is in degrees
_DEG = math.degrees(1.0)

FloatArray = NDArray[np.float64]


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
