"""The robot types every layer shares: geometry, systematic errors, calibration, odometry numbers.

Pure numpy: this module imports only numpy and :mod:`umbmark.errors`. Conventions (see the
README, "Conventions"): SI units (metres, radians), start frame with x along the first leg,
y to the left, angles counter-clockwise positive.

Five types, one role each; every conversion between them is a method of one of them:

* :class:`Geometry`: the nominal design of a robot with encoders (one nominal wheel diameter,
  the wheelbase and the encoder chain). What the simulator and the paper's test assume.
* :class:`WheelGeometry`: the size of each wheel and the wheelbase, without encoders. The
  geometry of logged runs, nominal or corrected, and what a path fit estimates.
* :class:`ErrorParams`: the systematic errors E_d, E_b, E_s of a physical robot relative to
  its :class:`Geometry`.
* :class:`Calibration`: the correction factors loaded into an odometry (c_L, c_R and the
  effective wheelbase).
* :class:`OdometryParams`: the three numbers an odometry computes with (metres per encoder
  unit of each wheel, wheelbase).

Equations are the paper's (Borenstein & Feng):

* Eq. 2.1  ``c_m = pi * D_n / (n * C_e)``: metres of wheel travel per encoder pulse.
* Eq. 2.2  ``dU_L = c_L * c_m * N_L``, ``dU_R = c_R * c_m * N_R``.
* Eq. 2.3  ``dU = (dU_R + dU_L) / 2``, ``dtheta = (dU_R - dU_L) / b``.
* Eq. 4.33 the odometry with correction factors ``c_L``, ``c_R`` and an effective wheelbase.

Headings are wrapped with :func:`wrap_angle` only, into (-pi, pi].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from umbmark._check import positive
from umbmark.errors import InputError

__all__ = [
    "FIG11_ERRORS",
    "Geometry",
    "WheelGeometry",
    "Calibration",
    "OdometryParams",
    "ErrorParams",
    "LABMATE",
    "wrap_angle",
    "ROBOT_SIZES_M",
    "Quantity",
    "QUANTITIES",
    "unit_slip",
    "FAR_FROM_NOMINAL",
    "nominal_slip",
]

# what a wheeled robot's geometry can be (metres): a wheel's diameter (a toy robot's 1 cm to a
# vehicle's 3 m) and the wheelbase (the distance between the wheels' contact points)
ROBOT_SIZES_M: dict[str, tuple[float, float]] = {"diameter": (0.01, 3.0), "wheelbase": (0.02, 10.0)}


@dataclass(frozen=True)
class Quantity:
    """A size of a robot's geometry as the checks of a given value know it: what it is called, the
    sizes a robot can have, how far an estimate may stray from it, the slips that give other factors.

    The built-in ones (:data:`QUANTITIES`) are a wheel's diameter and radius and the wheelbase; a
    kind of robot with a size of its own declares it (:mod:`umbmark.kinds`, e.g. a mecanum robot's
    ``lx + ly``).

    Parameters
    ----------
    name : str
        Its name (``"wheelbase"``).
    what : str
        How a message names it (``"wheelbase"``, ``"wheel's diameter"``).
    range_m : tuple of float
        ``(low, high)`` the sizes a robot can have [m].
    far : tuple of float, optional
        ``(low, high)``: an estimate outside these factors of the nominal is no odometry error
        (None: the quantity is not estimated).
    slips : tuple
        ``(factor, text)``: an estimate about ``factor`` times the nominal (within 20 %) is
        likely the slip ``text`` says.
    """

    name: str
    what: str
    range_m: tuple[float, float]
    far: tuple[float, float] | None = None
    slips: tuple[tuple[float, str], ...] = ()


# an estimate outside these factors of its nominal size is no odometry error (corrections of real
# wheels stay within 0.8 to 1.25; a skid-steer robot's effective wheelbase is up to about twice its
# track): the nominal size was given in another unit or as another quantity
QUANTITIES: dict[str, Quantity] = {
    "diameter": Quantity(
        "diameter",
        "wheel's diameter",
        ROBOT_SIZES_M["diameter"],
        (1 / 1.5, 1.5),
        (
            (0.5, "a diameter given as the radius (`wheel_radius_m` takes half the diameter)?"),
            (2.0, "a radius given as the diameter (`wheel_diameter_mm` takes twice the radius)?"),
        ),
    ),
    "radius": Quantity(
        "radius", "wheel's radius", (ROBOT_SIZES_M["diameter"][0] / 2, ROBOT_SIZES_M["diameter"][1] / 2)
    ),
    "wheelbase": Quantity(
        "wheelbase",
        "wheelbase",
        ROBOT_SIZES_M["wheelbase"],
        (1 / 1.5, 2.5),
        ((0.5, "a size twice the wheelbase given (the distance between the wheels' contact points)?"),),
    ),
}
"""The sizes every kind of robot has, by name."""

FAR_FROM_NOMINAL = {k: q.far for k, q in QUANTITIES.items() if q.far is not None}
_UNIT_SLIPS = (
    (1e-3, "millimetres given as metres?"),
    (1e3, "metres given as millimetres?"),
    (25.4, "inches given as millimetres?"),
)


def _quantity(kind: str | Quantity) -> Quantity:
    if isinstance(kind, Quantity):
        return kind
    if kind not in QUANTITIES:
        raise ValueError(f"unknown kind {kind!r}")
    return QUANTITIES[kind]


def unit_slip(kind: str | Quantity, value_m: float, unit: str) -> str | None:
    """Why a wheel size or wheelbase cannot be a robot's, naming the unit mistake it shows.

    Parameters
    ----------
    kind : str or Quantity
        ``"diameter"``, ``"radius"``, ``"wheelbase"`` (:data:`QUANTITIES`), or a kind's own
        :class:`Quantity` (a mecanum robot's half wheelbase plus half track).
    value_m : float
        The size as given, converted to metres with its stated unit.
    unit : str
        The unit it was given in (``"mm"`` or ``"m"``), to name the likely slip.

    Returns
    -------
    str or None
        None when the size is one a robot can have (see :data:`ROBOT_SIZES_M`, a radius being
        half a diameter); else a sentence such as ``"0.15 mm is no wheel's diameter (...):
        given in metres? 0.15 m is 150 mm"``.
    """
    q = _quantity(kind)
    if not math.isfinite(value_m) or value_m <= 0:
        return None  # a sign or a NaN is the callers' own check
    lo, hi = q.range_m
    if lo <= value_m <= hi:
        return None
    scale = 1e-3 if unit == "mm" else 1.0
    given = value_m / scale
    text = f"{given:g} {unit} is no {q.what} (a robot's is {lo / scale:g} to {hi / scale:g} {unit})"
    if unit == "mm" and value_m < lo:
        return f"{text}: given in metres? {given:g} m is {given * 1000.0:g} mm"
    if unit == "m" and value_m > hi:
        return f"{text}: given in millimetres? {given:g} mm is {given / 1000.0:g} m"
    return text


def nominal_slip(kind: str | Quantity, ratio: float) -> str | None:
    """What an estimated size ``ratio`` times its nominal one says of the nominal.

    Parameters
    ----------
    kind : str or Quantity
        ``"diameter"`` (a wheel's, or the mean of the wheels), ``"wheelbase"``, or a kind's own
        :class:`Quantity` (a mecanum robot's ``lx + ly``).
    ratio : float
        The estimate (from the data) over the nominal size given.

    Returns
    -------
    str or None
        None within the quantity's ``far`` factors (:data:`FAR_FROM_NOMINAL`: a robot's own
        error); else the likely slip, e.g. ``"a diameter given as the radius (...)?"`` for 0.5
        with a diameter, or the unit it is in; ``"the nominal size is in another unit or another
        quantity"`` otherwise.
    """
    q = _quantity(kind)
    if q.far is None:
        raise ValueError(f"unknown kind {q.name!r}")
    lo, hi = q.far
    if not (math.isfinite(ratio) and ratio > 0) or lo <= ratio <= hi:
        return None
    for factor, text in (*q.slips, *_UNIT_SLIPS):
        if abs(math.log(ratio / factor)) < math.log(1.2):
            return text
    return "the nominal size is in another unit or another quantity?"


def wrap_angle(a: Any) -> Any:
    """Wrap angles into (-pi, pi], the one convention of the package.

    Parameters
    ----------
    a : float or array_like
        Angles [rad].

    Returns
    -------
    numpy.float64 or numpy.ndarray
        ``a`` plus the multiple of 2 pi that brings it into (-pi, pi]: a scalar for a scalar
        input, else an array of the same shape. An angle of exactly -pi (or any odd multiple
        of pi) maps to +pi.
    """
    w = np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    # the modulo maps +pi to -pi; the half-open interval (-pi, pi] keeps +pi
    if w.ndim:
        w[w == -np.pi] = np.pi
        return w
    return np.float64(np.pi) if w == -np.pi else w


def _check_positive(obj: object, names: tuple[str, ...]) -> None:
    for name in names:
        positive(name, getattr(obj, name))


@dataclass(frozen=True)
class Geometry:
    """Nominal design of a differential-drive robot with wheel encoders.

    Both wheels have the nominal diameter; the encoders count ``gear_ratio * pulses_per_motor_rev``
    pulses per wheel revolution. A robot's actual wheels differ from this by its
    :class:`ErrorParams`.

    Parameters
    ----------
    wheel_diameter_m : float
        Nominal wheel diameter D_n [m].
    wheelbase_m : float
        Nominal wheelbase b [m].
    pulses_per_motor_rev : float
        Encoder resolution C_e, pulses per motor revolution.
    gear_ratio : float
        Reduction n between motor and wheel.

    Raises
    ------
    InputError
        If a field is not a positive finite number.
    """

    wheel_diameter_m: float
    wheelbase_m: float
    pulses_per_motor_rev: float = 1000.0
    gear_ratio: float = 1.0

    def __post_init__(self) -> None:
        _check_positive(self, ("wheel_diameter_m", "wheelbase_m", "pulses_per_motor_rev", "gear_ratio"))

    @property
    def m_per_pulse(self) -> float:
        """Eq. 2.1: c_m, metres of wheel travel per encoder pulse."""
        return math.pi * self.wheel_diameter_m / (self.gear_ratio * self.pulses_per_motor_rev)

    @property
    def pulses_per_wheel_rev(self) -> float:
        """Encoder pulses per wheel revolution, ``gear_ratio * pulses_per_motor_rev``."""
        return self.gear_ratio * self.pulses_per_motor_rev

    def wheels(self) -> WheelGeometry:
        """The nominal wheels: both of diameter D_n, the nominal wheelbase.

        Returns
        -------
        WheelGeometry
        """
        return WheelGeometry(self.wheel_diameter_m, self.wheel_diameter_m, self.wheelbase_m)


# The paper's LabMate: 340 mm nominal wheelbase (section 5). The paper does not give the wheel
# diameter or the encoder resolution; these are assumptions (150 mm wheels, 500-line encoders
# behind a 20:1 gear: about 0.047 mm per pulse). The UMBmark results do not depend on them
# except through encoder quantisation.
LABMATE = Geometry(wheel_diameter_m=0.150, wheelbase_m=0.340, pulses_per_motor_rev=500.0, gear_ratio=20.0)


@dataclass(frozen=True)
class OdometryParams:
    """The three numbers an odometry computes with (Eqs. 2.2, 2.3).

    Parameters
    ----------
    left_m_per_pulse, right_m_per_pulse : float
        Metres of wheel travel per encoder unit of each wheel (a pulse, or a radian for logs
        of wheel angles), correction factors included.
    wheelbase_m : float
        The wheelbase the odometry divides by [m].
    """

    left_m_per_pulse: float
    right_m_per_pulse: float
    wheelbase_m: float

    @classmethod
    def from_geometry(cls, geometry: Geometry, calibration: Calibration | None = None) -> OdometryParams:
        """The odometry of a robot of nominal ``geometry`` running ``calibration`` (Eq. 4.33).

        Parameters
        ----------
        geometry : Geometry
            The nominal geometry.
        calibration : Calibration, optional
            Correction factors and effective wheelbase; ``None``: the nominal odometry.

        Returns
        -------
        OdometryParams
            ``c_L * c_m``, ``c_R * c_m`` and the calibration's wheelbase (the nominal one when
            it has none).
        """
        cal = calibration or Calibration()
        cm = geometry.m_per_pulse
        b = geometry.wheelbase_m if cal.wheelbase_m is None else cal.wheelbase_m
        return cls(cal.c_left * cm, cal.c_right * cm, b)


@dataclass(frozen=True)
class Calibration:
    """Correction factors loaded into the odometry (Eq. 4.33).

    Parameters
    ----------
    c_left, c_right : float
        Factors on the nominal metres per pulse of each wheel.
    wheelbase_m : float or None
        The effective wheelbase the odometry uses [m]; ``None``: the nominal one.
    """

    c_left: float = 1.0
    c_right: float = 1.0
    wheelbase_m: float | None = None

    @property
    def ed(self) -> float:
        """The diameter ratio D_R / D_L this calibration assumes, ``c_right / c_left``."""
        return self.c_right / self.c_left


@dataclass(frozen=True)
class WheelGeometry:
    """The size of each wheel and the wheelbase of a differential-drive robot, in metres.

    Unlike :class:`Geometry` it has no encoder: the encoder units belong to the log
    (``units_per_wheel_rev`` of a dataset) and are given to :meth:`params`. It describes a nominal
    robot (from a dataset's metadata) as well as a corrected one (a calibration applied, or
    a path fit's estimate).

    Parameters
    ----------
    diameter_left_m, diameter_right_m : float
        Wheel diameters [m].
    wheelbase_m : float
        Wheelbase [m].

    Raises
    ------
    InputError
        If a field is not a positive finite number.
    """

    diameter_left_m: float
    diameter_right_m: float
    wheelbase_m: float

    def __post_init__(self) -> None:
        _check_positive(self, ("diameter_left_m", "diameter_right_m", "wheelbase_m"))

    @property
    def ed(self) -> float:
        """E_d = D_R / D_L."""
        return self.diameter_right_m / self.diameter_left_m

    @property
    def diameter_avg_m(self) -> float:
        """The mean wheel diameter (D_R + D_L) / 2 [m]."""
        return 0.5 * (self.diameter_left_m + self.diameter_right_m)

    def params(self, units_per_wheel_rev: float) -> OdometryParams:
        """The odometry of these wheels for a log counting ``units_per_wheel_rev`` per wheel revolution.

        Parameters
        ----------
        units_per_wheel_rev : float
            Log units (encoder pulses, or 2 pi for radians) per wheel revolution.

        Returns
        -------
        OdometryParams
            Metres of wheel travel per log unit of each wheel, and the wheelbase.
        """
        k = math.pi / units_per_wheel_rev
        return OdometryParams(k * self.diameter_left_m, k * self.diameter_right_m, self.wheelbase_m)

    def relative_to(self, nominal: WheelGeometry) -> dict:
        """This (corrected) geometry against ``nominal``, as every calibration report gives it.

        Parameters
        ----------
        nominal : WheelGeometry
            The nominal geometry.

        Returns
        -------
        dict
            ``Ed``, ``Eb``, ``Es``, ``c_left``, ``c_right`` (ratios) and
            ``wheelbase_corrected_mm``, ``diameter_left_mm``, ``diameter_right_mm``.
        """
        return {
            "Ed": self.ed,
            "Eb": self.wheelbase_m / nominal.wheelbase_m,
            "Es": self.diameter_avg_m / nominal.diameter_avg_m,
            "c_left": self.diameter_left_m / nominal.diameter_left_m,
            "c_right": self.diameter_right_m / nominal.diameter_right_m,
            "wheelbase_corrected_mm": self.wheelbase_m * 1e3,
            "diameter_left_mm": self.diameter_left_m * 1e3,
            "diameter_right_mm": self.diameter_right_m * 1e3,
        }

    def calibrated(self, cal: Calibration) -> WheelGeometry:
        """This (nominal) geometry with correction factors applied (Eq. 4.33).

        Parameters
        ----------
        cal : Calibration
            The factors (and effective wheelbase, if any) to apply.

        Returns
        -------
        WheelGeometry
        """
        b = self.wheelbase_m if cal.wheelbase_m is None else cal.wheelbase_m
        return WheelGeometry(cal.c_left * self.diameter_left_m, cal.c_right * self.diameter_right_m, b)

    def calibration_from(self, nominal: WheelGeometry) -> Calibration:
        """The correction factors that turn ``nominal`` into this geometry.

        Parameters
        ----------
        nominal : WheelGeometry
            The nominal geometry.

        Returns
        -------
        Calibration
        """
        return Calibration(
            self.diameter_left_m / nominal.diameter_left_m,
            self.diameter_right_m / nominal.diameter_right_m,
            self.wheelbase_m,
        )

    def to_dict(self) -> dict:
        """The geometry in millimetres: ``diameter_left_mm``, ``diameter_right_mm``, ``wheelbase_mm``."""
        return {
            "diameter_left_mm": self.diameter_left_m * 1e3,
            "diameter_right_mm": self.diameter_right_m * 1e3,
            "wheelbase_mm": self.wheelbase_m * 1e3,
        }


@dataclass(frozen=True)
class ErrorParams:
    """Systematic errors of a physical robot relative to its nominal :class:`Geometry` (Eqs. 2.3, 2.4).

    Parameters
    ----------
    ed : float
        ``E_d = D_R / D_L`` (actual diameters).
    eb : float
        ``E_b = b_actual / b_nominal``.
    es : float
        ``E_s = D_avg / D_n`` with ``D_avg = (D_R + D_L) / 2``.

    Raises
    ------
    InputError
        If a ratio is not a positive finite number.
    """

    ed: float = 1.0
    eb: float = 1.0
    es: float = 1.0

    def __post_init__(self) -> None:
        for name in ("ed", "eb", "es"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be a positive number, got {v!r}")

    def diameters_m(self, geometry: Geometry) -> tuple[float, float]:
        """The true wheel diameters.

        Parameters
        ----------
        geometry : Geometry
            The nominal geometry.

        Returns
        -------
        tuple of float
            ``(D_L, D_R)`` [m].
        """
        d_avg = self.es * geometry.wheel_diameter_m
        d_left = 2.0 * d_avg / (1.0 + self.ed)
        return d_left, d_left * self.ed

    def wheels(self, geometry: Geometry) -> WheelGeometry:
        """The true wheels and wheelbase of the robot.

        Parameters
        ----------
        geometry : Geometry
            The nominal geometry.

        Returns
        -------
        WheelGeometry
            :meth:`diameters_m` and ``E_b * b``.
        """
        d_left, d_right = self.diameters_m(geometry)
        return WheelGeometry(d_left, d_right, self.eb * geometry.wheelbase_m)

    def true_params(self, geometry: Geometry) -> OdometryParams:
        """Metres of ground travel per encoder pulse of each wheel, and the true wheelbase.

        Parameters
        ----------
        geometry : Geometry
            The nominal geometry (its encoder chain counts the pulses).

        Returns
        -------
        OdometryParams
            The odometry that would be exact for this robot.
        """
        return self.wheels(geometry).params(geometry.pulses_per_wheel_rev)

    def ideal_calibration(self, geometry: Geometry) -> Calibration:
        """The calibration that makes the odometry exact, keeping D_avg at nominal.

        E_s is left alone, as the paper assumes it is corrected separately.

        Parameters
        ----------
        geometry : Geometry
            The nominal geometry.

        Returns
        -------
        Calibration
            ``c_L = 2 / (E_d + 1)``, ``c_R = E_d c_L`` and the true wheelbase.
        """
        c_left = 2.0 / (self.ed + 1.0)
        return Calibration(c_left, c_left * self.ed, self.eb * geometry.wheelbase_m)


# The paper's Fig. 11 robot: after calibration b = 336.17 mm, D_R/D_L = 1.00084.
FIG11_ERRORS = ErrorParams(ed=1.00084, eb=336.17 / 340.0)
