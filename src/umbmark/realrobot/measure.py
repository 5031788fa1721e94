"""From tape-measured wall distances to a runs-file row (the paper's section 3.1).

The start area is the corner of two perpendicular walls. Measuring the distances from three
marked points on the robot to the walls fixes its position and orientation, before and after
each run; the end pose expressed in the start pose's frame is the runs file's
``x_abs, y_abs, theta_abs``.

Conventions (SI inside; the CLI and the distances file use millimetres and degrees):

* **Robot frame**: origin at the point the odometry tracks (the wheel-axle midpoint), x forward,
  y to the left.
* **Marks**: ``front`` and ``rear`` are two points on the robot's side that faces the *side
  wall*; ``back`` is a point at the robot's back, measured to the *back wall*. Each distance is
  the shortest (perpendicular) distance from the mark to the wall.
* **Wall frame**: origin at the corner, X along the side wall pointing the way the robot faces
  at the start (away from the back wall), Y to the left of X. The back wall is the line X = 0;
  the side wall is the line Y = 0, on the robot's right (``side_wall="right"``, robot at Y > 0)
  or on its left (``side_wall="left"``, robot at Y < 0).
* The pose of the robot in the wall frame follows from
  ``d_front - d_rear = s * ((f_x - r_x) sin(theta) + (f_y - r_y) cos(theta))`` (s = +1 for a wall on
  the right, -1 on the left; of the two solutions the one nearest the nominal heading 0 is taken),
  then ``Y = s * d_front - (f_x sin(theta) + f_y cos(theta))`` and
  ``X = d_back - (b_x cos(theta) - b_y sin(theta))``.
* **Return pose in the start frame**: ``T_start^-1 * T_end``.

Uncertainty: each distance is read off a tape with graduations ``resolution``; the reading error
is taken as uniform in +-resolution/2 (standard deviation ``resolution / sqrt(12)``) and
independent between readings. It is propagated to x, y, theta linearly (the Jacobian of the
whole computation, by central differences): ``*_sd`` is the resulting standard deviation and
``*_bound`` the worst case ``sum |J_i| * resolution / 2``.

The distances file (the readings as typed, millimetres) is read by
:mod:`umbmark.io.distances_csv`.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io._text import csv_writer
from umbmark.io.distances_csv import MAX_TAPE_MM, MeasuredRun
from umbmark.model.geometry import ROBOT_SIZES_M, wrap_angle
from umbmark.model.runs import DIRECTIONS, RunsTable

__all__ = [
    "RobotMarks",
    "WallPose",
    "Measurement",
    "MeasuredRuns",
    "pose_from_distances",
    "distances_from_pose",
    "distances_for_runs",
    "relative_pose",
    "marks_for_direction",
    "measure",
    "measure_run",
    "measure_runs",
    "format_measured_csv",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RobotMarks:
    """The three reference points on the robot and the side the side wall is on at the start.

    Attributes
    ----------
    front, rear : (float, float)
        Two points on the robot's side that faces the side wall, in the robot frame [m]
        (at least 1 mm apart).
    back : (float, float)
        A point at the robot's back, measured to the back wall [m].
    side_wall : str
        ``right`` or ``left``: the side of the robot the side wall is on.

    Raises
    ------
    InputError
        A point that is not two finite numbers, front and rear too close, another side; points
        beyond the largest robot (:data:`~umbmark.model.geometry.ROBOT_SIZES_M`) or all within
        the smallest; the front point not ahead of the rear one, the back point not behind the
        front one.
    """

    front: tuple[float, float]
    rear: tuple[float, float]
    back: tuple[float, float]
    side_wall: str = "right"

    def __post_init__(self) -> None:
        if self.side_wall not in ("right", "left"):
            raise InputError(f"side wall must be 'right' or 'left', got {self.side_wall!r}")
        for name in ("front", "rear", "back"):
            p = getattr(self, name)
            if len(p) != 2 or not all(math.isfinite(float(v)) for v in p):
                raise InputError(f"reference point {name} must be two finite numbers (x, y), got {p!r}")
        self._check_on_a_robot()
        if math.hypot(self.front[0] - self.rear[0], self.front[1] - self.rear[1]) < 1e-3:
            raise InputError(
                "the front and rear reference points must be at least 1 mm apart "
                "(their distances to the side wall give the orientation)"
            )
        self._check_order()

    def _check_on_a_robot(self) -> None:
        """Refuse points no robot carries: beyond the largest robot, or all within the smallest."""
        lo, hi = ROBOT_SIZES_M["wheelbase"]
        points = {"front": self.front, "rear": self.rear, "back": self.back}
        for name, p in points.items():
            if math.hypot(*p) > hi:
                raise InputError(
                    f"reference point {name} ({p[0] * 1e3:g}, {p[1] * 1e3:g}) mm is {math.hypot(*p):g} m from the "
                    "robot's origin: "
                    f"no robot is that large (at most {hi:g} m); check the point and its unit"
                )
        if max(math.hypot(*p) for p in points.values()) < lo / 2:
            raise InputError(
                f"the reference points all lie within {lo / 2 * 1e3:g} mm of the robot's origin: no robot is that "
                f"small (at least {lo * 1e3:g} mm); check their unit (metres where millimetres are expected?)"
            )

    def _check_order(self) -> None:
        """Refuse front and rear (or the back point) in the wrong order along x (forward)."""
        if self.front[0] <= self.rear[0]:
            raise InputError(
                f"the front reference point (x = {self.front[0] * 1e3:g} mm) is not ahead of the rear one (x = "
                f"{self.rear[0] * 1e3:g} mm; x points forward): front and rear exchanged?"
            )
        if self.back[0] >= self.front[0]:
            raise InputError(
                f"the back reference point (x = {self.back[0] * 1e3:g} mm) is not behind the front one (x = "
                f"{self.front[0] * 1e3:g} mm; x points forward): the sign of its x?"
            )

    @property
    def sign(self) -> float:
        """+1 for a side wall on the robot's right, -1 on its left."""
        return 1.0 if self.side_wall == "right" else -1.0

    def mirrored(self) -> RobotMarks:
        """The marks mirrored about the robot's centre line (y -> -y), side wall swapped.

        Returns
        -------
        RobotMarks
        """
        m = lambda p: (float(p[0]), -float(p[1]))  # noqa: E731
        return RobotMarks(m(self.front), m(self.rear), m(self.back), "left" if self.side_wall == "right" else "right")


