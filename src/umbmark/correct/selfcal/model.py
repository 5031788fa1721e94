"""The measurement model of the self-calibration, its Jacobian and its Fisher information.

The six parameters, in this order everywhere (:data:`PARAMETERS`), SI units::

    p = (r_L [m], r_R [m], b [m], l_x [m], l_y [m], l_yaw [rad])

For interval k with wheel rotations ``phi_L``, ``phi_R`` the robot moves along the arc with
``d = (r_L phi_L + r_R phi_R) / 2`` and ``theta = (r_R phi_R - r_L phi_L) / b``; the sensor
sees ``h_k(p) = l^-1 (+) arc (+) l`` (:func:`umbmark.model.intervals.sensor_motion`), i.e.

    h_yaw = theta,    h_xy = R(-l_yaw) (q_xy + (R(theta) - I) l_xy)

with ``q_xy = d sinc(theta/2) (cos(theta/2), sin(theta/2))``. Intervals with steps
(:class:`umbmark.model.intervals.IntervalSteps`) move by their steps' arcs composed
(:func:`umbmark.model.intervals.step_motion`) instead: ``steps=`` of each function.
:func:`jacobian` is the exact derivative of ``h`` (stable as ``theta -> 0``);
:func:`fisher_information` the information
``sum_k J_k^T Sigma_k^-1 J_k`` of the intervals about ``p`` for Gaussian noise of covariance
``Sigma_k`` on ``s_k``: its inverse is the Cramer-Rao bound.

Pure numpy: imports numpy and :mod:`umbmark.model`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.model import se2
from umbmark.model.geometry import wrap_angle
from umbmark.model.intervals import IntervalSteps, sensor_motion, step_motion

__all__ = [
    "PARAMETERS",
    "predict",
    "residuals",
    "jacobian",
    "time_shift_derivatives",
    "whitener",
    "whiten",
    "fisher_information",
]

PARAMETERS = ("r_left_m", "r_right_m", "wheelbase_m", "sensor_x_m", "sensor_y_m", "sensor_yaw_rad")

FloatArray = NDArray[np.float64]


def _seen(q: FloatArray, sensor_pose: FloatArray) -> FloatArray:
    """Robot motions ``(K, 3)`` seen from the sensor: ``l^-1 (+) q (+) l``, the yaw wrapped."""
    return se2.compose(se2.inverse(sensor_pose), se2.compose(q, sensor_pose))


def predict(p: ArrayLike, left_rad: ArrayLike, right_rad: ArrayLike, steps: IntervalSteps | None = None) -> FloatArray:
    """The sensor displacements the parameters predict.

    Parameters
    ----------
    p : array_like
        The six parameters (:data:`PARAMETERS`).
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    steps : IntervalSteps, optional
        The intervals' steps (then the motion is theirs composed; ``left_rad`` and ``right_rad``
        are their totals).

    Returns
    -------
    numpy.ndarray
        Shape (K, 3): ``(dx_m, dy_m, dyaw_rad)``.
    """
    q = np.asarray(p, dtype=float)
    if steps is None:
        return sensor_motion(left_rad, right_rad, q[0], q[1], q[2], q[3:6])
    motion, _ = step_motion(steps, float(q[0]), float(q[1]), float(q[2]))
    return _seen(motion, q[3:6])


def residuals(
    p: ArrayLike, left_rad: ArrayLike, right_rad: ArrayLike, sensor: ArrayLike, steps: IntervalSteps | None = None
) -> FloatArray:
    """Measured minus predicted sensor displacements, the yaw difference wrapped.

    Parameters
    ----------
    p : array_like
        The six parameters.
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    sensor : array_like
        Measured displacements, shape (K, 3).
    steps : IntervalSteps, optional
        As :func:`predict`.

    Returns
    -------
    numpy.ndarray
        Shape (K, 3).
    """
    r = np.asarray(sensor, dtype=float) - predict(p, left_rad, right_rad, steps)
    r[:, 2] = wrap_angle(r[:, 2])
    return r


def jacobian(p: ArrayLike, left_rad: ArrayLike, right_rad: ArrayLike, steps: IntervalSteps | None = None) -> FloatArray:
    """The derivative of the predicted displacements with respect to the parameters.

    Parameters
    ----------
    p : array_like
        The six parameters.
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    steps : IntervalSteps, optional
        As :func:`predict`.

    Returns
    -------
    numpy.ndarray
        Shape (K, 3, 6): ``d h_k[i] / d p[j]`` (the residuals' Jacobian is its negative).
    """
    rl, rr, b, lx, ly, lyaw = (float(v) for v in np.asarray(p, dtype=float))
    if steps is None:
        q, dq = _arc_motion(rl, rr, b, np.asarray(left_rad, dtype=float), np.asarray(right_rad, dtype=float))
    else:
        q, dq_steps = step_motion(steps, rl, rr, b, derivatives=True)
        assert dq_steps is not None
        dq = dq_steps
    th = q[:, 2]
    ct, st = np.cos(th), np.sin(th)
    # J R(theta) l  (J = rotation by +90 deg): the derivative of R(theta) l by theta
    jrl = np.stack([-(st * lx + ct * ly), ct * lx - st * ly], axis=-1)
    cl, sl = np.cos(lyaw), np.sin(lyaw)
    rot = np.array([[cl, sl], [-sl, cl]])  # R(-l_yaw)
    out = np.zeros((len(q), 3, 6))
    # the geometry through the robot's motion: h_xy = R(-l_yaw) (q_xy + (R(theta) - I) l_xy)
    out[:, :2, :3] = np.matmul(rot, dq[:, :2, :] + jrl[:, :, None] * dq[:, 2:3, :])
    out[:, 2, :3] = dq[:, 2, :]
    # sensor position: R(-l_yaw) (R(theta) - I)
    a11, a12, a21, a22 = ct - 1.0, -st, st, ct - 1.0
    out[:, 0, 3] = cl * a11 + sl * a21
    out[:, 0, 4] = cl * a12 + sl * a22
    out[:, 1, 3] = -sl * a11 + cl * a21
    out[:, 1, 4] = -sl * a12 + cl * a22
    # sensor yaw: d/dl_yaw R(-l_yaw) v = -J R(-l_yaw) v, i.e. (h_y, -h_x)
    rml = np.stack([ct * lx - st * ly - lx, st * lx + ct * ly - ly], axis=-1)
    h_xy = (q[:, :2] + rml) @ rot.T
    out[:, 0, 5] = h_xy[:, 1]
    out[:, 1, 5] = -h_xy[:, 0]
    return out


def _twist_seen(p: FloatArray, rate: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The sensor's velocity in its own frame ``(K, 3)`` at wheel rates ``rate`` ``(K, 2)``, and
    its derivative by the parameters ``(K, 3, 6)``."""
    rl, rr, b, lx, ly, lyaw = (float(v) for v in p)
    wl, wr = rate[:, 0], rate[:, 1]
    v = 0.5 * (rl * wl + rr * wr)
    w = (rr * wr - rl * wl) / b
    dv = np.zeros((len(wl), 6))
    dw = np.zeros((len(wl), 6))
    dv[:, 0], dv[:, 1] = 0.5 * wl, 0.5 * wr
    dw[:, 0], dw[:, 1], dw[:, 2] = -wl / b, wr / b, -w / b
    # the sensor point's velocity in the robot frame, then turned into the sensor's
    ux, uy = v - w * ly, w * lx
    dux = dv - dw * ly
    duy = dw * lx
    dux[:, 4] -= w
    duy[:, 3] += w
    cl, sl = np.cos(lyaw), np.sin(lyaw)
    ex, ey = cl * ux + sl * uy, -sl * ux + cl * uy
    eta = np.column_stack([ex, ey, w])
    deta = np.empty((len(wl), 3, 6))
    deta[:, 0, :] = cl * dux + sl * duy
    deta[:, 1, :] = -sl * dux + cl * duy
    deta[:, 0, 5] += ey
    deta[:, 1, 5] -= ex
    deta[:, 2, :] = dw
    return eta, deta


def time_shift_derivatives(
    p: ArrayLike,
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    rate_start: ArrayLike,
    rate_end: ArrayLike,
    steps: IntervalSteps | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """How each predicted displacement moves when its interval's ends move in time.

    The wheel data of an interval are read at two stamps; a stamp off by ``delta`` seconds
    adds (at the end) or removes (at the start) the motion of ``delta`` at the wheels' rate
    there: ``h(delta) = exp(-delta_s eta_s) (+) h (+) exp(delta_e eta_e)`` with ``eta`` the
    sensor's velocity in its own frame. These derivatives give the errors-in-variables terms
    of the fit (:func:`umbmark.correct.selfcal.estimate.selfcal`): the covariance
    ``sigma^2 a a^T`` that a stamp jitter of ``sigma`` adds at each end, and the correction
    ``sigma^2 (dJ/d delta)^T Sigma^-1 a`` of the fit's score that removes the bias such errors
    in the wheel data give a fit that takes them as exact (regression dilution: wheels and
    turns fitted small).

    Parameters
    ----------
    p : array_like
        The six parameters.
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    rate_start, rate_end : array_like
        ``(K, 2)`` the wheels' rates at the start and the end [rad/s]
        (:attr:`~umbmark.model.intervals.Intervals.end_rates`).
    steps : IntervalSteps, optional
        As :func:`predict`.

    Returns
    -------
    a_start, a_end : numpy.ndarray
        ``(K, 3)``: ``d h_k / d delta`` of each end [m/s, m/s, rad/s].
    dj_start, dj_end : numpy.ndarray
        ``(K, 3, 6)``: their derivatives by the parameters.
    """
    q = np.asarray(p, dtype=float)
    h = predict(q, left_rad, right_rad, steps)
    jac = jacobian(q, left_rad, right_rad, steps)
    es, des = _twist_seen(q, np.asarray(rate_start, dtype=float))
    ee, dee = _twist_seen(q, np.asarray(rate_end, dtype=float))
    th = h[:, 2]
    ct, st = np.cos(th), np.sin(th)
    dth = jac[:, 2, :]
    # end: h (+) delta eta: position R(theta_h) eta_xy, yaw eta_yaw
    a_e = np.column_stack([ct * ee[:, 0] - st * ee[:, 1], st * ee[:, 0] + ct * ee[:, 1], ee[:, 2]])
    dj_e = np.empty_like(jac)
    dj_e[:, 0, :] = ct[:, None] * dee[:, 0, :] - st[:, None] * dee[:, 1, :] - a_e[:, 1:2] * dth
    dj_e[:, 1, :] = st[:, None] * dee[:, 0, :] + ct[:, None] * dee[:, 1, :] + a_e[:, 0:1] * dth
    dj_e[:, 2, :] = dee[:, 2, :]
    # start: (-delta eta) (+) h: position -eta_xy - eta_yaw J h_xy, yaw -eta_yaw
    hx, hy = h[:, 0], h[:, 1]
    a_s = np.column_stack([-es[:, 0] + es[:, 2] * hy, -es[:, 1] - es[:, 2] * hx, -es[:, 2]])
    dj_s = np.empty_like(jac)
    dj_s[:, 0, :] = -des[:, 0, :] + des[:, 2, :] * hy[:, None] + es[:, 2:3] * jac[:, 1, :]
    dj_s[:, 1, :] = -des[:, 1, :] - des[:, 2, :] * hx[:, None] - es[:, 2:3] * jac[:, 0, :]
    dj_s[:, 2, :] = -des[:, 2, :]
    return a_s, a_e, dj_s, dj_e


def _arc_motion(rl: float, rr: float, b: float, fl: FloatArray, fr: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The arc of each interval ``(K, 3)`` and its derivative by ``(r_L, r_R, b)``, ``(K, 3, 3)``."""
    d = 0.5 * (rl * fl + rr * fr)
    th = (rr * fr - rl * fl) / b
    u = 0.5 * th
    cu, su = np.cos(u), np.sin(u)
    k = se2.sinc(u)
    dk = se2.dsinc(u)
    # q_xy = d k (cos u, sin u); derivatives by d and by theta
    dq_dd = np.stack([k * cu, k * su], axis=-1)
    dq_dth = 0.5 * d[:, None] * np.stack([dk * cu - k * su, dk * su + k * cu], axis=-1)
    q = np.column_stack([d[:, None] * dq_dd, th])
    dd = (0.5 * fl, 0.5 * fr, np.zeros_like(fl))
    dth = (-fl / b, fr / b, -th / b)
    dq = np.empty((len(fl), 3, 3))
    for j in range(3):
        dq[:, :2, j] = dq_dd * dd[j][:, None] + dq_dth * dth[j][:, None]
        dq[:, 2, j] = dth[j]
    return q, dq


def whitener(noise: ArrayLike, k: int) -> FloatArray:
    """The matrices that turn residuals into unit-variance ones: ``W_k`` with ``W_k^T W_k = Sigma_k^-1``.

    Parameters
    ----------
    noise : array_like
        Standard deviations of ``(dx, dy, dyaw)`` common to all intervals, shape (3,); or a
        covariance, shape (3, 3) for all or (K, 3, 3) per interval.
    k : int
        The number of intervals.

    Returns
    -------
    numpy.ndarray
        Shape (K, 3, 3): ``W_k = L_k^-1`` for ``Sigma_k = L_k L_k^T`` (diagonal for standard
        deviations).

    Raises
    ------
    numpy.linalg.LinAlgError
        If a covariance is not positive definite.
    ValueError
        If ``noise`` has another shape.
    """
    a = np.asarray(noise, dtype=float)
    if a.shape == (3,):
        return np.broadcast_to(np.diag(1.0 / a), (k, 3, 3)).copy()
    if a.shape == (3, 3):
        a = np.broadcast_to(a, (k, 3, 3))
    if a.shape != (k, 3, 3):
        raise ValueError(f"noise of shape {a.shape}: expected (3,), (3, 3) or ({k}, 3, 3)")
    chol = np.linalg.cholesky(a)
    return np.asarray(np.linalg.inv(chol), dtype=float)


def whiten(w: FloatArray, r: FloatArray) -> FloatArray:
    """Apply whitening matrices to residuals or to a Jacobian.

    Parameters
    ----------
    w : numpy.ndarray
        Shape (K, 3, 3), from :func:`whitener`.
    r : numpy.ndarray
        Shape (K, 3) (residuals) or (K, 3, n) (a Jacobian).

    Returns
    -------
    numpy.ndarray
        ``W_k r_k`` for each k, the shape of ``r``.
    """
    if r.ndim == 2:
        return np.asarray(np.matmul(w, r[:, :, None])[:, :, 0], dtype=float)
    return np.asarray(np.matmul(w, r), dtype=float)


def fisher_information(
    p: ArrayLike, left_rad: ArrayLike, right_rad: ArrayLike, noise: ArrayLike, steps: IntervalSteps | None = None
) -> FloatArray:
    """The Fisher information of the intervals about the parameters.

    Parameters
    ----------
    p : array_like
        The six parameters where the information is evaluated (the truth, for the
        Cramer-Rao bound).
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    noise : array_like
        The noise on the sensor displacements: standard deviations (3,) or covariances
        (3, 3) / (K, 3, 3), as :func:`whitener` takes.
    steps : IntervalSteps, optional
        As :func:`predict`.

    Returns
    -------
    numpy.ndarray
        Shape (6, 6), ``sum_k J_k^T Sigma_k^-1 J_k``.
    """
    fl = np.asarray(left_rad, dtype=float)
    jw = whiten(whitener(noise, len(fl)), jacobian(p, fl, right_rad, steps))
    flat = jw.reshape(-1, 6)
    return np.asarray(flat.T @ flat, dtype=float)
