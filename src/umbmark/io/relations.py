"""The relations file of the SLAM benchmark (Kümmerle et al. 2009): ground-truth relative poses.

One relation per line, fields separated by white space::

    timestamp1 timestamp2 x y z roll pitch yaw

(seconds; metres; radians): the pose of the sensor at ``timestamp2`` expressed in the frame of
its pose at ``timestamp1``. The relations are planar: ``z`` is read and dropped, ``roll`` and
``pitch`` must be small (at most :data:`MAX_TILT_RAD`). Blank lines and lines starting with
``#`` are skipped. Errors name the file and line (``file:line: problem``).

:class:`Relations` holds them in SI units; :meth:`Relations.indices` finds the scans (by their
stamps) that each relation joins.

Imports numpy, :mod:`umbmark.errors` and the helpers of :mod:`umbmark.io`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io._text import numeric_rows, read_text
from umbmark.io.atomic import atomic_write

__all__ = [
    "COLUMNS",
    "MAX_TILT_RAD",
    "Relations",
    "read_relations",
    "parse_relations",
    "format_relations",
    "write_relations",
]

COLUMNS = ("timestamp1", "timestamp2", "x", "y", "z", "roll", "pitch", "yaw")

MAX_TILT_RAD = math.radians(10.0)
"""The largest roll or pitch of a relation the planar file accepts [rad]."""

_MAX_M = 1e4  # a relative pose beyond 10 km is a unit or format error
_MAX_RAD = 2 * math.pi  # an angle beyond a full turn is not in radians

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Relations:
    """Ground-truth relative poses between pairs of time stamps.

    Parameters
    ----------
    t1_s, t2_s : array_like
        ``(K,)`` the two time stamps of each relation [s].
    pose : array_like
        ``(K, 3)`` ``(x_m, y_m, yaw_rad)``: the pose at ``t2_s`` in the frame of the pose at
        ``t1_s``.
    source : str, optional
        The file, for messages.
    lines : array_like, optional
        ``(K,)`` the 1-based line of each relation in ``source``.

    Raises
    ------
    InputError
        Shapes that do not agree, values that are not finite, a relation whose two stamps are
        equal.
    """

    t1_s: FloatArray
    t2_s: FloatArray
    pose: FloatArray
    source: str | None = None
    lines: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        t1 = np.asarray(self.t1_s, dtype=float).reshape(-1)
        t2 = np.asarray(self.t2_s, dtype=float)
        p = np.asarray(self.pose, dtype=float)
        if t2.shape != t1.shape:
            raise InputError(f"`t1_s` and `t2_s` differ in shape: {t1.shape} vs {t2.shape}", self.source)
        if p.shape != (len(t1), 3):
            raise InputError(f"`pose` must have shape ({len(t1)}, 3), got {p.shape}", self.source)
        for name, v in (("t1_s", t1), ("t2_s", t2), ("pose", p)):
            if not np.all(np.isfinite(v)):
                raise InputError(f"`{name}` has values that are not finite numbers", self.source)
        same = np.flatnonzero(t1 == t2)
        if same.size:
            raise InputError(
                f"relation {int(same[0])} joins time {t1[same[0]]:.6f} s to itself",
                self.source,
                None if self.lines is None else int(np.asarray(self.lines)[same[0]]),
            )
        object.__setattr__(self, "t1_s", t1)
        object.__setattr__(self, "t2_s", t2)
        object.__setattr__(self, "pose", p)
        if self.lines is not None:
            ln = np.asarray(self.lines, dtype=np.int64).reshape(-1)
            if ln.shape != t1.shape:
                raise InputError(f"`lines` must have shape {t1.shape}, got {ln.shape}", self.source)
            object.__setattr__(self, "lines", ln)

    def __len__(self) -> int:
        return len(self.t1_s)

    @property
    def span_s(self) -> FloatArray:
        """``(K,)`` the time each relation spans, ``|t2_s - t1_s|`` [s]."""
        return np.abs(self.t2_s - self.t1_s)

    def subset(self, mask: ArrayLike) -> Relations:
        """The relations selected by a boolean mask or an index array.

        Parameters
        ----------
        mask : array_like
            ``(K,)`` booleans, or indices.

        Returns
        -------
        Relations
        """
        m = np.asarray(mask)
        if m.dtype == bool and m.shape != self.t1_s.shape:
            raise InputError(f"`mask` must have shape {self.t1_s.shape}, got {m.shape}", self.source)
        return Relations(
            self.t1_s[m],
            self.t2_s[m],
            self.pose[m],
            self.source,
            None if self.lines is None else self.lines[m],
        )

    def indices(self, stamps_s: ArrayLike, tolerance_s: float = 1e-3) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The samples (e.g. scans) each relation joins: the nearest stamp to each of its times.

        Parameters
        ----------
        stamps_s : array_like
            ``(M,)`` increasing time stamps [s].
        tolerance_s : float
            The farthest a relation's time may be from its nearest stamp [s].

        Returns
        -------
        tuple of numpy.ndarray
            ``(i1, i2)``, each ``(K,)``: the indices into ``stamps_s`` of ``t1_s`` and ``t2_s``.

        Raises
        ------
        InputError
            Stamps that are empty or do not increase, a negative tolerance, or a relation
            time without a stamp within ``tolerance_s`` (its line named).
        """
        t = np.asarray(stamps_s, dtype=float).reshape(-1)
        if t.size == 0:
            raise InputError("`stamps_s` is empty", self.source)
        if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
            raise InputError("`stamps_s` must be finite and increasing", self.source)
        if not (isinstance(tolerance_s, (int, float)) and tolerance_s >= 0):
            raise InputError(f"`tolerance_s` must be a non-negative number, got {tolerance_s!r}", self.source)
        out = []
        for which, times in (("timestamp1", self.t1_s), ("timestamp2", self.t2_s)):
            if len(t) == 1:
                k = np.zeros(len(times), dtype=np.int64)
            else:
                k = np.clip(np.searchsorted(t, times), 1, len(t) - 1)
                k = np.where(np.abs(t[k - 1] - times) <= np.abs(t[k] - times), k - 1, k)
            off = np.abs(t[k] - times)
            bad = np.flatnonzero(off > tolerance_s)
            if bad.size:
                j = int(bad[0])
                raise InputError(
                    f"{which} {times[j]:.6f} s has no stamp within {tolerance_s:g} s (nearest {t[k[j]]:.6f} s; "
                    f"{bad.size} of {len(times)} relations without one): are these the relations of this log?",
                    self.source,
                    None if self.lines is None else int(self.lines[j]),
                )
            out.append(k.astype(np.int64))
        return out[0], out[1]


