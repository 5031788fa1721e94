"""Correction methods, one module each, behind one registry (:mod:`umbmark.correct.registry`).

* Square methods: ``bf`` (:mod:`umbmark.correct.bf`, the paper's linearised correction) and
  ``exact`` (:mod:`umbmark.correct.exact`, the non-linear fit of the closed-loop model). Each
  takes the runs, the square's side, the wheelbase the odometry used and the calibration the
  robot ran with, and returns a :class:`~umbmark.correct.result.CorrectionResult`
  (:func:`correct_runs`).
* Path methods: ``lsq`` (:mod:`umbmark.correct.lsq`, least squares on logs of any path with
  ground truth), returning the fitted wheel geometry (:func:`correct_paths`).
* Self-calibration: :func:`selfcal` (:mod:`umbmark.correct.selfcal`, Censi et al. 2013): wheel
  radii, wheelbase and the lidar's mounting pose from the wheel rotations and the sensor's own
  displacements between scans, with no ground truth.

Importing this package registers them all; it imports no scipy (the fits import it when they
run).
"""

from __future__ import annotations

from umbmark.correct import bf, exact, lsq  # noqa: F401  (register their methods)
from umbmark.correct.bf import bf_correction
from umbmark.correct.exact import exact_correction
from umbmark.correct.registry import (
    METHODS,
    PATH_METHODS,
    PathMethod,
    PathResult,
    SquareMethod,
    correct_paths,
    correct_runs,
    register,
    register_path,
)
from umbmark.correct.result import CorrectionResult, compose
from umbmark.correct.selfcal import SelfcalResult, selfcal

__all__ = [
    "bf_correction",
    "exact_correction",
    "selfcal",
    "SelfcalResult",
    "CorrectionResult",
    "compose",
    "METHODS",
    "PATH_METHODS",
    "SquareMethod",
    "PathMethod",
    "PathResult",
    "correct_runs",
    "correct_paths",
    "register",
    "register_path",
]
