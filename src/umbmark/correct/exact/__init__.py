"""Exact (non-linearised) calibration, method ``exact``.

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
[0.3, 4] (401 points), only where E_d,pass is in [0.85, 1.15], ranked by the lowest cost one
Gauss-Newton step predicts from each minimum or one of its eight grid neighbours (a narrow true
basin sampled off its centre must not lose to broad shallow ones, even where its lowest sample
sits where the linearisation sees no descent). Last, where none of these explains the runs, the
minima along the heading per leg alone beside them (a leg curving by whole turns: the cost hardly
depends on E_b there, and a basin narrower than the grid step holds no minimum of the grid),
ranked the same way and fitted from their neighbours on either side of the whole turn. The
lowest final cost wins.
``global_search=True`` always searches, ``False`` never.

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
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Literal

import numpy as np

from umbmark.correct.bf import _check_geometry
from umbmark.correct.exact.model import ExactFitError, FloatArray, _Problem, odometry_turns, square_errors
from umbmark.correct.exact.search import (
    _aliases,
    _bf_start,
    _explains,
    _fit,
    _grid_starts,
    _heading_starts,
    _Solution,
    _valley_starts,
)
from umbmark.correct.exact.uncertainty import _loss_rho1, _reweigh_heading, interval_figures
from umbmark.correct.registry import register
from umbmark.correct.result import CorrectionIntervals, CorrectionResult, ExactFit, compose
from umbmark.errors import InputError
from umbmark.metrics import umbmark_figures
from umbmark.model.geometry import Calibration, wrap_angle
from umbmark.model.runs import RunsTable

__all__ = [
    "square_errors",
    "odometry_turns",
    "exact_correction",
    "exact_method",
    "ExactFitError",
    "LOSSES",
]

LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


GlobalSearch = Literal["auto"] | bool


@contextmanager
def _quiet() -> Iterator[None]:
    """Floating-point and optimiser warnings off (trial parameters may be absurd)."""
    with np.errstate(all="ignore"), _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        yield


def _check_options(loss: str, confidence: float) -> None:
    """Refuse an unknown loss and a confidence level outside (0.5, 1)."""
    if loss not in LOSSES:
        raise InputError(f"unknown loss {loss!r} (choose from {', '.join(LOSSES)})")
    if not (0.5 < confidence < 1.0):
        raise InputError(f"confidence must be between 0.5 and 1, got {confidence!r}")


def _direction_counts(runs: RunsTable) -> tuple[int, int]:
    """``(n_cw, n_ccw)``; the fit needs runs in both directions."""
    n_cw = int(np.sum(runs.direction == "cw"))
    n_ccw = int(np.sum(runs.direction == "ccw"))
    if n_cw == 0 or n_ccw == 0:
        missing = "cw" if n_cw == 0 else "ccw"
        raise ExactFitError(
            f"no {missing} runs: the exact fit needs runs in both directions (E_d and E_b cannot be "
            "told apart from one direction)"
        )
    return n_cw, n_ccw


# a straight-line run shorter than this does not measure the wheel scale (metres)
_MIN_STRAIGHT_M = 0.1


def _scale_from_straight(straight_m: tuple[float, float] | None) -> float:
    """``E_s,pass`` from a straight-line measurement ``(odometry, measured)``; 1 without one."""
    if straight_m is None:
        return 1.0
    odo_d, meas_d = (float(v) for v in straight_m)
    if not (math.isfinite(odo_d) and math.isfinite(meas_d) and odo_d > 0 and meas_d > 0):
        raise InputError(f"straight-line measurement must be two positive distances, got {straight_m!r}")
    if max(odo_d, meas_d) < _MIN_STRAIGHT_M:
        raise InputError(
            f"the straight-line run is {odo_d * 1e3:g} mm by odometry and {meas_d * 1e3:g} mm measured: a "
            f"straight-line test drives metres (at least {_MIN_STRAIGHT_M * 1e3:g} mm); given in metres?"
        )
    es = meas_d / odo_d
    if abs(es - 1.0) > 0.2:
        raise InputError(f"straight-line measurement gives E_s = {es:.4f} (more than 20 % off): check the units")
    return es


def _closure_warnings(runs: RunsTable, prob: _Problem, side_m: float) -> list[str]:
    """Refuse runs whose odometry does not close; warn where it closes only roughly."""
    odo_off = np.hypot(runs.x_odo, runs.y_odo)
    if np.max(odo_off) > 0.25 * side_m:
        i = int(np.argmax(odo_off))
        raise ExactFitError(
            f"run {runs.run[i] if runs.run is not None else i + 1} does not close: its odometry ends "
            f"{odo_off[i] * 1e3:.0f} mm from the start (side {side_m * 1e3:.0f} mm); is this a UMBmark square run?"
        )
    if runs.theta_odo is not None and np.max(np.abs(wrap_angle(runs.theta_odo))) > math.radians(30):
        raise ExactFitError(
            "a run's odometry heading ends more than 30 deg from the start heading: the runs do not "
            "close (is this a UMBmark square run, and theta_odo in degrees?)"
        )
    if np.max(np.abs(prob.dev)) > math.radians(10) or np.max(prob.odo_misfit) > 0.02 * side_m:
        return [
            f"the odometry of some runs ends far from the start ({np.max(odo_off) * 1e3:.0f} mm): the model "
            "explains it by turn over/undershoot of up to "
            f"{math.degrees(np.max(np.abs(prob.dev))):.1f} deg, leaving {np.max(prob.odo_misfit) * 1e3:.0f} "
            "mm unexplained"
        ]
    return []


def _robust_scale(prob: _Problem, loss: str, f_scale_m: float | None, side_m: float) -> float:
    """The robust loss's scale: given, or the median per-direction radial spread of the runs
    (a tenth of a per cent of the side where that is zero); 1 for the linear loss."""
    spreads = []
    for mask in (prob.is_cw, ~prob.is_cw):
        if mask.sum() >= 2:
            spreads.append(math.hypot(np.std(prob.ex[mask], ddof=1), np.std(prob.ey[mask], ddof=1)) / math.sqrt(2))
    f_scale = float(f_scale_m) if f_scale_m is not None else (float(np.median(spreads)) if spreads else 0.0)
    if f_scale <= 0 or not math.isfinite(f_scale):
        f_scale = 1e-3 * side_m
    if loss == "linear":
        f_scale = 1.0
    return f_scale


def _solve(
    prob: _Problem,
    runs: RunsTable,
    loss: str,
    f_scale: float,
    sems: Sequence[float | None],
    heading_weight_m: float | None,
    global_search: GlobalSearch,
    start: tuple[float, float] | None = None,
) -> tuple[_Solution, bool, list[tuple[float, float]]]:
    """The fit: from the paper's estimate (or ``start``), headings weighed by the data, a
    global search where that does not explain the runs, and the turn-angle aliases of the
    answer.

    Returns ``(solution, searched, alternatives)``.
    """
    bf0 = _bf_start(runs, prob.side_m, prob.b) if start is None else np.asarray(start, dtype=float)
    with _quiet():
        sol = _fit(prob, [bf0], loss, f_scale) if bf0 is not None else None
        reweigh = prob.heading and heading_weight_m is None
        if reweigh and sol is not None and global_search != True:  # noqa: E712 (True, not 1)
            # headings that disagree with the positions must not send the fit searching:
            # weigh them by their agreement first; search only if that does not explain the runs
            sol_rw, _ = _reweigh_heading(prob, sol, loss, f_scale)
            if _explains(prob, sol_rw, sems):
                sol, reweigh = sol_rw, False
            else:
                prob.w = float(prob.side_m)
        sol, searched = _global_search(prob, sol, loss, f_scale, sems, global_search)
    if sol is None or sol.status <= 0:
        raise ExactFitError(
            "the exact fit did not converge (no finite solution from any start); check the runs, the "
            "side length, the wheelbase and the units"
        )
    with _quiet():
        if reweigh:
            sol, _ = _reweigh_heading(prob, sol, loss, f_scale)
        sol, alternatives = _aliases(prob, sol, loss, f_scale)
    return sol, searched, alternatives


def _global_search(
    prob: _Problem,
    sol: _Solution | None,
    loss: str,
    f_scale: float,
    sems: Sequence[float | None],
    global_search: GlobalSearch,
) -> tuple[_Solution | None, bool]:
    """The global search in stages until a fit explains the runs: candidates from the
    headings (cheap), the grid's basins, then the basins the grid holds no minimum of (that
    stage takes a missing SEM, one run per direction, as zero). Returns the best solution and
    whether it searched."""
    searched = False
    for stage in (_heading_starts, _grid_starts, _valley_starts):
        # the last stage is for basins the grid missed: where one run per direction leaves no
        # SEM, a fit within the noise-free allowance already explains the runs
        need = sems if stage is not _valley_starts else [0.0 if s is None else s for s in sems]
        if global_search is False or (global_search == "auto" and _explains(prob, sol, need)):
            break
        searched = True
        sp = prob.small() or prob  # many runs: the starts from pseudo-runs of the same minima

        def explains(q, need=need, sp=sp):
            return _explains(sp, q, need)

        sol2 = _fit(prob, stage(sp), loss, f_scale, good=explains if global_search == "auto" else None)
        if sol is None or (sol2 is not None and sol2.cost < sol.cost):
            sol = sol2
    return sol, searched


def _ambiguity_warning(alternatives: list[tuple[float, float]], es: float, p: FloatArray) -> str:
    """The warning that names the calibrations the runs cannot tell from the answer."""
    alt = "; ".join(
        f"E_d {a[0]:.6f}, E_b {a[1]:.6f} (a robot turning {90.0 * es / a[1]:.0f} deg per commanded 90 deg)"
        for a in alternatives
    )
    return (
        f"ambiguous: {alt} would produce the same runs (the square test cannot tell them apart); the "
        f"answer assumes the robot visibly turned about {90.0 * es / p[1]:.0f} deg at each corner"
    )


def _check_bounds(p: FloatArray) -> None:
    """Refuse a fit that ended on the bounds of E_d (0.5, 2) or E_b (0.05, 20)."""
    for j, (lo, hi, name) in enumerate(((0.5, 2.0, "E_d"), (0.05, 20.0, "E_b"))):
        if min(p[j] - lo, hi - p[j]) < 1e-6 * (hi - lo):
            raise ExactFitError(
                f"the exact fit ran into the bound of {name} ({p[j]:.4g}): no plausible calibration "
                "explains these runs; check the side length, wheelbase and units"
            )


def _residual_warnings(
    prob: _Problem, runs: RunsTable, r: FloatArray, sems: Sequence[float | None], loss: str
) -> list[str]:
    """Goodness of fit: centres of gravity the model misses, and outlier runs (far from the
    other runs of their direction on a robust scale; reported with the linear loss)."""
    side_m = prob.side_m
    warns = []
    for mask, sem, name in ((prob.is_cw, sems[0], "cw"), (~prob.is_cw, sems[1], "ccw")):
        miss = float(np.hypot(*r[mask, :2].mean(axis=0)))
        ref = sem if sem is not None and sem > 0 else None
        if ref is not None and miss > 5.0 * ref and miss > 1e-4 * side_m:
            warns.append(
                f"the model misses the {name} centre of gravity by {miss * 1e3:.1f} mm ({miss / ref:.1f} x its "
                "SEM): the runs may not follow the closed-loop square model (outliers? use a robust loss)"
            )
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
    return warns


def _plausibility_warnings(ed_pass: float, eb_pass: float, wheelbase_m: float) -> list[str]:
    """Errors this large usually mean a wrong side length or wheelbase (units)."""
    warns = []
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
    return warns


def _paper_angles(
    es: float, ed_pass: float, eb_pass: float, side_m: float, wheelbase_m: float
) -> tuple[float, float, float]:
    """The paper's ``(alpha, beta, R)`` equivalents of the fitted errors, for comparison with
    bf: the turn shortfall per 90 deg turn, the heading gained per leg, the legs' radius."""
    alpha = 0.5 * math.pi * (1.0 - es / eb_pass)
    beta = 2.0 * es * (ed_pass - 1.0) / (ed_pass + 1.0) * side_m / (eb_pass * wheelbase_m)
    radius = math.inf if beta == 0 else (side_m / 2.0) / math.sin(beta / 2.0)
    return alpha, beta, radius


