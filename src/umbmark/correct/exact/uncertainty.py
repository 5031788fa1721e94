"""How well the runs determine the exact fit: heading weight, covariance, intervals.

* :func:`_reweigh_heading`: the heading weight from the scatter of the positions and of the
  headings about the positions-only fit (variance components).
* :func:`_interval_stats`: the delta-method covariance from each direction's scatter, with
  Welch-Satterthwaite degrees of freedom.
* :func:`_predicted_after`: the E_max,syst a robot corrected with this uncertainty would show.
* :func:`interval_figures`: the standard errors, intervals and predictions the result reports.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from umbmark.correct.exact.model import FloatArray, _Problem, square_errors
from umbmark.correct.exact.search import _fit, _Solution
from umbmark.correct.result import CorrectionIntervals

__all__ = ["interval_figures"]


def _loss_rho1(loss: str, z: FloatArray) -> FloatArray:
    """First derivative of scipy's robust loss ``rho(z)``: the IRLS weight of each residual.

    Parameters
    ----------
    loss : str
        The loss name (``linear``, ``soft_l1``, ``huber``, ``cauchy``, ``arctan``).
    z : numpy.ndarray
        Squared scaled residuals ``(r / f_scale) ** 2``.

    Returns
    -------
    numpy.ndarray
        The weights, the shape of ``z``.
    """
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1e-300)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z * z)
    return np.ones_like(z)


def _reweigh_heading(prob: _Problem, sol: _Solution, loss: str, f_scale: float) -> tuple[_Solution, float]:
    """Weigh the headings by how well they agree with the model (variance components).

    Fits the positions alone (from ``sol``), then estimates the residual scatter of the
    positions (``sigma_pos``, per axis, 2 n - 2 degrees of freedom) and of the headings about
    that fit (``sigma_theta``, n degrees of freedom; any systematic disagreement of the
    headings with the model counts as scatter). The heading weight becomes
    ``min(side, sigma_pos / sigma_theta)`` metres per radian: never more than the default (the
    side), less when the headings are noisier than the positions suggest or disagree with
    them (a real robot: heading measured by a motion-capture system, turns that slip
    differently from the legs). Noise-free runs keep the side.

    Parameters
    ----------
    prob : _Problem
        The runs; its heading weight ``w`` is set to the new weight.
    sol : scipy.optimize.OptimizeResult
        The fit with the current weight.
    loss : str
        The least-squares loss.
    f_scale : float
        Its scale [m].

    Returns
    -------
    solution : scipy.optimize.OptimizeResult
        The fit with the new weight (``sol`` when the weight stays).
    weight : float
        The heading weight used [m/rad].
    """
    w0 = prob.w
    prob.w = 0.0
    try:
        sp = _fit(prob, [sol.x], loss, f_scale)
    finally:
        prob.w = w0
    if sp is None:
        return sol, w0
    r = prob.residuals_matrix([sp.x[0]], [sp.x[1]])[0]
    n = prob.n
    s_pos = math.sqrt(float(np.sum(r[:, :2] ** 2)) / max(2 * n - 2, 1))
    s_th = math.sqrt(float(np.sum((r[:, 2] / w0) ** 2)) / n)
    tiny = 1e-9 * prob.side_m
    if not (math.isfinite(s_pos) and math.isfinite(s_th)) or s_th * w0 <= max(s_pos, tiny):
        return sol, w0
    w = s_pos / s_th
    prob.w = w
    sol2 = _fit(prob, [sp.x, sol.x], loss, f_scale)
    if sol2 is None:  # pragma: no cover - defensive
        prob.w = w0
        return sol, w0
    return sol2, w


def _interval_stats(
    prob: _Problem, p: npt.ArrayLike, weights: FloatArray | None = None
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
    """Delta-method covariance from per-direction scatter, and Satterthwaite dof per parameter.

    ``Cov = H^-1 (sum_i J_i^T S_d(i) J_i) H^-1`` with ``H = sum_i J_i^T J_i`` and ``S_d`` the
    sample covariance (ddof 1) of the residuals of direction d.

    Parameters
    ----------
    prob : _Problem
        The runs.
    p : array_like
        The fitted ``(E_d,pass, E_b,pass)``.
    weights : numpy.ndarray or None
        Shape (n, ncomp): IRLS weights of a robust loss (:func:`_loss_rho1`); ``None``: linear.

    Returns
    -------
    tuple of numpy.ndarray or None
        ``(cov, dof, J, H)``: the 2 x 2 covariance, the degrees of freedom of each parameter,
        the per-run Jacobian and the Gauss-Newton matrix; ``None`` with fewer than 2 runs in a
        direction or an ill-conditioned fit.
    """
    q = np.asarray(p, dtype=float)
    J = prob.jacobian_runs(q)  # (n, c, 2)
    r = prob.residuals_matrix([q[0]], [q[1]])[0]  # (n, c)
    if weights is not None:
        sw = np.sqrt(weights)  # (n, c)
        J = J * sw[..., None]
        r = r * sw
    H = np.einsum("ncj,nck->jk", J, J)
    try:
        Hinv = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(Hinv)) or np.linalg.cond(H) > 1e14:
        return None
    parts = []
    dofs = []
    for mask in (prob.is_cw, ~prob.is_cw):
        nd = int(mask.sum())
        if nd < 2:
            return None
        rd = r[mask]
        S = np.cov(rd, rowvar=False, ddof=1).reshape(prob.ncomp, prob.ncomp)
        M = np.einsum("ncj,cd,ndk->jk", J[mask], S, J[mask])
        parts.append(Hinv @ M @ Hinv)
        dofs.append(nd - 1)
    cov = parts[0] + parts[1]
    v = np.array([[parts[0][j, j], parts[1][j, j]] for j in range(2)])  # (param, direction)
    df = np.empty(2)
    for j in range(2):
        num = v[j].sum() ** 2
        den = v[j, 0] ** 2 / dofs[0] + v[j, 1] ** 2 / dofs[1]
        df[j] = num / den if den > 0 else float(sum(dofs))
    return cov, df, J, H


def _predicted_after(
    prob: _Problem, p: FloatArray, cov: FloatArray, sem: Sequence[float | None]
) -> tuple[float, float]:
    """Predicted E_max,syst after correction [m].

    The centre of gravity a robot whose remaining relative errors are distributed with
    ``cov`` would show, RMS (systematic part), and combined with the sampling error of n fresh
    runs per direction (``sem``).

    Parameters
    ----------
    prob : _Problem
        The runs.
    p : numpy.ndarray
        The fitted ``(E_d,pass, E_b,pass)``.
    cov : numpy.ndarray
        Their 2 x 2 covariance.
    sem : sequence of float or None
        The standard errors of the cw and ccw centres of gravity [m].

    Returns
    -------
    tuple of float
        ``(systematic, with_sampling)`` [m], the larger of the two directions each.
    """
    side, b = prob.side_m, prob.b * p[1]
    h = 1e-6
    out_syst, out_meas = [], []
    for sgn, s in ((-1.0, sem[0]), (1.0, sem[1])):
        base = np.array(square_errors(1.0, 1.0, side, b, sgn)[:2])
        g = []
        for j in range(2):
            e = [1.0, 1.0]
            e[j] += h
            g.append((np.array(square_errors(e[0], e[1], side, b, sgn)[:2]) - base) / h)
        G = np.stack(g, axis=1)  # (2, 2)
        # relative errors after correction: ed_true/ed_hat, eb_true/eb_hat ~ 1 +- cov / p^2
        rel_cov = cov / np.outer(p, p)
        ms = float(np.trace(G @ rel_cov @ G.T))
        out_syst.append(math.sqrt(max(ms, 0.0)))
        out_meas.append(math.sqrt(max(ms, 0.0) + (s or 0.0) ** 2))
    return max(out_syst), max(out_meas)


def interval_figures(
    prob: _Problem,
    p: FloatArray,
    weights: FloatArray | None,
    sems: Sequence[float | None],
    prior_ed: float,
    wheelbase_m: float,
    confidence: float,
) -> tuple[CorrectionIntervals | None, list[str]]:
    """Standard errors, confidence intervals and the predicted E_max,syst after correction.

    Parameters
    ----------
    prob : _Problem
        The runs.
    p : numpy.ndarray
        The fitted ``(E_d,pass, E_b,pass)``.
    weights : numpy.ndarray or None
        IRLS weights of a robust loss; ``None``: linear.
    sems : sequence of float or None
        The standard errors of the cw and ccw centres of gravity [m].
    prior_ed : float
        E_d of the calibration the runs were made with (the intervals of E_d are composed
        with it).
    wheelbase_m : float
        The wheelbase the odometry used [m].
    confidence : float
        Confidence level of the intervals.

    Returns
    -------
    intervals : CorrectionIntervals or None
        None where the runs give no intervals.
    warnings : list of str
        No intervals, or intervals too wide.
    """
    from umbmark._stats import t_ppf

    ist = _interval_stats(prob, p, weights)
    if ist is None:
        return None, ["no confidence intervals: they need at least 2 runs in each direction and a well-conditioned fit"]
    ed_pass, eb_pass = float(p[0]), float(p[1])
    cov, df, _, _ = ist
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    q = [t_ppf(0.5 + confidence / 2.0, float(d)) for d in np.atleast_1d(df)]
    ed_lo, ed_hi = ed_pass - q[0] * se[0], ed_pass + q[0] * se[0]
    eb_lo, eb_hi = eb_pass - q[1] * se[1], eb_pass + q[1] * se[1]
    syst, meas = _predicted_after(prob, p, cov, sems)
    figures = CorrectionIntervals(
        ed_se=float(se[0] * prior_ed),
        eb_se=float(se[1]),
        ed=(float(ed_lo * prior_ed), float(ed_hi * prior_ed)),
        ed_pass=(float(ed_lo), float(ed_hi)),
        eb=(float(eb_lo), float(eb_hi)),
        wheelbase_m=(float(eb_lo * wheelbase_m), float(eb_hi * wheelbase_m)),
        dof=(float(df[0]), float(df[1])),
        ed_eb_corr=float(cov[0, 1] / (se[0] * se[1])) if se[0] > 0 and se[1] > 0 else None,
        emax_syst_after_pred_m=syst,
        emax_syst_after_pred_measured_m=meas,
        confidence=confidence,
    )
    warns = []
    if (eb_hi - eb_lo) > 0.05 * eb_pass or (ed_hi - ed_lo) > 0.01:
        warns.append(
            f"the runs determine the calibration poorly (E_d {ed_lo * prior_ed:.4f} to "
            f"{ed_hi * prior_ed:.4f}, E_b {eb_lo:.3f} to {eb_hi:.3f}): too few runs or too much "
            "scatter"
        )
    return figures, warns
