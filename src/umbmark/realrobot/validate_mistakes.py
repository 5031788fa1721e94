"""The refusals of mistaken references in a calibration's check (:mod:`umbmark.realrobot.validate`):
a reference that agrees with the odometry far better with a likely mistake undone (timestamps
exchanged, mirrored, x and y exchanged, the other frame's poses) is refused naming the mistake;
one whose angles look like degrees or translations like millimetres too; a trajectory of the base
frame is read as a SLAM's or as the robot's true one, whichever the calibrated odometry agrees
with.

Part of the check of a calibration on a real log (:mod:`umbmark.realrobot.validate`). Imports
numpy, :mod:`umbmark.errors`, :mod:`umbmark.model.se2`, the readers' types
(:mod:`umbmark.io.relations`, :mod:`umbmark.io.tum`) and the other parts of the check
(:mod:`~umbmark.realrobot.validate_figures`, :mod:`~umbmark.realrobot.validate_odometry`,
:mod:`~umbmark.realrobot.validate_reference`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError
from umbmark.io.relations import Relations
from umbmark.io.tum import Trajectory
from umbmark.model import se2
from umbmark.model.se2 import Pose
from umbmark.realrobot.validate_figures import _DEG, OdometryFigures, in_sensor_frame, relation_errors
from umbmark.realrobot.validate_odometry import _Odometries
from umbmark.realrobot.validate_reference import relations_from_trajectory

__all__ = ["TRUE_BASE_RATIO", "MISTAKE_RATIO", "MISTAKE_FLOOR_M2"]

FloatArray = NDArray[np.float64]


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
