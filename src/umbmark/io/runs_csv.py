"""The runs file: CSV with a header, millimetres and degrees, start frame.

Columns: ``direction`` (``cw`` or ``ccw``), ``x_abs``, ``y_abs``, ``x_odo``, ``y_odo``; optional
``run``, ``theta_abs``, ``theta_odo``. ``_abs``: where the robot really stopped, ``_odo``: what
its odometry reported. Extra columns are ignored; blank lines and lines starting with ``#``
are skipped. An optional column that is present must be filled on every row (or left empty on
every row: not measured).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io._text import csv_rows, csv_writer, header_columns, parse_number, read_text
from umbmark.io.atomic import atomic_write
from umbmark.model.runs import DIRECTIONS, RunsTable

__all__ = ["read_runs_csv", "write_runs_csv", "parse_runs_csv", "format_runs_csv", "REQUIRED", "OPTIONAL"]

REQUIRED = ("direction", "x_abs", "y_abs", "x_odo", "y_odo")
OPTIONAL = ("run", "theta_abs", "theta_odo")
_NUMERIC = ("x_abs", "y_abs", "x_odo", "y_odo", "theta_abs", "theta_odo")


def read_runs_csv(path: str | Path) -> RunsTable:
    """Read a runs file.

    Parameters
    ----------
    path : str or Path
        The file (mm, deg).

    Returns
    -------
    RunsTable
        In metres and radians.

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    text = read_text(path)
    return parse_runs_csv(text, source=str(path))


def _number(cell: str, col: str, source: str, line: int) -> float:
    v = parse_number(cell, col, source, line)
    if col.startswith("theta"):
        if abs(v) > 360.0:
            raise InputError(f"column {col}: {cell.strip()} is not a heading in degrees (-180 to 180)", source, line)
    elif abs(v) > _MAX_MM:
        raise InputError(
            f"column {col}: {cell.strip()} mm is more than 10 km from the start: check the units", source, line
        )
    return v


_MAX_MM = 1e7  # positions (mm) of a square run: anything beyond 10 km is a unit or format error


def parse_runs_csv(text: str, source: str = "<runs>") -> RunsTable:
    """Parse the text of a runs file (see the module docstring).

    Parameters
    ----------
    text : str
        The file's content (mm, deg).
    source : str
        Its name, for error messages.

    Returns
    -------
    RunsTable
        In metres and radians.

    Raises
    ------
    InputError
        A missing column, a bad cell, a position beyond 10 km or a heading beyond 360 deg, no
        runs in a direction (file and line named).
    """
    rows = []
    header = None
    header_line = None
    for line, row in csv_rows(text, source):
        if header is None:
            header = header_columns(row)
            header_line = line
            missing = [c for c in REQUIRED if c not in header]
            if missing:
                raise InputError(
                    "no header with the runs-file columns: missing "
                    + ", ".join(missing)
                    + " (expected direction,x_abs,y_abs,x_odo,y_odo[,run,theta_abs,theta_odo])",
                    source,
                    line,
                )
            dup = sorted({c for c in header if header.count(c) > 1 and c in REQUIRED + OPTIONAL})
            if dup:
                raise InputError(f"column {dup[0]} appears twice in the header", source, line)
            continue
        rows.append((line, row))
    if header is None:
        raise InputError("empty file: no header and no runs", source)
    if not rows:
        raise InputError("no runs after the header", source, header_line)
    col = {name: header.index(name) for name in REQUIRED + OPTIONAL if name in header}
    present_opt = [c for c in OPTIONAL if c in col]
    # an optional column left empty everywhere counts as absent
    for c in list(present_opt):
        cells = [r[col[c]].strip() if col[c] < len(r) else "" for _, r in rows]
        if all(not x for x in cells):
            present_opt.remove(c)
    data: dict[str, list] = {c: [] for c in REQUIRED + tuple(present_opt)}
    for line, r in rows:
        need = max(col[c] for c in data) + 1
        if len(r) < need:
            raise InputError(f"has {len(r)} fields, the header has {len(header)}", source, line)
        d = r[col["direction"]].strip().lower()
        if d not in DIRECTIONS:
            raise InputError(f"unknown direction {r[col['direction']].strip()!r} (expected cw or ccw)", source, line)
        data["direction"].append(d)
        for c in data:
            if c in _NUMERIC:
                data[c].append(_number(r[col[c]], c, source, line))
        if "run" in data:
            cell = r[col["run"]].strip()
            if not cell:
                raise InputError("column run is empty", source, line)
            data["run"].append(cell)
    for d in DIRECTIONS:
        if d not in data["direction"]:
            raise InputError(f"no {d} runs: the bi-directional test needs runs in both directions", source)
    mm = lambda c: np.asarray(data[c]) * 1e-3  # noqa: E731
    rad = lambda c: np.radians(np.asarray(data[c])) if c in data else None  # noqa: E731
    return RunsTable.from_columns(
        data["direction"],
        mm("x_abs"),
        mm("y_abs"),
        mm("x_odo"),
        mm("y_odo"),
        rad("theta_abs"),
        rad("theta_odo"),
        np.asarray(data["run"]) if "run" in data else None,
    )


def format_runs_csv(runs: RunsTable) -> str:
    """The text of a runs file (mm, deg; micrometre and micro-degree resolution).

    Parameters
    ----------
    runs : RunsTable
        The runs.

    Returns
    -------
    str
        The header ``run, direction, x_abs, y_abs, x_odo, y_odo`` (and ``theta_abs,
        theta_odo`` when both headings are known) and one line per run.
    """
    out = io.StringIO()
    w = csv_writer(out, lineterminator="\n")
    theta_abs, theta_odo = runs.theta_abs, runs.theta_odo
    headings = (theta_abs, theta_odo) if theta_abs is not None and theta_odo is not None else None
    header = ["run", "direction", "x_abs", "y_abs", "x_odo", "y_odo"]
    if headings is not None:
        header += ["theta_abs", "theta_odo"]
    w.writerow(header)
    f = lambda v: repr(round(float(v), 6))  # noqa: E731  (micrometre / micro-degree resolution)
    for i in range(len(runs)):
        row = [
            runs.run[i] if runs.run is not None else i + 1,
            runs.direction[i],
            f(runs.x_abs[i] * 1e3),
            f(runs.y_abs[i] * 1e3),
            f(runs.x_odo[i] * 1e3),
            f(runs.y_odo[i] * 1e3),
        ]
        if headings is not None:
            row += [f(math.degrees(headings[0][i])), f(math.degrees(headings[1][i]))]
        w.writerow(row)
    return out.getvalue()


def write_runs_csv(runs: RunsTable, path: str | Path) -> None:
    """Write a runs file (mm, deg), atomically.

    Parameters
    ----------
    runs : RunsTable
        The runs.
    path : str or Path
        The file.
    """
    atomic_write(path, format_runs_csv(runs))
