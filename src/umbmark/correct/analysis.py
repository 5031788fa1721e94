"""Analyse a runs table: the UMBmark figures and a calibration by one correction method."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from umbmark._check import positive
from umbmark.correct.registry import correct_runs
from umbmark.correct.result import CorrectionResult
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.geometry import Calibration
from umbmark.model.runs import RunsTable

__all__ = ["Analysis", "analyze"]


@dataclass(frozen=True)
class Analysis:
    """The UMBmark figures of a runs table and a calibration from it.

    Parameters
    ----------
    runs : RunsTable
        The runs analysed.
    result : UMBmarkResult
        Their UMBmark figures (centres of gravity, E_max,syst).
    correction : CorrectionResult
        The calibration the method estimated.
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used during the runs [m].
    checks : tuple of str
        The warnings of the plausibility checks (:mod:`umbmark.correct.plausibility`): units,
        labels or columns that look mistaken.
    """

    runs: RunsTable
    result: UMBmarkResult
    correction: CorrectionResult
    side_m: float
    wheelbase_m: float
    checks: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The figures and the correction as one JSON-ready dict.

        Returns
        -------
        dict
            The UMBmark figures, the correction's keys, ``side_mm``, ``wheelbase_mm`` and
            ``warnings`` (the plausibility checks', the figures' and the correction's, each once).
        """
        d = self.result.to_dict()
        d.update(self.correction.to_dict())
        d["side_mm"] = self.side_m * 1e3
        d["wheelbase_mm"] = self.wheelbase_m * 1e3
        warnings = [*self.checks, *self.result.warnings, *self.correction.warnings]
        d["warnings"] = list(dict.fromkeys(warnings))
        return d


def analyze(
    runs: RunsTable,
    side_m: float,
    wheelbase_m: float,
    method: str = "bf",
    prior: Calibration | None = None,
    check: bool = True,
    **options: Any,
) -> Analysis:
    """UMBmark metrics and a calibration from square runs.

    Parameters
    ----------
    runs : RunsTable
        Square runs in both directions (SI units).
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used during the runs [m].
    method : str
        A registered square method (:data:`umbmark.correct.registry.METHODS`).
    prior : Calibration or None
        The correction factors the robot ran with (``None``: none).
    check : bool
        Run the plausibility checks on the geometry and the runs
        (:func:`umbmark.correct.plausibility.check_geometry` and
        :func:`~umbmark.correct.plausibility.runs_warnings`); their warnings go into
        :attr:`Analysis.checks`. A geometry no answer can mean anything for is refused either way.
    **options
        The method's keyword options.

    Returns
    -------
    Analysis
        The figures and the calibration.

    Raises
    ------
    InputError
        ``side_m`` or ``wheelbase_m`` is not a positive number, or the method refuses its input.
    """
    positive("side_m", side_m)
    positive("wheelbase_m", wheelbase_m)
    checks: list[str] = []
    if check:
        from umbmark.correct.plausibility import check_geometry, runs_warnings

        checks = check_geometry(side_m, wheelbase_m) + runs_warnings(runs, side_m)
    result = umbmark_figures(runs)
    corr = correct_runs(method, runs, side_m, wheelbase_m, prior, **options)
    return Analysis(runs, result, corr, side_m, wheelbase_m, tuple(checks))