def marks_for_direction(marks: RobotMarks, direction: str, side_wall: str = "auto") -> RobotMarks:
    """The marks used for the runs of one direction.

    Parameters
    ----------
    marks : RobotMarks
        The marks as given.
    direction : str
        ``cw`` or ``ccw``.
    side_wall : str
        ``auto``: the square turns away from the side wall, so the wall is on the robot's left
        for cw runs and on its right for ccw runs; the front and rear marks are taken on that
        side (mirrored about the centre line when they were given on the other side, i.e. the
        robot carries the same marks on both sides). ``left`` / ``right``: the wall is on that
        side for every run and the marks are used as given.

    Returns
    -------
    RobotMarks

    Raises
    ------
    InputError
        Another ``side_wall``.
    """
    if side_wall in ("left", "right"):
        return RobotMarks(marks.front, marks.rear, marks.back, side_wall)
    if side_wall != "auto":
        raise InputError(f"side wall must be auto, left or right, got {side_wall!r}")
    want = "left" if direction == "cw" else "right"
    base = RobotMarks(marks.front, marks.rear, marks.back, "right" if marks.front[1] <= 0 else "left")
    return base if base.side_wall == want else base.mirrored()


@dataclass(frozen=True)
class WallPose:
    """The pose of the robot frame in the wall frame; arrays or scalars.

    Attributes
    ----------
    x, y : numpy.ndarray
        Position [m] (X along the side wall, away from the back wall).
    theta : numpy.ndarray
        Heading [rad] from X.
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray


def distances_from_pose(marks: RobotMarks, pose: WallPose) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The three distances a person would measure from a pose.

    Parameters
    ----------
    marks : RobotMarks
        The reference points.
    pose : WallPose
        The robot's pose in the wall frame.

    Returns
    -------
    d_front, d_rear, d_back : numpy.ndarray
        Front and rear mark to the side wall, back mark to the back wall [m].

    Raises
    ------
    InputError
        A mark would be behind its wall.
    """
    x, y, th = (np.asarray(v, dtype=float) for v in (pose.x, pose.y, pose.theta))
    c, s = np.cos(th), np.sin(th)

    def world(p: tuple[float, float]) -> tuple[FloatArray, FloatArray]:
        return x + p[0] * c - p[1] * s, y + p[0] * s + p[1] * c

    d_front = marks.sign * world(marks.front)[1]
    d_rear = marks.sign * world(marks.rear)[1]
    d_back = world(marks.back)[0]
    if np.any(d_front < 0) or np.any(d_rear < 0) or np.any(d_back < 0):
        raise InputError("a reference point is behind its wall in this pose")
    return d_front, d_rear, d_back


