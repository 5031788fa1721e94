"""Logged runs of a real robot: per-sample wheel increments, time, optional ground truth.

Every reader in :mod:`umbmark.io` (optiodom folders, the generic CSV, ROS bags) returns a
:class:`Dataset`: a nominal geometry, the wheel units of the log and a list of :class:`Run`.

* Wheel increments are in the log's own units (``units_per_rev`` of them per wheel
  revolution): encoder pulses (``units_per_rev = gear ratio x pulses per motor revolution``)
  or radians (``units_per_rev = 2 pi``, e.g. ``sensor_msgs/JointState`` positions).
  ``d_left[k]``/``d_right[k]`` is the wheel rotation during sample k (between ``t[k-1]`` and
  ``t[k]``); sample 0 is the start pose (its increment is normally 0).
* The ground truth (``gt``, shape (K, 3): x, y, theta) is at the same sample times, in the run's
  **start frame**: origin at the pose at sample 0, x along the robot's heading there (the
  first leg), y to the left, theta counter-clockwise and unwrapped. NaN rows: no ground truth
  at that sample. A run may instead carry only a measured end pose (``gt_end``, e.g. taped).

SI units (metres, radians, seconds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from umbmark.errors import InputError
from umbmark.model import odometry as _fast
from umbmark.model.geometry import Calibration, OdometryParams, integrate, integrate_end

__all__ = [
    "WheelGeometry",
    "Run",
    "Dataset",
    "to_start_frame",
    "wheel_travel_from_poses",
    "split_at_stops",
    "replay_increments",
    "FAST_MIN_SAMPLES",
]

# Below this many samples (runs x samples) the plain numpy replay of
# :func:`umbmark.model.geometry.integrate` is as fast as the chunked kernels of
# :mod:`umbmark.model.odometry` (their set-up costs more than they save); above it the fast kernels
# win (integer increments: the table kernel, 2-4x; end pose only: more) and keep the working
# memory bounded. Measured on this machine: see the README, real robots section.
FAST_MIN_SAMPLES = 1 << 17


@dataclass(frozen=True)
class WheelGeometry:
    """Absolute geometry of a differential-drive robot: wheel diameters and wheelbase [m]."""

    diameter_left_m: float
    diameter_right_m: float
    wheelbase_m: float

    def __post_init__(self):
        for name in ("diameter_left_m", "diameter_right_m", "wheelbase_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be a positive number, got {v!r}")

    @property
    def ed(self) -> float:
        """E_d = D_R / D_L."""
        return self.diameter_right_m / self.diameter_left_m

    @property
    def diameter_avg_m(self) -> float:
        return 0.5 * (self.diameter_left_m + self.diameter_right_m)

    def params(self, units_per_rev: float) -> OdometryParams:
        """Metres of wheel travel per log unit of each wheel, and the wheelbase."""
        k = math.pi / units_per_rev
        return OdometryParams(k * self.diameter_left_m, k * self.diameter_right_m, self.wheelbase_m)

    def relative_to(self, nominal: WheelGeometry) -> dict:
        """This (corrected) geometry against ``nominal``: the ratios and absolute sizes every
        calibration report gives (``Ed``, ``Eb``, ``Es``, ``c_left``, ``c_right``, mm values)."""
        return {
            "Ed": self.ed,
            "Eb": self.wheelbase_m / nominal.wheelbase_m,
            "Es": self.diameter_avg_m / nominal.diameter_avg_m,
            "c_left": self.diameter_left_m / nominal.diameter_left_m,
            "c_right": self.diameter_right_m / nominal.diameter_right_m,
            "wheelbase_corrected_mm": self.wheelbase_m * 1e3,
            "diameter_left_mm": self.diameter_left_m * 1e3,
            "diameter_right_mm": self.diameter_right_m * 1e3,
        }

    def calibrated(self, cal: Calibration) -> WheelGeometry:
        """This (nominal) geometry with correction factors applied (Eq. 4.33)."""
        b = self.wheelbase_m if cal.wheelbase_m is None else cal.wheelbase_m
        return WheelGeometry(cal.c_left * self.diameter_left_m, cal.c_right * self.diameter_right_m, b)

    def calibration_from(self, nominal: WheelGeometry) -> Calibration:
        """The correction factors that turn ``nominal`` into this geometry."""
        return Calibration(
            self.diameter_left_m / nominal.diameter_left_m,
            self.diameter_right_m / nominal.diameter_right_m,
            self.wheelbase_m,
        )

    def to_dict(self) -> dict:
        return {
            "diameter_left_mm": self.diameter_left_m * 1e3,
            "diameter_right_mm": self.diameter_right_m * 1e3,
            "wheelbase_mm": self.wheelbase_m * 1e3,
        }


@dataclass(frozen=True)
class Run:
    """One logged run (see the module docstring)."""

    name: str
    t: np.ndarray
    d_left: np.ndarray
    d_right: np.ndarray
    gt: np.ndarray | None = None
    gt_end: np.ndarray | None = None
    source: str | None = None

    def __post_init__(self):
        k = len(self.t)
        where = self.source or self.name
        if k < 2:
            raise InputError("a run needs at least two samples", source=where)
        for a in (self.d_left, self.d_right):
            if a.shape != (k,):
                raise InputError("wheel increments and times differ in length", source=where)
            if not np.all(np.isfinite(a)):
                raise InputError("wheel increments must be finite numbers", source=where)
        if self.gt is not None and self.gt.shape != (k, 3):
            raise InputError("ground truth must have one (x, y, theta) row per sample", source=where)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def has_trajectory(self) -> bool:
        """True when there is ground truth along the path (not only at the end)."""
        return self.gt is not None and int(np.isfinite(self.gt[:, 0]).sum()) >= 2

    @property
    def end_truth(self) -> np.ndarray | None:
        """The true end pose (x, y, theta) in the start frame, or None."""
        if self.gt_end is not None:
            return np.asarray(self.gt_end, dtype=float)
        if self.gt is not None and np.all(np.isfinite(self.gt[-1])):
            return self.gt[-1]
        return None

    def slice(self, start: int, stop: int, name: str | None = None) -> Run:
        """Samples ``start..stop-1`` as a run of its own (its ground truth re-expressed in the
        new start frame; the first increment dropped: it happened before the new start)."""
        sl = slice(start, stop)
        d_l = self.d_left[sl].copy()
        d_r = self.d_right[sl].copy()
        d_l[0] = d_r[0] = 0.0
        gt = None
        if self.gt is not None:
            g = self.gt[sl]
            gt = None if not np.all(np.isfinite(g[0])) else np.column_stack(to_start_frame(*g.T))
        return Run(name or f"{self.name}[{start}:{stop}]", self.t[sl] - self.t[start], d_l, d_r, gt, None, self.source)


@dataclass(frozen=True)
class Dataset:
    """Runs of one robot logged with one nominal geometry.

    ``units_per_rev``: log units per wheel revolution (pulses, or 2 pi for radians).
    ``side_m``: side of the square for UMBmark square runs (None: a general path).
    ``directions``: the direction each run is declared to have (optional, e.g. from a file
    layout), checked against the detected one.
    """

    name: str
    nominal: WheelGeometry
    units_per_rev: float
    runs: tuple
    side_m: float | None = None
    source: str | None = None
    directions: tuple | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.runs:
            raise InputError("no runs", source=self.source or self.name)
        if not (math.isfinite(self.units_per_rev) and self.units_per_rev > 0):
            raise InputError(
                f"units per wheel revolution must be positive, got {self.units_per_rev!r}", source=self.source
            )

    @property
    def is_square(self) -> bool:
        return self.side_m is not None

    def subset(self, idx) -> Dataset:
        idx = list(idx)
        dirs = None if self.directions is None else tuple(self.directions[i] for i in idx)
        return replace(self, runs=tuple(self.runs[i] for i in idx), directions=dirs)

    def with_runs(self, runs) -> Dataset:
        return replace(self, runs=tuple(runs), directions=None)

    def padded(self):
        """Wheel increments of all runs, zero-padded to a common length: (R, K) arrays and
        the length of each run. Zero increments leave the pose unchanged."""
        n = np.array([len(r) for r in self.runs])
        k = int(n.max())
        dl = np.zeros((len(self.runs), k))
        dr = np.zeros((len(self.runs), k))
        for i, r in enumerate(self.runs):
            dl[i, : n[i]] = r.d_left
            dr[i, : n[i]] = r.d_right
        return dl, dr, n


def to_start_frame(x, y, theta):
    """Express poses in the frame of the first one: (0, 0, 0) at sample 0; theta unwrapped."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    th = np.unwrap(np.asarray(theta, dtype=float))
    x0, y0, t0 = x[0], y[0], th[0]
    c, s = math.cos(t0), math.sin(t0)
    dx, dy = x - x0, y - y0
    return c * dx + s * dy, -s * dx + c * dy, th - t0


