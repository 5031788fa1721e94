"""The self-calibration of pooled intervals (step 5 of :mod:`umbmark.realrobot.selfcal`): the
intervals of several inputs pooled, in blocks of time per input (:func:`interval_blocks`), the
estimate (:func:`selfcal_report`) and its report (:class:`SelfcalReport`, the JSON of
``umbmark selfcal``), with the warnings of an estimated sensor pose far from ``/tf_static``'s and
the refusals of intervals files whose columns the fit shows misread.

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports these
names). Imports numpy, :mod:`umbmark.model.intervals`, :mod:`umbmark.correct.selfcal` (the
estimate), :mod:`umbmark.correct.noise` and the other parts of the self-calibration
(:mod:`~umbmark.realrobot.selfcal_tf`, :mod:`~umbmark.realrobot.selfcal_match`,
:mod:`~umbmark.realrobot.selfcal_history`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark.correct.noise import OdometryNoise
from umbmark.correct.selfcal import SelfcalResult, selfcal
from umbmark.correct.selfcal.estimate import BLOCK_S, MAX_BLOCKS
from umbmark.errors import InputError
from umbmark.model.intervals import Intervals, IntervalSteps
from umbmark.realrobot.selfcal_history import selfcal_history_fields
from umbmark.realrobot.selfcal_match import ScanIntervals
from umbmark.realrobot.selfcal_tf import BASE_FRAMES

__all__ = [
    "POSE_WARN_M",
    "POSE_WARN_RAD",
    "SIDEWAYS_RAD",
    "MISREAD_COST",
    "MISREAD_SIZE",
    "SelfcalReport",
    "interval_blocks",
    "selfcal_report",
]

POSE_WARN_M, POSE_WARN_RAD = 0.01, math.radians(1.0)
"""An estimated sensor pose further than these from the ``/tf_static`` one is reported."""


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