def distances_for_runs(
    marks: RobotMarks, runs: RunsTable, start: WallPose, side_wall: str | None = "auto"
) -> FloatArray:
    """The six distances a person would measure for each run: the forward model of
    :func:`measure`, for tests and examples.

    Parameters
    ----------
    marks : RobotMarks
        The reference points.
    runs : RunsTable
        The runs; each stops at its true end pose (``x_abs, y_abs, theta_abs`` in the start frame).
    start : WallPose
        Where each run starts, in the wall frame (arrays of length n or scalars).
    side_wall : str or None
        As in :func:`marks_for_direction` (None: ``marks`` as they are). With ``auto`` the
        start's Y is taken as given for ccw runs (wall on the right, Y > 0) and mirrored
        (Y -> -Y, theta -> -theta) for cw runs (wall on the left).

    Returns
    -------
    numpy.ndarray
        (n, 6) distances [m] in the order of :data:`~umbmark.io.distances_csv.DIST_COLUMNS`.

    Raises
    ------
    InputError
        Runs without ``theta_abs``; a mark behind its wall.
    """
    if runs.theta_abs is None:
        raise InputError("the runs need theta_abs (the true end orientation)")
    n = len(runs)
    sx, sy, st = (np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy() for v in (start.x, start.y, start.theta))
    out = np.empty((n, 6))
    for dn in DIRECTIONS:
        sel = runs.direction == dn
        if not sel.any():
            continue
        mk = marks if side_wall is None else marks_for_direction(marks, dn, side_wall)
        y0, t0 = sy[sel], st[sel]
        if side_wall == "auto" and dn == "cw":
            y0, t0 = -y0, -t0
        s0 = WallPose(sx[sel], y0, t0)
        c, s = np.cos(t0), np.sin(t0)
        ex, ey = runs.x_abs[sel], runs.y_abs[sel]
        e = WallPose(s0.x + c * ex - s * ey, s0.y + s * ex + c * ey, t0 + runs.theta_abs[sel])
        out[sel, :3] = np.stack(distances_from_pose(mk, s0), axis=-1)
        out[sel, 3:] = np.stack(distances_from_pose(mk, e), axis=-1)
    return out


