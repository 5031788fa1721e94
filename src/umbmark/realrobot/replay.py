"""Replay logged wheel increments with any parameter set, calibrate, and report before/after
with held-out figures.

* :func:`replay`: odometry poses of every run of a data set for a geometry (vectorised over
  runs and samples, exact arcs: :func:`umbmark.model.dataset.replay_increments`, which uses the fast
  chunked kernels of :mod:`umbmark.model.odometry` for long logs).
* :func:`detect_directions`: cw / ccw of square runs from the nominal odometry's total turn
  (negative: clockwise).
* :func:`square_runs`: the UMBmark runs table of square runs (replayed end pose as the
  odometry, ground-truth end pose as the absolute measurement, start frame).
* :func:`calibrate`: a geometry from a data set with a registered square method (``bf``,
  ``exact``, ...: :func:`umbmark.correct.correct_runs`) or with ``lsq``
  (:func:`umbmark.correct.lsq.fit_lsq`).
* :func:`evaluate`: UMBmark figures (square data) and end-pose / along-path errors of the
  replayed odometry against the ground truth.
* :func:`replay_report`: all of it for one or several data sets, with held-out figures:
  leave-one-run-out (calibrate without run i, evaluate run i; for squares the held-out
  return errors are benchmarked per direction) and, with several data sets, across data
  sets (calibrate on one, evaluate on each of the others).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from umbmark.correct import METHODS, correct_runs
from umbmark.correct.lsq import LSQ_DEFAULTS, fit_lsq
from umbmark.errors import InputError
from umbmark.metrics import umbmark
from umbmark.model.dataset import Dataset, WheelGeometry, replay_increments
from umbmark.model.runs import RunsTable

__all__ = [
    "stream_log",
    "replay",
    "end_poses",
    "detect_directions",
    "square_runs",
    "Calibrated",
    "calibrate",
    "evaluate",
    "replay_report",
    "pooled_report",
    "prepare",
    "method_names",
    "stream_replay",
]


def method_names() -> list[str]:
    """Every method replay accepts: the registered square methods and ``lsq``."""
    return sorted(set(METHODS) | {"lsq"})


def replay(ds: Dataset, geometry: WheelGeometry, method: str = "exact"):
    """Odometry of every run for ``geometry``: arrays (R, K) x, y, theta (zero-padded runs keep
    their last pose) and the run lengths."""
    dl, dr, n = ds.padded()
    x, y, th = replay_increments(dl, dr, geometry.params(ds.units_per_rev), method=method)
    return x, y, th, n


def end_poses(ds: Dataset, geometry: WheelGeometry) -> np.ndarray:
    """(R, 3) replayed end poses (x, y, theta unwrapped)."""
    dl, dr, _ = ds.padded()
    x, y, th = replay_increments(dl, dr, geometry.params(ds.units_per_rev), end=True)
    return np.column_stack([np.reshape(x, -1), np.reshape(y, -1), np.reshape(th, -1)])


def detect_directions(ds: Dataset) -> tuple[list[str], np.ndarray, list[str]]:
    """cw / ccw of each run from the nominal odometry's total turn; also the total turns
    (radians) and warnings (direction differs from the declared one; odd total turn)."""
    turn = end_poses(ds, ds.nominal)[:, 2]
    dirs = ["cw" if t < 0 else "ccw" for t in turn]
    warnings = []
    for run, t in zip(ds.runs, turn):
        if abs(abs(math.degrees(t)) - 360.0) > 45.0:
            warnings.append(
                f"{ds.name}/{run.name}: the odometry turns {math.degrees(t):.0f} deg in total, not about "
                "+-360 deg as on a UMBmark square"
            )
    if ds.directions is not None:
        for run, d, decl in zip(ds.runs, dirs, ds.directions):
            if d != decl:
                warnings.append(
                    f"{ds.name}/{run.name}: detected direction {d} differs from the declared {decl} "
                    "(the detected one is used)"
                )
    return dirs, turn, warnings


def square_runs(ds: Dataset, geometry: WheelGeometry, directions) -> RunsTable:
    """The UMBmark runs table: replayed end pose (odometry) vs ground-truth end pose."""
    odo = end_poses(ds, geometry)
    truth = []
    for run in ds.runs:
        e = run.end_truth
        if e is None:
            raise InputError("no ground-truth end pose for this run", source=run.source or f"{ds.name}/{run.name}")
        truth.append(e)
    truth = np.asarray(truth)
    wrap = lambda a: np.mod(a + np.pi, 2 * np.pi) - np.pi  # noqa: E731
    return RunsTable.from_columns(
        list(directions),
        truth[:, 0],
        truth[:, 1],
        odo[:, 0],
        odo[:, 1],
        wrap(truth[:, 2]),
        wrap(odo[:, 2]),
        run=[r.name for r in ds.runs],
    )


@dataclass(frozen=True)
class Calibrated:
    """A calibration result: the corrected absolute geometry and the method's figures."""

    method: str
    geometry: WheelGeometry
    nominal: WheelGeometry
    figures: dict = field(default_factory=dict)
    lsq: object | None = None

    def to_dict(self) -> dict:
        g, n = self.geometry, self.nominal
        d = {**g.relative_to(n), "wheelbase_per_mean_diameter": g.wheelbase_m / g.diameter_avg_m}
        for k, v in self.figures.items():
            d.setdefault(k, v)
        return d