def wheel_travel_from_poses(x, y, theta, wheelbase_m):
    """Per-sample wheel travel (left, right) [m] that an odometry with this wheelbase turned
    into these poses (exact-arc model: the inverse of :func:`umbmark.model.geometry.integrate`).

    Useful for logs that hold only the robot's own odometry poses (e.g. ``nav_msgs/Odometry``)
    and for producing wheel logs from simulated trajectories. Sample 0 gets zero travel.
    """
    x, y, th = (np.asarray(a, dtype=float) for a in (x, y, theta))
    dth = np.diff(th, prepend=th[..., :1], axis=-1)
    dx = np.diff(x, prepend=x[..., :1], axis=-1)
    dy = np.diff(y, prepend=y[..., :1], axis=-1)
    chord = np.hypot(dx, dy)
    heading_mid = th - 0.5 * dth
    sign = np.sign(dx * np.cos(heading_mid) + dy * np.sin(heading_mid))
    du = sign * chord / np.sinc(dth / (2.0 * np.pi))
    half = 0.5 * np.asarray(wheelbase_m, dtype=float) * dth
    return du - half, du + half


def split_at_stops(
    run: Run, units_per_rev: float, stop_s: float = 1.0, min_samples: int = 5, still_units: float = 0.0
) -> list:
    """Split a run where both wheels stand still for at least ``stop_s`` seconds.

    A sample is still when neither wheel turned more than ``still_units`` log units. The
    pieces are the moving stretches (each with the still samples just before it, so it starts
    at rest); pieces with fewer than ``min_samples`` samples are dropped.
    """
    moving = (np.abs(run.d_left) > still_units) | (np.abs(run.d_right) > still_units)
    t = run.t
    pieces = []
    k = len(run)
    idx_moving = np.flatnonzero(moving)
    if idx_moving.size == 0:
        return []
    start = max(int(idx_moving[0]) - 1, 0)
    last_move = int(idx_moving[0])
    for j in idx_moving[1:]:
        j = int(j)
        if t[j - 1] - t[last_move] >= stop_s:
            pieces.append((start, last_move + 1))
            start = j - 1
        last_move = j
    pieces.append((start, min(last_move + 1, k)))
    out = []
    for n, (a, b) in enumerate(pieces, 1):
        if b - a >= min_samples:
            out.append(run.slice(a, b, name=f"{run.name}#{n}"))
    return out


