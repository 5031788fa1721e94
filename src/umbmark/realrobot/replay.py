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
  sets (calibrate on one, evaluate on each of the others). :func:`pooled_report`: one ``lsq``
  fit of all data sets, held out by data set.
* :func:`stream_replay` / :func:`stream_log`: one long log replayed in bounded memory.
* :func:`history_fields`: the calibration-history records of a report.

The results are the dataclasses of :mod:`umbmark.realrobot.results` (SI units); their
``to_dict()`` is the JSON of ``umbmark replay``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from umbmark.correct import METHODS, correct_runs
from umbmark.correct.lsq import LSQ_DEFAULTS, LsqResult, fit_lsq
from umbmark.errors import InputError
from umbmark.io.load import LogOptions
from umbmark.metrics import umbmark_figures
from umbmark.model.dataset import Dataset, Run, WheelGeometry, replay_increments
from umbmark.model.geometry import nominal_slip, wrap_angle
from umbmark.model.runs import RunsTable
from umbmark.realrobot.results import (
    AcrossHeldOut,
    AcrossRow,
    Calibrated,
    ErrorSummary,
    Evaluation,
    HeldOut,
    HeldOutRun,
    KeptPoses,
    MultiReplayReport,
    PooledReport,
    PooledRow,
    ReplayReport,
    RunErrors,
    RunInfo,
    StreamReport,
)

__all__ = [
    "method_names",
    "replay",
    "end_poses",
    "detect_directions",
    "square_runs",
    "prepare",
    "Calibrated",
    "calibrate",
    "evaluate",
    "replay_report",
    "pooled_report",
    "stream_replay",
    "stream_log",
    "history_fields",
]


def method_names() -> list[str]:
    """Every method replay accepts.

    Returns
    -------
    list of str
        The registered square methods and ``lsq``, sorted.
    """
    return sorted(set(METHODS) | {"lsq"})


