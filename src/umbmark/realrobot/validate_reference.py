"""The reference of a calibration's check (step 2 of :mod:`umbmark.realrobot.validate`): relations
made from a trajectory (:func:`relations_from_trajectory`), the relations of the window, each
relation's stamps matched to scans and those without scans, without wheel data or outside the
window counted, and the summary of what became of them (:class:`ReferenceSummary`).

Part of the check of a calibration on a real log (:mod:`umbmark.realrobot.validate`, which
re-exports these names). Imports numpy, :mod:`umbmark.errors`, :mod:`umbmark.model.se2` and the
readers' types (:mod:`umbmark.io.relations`, :mod:`umbmark.io.tum`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.relations import Relations
from umbmark.io.tum import Trajectory
from umbmark.model import se2
from umbmark.model.se2 import Pose

__all__ = [
    "SHORT_MAX_S",
    "STAMP_TOLERANCE_S",
    "TRAJECTORY_MAX_GAP_S",
    "REFERENCE_FRAMES",
    "relations_from_trajectory",
    "ReferenceSummary",
]

SHORT_MAX_S = 10.0
"""A relation spanning less than this is short [s] (the benchmark's are 0.1 to 10 s, or loops)."""

STAMP_TOLERANCE_S = 1e-3
"""How far a relation's stamp may be from its scan's [s] (the benchmark's are to 5 us)."""

TRAJECTORY_MAX_GAP_S = 1.0
"""A trajectory is not interpolated across a gap between its poses longer than this [s]."""

REFERENCE_FRAMES = ("base", "sensor")
"""Whose poses a trajectory holds: the robot's base frame (as a SLAM publishes them) or the lidar's."""

FloatArray = NDArray[np.float64]


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
