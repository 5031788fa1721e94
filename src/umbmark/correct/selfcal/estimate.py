"""The self-calibration itself: closed-form start, maximum-likelihood fit, outliers, uncertainty.

:func:`selfcal` runs the steps in order:

1. Start: the paper's closed form (:mod:`umbmark.correct.selfcal.closed_form`), or the
   sensor pose fitted with the nominal odometry, whichever leaves the smaller residuals (per
   component, robustly); refined first with a robust (Cauchy) loss, so that failed scan
   matches do not pull it (when the loss is heavy-tailed or outliers are rejected).
2. Maximum likelihood of all six parameters on the residuals ``s_k - l^-1 (+) arc_k (+) l``
   (``scipy.optimize.least_squares`` inside). What depends on the noise model (the weights,
   the degrees of freedom, the information factor, the outlier threshold, the robust start)
   the loss says (:mod:`umbmark.correct.selfcal.loss`). By default the noise is **Student t**: its
   3 x 3 scatter matrix and its degrees of freedom ``nu`` are estimated with the parameters
   (expectation maximisation: each interval weighs ``(nu + 3) / (nu + d_k^2)``, ``d_k`` its
   Mahalanobis distance). Real recordings have heavy tails (wheel data stamped a little off
   the scans, odometry that lags and catches up, scenes the matcher half fails on): a few
   large residuals then weigh little instead of steering the fit, and on Gaussian noise
   ``nu`` grows large and the fit is least squares. ``loss="gaussian"`` is the plain
   maximum likelihood of Gaussian noise with the standard deviation of each component
   estimated from the residuals; given covariances whiten the residuals instead of an
   estimated scatter. **Errors in the wheel data** (``time_jitter``, on by default): the
   wheels' rotation over an interval is read at two stamps, and a stamp off by ``delta`` adds
   the motion of ``delta`` at the wheels' rate there. Each interval's noise then also holds
   ``sigma^2 (a_s a_s^T + a_e a_e^T)`` (``a``: how its displacement moves with each end,
   :func:`~umbmark.correct.selfcal.model.time_shift_derivatives`), ``sigma`` estimated with
   the rest, and each step solves the score corrected by its expectation under such errors
   (the corrected score of errors-in-variables models): a fit that takes the wheel data as
   exact makes wheels and turns come out small (regression dilution), the more so the
   shorter the intervals.
3. Outliers: an interval beyond the ``1 - outlier_tail`` quantile of the fitted noise (the
   F distribution of ``d_k^2 / 3`` for Student t, with at least :data:`~umbmark.correct.selfcal.loss.OUTLIER_DOF_MIN`
   degrees of freedom; chi-square with 3 degrees of freedom for
   Gaussian noise, with a robust scale in the first round) is set aside (a failed scan
   match). 2 and 3 repeat until the set is stable; set-aside intervals are judged again every
   round (a good one can come back).
4. Mirror: ``(r_L, r_R, b, l_x, l_y, l_yaw)`` and ``(-r_L, -r_R, -b, -l_x, -l_y, l_yaw + pi)``
   predict the same displacements; the one with positive radii (and wheelbase) is kept.
5. Uncertainty: the inverse of the Fisher information at the solution (for Student t noise
   ``(nu + 3) / (nu + 5)`` times the whitened Gauss-Newton matrix). Errors shared by
   neighbouring intervals (a stretch of a room the matcher measures a little short, wheels
   slipping on one floor) are not in it, nor errors that cancel between neighbours (a scan's
   own error enters the two intervals it ends and starts with opposite signs): with at least
   :data:`MIN_BLOCKS` blocks of time (:func:`time_blocks`, or the pipeline's labels) the
   covariance is the cluster-robust one, from the scores summed per block (the delete-one-block
   jackknife's sandwich), and the 95 % intervals use Student's t on the blocks less one. Errors
   shared over longer stretches (minutes: a floor, a load, a part of a building the matcher
   measures short) make neighbouring blocks alike, which short blocks do not see: the same
   covariance over :data:`LONG_BLOCKS` blocks of neighbours merged (:func:`merge_blocks`),
   scaled by the ratio of its Student t quantile to the short blocks', and in every direction
   the larger of the two is kept (:func:`loewner_max`). Without such errors this widens the
   intervals by about a quarter; with them, the halves of a recording agree within their
   intervals. With fewer than :data:`MIN_BLOCKS` blocks, the Fisher information's and
   Student's t on the residual degrees of freedom.
6. Identifiability and plausibility (:mod:`umbmark.correct.selfcal.identify`): warnings for
   what the driving leaves undetermined and for implausible values; an error when the
   information is singular.

Imports numpy, scipy (when it runs), :mod:`umbmark.model` and this package.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal import identify
from umbmark.correct.selfcal.closed_form import ClosedFormFailed, closed_form, closed_form_fixed_scale
from umbmark.correct.selfcal.loss import Loss, loss_named
from umbmark.correct.selfcal.model import jacobian, residuals, time_shift_derivatives, whiten, whitener
from umbmark.correct.selfcal.result import SelfcalResult
from umbmark.errors import InputError
from umbmark.model.geometry import wrap_angle
from umbmark.model.intervals import Intervals

__all__ = [
    "selfcal",
    "mirror",
    "time_blocks",
    "merge_blocks",
    "loewner_max",
    "BLOCK_S",
    "MAX_BLOCKS",
    "LONG_BLOCKS",
    "MIN_BLOCKS",
]

FloatArray = NDArray[np.float64]

# noise standard deviations are never taken below this (m, m, rad): noise-free data stay finite
_SD_FLOOR = 1e-10
_EM_ROUNDS = 500  # expectation-maximisation rounds of the Student t fit at most
_S_STEPS = 10  # EM steps of the scatter matrix per round when the jitter is modelled

BLOCK_S = 20.0
"""The shortest block of time of the covariance of shared errors [s] (:func:`time_blocks`)."""

MAX_BLOCKS = 20
"""The most blocks of time (longer recordings get longer blocks)."""

MIN_BLOCKS = 6
"""With fewer blocks than this the covariance is the Fisher information's alone."""

