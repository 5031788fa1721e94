"""Exact (non-linearised) calibration, method ``exact`` (issue 7).

The paper's correction (method ``bf``) linearises: small angles, E_d ignored in the turns,
E_d and E_b treated as independent. Method ``exact`` instead fits the full noise-free
closed-loop model of the square runs to every run by non-linear least squares
(:func:`scipy.optimize.least_squares`).

Model (the same as the simulator with ``Motion(sample_period_s=None)`` and no noise): the
robot drives each segment until its *odometry* says it is done; the true robot moves with its
true geometry. Relative to the odometry the runs were made with (prior calibration and the
wheelbase it used), the true robot is described by

* ``E_d,pass = k_R / k_L`` and ``E_s,pass = (k_L + k_R) / 2``, where ``k = true ground travel
  per pulse / odometry's travel per pulse`` of each wheel;
* ``E_b,pass = b_true / b_odometry``.

A leg of length L: the odometry commands L of travel on both wheels, the true wheels roll
``k_L L`` and ``k_R L`` (one exact arc). An on-the-spot turn through phi: the odometry
commands ``-+ phi b / 2``, the true wheels roll ``k`` times that (an arc about a turn centre
shifted off the axle midpoint when ``k_L != k_R``). The predicted return error of a run is
``true end pose - odometry end pose`` (x, y, and heading when measured).

Real controllers stop a little after each target, so the odometry's own path is not the
nominal square: its reported end pose (``x_odo``, ``y_odo`` and ``theta_odo`` when given) is
explained by the minimum-norm deviations of its four turns (:func:`odometry_turns`), and the
model drives those turns. Where the measured headings (``theta_abs`` and
``theta_odo``) are given, their difference is fitted too, weighted by ``heading_weight_m``
metres per radian. Default: weighed by the data (variance components,
:func:`_reweigh_heading`): ``min(side, sigma_pos / sigma_theta)`` with the scatter of the
positions and of the headings about the positions-only fit, so headings that are noisier
than the positions, or disagree with them systematically, count less (a real robot's
motion-capture headings: the optiodom 1.7 m squares, where the fixed weight of one side
left 27 mm after correction instead of 4 mm). The side length (a heading error counts like
the lateral miss it causes over one leg) stays the upper limit and the weight of
noise-free runs.

E_s is invisible on a closed square (it only scales the square); it is 1 unless the user
gives a straight-line distance measurement (``straight_m=(odometry_m, measured_m)``), in
which case ``E_s,pass = measured / odometry`` and both correction factors are scaled by it.

Start values: the bf estimate first. Where the fit from there does not explain both centres
of gravity to within 3 SEM (bf is far off: large errors, skid-steer robots whose effective
wheelbase is 1.5 to 2.5 times the track), a global search follows, in two stages until one
explains the runs: candidates from the mean measured headings (``eps_theta = 4 beta' -+ 2 pi
(E_s / E_b - 1)``, all 2 pi ambiguities), then the best local minima of a grid over
the heading gained per leg (step pi/105, at least +-270 deg and as wide as E_d,pass in [0.85, 1.15]
needs at E_b,pass 0.3: several turns per leg for a long side on a narrow robot) x ``E_b,pass`` in
[0.3, 4] (401 points), only where E_d,pass is in [0.85, 1.15], ranked by the cost one
Gauss-Newton step from each predicts (a narrow true basin sampled off its centre must not lose
to broad shallow ones). The lowest final cost wins. ``global_search=True`` always searches, ``False`` never.

Uncertainty (delta method with per-direction scatter, documented in the README): the
least-squares estimate depends on the runs only through each direction's mean residual, so
``Cov = H^-1 (sum_i J_i^T S_d(i) J_i) H^-1`` with ``H = sum_i J_i^T J_i`` (Gauss-Newton, J
the model's Jacobian per run) and ``S_d`` the sample covariance (ddof 1) of the runs of
direction d about their mean. Each variance is a sum of one scaled chi-square per direction;
the 95 % interval uses Student's t with the Welch-Satterthwaite degrees of freedom. With a
robust loss the same formula is applied to the loss-weighted residuals (approximate).
"""

from __future__ import annotations

import math
import warnings as _warnings

import numpy as np
from scipy import optimize, stats

