"""The closed-form model of noise-free square runs, and the runs prepared for the fit.

* :func:`square_errors`: the return errors (true - odometry end pose) a robot with given
  relative errors makes on closed-loop square runs (exact arcs, vectorised over parameter sets
  and runs).
* :func:`odometry_turns`: the odometry's four turn deviations that explain the end pose it
  reported (real controllers stop a little after each target).
* :class:`_Problem`: the runs as arrays, with the residuals ``data - model`` and the model's
  Jacobian (central differences) for many parameter pairs at once.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from umbmark.correct.exact import kernel
from umbmark.errors import CorrectionUndefined, InputError
from umbmark.model.geometry import wrap_angle
from umbmark.model.runs import RunsTable

__all__ = ["ExactFitError", "square_errors", "odometry_turns"]

FloatArray = npt.NDArray[np.floating[Any]]


class ExactFitError(CorrectionUndefined):
    """The exact fit has no trustworthy answer (degenerate runs, no convergence)."""


def square_errors(
    ed: npt.ArrayLike,
    eb: npt.ArrayLike,
    side_m: float,
    wheelbase_m: float,
    sign: npt.ArrayLike,
    es: npt.ArrayLike = 1.0,
    turn_adjust: npt.ArrayLike | Sequence[npt.ArrayLike] = 0.0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Predicted return errors (true - odometry end pose) of closed-loop square runs.

    All array arguments broadcast (numpy), so many parameter sets and many runs are evaluated
    at once.

    Parameters
    ----------
    ed, eb, es : array_like
        The true robot relative to the odometry in use: diameter ratio ``E_d,pass``, wheelbase
        ratio ``E_b,pass`` and scale ``E_s,pass`` (see :mod:`umbmark.correct.exact`).
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry uses [m].
    sign : array_like
        +1 for ccw runs, -1 for cw runs.
    turn_adjust : array_like or sequence of four array_like
        Extra odometry turn [rad] beyond the nominal 90 deg: one value for all four turns, or a
        list or tuple of four (one per turn).

    Returns
    -------
    tuple of numpy.ndarray
        ``(eps_x, eps_y, eps_theta)`` in metres and radians; ``eps_theta`` is not wrapped.

    Raises
    ------
    InputError
        ``turn_adjust`` is a list or tuple of other than four values.
    """
    if isinstance(turn_adjust, (list, tuple)):
        if len(turn_adjust) != 4:
            raise InputError("turn_adjust must be one value or four (one per turn)")
        adjs = [np.asarray(a, dtype=float) for a in turn_adjust]
    else:
        adjs = [np.asarray(turn_adjust, dtype=float)] * 4
    ed, eb, es, sign, *adjs = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (ed, eb, es, sign)), *adjs)
    k_l = 2.0 * es / (1.0 + ed)
    k_r = ed * k_l
    b_t = eb * wheelbase_m
    xt = np.zeros(ed.shape)
    yt = np.zeros(ed.shape)
    tt = np.zeros(ed.shape)
    xo = np.zeros(ed.shape)
    yo = np.zeros(ed.shape)
    to = np.zeros(ed.shape)

    def arc(x: Any, y: Any, th: Any, du: Any, dth: Any) -> tuple[Any, Any, Any]:
        c = du * np.sinc(dth / (2.0 * np.pi))
        m = th + 0.5 * dth
        return x + c * np.cos(m), y + c * np.sin(m), th + dth

    du_leg = 0.5 * (k_l + k_r) * side_m
    dth_leg = (k_r - k_l) * side_m / b_t
    for i in range(4):
        xt, yt, tt = arc(xt, yt, tt, du_leg, dth_leg)
        xo, yo, to = xo + side_m * np.cos(to), yo + side_m * np.sin(to), to
        phi = sign * (0.5 * np.pi) + adjs[i]  # the odometry's turn
        half = 0.5 * wheelbase_m * phi  # model travel of the right wheel (left: -half)
        xt, yt, tt = arc(xt, yt, tt, 0.5 * (k_r - k_l) * half, (k_r + k_l) * half / b_t)
        to = to + phi
    return xt - xo, yt - yo, tt - to


