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
diameters, wheelbase, pulses per wheel revolution) is not in the file: it is given to the
reader (``--wheel-diameter-mm``, ``--wheelbase-mm``, ``--pulses-per-wheel-rev``).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..logs import Dataset, Run, WheelGeometry, to_start_frame
from ._text import read_text

__all__ = ["read_generic_csv", "format_generic_csv", "REQUIRED", "OPTIONAL"]

REQUIRED = ("time_s", "left_ticks", "right_ticks")
OPTIONAL = ("x_m", "y_m", "theta_rad", "theta_deg", "run")


def _cell(v: str, col: str, src: str, line: int, allow_empty: bool) -> float:
    s = v.strip()
    if not s:
        if allow_empty:
            return math.nan
        raise InputError(f"column {col} is empty", src, line)
    try:
        x = float(s)
    except ValueError:
        raise InputError(f"column {col}: {s!r} is not a number", src, line) from None
    if not math.isfinite(x):
        raise InputError(f"column {col}: {s!r} is not a finite number", src, line)
    return x


def _parse(text: str, src: str):
    reader = csv.reader(io.StringIO(text))
    header = None
    rows = []
    for row in reader:
        line = reader.line_num
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        if header is None:
            header = [c.strip().lower() for c in row]
            missing = [c for c in REQUIRED if c not in header]
            if missing:
                raise InputError("header lacks column(s) " + ", ".join(missing)
                                 + " (expected time_s,left_ticks,right_ticks[,x_m,y_m,theta_rad|theta_deg][,run])",
                                 src, line)
            if "theta_rad" in header and "theta_deg" in header:
                raise InputError("give theta_rad or theta_deg, not both", src, line)
            gt_cols = [c for c in ("x_m", "y_m") if c in header] + [c for c in ("theta_rad", "theta_deg")
                                                                    if c in header]
            if gt_cols and len(gt_cols) != 3:
                raise InputError("ground truth needs x_m, y_m and theta_rad (or theta_deg)", src, line)
            continue
        rows.append((line, row))
    if header is None:
        raise InputError("empty file: no header", src)
    if not rows:
        raise InputError("no data rows after the header", src)
    return header, rows


def read_generic_csv(paths, nominal: WheelGeometry, pulses_per_wheel_rev: float, ticks: str = "cumulative",
                     side_m: float | None = None, name: str | None = None) -> Dataset:
    """Read one or more generic CSV files into a :class:`~umbmark.logs.Dataset`."""
    if ticks not in ("cumulative", "incremental"):
        raise InputError(f"ticks must be 'cumulative' or 'incremental', got {ticks!r}")
    if isinstance(paths, (str, Path)):
        paths = [paths]
    runs = []
    for path in paths:
        src = str(path)
        header, rows = _parse(read_text(path), src)
        col = {c: header.index(c) for c in REQUIRED + OPTIONAL if c in header}
        has_gt = "x_m" in col
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
            vals = [_cell(r[col[c]], c, src, line, False) for c in REQUIRED]
            if has_gt:
                vals += [_cell(r[col[c]], c, src, line, True) for c in ("x_m", "y_m", theta_col)]
            groups[label].append((line, vals))
        for label in order:
            g = groups[label]
            lines = np.array([ln for ln, _ in g])
            a = np.array([v for _, v in g], dtype=float)
            where = f"{src} (run {label})" if "run" in col else src
            if len(a) < 2:
                raise InputError("a run needs at least two rows", where, int(lines[0]))
            bad = np.flatnonzero(np.diff(a[:, 0]) <= 0)
            if bad.size:
                k = int(bad[0]) + 1
                raise InputError(f"time {a[k, 0]:g} s does not increase (previous row: {a[k - 1, 0]:g} s)", src,
                                 int(lines[k]))
            if ticks == "cumulative":
                dl = np.diff(a[:, 1], prepend=a[0, 1])
                dr = np.diff(a[:, 2], prepend=a[0, 2])
            else:
                dl, dr = a[:, 1].copy(), a[:, 2].copy()
                dl[0] = dr[0] = 0.0
            gt = gt_end = None
            if has_gt:
                g3 = a[:, 3:6].copy()
                if theta_col == "theta_deg":
                    g3[:, 2] = np.radians(g3[:, 2])
                partial = np.isfinite(g3).any(axis=1) & ~np.isfinite(g3).all(axis=1)
                if partial.any():
                    k = int(np.flatnonzero(partial)[0])
                    raise InputError("ground truth x_m, y_m, theta must be all given or all empty", src, int(lines[k]))
                ok = np.isfinite(g3[:, 0])
                if ok.sum() == 1 and ok[-1]:
                    gt_end = g3[-1]
                elif ok.any():
                    if not ok[0]:
                        raise InputError("the ground truth must start at the first row of a run (its start pose)", src,
                                         int(lines[0]))
                    th = g3[:, 2].copy()
                    th[ok] = np.unwrap(th[ok])
                    x, y, t = to_start_frame(g3[ok, 0], g3[ok, 1], th[ok])
                    gt = np.full_like(g3, np.nan)
                    gt[ok] = np.column_stack([x, y, t])
            runs.append(Run(label, a[:, 0] - a[0, 0], dl, dr, gt, gt_end, where))
    if not runs:
        raise InputError("no runs")
    if name is None:
        name = Path(paths[0]).stem if len(paths) == 1 else Path(paths[0]).parent.name or "logs"
    return Dataset(name, nominal, float(pulses_per_wheel_rev), tuple(runs), side_m, str(paths[0]),
                   meta={"format": "csv"})


def format_generic_csv(ds: Dataset) -> str:
    """Write a data set as the generic CSV (one file, ``run`` column, cumulative ticks; ground
    truth in each run's start frame)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["# umbmark generic log; nominal diameters left/right [mm], wheelbase [mm], pulses per wheel rev:",
                f"{ds.nominal.diameter_left_m * 1e3:.6g}", f"{ds.nominal.diameter_right_m * 1e3:.6g}",
                f"{ds.nominal.wheelbase_m * 1e3:.6g}", f"{ds.units_per_rev:.9g}"])
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
