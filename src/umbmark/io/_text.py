"""Shared helpers of the text log readers: read a file, parse numeric CSV rows with line numbers."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from umbmark.errors import InputError


def read_text(path) -> str:
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", source=str(path))
    if p.is_dir():
        raise InputError("is a folder, not a file", source=str(path))
    try:
        return p.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8) file", source=str(path)) from None
    except OSError as e:
        raise InputError(f"cannot read: {e.strerror}", source=str(path)) from None


def csv_rows(text: str, source: str):
    """Yield ``(line, cells)`` of the CSV rows of ``text`` that carry data: blank lines and lines
    whose first cell starts with ``#`` are skipped. ``line`` is the 1-based number of the row's
    last physical line. Malformed CSV raises an :class:`InputError` naming the line."""
    reader = csv.reader(io.StringIO(text, newline=None))
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as e:
            raise InputError(f"not valid CSV: {e}", source, reader.line_num) from None
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        yield reader.line_num, row


def header_columns(row) -> list[str]:
    """A header row's column names: stripped, lower case."""
    return [c.strip().lower() for c in row]


def numeric_rows(text: str, source: str, ncols: int | None = None, names=None, skip=(), delimiter=","):
    """Parse CSV lines of numbers into a (K, ncols) array.

    Blank lines and lines starting with ``#`` are skipped, as are the 1-based line numbers in
    ``skip`` (e.g. a header). Returns ``(array, line_numbers)``. Every problem raises an
    :class:`InputError` naming the file and line.
    """
    rows, lines = [], []
    skip = set(skip)
    for i, raw in enumerate(text.splitlines(), 1):
        if i in skip:
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
            try:
                v = float(c)
            except ValueError:
                raise InputError(
                    f"column {col}: {c!r} is not a number" if c else f"column {col} is empty", source, i
                ) from None
            if not math.isfinite(v):
                raise InputError(f"column {col}: {c!r} is not a finite number", source, i)
            vals.append(v)
        rows.append(vals)
        lines.append(i)
    if not rows:
        raise InputError("no data rows", source)
    return np.asarray(rows, dtype=float), np.asarray(lines)


def check_increasing_time(t, lines, source: str):
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(f"time {t[k]:g} s does not increase (previous row: {t[k - 1]:g} s)", source, int(lines[k]))