from umbmark.correct.bf import _check_geometry, bf_correction
from umbmark.correct.registry import register
from umbmark.correct.result import CorrectionResult, compose
from umbmark.errors import CorrectionUndefined, InputError
from umbmark.metrics import umbmark
from umbmark.model.geometry import Calibration

__all__ = [
    "square_errors",
    "exact_correction",
    "ExactFitError",
    "LOSSES",
]

LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")

# global search grid (relative to the odometry in use)
_GRID_BETA_STEP = np.pi / 105  # the cost varies with the heading gained per leg on about this scale
_GRID_BETA_MIN = 157 * _GRID_BETA_STEP  # about +-270 deg at least
_GRID_EB = np.geomspace(0.3, 4.0, 401)
_GRID_ED = (0.85, 1.15)


def _grid_beta(prob) -> np.ndarray:
    """The grid of the heading gained per leg: step pi/105, wide enough for every E_d,pass in
    [0.85, 1.15] at the smallest E_b,pass of the grid (a long side on a narrow robot: the leg may
    curve by several turns), and at least +-270 deg."""
    q = (_GRID_ED[1] - 1.0) / (_GRID_ED[1] + 1.0)
    need = 2.0 * q * prob.es * prob.side_m / (_GRID_EB[0] * prob.b)
    half = max(_GRID_BETA_MIN, need)
    k = int(math.ceil(half / _GRID_BETA_STEP))
    return _GRID_BETA_STEP * np.arange(-k, k + 1)


class ExactFitError(CorrectionUndefined):
    """The exact fit has no trustworthy answer (degenerate runs, no convergence)."""


def _wrap(a):
    return np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi) - np.pi