def prepare(ds: Dataset) -> tuple[Dataset, list[str], np.ndarray]:
    """For square data: the data set with its detected directions, warnings, total turns."""
    if not ds.is_square:
        return ds, [], np.array([])
    dirs, turn, warnings = detect_directions(ds)
    return replace(ds, directions=tuple(dirs)), warnings, turn


def calibrate(ds, method: str, lsq_options: dict | None = None) -> Calibrated:
    """Calibrate with ``method`` (a registered square method, or ``lsq``). ``ds``: a data set
    (square methods need a square data set whose ``directions`` are set: see :func:`prepare`)
    or, for ``lsq``, a list of data sets fitted jointly."""
    if method == "lsq":
        sets = ds if isinstance(ds, (list, tuple)) else [ds]
        res = fit_lsq(sets, **{**LSQ_DEFAULTS, **(lsq_options or {})})
        return Calibrated("lsq", res.geometry, res.nominal, res.to_dict(), res)
    if method not in METHODS:
        raise InputError(f"unknown method {method!r} (choose from {', '.join(method_names())})")
    if isinstance(ds, (list, tuple)):
        if len(ds) != 1:
            raise InputError(f"method {method} calibrates on one data set at a time")
        ds = ds[0]
    if not ds.is_square:
        raise InputError(
            f"method {method} needs UMBmark square runs (a square side); use `method='lsq'` for other paths",
            source=ds.source,
        )
    if ds.directions is None:
        ds = prepare(ds)[0]
    runs = square_runs(ds, ds.nominal, ds.directions)
    corr = correct_runs(method, runs, ds.side_m, ds.nominal.wheelbase_m)
    geom = ds.nominal.calibrated(corr.calibration)
    fig = corr.to_dict()
    fig.pop("wheelbase_corrected_mm", None)
    return Calibrated(method, geom, ds.nominal, {"correction": fig, "Ed": corr.ed, "Eb": corr.eb})


def _path_errors(ds: Dataset, geometry: WheelGeometry) -> dict:
    x, y, th, n = replay(ds, geometry)
    end_pos, end_head, path_rms = [], [], []
    for i, run in enumerate(ds.runs):
        e = run.end_truth
        k = n[i] - 1
        if e is not None:
            end_pos.append(math.hypot(e[0] - x[i, k], e[1] - y[i, k]))
            end_head.append(float(np.mod(e[2] - th[i, k] + np.pi, 2 * np.pi) - np.pi))
        else:
            end_pos.append(float("nan"))
            end_head.append(float("nan"))
        if run.has_trajectory:
            g = run.gt
            ok = np.all(np.isfinite(g), axis=1)
            d = np.hypot(g[ok, 0] - x[i, : n[i]][ok], g[ok, 1] - y[i, : n[i]][ok])
            path_rms.append(float(np.sqrt(np.mean(d**2))))
        else:
            path_rms.append(float("nan"))
    return {
        "end_position_error_m": np.array(end_pos),
        "end_heading_error_rad": np.array(end_head),
        "path_position_rms_m": np.array(path_rms),
    }


def _rms(a):
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a**2))) if a.size else None


