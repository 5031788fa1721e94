"""What the intervals can determine, and whether the answer is plausible.

* :func:`driving_summary`: how the robot drove (forward travel, turns each way, the spread of
  the ratio between the wheels), computed with the nominal geometry.
* :func:`driving_causes`: the shortcomings of that driving, each with what to drive instead.
* :func:`identifiability`: from the Fisher information, which parameters the intervals
  determine poorly (standard deviation beyond the limits) or not at all (a numerically
  singular information matrix), with the causes named.
* :func:`plausibility`: signs and sizes against the nominal geometry (swapped or reversed
  wheels, wrong units).

The information is scaled before it is judged (radii by the nominal radius, wheelbase and
sensor position by the nominal wheelbase), so its condition number compares like with like.

Pure numpy: imports numpy and :mod:`umbmark.correct.selfcal.model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.correct.selfcal.model import PARAMETERS
from umbmark.model.geometry import nominal_slip

__all__ = [
    "Driving",
    "Limits",
    "driving_summary",
    "driving_causes",
    "identifiability",
    "plausibility",
    "SINGULAR_COND",
]

FloatArray = NDArray[np.float64]

# a scaled information matrix beyond this condition number has no usable inverse
SINGULAR_COND = 1e12


@dataclass(frozen=True)
class Limits:
    """The standard deviations beyond which a parameter counts as poorly determined.

    Parameters
    ----------
    relative_sd : float
        For the wheel radii and the wheelbase, relative to their value.
    position_sd_m : float
        For the sensor position [m].
    yaw_sd_rad : float
        For the sensor yaw [rad].
    min_intervals : int
        Fewer intervals than this: the noise estimate and the intervals are unreliable.
    """

    relative_sd: float = 0.01
    position_sd_m: float = 0.01
    yaw_sd_rad: float = math.radians(1.0)
    min_intervals: int = 30


@dataclass(frozen=True)
class Driving:
    """How the robot drove over the intervals (nominal geometry).

    Parameters
    ----------
    intervals : int
        Their number.
    travel_m : float
        Forward travel of the robot's centre, ``sum |d_k|`` [m].
    turn_ccw_rad, turn_cw_rad : float
        Heading turned counter-clockwise and clockwise, summed over the intervals [rad].
    ratio_spread : float
        The smaller over the larger singular value of the (K, 2) matrix of wheel travels:
        0 when the wheels always turn in one ratio (only straights, only spins, or arcs of
        one radius), about 1 for a good mix.
    wheelbase_m : float
        The nominal wheelbase used.
    """

    intervals: int
    travel_m: float
    turn_ccw_rad: float
    turn_cw_rad: float
    ratio_spread: float
    wheelbase_m: float

    @property
    def turn_rad(self) -> float:
        """Total heading turned, both ways [rad]."""
        return self.turn_ccw_rad + self.turn_cw_rad

    @property
    def turn_arc_m(self) -> float:
        """Wheel travel spent turning, ``turn_rad * b / 2`` [m]."""
        return self.turn_rad * self.wheelbase_m / 2.0


def driving_summary(left_rad: ArrayLike, right_rad: ArrayLike, r_nominal_m: float, wheelbase_m: float) -> Driving:
    """Summarise the driving of the intervals with the nominal geometry.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    r_nominal_m : float
        Nominal wheel radius [m].
    wheelbase_m : float
        Nominal wheelbase [m].

    Returns
    -------
    Driving
    """
    dl = r_nominal_m * np.asarray(left_rad, float)
    dr = r_nominal_m * np.asarray(right_rad, float)
    d = 0.5 * (dl + dr)
    th = (dr - dl) / wheelbase_m
    a = np.column_stack([dl, dr])
    sv = np.linalg.svd(a, compute_uv=False) if len(a) else np.zeros(2)
    spread = float(sv[1] / sv[0]) if len(sv) > 1 and sv[0] > 0 else 0.0
    return Driving(
        intervals=len(d),
        travel_m=float(np.abs(d).sum()),
        turn_ccw_rad=float(th[th > 0].sum()),
        turn_cw_rad=float(np.abs(th[th < 0]).sum()),
        ratio_spread=spread,
        wheelbase_m=float(wheelbase_m),
    )


def driving_causes(drv: Driving, limits: Limits = Limits()) -> list[str]:
    """The shortcomings of the driving, each with what to drive instead.

    Parameters
    ----------
    drv : Driving
        From :func:`driving_summary`.
    limits : Limits
        ``min_intervals`` is used.

    Returns
    -------
    list of str
        Sentences, the most telling first; empty when the driving has none of the known
        shortcomings.
    """
    out = []
    deg = math.degrees
    no_turns = drv.turn_arc_m < 0.1 * drv.travel_m or drv.turn_rad < math.radians(10.0)
    no_travel = drv.travel_m < 0.1 * drv.turn_arc_m or drv.travel_m < drv.wheelbase_m
    if drv.travel_m == 0 and drv.turn_rad == 0:
        return ["the wheels do not turn: record intervals while the robot drives"]
    if no_turns:
        out.append(
            f"the robot hardly turns ({deg(drv.turn_rad):.0f} deg in all, against {drv.travel_m:.2f} m forward): "
            "the wheelbase and the sensor position need turns; drive spins on the spot and tight arcs, both ways"
        )
    if no_travel:
        out.append(
            f"the robot hardly moves forward ({drv.travel_m:.3f} m in all, against {deg(drv.turn_rad):.0f} deg "
            "of turning): the scale of the wheel radii and wheelbase and the sensor's yaw need forward motion; "
            "drive straight lines and wide arcs"
        )
    if not no_turns:
        big, small = max(drv.turn_ccw_rad, drv.turn_cw_rad), min(drv.turn_ccw_rad, drv.turn_cw_rad)
        if small < 0.1 * big:
            way = "counter-clockwise (left)" if drv.turn_ccw_rad > drv.turn_cw_rad else "clockwise (right)"
            out.append(
                f"the robot turns one way only ({deg(drv.turn_ccw_rad):.0f} deg counter-clockwise, "
                f"{deg(drv.turn_cw_rad):.0f} deg clockwise, mostly {way}): drive turns the other way too"
            )
    if drv.ratio_spread < 0.05 and not (no_turns or no_travel):
        out.append(
            "the wheels keep nearly one ratio (arcs of a single radius): one kind of motion cannot separate "
            "the parameters; mix straight lines, spins on the spot and arcs of different radii"
        )
    if drv.intervals < limits.min_intervals:
        out.append(
            f"only {drv.intervals} intervals (at least {limits.min_intervals} recommended): the noise estimate "
            "and the intervals are unreliable; record more driving"
        )
    return out


def _scales(r_nominal_m: float, wheelbase_m: float) -> FloatArray:
    return np.array([r_nominal_m, r_nominal_m, wheelbase_m, wheelbase_m, wheelbase_m, 1.0])


_LABELS = tuple(f"`{n}`" for n in PARAMETERS)


def identifiability(
    p: ArrayLike,
    information: ArrayLike,
    drv: Driving,
    r_nominal_m: float,
    wheelbase_m: float,
    limits: Limits = Limits(),
    covariance: ArrayLike | None = None,
) -> tuple[FloatArray, list[str], str | None]:
    """The covariance of the parameters and what the intervals fail to determine.

    Parameters
    ----------
    p : array_like
        The estimate (six parameters).
    information : array_like
        The Fisher information at ``p`` (6 x 6).
    drv : Driving
        The driving, for the causes.
    r_nominal_m, wheelbase_m : float
        Nominal radius and wheelbase (the scales).
    limits : Limits
        The standard deviations that count as poorly determined.
    covariance : array_like, optional
        The covariance to judge the standard deviations by (e.g. one that also holds the
        errors shared within a recording); default the inverse of the information. The
        singularity is always judged on the information.

    Returns
    -------
    covariance : numpy.ndarray
        ``covariance`` when given, else the inverse of the information (6 x 6); infinite where
        the information is singular.
    warnings : list of str
        One warning naming the poorly determined parameters and the causes (or none).
    singular : str or None
        When the information is singular: the message of the error to raise (which
        parameters, why, what to drive); otherwise ``None``.
    """
    q = np.asarray(p, float)
    f = np.asarray(information, float)
    sc = _scales(r_nominal_m, wheelbase_m)
    fs = f * np.outer(sc, sc)
    fs = 0.5 * (fs + fs.T)
    w, v = np.linalg.eigh(fs) if np.all(np.isfinite(fs)) else (np.zeros(6), np.eye(6))
    causes = driving_causes(drv, limits)
    few = [c for c in causes if c.startswith("only ")]
    advice = "; ".join(causes) if causes else "drive longer, mixing straight lines, spins and arcs both ways"
    if w[-1] <= 0 or w[0] <= w[-1] / SINGULAR_COND:
        null = v[:, w <= max(w[-1], 0.0) / SINGULAR_COND]
        weight = np.sqrt((null * null).sum(axis=1))  # each parameter's share of the null space
        names = [_LABELS[i] for i in np.flatnonzero(weight > 0.2)] or [_LABELS[int(np.argmax(weight))]]
        msg = f"the intervals cannot determine {_join(names)} (the information matrix is singular): {advice}"
        return np.full((6, 6), np.inf), [], msg
    cov = (v / w) @ v.T * np.outer(sc, sc) if covariance is None else np.asarray(covariance, float)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    poor = []
    for i in range(3):
        if sd[i] > limits.relative_sd * abs(q[i]):
            poor.append(f"{_LABELS[i]} (sd {100 * sd[i] / abs(q[i]):.2g} %)")
    for i in (3, 4):
        if sd[i] > limits.position_sd_m:
            poor.append(f"{_LABELS[i]} (sd {1e3 * sd[i]:.2g} mm)")
    if sd[5] > limits.yaw_sd_rad:
        poor.append(f"{_LABELS[5]} (sd {math.degrees(sd[5]):.2g} deg)")
    warnings = []
    if poor:
        warnings.append(f"poorly determined by these intervals: {_join(poor)}; {advice}")
    else:
        warnings += few
    return cov, warnings, None


def _join(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def plausibility(p: ArrayLike, wheel_diameter_m: float, wheelbase_m: float) -> list[str]:
    """Signs and sizes of the estimate against the nominal geometry.

    Parameters
    ----------
    p : array_like
        The estimate (six parameters), with the mirror ambiguity already resolved (radii
        positive where the data allow).
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry.

    Returns
    -------
    list of str
        Warnings: swapped wheels (positive radii need a negative wheelbase), one wheel
        counted backwards (radii of opposite signs), a diameter or wheelbase more than twice
        or less than half the nominal one (units).
    """
    rl, rr, b = (float(x) for x in np.asarray(p, float)[:3])
    out = []
    if rl > 0 and rr > 0 and b < 0:
        out.append(
            f"the intervals fit only with the wheels exchanged (positive radii need a negative wheelbase, "
            f"{1e3 * b:.1f} mm): `left_rad` and `right_rad` are swapped (or both counted backwards, or the "
            "sensor's turns counted clockwise, `sensor_dyaw_rad` negated); exchange them and calibrate again (the "
            "diameters reported here are then the other wheel's)"
        )
    elif rl * rr < 0:
        which = "left" if rl < 0 else "right"
        out.append(
            f"the wheel radii come out with opposite signs ({1e3 * rl:.1f} mm, {1e3 * rr:.1f} mm): the {which} "
            f"wheel's angle is counted backwards; negate `{which}_rad` and calibrate again"
        )
    for name, value, nominal in (
        ("left wheel diameter", 2 * abs(rl), wheel_diameter_m),
        ("right wheel diameter", 2 * abs(rr), wheel_diameter_m),
    ):
        ratio = value / nominal
        slip = nominal_slip("diameter", ratio)
        if slip is not None:
            out.append(
                f"the {name} comes out {ratio:.3g} x the nominal `wheel_diameter_m` ({1e3 * value:.1f} mm against "
                f"{1e3 * nominal:.1f} mm): {slip} Else wheel angles not in radians (degrees, encoder ticks, a gear "
                "ratio), a wrong nominal diameter or swapped wheels"
            )
    ratio = abs(b) / wheelbase_m
    if not 0.5 <= ratio <= 2.0:
        out.append(
            f"the wheelbase comes out {ratio:.3g} x the nominal `wheelbase_m` ({1e3 * abs(b):.1f} mm against "
            f"{1e3 * wheelbase_m:.1f} mm): sensor displacements not in metres and radians, a wrong nominal "
            "wheelbase or swapped wheels"
        )
    return out
