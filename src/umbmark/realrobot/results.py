"""The results of replaying real-robot logs, in SI units (metres, radians, seconds).

Every class here is a frozen dataclass built by :mod:`umbmark.realrobot.replay`; ``to_dict()``
gives the JSON of ``umbmark replay --json`` (millimetres and degrees, keys named with their
units: ``emax_syst_mm``, ``end_heading_rms_deg``, ...). Statistics over several values (the
jackknife spread, the means across data sets, the pooled RMS) are computed in ``to_dict()`` from
the values it reports, so the JSON figures are those of the numbers shown beside them.

* :class:`Calibrated`: a calibrated geometry and the figures of the method that found it;
* :class:`Evaluation`: errors of the odometry replayed with one geometry (:class:`ErrorSummary`
  plus :class:`RunErrors` of every run);
* :class:`HeldOut`: leave-one-run-out figures (:class:`HeldOutRun`, :class:`JackknifeStd`) and,
  with several data sets, :class:`AcrossHeldOut` (rows :class:`AcrossRow`);
* :class:`ReplayReport` (one data set), :class:`MultiReplayReport` (several, held out across
  them), :class:`PooledReport` (one ``lsq`` fit of all data sets; rows :class:`PooledRow`);
* :class:`StreamReport`: one long log replayed in bounded memory (:class:`KeptPoses`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from umbmark.correct.lsq import LsqResult
from umbmark.correct.result import CorrectionResult
from umbmark.metrics import UMBmarkResult
from umbmark.model.dataset import WheelGeometry

__all__ = [
    "Calibrated",
    "RunErrors",
    "ErrorSummary",
    "Evaluation",
    "HeldOutRun",
    "JackknifeStd",
    "AcrossRow",
    "AcrossHeldOut",
    "HeldOut",
    "RunInfo",
    "ReplayReport",
    "MultiReplayReport",
    "PooledRow",
    "PooledReport",
    "KeptPoses",
    "StreamReport",
]

# the three figures a pooled fit and the across-data-set rows report of an evaluation
_HEADLINE = ("emax_syst_mm", "end_position_rms_mm", "path_position_rms_mm")


def _mm(v: float | None) -> float | None:
    return None if v is None else v * 1e3


def _deg(v: float | None) -> float | None:
    return None if v is None else math.degrees(v)


def _jackknife(values: Iterable[float]) -> float:
    """The jackknife standard deviation of leave-one-out estimates."""
    v = np.array(values)
    n = len(v)
    return float(math.sqrt((n - 1) / n * np.sum((v - np.mean(v)) ** 2)))


def _rms_of(values: Iterable[float | None]) -> float | None:
    """RMS of the values that are not None (None when there are none)."""
    v = [x for x in values if x is not None]
    return float(np.sqrt(np.mean(np.square(v)))) if v else None


def _nominal_dict(nominal: WheelGeometry, units_per_wheel_rev: float) -> dict:
    return {**nominal.to_dict(), "units_per_wheel_rev": units_per_wheel_rev}


@dataclass(frozen=True)
class Calibrated:
    """A calibration: the corrected absolute geometry and the figures of the method.

    Attributes
    ----------
    method : str
        The method that calibrated (``bf``, ``exact``, ..., or ``lsq``).
    geometry : WheelGeometry
        The corrected geometry.
    nominal : WheelGeometry
        The geometry the logs were recorded with.
    correction : CorrectionResult or None
        A square method's result (None for ``lsq``).
    lsq : LsqResult or None
        The least-squares fit (``method == "lsq"``), else None.
    """

    method: str
    geometry: WheelGeometry
    nominal: WheelGeometry
    correction: CorrectionResult | None = None
    lsq: LsqResult | None = None

    @property
    def ed(self) -> float:
        """E_d = D_R / D_L of the corrected geometry."""
        return self.geometry.ed

    @property
    def eb(self) -> float:
        """E_b: the corrected wheelbase over the nominal one."""
        return self.geometry.wheelbase_m / self.nominal.wheelbase_m

    @property
    def c_left(self) -> float:
        """The left wheel's correction factor: corrected over nominal diameter."""
        return self.geometry.diameter_left_m / self.nominal.diameter_left_m

    @property
    def c_right(self) -> float:
        """The right wheel's correction factor: corrected over nominal diameter."""
        return self.geometry.diameter_right_m / self.nominal.diameter_right_m

    @property
    def wheelbase_per_mean_diameter(self) -> float:
        """The corrected wheelbase over the mean corrected wheel diameter (the scale-free figure)."""
        return self.geometry.wheelbase_m / self.geometry.diameter_avg_m

    def to_dict(self) -> dict:
        """The corrected geometry against the nominal one (``Ed``, ``Eb``, ``c_left``, mm sizes,
        ...), then the method's figures (``correction`` of a square method; an ``lsq`` fit's
        figures)."""
        d = {**self.geometry.relative_to(self.nominal), "wheelbase_per_mean_diameter": self.wheelbase_per_mean_diameter}
        if self.lsq is not None:
            figures = self.lsq.to_dict()
        elif self.correction is not None:
            fig = self.correction.to_dict()
            fig.pop("wheelbase_corrected_mm", None)
            figures = {"correction": fig, "Ed": self.correction.ed, "Eb": self.correction.eb}
        else:
            figures = {}
        for k, v in figures.items():
            d.setdefault(k, v)
        return d