def exact_correction(
    runs: RunsTable,
    side_m: float,
    wheelbase_m: float,
    prior: Calibration | None = None,
    *,
    loss: str = "linear",
    f_scale_m: float | None = None,
    use_heading: bool = True,
    heading_weight_m: float | None = None,
    straight_m: tuple[float, float] | None = None,
    global_search: GlobalSearch = "auto",
    confidence: float = 0.95,
    _reference: bool = False,
    _start: tuple[float, float] | None = None,
    _intervals: bool = True,
    _fast: bool = False,
) -> CorrectionResult:
    """Exact calibration from square runs (see the module docstring).

    Parameters
    ----------
    runs : RunsTable
        Square runs in both directions (SI units).
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used during the runs [m].
    prior : Calibration or None
        The correction factors the robot ran with (``None``: none).
    loss : str
        Least-squares loss: ``linear``, or a robust one (``soft_l1``, ``huber``, ``cauchy``,
        ``arctan``).
    f_scale_m : float or None
        Scale of a robust loss [m]; default: the median per-direction spread of the runs.
    use_heading : bool
        Fit the measured heading errors too (where the runs have them).
    heading_weight_m : float or None
        Metres per radian of heading residual; ``None``: weighed by the data.
    straight_m : tuple of float or None
        ``(odometry distance, measured distance)`` of a straight-line run, to estimate E_s.
    global_search : {"auto", True, False}
        Search globally where the fit from the paper's estimate does not explain the runs
        (``"auto"``), always, or never.
    confidence : float
        Confidence level of the intervals, in (0.5, 1).
    _reference : bool
        The reference computation (tests): central-difference Jacobians and the global search
        on every run. Default: analytic Jacobians and the compiled model, and the global
        search on pseudo-runs with the same least-squares cost (:meth:`_Problem.compressed`),
        its answer refitted on the runs.
    _start : tuple of float or None
        ``(E_d,pass, E_b,pass)`` to start from instead of the paper's estimate (the
        bootstrap of a report starts each resample from the answer on all runs).
    _intervals : bool
        Compute the intervals (``False``: the bootstrap's resamples need only the answer).
    _fast : bool
        Kept for callers that ask for the default computation explicitly (the bootstrap).

    Returns
    -------
    CorrectionResult
        Method ``exact``; its ``details`` (:class:`~umbmark.correct.result.ExactFit`) hold the
        fit's figures, the intervals and the alternatives the runs cannot tell apart from the
        answer.

    Raises
    ------
    InputError
        Invalid geometry or options.
    ExactFitError
        Runs in one direction only, runs that do not close, no convergence, or a fit on the
        bounds of E_d or E_b.
    """
    _check_geometry(side_m, wheelbase_m)
    _check_options(loss, confidence)
    n_cw, n_ccw = _direction_counts(runs)
    es = _scale_from_straight(straight_m)
    prob = _Problem(runs, side_m, wheelbase_m, es, use_heading, heading_weight_m)
    prob.fast = not _reference
    warns = _closure_warnings(runs, prob, side_m)
    f_scale = _robust_scale(prob, loss, f_scale_m, side_m)
    st = umbmark_figures(runs)
    sems = [st.cw.sem, st.ccw.sem]
    if global_search not in ("auto", True, False):
        raise InputError(f"global_search must be 'auto', True or False, got {global_search!r}")

    sol, searched, alternatives = _solve(prob, runs, loss, f_scale, sems, heading_weight_m, global_search, _start)
    p = sol.x
    if alternatives:
        warns.append(_ambiguity_warning(alternatives, es, p))
    _check_bounds(p)
    ed_pass, eb_pass = float(p[0]), float(p[1])

    r = prob.residuals_matrix([ed_pass], [eb_pass])[0]
    warns += _residual_warnings(prob, runs, r, sems, loss)
    weights = None if loss == "linear" else _loss_rho1(loss, (r / f_scale) ** 2)
    warns += _plausibility_warnings(ed_pass, eb_pass, wheelbase_m)
    ed_total, cal = compose(ed_pass, eb_pass, wheelbase_m, prior)
    if es != 1.0:
        cal = Calibration(cal.c_left * es, cal.c_right * es, cal.wheelbase_m)
    intervals = None
    if _intervals:
        prior_ed = (prior or Calibration()).ed
        intervals, ci_warns = interval_figures(prob, p, weights, sems, prior_ed, wheelbase_m, confidence)
        warns += ci_warns
    alpha, beta, radius = _paper_angles(es, ed_pass, eb_pass, side_m, wheelbase_m)
    fit = _fit_figures(prob, sol, r, searched, loss, (n_cw, n_ccw), alternatives, intervals, _intervals)
    return CorrectionResult(
        "exact",
        ed=ed_total,
        ed_pass=ed_pass,
        eb=eb_pass,
        calibration=cal,
        alpha=alpha,
        beta=beta,
        radius_m=radius,
        warnings=tuple(warns),
        details=fit,
    )


