"""Reader of the OptiOdom data-set layout (Sousa et al.; see data/optiodom/README.md).

A data set is a folder ``ID/`` holding:

* ``ID_metadata.csv``: rows ``key,value,...``; used keys: ``type`` (must be ``diff``),
  ``ngear`` (gear ratio), ``encRes`` (encoder pulses per motor revolution), ``Li`` (nominal
  wheelbase, m), ``Di`` (nominal wheel diameters, m: **right, then left**), ``N`` (number of
  runs), ``L`` (side of the square, m; square data sets only). Other rows are ignored.
* ``ID_run-NN.csv`` (NN = 01 .. N): no header, one row per sample:
  ``time (s), x_gt (m), y_gt (m), theta_gt (rad), ticks_right, ticks_left``; the ticks are
  the encoder pulses counted in that sample (not cumulative). The ground truth is brought
  into the start frame (it already starts at (0, 0, 0) with x along the first leg).

In square data sets the first half of the runs are declared cw and the second half ccw.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from umbmark._numbers import strict_float
from umbmark.errors import InputError
from umbmark.io._checks import wheels_against_truth
from umbmark.io._text import check_increasing_time, numeric_rows, read_text
from umbmark.model.dataset import Dataset, Run, WheelGeometry, to_start_frame

__all__ = ["read_optiodom", "read_metadata", "read_run_file", "is_optiodom", "COLUMNS"]

COLUMNS = ("time", "x_gt", "y_gt", "theta_gt", "ticks_right", "ticks_left")


def is_optiodom(path: str | Path) -> bool:
    """Whether ``path`` is an optiodom data-set folder (it holds a ``*_metadata.csv`` file).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    p = Path(path)
    return p.is_dir() and any(p.glob("*_metadata.csv"))


def _metadata_file(folder: Path) -> Path:
    own = folder / f"{folder.name}_metadata.csv"
    if own.is_file():
        return own
    found = sorted(folder.glob("*_metadata.csv"))
    if len(found) == 1:
        return found[0]
    if not found:
        raise InputError("no *_metadata.csv file: not an optiodom data-set folder", source=str(folder))
    raise InputError(f"{len(found)} metadata files; expected one", source=str(folder))


def read_metadata(path: str | Path) -> dict:
    """Read the metadata file of a data set.

    Parameters
    ----------
    path : str or Path
        The ``ID_metadata.csv`` file.

    Returns
    -------
    dict
        ``{key: (line, [values])}`` of every row (empty cells dropped).

    Raises
    ------
    InputError
        A missing or unreadable file.
    """
    text = read_text(path)
    meta: dict = {}
    for i, raw in enumerate(text.splitlines(), 1):
        cells = [c.strip() for c in raw.split(",")]
        if not cells or not cells[0]:
            continue
        vals = [c for c in cells[1:] if c]
        if cells[0] in USED_KEYS and cells[0] in meta and meta[cells[0]][1] != vals:
            first = meta[cells[0]]
            raise InputError(
                f"metadata row {cells[0]!r} appears twice with different values ({','.join(first[1])} on line "
                f"{first[0]}, {','.join(vals)} here): keep the right one",
                str(path),
                i,
            )
        meta[cells[0]] = (i, vals)
    return meta


# the metadata rows the reader uses
USED_KEYS = ("type", "ngear", "encRes", "Li", "Di", "N", "L")
# a wheel diameter or wheelbase (m) beyond these is one given in millimetres
_MAX_DIAMETER_M = 2.0
_MAX_WHEELBASE_M = 5.0


def _num(meta: dict, key: str, source: str, count: int = 1, required: bool = True):
    if key not in meta:
        if required:
            raise InputError(f"metadata row {key!r} is missing", source)
        return None
    line, vals = meta[key]
    if not vals:
        if required:
            raise InputError(f"metadata row {key!r} has no value", source, line)
        return None
    if len(vals) < count:
        raise InputError(f"metadata row {key!r} needs {count} values, has {len(vals)}", source, line)
    out = []
    for v in vals[:count]:
        try:
            x = strict_float(v)
        except ValueError:
            raise InputError(f"metadata {key}: {v!r} is not a number", source, line) from None
        if not (math.isfinite(x) and x > 0):
            raise InputError(f"metadata {key}: {v!r} must be a positive number", source, line)
        out.append(x)
    return out if count > 1 else out[0]


