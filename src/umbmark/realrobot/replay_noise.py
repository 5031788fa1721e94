"""The odometry's random error from a replay: each wheel's travel variance per metre from the
residuals of the calibrated odometry against a ground-truth trajectory (motion capture).

Each run is cut into consecutive intervals of a time stride; an interval's residual is the
ground truth's motion over it minus the calibrated odometry's (its samples' exact arcs composed),
in its start frame. Its covariance (:func:`umbmark.correct.noise.estimate_interval_noise`) is
``R + k_L A_i + k_R B_i + sigma_t^2 C_i + q H_i``: the wheels' (each sample's travel error
propagated to the interval's end), the ground truth's own noise (``R``, constant), its random time
error against the wheels at each end (``C_i``, from the twists at the ends: a motion capture's pose
at a point in time against ticks counted over a sample) and its heading's jitter while the robot
turns (``H_i``, variance proportional to the turn rate at each end: on OptiOdom's motion capture
it is what made the per-metre noise fall with the stride). Each run's constant time offset between its
ground truth and its wheels (runs synchronised one by one are off by different amounts) moves the
residuals by :func:`umbmark.correct.noise.timing_direction` times it: it is fitted with the noise
(profiled out), one offset per run; :func:`replay_noise` moves each run's wheels by its offset
first (:func:`align_offsets`: the linearisation holds for small offsets) and fits what is left.

* :func:`truth_intervals`: the residuals and their covariance shapes at one stride.
* :func:`fit_intervals`: the noise of such intervals; :func:`run_offsets`: each run's offset;
  :func:`shift_wheels`: the wheels moved in time by them; :func:`align_offsets`: both, repeated.
* :func:`heading_test`: whether the data show the ground truth's heading jitter (a likelihood
  ratio): on a straight drive its term has the shape of the wheels' heading noise and is left out.
* :func:`heldout_nees`: the normalised error of other runs' residuals under a fitted noise.
* :func:`replay_noise`: the fit at several strides, whether they agree, and the held-out NEES (fit
  on half the runs, checked on the other half at every stride).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.noise import (
    OdometryNoise,
    estimate_interval_noise,
    gls_mean,
    heading_jitter_covariance,
    nees,
    residual_covariance,
    timing_covariance,
    timing_direction,
    travel_shapes,
)
from umbmark.errors import InputError
from umbmark.model import se2
from umbmark.model.dataset import Dataset, Run, WheelGeometry
from umbmark.model.drive import integrate_wheels
from umbmark.realrobot.results import ReplayReport

__all__ = [
    "TruthIntervals",
    "StrideFit",
    "ReplayNoise",
    "truth_intervals",
    "fit_intervals",
    "heading_test",
    "run_offsets",
    "shift_wheels",
    "align_offsets",
    "refine_geometry",
    "heldout_nees",
    "replay_noise",
    "report_noise",
    "DEFAULT_STRIDES_S",
]

DEFAULT_STRIDES_S = (0.1, 0.25, 0.5, 1.0)
HEADING_LR_95 = 3.841458820694124  # chi^2 of one degree of freedom at 95 %
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TruthIntervals:
    """The intervals of a data set's runs against their ground truth at one stride.

    Attributes
    ----------
    residual : numpy.ndarray
        ``(K, 3)`` the ground truth's motion minus the odometry's ``(dx_m, dy_m, dyaw_rad)``.
    motion : numpy.ndarray
        ``(K, 3)`` the odometry's motion.
    left_cov, right_cov : numpy.ndarray
        ``(K, 3, 3)`` the residual's covariance per unit of each wheel's variance per metre [m].
    timing_cov : numpy.ndarray
        ``(K, 3, 3)`` its covariance per second squared of the ground truth's time error at the ends.
    heading_cov : numpy.ndarray
        ``(K, 3, 3)`` its covariance per unit of the ground truth's heading jitter (variance per
        rad/s of turn rate) at the ends.
    offset_dir : numpy.ndarray
        ``(K, 3)`` its change per second of a constant time offset (the ground truth late).
    run : numpy.ndarray
        ``(K,)`` the index of each interval's run in the data set.
    travel_m : numpy.ndarray
        ``(K,)`` the distance the wheels rolled in each interval (mean of the two) [m].
    stride_s : float
        The intervals' length [s].
    """

    residual: FloatArray
    motion: FloatArray
    left_cov: FloatArray
    right_cov: FloatArray
    timing_cov: FloatArray
    heading_cov: FloatArray
    offset_dir: FloatArray
    run: NDArray[np.int64]
    travel_m: FloatArray
    stride_s: float

    def __len__(self) -> int:
        return len(self.residual)

    def subset(self, keep: NDArray[np.bool_]) -> TruthIntervals:
        """The intervals where ``keep`` is True."""
        arrays = {k: getattr(self, k)[keep] for k in self.__dataclass_fields__ if k != "stride_s"}
        return TruthIntervals(**arrays, stride_s=self.stride_s)

    def offset_design(self) -> FloatArray:
        """``(K, 3, G)`` the residuals' change per second of each run's time offset (one column per run
        present, in the order of ``numpy.unique(run)``)."""
        runs, col = np.unique(self.run, return_inverse=True)
        x = np.zeros((len(self), 3, len(runs)))
        x[np.arange(len(self)), :, col] = self.offset_dir
        return x


def _twists(sl: FloatArray, sr: FloatArray, t: FloatArray, wheelbase_m: float) -> FloatArray:
    """``(K, 3)`` the robot's twist ``(v, 0, omega)`` at each sample time from the wheel travel of the
    samples either side (``sl[k]``: the travel between ``t[k-1]`` and ``t[k]``; one side at the ends)."""
    k = len(t)
    i = np.arange(k)
    nxt, prv = np.minimum(i + 1, k - 1), np.maximum(i - 1, 0)
    dl = np.where(i == 0, 0.0, sl) + np.where(nxt > i, sl[nxt], 0.0)
    dr = np.where(i == 0, 0.0, sr) + np.where(nxt > i, sr[nxt], 0.0)
    dt = t[nxt] - t[prv]
    dt = np.where(dt > 0, dt, np.inf)
    return np.column_stack([0.5 * (dl + dr) / dt, np.zeros(k), (dr - dl) / (wheelbase_m * dt)])


def _run_intervals(run: Run, m: int, left_m: float, right_m: float, wheelbase_m: float) -> tuple | None:
    """One run's intervals of ``m`` samples: residual, motion, the two wheels', the timing's and the
    heading jitter's covariance shapes, the offset's direction and the travel (the intervals with a ground truth at
    both ends); None without a whole interval."""
    assert run.gt is not None
    nw = (len(run.t) - 1) // m
    if nw < 1:
        return None
    sl = np.asarray(run.d_left, dtype=float) * left_m
    sr = np.asarray(run.d_right, dtype=float) * right_m
    poses = integrate_wheels(sl[1:], sr[1:], wheelbase_m)  # at every sample
    idx = np.arange(nw)[:, None] * m + np.arange(m + 1)[None, :]  # (nw, m + 1) sample indices
    q = se2.between(poses[idx[:, :1]], poses[idx])  # the poses in each interval's start frame
    d = q[:, -1]
    ql, qr = travel_shapes(sl[1:], sr[1:], wheelbase_m)
    steps = idx[:, 1:] - 1  # each interval's steps (indices into sl[1:])
    c, s = np.cos(q[:, :-1, 2]), np.sin(q[:, :-1, 2])
    lx, ly = q[:, 1:, 1] - d[:, None, 1], d[:, None, 0] - q[:, 1:, 0]  # a step's turn moves the end by these
    # a change of a step's motion (in its own frame) as a change of the interval's motion
    move = np.zeros((*steps.shape, 3, 3))
    move[..., 0, 0], move[..., 0, 1], move[..., 0, 2] = c, -s, lx
    move[..., 1, 0], move[..., 1, 1], move[..., 1, 2] = s, c, ly
    move[..., 2, 2] = 1.0
    covs = [
        np.einsum("nj,njab,njbc,njdc->nad", np.abs(w), move, shape[steps], move)
        for shape, w in ((ql, sl[1:][steps]), (qr, sr[1:][steps]))
    ]
    xi = _twists(sl, sr, np.asarray(run.t, dtype=float), wheelbase_m)
    a, b = idx[:, 0], idx[:, -1]
    gt = np.asarray(run.gt, dtype=float)
    e = se2.between(gt[a], gt[b]) - d
    e[:, 2] = np.arctan2(np.sin(e[:, 2]), np.cos(e[:, 2]))
    ok = np.all(np.isfinite(e), axis=1)
    travel = 0.5 * np.sum(np.abs(sl[1:][steps]) + np.abs(sr[1:][steps]), axis=1)
    ends = (d, xi[a], xi[b])
    out = (e, d, *covs, timing_covariance(*ends), heading_jitter_covariance(*ends), timing_direction(*ends), travel)
    return tuple(v[ok] for v in out)


def truth_intervals(ds: Dataset, geometry: WheelGeometry, stride_s: float) -> TruthIntervals:
    """A data set's runs cut into consecutive intervals of ``stride_s`` against their ground truth.

    Parameters
    ----------
    ds : Dataset
        Runs with ground-truth trajectories at the wheels' samples (in each run's start frame, of
        the axle midpoint: :func:`umbmark.realrobot.replay.axle_truth` when a marker's offset was
        fitted); runs without one are skipped.
    geometry : WheelGeometry
        The calibrated geometry.
    stride_s : float
        The intervals' length [s] (rounded to a whole number of samples, at least one).

    Returns
    -------
    TruthIntervals

    Raises
    ------
    InputError
        A stride that is not a positive number, or no run with a ground truth long enough for
        one interval.
    """
    if isinstance(stride_s, bool) or not (isinstance(stride_s, (int, float)) and math.isfinite(stride_s)):
        raise InputError(f"the stride must be a positive number of seconds, got {stride_s!r}")
    if stride_s <= 0:
        raise InputError(f"the stride must be a positive number of seconds, got {stride_s!r}")
    p = geometry.params(ds.units_per_wheel_rev)
    parts, runs = [], []
    for i, run in enumerate(ds.runs):
        dt = np.diff(np.asarray(run.t, dtype=float))
        if not run.has_trajectory or not np.any(dt > 0):
            continue
        m = max(1, int(round(stride_s / float(np.median(dt[dt > 0])))))
        got = _run_intervals(run, m, p.left_m_per_pulse, p.right_m_per_pulse, p.wheelbase_m)
        if got is not None and len(got[0]):
            parts.append(got)
            runs.append(np.full(len(got[0]), i))
    if not parts:
        raise InputError(
            f"no run has a ground-truth trajectory longer than {stride_s:g} s: the odometry's noise from a replay "
            "needs one",
            source=ds.source,
        )
    e, d, left, right, tcov, hcov, tdir, travel = (np.concatenate(v) for v in zip(*parts))
    return TruthIntervals(e, d, left, right, tcov, hcov, tdir, np.concatenate(runs), travel, float(stride_s))


def fit_intervals(
    iv: TruthIntervals,
    timing: bool = True,
    offsets: bool = True,
    ci95: bool = True,
    heading: bool | None = None,
    design: FloatArray | None = None,
) -> OdometryNoise:
    """The noise of intervals (:func:`umbmark.correct.noise.estimate_interval_noise`).

    Parameters
    ----------
    iv : TruthIntervals
        The intervals.
    timing : bool
        Fit the ground truth's random time error at the interval ends (``timing_sd_s``).
    offsets : bool
        Fit each run's constant time offset with it (profiled out: :func:`run_offsets` gives them).
    ci95 : bool
        Compute the 95 % intervals (NaN when False).
    heading : bool, optional
        Fit the ground truth's heading jitter while turning (``heading_jitter_var_rad_s``); by
        default when the timing is fitted.
    design : numpy.ndarray, optional
        ``(K, 3, P)`` more of the residuals' mean to profile out, after the offsets' columns.

    Returns
    -------
    OdometryNoise

    Raises
    ------
    InputError
        Fewer than 20 intervals or less than a metre rolled.
    """
    parts = ([iv.offset_design()] if offsets else []) + ([design] if design is not None else [])
    return estimate_interval_noise(
        iv.residual,
        iv.left_cov,
        iv.right_cov,
        float(np.sum(iv.travel_m)),
        iv.timing_cov if timing else None,
        np.concatenate(parts, axis=2) if parts else None,
        ci95,
        heading_cov=iv.heading_cov if (timing if heading is None else heading) else None,
    )


def heading_test(iv: TruthIntervals, timing: bool = True, offsets: bool = True) -> float:
    """The likelihood-ratio statistic of the ground truth's heading jitter: twice the gain in
    log-likelihood when it is fitted with the rest (:func:`fit_intervals`). The term is told from
    the wheels' noise only where the turn rate varies apart from the travel: on a straight drive
    it takes a share of the wheels' heading noise and gains little (under 3.84, chi^2 of one degree
    of freedom at 95 %, says the data do not show it)."""
    with_it = fit_intervals(iv, timing, offsets, ci95=False, heading=True)
    without = fit_intervals(iv, timing, offsets, ci95=False, heading=False)
    assert with_it.neg_log_likelihood is not None and without.neg_log_likelihood is not None
    return max(0.0, 2.0 * (without.neg_log_likelihood - with_it.neg_log_likelihood))


def _covariance(iv: TruthIntervals, noise: OdometryNoise) -> FloatArray:
    return residual_covariance(noise, iv.left_cov, iv.right_cov, iv.timing_cov, iv.heading_cov)


def run_offsets(iv: TruthIntervals, noise: OdometryNoise) -> dict[int, float]:
    """Each run's constant time offset (the ground truth late) [s] under a fitted noise: the
    generalised least squares of its residuals along :func:`umbmark.correct.noise.timing_direction`.

    Returns
    -------
    dict
        Run index -> offset [s].
    """
    tau = gls_mean(iv.residual, _covariance(iv, noise), iv.offset_design())
    return {int(r): float(v) for r, v in zip(np.unique(iv.run), tau)}


def shift_wheels(ds: Dataset, offsets_s: dict[int, float]) -> Dataset:
    """The data set with each run's wheels moved in time by its offset (the ground truth late by
    ``offsets_s[run]``): the cumulative wheel travel interpolated linearly at ``t - offset`` (exact
    at constant speed within a sample), so the ground truth keeps its own samples and noise; the
    samples whose moved time leaves the run lose their ground truth.

    Parameters
    ----------
    ds : Dataset
        The runs.
    offsets_s : dict
        Run index -> offset [s] (runs not named are kept).

    Returns
    -------
    Dataset
    """
    runs = list(ds.runs)
    for i, tau in offsets_s.items():
        r = runs[i]
        t = np.asarray(r.t, dtype=float)
        tq = t - tau
        inside = (tq >= t[0]) & (tq <= t[-1])
        moved = [np.diff(np.interp(tq, t, np.cumsum(d)), prepend=0.0) for d in (r.d_left, r.d_right)]
        for m in moved:
            m[0] = 0.0
        gt = None if r.gt is None else np.where(inside[:, None], r.gt, np.nan)
        runs[i] = replace(r, d_left=moved[0], d_right=moved[1], gt=gt)
    return replace(ds, runs=tuple(runs))


def align_offsets(
    ds: Dataset, geometry: WheelGeometry, stride_s: float, timing: bool = True, rounds: int = 3
) -> dict[int, float]:
    """Each run's time offset, the wheels moved by it and it estimated again (the residuals are linear
    in the offset only for small ones): Gauss-Newton steps at one stride.

    Parameters
    ----------
    ds : Dataset
        The runs.
    geometry : WheelGeometry
        The calibrated geometry.
    stride_s : float
        The stride of the intervals the offsets are estimated on [s].
    timing : bool
        Fit the ground truth's timing and heading jitter with them.
    rounds : int
        Estimates (the first on the runs as they are).

    Returns
    -------
    dict
        Run index -> offset [s] (:func:`shift_wheels` moves the wheels by it).
    """
    moved: dict[int, float] = {}
    for _ in range(max(1, rounds)):
        iv = truth_intervals(shift_wheels(ds, moved), geometry, stride_s)
        step = run_offsets(iv, fit_intervals(iv, timing, True, ci95=False))
        moved = {r: moved.get(r, 0.0) + v for r, v in step.items()}
        if max(abs(v) for v in step.values()) < 1e-3:
            break
    return moved


def _scaled(geometry: WheelGeometry, f: ArrayLike) -> WheelGeometry:
    """The geometry with its left and right diameters and its wheelbase multiplied by ``f``."""
    a = np.asarray(f, dtype=float)
    return WheelGeometry(
        geometry.diameter_left_m * float(a[0]),
        geometry.diameter_right_m * float(a[1]),
        geometry.wheelbase_m * float(a[2]),
    )


def geometry_design(ds: Dataset, geometry: WheelGeometry, stride_s: float, base: TruthIntervals) -> FloatArray:
    """``(K, 3, 3)`` the residuals' change per relative change of the left and the right wheel's
    diameter and of the wheelbase (forward differences; ``base``: the intervals at ``geometry``)."""
    h = 1e-6
    cols = []
    for j in range(3):
        moved = truth_intervals(ds, _scaled(geometry, 1.0 + h * np.eye(3)[j]), stride_s).residual - base.residual
        moved[:, 2] = np.arctan2(np.sin(moved[:, 2]), np.cos(moved[:, 2]))
        cols.append(moved / h)
    return np.stack(cols, axis=2)


def refine_geometry(
    ds: Dataset, geometry: WheelGeometry, stride_s: float, timing: bool = True, offsets: bool = True, rounds: int = 4
) -> WheelGeometry:
    """The geometry that makes the intervals' residuals zero-mean, by generalised least squares under
    their fitted noise (each run's time offset fitted with it): Gauss-Newton steps at one stride.

    A calibration that minimises the errors of whole paths in their start frame (the ``lsq``
    fit's poses sampled along a run) shrinks the wheels and the wheelbase when the wheels' random
    error is large against the path's length: a random walk in heading makes the odometry's far
    poses scatter, and a shorter step scatters less. The intervals are independent given the
    noise, so their weighted fit is not biased that way, on drives that follow the noise model.
    It is not a calibration method of its own: where the residuals break the model (a motion
    capture whose noise grows with speed, errors that persist over seconds) its geometry
    generalises worse than the path fit's; :func:`replay_noise` keeps the given geometry by default.

    Parameters
    ----------
    ds : Dataset
        The runs (their wheels already moved by their offsets, :func:`shift_wheels`, for large ones).
    geometry : WheelGeometry
        The starting geometry.
    stride_s : float
        The intervals' length [s].
    timing, offsets : bool
        As :func:`fit_intervals`.
    rounds : int
        The most steps.

    Returns
    -------
    WheelGeometry
    """
    for _ in range(max(1, rounds)):
        iv = truth_intervals(ds, geometry, stride_s)
        x = geometry_design(ds, geometry, stride_s, iv)
        noise = fit_intervals(iv, timing, offsets, ci95=False, design=x)
        if offsets:
            x = np.concatenate([iv.offset_design(), x], axis=2)
        beta = gls_mean(iv.residual, _covariance(iv, noise), x)[-3:]
        geometry = _scaled(geometry, 1.0 - beta)  # the residuals' mean, x beta, removed
        if float(np.max(np.abs(beta))) < 1e-7:
            break
    return geometry


def heldout_nees(iv: TruthIntervals, noise: OdometryNoise, offsets: bool = True) -> float:
    """The NEES of intervals not fitted under a fitted noise (their covariance
    :func:`umbmark.correct.noise.residual_covariance`; each run's time offset, when fitted,
    estimated on these runs first, as it is their own): 1 when the noise is right."""
    cov = _covariance(iv, noise)
    e = iv.residual
    if offsets:
        e = e - iv.offset_design() @ gls_mean(e, cov, iv.offset_design())
    return nees(e, cov)


@dataclass(frozen=True)
class StrideFit:
    """The noise fitted at one stride.

    Attributes
    ----------
    stride_s : float
        The intervals' length [s].
    noise : OdometryNoise
        With the ground truth's timing and heading jitter (when asked) and each run's time offset
        fitted.
    plain : OdometryNoise
        Without the ground truth's timing and heading jitter (the runs' offsets as in ``noise``):
        its per-metre noise takes up their variance, which grows with speed and turn rate and not
        with the interval's length, so it falls with the stride.
    offsets_s : dict
        Run index -> its time offset [s] (empty when not fitted).
    heldout_nees : tuple of float or None
        At each stride of the report: the NEES of the other half's intervals under the noise
        fitted on one half of the runs at this stride, averaged over the two halves (None where a
        half is too short to fit).
    """

    stride_s: float
    noise: OdometryNoise
    plain: OdometryNoise
    offsets_s: dict[int, float]
    heldout_nees: tuple[float | None, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able (the noises as :meth:`OdometryNoise.to_dict`, offsets in ms by run)."""
        return {
            "stride_s": self.stride_s,
            "noise": self.noise.to_dict(),
            "plain": self.plain.to_dict(),
            "time_offsets_ms": {str(r): 1e3 * v for r, v in self.offsets_s.items()},
            "heldout_nees": list(self.heldout_nees),
        }


@dataclass(frozen=True)
class ReplayNoise:
    """The odometry's noise from a replay's ground truth at several strides.

    Attributes
    ----------
    fits : tuple of StrideFit
        One per stride, shortest first.
    consistent : bool
        Whether each wheel's 95 % intervals have a value in common at every stride: the per-metre
        model holds across time scales.
    halves : str
        How the runs were halved for the held-out NEES: ``"runs"`` (every other run) or
        ``"time"`` (each run cut at its middle sample, for a data set of one run).
    geometry : WheelGeometry or None
        The geometry fitted to the intervals (:func:`refine_geometry`) the noise is of, or None
        when the given one was kept.
    heading_lr : float or None
        :func:`heading_test` at the shortest stride (None without the timing): the ground truth's
        heading jitter is fitted at every stride when it is at least 3.84.
    """

    fits: tuple[StrideFit, ...]
    consistent: bool
    halves: str
    geometry: WheelGeometry | None = None
    heading_lr: float | None = None

    @property
    def strides_s(self) -> tuple[float, ...]:
        """The strides [s]."""
        return tuple(f.stride_s for f in self.fits)

    @property
    def noise(self) -> OdometryNoise:
        """The fit at the longest stride (where the wheels' share of the residual is largest)."""
        return self.fits[-1].noise

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: every stride's fit and the verdict (and the intervals' geometry)."""
        out: dict[str, Any] = {
            "strides_s": list(self.strides_s),
            "consistent": self.consistent,
            "halves": self.halves,
            "fits": [f.to_dict() for f in self.fits],
        }
        if self.heading_lr is not None:
            out["heading_jitter_lr"] = self.heading_lr
            out["heading_jitter_fitted"] = self.heading_lr >= HEADING_LR_95
        if self.geometry is not None:
            g = self.geometry
            out["geometry"] = {
                "diameter_left_mm": g.diameter_left_m * 1e3,
                "diameter_right_mm": g.diameter_right_m * 1e3,
                "wheelbase_mm": g.wheelbase_m * 1e3,
            }
        return out


def _overlap(cis: list[tuple[float, float]]) -> bool:
    return max(lo for lo, _ in cis) <= min(hi for _, hi in cis)


def _consistent(fits: list[StrideFit], timing: bool) -> bool:
    """Whether the 95 % intervals of each wheel's noise share a value over the strides (the ground
    truth's timing, a nuisance here, may differ: a reference whose jitter is not white in time)."""
    return _overlap([f.noise.k_left_ci95 for f in fits]) and _overlap([f.noise.k_right_ci95 for f in fits])


