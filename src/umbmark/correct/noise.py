"""The odometry's random error: each wheel's travel variance per metre, from the residuals of a
calibration, and the covariances it gives.

The model is the standard one of Chong & Kleeman (1997): each wheel's travel over a stretch is
off by a zero-mean error whose variance grows with the distance it rolled, ``k_L |s_L|`` and
``k_R |s_R|`` (``k`` in m^2 per metre: a wheel with ``k = 1e-4`` m is off by 1 cm, one standard
deviation, after rolling 1 m), independent between the wheels and between stretches. The pose
error of a stretch follows by linearising the arc, and of a path by propagating along it.

Estimation: the residuals of a calibration's intervals (the sensor's measured motion minus the
motion the calibrated odometry predicts, in the sensor frame) have the covariance
``R + k_L A_i + k_R B_i``, where ``A_i = |s_L| g_L g_L^T`` with ``g_L`` the derivative of the
interval's predicted sensor motion by the left wheel's travel (likewise right), and ``R`` the
sensor's own noise (diagonal, the same for every interval). ``k_L``, ``k_R`` and ``R`` are the
maximum-likelihood fit of the residuals, with 95 % intervals from the curvature of the likelihood.
The wheel terms grow with each interval's travel and the sensor's do not, and the correlation of
a residual's heading with its forward component tells the two wheels apart (the left wheel's
error turns the robot one way, the right's the other). Each interval ends where the likelihood
has dropped by 1.92 (chi^2 of one degree of freedom at 95 %), the other parameters held at their
best values; a lower end of 0 says the data cannot tell the wheel's noise from none.

Checking: the normalised estimation error squared (NEES) of held-out stretches of odometry
against a reference, ``e^T P^-1 e / 3`` averaged, is 1 when the covariance is right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2
from umbmark.model.intervals import sensor_motion

__all__ = [
    "OdometryNoise",
    "travel_jacobians",
    "estimate_odometry_noise",
    "step_covariance",
    "window_covariance",
    "window_errors",
    "nees",
    "controller_covariances",
]

_Z95 = 1.959963984540054
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class OdometryNoise:
    """Each wheel's travel variance per metre and the sensor noise estimated with it.

    Attributes
    ----------
    k_left_m, k_right_m : float
        Variance of each wheel's travel per metre rolled [m^2/m].
    k_left_ci95, k_right_ci95 : tuple of float
        Their 95 % intervals.
    sensor_sd : tuple of float
        The sensor's own noise per interval ``(dx_m, dy_m, dyaw_rad)`` (standard deviations).
    intervals : int
        The intervals fitted.
    travel_m : float
        The distance the wheels rolled in them (mean of the two).
    """

    k_left_m: float
    k_right_m: float
    k_left_ci95: tuple[float, float]
    k_right_ci95: tuple[float, float]
    sensor_sd: tuple[float, float, float]
    intervals: int
    travel_m: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: variances per metre in m^2/m and standard deviations per square-root metre in mm."""
        return {
            "wheel_variance_left_m2_per_m": self.k_left_m,
            "wheel_variance_left_m2_per_m_ci95": list(self.k_left_ci95),
            "wheel_variance_right_m2_per_m": self.k_right_m,
            "wheel_variance_right_m2_per_m_ci95": list(self.k_right_ci95),
            "wheel_sd_left_mm_per_sqrt_m": 1e3 * math.sqrt(max(self.k_left_m, 0.0)),
            "wheel_sd_right_mm_per_sqrt_m": 1e3 * math.sqrt(max(self.k_right_m, 0.0)),
            "sensor_sd": {
                "dx_mm": 1e3 * self.sensor_sd[0],
                "dy_mm": 1e3 * self.sensor_sd[1],
                "dyaw_deg": math.degrees(self.sensor_sd[2]),
            },
            "intervals": self.intervals,
            "travel_m": self.travel_m,
        }


