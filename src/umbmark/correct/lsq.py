"""General-path least squares (method ``lsq``): wheel diameters and wheelbase from logs of any
path with ground truth (circles, free driving, straight-and-spin, squares).

The logged wheel increments are replayed (:func:`umbmark.model.dataset.replay_increments`, exact arcs;
the fast kernels of :mod:`umbmark.model.odometry` on long logs; end poses only in end mode) with
trial parameters, and the parameters minimise the pose errors of the replayed odometry
against the ground truth:

* ``mode="sampled"``: errors at up to ``points_per_run`` samples spread evenly along each
  run (every run counts equally);
* ``mode="end"``: the end-pose error of each run only.

A pose error is ``(x_odo - x_gt, y_odo - y_gt, w * wrap(theta_odo - theta_gt))`` with
``w = heading_weight_m`` metres per radian.

Which parameters are fitted (``scale``):

* ``"fit"``: D_L, D_R and b (three parameters). Right when the ground truth measures
  distances: poses along the path, or end poses away from the start.
* ``"fixed"``: E_d = D_R / D_L and b with D_avg kept at nominal (two parameters), as the
  paper does. Needed when the ground truth does not fix the scale: the end pose of a
  closed path (a square, a full circle) is unchanged when D_L, D_R and b are all scaled by
  the same factor.
* ``"auto"`` (default): ``fit`` in sampled mode, and in end mode when the runs end on
  average at least 10 % of their path length away from where they started; ``fixed``
  otherwise. The result says which (``scale_fitted``, ``scale_reason``).

``fit_offset``: in sampled mode, also fit where the tracked point (a motion-capture marker)
sits in the robot frame relative to the axle midpoint (two more parameters, reported as
``tracked_point_offset_mm``). A marker off the axle swings around it in every turn, which
otherwise reads as odometry error along the path. The run's start frame stays that of the
tracked point.

Uncertainty: the standard deviations from the Gauss-Newton covariance
``s^2 (J^T J)^-1`` (``s^2`` = residual sum of squares / (N - p)). In sampled mode the residuals
along one run are strongly correlated, so these are optimistic; :mod:`umbmark.realrobot.replay`
adds a leave-one-run-out jackknife, which is the figure to trust.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from umbmark.correct.registry import register_path
from umbmark.errors import InputError
from umbmark.model.dataset import FAST_MIN_SAMPLES, Dataset, WheelGeometry, replay_increments
from umbmark.model.defaults import HEADING_WEIGHT_M, LSQ_MODES, LSQ_SCALES, POINTS_PER_RUN
from umbmark.model.geometry import OdometryParams, wrap_angle

__all__ = ["LsqStd", "LsqResult", "fit_lsq", "lsq_method", "LSQ_DEFAULTS"]

_LOG_LIMIT = 30.0  # trial log-parameters are clipped to +-this (no overflow on a diverging fit)
_FAR_START = 1.2  # the linear start is tried where a parameter of it is this factor from nominal
_MAX_FACTOR = 10.0  # a fitted diameter or wheelbase further than this factor from nominal: no fit

LSQ_DEFAULTS: dict[str, Any] = {
    "mode": "auto",
    "scale": "auto",
    "heading_weight_m": 0.5,
    "points_per_run": 100,
    "fit_offset": False,
}


@dataclass(frozen=True)
class LsqStd:
    """The Gauss-Newton standard deviations of a least-squares fit (SI).

    Parameters
    ----------
    diameter_left_m, diameter_right_m, wheelbase_m : float
        Of the fitted diameters and wheelbase [m].
    ed, es : float
        Of E_d and of the wheel scale E_s (0 when the scale was kept at nominal).
    """

    diameter_left_m: float
    diameter_right_m: float
    wheelbase_m: float
    ed: float
    es: float

    def to_dict(self) -> dict[str, float]:
        """``diameter_left_mm``, ``diameter_right_mm``, ``wheelbase_mm``, ``Ed``, ``Es``."""
        return {
            "diameter_left_mm": self.diameter_left_m * 1e3,
            "diameter_right_mm": self.diameter_right_m * 1e3,
            "wheelbase_mm": self.wheelbase_m * 1e3,
            "Ed": self.ed,
            "Es": self.es,
        }


@dataclass(frozen=True)
class LsqResult:
    """The geometry fitted by :func:`fit_lsq`, and the figures of the fit.

    Parameters
    ----------
    geometry : WheelGeometry
        The fitted wheel diameters and wheelbase.
    nominal : WheelGeometry
        The first data set's nominal geometry (the reference of the relative figures).
    mode : str
        ``sampled`` or ``end`` (see the module docstring).
    scale_fitted : bool
        Whether D_avg was fitted (``fit``) or kept at nominal (``fixed``).
    scale_reason : str
        Why.
    std : LsqStd
        Gauss-Newton standard deviations.
    n_runs, n_residuals : int
        Runs and residuals fitted.
    rms_position_m, rms_heading_rad : float
        RMS of the position and heading residuals at the fit.
    cost : float
        Final least-squares cost.
    success : bool
        Whether the optimiser converged.
    message : str
        The optimiser's message.
    heading_weight_m : float
        Metres of position residual worth one radian of heading residual.
    points_per_run : int
        Poses compared per run (1 in ``end`` mode).
    marker_offset_m, marker_offset_std_m : (float, float) or None
        With ``fit_offset``: where the tracked point sits in the robot frame (x forward, y
        left of the axle's midpoint) and its standard deviations [m].
    """

    geometry: WheelGeometry
    nominal: WheelGeometry
    mode: str
    scale_fitted: bool
    scale_reason: str
    std: LsqStd
    n_runs: int
    n_residuals: int
    rms_position_m: float
    rms_heading_rad: float
    cost: float
    success: bool
    message: str
    heading_weight_m: float = 0.5
    points_per_run: int = 1
    marker_offset_m: tuple[float, float] | None = None
    marker_offset_std_m: tuple[float, float] | None = None

    @property
    def fitted_parameters(self) -> str:
        """The parameters the fit adjusted, in words."""
        return "D_L, D_R, b" if self.scale_fitted else "E_d, b (D_avg kept at nominal)"

    def to_dict(self) -> dict[str, Any]:
        """The fit as a JSON-ready dict (millimetres, degrees).

        Returns
        -------
        dict
            ``method`` (``lsq``), the mode and scale decision, the geometry relative to the
            nominal one, ``std_model``, the residual figures, ``heading_weight_m``,
            ``points_per_run`` and, with a fitted tracked point, ``tracked_point_offset_mm`` and
            ``tracked_point_offset_std_mm``.
        """
        g, n = self.geometry, self.nominal
        return {
            "method": "lsq",
            "mode": self.mode,
            "scale_fitted": self.scale_fitted,
            "scale_reason": self.scale_reason,
            "fitted_parameters": self.fitted_parameters,
            **g.relative_to(n),
            "std_model": self.std.to_dict(),
            "n_runs": self.n_runs,
            "n_residuals": self.n_residuals,
            "rms_position_residual_mm": self.rms_position_m * 1e3,
            "rms_heading_residual_deg": math.degrees(self.rms_heading_rad),
            "converged": self.success,
            "heading_weight_m": self.heading_weight_m,
            "points_per_run": self.points_per_run,
            **(
                {}
                if self.marker_offset_m is None or self.marker_offset_std_m is None
                else {
                    "tracked_point_offset_mm": [v * 1e3 for v in self.marker_offset_m],
                    "tracked_point_offset_std_mm": [v * 1e3 for v in self.marker_offset_std_m],
                }
            ),
        }


class _Problem:
    """Pre-computed arrays of one data set: padded increments, chosen samples, ground truth."""

    def __init__(self, ds: Dataset, mode: str, points_per_run: int) -> None:
        self.ds = ds
        self.dl, self.dr, n = ds.padded()
        rows, cols, gts = [], [], []
        for i, run in enumerate(ds.runs):
            if mode == "sampled":
                ok = np.flatnonzero(np.all(np.isfinite(run.gt), axis=1))
                ok = ok[ok > 0]  # sample 0 is the start pose: zero error by construction
                if ok.size > points_per_run:
                    pick = np.unique(np.round(np.linspace(0, ok.size - 1, points_per_run)).astype(int))
                    ok = ok[pick]
                idx = ok
                g = run.gt[idx]
            else:
                end = run.end_truth
                idx = np.array([len(run) - 1])
                g = end[None, :]
            rows.append(np.full(idx.size, i))
            cols.append(idx)
            gts.append(g)
        self.rows = np.concatenate(rows)
        self.cols = np.concatenate(cols)
        self.gt = np.concatenate(gts)
        self.k = math.pi / ds.units_per_wheel_rev
        self.end = mode != "sampled"
        if not self.end:  # samples after the last compared one do not matter
            kmax = int(self.cols.max()) + 1
            self.dl, self.dr = self.dl[:, :kmax], self.dr[:, :kmax]
        # whole-number increments (encoder pulses): checked once, not at every trial
        self.integral: bool | None = None
        if self.dl.size >= FAST_MIN_SAMPLES:
            self.integral = bool(
                np.all(self.dl == np.round(self.dl))
                and np.all(self.dr == np.round(self.dr))
                and max(np.abs(self.dl).max(), np.abs(self.dr).max()) < 2**52
            )

    def residuals(
        self, d_left: float, d_right: float, b: float, w: float, offset: npt.ArrayLike | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose errors ``(ex, ey, etheta)`` of the replayed odometry at the compared samples.

        Parameters
        ----------
        d_left, d_right, b : float
            Trial wheel diameters and wheelbase [m].
        w : float
            Heading weight [m/rad] (the caller applies it).
        offset : array_like or None
            The tracked point's position in the robot frame [m]; ``None``: the axle midpoint.

        Returns
        -------
        tuple of numpy.ndarray
            Position errors [m] and wrapped heading errors [rad].
        """
        p = OdometryParams(self.k * d_left, self.k * d_right, b)
        if self.end:  # one end pose per run, in run order
            x, y, th = (
                np.reshape(a, -1)[self.rows]
                for a in replay_increments(self.dl, self.dr, p, end=True, integral=self.integral)
            )
        else:
            x, y, th = replay_increments(self.dl, self.dr, p, integral=self.integral)
            sel = (self.rows, self.cols)
            x, y, th = x[sel], y[sel], th[sel]
        if offset is not None:  # the tracked point sits at ``offset`` in the robot frame
            off = np.asarray(offset, dtype=float)
            c, s = np.cos(th), np.sin(th)
            x = x + (c - 1.0) * off[0] - s * off[1]
            y = y + s * off[0] + (c - 1.0) * off[1]
        ex = x - self.gt[:, 0]
        ey = y - self.gt[:, 1]
        eth = wrap_angle(th - self.gt[:, 2])
        return ex, ey, eth


def _heading_start(datasets: Sequence[Dataset]) -> tuple[float, float] | None:
    """``(D_R / b, D_L / b)`` from the ground truth's headings, linear in the wheel travel.

    Along a run the heading is ``k (D_R R(t) - D_L L(t)) / b`` (``R``, ``L``: the wheels'
    summed increments, ``k`` = pi / units per revolution), so the two ratios are the linear
    least squares fit of the unwrapped true headings: no start value, no local minimum, and
    whatever the nominal sizes (a diameter given as the radius, a size in another unit).
    None where the runs do not turn enough to tell the two apart.
    """
    rows, rhs = [], []
    for ds in datasets:
        k = math.pi / ds.units_per_wheel_rev
        for r in ds.runs:
            if r.gt is None:
                continue
            ok = np.flatnonzero(np.all(np.isfinite(r.gt), axis=1))
            if ok.size < 3 or ok[0] != 0:
                continue
            rows.append(np.column_stack([k * np.cumsum(r.d_right)[ok], -k * np.cumsum(r.d_left)[ok]]))
            rhs.append(np.unwrap(r.gt[ok, 2]) - r.gt[0, 2])
    if not rows:
        return None
    a, y = np.concatenate(rows), np.concatenate(rhs)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(y))):
        return None
    sv = np.linalg.svd(a, compute_uv=False)
    if sv.size < 2 or not sv[-1] > 1e-6 * sv[0]:
        return None
    (u, v), *_ = np.linalg.lstsq(a, y, rcond=None)
    return (float(u), float(v)) if u > 0 and v > 0 else None


