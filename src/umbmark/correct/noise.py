"""The odometry's random error: each wheel's travel variance per metre, from the residuals of a
calibration, and the covariances it gives.

The model is the standard one of Chong & Kleeman (1997): each wheel's travel over a stretch is
off by a zero-mean error whose variance grows with the distance it rolled, ``k_L |s_L|`` and
``k_R |s_R|`` (``k`` in m^2 per metre: a wheel with ``k = 1e-4`` m is off by 1 cm, one standard
deviation, after rolling 1 m), independent between the wheels and between stretches. The pose
error of a stretch follows by linearising the arc, and of a path by propagating along it.

Estimation: the residuals of a calibration's intervals (the sensor's measured motion minus the
motion the calibrated odometry predicts, in the sensor frame) have the covariance
``R + k_L A_i + k_R B_i``, where ``A_i = |s_L| Q_L`` with ``Q_L`` the mean of ``g_L g_L^T`` over
the arc, ``g_L`` the derivative of the interval's predicted sensor motion by a travel error of the
left wheel at a point of the arc (:func:`travel_shapes`; likewise right), and ``R`` the sensor's own
noise (diagonal, the same for every interval). ``k_L``, ``k_R`` and ``R`` are the
maximum-likelihood fit of the residuals, with 95 % intervals from the curvature of the likelihood.
The wheel terms grow with each interval's travel and the sensor's do not, and the correlation of
a residual's heading with its forward component tells the two wheels apart (the left wheel's
error turns the robot one way, the right's the other). Each interval ends where the likelihood
has dropped by 1.92 (chi^2 of one degree of freedom at 95 %), the other parameters held at their
best values; a lower end of 0 says the data cannot tell the wheel's noise from none.

Timing (optional): when the reference is a trajectory sampled at points in time (a motion
capture's poses against the wheels' ticks), each end of an interval is off by a random time
error ``delta`` (standard deviation ``sigma_t``, independent between ends): the reference's end
pose moves by the robot's twist there times ``delta``. The residual then has the covariance
``R + k_L A_i + k_R B_i + sigma_t^2 C_i`` with ``C_i = J_L xi_a xi_a^T J_L^T + J_R xi_b xi_b^T
J_R^T`` (:func:`timing_covariance`: ``xi_a``, ``xi_b`` the twists at the interval's start and end,
``J_L``, ``J_R`` the derivatives of the motion's coordinates by a perturbation at its start and
at its end, the far end's twist so brought into the start frame). Its variance grows with the
speed squared and not with the interval's length, so it is told apart from the wheels' (which
grow with the distance rolled) and from ``R`` (which does not grow with speed). A reference late
by a constant offset moves every residual by ``J_L xi_a - J_R xi_b`` times the offset: zero at
constant twist, so it only shows where the robot speeds up, slows down or turns more or less
(:func:`timing_direction`); such an offset, or any mean linear in unknowns, is fitted with the noise
(profiled out by generalised least squares: :func:`estimate_interval_noise`'s ``mean_design``,
:func:`gls_mean`). With the timing or a mean, the 95 % intervals are the profile likelihood's (the
other parameters at their best for each value), as those parameters trade off against the wheels'.

Heading jitter (optional): a motion capture's heading can be noisier while the
body turns than its position and its timing say (the markers' fit blurs with the rotation). Each
end's heading is then off by an independent error of variance ``q |omega|`` (``omega`` the turn
rate there): the residual gains ``q H_i`` with ``H_i = |omega_a| u_a u_a^T + |omega_b| e_3 e_3^T``
(:func:`heading_jitter_covariance`; ``u_a = (-dy, dx, 1)`` the motion's change per turn of its
start frame, ``e_3`` its heading). It grows with the turn rate and not with the interval's length,
so it is told apart from the wheels' noise; unmodelled, it shows as a per-metre noise that falls
as the intervals grow.

Checking: the normalised estimation error squared (NEES) of held-out stretches of odometry
against a reference, ``e^T P^-1 e / 3`` averaged, is 1 when the covariance is right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2
from umbmark.model.intervals import sensor_motion

__all__ = [
    "OdometryNoise",
    "travel_shapes",
    "timing_covariance",
    "timing_direction",
    "heading_jitter_covariance",
    "estimate_interval_noise",
    "estimate_odometry_noise",
    "residual_covariance",
    "gls_mean",
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
    timing_sd_s : float or None
        The reference's random time error at each interval end (standard deviation) [s], when
        it was estimated (see the module docstring); None otherwise.
    timing_sd_ci95_s : tuple of float or None
        Its 95 % interval [s].
    heading_jitter_var_rad_s : float or None
        The reference's heading variance at each interval end per rad/s of turn rate [rad^2 s/rad],
        when it was estimated (see the module docstring); None otherwise.
    heading_jitter_var_ci95_rad_s : tuple of float or None
        Its 95 % interval.
    neg_log_likelihood : float or None
        The fit's negative log-likelihood (up to a constant; fits of the same residuals with and
        without a term compare by it: twice the difference is the likelihood-ratio statistic).
    """

    k_left_m: float
    k_right_m: float
    k_left_ci95: tuple[float, float]
    k_right_ci95: tuple[float, float]
    sensor_sd: tuple[float, float, float]
    intervals: int
    travel_m: float
    timing_sd_s: float | None = None
    timing_sd_ci95_s: tuple[float, float] | None = None
    heading_jitter_var_rad_s: float | None = None
    heading_jitter_var_ci95_rad_s: tuple[float, float] | None = None
    neg_log_likelihood: float | None = field(default=None, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: variances per metre in m^2/m and standard deviations per square-root metre in mm
        (the timing's standard deviation in ms and the heading jitter's in mrad at 1 rad/s, only when
        estimated)."""
        out = {
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
        if self.timing_sd_s is not None:
            out["timing_sd_ms"] = 1e3 * self.timing_sd_s
            ci = self.timing_sd_ci95_s or (0.0, math.inf)
            out["timing_sd_ms_ci95"] = [1e3 * ci[0], 1e3 * ci[1]]
        if self.heading_jitter_var_rad_s is not None:
            out["heading_jitter_mrad_at_1radps"] = 1e3 * math.sqrt(self.heading_jitter_var_rad_s)
            ci = self.heading_jitter_var_ci95_rad_s or (0.0, math.inf)
            out["heading_jitter_mrad_at_1radps_ci95"] = [1e3 * math.sqrt(ci[0]), 1e3 * math.sqrt(ci[1])]
        return out


def travel_shapes(
    s_left_m: ArrayLike, s_right_m: ArrayLike, wheelbase_m: float, sensor_pose: ArrayLike = (0.0, 0.0, 0.0)
) -> tuple[FloatArray, FloatArray]:
    """Each arc's motion covariance per unit of a wheel's slip variance ``k |s|``, the slip spread
    along the arc as a random walk: ``integral over u of h(u) h(u)^T`` ``(K, 3, 3)`` per wheel.

    ``h(u)`` is the derivative of the sensor's motion by a travel error of the wheel a fraction
    ``u`` along the arc (the robot turned and pushed there, the rest of the arc carried on from
    it), integrated by four-point Gauss-Legendre quadrature. A slip early in the arc has a longer
    lever to its end than the arc's mean derivative ``g`` says, a late one a shorter: across the
    arc the integral exceeds ``g g^T`` by about 1/12 of its displacement squared over the
    wheelbase squared.

    Parameters
    ----------
    s_left_m, s_right_m : array_like
        ``(K,)`` each wheel's travel over the arc [m].
    wheelbase_m : float
        The wheelbase [m].
    sensor_pose : array_like
        The sensor's pose on the robot ``(x_m, y_m, yaw_rad)`` (the motion is the sensor's).

    Returns
    -------
    tuple of numpy.ndarray
        The left wheel's and the right wheel's ``(K, 3, 3)``.
    """
    sl = np.asarray(s_left_m, dtype=float).reshape(-1)
    sr = np.asarray(s_right_m, dtype=float).reshape(-1)
    mount = np.broadcast_to(np.asarray(sensor_pose, dtype=float), (len(sl), 3))
    nodes, weights = np.polynomial.legendre.leggauss(4)
    h = 1e-6
    out = []
    for push in ((h, 0.0), (0.0, h)):
        acc = np.zeros((len(sl), 3, 3))
        for x, w in zip(0.5 * (nodes + 1.0), 0.5 * weights):
            first, rest = se2.arc(x * sl, x * sr, wheelbase_m), se2.arc((1 - x) * sl, (1 - x) * sr, wheelbase_m)
            ends = []
            for sign in (1.0, -1.0):
                kick = se2.arc(np.full(len(sl), sign * push[0]), np.full(len(sl), sign * push[1]), wheelbase_m)
                robot = se2.compose(se2.compose(first, kick), rest)
                ends.append(se2.between(mount, se2.compose(robot, mount)))
            g = (ends[0] - ends[1]) / (2 * h)
            g[:, 2] = np.arctan2(np.sin(ends[0][:, 2] - ends[1][:, 2]), np.cos(ends[0][:, 2] - ends[1][:, 2])) / (2 * h)
            acc += w * g[:, :, None] * g[:, None, :]
        out.append(acc)
    return out[0], out[1]


def _residuals(meas: FloatArray, pred: FloatArray) -> FloatArray:
    e = np.asarray(meas, dtype=float) - pred
    e[:, 2] = np.arctan2(np.sin(e[:, 2]), np.cos(e[:, 2]))
    return e


def _adjugate6(c: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Symmetric 3 x 3 matrices as their six distinct entries ``(K, 6)`` (xx, yy, tt, xy, xt, yt):
    their adjugates (the same six) and determinants ``(K,)``."""
    sxx, syy, stt, sxy, sxt, syt = c.T
    adj = np.column_stack(
        [
            syy * stt - syt * syt,
            sxx * stt - sxt * sxt,
            sxx * syy - sxy * sxy,
            sxt * syt - sxy * stt,
            sxy * syt - sxt * syy,
            sxy * sxt - sxx * syt,
        ]
    )
    return adj, sxx * adj[:, 0] + sxy * adj[:, 3] + sxt * adj[:, 4]