def _fit_figures(
    prob: _Problem,
    sol: Any,
    r: FloatArray,
    searched: bool,
    loss: str,
    counts: tuple[int, int],
    alternatives: list[tuple[float, float]],
    intervals: CorrectionIntervals | None,
    asked: bool,
) -> ExactFit:
    """How the fit went (residuals ``r`` at the answer of ``sol``), with its intervals."""
    return ExactFit(
        es_pass=prob.es,
        cost=float(sol.cost),
        rms_m=float(np.sqrt(np.mean(r[:, :2] ** 2))),
        nfev=int(sol.nfev),
        global_search=searched,
        loss=loss,
        heading_used=bool(prob.heading),
        heading_weight_m=float(prob.w) if prob.heading else None,
        runs_cw=counts[0],
        runs_ccw=counts[1],
        alternatives=tuple((float(a[0]), float(a[1])) for a in alternatives),
        intervals=intervals,
        intervals_asked=asked,
    )


@register("exact")
def exact_method(
    runs: RunsTable, side_m: float, wheelbase_m: float, prior: Calibration | None = None, **options: Any
) -> CorrectionResult:
    """Registry entry: the exact non-linear least-squares calibration.

    Parameters
    ----------
    runs : RunsTable
        Square runs in both directions.
    side_m, wheelbase_m : float
        Side of the square and the wheelbase the odometry used [m].
    prior : Calibration or None
        The correction factors the robot ran with.
    **options
        Keyword options of :func:`exact_correction`.

    Returns
    -------
    CorrectionResult
        As :func:`exact_correction`.
    """
    return exact_correction(runs, side_m, wheelbase_m, prior, **options)