def _linear_start(problems: Sequence[_Problem], datasets: Sequence[Dataset]) -> tuple[float, float, float] | None:
    """A start ``(D_L, D_R, b)`` from the ground truth alone (sampled mode).

    The heading fixes ``D_R / b`` and ``D_L / b`` (:func:`_heading_start`); scaling the three
    together scales the path and keeps the heading, so the positions replayed with
    ``D_L = 1`` fix ``D_L`` by linear least squares.
    """
    ratios = _heading_start(datasets)
    if ratios is None:
        return None
    u, v = ratios
    q, g = [], []
    for pr in problems:
        ex, ey, _ = pr.residuals(1.0, u / v, 1.0 / v, 0.0)
        q.append(np.concatenate([ex + pr.gt[:, 0], ey + pr.gt[:, 1]]))
        g.append(np.concatenate([pr.gt[:, 0], pr.gt[:, 1]]))
    qa, ga = np.concatenate(q), np.concatenate(g)
    den = float(qa @ qa)
    if not (math.isfinite(den) and den > 0):
        return None
    d_l = float(qa @ ga) / den
    if not (math.isfinite(d_l) and d_l > 0):
        return None
    return d_l, d_l * u / v, d_l / v


def _scale_decision(datasets: Sequence[Dataset], mode: str, scale: str) -> tuple[bool, str]:
    """Whether to fit the scale (D_avg), and why (see ``scale`` in the module docstring)."""
    if scale == "fit":
        return True, 'asked for (`scale="fit"`)'
    if scale == "fixed":
        return False, 'asked for (`scale="fixed"`)'
    if mode == "sampled":
        return True, "the ground truth along the path measures distances, so it fixes the scale"
    ratios = []
    for ds in datasets:
        for run in ds.runs:
            end = run.end_truth
            k = math.pi * ds.nominal.diameter_avg_m / ds.units_per_wheel_rev
            path = np.sum(0.5 * np.abs(run.d_left + run.d_right)) * k
            if path > 0:
                ratios.append(math.hypot(end[0], end[1]) / path)
    r = float(np.mean(ratios)) if ratios else 0.0
    if r >= 0.1:
        return True, f"the runs end {100 * r:.0f} % of their path length from the start, so the end poses fix the scale"
    return False, (
        f"the runs end near their start ({100 * r:.1f} % of the path length): closed paths do not fix the "
        "scale, so D_avg is kept at nominal"
    )