def _halved(ds: Dataset) -> tuple[Dataset, str]:
    """The data set as it is when two or more runs have a trajectory, else each run cut at its middle."""
    if sum(r.has_trajectory for r in ds.runs) >= 2:
        return ds, "runs"
    runs = []
    for r in ds.runs:
        mid = len(r.t) // 2
        if not r.has_trajectory or mid < 2:
            runs.append(r)
            continue
        runs += [
            r.slice(0, mid + 1, name=f"{r.name}[first half]"),
            r.slice(mid, len(r.t), name=f"{r.name}[second half]"),
        ]
    return replace(ds, runs=tuple(runs), directions=None), "time"


def _heldout(ivs: list[TruthIntervals], i: int, timing: bool, offsets: bool, heading: bool) -> tuple[float | None, ...]:
    """The held-out NEES of every stride's intervals under the noise fitted at stride ``i`` on the other
    half of the runs (every other run with a trajectory), averaged over the two halves."""
    present = np.unique(np.concatenate([iv.run for iv in ivs]))
    first = set(present[::2].tolist())
    out: list[list[float]] = [[] for _ in ivs]
    for fold in (True, False):
        train = ivs[i].subset(np.isin(ivs[i].run, list(first)) == fold)
        try:
            noise = fit_intervals(train, timing, offsets, ci95=False, heading=heading)
        except InputError:
            return tuple(None for _ in ivs)
        for j, iv in enumerate(ivs):
            test = iv.subset(np.isin(iv.run, list(first)) != fold)
            if len(test):
                out[j].append(heldout_nees(test, noise, offsets))
    return tuple(float(np.mean(v)) if len(v) == 2 else None for v in out)


