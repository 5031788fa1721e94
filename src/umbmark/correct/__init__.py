"""Correction methods, one module each: ``borenstein`` (the paper's, ``bf``), ``exact`` ...

Every method takes the runs, the square's side, the wheelbase the odometry used and the
calibration the robot ran with, and returns a :class:`~umbmark.correct.result.CorrectionResult`.
Modules register their methods in :mod:`umbmark.correct.registry`.
"""

from __future__ import annotations

from umbmark.correct import bf, exact  # noqa: F401  (register their methods)
from umbmark.correct.bf import bf_correction
from umbmark.correct.registry import METHODS, correct_runs, register
from umbmark.correct.result import CorrectionResult, compose

__all__ = ["bf_correction", "CorrectionResult", "compose", "METHODS", "correct_runs", "register"]
