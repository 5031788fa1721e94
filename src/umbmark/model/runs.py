"""The runs of a UMBmark experiment: where each run really ended and where its odometry said.

In memory everything is SI (metres, radians) in the start frame; the runs *file* is in
millimetres and degrees (see :mod:`umbmark.io.runs_csv`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from umbmark.errors import InputError

__all__ = ["RunsTable", "DIRECTIONS"]

DIRECTIONS = ("cw", "ccw")


@dataclass(frozen=True)
class RunsTable:
    """One row per run. ``theta_abs`` / ``theta_odo`` may be ``None`` (not measured)."""

    direction: np.ndarray  # str, 'cw' or 'ccw'
    x_abs: np.ndarray
    y_abs: np.ndarray
    x_odo: np.ndarray
    y_odo: np.ndarray
    theta_abs: np.ndarray | None = None
    theta_odo: np.ndarray | None = None
    run: np.ndarray | None = None

    @classmethod
    def from_columns(cls, direction, x_abs, y_abs, x_odo, y_odo, theta_abs=None, theta_odo=None, run=None):
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
        return cls(d, *cols, *th, r)

    def __len__(self) -> int:
        return len(self.direction)

    def select(self, mask) -> RunsTable:
        """The rows where ``mask`` is true."""
        m = np.asarray(mask)
        pick = lambda a: None if a is None else a[m]
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
        return self.select(self.direction == direction)

    def concat(self, other: RunsTable) -> RunsTable:
        def cat(a, b):
            return None if a is None or b is None else np.concatenate([a, b])

        return RunsTable(
            np.concatenate([self.direction, other.direction]),
            *(np.concatenate([getattr(self, k), getattr(other, k)]) for k in ("x_abs", "y_abs", "x_odo", "y_odo")),
            cat(self.theta_abs, other.theta_abs),
            cat(self.theta_odo, other.theta_odo),
            cat(self.run, other.run),
        )

    @property
    def eps_x(self) -> np.ndarray:
        """Eq. 3.1: return position error, absolute minus calculated (x)."""
        return self.x_abs - self.x_odo

    @property
    def eps_y(self) -> np.ndarray:
        return self.y_abs - self.y_odo

    @property
    def eps_theta(self) -> np.ndarray | None:
        if self.theta_abs is None or self.theta_odo is None:
            return None
        d = self.theta_abs - self.theta_odo
        return np.mod(d + np.pi, 2 * np.pi) - np.pi