def pose_from_distances(
    marks: RobotMarks,
    d_front: ArrayLike,
    d_rear: ArrayLike,
    d_back: ArrayLike,
    source: str | None = None,
    line: ArrayLike | None = None,
) -> WallPose:
    """The pose in the wall frame from the three distances.

    Parameters
    ----------
    marks : RobotMarks
        The reference points.
    d_front, d_rear, d_back : float or array_like
        The distances [m].
    source : str, optional
        The distances file, for error messages.
    line : array_like of int, optional
        The file's line numbers of the readings, for error messages.

    Returns
    -------
    WallPose
        Of the two headings the readings allow, the one nearest 0.

    Raises
    ------
    InputError
        Front and rear readings that differ by more than the marks are apart.
    """
    df, dr, db = (np.asarray(v, dtype=float) for v in (d_front, d_rear, d_back))
    sgn = marks.sign
    a = marks.front[0] - marks.rear[0]
    b = marks.front[1] - marks.rear[1]
    r = math.hypot(a, b)
    phi = math.atan2(b, a)
    ratio = sgn * (df - dr) / r
    bad = np.abs(ratio) > 1.0
    if np.any(bad):
        i = int(np.flatnonzero(np.atleast_1d(bad))[0])
        ln = None if line is None else int(np.atleast_1d(line)[i])
        raise InputError(
            f"front and rear distances differ by {abs(np.atleast_1d(df - dr)[i]) * 1e3:.1f} mm, more than the "
            f"{r * 1e3:.1f} mm between the front and rear reference points: check the readings and the marks",
            source,
            ln,
        )
    asn = np.arcsin(ratio)
    # a sin(t) + b cos(t) = r sin(t + phi): t = asin(ratio) - phi  or  pi - asin(ratio) - phi
    t1 = wrap_angle(asn - phi)
    t2 = wrap_angle(np.pi - asn - phi)
    theta = np.where(np.abs(t1) <= np.abs(t2), t1, t2)
    c, s = np.cos(theta), np.sin(theta)
    y = sgn * df - (marks.front[0] * s + marks.front[1] * c)
    x = db - (marks.back[0] * c - marks.back[1] * s)
    return WallPose(x, y, theta)


def relative_pose(start: WallPose, end: WallPose) -> tuple[FloatArray, FloatArray, FloatArray]:
    """An end pose expressed in the frame of a start pose.

    Parameters
    ----------
    start, end : WallPose
        The two poses in the wall frame.

    Returns
    -------
    x, y, theta : numpy.ndarray
        The end pose in the start frame [m, m, rad; theta wrapped].
    """
    dx = np.asarray(end.x) - np.asarray(start.x)
    dy = np.asarray(end.y) - np.asarray(start.y)
    c, s = np.cos(start.theta), np.sin(start.theta)
    return c * dx + s * dy, -s * dx + c * dy, wrap_angle(np.asarray(end.theta) - np.asarray(start.theta))


def _return_pose(
    marks: RobotMarks, d6: FloatArray, source: str | None = None, line: ArrayLike | None = None
) -> FloatArray:
    """``d6``: (..., 6) distances start_front, start_rear, start_back, end_front, end_rear,
    end_back (metres) -> (..., 3) return pose x, y, theta in the start frame."""
    start = pose_from_distances(marks, d6[..., 0], d6[..., 1], d6[..., 2], source, line)
    end = pose_from_distances(marks, d6[..., 3], d6[..., 4], d6[..., 5], source, line)
    return np.stack(relative_pose(start, end), axis=-1)