def replay(
    ds: Dataset, geometry: WheelGeometry, integrator: str = "exact"
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The odometry of every run of a data set, replayed with a geometry.

    Parameters
    ----------
    ds : Dataset
        The logged runs.
    geometry : WheelGeometry
        The geometry to replay with.
    integrator : str
        The integration of one sample (see :func:`umbmark.model.dataset.replay_increments`).

    Returns
    -------
    x, y, theta : numpy.ndarray
        (R, K) poses in each run's start frame (zero-padded runs keep their last pose).
    n : numpy.ndarray
        The length of each run.
    """
    dl, dr, n = ds.padded()
    x, y, th = replay_increments(dl, dr, geometry.params(ds.units_per_wheel_rev), integrator=integrator)
    return x, y, th, n


def end_poses(ds: Dataset, geometry: WheelGeometry) -> np.ndarray:
    """The replayed end pose of every run.

    Parameters
    ----------
    ds : Dataset
        The logged runs.
    geometry : WheelGeometry
        The geometry to replay with.

    Returns
    -------
    numpy.ndarray
        (R, 3): x, y [m] and theta [rad, unwrapped] in each run's start frame.
    """
    dl, dr, _ = ds.padded()
    x, y, th = replay_increments(dl, dr, geometry.params(ds.units_per_wheel_rev), end=True)
    return np.column_stack([np.reshape(x, -1), np.reshape(y, -1), np.reshape(th, -1)])


def detect_directions(ds: Dataset) -> tuple[list[str], np.ndarray, list[str]]:
    """The direction of each square run, from the nominal odometry's total turn.

    Parameters
    ----------
    ds : Dataset
        Square runs.

    Returns
    -------
    directions : list of str
        ``cw`` (negative total turn) or ``ccw`` per run.
    turn : numpy.ndarray
        The total turns [rad].
    warnings : list of str
        A detected direction that differs from the declared one; a total turn far from one
        revolution.
    """
    turn = end_poses(ds, ds.nominal)[:, 2]
    dirs = ["cw" if t < 0 else "ccw" for t in turn]
    warnings = []
    several = len({r.source for r in ds.runs}) > 1  # runs of several logs: each named with its log

    def where(run: Run) -> str:
        return f"{ds.name}/{run.name}" + (f" ({run.source})" if several and run.source else "")

    for run, t in zip(ds.runs, turn):
        if abs(abs(math.degrees(t)) - 360.0) > 45.0:
            warnings.append(
                f"{where(run)}: the odometry turns {math.degrees(t):.0f} deg in total, not about "
                "+-360 deg as on a UMBmark square"
            )
    if ds.directions is not None:
        for run, d, decl in zip(ds.runs, dirs, ds.directions):
            if d != decl:
                warnings.append(
                    f"{where(run)}: detected direction {d} differs from the declared {decl} (the detected one is used)"
                )
    return dirs, turn, warnings


def square_runs(ds: Dataset, geometry: WheelGeometry, directions: Iterable[str]) -> RunsTable:
    """The UMBmark runs table of square runs: replayed end pose (odometry) against the
    ground-truth end pose (absolute), in the start frame.

    Parameters
    ----------
    ds : Dataset
        Square runs, each with a ground-truth end pose.
    geometry : WheelGeometry
        The geometry the odometry is replayed with.
    directions : sequence of str
        ``cw`` / ``ccw`` of each run.

    Returns
    -------
    RunsTable

    Raises
    ------
    InputError
        A run has no ground-truth end pose.
    """
    odo = end_poses(ds, geometry)
    ends = []
    for run in ds.runs:
        e = run.end_truth
        if e is None:
            raise InputError("no ground-truth end pose for this run", source=run.source or f"{ds.name}/{run.name}")
        ends.append(e)
    truth = np.asarray(ends)
    return RunsTable.from_columns(
        list(directions),
        truth[:, 0],
        truth[:, 1],
        odo[:, 0],
        odo[:, 1],
        wrap_angle(truth[:, 2]),
        wrap_angle(odo[:, 2]),
        run=[r.name for r in ds.runs],
    )


def prepare(ds: Dataset) -> tuple[Dataset, list[str], np.ndarray]:
    """A square data set with its detected directions set.

    Parameters
    ----------
    ds : Dataset
        Any data set.

    Returns
    -------
    dataset : Dataset
        ``ds`` with ``directions`` detected (:func:`detect_directions`); unchanged when it is not
        a square data set.
    warnings : list of str
        The reader's warnings (``ds.meta["warnings"]``) and the detection's.
    turn : numpy.ndarray
        The runs' total turns [rad] (empty for general paths).
    """
    read = list(ds.meta.get("warnings") or ())
    if not ds.is_square:
        return ds, read, np.array([])
    dirs, turn, warnings = detect_directions(ds)
    return replace(ds, directions=tuple(dirs)), read + warnings, turn


def _directions(ds: Dataset) -> tuple[str, ...]:
    """The directions of a square data set's runs (set by :func:`prepare` or declared)."""
    assert ds.directions is not None, "square runs without their directions"
    return ds.directions


def _check_method(method: str) -> None:
    if method not in method_names():
        raise InputError(f"unknown method {method!r} (choose from {', '.join(method_names())})")


def calibrate(
    ds: Dataset | list[Dataset] | tuple[Dataset, ...], method: str, lsq_options: dict | None = None
) -> Calibrated:
    """Calibrate a geometry from logged runs.

    Parameters
    ----------
    ds : Dataset or sequence of Dataset
        A data set. Square methods need square runs (their directions are detected when not
        set: :func:`prepare`); ``lsq`` also takes several data sets, fitted jointly.
    method : str
        A registered square method (``bf``, ``exact``, ...) or ``lsq``.
    lsq_options : dict, optional
        Options of :func:`umbmark.correct.lsq.fit_lsq` (over :data:`LSQ_DEFAULTS`).

    Returns
    -------
    Calibrated

    Raises
    ------
    InputError
        An unknown method; a square method given a general path or several data sets.
    """
    if method == "lsq":
        sets = ds if isinstance(ds, (list, tuple)) else [ds]
        opts = {**LSQ_DEFAULTS, **(lsq_options or {})}
        res = fit_lsq(sets, **{**opts, "fit_offset": bool(opts["fit_offset"])})  # None (auto): see auto_offset
        return Calibrated("lsq", res.geometry, res.nominal, lsq=res)
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
    _check_both_directions(ds)
    runs = square_runs(ds, ds.nominal, _directions(ds))
    assert ds.side_m is not None  # square runs: their side is known
    corr = correct_runs(method, runs, ds.side_m, ds.nominal.wheelbase_m)
    return Calibrated(method, ds.nominal.calibrated(corr.calibration), ds.nominal, correction=corr)


def _check_both_directions(ds: Dataset) -> None:
    """Refuse square runs in one direction only, naming every run with its direction and log."""
    directions = _directions(ds)
    missing = [d for d in ("cw", "ccw") if d not in directions]
    if not missing:
        return
    several = len({r.source for r in ds.runs}) > 1  # several logs: each run's named
    listed = [f"{r.name} {d}" + (f" ({r.source})" if several else "") for r, d in zip(ds.runs, directions)]
    more = f", and {len(listed) - 20} more" if len(listed) > 20 else ""
    raise InputError(
        f"no {missing[0]} runs: the bi-directional test needs runs in both directions (the direction of a run "
        f"is the sign of its odometry's total turn); the {len(listed)} runs: {', '.join(listed[:20])}{more}",
        source=ds.source,
    )


def _run_errors(ds: Dataset, geometry: WheelGeometry) -> list[tuple[float, float, float]]:
    """Per run: end-position error, end-heading error, along-path RMS position error (NaN: no
    ground truth for it)."""
    x, y, th, n = replay(ds, geometry)
    out = []
    for i, run in enumerate(ds.runs):
        e = run.end_truth
        k = n[i] - 1
        if e is not None:
            end_pos = math.hypot(e[0] - x[i, k], e[1] - y[i, k])
            end_head = float(wrap_angle(e[2] - th[i, k]))
        else:
            end_pos = end_head = float("nan")
        path_rms = float("nan")
        if run.has_trajectory:
            g = run.gt
            ok = np.all(np.isfinite(g), axis=1)
            d = np.hypot(g[ok, 0] - x[i, : n[i]][ok], g[ok, 1] - y[i, : n[i]][ok])
            path_rms = float(np.sqrt(np.mean(d**2)))
        out.append((end_pos, end_head, path_rms))
    return out


def _rms(values: np.ndarray) -> float | None:
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a**2))) if a.size else None