def _inverse6(theta: FloatArray, terms: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The covariances ``diag(exp(theta[M:])) + sum_m exp(theta[m]) terms[m]`` (``terms`` ``(M, K, 6)``)
    as their adjugates and determinants (:func:`_adjugate6`)."""
    n = len(terms)
    m = np.tensordot(np.exp(theta[:n]), terms, axes=1)
    m[:, :3] += np.exp(theta[n : n + 3])
    return _adjugate6(m)


def _quad(adj: FloatArray, u: FloatArray, w: FloatArray) -> FloatArray:
    """``u^T adj w`` of each row (``adj`` as six entries)."""
    return (
        adj[:, 0] * u[:, 0] * w[:, 0]
        + adj[:, 1] * u[:, 1] * w[:, 1]
        + adj[:, 2] * u[:, 2] * w[:, 2]
        + adj[:, 3] * (u[:, 0] * w[:, 1] + u[:, 1] * w[:, 0])
        + adj[:, 4] * (u[:, 0] * w[:, 2] + u[:, 2] * w[:, 0])
        + adj[:, 5] * (u[:, 1] * w[:, 2] + u[:, 2] * w[:, 1])
    )


def _mean_fit(adj: FloatArray, det: FloatArray, e: FloatArray, design: FloatArray | None) -> FloatArray:
    """The generalised-least-squares coefficients ``(P,)`` of a mean ``design`` (``(3, K, P)``: each
    residual component's change per unit of each coefficient) under the covariances ``adj / det``."""
    if design is None:
        return np.zeros(0)
    a = adj / det[:, None]
    x, y, t = design
    wx = a[:, 0:1] * x + a[:, 3:4] * y + a[:, 4:5] * t  # the covariances' inverses times the design
    wy = a[:, 3:4] * x + a[:, 1:2] * y + a[:, 5:6] * t
    wt = a[:, 4:5] * x + a[:, 5:6] * y + a[:, 2:3] * t
    normal = x.T @ wx + y.T @ wy + t.T @ wt
    rhs = e[:, 0] @ wx + e[:, 1] @ wy + e[:, 2] @ wt
    scale = np.sqrt(np.maximum(np.diag(normal), 1e-300))
    sol = np.linalg.lstsq(normal / np.outer(scale, scale), rhs / scale, rcond=1e-12)[0]
    return sol / scale


def _demeaned(adj: FloatArray, det: FloatArray, e: FloatArray, design: FloatArray | None) -> FloatArray:
    """The residuals less their mean ``design`` (``(3, K, P)``) fitted under the covariances ``adj / det``
    (:func:`_mean_fit`); as they are without a design."""
    if design is None:
        return e
    c = _mean_fit(adj, det, e, design)
    return e - np.column_stack([design[0] @ c, design[1] @ c, design[2] @ c])


def _split_design(design: ArrayLike, k: int) -> FloatArray:
    """A design ``(K, 3, P)`` as three contiguous ``(K, P)`` blocks ``(3, K, P)``."""
    return np.ascontiguousarray(np.moveaxis(np.asarray(design, dtype=float).reshape(k, 3, -1), 1, 0))


def _nll(theta: FloatArray, e: FloatArray, terms: FloatArray, design: FloatArray | None = None) -> float:
    """Negative log-likelihood (up to a constant) of residuals ``e`` with the covariances of
    :func:`_inverse6`, a linear mean ``design`` (``(3, K, P)``, see :func:`_mean_fit`) profiled out."""
    adj, det = _inverse6(theta, terms)
    if np.any(det <= 0):
        return 1e300
    e = _demeaned(adj, det, e, design)
    return 0.5 * float(np.sum(np.log(det)) + np.sum(_quad(adj, e, e) / det))


def _nll_grad(
    theta: FloatArray, e: FloatArray, terms: FloatArray, design: FloatArray | None = None
) -> tuple[float, FloatArray]:
    """:func:`_nll` and its gradient by ``theta`` (the mean held at its profiled value: by the envelope
    theorem its own change does not move the likelihood)."""
    adj, det = _inverse6(theta, terms)
    if np.any(det <= 0):
        return 1e300, np.zeros(len(theta))
    e = _demeaned(adj, det, e, design)
    inv = adj / det[:, None]
    u = np.column_stack(
        [
            inv[:, 0] * e[:, 0] + inv[:, 3] * e[:, 1] + inv[:, 4] * e[:, 2],
            inv[:, 3] * e[:, 0] + inv[:, 1] * e[:, 1] + inv[:, 5] * e[:, 2],
            inv[:, 4] * e[:, 0] + inv[:, 5] * e[:, 1] + inv[:, 2] * e[:, 2],
        ]
    )
    f = 0.5 * float(np.sum(np.log(det)) + np.sum(u * e))
    uu = np.column_stack(
        [u[:, 0] ** 2, u[:, 1] ** 2, u[:, 2] ** 2, u[:, 0] * u[:, 1], u[:, 0] * u[:, 2], u[:, 1] * u[:, 2]]
    )
    d = inv - uu
    d[:, 3:] *= 2.0  # off-diagonal entries count twice in a trace
    n = len(terms)
    total = np.empty(len(theta))
    total[:n] = np.tensordot(terms, d, axes=([1, 2], [0, 1])) if n else 0.0
    total[n : n + 3] = d[:, :3].sum(axis=0)  # the diagonal's three unit terms
    return f, 0.5 * np.exp(theta) * total


def _sym6(g: FloatArray, w: FloatArray) -> FloatArray:
    """``w g g^T`` of each row as its six distinct entries (xx, yy, tt, xy, xt, yt)."""
    return w[:, None] * np.column_stack(
        [g[:, 0] ** 2, g[:, 1] ** 2, g[:, 2] ** 2, g[:, 0] * g[:, 1], g[:, 0] * g[:, 2], g[:, 1] * g[:, 2]]
    )


def _six(m: FloatArray) -> FloatArray:
    """Symmetric ``(K, 3, 3)`` matrices as their six distinct entries ``(K, 6)``."""
    return np.column_stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], m[:, 0, 1], m[:, 0, 2], m[:, 1, 2]])


