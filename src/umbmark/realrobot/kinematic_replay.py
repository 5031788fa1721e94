"""A tricycle's or mecanum robot's geometry against a ground truth (motion capture, a simulator's pose).

The tracked point is a marker somewhere on the robot: its poses ``m(t) = x(t) (+) l`` are the
robot's poses composed with the marker's pose ``l`` on the robot, which is fitted with the
geometry (a marker ahead of the axle is the usual case). Along the path, keyframes are chosen
on the ground truth (:class:`~umbmark.realrobot.selfcal.KeyframeRule`, by default
:data:`~umbmark.realrobot.selfcal.DEFAULT_KEYFRAMES`); between two keyframes the joints' steps
predict the robot's motion and ``l^-1 (+) q (+) l`` the marker's, which the ground truth
measures: least squares over the path's relative motions, with the self-calibration's
estimator (:func:`umbmark.correct.selfcal.kinematic.kinematic_selfcal`: robust start, Student t
noise, outliers, intervals). The ground truth's delay behind the joints is estimated first from
the turns (:func:`umbmark.realrobot.selfcal.delay_from_turns`), or given.

What it did for the odometry: the relative pose error of the dead reckoning over windows of
``window_s`` along the path, with the nominal and with the calibrated geometry (the robot's
motion over each window from the ground truth, the marker taken off).

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io`, :mod:`umbmark.correct.selfcal` and
:mod:`umbmark.realrobot`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark.correct.selfcal.kinematic import KinematicSelfcalResult, kinematic_selfcal
from umbmark.errors import InputError
from umbmark.io.rosbag import JointTruthBag, read_joint_truth_bag
from umbmark.model import se2
from umbmark.model.kinematics import JointIntervals, Kinematics, integrate_steps, twist_displacement
from umbmark.realrobot.kinematic import _grid_of, _moving, _steps_of, _wheel_odometry, joint_source
from umbmark.realrobot.selfcal import DEFAULT_KEYFRAMES, KeyframeRule, delay_from_turns

__all__ = ["KinematicReplay", "kinematic_replay", "kinematic_replay_from_bag", "WINDOW_S"]

FloatArray = NDArray[np.float64]

WINDOW_S = 10.0
"""The windows of the relative pose error [s]."""


@dataclass(frozen=True, eq=False)
class KinematicReplay:
    """A geometry fitted to a ground truth, and what it does for the odometry.

    Attributes
    ----------
    result : KinematicSelfcalResult
        The geometry; its ``sensor_pose`` is the tracked marker's pose on the robot.
    time_offset_s : float
        The ground truth's delay behind the joints applied [s].
    time_offset_estimated : bool
    intervals : int
        Keyframe intervals fitted.
    rpe_before_m, rpe_after_m : float
        Root-mean-square translation error of the dead reckoning over windows of
        :attr:`window_s`, with the nominal and the calibrated geometry [m].
    rpe_heading_before_rad, rpe_heading_after_rad : float
        The same for the heading [rad].
    window_s : float
    windows : int
    source : str
    warnings : tuple of str
    """

    result: KinematicSelfcalResult
    time_offset_s: float
    time_offset_estimated: bool
    intervals: int
    rpe_before_m: float
    rpe_after_m: float
    rpe_heading_before_rad: float
    rpe_heading_after_rad: float
    window_s: float
    windows: int
    source: str
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """As JSON: the self-calibration's keys (:meth:`KinematicSelfcalResult.to_dict`) with the
        marker's pose as ``marker_pose`` (and ``sensor_pose``), ``method`` (``lsq``),
        ``time_offset_s``, ``time_offset_estimated``, ``relative_pose_error`` (``window_s``,
        ``windows``, ``before_mm``, ``after_mm``, ``heading_before_deg``, ``heading_after_deg``,
        ``improvement``) and ``path``."""
        out = self.result.to_dict()
        out["method"] = "lsq"
        out["marker_pose"] = out["sensor_pose"]
        out["warnings"] = list(self.warnings) + out["warnings"]
        out["time_offset_s"] = self.time_offset_s
        out["time_offset_estimated"] = self.time_offset_estimated
        out["relative_pose_error"] = {
            "window_s": self.window_s,
            "windows": self.windows,
            "before_mm": self.rpe_before_m * 1e3,
            "after_mm": self.rpe_after_m * 1e3,
            "heading_before_deg": math.degrees(self.rpe_heading_before_rad),
            "heading_after_deg": math.degrees(self.rpe_heading_after_rad),
            "improvement": self.rpe_before_m / self.rpe_after_m if self.rpe_after_m > 0 else None,
        }
        out["path"] = self.source
        return out


def _delay(bag: JointTruthBag, nominal: Kinematics, wt: FloatArray, gt: FloatArray) -> float:
    """The ground truth's delay behind the joints, from the turns over 0.5 s apart."""
    heading = _wheel_odometry(bag, nominal)[:, 2]
    step = max(1, int(round(0.5 / max(float(np.median(np.diff(gt[:, 0]))), 1e-6))))
    idx = np.arange(0, len(gt) - step, step)
    inside = (gt[idx, 0] > wt[0] + 0.4) & (gt[idx + step, 0] < wt[-1] - 0.4)
    idx = idx[inside]
    turn = gt[idx + step, 3] - gt[idx, 3]
    return delay_from_turns(wt, heading, gt[idx, 0], gt[idx + step, 0], turn, 0.0, source=bag.source).delay_s


