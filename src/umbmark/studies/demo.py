"""The demo: the paper's Fig. 11 robot benchmarked, calibrated and benchmarked again, in simulation."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from umbmark.correct.analysis import Analysis, analyze
from umbmark.errors import InputError
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.geometry import FIG11_ERRORS, LABMATE, ErrorParams, Geometry
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import Motion, NoiseModel, simulate_umbmark

__all__ = ["DemoResult", "demo", "SCATTER_TITLE", "FILE_NAMES"]

SCATTER_TITLE = "UMBmark, simulated LabMate (paper's Fig. 11 errors): before and after"
# key of DemoResult.files -> file name written by DemoResult.save
FILE_NAMES = {
    "scatter_png": "umbmark-demo-scatter.png",
    "before_csv": "umbmark-demo-before.csv",
    "after_csv": "umbmark-demo-after.csv",
}


@dataclass(frozen=True)
class DemoResult:
    """The demo's robot, its test before calibration, the calibration, and its test after.

    Attributes
    ----------
    errors : ErrorParams
        The robot's true errors.
    geometry : Geometry
        Its nominal geometry (what the odometry starts from).
    side_m : float
        Side of the square path.
    before : Analysis
        The test of the uncalibrated robot and the calibration computed from it.
    after_runs : RunsTable
        Fresh runs of the robot with that calibration loaded into its odometry.
    after : UMBmarkResult
        The UMBmark figures of ``after_runs``.
    runs_per_direction : int
        Runs per direction in each test.
    noise : str
        Name of the non-systematic noise model.
    seed : int
        The seed of the simulation.
    files : dict or None
        ``{"scatter_png", "before_csv", "after_csv"}`` -> path, once :meth:`save` wrote them.
    """

    errors: ErrorParams
    geometry: Geometry
    side_m: float
    before: Analysis
    after_runs: RunsTable
    after: UMBmarkResult
    runs_per_direction: int = 5
    noise: str = "paper"
    seed: int = 1
    files: dict[str, str] | None = None

    @property
    def improvement(self) -> float:
        """E_max,syst before / after (infinite when the after-runs close exactly)."""
        return self.before.result.emax_syst / self.after.emax_syst if self.after.emax_syst > 0 else math.inf

    def to_dict(self) -> dict:
        """The demo as JSON-able values: the robot, the test settings, both tests, the files.

        Returns
        -------
        dict
            Keys ``true_Ed``, ``true_Eb``, ``true_wheelbase_mm``, ``nominal_wheelbase_mm``,
            ``side_mm``, ``runs_per_direction``, ``noise``, ``seed``, ``before`` (the
            :meth:`Analysis.to_dict` of the first test), ``after`` (the UMBmark figures of the
            second), ``improvement``, and ``files`` once :meth:`save` wrote them.
        """
        d = {
            "true_Ed": self.errors.ed,
            "true_Eb": self.errors.eb,
            "true_wheelbase_mm": self.errors.eb * self.geometry.wheelbase_m * 1e3,
            "nominal_wheelbase_mm": self.geometry.wheelbase_m * 1e3,
            "side_mm": self.side_m * 1e3,
            "runs_per_direction": self.runs_per_direction,
            "noise": self.noise,
            "seed": self.seed,
            "before": self.before.to_dict(),
            "after": self.after.to_dict(),
            "improvement": self.improvement,
        }
        if self.files is not None:
            d["files"] = dict(self.files)
        return d

    def save(self, out_dir=".") -> DemoResult:
        """Write the two runs files and the before/after scatter plot into a folder.

        Parameters
        ----------
        out_dir : str or Path
            An existing folder.

        Returns
        -------
        DemoResult
            This result with :attr:`files` set to the paths written (named as :data:`FILE_NAMES`).

        Raises
        ------
        InputError
            If ``out_dir`` is not an existing folder, or a file cannot be written.
        """
        from umbmark.io.runs_csv import write_runs_csv
        from umbmark.viz.plots import save_figure, scatter_figure

        out = Path(out_dir)
        if not out.is_dir():
            raise InputError(f"output folder {out} does not exist")
        paths = {k: out / name for k, name in FILE_NAMES.items()}
        write_runs_csv(self.before.runs, paths["before_csv"])
        write_runs_csv(self.after_runs, paths["after_csv"])
        save_figure(scatter_figure(self.before.runs, self.after_runs, title=SCATTER_TITLE), paths["scatter_png"])
        return replace(self, files={k: str(p) for k, p in paths.items()})


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

    Parameters
    ----------
    errors : ErrorParams
        The robot's true errors (default: the paper's Fig. 11 robot).
    geometry : Geometry
        Its nominal geometry (default: the LabMate).
    side_m : float
        Side of the square path.
    n_runs : int
        Runs per direction in each test.
    noise : NoiseModel or str
        Non-systematic errors: a model or a preset name (``"none"``, ``"paper"``).
    motion : Motion or None
        Speed and sampling period (default: :class:`Motion` ``()``).
    seed : int
        Seed of both tests. The "after" runs use their own seed stream (fresh runs).
    method : str
        The correction method (``"bf"``: the paper's).

    Returns
    -------
    DemoResult
    """
    s_before, s_after = np.random.SeedSequence(seed).spawn(2)
    before_runs = simulate_umbmark(errors, geometry, side_m, n_runs, None, noise, motion, seed=s_before)
    before = analyze(before_runs, side_m, geometry.wheelbase_m, method)
    after_runs = simulate_umbmark(
        errors, geometry, side_m, n_runs, before.correction.calibration, noise, motion, seed=s_after
    )
    name = noise if isinstance(noise, str) else noise.name
    return DemoResult(errors, geometry, side_m, before, after_runs, umbmark_figures(after_runs), n_runs, name, seed)
