"""The intervals file of a lidar self-calibration: CSV with a header, SI units.

Columns, in any order: ``dt_s`` (duration of the interval [s]), ``left_rad``, ``right_rad``
(rotation of each wheel over the interval [rad], positive rolling forward), ``sensor_dx_m``,
``sensor_dy_m``, ``sensor_dyaw_rad`` (the sensor's displacement over the interval in its own
frame at the start of it, e.g. from matching consecutive scans). One row per interval; extra
columns are ignored; blank lines and lines starting with ``#`` are skipped; a UTF-8 byte-order
mark is dropped. See :mod:`umbmark.model.intervals` for the meaning.

**Covariances** (optional): the six columns ``cov_dx_dx``, ``cov_dx_dy``, ``cov_dx_dyaw``,
``cov_dy_dy``, ``cov_dy_dyaw``, ``cov_dyaw_dyaw`` [m^2, m rad, rad^2] give each sensor
displacement's own covariance (a scan matcher's), on the interval's row; a self-calibration
adds the noise it estimates to it.

**Wheel rates** (optional): the four columns ``rate_left_start_rad_s``,
``rate_right_start_rad_s``, ``rate_left_end_rad_s``, ``rate_right_end_rad_s`` give the wheels'
rates at the interval's two stamps (from the wheel data around them), on the interval's row;
a self-calibration models the errors of the wheel data's stamps with them.

**Steps**: an interval may take several rows, its steps in order (e.g. from one scan to the
next between two keyframes): a row whose three sensor cells are empty is a step of the
interval that the next complete row ends. Each row holds its own step's ``dt_s``,
``left_rad``, ``right_rad``; the interval is their sum, and its motion their arcs composed
(:class:`~umbmark.model.intervals.IntervalSteps`).

Errors name the file and line (``file:line: problem``). Values that parse but look wrong
(zero durations, more than half a turn of the sensor in one interval, wheel rotations or
displacements that suggest other units) do not stop the reading: they come back in
:attr:`~umbmark.model.intervals.Intervals.warnings`.

Imports :mod:`umbmark.model.intervals`, :mod:`umbmark.errors` and the helpers of
:mod:`umbmark.io`.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io._text import csv_rows, csv_writer, header_columns, parse_number, read_text
from umbmark.io.atomic import atomic_write
from umbmark.model.intervals import Intervals, IntervalSteps

__all__ = [
    "COLUMNS",
    "COVARIANCE_COLUMNS",
    "RATE_COLUMNS",
    "read_intervals_csv",
    "parse_intervals_csv",
    "format_intervals_csv",
    "write_intervals_csv",
]

COLUMNS = ("dt_s", "left_rad", "right_rad", "sensor_dx_m", "sensor_dy_m", "sensor_dyaw_rad")
COVARIANCE_COLUMNS = ("cov_dx_dx", "cov_dx_dy", "cov_dx_dyaw", "cov_dy_dy", "cov_dy_dyaw", "cov_dyaw_dyaw")
_COV_INDEX = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
RATE_COLUMNS = ("rate_left_start_rad_s", "rate_right_start_rad_s", "rate_left_end_rad_s", "rate_right_end_rad_s")

# beyond these a value is read but looks like other units (warned about, not refused)
_WHEEL_RAD_PER_INTERVAL = 100.0  # 16 wheel turns between two scans: encoder ticks?
_SENSOR_M_PER_INTERVAL = 5.0  # 5 m between two scans: millimetres?
_MAX_CELL = 1e6  # a duration, wheel rotation or displacement beyond this is no interval's
_DT_S_PER_INTERVAL = 60.0  # a minute between two matched scans: milliseconds?


def read_intervals_csv(path: str | Path) -> Intervals:
    """Read an intervals file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Intervals
        With ``source`` the file name and the reader's ``warnings``.

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    return parse_intervals_csv(read_text(path), source=str(path))


