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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io._text import csv_rows, header_columns, read_text
from umbmark.model.dataset import Dataset, Run, WheelGeometry, to_start_frame

__all__ = ["read_generic_csv", "format_generic_csv", "iter_generic_csv", "CsvChunk", "REQUIRED", "OPTIONAL"]

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
    header = None
    rows = []
    for line, row in csv_rows(text, src):
        if header is None:
            header = header_columns(row)
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
            gt_cols = [c for c in ("x_m", "y_m") if c in header] + [
                c for c in ("theta_rad", "theta_deg") if c in header
            ]
            if gt_cols and len(gt_cols) != 3:
                raise InputError("ground truth needs x_m, y_m and theta_rad (or theta_deg)", src, line)
            continue
        rows.append((line, row))
    if header is None:
        raise InputError("empty file: no header", src)
    if not rows:
        raise InputError("no data rows after the header", src)
    return header, rows


def read_generic_csv(
    paths,
    nominal: WheelGeometry,
    pulses_per_wheel_rev: float,
    ticks: str = "cumulative",
    side_m: float | None = None,
    name: str | None = None,
) -> Dataset:
    """Read one or more generic CSV files into a :class:`~umbmark.model.dataset.Dataset`."""
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
                raise InputError(
                    f"time {a[k, 0]:g} s does not increase (previous row: {a[k - 1, 0]:g} s)", src, int(lines[k])
                )
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
                        raise InputError(
                            "the ground truth must start at the first row of a run (its start pose)", src, int(lines[0])
                        )
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
    return Dataset(
        name, nominal, float(pulses_per_wheel_rev), tuple(runs), side_m, str(paths[0]), meta={"format": "csv"}
    )