def _summary(errors: list[tuple[float, float, float]], runs: RunsTable | None) -> dict:
    """The fields of an :class:`ErrorSummary` from per-run errors (and square runs' table)."""
    cols = np.array(errors, dtype=float).reshape(-1, 3)
    return {
        "benchmark": None if runs is None else umbmark_figures(runs),
        "end_position_rms_m": _rms(cols[:, 0]),
        "end_heading_rms_rad": _rms(cols[:, 1]),
        "path_position_rms_m": _rms(cols[:, 2]),
    }


def evaluate(ds: Dataset, geometry: WheelGeometry) -> Evaluation:
    """The errors of the odometry replayed with a geometry, against the ground truth.

    Parameters
    ----------
    ds : Dataset
        The logged runs (square runs are benchmarked when their ``directions`` are set).
    geometry : WheelGeometry
        The geometry to replay with.

    Returns
    -------
    Evaluation
        UMBmark figures of square runs, end-pose and along-path RMS errors, per-run errors.
    """
    errors = _run_errors(ds, geometry)
    runs = square_runs(ds, geometry, ds.directions) if ds.is_square and ds.directions is not None else None
    per_run = []
    for i, (run, (end_pos, end_head, path_rms)) in enumerate(zip(ds.runs, errors)):
        extra = {}
        if runs is not None:
            extra = {"direction": str(runs.direction[i]), "eps_x_m": runs.eps_x[i], "eps_y_m": runs.eps_y[i]}
        per_run.append(RunErrors(run.name, end_pos, end_head, path_rms, **extra))
    return Evaluation(**_summary(errors, runs), runs=tuple(per_run))


_LOO_SCHEME = "leave-one-run-out (calibrate without run i, evaluate run i)"
_ACROSS_HINT = "give several data sets for held-out figures across data sets"


def _loo_obstacle(ds: Dataset) -> str | None:
    """Why leave-one-run-out cannot be done on ``ds`` (None: it can)."""
    if len(ds.runs) < 2:
        return f"only one run: nothing to hold out ({_ACROSS_HINT})"
    if ds.is_square:
        counts = {d: list(_directions(ds)).count(d) for d in ("cw", "ccw")}
        if min(counts.values()) < 2:
            return (
                f"leave-one-run-out needs at least 2 runs in both directions (this set has "
                f"{counts['cw']} cw and {counts['ccw']} ccw): without a run, a direction would be "
                f"missing from the calibration ({_ACROSS_HINT})"
            )
    return None


def _heldout_loo(ds: Dataset, method: str, lsq_options: dict | None, full: Calibrated) -> HeldOut:
    """Leave-one-run-out: calibrate without run i, evaluate run i."""
    n = len(ds.runs)
    scheme = _LOO_SCHEME + ("; held-out return errors benchmarked per direction" if ds.is_square else "")
    reason = _loo_obstacle(ds)
    if reason is not None:
        return HeldOut(scheme, reason=reason)
    geoms: list[WheelGeometry] = []
    failed = []
    for i in range(n):
        sub = ds.subset([j for j in range(n) if j != i])
        try:
            if ds.is_square and set(_directions(sub)) != {"cw", "ccw"}:
                raise InputError("runs in both directions are needed")
            opts = {**(lsq_options or {}), "start": full.geometry} if method == "lsq" else lsq_options
            geoms.append(calibrate(sub, method, opts).geometry)
        except InputError as e:
            failed.append(f"{ds.runs[i].name}: {e}")
    if failed:
        return HeldOut(scheme, reason="cannot calibrate without a run: " + "; ".join(failed))
    odo = np.array([end_poses(ds.subset([i]), g)[0] for i, g in enumerate(geoms)])
    errors = [_run_errors(ds.subset([i]), g)[0] for i, g in enumerate(geoms)]
    runs = None
    if ds.is_square:
        truth = np.array([r.end_truth for r in ds.runs])
        runs = RunsTable.from_columns(
            list(_directions(ds)), truth[:, 0], truth[:, 1], odo[:, 0], odo[:, 1], run=[r.name for r in ds.runs]
        )
    held = tuple(HeldOutRun(r.name, g, e[0]) for r, g, e in zip(ds.runs, geoms, errors))
    return HeldOut(scheme, ErrorSummary(**_summary(errors, runs)), held)


