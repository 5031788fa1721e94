"""Self-calibration of any kind of robot (:mod:`umbmark.kinds`: tricycle, mecanum, differential drive) from
sensor displacements.

The formulation of Censi, Franchi, Marchionni, Oriolo (IEEE T-RO 2013) with the kind's own
prediction (its geometry's twist, :mod:`umbmark.model.kinematics`) in place of the differential drive's arc: for
interval ``k`` the joints' steps move the robot by ``q_k(g)`` (the steps' exact constant-twist
displacements composed, ``g`` the geometry), and the sensor at ``l = (l_x, l_y, l_yaw)`` on it
sees ``h_k = l^-1 (+) q_k (+) l``. The parameters are the geometry's free ones (a tricycle's
wheel diameter, wheelbase, steering offset and, on request, steering scale; a mecanum robot's
four diameters and ``l_x + l_y``) and the sensor pose. What depends on the kind (the parameters
estimated by default, the JSON keys, the advice on the driving, what a negative size means) the
kind says (:class:`umbmark.kinds.Kind`).

:func:`kinematic_selfcal` runs the steps of :func:`umbmark.correct.selfcal.selfcal`:

1. Start: the nominal geometry; the sensor yaw from the directions of the translations, its
   position by linear least squares; refined with a robust (Cauchy) loss.
2. Maximum likelihood with Student t noise (scatter and degrees of freedom estimated, the scan
   matcher's covariances added when the intervals carry them), outliers set aside and judged
   again each round, until the inliers settle (the engine of
   :mod:`umbmark.correct.selfcal.estimate`).
3. Uncertainty: the cluster-robust covariance over blocks of time (errors shared by
   neighbouring intervals), 95 % intervals from Student's t.
4. Identifiability: a parameter the intervals leave poorly determined is named with what to
   drive (:func:`driving`); an information matrix that is singular is an error saying so.

The Jacobian is exact but for each step's own derivative by the geometry, taken by central
differences (the composition of the steps and the sensor's frame are differentiated in closed
form).

Imports numpy, scipy (when it runs), :mod:`umbmark.model`, :mod:`umbmark.kinds` and this package.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal.estimate import (
    BLOCK_S,
    MAX_BLOCKS,
    Fit,
    Problem,
    Uncertainty,
    diag_whitener,
    fit_and_reject,
    robust_sd,
    time_blocks,
    uncertainty,
)
from umbmark.correct.selfcal.loss import ROBUST_START, loss_named
from umbmark.errors import InputError
from umbmark.kinds import kind_of
from umbmark.model import se2
from umbmark.model.geometry import nominal_slip, wrap_angle
from umbmark.model.kinematics import JointIntervals, Kinematics, twist_displacement

__all__ = [
    "KinematicSelfcalResult",
    "kinematic_selfcal",
    "kinematic_residuals",
    "KinematicLimits",
    "DrivingCoverage",
    "driving",
    "SENSOR_PARAMETERS",
]

FloatArray = NDArray[np.float64]

SENSOR_PARAMETERS = ("sensor_x_m", "sensor_y_m", "sensor_yaw_rad")

_J = np.array([[0.0, -1.0], [1.0, 0.0]])
_SINGULAR_COND = 1e12


def _rot(a: FloatArray) -> FloatArray:
    """``(..., 2, 2)`` rotation matrices."""
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


class KinematicProblem(Problem):
    """The intervals of a kind of robot for the estimation engine: residuals and their Jacobian
    in the free geometry parameters and the sensor pose."""

    def __init__(self, iv: JointIntervals, nominal: Kinematics, free: Sequence[bool]):
        self.source = iv.source
        self.kin = nominal
        self.free = np.asarray(free, dtype=bool)
        self.base = nominal.vector()
        self.s = np.asarray(iv.sensor, float)
        self.values = iv.steps.values
        self.start = iv.steps.start
        self.first = self.start[:-1]
        self.seg = np.repeat(np.arange(len(self.first)), np.diff(self.start))
        self.all = np.arange(len(iv))
        self.given_w = None
        self.sig = None if iv.covariance is None else np.asarray(iv.covariance, float)
        self.jitter = False
        self.rates = None
        self.n = int(self.free.sum()) + 3
        self.settle_by_sd = True
        self.last_information = np.eye(self.n)
        self._cache: tuple[bytes, FloatArray, FloatArray | None] | None = None

    def geometry(self, p: FloatArray) -> FloatArray:
        """The full geometry vector of the parameters ``p``."""
        g = self.base.copy()
        g[self.free] = p[: int(self.free.sum())]
        return g

    def param_scale(self, p: FloatArray) -> FloatArray:
        # the lengths (names in metres) scale with their nominal size, angles and ratios by 1
        g = np.abs(self.base[self.free])
        names = np.array(self.kin.parameter_names)[self.free]
        scale = np.array([v if n.endswith("_m") else 1.0 for n, v in zip(names, g)])
        length = float(np.max(np.abs(self.base[[n.endswith("_m") for n in self.kin.parameter_names]])))
        return np.concatenate([scale, [length, length, 1.0]])

    def _local(self, g: FloatArray) -> FloatArray:
        return twist_displacement(self.kin.twist(self.values, g))

    def _motion(self, local: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Per interval the motion ``q`` ``(K, 3)``; per step its heading from the interval's start
        and its position after it ``(S, 2)``."""
        cum = np.cumsum(local[:, 2])
        phi = cum - local[:, 2]
        phi = phi - phi[self.first][self.seg]
        c, s = np.cos(phi), np.sin(phi)
        gx = c * local[:, 0] - s * local[:, 1]
        gy = s * local[:, 0] + c * local[:, 1]
        cx, cy = np.cumsum(gx), np.cumsum(gy)
        q = np.column_stack(
            [np.add.reduceat(gx, self.first), np.add.reduceat(gy, self.first), np.add.reduceat(local[:, 2], self.first)]
        )
        after = np.column_stack([cx - (cx - gx)[self.first][self.seg], cy - (cy - gy)[self.first][self.seg]])
        return q, phi, after

    def _evaluate(self, p: FloatArray, jacobian: bool) -> tuple[FloatArray, FloatArray | None]:
        key = p.tobytes()
        if self._cache is not None and self._cache[0] == key and (self._cache[2] is not None or not jacobian):
            return self._cache[1], self._cache[2]
        nf = int(self.free.sum())
        g = self.geometry(p)
        lp = p[nf:]
        local = self._local(g)
        q, phi, after = self._motion(local)
        h = se2.compose(se2.inverse(lp), se2.compose(q, lp))
        h[:, 2] = q[:, 2]
        jac = None
        if jacobian:
            jac = np.zeros((len(q), 3, self.n))
            rl = _rot(np.array(-lp[2]))
            # the geometry: each step's derivative by central differences, composed in closed form
            scale = self.param_scale(p)
            dq = np.zeros((len(q), 3, nf))
            for i, j in enumerate(np.flatnonzero(self.free)):
                e = 1e-6 * scale[i]
                up, dn = g.copy(), g.copy()
                up[j] += e
                dn[j] -= e
                d = (self._local(up) - self._local(dn)) / (2 * e)
                c, s = np.cos(phi), np.sin(phi)
                dx = c * d[:, 0] - s * d[:, 1]
                dy = s * d[:, 0] + c * d[:, 1]
                lever = q[self.seg, :2] - after  # what a turn of the step swings
                dx = dx - lever[:, 1] * d[:, 2]
                dy = dy + lever[:, 0] * d[:, 2]
                dq[:, 0, i] = np.add.reduceat(dx, self.first)
                dq[:, 1, i] = np.add.reduceat(dy, self.first)
                dq[:, 2, i] = np.add.reduceat(d[:, 2], self.first)
            # h_xy = R(-l_yaw) (q_xy + (R(q_yaw) - I) l_xy), h_yaw = q_yaw
            rq = _rot(q[:, 2])
            dh_dqyaw = rl @ (_J @ (rq @ lp[:2]).T)  # (2, K)
            jac[:, :2, :nf] = np.einsum("ij,kjn->kin", rl, dq[:, :2, :]) + dh_dqyaw.T[:, :, None] * dq[:, 2, None, :]
            jac[:, 2, :nf] = dq[:, 2, :]
            jac[:, :2, nf : nf + 2] = np.einsum("ij,kjl->kil", rl, rq - np.eye(2))
            jac[:, :2, nf + 2] = -(h[:, :2] @ _J.T)
        self._cache = (key, h, jac)
        return h, jac

    def res(self, p: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        h, _ = self._evaluate(np.asarray(p, float), False)
        r = self.s - h
        r[:, 2] = wrap_angle(r[:, 2])
        return np.asarray(r[idx], dtype=float)

    def jac(self, p: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        _, j = self._evaluate(np.asarray(p, float), True)
        assert j is not None
        return j[idx]


@dataclass(frozen=True)
class KinematicLimits:
    """The standard deviations beyond which a parameter counts as poorly determined.

    Parameters
    ----------
    relative_sd : float
        Of the lengths (diameters, wheelbase, ``l_x + l_y``) and the steering scale, relative.
    angle_sd_rad : float
        Of the steering offset and the sensor yaw [rad].
    position_sd_m : float
        Of the sensor position [m].
    """

    relative_sd: float = 0.005
    angle_sd_rad: float = math.radians(0.5)
    position_sd_m: float = 0.01


@dataclass(frozen=True)
class DrivingCoverage:
    """How a robot drove over the intervals, by its nominal geometry.

    Parameters
    ----------
    travel_m : float
        Distance the robot's origin travelled [m].
    sideways_m : float
        Of it, sideways (``|v_y|``) [m].
    turn_ccw_rad, turn_cw_rad : float
        Heading turned each way [rad].
    steer_left_m, steer_right_m : float
        A steered robot's wheel travel with the steering beyond 5 deg to the left and to the
        right [m] (:meth:`umbmark.kinds.Kind.steering_travel`).
    """

    travel_m: float
    sideways_m: float
    turn_ccw_rad: float
    turn_cw_rad: float
    steer_left_m: float = 0.0
    steer_right_m: float = 0.0


def driving(iv: JointIntervals, nominal: Kinematics) -> DrivingCoverage:
    """How the robot drove over the intervals (nominal geometry).

    Parameters
    ----------
    iv : JointIntervals
    nominal : Kinematics

    Returns
    -------
    DrivingCoverage
    """
    tw = nominal.twist(iv.steps.values)
    travel = float(np.hypot(tw[:, 0], tw[:, 1]).sum())
    left, right = kind_of(nominal).steering_travel(nominal, np.asarray(iv.steps.values, dtype=float))
    th = tw[:, 2]
    return DrivingCoverage(
        travel_m=travel,
        sideways_m=float(np.abs(tw[:, 1]).sum()),
        turn_ccw_rad=float(th[th > 0].sum()),
        turn_cw_rad=float(-th[th < 0].sum()),
        steer_left_m=left,
        steer_right_m=right,
    )


def _advice(cov: DrivingCoverage, nominal: Kinematics) -> list[str]:
    """What the driving lacks, each with what to drive: turns both ways, then the kind's own
    (:meth:`umbmark.kinds.Kind.advice`)."""
    out = []
    if min(cov.turn_ccw_rad, cov.turn_cw_rad) < math.radians(90.0):
        side = "clockwise" if cov.turn_cw_rad < cov.turn_ccw_rad else "counter-clockwise"
        out.append(f"the robot hardly turns {side}: drive turns both ways")
    return out + kind_of(nominal).advice(cov)


def _label(name: str) -> str:
    return f"`{name}`"


def _judge(prob: KinematicProblem, cover: DrivingCoverage, limits: KinematicLimits):
    """The kind's identifiability for the engine (:data:`umbmark.correct.selfcal.estimate.Identify`)."""
    names = [n for n, f in zip(prob.kin.parameter_names, prob.free) if f] + list(SENSOR_PARAMETERS)

    def judge(p: FloatArray, info: FloatArray, idx: NDArray[np.intp], covariance: FloatArray | None):
        sc = prob.param_scale(p)
        fs = info * np.outer(sc, sc)
        fs = 0.5 * (fs + fs.T)
        w, v = np.linalg.eigh(fs) if np.all(np.isfinite(fs)) else (np.zeros(prob.n), np.eye(prob.n))
        advice = _advice(cover, prob.kin)
        what = "; ".join(advice) or "drive longer, mixing every motion the robot can make, both ways"
        if w[-1] <= 0 or w[0] <= w[-1] / _SINGULAR_COND:
            null = v[:, w <= max(w[-1], 0.0) / _SINGULAR_COND]
            weight = np.sqrt((null * null).sum(axis=1))
            bad = [_label(names[i]) for i in np.flatnonzero(weight > 0.2)] or [_label(names[int(np.argmax(weight))])]
            msg = f"the intervals cannot determine {', '.join(bad)} (the information matrix is singular): {what}"
            return np.full((prob.n, prob.n), np.inf), [], msg
        cov = (v / w) @ v.T * np.outer(sc, sc) if covariance is None else np.asarray(covariance, float)
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        poor = []
        for i, n in enumerate(names):
            if n.endswith("_rad"):
                if sd[i] > limits.angle_sd_rad:
                    poor.append(f"{_label(n)} (sd {math.degrees(sd[i]):.2g} deg)")
            elif n.startswith("sensor_"):
                if sd[i] > limits.position_sd_m:
                    poor.append(f"{_label(n)} (sd {1e3 * sd[i]:.2g} mm)")
            elif sd[i] > limits.relative_sd * abs(p[i]):
                poor.append(f"{_label(n)} (sd {100 * sd[i] / abs(p[i]):.2g} %)")
        if poor:
            return cov, [f"poorly determined by these intervals: {', '.join(poor)}; {what}"], None
        # driving that leaves a parameter resting on an assumption, even where the fit looks sure
        return cov, advice, None

    return judge


@dataclass(frozen=True, eq=False)
class KinematicSelfcalResult:
    """A self-calibration of a robot of any kind (a tricycle, a mecanum robot, a differential drive):
    geometry, sensor pose, their covariance and 95 % intervals.

    Attributes
    ----------
    kinematics : Kinematics
        The estimated geometry (fixed parameters at their nominal values).
    nominal : Kinematics
        The nominal geometry.
    sensor_pose : tuple of float
        ``(x_m, y_m, yaw_rad)``.
    parameters : tuple of str
        The estimated parameters, in the order of ``covariance``.
    estimate : numpy.ndarray
        Their values (SI).
    covariance : numpy.ndarray
    ci95 : dict
        Name -> ``(low, high)`` (SI).
    intervals_used : int
    intervals_rejected : tuple of int
    warnings : list of str
    noise_sd : tuple of float
        The scale of the displacements' noise ``(dx_m, dy_m, dyaw_rad)``.
    noise_dof : float
        Its Student t degrees of freedom (inf: Gaussian).
    covariance_blocks : int
        Blocks of time of the covariance of shared errors (0: none).
    t_quantile : float
        The quantile of the 95 % intervals.
    """

    kinematics: Kinematics
    nominal: Kinematics
    sensor_pose: tuple[float, float, float]
    parameters: tuple[str, ...]
    estimate: FloatArray
    covariance: FloatArray
    ci95: dict[str, tuple[float, float]]
    intervals_used: int
    intervals_rejected: tuple[int, ...]
    warnings: list[str] = field(default_factory=list)
    noise_sd: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    noise_dof: float = math.inf
    covariance_blocks: int = 0
    t_quantile: float = 1.959963984540054

    @property
    def kind(self) -> str:
        """The kind's name (:data:`umbmark.kinds.KINDS`)."""
        return self.kinematics.kind

    @property
    def sd(self) -> FloatArray:
        """The standard deviations, in the order of :attr:`parameters`."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    def interval(self, name: str) -> tuple[float, float] | None:
        """The 95 % interval of a parameter (SI), or None for a fixed one."""
        return self.ci95.get(name)

    def _ci(self, name: str, k: float) -> list[float] | None:
        c = self.interval(name)
        return None if c is None else [c[0] * k, c[1] * k]

    def to_dict(self) -> dict[str, Any]:
        """The result as JSON: millimetres and degrees, each estimate with its ``_ci95`` ``[low, high]``.

        Returns
        -------
        dict
            ``kinematics``; the kind's geometry under its keys (:attr:`umbmark.kinds.Parameter.key`,
            each with its ``_ci95``, null when it was not estimated): a tricycle's
            ``wheel_diameter_mm``, ``wheelbase_mm``, ``steering_offset_deg``, ``steering_scale``;
            a mecanum robot's ``wheel_diameters_mm`` (``front_left``, ``front_right``,
            ``rear_left``, ``rear_right``) and ``lx_plus_ly_mm``; a differential drive's
            ``wheel_diameter_left_mm``, ``wheel_diameter_right_mm``, ``wheelbase_mm``; then
            ``sensor_pose`` (``x_mm``, ``y_mm``, ``yaw_deg`` and their
            ``_ci95``), ``intervals_used``, ``intervals_rejected``, ``warnings``, the nominal
            geometry (``nominal``), ``noise_sd``, ``noise_dof``, ``covariance_blocks``,
            ``parameters``, ``sd`` and ``covariance`` (SI).
        """
        deg = math.degrees(1.0)
        g = self.kinematics
        out: dict[str, Any] = {"kinematics": self.kind}
        out.update(kind_of(g).geometry_json(g, self._ci))
        x, y, yaw = self.sensor_pose
        out["sensor_pose"] = {
            "x_mm": x * 1e3,
            "x_mm_ci95": self._ci("sensor_x_m", 1e3),
            "y_mm": y * 1e3,
            "y_mm_ci95": self._ci("sensor_y_m", 1e3),
            "yaw_deg": math.degrees(yaw),
            "yaw_deg_ci95": self._ci("sensor_yaw_rad", deg),
        }
        out["intervals_used"] = int(self.intervals_used)
        out["intervals_rejected"] = [int(i) for i in self.intervals_rejected]
        out["warnings"] = list(self.warnings)
        out["nominal"] = kind_of(self.nominal).geometry_json(self.nominal)
        out["noise_sd"] = {
            "dx_mm": self.noise_sd[0] * 1e3,
            "dy_mm": self.noise_sd[1] * 1e3,
            "dyaw_deg": math.degrees(self.noise_sd[2]),
        }
        out["noise_dof"] = self.noise_dof if math.isfinite(self.noise_dof) else None
        out["covariance_blocks"] = int(self.covariance_blocks)
        out["parameters"] = list(self.parameters)
        out["sd"] = [float(v) for v in self.sd]
        out["covariance"] = [[float(v) for v in row] for row in self.covariance]
        return out


def _start_pose(prob: KinematicProblem, sensor_pose: FloatArray | None) -> FloatArray:
    """The sensor pose with the nominal geometry: the yaw from the translations' directions (of the
    intervals that hardly turn), the position by linear least squares; or the one given."""
    if sensor_pose is not None:
        return np.asarray(sensor_pose, dtype=float)
    g = prob.base
    q, _, _ = prob._motion(prob._local(g))
    s = prob.s
    small = np.abs(q[:, 2]) < math.radians(5.0)
    use = small if small.sum() >= 3 else np.ones(len(q), dtype=bool)
    z = np.sum((q[use, 0] - 1j * q[use, 1]) * (s[use, 0] + 1j * s[use, 1]))
    yaw = -float(np.angle(z)) if abs(z) > 0 else 0.0
    # R(yaw) s_xy - q_xy = (R(q_yaw) - I) l_xy
    rs = s[:, :2] @ _rot(np.array(yaw)).T
    a = _rot(q[:, 2]) - np.eye(2)
    b = rs - q[:, :2]
    try:
        lxy = np.linalg.lstsq(a.reshape(-1, 2), b.reshape(-1), rcond=None)[0]
    except np.linalg.LinAlgError:
        lxy = np.zeros(2)
    return np.array([lxy[0], lxy[1], yaw])


def kinematic_selfcal(
    intervals: JointIntervals,
    nominal: Kinematics,
    *,
    fit: Sequence[str] | None = None,
    sensor_pose: ArrayLike | None = None,
    reject_outliers: bool = True,
    loss: str = "student",
    outlier_tail: float = 1e-4,
    max_rounds: int = 10,
    limits: KinematicLimits | None = None,
    blocks: ArrayLike | None = None,
    block_s: float = BLOCK_S,
    max_blocks: int = MAX_BLOCKS,
) -> KinematicSelfcalResult:
    """Estimate a robot's geometry and its sensor's pose from intervals of joint steps and sensor displacements.

    Parameters
    ----------
    intervals : JointIntervals
        In time order.
    nominal : Kinematics
        The nominal geometry (the start, the scale of the checks, the values of parameters not
        fitted).
    fit : sequence of str, optional
        The geometry parameters to estimate (names of ``nominal.parameter_names``); default the
        kind's (:meth:`umbmark.kinds.Kind.default_fit`: all but a tricycle's ``steering_scale``).
    sensor_pose : array_like, optional
        A start for the sensor pose ``(x_m, y_m, yaw_rad)`` (default: found from the data).
    reject_outliers, loss, outlier_tail, max_rounds, blocks, block_s, max_blocks
        As for :func:`umbmark.correct.selfcal.selfcal`.
    limits : KinematicLimits, optional
        The standard deviations beyond which a parameter is reported poorly determined.

    Returns
    -------
    KinematicSelfcalResult

    Raises
    ------
    InputError
        Fewer intervals than parameters and three, joints that never move, an unknown
        parameter or loss, blocks that do not fit, or intervals that cannot determine the
        parameters (the message names them and what to drive).
    """
    if not isinstance(intervals, JointIntervals):
        raise InputError(f"`intervals` must be JointIntervals, got {type(intervals).__name__}")
    src = intervals.source
    noise = loss_named(loss)
    if not 0 < outlier_tail < 1:
        raise InputError(f"`outlier_tail` must be a probability between 0 and 1, got {outlier_tail!r}")
    if intervals.steps.joints != len(nominal.joint_roles):
        raise InputError(
            f"the intervals hold {intervals.steps.joints} joints, a {nominal.kind} has {len(nominal.joint_roles)} "
            f"({', '.join(nominal.joint_roles)})",
            src,
        )
    names = nominal.parameter_names
    wanted = kind_of(nominal).default_fit() if fit is None else tuple(fit)
    unknown = [n for n in wanted if n not in names]
    if unknown:
        raise InputError(f"unknown parameter(s) {', '.join(unknown)} of a {nominal.kind} (it has {', '.join(names)})")
    free = [n in wanted for n in names]
    k = len(intervals)
    if k < max(3, sum(free) + 3):
        raise InputError(
            f"a self-calibration of a {nominal.kind} needs at least {max(3, sum(free) + 3)} intervals, got {k}", src
        )
    rolling = np.array(nominal.rolling)
    if not np.any(intervals.steps.values[:, rolling]):
        raise InputError("the wheels do not turn in any interval: record intervals while the robot drives", src)
    labels = time_blocks(intervals.dt_s, block_s, max_blocks) if blocks is None else np.asarray(blocks)
    if labels.shape != (k,):
        raise InputError(f"`blocks` must hold one label per interval ({k}), got shape {labels.shape}", src)
    prob = KinematicProblem(intervals, nominal, free)
    l0 = _start_pose(prob, None if sensor_pose is None else np.asarray(sensor_pose, dtype=float).reshape(3))
    p0 = np.concatenate([nominal.vector()[prob.free], l0])
    w0 = diag_whitener(robust_sd(prob.res(p0, prob.all)))
    p0 = prob.fit(p0, prob.all, w0, loss=ROBUST_START)  # the nominal start: refined robustly whatever the loss
    if not np.all(np.isfinite(p0)):
        raise InputError("the fit did not converge to finite values: check the units and the joint order", src)
    result: Fit = fit_and_reject(prob, p0, noise, reject_outliers, outlier_tail, max_rounds)
    unc: Uncertainty = uncertainty(
        prob, result, noise, labels, _judge(prob, driving(intervals, nominal), limits or KinematicLimits())
    )
    return _result(prob, result, unc, intervals, nominal)


def kinematic_residuals(intervals: JointIntervals, result: KinematicSelfcalResult) -> FloatArray:
    """Each interval's measured minus predicted sensor displacement at the estimate (the heading wrapped).

    Parameters
    ----------
    intervals : JointIntervals
        The intervals the estimate was made from.
    result : KinematicSelfcalResult

    Returns
    -------
    numpy.ndarray
        ``(K, 3)`` ``(dx_m, dy_m, dyaw_rad)`` in the sensor's frame.
    """
    names = result.nominal.parameter_names
    prob = KinematicProblem(intervals, result.nominal, [n in result.parameters for n in names])
    return prob.res(np.asarray(result.estimate, dtype=float), prob.all)


def _refuse_negative(nominal: Kinematics, g: FloatArray, source: str | None) -> None:
    """A fitted diameter or length that is not positive (or a tricycle's steering half a turn off) is
    a joint read backwards or joints in another order: an error saying which
    (:meth:`umbmark.kinds.Kind.negative`)."""
    names = nominal.parameter_names
    bad = [n for n, v in zip(names, g) if n.endswith("_m") and not v > 0]
    bad, why = kind_of(nominal).negative(g, bad)
    if not bad:
        return
    raise InputError(f"the fit needs a negative {' and '.join(bad)} (or the steering half a turn off): {why}", source)


def _nominal_notes(nominal: Kinematics, g: FloatArray, free: NDArray[np.bool_]) -> list[str]:
    """A fitted size far from its nominal one (the mean of the wheels it gives): the nominal size
    given in another unit or as another quantity (:func:`umbmark.model.geometry.nominal_slip`),
    for each of the kind's nominal sizes (:attr:`umbmark.kinds.Kind.sizes`)."""
    nom = nominal.vector()
    names = nominal.parameter_names
    out = []
    for size in kind_of(nominal).sizes:
        idx = [names.index(p) for p in size.parameters if free[names.index(p)]]
        if not idx:
            continue
        est, was = float(np.mean(g[idx])), float(np.mean(nom[idx]))
        slip = nominal_slip(size.quantity, est / was) if was > 0 else None
        if slip is not None:
            out.append(
                f"the {size.label} comes out {est / was:.3g} x the nominal `{size.option}` ({1e3 * est:.1f} mm "
                f"against {1e3 * was:.1f} mm): {slip} The estimate is the robot's; give the nominal size right "
                "so that the controller's parameters and the factors against it mean what they say"
            )
    return out


def _result(
    prob: KinematicProblem, fit: Fit, unc: Uncertainty, iv: JointIntervals, nominal: Kinematics
) -> KinematicSelfcalResult:
    p = fit.p.copy()
    nf = int(prob.free.sum())
    p[nf + 2] = float(wrap_angle(p[nf + 2]))
    g = prob.geometry(p)
    warnings = list(iv.warnings) + list(unc.warnings)
    _refuse_negative(nominal, g, iv.source)
    try:
        geometry = nominal.with_vector(g)
    except InputError as err:
        raise InputError(
            f"the fit left an impossible geometry ({err}): check the joints' order and signs", iv.source
        ) from None
    rejected = np.flatnonzero(~fit.inliers)
    if rejected.size > 0.2 * len(iv):
        warnings.append(
            f"{rejected.size} of {len(iv)} intervals ({100 * rejected.size / len(iv):.0f} %) rejected as outliers: "
            "check the scan matching (and the joint data) of those intervals"
        )
    warnings += _nominal_notes(nominal, g, prob.free)
    names = tuple(n for n, f in zip(nominal.parameter_names, prob.free) if f) + SENSOR_PARAMETERS
    sd = np.sqrt(np.maximum(np.diag(unc.covariance), 0.0))
    tq = unc.t_quantile
    ci = {n: (float(p[i] - tq * sd[i]), float(p[i] + tq * sd[i])) for i, n in enumerate(names)}
    return KinematicSelfcalResult(
        kinematics=geometry,
        nominal=nominal,
        sensor_pose=(float(p[nf]), float(p[nf + 1]), float(p[nf + 2])),
        parameters=names,
        estimate=p,
        covariance=unc.covariance,
        ci95=ci,
        intervals_used=int(fit.inliers.sum()),
        intervals_rejected=tuple(int(i) for i in rejected),
        warnings=warnings,
        noise_sd=unc.noise_sd,
        noise_dof=float(fit.nu),
        covariance_blocks=unc.blocks,
        t_quantile=tq,
    )