def parse_intervals_csv(text: str, source: str = "<intervals>") -> Intervals:
    """Parse the text of an intervals file (see the module docstring).

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Its name, for error messages.

    Returns
    -------
    Intervals
        The intervals, ``source`` and the warnings about suspicious values.

    Raises
    ------
    InputError
        No header with the six columns, a column twice, a row with too few fields, a cell that
        is not a finite number, a negative duration, a row with some sensor cells empty but not
        all, steps that no complete row ends, no rows (file and line named).
    """
    header: list[str] | None = None
    with_cov = False
    with_rates = False
    header_line = 0
    col: dict[str, int] = {}
    values: list[list[float]] = []
    lines: list[int] = []
    for line, row in csv_rows(text, source):
        if header is None:
            header = header_columns(row)
            header_line = line
            missing = [c for c in COLUMNS if c not in header]
            if missing:
                raise InputError(
                    "no header with the intervals-file columns: missing "
                    + ", ".join(missing)
                    + " (expected "
                    + ",".join(COLUMNS)
                    + ")",
                    source,
                    line,
                )
            dup = [c for c in COLUMNS if header.count(c) > 1]
            if dup:
                raise InputError(f"column {dup[0]} appears twice in the header", source, line)
            col = {c: header.index(c) for c in COLUMNS}
            with_cov = _column_group(header, COVARIANCE_COLUMNS, "covariance", "six", col, source, line)
            with_rates = _column_group(header, RATE_COLUMNS, "wheel-rate", "four", col, source, line)
            continue
        need = max(col.values()) + 1
        if len(row) < need:
            raise InputError(f"has {len(row)} fields, the header has {len(header)}", source, line)
        blank = [not row[col[c]].strip() for c in COLUMNS[3:]]
        if any(blank) and not all(blank):
            raise InputError(
                "some sensor cells are empty: a step row leaves all three empty, an interval's row fills them",
                source,
                line,
            )
        extra = (COVARIANCE_COLUMNS if with_cov else ()) + (RATE_COLUMNS if with_rates else ())
        names = COLUMNS[:3] if all(blank) else COLUMNS + extra
        pad = [math.nan] * (3 + len(extra)) if all(blank) else []
        vals = [parse_number(row[col[c]], c, source, line) for c in names] + pad
        if vals[0] < 0:
            raise InputError(f"column dt_s: {row[col['dt_s']].strip()} s is negative", source, line)
        for c, v in zip(COLUMNS, vals[:6]):
            if abs(v) > _MAX_CELL:  # no interval between two scans holds a million seconds, radians or metres
                raise InputError(
                    f"column {c}: {row[col[c]].strip()} is beyond any interval (at most {_MAX_CELL:g})", source, line
                )
        values.append(vals)
        lines.append(line)
    if header is None:
        raise InputError("empty file: no header and no intervals", source)
    if not values:
        raise InputError("no intervals after the header", source, header_line)
    rows = np.asarray(values, dtype=float)
    ends = np.flatnonzero(~np.isnan(rows[:, 3]))
    if ends.size == 0 or ends[-1] != len(rows) - 1:
        first = int(ends[-1]) + 1 if ends.size else 0
        raise InputError(
            "a step row without a row of the interval after it (the last step's row holds the sensor's displacement)",
            source,
            int(lines[first]),
        )
    start = np.concatenate([[0], ends + 1])
    steps = None
    if len(ends) < len(rows):
        steps = IntervalSteps(rows[:, 1], rows[:, 2], start, rows[:, 0])
    a = np.column_stack([np.add.reduceat(rows[:, c], start[:-1]) for c in range(3)] + [rows[ends, 3:6]])
    warnings = _warnings(a, np.asarray(lines)[ends], source)
    cov = None
    if with_cov:
        cov = np.zeros((len(ends), 3, 3))
        for j, (u, v) in enumerate(_COV_INDEX):
            cov[:, u, v] = cov[:, v, u] = rows[ends, 6 + j]
        bad = np.flatnonzero(np.linalg.eigvalsh(cov)[:, 0] < -1e-12 * np.abs(cov).max(axis=(1, 2)))
        if bad.size:
            raise InputError(
                "the covariance is not positive semi-definite", source, int(np.asarray(lines)[ends][bad[0]])
            )
    rates = None
    if with_rates:
        first = 6 + (6 if with_cov else 0)
        rates = rows[ends, first : first + 4]
    return Intervals(a[:, 0], a[:, 1], a[:, 2], a[:, 3:6], source, tuple(warnings), steps, cov, rates)


def _column_group(
    header: list[str], names: tuple[str, ...], what: str, count: str, col: dict[str, int], source: str, line: int
) -> bool:
    """Whether the header holds the optional columns ``names`` (all of them, or none: else an
    error naming those missing); their positions go into ``col``."""
    have = [c for c in names if c in header]
    if have and len(have) < len(names):
        lack = [c for c in names if c not in header]
        raise InputError(
            f"{what} columns {', '.join(have)} without {', '.join(lack)}: give all {count} or none", source, line
        )
    col.update({c: header.index(c) for c in have})
    return bool(have)