@dataclass(frozen=True)
class Measurement:
    """The return pose of one or more runs with its propagated uncertainty.

    Attributes
    ----------
    x, y, theta : numpy.ndarray
        The return pose in the start frame [m, m, rad].
    x_sd, y_sd, theta_sd : numpy.ndarray
        Their standard deviations from the tape's resolution.
    x_bound, y_bound, theta_bound : numpy.ndarray
        Their worst-case errors (every reading off by half the resolution).
    covariance : numpy.ndarray
        (..., 3, 3) covariance of x, y, theta.
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    x_sd: np.ndarray
    y_sd: np.ndarray
    theta_sd: np.ndarray
    x_bound: np.ndarray
    y_bound: np.ndarray
    theta_bound: np.ndarray
    covariance: np.ndarray  # (..., 3, 3): x, y, theta


# every distance under this (metres): the distances were written in another unit
_MIN_WALL_M = 0.01
# a distance beyond this (metres) is no tape's reading
_MAX_WALL_M = MAX_TAPE_MM * 1e-3  # the longest tape


def measure(
    marks: RobotMarks,
    distances: ArrayLike,
    resolution_m: float = 1e-3,
    source: str | None = None,
    line: ArrayLike | None = None,
) -> Measurement:
    """Return poses in the start frame from the six distances, with the tape's resolution
    propagated (see the module docstring).

    Parameters
    ----------
    marks : RobotMarks
        The reference points.
    distances : array_like
        (..., 6) distances [m] in the order of :data:`~umbmark.io.distances_csv.DIST_COLUMNS`.
    resolution_m : float
        The tape's resolution.
    source : str, optional
        The distances file, for error messages.
    line : array_like of int, optional
        The file's line numbers, for error messages.

    Returns
    -------
    Measurement

    Raises
    ------
    InputError
        A negative resolution or distance, not six distances, inconsistent readings.
    """
    if not (math.isfinite(resolution_m) and resolution_m >= 0):
        raise InputError(f"tape resolution must be a non-negative number, got {resolution_m!r}")
    d6 = np.asarray(distances, dtype=float)
    if d6.shape[-1] != 6:
        raise InputError("need six distances per run (start front, rear, back; end front, rear, back)")
    if np.any(d6 < 0):
        raise InputError("a distance is negative")
    if d6.size and not float(np.max(d6)) <= _MAX_WALL_M:
        raise InputError(
            f"a distance of {float(np.max(d6)) * 1e3:g} mm to a wall: a tape measures at most "
            f"{_MAX_WALL_M * 1e3:g} mm (the file is in millimetres)",
            source,
        )
    if d6.size and float(np.max(d6)) < _MIN_WALL_M:
        raise InputError(
            f"every distance is under {_MIN_WALL_M * 1e3:g} mm (the largest {float(np.max(d6)) * 1e3:g} mm): the "
            "marks cannot all touch the walls; distances in metres? (the file is in millimetres)",
            source,
        )
    pose = _return_pose(marks, d6, source, line)
    # Jacobian by central differences (the computation is smooth away from the inconsistent case)
    h = 1e-7
    cols = []
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        hi = _return_pose(marks, d6 + e)
        lo = _return_pose(marks, np.maximum(d6 - e, 0.0))
        diff = hi - lo
        diff[..., 2] = wrap_angle(diff[..., 2])
        cols.append(diff / (2 * h))
    jac = np.stack(cols, axis=-1)  # (..., 3, 6)
    var = resolution_m**2 / 12.0
    cov = var * jac @ np.swapaxes(jac, -1, -2)
    sd = np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))
    bound = np.abs(jac).sum(axis=-1) * resolution_m / 2.0
    return Measurement(
        pose[..., 0],
        pose[..., 1],
        pose[..., 2],
        sd[..., 0],
        sd[..., 1],
        sd[..., 2],
        bound[..., 0],
        bound[..., 1],
        bound[..., 2],
        cov,
    )


def measure_run(
    marks: RobotMarks, row: MeasuredRun, resolution_m: float = 1e-3, source: str | None = None
) -> Measurement:
    """The return pose of one row of a distances file.

    Parameters
    ----------
    marks : RobotMarks
        The reference points, with the side the wall is on.
    row : MeasuredRun
        The six distances (mm, as typed).
    resolution_m : float
        The tape's resolution.
    source : str, optional
        The distances file, for error messages.

    Returns
    -------
    Measurement
    """
    return measure(marks, np.asarray(row.distances_mm) * 1e-3, resolution_m, source, row.line)


@dataclass(frozen=True)
class MeasuredRuns:
    """Runs whose return poses were measured with a tape.

    Attributes
    ----------
    runs : RunsTable
        The runs table: the measured return poses (``x_abs``, ``y_abs``, ``theta_abs``) and the
        odometry's, in the start frame.
    measurement : Measurement
        The measured poses with their propagated uncertainty.
    resolution_m : float
        The tape's resolution.
    side_wall : str or None
        How the side wall was placed (``auto``, ``left``, ``right``; None: as the marks say).
    out : str or None
        The runs file written (:meth:`write`).
    warnings : tuple of str
        What the runs show of a mistake in the distances file (cw and ccw labels exchanged).
    """

    runs: RunsTable
    measurement: Measurement
    resolution_m: float
    side_wall: str | None = None
    out: str | None = None
    warnings: tuple[str, ...] = ()

    def write(self, path: str | Path) -> MeasuredRuns:
        """Write the runs file with the standard deviations (:func:`format_measured_csv`), atomically.

        Parameters
        ----------
        path : str or Path
            The file to write.

        Returns
        -------
        MeasuredRuns
            This result with ``out`` set.
        """
        from umbmark.io.atomic import atomic_write

        atomic_write(path, format_measured_csv(self.runs, self.measurement))
        return replace(self, out=str(path))

    def to_dict(self) -> dict:
        """The JSON of ``umbmark measure --json``: the file written, the tape resolution and
        every run's measured return pose with its standard deviation and worst-case bound (mm, deg)."""
        runs, m = self.runs, self.measurement
        assert runs.run is not None and runs.theta_abs is not None  # measured runs: named, with their headings
        return {
            "out": self.out,
            "resolution_mm": self.resolution_m * 1e3,
            "side_wall": self.side_wall,
            "warnings": list(self.warnings),
            "runs": [
                {
                    "run": str(runs.run[i]),
                    "direction": str(runs.direction[i]),
                    "x_abs_mm": runs.x_abs[i] * 1e3,
                    "y_abs_mm": runs.y_abs[i] * 1e3,
                    "theta_abs_deg": math.degrees(runs.theta_abs[i]),
                    "x_abs_sd_mm": m.x_sd[i] * 1e3,
                    "y_abs_sd_mm": m.y_sd[i] * 1e3,
                    "theta_abs_sd_deg": math.degrees(m.theta_sd[i]),
                    "x_abs_bound_mm": m.x_bound[i] * 1e3,
                    "y_abs_bound_mm": m.y_bound[i] * 1e3,
                    "theta_abs_bound_deg": math.degrees(m.theta_bound[i]),
                }
                for i in range(len(runs))
            ],
        }