def fit_lsq(
    datasets: Dataset | Sequence[Dataset],
    mode: str = LSQ_MODES[0],
    scale: str = LSQ_SCALES[0],
    heading_weight_m: float = HEADING_WEIGHT_M,
    points_per_run: int = POINTS_PER_RUN,
    start: WheelGeometry | None = None,
    fit_offset: bool = False,
) -> LsqResult:
    """Fit the geometry to one or more data sets of the same robot (see the module docstring).

    The data sets may have different nominal geometries (the fit is in absolute diameters and
    wheelbase; their encoder units must describe the same wheels). The first data set's nominal
    geometry is the reference for E_b, E_s and the fixed-scale D_avg.

    Parameters
    ----------
    datasets : Dataset or sequence of Dataset
        The logs, fitted jointly.
    mode : {"auto", "sampled", "end"}
        Compare poses along the path (``sampled``) or end poses only (``end``); ``auto``:
        sampled where every run has ground truth along its path.
    scale : {"auto", "fit", "fixed"}
        Fit D_L, D_R and b (``fit``), or E_d and b with D_avg at nominal (``fixed``).
    heading_weight_m : float
        Metres of position error one radian of heading error counts as (>= 0).
    points_per_run : int
        Samples compared per run in sampled mode (>= 1).
    start : WheelGeometry or None
        Start of the fit; ``None``: the nominal geometry.
    fit_offset : bool
        Also fit the tracked point's offset from the axle midpoint (sampled mode).

    Returns
    -------
    LsqResult
        The fitted geometry and the figures of the fit.

    Raises
    ------
    InputError
        No data, unknown options, runs without the ground truth the mode needs, or no valid
        geometry (the fit diverged).
    """
    datasets = [datasets] if isinstance(datasets, Dataset) else list(datasets)
    mode = _checked_mode(datasets, mode, scale, heading_weight_m, points_per_run, fit_offset)
    fit_scale, reason = _scale_decision(datasets, mode, scale)
    nominal = datasets[0].nominal
    problems = [_Problem(ds, mode, points_per_run) for ds in datasets]
    par = _Parameters(fit_scale, fit_offset, nominal.diameter_avg_m)
    linear = _linear_start(problems, datasets) if start is None and mode == "sampled" else None
    w = heading_weight_m

    def fun(p: np.ndarray) -> np.ndarray:
        d_l, d_r, b = par.unpack(p)
        parts = []
        for pr in problems:
            ex, ey, eth = pr.residuals(d_l, d_r, b, w, par.offset_of(p))
            parts += [ex, ey, w * eth]
        return np.concatenate(parts)

    sol = _solve(fun, par.starts(start or nominal, linear))
    d_l, d_r, b = par.unpack(sol.x)
    geom = _checked_geometry(d_l, d_r, b, nominal, finite=bool(np.all(np.isfinite(sol.x))))
    std, offset, offset_sd = par.uncertainty(sol, nominal)
    # position / heading parts of the residuals
    pos_parts, head_parts = [], []
    for pr in problems:
        ex, ey, eth = pr.residuals(d_l, d_r, b, w, par.offset_of(sol.x))
        pos_parts.append(np.hypot(ex, ey))
        head_parts.append(eth)
    pos = np.concatenate(pos_parts)
    head = np.concatenate(head_parts)
    return LsqResult(
        geometry=geom,
        nominal=nominal,
        mode=mode,
        scale_fitted=fit_scale,
        scale_reason=reason,
        std=std,
        n_runs=sum(len(ds.runs) for ds in datasets),
        n_residuals=int(sol.fun.size),
        rms_position_m=float(np.sqrt(np.mean(pos**2))),
        rms_heading_rad=float(np.sqrt(np.mean(head**2))),
        cost=float(sol.cost),
        success=bool(sol.success),
        message=str(sol.message),
        heading_weight_m=w,
        points_per_run=points_per_run if mode == "sampled" else 1,
        marker_offset_m=offset,
        marker_offset_std_m=offset_sd,
    )