def replay_increments(
    d_left, d_right, params: OdometryParams, method: str = "exact", end: bool = False, integral: bool | None = None
):
    """Odometry from logged wheel increments (arrays (..., K), log units) with ``params``
    (metres per unit of each wheel, wheelbase): the poses after each sample ``(x, y, theta)``,
    or with ``end=True`` only the end pose (arrays of the leading shape).

    Small logs (fewer than :data:`FAST_MIN_SAMPLES` samples in all) are replayed with
    :func:`umbmark.model.geometry.integrate`; larger ones with the chunked kernels of
    :mod:`umbmark.model.odometry` (same poses to rounding, ~1e-11 m): the table kernel when every
    increment is a whole number (``integral``: known already, or None to check), else the
    float kernel.
    """
    d_left = np.asarray(d_left, dtype=float)
    d_right = np.asarray(d_right, dtype=float)
    if d_left.size >= FAST_MIN_SAMPLES:
        if integral is None:
            integral = bool(
                np.all(d_left == np.round(d_left))
                and np.all(d_right == np.round(d_right))
                and np.abs(d_left).max(initial=0) < 2**52
                and np.abs(d_right).max(initial=0) < 2**52
            )
        if integral:
            f = _fast.integrate_pulses_end if end else _fast.integrate_pulses
            return f(d_left.astype(np.int64), d_right.astype(np.int64), params, method=method)
        f = _fast.integrate_end if end else _fast.integrate
    else:
        f = integrate_end if end else integrate
    return f(d_left * params.left_m_per_pulse, d_right * params.right_m_per_pulse, params.wheelbase_m, method=method)