@dataclass(frozen=True)
class RunErrors:
    """The errors of one replayed run against its ground truth (NaN where there is none).

    Attributes
    ----------
    run : str
        The run's name.
    end_position_error_m, end_heading_error_rad : float
        End-pose errors (truth minus odometry; the heading wrapped to [-pi, pi)).
    path_position_rms_m : float
        RMS position error over the samples with ground truth along the path.
    direction : str or None
        ``cw`` / ``ccw`` of a square run (None on a general path).
    eps_x_m, eps_y_m : float or None
        A square run's return-position errors (truth minus odometry), as in the runs table.
    """

    run: str
    end_position_error_m: float
    end_heading_error_rad: float
    path_position_rms_m: float
    direction: str | None = None
    eps_x_m: float | None = None
    eps_y_m: float | None = None

    def to_dict(self) -> dict:
        """The JSON of one run (mm, deg)."""
        d = {
            "run": self.run,
            "end_position_error_mm": self.end_position_error_m * 1e3,
            "end_heading_error_deg": math.degrees(self.end_heading_error_rad),
            "path_position_rms_mm": self.path_position_rms_m * 1e3,
        }
        if self.direction is not None:
            assert self.eps_x_m is not None and self.eps_y_m is not None  # a square run's: set with its direction
            d.update({"direction": self.direction, "eps_x_mm": self.eps_x_m * 1e3, "eps_y_mm": self.eps_y_m * 1e3})
        return d


@dataclass(frozen=True)
class ErrorSummary:
    """The errors of the replayed odometry over a data set.

    Attributes
    ----------
    benchmark : UMBmarkResult or None
        The UMBmark figures of square runs (None on general paths).
    end_position_rms_m, end_heading_rms_rad, path_position_rms_m : float or None
        RMS over the runs with ground truth of the end-position error, the end-heading error
        and the along-path RMS position error (None when no run has it).
    """

    benchmark: UMBmarkResult | None
    end_position_rms_m: float | None
    end_heading_rms_rad: float | None
    path_position_rms_m: float | None

    @property
    def emax_syst_m(self) -> float | None:
        """E_max,syst of square runs (None on general paths)."""
        return None if self.benchmark is None else self.benchmark.emax_syst

    def to_dict(self) -> dict:
        """The UMBmark figures (``emax_syst_mm``, ``cw``, ``ccw``, ...; only ``emax_syst_mm:
        null`` on general paths), then the RMS errors (mm, deg)."""
        d = {
            "end_position_rms_mm": _mm(self.end_position_rms_m),
            "end_heading_rms_deg": _deg(self.end_heading_rms_rad),
            "path_position_rms_mm": _mm(self.path_position_rms_m),
        }
        if self.benchmark is not None:
            return {**self.benchmark.to_dict(), **d}
        return {"emax_syst_mm": None, **d}


@dataclass(frozen=True)
class Evaluation(ErrorSummary):
    """An :class:`ErrorSummary` with the errors of every run.

    Attributes
    ----------
    runs : tuple of RunErrors
        One entry per run, in the data set's order.
    """

    runs: tuple[RunErrors, ...] = ()

    def to_dict(self) -> dict:
        """The summary's JSON and ``runs``."""
        return {**super().to_dict(), "runs": [r.to_dict() for r in self.runs]}


