"""What every square correction method returns, and the composition with a calibration in use."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from umbmark.errors import CorrectionUndefined
from umbmark.model.geometry import Calibration

__all__ = ["CorrectionResult", "compose"]


def compose(
    ed_pass: float, eb_pass: float, wheelbase_used_m: float, prior: Calibration | None = None
) -> tuple[float, Calibration]:
    """Compose a correction measured on a robot that already runs ``prior``.

    A second pass is "a new uncompensated robot with different parameters" (section 4). The
    correction factors keep the mean of the prior factors (Eqs. 4.31, 4.32:
    ``c_L = 2 / (E_d + 1)``, ``c_R = 2 / (1 / E_d + 1)`` for a robot without prior
    calibration).

    Parameters
    ----------
    ed_pass, eb_pass : float
        The diameter ratio and wheelbase ratio measured in this pass, relative to the odometry
        the runs were made with.
    wheelbase_used_m : float
        The wheelbase the odometry used during the runs [m].
    prior : Calibration or None
        The calibration the robot ran with (``None``: none).

    Returns
    -------
    ed_total : float
        The robot's diameter ratio ``(c_R0 / c_L0) * ed_pass``.
    calibration : Calibration
        The factors and the wheelbase ``b_used * eb_pass`` to load into the odometry.

    Raises
    ------
    CorrectionUndefined
        ``ed_pass`` or ``eb_pass`` is not a positive number.
    """
    prior = prior or Calibration()
    if not (math.isfinite(ed_pass) and ed_pass > 0):
        raise CorrectionUndefined(f"the diameter ratio E_d = {ed_pass!r} is not a positive number")
    if not (math.isfinite(eb_pass) and eb_pass > 0):
        raise CorrectionUndefined(f"the wheelbase ratio E_b = {eb_pass!r} is not a positive number")
    ed_total = prior.ed * ed_pass
    mean_c = 0.5 * (prior.c_left + prior.c_right)
    c_left = mean_c * 2.0 / (ed_total + 1.0)
    c_right = mean_c * 2.0 / (1.0 / ed_total + 1.0)
    return ed_total, Calibration(c_left, c_right, wheelbase_used_m * eb_pass)


@dataclass(frozen=True)
class CorrectionResult:
    """A calibration estimate. Angles in radians, lengths in metres.

    Parameters
    ----------
    method : str
        The method's registered name.
    ed : float
        The robot's diameter ratio D_R/D_L (composed with the prior calibration, if any).
    ed_pass, eb : float
        The diameter and wheelbase ratios measured in this pass, relative to the odometry in
        use.
    calibration : Calibration
        The factors and wheelbase to load into the odometry.
    alpha, beta : float or None
        The paper's turn error per 90 deg turn and heading gained per leg (or their
        equivalents).
    radius_m : float or None
        The legs' curvature radius (infinite for straight legs).
    extra : dict
        The method's own figures; ``warnings`` (list of str) where it has any.
    """

    method: str
    ed: float
    ed_pass: float
    eb: float
    calibration: Calibration
    alpha: float | None = None
    beta: float | None = None
    radius_m: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The result as a JSON-ready dict (degrees and millimetres), ``extra`` merged in.

        Returns
        -------
        dict
            ``method``, ``alpha_deg``, ``beta_deg``, ``radius_mm``, ``Ed``, ``Ed_pass``,
            ``Eb``, ``c_left``, ``c_right``, ``wheelbase_corrected_mm`` and the ``extra`` keys.
        """
        deg = lambda v: None if v is None else math.degrees(v)  # noqa: E731
        radius, wheelbase = self.radius_m, self.calibration.wheelbase_m
        d: dict[str, Any] = {
            "method": self.method,
            "alpha_deg": deg(self.alpha),
            "beta_deg": deg(self.beta),
            "radius_mm": None if radius is None or not math.isfinite(radius) else radius * 1e3,
            "Ed": self.ed,
            "Ed_pass": self.ed_pass,
            "Eb": self.eb,
            "c_left": self.calibration.c_left,
            "c_right": self.calibration.c_right,
            "wheelbase_corrected_mm": None if wheelbase is None else wheelbase * 1e3,
        }
        d.update(self.extra)
        return d