# the tracked point's lever arm is named when fitting it removes this share of the position
# residual and it is this far from the axle (and beyond three standard deviations)
_LEVER_GAIN = 0.3
_LEVER_MIN_M = 0.01
# ... and fitted by default (``fit_offset`` None) when it removes this share and is this far: a
# marker clearly off the axle (the 9 to 23 mm of the OptiOdom sets remove 40 % at most)
_LEVER_AUTO_GAIN = 0.7
_LEVER_AUTO_M = 0.03


def _truth_delayed(ds: Dataset) -> bool:
    """True when the ground truth is late or early against the wheels as used (estimated less applied
    beyond :data:`umbmark.model.timing.LARGE_OFFSET_S`): its lag, not a lever arm, explains the residual."""
    from umbmark.model.timing import LARGE_OFFSET_S

    if ds.meta.get("truth_delay_s") is not None:
        return True
    for o in ds.meta.get("time_offset") or ():
        est, applied = o.get("estimated_s"), o.get("applied_s") or 0.0
        if est is not None and abs(est - applied) > max(LARGE_OFFSET_S, o.get("truth_period_s") or 0.0):
            return True
    return False


def _lever_arm(ds: Dataset, cal: Calibrated, opts: dict) -> tuple[LsqResult, bool] | None:
    """The ``lsq`` fit repeated with the tracked point's offset, when that offset explains much of the
    residual (see :data:`_LEVER_GAIN`), and whether it explains most of it (:data:`_LEVER_AUTO_GAIN`);
    None when it does not, the fit was along the end poses, or the ground truth is delayed."""
    res = cal.lsq
    if res is None or res.mode != "sampled" or _truth_delayed(ds):
        return None
    try:
        with_arm = fit_lsq([ds], **{**opts, "fit_offset": True, "start": cal.geometry})
    except InputError:
        return None
    assert with_arm.marker_offset_m is not None and with_arm.marker_offset_std_m is not None
    off = np.asarray(with_arm.marker_offset_m)
    sd = np.asarray(with_arm.marker_offset_std_m)
    arm = float(np.hypot(*off))
    far = arm >= _LEVER_MIN_M and bool(np.any(np.abs(off) > 3 * sd))
    if not (far and with_arm.rms_position_m < (1 - _LEVER_GAIN) * res.rms_position_m):
        return None
    return with_arm, arm >= _LEVER_AUTO_M and with_arm.rms_position_m < (1 - _LEVER_AUTO_GAIN) * res.rms_position_m


def _where(off: np.ndarray) -> str:
    side = "left" if off[1] >= 0 else "right"
    return (
        f"a point {1e3 * abs(off[0]):.0f} mm {'ahead of' if off[0] >= 0 else 'behind'} and {1e3 * abs(off[1]):.0f} "
        f"mm {side} of the axle midpoint"
    )


def auto_offset(ds: Dataset, cal: Calibrated, lsq_options: dict | None = None) -> tuple[Calibrated, str] | None:
    """``lsq`` with ``fit_offset`` None (the default): the calibration with the tracked point's offset
    fitted, when the data determine it (a marker clearly off the axle that explains most of the residual).

    Parameters
    ----------
    ds : Dataset
        The data set calibrated.
    cal : Calibrated
        Its ``lsq`` calibration without the offset.
    lsq_options : dict, optional
        The options of the fit.

    Returns
    -------
    (Calibrated, str) or None
        The calibration with the offset and a note saying so; None when the offset was given
        (``fit_offset`` True or False) or the data do not determine it.
    """
    opts = {**LSQ_DEFAULTS, **(lsq_options or {})}
    if (lsq_options or {}).get("fit_offset") is not None:
        return None
    found = _lever_arm(ds, cal, {**opts, "fit_offset": False})
    if found is None or not found[1]:
        return None
    with_arm = found[0]
    assert with_arm.marker_offset_m is not None and cal.lsq is not None
    note = (
        f"the ground truth moves as {_where(np.asarray(with_arm.marker_offset_m))} (a motion-capture marker off the "
        f"axle): its offset is fitted with the geometry, as the data determine it (the position residual falls from "
        f"{1e3 * cal.lsq.rms_position_m:.1f} to {1e3 * with_arm.rms_position_m:.1f} mm; without it E_b would be "
        f"{cal.geometry.wheelbase_m / cal.nominal.wheelbase_m:.4f}); `fit_offset=False` fits without it"
    )
    return Calibrated("lsq", with_arm.geometry, with_arm.nominal, lsq=with_arm), note


