"""The square-run model of :mod:`umbmark.correct.exact` as one compiled loop (numba).

:func:`residuals_jacobian` evaluates, for many parameter pairs and many runs at once, the
residuals ``data - model`` of :meth:`umbmark.correct.exact.model._Problem.residuals_matrix`,
their analytic derivatives (forward mode through the same arcs as
:func:`umbmark.correct.exact.model.square_errors`) or only each pair's weighted sum of
squares, without the temporary arrays of the numpy version. It is used where the runs are
many (:attr:`_Problem.fast`) and numba is installed; otherwise the numpy functions of
:mod:`umbmark.correct.exact.model` do the same.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from umbmark._numba import numba_module

__all__ = ["available", "residuals_jacobian"]

_KERNEL: list[Any] = []


def _sinc_d(h: float, ch: float, sh: float) -> tuple[float, float]:
    """``sin(h) / h`` and its derivative, from ``cos h`` and ``sin h`` (series near 0)."""
    if abs(h) < 1e-2:
        h2 = h * h
        return (
            1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0)),
            -(h / 3.0) * (1.0 - h2 / 10.0 + h2 * h2 / 280.0 - h2 * h2 * h2 / 15120.0),
        )
    sc = sh / h
    return sc, (ch - sc) / h


def _kernel_py(ed, eb, sign, adj, odo, ex, ey, eth, sw, side, b, es, w, heading, mode, r_out, j_out, sums):
    """One pass over the pairs ``p`` and runs ``i``.

    mode 0: ``sums[p, 0]`` the weighted sum of squares; 1: residuals (``r_out``); 2:
    residuals and their Jacobian (``j_out``, unweighted); 3: the weighted sums of squares,
    ``J^T J`` (``sums[p, 1:4]``: 00, 01, 11) and ``J^T r`` (``sums[p, 4:6]``).
    Headings are carried as their cosine and sine (one sine and cosine per turn).
    """
    two_pi = 2.0 * math.pi
    n_p = ed.shape[0]
    n = sign.shape[0]
    deriv = mode >= 2
    for p in range(n_p):
        e_d = ed[p]
        e_b = eb[p]
        k_l = 2.0 * es / (1.0 + e_d)
        kl_d = -2.0 * es / ((1.0 + e_d) * (1.0 + e_d))
        k_r = e_d * k_l
        kr_d = k_l + e_d * kl_d
        ib = 1.0 / (e_b * b)
        ib_b = -1.0 / (e_b * e_b * b)
        leg_du = 0.5 * side * (k_l + k_r)
        leg_du_d = 0.5 * side * (kl_d + kr_d)
        leg_h = 0.5 * side * (k_r - k_l) * ib  # half the heading gained on a leg
        leg_h_d = 0.5 * side * (kr_d - kl_d) * ib
        leg_h_b = 0.5 * side * (k_r - k_l) * ib_b
        leg_ch = math.cos(leg_h)
        leg_sh = math.sin(leg_h)
        leg_sc, leg_dsc = _sinc_d(leg_h, leg_ch, leg_sh)
        tot = 0.0
        a00 = 0.0
        a01 = 0.0
        a11 = 0.0
        g0 = 0.0
        g1 = 0.0
        for i in range(n):
            x = 0.0
            y = 0.0
            th = 0.0
            cth = 1.0
            sth = 0.0
            x_d = 0.0
            x_b = 0.0
            y_d = 0.0
            y_b = 0.0
            th_d = 0.0
            th_b = 0.0
            for corner in range(8):
                if corner % 2 == 0:  # a leg
                    du = leg_du
                    du_d = leg_du_d
                    h = leg_h
                    h_d = leg_h_d
                    h_b = leg_h_b
                    ch = leg_ch
                    sh = leg_sh
                    sc = leg_sc
                    dsc = leg_dsc
                else:  # an on-the-spot turn through the odometry's phi
                    phi = sign[i] * (0.5 * math.pi) + adj[i, corner // 2]
                    half = 0.5 * b * phi
                    du = 0.5 * half * (k_r - k_l)
                    du_d = 0.5 * half * (kr_d - kl_d)
                    h = 0.5 * half * (k_r + k_l) * ib
                    h_d = 0.5 * half * (kr_d + kl_d) * ib
                    h_b = 0.5 * half * (k_r + k_l) * ib_b
                    ch = math.cos(h)
                    sh = math.sin(h)
                    sc, dsc = _sinc_d(h, ch, sh)
                c = du * sc
                cm = cth * ch - sth * sh  # cos and sin of the chord's direction th + h
                sm = sth * ch + cth * sh
                if deriv:
                    c_d = du_d * sc + du * dsc * h_d
                    c_b = du * dsc * h_b
                    m_d = th_d + h_d
                    m_b = th_b + h_b
                    x_d += c_d * cm - c * sm * m_d
                    x_b += c_b * cm - c * sm * m_b
                    y_d += c_d * sm + c * cm * m_d
                    y_b += c_b * sm + c * cm * m_b
                    th_d += 2.0 * h_d
                    th_b += 2.0 * h_b
                x += c * cm
                y += c * sm
                th += 2.0 * h
                cth, sth = cm * ch - sm * sh, sm * ch + cm * sh
            rx = ex[i] - (x - odo[i, 0])
            ry = ey[i] - (y - odo[i, 1])
            rt = 0.0
            if heading:
                a = eth[i] - (th - odo[i, 2]) + math.pi
                v = a - two_pi * math.floor(a / two_pi) - math.pi
                if v == -math.pi:  # (-pi, pi], as umbmark.model.geometry.wrap_angle
                    v = math.pi
                rt = w * v
            if mode == 0:
                tot += sw[i] * sw[i] * (rx * rx + ry * ry + rt * rt)
            elif mode == 3:
                q = sw[i] * sw[i]
                tot += q * (rx * rx + ry * ry + rt * rt)
                wt_d = w * th_d if heading else 0.0
                wt_b = w * th_b if heading else 0.0
                a00 += q * (x_d * x_d + y_d * y_d + wt_d * wt_d)
                a01 += q * (x_d * x_b + y_d * y_b + wt_d * wt_b)
                a11 += q * (x_b * x_b + y_b * y_b + wt_b * wt_b)
                g0 -= q * (x_d * rx + y_d * ry + wt_d * rt)
                g1 -= q * (x_b * rx + y_b * ry + wt_b * rt)
            else:
                r_out[p, i, 0] = rx
                r_out[p, i, 1] = ry
                if heading:
                    r_out[p, i, 2] = rt
                if mode == 2:
                    j_out[p, i, 0, 0] = -x_d
                    j_out[p, i, 0, 1] = -x_b
                    j_out[p, i, 1, 0] = -y_d
                    j_out[p, i, 1, 1] = -y_b
                    if heading:
                        j_out[p, i, 2, 0] = -w * th_d
                        j_out[p, i, 2, 1] = -w * th_b
        sums[p, 0] = tot
        sums[p, 1] = a00
        sums[p, 2] = a01
        sums[p, 3] = a11
        sums[p, 4] = g0
        sums[p, 5] = g1


def available() -> bool:
    """Whether the compiled kernel can be used (numba installed).

    Returns
    -------
    bool
    """
    return numba_module() is not None


def _kernel() -> Any:
    if not _KERNEL:
        numba = numba_module()
        if numba is None:  # pragma: no cover - depends on the environment
            raise RuntimeError("numba is not installed")
        g = globals()
        g["_sinc_d"] = numba.njit(cache=True)(g["_sinc_d"])
        _KERNEL.append(numba.njit(cache=True, nogil=True)(_kernel_py))
    return _KERNEL[0]


def _odometry_ends(prob: Any) -> np.ndarray:
    """The odometry's own end pose of every run (legs of the side, the turns it made)."""
    if "odometry ends" not in prob.cache:
        n = prob.n
        xo, yo, to = np.zeros(n), np.zeros(n), np.zeros(n)
        for i in range(4):
            xo, yo = xo + prob.side_m * np.cos(to), yo + prob.side_m * np.sin(to)
            to = to + prob.sign * (0.5 * np.pi) + prob.dev[:, i]
        prob.cache["odometry ends"] = np.ascontiguousarray(np.stack([xo, yo, to], axis=1))
    out: np.ndarray = prob.cache["odometry ends"]
    return out


