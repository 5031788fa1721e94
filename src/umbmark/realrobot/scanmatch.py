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

The kernels (:mod:`umbmark.realrobot.scanmatch_kernel`) are compiled with numba when it is
installed (once per machine: numba's cache), one version each (their argument types are fixed),
in two halves at once: a second Python process compiles the matching kernels into the cache
while the first match compiles the scans' kernels (:func:`start_compiling` starts it earlier,
e.g. before a bag is read); the wide search's kernels (``ICPConfig.coarse``) on its first use.
Without numba the same code runs interpreted (the same results, about a hundred times slower).
Imports numpy, :mod:`umbmark.errors` and the kernels' module; numba lazily, on the first match.

The pose convention: the result is the current scan's frame expressed in the reference scan's
frame, ``p_ref = R(yaw) p_cur + (x, y)``; for consecutive scans of a moving sensor it is the
sensor's displacement ``between(pose_ref, pose_cur)`` (:func:`umbmark.model.se2.between`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.realrobot import scanmatch_kernel as K
from umbmark.realrobot.scanmatch_kernel import have_numba, kernel_state, start_compiling

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


STATUS_REASONS: dict[int, str] = {
    K._OK: "",
    K._FEW_REF: "too few valid points in the reference scan",
    K._FEW_CUR: "too few valid points in the current scan",
    K._FEW_CORR: "too few correspondences",
    K._DEGENERATE: "degenerate scene: a direction is unconstrained",
    K._MAX_ITER: "no convergence within `max_iterations`",
    K._FEW_INLIERS: "too few of the current scan's points matched",
    K._SINGULAR: "degenerate scene: singular normal equations",
}
"""The reason of each kernel status (the empty string for a converged match)."""


def _reason(row: NDArray[np.float64], cfg: ICPConfig) -> str:
    status = int(row[K._O_STATUS])
    base = STATUS_REASONS[status]
    if status == K._FEW_REF:
        return f"{base} ({int(row[K._O_NREF])} with a line, `min_points` {cfg.min_points})"
    if status == K._FEW_CUR:
        return f"{base} ({int(row[K._O_NCUR])}, `min_points` {cfg.min_points})"
    if status == K._FEW_CORR:
        return f"{base} ({int(row[K._O_NIN])}, `min_points` {cfg.min_points})"
    if status == K._DEGENERATE:
        return f"{base} (constraint ratio {row[K._O_RATIO]:.2g} < `min_constraint_ratio` {cfg.min_constraint_ratio:g})"
    if status == K._MAX_ITER:
        return f"{base} ({cfg.max_iterations}; last step {row[K._O_STEP]:.2g} m, {row[K._O_STEP + 1]:.2g} rad)"
    if status == K._FEW_INLIERS:
        frac = row[K._O_NCLOSE] / max(row[K._O_NCUR], 1.0)
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
    ip = np.zeros(K._I_WIDTH, dtype=np.int64)
    ip[K._I_MAX_ITER] = cfg.max_iterations
    ip[K._I_LINE_POINTS] = cfg.line_points
    ip[K._I_MIN_POINTS] = cfg.min_points
    ip[K._I_COARSE] = int(cfg.coarse)
    ip[K._I_CANDIDATES] = cfg.coarse_candidates
    fp = np.zeros(K._F_WIDTH)
    fp[K._F_GATE] = cfg.max_correspondence_m
    fp[K._F_TRIM] = cfg.trim_fraction
    fp[K._F_OUT_SIGMAS] = cfg.outlier_sigmas
    fp[K._F_LINE_RMS] = cfg.line_max_rms_m
    fp[K._F_LINE_GAP] = cfg.line_max_gap_m
    fp[K._F_TOL_M] = cfg.tolerance_m
    fp[K._F_TOL_RAD] = cfg.tolerance_rad
    fp[K._F_TOL_SIGMA] = cfg.tolerance_sigma
    fp[K._F_INLIER_M] = cfg.inlier_threshold_m
    fp[K._F_MIN_INLIERS] = cfg.min_inlier_fraction
    fp[K._F_MIN_RATIO] = cfg.min_constraint_ratio
    fp[K._F_COV_SCALE] = cfg.covariance_scale
    fp[K._F_RANGE_MIN] = cfg.range_min_m
    fp[K._F_RANGE_MAX] = cfg.range_max_m
    fp[K._F_COARSE_M] = cfg.coarse_range_m
    fp[K._F_COARSE_RAD] = cfg.coarse_range_rad
    fp[K._F_STEP_M] = cfg.coarse_step_m
    fp[K._F_STEP_RAD] = cfg.coarse_step_rad
    fp[K._F_GAP_RATIO] = cfg.line_max_gap_ratio
    fp[K._F_SPLIT_M] = cfg.line_split_m
    fp[K._F_SPLIT_SIGMAS] = cfg.line_split_sigmas
    fp[K._F_NORMAL_SD] = cfg.line_max_normal_sd_rad
    beams = np.array([a0, inc, 1.0 if wrap else 0.0])
    out = np.zeros((k, K._O_WIDTH))
    if k:
        K._kernel(bool(cfg.coarse))(scans, ref_idx, cur_idx, init, np.cos(a), np.sin(a), beams, ip, fp, out)
    status = out[:, K._O_STATUS].astype(np.int64)
    return ScanMatches(
        poses=out[:, K._O_POSE : K._O_POSE + 3].copy(),
        covariances=out[:, K._O_COV : K._O_COV + 9].reshape(k, 3, 3).copy(),
        rms_m=out[:, K._O_RMS].copy(),
        inlier_fraction=out[:, K._O_NCLOSE] / np.maximum(out[:, K._O_NCUR], 1.0),
        iterations=out[:, K._O_ITER].astype(np.int64),
        converged=status == K._OK,
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