# the odometry's end heading after a square: near 0 or, unwrapped, one full turn (degrees)
_MAX_END_HEADING_DEG = 720.0


def _check_odometry(rows: list[MeasuredRun], source: str | None) -> None:
    """Refuse an odometry end pose no square run ends at: beyond the longest tape from the start
    (the run returns to where it started), or a heading beyond two turns."""
    for r in rows:
        for col, v in (("x_odo", r.x_odo_mm), ("y_odo", r.y_odo_mm)):
            if not abs(v) <= _MAX_WALL_M * 1e3:
                raise InputError(
                    f"column {col}: the odometry's end {v:g} mm from the start: a square run returns to its start "
                    f"(at most {_MAX_WALL_M * 1e3:g} mm; the file is in millimetres)",
                    source,
                    r.line,
                )
        if r.theta_odo_deg is not None and not abs(r.theta_odo_deg) <= _MAX_END_HEADING_DEG:
            raise InputError(
                f"column theta_odo: an end heading of {r.theta_odo_deg:g} deg: a square run ends within a turn of its "
                f"start heading (at most {_MAX_END_HEADING_DEG:g} deg; the file is in degrees)",
                source,
                r.line,
            )


def measure_runs(
    marks: RobotMarks,
    rows: list[MeasuredRun],
    resolution_m: float = 1e-3,
    source: str | None = None,
    side_wall: str | None = None,
) -> MeasuredRuns:
    """The return poses of every row of a distances file, at once.

    Parameters
    ----------
    marks : RobotMarks
        The reference points.
    rows : list of MeasuredRun
        The rows (mm, as typed).
    resolution_m : float
        The tape's resolution.
    source : str, optional
        The distances file, for error messages.
    side_wall : str, optional
        None: ``marks`` as they are for every run; otherwise ``auto``, ``left`` or ``right``
        (see :func:`marks_for_direction`).

    Returns
    -------
    MeasuredRuns

    Raises
    ------
    InputError
        No rows, or distances that no pose explains (file and line named).
    """
    if not rows:
        raise InputError("no runs to measure", source)
    _check_odometry(rows, source)
    d = np.array([r.distances_mm for r in rows], dtype=float) * 1e-3
    lines = np.array([r.line if r.line is not None else 0 for r in rows])
    has_lines = any(r.line for r in rows)
    direction = np.array([r.direction for r in rows])
    parts = {}
    for dn in DIRECTIONS:
        sel = direction == dn
        if sel.any():
            mk = marks if side_wall is None else marks_for_direction(marks, dn, side_wall)
            parts[dn] = (sel, measure(mk, d[sel], resolution_m, source, lines[sel] if has_lines else None))
    fields = {}
    for name in ("x", "y", "theta", "x_sd", "y_sd", "theta_sd", "x_bound", "y_bound", "theta_bound"):
        a = np.empty(len(rows))
        for sel, mm in parts.values():
            a[sel] = getattr(mm, name)
        fields[name] = a
    cov = np.empty((len(rows), 3, 3))
    for sel, mm in parts.values():
        cov[sel] = mm.covariance
    m = Measurement(**fields, covariance=cov)
    theta_odo_deg = [r.theta_odo_deg for r in rows if r.theta_odo_deg is not None]
    has_theta = len(theta_odo_deg) == len(rows)
    runs = RunsTable.from_columns(
        [r.direction for r in rows],
        m.x,
        m.y,
        [r.x_odo_mm * 1e-3 for r in rows],
        [r.y_odo_mm * 1e-3 for r in rows],
        m.theta,
        np.radians(theta_odo_deg) if has_theta else None,
        np.array([r.run for r in rows]),
    )
    return MeasuredRuns(runs, m, resolution_m, side_wall, warnings=tuple(_label_warnings(runs, side_wall)))


