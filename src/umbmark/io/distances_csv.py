"""The distances file: tape-measured wall distances of UMBmark runs (millimetres, degrees).

One row per run. Columns ``direction`` (``cw`` or ``ccw``), ``start_front, start_rear,
start_back, end_front, end_rear, end_back`` (the distances from the robot's front, rear and back
marks to the side and back walls before and after the run, perpendicular to the wall), ``x_odo,
y_odo`` (the odometry's end position); optional ``run`` and ``theta_odo`` (the odometry's end
heading). The three start cells of a row may be left empty together: the start of the previous
row of the same direction is reused. Blank lines and lines starting with ``#`` are skipped.
:mod:`umbmark.realrobot.measure` turns the rows into return poses.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

from umbmark.errors import InputError
from umbmark.io._text import csv_rows, csv_writer, header_columns, parse_number
from umbmark.model.runs import DIRECTIONS

__all__ = [
    "MAX_TAPE_MM",
    "DIST_COLUMNS",
    "START_COLUMNS",
    "END_COLUMNS",
    "MeasuredRun",
    "read_distances_csv",
    "parse_distances_csv",
    "format_distances_csv",
]

MAX_TAPE_MM = 1e6
"""The longest distance a tape measures to a wall (1 km)."""
START_COLUMNS = ("start_front", "start_rear", "start_back")
END_COLUMNS = ("end_front", "end_rear", "end_back")
DIST_COLUMNS = START_COLUMNS + END_COLUMNS


@dataclass(frozen=True)
class MeasuredRun:
    """One row of a distances file (millimetres and degrees, as typed).

    Attributes
    ----------
    run : str
        The run's label.
    direction : str
        ``cw`` or ``ccw``.
    distances_mm : tuple of float
        The six distances in the order of :data:`DIST_COLUMNS`.
    x_odo_mm, y_odo_mm : float
        The odometry's end position.
    theta_odo_deg : float or None
        The odometry's end heading (None: not read).
    line : int or None
        The row's line in the file.
    """

    run: str
    direction: str
    distances_mm: tuple[float, ...]  # DIST_COLUMNS order
    x_odo_mm: float
    y_odo_mm: float
    theta_odo_deg: float | None = None
    line: int | None = None


def read_distances_csv(path: str | Path) -> list[MeasuredRun]:
    """Read a distances file (see :func:`parse_distances_csv`).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    list of MeasuredRun

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", source=str(path))
    if p.is_dir():
        raise InputError("is a folder, not a distances file", source=str(path))
    try:
        text = p.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8) file", source=str(path)) from None
    return parse_distances_csv(text, source=str(path))


def parse_distances_csv(text: str, source: str = "<distances>") -> list[MeasuredRun]:
    """Parse a distances file (mm, deg).

    Columns: ``direction, start_front, start_rear, start_back, end_front, end_rear, end_back,
    x_odo, y_odo``; optional ``run``, ``theta_odo``. The three start cells of a row may be left
    empty together: the start of the previous row of the same direction is reused (the robot was
    put back on the same marked start; cw and ccw runs start at different corners). Blank lines
    and lines starting with ``#`` are skipped.

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Its name, for error messages.

    Returns
    -------
    list of MeasuredRun

    Raises
    ------
    InputError
        A missing column, a bad cell, a start to reuse that is not there (file and line named).
    """
    required = ("direction",) + DIST_COLUMNS + ("x_odo", "y_odo")
    header = None
    out: list[MeasuredRun] = []
    prev_start: dict[str, tuple] = {}
    for line, row in csv_rows(text, source):
        if header is None:
            header = header_columns(row)
            missing = [c for c in required if c not in header]
            if missing:
                raise InputError(
                    "no header with the distances-file columns: missing "
                    + ", ".join(missing)
                    + " (expected direction,"
                    + ",".join(DIST_COLUMNS)
                    + ",x_odo,y_odo[,run,theta_odo])",
                    source,
                    line,
                )
            continue
        col = {c: header.index(c) for c in required + ("run", "theta_odo") if c in header}

        def cell(c, row=row, col=col):
            return row[col[c]].strip() if col[c] < len(row) else ""

        if len(row) < max(col[c] for c in required) + 1:
            raise InputError(f"has {len(row)} fields, the header has {len(header)}", source, line)
        d = cell("direction").lower()
        if d not in DIRECTIONS:
            raise InputError(f"unknown direction {cell('direction')!r} (expected cw or ccw)", source, line)
        starts = [cell(c) for c in START_COLUMNS]
        if all(not s for s in starts):
            if d not in prev_start:
                raise InputError(
                    f"the start distances are empty and there is no previous {d} row to reuse", source, line
                )
            start = prev_start[d]
        else:
            start = tuple(parse_number(cell(c), c, source, line) for c in START_COLUMNS)
        end = tuple(parse_number(cell(c), c, source, line) for c in END_COLUMNS)
        for c, v in zip(DIST_COLUMNS, start + end):
            if v < 0:
                raise InputError(f"column {c}: a distance cannot be negative ({v:g})", source, line)
            if v > MAX_TAPE_MM:
                raise InputError(
                    f"column {c}: a distance of {v:g} mm to a wall: a tape measures at most {MAX_TAPE_MM:g} mm (the "
                    "file is in millimetres)",
                    source,
                    line,
                )
        prev_start[d] = start
        theta = None
        if "theta_odo" in col and cell("theta_odo"):
            theta = parse_number(cell("theta_odo"), "theta_odo", source, line)
        run = cell("run") if "run" in col and cell("run") else str(sum(1 for r in out if r.direction == d) + 1)
        out.append(
            MeasuredRun(
                run,
                d,
                start + end,
                parse_number(cell("x_odo"), "x_odo", source, line),
                parse_number(cell("y_odo"), "y_odo", source, line),
                theta,
                line,
            )
        )
    if header is None:
        raise InputError("empty file: no header and no runs", source)
    if not out:
        raise InputError("no runs after the header", source)
    with_theta = [r.theta_odo_deg is not None for r in out]
    if any(with_theta) and not all(with_theta):
        r = out[with_theta.index(False)]
        raise InputError(
            "column theta_odo is empty here but filled on other rows (fill it on every row or none)", source, r.line
        )
    return out


def format_distances_csv(rows: list[MeasuredRun]) -> str:
    """A distances file (mm, deg) of the rows, as :func:`parse_distances_csv` reads it.

    Parameters
    ----------
    rows : list of MeasuredRun
        The rows.

    Returns
    -------
    str
        The header ``run, direction, start_front, ..., end_back, x_odo, y_odo, theta_odo`` and
        one line per row (an empty ``theta_odo`` when the heading was not read).
    """
    buf = io.StringIO()
    w = csv_writer(buf, lineterminator="\n")
    w.writerow(["run", "direction", *DIST_COLUMNS, "x_odo", "y_odo", "theta_odo"])
    for r in rows:
        w.writerow(
            [
                r.run,
                r.direction,
                *[f"{v:g}" for v in r.distances_mm],
                f"{r.x_odo_mm:g}",
                f"{r.y_odo_mm:g}",
                "" if r.theta_odo_deg is None else f"{r.theta_odo_deg:g}",
            ]
        )
    return buf.getvalue()