def _dsinc(x: FloatArray) -> FloatArray:
    """The derivative of :func:`numpy.sinc` (``sin(pi x) / (pi x)``), accurate near 0."""
    px = np.pi * x
    small = np.abs(px) < 1e-2
    safe = np.where(small, 1.0, x)
    with np.errstate(divide="ignore", invalid="ignore"):
        far = (np.cos(np.pi * safe) - np.sinc(safe)) / safe
    p2 = px * px
    near = -(np.pi * px / 3.0) * (1.0 - p2 / 10.0 + p2 * p2 / 280.0 - p2 * p2 * p2 / 15120.0)
    out: FloatArray = np.where(small, near, far)
    return out


def _square_errors_grad(
    ed: FloatArray,
    eb: FloatArray,
    side_m: float,
    wheelbase_m: float,
    sign: FloatArray,
    es: float,
    adjs: Sequence[FloatArray],
) -> tuple[FloatArray, FloatArray]:
    """:func:`square_errors` and its analytic derivatives with respect to ``ed`` and ``eb``.

    Forward-mode differentiation of the same arcs: every quantity is carried as an array of
    shape ``(3, ...)`` holding its value and its two partial derivatives.

    Parameters
    ----------
    ed, eb : numpy.ndarray
        ``E_d,pass`` and ``E_b,pass`` (broadcast with ``sign`` and ``adjs``).
    side_m, wheelbase_m : float
        Side of the square and the wheelbase the odometry uses [m].
    sign : numpy.ndarray
        +1 for ccw runs, -1 for cw runs.
    es : float
        ``E_s,pass``.
    adjs : sequence of four numpy.ndarray
        The odometry's extra turn of each corner [rad].

    Returns
    -------
    value : numpy.ndarray
        Shape ``(3, ...)``: ``eps_x``, ``eps_y``, ``eps_theta`` (not wrapped).
    grad : numpy.ndarray
        Shape ``(3, ..., 2)``: their derivatives with respect to ``(ed, eb)``.
    """
    ed, eb, sign, *adjs = np.broadcast_arrays(ed, eb, sign, *adjs)
    zero = np.zeros(ed.shape)
    one = np.ones(ed.shape)

    def dual(v: Any, d0: Any, d1: Any) -> FloatArray:
        return np.stack(np.broadcast_arrays(v, d0, d1))

    def mul(a: FloatArray, b: FloatArray) -> FloatArray:
        return dual(a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + a[0] * b[2])

    def chain(f: FloatArray, df: FloatArray, a: FloatArray) -> FloatArray:
        return dual(f, df * a[1], df * a[2])

    k_l = dual(2.0 * es / (1.0 + ed), -2.0 * es / (1.0 + ed) ** 2, zero)
    k_r = mul(dual(ed, one, zero), k_l)
    inv_bt = dual(1.0 / (eb * wheelbase_m), zero, -1.0 / (eb * eb * wheelbase_m))
    xt, yt, tt = (dual(zero, zero, zero) for _ in range(3))
    xo, yo, to = zero, zero, zero

    def arc(x: FloatArray, y: FloatArray, th: FloatArray, du: FloatArray, dth: FloatArray):
        u = dth / (2.0 * np.pi)
        c = mul(du, chain(np.sinc(u[0]), _dsinc(u[0]), u))
        m = th + 0.5 * dth
        cm, sm = np.cos(m[0]), np.sin(m[0])
        return x + mul(c, chain(cm, -sm, m)), y + mul(c, chain(sm, cm, m)), th + dth

    du_leg = 0.5 * side_m * (k_l + k_r)
    dth_leg = side_m * mul(k_r - k_l, inv_bt)
    for i in range(4):
        xt, yt, tt = arc(xt, yt, tt, du_leg, dth_leg)
        xo, yo = xo + side_m * np.cos(to), yo + side_m * np.sin(to)
        phi = sign * (0.5 * np.pi) + adjs[i]
        half = 0.5 * wheelbase_m * phi
        xt, yt, tt = arc(xt, yt, tt, (0.5 * half) * (k_r - k_l), mul(half * (k_r + k_l), inv_bt))
        to = to + phi
    out = np.stack([xt - np.stack([xo, zero, zero]), yt - np.stack([yo, zero, zero]), tt - np.stack([to, zero, zero])])
    return out[:, 0], np.moveaxis(out[:, 1:], 1, -1)


