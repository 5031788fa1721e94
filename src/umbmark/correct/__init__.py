"""Correction methods, one module each: ``borenstein`` (the paper's, ``bf``), ``exact`` ...

Every method takes the runs, the square's side, the wheelbase the odometry used and the
calibration the robot ran with, and returns a :class:`~umbmark.correct.result.CorrectionResult`.
Modules register their methods in :mod:`umbmark.correct.registry`.
"""

from __future__ import annotations

from . import borenstein, exact  # noqa: F401  (register their methods)
from .borenstein import bf_correction
from .registry import METHODS, correct_runs, register
from .result import CorrectionResult, compose

__all__ = ["bf_correction", "CorrectionResult", "compose", "METHODS", "correct_runs", "register"]
