"""Trajectories in the TUM format (the TUM RGB-D benchmark's, written by evo, cartographer,
slam_toolbox tooling ...): one pose per line, fields separated by white space::

    timestamp x y z qx qy qz qw

(seconds; metres; the orientation as a unit quaternion, ``w`` last). Blank lines and lines
starting with ``#`` are skipped. The trajectory must be planar: ``z`` is read and dropped, the
roll and pitch of each orientation must be small (at most :data:`MAX_TILT_RAD`), and the heading
is the quaternion's yaw. Errors name the file and line (``file:line: problem``).

:class:`Trajectory` holds the poses in SI units (``x_m``, ``y_m``, ``yaw_rad``); the writer
writes ``z`` as 0 and each yaw as the quaternion about the vertical axis.

Imports numpy, :mod:`umbmark.errors` and the helpers of :mod:`umbmark.io`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError
from umbmark.io._text import check_increasing_time, numeric_rows, read_text
from umbmark.io.atomic import atomic_write

__all__ = [
    "COLUMNS",
    "MAX_TILT_RAD",
    "QUATERNION_TOLERANCE",
    "Trajectory",
    "read_tum",
    "parse_tum",
    "format_tum",
    "write_tum",
]

COLUMNS = ("timestamp", "x", "y", "z", "qx", "qy", "qz", "qw")

MAX_TILT_RAD = math.radians(10.0)
"""The largest roll or pitch of a pose the planar reader accepts [rad]."""

QUATERNION_TOLERANCE = 1e-3
"""How far the norm of a quaternion may be from 1 (the rounding of written digits)."""

_MAX_M = 1e5  # a position beyond 100 km is a unit or format error

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Planar poses at increasing time stamps.

    Parameters
    ----------
    t_s : array_like
        ``(K,)`` time stamps [s], increasing.
    pose : array_like
        ``(K, 3)`` ``(x_m, y_m, yaw_rad)`` in the trajectory's fixed frame.
    source : str, optional
        The file, for messages.
    lines : array_like, optional
        ``(K,)`` the 1-based line of each pose in ``source``.

    Raises
    ------
    InputError
        Shapes that do not agree, values that are not finite, stamps that do not increase.
    """

    t_s: FloatArray
    pose: FloatArray
    source: str | None = None
    lines: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.t_s, dtype=float).reshape(-1)
        p = np.asarray(self.pose, dtype=float)
        if p.shape != (len(t), 3):
            raise InputError(f"`pose` must have shape ({len(t)}, 3), got {p.shape}", self.source)
        for name, v in (("t_s", t), ("pose", p)):
            if not np.all(np.isfinite(v)):
                raise InputError(f"`{name}` has values that are not finite numbers", self.source)
        ln = None if self.lines is None else np.asarray(self.lines, dtype=np.int64).reshape(-1)
        if ln is not None and ln.shape != t.shape:
            raise InputError(f"`lines` must have shape {t.shape}, got {ln.shape}", self.source)
        check_increasing_time(t, ln if ln is not None else np.arange(1, len(t) + 1), self.source or "<trajectory>")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "pose", p)
        object.__setattr__(self, "lines", ln)

    def __len__(self) -> int:
        return len(self.t_s)


def read_tum(path: str | Path) -> Trajectory:
    """Read a TUM trajectory file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Trajectory

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    return parse_tum(read_text(path), source=str(path))


def parse_tum(text: str, source: str = "<tum>") -> Trajectory:
    """Parse the text of a TUM trajectory file (see the module docstring).

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Its name, for error messages.

    Returns
    -------
    Trajectory

    Raises
    ------
    InputError
        A line without 8 fields (7 fields: named as the likely ``x y z roll pitch yaw``), a
        field that is not a finite number, a position beyond 100 km, a quaternion whose norm is
        not 1 (within :data:`QUATERNION_TOLERANCE`), a roll or pitch beyond
        :data:`MAX_TILT_RAD` (the quaternion written ``w`` first is named), time stamps that
        do not increase, no poses (file and line named).
    """
    try:
        rows, lines = numeric_rows(text, source, ncols=len(COLUMNS), names=COLUMNS, delimiter=None)
    except InputError as e:
        if e.message.startswith("has 7 fields"):
            raise InputError(
                "has 7 fields, a TUM trajectory has 8 (timestamp x y z qx qy qz qw): is this "
                "timestamp x y z roll pitch yaw? write the orientation as a quaternion",
                e.source,
                e.line,
            ) from None
        raise
    for col in (1, 2, 3):
        bad = np.flatnonzero(np.abs(rows[:, col]) > _MAX_M)
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"column {COLUMNS[col]}: {rows[j, col]:g} m is more than 100 km: check the units", source, int(lines[j])
            )
    q = rows[:, 4:8]
    norm = np.sqrt(np.sum(q * q, axis=1))
    bad = np.flatnonzero(np.abs(norm - 1.0) > QUATERNION_TOLERANCE)
    if bad.size:
        j = int(bad[0])
        raise InputError(
            f"the quaternion (qx qy qz qw) has norm {norm[j]:.6g}, not 1 ({bad.size} of {len(q)} poses): "
            "the orientation must be a unit quaternion",
            source,
            int(lines[j]),
        )
    x, y, z, w = (q[:, k] / norm for k in range(4))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    tilt = np.maximum(np.abs(roll), np.abs(pitch))
    bad = np.flatnonzero(tilt > MAX_TILT_RAD)
    if bad.size:
        j = int(bad[0])
        hint = ""
        if abs(y[j]) < 0.1 and abs(z[j]) < 0.1:  # a turn about x: a planar turn written w first
            hint = " (is the quaternion written qw first? TUM's order is qx qy qz qw)"
        raise InputError(
            f"roll {math.degrees(roll[j]):.1f} deg, pitch {math.degrees(pitch[j]):.1f} deg: not a planar trajectory "
            f"(roll and pitch at most {math.degrees(MAX_TILT_RAD):g} deg){hint}",
            source,
            int(lines[j]),
        )
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return Trajectory(rows[:, 0], np.column_stack([rows[:, 1], rows[:, 2], yaw]), source=source, lines=lines)


def format_tum(trajectory: Trajectory) -> str:
    """The text of a TUM trajectory file (``z`` written as 0, the yaw as a quaternion about z).

    Parameters
    ----------
    trajectory : Trajectory
        The poses.

    Returns
    -------
    str
        A comment line naming the columns, then one line per pose; numbers with the shortest
        text that reads back to the same value.
    """
    f = lambda v: repr(float(v))  # noqa: E731  (the shortest text that reads back exactly)
    out = ["# " + " ".join(COLUMNS) + "\n"]
    for t, (x, y, yaw) in zip(trajectory.t_s, trajectory.pose):
        out.append(f"{f(t)} {f(x)} {f(y)} 0 0 0 {f(math.sin(yaw / 2))} {f(math.cos(yaw / 2))}\n")
    return "".join(out)


def write_tum(trajectory: Trajectory, path: str | Path) -> None:
    """Write a TUM trajectory file, atomically.

    Parameters
    ----------
    trajectory : Trajectory
        The poses.
    path : str or Path
        The file.
    """
    atomic_write(path, format_tum(trajectory))