def odometry_turns(
    x_odo: npt.ArrayLike,
    y_odo: npt.ArrayLike,
    theta_odo: npt.ArrayLike | None,
    sign: npt.ArrayLike,
    side_m: float,
    iterations: int = 8,
) -> tuple[FloatArray, FloatArray]:
    """The odometry's four turn deviations most consistent with the end pose it reported.

    The minimum-norm deviations from the nominal 90 deg turns that put the odometry's own
    square path (legs of exactly ``side_m``) at ``(x_odo, y_odo, theta_odo)``. Real
    controllers stop a little after each target; the odometry knows it, the nominal square
    does not.

    Parameters
    ----------
    x_odo, y_odo : array_like
        The odometry's end positions [m], one per run.
    theta_odo : array_like or None
        The odometry's end headings [rad]; ``None``: not reported.
    sign : array_like
        +1 for ccw runs, -1 for cw runs (one value, or one per run).
    side_m : float
        Side of the square [m].
    iterations : int
        Damped minimum-norm Gauss-Newton steps.

    Returns
    -------
    deviations : numpy.ndarray
        Shape (n, 4): each turn's deviation [rad].
    misfit_m : numpy.ndarray
        Shape (n,): the distance between the reported end position and the one the
        reconstructed path reaches (what turns alone cannot explain).
    """
    x = np.asarray(x_odo, dtype=float)
    y = np.asarray(y_odo, dtype=float)
    n = x.size
    sgn = np.broadcast_to(np.asarray(sign, dtype=float), (n,))
    with_heading = theta_odo is not None
    columns = [x / side_m, y / side_m] + ([wrap_angle(theta_odo)] if theta_odo is not None else [])
    target = np.stack(columns, axis=-1)  # (n, m)
    d = np.zeros((n, 4))

    def f_and_jac(d: FloatArray) -> tuple[FloatArray, FloatArray]:
        phi = sgn[:, None] * (0.5 * np.pi) + d
        psi = np.concatenate([np.zeros((n, 1)), np.cumsum(phi, axis=1)[:, :3]], axis=1)  # leg headings
        c, s_ = np.cos(psi), np.sin(psi)
        fx, fy = c.sum(axis=1), s_.sum(axis=1)
        # d psi_j / d delta_i = 1 for i < j
        lower = np.tril(np.ones((4, 4)), -1)  # [j, i]
        jx = -np.einsum("nj,ji->ni", s_, lower)
        jy = np.einsum("nj,ji->ni", c, lower)
        rows_f = [fx, fy]
        rows_j = [jx, jy]
        if with_heading:
            rows_f.append(wrap_angle(np.sum(d, axis=1)))
            rows_j.append(np.ones((n, 4)))
        return np.stack(rows_f, axis=-1), np.stack(rows_j, axis=1)  # (n, m), (n, m, 4)

    for _ in range(iterations):
        f, J = f_and_jac(d)
        res = target - f
        if with_heading:
            res[:, 2] = wrap_angle(res[:, 2])
        # minimum-norm Gauss-Newton step (damped): d += J^T (J J^T + mu I)^-1 res
        JJt = np.einsum("nak,nbk->nab", J, J) + 1e-10 * np.eye(J.shape[1])
        step = np.einsum("nak,na->nk", J, np.linalg.solve(JJt, res[..., None])[..., 0])
        d = d + step
    f, _ = f_and_jac(d)
    misfit = side_m * np.hypot(target[:, 0] - f[:, 0], target[:, 1] - f[:, 1])
    return d, misfit


