"""Rigid motions of the plane (SE(2)), vectorised over arrays of poses.

Pure numpy: this module imports only numpy and :mod:`umbmark.model.geometry` (for
:func:`~umbmark.model.geometry.wrap_angle`). A pose is an array whose last axis holds
``(x, y, theta)`` [m, m, rad]; every function broadcasts over the leading axes, so one call
handles one pose or a million. Frames follow the package conventions: x forward, y to the
left, angles counter-clockwise positive.

``compose(a, b)`` is the pose ``b`` (given in frame ``a``) expressed in the frame in which
``a`` is given: ``a (+) b``. The headings that :func:`compose`, :func:`inverse` and
:func:`between` return are wrapped into (-pi, pi]; :func:`arc` returns the heading change it
turned, unwrapped.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.model.geometry import wrap_angle

__all__ = ["Pose", "compose", "inverse", "between", "arc", "sinc", "dsinc"]

Pose = tuple[float, float, float]
"""One planar pose or relative pose ``(x_m, y_m, yaw_rad)``."""


def _split(p: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    a = np.asarray(p, dtype=float)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"a pose array has 3 values (x, y, theta) on its last axis, got shape {a.shape}")
    return a[..., 0], a[..., 1], a[..., 2]


def _stack(x: ArrayLike, y: ArrayLike, th: ArrayLike) -> NDArray[np.float64]:
    return np.stack(np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(th, float)), axis=-1)


def sinc(u: ArrayLike) -> NDArray[np.float64]:
    """The unnormalised sinc, ``sin(u) / u`` with the value 1 at ``u = 0``.

    Parameters
    ----------
    u : array_like
        Angles [rad].

    Returns
    -------
    numpy.ndarray
        ``sin(u) / u``, exact to rounding for every ``u`` (no cancellation near 0).

    Examples
    --------
    >>> float(sinc(0.0)), bool(np.isclose(sinc(np.pi / 2), 2 / np.pi))
    (1.0, True)
    """
    return np.asarray(np.sinc(np.asarray(u, dtype=float) / np.pi), dtype=float)


def dsinc(u: ArrayLike) -> NDArray[np.float64]:
    """The derivative of :func:`sinc`, ``(cos u - sin(u) / u) / u``, by its series below
    ``|u| = 0.1`` (no cancellation near 0).

    Parameters
    ----------
    u : array_like
        Angles [rad].

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    The series and the closed form meet at ``|u| = 0.1``; both agree with a central difference:

    >>> float(dsinc(0.0)) == 0.0
    True
    >>> h = 1e-6
    >>> bool(np.isclose(dsinc(1.0), (sinc(1.0 + h) - sinc(1.0 - h)) / (2 * h)))
    True
    """
    x = np.asarray(u, dtype=float)
    small = np.abs(x) < 0.1
    us = np.where(small, x, 0.0)
    u2 = us * us
    series = us * (-1.0 / 3.0 + u2 * (1.0 / 30.0 + u2 * (-1.0 / 840.0 + u2 / 45360.0)))
    ub = np.where(small, 1.0, x)
    direct = (np.cos(ub) - np.sin(ub) / ub) / ub
    return np.asarray(np.where(small, series, direct), dtype=float)


def compose(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """The composition ``a (+) b``: pose ``b``, given in the frame of ``a``, in ``a``'s parent frame.

    Parameters
    ----------
    a, b : array_like
        Poses, shape ``(..., 3)`` (``x``, ``y`` [m], ``theta`` [rad]); broadcast together.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``; heading wrapped into (-pi, pi].

    Raises
    ------
    ValueError
        If the last axis of an input does not have length 3.

    Examples
    --------
    A robot at (1, 0) facing left (+y) drives one metre forward, in its own frame:

    >>> print(np.round(compose([1.0, 0.0, np.pi / 2], [1.0, 0.0, 0.0]), 6) + 0.0)
    [1.       1.       1.570796]

    It broadcasts: one start pose and three relative motions give three poses.

    >>> compose([0.0, 0.0, 0.0], np.eye(3)).shape
    (3, 3)
    """
    ax, ay, ath = _split(a)
    bx, by, bth = _split(b)
    c, s = np.cos(ath), np.sin(ath)
    return _stack(ax + c * bx - s * by, ay + s * bx + c * by, wrap_angle(ath + bth))


def inverse(a: ArrayLike) -> NDArray[np.float64]:
    """The inverse pose ``a^-1``, such that ``a (+) a^-1`` is the identity.

    Parameters
    ----------
    a : array_like
        Poses, shape ``(..., 3)``.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``: the parent frame's origin expressed in the frame of ``a``; heading
        wrapped into (-pi, pi].

    Raises
    ------
    ValueError
        If the last axis does not have length 3.

    Examples
    --------
    >>> a = [2.0, 1.0, 0.7]
    >>> print(np.round(compose(a, inverse(a)), 12) + 0.0)
    [0. 0. 0.]
    >>> print(np.round(inverse([1.0, 0.0, np.pi / 2]), 6) + 0.0)
    [ 0.        1.       -1.570796]
    """
    ax, ay, ath = _split(a)
    c, s = np.cos(ath), np.sin(ath)
    return _stack(-c * ax - s * ay, s * ax - c * ay, wrap_angle(-ath))


def between(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """The relative pose ``a^-1 (+) b``: pose ``b`` expressed in the frame of pose ``a``.

    Parameters
    ----------
    a, b : array_like
        Poses in one common frame, shape ``(..., 3)``; broadcast together.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``; heading wrapped into (-pi, pi].

    Raises
    ------
    ValueError
        If the last axis of an input does not have length 3.

    Examples
    --------
    Two poses facing +y, the second one metre further along y: seen from the first, it is one
    metre straight ahead.

    >>> print(np.round(between([1.0, 1.0, np.pi / 2], [1.0, 2.0, np.pi / 2]), 6) + 0.0)
    [1. 0. 0.]
    """
    ax, ay, ath = _split(a)
    bx, by, bth = _split(b)
    c, s = np.cos(ath), np.sin(ath)
    dx, dy = bx - ax, by - ay
    return _stack(c * dx + s * dy, -s * dx + c * dy, wrap_angle(bth - ath))


def arc(d_left_m: ArrayLike, d_right_m: ArrayLike, wheelbase_m: ArrayLike) -> NDArray[np.float64]:
    """The exact end pose of a differential-drive motion at constant wheel speeds.

    The robot starts at the origin heading along x; its left and right wheels roll
    ``d_left_m`` and ``d_right_m`` at constant speeds (the same duration), so it moves along a
    circular arc (a straight line or a spin on the spot as limits). With
    ``d = (d_L + d_R) / 2`` and ``dtheta = (d_R - d_L) / b``::

        x = d * sinc(dtheta / 2) * cos(dtheta / 2)   (= d sin(dtheta) / dtheta)
        y = d * sinc(dtheta / 2) * sin(dtheta / 2)   (= d (1 - cos dtheta) / dtheta)
        theta = dtheta

    which is exact to rounding for every ``dtheta``, including 0.

    Parameters
    ----------
    d_left_m, d_right_m : array_like
        Distances rolled by the left and right wheel [m] (signed: negative backwards).
    wheelbase_m : array_like
        Distance between the wheels' contact points [m] (non-zero).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(d_left_m, d_right_m, wheelbase_m).shape + (3,)``: ``(x, y, theta)``;
        ``theta`` is the heading change turned, not wrapped (a spin of a full turn gives 2 pi).

    Examples
    --------
    Equal travel is a straight line; opposite travel of a quarter of the wheelbase's circle
    (``pi b / 4`` each) a quarter turn on the spot:

    >>> print(arc(1.0, 1.0, 0.5))
    [1. 0. 0.]
    >>> print(np.round(arc(-np.pi * 0.5 / 4, np.pi * 0.5 / 4, 0.5), 6) + 0.0)
    [0.       0.       1.570796]

    The right wheel rolling 1 % further bends the path to the left (y and theta positive):

    >>> print(np.round(arc(1.0, 1.01, 0.34), 4))
    [1.0049 0.0148 0.0294]
    """
    dl = np.asarray(d_left_m, dtype=float)
    dr = np.asarray(d_right_m, dtype=float)
    d = 0.5 * (dl + dr)
    dth = (dr - dl) / np.asarray(wheelbase_m, dtype=float)
    half = 0.5 * dth
    k = d * sinc(half)
    return _stack(k * np.cos(half), k * np.sin(half), dth)
