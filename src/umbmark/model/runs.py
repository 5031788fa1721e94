"""The runs of a UMBmark experiment: where each run really ended and where its odometry said.

In memory everything is SI (metres, radians) in the start frame; the runs *file* is in
millimetres and degrees (see :mod:`umbmark.io.runs_csv`). Pure numpy: this module imports only
numpy and :mod:`umbmark.model.geometry`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from umbmark.errors import InputError
from umbmark.model.geometry import wrap_angle

__all__ = ["RunsTable", "DIRECTIONS"]

DIRECTIONS = ("cw", "ccw")


@dataclass(frozen=True)
class RunsTable:
    """The end poses of a bi-directional test, one row per run (SI units, start frame).

    Parameters
    ----------
    direction : numpy.ndarray
        ``"cw"`` or ``"ccw"`` per run.
    x_abs, y_abs : numpy.ndarray
        The absolute (measured) end position [m].
    x_odo, y_odo : numpy.ndarray
        The end position the odometry reported [m].
    theta_abs, theta_odo : numpy.ndarray or None
        The end headings [rad], or ``None`` (not measured).
    run : numpy.ndarray or None
        Run numbers or names.
    """

    direction: np.ndarray  # str, 'cw' or 'ccw'
    x_abs: np.ndarray
    y_abs: np.ndarray
    x_odo: np.ndarray
    y_odo: np.ndarray
    theta_abs: np.ndarray | None = None
    theta_odo: np.ndarray | None = None
    run: np.ndarray | None = None

    @classmethod
    def from_columns(
        cls,
        direction: ArrayLike,
        x_abs: ArrayLike,
        y_abs: ArrayLike,
        x_odo: ArrayLike,
        y_odo: ArrayLike,
        theta_abs: ArrayLike | None = None,
        theta_odo: ArrayLike | None = None,
        run: ArrayLike | None = None,
    ) -> RunsTable:
        """A table from columns of any array-like type, checked.

        Parameters
        ----------
        direction, x_abs, y_abs, x_odo, y_odo, theta_abs, theta_odo, run
            As the fields; ``run`` defaults to 1, 2, ...

        Returns
        -------
        RunsTable

        Raises
        ------
        InputError
            On an unknown direction, columns of different lengths or non-finite values.
        """
        d = np.asarray(direction, dtype=str)
        bad = ~np.isin(d, DIRECTIONS)
        if bad.any():
            raise InputError(f"unknown direction {d[bad][0]!r} (expected 'cw' or 'ccw')")
        cols = [np.asarray(c, dtype=float) for c in (x_abs, y_abs, x_odo, y_odo)]
        th = [None if t is None else np.asarray(t, dtype=float) for t in (theta_abs, theta_odo)]
        n = len(d)
        for c in cols + [t for t in th if t is not None]:
            if c.shape != (n,):
                raise InputError("all columns of a runs table must have the same length")
            if not np.all(np.isfinite(c)):
                raise InputError("runs table values must be finite numbers")
        r = np.arange(1, n + 1) if run is None else np.asarray(run)
        return cls(d, cols[0], cols[1], cols[2], cols[3], th[0], th[1], r)

    def __len__(self) -> int:
        return len(self.direction)

    def select(self, mask: ArrayLike) -> RunsTable:
        """Some of the rows.

        Parameters
        ----------
        mask : array_like
            Booleans, one per row, or row indices.

        Returns
        -------
        RunsTable
            The rows where ``mask`` is true (or at its indices).
        """
        m = np.asarray(mask)

        def pick(a):
            return None if a is None else a[m]

        return RunsTable(
            self.direction[m],
            self.x_abs[m],
            self.y_abs[m],
            self.x_odo[m],
            self.y_odo[m],
            pick(self.theta_abs),
            pick(self.theta_odo),
            pick(self.run),
        )

    def direction_rows(self, direction: str) -> RunsTable:
        """The runs of one direction.

        Parameters
        ----------
        direction : str
            ``"cw"`` or ``"ccw"``.

        Returns
        -------
        RunsTable
        """
        return self.select(self.direction == direction)

    @property
    def eps_x(self) -> np.ndarray:
        """Eq. 3.1: return position error, absolute minus calculated (x).

        Examples
        --------
        Two runs: the first ended 1 cm ahead of where its odometry said, the second 2 cm short.

        >>> runs = RunsTable.from_columns(["cw", "ccw"], [0.01, -0.02], [0.0, 0.005], [0.0, 0.0], [0.0, 0.0])
        >>> print(runs.eps_x, runs.direction_rows("ccw").eps_y)
        [ 0.01 -0.02] [0.005]
        """
        return self.x_abs - self.x_odo

    @property
    def eps_y(self) -> np.ndarray:
        """Eq. 3.1: return position error, absolute minus calculated (y)."""
        return self.y_abs - self.y_odo

    @property
    def eps_theta(self) -> np.ndarray | None:
        """Return heading error, absolute minus calculated, wrapped into (-pi, pi]; None if not measured."""
        if self.theta_abs is None or self.theta_odo is None:
            return None
        return wrap_angle(self.theta_abs - self.theta_odo)