class _Problem:
    """The runs, prepared for the fit.

    Parameters
    ----------
    runs : RunsTable
        The square runs (both directions).
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used [m].
    es : float
        ``E_s,pass`` (1 unless a straight-line measurement gives it).
    use_heading : bool
        Fit the measured heading errors too (where the runs have them).
    heading_weight_m : float or None
        Metres of position residual one radian of heading residual counts as; ``None``: the
        side length.

    Attributes
    ----------
    w : float
        The heading weight in use (the fit's weighting steps change it).
    heading : bool
        Whether headings are fitted.
    ncomp : int
        Residual components per run: 2 (x, y) or 3 (x, y, weighted heading).
    """

    def __init__(
        self,
        runs: RunsTable,
        side_m: float,
        wheelbase_m: float,
        es: float,
        use_heading: bool,
        heading_weight_m: float | None,
    ) -> None:
        self.side_m = side_m
        self.b = wheelbase_m
        self.es = es
        d = np.asarray(runs.direction)
        self.sign = np.where(d == "ccw", 1.0, -1.0)
        self.is_cw = d == "cw"
        self.ex = np.asarray(runs.eps_x, dtype=float)
        self.ey = np.asarray(runs.eps_y, dtype=float)
        self.n = len(d)
        dev, self.odo_misfit = odometry_turns(runs.x_odo, runs.y_odo, runs.theta_odo, self.sign, side_m)
        self.dev = dev
        self.adj = [dev[None, :, i] for i in range(4)]
        eth = runs.eps_theta
        self.heading = bool(use_heading) and eth is not None
        self.eth = None if eth is None else np.asarray(eth, dtype=float)
        self.w = float(heading_weight_m if heading_weight_m is not None else side_m)
        self.ncomp = 3 if self.heading else 2
        self.fast = False  # analytic Jacobians (set by the fit for many runs)
        self.sw: FloatArray | None = None  # square roots of the runs' weights (pseudo-runs only)
        self.cache: dict[str, Any] = {}

    def weighted(self, r: FloatArray) -> FloatArray:
        """Residuals of shape ``(..., n, ncomp)`` times the square roots of the runs' weights.

        Parameters
        ----------
        r : numpy.ndarray
            Residuals, runs on the second-last axis.

        Returns
        -------
        numpy.ndarray
            ``r`` itself where every run weighs 1.
        """
        if self.sw is None:
            return r
        out: FloatArray = r * self.sw[:, None]
        return out

    def model_jacobian(self, ed: npt.ArrayLike, eb: npt.ArrayLike) -> FloatArray:
        """Analytic per-run Jacobian of the *residuals* for many parameter pairs.

        Parameters
        ----------
        ed, eb : array_like
            Shape (P,): the parameter pairs.

        Returns
        -------
        numpy.ndarray
            Shape (P, n, ncomp, 2): derivatives of ``data - model`` with respect to
            ``E_d,pass`` and ``E_b,pass`` (unweighted).
        """
        if self.fast and kernel.available():
            return kernel.residuals_jacobian(self, np.asarray(ed, dtype=float), np.asarray(eb, dtype=float), 2)[1]
        ed = np.asarray(ed, dtype=float)[:, None]
        eb = np.asarray(eb, dtype=float)[:, None]
        _, g = _square_errors_grad(ed, eb, self.side_m, self.b, self.sign[None, :], self.es, self.adj)
        comps = [-g[0], -g[1]]
        if self.heading:
            comps.append(-self.w * g[2])
        return np.stack(comps, axis=-2)

    def residual_jacobian(self, p: npt.ArrayLike) -> FloatArray:
        """The Jacobian of :meth:`residuals` at one parameter pair (analytic).

        Parameters
        ----------
        p : array_like
            ``(E_d,pass, E_b,pass)``.

        Returns
        -------
        numpy.ndarray
            Shape (n * ncomp, 2).
        """
        q = np.asarray(p, dtype=float)
        J = self.model_jacobian([q[0]], [q[1]])[0]
        if self.sw is not None:
            J = J * self.sw[:, None, None]
        return J.reshape(-1, 2)

    def small(self) -> _Problem | None:
        """The pseudo-runs of :meth:`compressed` (made once), with this problem's heading weight.

        Returns
        -------
        _Problem or None
            ``None`` unless :attr:`fast`, or where the pseudo-runs would not be fewer.
        """
        if not self.fast or self.sw is not None:
            return None
        if "small" not in self.cache:
            self.cache["small"] = self.compressed()
        q: _Problem | None = self.cache["small"]
        if q is not None:
            q.w = self.w
        return q

    def compressed(self) -> _Problem | None:
        """A few weighted pseudo-runs whose least-squares cost has the minima of these runs'.

        The model depends on a run only through its direction and its odometry turn
        deviations ``delta`` (four per run), and nearly linearly over their spread
        (milliradians). To second order in that spread the sum of squared residuals of a
        direction's ``n_d`` runs is then a constant plus a function of ``(E_d, E_b)`` that
        depends on the runs only through the means of the data ``e = (eps_x, eps_y,
        [eps_theta])`` and of ``delta``, the covariance of ``delta`` and the covariance of
        ``e`` with ``delta``. Per direction ``2 k`` pseudo-runs reproduce these:
        ``delta = mean +- sqrt(k lambda_j) u_j`` (``lambda_j, u_j``: the ``k`` eigenpairs of the
        population covariance of ``delta`` above 1e-9 of the largest and above 1e-24 rad^2) and ``e = mean +- sqrt(k
        lambda_j) B u_j`` (``B``: the regression of ``e`` on ``delta``), each of weight
        ``n_d / (2 k)``. Headings are taken about their circular mean. The constant (the
        scatter of ``e`` not explained by ``delta``) is left out: costs of the pseudo-runs
        compare with each other, not with the runs'. Where ``delta`` does not vary, one
        pseudo-run of weight ``n_d`` per direction.

        Returns
        -------
        _Problem or None
            ``None`` where it would not hold fewer runs than this problem.
        """
        parts = []
        for mask, sgn in ((self.is_cw, -1.0), (~self.is_cw, 1.0)):
            cols = [self.ex[mask], self.ey[mask]]
            if self.heading and self.eth is not None:
                th = self.eth[mask]
                cm = float(np.angle(np.mean(np.exp(1j * th))))
                cols.append(cm + wrap_angle(th - cm))
            e = np.stack(cols, axis=1)
            dv = self.dev[mask]
            nd = e.shape[0]
            e_mean, d_mean = e.mean(axis=0), dv.mean(axis=0)
            de, dd = e - e_mean, dv - d_mean
            lam, u = np.linalg.eigh(dd.T @ dd / nd)
            keep = lam > max(1e-9 * float(lam[-1]), 1e-24)  # turns that vary by more than a picoradian
            k = int(np.sum(keep))
            if k == 0:
                pe, pd, wz = e_mean[None, :], d_mean[None, :], np.array([float(nd)])
            else:
                lk, uk = lam[keep], u[:, keep]
                B = (de.T @ dd / nd) @ uk / lk  # (m, k): the regression of e on delta, in the eigenbasis
                s = np.sqrt(k * lk)
                step_d, step_e = (s * uk).T, (s * B).T  # (k, 4), (k, m)
                pd = np.concatenate([d_mean + step_d, d_mean - step_d])
                pe = np.concatenate([e_mean + step_e, e_mean - step_e])
                wz = np.full(2 * k, nd / (2.0 * k))
            parts.append((pe, pd, wz, np.full(len(wz), sgn)))
        n_small = sum(len(p[2]) for p in parts)
        if n_small >= self.n:
            return None
        q = object.__new__(_Problem)
        q.__dict__.update(self.__dict__)
        q.cache = {}
        q.sign = np.concatenate([p[3] for p in parts])
        q.is_cw = q.sign < 0
        q.n = n_small
        pe = np.concatenate([p[0] for p in parts])
        q.ex, q.ey = pe[:, 0], pe[:, 1]
        q.eth = pe[:, 2] if self.heading else None
        q.dev = np.concatenate([p[1] for p in parts])
        q.adj = [q.dev[None, :, i] for i in range(4)]
        q.odo_misfit = np.zeros(q.n)
        q.sw = np.sqrt(np.concatenate([p[2] for p in parts]))
        return q

    def residuals_matrix(self, ed: npt.ArrayLike, eb: npt.ArrayLike) -> FloatArray:
        """Residuals ``data - model`` of every run for many parameter pairs.

        Parameters
        ----------
        ed, eb : array_like
            Shape (P,): ``E_d,pass`` and ``E_b,pass`` of each pair.

        Returns
        -------
        numpy.ndarray
            Shape (P, n, ncomp).
        """
        if self.fast and kernel.available():
            return kernel.residuals_jacobian(self, np.asarray(ed, dtype=float), np.asarray(eb, dtype=float), 1)[0]
        ed = np.asarray(ed, dtype=float)[:, None]
        eb = np.asarray(eb, dtype=float)[:, None]
        px, py, pth = square_errors(ed, eb, self.side_m, self.b, self.sign[None, :], self.es, self.adj)
        comps = [self.ex[None, :] - px, self.ey[None, :] - py]
        if self.heading and self.eth is not None:
            comps.append(self.w * wrap_angle(self.eth[None, :] - pth))
        return np.stack(comps, axis=-1)

    def residuals(self, p: npt.ArrayLike) -> FloatArray:
        """The residual vector (n * ncomp) at one parameter pair ``p = (E_d,pass, E_b,pass)``.

        Parameters
        ----------
        p : array_like
            The parameter pair.

        Returns
        -------
        numpy.ndarray
            Shape (n * ncomp,).
        """
        q = np.asarray(p, dtype=float)
        return self.weighted(self.residuals_matrix([q[0]], [q[1]])[0]).ravel()

    def jacobian_matrix(self, ed: npt.ArrayLike, eb: npt.ArrayLike, h: float = 1e-7) -> FloatArray:
        """Per-run Jacobian of the *model* (central differences) for many parameter pairs.

        Parameters
        ----------
        ed, eb : array_like
            Shape (P,): the parameter pairs.
        h : float
            Relative step (at least ``h`` absolute).

        Returns
        -------
        numpy.ndarray
            Shape (P, n, ncomp, 2): derivatives with respect to ``E_d,pass`` and ``E_b,pass``.
        """
        p = [np.asarray(ed, dtype=float), np.asarray(eb, dtype=float)]
        cols = []
        for j in range(2):
            d = h * np.maximum(1.0, np.abs(p[j]))
            hi = [p[0] + d, p[1]] if j == 0 else [p[0], p[1] + d]
            lo = [p[0] - d, p[1]] if j == 0 else [p[0], p[1] - d]
            rp = self.residuals_matrix(*hi)
            rm = self.residuals_matrix(*lo)
            cols.append(-(rp - rm) / (2 * d[:, None, None]))
        return np.stack(cols, axis=-1)

    def jacobian_runs(self, p: npt.ArrayLike, h: float = 1e-7) -> FloatArray:
        """Per-run Jacobian of the *model* at one parameter pair ``p``.

        Parameters
        ----------
        p : array_like
            ``(E_d,pass, E_b,pass)``.
        h : float
            Relative step.

        Returns
        -------
        numpy.ndarray
            Shape (n, ncomp, 2).
        """
        q = np.asarray(p, dtype=float)
        return self.jacobian_matrix([q[0]], [q[1]], h)[0]