@dataclass(frozen=True)
class HeldOutRun:
    """One run held out: the geometry calibrated without it and its end-position error with it.

    Attributes
    ----------
    run : str
        The run's name.
    calibrated_without_it : WheelGeometry
        The geometry calibrated on the other runs.
    end_position_error_m : float
        This run's end-position error, replayed with that geometry.
    """

    run: str
    calibrated_without_it: WheelGeometry
    end_position_error_m: float

    def to_dict(self) -> dict:
        """The JSON of one held-out run (mm)."""
        return {
            "run": self.run,
            "calibrated_without_it": self.calibrated_without_it.to_dict(),
            "end_position_error_mm": self.end_position_error_m * 1e3,
        }


@dataclass(frozen=True)
class JackknifeStd:
    """The jackknife spread of leave-one-out calibrations (the uncertainty of the full one).

    Attributes
    ----------
    geometries : tuple of WheelGeometry
        The leave-one-out geometries (at least three).
    """

    geometries: tuple[WheelGeometry, ...]

    @property
    def diameter_left_m(self) -> float:
        """Standard deviation of the left wheel diameter."""
        return _jackknife([g.diameter_left_m for g in self.geometries])

    @property
    def diameter_right_m(self) -> float:
        """Standard deviation of the right wheel diameter."""
        return _jackknife([g.diameter_right_m for g in self.geometries])

    @property
    def wheelbase_m(self) -> float:
        """Standard deviation of the wheelbase."""
        return _jackknife([g.wheelbase_m for g in self.geometries])

    @property
    def ed(self) -> float:
        """Standard deviation of E_d."""
        return _jackknife([g.ed for g in self.geometries])

    def to_dict(self) -> dict:
        """The spreads in mm (``diameter_left_mm``, ``diameter_right_mm``, ``wheelbase_mm``) and of ``Ed``."""
        gs = self.geometries
        return {
            "diameter_left_mm": _jackknife([g.diameter_left_m * 1e3 for g in gs]),
            "diameter_right_mm": _jackknife([g.diameter_right_m * 1e3 for g in gs]),
            "wheelbase_mm": _jackknife([g.wheelbase_m * 1e3 for g in gs]),
            "Ed": _jackknife([g.ed for g in gs]),
        }


@dataclass(frozen=True)
class AcrossRow:
    """A calibration from one data set evaluated on another.

    Attributes
    ----------
    calibrated_on, evaluated_on : str
        The names of the two data sets.
    evaluation : ErrorSummary
        The errors on ``evaluated_on`` of the odometry replayed with the geometry calibrated
        on ``calibrated_on``.
    """

    calibrated_on: str
    evaluated_on: str
    evaluation: ErrorSummary

    def to_dict(self) -> dict:
        """``calibrated_on``, ``evaluated_on`` and the three headline figures (mm)."""
        ev = self.evaluation.to_dict()
        return {"calibrated_on": self.calibrated_on, "evaluated_on": self.evaluated_on, **{k: ev[k] for k in _HEADLINE}}


@dataclass(frozen=True)
class AcrossHeldOut:
    """The held-out figures of one data set across data sets: calibrated on each other one.

    Attributes
    ----------
    rows : tuple of AcrossRow
        One row per other data set.
    """

    rows: tuple[AcrossRow, ...]

    scheme = "calibrated on each other data set, evaluated on this one"

    def _values(self, attr: str) -> list[float]:
        return [v for v in (getattr(r.evaluation, attr) for r in self.rows) if v is not None]

    def to_dict(self) -> dict:
        """``scheme``, the means and maximum (mm) and the rows (``from``)."""
        rows = [r.to_dict() for r in self.rows]
        vals = [r["emax_syst_mm"] for r in rows if r["emax_syst_mm"] is not None]
        ends = [r["end_position_rms_mm"] for r in rows if r["end_position_rms_mm"] is not None]
        return {
            "scheme": self.scheme,
            "emax_syst_mm_mean": float(np.mean(vals)) if vals else None,
            "emax_syst_mm_max": float(np.max(vals)) if vals else None,
            "end_position_rms_mm_mean": float(np.mean(ends)) if ends else None,
            "from": rows,
        }


