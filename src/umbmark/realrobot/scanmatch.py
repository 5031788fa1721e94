"""2D scan registration: the pose of one lidar scan's frame in another's (point-to-line ICP).

The matcher is a point-to-line ICP in the manner of Censi's PLICP, built on the ordered structure of
a scan (beams at uniformly spaced angles; ``inf``, ``nan`` or ``0`` where a beam has no return):

* **Reference lines.** The reference scan's valid points, in the order of the beams (beams
  without a return skipped), are cut into straight pieces: at gaps wider than
  :attr:`ICPConfig.line_max_gap_m` and than :attr:`ICPConfig.line_max_gap_ratio` times the range,
  and, recursively, at the point furthest from the chord of a piece's ends while it is more than
  :attr:`ICPConfig.line_split_sigmas` times the scan's noise off (the noise is measured on the
  lines themselves, in three rounds starting from a tolerance of 1.5
  :attr:`ICPConfig.line_max_rms_m`; at least :attr:`ICPConfig.line_split_m`). Every piece of
  :attr:`ICPConfig.line_points` or more points whose residual is within
  :attr:`ICPConfig.line_max_rms_m` gives its points one total least squares line (an end point
  four standard deviations off the line of the others is left out of it). A line spans a whole
  straight wall, not a few neighbouring points: the steps of a coarse range resolution (ranges
  rounded to a few centimetres, the same in consecutive scans of a wall the sensor moves along) stay
  on one line instead of tilting the short lines that follow them, which would pull the pose
  back towards the reference scan's. A line whose direction is uncertain by more than
  :attr:`ICPConfig.line_max_normal_sd_rad` (a few points of a small object) pairs points and
  counts inliers but is left out of the pose estimate.
* **Correspondences.** Each current point, moved by the pose estimate, is projected into the
  reference scan's beam index; the nearest reference point is searched outwards from that beam,
  stopping as soon as the distance to the next beam's ray exceeds the best distance found (an
  exact nearest-point search over the points that have a line). The pair counts only when the
  current sensor's ray through the point meets that point's line within the extent of the
  line's points (half a point spacing beyond its ends) and within
  :attr:`ICPConfig.max_correspondence_m` of the point: a part of a surface that the reference
  scan did not see (beyond a corner, behind an edge) is not matched to the end of another line.
* **Outliers, in two stages.** Until the iteration first settles, the largest
  :attr:`ICPConfig.trim_fraction` of the point-to-line residuals are left out of each step
  (robust from far off); from there on, instead, the residuals beyond
  :attr:`ICPConfig.outlier_sigmas` robust standard deviations (from the median residual), and
  the iteration continues to convergence (keeps every good point near the solution).
* **Step.** One Gauss-Newton step of the point-to-line cost per correspondence update: the 3x3
  normal equations solved in closed form. The iteration has settled when the step is below
  :attr:`ICPConfig.tolerance_m` and :attr:`ICPConfig.tolerance_rad`, or below
  :attr:`ICPConfig.tolerance_sigma` standard deviations of the estimate; no step is longer than
  :attr:`ICPConfig.max_correspondence_m` (a direction the lines leave almost free does not throw
  the pose out of reach). When the correspondences cycle (the pose returns to where it was two
  steps before) or half of :attr:`ICPConfig.max_iterations` is spent, they are kept fixed and
  that least-squares problem is solved to the end.
* **Covariance.** ``sigma^2 H^-1`` at the solution, ``H`` the Gauss-Newton matrix of the kept
  correspondences and ``sigma^2`` their residual variance (``n - 3`` degrees of freedom), times
  :attr:`ICPConfig.covariance_scale`.
* **Coarse stage** (:attr:`ICPConfig.coarse`): a correlative grid search (Olson's correlative
  scan matching) over translations within :attr:`ICPConfig.coarse_range_m` and rotations within
  :attr:`ICPConfig.coarse_range_rad` of the initial pose, on a smoothed grid of the reference
  points; ICP then starts from the best :attr:`ICPConfig.coarse_candidates` distinct peaks, and
  the result with the most inliers wins. For displacements that odometry cannot predict (up to
  a metre and tens of degrees).

A match is ``converged`` only when the iteration settled, enough points matched
(:attr:`ICPConfig.min_points`, :attr:`ICPConfig.min_inlier_fraction`) and the geometry
constrains all three degrees of freedom (:attr:`ICPConfig.min_constraint_ratio`, computed from the
correspondences of the estimate: a corridor without visible ends does not, whether or not the
iteration settled); otherwise ``reason`` says why. Bad numbers never raise from the
compiled code: too few valid points is a result, not an exception.

The kernels are compiled with numba when it is installed (once per machine: numba's cache), one
version each (their argument types are fixed), in two halves at once: a second Python process
compiles the matching kernels into the cache while the first match compiles the scans' kernels
(:func:`start_compiling` starts it earlier, e.g. before a bag is read); the wide search's kernels
(``ICPConfig.coarse``) on its first use. Without numba the same code
runs interpreted (the same results, about a hundred times slower). Imports numpy and
:mod:`umbmark.errors`; numba lazily, on the first match.

The pose convention: the result is the current scan's frame expressed in the reference scan's
frame, ``p_ref = R(yaw) p_cur + (x, y)``; for consecutive scans of a moving sensor it is the
sensor's displacement ``between(pose_ref, pose_cur)`` (:func:`umbmark.model.se2.between`).
"""

from __future__ import annotations

import math
import subprocess
import sys
import threading
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._numba import numba_module
from umbmark.errors import InputError

__all__ = [
    "ICPConfig",
    "ScanMatch",
    "ScanMatches",
    "match_scans",
    "match_scan_pairs",
    "match_consecutive",
    "have_numba",
    "kernel_state",
    "start_compiling",
    "STATUS_REASONS",
]

# ---------------------------------------------------------------- configuration and results


@dataclass(frozen=True)
class ICPConfig:
    """Settings of :func:`match_scans` (SI units).

    Parameters
    ----------
    max_iterations : int
        Correspondence updates (one Gauss-Newton step each) before giving up.
    max_correspondence_m : float
        A current point further than this from its nearest reference point has no partner.
    trim_fraction : float
        First stage: the fraction of the correspondences with the largest point-to-line residuals
        left out of every step (0 keeps all, below 1).
    outlier_sigmas : float
        Second stage, once the first has settled: instead, the correspondences whose residual
        exceeds this many robust standard deviations (``1.4826 * median |r|``, but at least a
        micrometre) are left out, and the iteration continues to convergence (0: no second
        stage).
    line_points : int
        Fewest points of a reference line (a straight piece of the reference scan, at least 2).
    line_max_rms_m : float
        A reference line whose fit residual (root mean square) exceeds this is not used.
    line_max_gap_m, line_max_gap_ratio : float
        Consecutive points (in the order of the beams) further apart than ``line_max_gap_m``
        and than ``line_max_gap_ratio`` times their range are not on one line (the second lets
        the sparse points of far walls form lines).
    line_split_m, line_split_sigmas : float
        A run of points is split into straight pieces at the point furthest from the chord of
        its ends while that distance exceeds ``line_split_sigmas`` times the scan's noise
        (measured on its lines), and at least ``line_split_m``: steps of a coarse range
        resolution stay on one line, corners do not.
    line_max_normal_sd_rad : float
        A reference line whose direction is uncertain by more than this (standard deviation,
        from its residual, at least the scan's noise) still pairs points and counts inliers but
        is left out of the pose estimate (``inf``: every line is used).
    tolerance_m, tolerance_rad : float
        The iteration has converged when the step is below both,
    tolerance_sigma : float
        or when the step is below this many standard deviations of the estimate (its
        Mahalanobis length under the covariance).
    min_points : int
        Fewest valid points in either scan, and fewest kept correspondences, for a match.
    inlier_threshold_m : float
        A current point is an inlier when it lies within this distance of its reference line at
        the solution (well above the range noise: it tells a right alignment from a wrong one).
    min_inlier_fraction : float
        Fewest inliers, as a fraction of the current scan's valid points, for a converged match.
    min_constraint_ratio : float
        Smallest ratio of the least to the largest eigenvalue of the Gauss-Newton matrix (the
        rotation scaled by the points' root-mean-square range) for a converged match; below it the
        scene leaves a direction unconstrained (a corridor).
    covariance_scale : float
        Factor applied to ``sigma^2 H^-1``. ``sigma^2 H^-1`` alone understates the error: the
        lines of neighbouring reference points share their points, so the residuals are not
        independent (all the points of a wall share its line). The default is the ratio of the
        actual to the predicted error variance on simulated scans (1.6 to 2.0 for 2 to 10 mm of
        range noise, 180 to 720 beams, no or 20 % dropouts).
    range_min_m, range_max_m : float
        Ranges outside ``[range_min_m, range_max_m]`` are dropped (as are inf, nan and ranges
        of zero or less: no return).
    coarse : bool
        Run the correlative grid search before ICP (large or unknown displacements).
    coarse_range_m, coarse_range_rad : float
        Half-widths of the coarse search around the initial pose: translation in x and y, rotation.
    coarse_step_m, coarse_step_rad : float
        Grid steps of the coarse search (the map's cell and its smoothing).
    coarse_candidates : int
        Distinct coarse peaks that ICP starts from.

    Raises
    ------
    InputError
        If a setting is out of range (the message names it).
    """

    max_iterations: int = 40
    max_correspondence_m: float = 0.3
    trim_fraction: float = 0.05
    outlier_sigmas: float = 4.0
    line_points: int = 3
    line_max_rms_m: float = 0.04
    line_max_gap_m: float = 0.5
    line_max_gap_ratio: float = 0.1
    line_split_m: float = 0.0001
    line_split_sigmas: float = 4.0
    line_max_normal_sd_rad: float = 0.05
    tolerance_m: float = 1e-7
    tolerance_rad: float = 1e-7
    tolerance_sigma: float = 0.05
    min_points: int = 20
    inlier_threshold_m: float = 0.05
    min_inlier_fraction: float = 0.7
    min_constraint_ratio: float = 0.02
    covariance_scale: float = 1.8
    range_min_m: float = 0.0
    range_max_m: float = math.inf
    coarse: bool = False
    coarse_range_m: float = 1.2
    coarse_range_rad: float = math.radians(35.0)
    coarse_step_m: float = 0.1
    coarse_step_rad: float = math.radians(1.5)
    coarse_candidates: int = 6

    def __post_init__(self) -> None:
        ints = {"max_iterations": 1, "line_points": 2, "min_points": 3, "coarse_candidates": 1}
        for name, lo in ints.items():
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < lo:
                raise InputError(f"`{name}` must be an integer >= {lo}, got {v!r}")
        positive = (
            "max_correspondence_m",
            "line_max_rms_m",
            "line_max_gap_m",
            "line_max_gap_ratio",
            "line_split_m",
            "line_split_sigmas",
            "tolerance_m",
            "tolerance_rad",
            "tolerance_sigma",
            "inlier_threshold_m",
            "covariance_scale",
            "coarse_range_m",
            "coarse_range_rad",
            "coarse_step_m",
            "coarse_step_rad",
        )
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v) and v > 0):
                raise InputError(f"`{name}` must be a positive number, got {v!r}")
        v = self.line_max_normal_sd_rad
        if not (isinstance(v, (int, float, np.integer, np.floating)) and v > 0):
            raise InputError(f"`line_max_normal_sd_rad` must be a positive number or inf, got {v!r}")
        if not (math.isfinite(self.outlier_sigmas) and self.outlier_sigmas >= 0):
            raise InputError(f"`outlier_sigmas` must be a number >= 0, got {self.outlier_sigmas!r}")
        for name in ("trim_fraction", "min_inlier_fraction", "min_constraint_ratio"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.integer, np.floating)) and 0.0 <= v < 1.0):
                raise InputError(f"`{name}` must be in [0, 1), got {v!r}")
        if not (0.0 <= self.range_min_m < self.range_max_m):
            raise InputError(
                f"need 0 <= `range_min_m` < `range_max_m`, got {self.range_min_m!r} and {self.range_max_m!r}"
            )
        if self.coarse_range_rad > math.pi:
            raise InputError(f"`coarse_range_rad` must be at most pi, got {self.coarse_range_rad!r}")