def read_relations(path: str | Path) -> Relations:
    """Read a relations file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Relations

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    return parse_relations(read_text(path), source=str(path))


def parse_relations(text: str, source: str = "<relations>") -> Relations:
    """Parse the text of a relations file (see the module docstring).

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Its name, for error messages.

    Returns
    -------
    Relations

    Raises
    ------
    InputError
        A line without 8 fields, a field that is not a finite number, a translation beyond
        10 km, an angle beyond a full turn, a roll or pitch beyond :data:`MAX_TILT_RAD`, two
        equal time stamps, no relations (file and line named).
    """
    rows, lines = numeric_rows(text, source, ncols=len(COLUMNS), names=COLUMNS, delimiter=None)
    for col in (2, 3, 4):
        bad = np.flatnonzero(np.abs(rows[:, col]) > _MAX_M)
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"column {COLUMNS[col]}: {rows[j, col]:g} m is more than 10 km: check the units", source, int(lines[j])
            )
    for col in (5, 6, 7):
        bad = np.flatnonzero(np.abs(rows[:, col]) > _MAX_RAD)
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"column {COLUMNS[col]}: {rows[j, col]:g} is more than a full turn: angles are in radians",
                source,
                int(lines[j]),
            )
    for col in (5, 6):
        bad = np.flatnonzero(np.abs(rows[:, col]) > MAX_TILT_RAD)
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"column {COLUMNS[col]}: {math.degrees(rows[j, col]):.1f} deg: not a planar relation "
                f"(roll and pitch at most {math.degrees(MAX_TILT_RAD):g} deg)",
                source,
                int(lines[j]),
            )
    same = np.flatnonzero(rows[:, 0] == rows[:, 1])
    if same.size:
        j = int(same[0])
        raise InputError(f"timestamp1 and timestamp2 are equal ({rows[j, 0]:.6f} s)", source, int(lines[j]))
    return Relations(rows[:, 0], rows[:, 1], rows[:, [2, 3, 7]], source=source, lines=lines)


def format_relations(relations: Relations) -> str:
    """The text of a relations file (``z``, ``roll``, ``pitch`` written as 0).

    Parameters
    ----------
    relations : Relations
        The relations.

    Returns
    -------
    str
        One line per relation; times, metres and radians with the shortest text that reads
        back to the same number.
    """
    f = lambda v: repr(float(v))  # noqa: E731  (the shortest text that reads back exactly)
    return "".join(
        f"{f(t1)} {f(t2)} {f(x)} {f(y)} 0 0 0 {f(yaw)}\n"
        for t1, t2, (x, y, yaw) in zip(relations.t1_s, relations.t2_s, relations.pose)
    )


def write_relations(relations: Relations, path: str | Path) -> None:
    """Write a relations file, atomically.

    Parameters
    ----------
    relations : Relations
        The relations.
    path : str or Path
        The file.
    """
    atomic_write(path, format_relations(relations))