def replay_noise(
    ds: Dataset,
    geometry: WheelGeometry,
    strides_s: tuple[float, ...] = DEFAULT_STRIDES_S,
    timing: bool = True,
    offsets: bool = True,
    refine: bool = False,
) -> ReplayNoise:
    """The odometry's noise from a data set's ground truth at several strides, their agreement and
    their held-out NEES.

    Parameters
    ----------
    ds : Dataset
        The replayed runs with ground-truth trajectories (the axle's: see
        :func:`umbmark.realrobot.replay.axle_truth`); a data set of one run is cut at its middle
        into two (for the held-out halves).
    geometry : WheelGeometry
        The calibrated geometry (e.g. :func:`umbmark.realrobot.replay.calibrate`'s).
    strides_s : tuple of float
        The intervals' lengths [s].
    timing : bool
        Fit the ground truth's random time error at the interval ends, and its heading jitter while
        turning where the data show it (:func:`heading_test` at the shortest stride).
    offsets : bool
        Fit each run's constant time offset between its ground truth and its wheels.
    refine : bool
        Fit the geometry to the intervals first (:func:`refine_geometry`) and give the noise about
        it, instead of about ``geometry`` (the noise of the calibration that is exported).

    Returns
    -------
    ReplayNoise

    Raises
    ------
    InputError
        No stride, a stride that is not a positive number, no ground truth, or too little of it
        (fewer than 20 intervals, less than a metre rolled) at a stride.
    """
    strides = tuple(strides_s) if isinstance(strides_s, (tuple, list)) else ()
    if not strides:
        raise InputError(f"the strides must be a non-empty list of seconds, got {strides_s!r}")
    work, halves = _halved(ds)
    moved = align_offsets(work, geometry, min(strides), timing) if offsets else {}
    if refine:
        geometry = refine_geometry(shift_wheels(work, moved), geometry, min(strides), timing, offsets)
        moved = align_offsets(work, geometry, min(strides), timing) if offsets else {}
    ivs = [truth_intervals(shift_wheels(work, moved), geometry, s) for s in sorted(strides)]
    lr = heading_test(ivs[0], timing, offsets) if timing else None
    heading = lr is not None and lr >= HEADING_LR_95
    fits = []
    for i, iv in enumerate(ivs):
        noise = fit_intervals(iv, timing, offsets, heading=heading)
        rest = run_offsets(iv, noise) if offsets else {}
        fits.append(
            StrideFit(
                iv.stride_s,
                noise,
                fit_intervals(iv, False, offsets),
                {r: moved.get(r, 0.0) + v for r, v in rest.items()},
                _heldout(ivs, i, timing, offsets, heading),
            )
        )
    return ReplayNoise(tuple(fits), _consistent(fits, timing), halves, geometry if refine else None, lr)


def report_noise(ds: Dataset, report: ReplayReport, strides_s: tuple[float, ...] = DEFAULT_STRIDES_S) -> ReplayNoise:
    """The odometry's noise of a replayed data set under the report's calibration.

    The runs are prepared as the replay prepared them, their ground truth carried to the axle
    when the calibration fitted where the tracked point sits (:func:`umbmark.realrobot.replay.axle_truth`).

    Parameters
    ----------
    ds : Dataset
        The data set as read (the one the report was made from).
    report : ReplayReport
        Its replay report (:func:`umbmark.realrobot.replay.replay_report`).
    strides_s : tuple of float
        The intervals' lengths [s].

    Returns
    -------
    ReplayNoise

    Raises
    ------
    InputError
        As :func:`replay_noise` (runs without a ground-truth trajectory among them).
    """
    from umbmark.realrobot.replay import axle_truth, prepare

    work = prepare(ds)[0]
    cal = report.calibration
    if cal.lsq is not None and cal.lsq.marker_offset_m is not None:
        work = axle_truth(work, cal.lsq.marker_offset_m)
    return replay_noise(work, cal.geometry, strides_s)