def _rpe(
    t: FloatArray, truth_robot: FloatArray, odo: dict[str, FloatArray], window_s: float
) -> tuple[dict[str, tuple[float, float]], int]:
    """Per odometry: the RMS translation and heading error of its motion over consecutive windows."""
    edges = np.arange(t[0], t[-1], window_s)
    if len(edges) < 2:
        return {k: (math.nan, math.nan) for k in odo}, 0
    a, b = np.searchsorted(t, edges[:-1]), np.searchsorted(t, edges[1:])
    true = se2.between(truth_robot[a], truth_robot[b])
    out = {}
    for k, p in odo.items():
        est = se2.between(p[a], p[b])
        err = se2.between(est, true)
        out[k] = (float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))), float(np.sqrt(np.mean(err[:, 2] ** 2))))
    return out, len(a)


def kinematic_replay(
    bag: JointTruthBag,
    nominal: Kinematics,
    *,
    time_offset: float | str = "auto",
    keyframes: KeyframeRule = DEFAULT_KEYFRAMES,
    fit: Sequence[str] | None = None,
    window_s: float = WINDOW_S,
) -> KinematicReplay:
    """Fit a tricycle's or mecanum robot's geometry and the marker's pose to a ground truth (module docstring).

    Parameters
    ----------
    bag : JointTruthBag
        Joints and ground truth (:func:`umbmark.io.rosbag.read_joint_truth_bag`).
    nominal : Kinematics
    time_offset : float or "auto"
        The ground truth's delay behind the joints [s] (positive: late), or estimated.
    keyframes : KeyframeRule
        On the ground truth.
    fit : sequence of str, optional
        The geometry parameters to fit (default :func:`kinematic_selfcal`'s).
    window_s : float
        The windows of the relative pose error [s].

    Returns
    -------
    KinematicReplay

    Raises
    ------
    InputError
        A ground truth that does not overlap the joints, no motion, too few intervals, or what
        the estimator refuses.
    """
    src = bag.source
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    gt = np.asarray(bag.truth, dtype=float).copy()
    warnings: list[str] = list(bag.warnings)
    estimated = time_offset == "auto"
    if estimated:
        try:
            delay = _delay(bag, nominal, wt, gt)
        except InputError as err:
            delay = 0.0
            warnings.append(f"the ground truth's delay is not estimated ({err.message}): stamps as recorded")
    else:
        delay = float(time_offset)
        if not math.isfinite(delay):
            raise InputError(f"`time_offset` must be 'auto' or seconds, got {time_offset!r}")
    gt[:, 0] -= delay
    usable = (gt[:, 0] >= wt[0]) & (gt[:, 0] <= wt[-1])
    if usable.sum() < 3:
        raise InputError(
            f"the ground truth ({gt[0, 0]:.3f} to {gt[-1, 0]:.3f} s) and the joints ({wt[0]:.3f} to {wt[-1]:.3f} s) "
            "hardly overlap in time: record both in one bag, stamped by one clock",
            src,
        )
    grid = _grid_of(wt, np.asarray(bag.joint_positions, float), nominal, gt[:, 0], usable)
    pairs = np.array(keyframes.select(gt[:, 0], gt[:, 1:], usable), dtype=np.int64).reshape(-1, 2)
    moving = _moving(grid, pairs, nominal)
    pairs = pairs[moving]
    if len(pairs) < 10:
        raise InputError(f"only {len(pairs)} stretches of the path with motion: drive longer", src)
    steps = _steps_of(grid, pairs)
    dt = gt[pairs[:, 1], 0] - gt[pairs[:, 0], 0]
    seen = se2.between(gt[pairs[:, 0], 1:], gt[pairs[:, 1], 1:])
    iv = JointIntervals(dt, steps, seen, src, ())
    result = kinematic_selfcal(iv, nominal, fit=fit)
    # the dead reckoning over windows, the marker taken off the ground truth
    lp = np.asarray(result.sensor_pose, dtype=float)
    robot = se2.compose(gt[usable, 1:], se2.inverse(lp))
    robot[:, 2] = gt[usable, 3] - lp[2]
    tu = gt[usable, 0]
    odo = {}
    for name, k in (("before", nominal), ("after", result.kinematics)):
        path = integrate_steps(twist_displacement(k.twist(grid.steps_values)))
        odo[name] = path[grid.scan_index[usable]]
    rpe, n = _rpe(tu, robot, odo, window_s)
    return KinematicReplay(
        result=result,
        time_offset_s=delay,
        time_offset_estimated=estimated,
        intervals=len(iv),
        rpe_before_m=rpe["before"][0],
        rpe_after_m=rpe["after"][0],
        rpe_heading_before_rad=rpe["before"][1],
        rpe_heading_after_rad=rpe["after"][1],
        window_s=window_s,
        windows=n,
        source=src,
        warnings=tuple(warnings),
    )


def kinematic_replay_from_bag(
    path: str | Path,
    nominal: Kinematics,
    joints: Sequence[str],
    *,
    gt_topic: str,
    gt_frame: str | None = None,
    gt_parent: str | None = None,
    joint_topic: str = "/joint_states",
    time_offset: float | str = "auto",
    fit: Sequence[str] | None = None,
) -> KinematicReplay:
    """:func:`kinematic_replay` of a bag: read its joints (in the kind's roles' order) and ground truth.

    Raises
    ------
    InputError
        As :func:`umbmark.io.rosbag.read_joint_truth_bag` and :func:`kinematic_replay`.
    """
    source = joint_source(nominal, joints, joint_topic)
    bag = read_joint_truth_bag(path, wheels=source, gt_topic=gt_topic, gt_frame=gt_frame, gt_parent=gt_parent)
    return kinematic_replay(bag, nominal, time_offset=time_offset, fit=fit)