def _summary(errs: dict, runs: RunsTable | None) -> dict:
    d = {
        "end_position_rms_mm": None
        if _rms(errs["end_position_error_m"]) is None
        else _rms(errs["end_position_error_m"]) * 1e3,
        "end_heading_rms_deg": None
        if _rms(errs["end_heading_error_rad"]) is None
        else math.degrees(_rms(errs["end_heading_error_rad"])),
        "path_position_rms_mm": None
        if _rms(errs["path_position_rms_m"]) is None
        else _rms(errs["path_position_rms_m"]) * 1e3,
    }
    if runs is not None:
        res = umbmark(runs)
        d = {**res.to_dict(), **d}
    else:
        d = {"emax_syst_mm": None, **d}
    return d


def evaluate(ds: Dataset, geometry: WheelGeometry) -> dict:
    """Errors of the odometry replayed with ``geometry``: UMBmark figures for square data
    (``emax_syst_mm``, ``cw``, ``ccw``, ...), end-pose and along-path RMS errors, per-run
    errors (``runs``)."""
    errs = _path_errors(ds, geometry)
    runs = square_runs(ds, geometry, ds.directions) if ds.is_square and ds.directions is not None else None
    out = _summary(errs, runs)
    per_run = []
    for i, run in enumerate(ds.runs):
        r = {
            "run": run.name,
            "end_position_error_mm": errs["end_position_error_m"][i] * 1e3,
            "end_heading_error_deg": math.degrees(errs["end_heading_error_rad"][i]),
            "path_position_rms_mm": errs["path_position_rms_m"][i] * 1e3,
        }
        if runs is not None:
            r.update({"direction": runs.direction[i], "eps_x_mm": runs.eps_x[i] * 1e3, "eps_y_mm": runs.eps_y[i] * 1e3})
        per_run.append(r)
    out["runs"] = per_run
    return out


def _heldout_loo(ds: Dataset, method: str, lsq_options: dict | None, full: Calibrated) -> dict:
    """Leave-one-run-out: calibrate without run i, evaluate run i."""
    n = len(ds.runs)
    scheme = "leave-one-run-out (calibrate without run i, evaluate run i)"
    if ds.is_square:
        scheme += "; held-out return errors benchmarked per direction"
    if n < 2:
        return {
            "scheme": scheme,
            "emax_syst_mm": None,
            "end_position_rms_mm": None,
            "reason": "only one run: nothing to hold out (give several data sets for held-out figures across "
            "data sets)",
        }
    if ds.is_square:
        counts = {d: list(ds.directions).count(d) for d in ("cw", "ccw")}
        if min(counts.values()) < 2:
            return {
                "scheme": scheme,
                "emax_syst_mm": None,
                "end_position_rms_mm": None,
                "reason": f"leave-one-run-out needs at least 2 runs in both directions (this set has "
                f"{counts['cw']} cw and {counts['ccw']} ccw): without a run, a direction would be "
                "missing from the calibration (give several data sets for held-out figures across "
                "data sets)",
            }
    geoms, failed = [], []
    for i in range(n):
        sub = ds.subset([j for j in range(n) if j != i])
        try:
            if ds.is_square:
                dirs = set(sub.directions)
                if dirs != {"cw", "ccw"}:
                    raise InputError("runs in both directions are needed")
            opts = {**(lsq_options or {}), "start": full.geometry} if method == "lsq" else lsq_options
            geoms.append(calibrate(sub, method, opts).geometry)
        except InputError as e:
            geoms.append(None)
            failed.append(f"{ds.runs[i].name}: {e}")
    if any(g is None for g in geoms):
        return {
            "scheme": scheme,
            "emax_syst_mm": None,
            "end_position_rms_mm": None,
            "reason": "cannot calibrate without a run: " + "; ".join(failed),
        }
    odo = np.array([end_poses(ds.subset([i]), g)[0] for i, g in enumerate(geoms)])
    errs = {
        k: np.array([_path_errors(ds.subset([i]), g)[k][0] for i, g in enumerate(geoms)])
        for k in ("end_position_error_m", "end_heading_error_rad", "path_position_rms_m")
    }
    runs = None
    if ds.is_square:
        truth = np.array([r.end_truth for r in ds.runs])
        runs = RunsTable.from_columns(
            list(ds.directions), truth[:, 0], truth[:, 1], odo[:, 0], odo[:, 1], run=[r.name for r in ds.runs]
        )
    out = {"scheme": scheme, **_summary(errs, runs)}
    # jackknife spread of the leave-one-out calibrations (uncertainty of the full calibration)
    if n >= 3:
        vals = {
            "diameter_left_mm": [g.diameter_left_m * 1e3 for g in geoms],
            "diameter_right_mm": [g.diameter_right_m * 1e3 for g in geoms],
            "wheelbase_mm": [g.wheelbase_m * 1e3 for g in geoms],
            "Ed": [g.ed for g in geoms],
        }
        out["jackknife_std"] = {
            k: float(math.sqrt((n - 1) / n * np.sum((np.array(v) - np.mean(v)) ** 2))) for k, v in vals.items()
        }
    out["runs"] = [
        {
            "run": r.name,
            "calibrated_without_it": g.to_dict(),
            "end_position_error_mm": errs["end_position_error_m"][i] * 1e3,
        }
        for i, (r, g) in enumerate(zip(ds.runs, geoms))
    ]
    return out


