"""The demo: the paper's Fig. 11 robot benchmarked, calibrated and benchmarked again, in simulation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from umbmark.correct.analysis import Analysis, analyze
from umbmark.metrics import UMBmarkResult, umbmark
from umbmark.model.geometry import FIG11_ERRORS, LABMATE, ErrorParams, Geometry
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import Motion, NoiseModel, simulate_umbmark

__all__ = ["DemoResult", "demo"]


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


def demo(
    errors: ErrorParams = FIG11_ERRORS,
    geometry: Geometry = LABMATE,
    side_m: float = 4.0,
    n_runs: int = 5,
    noise: NoiseModel | str = "paper",
    motion: Motion | None = None,
    seed: int = 1,
    method: str = "bf",
) -> DemoResult:
    """UMBmark before, calibrate, load the calibration into the robot's odometry, UMBmark after.

    The "after" runs use a different seed stream from the "before" runs (fresh runs)."""
    s_before, s_after = np.random.SeedSequence(seed).spawn(2)
    before_runs = simulate_umbmark(errors, geometry, side_m, n_runs, None, noise, motion, seed=s_before)
    before = analyze(before_runs, side_m, geometry.wheelbase_m, method)
    after_runs = simulate_umbmark(
        errors, geometry, side_m, n_runs, before.correction.calibration, noise, motion, seed=s_after
    )
    return DemoResult(errors, geometry, side_m, before, after_runs, umbmark(after_runs))