def _interval95(f: Any, theta: FloatArray, j: int, best: float, fg: Any = None) -> tuple[float, float]:
    """Where the likelihood of parameter ``j`` (in the log) drops by 1.92 either side of its
    best value, the others held (or, given ``fg`` (the likelihood and its gradient), at their best
    for each value of it, the profile likelihood: wider when the parameters trade off against each
    other): the ends of its 95 % interval, 0 when the fit cannot tell it from nothing."""
    from scipy.optimize import brentq, minimize

    others = [i for i in range(len(theta)) if i != j]

    seen: dict[float, float] = {}

    def g(x: float) -> float:
        if x not in seen:
            seen[x] = _drop(x)
        return seen[x]

    def _drop(x: float) -> float:
        t = theta.copy()
        t[j] = x
        if fg is not None:  # the others at their best for this value (searched from the fit's best)

            def h(u: FloatArray) -> tuple[float, FloatArray]:
                t[others] = u
                val, grad = fg(t)
                return val, grad[others]

            res = minimize(h, theta[others], jac=True, method="L-BFGS-B", bounds=[(-40.0, 5.0)] * len(others))
            return float(res.fun) - best - 0.5 * 3.841458820694124
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
        lo, hi = min(x, y), max(x, y)
        if (g(lo) < 0) == (g(hi) < 0):  # a profile's inner search landing elsewhere: the outer end
            ends.append(math.exp(y))
            continue
        ends.append(math.exp(brentq(g, lo, hi, xtol=1e-3 if fg is not None else 1e-4)))
    return ends[0], ends[1]


