"""Shared helpers of the text log readers: read a file, parse numeric CSV rows with line numbers."""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from umbmark._numbers import strict_float
from umbmark.errors import InputError

__all__ = [
    "check_increasing_time",
    "csv_rows",
    "csv_writer",
    "header_columns",
    "numeric_rows",
    "parse_json",
    "parse_number",
    "read_text",
]


def read_text(path: str | Path, max_bytes: int | None = None) -> str:
    """The text of a UTF-8 file (a byte-order mark dropped).

    Parameters
    ----------
    path : str or Path
        The file.
    max_bytes : int, optional
        Read no more than this: a longer file (or an endless one, ``/dev/zero``) is refused.

    Returns
    -------
    str

    Raises
    ------
    InputError
        A missing file, a folder, not UTF-8, unreadable, longer than ``max_bytes``.
    """
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", source=str(path))
    if p.is_dir():
        raise InputError("is a folder, not a file", source=str(path))
    try:
        if max_bytes is None:
            return p.read_text(encoding="utf-8-sig")
        with open(p, "rb") as fh:
            data = fh.read(max_bytes + 1)
        if len(data) > max_bytes:
            what = "" if p.is_file() else " (a device or a pipe, not a file)"
            raise InputError(f"longer than {max_bytes:,} bytes{what}: not the file expected here", source=str(path))
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8) file", source=str(path)) from None
    except OSError as e:
        raise InputError(f"cannot read: {e.strerror}", source=str(path)) from None


def parse_json(text: str, source: str, expected: str = "") -> Any:
    """The value of a JSON text, or one line saying why there is none.

    Parameters
    ----------
    text : str
        The JSON.
    source : str
        Its file, for messages.
    expected : str
        What the file should be, appended to a message (``"a calibration is ..."``).

    Returns
    -------
    object

    Raises
    ------
    InputError
        Not JSON (the line named), nested too deeply, or a number of more digits than Python
        reads (thousands: no value of a robot's).
    """
    tail = f"; {expected}" if expected else ""
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"not valid JSON: {e.msg}{tail}", source, e.lineno) from None
    except RecursionError:
        raise InputError(f"JSON nested too deeply{tail}", source) from None
    except ValueError as e:  # Python's limit on the digits of an integer (4300 by default)
        m = re.search(r"value has (\d+) digits", str(e))
        digits = f"{m.group(1)} digits" if m else "thousands of digits"
        raise InputError(f"a number of {digits}: no value a robot's file holds{tail}", source) from None


def csv_rows(text: str, source: str) -> Iterator[tuple[int, list[str]]]:
    """The CSV rows of a text that carry data.

    Blank lines and comment lines (a line that starts with ``#`` outside a quoted field) are
    skipped; a quoted first cell that starts with ``#`` (``"#3"``, as :func:`csv_writer` writes
    it) is data.

    Parameters
    ----------
    text : str
        The CSV text.
    source : str
        Its name, for error messages.

    Yields
    ------
    line : int
        The 1-based number of the row's last physical line.
    cells : list of str
        The row.

    Raises
    ------
    InputError
        Malformed CSV (the line named).
    """
    reader = csv.reader(_without_comments(text))
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as e:
            raise InputError(f"not valid CSV: {e}", source, reader.line_num) from None
        if not row or all(not c.strip() for c in row):
            continue
        yield reader.line_num, row


def _without_comments(text: str) -> Iterator[str]:
    """The lines of a CSV text, each comment line replaced by an empty one (line numbers kept).

    A line is a comment when it starts (after blanks) with ``#`` and no quoted field is open
    (an odd number of quote characters so far opens one: doubled quotes inside a field keep
    the parity).
    """
    in_quotes = False
    for line in io.StringIO(text, newline=""):
        if not in_quotes and line.lstrip().startswith("#"):
            yield "\n"
            continue
        if line.count('"') % 2:
            in_quotes = not in_quotes
        yield line


class _CommentSafeWriter:
    """A CSV writer (comma-separated, minimal quoting) whose rows read back exactly, through
    :func:`csv_rows`, as the cells they were given: a cell is quoted when it holds a comma, a
    quote or a line break (``\\r`` included, which :func:`csv.writer` leaves bare when the line
    terminator is ``\\n``), and a first cell when it starts with ``#`` (it would read as a comment).
    """

    def __init__(self, out: TextIO, lineterminator: str = "\n") -> None:
        self._out = out
        self._end = lineterminator

    @staticmethod
    def _cell(v: object, first: bool) -> str:
        c = repr(v) if isinstance(v, float) else str(v)
        if any(ch in c for ch in ',"\r\n') or (first and c.lstrip().startswith("#")):
            return '"' + c.replace('"', '""') + '"'
        return c

    def writerow(self, row: Iterable[object]) -> None:
        self._out.write(",".join(self._cell(v, i == 0) for i, v in enumerate(row)) + self._end)

    def writerows(self, rows: Iterable[Iterable[object]]) -> None:
        for row in rows:
            self.writerow(row)