# the outlier threshold never drops below this: on noise-free scans the residuals at the solution are
# rounding errors, and a threshold relative to them would keep an arbitrary (possibly degenerate) subset
_OUTLIER_FLOOR_M = 1e-6

# status codes of the compiled kernel
_OK, _FEW_REF, _FEW_CUR, _FEW_CORR, _DEGENERATE, _MAX_ITER, _FEW_INLIERS, _SINGULAR = range(8)

STATUS_REASONS: dict[int, str] = {
    _OK: "",
    _FEW_REF: "too few valid points in the reference scan",
    _FEW_CUR: "too few valid points in the current scan",
    _FEW_CORR: "too few correspondences",
    _DEGENERATE: "degenerate scene: a direction is unconstrained",
    _MAX_ITER: "no convergence within `max_iterations`",
    _FEW_INLIERS: "too few of the current scan's points matched",
    _SINGULAR: "degenerate scene: singular normal equations",
}
"""The reason of each kernel status (the empty string for a converged match)."""

# layout of the kernel's per-pair output row
# (pose 3, covariance 9, rms, kept correspondences, valid current points, reference points with a
# line, iterations, status, constraint ratio, last step (m, rad), inliers)
_O_POSE, _O_COV, _O_RMS, _O_NIN, _O_NCUR, _O_NREF, _O_ITER, _O_STATUS, _O_RATIO, _O_STEP = (
    0,
    3,
    12,
    13,
    14,
    15,
    16,
    17,
    18,
    19,
)
_O_NCLOSE = 21
_O_WIDTH = 22


def _reason(row: NDArray[np.float64], cfg: ICPConfig) -> str:
    status = int(row[_O_STATUS])
    base = STATUS_REASONS[status]
    if status == _FEW_REF:
        return f"{base} ({int(row[_O_NREF])} with a line, `min_points` {cfg.min_points})"
    if status == _FEW_CUR:
        return f"{base} ({int(row[_O_NCUR])}, `min_points` {cfg.min_points})"
    if status == _FEW_CORR:
        return f"{base} ({int(row[_O_NIN])}, `min_points` {cfg.min_points})"
    if status == _DEGENERATE:
        return f"{base} (constraint ratio {row[_O_RATIO]:.2g} < `min_constraint_ratio` {cfg.min_constraint_ratio:g})"
    if status == _MAX_ITER:
        return f"{base} ({cfg.max_iterations}; last step {row[_O_STEP]:.2g} m, {row[_O_STEP + 1]:.2g} rad)"
    if status == _FEW_INLIERS:
        frac = row[_O_NCLOSE] / max(row[_O_NCUR], 1.0)
        return f"{base} ({frac:.0%} < `min_inlier_fraction` {cfg.min_inlier_fraction:.0%})"
    return base


@dataclass(frozen=True)
class ScanMatch:
    """The result of matching one scan against a reference scan.

    Parameters
    ----------
    pose : numpy.ndarray
        ``(x_m, y_m, yaw_rad)``: the current scan's frame in the reference scan's frame.
    covariance : numpy.ndarray
        3x3 covariance of ``pose`` [m^2, m rad, rad^2] (nan when there was no solution).
    rms_m : float
        Root mean square of the kept point-to-line residuals.
    inlier_fraction : float
        Fraction of the current scan's valid points within
        :attr:`ICPConfig.inlier_threshold_m` of their reference line at the solution.
    iterations : int
        Gauss-Newton steps taken (of the winning start, with the coarse stage).
    converged : bool
        The iteration settled and the match passed the checks of :class:`ICPConfig`.
    reason : str
        Why the match did not converge (empty when it did).
    """

    pose: NDArray[np.float64]
    covariance: NDArray[np.float64]
    rms_m: float
    inlier_fraction: float
    iterations: int
    converged: bool
    reason: str = ""

    @property
    def x_m(self) -> float:
        """Translation along the reference frame's x axis [m]."""
        return float(self.pose[0])

    @property
    def y_m(self) -> float:
        """Translation along the reference frame's y axis [m]."""
        return float(self.pose[1])

    @property
    def yaw_rad(self) -> float:
        """Rotation of the current frame relative to the reference frame [rad]."""
        return float(self.pose[2])

    def to_dict(self) -> dict[str, Any]:
        """The result as JSON-ready values.

        Returns
        -------
        dict
            ``x_m``, ``y_m``, ``yaw_rad``, ``covariance`` (3x3 nested lists), ``rms_m``,
            ``inlier_fraction``, ``iterations``, ``converged``, ``reason``.
        """
        return {
            "x_m": self.x_m,
            "y_m": self.y_m,
            "yaw_rad": self.yaw_rad,
            "covariance": self.covariance.tolist(),
            "rms_m": float(self.rms_m),
            "inlier_fraction": float(self.inlier_fraction),
            "iterations": int(self.iterations),
            "converged": bool(self.converged),
            "reason": self.reason,
        }