def _transfer(src: Calibrated, dst: Dataset) -> WheelGeometry:
    """The same absolute geometry, used on another data set (same robot and encoders)."""
    return src.geometry


def replay_report(datasets, method: str = "bf", lsq_options: dict | None = None, heldout: bool = True) -> dict:
    """Replay, calibrate and evaluate each data set; held-out figures (see module docstring).

    One data set: one report dict. Several: ``{"datasets": [...], "across": [...]}`` where
    each report also holds the across-data-set held-out figures of its data set.
    """
    if isinstance(datasets, Dataset):
        datasets = [datasets]
    datasets = list(datasets)
    if method not in method_names():
        raise InputError(f"unknown method {method!r} (choose from {', '.join(method_names())})")
    reports, cals, prepared = [], [], []
    for ds in datasets:
        ds, warnings, turn = prepare(ds)
        prepared.append(ds)
        cal = calibrate(ds, method, lsq_options)
        cals.append(cal)
        before = evaluate(ds, ds.nominal)
        after = evaluate(ds, cal.geometry)
        rep = {
            "dataset": ds.name,
            "source": ds.source,
            "format": ds.meta.get("format"),
            "kind": "square" if ds.is_square else "path",
            "method": method,
            "nominal": {**ds.nominal.to_dict(), "units_per_wheel_rev": ds.units_per_rev},
            "side_mm": None if ds.side_m is None else ds.side_m * 1e3,
            "runs": [
                {
                    "run": r.name,
                    "samples": len(r),
                    "duration_s": float(r.t[-1] - r.t[0]),
                    **(
                        {"direction": ds.directions[i], "total_turn_deg": math.degrees(turn[i])} if ds.is_square else {}
                    ),
                }
                for i, r in enumerate(ds.runs)
            ],
            **cal.to_dict(),
            "before": before,
            "after": after,
            "improvement": (
                before["emax_syst_mm"] / after["emax_syst_mm"]
                if ds.is_square and after["emax_syst_mm"]
                else (
                    before["end_position_rms_mm"] / after["end_position_rms_mm"]
                    if before["end_position_rms_mm"] and after["end_position_rms_mm"]
                    else None
                )
            ),
            "warnings": warnings,
        }
        if heldout:
            rep["heldout"] = _heldout_loo(ds, method, lsq_options, cal)
            if cal.lsq is not None and "jackknife_std" in rep["heldout"]:
                rep["std"] = rep["heldout"]["jackknife_std"]
        reports.append(rep)
    if len(datasets) == 1:
        return reports[0]
    across = []
    for j, dst in enumerate(prepared):
        rows = []
        for i, src in enumerate(cals):
            if i == j:
                continue
            ev = evaluate(dst, _transfer(src, dst))
            rows.append(
                {
                    "calibrated_on": prepared[i].name,
                    "evaluated_on": dst.name,
                    "emax_syst_mm": ev["emax_syst_mm"],
                    "end_position_rms_mm": ev["end_position_rms_mm"],
                    "path_position_rms_mm": ev["path_position_rms_mm"],
                }
            )
        across += rows
        if heldout:
            vals = [r["emax_syst_mm"] for r in rows if r["emax_syst_mm"] is not None]
            ends = [r["end_position_rms_mm"] for r in rows if r["end_position_rms_mm"] is not None]
            reports[j]["heldout"]["across_datasets"] = {
                "scheme": "calibrated on each other data set, evaluated on this one",
                "emax_syst_mm_mean": float(np.mean(vals)) if vals else None,
                "emax_syst_mm_max": float(np.max(vals)) if vals else None,
                "end_position_rms_mm_mean": float(np.mean(ends)) if ends else None,
                "from": rows,
            }
    return {"method": method, "datasets": reports, "across": across}