@dataclass(frozen=True)
class HeldOut:
    """Held-out figures of one data set: leave-one-run-out and (several data sets) across them.

    Attributes
    ----------
    scheme : str
        How the runs were held out.
    summary : ErrorSummary or None
        The errors of the held-out runs, each replayed with the geometry calibrated without it
        (square runs: their return errors benchmarked per direction). None when there was
        nothing to hold out (see ``reason``).
    runs : tuple of HeldOutRun
        Every run with the geometry calibrated without it.
    reason : str or None
        Why there are no leave-one-run-out figures (None when there are).
    across : AcrossHeldOut or None
        With several data sets: the calibrations of the other data sets evaluated on this one.
    """

    scheme: str
    summary: ErrorSummary | None = None
    runs: tuple[HeldOutRun, ...] = ()
    reason: str | None = None
    across: AcrossHeldOut | None = None

    @property
    def emax_syst_m(self) -> float | None:
        """Held-out E_max,syst (None: general paths, or nothing held out)."""
        return None if self.summary is None else self.summary.emax_syst_m

    @property
    def end_position_rms_m(self) -> float | None:
        """Held-out end-position RMS (None: nothing held out)."""
        return None if self.summary is None else self.summary.end_position_rms_m

    @property
    def jackknife_std(self) -> JackknifeStd | None:
        """The jackknife spread of the leave-one-out calibrations (at least three runs), or None."""
        if self.summary is None or len(self.runs) < 3:
            return None
        return JackknifeStd(tuple(r.calibrated_without_it for r in self.runs))

    def to_dict(self) -> dict:
        """``scheme``, then the held-out figures (or ``reason``), ``jackknife_std``, ``runs`` and
        ``across_datasets`` as they apply."""
        d: dict[str, Any]
        if self.summary is None:
            d = {"scheme": self.scheme, "emax_syst_mm": None, "end_position_rms_mm": None, "reason": self.reason}
        else:
            d = {"scheme": self.scheme, **self.summary.to_dict()}
            jk = self.jackknife_std
            if jk is not None:
                d["jackknife_std"] = jk.to_dict()
            d["runs"] = [r.to_dict() for r in self.runs]
        if self.across is not None:
            d["across_datasets"] = self.across.to_dict()
        return d


@dataclass(frozen=True)
class RunInfo:
    """What a report says about one logged run.

    Attributes
    ----------
    run : str
        The run's name.
    samples : int
        Number of samples.
    duration_s : float
        Time from the first to the last sample.
    direction : str or None
        ``cw`` / ``ccw`` detected on a square run (None on a general path).
    total_turn_rad : float or None
        The nominal odometry's total turn of a square run (negative: clockwise).
    """

    run: str
    samples: int
    duration_s: float
    direction: str | None = None
    total_turn_rad: float | None = None

    def to_dict(self) -> dict:
        """The JSON of one run (``total_turn_deg`` in degrees)."""
        d = {"run": self.run, "samples": self.samples, "duration_s": self.duration_s}
        if self.direction is not None:
            assert self.total_turn_rad is not None  # a square run's: set with its direction
            d.update({"direction": self.direction, "total_turn_deg": math.degrees(self.total_turn_rad)})
        return d


def _improvement(before: dict, after: dict, square: bool) -> float | None:
    if square and after["emax_syst_mm"]:
        return before["emax_syst_mm"] / after["emax_syst_mm"]
    if before["end_position_rms_mm"] and after["end_position_rms_mm"]:
        return before["end_position_rms_mm"] / after["end_position_rms_mm"]
    return None