def _where(mask: np.ndarray, lines: np.ndarray, source: str) -> str:
    idx = np.flatnonzero(mask)
    first = ", ".join(str(int(n)) for n in lines[idx[:3]])
    more = f" and {idx.size - 3} more" if idx.size > 3 else ""
    return f"{source}: {idx.size} interval{'s' if idx.size != 1 else ''} (line {first}{more})"


def _warnings(a: np.ndarray, lines: np.ndarray, source: str) -> list[str]:
    out = []
    zero = a[:, 0] == 0
    if zero.any():
        out.append(_where(zero, lines, source) + " of zero duration (`dt_s` = 0)")
    half = np.abs(a[:, 5]) > math.pi
    if half.any():
        out.append(
            _where(half, lines, source) + " where the sensor turns more than half a turn "
            "(|sensor_dyaw_rad| > pi): degrees instead of radians, or intervals too long for scan matching"
        )
    wheel = np.maximum(np.abs(a[:, 1]), np.abs(a[:, 2])) > _WHEEL_RAD_PER_INTERVAL
    if wheel.any():
        out.append(
            _where(wheel, lines, source) + f" where a wheel turns more than {_WHEEL_RAD_PER_INTERVAL:g} rad: "
            "encoder ticks or degrees instead of radians?"
        )
    far = np.hypot(a[:, 3], a[:, 4]) > _SENSOR_M_PER_INTERVAL
    if far.any():
        out.append(
            _where(far, lines, source) + f" where the sensor moves more than {_SENSOR_M_PER_INTERVAL:g} m: "
            "millimetres instead of metres?"
        )
    slow = a[:, 0] > _DT_S_PER_INTERVAL
    if slow.any():
        out.append(
            _where(slow, lines, source) + f" longer than {_DT_S_PER_INTERVAL:g} s (`dt_s`): milliseconds instead "
            "of seconds?"
        )
    return out


def format_intervals_csv(iv: Intervals) -> str:
    """The text of an intervals file (full double precision: it reads back exactly).

    Parameters
    ----------
    iv : Intervals
        The intervals.

    Returns
    -------
    str
        The header ``dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad`` (and
        the covariance and the wheel-rate columns when the intervals have them) and one line per
        interval, or per step of the intervals that have steps (the sensor cells
        on the interval's last step; a step's duration, when the steps do not know it, an
        equal share of the interval's).
    """
    out = io.StringIO()
    w = csv_writer(out, lineterminator="\n")
    cov = None if iv.covariance is None else np.column_stack([iv.covariance[:, u, v] for u, v in _COV_INDEX])
    rates = iv.end_rates
    w.writerow(COLUMNS + (COVARIANCE_COLUMNS if cov is not None else ()) + (RATE_COLUMNS if rates is not None else ()))

    def end(k: int) -> list[str]:
        cells = [repr(float(v)) for v in iv.sensor[k]]
        if cov is not None:
            cells += [repr(float(v)) for v in cov[k]]
        if rates is not None:
            cells += [repr(float(v)) for v in rates[k]]
        return cells

    blank = [""] * (3 + (0 if cov is None else 6) + (0 if rates is None else 4))
    st = iv.steps
    if st is None:
        for k in range(len(iv)):
            w.writerow([repr(float(iv.dt_s[k])), repr(float(iv.left_rad[k])), repr(float(iv.right_rad[k]))] + end(k))
        return out.getvalue()
    counts = np.diff(st.start)
    dt = np.repeat(iv.dt_s / counts, counts) if st.dt_s is None else st.dt_s
    for k in range(len(iv)):
        for j in range(int(st.start[k]), int(st.start[k + 1])):
            cells = [repr(float(dt[j])), repr(float(st.left_rad[j])), repr(float(st.right_rad[j]))]
            last = j == st.start[k + 1] - 1
            w.writerow(cells + (end(k) if last else blank))
    return out.getvalue()


def write_intervals_csv(iv: Intervals, path: str | Path) -> None:
    """Write an intervals file, atomically (whole or not at all).

    Parameters
    ----------
    iv : Intervals
        The intervals.
    path : str or Path
        The file.

    Raises
    ------
    InputError
        A path that cannot be written (no such folder, a folder).
    """
    atomic_write(path, format_intervals_csv(iv))