def square_errors(ed, eb, side_m, wheelbase_m, sign, es=1.0, turn_adjust=0.0):
    """Predicted return errors (true - odometry end pose) of closed-loop square runs.

    ``ed``, ``eb``, ``es``: the true robot relative to the odometry in use (see the module
    docstring); ``sign``: +1 for ccw runs, -1 for cw runs; ``turn_adjust``: extra odometry
    turn [rad] beyond the nominal 90 deg, either one value (array) for all four turns or a
    sequence of four (one per turn). All arguments broadcast (numpy), so many parameter sets
    and many runs are evaluated at once.

    Returns ``(eps_x, eps_y, eps_theta)`` in metres / radians; ``eps_theta`` is not wrapped.
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

    def arc(x, y, th, du, dth):
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


def odometry_turns(x_odo, y_odo, theta_odo, sign, side_m, iterations: int = 8):
    """The odometry's four turn deviations (rad, shape (n, 4)) most consistent with the end
    pose it reported: the minimum-norm deviations from the nominal 90 deg turns that put the
    odometry's own square path (legs of exactly ``side_m``) at ``(x_odo, y_odo, theta_odo)``
    (``theta_odo`` may be ``None``: not reported). Real controllers stop a little after each
    target; the odometry knows it, the nominal square does not.

    Returns ``(deviations, misfit_m)``: misfit is the distance between the reported end
    position and the one the reconstructed path reaches (what turns alone cannot explain).
    """
    x = np.asarray(x_odo, dtype=float)
    y = np.asarray(y_odo, dtype=float)
    n = x.size
    sgn = np.broadcast_to(np.asarray(sign, dtype=float), (n,))
    with_heading = theta_odo is not None
    target = [x / side_m, y / side_m] + ([_wrap(theta_odo)] if with_heading else [])
    target = np.stack(target, axis=-1)  # (n, m)
    d = np.zeros((n, 4))

    def f_and_jac(d):
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
            rows_f.append(_wrap(np.sum(d, axis=1)))
            rows_j.append(np.ones((n, 4)))
        return np.stack(rows_f, axis=-1), np.stack(rows_j, axis=1)  # (n, m), (n, m, 4)

    for _ in range(iterations):
        f, J = f_and_jac(d)
        res = target - f
        if with_heading:
            res[:, 2] = _wrap(res[:, 2])
        # minimum-norm Gauss-Newton step (damped): d += J^T (J J^T + mu I)^-1 res
        JJt = np.einsum("nak,nbk->nab", J, J) + 1e-10 * np.eye(J.shape[1])
        step = np.einsum("nak,na->nk", J, np.linalg.solve(JJt, res[..., None])[..., 0])
        d = d + step
    f, _ = f_and_jac(d)
    misfit = side_m * np.hypot(target[:, 0] - f[:, 0], target[:, 1] - f[:, 1])
    return d, misfit


class _Problem:
    """The runs, prepared for the fit."""

    def __init__(self, runs, side_m, wheelbase_m, es, use_heading, heading_weight_m):
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

    def residuals_matrix(self, ed, eb):
        """(P, n, ncomp) residuals data - model for arrays ed, eb of shape (P,)."""
        ed = np.asarray(ed, dtype=float)[:, None]
        eb = np.asarray(eb, dtype=float)[:, None]
        px, py, pth = square_errors(ed, eb, self.side_m, self.b, self.sign[None, :], self.es, self.adj)
        comps = [self.ex[None, :] - px, self.ey[None, :] - py]
        if self.heading:
            comps.append(self.w * _wrap(self.eth[None, :] - pth))
        return np.stack(comps, axis=-1)

    def residuals(self, p):
        return self.residuals_matrix([p[0]], [p[1]])[0].ravel()

    def jacobian_matrix(self, ed, eb, h=1e-7):
        """Per-run Jacobian of the *model* (P, n, ncomp, 2) at arrays ed, eb of shape (P,),
        central differences."""
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

    def jacobian_runs(self, p, h=1e-7):
        """Per-run Jacobian of the *model* (n, ncomp, 2) at one parameter pair ``p``."""
        return self.jacobian_matrix([p[0]], [p[1]], h)[0]


def _bf_start(runs, side_m, wheelbase_m):
    try:
        bf = bf_correction(umbmark(runs), side_m, wheelbase_m)
    except CorrectionUndefined:
        return None
    if not (0.5 < bf.ed_pass < 2.0 and 0.1 < bf.eb < 10.0):
        return None
    return np.array([bf.ed_pass, bf.eb])


def _heading_starts(prob: _Problem):
    """Candidates from the mean heading errors alone (when measured): per direction
    ``eps_theta = 4 beta' -+ 2 pi (E_s / E_b - 1)`` (cw: -, ccw: +) with ``beta'`` the heading
    gained per leg, up to multiples of 2 pi (the headings are wrapped)."""
    if not prob.heading:
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


def _grid_starts(prob: _Problem, k: int | None = None):
    """The ``k`` best (:func:`_ranked`) local minima (default: 8 per 315 grid values of ``beta'``) of the
    cost on a global grid over ``E_b,pass`` in
    [0.3, 4] (401 points, log-spaced) and the heading gained per leg ``beta'`` (:func:`_grid_beta`;
    the cost varies with E_d on the scale of ``b / L``, so E_d is gridded through ``beta'``),
    limited to ``E_d,pass`` in [0.85, 1.15]."""
    beta = _grid_beta(prob)
    if k is None:  # wider grids (curlier legs) have more local minima: keep more of them
        k = int(min(128, max(8, math.ceil(8 * beta.size / 315))))
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
        r = prob.residuals_matrix(flat_ed[sel], flat_eb[sel])
        cost[sel] = np.sum(r * r, axis=(1, 2))
    cost = cost.reshape(ED.shape)
    # local minima on the grid (8-neighbourhood, edges padded with +inf)
    pad = np.pad(cost, 1, constant_values=np.inf)
    is_min = np.isfinite(cost)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                is_min &= cost <= pad[1 + di : 1 + di + cost.shape[0], 1 + dj : 1 + dj + cost.shape[1]]
    idx = np.flatnonzero(is_min.ravel())
    return _ranked(prob, [np.array([flat_ed[i], flat_eb[i]]) for i in idx], k)


def _ranked(prob: _Problem, starts, k: int | None = None):
    """The ``k`` (default: all) starts with the lowest cost one Gauss-Newton step from each
    predicts, best first. Not the cost at the start itself: a narrow basin sampled off its
    centre (E_b near 0.5, where each turn is most sensitive to it) must not lose to broad,
    shallow basins that merely sit near a start, nor be fitted after them (the search stops at
    the first fit that explains the runs)."""
    if len(starts) < 2:
        return list(starts)
    P = np.array(starts)
    order = np.argsort(_gauss_newton_cost(prob, P[:, 0], P[:, 1]))[:k]
    return [starts[i] for i in order]


def _gauss_newton_cost(prob: _Problem, ed, eb) -> np.ndarray:
    """The least-squares cost after one Gauss-Newton step from each ``(ed, eb)``: the part of
    the residual vector the model's local linearisation cannot remove."""
    ed = np.asarray(ed, dtype=float)
    r = prob.residuals_matrix(ed, eb).reshape(ed.size, -1)  # (P, m)
    J = -prob.jacobian_matrix(ed, eb).reshape(ed.size, -1, 2)  # of the residuals: (P, m, 2)
    JtJ = np.einsum("pmi,pmj->pij", J, J)
    Jtr = np.einsum("pmi,pm->pi", J, r)
    ridge = 1e-12 * np.trace(JtJ, axis1=1, axis2=2)[:, None, None] * np.eye(2) + 1e-300 * np.eye(2)
    step = np.linalg.solve(JtJ + ridge, Jtr[..., None])[..., 0]
    return np.sum(r * r, axis=1) - np.einsum("pi,pi->p", Jtr, step)


def _fit(prob: _Problem, starts, loss: str, f_scale: float, good=None):
    """Local fits from each start, in the order given (see :func:`_ranked`); the lowest final
    cost wins. ``good(sol)``: stop early as soon as a solution passes this test."""
    best = None
    for x0 in starts:
        if best is not None and good is not None and good(best):
            break
        try:
            sol = optimize.least_squares(
                prob.residuals,
                x0,
                jac="3-point",
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


def _reweigh_heading(prob: _Problem, sol, loss, f_scale):
    """Weigh the headings by how well they agree with the model (variance components).

    Fits the positions alone (from ``sol``), then estimates the residual scatter of the
    positions (``sigma_pos``, per axis, 2 n - 2 degrees of freedom) and of the headings about
    that fit (``sigma_theta``, n degrees of freedom; any systematic disagreement of the
    headings with the model counts as scatter). The heading weight becomes
    ``min(side, sigma_pos / sigma_theta)`` metres per radian: never more than the default (the
    side), less when the headings are noisier than the positions suggest or disagree with
    them (a real robot: heading measured by a motion-capture system, turns that slip
    differently from the legs). Noise-free runs keep the side. Returns the new solution (or
    ``sol`` when the weight stays) and the weight used."""
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


def _aliases(prob: _Problem, sol, loss, f_scale):
    """Other calibrations that explain the runs as well (the square test is blind to some: a
    robot that really turns 180 deg per commanded 90 deg with equal wheels ends exactly where
    a perfect one does). Probes the turn-angle aliases (true turn +- multiples of 90 deg).

    Returns ``(chosen, alternatives)``: the chosen solution is the one whose E_b is nearest
    1 (the nominal wheelbase); alternatives are ``(E_d, E_b)`` pairs."""
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


def _explains(prob: _Problem, sol, sems) -> bool:
    """True when a fit explains both centres of gravity to within 3 SEM (noise-free: to within
    a micrometre per metre of side): no need to look elsewhere."""
    if sol is None:
        return False
    r = prob.residuals_matrix([sol.x[0]], [sol.x[1]])[0]
    for mask, sem in ((prob.is_cw, sems[0]), (~prob.is_cw, sems[1])):
        if sem is None:
            return False
        miss = float(np.hypot(*r[mask, :2].mean(axis=0)))
        if miss > 3.0 * sem + 1e-6 * prob.side_m:
            return False
    return True


def _interval_stats(prob: _Problem, p, weights=None):
    """Delta-method covariance from per-direction scatter, and Satterthwaite dof per parameter."""
    J = prob.jacobian_runs(p)  # (n, c, 2)
    r = prob.residuals_matrix([p[0]], [p[1]])[0]  # (n, c)
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


def _predicted_after(prob: _Problem, p, cov, sem):
    """Predicted E_max,syst after correction [m]: the centre of gravity a robot whose
    remaining relative errors are distributed with ``cov`` would show, RMS (systematic part),
    and combined with the sampling error of n fresh runs per direction (``sem``)."""
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


def exact_correction(
    runs,
    side_m: float,
    wheelbase_m: float,
    prior: Calibration | None = None,
    *,
    loss: str = "linear",
    f_scale_m: float | None = None,
    use_heading: bool = True,
    heading_weight_m: float | None = None,
    straight_m: tuple[float, float] | None = None,
    global_search="auto",
    confidence: float = 0.95,
) -> CorrectionResult:
    """Exact calibration from square runs (see the module docstring).

    ``wheelbase_m``: the wheelbase the odometry used during the runs; ``prior``: the
    correction factors the robot ran with. ``loss``: least-squares loss (``linear``, or a
    robust one: ``soft_l1``, ``huber``, ``cauchy``, ``arctan``) with scale ``f_scale_m``
    (default: the median per-direction spread of the runs). ``straight_m``: (odometry
    distance, measured distance) of a straight-line run, to estimate E_s.
    """
    _check_geometry(side_m, wheelbase_m)
    if loss not in LOSSES:
        raise InputError(f"unknown loss {loss!r} (choose from {', '.join(LOSSES)})")
    if not (0.5 < confidence < 1.0):
        raise InputError(f"confidence must be between 0.5 and 1, got {confidence!r}")
    n_cw = int(np.sum(runs.direction == "cw"))
    n_ccw = int(np.sum(runs.direction == "ccw"))
    if n_cw == 0 or n_ccw == 0:
        missing = "cw" if n_cw == 0 else "ccw"
        raise ExactFitError(
            f"no {missing} runs: the exact fit needs runs in both directions (E_d and E_b cannot be "
            "told apart from one direction)"
        )
    warns: list[str] = []
    es = 1.0
    if straight_m is not None:
        odo_d, meas_d = (float(v) for v in straight_m)
        if not (math.isfinite(odo_d) and math.isfinite(meas_d) and odo_d > 0 and meas_d > 0):
            raise InputError(f"straight-line measurement must be two positive distances, got {straight_m!r}")
        es = meas_d / odo_d
        if abs(es - 1.0) > 0.2:
            raise InputError(f"straight-line measurement gives E_s = {es:.4f} (more than 20 % off): check the units")

    prob = _Problem(runs, side_m, wheelbase_m, es, use_heading, heading_weight_m)
    # runs that do not close: the odometry must report the end near the start
    odo_off = np.hypot(runs.x_odo, runs.y_odo)
    if np.max(odo_off) > 0.25 * side_m:
        i = int(np.argmax(odo_off))
        raise ExactFitError(
            f"run {runs.run[i] if runs.run is not None else i + 1} does not close: its odometry ends "
            f"{odo_off[i] * 1e3:.0f} mm from the start (side {side_m * 1e3:.0f} mm); is this a UMBmark square run?"
        )
    if runs.theta_odo is not None and np.max(np.abs(_wrap(runs.theta_odo))) > math.radians(30):
        raise ExactFitError(
            "a run's odometry heading ends more than 30 deg from the start heading: the runs do not "
            "close (is this a UMBmark square run, and theta_odo in degrees?)"
        )
    if np.max(np.abs(prob.dev)) > math.radians(10) or np.max(prob.odo_misfit) > 0.02 * side_m:
        warns.append(
            f"the odometry of some runs ends far from the start ({np.max(odo_off) * 1e3:.0f} mm): the model "
            "explains it by turn over/undershoot of up to "
            f"{math.degrees(np.max(np.abs(prob.dev))):.1f} deg, leaving {np.max(prob.odo_misfit) * 1e3:.0f} "
            "mm unexplained"
        )

    # robust scale: median per-direction radial spread (or a tenth of a per cent of the side)
    spreads = []
    for mask in (prob.is_cw, ~prob.is_cw):
        if mask.sum() >= 2:
            spreads.append(math.hypot(np.std(prob.ex[mask], ddof=1), np.std(prob.ey[mask], ddof=1)) / math.sqrt(2))
    f_scale = float(f_scale_m) if f_scale_m is not None else (float(np.median(spreads)) if spreads else 0.0)
    if f_scale <= 0 or not math.isfinite(f_scale):
        f_scale = 1e-3 * side_m
    if loss == "linear":
        f_scale = 1.0

    st = umbmark(runs)
    sems = [st.cw.sem, st.ccw.sem]
    if global_search not in ("auto", True, False):
        raise InputError(f"global_search must be 'auto', True or False, got {global_search!r}")
    bf0 = _bf_start(runs, side_m, wheelbase_m)
    with np.errstate(all="ignore"), _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        sol = _fit(prob, [bf0], loss, f_scale) if bf0 is not None else None
        reweigh = prob.heading and heading_weight_m is None
        if reweigh and sol is not None and global_search != True:  # noqa: E712 (True, not 1)
            # headings that disagree with the positions must not send the fit searching:
            # weigh them by their agreement first; search only if that does not explain the runs
            sol_rw, w_rw = _reweigh_heading(prob, sol, loss, f_scale)
            if _explains(prob, sol_rw, sems):
                sol, reweigh = sol_rw, False
            else:
                prob.w = float(side_m)
        searched = False
        # global search in two stages: candidates from the headings (cheap), then the grid
        for stage in (_heading_starts, _grid_starts):
            if global_search is False or (global_search == "auto" and _explains(prob, sol, sems)):
                break
            searched = True
            sol2 = _fit(
                prob,
                stage(prob),
                loss,
                f_scale,
                good=(lambda q: _explains(prob, q, sems)) if global_search == "auto" else None,
            )
            if sol is None or (sol2 is not None and sol2.cost < sol.cost):
                sol = sol2
    if sol is None or sol.status <= 0:
        raise ExactFitError(
            "the exact fit did not converge (no finite solution from any start); check the runs, the "
            "side length, the wheelbase and the units"
        )
    alternatives = []
    with np.errstate(all="ignore"), _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        if reweigh:
            sol, _ = _reweigh_heading(prob, sol, loss, f_scale)
        sol, alternatives = _aliases(prob, sol, loss, f_scale)
    p = sol.x
    if alternatives:
        alt = "; ".join(
            f"E_d {a[0]:.6f}, E_b {a[1]:.6f} (a robot turning {90.0 * es / a[1]:.0f} deg per commanded 90 deg)"
            for a in alternatives
        )
        warns.append(
            f"ambiguous: {alt} would produce the same runs (the square test cannot tell them apart); the "
            f"answer assumes the robot visibly turned about {90.0 * es / p[1]:.0f} deg at each corner"
        )
    for j, (lo, hi, name) in enumerate(((0.5, 2.0, "E_d"), (0.05, 20.0, "E_b"))):
        if min(p[j] - lo, hi - p[j]) < 1e-6 * (hi - lo):
            raise ExactFitError(
                f"the exact fit ran into the bound of {name} ({p[j]:.4g}): no plausible calibration "
                "explains these runs; check the side length, wheelbase and units"
            )
    ed_pass, eb_pass = float(p[0]), float(p[1])

    # goodness of fit: does the model explain the centres of gravity?
    r = prob.residuals_matrix([ed_pass], [eb_pass])[0]
    for mask, sem, name in ((prob.is_cw, sems[0], "cw"), (~prob.is_cw, sems[1], "ccw")):
        miss = float(np.hypot(*r[mask, :2].mean(axis=0)))
        ref = sem if sem is not None and sem > 0 else None
        if ref is not None and miss > 5.0 * ref and miss > 1e-4 * side_m:
            warns.append(
                f"the model misses the {name} centre of gravity by {miss * 1e3:.1f} mm ({miss / ref:.1f} x its "
                "SEM): the runs may not follow the closed-loop square model (outliers? use a robust loss)"
            )

    # outlier runs: far from the other runs of their direction (robust scale)
    for mask, name in ((prob.is_cw, "cw"), (~prob.is_cw, "ccw")):
        if mask.sum() >= 4:
            rd = r[mask, :2]
            dist = np.hypot(*(rd - np.median(rd, axis=0)).T)
            scale = 1.4826 * np.median(dist)
            ids = np.asarray(runs.run)[mask] if runs.run is not None else np.flatnonzero(mask) + 1
            for i in np.flatnonzero(dist > max(6.0 * scale, 1e-4 * side_m)):
                if loss == "linear":
                    warns.append(
                        f"{name} run {ids[i]} lies {dist[i] * 1e3:.0f} mm from the other {name} runs "
                        f"(robust spread {scale * 1e3:.0f} mm): an outlier? try a robust loss"
                    )
    weights = None
    if loss != "linear":
        z = (r / f_scale) ** 2
        rho = _loss_rho1(loss, z)
        weights = rho
    ist = _interval_stats(prob, p, weights)
    extra: dict = {
        "Es_pass": es,
        "fit_cost": float(sol.cost),
        "fit_rms_mm": float(np.sqrt(np.mean(r[:, :2] ** 2)) * 1e3),
        "fit_nfev": int(sol.nfev),
        "global_search": searched,
        "loss": loss,
        "heading_used": bool(prob.heading),
        "heading_weight_m": float(prob.w) if prob.heading else None,
        "runs_cw": n_cw,
        "runs_ccw": n_ccw,
    }
    # plausibility: errors this large usually mean a wrong side length or wheelbase (units)
    if abs(ed_pass - 1.0) > 0.1:
        warns.append(
            f"E_d = {ed_pass:.4f} (wheel diameters differing by {abs(ed_pass - 1) * 100:.0f} %) is unusual: "
            "check the wheelbase and side length (units: mm)"
        )
    if not (1.0 / 3.0 <= eb_pass <= 3.0):
        warns.append(
            f"E_b = {eb_pass:.4f} is unusual (the effective wheelbase would be {eb_pass * wheelbase_m * 1e3:.0f} "
            "mm): check the wheelbase and side length (units: mm)"
        )
    ed_total, cal = compose(ed_pass, eb_pass, wheelbase_m, prior)
    if es != 1.0:
        cal = Calibration(cal.c_left * es, cal.c_right * es, cal.wheelbase_m)
    if ist is None:
        warns.append("no confidence intervals: they need at least 2 runs in each direction and a well-conditioned fit")
        extra.update(
            {
                "Ed_ci95": None,
                "Eb_ci95": None,
                "wheelbase_corrected_mm_ci95": None,
                "Ed_se": None,
                "Eb_se": None,
                "Ed_pass_ci95": None,
                "emax_syst_after_pred_mm": None,
                "emax_syst_after_pred_measured_mm": None,
            }
        )
    else:
        cov, df, _, _ = ist
        se = np.sqrt(np.maximum(np.diag(cov), 0.0))
        q = stats.t.ppf(0.5 + confidence / 2.0, df)
        ed_lo, ed_hi = ed_pass - q[0] * se[0], ed_pass + q[0] * se[0]
        eb_lo, eb_hi = eb_pass - q[1] * se[1], eb_pass + q[1] * se[1]
        prior_ed = (prior or Calibration()).ed
        syst, meas = _predicted_after(prob, p, cov, sems)
        extra.update(
            {
                "Ed_se": float(se[0] * prior_ed),
                "Eb_se": float(se[1]),
                "Ed_ci95": [float(ed_lo * prior_ed), float(ed_hi * prior_ed)],
                "Ed_pass_ci95": [float(ed_lo), float(ed_hi)],
                "Eb_ci95": [float(eb_lo), float(eb_hi)],
                "wheelbase_corrected_mm_ci95": [float(eb_lo * wheelbase_m * 1e3), float(eb_hi * wheelbase_m * 1e3)],
                "ci_dof": [float(df[0]), float(df[1])],
                "Ed_Eb_corr": float(cov[0, 1] / (se[0] * se[1])) if se[0] > 0 and se[1] > 0 else None,
                "emax_syst_after_pred_mm": syst * 1e3,
                "emax_syst_after_pred_measured_mm": meas * 1e3,
            }
        )
        if confidence != 0.95:
            extra["confidence"] = confidence
        if (eb_hi - eb_lo) > 0.05 * eb_pass or (ed_hi - ed_lo) > 0.01:
            warns.append(
                f"the runs determine the calibration poorly (E_d {ed_lo * prior_ed:.4f} to "
                f"{ed_hi * prior_ed:.4f}, E_b {eb_lo:.3f} to {eb_hi:.3f}): too few runs or too much "
                "scatter"
            )
    # the paper's alpha/beta equivalents of the fitted errors, for comparison with bf
    alpha = 0.5 * math.pi * (1.0 - es / eb_pass)  # turn shortfall per 90 deg turn
    beta = 2.0 * es * (ed_pass - 1.0) / (ed_pass + 1.0) * side_m / (eb_pass * wheelbase_m)
    radius = math.inf if beta == 0 else (side_m / 2.0) / math.sin(beta / 2.0)
    extra["warnings"] = warns
    extra["alternatives"] = [{"Ed_pass": a[0], "Eb_pass": a[1]} for a in alternatives]
    return CorrectionResult("exact", ed_total, ed_pass, eb_pass, cal, alpha, beta, radius, extra)


def _loss_rho1(loss: str, z):
    """First derivative of scipy's robust loss rho(z) (the IRLS weight of each residual)."""
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1e-300)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z * z)
    return np.ones_like(z)


@register("exact")
def exact_method(runs, side_m, wheelbase_m, prior=None, **options):
    """Registry entry: the exact non-linear least-squares calibration."""
    return exact_correction(runs, side_m, wheelbase_m, prior, **options)
