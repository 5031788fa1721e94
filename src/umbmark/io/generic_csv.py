"""The generic encoder-log CSV.

One file per run, or several runs in one file told apart by a ``run`` column. A header row
names the columns (any order, extra columns ignored):

* ``time_s``: sample time [s], increasing within a run;
* ``left_ticks``, ``right_ticks``: encoder pulses, **cumulative** (a counter, the default)
  or **incremental** (pulses counted in that sample), as the reader is told;
* optional ground truth ``x_m``, ``y_m`` and ``theta_rad`` (or ``theta_deg``): the true pose
  in any fixed frame; it is brought into the run's start frame (origin at the first row's
  pose, x along its heading). Cells may be left empty where there is no measurement. If
  only the last row of a run has them, they are taken as a measured end pose already in the
  start frame (e.g. taped).
* optional ``run``: a run label; rows of one run must be consecutive.

Blank lines and lines starting with ``#`` are skipped. The nominal geometry (wheel
diameters, wheelbase, pulses per wheel revolution) is given to the reader
(``--wheel-diameter-mm``, ``--wheelbase-mm``, ``--pulses-per-wheel-rev``), or read from a
comment line before the header as :func:`format_generic_csv` writes it
(:func:`read_csv_geometry`), e.g. (one line)::

    # umbmark nominal geometry: left_diameter_mm=100.0 right_diameter_mm=100.0
      wheelbase_mm=300.0 pulses_per_wheel_rev=6.283185307179586
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io._checks import check_tick_mode, wheels_against_truth
from umbmark.io._text import check_clock, csv_rows, csv_writer, header_columns, parse_number, read_text
from umbmark.model.dataset import Dataset, Run, WheelGeometry, to_start_frame
from umbmark.model.geometry import unit_slip

__all__ = [
    "read_generic_csv",
    "format_generic_csv",
    "read_csv_geometry",
    "iter_generic_csv",
    "CsvChunk",
    "REQUIRED",
    "OPTIONAL",
    "GEOMETRY_KEYS",
]

REQUIRED = ("time_s", "left_ticks", "right_ticks")
# wheel samples further apart than this (seconds, the median) are a time column in another unit
_MAX_PERIOD_S = 2.0
OPTIONAL = ("x_m", "y_m", "theta_rad", "theta_deg", "run")


GEOMETRY_KEYS = ("left_diameter_mm", "right_diameter_mm", "wheelbase_mm", "pulses_per_wheel_rev")
_GEOMETRY_LINE = "# umbmark nominal geometry:"
_OLD_GEOMETRY_LINE = "# umbmark generic log; nominal diameters left/right [mm], wheelbase [mm], pulses per wheel rev:"


def _geometry_values(line: str, src: str, n: int) -> dict[str, float] | None:
    """The geometry of one comment line (None: not a geometry line)."""
    s = line.strip()
    if s.startswith(_GEOMETRY_LINE):
        out: dict[str, str] = {}
        for item in s[len(_GEOMETRY_LINE) :].split():
            key, eq, val = item.partition("=")
            if not eq or key not in GEOMETRY_KEYS:
                raise InputError(f"bad nominal geometry item {item!r} (expected {', '.join(GEOMETRY_KEYS)})", src, n)
            out[key] = val
    elif s.lstrip('"').startswith(_OLD_GEOMETRY_LINE):  # the comment row format_generic_csv wrote before
        cells = next(csv.reader([s]))[1:]
        if len(cells) != 4:
            raise InputError("bad nominal geometry line: expected 4 numbers", src, n)
        out = dict(zip(GEOMETRY_KEYS, cells))
    else:
        return None
    missing = [k for k in GEOMETRY_KEYS if k not in out]
    if missing:
        raise InputError(f"the nominal geometry line lacks {', '.join(missing)}", src, n)
    vals = {}
    for k in GEOMETRY_KEYS:
        v = parse_number(out[k], k, src, n)
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"nominal geometry {k} must be a positive number, got {out[k]!r}", src, n)
        slip = None if k == "pulses_per_wheel_rev" else unit_slip(k.split("_")[-2], v * 1e-3, "mm")
        if slip is not None:
            raise InputError(f"nominal geometry {k}: {slip}", src, n)
        vals[k] = v
    return vals


def read_csv_geometry(path: str | Path) -> dict[str, float] | None:
    """The nominal geometry written into a generic CSV log's comment lines (before its header).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict or None
        ``left_diameter_mm``, ``right_diameter_mm``, ``wheelbase_mm``, ``pulses_per_wheel_rev``;
        None when the file holds no geometry line.

    Raises
    ------
    InputError
        An unreadable file, or a geometry line that is not four positive numbers (line named).
    """
    src = str(path)
    for n, line in enumerate(read_text(path).splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if not s.lstrip('"').startswith("#"):
            return None  # the header: no geometry before it
        vals = _geometry_values(s, src, n)
        if vals is not None:
            return vals
    return None


def _check_ticks(ticks: str) -> None:
    if ticks not in ("cumulative", "incremental"):
        raise InputError(f"ticks must be 'cumulative' or 'incremental', got {ticks!r}")


def _check_header(header: list[str], src: str, line: int | None) -> list[str]:
    """The ground-truth columns of a header (none, or x, y and one heading column), after
    checking it has the required columns."""
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise InputError(
            "header lacks column(s) "
            + ", ".join(missing)
            + " (expected time_s,left_ticks,right_ticks[,x_m,y_m,theta_rad|theta_deg][,run])",
            src,
            line,
        )
    if "theta_rad" in header and "theta_deg" in header:
        raise InputError("give theta_rad or theta_deg, not both", src, line)
    gt_cols: list[str] = [c for c in ("x_m", "y_m", "theta_rad", "theta_deg") if c in header]
    if gt_cols and len(gt_cols) != 3:
        raise InputError("ground truth needs x_m, y_m and theta_rad (or theta_deg)", src, line)
    return gt_cols


def _parse(text: str, src: str):
    """The header and the ``(line, cells)`` data rows of a generic CSV file."""
    header = None
    rows = []
    for line, row in csv_rows(text, src):
        if header is None:
            header = header_columns(row)
            _check_header(header, src, line)
            continue
        rows.append((line, row))
    if header is None:
        raise InputError("empty file: no header", src)
    if not rows:
        raise InputError("no data rows after the header", src)
    return header, rows


def _group_runs(path, header: list[str], rows, src: str) -> list[tuple[str, list]]:
    """The rows of each run, in file order: ``(label, [(line, values)])``; values are time,
    left and right ticks and (when the file has them) x, y, theta of the ground truth."""
    col = {c: header.index(c) for c in REQUIRED + OPTIONAL if c in header}
    theta_col = "theta_rad" if "theta_rad" in col else "theta_deg"
    groups: dict = {}
    order = []
    for line, r in rows:
        need = max(col.values()) + 1
        if len(r) < need:
            raise InputError(f"has {len(r)} fields, the header has {len(header)}", src, line)
        label = r[col["run"]].strip() if "run" in col else Path(path).stem
        if "run" in col and not label:
            raise InputError("column run is empty", src, line)
        if label not in groups:
            groups[label] = []
            order.append(label)
        elif order[-1] != label:
            raise InputError(f"rows of run {label!r} are not consecutive", src, line)
        vals = [parse_number(r[col[c]], c, src, line) for c in REQUIRED]
        if "x_m" in col:
            vals += [parse_number(r[col[c]], c, src, line, allow_empty=True) for c in ("x_m", "y_m", theta_col)]
        groups[label].append((line, vals))
    return [(label, groups[label]) for label in order]


def _increments(a: np.ndarray, ticks: str) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample wheel increments of one run's tick columns (the first sample: 0)."""
    if ticks == "cumulative":
        return np.diff(a[:, 1], prepend=a[0, 1]), np.diff(a[:, 2], prepend=a[0, 2])
    dl, dr = a[:, 1].copy(), a[:, 2].copy()
    dl[0] = dr[0] = 0.0
    return dl, dr