def _moments_start(e: FloatArray, terms: FloatArray) -> FloatArray:
    """A starting point of the likelihood's search: the non-negative least squares of the residuals'
    products on the terms and a diagonal (each of the six entries scaled to its residuals' size),
    every value floored at a hundredth of what would explain the residuals alone."""
    from scipy.optimize import nnls

    y = _sym6(e, np.ones(len(e)))
    scale = np.sqrt(
        np.maximum(np.mean(y[:, [0, 1, 2, 0, 0, 1]], axis=0) * np.mean(y[:, [0, 1, 2, 1, 2, 2]], axis=0), 1e-30)
    )
    diag = np.zeros((3, len(e), 6))
    for j in range(3):
        diag[j, :, j] = 1.0
    cols = np.concatenate([terms, diag])
    design = (cols / scale).transpose(1, 2, 0).reshape(-1, len(cols))
    sol = nnls(design, (y / scale).reshape(-1), maxiter=50 * len(cols))[0]
    alone = np.array([np.sum(y[:, :3] / scale[:3]) / max(np.sum(c[:, :3] / scale[:3]), 1e-300) for c in cols])
    return np.log(np.clip(np.maximum(sol, 0.01 * alone), 1e-17, 1e2))


def _fit_terms(
    e: FloatArray,
    terms: FloatArray,
    starts: list[FloatArray],
    design: FloatArray | None = None,
    profile: bool = False,
    intervals: bool = True,
) -> tuple[FloatArray, float, list]:
    """The maximum-likelihood multipliers of ``terms`` and the diagonal (in the log), from the best of
    several starts, and the 95 % intervals of the multipliers (see :func:`_interval95`)."""
    from scipy.optimize import minimize

    def f(t: FloatArray) -> float:
        return _nll(t, e, terms, design)

    def fg(t: FloatArray) -> tuple[float, FloatArray]:
        return _nll_grad(t, e, terms, design)

    best = None
    for theta0 in starts:
        res = minimize(fg, theta0, jac=True, method="L-BFGS-B", bounds=[(-40.0, 5.0)] * len(theta0))
        if best is None or res.fun < best.fun:
            best = res
    assert best is not None
    theta = best.x
    if not intervals:
        return theta, float(best.fun), [(math.nan, math.nan)] * len(terms)
    cis = [_interval95(f, theta, j, float(best.fun), fg if profile else None) for j in range(len(terms))]
    return theta, float(best.fun), cis