@dataclass(frozen=True)
class ReplayReport:
    """One data set replayed with its nominal and its calibrated geometry.

    Attributes
    ----------
    dataset : str
        The data set's name.
    source : str or None
        Where it was read from.
    format : str or None
        The log format (``optiodom``, ``csv``, ``bag``).
    kind : str
        ``square`` (UMBmark square runs) or ``path``.
    method : str
        The calibration method.
    nominal : WheelGeometry
        The geometry the logs were recorded with.
    units_per_wheel_rev : float
        Log units per wheel revolution.
    side_m : float or None
        The side of the square (None on general paths).
    runs : tuple of RunInfo
        The runs.
    calibration : Calibrated
        The calibration from all runs.
    before, after : Evaluation
        The errors of the odometry replayed with the nominal and with the calibrated geometry.
    warnings : tuple of str
        Doubts about the data (direction, total turn).
    heldout : HeldOut or None
        The held-out figures (None when not asked for).
    time_offset : tuple of dict
        Per bag with a ground truth: the time offset between its wheels and its ground truth,
        estimated and applied (:meth:`umbmark.model.timing.TimeOffset.to_dict` and ``bag``);
        the JSON key ``time_offset`` when not empty.
    wheel_stream : tuple of dict
        Per bag: what the check of its wheel data found and did
        (:meth:`umbmark.model.wheel_stream.StreamReport.to_dict` and ``bag``); the JSON key
        ``wheel_stream`` when not empty.
    """

    dataset: str
    source: str | None
    format: str | None
    kind: str
    method: str
    nominal: WheelGeometry
    units_per_wheel_rev: float
    side_m: float | None
    runs: tuple[RunInfo, ...]
    calibration: Calibrated
    before: Evaluation
    after: Evaluation
    warnings: tuple[str, ...] = ()
    heldout: HeldOut | None = None
    time_offset: tuple[dict, ...] = ()
    wheel_stream: tuple[dict, ...] = ()

    @property
    def improvement(self) -> float | None:
        """E_max,syst before over after (square runs), else the end-position RMS before over after."""
        return _improvement(self.before.to_dict(), self.after.to_dict(), self.kind == "square")

    @property
    def std(self) -> JackknifeStd | None:
        """An ``lsq`` calibration's jackknife spread (held out, at least three runs), else None."""
        if self.calibration.lsq is None or self.heldout is None:
            return None
        return self.heldout.jackknife_std

    def to_dict(self) -> dict:
        """The JSON of ``umbmark replay --json`` for one data set."""
        before, after = self.before.to_dict(), self.after.to_dict()
        d = {
            "dataset": self.dataset,
            "source": self.source,
            "format": self.format,
            "kind": self.kind,
            "method": self.method,
            "nominal": _nominal_dict(self.nominal, self.units_per_wheel_rev),
            "side_mm": _mm(self.side_m),
            "runs": [r.to_dict() for r in self.runs],
            **self.calibration.to_dict(),
            "before": before,
            "after": after,
            "improvement": _improvement(before, after, self.kind == "square"),
            "warnings": list(self.warnings),
        }
        if self.time_offset:
            d["time_offset"] = [dict(o) for o in self.time_offset]
        if self.wheel_stream:
            d["wheel_stream"] = [dict(o) for o in self.wheel_stream]
        if self.heldout is not None:
            d["heldout"] = self.heldout.to_dict()
            if self.calibration.lsq is not None and "jackknife_std" in d["heldout"]:
                d["std"] = d["heldout"]["jackknife_std"]
        return d


@dataclass(frozen=True)
class MultiReplayReport:
    """Several data sets, each calibrated and evaluated, and every calibration evaluated on
    every other data set.

    Attributes
    ----------
    method : str
        The calibration method.
    reports : tuple of ReplayReport
        One report per data set (its ``heldout.across``: the other data sets' calibrations).
    across : tuple of AcrossRow
        Every (calibrated on, evaluated on) pair of different data sets.
    """

    method: str
    reports: tuple[ReplayReport, ...]
    across: tuple[AcrossRow, ...]

    def to_dict(self) -> dict:
        """``method``, ``datasets`` (the reports) and ``across``."""
        return {
            "method": self.method,
            "datasets": [r.to_dict() for r in self.reports],
            "across": [a.to_dict() for a in self.across],
        }


@dataclass(frozen=True)
class PooledRow:
    """One data set of a pooled fit.

    Attributes
    ----------
    dataset : str
        Its name.
    kind : str
        ``square`` or ``path``.
    before, after : Evaluation
        Its errors with the nominal geometry and with the pooled fit.
    heldout_geometry : WheelGeometry or None
        The geometry fitted on the other data sets (None: not held out).
    heldout : Evaluation or None
        Its errors with that geometry.
    """

    dataset: str
    kind: str
    before: Evaluation
    after: Evaluation
    heldout_geometry: WheelGeometry | None = None
    heldout: Evaluation | None = None

    def to_dict(self) -> dict:
        """The data set's headline figures before, after and held out (mm)."""
        before, after = self.before.to_dict(), self.after.to_dict()
        d = {
            "dataset": self.dataset,
            "kind": self.kind,
            "before": {k: before[k] for k in _HEADLINE},
            "after": {k: after[k] for k in _HEADLINE},
        }
        if self.heldout is not None:
            assert self.heldout_geometry is not None  # held out: fitted on the others
            ev = self.heldout.to_dict()
            d["heldout"] = {
                "scheme": "fitted on the other data sets",
                "calibrated_without_it": self.heldout_geometry.to_dict(),
                **{k: ev[k] for k in _HEADLINE},
            }
        return d