def csv_writer(out: TextIO, lineterminator: str = "\n") -> _CommentSafeWriter:
    """A CSV writer on ``out`` whose rows :func:`csv_rows` reads back as the same cells, never as
    comments (see :class:`_CommentSafeWriter`)."""
    return _CommentSafeWriter(out, lineterminator)


def header_columns(row: Iterable[str]) -> list[str]:
    """A header row's column names: stripped, lower case.

    Parameters
    ----------
    row : list of str
        The header row.

    Returns
    -------
    list of str
    """
    return [c.strip().lower() for c in row]


def parse_number(cell: str, col: str, source: str, line: int, allow_empty: bool = False) -> float:
    """The number in one cell of a text file.

    Parameters
    ----------
    cell : str
        The cell's text (surrounding white space ignored).
    col : str
        The cell's column, for error messages.
    source : str
        The file's name, for error messages.
    line : int
        The cell's line, for error messages.
    allow_empty : bool
        Whether an empty cell is allowed (read as NaN).

    Returns
    -------
    float
        A finite number, or NaN for an allowed empty cell.

    Raises
    ------
    InputError
        A cell that is empty (unless allowed), not a number or not a finite number (file and
        line named).
    """
    s = cell.strip()
    if not s:
        if allow_empty:
            return math.nan
        raise InputError(f"column {col} is empty", source, line)
    try:
        v = strict_float(s)
    except ValueError:
        raise InputError(f"column {col}: {s!r} is not a number", source, line) from None
    if not math.isfinite(v):
        raise InputError(f"column {col}: {s!r} is not a finite number", source, line)
    return v


def numeric_rows(
    text: str,
    source: str,
    ncols: int | None = None,
    names: Sequence[str] | None = None,
    skip: Iterable[int] = (),
    delimiter: str | None = ",",
) -> tuple[NDArray[np.float64], NDArray[np.int_]]:
    """Parse lines of numbers into an array.

    Blank lines and lines starting with ``#`` are skipped, as are the 1-based line numbers in
    ``skip`` (e.g. a header).

    Parameters
    ----------
    text : str
        The text.
    source : str
        Its name, for error messages.
    ncols : int, optional
        The number of columns (default: the first data line's).
    names : sequence of str, optional
        Column names, for error messages.
    skip : iterable of int
        Line numbers to skip.
    delimiter : str or None
        The cell separator (None: runs of white space).

    Returns
    -------
    array : numpy.ndarray
        (K, ncols) numbers.
    lines : numpy.ndarray
        The line number of each row.

    Raises
    ------
    InputError
        A wrong number of fields, a cell that is not a finite number, no data rows (file and
        line named).
    """
    rows: list[list[float]] = []
    lines: list[int] = []
    skipped = set(skip)
    for i, raw in enumerate(text.splitlines(), 1):
        if i in skipped:
            continue
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        cells = [c.strip() for c in s.split(delimiter)]
        if ncols is None:
            ncols = len(cells)
        if len(cells) != ncols:
            raise InputError(f"has {len(cells)} fields, expected {ncols}", source, i)
        vals = []
        for j, c in enumerate(cells):
            col = names[j] if names is not None and j < len(names) else f"{j + 1}"
            vals.append(parse_number(c, col, source, i))
        rows.append(vals)
        lines.append(i)
    if not rows:
        raise InputError("no data rows", source)
    return np.asarray(rows, dtype=float), np.asarray(lines)


MAX_TIME_S = 1e11
"""The latest time stamp of any clock a log is stamped with [s]: 3000 years, past any Unix time
in seconds (1.7e9 in 2024); the same time in micro- or nanoseconds lies beyond it."""


def check_clock(t: NDArray[np.float64], lines: NDArray[np.int_], source: str, column: str = "time") -> None:
    """Refuse a time stamp beyond :data:`MAX_TIME_S` (file, line and column named).

    Parameters
    ----------
    t : numpy.ndarray
        The times [s].
    lines : numpy.ndarray
        Their line numbers.
    source : str
        The file, for error messages.
    column : str
        The column's name, for error messages.

    Raises
    ------
    InputError
        A time beyond any clock (likely micro- or nanoseconds).
    """
    far = np.abs(t) > MAX_TIME_S
    if far.any():
        k = int(np.flatnonzero(far)[0])
        raise InputError(
            f"column {column}: {t[k]:g} s is on no clock (beyond {MAX_TIME_S:g} s, 3000 years): microseconds or "
            "nanoseconds instead of seconds, or a broken value?",
            source,
            int(lines[k]),
        )


def check_increasing_time(t: NDArray[np.float64], lines: NDArray[np.int_], source: str) -> None:
    """Check that sample times are on a clock (:func:`check_clock`) and increase.

    Parameters
    ----------
    t : numpy.ndarray
        The times [s].
    lines : numpy.ndarray
        Their line numbers.
    source : str
        The file, for error messages.

    Raises
    ------
    InputError
        A time beyond any clock, or one that does not increase (file and line named).
    """
    check_clock(t, lines, source)
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(f"time {t[k]:g} s does not increase (previous row: {t[k - 1]:g} s)", source, int(lines[k]))