def _either(names: Sequence[str]) -> str:
    """``auto, sampled or end``."""
    return f"{', '.join(names[:-1])} or {names[-1]}"


def _checked_mode(
    datasets: list[Dataset], mode: str, scale: str, heading_weight_m: float, points_per_run: int, fit_offset: bool
) -> str:
    """The options checked, and the mode (``auto``: sampled where every run has a ground truth
    along its path); an error for a run without the ground truth the mode needs."""
    if not datasets:
        raise InputError("lsq: no data")
    if mode not in LSQ_MODES:
        raise InputError(f"unknown lsq mode {mode!r} (use {_either(LSQ_MODES)})")
    if scale not in LSQ_SCALES:
        raise InputError(f"unknown lsq scale option {scale!r} (use {_either(LSQ_SCALES)})")
    if not (math.isfinite(heading_weight_m) and heading_weight_m >= 0):
        raise InputError(f"heading weight must be >= 0, got {heading_weight_m!r}")
    if points_per_run < 1:
        raise InputError("points per run must be >= 1")
    all_runs = [(ds, r) for ds in datasets for r in ds.runs]
    if mode == "auto":
        mode = "sampled" if all(r.has_trajectory for _, r in all_runs) else "end"
    for ds, r in all_runs:
        where = r.source or f"{ds.name}/{r.name}"
        if mode == "sampled" and not r.has_trajectory:
            raise InputError("lsq (sampled poses) needs ground truth along the path; this run has none", where)
        if mode == "end" and r.end_truth is None:
            raise InputError("lsq needs a ground-truth end pose; this run has none", where)
    if fit_offset and mode != "sampled":
        raise InputError("fitting the tracked point's offset needs ground truth along the path (sampled mode)")
    return mode


