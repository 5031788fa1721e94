"""UMBmark metrics (the paper's Eqs. 3.1 - 3.4 and the 3 x SEM rule of section 5).

Definitions used throughout (the paper leaves sigma open):

* return position error of a run (Eq. 3.1): ``eps = absolute - calculated`` (x and y);
* centre of gravity of one direction (Eq. 3.2): ``x_cg = mean(eps_x)``, ``y_cg = mean(eps_y)``;
  ``r_cg = hypot(x_cg, y_cg)`` (Eq. 3.3);
* ``E_max,syst = max(r_cg,cw, r_cg,ccw)`` (Eq. 3.4);
* spread ``sigma`` of one direction: the *radial* sample standard deviation of the return
  errors about their centre of gravity, ``sqrt(sum |eps_i - eps_cg|^2 / (n - 1))``
  (equal to ``sqrt(sigma_x^2 + sigma_y^2)``); ``SEM = sigma / sqrt(n)`` is then the RMS
  distance by which the estimated centre of gravity misses the true one;
* 3 x SEM rule: a second compensation pass is recommended when
  ``E_max,syst >= 3 * SEM`` of the direction that sets E_max,syst; below that the remaining
  centre of gravity cannot be told apart from the non-systematic spread.

Pure numpy: this module imports only numpy and :mod:`umbmark.model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from umbmark.errors import InputError
from umbmark.model.runs import DIRECTIONS, RunsTable

__all__ = ["DirectionStats", "UMBmarkResult", "direction_stats", "umbmark_figures"]


@dataclass(frozen=True)
class DirectionStats:
    """Statistics of the return errors of the runs of one direction (metres).

    Parameters
    ----------
    direction : str
        ``"cw"`` or ``"ccw"``.
    n : int
        Number of runs.
    x_cg, y_cg : float
        Centre of gravity (Eq. 3.2).
    r_cg : float
        Its distance from the origin (Eq. 3.3).
    std : float or None
        Radial sample standard deviation about the centre of gravity (None when n < 2).
    std_x, std_y : float or None
        Sample standard deviations of x and y (None when n < 2).
    sem : float or None
        ``std / sqrt(n)`` (None when n < 2).
    """

    direction: str
    n: int
    x_cg: float
    y_cg: float
    r_cg: float
    std: float | None  # radial sample standard deviation (None when n < 2)
    std_x: float | None
    std_y: float | None
    sem: float | None

    def to_dict(self) -> dict:
        """The statistics in millimetres: ``n``, ``x_cg_mm``, ``y_cg_mm``, ``r_cg_mm``,
        ``std_mm``, ``sem_mm``, ``std_x_mm``, ``std_y_mm``."""
        mm = lambda v: None if v is None else v * 1e3  # noqa: E731
        return {
            "n": self.n,
            "x_cg_mm": mm(self.x_cg),
            "y_cg_mm": mm(self.y_cg),
            "r_cg_mm": mm(self.r_cg),
            "std_mm": mm(self.std),
            "sem_mm": mm(self.sem),
            "std_x_mm": mm(self.std_x),
            "std_y_mm": mm(self.std_y),
        }


def direction_stats(direction: str, eps_x: ArrayLike, eps_y: ArrayLike) -> DirectionStats:
    """The statistics of one direction's return errors.

    Parameters
    ----------
    direction : str
        ``"cw"`` or ``"ccw"``.
    eps_x, eps_y : array_like
        Return position errors of the runs (Eq. 3.1) [m].

    Returns
    -------
    DirectionStats

    Raises
    ------
    InputError
        Without runs.
    """
    ex = np.asarray(eps_x, dtype=float)
    ey = np.asarray(eps_y, dtype=float)
    n = ex.size
    if n == 0:
        raise InputError(f"no {direction} runs: the bi-directional test needs runs in both directions")
    x_cg, y_cg = float(ex.mean()), float(ey.mean())
    if n < 2:
        return DirectionStats(direction, n, x_cg, y_cg, math.hypot(x_cg, y_cg), None, None, None, None)
    sx = float(np.std(ex, ddof=1))
    sy = float(np.std(ey, ddof=1))
    s = math.hypot(sx, sy)
    return DirectionStats(direction, n, x_cg, y_cg, math.hypot(x_cg, y_cg), s, sx, sy, s / math.sqrt(n))


@dataclass(frozen=True)
class UMBmarkResult:
    """The UMBmark figures of a bi-directional test.

    Parameters
    ----------
    cw, ccw : DirectionStats
        The statistics of each direction.
    warnings : tuple of str
        What limits the figures (e.g. a single run in a direction).
    """

    cw: DirectionStats
    ccw: DirectionStats
    warnings: tuple[str, ...] = field(default=())

    @property
    def emax_syst(self) -> float:
        """Eq. 3.4, metres."""
        return max(self.cw.r_cg, self.ccw.r_cg)

    @property
    def worst(self) -> DirectionStats:
        """The direction that sets E_max,syst (cw on a tie)."""
        return self.cw if self.cw.r_cg >= self.ccw.r_cg else self.ccw

    @property
    def sem_rule(self) -> float | None:
        """3 x SEM of the direction that sets E_max,syst (metres), or None when n < 2."""
        sem = self.worst.sem
        return None if sem is None else 3.0 * sem

    @property
    def second_pass_recommended(self) -> bool:
        """True when E_max,syst >= 3 SEM (or when the spread is unknown: n < 2)."""
        rule = self.sem_rule
        return True if rule is None else self.emax_syst >= rule

    def to_dict(self) -> dict:
        """The figures in millimetres: ``emax_syst_mm``, ``cw``, ``ccw``, ``three_sem_mm``,
        ``second_pass_recommended``."""
        rule = self.sem_rule
        return {
            "emax_syst_mm": self.emax_syst * 1e3,
            "cw": self.cw.to_dict(),
            "ccw": self.ccw.to_dict(),
            "three_sem_mm": None if rule is None else rule * 1e3,
            "second_pass_recommended": self.second_pass_recommended,
        }


def umbmark_figures(runs: RunsTable) -> UMBmarkResult:
    """UMBmark metrics of a bi-directional square test.

    Parameters
    ----------
    runs : RunsTable
        The runs, both directions.

    Returns
    -------
    UMBmarkResult

    Raises
    ------
    InputError
        Without runs in a direction.
    """
    stats = {}
    for d in DIRECTIONS:
        rows = runs.direction_rows(d)
        stats[d] = direction_stats(d, rows.eps_x, rows.eps_y)
    warnings = []
    for d in DIRECTIONS:
        if stats[d].n < 2:
            warnings.append(f"only one {d} run: its spread (and so the 3 x SEM rule) is unknown")
    return UMBmarkResult(stats["cw"], stats["ccw"], tuple(warnings))