@dataclass(frozen=True)
class ScanMatches:
    """The results of many matches, as arrays (one row per pair).

    Parameters
    ----------
    poses : numpy.ndarray
        ``(K, 3)``: ``(x_m, y_m, yaw_rad)`` of each current scan in its reference scan's frame.
    covariances : numpy.ndarray
        ``(K, 3, 3)``.
    rms_m, inlier_fraction : numpy.ndarray
        ``(K,)``, as in :class:`ScanMatch`.
    iterations : numpy.ndarray
        ``(K,)`` integers.
    converged : numpy.ndarray
        ``(K,)`` booleans.
    reasons : list of str
        Why each match did not converge (empty strings for those that did).
    config : ICPConfig
        The settings used.
    """

    poses: NDArray[np.float64]
    covariances: NDArray[np.float64]
    rms_m: NDArray[np.float64]
    inlier_fraction: NDArray[np.float64]
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    reasons: list[str] = field(default_factory=list)
    config: ICPConfig = field(default_factory=ICPConfig)

    def __len__(self) -> int:
        return int(self.poses.shape[0])

    def __getitem__(self, k: int) -> ScanMatch:
        """Pair ``k`` as a :class:`ScanMatch`.

        Parameters
        ----------
        k : int
            Index of the pair (negative counts from the end).

        Returns
        -------
        ScanMatch
        """
        return ScanMatch(
            pose=self.poses[k].copy(),
            covariance=self.covariances[k].copy(),
            rms_m=float(self.rms_m[k]),
            inlier_fraction=float(self.inlier_fraction[k]),
            iterations=int(self.iterations[k]),
            converged=bool(self.converged[k]),
            reason=self.reasons[k],
        )

    def to_dict(self) -> dict[str, Any]:
        """All matches as JSON-ready values.

        Returns
        -------
        dict
            ``config`` (the settings) and ``matches``: one :meth:`ScanMatch.to_dict` per pair.
        """
        cfg = {k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in asdict(self.config).items()}
        return {"config": cfg, "matches": [self[k].to_dict() for k in range(len(self))]}


# ---------------------------------------------------------------- kernels (numba when installed)

# integer settings (``ip``) and real settings (``fp``) of the kernels, by index
_I_MAX_ITER, _I_LINE_POINTS, _I_MIN_POINTS, _I_COARSE, _I_CANDIDATES = range(5)
_I_WIDTH = 5
(
    _F_GATE,
    _F_TRIM,
    _F_OUT_SIGMAS,
    _F_LINE_RMS,
    _F_LINE_GAP,
    _F_TOL_M,
    _F_TOL_RAD,
    _F_TOL_SIGMA,
    _F_INLIER_M,
    _F_MIN_INLIERS,
    _F_MIN_RATIO,
    _F_COV_SCALE,
    _F_RANGE_MIN,
    _F_RANGE_MAX,
    _F_COARSE_M,
    _F_COARSE_RAD,
    _F_STEP_M,
    _F_STEP_RAD,
    _F_GAP_RATIO,
    _F_SPLIT_M,
    _F_SPLIT_SIGMAS,
    _F_NORMAL_SD,
) = range(22)
_F_WIDTH = 22

# a scan's arrays: rows of the float array ``pts`` and of the boolean array ``flags``
# point; unit normal and a point of its line; the extent of the line (along (-ny, nx) from that point)
_P_X, _P_Y, _P_NX, _P_NY, _P_LX, _P_LY, _P_U0, _P_U1 = range(8)
_P_WIDTH = 8
_B_VALID, _B_LINE, _B_WEAK = range(3)  # a valid return; a line was fitted; its direction is uncertain
_B_WIDTH = 3


def _split_pieces(x, y, order, nv, gap2, ratio2, split, iwork):
    """Cut the valid points (in beam order) into straight pieces; returns their number.

    A piece ends where consecutive points are further apart than ``sqrt(gap2)`` and than
    ``sqrt(ratio2)`` times the range of the nearer one; each run between such gaps is split
    recursively at its point furthest from the chord of its end points while that distance
    exceeds ``split``; the split point is on both pieces (it may be the corner, or next to it on
    either wall: :func:`_fit_pieces` leaves it out of the line it is off). Rows of ``iwork``: 0
    and 1 the first and last position of each piece in ``order``, 2 and 3 whether that end is a
    split point, 4 and 5 the stack.
    """
    seg_a = iwork[0]
    seg_b = iwork[1]
    cut_a = iwork[2]
    cut_b = iwork[3]
    stack_a = iwork[4]
    stack_b = iwork[5]
    nseg = 0
    start = 0
    for t in range(1, nv + 1):
        if t < nv:
            k = order[t]
            kp = order[t - 1]
            lim2 = max(gap2, ratio2 * min(x[k] * x[k] + y[k] * y[k], x[kp] * x[kp] + y[kp] * y[kp]))
            if (x[k] - x[kp]) ** 2 + (y[k] - y[kp]) ** 2 <= lim2:
                continue
        # the stack holds a piece as (first, last); a split end is stored as -1 - position
        ns = 1
        stack_a[0] = start
        stack_b[0] = t - 1
        while ns > 0:
            ns -= 1
            a = stack_a[ns]
            b = stack_b[ns]
            ca = a < 0
            cb = b < 0
            if ca:
                a = -1 - a
            if cb:
                b = -1 - b
            best = -1.0
            bq = a
            if b - a >= 2:
                ka = order[a]
                kb = order[b]
                cx = x[kb] - x[ka]
                cy = y[kb] - y[ka]
                cl = math.sqrt(cx * cx + cy * cy)
                for q in range(a + 1, b):
                    k = order[q]
                    if cl > 0.0:
                        d = abs((x[k] - x[ka]) * cy - (y[k] - y[ka]) * cx) / cl
                    else:
                        d = math.sqrt((x[k] - x[ka]) ** 2 + (y[k] - y[ka]) ** 2)
                    if d > best:
                        best = d
                        bq = q
            if best > split:
                stack_a[ns] = -1 - a if ca else a
                stack_b[ns] = -1 - bq
                stack_a[ns + 1] = -1 - bq
                stack_b[ns + 1] = -1 - b if cb else b
                ns += 2
            else:
                seg_a[nseg] = a
                seg_b[nseg] = b
                cut_a[nseg] = 1 if ca else 0
                cut_b[nseg] = 1 if cb else 0
                nseg += 1
        start = t
    return nseg


def _tls(x, y, order, a, b):
    """Total least squares line of the points ``order[a..b]``: (normal x, y, centroid x, y, sum
    of squared distances to the line, scatter along it); the normal is ``nan`` for coincident
    points."""
    cnt = b - a + 1
    # moments about the first point (no cancellation far from the sensor)
    k0 = order[a]
    x0 = x[k0]
    y0 = y[k0]
    sx = sy = sxx = sxy = syy = 0.0
    for q in range(a, b + 1):
        k = order[q]
        u = x[k] - x0
        v = y[k] - y0
        sx += u
        sy += v
        sxx += u * u
        sxy += u * v
        syy += v * v
    mx = sx / cnt
    my = sy / cnt
    ca = sxx - cnt * mx * mx
    cb = sxy - cnt * mx * my
    cc = syy - cnt * my * my
    h = 0.5 * (ca - cc)
    root = math.sqrt(h * h + cb * cb)
    lam = max(0.5 * (ca + cc) - root, 0.0)
    # the eigenvector of the smallest eigenvalue is the normal
    if h > 0.0:
        vx = cb
        vy = lam - ca
    else:
        vx = lam - cc
        vy = cb
    nn = math.sqrt(vx * vx + vy * vy)
    if not nn > 0.0:
        return math.nan, math.nan, mx + x0, my + y0, lam, 0.5 * (ca + cc) + root
    return vx / nn, vy / nn, mx + x0, my + y0, lam, 0.5 * (ca + cc) + root


def _fit_pieces(x, y, order, nseg, iwork, fits, m, max_rms2, noise2):
    """The total least squares line of every piece: rows of ``fits`` (normal x, y; centroid x, y;
    sum of squared distances to the line; scatter along it), normal x ``nan`` when fewer than
    ``m`` points fit or their residual (root mean square) exceeds ``sqrt(max_rms2)``.

    An end point more than four standard deviations off the line of the other points (their
    residual, at least ``noise2``) is left out of the fit, repeatedly: a point of the next
    surface that the split tolerance let in. Rows 2 and 3 of ``iwork`` become the numbers of points left
    out at the first and the last end.
    """
    for s in range(nseg):
        a = iwork[0, s]
        b = iwork[1, s]
        fits[0, s] = math.nan
        nx = ny = lx = ly = lam = lal = math.nan
        while True:
            nx, ny, lx, ly, lam, lal = _tls(x, y, order, a, b)
            if not nx == nx or b - a + 1 <= 2:
                break
            # each end point against the line of the others: leave out the worse one if it is
            # more than four standard deviations (of the others, at least the noise) off
            worst = 0.0
            side = 0
            for e in range(2):
                ke = order[a] if e == 0 else order[b]
                fnx, fny, flx, fly, flam, _ = _tls(x, y, order, a + 1 - e, b - e)
                if not fnx == fnx:
                    continue
                d2 = (fnx * (x[ke] - flx) + fny * (y[ke] - fly)) ** 2
                z2 = d2 / (16.0 * max(flam / max(b - a - 2, 1), noise2) + 1e-24)
                if z2 > worst:
                    worst = z2
                    side = e
            if worst <= 1.0:
                break
            if side == 0:
                a += 1
            else:
                b -= 1
        cnt = b - a + 1
        iwork[2, s] = a - iwork[0, s]
        iwork[3, s] = iwork[1, s] - b
        if cnt < m or not nx == nx or lam > max_rms2 * cnt:
            continue
        fits[0, s] = nx
        fits[1, s] = ny
        fits[2, s] = lx
        fits[3, s] = ly
        fits[4, s] = lam
        fits[5, s] = lal