@dataclass(frozen=True)
class PooledReport:
    """One ``lsq`` geometry fitted to all data sets together (same robot).

    Attributes
    ----------
    datasets : tuple of str
        The data sets' names.
    calibration : Calibrated
        The pooled fit.
    per_dataset : tuple of PooledRow
        Each data set's figures.
    """

    datasets: tuple[str, ...]
    calibration: Calibrated
    per_dataset: tuple[PooledRow, ...]

    @property
    def is_held_out(self) -> bool:
        """True when every data set was also evaluated with a fit on the others."""
        return len(self.per_dataset) > 1 and all(p.heldout is not None for p in self.per_dataset)

    def _rms(self, part: str) -> float | None:
        return _rms_of(getattr(p, part).end_position_rms_m for p in self.per_dataset)

    def to_dict(self) -> dict:
        """The JSON of ``umbmark replay --pool --json``."""
        per = [p.to_dict() for p in self.per_dataset]
        out = {
            "method": "lsq",
            "pooled": True,
            "datasets": list(self.datasets),
            **self.calibration.to_dict(),
            "per_dataset": per,
        }
        if self.is_held_out:

            def agg(part: str) -> float | None:
                return _rms_of(r[part]["end_position_rms_mm"] for r in per)

            out["before"] = {"end_position_rms_mm": agg("before")}
            out["after"] = {"end_position_rms_mm": agg("after")}
            out["heldout"] = {
                "scheme": "leave-one-data-set-out",
                "end_position_rms_mm": agg("heldout"),
                "emax_syst_mm": None,
            }
        return out


@dataclass(frozen=True)
class KeptPoses:
    """The odometry's poses kept while streaming (every n-th sample).

    Attributes
    ----------
    sample : numpy.ndarray
        Sample indices (0: the first row of the log).
    t_s : numpy.ndarray
        Their times from the run's start.
    x_m, y_m, theta_rad : numpy.ndarray
        The poses in the start frame.
    """

    sample: np.ndarray
    t_s: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    theta_rad: np.ndarray

    def __len__(self) -> int:
        return int(self.sample.size)


@dataclass(frozen=True)
class StreamReport:
    """One long run replayed with a given geometry in bounded memory.

    Attributes
    ----------
    dataset, source, format : str or None
        The log's name, path and format (None when the chunks did not come from a file).
    samples, chunks : int
        Samples replayed and chunks read.
    duration_s : float
        Time of the last sample from the run's start.
    nominal : WheelGeometry
        The geometry replayed with.
    units_per_wheel_rev : float
        Log units per wheel revolution.
    end_pose : tuple of float
        The odometry's end pose (x [m], y [m], theta [rad], unwrapped).
    end_truth : tuple of float or None
        The ground-truth end pose when the last row has one.
    end_position_error_m, end_heading_error_rad : float or None
        End-pose errors (truth minus odometry) when there is a ground-truth end pose.
    path_position_rms_m : float or None
        RMS position error over every sample with ground truth (at least two).
    samples_with_truth : int
        Samples with ground truth.
    kept : KeptPoses or None
        The kept poses (with ``decimate``).
    decimate : int or None
        Every how many samples a pose was kept.
    poses_out : str or None
        The CSV file the kept poses were written to.
    """

    dataset: str | None
    source: str | None
    format: str | None
    samples: int
    chunks: int
    duration_s: float
    nominal: WheelGeometry
    units_per_wheel_rev: float
    end_pose: tuple[float, float, float]
    end_truth: tuple[float, float, float] | None
    end_position_error_m: float | None
    end_heading_error_rad: float | None
    path_position_rms_m: float | None
    samples_with_truth: int
    kept: KeptPoses | None = None
    decimate: int | None = None
    poses_out: str | None = None

    def to_dict(self) -> dict:
        """The JSON of ``umbmark replay --stream --json`` (the number of kept poses, not the poses)."""

        def pose(p: tuple[float, float, float] | None) -> dict[str, float] | None:
            return None if p is None else {"x_mm": p[0] * 1e3, "y_mm": p[1] * 1e3, "theta_deg": math.degrees(p[2])}

        d = {
            "dataset": self.dataset,
            "source": self.source,
            "format": self.format,
            "mode": "stream",
            "samples": self.samples,
            "chunks": self.chunks,
            "duration_s": self.duration_s,
            "nominal": _nominal_dict(self.nominal, self.units_per_wheel_rev),
            "end_pose": pose(self.end_pose),
            "end_truth": pose(self.end_truth),
            "end_position_error_mm": _mm(self.end_position_error_m),
            "end_heading_error_deg": _deg(self.end_heading_error_rad),
            "path_position_rms_mm": _mm(self.path_position_rms_m),
            "samples_with_truth": self.samples_with_truth,
        }
        if self.kept is not None:
            d["decimate"] = self.decimate
            d["kept_poses"] = len(self.kept)
        if self.poses_out is not None:
            d["poses_out"] = self.poses_out
        return d
