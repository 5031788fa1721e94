"""The paper's linearised correction (Borenstein & Feng, Eqs. 4.20 - 4.32), method ``bf``.

From the centres of gravity of the cw and ccw return errors (start frame, metres):

* from x: ``beta = (x_cg,cw - x_cg,ccw) / (-4L)``, ``alpha = (x_cg,cw + x_cg,ccw) / (-4L)``;
* from y: ``beta = (y_cg,cw + y_cg,ccw) / (-4L)``, ``alpha = (y_cg,cw - y_cg,ccw) / (-4L)``;
* the averages of the x- and y-based values are used (the paper's footnote 2);
* ``R = (L/2) / sin(beta/2)``, ``E_d = (R + b/2) / (R - b/2)``, computed as
  ``(1 + k) / (1 - k)`` with ``k = b sin(beta/2) / L`` so that beta = 0 gives E_d = 1 exactly;
* ``E_b = 90 deg / (90 deg - alpha)``, ``b_new = E_b * b``;
* ``c_L = 2 / (E_d + 1)``, ``c_R = 2 / (1/E_d + 1)`` (composed with a prior calibration).

alpha > 0: the robot turns less than commanded; beta > 0: the legs curve to the left.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from umbmark.correct.plausibility import check_units
from umbmark.correct.registry import register
from umbmark.correct.result import CorrectionResult, LinearEstimates, compose
from umbmark.errors import CorrectionUndefined, InputError
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.geometry import Calibration
from umbmark.model.runs import RunsTable

__all__ = ["bf_correction", "alpha_beta", "ed_from_beta", "eb_from_alpha"]


def _check_geometry(side_m: float, wheelbase_m: float) -> None:
    """Refuse a side or wheelbase that is not a positive finite length, a wheelbase below 10 mm
    and a side beyond 1 km (units mistaken: see :func:`umbmark.correct.plausibility.check_geometry`)."""
    if not (isinstance(side_m, (int, float)) and math.isfinite(side_m) and side_m > 0):
        raise InputError(f"side must be a positive length, got {side_m!r}")
    if not (isinstance(wheelbase_m, (int, float)) and math.isfinite(wheelbase_m) and wheelbase_m > 0):
        raise InputError(f"wheelbase must be a positive length, got {wheelbase_m!r}")
    check_units(side_m, wheelbase_m)


def alpha_beta(result: UMBmarkResult, side_m: float) -> LinearEstimates:
    """alpha and beta from the centres of gravity (Eqs. 4.20, 4.24).

    Parameters
    ----------
    result : UMBmarkResult
        The UMBmark figures of the runs (centres of gravity in metres).
    side_m : float
        Side of the square [m].

    Returns
    -------
    LinearEstimates
        ``alpha_x``, ``alpha_y``, ``beta_x``, ``beta_y`` (from x and from y) and their averages
        ``alpha``, ``beta`` [rad]; no E_d, E_b yet.
    """
    cw, ccw = result.cw, result.ccw
    k = -4.0 * side_m
    beta_x = (cw.x_cg - ccw.x_cg) / k
    alpha_x = (cw.x_cg + ccw.x_cg) / k
    beta_y = (cw.y_cg + ccw.y_cg) / k
    alpha_y = (cw.y_cg - ccw.y_cg) / k
    return LinearEstimates(alpha_x, alpha_y, beta_x, beta_y)


def ed_from_beta(beta: float, side_m: float, wheelbase_m: float) -> tuple[float, float]:
    """The diameter ratio and the legs' radius from beta (Eqs. 4.21, 4.22).

    Parameters
    ----------
    beta : float
        Heading gained per leg [rad].
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used [m].

    Returns
    -------
    tuple of float
        ``(E_d, R)``; R [m] is infinite for beta = 0.

    Raises
    ------
    CorrectionUndefined
        The radius is not larger than half the wheelbase.
    """
    s = math.sin(beta / 2.0)
    k = wheelbase_m * s / side_m
    if not abs(k) < 1.0:
        raise CorrectionUndefined(
            f"correction undefined: the curvature radius R = {side_m / 2 / abs(s) * 1e3:.1f} mm is not larger than "
            f"half the wheelbase ({wheelbase_m / 2 * 1e3:.1f} mm); check the side length, wheelbase and units"
        )
    radius = math.inf if s == 0 else (side_m / 2.0) / s
    return (1.0 + k) / (1.0 - k), radius


def eb_from_alpha(alpha: float) -> float:
    """The wheelbase ratio from alpha, Eq. 4.26: ``E_b = 90 / (90 - alpha)`` (alpha in degrees).

    Parameters
    ----------
    alpha : float
        The turn shortfall per 90 deg turn [rad].

    Returns
    -------
    float
        E_b.

    Raises
    ------
    CorrectionUndefined
        alpha is not below 90 deg.
    """
    a = math.degrees(alpha)
    if not a < 90.0:
        raise CorrectionUndefined(f"correction undefined: alpha = {a:.2f} deg is not below 90 deg")
    return 90.0 / (90.0 - a)


def bf_correction(
    result: UMBmarkResult, side_m: float, wheelbase_m: float, prior: Calibration | None = None
) -> CorrectionResult:
    """The paper's correction from a UMBmark result.

    Parameters
    ----------
    result : UMBmarkResult
        The UMBmark figures of the runs.
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used during the runs (the nominal one for an uncalibrated
        robot, the corrected one for a second pass) [m].
    prior : Calibration or None
        The correction factors the robot ran with (``None``: none).

    Returns
    -------
    CorrectionResult
        Method ``bf``; its ``details`` (:class:`~umbmark.correct.result.LinearEstimates`) hold
        the x- and y-based estimates.

    Raises
    ------
    InputError
        The side or wheelbase is not a positive length.
    CorrectionUndefined
        The formulas have no answer (radius within half the wheelbase, alpha of 90 deg or more).
    """
    _check_geometry(side_m, wheelbase_m)
    ab = alpha_beta(result, side_m)
    ed_pass, radius = ed_from_beta(ab.beta, side_m, wheelbase_m)
    eb = eb_from_alpha(ab.alpha)
    ed_total, cal = compose(ed_pass, eb, wheelbase_m, prior)

    def ed_of(beta_: float) -> float | None:
        try:
            return ed_from_beta(beta_, side_m, wheelbase_m)[0]
        except CorrectionUndefined:
            return None

    def eb_of(alpha_: float) -> float | None:
        try:
            return eb_from_alpha(alpha_)
        except CorrectionUndefined:
            return None

    # the paper's footnote 2: both estimates, for comparison
    linear = replace(ab, ed_x=ed_of(ab.beta_x), ed_y=ed_of(ab.beta_y), eb_x=eb_of(ab.alpha_x), eb_y=eb_of(ab.alpha_y))
    warns = []
    a_deg, b_deg = math.degrees(ab.alpha), math.degrees(ab.beta)
    if a_deg <= -90.0 or abs(b_deg) >= 180.0:
        warns.append(
            f"alpha = {a_deg:.1f} deg, beta = {b_deg:.1f} deg: far beyond the small angles the paper's "
            "formulas assume, so this correction means little (an outlier run, wrong units, or a very "
            'large error: try `method="exact"`)'
        )
    return CorrectionResult(
        "bf",
        ed=ed_total,
        ed_pass=ed_pass,
        eb=eb,
        calibration=cal,
        alpha=ab.alpha,
        beta=ab.beta,
        radius_m=radius,
        warnings=tuple(warns),
        details=linear,
    )


@register("bf")
def bf_method(
    runs: RunsTable, side_m: float, wheelbase_m: float, prior: Calibration | None = None, **_: Any
) -> CorrectionResult:
    """Registry entry: the paper's correction from the runs' centres of gravity.

    Parameters
    ----------
    runs : RunsTable
        Square runs in both directions.
    side_m, wheelbase_m : float
        Side of the square and the wheelbase the odometry used [m].
    prior : Calibration or None
        The correction factors the robot ran with.
    **_
        Ignored (the method has no options).

    Returns
    -------
    CorrectionResult
        As :func:`bf_correction`.
    """
    return bf_correction(umbmark_figures(runs), side_m, wheelbase_m, prior)