def axle_truth(ds: Dataset, offset_m) -> Dataset:
    """The data set with the ground truth of a tracked point at ``offset_m`` (x, y in the robot frame)
    moved to the axle midpoint, in the same start frame (as :func:`umbmark.correct.lsq.fit_lsq`
    models the tracked point): what the replayed odometry is evaluated against once the offset is
    fitted.

    Parameters
    ----------
    ds : Dataset
        Runs with ground-truth tracks (runs without one are kept as they are).
    offset_m : (float, float)
        The tracked point's offset [m].

    Returns
    -------
    Dataset
    """
    ox, oy = (float(v) for v in offset_m)
    runs = []
    for r in ds.runs:
        if r.gt is None:
            runs.append(r)
            continue
        g = np.asarray(r.gt, dtype=float)
        c, s = np.cos(g[:, 2]), np.sin(g[:, 2])
        moved = np.column_stack([g[:, 0] - (c - 1.0) * ox + s * oy, g[:, 1] - s * ox - (c - 1.0) * oy, g[:, 2]])
        runs.append(replace(r, gt=moved))
    return replace(ds, runs=tuple(runs))  # the same runs: their directions kept


def calibration_notes(ds: Dataset, cal: Calibrated, lsq_options: dict | None = None) -> list[str]:
    """Warnings about what a calibration's numbers say of its inputs.

    * A corrected mean wheel diameter or wheelbase far from the nominal one
      (:func:`umbmark.model.geometry.nominal_slip`): the nominal size was given in another unit or
      as another quantity.
    * ``lsq`` along the path without the tracked point's offset: the fit is repeated with it,
      and an offset that explains much of the residual (a motion-capture marker ahead of the
      axle biases the wheelbase) is named with how to fit it; not when the ground truth is late
      or early against the wheels (its lag, named by the readers, explains the residual).

    Parameters
    ----------
    ds : Dataset
        The data set calibrated.
    cal : Calibrated
        Its calibration (:func:`calibrate`).
    lsq_options : dict, optional
        The options of the ``lsq`` fit.

    Returns
    -------
    list of str
    """
    notes = []
    g, n = cal.geometry, cal.nominal
    d_ratio = g.diameter_avg_m / n.diameter_avg_m
    b_ratio = g.wheelbase_m / n.wheelbase_m
    for what, kind, ratio, got, nom in (
        ("mean wheel diameter", "diameter", d_ratio, g.diameter_avg_m, n.diameter_avg_m),
        ("wheelbase", "wheelbase", b_ratio, g.wheelbase_m, n.wheelbase_m),
    ):
        slip = nominal_slip(kind, ratio)
        if slip is not None:
            notes.append(
                f"the calibrated {what} is {1e3 * got:.1f} mm, {ratio:.2f} times the nominal {1e3 * nom:.1f} mm: "
                f"the nominal size is likely in another unit or another quantity ({slip}); give the robot's "
                "nominal geometry, or the calibration's correction factors mean little"
            )
    opts = {**LSQ_DEFAULTS, **(lsq_options or {})}
    found = None if opts.get("fit_offset") else _lever_arm(ds, cal, {**opts, "fit_offset": False})
    if found is not None and cal.lsq is not None:
        with_arm, res = found[0], cal.lsq
        assert with_arm.marker_offset_m is not None
        notes.append(
            f"the ground truth moves as {_where(np.asarray(with_arm.marker_offset_m))} (a motion-capture marker off "
            f"the axle?): fitted with that offset the position residual falls from {1e3 * res.rms_position_m:.1f} to "
            f"{1e3 * with_arm.rms_position_m:.1f} mm and E_b is {with_arm.geometry.wheelbase_m / n.wheelbase_m:.4f} "
            f"(here {g.wheelbase_m / n.wheelbase_m:.4f}); fit the offset (`fit_offset`)"
        )
    return notes


def _report(
    ds: Dataset, method: str, cal: Calibrated, turn: np.ndarray, warnings: list[str], heldout: HeldOut | None
) -> ReplayReport:
    dirs = _directions(ds) if ds.is_square else ()
    runs = tuple(
        RunInfo(r.name, len(r), float(r.t[-1] - r.t[0]), *((dirs[i], turn[i]) if ds.is_square else ()))
        for i, r in enumerate(ds.runs)
    )
    return ReplayReport(
        dataset=ds.name,
        source=ds.source,
        format=ds.meta.get("format"),
        kind="square" if ds.is_square else "path",
        method=method,
        nominal=ds.nominal,
        units_per_wheel_rev=ds.units_per_wheel_rev,
        side_m=ds.side_m,
        runs=runs,
        calibration=cal,
        before=evaluate(ds, ds.nominal),
        after=evaluate(ds, cal.geometry),
        warnings=tuple(warnings),
        heldout=heldout,
        time_offset=tuple(ds.meta.get("time_offset") or ()),
        wheel_stream=tuple(ds.meta.get("wheel_stream") or ()),
    )