def pooled_report(datasets, lsq_options: dict | None = None, heldout: bool = True) -> dict:
    """``lsq`` fitted jointly on all data sets (same robot); held out: leave-one-data-set-out
    (fit on the others, evaluate the one left out)."""
    prepared = [prepare(ds)[0] for ds in datasets]
    if len(prepared) < 1:
        raise InputError("no data sets")
    cal = calibrate(prepared, "lsq", lsq_options)
    per = []
    for i, ds in enumerate(prepared):
        before = evaluate(ds, ds.nominal)
        after = evaluate(ds, cal.geometry)
        row = {
            "dataset": ds.name,
            "kind": "square" if ds.is_square else "path",
            "before": {k: before[k] for k in ("emax_syst_mm", "end_position_rms_mm", "path_position_rms_mm")},
            "after": {k: after[k] for k in ("emax_syst_mm", "end_position_rms_mm", "path_position_rms_mm")},
        }
        if heldout and len(prepared) > 1:
            others = [d for j, d in enumerate(prepared) if j != i]
            g = calibrate(others, "lsq", {**(lsq_options or {}), "start": cal.geometry}).geometry
            ev = evaluate(ds, g)
            row["heldout"] = {
                "scheme": "fitted on the other data sets",
                "calibrated_without_it": g.to_dict(),
                **{k: ev[k] for k in ("emax_syst_mm", "end_position_rms_mm", "path_position_rms_mm")},
            }
        per.append(row)
    out = {"method": "lsq", "pooled": True, "datasets": [d.name for d in prepared], **cal.to_dict(), "per_dataset": per}
    if heldout and len(prepared) > 1:

        def agg(key, part):
            v = [r[part][key] for r in per if r[part][key] is not None]
            return float(np.sqrt(np.mean(np.square(v)))) if v else None

        out["before"] = {"end_position_rms_mm": agg("end_position_rms_mm", "before")}
        out["after"] = {"end_position_rms_mm": agg("end_position_rms_mm", "after")}
        out["heldout"] = {
            "scheme": "leave-one-data-set-out",
            "end_position_rms_mm": agg("end_position_rms_mm", "heldout"),
            "emax_syst_mm": None,
        }
    return out