def read_optiodom(folder: str | Path) -> Dataset:
    """Read one optiodom data-set folder (see the module docstring).

    Parameters
    ----------
    folder : str or Path
        The data set's folder.

    Returns
    -------
    Dataset
        Square data sets (a side ``L``) with the declared directions: the first half of the
        runs cw, the second half ccw.

    Raises
    ------
    InputError
        Not such a folder, bad metadata, a missing or bad run file (file and line named).
    """
    folder = Path(folder)
    if not folder.exists():
        raise InputError("folder not found", source=str(folder))
    if not folder.is_dir():
        raise InputError(
            "not a folder: an optiodom data set is a folder with a *_metadata.csv file", source=str(folder)
        )
    mfile = _metadata_file(folder)
    src = str(mfile)
    meta = read_metadata(mfile)
    if "type" in meta and meta["type"][1] and meta["type"][1][0].lower() != "diff":
        raise InputError(f"robot type {meta['type'][1][0]!r} is not supported (only 'diff')", src, meta["type"][0])
    ngear = _num(meta, "ngear", src)
    enc = _num(meta, "encRes", src)
    b = _num(meta, "Li", src)
    d_right, d_left = _num(meta, "Di", src, count=2)
    n = _num(meta, "N", src)
    if n != int(n):
        raise InputError(f"metadata N: {n!r} is not a whole number", src, meta["N"][0])
    n = int(n)
    for key, values, top, what in (
        ("Di", (d_right, d_left), _MAX_DIAMETER_M, "wheel diameter"),
        ("Li", (b,), _MAX_WHEELBASE_M, "wheelbase"),
    ):
        if max(values) > top:
            raise InputError(
                f"metadata {key}: a {what} of {max(values):g} m: {key} is in metres ({max(values):g} mm would be "
                f"{max(values) / 1e3:g})",
                src,
                meta[key][0],
            )
    side = _num(meta, "L", src, required=False)
    prefix = mfile.name[: -len("_metadata.csv")]
    runs = []
    for i in range(1, n + 1):
        f = folder / f"{prefix}_run-{i:02d}.csv"
        if not f.is_file():
            raise InputError(f"metadata says N = {n} runs but {f.name} is missing", src, meta["N"][0])
        runs.append(read_run_file(f))
    expected = {f"{prefix}_run-{i:02d}.csv" for i in range(1, n + 1)}
    extra = sorted(p.name for p in folder.glob(f"{prefix}_run-*.csv") if p.name not in expected)
    directions = None
    warnings = []
    if extra:
        warnings.append(
            f"{src}: metadata says N = {n} runs but the folder also holds {', '.join(extra)}: they are ignored "
            "(check N)"
        )
    if side is not None and n % 2 == 0:
        directions = tuple(["cw"] * (n // 2) + ["ccw"] * (n // 2))
    elif side is not None:
        warnings.append(
            f"{src}: N = {n} runs is odd, so the square runs are not half cw and half ccw as declared: check N "
            "(each run's direction is taken from its odometry)"
        )
    nominal = WheelGeometry(d_left, d_right, b)
    for run in runs:
        warnings += wheels_against_truth(
            run,
            nominal,
            ngear * enc,
            f"Di (metres), ngear and encRes in {src}",
            f"Li (metres) in {src}",
            "theta_gt is in radians",
        )
    return Dataset(
        name=folder.name,
        nominal=nominal,
        units_per_wheel_rev=ngear * enc,
        runs=tuple(runs),
        side_m=side,
        source=str(folder),
        directions=directions,
        meta={
            "format": "optiodom",
            "gear_ratio": ngear,
            "pulses_per_motor_rev": enc,
            "ignored_files": extra,
            "warnings": tuple(warnings),
        },
    )


def read_run_file(path: str | Path) -> Run:
    """Read one run file of a data set.

    Parameters
    ----------
    path : str or Path
        An ``ID_run-NN.csv`` file.

    Returns
    -------
    Run
        Named ``run-NN``, the ground truth in the start frame.

    Raises
    ------
    InputError
        Bad content (file and line named).
    """
    src = str(path)
    a, lines = numeric_rows(read_text(path), src, ncols=6, names=COLUMNS)
    if len(a) < 2:
        raise InputError("a run needs at least two samples", src)
    check_increasing_time(a[:, 0], lines, src)
    for col in (4, 5):
        frac = np.flatnonzero(a[:, col] != np.round(a[:, col]))
        if frac.size:
            k = int(frac[0])
            raise InputError(
                f"column {COLUMNS[col]}: {a[k, col]:g} is not a whole number of encoder pulses", src, int(lines[k])
            )
    gx, gy, gth = to_start_frame(a[:, 1], a[:, 2], a[:, 3])
    m = re.search(r"run-(\d+)", Path(path).stem)
    name = f"run-{m.group(1)}" if m else Path(path).stem
    return Run(name, a[:, 0] - a[0, 0], a[:, 5], a[:, 4], np.column_stack([gx, gy, gth]), None, src)