def timing_covariance(motion: ArrayLike, twist_start: ArrayLike, twist_end: ArrayLike) -> FloatArray:
    """The covariance per second squared of each interval's motion when the reference is off in
    time at either end (independent errors).

    Parameters
    ----------
    motion : array_like
        ``(K, 3)`` each interval's motion ``(dx_m, dy_m, dyaw_rad)`` in its start frame.
    twist_start, twist_end : array_like
        ``(K, 3)`` the frame's twist ``(vx_mps, vy_mps, omega_radps)`` at the interval's start and
        at its end, each in the frame at that time.

    Returns
    -------
    numpy.ndarray
        ``(K, 3, 3)``: ``J_L xi_a xi_a^T J_L^T + J_R xi_b xi_b^T J_R^T`` [(m/s)^2, (m/s)(rad/s),
        (rad/s)^2]; times ``sigma_t^2`` it is the residual's covariance from the timing.
    """
    ja, jb = _end_twists(motion, twist_start, twist_end)
    return ja[:, :, None] * ja[:, None, :] + jb[:, :, None] * jb[:, None, :]


def timing_direction(motion: ArrayLike, twist_start: ArrayLike, twist_end: ArrayLike) -> FloatArray:
    """How each interval's measured motion moves when the reference is late by a constant offset (its
    pose stamped ``t`` is the one at ``t - offset``): ``d motion / d offset`` ``(K, 3)`` [m/s, m/s,
    rad/s] (zero at constant twist). Arguments as :func:`timing_covariance`."""
    ja, jb = _end_twists(motion, twist_start, twist_end)
    return ja - jb