def stream_replay(
    chunks, geometry: WheelGeometry, units_per_rev: float, decimate: int | None = None, method: str = "exact"
) -> dict:
    """Replay ONE long run given as an iterable of chunks (e.g.
    :func:`umbmark.io.generic_csv.iter_generic_csv`: objects with ``t``, ``d_left``,
    ``d_right``, ``gt``) in bounded memory: only the current chunk, the running sums and the kept
    poses are held (:class:`umbmark.model.odometry.Odometer`; whole-number increments use its table
    kernel).

    Returns the odometry's end pose, the ground-truth end pose and the end-pose errors when the
    last row has ground truth, the RMS position error over every sample with ground truth
    (``path_position_rms_mm``, as in :func:`evaluate`), and with ``decimate=n`` the poses after
    every n-th sample (``kept``: arrays ``sample``, ``t_s``, ``x_m``, ``y_m``, ``theta_rad``).
    """
    from umbmark.model.odometry import Odometer

    if decimate is not None and decimate < 1:
        raise InputError(f"decimate must be >= 1, got {decimate}")
    p = geometry.params(units_per_rev)
    odo = Odometer(None, params=p, method=method)
    kept = {"sample": [], "t_s": [], "x_m": [], "y_m": [], "theta_rad": []} if decimate else None
    n = 0
    sq_sum, n_gt = 0.0, 0
    last_gt, t_end, chunks_read = None, 0.0, 0
    for ch in chunks:
        dl = np.asarray(ch.d_left, dtype=float)
        dr = np.asarray(ch.d_right, dtype=float)
        k = dl.size
        if k == 0:
            continue
        chunks_read += 1
        integral = bool(
            np.all(dl == np.round(dl))
            and np.all(dr == np.round(dr))
            and max(np.abs(dl).max(), np.abs(dr).max()) < 2**52
        )
        want = bool(decimate) or ch.gt is not None
        if integral:
            res = odo.update_pulses(dl.astype(np.int64), dr.astype(np.int64), poses=want)
        else:
            res = odo.update(dl * p.left_m_per_pulse, dr * p.right_m_per_pulse, poses=want)
        if ch.gt is not None:
            g = np.asarray(ch.gt, dtype=float)
            ok = np.isfinite(g[:, 0])
            if ok.any():
                sq_sum += float(np.sum((g[ok, 0] - res[0][ok]) ** 2 + (g[ok, 1] - res[1][ok]) ** 2))
                n_gt += int(ok.sum())
            last_gt = g[-1] if ok[-1] else None
        if decimate:
            sel = np.arange((-(n + 1)) % decimate, k, decimate)
            kept["sample"].append(n + sel)
            kept["t_s"].append(np.asarray(ch.t, dtype=float)[sel])
            for name, arr in zip(("x_m", "y_m", "theta_rad"), res):
                kept[name].append(np.asarray(arr)[sel])
        n += k
        t_end = float(ch.t[-1])
    if n < 2:
        raise InputError("a run needs at least two samples")
    x, y, th = odo.pose
    out = {
        "mode": "stream",
        "samples": n,
        "chunks": chunks_read,
        "duration_s": t_end,
        "nominal": {**geometry.to_dict(), "units_per_wheel_rev": units_per_rev},
        "end_pose": {"x_mm": x * 1e3, "y_mm": y * 1e3, "theta_deg": math.degrees(th)},
        "end_truth": None,
        "end_position_error_mm": None,
        "end_heading_error_deg": None,
        "path_position_rms_mm": math.sqrt(sq_sum / n_gt) * 1e3 if n_gt >= 2 else None,
        "samples_with_truth": n_gt,
    }
    if last_gt is not None:
        out["end_truth"] = {"x_mm": last_gt[0] * 1e3, "y_mm": last_gt[1] * 1e3, "theta_deg": math.degrees(last_gt[2])}
        out["end_position_error_mm"] = math.hypot(last_gt[0] - x, last_gt[1] - y) * 1e3
        out["end_heading_error_deg"] = math.degrees(float(np.mod(last_gt[2] - th + np.pi, 2 * np.pi) - np.pi))
    if kept is not None:
        out["kept"] = {k: (np.concatenate(v) if v else np.empty(0)) for k, v in kept.items()}
        out["decimate"] = decimate
    return out


def stream_log(path, decimate: int | None = None, chunk_rows: int = 1 << 16, fmt: str = "auto", **opts) -> dict:
    """Replay ONE long generic CSV log with the nominal geometry of ``opts`` in bounded memory
    (read in chunks of ``chunk_rows`` rows, see :func:`umbmark.realrobot.replay.stream_replay`)."""
    from umbmark.io.generic_csv import iter_generic_csv
    from umbmark.io.load import _nominal, detect_format

    if isinstance(path, (list, tuple)):
        if len(path) != 1:
            raise InputError("streaming replays one log file at a time")
        path = path[0]
    if fmt == "auto":
        fmt = detect_format(path)
    if fmt != "csv":
        raise InputError(
            f"streaming reads the generic CSV log only (this is {fmt}; use `umbmark convert` first)", source=str(path)
        )
    if opts.get("side_mm") is not None:
        raise InputError(
            "streaming replays one run with the given geometry; UMBmark squares (`side_mm`) need "
            "the whole data set (replay it without `stream`)"
        )
    ppr = opts.get("pulses_per_wheel_rev")
    if ppr is None:
        raise InputError(
            "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(path)
        )
    nominal = _nominal(opts, str(path))
    rep = stream_replay(
        iter_generic_csv(path, opts.get("ticks") or "cumulative", chunk_rows), nominal, ppr, decimate=decimate
    )
    return {"dataset": Path(path).stem, "source": str(path), "format": "csv", **rep}