def _ground_truth(g3: np.ndarray, lines: np.ndarray, degrees: bool, src: str):
    """``(gt, gt_end)`` of one run from its x, y, theta columns (NaN: empty cells): a track in
    the start frame, or only a measured end pose (the last row alone), or neither."""
    g3 = g3.copy()
    if degrees:
        g3[:, 2] = np.radians(g3[:, 2])
    partial = np.isfinite(g3).any(axis=1) & ~np.isfinite(g3).all(axis=1)
    if partial.any():
        k = int(np.flatnonzero(partial)[0])
        raise InputError("ground truth x_m, y_m, theta must be all given or all empty", src, int(lines[k]))
    _check_headings(g3, lines, src, degrees)
    far = np.abs(np.nan_to_num(g3[:, :2])) > _MAX_POSITION_M
    if far.any():
        k = int(np.flatnonzero(far.any(axis=1))[0])
        raise InputError(
            f"ground truth {'x_m' if far[k, 0] else 'y_m'} {g3[k, 0 if far[k, 0] else 1]:g} m is beyond any test "
            f"track ({_MAX_POSITION_M:g} m): millimetres instead of metres, or a broken value?",
            src,
            int(lines[k]),
        )
    ok = np.isfinite(g3[:, 0])
    if ok.sum() == 1 and ok[-1]:
        return None, g3[-1]
    if not ok.any():
        return None, None
    if not ok[0]:
        raise InputError("the ground truth must start at the first row of a run (its start pose)", src, int(lines[0]))
    th = g3[:, 2].copy()
    th[ok] = np.unwrap(th[ok])
    x, y, t = to_start_frame(g3[ok, 0], g3[ok, 1], th[ok])
    gt = np.full_like(g3, np.nan)
    gt[ok] = np.column_stack([x, y, t])
    return gt, None


