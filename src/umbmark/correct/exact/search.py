"""Where the exact fit starts, and the local fits from there.

* :func:`_bf_start`: the paper's linearised estimate, the first start.
* :func:`_heading_starts`: candidates from the mean measured heading errors (all 2 pi
  ambiguities).
* :func:`_grid_starts`: the best local minima of the cost on a global grid over the heading
  gained per leg and ``E_b,pass``.
* :func:`_valley_starts`: starts beside the grid's minima along the heading gained per leg
  alone (basins too narrow for the grid, in valleys along ``E_b,pass``).
* :func:`_ranked`: starts in the order of the cost one Gauss-Newton step from each predicts.
* :func:`_fit`: bounded local least-squares fits from the starts, in that order.
* :func:`_explains`: whether a fit explains both centres of gravity (the search stops there).
* :func:`_aliases`: the turn-angle aliases that explain the runs as well.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

from umbmark.correct.bf import bf_correction
from umbmark.correct.exact import kernel
from umbmark.correct.exact.model import FloatArray, _Problem
from umbmark.errors import CorrectionUndefined
from umbmark.metrics import umbmark_figures
from umbmark.model.runs import RunsTable

__all__: list[str] = []

# global search grid (relative to the odometry in use)
_GRID_BETA_STEP = np.pi / 105  # the cost varies with the heading gained per leg on about this scale
_GRID_BETA_MIN = 157 * _GRID_BETA_STEP  # about +-270 deg at least
_GRID_EB = np.geomspace(0.3, 4.0, 401)
_GRID_ED = (0.85, 1.15)


class _Solution(Protocol):
    """What the fit uses of a :class:`scipy.optimize.OptimizeResult`."""

    x: FloatArray
    cost: float
    status: int
    nfev: int


def _grid_beta(prob: _Problem) -> FloatArray:
    """The grid of the heading gained per leg.

    Step pi/105, wide enough for every E_d,pass in [0.85, 1.15] at the smallest E_b,pass of
    the grid (a long side on a narrow robot: the leg may curve by several turns), and at least
    +-270 deg.

    Parameters
    ----------
    prob : _Problem
        The runs.

    Returns
    -------
    numpy.ndarray
        The grid values [rad], symmetric about 0.
    """
    q = (_GRID_ED[1] - 1.0) / (_GRID_ED[1] + 1.0)
    need = 2.0 * q * prob.es * prob.side_m / (_GRID_EB[0] * prob.b)
    half = max(_GRID_BETA_MIN, need)
    k = int(math.ceil(half / _GRID_BETA_STEP))
    return _GRID_BETA_STEP * np.arange(-k, k + 1)


def _bf_start(runs: RunsTable, side_m: float, wheelbase_m: float) -> FloatArray | None:
    """The paper's estimate ``(E_d,pass, E_b,pass)`` as a start, where it is plausible.

    Parameters
    ----------
    runs : RunsTable
        The square runs.
    side_m, wheelbase_m : float
        Side of the square and the wheelbase the odometry used [m].

    Returns
    -------
    numpy.ndarray or None
        ``None`` where the paper's correction is undefined or far outside E_d in (0.5, 2),
        E_b in (0.1, 10).
    """
    try:
        bf = bf_correction(umbmark_figures(runs), side_m, wheelbase_m)
    except CorrectionUndefined:
        return None
    if not (0.5 < bf.ed_pass < 2.0 and 0.1 < bf.eb < 10.0):
        return None
    return np.array([bf.ed_pass, bf.eb])


def _heading_starts(prob: _Problem) -> list[FloatArray]:
    """Candidates from the mean heading errors alone (when measured), best first.

    Per direction ``eps_theta = 4 beta' -+ 2 pi (E_s / E_b - 1)`` (cw: -, ccw: +) with
    ``beta'`` the heading gained per leg, up to multiples of 2 pi (the headings are wrapped).

    Parameters
    ----------
    prob : _Problem
        The runs.

    Returns
    -------
    list of numpy.ndarray
        The candidates ``(E_d,pass, E_b,pass)`` in the order of :func:`_ranked`; empty without
        headings.
    """
    if not prob.heading or prob.eth is None:
        return []
    out = []
    m = []
    for mask in (prob.is_cw, ~prob.is_cw):
        e = prob.eth[mask]
        m.append(float(np.angle(np.mean(np.exp(1j * e)))))  # circular mean
    for kc in range(-2, 3):
        for kw in range(-2, 3):
            cw, ccw = m[0] + 2 * np.pi * kc, m[1] + 2 * np.pi * kw
            beta = (cw + ccw) / 8.0
            ratio = (ccw - cw) / (4 * np.pi) + 1.0  # E_s / E_b
            if ratio <= 0:
                continue
            eb = prob.es / ratio
            q = beta * eb * prob.b / (2.0 * prob.es * prob.side_m)
            if not abs(q) < 0.3 or not 0.05 < eb < 20:
                continue
            out.append(np.array([(1 + q) / (1 - q), eb]))
    return _ranked(prob, out)


def _grid(prob: _Problem) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The cost on the global grid.

    The grid spans ``E_b,pass`` in [0.3, 4] (401 points, log-spaced) and the heading gained
    per leg ``beta'`` (:func:`_grid_beta`; the cost varies with E_d on the scale of
    ``b / L``, so E_d is gridded through ``beta'``), limited to ``E_d,pass`` in [0.85, 1.15].

    Parameters
    ----------
    prob : _Problem
        The runs.

    Returns
    -------
    ED, EB : numpy.ndarray
        Shape (n_beta, n_eb): the grid's ``E_d,pass`` and ``E_b,pass``.
    grid : numpy.ndarray
        Shape (n_beta, n_eb): the sums of squared residuals (``inf`` outside the searched
        range).
    """
    key = f"grid {prob.w!r}"
    if key in prob.cache:
        cached: tuple[FloatArray, FloatArray, FloatArray] = prob.cache[key]
        return cached
    beta = _grid_beta(prob)
    BETA, EB = np.meshgrid(beta, _GRID_EB, indexing="ij")
    q = BETA * EB * prob.b / (2.0 * prob.es * prob.side_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        ED = (1.0 + q) / (1.0 - q)
    ok = (np.abs(q) < 0.5) & (ED > _GRID_ED[0]) & (ED < _GRID_ED[1])
    flat_ed, flat_eb = ED.ravel(), EB.ravel()
    cost = np.full(flat_ed.size, np.inf)
    idx_ok = np.flatnonzero(ok.ravel())
    chunk = max(1, 400000 // max(prob.n, 1))
    for i in range(0, idx_ok.size, chunk):
        sel = idx_ok[i : i + chunk]
        if prob.fast and kernel.available():
            cost[sel] = kernel.residuals_jacobian(prob, flat_ed[sel], flat_eb[sel], 0)[0]
            continue
        r = prob.weighted(prob.residuals_matrix(flat_ed[sel], flat_eb[sel]))
        cost[sel] = np.sum(r * r, axis=(1, 2))
    grid: FloatArray = cost.reshape(ED.shape)
    prob.cache[key] = (ED, EB, grid)
    return ED, EB, grid


def _local_minima(values: FloatArray, beta_only: bool = False) -> npt.NDArray[np.bool_]:
    """The finite local minima of a grid (edges padded with ``+inf``).

    Parameters
    ----------
    values : numpy.ndarray
        Shape (n_beta, n_eb).
    beta_only : bool
        Minima along ``beta'`` alone (the two neighbours along the first axis); default: in
        the 8-neighbourhood.

    Returns
    -------
    numpy.ndarray of bool
        Shape (n_beta, n_eb).
    """
    n_beta, n_eb = values.shape
    pad = np.pad(values, 1, constant_values=np.inf)
    is_min = np.isfinite(values)
    for di in (-1, 0, 1):
        for dj in (0,) if beta_only else (-1, 0, 1):
            if di or dj:
                is_min &= values <= pad[1 + di : 1 + di + n_beta, 1 + dj : 1 + dj + n_eb]
    return is_min


def _default_k(n_beta: int) -> int:
    """How many basins to keep: 8 per 315 grid values of ``beta'``, at most 128.

    Parameters
    ----------
    n_beta : int
        The number of grid values of ``beta'`` (wider grids, curlier legs, have more local
        minima).

    Returns
    -------
    int
        The number of basins.
    """
    return int(min(128, max(8, math.ceil(8 * n_beta / 315))))


def _grid_starts(prob: _Problem, k: int | None = None) -> list[FloatArray]:
    """Starts in the best basins of the cost on a global grid, best first.

    The grid: :func:`_grid`. Each local minimum of the grid stands for a basin
    (:func:`_basin_starts`).

    Parameters
    ----------
    prob : _Problem
        The runs.
    k : int or None
        How many basins to keep; default: 8 per 315 grid values of ``beta'``, at most 128.

    Returns
    -------
    list of numpy.ndarray
        The starts ``(E_d,pass, E_b,pass)``.
    """
    ED, EB, grid = _grid(prob)
    return _basin_starts(prob, ED, EB, grid, _local_minima(grid), _default_k(ED.shape[0]) if k is None else k)


def _valley_starts(prob: _Problem, k: int | None = None) -> list[FloatArray]:
    """Starts in basins that hold no local minimum of the grid, best first.

    Where a leg curves by a whole number of turns its chord vanishes and the square shrinks to
    a point whatever the turns: along such a ``beta'`` the cost hardly depends on
    ``E_b,pass``, a valley whose lowest grid sample can lie far (in E_b) from a true basin
    narrower than the grid step in ``beta'`` (legs curving by 359.4 deg at E_b 1: an 8 m square
    on a 53 mm wheelbase). The basin's samples are then minima along ``beta'`` only. These
    (the minima along ``beta'`` that are not minima of the grid) are scored like the grid's
    basins, by the lowest cost one Gauss-Newton step predicts from each or one of its eight
    neighbours (:func:`_neighbour_predictions`); of neighbouring candidates only the local
    minima of the scores count, and of those one per neighbour that gives the score. Each is
    fitted from its two neighbours along ``beta'``, the more promising first: the whole turn
    is a singular line of the model and the true basin lies on one side of it (from the
    sample on the line itself the fit slides along the valley).

    Parameters
    ----------
    prob : _Problem
        The runs.
    k : int or None
        How many starts to keep; default: as many as :func:`_grid_starts` keeps.

    Returns
    -------
    list of numpy.ndarray
        The starts ``(E_d,pass, E_b,pass)``.
    """
    ED, EB, grid = _grid(prob)
    k = _default_k(ED.shape[0]) if k is None else k
    mi, mj = np.nonzero(_local_minima(grid, beta_only=True) & ~_local_minima(grid))
    if mi.size == 0:
        return []
    pred, ni, nj = _neighbour_predictions(prob, ED, EB, grid, mi, mj)
    best = np.argmin(pred, axis=1)
    rows = np.arange(mi.size)
    score = np.full(grid.shape, np.inf)
    score[mi, mj] = pred[rows, best]
    keep = _local_minima(score)[mi, mj]
    source = (ni * grid.shape[1] + nj)[rows, best]  # the neighbour giving the score
    out: list[FloatArray] = []
    seen: set[int] = set()
    for m in np.argsort(np.where(keep, score[mi, mj], np.inf), kind="stable"):
        if len(out) >= k or not keep[m]:
            break
        if int(source[m]) in seen:
            continue
        seen.add(int(source[m]))
        # the neighbours along beta', on either side of the whole turn, the more promising first
        sides = [c for c in (1, 7) if np.isfinite(pred[m, c])]
        for c in sorted(sides, key=lambda c: pred[m, c]):
            out.append(np.array([ED[ni[m, c], nj[m, c]], EB[ni[m, c], nj[m, c]]]))
    return out


def _neighbour_predictions(
    prob: _Problem,
    ED: FloatArray,
    EB: FloatArray,
    grid: FloatArray,
    mi: npt.NDArray[np.intp],
    mj: npt.NDArray[np.intp],
) -> tuple[FloatArray, npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The cost one Gauss-Newton step predicts from each grid point and its eight neighbours.

    Parameters
    ----------
    prob : _Problem
        The runs.
    ED, EB, grid : numpy.ndarray
        Shape (n_beta, n_eb): the grid (:func:`_grid`).
    mi, mj : numpy.ndarray of int
        Shape (M,): the grid points.

    Returns
    -------
    pred : numpy.ndarray
        Shape (M, 9): the predicted sums of squared residuals (``inf`` off the grid or
        outside its searched range).
    ni, nj : numpy.ndarray of int
        Shape (M, 9): the grid indices of the nine points.
    """
    di, dj = (a.ravel() for a in np.meshgrid((-1, 0, 1), (-1, 0, 1), indexing="ij"))
    ni, nj = mi[:, None] + di[None, :], mj[:, None] + dj[None, :]  # (M, 9)
    inside = (ni >= 0) & (ni < grid.shape[0]) & (nj >= 0) & (nj < grid.shape[1])
    ni, nj = np.where(inside, ni, mi[:, None]), np.where(inside, nj, mj[:, None])
    use = inside & np.isfinite(grid[ni, nj])
    pred = np.full(ni.shape, np.inf)
    pred[use] = _gauss_newton_cost(prob, ED[ni[use], nj[use]], EB[ni[use], nj[use]])
    pred[np.isnan(pred)] = np.inf
    return pred, ni, nj


def _basin_starts(
    prob: _Problem,
    ED: FloatArray,
    EB: FloatArray,
    grid: FloatArray,
    is_min: npt.NDArray[np.bool_],
    k: int | None,
) -> list[FloatArray]:
    """One start per local minimum of the grid, the ``k`` most promising first.

    A minimum stands for its basin together with its eight grid neighbours: the basin is
    ranked by the lowest cost one Gauss-Newton step predicts from any of these nine points
    (see :func:`_ranked`), and fitted from the minimum, its lowest sample. The prediction from
    the minimum alone is not enough: where the grid is coarse for the basin (a narrow robot on
    a long side: the legs curve by whole turns, and near E_b 0.5 each turn is most sensitive to
    E_b), its lowest sample can sit where the model's linearisation sees almost no descent (a
    Jacobian more than ten times smaller than a grid step away), so one step from it predicts
    no gain while one step from a neighbour predicts the basin's floor.

    Parameters
    ----------
    prob : _Problem
        The runs.
    ED, EB : numpy.ndarray
        Shape (n_beta, n_eb): the grid's ``E_d,pass`` and ``E_b,pass``.
    grid : numpy.ndarray
        The cost on the grid (``inf`` outside the searched range).
    is_min : numpy.ndarray of bool
        The grid's local minima.
    k : int or None
        Keep the ``k`` best; ``None``: all.

    Returns
    -------
    list of numpy.ndarray
        The starts ``(E_d,pass, E_b,pass)``, best first.
    """
    mi, mj = np.nonzero(is_min)
    if mi.size == 0:
        return []
    pred, _, _ = _neighbour_predictions(prob, ED, EB, grid, mi, mj)
    order = np.argsort(pred.min(axis=1))[:k]
    return [np.array([ED[mi[m], mj[m]], EB[mi[m], mj[m]]]) for m in order]


def _ranked(prob: _Problem, starts: Sequence[FloatArray], k: int | None = None) -> list[FloatArray]:
    """The starts with the lowest cost one Gauss-Newton step from each predicts, best first.

    Not the cost at the start itself: a narrow basin sampled off its centre (E_b near 0.5,
    where each turn is most sensitive to it) must not lose to broad, shallow basins that
    merely sit near a start, nor be fitted after them (the search stops at the first fit that
    explains the runs).

    Parameters
    ----------
    prob : _Problem
        The runs.
    starts : sequence of numpy.ndarray
        Candidate ``(E_d,pass, E_b,pass)`` pairs.
    k : int or None
        Keep the ``k`` best; ``None``: all.

    Returns
    -------
    list of numpy.ndarray
        The kept starts, best first.
    """
    if len(starts) < 2:
        return list(starts)
    P = np.array(starts)
    order = np.argsort(_gauss_newton_cost(prob, P[:, 0], P[:, 1]))[:k]
    return [starts[i] for i in order]


def _gauss_newton_cost(prob: _Problem, ed: npt.ArrayLike, eb: npt.ArrayLike) -> FloatArray:
    """The least-squares cost after one Gauss-Newton step from each ``(ed, eb)``.

    The part of the residual vector the model's local linearisation cannot remove.

    Parameters
    ----------
    prob : _Problem
        The runs.
    ed, eb : array_like
        Shape (P,): the parameter pairs.

    Returns
    -------
    numpy.ndarray
        Shape (P,): the predicted sums of squared residuals.
    """
    ed = np.asarray(ed, dtype=float)
    if prob.fast:
        if kernel.available():
            r, J = kernel.residuals_jacobian(prob, ed, np.asarray(eb, dtype=float), 2)
        else:
            r, J = prob.residuals_matrix(ed, eb), prob.model_jacobian(ed, eb)
        if prob.sw is not None:  # (P, n, ncomp), (P, n, ncomp, 2): weighted
            r, J = r * prob.sw[:, None], J * prob.sw[:, None, None]
        r, J = r.reshape(ed.size, -1), J.reshape(ed.size, -1, 2)
    else:
        r = prob.weighted(prob.residuals_matrix(ed, eb)).reshape(ed.size, -1)  # (P, m)
        J = -prob.jacobian_matrix(ed, eb).reshape(ed.size, -1, 2)  # of the residuals: (P, m, 2)
    JtJ = np.einsum("pmi,pmj->pij", J, J)
    Jtr = np.einsum("pmi,pm->pi", J, r)
    ridge = 1e-12 * np.trace(JtJ, axis1=1, axis2=2)[:, None, None] * np.eye(2) + 1e-300 * np.eye(2)
    step = np.linalg.solve(JtJ + ridge, Jtr[..., None])[..., 0]
    out: FloatArray = np.sum(r * r, axis=1) - np.einsum("pi,pi->p", Jtr, step)
    return out


def _fit(
    prob: _Problem,
    starts: Sequence[FloatArray | None],
    loss: str,
    f_scale: float,
    good: Callable[[_Solution], bool] | None = None,
) -> _Solution | None:
    """Bounded local least-squares fits from each start, in the order given.

    Parameters
    ----------
    prob : _Problem
        The runs (its heading weight ``w`` as set).
    starts : sequence of numpy.ndarray
        Starts ``(E_d,pass, E_b,pass)``, fitted in this order (see :func:`_ranked`).
    loss : str
        The least-squares loss (:data:`umbmark.correct.exact.LOSSES`).
    f_scale : float
        Its scale [m].
    good : callable or None
        ``good(solution)``: stop as soon as the best solution so far passes this test.

    Where the problem has pseudo-runs (:meth:`_Problem.small`: many runs), the fits from the
    starts run on them, and the best is refitted on the runs from where it ended (few
    iterations: the pseudo-runs' minima are the runs' to second order in the spread of the
    odometry turns).

    Returns
    -------
    scipy.optimize.OptimizeResult or None
        The solution with the lowest final cost; ``None`` when no fit ended finite.
    """
    small = prob.small()
    if small is not None:
        best_small = _fit(small, starts, "linear", 1.0, good)
        if best_small is None:
            return None
        if loss == "linear" and kernel.available():
            polished = _polish(prob, best_small.x)
            if polished is not None:
                return polished
        return _fit_from(prob, [best_small.x], loss, f_scale, None)
    one = len(starts) == 1 and starts[0] is not None
    if one and prob.fast and prob.sw is None and loss == "linear" and kernel.available():
        polished = _polish(prob, np.asarray(starts[0], dtype=float))  # a start next to its minimum (bootstrap)
        if polished is not None:
            return polished
    return _fit_from(prob, starts, loss, f_scale, good)


class _Polished:
    """A least-squares solution found by :func:`_polish` (what the fit uses of one)."""

    def __init__(self, x: FloatArray, cost: float, nfev: int) -> None:
        self.x = x
        self.cost = cost
        self.status = 1
        self.nfev = nfev


_LOWER = np.array([0.5, 0.05])
_UPPER = np.array([2.0, 20.0])


def _polish(prob: _Problem, x0: FloatArray, max_iter: int = 60) -> _Polished | None:
    """The least-squares minimum next to ``x0`` (linear loss), by damped Gauss-Newton steps.

    The normal equations are summed over the runs in one compiled pass each
    (:func:`umbmark.correct.exact.kernel.residuals_jacobian`, mode 3), so a step costs one
    evaluation of the model and no residual vector is held. Steps stop when they change
    neither parameter by more than 1e-15 of its value, or by more than 1e-10 while the cost
    falls by at most 1e-15 of itself, or when no damped step lowers the cost.

    Parameters
    ----------
    prob : _Problem
        The runs.
    x0 : numpy.ndarray
        A start near the minimum (the pseudo-runs' fit).
    max_iter : int
        At most this many accepted steps.

    Returns
    -------
    _Polished or None
        ``None`` where a step would leave the bounds of the fit (the caller falls back to the
        bounded fit).
    """
    x = np.asarray(x0, dtype=float).copy()
    sums = kernel.residuals_jacobian(prob, x[:1], x[1:], 3)[0][0]
    nfev, mu = 1, 0.0
    for _ in range(max_iter):
        A = np.array([[sums[1], sums[2]], [sums[2], sums[3]]])
        g = sums[4:6]
        damp = mu * np.diag(np.diag(A))
        try:
            step = -np.linalg.solve(A + damp, g)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(step)):
            return None
        if np.all(np.abs(step) <= 1e-15 * np.abs(x)):
            break
        x_new = x + step
        if np.any(x_new <= _LOWER) or np.any(x_new >= _UPPER):
            return None
        new = kernel.residuals_jacobian(prob, x_new[:1], x_new[1:], 3)[0][0]
        nfev += 1
        if not np.isfinite(new[0]):
            return None
        if new[0] <= sums[0]:
            gain = sums[0] - new[0]
            x, sums, mu = x_new, new, 0.0
            if gain <= 1e-15 * sums[0] and np.all(np.abs(step) <= 1e-10 * np.abs(x)):
                break  # at the minimum to rounding
            continue
        if mu > 1e6:  # no descent left: at the minimum to rounding
            break
        mu = max(1e-6, 10.0 * mu)
    return _Polished(x, 0.5 * float(sums[0]), nfev)


def _fit_from(
    prob: _Problem,
    starts: Sequence[FloatArray | None],
    loss: str,
    f_scale: float,
    good: Callable[[_Solution], bool] | None,
) -> _Solution | None:
    """:func:`_fit` on the problem's own runs."""
    from scipy import optimize

    best: _Solution | None = None
    for x0 in starts:
        if best is not None and good is not None and good(best):
            break
        try:
            sol = optimize.least_squares(
                prob.residuals,
                x0,
                jac=prob.residual_jacobian if prob.fast else "3-point",
                bounds=([0.5, 0.05], [2.0, 20.0]),
                loss=loss,
                f_scale=f_scale,
                x_scale=[0.01, 0.01],
                xtol=1e-14,
                ftol=1e-14,
                gtol=1e-14,
                max_nfev=400,
            )
        except (ValueError, FloatingPointError):  # pragma: no cover - defensive
            continue
        if not np.all(np.isfinite(sol.x)):
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    return best


def _explains(prob: _Problem, sol: _Solution | None, sems: Sequence[float | None]) -> bool:
    """Whether a fit explains both centres of gravity: no need to look elsewhere.

    The allowance beyond 3 SEM, 10 nm per metre of side, is what noise-free runs leave (their
    SEM is zero): the model reproduces simulated runs, read back from a runs file, to below
    1 nm per metre. A wider allowance stops the search at near twins of the truth: where each
    turn is about 180 deg (E_b near 0.5), E_d and about 1 / E_d explain the same runs to a few
    tenths of a micrometre per metre, and the twin fitted first would be taken.

    Parameters
    ----------
    prob : _Problem
        The runs.
    sol : scipy.optimize.OptimizeResult or None
        The fit.
    sems : sequence of float or None
        The standard errors of the cw and ccw centres of gravity [m] (``None``: one run).

    Returns
    -------
    bool
        True when the model misses each centre of gravity by at most 3 SEM plus 10 nm per
        metre of side.
    """
    if sol is None:
        return False
    r = prob.residuals_matrix([sol.x[0]], [sol.x[1]])[0]
    for mask, sem in ((prob.is_cw, sems[0]), (~prob.is_cw, sems[1])):
        if sem is None:
            return False
        miss = float(np.hypot(*r[mask, :2].mean(axis=0)))
        if miss > 3.0 * sem + 1e-8 * prob.side_m:
            return False
    return True


def _aliases(prob: _Problem, sol: _Solution, loss: str, f_scale: float) -> tuple[_Solution, list[tuple[float, float]]]:
    """Other calibrations that explain the runs as well.

    The square test is blind to some: a robot that really turns 180 deg per commanded 90 deg
    with equal wheels ends exactly where a perfect one does. Probes the turn-angle aliases
    (true turn +- multiples of 90 deg).

    Parameters
    ----------
    prob : _Problem
        The runs.
    sol : scipy.optimize.OptimizeResult
        The fit found.
    loss : str
        The least-squares loss.
    f_scale : float
        Its scale [m].

    Returns
    -------
    chosen : scipy.optimize.OptimizeResult
        Of the equally good solutions, the one whose E_b is nearest 1 (the nominal wheelbase).
    alternatives : list of tuple of float
        The others, as ``(E_d,pass, E_b,pass)`` pairs.
    """
    ed, eb = sol.x
    turn = 90.0 * prob.es / eb  # true degrees per commanded 90
    cands = [90.0 * prob.es / (turn + 90.0 * k) for k in (-3, -2, -1, 1, 2, 3) if 10.0 < turn + 90.0 * k < 350.0]
    cands = [c for c in cands if 0.05 < c < 20.0]
    if not cands:
        return sol, []
    r = prob.residuals_matrix([ed], [eb])[0]
    var = []
    for mask in (prob.is_cw, ~prob.is_cw):
        if mask.sum() >= 2:
            var.append(np.mean(np.var(r[mask], axis=0, ddof=1)))
    sigma2 = float(np.mean(var)) if var else 0.0
    cost0 = 0.5 * float(np.sum(r * r))
    thr = cost0 + 2.0 * sigma2 + 1e-12 * prob.side_m**2
    rc = prob.residuals_matrix([ed] * len(cands), cands)
    costs = 0.5 * np.sum(rc * rc, axis=(1, 2))
    found = [sol]
    for c, cc in zip(cands, costs):
        if cc > 10.0 * thr:
            continue
        s2 = _fit(prob, [np.array([ed, c])], loss, f_scale)
        if s2 is None:
            continue
        r2 = prob.residuals_matrix([s2.x[0]], [s2.x[1]])[0]
        if 0.5 * float(np.sum(r2 * r2)) <= thr and all(abs(math.log(s2.x[1] / f.x[1])) > 1e-3 for f in found):
            found.append(s2)
    if len(found) == 1:
        return sol, []
    found.sort(key=lambda f: abs(math.log(f.x[1])))
    return found[0], [(float(f.x[0]), float(f.x[1])) for f in found[1:]]
