"""What every square correction method returns, and the composition with a calibration in use."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from umbmark.errors import CorrectionUndefined
from umbmark.model.geometry import Calibration

__all__ = ["CorrectionResult", "CorrectionIntervals", "ExactFit", "LinearEstimates", "compose"]


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


def _pair(v: Any) -> tuple[float, float]:
    return (float(v[0]), float(v[1]))


def _opt(v: Any) -> float | None:
    return None if v is None else float(v)


@dataclass(frozen=True)
class LinearEstimates:
    """The paper's linear correction from the x and from the y coordinates apart (its footnote 2).

    Parameters
    ----------
    alpha_x, alpha_y, beta_x, beta_y : float
        The turn error per 90 deg turn and the heading gained per leg from either coordinate [rad].
    ed_x, ed_y, eb_x, eb_y : float or None
        E_d (this pass) and E_b from either (None where the formulas have no answer).
    """

    alpha_x: float
    alpha_y: float
    beta_x: float
    beta_y: float
    ed_x: float | None = None
    ed_y: float | None = None
    eb_x: float | None = None
    eb_y: float | None = None

    @property
    def alpha(self) -> float:
        """The average of :attr:`alpha_x` and :attr:`alpha_y` (the paper's experiments use it) [rad]."""
        return 0.5 * (self.alpha_x + self.alpha_y)

    @property
    def beta(self) -> float:
        """The average of :attr:`beta_x` and :attr:`beta_y` [rad]."""
        return 0.5 * (self.beta_x + self.beta_y)

    def to_dict(self) -> dict[str, Any]:
        """``alpha_x_deg``, ``alpha_y_deg``, ``beta_x_deg``, ``beta_y_deg``, ``Ed_x``, ``Eb_x``, ``Ed_y``, ``Eb_y``."""
        deg = math.degrees
        return {
            "alpha_x_deg": deg(self.alpha_x),
            "alpha_y_deg": deg(self.alpha_y),
            "beta_x_deg": deg(self.beta_x),
            "beta_y_deg": deg(self.beta_y),
            "Ed_x": self.ed_x,
            "Eb_x": self.eb_x,
            "Ed_y": self.ed_y,
            "Eb_y": self.eb_y,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LinearEstimates | None:
        """From :meth:`to_dict`'s keys (None when they are not all there)."""
        try:
            rad = lambda k: math.radians(float(d[k]))  # noqa: E731
            return cls(
                rad("alpha_x_deg"),
                rad("alpha_y_deg"),
                rad("beta_x_deg"),
                rad("beta_y_deg"),
                *(_opt(d.get(k)) for k in ("Ed_x", "Ed_y", "Eb_x", "Eb_y")),
            )
        except (KeyError, TypeError, ValueError):
            return None


_NO_INTERVALS = (
    "Ed_ci95",
    "Eb_ci95",
    "wheelbase_corrected_mm_ci95",
    "Ed_se",
    "Eb_se",
    "Ed_pass_ci95",
    "emax_syst_after_pred_mm",
    "emax_syst_after_pred_measured_mm",
)


@dataclass(frozen=True)
class CorrectionIntervals:
    """A fit's uncertainty: standard errors, intervals and the E_max,syst it predicts after the
    correction (SI units).

    Parameters
    ----------
    ed_se, eb_se : float
        Standard errors of the robot's E_d and of E_b.
    ed, ed_pass, eb : (float, float)
        Intervals of the robot's E_d (composed with the prior calibration), of this pass's E_d
        and of E_b at ``confidence``.
    wheelbase_m : (float, float)
        The corrected wheelbase's interval [m].
    dof : (float, float)
        The degrees of freedom of the Student t of E_d and E_b.
    ed_eb_corr : float or None
        The correlation of E_d and E_b.
    emax_syst_after_pred_m, emax_syst_after_pred_measured_m : float
        The E_max,syst after the correction that the uncertainty predicts, of the robot and as
        measured (with the runs' own scatter) [m].
    confidence : float
        The intervals' confidence level.
    """

    ed_se: float
    eb_se: float
    ed: tuple[float, float]
    ed_pass: tuple[float, float]
    eb: tuple[float, float]
    wheelbase_m: tuple[float, float]
    dof: tuple[float, float]
    ed_eb_corr: float | None
    emax_syst_after_pred_m: float
    emax_syst_after_pred_measured_m: float
    confidence: float = 0.95

    def to_dict(self) -> dict[str, Any]:
        """``Ed_se``, ``Eb_se``, ``Ed_ci95``, ``Ed_pass_ci95``, ``Eb_ci95``,
        ``wheelbase_corrected_mm_ci95``, ``ci_dof``, ``Ed_Eb_corr``, ``emax_syst_after_pred_mm``,
        ``emax_syst_after_pred_measured_mm`` and ``confidence`` (when not 0.95)."""
        d: dict[str, Any] = {
            "Ed_se": self.ed_se,
            "Eb_se": self.eb_se,
            "Ed_ci95": list(self.ed),
            "Ed_pass_ci95": list(self.ed_pass),
            "Eb_ci95": list(self.eb),
            "wheelbase_corrected_mm_ci95": [self.wheelbase_m[0] * 1e3, self.wheelbase_m[1] * 1e3],
            "ci_dof": list(self.dof),
            "Ed_Eb_corr": self.ed_eb_corr,
            "emax_syst_after_pred_mm": self.emax_syst_after_pred_m * 1e3,
            "emax_syst_after_pred_measured_mm": self.emax_syst_after_pred_measured_m * 1e3,
        }
        if self.confidence != 0.95:
            d["confidence"] = self.confidence
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CorrectionIntervals | None:
        """From :meth:`to_dict`'s keys (None when the intervals are missing)."""
        try:
            w = d["wheelbase_corrected_mm_ci95"]
            return cls(
                float(d["Ed_se"]),
                float(d["Eb_se"]),
                _pair(d["Ed_ci95"]),
                _pair(d["Ed_pass_ci95"]),
                _pair(d["Eb_ci95"]),
                (float(w[0]) * 1e-3, float(w[1]) * 1e-3),
                _pair(d["ci_dof"]),
                _opt(d.get("Ed_Eb_corr")),
                float(d["emax_syst_after_pred_mm"]) * 1e-3,
                float(d["emax_syst_after_pred_measured_mm"]) * 1e-3,
                float(d.get("confidence", 0.95)),
            )
        except (KeyError, TypeError, ValueError, IndexError):
            return None


@dataclass(frozen=True)
class ExactFit:
    """How the exact calibration fitted the runs.

    Parameters
    ----------
    es_pass : float
        The wheel scale E_s of this pass (1 without a straight-line measurement).
    cost : float
        The least-squares cost at the answer.
    rms_m : float
        The RMS position residual [m].
    nfev : int
        The solver's evaluations.
    global_search : bool
        The global search ran.
    loss : str
        The loss.
    heading_used : bool
        The runs' headings were fitted.
    heading_weight_m : float or None
        Metres of position residual worth one radian of heading residual (None: not used).
    runs_cw, runs_ccw : int
        Runs per direction.
    alternatives : tuple of (float, float)
        ``(E_d,pass, E_b,pass)`` the runs cannot tell apart from the answer.
    intervals : CorrectionIntervals or None
        The uncertainty (None when it could not be computed).
    intervals_asked : bool
        Whether the uncertainty was computed at all (not for a bootstrap's resamples).
    """

    es_pass: float
    cost: float
    rms_m: float
    nfev: int
    global_search: bool
    loss: str
    heading_used: bool
    heading_weight_m: float | None
    runs_cw: int
    runs_ccw: int
    alternatives: tuple[tuple[float, float], ...] = ()
    intervals: CorrectionIntervals | None = None
    intervals_asked: bool = True

    def to_dict(self) -> dict[str, Any]:
        """``Es_pass``, ``fit_cost``, ``fit_rms_mm``, ``fit_nfev``, ``global_search``, ``loss``,
        ``heading_used``, ``heading_weight_m``, ``runs_cw``, ``runs_ccw``, the intervals' keys
        (:meth:`CorrectionIntervals.to_dict`; None where they could not be computed) and
        ``alternatives`` (``Ed_pass``, ``Eb_pass``)."""
        d: dict[str, Any] = {
            "Es_pass": self.es_pass,
            "fit_cost": self.cost,
            "fit_rms_mm": self.rms_m * 1e3,
            "fit_nfev": self.nfev,
            "global_search": self.global_search,
            "loss": self.loss,
            "heading_used": self.heading_used,
            "heading_weight_m": self.heading_weight_m,
            "runs_cw": self.runs_cw,
            "runs_ccw": self.runs_ccw,
        }
        if self.intervals is not None:
            d.update(self.intervals.to_dict())
        elif self.intervals_asked:
            d.update(dict.fromkeys(_NO_INTERVALS))
        d["alternatives"] = [{"Ed_pass": a[0], "Eb_pass": a[1]} for a in self.alternatives]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ExactFit | None:
        """From :meth:`to_dict`'s keys (None when they are not there)."""
        try:
            hw = d.get("heading_weight_m")
            return cls(
                float(d["Es_pass"]),
                float(d["fit_cost"]),
                float(d["fit_rms_mm"]) * 1e-3,
                int(d["fit_nfev"]),
                bool(d["global_search"]),
                str(d["loss"]),
                bool(d["heading_used"]),
                None if hw is None else float(hw),
                int(d["runs_cw"]),
                int(d["runs_ccw"]),
                tuple((float(a["Ed_pass"]), float(a["Eb_pass"])) for a in d.get("alternatives") or ()),
                CorrectionIntervals.from_dict(d),
                any(k in d for k in _NO_INTERVALS),
            )
        except (KeyError, TypeError, ValueError):
            return None


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
    warnings : tuple of str
        What the method found doubtful.
    details : LinearEstimates, ExactFit or None
        The method's own figures: the paper's estimates from x and from y (``bf``), how the
        exact fit went and its uncertainty (``exact``).
    """

    method: str
    ed: float
    ed_pass: float
    eb: float
    calibration: Calibration
    alpha: float | None = None
    beta: float | None = None
    radius_m: float | None = None
    warnings: tuple[str, ...] = ()
    details: LinearEstimates | ExactFit | None = None

    @property
    def intervals(self) -> CorrectionIntervals | None:
        """The uncertainty, where the method gives one."""
        return self.details.intervals if isinstance(self.details, ExactFit) else None

    def to_dict(self) -> dict[str, Any]:
        """The result as a JSON-ready dict (degrees and millimetres).

        Returns
        -------
        dict
            ``method``, ``alpha_deg``, ``beta_deg``, ``radius_mm``, ``Ed``, ``Ed_pass``,
            ``Eb``, ``c_left``, ``c_right``, ``wheelbase_corrected_mm``, the details' keys and
            ``warnings``.
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
        if self.details is not None:
            d.update(self.details.to_dict())
        d["warnings"] = list(self.warnings)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any], warnings=()) -> CorrectionResult:
        """A result from :meth:`to_dict`'s keys (a saved replay's correction, for its report).

        Parameters
        ----------
        d : dict
            ``method``, ``Ed``, ``Eb``, ``c_left``, ``c_right``, ``wheelbase_corrected_mm`` and
            what else :meth:`to_dict` writes (each optional).
        warnings : sequence of str
            The warnings, where they are kept apart from ``d``.

        Raises
        ------
        KeyError, TypeError, ValueError
            The keys of the calibration missing or not numbers.
        """
        rad = lambda k: None if d.get(k) is None else math.radians(float(d[k]))  # noqa: E731
        ed = float(d["Ed"])
        radius = d.get("radius_mm")
        details: LinearEstimates | ExactFit | None = ExactFit.from_dict(d) or LinearEstimates.from_dict(d)
        return cls(
            str(d["method"]),
            ed,
            float(d.get("Ed_pass", ed)),
            float(d["Eb"]),
            Calibration(float(d["c_left"]), float(d["c_right"]), float(d["wheelbase_corrected_mm"]) * 1e-3),
            rad("alpha_deg"),
            rad("beta_deg"),
            None if radius is None else float(radius) * 1e-3,
            tuple(str(w) for w in (warnings or d.get("warnings") or ())),
            details,
        )