def residuals_jacobian(prob: Any, ed: np.ndarray, eb: np.ndarray, mode: int) -> tuple[np.ndarray, ...]:
    """Residuals, Jacobian or weighted sums of a problem for many parameter pairs.

    Parameters
    ----------
    prob : umbmark.correct.exact.model._Problem
        The runs (or pseudo-runs).
    ed, eb : numpy.ndarray
        Shape (P,): the parameter pairs.
    mode : int
        0: the weighted sums of squares; 1: the residuals; 2: residuals and Jacobian; 3: the
        weighted sums of squares, ``J^T J`` and ``J^T r`` (the normal equations).

    Returns
    -------
    tuple of numpy.ndarray
        mode 0: ``(cost,)`` of shape (P,); 1: ``(r,)`` of shape (P, n, ncomp); 2: ``(r, J)``
        with ``J`` of shape (P, n, ncomp, 2) (unweighted); 3: ``(sums,)`` of shape (P, 6):
        sum of squares, ``J^T J`` (00, 01, 11), ``J^T r`` (0, 1).
    """
    ed = np.ascontiguousarray(ed, dtype=float).ravel()
    eb = np.ascontiguousarray(eb, dtype=float).ravel()
    n_p, n, c = ed.size, prob.n, prob.ncomp
    r = np.zeros((n_p if mode in (1, 2) else 0, n, c))
    jac = np.zeros((n_p if mode == 2 else 0, n, c, 2))
    sums = np.zeros((n_p, 6))
    eth = prob.eth if prob.heading and prob.eth is not None else np.zeros(n)
    sw = prob.sw if prob.sw is not None else np.ones(n)
    _kernel()(
        ed,
        eb,
        np.ascontiguousarray(prob.sign, dtype=float),
        np.ascontiguousarray(prob.dev, dtype=float),
        _odometry_ends(prob),
        np.ascontiguousarray(prob.ex, dtype=float),
        np.ascontiguousarray(prob.ey, dtype=float),
        np.ascontiguousarray(eth, dtype=float),
        np.ascontiguousarray(sw, dtype=float),
        float(prob.side_m),
        float(prob.b),
        float(prob.es),
        float(prob.w),
        bool(prob.heading),
        int(mode),
        r,
        jac,
        sums,
    )
    if mode == 0:
        return (sums[:, 0],)
    if mode == 1:
        return (r,)
    if mode == 2:
        return r, jac
    return (sums,)