def replay_report(
    datasets: Dataset | Iterable[Dataset], method: str = "bf", lsq_options: dict | None = None, heldout: bool = True
) -> ReplayReport | MultiReplayReport:
    """Replay, calibrate and evaluate each data set, with held-out figures.

    Parameters
    ----------
    datasets : Dataset or iterable of Dataset
        The data sets (of one robot).
    method : str
        The calibration method (:func:`method_names`).
    lsq_options : dict, optional
        Options of the ``lsq`` fit. ``fit_offset`` not given (or None): the tracked point's
        offset is fitted where the data determine it (:func:`auto_offset`, with a warning saying
        so); True or False: it is, or is not.
    heldout : bool
        Also compute the held-out figures: leave-one-run-out and, with several data sets,
        across data sets (see the module docstring).

    Returns
    -------
    ReplayReport or MultiReplayReport
        One data set: its report. Several: every report (each also holding the
        across-data-set figures of its data set) and every (calibrated on, evaluated on) pair.

    Raises
    ------
    InputError
        An unknown method; a data set the method cannot calibrate.
    """
    if isinstance(datasets, Dataset):
        datasets = [datasets]
    datasets = list(datasets)
    _check_method(method)
    parts = []
    for ds in datasets:
        ds, warnings, turn = prepare(ds)
        opts = lsq_options
        cal = calibrate(ds, method, opts)
        auto = auto_offset(ds, cal, opts) if method == "lsq" else None
        if auto is not None:
            cal, opts = auto[0], {**(opts or {}), "fit_offset": True}
            warnings = [*warnings, auto[1]]
        warnings = [*warnings, *calibration_notes(ds, cal, opts)]
        if cal.lsq is not None and cal.lsq.marker_offset_m is not None:  # the odometry is the axle's
            ds = axle_truth(ds, cal.lsq.marker_offset_m)
        loo = _heldout_loo(ds, method, opts, cal) if heldout else None
        parts.append((ds, cal, turn, warnings, loo))
    if len(parts) == 1:
        ds, cal, turn, warnings, loo = parts[0]
        return _report(ds, method, cal, turn, warnings, loo)
    across: list[AcrossRow] = []
    reports = []
    for j, (dst, dst_cal, turn, warnings, loo) in enumerate(parts):
        rows = tuple(
            AcrossRow(src.name, dst.name, evaluate(dst, cal.geometry))
            for i, (src, cal, *_) in enumerate(parts)
            if i != j
        )
        across += rows
        if loo is not None:
            loo = replace(loo, across=AcrossHeldOut(rows))
        reports.append(_report(dst, method, dst_cal, turn, warnings, loo))
    return MultiReplayReport(method, tuple(reports), tuple(across))


def pooled_report(datasets: Iterable[Dataset], lsq_options: dict | None = None, heldout: bool = True) -> PooledReport:
    """One ``lsq`` geometry fitted to all data sets together (same robot).

    Parameters
    ----------
    datasets : iterable of Dataset
        The data sets.
    lsq_options : dict, optional
        Options of the ``lsq`` fit.
    heldout : bool
        Also leave-one-data-set-out: fit on the others, evaluate the one left out (with at
        least two data sets).

    Returns
    -------
    PooledReport

    Raises
    ------
    InputError
        No data sets; the fit fails.
    """
    prepared = [prepare(ds)[0] for ds in datasets]
    if len(prepared) < 1:
        raise InputError("no data sets")
    cal = calibrate(prepared, "lsq", lsq_options)
    per = []
    for i, ds in enumerate(prepared):
        row = PooledRow(
            ds.name, "square" if ds.is_square else "path", evaluate(ds, ds.nominal), evaluate(ds, cal.geometry)
        )
        if heldout and len(prepared) > 1:
            others = [d for j, d in enumerate(prepared) if j != i]
            g = calibrate(others, "lsq", {**(lsq_options or {}), "start": cal.geometry}).geometry
            row = replace(row, heldout_geometry=g, heldout=evaluate(ds, g))
        per.append(row)
    return PooledReport(tuple(d.name for d in prepared), cal, tuple(per))


# --- streaming: one long run in bounded memory --------------------------------------------------