LONG_BLOCKS = 6
"""The blocks of the second, longer scale of shared errors: neighbouring blocks merged into this many."""
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


def robust_sd(r: FloatArray) -> FloatArray:
    med = np.median(r, axis=0)
    return np.maximum(_MAD * np.median(np.abs(r - med), axis=0), _SD_FLOOR)


class Problem:
    """The intervals in use and their whitening: given covariances, or a common scatter matrix."""

    def __init__(self, iv: Intervals, given_w: FloatArray | None, jitter: bool = False):
        self.source = iv.source
        self.fl = np.asarray(iv.left_rad, float)
        self.fr = np.asarray(iv.right_rad, float)
        self.s = np.asarray(iv.sensor, float)
        self.steps = iv.steps
        self.all = np.arange(len(iv))
        self.given_w = given_w
        # the sensor displacements' own covariance, added to the estimated scatter (or None)
        self.sig = None if given_w is not None or iv.covariance is None else np.asarray(iv.covariance, float)
        # errors in the wheel data: their stamps off by a jitter estimated with the noise
        # (with the wheels' rates at the ends from the wheel data around the stamps: a rate
        # from the interval's own rotation would carry the jitter's error, and weigh by it)
        self.jitter = bool(jitter) and given_w is None and iv.end_rates is not None
        self.rates = None
        if self.jitter:
            assert iv.end_rates is not None
            self.rates = (np.asarray(iv.end_rates[:, :2], float), np.asarray(iv.end_rates[:, 2:], float))
        self.n = 6  # parameters
        # settled once a step moves the parameters by less than 1e-3 of their standard deviations
        self.settle_by_sd = False
        self.last_information = np.eye(6)  # the last Gauss-Newton step's (whitened, weighted)

    def param_scale(self, p: FloatArray) -> FloatArray:
        """The scale of each parameter for relative steps (:func:`_param_scale`)."""
        return _param_scale(p)

    def jitter_terms(self, p: FloatArray) -> tuple[FloatArray, tuple[FloatArray, FloatArray, FloatArray, FloatArray]]:
        """``G_k = a_s a_s^T + a_e a_e^T`` ``(K, 3, 3)`` (the covariance of a unit jitter at both
        ends) and the derivatives of :func:`time_shift_derivatives`."""
        assert self.rates is not None
        with np.errstate(all="ignore"):  # parameters far off (undetermined): no jitter term there
            raw = time_shift_derivatives(p, self.fl, self.fr, self.rates[0], self.rates[1], self.steps)
        a_s, a_e, dj_s, dj_e = (np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0) for a in raw)
        g = a_s[:, :, None] * a_s[:, None, :] + a_e[:, :, None] * a_e[:, None, :]
        return g, (a_s, a_e, dj_s, dj_e)

    def own(self, g: FloatArray | None, sig2: float) -> FloatArray | None:
        """Each interval's own covariance ``(K, 3, 3)``: the matcher's plus the jitter's (or None)."""
        if self.sig is None and g is None:
            return None
        out = np.zeros((len(self.fl), 3, 3)) if self.sig is None else self.sig
        return out if g is None else out + sig2 * g

    def score_correction(
        self,
        d: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
        idx: NDArray[np.intp],
        w3: FloatArray | None,
        sig2: float,
    ) -> FloatArray:
        """``(n, 6)``: ``sig2 (dJ/d delta)^T Sigma^-1 a`` of both ends of each interval ``idx``:
        what errors in the wheel data add to the score on average, taken off."""
        out = np.zeros((len(idx), 6))
        for a, dj in ((d[0], d[2]), (d[1], d[3])):
            u = self.white(a[idx], idx, w3)
            v = self.white(dj[idx], idx, w3)
            out += np.einsum("kij,ki->kj", v, u)
        return sig2 * out

    def res(self, p: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        if self.steps is None:
            return residuals(p, self.fl[idx], self.fr[idx], self.s[idx])
        return residuals(p, self.fl, self.fr, self.s, self.steps)[idx]

    def jac(self, p: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        if self.steps is None:
            return jacobian(p, self.fl[idx], self.fr[idx])
        return jacobian(p, self.fl, self.fr, self.steps)[idx]

    def white(self, r: FloatArray, idx: NDArray[np.intp], w3: FloatArray | None) -> FloatArray:
        """Whiten residuals ``(n, 3)`` or a Jacobian ``(n, 3, 6)``: by the given covariances, else by
        ``w3`` (one ``(3, 3)`` whitener, or ``(K, 3, 3)``, one per interval)."""
        if self.given_w is not None:
            return whiten(self.given_w[idx], r)
        assert w3 is not None
        if w3.ndim == 3:
            return whiten(w3[idx], r)
        return r @ w3.T if r.ndim == 2 else np.matmul(w3, r)

    def whiteners(self, scatter: FloatArray, own: FloatArray | None = None) -> FloatArray:
        """``(K, 3, 3)``: the whiteners of ``scatter`` plus each interval's own covariance."""
        if own is None:
            assert self.sig is not None
            own = self.sig
        c = own + scatter + np.diag(np.full(3, _SD_FLOOR**2))
        return np.asarray(np.linalg.inv(np.linalg.cholesky(0.5 * (c + np.swapaxes(c, 1, 2)))), dtype=float)

    def fit(
        self,
        p0: FloatArray,
        idx: NDArray[np.intp],
        w3: FloatArray | None,
        loss: str = "linear",
        weights: FloatArray | None = None,
    ) -> FloatArray:
        from scipy.optimize import least_squares

        sw = np.ones(len(idx)) if weights is None else np.sqrt(weights)
        fun: Callable[[FloatArray], FloatArray] = lambda p: (  # noqa: E731
            sw[:, None] * self.white(self.res(p, idx), idx, w3)
        ).ravel()
        jac: Callable[[FloatArray], FloatArray] = lambda p: (  # noqa: E731
            -sw[:, None, None] * self.white(self.jac(p, idx), idx, w3)
        ).reshape(-1, self.n)
        method = "lm" if loss == "linear" else "trf"
        sol = least_squares(
            fun, p0, jac=jac, method=method, loss=loss, x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=500
        )
        return np.asarray(sol.x, dtype=float)

    def whitened_jacobian(self, p: FloatArray, idx: NDArray[np.intp], w3: FloatArray | None) -> FloatArray:
        return self.white(self.jac(p, idx), idx, w3)

    def gauss_newton(
        self,
        p: FloatArray,
        idx: NDArray[np.intp],
        w3: FloatArray | None,
        weights: FloatArray,
        correction: FloatArray | None = None,
    ) -> FloatArray:
        """One Gauss-Newton step on ``sum w_k |W r_k|^2`` (the weights held), halved until it does not rise.

        With a ``correction`` of the score (``(6,)``, the errors-in-variables term) the step
        solves the corrected score equation instead, whole: its root is not the cost's minimum."""

        def cost(q: FloatArray) -> float:
            z = self.white(self.res(q, idx), idx, w3)
            return float((weights[:, None] * z * z).sum())

        z = self.white(self.res(p, idx), idx, w3)
        sw = np.sqrt(weights)
        jw = (sw[:, None, None] * self.whitened_jacobian(p, idx, w3)).reshape(-1, self.n)
        h = jw.T @ jw
        self.last_information = h
        g = jw.T @ (sw[:, None] * z).reshape(-1)
        if correction is not None:
            g = g + correction
        try:
            step = np.linalg.solve(h, g)
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(h, g, rcond=None)[0]
        if correction is not None:
            q = p + step
            return q if np.all(np.isfinite(q)) else p
        c0 = float((weights[:, None] * z * z).sum())
        for _ in range(10):
            q = p + step
            if np.all(np.isfinite(q)) and cost(q) <= c0 * (1.0 + 1e-12):  # not above it beyond rounding
                return q
            step = 0.5 * step
        return p


def diag_whitener(sd: FloatArray) -> FloatArray:
    return np.diag(1.0 / np.maximum(sd, _SD_FLOOR))


def _scatter_whitener(scatter: FloatArray) -> FloatArray:
    """``W`` with ``W^T W = scatter^-1``, the scatter floored so that noise-free data stay finite."""
    a = 0.5 * (scatter + scatter.T) + np.diag(np.full(3, _SD_FLOOR**2))
    try:
        return np.asarray(np.linalg.inv(np.linalg.cholesky(a)), dtype=float)
    except np.linalg.LinAlgError:
        return diag_whitener(np.sqrt(np.maximum(np.diag(a), 0.0)))


def _gaussian_fit(prob: Problem, p0: FloatArray, idx: NDArray[np.intp]) -> tuple[FloatArray, FloatArray | None]:
    """Maximum likelihood for Gaussian noise on the intervals ``idx``: the parameters and the
    whitener (``None`` with given covariances; else that of the noise sd of each component,
    estimated from the residuals and the fit repeated until it settles)."""
    if prob.given_w is not None:
        return prob.fit(p0, idx, None), None
    n = len(idx)
    sd = robust_sd(prob.res(p0, idx))
    p = p0
    for _ in range(10):
        p = prob.fit(p, idx, diag_whitener(sd))
        r = prob.res(p, idx)
        new = np.maximum(np.sqrt((r * r).sum(axis=0) / max(n - 2, 1)), _SD_FLOOR)
        done = bool(np.all(np.abs(new / sd - 1.0) < 1e-4))
        sd = new
        if done:
            break
    return p, diag_whitener(sd)


def _param_scale(p: FloatArray) -> FloatArray:
    """The scale of each parameter for relative steps: the radii, the wheelbase (for the
    sensor position too) and 1 rad."""
    return np.array([p[0], p[1], p[2], p[2], p[2], 1.0])


JITTER_SD_MAX = 0.25
"""The largest stamp jitter of the wheel data the fit considers [s]."""


def _fit_jitter(base: FloatArray, g: FloatArray, r: FloatArray, wt: FloatArray) -> float:
    """The variance of the wheel data's stamp jitter of most likelihood [s^2], the rest held:
    the noise of interval k is ``base_k + sigma^2 G_k``, its residual ``r_k``, its weight ``wt_k``."""
    from scipy.optimize import minimize_scalar

    def nll(sd: float) -> float:
        c = base + (sd * sd) * g
        try:
            chol = np.linalg.cholesky(c)
        except np.linalg.LinAlgError:
            return math.inf
        y = np.linalg.solve(chol, r[:, :, None])[:, :, 0]
        logdet = 2.0 * np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)
        return float(0.5 * np.sum(logdet + wt * (y * y).sum(axis=1)))

    # on a log scale, from a tenth of a microsecond: noise-free data leave it at nil
    sol = minimize_scalar(
        lambda u: nll(10.0**u), bounds=(-7.0, math.log10(JITTER_SD_MAX)), method="bounded", options={"xatol": 1e-4}
    )
    sd = float(10.0**sol.x)
    return 0.0 if nll(0.0) <= nll(sd) else sd * sd


def _em_fit(
    prob: Problem, p0: FloatArray, idx: NDArray[np.intp], loss: Loss
) -> tuple[FloatArray, FloatArray | None, float, FloatArray, FloatArray | None, float]:
    """Maximum likelihood for the noise of ``loss`` on the intervals ``idx`` (expectation maximisation).

    The noise of interval k has the scatter matrix ``S`` (estimated), plus the interval's own
    covariance when the intervals carry one (the scan matcher's: ``S + Sigma_k``, ``S`` then
    the residuals' weighted scatter less the intervals' mean covariance). With the wheel
    data's jitter (``prob.jitter``) each interval's covariance also holds ``sigma^2 G_k``
    (``sigma`` estimated, ``G_k`` from :func:`time_shift_derivatives`) and each step solves
    the score corrected for the errors such jitter puts in the wheel data. The weights, the
    degrees of freedom and when they have settled are the loss's (:mod:`umbmark.correct.selfcal.loss`:
    for Gaussian noise no weights and ``nu`` infinite).

    Returns the parameters, the whitener (``(3, 3)``; ``(K, 3, 3)`` with the intervals' own
    covariances; ``None`` with given covariances), the degrees of freedom, the weight of each
    interval (:meth:`~umbmark.correct.selfcal.loss.Loss.weights`), ``S`` (``None`` with given covariances) and the
    jitter's variance ``sigma^2`` [s^2].
    """
    p = p0
    r = prob.res(p, idx)
    scatter = None if prob.given_w is not None else np.diag(robust_sd(r) ** 2)
    sig2 = 0.0
    g, d = prob.jitter_terms(p) if prob.jitter else (None, None)
    own = prob.own(g, sig2)
    w3 = None
    if scatter is not None:
        w3 = _scatter_whitener(scatter) if own is None else prob.whiteners(scatter, own)
    nu = loss.start_dof
    p_terms = p.copy()  # where the jitter's terms were last computed
    for rounds in range(_EM_ROUNDS):
        z = prob.white(r, idx, w3)
        d2 = (z * z).sum(axis=1)
        sig2_old = sig2
        if scatter is not None:
            wt = loss.weights(nu, d2)
            if own is None:
                scatter = (wt[:, None] * r).T @ r / len(idx)
                w3 = _scatter_whitener(scatter)
            elif g is not None:
                # the noise is a ~ N(0, S) plus b_k ~ N(0, own_k): the expectation of a a^T
                # given the residual, averaged (an EM step for S; own_k varies too much with
                # the jitter's part for the moments below)
                for _inner in range(_S_STEPS):
                    c = scatter[None] + own[idx] + np.diag(np.full(3, _SD_FLOOR**2))
                    sc = np.linalg.inv(c) @ scatter
                    y = np.einsum("kij,kj->ki", np.swapaxes(sc, 1, 2), r)  # S C^-1 r
                    nxt = (scatter[None] - scatter[None] @ sc + wt[:, None, None] * y[:, :, None] * y[:, None, :]).mean(
                        axis=0
                    )
                    scatter = 0.5 * (nxt + nxt.T) + np.diag(np.full(3, _SD_FLOOR**2))
                base = scatter + (0.0 if prob.sig is None else prob.sig[idx]) + np.diag(np.full(3, _SD_FLOOR**2))
                # the first round unweighted: heavy tails would otherwise explain the fast
                # intervals' larger errors before the jitter could
                sig2 = _fit_jitter(base, g[idx], r, wt if rounds else np.ones(len(idx)))
                own = prob.own(g, sig2)
                w3 = prob.whiteners(scatter, own)
            else:
                # the residuals' weighted scatter less the intervals' own mean covariance (at
                # least a thousandth of it: the estimated part never vanishes)
                mean_own = own[idx].mean(axis=0)
                excess = (wt[:, None] * r).T @ r / len(idx) - mean_own
                val, vec = np.linalg.eigh(0.5 * (excess + excess.T))
                floor = 1e-3 * np.maximum(np.diag(mean_own), _SD_FLOOR**2)
                scatter = (vec * np.maximum(val, 0.0)) @ vec.T + np.diag(floor)
                w3 = prob.whiteners(scatter, own)
            z = prob.white(r, idx, w3)
            d2 = (z * z).sum(axis=1)
        nu_new = loss.fit_dof(d2)
        wt = loss.weights(nu_new, d2)
        corr = None
        if d is not None and sig2 > 0:
            corr = (wt[:, None] * prob.score_correction(d, idx, w3, sig2)).sum(axis=0)
        q = prob.gauss_newton(p, idx, w3, wt, corr)
        step = prob.param_scale(p)
        # with the jitter modelled the EM converges linearly and slowly (the scatter's EM
        # steps, the jitter and the degrees of freedom trade off): it has settled once the
        # degrees of freedom move by less than 1e-4 of themselves and the jitter by 10 us
        loose = prob.jitter or prob.settle_by_sd
        nu_tol = 1e-4 if loose else 1e-7
        settled = loss.dof_settled(nu_new, nu, nu_tol) and abs(math.sqrt(sig2) - math.sqrt(sig2_old)) < 1e-5
        # and the parameters once they move by 1e-9 of themselves, or by 1e-3 of their
        # standard deviations: far below their uncertainty
        tol = 1e-9 if sig2 > 0 else 1e-11
        small = bool(np.max(np.abs(q - p) / np.abs(step)) < tol)
        if loose and not small:
            try:
                sd = np.sqrt(np.maximum(np.diag(np.linalg.inv(prob.last_information)), 0.0))
                small = bool(np.all(np.abs(q - p) <= 1e-3 * sd))
            except np.linalg.LinAlgError:
                pass
        done = small and settled
        p, nu = q, nu_new
        r = prob.res(p, idx)
        # the jitter's terms move with the parameters, slowly: computed again once they moved
        if prob.jitter and bool(np.max(np.abs(p - p_terms) / np.abs(prob.param_scale(p))) > 1e-5):
            g, d = prob.jitter_terms(p)
            p_terms = p.copy()
            own = prob.own(g, sig2)
            if scatter is not None:
                w3 = prob.whiteners(scatter, own)
        if done:
            break
    z = prob.white(r, idx, w3)
    wt = loss.weights(nu, (z * z).sum(axis=1))
    return p, w3, nu, wt, scatter, sig2


def _score(prob: Problem, p: FloatArray, idx: NDArray[np.intp]) -> float:
    """Robust log-likelihood-like score of a candidate: the log of the robust noise scales."""
    r = prob.res(p, idx)
    if prob.given_w is not None:
        r = whiten(prob.given_w[idx], r)
    return float(np.log(robust_sd(r)).sum())


def time_blocks(dt_s: ArrayLike, block_s: float = BLOCK_S, max_blocks: int = MAX_BLOCKS) -> NDArray[np.intp]:
    """Consecutive intervals grouped into blocks of time, for the covariance of errors they share.

    The intervals are taken in time order; a block spans ``max(block_s, T / max_blocks)`` of
    their summed duration ``T``, so there are at most ``max_blocks`` blocks.

    Parameters
    ----------
    dt_s : array_like
        ``(K,)`` durations [s], in time order.
    block_s : float
        The shortest block [s].
    max_blocks : int
        The most blocks.

    Returns
    -------
    numpy.ndarray
        ``(K,)`` block labels ``0, 1, ...`` (non-decreasing).
    """
    t = np.cumsum(np.asarray(dt_s, dtype=float)) if len(np.atleast_1d(dt_s)) else np.zeros(0)
    if t.size == 0 or not t[-1] > 0:
        return np.zeros(t.size, dtype=np.intp)
    span = max(float(block_s), float(t[-1]) / max(int(max_blocks), 1))
    lab = np.minimum(np.floor((t - 0.5 * np.asarray(dt_s, dtype=float)) / span), max(int(max_blocks), 1) - 1)
    return np.asarray(lab, dtype=np.intp)


def _block_covariance(
    info: FloatArray, hessians: FloatArray, scores: FloatArray, labels: NDArray[np.intp]
) -> tuple[FloatArray, int]:
    """The cluster-robust covariance over blocks, and the block count ``G``.

    The delete-one-block jackknife's (the "CR3" sandwich): ``(G - 1) / G sum_g (A - A_g)^-1
    s_g s_g^T (A - A_g)^-1`` with ``A`` the information, ``A_g`` and ``s_g`` the information and
    the scores summed over block ``g``: each block's score weighs as much as leaving it out
    would move the estimate, so a block that alone holds some motion (the only spins) counts
    fully, and the covariance is not too small with few blocks.
    """
    uniq, inv = np.unique(labels, return_inverse=True)
    nb = len(uniq)
    g = np.zeros((nb, scores.shape[1]))
    np.add.at(g, inv, scores)
    hg = np.zeros((nb, info.shape[0], info.shape[1]))
    np.add.at(hg, inv, hessians)
    out = np.zeros_like(info)
    for k in range(nb):
        rest = info - hg[k]
        try:
            d = np.linalg.solve(rest, g[k])
        except np.linalg.LinAlgError:
            d = np.linalg.lstsq(rest, g[k], rcond=None)[0]
        out += np.outer(d, d)
    return np.asarray(out * (nb - 1) / nb, dtype=float), nb


def merge_blocks(labels: ArrayLike, n: int = LONG_BLOCKS) -> NDArray[np.intp]:
    """Neighbouring blocks merged into ``n`` (or fewer) of about equal counts of blocks.

    Parameters
    ----------
    labels : array_like
        ``(K,)`` block labels, non-decreasing (:func:`time_blocks`, the pipeline's).
    n : int
        The blocks wanted.

    Returns
    -------
    numpy.ndarray
        ``(K,)`` labels ``0 .. n - 1``: block ``g`` of ``G`` goes to ``floor(g n / G)``.
    """
    uniq, inv = np.unique(np.asarray(labels), return_inverse=True)
    g = len(uniq)
    return np.asarray((np.arange(g) * min(int(n), g)) // max(g, 1), dtype=np.intp)[inv]


def loewner_max(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """The least covariance at least as large as both ``a`` and ``b`` in every direction, in ``a``'s metric.

    With ``a = L L^T`` and ``L^-1 b L^-T = V diag(l) V^T``: ``L V diag(max(l, 1)) V^T L^T``.
    Every linear combination's variance is then at least its variance under ``a`` and under
    ``b``.

    Parameters
    ----------
    a, b : array_like
        ``(n, n)`` symmetric positive semi-definite; ``a`` positive definite.

    Returns
    -------
    numpy.ndarray
        ``(n, n)``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    val, vec = np.linalg.eigh(0.5 * (a + a.T))
    floor = max(float(val.max()), 0.0) * 1e-12
    half = vec * np.sqrt(np.maximum(val, floor))
    inv = vec / np.sqrt(np.maximum(val, floor))
    m = inv.T @ (0.5 * (b + b.T)) @ inv
    lv, lvec = np.linalg.eigh(0.5 * (m + m.T))
    grown = half @ (lvec * np.maximum(lv, 1.0)) @ lvec.T @ half.T
    return np.asarray(0.5 * (grown + grown.T), dtype=float)


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
    loss: str = "student",
    outlier_tail: float = 1e-4,
    max_rounds: int = 10,
    limits: identify.Limits | None = None,
    blocks: ArrayLike | None = None,
    block_s: float = BLOCK_S,
    max_blocks: int = MAX_BLOCKS,
    time_jitter: bool = True,
) -> SelfcalResult:
    """Estimate the wheel radii, the wheelbase and the sensor pose from intervals.

    The method of Censi, Franchi, Marchionni, Oriolo (IEEE T-RO 2013), with heavy-tailed noise
    and intervals that hold the errors shared within a recording; the steps are in the module
    docstring.

    Parameters
    ----------
    intervals : Intervals
        Wheel rotations and sensor displacements (:mod:`umbmark.model.intervals`), in time
        order.
    wheel_diameter_m : float
        Nominal wheel diameter [m] (the scale of the checks and of the closed form's
        fallback).
    wheelbase_m : float
        Nominal wheelbase [m] (``E_b`` is relative to it).
    sensor_covariance : array_like, optional
        The covariance of each sensor displacement ``(dx, dy, dyaw)``: (3, 3) for all
        intervals or (K, 3, 3) per interval (e.g. the scan matcher's). ``None``: the noise's
        scatter matrix is estimated from the residuals.
    reject_outliers : bool
        Set aside intervals whose residual is far beyond the rest.
    loss : str
        ``"student"`` (the default): the noise is Student t, its scatter and degrees of freedom
        estimated with the parameters (heavy tails, e.g. wheel data that lag the scans now and
        then, weigh less); ``"gaussian"``: Gaussian noise, independent per component. A name
        of :data:`umbmark.correct.selfcal.loss.LOSS_TABLE`.
    outlier_tail : float
        The tail probability of the fitted noise distribution beyond which an interval is an
        outlier.
    max_rounds : int
        Fit-and-reject rounds at most.
    limits : identify.Limits, optional
        The standard deviations beyond which a parameter is reported poorly determined.
    blocks : array_like, optional
        ``(K,)`` labels of the blocks of time the intervals fall in (e.g. per bag and per
        stretch of its recording), for the covariance of errors shared within a block; default
        :func:`time_blocks` of the durations.
    block_s, max_blocks : float, int
        The shortest block and the most blocks of the default labels.
    time_jitter : bool
        Model errors in the wheel data from their stamps' jitter against the sensor's (step
        2 of the module docstring): for intervals with the wheels' rates at their ends
        (:attr:`~umbmark.model.intervals.Intervals.end_rates`, as the bag pipeline makes
        them), not with ``sensor_covariance``.

    Returns
    -------
    SelfcalResult
        The estimate, its covariance and 95 % intervals, the intervals used and rejected, and
        the warnings (the reader's, identifiability, plausibility, outliers).

    Raises
    ------
    InputError
        A nominal geometry that is not positive, fewer than 3 intervals, wheels that never
        turn, a covariance that is not positive definite, an unknown loss, blocks that do not
        fit the intervals, or intervals that cannot determine the parameters (a singular
        information matrix; the message names the parameters, the cause and what to drive).
    """
    _check_nominal(wheel_diameter_m, wheelbase_m)
    noise = loss_named(loss)
    if not 0 < outlier_tail < 1:
        raise InputError(f"`outlier_tail` must be a probability between 0 and 1, got {outlier_tail!r}")
    prob, labels = _problem(intervals, sensor_covariance, blocks, block_s, max_blocks, time_jitter)
    lim = limits or identify.Limits()
    r_nom = 0.5 * float(wheel_diameter_m)
    b_nom = float(wheelbase_m)
    # 1. the better start, refined robustly when outliers are rejected or the loss is robust
    p0 = _start(prob, r_nom, b_nom, noise.start_loss(reject_outliers))
    # 2-3. maximum likelihood and outliers, until the inliers settle
    fit = fit_and_reject(prob, p0, noise, reject_outliers, outlier_tail, max_rounds)
    # 4. the physical one of the mirror pair
    fit = replace(fit, p=_physical(fit.p))
    # 5-6. uncertainty, identifiability, plausibility
    unc = uncertainty(prob, fit, noise, labels, _drive_identify(prob, r_nom, b_nom, lim))
    return _result(intervals, fit, unc, float(wheel_diameter_m), b_nom, prob.jitter)


def _result(
    intervals: Intervals, fit: Fit, unc: Uncertainty, wheel_diameter_m: float, b_nom: float, jitter: bool
) -> SelfcalResult:
    """The estimate with its 95 % intervals and every warning (the reader's, plausibility,
    identifiability, many outliers)."""
    p, idx, k = fit.p, np.flatnonzero(fit.inliers), len(intervals)
    warnings = list(intervals.warnings)
    warnings += identify.plausibility(p, wheel_diameter_m, b_nom)
    warnings += unc.warnings
    rejected = np.flatnonzero(~fit.inliers)
    if rejected.size > 0.2 * k:
        warnings.append(
            f"{rejected.size} of {k} intervals ({100 * rejected.size / k:.0f} %) rejected as outliers: "
            "check the scan matching (and the wheel data) of those intervals"
        )
    sdp = np.sqrt(np.maximum(np.diag(unc.covariance), 0.0))
    names = ("r_left_m", "r_right_m", "wheelbase_m", "sensor_x_m", "sensor_y_m", "sensor_yaw_rad")
    tq = unc.t_quantile
    ci = {n: (float(p[i] - tq * sdp[i]), float(p[i] + tq * sdp[i])) for i, n in enumerate(names)}
    return SelfcalResult(
        r_left_m=float(p[0]),
        r_right_m=float(p[1]),
        wheelbase_m=float(p[2]),
        sensor_pose=(float(p[3]), float(p[4]), float(p[5])),
        covariance=unc.covariance,
        ci95=ci,
        intervals_used=len(idx),
        intervals_rejected=tuple(int(i) for i in rejected),
        warnings=warnings,
        nominal_wheel_diameter_m=wheel_diameter_m,
        nominal_wheelbase_m=b_nom,
        noise_sd=unc.noise_sd,
        t_quantile=tq,
        cost=unc.cost,
        noise_dof=float(fit.nu),
        covariance_blocks=unc.blocks,
        wheel_jitter_s=math.sqrt(fit.sig2) if jitter else math.nan,
    )


def _problem(
    intervals: Intervals,
    sensor_covariance: ArrayLike | None,
    blocks: ArrayLike | None,
    block_s: float,
    max_blocks: int,
    time_jitter: bool,
) -> tuple[Problem, NDArray[Any]]:
    """The intervals checked (at least 3, wheels that turn, a positive definite covariance, a block
    label each) as a :class:`Problem`, and the labels of their blocks of time."""
    if not isinstance(intervals, Intervals):
        raise InputError(f"`intervals` must be an Intervals, got {type(intervals).__name__}")
    src = intervals.source
    k = len(intervals)
    if k < 3:
        raise InputError(f"a self-calibration needs at least 3 intervals, got {k}", src)
    labels = time_blocks(intervals.dt_s, block_s, max_blocks) if blocks is None else np.asarray(blocks)
    if labels.shape != (k,):
        raise InputError(f"`blocks` must hold one label per interval ({k}), got shape {labels.shape}", src)
    if not (np.any(intervals.left_rad != 0) or np.any(intervals.right_rad != 0)):
        raise InputError("the wheels do not turn in any interval: record intervals while the robot drives", src)
    given_w = None
    if sensor_covariance is not None:
        try:
            given_w = whitener(sensor_covariance, k)
        except np.linalg.LinAlgError:
            raise InputError("`sensor_covariance` must be positive definite", src) from None
        except ValueError as err:
            raise InputError(f"`sensor_covariance`: {err}", src) from None
    return Problem(intervals, given_w, jitter=time_jitter), labels


def _start(prob: Problem, r_nom: float, b_nom: float, refine: str | None) -> FloatArray:
    """Step 1: of the closed form and the fixed-scale closed form (the nominal geometry where both
    fail), the start with the smaller robust residuals, refined with the loss ``refine`` of
    ``scipy.optimize.least_squares`` (:meth:`~umbmark.correct.selfcal.loss.Loss.start_loss`) unless None."""
    idx = prob.all
    fl, fr, s = prob.fl, prob.fr, prob.s
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
    p = p0
    if refine is not None:
        w0 = diag_whitener(robust_sd(prob.res(p0, idx))) if prob.given_w is None else None
        p = prob.fit(p0, idx, w0, loss=refine)
    if not np.all(np.isfinite(p)):
        raise InputError("the fit did not converge to finite values: check the units and the wheel order", prob.source)
    return p


@dataclass(frozen=True)
class Fit:
    """The maximum-likelihood fit on the inliers: the parameters, the inliers, the whitener, the
    Student t degrees of freedom, the scatter matrix and the wheel data's jitter variance [s^2]."""

    p: FloatArray
    inliers: NDArray[np.bool_]
    w3: FloatArray | None
    nu: float
    scatter: FloatArray | None
    sig2: float


def _fit_on(prob: Problem, mask: NDArray[np.bool_], start: FloatArray, loss: Loss) -> Fit:
    """The maximum-likelihood fit on the intervals of ``mask`` from ``start``: by expectation
    maximisation where the loss's scatter is a full matrix or the intervals have noise of their own."""
    sel = np.flatnonzero(mask)
    if _em(prob, loss):
        q, w, dof, _, sc, j2 = _em_fit(prob, start, sel, loss)
        return Fit(q, mask, w, dof, sc, j2)
    q, w = _gaussian_fit(prob, start, sel)
    return Fit(q, mask, w, math.inf, None, 0.0)


def _em(prob: Problem, loss: Loss) -> bool:
    """Whether the fit is the expectation maximisation of :func:`_em_fit`: the loss's scatter is a
    full matrix, or the intervals carry covariances of their own or the wheel data's jitter."""
    return loss.full_scatter or prob.sig is not None or prob.jitter


def _outside(prob: Problem, fit: Fit, loss: Loss, tail: float, first_round: bool) -> NDArray[np.bool_]:
    """Step 3: the intervals within the ``1 - tail`` quantile of the fitted noise (the inliers)."""
    every = prob.all
    e = prob.res(fit.p, every)
    thr = loss.outlier_threshold(tail, fit.nu)
    if _em(prob, loss):
        z = prob.white(e, every, fit.w3)
        return np.asarray((z * z).sum(axis=1) <= thr)
    if prob.given_w is not None:
        e = whiten(prob.given_w, e)
    # first round robust (the outliers are still in); then the scale of the inliers
    ei = e[fit.inliers]
    scale = robust_sd(ei) if first_round else np.maximum(np.sqrt((ei * ei).mean(axis=0)), _SD_FLOOR)
    return np.asarray(((e / scale) ** 2).sum(axis=1) <= thr)


def fit_and_reject(prob: Problem, p: FloatArray, loss: Loss, reject: bool, tail: float, max_rounds: int) -> Fit:
    """Steps 2-3: the fit on the inliers and the outliers set aside, until the inliers settle (a
    set-aside interval is judged again every round)."""
    inl = np.ones(len(prob.all), dtype=bool)
    fit: Fit | None = None
    for rnd in range(max_rounds):
        fit = _fit_on(prob, inl, p if fit is None else fit.p, loss)
        if not reject:
            return fit
        new = _outside(prob, fit, loss, tail, first_round=rnd == 0)
        if new.sum() < 3 or np.array_equal(new, inl):
            return fit
        inl = new
    # the rounds ran out just after the inliers changed
    return _fit_on(prob, inl, p if fit is None else fit.p, loss)


@dataclass(frozen=True)
class Uncertainty:
    """Steps 5-6: the covariance (cluster-robust where there are blocks), the quantile of its 95 %
    intervals, the noise's standard deviations, the identifiability warnings, the blocks used and
    the cost at the answer."""

    covariance: FloatArray
    t_quantile: float
    noise_sd: tuple[float, float, float]
    warnings: list[str]
    blocks: int
    cost: float


Identify = Callable[
    [FloatArray, FloatArray, NDArray[np.intp], "FloatArray | None"], tuple[FloatArray, list[str], "str | None"]
]
"""How a kind of robot judges what its intervals determine: ``(p, information, inliers,
covariance or None) -> (covariance, warnings, the error of a singular information or None)``."""


def _drive_identify(prob: Problem, r_nom: float, b_nom: float, lim: identify.Limits) -> Identify:
    """The differential drive's identifiability (:func:`identify.identifiability`) as an :data:`Identify`."""

    def judge(p: FloatArray, info: FloatArray, idx: NDArray[np.intp], cov: FloatArray | None):
        drv = identify.driving_summary(prob.fl[idx], prob.fr[idx], r_nom, b_nom)
        c, warn, singular = identify.identifiability(p, info, drv, r_nom, b_nom, lim, covariance=cov)
        return c, list(warn), singular

    return judge


def uncertainty(prob: Problem, fit: Fit, loss: Loss, labels: NDArray[Any], judge: Identify) -> Uncertainty:
    """Steps 5-6 of the module docstring at the fit's answer (``judge``: the kind's identifiability;
    the weights and the information factor: the loss's)."""
    from umbmark._stats import t_ppf

    p, w3, nu, idx = fit.p, fit.w3, fit.nu, np.flatnonzero(fit.inliers)
    jw = prob.whitened_jacobian(p, idx, w3)
    z = prob.white(prob.res(p, idx), idx, w3)
    d2 = (z * z).sum(axis=1)
    wt = loss.weights(nu, d2)
    factor = loss.information_factor(nu)
    flat = jw.reshape(-1, prob.n)
    info = (flat.T @ flat) * factor
    if prob.given_w is None:
        assert w3 is not None
        scatter = np.linalg.inv(w3.T @ w3) if fit.scatter is None else fit.scatter
        sd_noise = np.sqrt(np.maximum(np.diag(scatter), 0.0))
        noise_sd = (float(sd_noise[0]), float(sd_noise[1]), float(sd_noise[2]))
        tq = t_ppf(0.975, max(3 * len(idx) - prob.n, 1))
    else:
        given = prob.given_w[idx]
        cov_in = np.linalg.inv(np.einsum("kji,kjl->kil", given, given))
        rms = np.sqrt(np.mean(np.diagonal(cov_in, axis1=1, axis2=2), axis=0))
        noise_sd = (float(rms[0]), float(rms[1]), float(rms[2]))
        tq = 1.959963984540054
    cov, id_warnings, singular = judge(p, info, idx, None)
    if singular is not None:
        raise InputError(singular, prob.source)
    n_blocks = 0
    if len(np.unique(labels[idx])) >= MIN_BLOCKS:
        scores = wt[:, None] * (np.swapaxes(jw, 1, 2) @ z[:, :, None])[:, :, 0]
        if prob.jitter and fit.sig2 > 0:
            scores = scores + wt[:, None] * prob.score_correction(prob.jitter_terms(p)[1], idx, w3, fit.sig2)
        hessians = np.swapaxes(jw, 1, 2) @ jw * factor
        cov, n_blocks = _block_covariance(info, hessians, scores, labels[idx])
        tq = t_ppf(0.975, n_blocks - 1)
        # errors shared over longer stretches: the same over LONG_BLOCKS merged blocks, its
        # Student t quantile folded into the covariance, and in every direction the larger
        n_long = min(LONG_BLOCKS, n_blocks)
        if MIN_BLOCKS <= n_long < n_blocks:
            cov_long, _ = _block_covariance(info, hessians, scores, merge_blocks(labels[idx], n_long))
            cov = loewner_max(cov, cov_long * (t_ppf(0.975, n_long - 1) / tq) ** 2)
        cov, id_warnings, _ = judge(p, info, idx, cov)
    return Uncertainty(cov, tq, noise_sd, list(id_warnings), n_blocks, float(0.5 * (z * z).sum()))
