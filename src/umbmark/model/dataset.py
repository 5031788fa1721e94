"""Logged runs of a real robot: per-sample wheel increments, time, optional ground truth.

Every reader in :mod:`umbmark.io` (optiodom folders, the generic CSV, ROS bags) returns a
:class:`Dataset`: a nominal geometry, the wheel units of the log and a list of :class:`Run`.

* Wheel increments are in the log's own units (``units_per_wheel_rev`` of them per wheel
  revolution): encoder pulses (``units_per_wheel_rev = gear ratio x pulses per motor revolution``)
  or radians (``units_per_wheel_rev = 2 pi``, e.g. ``sensor_msgs/JointState`` positions).
  ``d_left[k]``/``d_right[k]`` is the wheel rotation during sample k (between ``t[k-1]`` and
  ``t[k]``); sample 0 is the start pose (its increment is normally 0).
* The ground truth (``gt``, shape (K, 3): x, y, theta) is at the same sample times, in the run's
  **start frame**: origin at the pose at sample 0, x along the robot's heading there (the
  first leg), y to the left, theta counter-clockwise and unwrapped. NaN rows: no ground truth
  at that sample. A run may instead carry only a measured end pose (``gt_end``, e.g. taped).

SI units (metres, radians, seconds). Pure numpy: this module imports only numpy and the lower
modules of :mod:`umbmark.model`. :class:`~umbmark.model.geometry.WheelGeometry` is defined in
:mod:`umbmark.model.geometry` and importable from here too.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from umbmark.errors import InputError
from umbmark.model import odometry
from umbmark.model.defaults import STOP_S
from umbmark.model.geometry import OdometryParams, WheelGeometry

__all__ = [
    "WheelGeometry",
    "Run",
    "Dataset",
    "to_start_frame",
    "wheel_travel_from_poses",
    "wheel_angles_from_poses",
    "split_at_stops",
    "check_stop_s",
    "MAX_STOP_S",
    "replay_increments",
    "FAST_MIN_SAMPLES",
]

# Below this many samples (runs x samples) the "trig" kernel of :mod:`umbmark.model.odometry` is
# as fast as its chunked "fast" kernels (their set-up costs more than they save); above it the
# fast kernels win (integer increments: the table kernel, 2-4x; end pose only: more) and keep the
# working memory bounded. The measurements are in the README, real robots section.
FAST_MIN_SAMPLES = 1 << 17


@dataclass(frozen=True)
class Run:
    """One logged run (see the module docstring).

    Parameters
    ----------
    name : str
        Name of the run (a file name, a bag range).
    t : numpy.ndarray
        Sample times [s], shape (K,), K >= 2.
    d_left, d_right : numpy.ndarray
        Wheel increments per sample in log units, shape (K,).
    gt : numpy.ndarray, optional
        Ground truth ``(x, y, theta)`` per sample in the start frame, shape (K, 3); NaN rows:
        none at that sample.
    gt_end : numpy.ndarray, optional
        A measured end pose ``(x, y, theta)`` instead of a trajectory.
    source : str, optional
        Where the run was read from (for messages).
    clock_s : float, optional
        The recording's clock at the run's first sample [s] (``t`` starts at 0): a bag's header
        stamp, a CSV log's first time; None when the log keeps no clock of its own.

    Raises
    ------
    InputError
        On fewer than two samples, arrays of different lengths, non-finite increments or clock.
    """

    name: str
    t: np.ndarray
    d_left: np.ndarray
    d_right: np.ndarray
    gt: np.ndarray | None = None
    gt_end: np.ndarray | None = None
    source: str | None = None
    clock_s: float | None = None

    def __post_init__(self) -> None:
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
        if self.clock_s is not None and not math.isfinite(self.clock_s):
            raise InputError("a run's clock must be a finite time", source=where)

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
        """Samples ``start..stop-1`` as a run of its own.

        Its ground truth is re-expressed in the new start frame; the first increment is
        dropped (it happened before the new start).

        Parameters
        ----------
        start, stop : int
            The sample range.
        name : str, optional
            Name of the new run (default: ``name[start:stop]``).

        Returns
        -------
        Run
        """
        sl = slice(start, stop)
        d_l = self.d_left[sl].copy()
        d_r = self.d_right[sl].copy()
        d_l[0] = d_r[0] = 0.0
        gt = None
        if self.gt is not None:
            g = self.gt[sl]
            gt = None if not np.all(np.isfinite(g[0])) else np.column_stack(to_start_frame(*g.T))
        clock = None if self.clock_s is None else self.clock_s + float(self.t[start])
        name = name or f"{self.name}[{start}:{stop}]"
        return Run(name, self.t[sl] - self.t[start], d_l, d_r, gt, None, self.source, clock)


@dataclass(frozen=True)
class Dataset:
    """Runs of one robot logged with one nominal geometry.

    Parameters
    ----------
    name : str
        Name of the dataset.
    nominal : WheelGeometry
        The nominal geometry the runs are replayed with.
    units_per_wheel_rev : float
        Log units per wheel revolution (pulses, or 2 pi for radians).
    runs : tuple of Run
        The runs (at least one).
    side_m : float, optional
        Side of the square for UMBmark square runs (None: a general path).
    source : str, optional
        Where the dataset was read from.
    directions : tuple of str, optional
        The direction each run is declared to have (e.g. from a file layout), checked
        against the detected one.
    meta : dict
        Anything else the reader found.

    Raises
    ------
    InputError
        Without runs, or on a non-positive ``units_per_wheel_rev``.
    """

    name: str
    nominal: WheelGeometry
    units_per_wheel_rev: float
    runs: tuple
    side_m: float | None = None
    source: str | None = None
    directions: tuple | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.runs:
            raise InputError("no runs", source=self.source or self.name)
        if not (math.isfinite(self.units_per_wheel_rev) and self.units_per_wheel_rev > 0):
            raise InputError(
                f"units per wheel revolution must be positive, got {self.units_per_wheel_rev!r}", source=self.source
            )

    @property
    def is_square(self) -> bool:
        """True for UMBmark square runs (a side length is known)."""
        return self.side_m is not None

    def subset(self, idx: Iterable[int]) -> Dataset:
        """The dataset with only some of its runs.

        Parameters
        ----------
        idx : iterable of int
            Indices of the runs to keep, in the order wanted.

        Returns
        -------
        Dataset
            The same dataset with those runs (and their declared directions).
        """
        idx = list(idx)
        dirs = None if self.directions is None else tuple(self.directions[i] for i in idx)
        return replace(self, runs=tuple(self.runs[i] for i in idx), directions=dirs)

    def with_runs(self, runs: Iterable[Run]) -> Dataset:
        """The dataset with other runs.

        Parameters
        ----------
        runs : iterable of Run
            The new runs.

        Returns
        -------
        Dataset
            The same dataset with these runs and no declared directions.
        """
        return replace(self, runs=tuple(runs), directions=None)

    def padded(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Wheel increments of all runs, zero-padded to a common length.

        Returns
        -------
        tuple of numpy.ndarray
            ``(d_left, d_right, n)``: (R, K) arrays (zero increments leave the pose unchanged)
            and the length of each run.
        """
        n = np.array([len(r) for r in self.runs])
        k = int(n.max())
        dl = np.zeros((len(self.runs), k))
        dr = np.zeros((len(self.runs), k))
        for i, r in enumerate(self.runs):
            dl[i, : n[i]] = r.d_left
            dr[i, : n[i]] = r.d_right
        return dl, dr, n


