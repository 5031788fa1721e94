"""End-to-end workflows the CLI calls: analyse a runs file, the demo. No printing here."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .benchmark import UMBmarkResult, umbmark
from .correct import CorrectionResult, correct_runs
from .errors import InputError
from .kinematics import LABMATE, Calibration, ErrorParams, Geometry
from .runs import RunsTable
from .simulate import Motion, NoiseModel, simulate_umbmark

__all__ = ["Analysis", "analyze", "DemoResult", "demo", "FIG11_ERRORS", "positive"]

# The paper's Fig. 11 robot: after calibration b = 336.17 mm, D_R/D_L = 1.00084.
FIG11_ERRORS = ErrorParams(ed=1.00084, eb=336.17 / 340.0)


def positive(name: str, value: float) -> float:
    if value is None or not (math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number, got {value!r}")
    return float(value)


# the true errors a simulated robot may have: wheels differing by up to a factor of 2, an
# effective wheelbase from 1/20 to 20 times the nominal one, a mean wheel scale 0.5 to 2
ERROR_RANGES = {"--ed": (0.5, 2.0), "--eb": (0.05, 20.0), "--es": (0.5, 2.0)}


def error_param(name: str, value: float) -> float:
    """A true error factor from the command line, within :data:`ERROR_RANGES`."""
    lo, hi = ERROR_RANGES[name]
    if value is None or not (math.isfinite(value) and lo <= value <= hi):
        raise InputError(f"{name} must be a number from {lo:g} to {hi:g}, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Analysis:
    runs: RunsTable
    result: UMBmarkResult
    correction: CorrectionResult
    side_m: float
    wheelbase_m: float

    def to_dict(self) -> dict:
        d = self.result.to_dict()
        d.update(self.correction.to_dict())
        d["side_mm"] = self.side_m * 1e3
        d["wheelbase_mm"] = self.wheelbase_m * 1e3
        d["warnings"] = list(self.result.warnings) + list(self.correction.extra.get("warnings", []))
        return d


def analyze(runs: RunsTable, side_m: float, wheelbase_m: float, method: str = "bf",
            prior: Calibration | None = None, **options) -> Analysis:
    """UMBmark metrics and a calibration from square runs."""
    positive("side", side_m)
    positive("wheelbase", wheelbase_m)
    result = umbmark(runs)
    corr = correct_runs(method, runs, side_m, wheelbase_m, prior, **options)
    return Analysis(runs, result, corr, side_m, wheelbase_m)


@dataclass(frozen=True)
class DemoResult:
    errors: ErrorParams
    geometry: Geometry
    side_m: float
    before: Analysis
    after_runs: RunsTable
    after: UMBmarkResult

    @property
    def improvement(self) -> float:
        return self.before.result.emax_syst / self.after.emax_syst if self.after.emax_syst > 0 else math.inf


def demo(errors: ErrorParams = FIG11_ERRORS, geometry: Geometry = LABMATE, side_m: float = 4.0, n_runs: int = 5,
         noise: NoiseModel | str = "paper", motion: Motion | None = None, seed: int = 1,
         method: str = "bf") -> DemoResult:
    """UMBmark before, calibrate, load the calibration into the robot's odometry, UMBmark after.

    The "after" runs use a different seed stream from the "before" runs (fresh runs)."""
    s_before, s_after = np.random.SeedSequence(seed).spawn(2)
    before_runs = simulate_umbmark(errors, geometry, side_m, n_runs, None, noise, motion, seed=s_before)
    before = analyze(before_runs, side_m, geometry.wheelbase_m, method)
    after_runs = simulate_umbmark(errors, geometry, side_m, n_runs, before.correction.calibration, noise, motion,
                                  seed=s_after)
    return DemoResult(errors, geometry, side_m, before, after_runs, umbmark(after_runs))
