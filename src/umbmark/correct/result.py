"""What every correction method returns, and the composition with a calibration in use."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from umbmark.errors import CorrectionUndefined
from umbmark.model.geometry import Calibration

__all__ = ["CorrectionResult", "compose"]


def compose(ed_pass: float, eb_pass: float, wheelbase_used_m: float, prior: Calibration | None = None):
    """Compose a correction measured on a robot that already runs ``prior`` (a second pass is
    "a new uncompensated robot with different parameters", section 4).

    ``ed_pass``/``eb_pass``: the diameter ratio and wheelbase ratio measured in this pass,
    relative to the odometry the runs were made with. Returns ``(ed_total, calibration)``:
    ``ed_total = (c_R0 / c_L0) * ed_pass``, ``b = b_used * eb_pass``, and correction factors
    that keep the mean of the prior factors (Eqs. 4.31, 4.32: ``c_L = 2 / (E_d + 1)``,
    ``c_R = 2 / (1 / E_d + 1)`` for a robot without prior calibration).
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

    ``ed``: the robot's diameter ratio D_R/D_L (composed with the prior calibration, if any);
    ``ed_pass``/``eb``: the ratios measured in this pass relative to the odometry in use;
    ``calibration``: the factors and wheelbase to load into the odometry.
    """

    method: str
    ed: float
    ed_pass: float
    eb: float
    calibration: Calibration
    alpha: float | None = None
    beta: float | None = None
    radius_m: float | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        deg = lambda v: None if v is None else math.degrees(v)  # noqa: E731
        d = {
            "method": self.method,
            "alpha_deg": deg(self.alpha),
            "beta_deg": deg(self.beta),
            "radius_mm": None if self.radius_m is None or not math.isfinite(self.radius_m) else self.radius_m * 1e3,
            "Ed": self.ed,
            "Ed_pass": self.ed_pass,
            "Eb": self.eb,
            "c_left": self.calibration.c_left,
            "c_right": self.calibration.c_right,
            "wheelbase_corrected_mm": self.calibration.wheelbase_m * 1e3,
        }
        d.update(self.extra)
        return d