def travel_jacobians(
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    r_left_m: float,
    r_right_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike = (0.0, 0.0, 0.0),
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The derivatives of each interval's sensor motion by each wheel's travel.

    Returns
    -------
    g_left, g_right : numpy.ndarray
        ``(K, 3)``: d(dx, dy, dyaw) / d(travel) [m/m, m/m, rad/m].
    s_left, s_right : numpy.ndarray
        ``(K,)``: each wheel's travel [m].
    """
    sl = r_left_m * np.asarray(left_rad, dtype=float)
    sr = r_right_m * np.asarray(right_rad, dtype=float)
    h = 1e-6
    g = []
    for dl, dr in ((h, 0.0), (0.0, h)):
        plus = sensor_motion((sl + dl) / r_left_m, (sr + dr) / r_right_m, r_left_m, r_right_m, wheelbase_m, sensor_pose)
        minus = sensor_motion(
            (sl - dl) / r_left_m, (sr - dr) / r_right_m, r_left_m, r_right_m, wheelbase_m, sensor_pose
        )
        d = plus - minus
        d[:, 2] = np.arctan2(np.sin(d[:, 2]), np.cos(d[:, 2]))
        g.append(d / (2 * h))
    return g[0], g[1], sl, sr


def _residuals(meas: FloatArray, pred: FloatArray) -> FloatArray:
    e = np.asarray(meas, dtype=float) - pred
    e[:, 2] = np.arctan2(np.sin(e[:, 2]), np.cos(e[:, 2]))
    return e


def _nll(theta: FloatArray, e: FloatArray, a: FloatArray, b: FloatArray) -> float:
    """Negative log-likelihood (up to a constant) of residuals ``e`` with covariances
    ``diag(exp(theta[2:])) + exp(theta[0]) A + exp(theta[1]) B`` (``A``, ``B`` as the six
    distinct entries of symmetric 3 x 3 matrices: xx, yy, tt, xy, xt, yt)."""
    kl, kr = math.exp(theta[0]), math.exp(theta[1])
    m = kl * a + kr * b
    sxx, syy, stt = m[:, 0] + math.exp(theta[2]), m[:, 1] + math.exp(theta[3]), m[:, 2] + math.exp(theta[4])
    sxy, sxt, syt = m[:, 3], m[:, 4], m[:, 5]
    # the adjugate and the determinant of each symmetric matrix
    cxx = syy * stt - syt * syt
    cyy = sxx * stt - sxt * sxt
    ctt = sxx * syy - sxy * sxy
    cxy = sxt * syt - sxy * stt
    cxt = sxy * syt - sxt * syy
    cyt = sxy * sxt - sxx * syt
    det = sxx * cxx + sxy * cxy + sxt * cxt
    if np.any(det <= 0):
        return 1e300
    ex, ey, et = e[:, 0], e[:, 1], e[:, 2]
    quad = cxx * ex * ex + cyy * ey * ey + ctt * et * et + 2 * (cxy * ex * ey + cxt * ex * et + cyt * ey * et)
    return 0.5 * float(np.sum(np.log(det)) + np.sum(quad / det))


def _sym6(g: FloatArray, w: FloatArray) -> FloatArray:
    """``w g g^T`` of each row as its six distinct entries (xx, yy, tt, xy, xt, yt)."""
    return w[:, None] * np.column_stack(
        [g[:, 0] ** 2, g[:, 1] ** 2, g[:, 2] ** 2, g[:, 0] * g[:, 1], g[:, 0] * g[:, 2], g[:, 1] * g[:, 2]]
    )


def _interval95(f: Any, theta: FloatArray, j: int, best: float) -> tuple[float, float]:
    """Where the likelihood of parameter ``j`` (in the log) drops by 1.92 either side of its
    best value, the others held: the ends of its 95 % interval, 0 when the fit cannot tell it
    from nothing."""
    from scipy.optimize import brentq

    def g(x: float) -> float:
        t = theta.copy()
        t[j] = x
        return f(t) - best - 0.5 * 3.841458820694124

    x0 = theta[j]
    ends = []
    for direction in (-1.0, 1.0):
        step, x = 0.05, x0
        while abs(x - x0) < 60 and g(x0 + direction * step) < 0:
            x = x0 + direction * step
            step *= 2
        y = x0 + direction * step
        if abs(y - x0) >= 60:
            ends.append(0.0 if direction < 0 else math.inf)
            continue
        ends.append(math.exp(brentq(g, min(x, y), max(x, y), xtol=1e-4)))
    return ends[0], ends[1]


def estimate_odometry_noise(
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    sensor: ArrayLike,
    r_left_m: float,
    r_right_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike = (0.0, 0.0, 0.0),
) -> OdometryNoise:
    """Each wheel's travel variance per metre from the residuals of calibrated intervals.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], ``(K,)`` (the inliers of the calibration).
    sensor : array_like
        The sensor's measured motion per interval ``(K, 3)`` ``(dx_m, dy_m, dyaw_rad)``.
    r_left_m, r_right_m, wheelbase_m : float
        The calibrated geometry.
    sensor_pose : array_like
        The calibrated sensor pose on the robot.

    Returns
    -------
    OdometryNoise

    Raises
    ------
    InputError
        Fewer than 20 intervals, or wheels that hardly rolled.
    """
    from scipy.optimize import minimize

    left = np.asarray(left_rad, dtype=float)
    right = np.asarray(right_rad, dtype=float)
    meas = np.asarray(sensor, dtype=float).reshape(-1, 3)
    if len(left) < 20:
        raise InputError(f"the odometry's noise needs at least 20 intervals, got {len(left)}")
    pred = sensor_motion(left, right, r_left_m, r_right_m, wheelbase_m, sensor_pose)
    e = _residuals(meas, pred)
    gl, gr, sl, sr = travel_jacobians(left, right, r_left_m, r_right_m, wheelbase_m, sensor_pose)
    travel = 0.5 * float(np.sum(np.abs(sl)) + np.sum(np.abs(sr)))
    if travel < 1.0:
        raise InputError(f"the wheels rolled {travel:.2f} m: the odometry's noise needs a drive of metres")
    a = _sym6(gl, np.abs(sl))
    b = _sym6(gr, np.abs(sr))
    var0 = np.maximum(np.var(e, axis=0), 1e-16)
    k0 = 1e-5
    theta0 = np.log(np.array([k0, k0, *(0.5 * var0)]))

    def f(t: FloatArray) -> float:
        return _nll(t, e, a, b)

    res = minimize(f, theta0, method="L-BFGS-B", bounds=[(-40.0, 5.0)] * 5)
    theta = res.x
    k = np.exp(theta[:2])
    cis = [_interval95(f, theta, j, float(res.fun)) for j in (0, 1)]
    sd3 = np.sqrt(np.exp(theta[2:]))
    return OdometryNoise(
        float(k[0]), float(k[1]), cis[0], cis[1], (float(sd3[0]), float(sd3[1]), float(sd3[2])), len(left), travel
    )


def step_covariance(
    s_left_m: ArrayLike, s_right_m: ArrayLike, wheelbase_m: float, k_left_m: float, k_right_m: float
) -> FloatArray:
    """The covariance of each step's robot motion ``(dx, dy, dyaw)`` (in the robot frame at the
    step's start) from its wheels' travel errors, ``(K, 3, 3)``."""
    gl, gr, sl, sr = travel_jacobians(s_left_m, s_right_m, 1.0, 1.0, wheelbase_m)
    return (k_left_m * np.abs(sl))[:, None, None] * gl[:, :, None] * gl[:, None, :] + (k_right_m * np.abs(sr))[
        :, None, None
    ] * gr[:, :, None] * gr[:, None, :]


def _adjoint(p: FloatArray) -> FloatArray:
    """SE(2) adjoints ``(..., 3, 3)`` of poses ``(..., 3)`` (a right perturbation moved left)."""
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    out = np.zeros((*p.shape[:-1], 3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
    out[..., 0, 2], out[..., 1, 2], out[..., 2, 2] = p[..., 1], -p[..., 0], 1.0
    return out


def window_covariance(steps: ArrayLike, step_cov: ArrayLike, window: int) -> FloatArray:
    """The covariance of the composed motion of consecutive windows of ``window`` steps.

    Parameters
    ----------
    steps : array_like
        ``(K, 3)`` the steps' motions (odometry).
    step_cov : array_like
        ``(K, 3, 3)`` their covariances (:func:`step_covariance`).
    window : int
        Steps per window; the windows do not overlap (the last, incomplete, is dropped).

    Returns
    -------
    numpy.ndarray
        ``(K // window, 3, 3)``: each window's end pose in its start frame, linearised.
    """
    d = np.asarray(steps, dtype=float)
    q = np.asarray(step_cov, dtype=float)
    nw = len(d) // window
    d = d[: nw * window].reshape(nw, window, 3)
    q = q[: nw * window].reshape(nw, window, 3, 3)
    out = np.zeros((nw, 3, 3))
    rest = np.zeros((nw, 3))  # the motion after step j to the window's end
    for j in range(window - 1, -1, -1):
        ad = _adjoint(se2.inverse(rest))
        out += ad @ q[:, j] @ np.swapaxes(ad, 1, 2)
        rest = se2.compose(d[:, j], rest)
    return out


def window_errors(steps: ArrayLike, reference: ArrayLike, window: int) -> FloatArray:
    """Each window's composed odometry against the composed reference: ``(dx, dy, dyaw)`` of the
    reference's end pose in the odometry's, ``(K // window, 3)``."""
    d = np.asarray(steps, dtype=float)
    r = np.asarray(reference, dtype=float)
    nw = len(d) // window
    a = np.zeros((nw, 3))
    b = np.zeros((nw, 3))
    for j in range(window):
        a = se2.compose(a, d[np.arange(nw) * window + j])
        b = se2.compose(b, r[np.arange(nw) * window + j])
    return se2.between(a, b)


def nees(errors: ArrayLike, covariances: ArrayLike) -> float:
    """Mean normalised estimation error squared per dimension, ``mean(e^T P^-1 e) / 3``: 1 when
    the covariances are right, above when they are too small."""
    e = np.asarray(errors, dtype=float)
    p = np.asarray(covariances, dtype=float)
    sol = np.linalg.solve(p, e[:, :, None])[:, :, 0]
    return float(np.mean(np.sum(e * sol, axis=1)) / e.shape[1])


def controller_covariances(
    noise: OdometryNoise | tuple[float, float],
    wheelbase_m: float,
    speed_mps: float,
    period_s: float,
    distance_m: float = 1.0,
) -> dict[str, list[float]]:
    """``diff_drive_controller``'s ``pose_covariance_diagonal`` and ``twist_covariance_diagonal``
    (x, y, z, roll, pitch, yaw) for this noise (an :class:`OdometryNoise` or each wheel's
    variance per metre ``(k_left, k_right)``).

    The twist's: the variance of the speeds averaged over ``period_s`` at ``speed_mps`` (each
    wheel rolling ``speed * period``; diff_drive_controller averages its speeds over
    ``velocity_rolling_window_size`` updates, and the average of the wheel-angle differences is the
    difference over the whole window). The pose's: the covariance after driving ``distance_m``
    straight (the odometry's pose error grows without bound; robot_localization should fuse the
    twist, or the pose differentially). The unobserved axes get 1e6, ``vy`` and ``y``'s lower
    bound the tiniest of the others (a differential drive cannot slide, but a zero breaks filters).
    """
    if not all(math.isfinite(v) and v > 0 for v in (speed_mps, period_s, distance_m, wheelbase_m)):
        raise InputError("speed, period, distance and wheelbase must be positive")
    k_left, k_right = (noise.k_left_m, noise.k_right_m) if isinstance(noise, OdometryNoise) else noise
    s = speed_mps * period_s
    q = step_covariance([s], [s], wheelbase_m, k_left, k_right)[0]
    twist = np.diag(q) / period_s**2
    n = max(1, int(round(distance_m / 0.01)))
    steps = np.tile([distance_m / n, 0.0, 0.0], (n, 1))
    sc = step_covariance(np.full(n, distance_m / n), np.full(n, distance_m / n), wheelbase_m, k_left, k_right)
    pose = np.diag(window_covariance(steps, sc, n)[0])
    floor = float(min(v for v in (*twist, *pose) if v > 0)) if np.any(twist > 0) else 1e-9
    big = 1e6
    return {
        "pose_covariance_diagonal": [float(pose[0]), max(float(pose[1]), floor), big, big, big, float(pose[2])],
        "twist_covariance_diagonal": [float(twist[0]), floor, big, big, big, float(twist[2])],
    }