def _label_warnings(runs: RunsTable, side_wall: str | None) -> list[str]:
    """A warning when the measured return poses fit the square with the cw and ccw labels
    exchanged far better than as labelled (:func:`umbmark.correct.plausibility.fits_lines_better`):
    with ``side_wall`` auto, a label also mirrors the marks, so the runs as the other label would
    have them are mirrored (y and the heading negated) as well."""
    from umbmark.correct.plausibility import fits_lines_better

    out: list[str] = []
    swap = {"cw": "ccw", "ccw": "cw"}
    mirrored = side_wall == "auto"
    th = runs.theta_abs
    other = RunsTable.from_columns(
        [swap[d] for d in runs.direction],
        runs.x_abs,
        -runs.y_abs if mirrored else runs.y_abs,
        runs.x_odo,
        runs.y_odo,
        None if th is None else (-th if mirrored else th),
        runs.theta_odo,
        runs.run,
    )
    if fits_lines_better(runs, other):
        how = " (and with them the side of the side wall)" if mirrored else ""
        out.append(
            f"the runs fit the square far better with the cw and ccw labels exchanged{how}: check the direction "
            "column (cw turns right after the first leg)"
        )
    return out


def format_measured_csv(runs: RunsTable, m: Measurement) -> str:
    """The runs file (mm, deg) of measured runs, with the propagated standard deviations as
    extra columns ``x_abs_sd, y_abs_sd`` (mm) and ``theta_abs_sd`` (deg), which the runs-file
    reader ignores.

    Parameters
    ----------
    runs : RunsTable
        The measured runs.
    m : Measurement
        Their uncertainty.

    Returns
    -------
    str
        The file's text.
    """
    out = io.StringIO()
    w = csv_writer(out, lineterminator="\n")
    assert runs.run is not None and runs.theta_abs is not None  # measured runs: named, with their headings
    theta_odo = runs.theta_odo
    has_theta = theta_odo is not None
    header = ["run", "direction", "x_abs", "y_abs", "x_odo", "y_odo", "theta_abs"]
    if has_theta:
        header += ["theta_odo"]
    header += ["x_abs_sd", "y_abs_sd", "theta_abs_sd"]
    w.writerow(header)
    f = lambda v, nd=3: repr(round(float(v), nd))  # noqa: E731
    for i in range(len(runs)):
        row = [
            runs.run[i],
            runs.direction[i],
            f(runs.x_abs[i] * 1e3),
            f(runs.y_abs[i] * 1e3),
            f(runs.x_odo[i] * 1e3),
            f(runs.y_odo[i] * 1e3),
        ]
        row += [f(math.degrees(runs.theta_abs[i]), 4)]
        if theta_odo is not None:
            row += [f(math.degrees(theta_odo[i]), 4)]
        row += [f(m.x_sd[i] * 1e3), f(m.y_sd[i] * 1e3), f(math.degrees(m.theta_sd[i]), 4)]
        w.writerow(row)
    return out.getvalue()
