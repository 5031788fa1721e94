"""Robot geometry, calibration factors and odometry integration (pure numpy).

Conventions (see the README, "Conventions"): SI units inside the library (metres, radians),
start frame with x along the first leg, y to the left, angles counter-clockwise positive.

Equations are the paper's (Borenstein & Feng):

* Eq. 2.1  ``c_m = pi * D_n / (n * C_e)``: metres of wheel travel per encoder pulse.
* Eq. 2.2  ``dU_L = c_L * c_m * N_L``, ``dU_R = c_R * c_m * N_R``.
* Eq. 2.3  ``dU = (dU_R + dU_L) / 2``, ``dtheta = (dU_R - dU_L) / b``.
* Eq. 4.33 the odometry with correction factors ``c_L``, ``c_R`` and an effective wheelbase.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from umbmark.errors import InputError

__all__ = [
    "FIG11_ERRORS",
    "Geometry",
    "Calibration",
    "OdometryParams",
    "ErrorParams",
    "LABMATE",
    "integrate",
    "integrate_end",
    "odometry_from_pulses",
    "wrap_angle",
]


def wrap_angle(a):
    """Wrap angles (radians) into (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    # mod maps +pi to -pi; (-pi, pi] wants +pi
    return np.where(w == -np.pi, np.pi, w)


@dataclass(frozen=True)
class Geometry:
    """Nominal geometry of a differential-drive robot.

    ``wheel_diameter_m`` is the nominal diameter D_n, ``pulses_per_rev`` the encoder
    resolution C_e (pulses per motor revolution) and ``gear_ratio`` n the reduction between
    motor and wheel.
    """

    wheel_diameter_m: float
    wheelbase_m: float
    pulses_per_rev: float = 1000.0
    gear_ratio: float = 1.0

    def __post_init__(self):
        for name in ("wheel_diameter_m", "wheelbase_m", "pulses_per_rev", "gear_ratio"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be a positive number, got {v!r}")

    @property
    def m_per_pulse(self) -> float:
        """Eq. 2.1: c_m, metres of wheel travel per encoder pulse."""
        return math.pi * self.wheel_diameter_m / (self.gear_ratio * self.pulses_per_rev)

    def with_wheelbase(self, wheelbase_m: float) -> Geometry:
        return replace(self, wheelbase_m=wheelbase_m)


# The paper's LabMate: 340 mm nominal wheelbase (section 5). The paper does not give the wheel
# diameter or the encoder resolution; these are assumptions (150 mm wheels, 500-line encoders
# behind a 20:1 gear: about 0.047 mm per pulse). The UMBmark results do not depend on them
# except through encoder quantisation.
LABMATE = Geometry(wheel_diameter_m=0.150, wheelbase_m=0.340, pulses_per_rev=500.0, gear_ratio=20.0)


@dataclass(frozen=True)
class Calibration:
    """Correction factors loaded into the odometry (Eq. 4.33).

    ``c_left``/``c_right`` multiply the nominal metres-per-pulse of each wheel;
    ``wheelbase_m`` is the effective wheelbase the odometry uses (``None``: nominal).
    """

    c_left: float = 1.0
    c_right: float = 1.0
    wheelbase_m: float | None = None

    @property
    def ed(self) -> float:
        """The diameter ratio D_R / D_L this calibration assumes."""
        return self.c_right / self.c_left


@dataclass(frozen=True)
class OdometryParams:
    """The numbers an odometry computes with: metres per pulse of each wheel and a wheelbase."""

    left_m_per_pulse: float
    right_m_per_pulse: float
    wheelbase_m: float

    @classmethod
    def from_geometry(cls, geometry: Geometry, calibration: Calibration | None = None) -> OdometryParams:
        cal = calibration or Calibration()
        cm = geometry.m_per_pulse
        b = geometry.wheelbase_m if cal.wheelbase_m is None else cal.wheelbase_m
        return cls(cal.c_left * cm, cal.c_right * cm, b)


@dataclass(frozen=True)
class ErrorParams:
    """Systematic errors of a physical robot relative to its nominal geometry (Eqs. 2.3, 2.4).

    ``ed = D_R / D_L`` (actual diameters), ``eb = b_actual / b_nominal`` and
    ``es = D_avg / D_n`` with ``D_avg = (D_R + D_L) / 2``.
    """

    ed: float = 1.0
    eb: float = 1.0
    es: float = 1.0

    def __post_init__(self):
        for name in ("ed", "eb", "es"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be a positive number, got {v!r}")

    def diameters_m(self, geometry: Geometry) -> tuple[float, float]:
        """True (left, right) wheel diameters."""
        d_avg = self.es * geometry.wheel_diameter_m
        d_left = 2.0 * d_avg / (1.0 + self.ed)
        return d_left, d_left * self.ed

    def true_params(self, geometry: Geometry) -> OdometryParams:
        """Metres of ground travel per encoder pulse of each wheel, and the true wheelbase."""
        d_left, d_right = self.diameters_m(geometry)
        k = math.pi / (geometry.gear_ratio * geometry.pulses_per_rev)
        return OdometryParams(k * d_left, k * d_right, self.eb * geometry.wheelbase_m)

    def ideal_calibration(self, geometry: Geometry) -> Calibration:
        """The calibration that makes the odometry exact (keeping D_avg at nominal: E_s is
        left alone, as the paper assumes it is corrected separately)."""
        c_left = 2.0 / (self.ed + 1.0)
        return Calibration(c_left, c_left * self.ed, self.eb * geometry.wheelbase_m)


def _increments(d_left, d_right, wheelbase_m, theta0, method):
    """Per-sample displacement (dx, dy) in the start frame and the heading after each sample."""
    d_left = np.asarray(d_left, dtype=float)
    d_right = np.asarray(d_right, dtype=float)
    du = 0.5 * (d_right + d_left)
    dth = (d_right - d_left) / np.asarray(wheelbase_m, dtype=float)[..., None]
    theta = np.asarray(theta0, dtype=float)[..., None] + np.cumsum(dth, axis=-1)
    if method == "euler":
        th_ref, chord = theta - dth, du
    elif method == "midpoint":
        th_ref, chord = theta - 0.5 * dth, du
    elif method == "exact":
        # chord of an arc of length du turning dth: du * sin(dth/2) / (dth/2)
        th_ref, chord = theta - 0.5 * dth, du * np.sinc(dth / (2.0 * np.pi))
    else:
        raise InputError(f"unknown integration method {method!r} (use 'exact', 'midpoint' or 'euler')")
    return chord * np.cos(th_ref), chord * np.sin(th_ref), theta


def integrate(d_left, d_right, wheelbase_m, pose0=(0.0, 0.0, 0.0), method: str = "exact"):
    """Integrate per-sample wheel travel into poses.

    ``d_left``/``d_right``: arrays (..., K) of wheel travel per sample [m]; leading axes are
    independent runs. ``wheelbase_m``: scalar or array broadcastable to the leading axes.
    ``method``: ``"exact"`` (constant wheel speeds within a sample: exact circular arcs),
    ``"midpoint"`` (heading at mid-sample) or ``"euler"`` (heading at sample start).

    Returns ``(x, y, theta)``, each of shape (..., K): the pose after each sample. ``theta``
    is not wrapped.
    """
    x0, y0, th0 = (np.asarray(p, dtype=float) for p in pose0)
    dx, dy, theta = _increments(d_left, d_right, wheelbase_m, th0, method)
    return x0[..., None] + np.cumsum(dx, axis=-1), y0[..., None] + np.cumsum(dy, axis=-1), theta


def integrate_end(d_left, d_right, wheelbase_m, pose0=(0.0, 0.0, 0.0), method: str = "exact"):
    """End pose only of :func:`integrate`: arrays of the leading shape (K must be >= 1)."""
    x0, y0, th0 = (np.asarray(p, dtype=float) for p in pose0)
    dx, dy, theta = _increments(d_left, d_right, wheelbase_m, th0, method)
    return x0 + dx.sum(axis=-1), y0 + dy.sum(axis=-1), theta[..., -1]


def odometry_from_pulses(n_left, n_right, params: OdometryParams, pose0=(0.0, 0.0, 0.0), method="exact"):
    """Poses from per-sample encoder pulse increments (Eqs. 2.2, 2.3)."""
    return integrate(
        np.asarray(n_left, dtype=float) * params.left_m_per_pulse,
        np.asarray(n_right, dtype=float) * params.right_m_per_pulse,
        params.wheelbase_m,
        pose0,
        method,
    )


# The paper's Fig. 11 robot: after calibration b = 336.17 mm, D_R/D_L = 1.00084.
FIG11_ERRORS = ErrorParams(ed=1.00084, eb=336.17 / 340.0)