class _PoseKeeper:
    """Collects the poses after every ``decimate``-th sample across chunks."""

    def __init__(self, decimate: int) -> None:
        self.decimate = decimate
        self.parts: dict[str, list] = {"sample": [], "t_s": [], "x_m": [], "y_m": [], "theta_rad": []}

    def add(self, first: int, t: np.ndarray, poses: Iterable[ArrayLike]) -> None:
        sel = np.arange((-(first + 1)) % self.decimate, len(t), self.decimate)
        self.parts["sample"].append(first + sel)
        self.parts["t_s"].append(np.asarray(t, dtype=float)[sel])
        for name, arr in zip(("x_m", "y_m", "theta_rad"), poses):
            self.parts[name].append(np.asarray(arr)[sel])

    def poses(self) -> KeptPoses:
        return KeptPoses(**{k: (np.concatenate(v) if v else np.empty(0)) for k, v in self.parts.items()})


def stream_replay(
    chunks: Iterable,
    geometry: WheelGeometry,
    units_per_wheel_rev: float,
    decimate: int | None = None,
    integrator: str = "exact",
) -> StreamReport:
    """Replay ONE long run given as chunks, in bounded memory.

    Only the current chunk, the running sums and the kept poses are held
    (:class:`umbmark.model.odometry.Odometer`; whole-number increments use its table kernel).

    Parameters
    ----------
    chunks : iterable
        Objects with ``t``, ``d_left``, ``d_right`` and ``gt`` (e.g. the chunks of
        :func:`umbmark.io.generic_csv.iter_generic_csv`).
    geometry : WheelGeometry
        The geometry to replay with.
    units_per_wheel_rev : float
        Log units per wheel revolution.
    decimate : int, optional
        Keep the pose after every ``decimate``-th sample.
    integrator : str
        The integration of one sample.

    Returns
    -------
    StreamReport
        The odometry's end pose; the ground-truth end pose and the end-pose errors when the last
        row has ground truth; the RMS position error over every sample with ground truth (as in
        :func:`evaluate`); the kept poses.

    Raises
    ------
    InputError
        ``decimate`` below 1; fewer than two samples.
    """
    from umbmark.model.odometry import Odometer

    if decimate is not None and decimate < 1:
        raise InputError(f"decimate must be >= 1, got {decimate}")
    p = geometry.params(units_per_wheel_rev)
    odo = Odometer(None, params=p, integrator=integrator)
    keeper = _PoseKeeper(decimate) if decimate else None
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
        if keeper is not None:
            keeper.add(n, ch.t, res)
        n += k
        t_end = float(ch.t[-1])
    if n < 2:
        raise InputError("a run needs at least two samples")
    x, y, th = odo.pose
    truth = err_pos = err_head = None
    if last_gt is not None:
        truth = (float(last_gt[0]), float(last_gt[1]), float(last_gt[2]))
        err_pos = math.hypot(last_gt[0] - x, last_gt[1] - y)
        err_head = float(wrap_angle(last_gt[2] - th))
    return StreamReport(
        dataset=None,
        source=None,
        format=None,
        samples=n,
        chunks=chunks_read,
        duration_s=t_end,
        nominal=geometry,
        units_per_wheel_rev=units_per_wheel_rev,
        end_pose=(x, y, th),
        end_truth=truth,
        end_position_error_m=err_pos,
        end_heading_error_rad=err_head,
        path_position_rms_m=math.sqrt(sq_sum / n_gt) if n_gt >= 2 else None,
        samples_with_truth=n_gt,
        kept=None if keeper is None else keeper.poses(),
        decimate=decimate,
    )