def _scan_noise(iwork, fits, nseg, vals):
    """The scan's noise: the median, over the points of the lines of 5 points or more, of their
    line's residual variance (squared metres; 0 without such a line)."""
    nval = 0
    for s in range(nseg):
        cnt = iwork[1, s] - iwork[3, s] - iwork[0, s] - iwork[2, s] + 1
        if cnt >= 5 and fits[0, s] == fits[0, s]:
            v = fits[4, s] / (cnt - 2)
            for _ in range(cnt):
                vals[nval] = v
                nval += 1
    if nval == 0:
        return 0.0
    return _kth_smallest(vals, nval, nval // 2)


def _fit_lines(pts, flags, wrap, ip, fp, work, order, iwork, fits):
    """The reference line of every valid point: the line of the straight piece of the scan it is on.

    The valid points are taken in the order of the beams (a full circle starting after its
    widest gap) and cut into straight pieces (:func:`_split_pieces`) three times: first within
    1.5 ``line_max_rms_m``, then within ``line_split_sigmas`` times the noise of the pieces of
    the round before (:func:`_scan_noise`; at least ``line_split_m``). A piece whose line
    (:func:`_fit_pieces`) fits ``line_points`` or more points within ``line_max_rms_m`` gives its
    points that line, the extent of its points along it (half a point spacing beyond the ends)
    and, when the direction of the line is uncertain by more than ``line_max_normal_sd_rad``
    (its residual variance, at least the scan's noise, over the scatter along it), the weak
    flag. A point where two pieces meet takes the nearer line. ``work`` is a ``(5, n)`` scratch
    array, ``order`` ``(n,)`` and ``iwork`` ``(6, n + 1)`` integer ones, ``fits``
    ``(7, 2 n + 2)``. Returns the number of points with a line.
    """
    x = pts[_P_X]
    y = pts[_P_Y]
    valid = flags[_B_VALID]
    m = ip[_I_LINE_POINTS]
    nv = 0
    for i in range(x.size):
        flags[_B_LINE, i] = False
        flags[_B_WEAK, i] = False
        if valid[i]:
            order[nv] = i
            nv += 1
    if nv < m:
        return 0
    if wrap:
        # start after the widest gap, so that a wall across the first and last beam stays whole
        bg = -1.0
        bt = 0
        for t in range(nv):
            k = order[t]
            kp = order[t - 1] if t > 0 else order[nv - 1]
            g = (x[k] - x[kp]) ** 2 + (y[k] - y[kp]) ** 2
            if g > bg:
                bg = g
                bt = t
        tmp = iwork[4]
        for t in range(nv):
            tmp[t] = order[(t + bt) % nv]
        for t in range(nv):
            order[t] = tmp[t]
    gap2 = fp[_F_LINE_GAP] ** 2
    ratio2 = fp[_F_GAP_RATIO] ** 2
    max_rms2 = fp[_F_LINE_RMS] ** 2
    split_min = fp[_F_SPLIT_M]
    # the noise of the pieces within a generous tolerance sets the tolerance of the next cut;
    # a second round removes what corners inside the first pieces added to the noise
    split = 1.5 * fp[_F_LINE_RMS]
    noise2 = 0.0
    for _ in range(3):
        nseg = _split_pieces(x, y, order, nv, gap2, ratio2, split, iwork)
        _fit_pieces(x, y, order, nseg, iwork, fits, m, max_rms2, noise2)
        noise2 = _scan_noise(iwork, fits, nseg, fits[6])
        split = max(split_min, fp[_F_SPLIT_SIGMAS] * math.sqrt(noise2))
    sd2 = fp[_F_NORMAL_SD] ** 2
    dist = work[0]
    for t in range(nv):
        dist[t] = math.inf
    count = 0
    for s in range(nseg):
        if not fits[0, s] == fits[0, s]:
            continue
        a = iwork[0, s]
        b = iwork[1, s]
        cnt = b - a + 1 - iwork[2, s] - iwork[3, s]
        nx = fits[0, s]
        ny = fits[1, s]
        lx = fits[2, s]
        ly = fits[3, s]
        weak = max(fits[4, s] / max(cnt - 2, 1), noise2) > sd2 * fits[5, s]
        umin = math.inf
        umax = -math.inf
        for q in range(a, b + 1):
            k = order[q]
            u = nx * (y[k] - ly) - ny * (x[k] - lx)
            umin = min(umin, u)
            umax = max(umax, u)
        pad = 0.5 * (umax - umin) / max(cnt - 1, 1)
        for q in range(a, b + 1):
            k = order[q]
            d = abs(nx * (x[k] - lx) + ny * (y[k] - ly))
            if d < dist[q]:
                if dist[q] == math.inf:
                    count += 1
                dist[q] = d
                pts[_P_NX, k] = nx
                pts[_P_NY, k] = ny
                pts[_P_LX, k] = lx
                pts[_P_LY, k] = ly
                pts[_P_U0, k] = umin - pad
                pts[_P_U1, k] = umax + pad
                flags[_B_LINE, k] = True
                flags[_B_WEAK, k] = weak
    return count


def _prepare_scan(r, cosa, sina, wrap, ip, fp, pts, flags, work, order, iwork, fits):
    """The points of one scan and the line of each; returns (valid points, points with a line)."""
    n = r.size
    rmin = fp[_F_RANGE_MIN]
    rmax = fp[_F_RANGE_MAX]
    nvalid = 0
    for i in range(n):
        ri = r[i]
        ok = math.isfinite(ri) and ri > 0.0 and ri >= rmin and ri <= rmax
        flags[_B_VALID, i] = ok
        pts[_P_X, i] = ri * cosa[i] if ok else 0.0
        pts[_P_Y, i] = ri * sina[i] if ok else 0.0
        if ok:
            nvalid += 1
    nline = _fit_lines(pts, flags, wrap, ip, fp, work, order, iwork, fits)
    return nvalid, nline


def _kth_smallest(a, n, k):
    """The k-th smallest (0-based) of ``a[:n]``, reordering ``a`` (quickselect)."""
    lo = 0
    hi = n - 1
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i = lo
        j = hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                t = a[i]
                a[i] = a[j]
                a[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return a[k]
    return a[k]


def _sym3_eigen_ratio(a00, a01, a02, a11, a12, a22):
    """Smallest over largest eigenvalue of a symmetric positive semi-definite 3x3 matrix."""
    q = (a00 + a11 + a22) / 3.0
    if not q > 0.0:
        return 0.0
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    p = math.sqrt(((a00 - q) ** 2 + (a11 - q) ** 2 + (a22 - q) ** 2 + 2.0 * p1) / 6.0)
    if p < 1e-12 * q:
        return 1.0  # a multiple of the identity
    b00 = (a00 - q) / p
    b11 = (a11 - q) / p
    b22 = (a22 - q) / p
    b01 = a01 / p
    b02 = a02 / p
    b12 = a12 / p
    det_b = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02)
    phi = math.acos(min(1.0, max(-1.0, 0.5 * det_b))) / 3.0
    e_max = q + 2.0 * p * math.cos(phi)
    e_min = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return max(e_min, 0.0) / e_max


def _icp(rpts, rflags, cpts, cflags, ncur, beams, sin2, pose0, ip, fp, wf, wn, wi, out):
    """Point-to-line ICP of one pair from ``pose0``; fills ``out`` (the ``_O_*`` layout).

    ``beams`` is ``(first angle, increment, 1.0 for a full circle)``; ``sin2[d]`` the squared sine
    of the smallest angle to a beam ``d`` steps away; ``wf`` (5, n), ``wn`` (2, n) and ``wi`` (n)
    are scratch arrays.
    """
    rx = rpts[_P_X]
    ry = rpts[_P_Y]
    rnx = rpts[_P_NX]
    rny = rpts[_P_NY]
    rlx = rpts[_P_LX]
    rly = rpts[_P_LY]
    rline = rflags[_B_LINE]
    rweak = rflags[_B_WEAK]
    ru0 = rpts[_P_U0]
    ru1 = rpts[_P_U1]
    cx = cpts[_P_X]
    cy = cpts[_P_Y]
    cvalid = cflags[_B_VALID]
    wr = wf[0]  # residual
    wa = wf[1]  # its absolute value (reordered by the selections)
    wj0 = wf[2]  # Jacobian: the normal, and the rotation column
    wj1 = wf[3]
    wj2 = wf[4]
    wc = wn[0]  # the current point of the correspondence
    wk = wn[1]  # its reference point
    n = rx.size
    inc = beams[1]
    wrap = beams[2] > 0.0
    half = 0.5 * (n - 1)
    amid = beams[0] + half * inc
    amid = math.atan2(math.sin(amid), math.cos(amid))
    maxd = n // 2 + 1 if wrap else n
    max_iter = ip[_I_MAX_ITER]
    min_points = ip[_I_MIN_POINTS]
    gate2 = fp[_F_GATE] ** 2
    keep = 1.0 - fp[_F_TRIM]
    k_mad = fp[_F_OUT_SIGMAS]
    tol_t = fp[_F_TOL_M]
    tol_r = fp[_F_TOL_RAD]
    tol_s2 = fp[_F_TOL_SIGMA] ** 2
    close_m = fp[_F_INLIER_M]
    tx = pose0[0]
    ty = pose0[1]
    th = pose0[2]
    status = _MAX_ITER
    it = 0
    frozen = False  # the correspondences are kept fixed
    robust = not k_mad > 0.0  # the second stage is on (or not wanted)
    px1 = py1 = pt1 = math.inf  # the poses after the last two steps
    px2 = py2 = pt2 = math.inf
    m = 0
    nin = 0
    nclose = 0
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    ssr = 0.0
    ssp = 0.0
    st = 0.0
    sr = 0.0
    while it < max_iter:
        c = math.cos(th)
        s = math.sin(th)
        if frozen:
            # the correspondences and the kept set of the last update, at the new pose
            for q in range(m):
                j = wc[q]
                kb = wk[q]
                qx = c * cx[j] - s * cy[j]
                qy = s * cx[j] + c * cy[j]
                wr[q] = rnx[kb] * (qx + tx - rlx[kb]) + rny[kb] * (qy + ty - rly[kb])
                wj2[q] = rny[kb] * qx - rnx[kb] * qy
        else:
            m = 0
            nclose = 0
            for j in range(cx.size):
                if not cvalid[j]:
                    continue
                qx = c * cx[j] - s * cy[j]
                qy = s * cx[j] + c * cy[j]
                px = qx + tx
                py = qy + ty
                r2 = px * px + py * py
                # the beam of the point's direction (counted from the middle of the field of view)
                da = math.atan2(py, px) - amid
                if da > math.pi:
                    da -= 2.0 * math.pi
                elif da < -math.pi:
                    da += 2.0 * math.pi
                k0 = int(math.floor(da / inc + half + 0.5))
                if wrap:
                    k0 = k0 % n
                elif k0 < 0:
                    k0 = 0
                elif k0 >= n:
                    k0 = n - 1
                # nearest reference point with a line: outwards from k0 until the beams' rays
                # are further than the best distance so far
                best = gate2
                kb = -1
                for d in range(maxd):
                    if r2 * sin2[d] > best:
                        break
                    for side in range(2 if d > 0 else 1):
                        k = k0 + d if side == 0 else k0 - d
                        if wrap:
                            if k >= n:
                                k -= n
                            elif k < 0:
                                k += n
                        elif k < 0 or k >= n:
                            continue
                        if rline[k]:
                            dx = px - rx[k]
                            dy = py - ry[k]
                            dd = dx * dx + dy * dy
                            if dd < best:
                                best = dd
                                kb = k
                if kb < 0:
                    continue
                res = rnx[kb] * (px - rlx[kb]) + rny[kb] * (py - rly[kb])
                if abs(res) <= close_m:
                    nclose += 1
                # the line must be what the current sensor sees there: its ray through the point
                # meets the line within the extent of the line's points (and within the gate)
                rho = math.sqrt(qx * qx + qy * qy)
                den = (rnx[kb] * qx + rny[kb] * qy) / rho if rho > 0.0 else 0.0
                if abs(den) < 1e-6:
                    continue
                hit = rho - res / den  # range of the line along the ray
                hx = tx + qx * (hit / rho)
                hy = ty + qy * (hit / rho)
                u = rnx[kb] * (hy - rly[kb]) - rny[kb] * (hx - rlx[kb])
                if hit <= 0.0 or (hit - rho) ** 2 > gate2 or u < ru0[kb] or u > ru1[kb]:
                    continue
                wr[m] = res
                wa[m] = abs(res)
                wj0[m] = rnx[kb]
                wj1[m] = rny[kb]
                wj2[m] = rny[kb] * qx - rnx[kb] * qy
                wc[m] = j
                wk[m] = kb
                m += 1
            if m < min_points:
                status = _FEW_CORR
                nin = m
                break
            if robust and k_mad > 0.0:
                # second stage: the residuals beyond k_mad robust deviations (1.4826 median |r|) out
                thr = max(k_mad * 1.4826 * _kth_smallest(wa, m, m // 2), _OUTLIER_FLOOR_M)
            else:
                # first stage: the largest trim fraction of the residuals out
                kk = max(int(math.ceil(keep * m)) - 1, min(m, min_points) - 1)
                thr = _kth_smallest(wa, m, kk)
            # the lines of uncertain direction take part in the selection, not in the estimate
            for q in range(m):
                wi[q] = abs(wr[q]) <= thr and not rweak[wk[q]]
        # the normal equations of the kept correspondences
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        g0 = g1 = g2 = 0.0
        ssr = 0.0
        ssp = 0.0
        nin = 0
        for q in range(m):
            if not wi[q]:
                continue
            res = wr[q]
            j0 = wj0[q]
            j1 = wj1[q]
            j2 = wj2[q]
            h00 += j0 * j0
            h01 += j0 * j1
            h02 += j0 * j2
            h11 += j1 * j1
            h12 += j1 * j2
            h22 += j2 * j2
            g0 += j0 * res
            g1 += j1 * res
            g2 += j2 * res
            ssr += res * res
            ssp += j2 * j2
            nin += 1
        # closed-form solve of H d = -g (adjugate over determinant)
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        det = h00 * c00 + h01 * c01 + h02 * c02
        if not (math.isfinite(det) and abs(det) > 1e-14 * (h00 + h11) * h22):
            status = _SINGULAR
            break
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        d0 = -(c00 * g0 + c01 * g1 + c02 * g2) / det
        d1 = -(c01 * g0 + c11 * g1 + c12 * g2) / det
        d2 = -(c02 * g0 + c12 * g1 + c22 * g2) / det
        # no step beyond the correspondence gate: a direction the lines leave almost free (a
        # corridor) must not throw the pose out of reach of every correspondence
        sl = math.sqrt(d0 * d0 + d1 * d1)
        if sl > fp[_F_GATE]:
            f = fp[_F_GATE] / sl
            d0 *= f
            d1 *= f
            d2 *= f
        tx += d0
        ty += d1
        th += d2
        it += 1
        st = math.sqrt(d0 * d0 + d1 * d1)
        sr = abs(d2)
        # settled: the step is below the tolerances, or below tolerance_sigma standard deviations
        # of the estimate (d' H d / sigma^2); the first stage only has to come within ten times that
        settled = st < tol_t and sr < tol_r
        if not settled and nin > 3 and ssr > 0.0:
            q2 = (
                h00 * d0 * d0 + h11 * d1 * d1 + h22 * d2 * d2
                + 2.0 * (h01 * d0 * d1 + h02 * d0 * d2 + h12 * d1 * d2)
            )  # fmt: skip
            settled = q2 * (nin - 3) < (tol_s2 if robust else 100.0 * tol_s2) * ssr
        if settled:
            if robust:
                status = _OK
                break
            # second stage, from this close pose on: a threshold relative to the median residual
            # is safe only near the solution (from far off, the residuals of one well-seen wall
            # could shut out the walls that fix the other directions)
            robust = True
            frozen = False
            px1 = py1 = pt1 = px2 = py2 = pt2 = math.inf
            continue
        # a cycle between correspondence sets (back to the pose of two steps ago), or half the
        # iterations spent: keep the correspondences fixed and solve that problem to the end
        cycle = abs(tx - px2) < tol_t and abs(ty - py2) < tol_t and abs(th - pt2) < tol_r
        if cycle or it >= max_iter // 2:
            frozen = True
        px2 = px1
        py2 = py1
        pt2 = pt1
        px1 = tx
        py1 = ty
        pt1 = th
    for q in range(_O_WIDTH):
        out[q] = math.nan
    out[_O_POSE] = tx
    out[_O_POSE + 1] = ty
    out[_O_POSE + 2] = math.atan2(math.sin(th), math.cos(th))
    out[_O_NIN] = nin
    out[_O_NCUR] = ncur
    out[_O_ITER] = it
    out[_O_STEP] = st
    out[_O_STEP + 1] = sr
    out[_O_NCLOSE] = nclose
    if nin > 0 and status != _FEW_CORR:
        out[_O_RMS] = math.sqrt(ssr / nin)
    if status == _OK or status == _MAX_ITER:
        # covariance sigma^2 H^-1, sigma^2 the residual variance with n - 3 degrees of freedom
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        det = h00 * c00 + h01 * c01 + h02 * c02
        f = fp[_F_COV_SCALE] * ssr / max(nin - 3, 1) / det
        out[_O_COV + 0] = f * c00
        out[_O_COV + 1] = f * c01
        out[_O_COV + 2] = f * c02
        out[_O_COV + 3] = f * c01
        out[_O_COV + 4] = f * c11
        out[_O_COV + 5] = f * c12
        out[_O_COV + 6] = f * c02
        out[_O_COV + 7] = f * c12
        out[_O_COV + 8] = f * c22
        # the rotation in metres at the points' rms lever arm, so that the eigenvalues compare
        sl = 1.0 / math.sqrt(ssp / nin) if ssp > 0.0 else 1.0
        ratio = _sym3_eigen_ratio(h00, h01, h02 * sl, h11, h12 * sl, h22 * sl * sl)
        out[_O_RATIO] = ratio
        if ratio < fp[_F_MIN_RATIO]:
            # also the reason when the iteration wandered along the free direction without end
            status = _DEGENERATE
        elif status == _OK and nclose < fp[_F_MIN_INLIERS] * ncur:
            status = _FEW_INLIERS
    out[_O_STATUS] = status


def _coarse_peaks(rpts, rflags, cpts, cflags, pose0, fp, peaks):
    """Correlative grid search around ``pose0``: the best distinct poses into the rows of ``peaks``.

    The reference points are spread on a grid of ``coarse_step_m`` cells (a Gaussian of that
    width); every rotation step and translation step within the search window scores the sum of
    the grid cells the current points fall in. Returns the number of peaks found.
    """
    rx = rpts[_P_X]
    ry = rpts[_P_Y]
    rvalid = rflags[_B_VALID]
    cx = cpts[_P_X]
    cy = cpts[_P_Y]
    cvalid = cflags[_B_VALID]
    step = fp[_F_STEP_M]
    step_rad = fp[_F_STEP_RAD]
    n = rx.size
    pad = 3.0 * step
    xmin = ymin = math.inf
    xmax = ymax = -math.inf
    for i in range(n):
        if rvalid[i]:
            xmin = min(xmin, rx[i])
            xmax = max(xmax, rx[i])
            ymin = min(ymin, ry[i])
            ymax = max(ymax, ry[i])
    if not xmin <= xmax:
        return 0
    ox = xmin - pad
    oy = ymin - pad
    w = int((xmax - xmin + 2.0 * pad) / step) + 2
    h = int((ymax - ymin + 2.0 * pad) / step) + 2
    grid = np.zeros((w, h))
    rad = int(math.ceil(pad / step))
    inv2s2 = 0.5 / (step * step)
    for i in range(n):
        if not rvalid[i]:
            continue
        gi = int((rx[i] - ox) / step)
        gj = int((ry[i] - oy) / step)
        for a in range(max(gi - rad, 0), min(gi + rad + 1, w)):
            ddx = ox + (a + 0.5) * step - rx[i]
            for b in range(max(gj - rad, 0), min(gj + rad + 1, h)):
                ddy = oy + (b + 0.5) * step - ry[i]
                v = math.exp(-(ddx * ddx + ddy * ddy) * inv2s2)
                if v > grid[a, b]:
                    grid[a, b] = v
    nt = int(math.ceil(fp[_F_COARSE_M] / step))
    nr = int(math.ceil(fp[_F_COARSE_RAD] / step_rad))
    ntr = 2 * nt + 1
    nrot = 2 * nr + 1
    scores = np.zeros((nrot, ntr, ntr))
    ncp = cx.size
    bi = np.zeros(ncp, dtype=np.int64)
    bj = np.zeros(ncp, dtype=np.int64)
    for ir in range(nrot):
        th = pose0[2] + (ir - nr) * step_rad
        c = math.cos(th)
        s = math.sin(th)
        # the cell of each point at the first translation; the others are whole cells away
        for j in range(ncp):
            if cvalid[j]:
                px = c * cx[j] - s * cy[j] + pose0[0] - nt * step
                py = s * cx[j] + c * cy[j] + pose0[1] - nt * step
                bi[j] = int(math.floor((px - ox) / step))
                bj[j] = int(math.floor((py - oy) / step))
        for a in range(ntr):
            for b in range(ntr):
                tot = 0.0
                for j in range(ncp):
                    if cvalid[j]:
                        gi = bi[j] + a
                        gj = bj[j] + b
                        if gi >= 0 and gi < w and gj >= 0 and gj < h:
                            tot += grid[gi, gj]
                scores[ir, a, b] = tot
    found = 0
    for _ in range(peaks.shape[0]):
        best = 0.0
        br = -1
        ba = 0
        bb = 0
        for ir in range(nrot):
            for a in range(ntr):
                for b in range(ntr):
                    if scores[ir, a, b] > best:
                        best = scores[ir, a, b]
                        br = ir
                        ba = a
                        bb = b
        if br < 0:
            break
        peaks[found, 0] = pose0[0] + (ba - nt) * step
        peaks[found, 1] = pose0[1] + (bb - nt) * step
        peaks[found, 2] = pose0[2] + (br - nr) * step_rad
        found += 1
        # the next peak is at least 4 steps away in one of the directions
        for ir in range(max(br - 3, 0), min(br + 4, nrot)):
            for a in range(max(ba - 3, 0), min(ba + 4, ntr)):
                for b in range(max(bb - 3, 0), min(bb + 4, ntr)):
                    scores[ir, a, b] = -1.0
    return found


def _prepare_kernel(scans, cosa, sina, wrap, ip, fp, pts, flags, nvalid, nline, work, order, iwork, fits):
    """Every scan's points and lines, once (:func:`_prepare_scan`; the kernel allocates
    nothing: less to compile)."""
    for i in range(scans.shape[0]):
        nvalid[i], nline[i] = _prepare_scan(
            scans[i], cosa, sina, wrap, ip, fp, pts[i], flags[i], work, order, iwork, fits
        )  # fmt: skip


def _pairs_kernel(ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, sin2, wf, wn, wi):
    """Match the prepared scan ``cur_idx[k]`` against ``ref_idx[k]`` from ``init[k]`` for every
    k: row k of ``out``, in the work space :func:`_match_batch` makes."""
    for k in range(ref_idx.size):
        ri = ref_idx[k]
        ci = cur_idx[k]
        o = out[k]
        if _pair_start(ip, o, nvalid[ci], nline[ri]):
            _icp(pts[ri], flags[ri], pts[ci], flags[ci], nvalid[ci], beams, sin2, init[k], ip, fp, wf, wn, wi, o)
            o[_O_NREF] = nline[ri]


def _coarse_pairs_kernel(
    ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, sin2, wf, wn, wi, peaks, row
):
    """:func:`_pairs_kernel` after a wide search (:func:`_coarse_peaks`): from each of its
    starts, the result that puts most points on their lines (compiled only when asked for)."""
    for k in range(ref_idx.size):
        ri = ref_idx[k]
        ci = cur_idx[k]
        o = out[k]
        if not _pair_start(ip, o, nvalid[ci], nline[ri]):
            continue
        npk = _coarse_peaks(pts[ri], flags[ri], pts[ci], flags[ci], init[k], fp, peaks)
        best = -1.0
        for p in range(npk):
            _icp(pts[ri], flags[ri], pts[ci], flags[ci], nvalid[ci], beams, sin2, peaks[p], ip, fp, wf, wn, wi, row)
            # the start whose result puts most points on their lines wins (a converged one a tie)
            score = row[_O_NCLOSE] + (0.5 if row[_O_STATUS] == _OK else 0.0)
            if score > best:
                best = score
                for q in range(o.size):
                    o[q] = row[q]
        if npk == 0:
            o[_O_STATUS] = _FEW_REF
        o[_O_NREF] = nline[ri]


def _pair_start(ip, o, ncur, nref):
    """Row ``o`` of a pair cleared; False (and its status set) when a scan has too few points."""
    for q in range(o.size):
        o[q] = math.nan
    o[_O_NREF] = nref
    o[_O_NCUR] = ncur
    o[_O_NCLOSE] = 0.0
    o[_O_ITER] = 0.0
    if nref < ip[_I_MIN_POINTS]:
        o[_O_STATUS] = _FEW_REF
        return False
    if ncur < ip[_I_MIN_POINTS]:
        o[_O_STATUS] = _FEW_CUR
        return False
    return True


def _match_batch(scans, ref_idx, cur_idx, init, cosa, sina, beams, ip, fp, out):
    """Match ``scans[cur_idx[k]]`` against ``scans[ref_idx[k]]`` for every k: row k of ``out``
    (the scans prepared by :func:`_prepare_kernel`, matched by :func:`_pairs_kernel`: two
    kernels, compiled at the same time by two processes, see :func:`start_compiling`)."""
    ns, n = scans.shape
    pts = np.zeros((ns, _P_WIDTH, n))  # every scan's points and lines
    flags = np.zeros((ns, _B_WIDTH, n), dtype=np.bool_)
    nvalid = np.zeros(ns, dtype=np.int64)  # its valid points
    nline = np.zeros(ns, dtype=np.int64)  # its points with a line
    _prepare_kernel(
        scans, cosa, sina, bool(beams[2] > 0.0), ip, fp, pts, flags, nvalid, nline,
        np.zeros((5, n)), np.zeros(n, dtype=np.int64), np.zeros((6, n + 1), dtype=np.int64), np.zeros((7, 2 * n + 2)),
    )  # fmt: skip
    # the squared sine of the smallest angle between a direction and a beam d steps from its nearest
    ang = (np.arange(n + 1) - 0.5) * beams[1]
    sin2 = np.where(ang <= 0.0, 0.0, np.where(ang < 0.5 * math.pi, np.sin(np.clip(ang, 0.0, None)) ** 2, 1.0))
    args = (ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, np.ascontiguousarray(sin2))
    work = (np.zeros((5, n)), np.zeros((2, n), dtype=np.int64), np.zeros(n, dtype=np.bool_))
    if ip[_I_COARSE] == 0:
        _pairs_kernel(*args, *work)
    else:
        _coarse_pairs_kernel(*args, *work, np.zeros((ip[_I_CANDIDATES], 3)), np.zeros(out.shape[1]))


_KERNELS = (
    "_split_pieces",
    "_tls",
    "_fit_pieces",
    "_kth_smallest",
    "_scan_noise",
    "_fit_lines",
    "_prepare_scan",
    "_sym3_eigen_ratio",
    "_icp",
    "_prepare_kernel",
    "_pair_start",
    "_pairs_kernel",
    "_coarse_peaks",
    "_coarse_pairs_kernel",
)
_PY_KERNELS = {name: globals()[name] for name in _KERNELS}  # the Python functions, for numba
# the kernels' argument types (numba's notation): one compiled version each, in the order above
# (a callee before its callers)
_F1, _F2 = "float64[::1]", "float64[:, ::1]"
_I1, _I2 = "int64[::1]", "int64[:, ::1]"
_B1, _B2 = "boolean[::1]", "boolean[:, ::1]"
# the pairs kernels' arguments: the pairs, the settings, the prepared scans, the work space
_PAIRS = (_I1, _I1, _F2, _F1, _I1, _F1, _F2, "float64[:, :, ::1]", "boolean[:, :, ::1]", _I1, _I1, _F1, _F2, _I2, _B1)
_SIGNATURES = {
    "_split_pieces": (_F1, _F1, _I1, "int64", "float64", "float64", "float64", _I2),
    "_tls": (_F1, _F1, _I1, "int64", "int64"),
    "_fit_pieces": (_F1, _F1, _I1, "int64", _I2, _F2, "int64", "float64", "float64"),
    "_scan_noise": (_I2, _F2, "int64", _F1),
    "_fit_lines": (_F2, _B2, "boolean", _I1, _F1, _F2, _I1, _I2, _F2),
    "_prepare_scan": (_F1, _F1, _F1, "boolean", _I1, _F1, _F2, _B2, _F2, _I1, _I2, _F2),
    "_kth_smallest": (_F1, "int64", "int64"),
    "_sym3_eigen_ratio": ("float64",) * 6,
    "_icp": (_F2, _B2, _F2, _B2, "int64", _F1, _F1, _F1, _I1, _F1, _F2, _I2, _B1, _F1),
    "_coarse_peaks": (_F2, _B2, _F2, _B2, _F1, _F1, _F2),
    "_prepare_kernel": (_F2, _F1, _F1, "boolean", _I1, _F1, "float64[:, :, ::1]", "boolean[:, :, ::1]", _I1, _I1)
    + (_F2, _I1, _I2, _F2),
    "_pair_start": (_I1, _F1, "int64", "int64"),
    "_pairs_kernel": _PAIRS,
    "_coarse_pairs_kernel": _PAIRS + (_F2, _F1),  # and the wide search's starts, one start's result
}
# the two halves of the work: the scans' lines (compiled by the first match) and the matching
# (compiled by a second process at the same time, see start_compiling)
_FOREGROUND = (
    "_split_pieces",
    "_tls",
    "_fit_pieces",
    "_kth_smallest",
    "_scan_noise",
    "_fit_lines",
    "_prepare_scan",
    "_prepare_kernel",
)
_BACKGROUND = ("_kth_smallest", "_sym3_eigen_ratio", "_icp", "_pair_start", "_pairs_kernel")
_COARSE = ("_coarse_peaks", "_coarse_pairs_kernel")  # compiled when a wide search is first asked for
_done: set[str] = set()  # the kernels compiled (or loaded) in this process
_dispatchers: dict[str, Any] = {}
_compiled = False
_lock = threading.Lock()
_helper: list[Any] = []  # the process compiling _BACKGROUND, while it runs
_HELPER_TIMEOUT_S = 120.0  # the longest wait for it (its compile takes seconds)


def have_numba() -> bool:
    """Whether numba is installed (the kernels are compiled; else they run interpreted).

    Returns
    -------
    bool
    """
    return numba_module() is not None


def _jit() -> bool:
    """numba is installed and compiles (``NUMBA_DISABLE_JIT`` unset)."""
    numba: Any = numba_module()
    return numba is not None and not numba.config.DISABLE_JIT


def _dispatcher(name: str) -> Any:
    """numba's dispatcher of kernel ``name`` (created on first use; nothing compiled yet)."""
    if name not in _dispatchers:
        numba: Any = numba_module()
        _dispatchers[name] = numba.njit(cache=True, nogil=True)(_PY_KERNELS[name])
    return _dispatchers[name]


def _signature(name: str) -> tuple[Any, ...]:
    """The argument types of kernel ``name``, as numba's types."""
    from numba.core import sigutils

    return tuple(sigutils.normalize_signature("(" + ", ".join(_SIGNATURES[name]) + ",)")[0])


def _cached(name: str) -> bool:
    """Whether numba's cache holds kernel ``name`` for this source and machine (its index is
    read; the machine code is not loaded)."""
    d = _dispatcher(name)
    try:
        key = d._cache._index_key(_signature(name), d.targetctx.codegen())
        return key in d._cache._cache_file._load_index()  # numba's own check (source stamp, CPU)
    except Exception:  # another numba's layout: nothing known
        return True


def kernel_state() -> str:
    """Whether the scan matcher's kernels are ready to run fast.

    Returns
    -------
    str
        ``"interpreted"`` without numba, or with ``NUMBA_DISABLE_JIT`` (the same results, about a
        hundred times slower);
        ``"compile"`` when the next match compiles them (once per machine: numba caches the
        machine code beside the module, or in ``NUMBA_CACHE_DIR``); ``"ready"`` when they are
        compiled in this process or in numba's cache.
    """
    if not _jit():
        return "interpreted"
    if _compiled or (_cached("_prepare_kernel") and _cached("_pairs_kernel")):
        return "ready"
    return "compile"


def start_compiling() -> None:
    """Start compiling the kernels in the background when the next match would compile them.

    A second process compiles the matching kernels into numba's cache while this one goes on
    (reading a bag, say); the first match compiles the scans' kernels and takes the matching
    ones from the cache: about half the wait on a machine with two cores. The first match
    starts it too when it has not been started. Does nothing without numba, when the kernels
    are ready, or when a compile is already under way.
    """
    with _lock:
        _start_helper()


def _start_helper() -> None:
    if _helper or _compiled or getattr(sys, "frozen", False) or kernel_state() != "compile":
        return  # (a frozen program's executable is not a Python to run code with)
    code = "from umbmark.realrobot import scanmatch; scanmatch._compile(scanmatch._BACKGROUND)"
    try:
        _helper.append(
            subprocess.Popen(
                [sys.executable, "-c", code],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
    except OSError:  # no second process: the first match compiles everything
        pass


def _compile(names: tuple[str, ...]) -> None:
    """Compile (or load from numba's cache) the kernels ``names``, callees first."""
    for name in _KERNELS:
        if name in names and name not in _done:
            d = _dispatcher(name)
            d.compile(_signature(name))
            d.disable_compile()  # one version: a call of other types is an error, not a second compile
            globals()[name] = d
            _done.add(name)


def _kernel(coarse: bool = False) -> Any:
    """The batch kernel, compiled on first use when numba is installed (the wide search's
    kernels on the first use of it)."""
    global _compiled
    with _lock:
        if not _compiled:
            if _jit():
                _start_helper()
                _compile(_FOREGROUND)
                if _helper:
                    try:
                        _helper[0].wait(timeout=_HELPER_TIMEOUT_S)
                    except subprocess.TimeoutExpired:  # a helper that hangs: compile here
                        _helper[0].kill()
                    _helper.clear()
                _compile(tuple(name for name in _KERNELS if name not in _COARSE))
            _compiled = True
        if coarse and _jit():
            _compile(_COARSE)
    return _match_batch


# ---------------------------------------------------------------- public functions


def _beams(angles_rad: ArrayLike, n: int) -> tuple[NDArray[np.float64], float, float, bool, bool]:
    """Validated beam angles: (angles in increasing order, first, increment, full circle, reversed)."""
    a = np.asarray(angles_rad, dtype=float)
    if a.ndim != 1 or a.size != n:
        raise InputError(f"`angles_rad` must have one angle per beam ({n}), got shape {a.shape}")
    if a.size < 3:
        raise InputError(f"a scan needs at least 3 beams, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise InputError("`angles_rad` must be finite")
    rev = bool(a[1] < a[0])
    if rev:
        a = a[::-1]
    inc = (a[-1] - a[0]) / (a.size - 1)
    if not inc > 0 or np.max(np.abs(np.diff(a) - inc)) > 1e-3 * inc:
        raise InputError("`angles_rad` must be uniformly spaced and monotonic (the beams of one scan)")
    if a.size * inc > 2.0 * np.pi + 0.5 * inc:
        raise InputError(f"`angles_rad` spans more than a full turn ({a.size} beams of {inc:.4g} rad)")
    wrap = bool(a.size * inc >= 2.0 * np.pi - 0.5 * inc)
    return a, float(a[0]), float(inc), wrap, rev


def _ranges(r: ArrayLike, name: str) -> NDArray[np.float64]:
    a = np.array(r, dtype=float)
    if a.ndim != 2:
        raise InputError(f"`{name}` must be a (pairs, beams) array, got shape {a.shape}")
    return a


def _run(
    scans: NDArray[np.float64],
    ref_idx: NDArray[np.int64],
    cur_idx: NDArray[np.int64],
    angles_rad: ArrayLike,
    initial: ArrayLike | None,
    config: ICPConfig | None,
) -> ScanMatches:
    cfg = config if config is not None else ICPConfig()
    if not isinstance(cfg, ICPConfig):
        raise InputError(f"`config` must be an ICPConfig, got {type(cfg).__name__}")
    k = ref_idx.size
    a, a0, inc, wrap, rev = _beams(angles_rad, scans.shape[1])
    if rev:
        scans = scans[:, ::-1]
    scans = np.ascontiguousarray(scans, dtype=float)
    ref_idx = np.ascontiguousarray(ref_idx, dtype=np.int64)
    cur_idx = np.ascontiguousarray(cur_idx, dtype=np.int64)
    if initial is None:
        init = np.zeros((k, 3))
    else:
        try:
            init = np.array(np.broadcast_to(np.asarray(initial, dtype=float), (k, 3)))
        except ValueError:
            raise InputError(f"`initial` must be (3,) or ({k}, 3), got shape {np.shape(initial)}") from None
        if not np.all(np.isfinite(init)):
            raise InputError("`initial` must be finite")
    ip = np.zeros(_I_WIDTH, dtype=np.int64)
    ip[_I_MAX_ITER] = cfg.max_iterations
    ip[_I_LINE_POINTS] = cfg.line_points
    ip[_I_MIN_POINTS] = cfg.min_points
    ip[_I_COARSE] = int(cfg.coarse)
    ip[_I_CANDIDATES] = cfg.coarse_candidates
    fp = np.zeros(_F_WIDTH)
    fp[_F_GATE] = cfg.max_correspondence_m
    fp[_F_TRIM] = cfg.trim_fraction
    fp[_F_OUT_SIGMAS] = cfg.outlier_sigmas
    fp[_F_LINE_RMS] = cfg.line_max_rms_m
    fp[_F_LINE_GAP] = cfg.line_max_gap_m
    fp[_F_TOL_M] = cfg.tolerance_m
    fp[_F_TOL_RAD] = cfg.tolerance_rad
    fp[_F_TOL_SIGMA] = cfg.tolerance_sigma
    fp[_F_INLIER_M] = cfg.inlier_threshold_m
    fp[_F_MIN_INLIERS] = cfg.min_inlier_fraction
    fp[_F_MIN_RATIO] = cfg.min_constraint_ratio
    fp[_F_COV_SCALE] = cfg.covariance_scale
    fp[_F_RANGE_MIN] = cfg.range_min_m
    fp[_F_RANGE_MAX] = cfg.range_max_m
    fp[_F_COARSE_M] = cfg.coarse_range_m
    fp[_F_COARSE_RAD] = cfg.coarse_range_rad
    fp[_F_STEP_M] = cfg.coarse_step_m
    fp[_F_STEP_RAD] = cfg.coarse_step_rad
    fp[_F_GAP_RATIO] = cfg.line_max_gap_ratio
    fp[_F_SPLIT_M] = cfg.line_split_m
    fp[_F_SPLIT_SIGMAS] = cfg.line_split_sigmas
    fp[_F_NORMAL_SD] = cfg.line_max_normal_sd_rad
    beams = np.array([a0, inc, 1.0 if wrap else 0.0])
    out = np.zeros((k, _O_WIDTH))
    if k:
        _kernel(bool(cfg.coarse))(scans, ref_idx, cur_idx, init, np.cos(a), np.sin(a), beams, ip, fp, out)
    status = out[:, _O_STATUS].astype(np.int64)
    return ScanMatches(
        poses=out[:, _O_POSE : _O_POSE + 3].copy(),
        covariances=out[:, _O_COV : _O_COV + 9].reshape(k, 3, 3).copy(),
        rms_m=out[:, _O_RMS].copy(),
        inlier_fraction=out[:, _O_NCLOSE] / np.maximum(out[:, _O_NCUR], 1.0),
        iterations=out[:, _O_ITER].astype(np.int64),
        converged=status == _OK,
        reasons=[_reason(row, cfg) for row in out],
        config=cfg,
    )


def match_scan_pairs(
    ref_ranges: ArrayLike,
    cur_ranges: ArrayLike,
    angles_rad: ArrayLike,
    initial: ArrayLike | None = None,
    config: ICPConfig | None = None,
) -> ScanMatches:
    """Match many pairs of scans (one compiled loop).

    Parameters
    ----------
    ref_ranges, cur_ranges : array_like
        ``(K, n_beams)`` ranges [m] of the reference and the current scans (inf or nan: no return).
    angles_rad : array_like
        ``(n_beams,)`` beam angles, uniformly spaced (increasing or decreasing), shared by all scans.
    initial : array_like, optional
        ``(K, 3)`` or ``(3,)``: first guesses of the poses (e.g. from odometry); default zeros.
    config : ICPConfig, optional
        Settings (default :class:`ICPConfig`).

    Returns
    -------
    ScanMatches
        One row per pair: the current scan's frame in the reference scan's frame.

    Raises
    ------
    InputError
        If shapes disagree, the angles are not uniformly spaced, ``initial`` is not finite or
        ``config`` is not an :class:`ICPConfig`.
    """
    ref = _ranges(ref_ranges, "ref_ranges")
    cur = _ranges(cur_ranges, "cur_ranges")
    if ref.shape != cur.shape:
        raise InputError(f"`ref_ranges` {ref.shape} and `cur_ranges` {cur.shape} must have the same shape")
    k = ref.shape[0]
    idx = np.arange(k, dtype=np.int64)
    return _run(np.concatenate([ref, cur]), idx, idx + k, angles_rad, initial, config)


def match_consecutive(
    ranges: ArrayLike,
    angles_rad: ArrayLike,
    initial: ArrayLike | None = None,
    config: ICPConfig | None = None,
) -> ScanMatches:
    """Match every scan of a sequence against the one before it.

    Parameters
    ----------
    ranges : array_like
        ``(M, n_beams)`` ranges [m] of consecutive scans (inf or nan: no return).
    angles_rad : array_like
        ``(n_beams,)`` beam angles, uniformly spaced.
    initial : array_like, optional
        ``(M - 1, 3)`` or ``(3,)``: first guesses of the displacements (e.g. from odometry).
    config : ICPConfig, optional
        Settings (default :class:`ICPConfig`).

    Returns
    -------
    ScanMatches
        ``M - 1`` rows: row ``k`` is scan ``k + 1``'s frame in scan ``k``'s frame (the sensor's
        displacement between them).

    Raises
    ------
    InputError
        As :func:`match_scan_pairs`.
    """
    r = _ranges(ranges, "ranges")
    k = max(r.shape[0] - 1, 0)
    idx = np.arange(k, dtype=np.int64)
    return _run(r, idx, idx + 1, angles_rad, initial, config)


def match_scans(
    ref_ranges: ArrayLike,
    cur_ranges: ArrayLike,
    angles_rad: ArrayLike,
    initial: ArrayLike = (0.0, 0.0, 0.0),
    config: ICPConfig | None = None,
) -> ScanMatch:
    """Register one scan against a reference scan.

    Parameters
    ----------
    ref_ranges, cur_ranges : array_like
        ``(n_beams,)`` ranges [m] (inf or nan: no return).
    angles_rad : array_like
        ``(n_beams,)`` beam angles, uniformly spaced (increasing or decreasing).
    initial : array_like
        ``(x_m, y_m, yaw_rad)``: first guess of the pose (e.g. the odometry's displacement in
        the sensor frame).
    config : ICPConfig, optional
        Settings (default :class:`ICPConfig`; ``ICPConfig(coarse=True)`` for large or unknown
        displacements).

    Returns
    -------
    ScanMatch
        The current scan's frame expressed in the reference scan's frame.

    Raises
    ------
    InputError
        If shapes disagree, the angles are not uniformly spaced or ``initial`` is not three
        finite numbers.
    """
    ref = np.asarray(ref_ranges, dtype=float)
    cur = np.asarray(cur_ranges, dtype=float)
    if ref.ndim != 1 or cur.shape != ref.shape:
        raise InputError(f"`ref_ranges` {ref.shape} and `cur_ranges` {cur.shape} must be equal 1-D arrays")
    init = np.asarray(initial, dtype=float)
    if init.shape != (3,):
        raise InputError(f"`initial` must be (x_m, y_m, yaw_rad), got shape {init.shape}")
    return match_scan_pairs(ref[None], cur[None], angles_rad, init[None], config)[0]
