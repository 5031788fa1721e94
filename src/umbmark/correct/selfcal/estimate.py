"""The self-calibration itself: closed-form start, maximum-likelihood fit, outliers, uncertainty.

:func:`selfcal` runs the steps in order:

1. Start: the paper's closed form (:mod:`umbmark.correct.selfcal.closed_form`), or the
   sensor pose fitted with the nominal odometry, whichever leaves the smaller residuals (per
   component, robustly); with outlier rejection it is refined first with a robust (Cauchy)
   loss, so that failed scan matches do not pull it.
2. Maximum likelihood: non-linear least squares (``scipy.optimize.least_squares``) of all six
   parameters on the whitened residuals ``s_k - l^-1 (+) arc_k (+) l``. Without given
   covariances the noise of each component (dx, dy, dyaw) is estimated from the residuals
   and the fit repeated until it settles (iteratively reweighted).
3. Outliers: an interval whose whitened residual is beyond the ``1 - outlier_tail`` quantile
   of chi-square with 3 degrees of freedom is set aside (a failed scan match); the noise
   scale is robust (median absolute deviation) in the first round, the inliers' root mean
   square after it. 2 and 3 repeat until the set is stable.
   Set-aside intervals are judged again every round (a good one can come back).
4. Mirror: ``(r_L, r_R, b, l_x, l_y, l_yaw)`` and ``(-r_L, -r_R, -b, -l_x, -l_y, l_yaw + pi)``
   predict the same displacements; the one with positive radii (and wheelbase) is kept.
5. Uncertainty: the covariance is the inverse of the Fisher information at the solution
   (Gauss-Newton), the 95 % intervals use Student's t on the residual degrees of freedom.
6. Identifiability and plausibility (:mod:`umbmark.correct.selfcal.identify`): warnings for
   what the driving leaves undetermined and for implausible values; an error when the
   information is singular.

Imports numpy, scipy (when it runs), :mod:`umbmark.model` and this package.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal import identify
from umbmark.correct.selfcal.closed_form import ClosedFormFailed, closed_form, closed_form_fixed_scale
from umbmark.correct.selfcal.model import fisher_information, jacobian, residuals, whiten, whitener
from umbmark.correct.selfcal.result import SelfcalResult
from umbmark.errors import InputError
from umbmark.model.geometry import wrap_angle
from umbmark.model.intervals import Intervals

__all__ = ["selfcal", "mirror"]

FloatArray = NDArray[np.float64]

# noise standard deviations are never taken below this (m, m, rad): noise-free data stay finite
_SD_FLOOR = 1e-10
_MAD = 1.482602218505602  # standard deviation / median absolute deviation of a Gaussian


def mirror(p: ArrayLike) -> FloatArray:
    """The mirror solution: radii and wheelbase negated, the sensor turned by pi about the robot.

    Parameters
    ----------
    p : array_like
        Six parameters ``(r_L, r_R, b, l_x, l_y, l_yaw)``.

    Returns
    -------
    numpy.ndarray
        ``(-r_L, -r_R, -b, -l_x, -l_y, l_yaw + pi)`` (yaw wrapped), which predicts exactly
        the same sensor displacements.
    """
    q = np.asarray(p, dtype=float)
    return np.array([-q[0], -q[1], -q[2], -q[3], -q[4], float(wrap_angle(q[5] + math.pi))])


def _physical(p: FloatArray) -> FloatArray:
    """Of ``p`` and its mirror, the one with more of (r_L, r_R, b) positive (ties: b > 0)."""
    m = mirror(p)
    score = lambda q: (int(q[0] > 0) + int(q[1] > 0) + int(q[2] > 0), q[2] > 0)  # noqa: E731
    out = m if score(m) > score(p) else p.copy()
    out[5] = float(wrap_angle(out[5]))
    return out


def _robust_sd(r: FloatArray) -> FloatArray:
    med = np.median(r, axis=0)
    return np.maximum(_MAD * np.median(np.abs(r - med), axis=0), _SD_FLOOR)


class _Problem:
    """The intervals in use and their whitening (given covariances, or standard deviations)."""

    def __init__(self, iv: Intervals, given_w: FloatArray | None):
        self.fl = np.asarray(iv.left_rad, float)
        self.fr = np.asarray(iv.right_rad, float)
        self.s = np.asarray(iv.sensor, float)
        self.given_w = given_w

    def res(self, p: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        return residuals(p, self.fl[idx], self.fr[idx], self.s[idx])

    def weighted(self, r: FloatArray, idx: NDArray[np.intp], sd: FloatArray | None) -> FloatArray:
        if self.given_w is not None:
            return whiten(self.given_w[idx], r)
        assert sd is not None
        return r / sd if r.ndim == 2 else r / sd[None, :, None]

    def fit(self, p0: FloatArray, idx: NDArray[np.intp], sd: FloatArray | None, loss: str = "linear") -> FloatArray:
        from scipy.optimize import least_squares

        fl, fr, s = self.fl[idx], self.fr[idx], self.s[idx]
        fun: Callable[[FloatArray], FloatArray] = lambda p: self.weighted(residuals(p, fl, fr, s), idx, sd).ravel()  # noqa: E731
        jac: Callable[[FloatArray], FloatArray] = lambda p: -self.weighted(jacobian(p, fl, fr), idx, sd).reshape(-1, 6)  # noqa: E731
        method = "lm" if loss == "linear" else "trf"
        sol = least_squares(
            fun, p0, jac=jac, method=method, loss=loss, x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=500
        )
        return np.asarray(sol.x, dtype=float)

    def information(self, p: FloatArray, idx: NDArray[np.intp], sd: FloatArray) -> FloatArray:
        if self.given_w is None:
            return fisher_information(p, self.fl[idx], self.fr[idx], sd)
        jw = whiten(self.given_w[idx], jacobian(p, self.fl[idx], self.fr[idx])).reshape(-1, 6)
        return np.asarray(jw.T @ jw, dtype=float)


def _ml_fit(prob: _Problem, p0: FloatArray, idx: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
    """Maximum-likelihood fit on the intervals ``idx``: the parameters and the noise sd."""
    if prob.given_w is not None:
        return prob.fit(p0, idx, None), np.full(3, math.nan)
    n = len(idx)
    sd = _robust_sd(prob.res(p0, idx))
    p = p0
    for _ in range(10):
        p = prob.fit(p, idx, sd)
        r = prob.res(p, idx)
        new = np.maximum(np.sqrt((r * r).sum(axis=0) / max(n - 2, 1)), _SD_FLOOR)
        done = bool(np.all(np.abs(new / sd - 1.0) < 1e-4))
        sd = new
        if done:
            break
    return p, sd


def _score(prob: _Problem, p: FloatArray, idx: NDArray[np.intp]) -> float:
    """Robust log-likelihood-like score of a candidate: the log of the robust noise scales."""
    r = prob.res(p, idx)
    if prob.given_w is not None:
        r = whiten(prob.given_w[idx], r)
    return float(np.log(_robust_sd(r)).sum())


def _check_nominal(wheel_diameter_m: float, wheelbase_m: float) -> None:
    for name, v in (("wheel_diameter_m", wheel_diameter_m), ("wheelbase_m", wheelbase_m)):
        if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v) and v > 0):
            raise InputError(f"`{name}` must be a positive number of metres, got {v!r}")


def selfcal(
    intervals: Intervals,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    sensor_covariance: ArrayLike | None = None,
    reject_outliers: bool = True,
    outlier_tail: float = 1e-4,
    max_rounds: int = 10,
    limits: identify.Limits | None = None,
) -> SelfcalResult:
    """Estimate the wheel radii, the wheelbase and the sensor pose from intervals.

    The method of Censi, Franchi, Marchionni, Oriolo (IEEE T-RO 2013); the steps are in the
    module docstring.

    Parameters
    ----------
    intervals : Intervals
        Wheel rotations and sensor displacements (:mod:`umbmark.model.intervals`).
    wheel_diameter_m : float
        Nominal wheel diameter [m] (the scale of the checks and of the closed form's
        fallback).
    wheelbase_m : float
        Nominal wheelbase [m] (``E_b`` is relative to it).
    sensor_covariance : array_like, optional
        The covariance of each sensor displacement ``(dx, dy, dyaw)``: (3, 3) for all
        intervals or (K, 3, 3) per interval (e.g. the scan matcher's). ``None``: the noise of
        each component is estimated from the residuals.
    reject_outliers : bool
        Set aside intervals whose residual is far beyond the rest.
    outlier_tail : float
        The chi-square tail probability (3 degrees of freedom) beyond which an interval is
        an outlier.
    max_rounds : int
        Fit-and-reject rounds at most.
    limits : identify.Limits, optional
        The standard deviations beyond which a parameter is reported poorly determined.

    Returns
    -------
    SelfcalResult
        The estimate, its covariance and 95 % intervals, the intervals used and rejected, and
        the warnings (the reader's, identifiability, plausibility, outliers).

    Raises
    ------
    InputError
        A nominal geometry that is not positive, fewer than 3 intervals, wheels that never
        turn, a covariance that is not positive definite, or intervals that cannot determine
        the parameters (a singular information matrix; the message names the parameters,
        the cause and what to drive).
    """
    _check_nominal(wheel_diameter_m, wheelbase_m)
    if not isinstance(intervals, Intervals):
        raise InputError(f"`intervals` must be an Intervals, got {type(intervals).__name__}")
    lim = limits or identify.Limits()
    if not 0 < outlier_tail < 1:
        raise InputError(f"`outlier_tail` must be a probability between 0 and 1, got {outlier_tail!r}")
    src = intervals.source
    k = len(intervals)
    if k < 3:
        raise InputError(f"a self-calibration needs at least 3 intervals, got {k}", src)
    r_nom = 0.5 * float(wheel_diameter_m)
    b_nom = float(wheelbase_m)
    fl, fr, s = intervals.left_rad, intervals.right_rad, intervals.sensor
    if not (np.any(fl != 0) or np.any(fr != 0)):
        raise InputError("the wheels do not turn in any interval: record intervals while the robot drives", src)
    given_w = None
    if sensor_covariance is not None:
        try:
            given_w = whitener(sensor_covariance, k)
        except np.linalg.LinAlgError:
            raise InputError("`sensor_covariance` must be positive definite", src) from None
        except ValueError as err:
            raise InputError(f"`sensor_covariance`: {err}", src) from None
    prob = _Problem(intervals, given_w)
    idx = np.arange(k)

    # 1. the better start, refined robustly when outliers are rejected
    starts = []
    for make in (
        lambda: closed_form(fl, fr, s),
        lambda: closed_form_fixed_scale(fl, fr, s, r_nom, r_nom, b_nom),
    ):
        try:
            starts.append(make())
        except ClosedFormFailed:
            pass
    if not starts:
        starts.append(np.array([r_nom, r_nom, b_nom, 0.0, 0.0, 0.0]))
    p0 = min(starts, key=lambda q: _score(prob, q, idx))
    if reject_outliers:
        sd0 = _robust_sd(prob.res(p0, idx)) if given_w is None else None
        p = prob.fit(p0, idx, sd0, loss="cauchy")
    else:
        p = p0
    if not np.all(np.isfinite(p)):
        raise InputError("the fit did not converge to finite values: check the units and the wheel order", src)

    # 2-3. maximum likelihood and outliers, until the inliers settle
    inl = np.ones(k, dtype=bool)
    sd = np.full(3, math.nan)
    if reject_outliers:
        from scipy.stats import chi2

        thr = float(chi2.isf(outlier_tail, 3))
    fitted = None
    for rnd in range(max_rounds):
        idx = np.flatnonzero(inl)
        p, sd = _ml_fit(prob, p, idx)
        fitted = inl
        if not reject_outliers:
            break
        e = prob.res(p, np.arange(k))
        if given_w is not None:
            e = whiten(given_w, e)
        # first round robust (the outliers are still in); then the scale of the inliers
        ei = e[inl]
        scale = _robust_sd(ei) if rnd == 0 else np.maximum(np.sqrt((ei * ei).mean(axis=0)), _SD_FLOOR)
        new = ((e / scale) ** 2).sum(axis=1) <= thr
        if new.sum() < 3 or np.array_equal(new, inl):
            break
        inl = new
    idx = np.flatnonzero(inl)
    if fitted is not inl:  # the rounds ran out just after the inliers changed
        p, sd = _ml_fit(prob, p, idx)

    # 4. the physical one of the mirror pair
    p = _physical(p)

    # 5-6. uncertainty, identifiability, plausibility
    if given_w is None:
        info = prob.information(p, idx, sd)
        noise_sd = (float(sd[0]), float(sd[1]), float(sd[2]))
        from scipy.stats import t as student_t

        tq = float(student_t.ppf(0.975, max(3 * len(idx) - 6, 1)))
    else:
        info = prob.information(p, idx, np.ones(3))
        cov_in = np.linalg.inv(np.einsum("kji,kjl->kil", given_w[idx], given_w[idx]))
        rms = np.sqrt(np.mean(np.diagonal(cov_in, axis1=1, axis2=2), axis=0))
        noise_sd = (float(rms[0]), float(rms[1]), float(rms[2]))
        tq = 1.959963984540054
    drv = identify.driving_summary(fl[idx], fr[idx], r_nom, b_nom)
    cov, id_warnings, singular = identify.identifiability(p, info, drv, r_nom, b_nom, lim)
    if singular is not None:
        raise InputError(singular, src)
    warnings = list(intervals.warnings)
    warnings += identify.plausibility(p, float(wheel_diameter_m), b_nom)
    warnings += id_warnings
    rejected = np.flatnonzero(~inl)
    if rejected.size > 0.2 * k:
        warnings.append(
            f"{rejected.size} of {k} intervals ({100 * rejected.size / k:.0f} %) rejected as outliers: "
            "check the scan matching (and the wheel data) of those intervals"
        )
    sdp = np.sqrt(np.maximum(np.diag(cov), 0.0))
    names = ("r_left_m", "r_right_m", "wheelbase_m", "sensor_x_m", "sensor_y_m", "sensor_yaw_rad")
    ci = {n: (float(p[i] - tq * sdp[i]), float(p[i] + tq * sdp[i])) for i, n in enumerate(names)}
    rw = prob.weighted(prob.res(p, idx), idx, sd if given_w is None else None)
    return SelfcalResult(
        r_left_m=float(p[0]),
        r_right_m=float(p[1]),
        wheelbase_m=float(p[2]),
        sensor_pose=(float(p[3]), float(p[4]), float(p[5])),
        covariance=cov,
        ci95=ci,
        intervals_used=len(idx),
        intervals_rejected=tuple(int(i) for i in rejected),
        warnings=warnings,
        nominal_wheel_diameter_m=float(wheel_diameter_m),
        nominal_wheelbase_m=b_nom,
        noise_sd=noise_sd,
        t_quantile=tq,
        cost=float(0.5 * (rw * rw).sum()),
    )