def _exp(v: float) -> float:
    """``exp(v)``, ``v`` clipped: a diverging trial must not overflow (the result is checked after)."""
    return math.exp(min(max(float(v), -_LOG_LIMIT), _LOG_LIMIT))


@dataclass(frozen=True)
class _Parameters:
    """The fit's parameter vector: ``log D_L, log D_R, log b`` (the scale fitted) or ``log E_d,
    log b`` (D_avg kept at nominal), then the tracked point's offset ``(x, y)`` [m] when fitted."""

    fit_scale: bool
    fit_offset: bool
    d_avg0: float

    @property
    def n_geometry(self) -> int:
        """How many of the parameters are the geometry's."""
        return 3 if self.fit_scale else 2

    def unpack(self, p: np.ndarray) -> tuple[float, float, float]:
        """``(D_L, D_R, b)`` [m] of a parameter vector."""
        if self.fit_scale:
            return _exp(p[0]), _exp(p[1]), _exp(p[2])
        ed = _exp(p[0])
        d_l = 2.0 * self.d_avg0 / (1.0 + ed)
        return d_l, d_l * ed, _exp(p[1])

    def offset_of(self, p: np.ndarray) -> np.ndarray | None:
        """The tracked point's offset of a parameter vector (None when it is not fitted)."""
        ng = self.n_geometry
        return p[ng : ng + 2] if self.fit_offset else None

    def starts(self, s0: WheelGeometry, linear: tuple[float, float, float] | None) -> list[np.ndarray]:
        """The start from ``s0``, and from the ground truth's linear start when there is one."""
        if self.fit_scale:
            starts = [np.log([s0.diameter_left_m, s0.diameter_right_m, s0.wheelbase_m])]
        else:
            starts = [np.array([math.log(s0.ed), math.log(s0.wheelbase_m)])]
        if linear is not None:
            d_l, d_r, b = linear
            if self.fit_scale:
                starts.append(np.log([d_l, d_r, b]))
            else:  # D_avg stays nominal: the wheelbase keeps the heading's ratio to the wheels
                ed = d_r / d_l
                starts.append(np.array([math.log(ed), math.log(b * 2.0 * self.d_avg0 / (1.0 + ed) / d_l)]))
        if self.fit_offset:
            starts = [np.concatenate([s_, [0.0, 0.0]]) for s_ in starts]
        return starts

    def uncertainty(
        self, sol: Any, nominal: WheelGeometry
    ) -> tuple[LsqStd, tuple[float, float] | None, tuple[float, float] | None]:
        """The Gauss-Newton standard deviations of the geometry, and the offset with its own."""
        r, n = sol.fun, sol.x.size
        s2 = float(r @ r) / max(r.size - n, 1)
        try:
            cov_p = s2 * np.linalg.inv(sol.jac.T @ sol.jac)
        except np.linalg.LinAlgError:
            cov_p = np.full((n, n), np.nan)

        def derived(p: np.ndarray) -> np.ndarray:
            dl_, dr_, b_ = self.unpack(p)
            return np.array([dl_, dr_, b_, dr_ / dl_, 0.5 * (dl_ + dr_) / nominal.diameter_avg_m])

        g0 = derived(sol.x)
        G = np.empty((5, n))
        for j in range(n):
            h = 1e-6
            pp = sol.x.copy()
            pp[j] += h
            G[:, j] = (derived(pp) - g0) / h
        sd = np.sqrt(np.clip(np.diag(G @ cov_p @ G.T), 0, None))
        std = LsqStd(float(sd[0]), float(sd[1]), float(sd[2]), float(sd[3]), float(sd[4]) if self.fit_scale else 0.0)
        if not self.fit_offset:
            return std, None, None
        ng = self.n_geometry
        offset = (float(sol.x[ng]), float(sol.x[ng + 1]))
        offset_sd = (float(math.sqrt(max(cov_p[ng, ng], 0.0))), float(math.sqrt(max(cov_p[ng + 1, ng + 1], 0.0))))
        return std, offset, offset_sd