def stream_log(
    path: str | Path | Sequence[str | Path],
    decimate: int | None = None,
    chunk_rows: int = 1 << 16,
    fmt: str = "auto",
    poses_out: str | Path | None = None,
    options: LogOptions | None = None,
) -> StreamReport:
    """Replay ONE long generic CSV log with its nominal geometry in bounded memory.

    Parameters
    ----------
    path : str or Path, or a sequence of one
        The CSV log (one run).
    decimate : int, optional
        Keep the pose after every ``decimate``-th sample.
    chunk_rows : int
        Rows read at a time.
    fmt : str
        The log format (``auto`` or ``csv``: streaming reads the generic CSV only).
    poses_out : str or Path, optional
        Write the kept poses to this CSV file (needs ``decimate``;
        :func:`umbmark.io.poses_csv.write_poses_csv`).
    options : LogOptions, optional
        The reader options of :func:`umbmark.io.load.load_logs`: the nominal geometry, the
        encoder resolution and the tick mode (else the log's own header lines).

    Returns
    -------
    StreamReport
        See :func:`stream_replay`; with the log's name, path and format.

    Raises
    ------
    InputError
        Several files, another format, a square side, missing geometry, ``poses_out`` without
        ``decimate``, or a bad log (file and line named).
    """
    from umbmark.io.generic_csv import iter_generic_csv
    from umbmark.io.load import csv_recorded_geometry, detect_format, nominal_geometry
    from umbmark.io.poses_csv import write_poses_csv

    opts = LogOptions() if options is None else options
    if isinstance(path, (list, tuple)):
        if len(path) != 1:
            raise InputError("streaming replays one log file at a time")
        path = path[0]
    assert isinstance(path, (str, Path)), "one log file"
    if fmt == "auto":
        fmt = detect_format(path)
    if fmt != "csv":
        raise InputError(
            f"streaming reads the generic CSV log only (this is {fmt}; use `umbmark convert` first)", source=str(path)
        )
    if opts.side_m is not None:
        raise InputError(
            "streaming replays one run with the given geometry; UMBmark squares (`side_mm`) need "
            "the whole data set (replay it without `stream`)"
        )
    if opts.time_offset is not None:
        raise InputError(
            "streaming does not move the ground truth in time (`time_offset`): replay the log without `stream`"
        )
    recorded, recorded_ppr = csv_recorded_geometry([path])
    ppr = opts.pulses_per_wheel_rev or recorded_ppr
    if ppr is None:
        raise InputError(
            "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(path)
        )
    nominal = nominal_geometry(opts, str(path), recorded)
    rep = stream_replay(iter_generic_csv(path, opts.ticks, chunk_rows), nominal, ppr, decimate=decimate)
    rep = replace(rep, dataset=Path(path).stem, source=str(path), format="csv")
    if poses_out is not None:
        if rep.kept is None:
            raise InputError("`poses_out` needs `decimate` (keep the pose after every N-th sample)")
        k = rep.kept
        write_poses_csv(poses_out, k.sample, k.t_s, k.x_m, k.y_m, k.theta_rad)
        rep = replace(rep, poses_out=str(poses_out))
    return rep


# --- the calibration history --------------------------------------------------------------------


def _report_parts(rep: dict) -> list[dict]:
    if rep.get("pooled"):
        return list(rep.get("per_dataset") or [])
    if isinstance(rep.get("datasets"), list):
        return list(rep["datasets"])
    return [rep]


def history_fields(
    report: ReplayReport | MultiReplayReport | PooledReport | dict[str, Any],
    paths: str | Path | Sequence[str | Path],
    *,
    kind: str = "replay",
    method: str | None = None,
    file_hash: Callable[[str], str] | None = None,
) -> list[dict]:
    """The calibration-history records of a replay report, one per data set.

    Parameters
    ----------
    report : ReplayReport, MultiReplayReport, PooledReport or dict
        A report, or its ``to_dict()`` (the JSON of ``umbmark replay --json``).
    paths : str, Path or sequence of them
        The log files or folders the report was made from (each data set's is found by its
        source or name).
    kind : str
        The record's kind.
    method : str, optional
        The record's method (default: the report's).
    file_hash : callable, optional
        The content hash of a log file or folder (:func:`umbmark.history.file_sha256`);
        None: no hash.

    Returns
    -------
    list of dict
        The keyword arguments of :func:`umbmark.history.record_result` (without ``robot`` and
        ``db``): ``parameters`` ``Ed``, ``Eb``, ``c_left``, ``c_right``, ``wheelbase_mm`` (the
        corrected one); ``results``: the data set's report with ``emax_syst_mm`` of the odometry
        as it ran (``before``); ``parameters_in_use``: the nominal geometry; ``input_sha256``,
        ``source`` and ``inputs`` (``paths``, ``dataset``).
    """
    rep = report.to_dict() if hasattr(report, "to_dict") else report
    names = [str(p) for p in (paths if isinstance(paths, (list, tuple)) else [paths])]
    out = []
    for i, part in enumerate(_report_parts(rep)):
        src = part.get("source") or part.get("dataset") or (names[i] if i < len(names) else None)
        src_path = next((p for p in names if src and (p == src or Path(p).name == Path(str(src)).name)), src)
        found = src_path if src_path and Path(src_path).exists() else None  # the path, when it exists
        params = {k: part.get(k, rep.get(k)) for k in ("Ed", "Eb", "c_left", "c_right")}
        params["wheelbase_mm"] = part.get("wheelbase_corrected_mm", rep.get("wheelbase_corrected_mm"))
        results = dict(part)
        before = part.get("before")
        results["emax_syst_mm"] = before.get("emax_syst_mm") if isinstance(before, dict) else None
        nominal = part.get("nominal", rep.get("nominal"))
        out.append(
            {
                "kind": kind,
                "method": str(method or part.get("method") or rep.get("method") or "?"),
                "results": results,
                "parameters": params,
                "input_sha256": file_hash(found) if found is not None and file_hash is not None else None,
                "source": None if src_path is None else str(Path(found).resolve() if found is not None else src_path),
                "parameters_in_use": nominal if isinstance(nominal, dict) else None,
                "inputs": {"paths": names, "dataset": src},
            }
        )
    return out