def to_start_frame(x: ArrayLike, y: ArrayLike, theta: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Express poses in the frame of the first one.

    Parameters
    ----------
    x, y, theta : array_like
        Poses, shape (K,).

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, y, theta)`` with (0, 0, 0) at sample 0; theta unwrapped.

    Examples
    --------
    A robot logged at (1, 2) facing +y, driving along +y: in its start frame, along +x.

    >>> x, y, theta = to_start_frame([1.0, 1.0, 1.0], [2.0, 3.0, 4.0], [np.pi / 2] * 3)
    >>> print(np.round(x, 9) + 0.0, np.round(y, 9) + 0.0, theta)
    [0. 1. 2.] [0. 0. 0.] [0. 0. 0.]
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    th = np.unwrap(np.asarray(theta, dtype=float))
    x0, y0, t0 = x[0], y[0], th[0]
    c, s = math.cos(t0), math.sin(t0)
    dx, dy = x - x0, y - y0
    return c * dx + s * dy, -s * dx + c * dy, th - t0


def wheel_travel_from_poses(
    x: ArrayLike, y: ArrayLike, theta: ArrayLike, wheelbase_m: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample wheel travel that an odometry with this wheelbase turned into these poses: the
    one inversion of an odometry into wheel travel that every reader uses.

    The exact-arc model, the inverse of :func:`umbmark.model.odometry.integrate`: each step's
    heading change ``dth`` is wrapped to (-pi, pi] (wrapped headings need no unwrapping), and
    its arc length is the least-squares one, the displacement projected on the heading halfway
    through the step over ``sinc(dth / 2)`` (negative backwards). A step that is an exact arc
    gives its arc length back; sideways motion, which no arc has, is left out. The wheels rolled
    ``ds -/+ b dth / 2``. Useful for logs that hold only the robot's own odometry poses (e.g.
    ``nav_msgs/Odometry``) and for producing wheel logs from simulated trajectories.

    Parameters
    ----------
    x, y, theta : array_like
        Poses, arrays (..., K).
    wheelbase_m : float or array_like
        The odometry's wheelbase [m].

    Returns
    -------
    tuple of numpy.ndarray
        ``(d_left, d_right)`` [m], arrays (..., K); sample 0 gets zero travel.

    Examples
    --------
    The inverse of the odometry: the poses of 10 cm and 12 cm steps give those steps back.

    >>> from umbmark.model.odometry import integrate
    >>> poses = integrate([0.0, 0.1, 0.1, 0.1], [0.0, 0.12, 0.12, 0.12], 0.3)
    >>> d_left, d_right = wheel_travel_from_poses(*poses, 0.3)
    >>> print(np.round(d_left, 9) + 0.0, np.round(d_right, 9) + 0.0)
    [0.  0.1 0.1 0.1] [0.   0.12 0.12 0.12]
    """
    x, y, th = (np.asarray(a, dtype=float) for a in (x, y, theta))
    dth = np.diff(th, prepend=th[..., :1], axis=-1)
    dth = np.remainder(dth + np.pi, 2.0 * np.pi) - np.pi
    dx = np.diff(x, prepend=x[..., :1], axis=-1)
    dy = np.diff(y, prepend=y[..., :1], axis=-1)
    before = np.concatenate([th[..., :1], th[..., :-1]], axis=-1)
    mid = before + 0.5 * dth
    du = (dx * np.cos(mid) + dy * np.sin(mid)) / np.sinc(dth / (2.0 * np.pi))
    half = 0.5 * np.asarray(wheelbase_m, dtype=float) * dth
    return du - half, du + half


def wheel_angles_from_poses(pose: ArrayLike, geometry: WheelGeometry) -> tuple[np.ndarray, np.ndarray]:
    """The cumulative wheel angles [rad] that an odometry with this geometry turned into these
    poses (0 at the first pose): :func:`wheel_travel_from_poses` over the wheels' radii.

    Parameters
    ----------
    pose : array_like
        ``(K, 3)`` poses ``(x_m, y_m, yaw_rad)`` in time order (yaw wrapped or not).
    geometry : WheelGeometry
        The odometry's geometry (its diameters and wheelbase).

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_rad, right_rad)``, each ``(K,)``.

    Raises
    ------
    InputError
        If ``pose`` is not ``(K, 3)``.
    """
    p = np.asarray(pose, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"`pose` must have shape (K, 3), got {p.shape}")
    dl, dr = wheel_travel_from_poses(p[:, 0], p[:, 1], p[:, 2], geometry.wheelbase_m)
    return np.cumsum(dl) / (0.5 * geometry.diameter_left_m), np.cumsum(dr) / (0.5 * geometry.diameter_right_m)


# a pause between runs longer than this (seconds) is not a pause between runs
MAX_STOP_S = 600.0


def check_stop_s(stop_s, source: str | None = None) -> float:
    """Refuse a pause between runs that is not more than 0 and at most :data:`MAX_STOP_S` seconds.

    Parameters
    ----------
    stop_s : float
        The stillness that ends a run [s].
    source : str, optional
        Where it applies (for the message).

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not a number in that range (milliseconds named where it is beyond it).
    """
    if not (isinstance(stop_s, (int, float)) and math.isfinite(stop_s) and 0 < stop_s <= MAX_STOP_S):
        hint = ""
        if isinstance(stop_s, (int, float)) and stop_s > MAX_STOP_S:
            hint = f" (given in milliseconds? {stop_s:g} ms is {stop_s / 1000:g} s)"
        raise InputError(
            f"`stop_s` must be a pause between runs of more than 0 and at most {MAX_STOP_S:g} s, got {stop_s!r}{hint}",
            source,
        )
    return float(stop_s)


def split_at_stops(
    run: Run, units_per_wheel_rev: float, stop_s: float = STOP_S, min_samples: int = 5, still_units: float = 0.0
) -> list[Run]:
    """Split a run where both wheels stand still for at least ``stop_s`` seconds.

    Parameters
    ----------
    run : Run
        The run to split.
    units_per_wheel_rev : float
        Log units per wheel revolution.
    stop_s : float
        The stillness [s] that ends a piece.
    min_samples : int
        Pieces with fewer samples are dropped.
    still_units : float
        A sample is still when neither wheel turned more than this many log units.

    Returns
    -------
    list of Run
        The moving stretches, each with the still samples just before it (so it starts at
        rest), named ``name#1``, ``name#2``, ...
    """
    check_stop_s(stop_s, run.source)
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


def _whole_numbers(d_left: np.ndarray, d_right: np.ndarray) -> bool:
    return bool(
        np.all(d_left == np.round(d_left))
        and np.all(d_right == np.round(d_right))
        and np.abs(d_left).max(initial=0) < 2**52
        and np.abs(d_right).max(initial=0) < 2**52
    )


def replay_increments(
    d_left: ArrayLike,
    d_right: ArrayLike,
    params: OdometryParams,
    integrator: str = "exact",
    end: bool = False,
    integral: bool | None = None,
) -> tuple[Any, Any, Any]:
    """Odometry from logged wheel increments, with the kernel that suits the log's size.

    Small logs (fewer than :data:`FAST_MIN_SAMPLES` samples in all) are replayed with the
    ``"trig"`` kernel of :mod:`umbmark.model.odometry`; larger ones with its chunked ``"fast"``
    kernels (same poses to rounding, about 1e-11 m): the table kernel when every increment is
    a whole number, else the float kernel.

    Parameters
    ----------
    d_left, d_right : array_like
        Wheel increments in log units, arrays (..., K).
    params : OdometryParams
        Metres per log unit of each wheel, and the wheelbase.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"``.
    end : bool
        Return only the end pose.
    integral : bool, optional
        Whether every increment is a whole number, if known (None: checked).

    Returns
    -------
    tuple
        ``(x, y, theta)``: the poses after each sample, arrays (..., K), or with ``end`` the
        end pose (arrays of the leading shape).
    """
    d_left = np.asarray(d_left, dtype=float)
    d_right = np.asarray(d_right, dtype=float)
    kernel = "fast" if d_left.size >= FAST_MIN_SAMPLES else "trig"
    if kernel == "fast" and (_whole_numbers(d_left, d_right) if integral is None else integral):
        n_left, n_right = d_left.astype(np.int64), d_right.astype(np.int64)
        if end:
            return odometry.integrate_pulses_end(n_left, n_right, params, integrator=integrator)
        return odometry.integrate_pulses(n_left, n_right, params, integrator=integrator)
    d_left = d_left * params.left_m_per_pulse
    d_right = d_right * params.right_m_per_pulse
    if end:
        return odometry.integrate_end(d_left, d_right, params.wheelbase_m, integrator=integrator, kernel=kernel)
    return odometry.integrate(d_left, d_right, params.wheelbase_m, integrator=integrator, kernel=kernel)