def _solve(fun: Callable[[np.ndarray], np.ndarray], starts: list[np.ndarray]) -> Any:
    """Levenberg-Marquardt from the start of least cost where the ground truth's linear start
    lies far from the nominal one (a nominal size in another unit, a diameter given as the
    radius): from there the fit cannot fall into the minima that a heading wrong by whole turns
    makes; from the first start otherwise."""
    from scipy.optimize import least_squares

    p0 = starts[0]
    if len(starts) > 1 and np.max(np.abs(starts[1] - starts[0])) > math.log(_FAR_START):
        costs = []
        for s_ in starts:
            f0 = fun(s_)
            costs.append(float(f0 @ f0) if np.all(np.isfinite(f0)) else math.inf)
        p0 = starts[int(np.argmin(costs))]
    return least_squares(
        fun, p0, method="lm", x_scale=np.full(p0.size, 1e-3), xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400 * p0.size
    )


def _checked_geometry(d_l: float, d_r: float, b: float, nominal: WheelGeometry, finite: bool) -> WheelGeometry:
    """The fitted geometry, or an error where the fit diverged (parameters not ``finite``, or
    beyond :data:`_MAX_FACTOR` of nominal)."""
    ratios = np.array([d_l / nominal.diameter_left_m, d_r / nominal.diameter_right_m, b / nominal.wheelbase_m])
    if not (
        finite and np.all(np.isfinite(ratios)) and np.all(ratios > 1.0 / _MAX_FACTOR) and np.all(ratios < _MAX_FACTOR)
    ):
        raise InputError(
            "lsq did not converge to a valid geometry (diameters or wheelbase more than "
            f"{_MAX_FACTOR:g}x off nominal: the data do not determine the fitted parameters; check the "
            "units and the ground truth, or use `scale='fixed'`)"
        )
    try:
        return WheelGeometry(d_l, d_r, b)
    except InputError:
        raise InputError("lsq did not converge to a valid geometry (check the units and the ground truth)") from None


@register_path("lsq")
def lsq_method(datasets: Dataset | Sequence[Dataset], **options: Any) -> LsqResult:
    """Registry entry: :func:`fit_lsq` with :data:`LSQ_DEFAULTS` for the options not given.

    Parameters
    ----------
    datasets : Dataset or sequence of Dataset
        The logs, fitted jointly.
    **options
        Keyword options of :func:`fit_lsq`.

    Returns
    -------
    LsqResult
        As :func:`fit_lsq`.
    """
    return fit_lsq(datasets, **{**LSQ_DEFAULTS, **options})