_MAX_TICKS = 2.0**63  # beyond any encoder counter
_MAX_POSITION_M = 1e5  # a ground-truth position beyond this (m) is not of a test track
# a ground-truth heading beyond this (rad), even unwrapped, is no robot's: 160 000 turns, a day
# of turning at two turns a second
_MAX_HEADING_RAD = 1e6


def _check_headings(g3: np.ndarray, lines: np.ndarray, src: str, degrees: bool) -> None:
    """Refuse a ground-truth heading (radians here) beyond :data:`_MAX_HEADING_RAD`."""
    far = np.abs(np.nan_to_num(g3[:, 2])) > _MAX_HEADING_RAD
    if far.any():
        k = int(np.flatnonzero(far)[0])
        col, v = ("theta_deg", math.degrees(g3[k, 2])) if degrees else ("theta_rad", g3[k, 2])
        raise InputError(
            f"ground truth {col} {v:g} is no robot's heading (beyond {_MAX_HEADING_RAD:g} rad even unwrapped): "
            "a broken value, or another column?",
            src,
            int(lines[k]),
        )


def _check_tick_values(ticks_lr: np.ndarray, lines: np.ndarray, src: str, ticks: str) -> None:
    """Refuse a tick beyond any counter."""
    big = np.flatnonzero(~(np.abs(ticks_lr) < _MAX_TICKS).all(axis=1))
    if big.size:
        k = int(big[0])
        i = 0 if not abs(ticks_lr[k, 0]) < _MAX_TICKS else 1
        col = ("left_ticks", "right_ticks")[i]
        raise InputError(f"column {col}: {ticks_lr[k, i]:g} is beyond any encoder counter", src, int(lines[k]))