def heading_jitter_covariance(motion: ArrayLike, twist_start: ArrayLike, twist_end: ArrayLike) -> FloatArray:
    """The covariance per unit of the reference's heading jitter (variance per rad/s of turn rate) of
    each interval's motion: ``|omega_a| u_a u_a^T + |omega_b| e_3 e_3^T`` ``(K, 3, 3)`` [rad/s, with
    the motion's units] (see the module docstring). Arguments as :func:`timing_covariance`. The
    heading error turns the reference about its own tracked point: a trajectory carried from a
    marker off the axle to the axle moves with it too, which this leaves out."""
    d = np.asarray(motion, dtype=float).reshape(-1, 3)
    wa = np.abs(np.asarray(twist_start, dtype=float).reshape(-1, 3)[:, 2])
    wb = np.abs(np.asarray(twist_end, dtype=float).reshape(-1, 3)[:, 2])
    if not (len(d) == len(wa) == len(wb)):
        raise InputError("the motions and the twists at their ends differ in number")
    u = np.column_stack([-d[:, 1], d[:, 0], np.ones(len(d))])
    out = wa[:, None, None] * u[:, :, None] * u[:, None, :]
    out[:, 2, 2] += wb
    return out


def _end_twists(motion: ArrayLike, twist_start: ArrayLike, twist_end: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The start's twist and the end's, as changes of the motion's coordinates (``J_L xi_a``, ``J_R xi_b``)."""
    d = np.asarray(motion, dtype=float).reshape(-1, 3)
    xa = np.asarray(twist_start, dtype=float).reshape(-1, 3)
    xb = np.asarray(twist_end, dtype=float).reshape(-1, 3)
    if not (len(d) == len(xa) == len(xb)):
        raise InputError("the motions and the twists at their ends differ in number")
    ja = np.column_stack([xa[:, 0] - d[:, 1] * xa[:, 2], xa[:, 1] + d[:, 0] * xa[:, 2], xa[:, 2]])
    c, s = np.cos(d[:, 2]), np.sin(d[:, 2])
    jb = np.column_stack([c * xb[:, 0] - s * xb[:, 1], s * xb[:, 0] + c * xb[:, 1], xb[:, 2]])
    return ja, jb


def estimate_interval_noise(
    residuals: ArrayLike,
    left_cov: ArrayLike,
    right_cov: ArrayLike,
    travel_m: float,
    timing_cov: ArrayLike | None = None,
    mean_design: ArrayLike | None = None,
    ci95: bool = True,
    *,
    heading_cov: ArrayLike | None = None,
) -> OdometryNoise:
    """Each wheel's travel variance per metre (and the reference's timing and heading jitter) from residuals whose
    covariance shapes are given: the general form of :func:`estimate_odometry_noise`, for
    intervals whose odometry is composed of many steps.

    Parameters
    ----------
    residuals : array_like
        ``(K, 3)`` measured minus predicted motion ``(dx_m, dy_m, dyaw_rad)``, heading wrapped.
    left_cov, right_cov : array_like
        ``(K, 3, 3)`` each residual's covariance per unit of the left (right) wheel's variance per
        metre (``sum_j |s_j| Q_j`` over the interval's steps, each step's :func:`travel_shapes`
        carried into the interval's start frame) [m].
    travel_m : float
        The distance the wheels rolled in all intervals (mean of the two) [m].
    timing_cov : array_like, optional
        ``(K, 3, 3)`` :func:`timing_covariance`: the reference's timing error is fitted too.
    mean_design : array_like, optional
        ``(K, 3, P)`` a mean of the residuals linear in ``P`` unknowns (each residual's change per
        unit of each: e.g. a constant time offset of each run, :func:`timing_direction` in that
        run's column), profiled out at every step of the fit by generalised least squares
        (:func:`gls_mean` gives them afterwards).
    ci95 : bool
        Compute the 95 % intervals (profile likelihood when the timing, the heading jitter or a
        mean is fitted: each value's likelihood with the other parameters at their best); NaN when
        False (faster).
    heading_cov : array_like, optional
        ``(K, 3, 3)`` :func:`heading_jitter_covariance`: the reference's heading jitter is fitted too
        (not when it is all zero: a robot that never turned).

    Returns
    -------
    OdometryNoise
        With ``timing_sd_s`` when ``timing_cov`` was given, ``heading_jitter_var_rad_s`` when
        ``heading_cov`` was.

    Raises
    ------
    InputError
        Fewer than 20 intervals, wheels that hardly rolled, or shapes that do not match.
    """
    e = np.asarray(residuals, dtype=float).reshape(-1, 3)
    if len(e) < 20:
        raise InputError(f"the odometry's noise needs at least 20 intervals, got {len(e)}")
    if not travel_m >= 1.0:
        raise InputError(f"the wheels rolled {travel_m:.2f} m: the odometry's noise needs a drive of metres")
    if heading_cov is not None and not np.any(np.asarray(heading_cov, dtype=float)):
        heading_cov = None  # a robot that never turned: the data say nothing of the jitter
    extra = [m for m in (timing_cov, heading_cov) if m is not None]
    mats = [left_cov, right_cov, *extra]
    terms = np.stack([_six(np.asarray(m, dtype=float).reshape(-1, 3, 3)) for m in mats])
    if terms.shape[1] != len(e) or not np.all(np.isfinite(terms)) or not np.all(np.isfinite(e)):
        raise InputError("the residuals and their covariance shapes must be finite and as many")
    design = None
    if mean_design is not None:
        raw = np.asarray(mean_design, dtype=float)
        if raw.ndim != 3 or raw.shape[:2] != (len(e), 3) or not np.all(np.isfinite(raw)):
            raise InputError("the mean's design must be finite, one (3, P) block per residual")
        design = _split_design(raw, len(e))
    var0 = np.maximum(np.var(e, axis=0), 1e-16)
    e0 = e
    if mean_design is not None:
        e0 = e - np.asarray(mean_design) @ gls_mean(e, np.broadcast_to(np.diag(var0), (len(e), 3, 3)), mean_design)
    start = [2.5e-5] * (timing_cov is not None) + [1e-5] * (heading_cov is not None)
    legacy = np.log(np.array([1e-5, 1e-5, *start, *(0.5 * var0)]))
    profile = bool(extra) or design is not None  # the new terms trade off against the others
    theta, nll, cis = _fit_terms(e, terms, [legacy, _moments_start(e0, terms)], design, profile, ci95)
    k = np.exp(theta[:2])
    sd3 = np.sqrt(np.exp(theta[len(terms) :]))
    timing = timing_ci = heading = heading_ci = None
    if timing_cov is not None:
        timing, timing_ci = math.sqrt(math.exp(theta[2])), (math.sqrt(cis[2][0]), math.sqrt(cis[2][1]))
    if heading_cov is not None:
        heading, heading_ci = math.exp(theta[len(terms) - 1]), cis[len(terms) - 1]
    return OdometryNoise(
        float(k[0]),
        float(k[1]),
        cis[0],
        cis[1],
        (float(sd3[0]), float(sd3[1]), float(sd3[2])),
        len(e),
        float(travel_m),
        timing,
        timing_ci,
        heading,
        heading_ci,
        nll,
    )


def gls_mean(residuals: ArrayLike, covariances: ArrayLike, design: ArrayLike) -> FloatArray:
    """The generalised-least-squares coefficients of a linear mean of residuals.

    Parameters
    ----------
    residuals : array_like
        ``(K, 3)``.
    covariances : array_like
        ``(K, 3, 3)`` theirs.
    design : array_like
        ``(K, 3, P)`` each residual's change per unit of each coefficient.

    Returns
    -------
    numpy.ndarray
        ``(P,)`` (a coefficient the residuals do not determine is 0).
    """
    e = np.asarray(residuals, dtype=float).reshape(-1, 3)
    cov = np.asarray(covariances, dtype=float).reshape(-1, 3, 3)
    x = _split_design(design, len(e))
    adj, det = _adjugate6(_six(cov))
    return _mean_fit(adj, det, e, x)


def residual_covariance(
    noise: OdometryNoise,
    left_cov: ArrayLike,
    right_cov: ArrayLike,
    timing_cov: ArrayLike | None = None,
    heading_cov: ArrayLike | None = None,
) -> FloatArray:
    """The covariance a fitted noise gives each residual, ``R + k_L A + k_R B (+ sigma_t^2 C + q H)``
    ``(K, 3, 3)`` (arguments as :func:`estimate_interval_noise`; the timing's and the heading
    jitter's only when both the noise has it and its shape is given): what a held-out NEES checks."""
    out = noise.k_left_m * np.asarray(left_cov, dtype=float) + noise.k_right_m * np.asarray(right_cov, dtype=float)
    if timing_cov is not None and noise.timing_sd_s is not None:
        out = out + noise.timing_sd_s**2 * np.asarray(timing_cov, dtype=float)
    if heading_cov is not None and noise.heading_jitter_var_rad_s is not None:
        out = out + noise.heading_jitter_var_rad_s * np.asarray(heading_cov, dtype=float)
    return out + np.diag(np.square(noise.sensor_sd))


def estimate_odometry_noise(
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    sensor: ArrayLike,
    r_left_m: float,
    r_right_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike = (0.0, 0.0, 0.0),
    twist_start: ArrayLike | None = None,
    twist_end: ArrayLike | None = None,
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
    twist_start, twist_end : array_like, optional
        ``(K, 3)`` the sensor frame's twist ``(vx_mps, vy_mps, omega_radps)`` at each interval's
        start and end (each in the frame at that time): given both, the reference's random time
        error at the interval ends is fitted too (:func:`timing_covariance`; ``timing_sd_s``).

    Returns
    -------
    OdometryNoise

    Raises
    ------
    InputError
        Fewer than 20 intervals, wheels that hardly rolled, or only one of the twists.
    """
    left = np.asarray(left_rad, dtype=float)
    right = np.asarray(right_rad, dtype=float)
    meas = np.asarray(sensor, dtype=float).reshape(-1, 3)
    if len(left) < 20:
        raise InputError(f"the odometry's noise needs at least 20 intervals, got {len(left)}")
    if (twist_start is None) != (twist_end is None):
        raise InputError("the timing needs the twists at both ends of the intervals")
    pred = sensor_motion(left, right, r_left_m, r_right_m, wheelbase_m, sensor_pose)
    e = _residuals(meas, pred)
    sl, sr = r_left_m * left, r_right_m * right
    travel = 0.5 * float(np.sum(np.abs(sl)) + np.sum(np.abs(sr)))
    ql, qr = travel_shapes(sl, sr, wheelbase_m, sensor_pose)
    timing = None if twist_start is None else timing_covariance(pred, twist_start, twist_end)  # type: ignore[arg-type]
    return estimate_interval_noise(e, np.abs(sl)[:, None, None] * ql, np.abs(sr)[:, None, None] * qr, travel, timing)


def step_covariance(
    s_left_m: ArrayLike, s_right_m: ArrayLike, wheelbase_m: float, k_left_m: float, k_right_m: float
) -> FloatArray:
    """The covariance of each step's robot motion ``(dx, dy, dyaw)`` (in the robot frame at the
    step's start) from its wheels' travel errors, ``(K, 3, 3)``."""
    sl = np.asarray(s_left_m, dtype=float).reshape(-1)
    sr = np.asarray(s_right_m, dtype=float).reshape(-1)
    ql, qr = travel_shapes(sl, sr, wheelbase_m)
    return (k_left_m * np.abs(sl))[:, None, None] * ql + (k_right_m * np.abs(sr))[:, None, None] * qr


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
