"""The closed-form calibration of Censi et al. (2013), the start of the maximum-likelihood fit.

Two linear steps, as the paper defines them:

1. Rotation. The sensor turns with the robot: ``s_yaw,k = theta_k = J21 phi_L,k + J22 phi_R,k``
   with ``J21 = -r_L / b`` and ``J22 = r_R / b``: linear least squares for ``(J21, J22)``.
2. Translation. With ``J21``, ``J22`` known, the robot's displacement over interval k is
   ``b c_k`` with ``c_k = (-J21 phi_L + J22 phi_R) / 2 (sin theta / theta, (1 - cos theta) / theta)``
   known, and ``l (+) s_k = q_k (+) l`` gives, in ``x = (b, l_x, l_y, cos l_yaw, sin l_yaw)``,
   two equations linear in ``x``::

       L_k x = 0,   L_k = [[-c_x, 1 - cos th,   sin th,     s_x, -s_y],
                           [-c_y,   -sin th,  1 - cos th, s_y,  s_x]]

   The solution minimises ``x^T M x`` (``M = sum L_k^T L_k``) subject to
   ``x_4^2 + x_5^2 = 1``. With a Lagrange multiplier, ``(M + lambda W) x = 0`` with
   ``W = diag(0, 0, 0, 1, 1)``, and ``det(M + lambda W) = 0`` is a quadratic in ``lambda``.
   Splitting ``M = [[A, B], [B^T, D]]`` (``A`` 3 x 3), ``det(M + lambda W) =
   det(A) det(S + lambda I)`` with the Schur complement ``S = D - B^T A^-1 B``: the two roots
   are minus the eigenvalues of ``S``, the cost at a root is the eigenvalue, so the solution
   is the smaller one's eigenvector ``z`` (unit norm: the constraint) and
   ``x = (-A^-1 B z, z)``, its sign chosen for ``b > 0``.

Then ``r_L = -J21 b``, ``r_R = J22 b``, ``l = (x_2, x_3, atan2(x_5, x_4))``.

Pure numpy: imports numpy and :mod:`umbmark.model`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.model import se2

__all__ = ["ClosedFormFailed", "rotation_step", "translation_matrix", "closed_form", "closed_form_fixed_scale"]

FloatArray = NDArray[np.float64]

# a 2 x 2 normal matrix beyond this condition number cannot separate J21 from J22
_MAX_COND = 1e12


class ClosedFormFailed(ArithmeticError):
    """The intervals do not determine the closed-form solution (a singular linear step)."""


def rotation_step(left_rad: ArrayLike, right_rad: ArrayLike, dyaw_rad: ArrayLike) -> tuple[float, float]:
    """Step 1: ``(J21, J22)`` by linear least squares on the sensor's rotations.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    dyaw_rad : array_like
        The sensor's rotation over each interval [rad], shape (K,).

    Returns
    -------
    tuple of float
        ``J21 = -r_L / b`` and ``J22 = r_R / b``.

    Raises
    ------
    ClosedFormFailed
        If the wheel rotations are (nearly) proportional, so the two cannot be separated.
    """
    a = np.column_stack([np.asarray(left_rad, float), np.asarray(right_rad, float)])
    n = a.T @ a
    if not np.all(np.isfinite(n)) or np.linalg.cond(n) > _MAX_COND:
        raise ClosedFormFailed("the wheel rotations do not separate the two wheels")
    j = np.linalg.solve(n, a.T @ np.asarray(dyaw_rad, float))
    return float(j[0]), float(j[1])


def translation_matrix(
    left_rad: ArrayLike, right_rad: ArrayLike, sensor: ArrayLike, j21: float, j22: float
) -> FloatArray:
    """Step 2's matrix ``M = sum_k L_k^T L_k`` in ``x = (b, l_x, l_y, cos l_yaw, sin l_yaw)``.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    sensor : array_like
        The sensor displacements, shape (K, 3).
    j21, j22 : float
        Step 1's result.

    Returns
    -------
    numpy.ndarray
        Shape (5, 5), symmetric, positive semi-definite.
    """
    fl = np.asarray(left_rad, float)
    fr = np.asarray(right_rad, float)
    s = np.asarray(sensor, float)
    th = j21 * fl + j22 * fr
    half = 0.5 * th
    k = se2.sinc(half)
    lin = 0.5 * (-j21 * fl + j22 * fr)  # d / b
    cx, cy = lin * k * np.cos(half), lin * k * np.sin(half)
    one_c, sn = 1.0 - np.cos(th), np.sin(th)
    sx, sy = s[:, 0], s[:, 1]
    row1 = np.column_stack([-cx, one_c, sn, sx, -sy])
    row2 = np.column_stack([-cy, -sn, one_c, sy, sx])
    return np.asarray(row1.T @ row1 + row2.T @ row2, dtype=float)


def _constrained_min(m: FloatArray) -> FloatArray:
    """``argmin x^T M x`` subject to ``x_4^2 + x_5^2 = 1`` (see the module docstring)."""
    a, bb, d = m[:3, :3], m[:3, 3:], m[3:, 3:]
    scale = np.sqrt(np.maximum(np.diag(a), 1e-300))
    an = a / np.outer(scale, scale)
    if np.linalg.cond(an) > _MAX_COND:
        raise ClosedFormFailed("the intervals do not determine the wheelbase and the sensor position")
    ainv_b = np.linalg.solve(a, bb)
    schur = d - bb.T @ ainv_b
    w, v = np.linalg.eigh(0.5 * (schur + schur.T))
    z = v[:, 0]
    x = np.concatenate([-ainv_b @ z, z])
    if x[0] < 0:
        x = -x
    return np.asarray(x, dtype=float)


def closed_form(left_rad: ArrayLike, right_rad: ArrayLike, sensor: ArrayLike) -> FloatArray:
    """The paper's closed-form calibration (both steps).

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    sensor : array_like
        The sensor displacements ``(dx_m, dy_m, dyaw_rad)``, shape (K, 3).

    Returns
    -------
    numpy.ndarray
        The six parameters ``(r_L, r_R, b, l_x, l_y, l_yaw)`` with ``b > 0`` (radii of either
        sign: their signs are the data's).

    Raises
    ------
    ClosedFormFailed
        If a linear step is singular (proportional wheel rotations, no turns, no motion).
    """
    s = np.asarray(sensor, float)
    j21, j22 = rotation_step(left_rad, right_rad, s[:, 2])
    x = _constrained_min(translation_matrix(left_rad, right_rad, s, j21, j22))
    b = x[0]
    out = np.array([-j21 * b, j22 * b, b, x[1], x[2], math.atan2(x[4], x[3])])
    if not np.all(np.isfinite(out)) or b <= 0:
        raise ClosedFormFailed("the closed form has no finite solution with a positive wheelbase")
    return out


def closed_form_fixed_scale(
    left_rad: ArrayLike, right_rad: ArrayLike, sensor: ArrayLike, r_left_m: float, r_right_m: float, wheelbase_m: float
) -> FloatArray:
    """The sensor pose by step 2 with the odometry parameters given (e.g. the nominal ones).

    With ``b``, ``J21``, ``J22`` known, ``L_k x = 0`` is linear least squares in
    ``(l_x, l_y, cos l_yaw, sin l_yaw)``; the angle is taken from the last two.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    sensor : array_like
        The sensor displacements, shape (K, 3).
    r_left_m, r_right_m, wheelbase_m : float
        The odometry parameters to assume.

    Returns
    -------
    numpy.ndarray
        The six parameters: the given three and the fitted sensor pose.

    Raises
    ------
    ClosedFormFailed
        If the system is singular.
    """
    b = float(wheelbase_m)
    j21, j22 = -float(r_left_m) / b, float(r_right_m) / b
    m = translation_matrix(left_rad, right_rad, sensor, j21, j22)
    # x = (b, y) with b fixed: minimise [b, y] M [b, y]^T over y -> M_yy y = -M_y0 b
    myy, my0 = m[1:, 1:], m[1:, 0]
    sol, *_ = np.linalg.lstsq(myy, -my0 * b, rcond=1e-12)
    if not np.all(np.isfinite(sol)) or math.hypot(sol[2], sol[3]) == 0:
        raise ClosedFormFailed("the sensor pose is not determined")
    return np.array([r_left_m, r_right_m, b, sol[0], sol[1], math.atan2(sol[3], sol[2])])