def _batch_run(label: str, rows: list, src: str, where: str, ticks: str, degrees: bool) -> Run:
    """One run from its ``(line, values)`` rows (see :func:`_group_runs`)."""
    lines = np.array([ln for ln, _ in rows])
    a = np.array([v for _, v in rows], dtype=float)
    if len(a) < 2:
        raise InputError("a run needs at least two rows", where, int(lines[0]))
    check_clock(a[:, 0], lines, src, "time_s")
    bad = np.flatnonzero(np.diff(a[:, 0]) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(f"time {a[k, 0]:g} s does not increase (previous row: {a[k - 1, 0]:g} s)", src, int(lines[k]))
    _check_tick_values(a[:, 1:3], lines, src, ticks)
    dl, dr = _increments(a, ticks)
    gt = gt_end = None
    if a.shape[1] > 3:
        gt, gt_end = _ground_truth(a[:, 3:6], lines, degrees, src)
    return Run(label, a[:, 0] - a[0, 0], dl, dr, gt, gt_end, where, float(a[0, 0]))


def read_generic_csv(
    paths: str | Path | Sequence[str | Path],
    nominal: WheelGeometry,
    pulses_per_wheel_rev: float,
    ticks: str = "cumulative",
    side_m: float | None = None,
    name: str | None = None,
) -> Dataset:
    """Read one or more generic CSV logs into a data set.

    Parameters
    ----------
    paths : str, Path or sequence of them
        The files (each one run, or several runs told apart by a ``run`` column).
    nominal : WheelGeometry
        The nominal geometry the logs were recorded with.
    pulses_per_wheel_rev : float
        Encoder pulses per wheel revolution.
    ticks : str
        ``cumulative`` (a running counter) or ``incremental`` (pulses counted in each sample).
    side_m : float, optional
        The side of the square: the runs are UMBmark squares.
    name : str, optional
        The data set's name (default: the file's name, or the folder's for several files).

    Returns
    -------
    Dataset

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    _check_ticks(ticks)
    if isinstance(paths, (str, Path)):
        paths = [paths]
    runs = []
    for path in paths:
        src = str(path)
        header, rows = _parse(read_text(path), src)
        with_runs = "run" in header
        degrees = "theta_rad" not in header
        for label, group in _group_runs(path, header, rows, src):
            where = f"{src} (run {label})" if with_runs else src
            runs.append(_batch_run(label, group, src, where, ticks, degrees))
            raw = np.array([v[1:3] for _, v in group], dtype=float)
            check_tick_mode(raw, ticks, runs[-1], nominal, float(pulses_per_wheel_rev), side_m, group[0][0])
    if not runs:
        raise InputError("no runs")
    if name is None:
        name = Path(paths[0]).stem if len(paths) == 1 else Path(paths[0]).parent.name or "logs"
    warnings = []
    for run in runs:  # samples seconds apart: a time column in milliseconds
        period = float(np.median(np.diff(run.t)))
        if period > _MAX_PERIOD_S:
            warnings.append(
                f"{run.source or src} (run {run.name}): the samples are {period:g} s apart (median of `time_s`): "
                f"a wheel log samples many times a second; time_s in milliseconds? (the durations and speeds "
                "then read 1000 times too long and too slow)"
            )
    for run in runs:  # the wheels against the ground truth: units, swapped wheels, nothing tracked
        warnings += wheels_against_truth(
            run,
            nominal,
            float(pulses_per_wheel_rev),
            "that x_m and y_m are in metres, the wheel diameters and the pulses per wheel revolution",
            "the wheelbase, that the heading column is in its unit (theta_rad or theta_deg)",
            "name the column theta_deg for degrees",
        )
    meta = {"format": "csv", "warnings": tuple(warnings)} if warnings else {"format": "csv"}
    return Dataset(name, nominal, float(pulses_per_wheel_rev), tuple(runs), side_m, str(paths[0]), meta=meta)


def format_generic_csv(ds: Dataset) -> str:
    """A data set as one generic CSV file.

    A ``run`` column, cumulative ticks, the ground truth in each run's start frame; a first
    comment line records the nominal geometry (:func:`read_csv_geometry` reads it back, and
    :func:`umbmark.io.load.load_logs` uses it for what its options do not give).

    Parameters
    ----------
    ds : Dataset
        The data set.

    Returns
    -------
    str
        The file's text.
    """
    out = io.StringIO()
    nom = ds.nominal
    values = (nom.diameter_left_m * 1e3, nom.diameter_right_m * 1e3, nom.wheelbase_m * 1e3, ds.units_per_wheel_rev)
    out.write(_GEOMETRY_LINE + "".join(f" {k}={float(v)!r}" for k, v in zip(GEOMETRY_KEYS, values)) + "\n")
    w = csv_writer(out, lineterminator="\n")
    w.writerow(["run", "time_s", "left_ticks", "right_ticks", "x_m", "y_m", "theta_rad"])
    f = lambda v: "" if not math.isfinite(v) else repr(round(float(v), 9))  # noqa: E731
    for r in ds.runs:
        cl = np.cumsum(r.d_left)
        cr = np.cumsum(r.d_right)
        for k in range(len(r)):
            if r.gt is not None:
                g = r.gt[k]
            elif r.gt_end is not None and k == len(r) - 1:
                g = r.gt_end
            else:
                g = (math.nan,) * 3
            w.writerow([r.name, f(r.t[k]), f(cl[k]), f(cr[k]), f(g[0]), f(g[1]), f(g[2])])
    return out.getvalue()


# --- streaming: one run read chunk by chunk (bounded memory) --------------------------------------


@dataclass
class CsvChunk:
    """Consecutive rows of a streamed generic CSV run.

    Attributes
    ----------
    t : numpy.ndarray
        Times [s] from the run's start.
    d_left, d_right : numpy.ndarray
        Wheel increments in log units (the run's first row: 0).
    gt : numpy.ndarray or None
        Ground truth (K, 3) in the run's start frame (NaN rows: none), or None when the file
        has no ground-truth columns.
    lines : numpy.ndarray
        The rows' line numbers.
    """

    t: np.ndarray
    d_left: np.ndarray
    d_right: np.ndarray
    gt: np.ndarray | None
    lines: np.ndarray


def _data_lines(f, src):
    """(line number, text) of every data line after the header, and the header."""
    header = None
    for n, raw in enumerate(f, 1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith('"') and next(csv.reader([s]), [""])[0].lstrip().startswith("#"):
            continue  # a quoted comment (e.g. the first line format_generic_csv writes)
        if header is None:
            row = next(csv.reader([s]))
            if not row or all(not c.strip() for c in row):
                continue
            header = [c.strip().lower() for c in row]
            yield None, header
            continue
        yield n, s
    if header is None:
        raise InputError("empty file: no header", src)


class _StreamedRun:
    """One run read chunk by chunk: what a chunk needs of the rows before it (the last time and
    counters, the ground truth's start pose and last heading)."""

    def __init__(self, header: list[str], src: str, ticks: str):
        gt_cols = _check_header(header, src, None)
        self.src, self.ticks, self.header = src, ticks, header
        self.has_gt = bool(gt_cols)
        self.use = list(REQUIRED) + gt_cols
        self.idx = [header.index(c) for c in self.use]
        self.run_col = header.index("run") if "run" in header else None
        self.need = max(self.idx + ([self.run_col] if self.run_col is not None else [])) + 1
        self.label: str | None = None  # the run column's label
        self.rows = 0
        self.t0: float | None = None  # first time
        self.t: float | None = None  # last time and counters
        self.left: float | None = None
        self.right: float | None = None
        # x, y, cos, sin, theta of the first ground-truth pose
        self.origin: tuple[float, float, float, float, float] | None = None
        self.theta: float | None = None  # the last unwrapped ground-truth heading
        self.end_only: bool | None = None  # only the last row may hold a (start-frame) end pose
        self.pending: int | None = None  # the line of such an end pose seen in an earlier chunk

    def parse(self, block) -> np.ndarray:
        """The used columns of ``(line, text)`` rows as numbers (empty ground truth: NaN)."""
        if self.run_col is None:  # fast path: numpy's C parser; any doubt -> the checking parser below
            try:
                vals = np.loadtxt(
                    io.StringIO("\n".join(text for _, text in block)),
                    delimiter=",",
                    usecols=self.idx,
                    ndmin=2,
                    dtype=float,
                    comments=None,
                )
                if vals.shape == (len(block), len(self.use)) and np.all(np.isfinite(vals)):
                    return vals
            except ValueError:
                pass
        src = self.src
        vals = np.empty((len(block), len(self.use)))
        for j, (ln, text) in enumerate(block):
            r = next(csv.reader([text]))
            if len(r) < self.need:
                raise InputError(f"has {len(r)} fields, the header has {len(self.header)}", src, ln)
            if self.run_col is not None:
                self._check_label(r[self.run_col].strip(), ln)
            for c, (name, k) in enumerate(zip(self.use, self.idx)):
                vals[j, c] = parse_number(r[k], name, src, ln, allow_empty=c >= 3)
        return vals

    def _check_label(self, label: str, ln: int) -> None:
        if not label:
            raise InputError("column run is empty", self.src, ln)
        if self.label is None:
            self.label = label
        elif label != self.label:
            raise InputError(
                f"streaming reads one run per file; run {label!r} follows run {self.label!r}", self.src, ln
            )

    def _wheels(self, a: np.ndarray, ln: np.ndarray, first: bool):
        t, cl, cr = a[:, 0], a[:, 1], a[:, 2]
        check_clock(t, ln, self.src, "time_s")
        prev_t = np.concatenate([[self.t if self.t is not None else -np.inf], t[:-1]])
        bad = np.flatnonzero(t <= prev_t)
        if bad.size:
            k = int(bad[0])
            raise InputError(f"time {t[k]:g} s does not increase (previous row: {prev_t[k]:g} s)", self.src, int(ln[k]))
        _check_tick_values(a[:, 1:3], ln, self.src, self.ticks)
        if first:
            self.t0 = t[0]
        if self.ticks == "cumulative":
            prev_l, prev_r = (cl[0], cr[0]) if first else (self.left, self.right)
            assert prev_l is not None and prev_r is not None  # the counters of the chunk before
            dl = np.diff(cl, prepend=prev_l)
            dr = np.diff(cr, prepend=prev_r)
        else:
            dl, dr = cl.copy(), cr.copy()
            if first:
                dl[0] = dr[0] = 0.0
        self.t, self.left, self.right = t[-1], cl[-1], cr[-1]
        return t, dl, dr

    def _truth(self, a: np.ndarray, ln: np.ndarray, first: bool) -> np.ndarray:
        src = self.src
        g = a[:, 3:6].copy()
        if "theta_deg" in self.use:
            g[:, 2] = np.radians(g[:, 2])
        fin = np.isfinite(g)
        partial = fin.any(axis=1) & ~fin.all(axis=1)
        if partial.any():
            k = int(np.flatnonzero(partial)[0])
            raise InputError("ground truth x_m, y_m, theta must be all given or all empty", src, int(ln[k]))
        _check_headings(g, ln, src, "theta_deg" in self.use)
        ok = fin[:, 0]
        if first:
            self.end_only = not ok[0]
            if ok[0]:
                x0, y0, th0 = g[0]
                self.origin = (x0, y0, math.cos(th0), math.sin(th0), th0)
                self.theta = th0
        if self.end_only:
            if self.pending is not None:
                raise InputError(
                    "the ground truth must start at the first row of a run (its start pose)", src, int(self.pending)
                )
            hits = np.flatnonzero(ok)
            if hits.size > 1 or (hits.size == 1 and hits[0] != len(g) - 1):
                raise InputError(
                    "the ground truth must start at the first row of a run (its start pose)", src, int(ln[hits[0]])
                )
            self.pending = int(ln[hits[0]]) if hits.size else None
            return g
        assert self.origin is not None  # a run whose first row holds a pose (else end_only)
        x0, y0, c, s, th0 = self.origin
        th = g[:, 2].copy()
        if ok.any():  # unwrap across chunks, from the last heading seen
            tt = np.unwrap(np.concatenate([[self.theta], th[ok]]))
            th[ok] = tt[1:]
            self.theta = tt[-1]
        dx, dy = g[:, 0] - x0, g[:, 1] - y0
        return np.column_stack([c * dx + s * dy, -s * dx + c * dy, th - th0])

    def chunk(self, block) -> CsvChunk:
        """The next chunk of the run from its ``(line, text)`` rows."""
        a = self.parse(block)
        ln = np.array([b[0] for b in block])
        first = self.rows == 0
        t, dl, dr = self._wheels(a, ln, first)
        gt = self._truth(a, ln, first) if self.has_gt else None
        self.rows += len(block)
        assert self.t0 is not None  # set by the first chunk
        return CsvChunk(t - self.t0, dl, dr, gt, ln)

    def finish(self) -> None:
        """Check the run, once every row was read."""
        if self.rows == 0:
            raise InputError("no data rows after the header", self.src)
        if self.rows < 2:
            raise InputError("a run needs at least two rows", self.src)


def _open_text(path):
    src = str(path)
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", source=src)
    if p.is_dir():
        raise InputError("is a folder, not a file", source=src)
    try:
        return open(p, encoding="utf-8-sig", newline="")
    except OSError as e:
        raise InputError(f"cannot read: {e.strerror}", source=src) from None


def iter_generic_csv(path: str | Path, ticks: str = "cumulative", chunk_rows: int = 1 << 16) -> Iterator[CsvChunk]:
    """Read ONE run of a generic CSV log in chunks (bounded memory: only the current chunk is held).

    The same checks and conventions as :func:`read_generic_csv`. A ``run`` column may be
    present but must hold one label. Only the ground-truth layouts "a track from the first row
    on" and "only the last row: a measured end pose in the start frame" are read.

    Parameters
    ----------
    path : str or Path
        The file.
    ticks : str
        ``cumulative`` or ``incremental``.
    chunk_rows : int
        Rows per chunk.

    Yields
    ------
    CsvChunk
        Consecutive rows of the run.

    Raises
    ------
    InputError
        A missing or unreadable file, or bad content (file and line named).
    """
    _check_ticks(ticks)
    if chunk_rows < 1:
        raise InputError(f"chunk rows must be >= 1, got {chunk_rows}")
    src = str(path)
    with _open_text(path) as f:
        lines = _data_lines(f, src)
        try:
            _, header = next(lines)
        except StopIteration:
            raise InputError("empty file: no header", src) from None
        except UnicodeDecodeError:
            raise InputError("not a text (UTF-8) file", source=src) from None
        run = _StreamedRun(header, src, ticks)
        buf = []
        try:
            for ln, text in lines:
                buf.append((ln, text))
                if len(buf) >= chunk_rows:
                    yield run.chunk(buf)
                    buf = []
        except UnicodeDecodeError:
            raise InputError("not a text (UTF-8) file", source=src) from None
        if buf:
            yield run.chunk(buf)
        run.finish()