def format_generic_csv(ds: Dataset) -> str:
    """Write a data set as the generic CSV (one file, ``run`` column, cumulative ticks; ground
    truth in each run's start frame)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(
        [
            "# umbmark generic log; nominal diameters left/right [mm], wheelbase [mm], pulses per wheel rev:",
            f"{ds.nominal.diameter_left_m * 1e3:.6g}",
            f"{ds.nominal.diameter_right_m * 1e3:.6g}",
            f"{ds.nominal.wheelbase_m * 1e3:.6g}",
            f"{ds.units_per_rev:.9g}",
        ]
    )
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
    """Consecutive rows of a streamed generic CSV run: times [s] from the run start, wheel
    increments (log units; row 0 of the run has 0), ground truth (K, 3) in the run's start frame
    (NaN rows: none) or None when the file has no ground-truth columns, and the line numbers."""

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


def iter_generic_csv(path, ticks: str = "cumulative", chunk_rows: int = 1 << 16):
    """Read ONE run of a generic CSV log in chunks of ``chunk_rows`` rows (bounded memory:
    only the current chunk is held). Yields :class:`CsvChunk` objects; the same checks and
    conventions as :func:`read_generic_csv` (errors name the file and line). A ``run`` column
    may be present but must hold one label. Only the ground-truth layouts "a track from the
    first row on" and "only the last row: a measured end pose in the start frame" are read.
    """
    if ticks not in ("cumulative", "incremental"):
        raise InputError(f"ticks must be 'cumulative' or 'incremental', got {ticks!r}")
    if chunk_rows < 1:
        raise InputError(f"chunk rows must be >= 1, got {chunk_rows}")
    src = str(path)
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", source=src)
    if p.is_dir():
        raise InputError("is a folder, not a file", source=src)
    try:
        f = open(p, encoding="utf-8-sig", newline="")
    except OSError as e:
        raise InputError(f"cannot read: {e.strerror}", source=src) from None
    with f:
        lines = _data_lines(f, src)
        try:
            _, header = next(lines)
        except StopIteration:
            raise InputError("empty file: no header", src) from None
        except UnicodeDecodeError:
            raise InputError("not a text (UTF-8) file", source=src) from None
        missing = [c for c in REQUIRED if c not in header]
        if missing:
            raise InputError(
                "header lacks column(s) "
                + ", ".join(missing)
                + " (expected time_s,left_ticks,right_ticks[,x_m,y_m,theta_rad|theta_deg][,run])",
                src,
            )
        if "theta_rad" in header and "theta_deg" in header:
            raise InputError("give theta_rad or theta_deg, not both", src)
        gt_cols = [c for c in ("x_m", "y_m", "theta_rad", "theta_deg") if c in header]
        if gt_cols and len(gt_cols) != 3:
            raise InputError("ground truth needs x_m, y_m and theta_rad (or theta_deg)", src)
        has_gt = bool(gt_cols)
        use = list(REQUIRED) + gt_cols
        idx = [header.index(c) for c in use]
        run_col = header.index("run") if "run" in header else None
        need = max(idx + ([run_col] if run_col is not None else [])) + 1
        state = {
            "label": None,
            "t": None,
            "l": None,
            "r": None,
            "origin": None,
            "theta": None,
            "end_only": None,
            "rows": 0,
        }
        buf = []

        def parse(block):
            if run_col is None:  # fast path: numpy's C parser; any doubt -> the checking parser below
                try:
                    vals = np.loadtxt(
                        io.StringIO("\n".join(text for _, text in block)),
                        delimiter=",",
                        usecols=idx,
                        ndmin=2,
                        dtype=float,
                        comments=None,
                    )
                    if vals.shape == (len(block), len(use)) and np.all(np.isfinite(vals)):
                        return vals
                except ValueError:
                    pass
            vals = np.empty((len(block), len(use)))
            for j, (ln, text) in enumerate(block):
                r = next(csv.reader([text]))
                if len(r) < need:
                    raise InputError(f"has {len(r)} fields, the header has {len(header)}", src, ln)
                if run_col is not None:
                    label = r[run_col].strip()
                    if not label:
                        raise InputError("column run is empty", src, ln)
                    if state["label"] is None:
                        state["label"] = label
                    elif label != state["label"]:
                        raise InputError(
                            f"streaming reads one run per file; run {label!r} follows run {state['label']!r}", src, ln
                        )
                for c, (name, k) in enumerate(zip(use, idx)):
                    vals[j, c] = _cell(r[k], name, src, ln, c >= 3)
            return vals

        def emit(block):
            a = parse(block)
            ln = np.array([b[0] for b in block])
            t, cl, cr = a[:, 0], a[:, 1], a[:, 2]
            prev_t = (
                np.concatenate([[state["t"]], t[:-1]])
                if state["t"] is not None
                else np.concatenate([[-np.inf], t[:-1]])
            )
            bad = np.flatnonzero(t <= prev_t)
            if bad.size:
                k = int(bad[0])
                raise InputError(f"time {t[k]:g} s does not increase (previous row: {prev_t[k]:g} s)", src, int(ln[k]))
            first = state["rows"] == 0
            if first:
                state["t0"] = t[0]
            if ticks == "cumulative":
                dl = np.diff(cl, prepend=cl[0] if first else state["l"])
                dr = np.diff(cr, prepend=cr[0] if first else state["r"])
            else:
                dl, dr = cl.copy(), cr.copy()
                if first:
                    dl[0] = dr[0] = 0.0
            state["t"], state["l"], state["r"] = t[-1], cl[-1], cr[-1]
            gt = None
            if has_gt:
                g = a[:, 3:6].copy()
                if "theta_deg" in use:
                    g[:, 2] = np.radians(g[:, 2])
                fin = np.isfinite(g)
                partial = fin.any(axis=1) & ~fin.all(axis=1)
                if partial.any():
                    k = int(np.flatnonzero(partial)[0])
                    raise InputError("ground truth x_m, y_m, theta must be all given or all empty", src, int(ln[k]))
                ok = fin[:, 0]
                if first:
                    state["end_only"] = not ok[0]
                    if ok[0]:
                        x0, y0, th0 = g[0]
                        state["origin"] = (x0, y0, math.cos(th0), math.sin(th0), th0)
                        state["theta"] = th0
                if state["end_only"]:
                    # only the run's last row may hold a (start-frame) end pose
                    if state.get("pending") is not None:
                        raise InputError(
                            "the ground truth must start at the first row of a run (its start pose)",
                            src,
                            int(state["pending"]),
                        )
                    hits = np.flatnonzero(ok)
                    if hits.size > 1 or (hits.size == 1 and hits[0] != len(g) - 1):
                        raise InputError(
                            "the ground truth must start at the first row of a run (its start pose)",
                            src,
                            int(ln[hits[0]]),
                        )
                    state["pending"] = int(ln[hits[0]]) if hits.size else None
                    gt = g
                else:
                    x0, y0, c, s, th0 = state["origin"]
                    th = g[:, 2].copy()
                    if ok.any():  # unwrap across chunks, from the last heading seen
                        tt = np.concatenate([[state["theta"]], th[ok]])
                        tt = np.unwrap(tt)
                        th[ok] = tt[1:]
                        state["theta"] = tt[-1]
                    dx, dy = g[:, 0] - x0, g[:, 1] - y0
                    gt = np.column_stack([c * dx + s * dy, -s * dx + c * dy, th - th0])
            state["rows"] += len(block)
            return CsvChunk(t - state["t0"], dl, dr, gt, ln)

        try:
            for ln, text in lines:
                buf.append((ln, text))
                if len(buf) >= chunk_rows:
                    yield emit(buf)
                    buf = []
        except UnicodeDecodeError:
            raise InputError("not a text (UTF-8) file", source=src) from None
        if buf:
            yield emit(buf)
        if state["rows"] == 0:
            raise InputError("no data rows after the header", src)
        if state["rows"] < 2:
            raise InputError("a run needs at least two rows", src)
