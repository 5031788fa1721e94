"""The gyro as a rotation reference: the effective wheelbase from on-the-spot turns, without any
external measurement, and the gyro's own scale factor where the true turns are known.

From a bag's ``sensor_msgs/Imu`` turn rates (``angular_velocity.z``) and its wheel data
(:func:`umbmark.io.rosbag.read_gyro_bag`), :func:`gyro_reference`:

* **Still periods**: stretches of at least ``still_s`` seconds in which neither wheel turns.
  The gyro's **bias** is the mean of its readings inside each (``margin_s`` in from either end)
  that lie within 4 robust standard deviations of their median (the robot lifted and turned by
  hand for part of a still period does not move it), interpolated linearly in time between
  still periods (a slowly drifting bias is followed); its noise is the standard deviation of
  those readings. Without a still period the bias is not removed (warned).
* **Turns**: the motion between two still periods. The gyro's turn is the integral of its
  readings (bias removed) from ``guard_s`` before the wheels start to ``guard_s`` after they
  stop (at most from the middle of the still periods: the robot at rest at both ends, so the
  readings' timing does not matter, and a robot carried back to its mark long before is not
  counted); the wheels' turn is
  ``(s_R - s_L) / b`` of the nominal wheel travel and wheelbase. A turn is **on the spot** when
  the wheels' mean travel is below ``spin_travel`` of the turn's arc (half the wheelbase times
  the angle): a spin, or the turn of a UMBmark square. Only turns of at least ``min_turn_rad``
  are used; only turns on the spot when there are any (on a straight or an arc the wheel
  diameter ratio E_d also turns the robot).
* **Effective wheelbase**: on the spot the robot turns by ``Delta psi = (s_R - s_L) / b_eff``
  whatever E_d, so ``psi_gyro = scale x psi_wheels x b / b_eff``: the least-squares ratio ``k``
  of the gyro's to the wheels' turns gives ``E_b = scale / k`` and ``b_eff = E_b x b``, the
  wheelbase the odometry should use with its nominal wheels (for a skid-steer robot much wider
  than its track: ``wheel_separation_multiplier``). Relative to the wheel scale: wheels that
  roll further than their nominal size turn the robot further too.
* **The gyro's scale**: assumed 1 unless the true turns are known: ``full_turns`` (every turn on
  the spot was a whole number of revolutions, counted: the true turn is the gyro's rounded to
  whole turns) or ``scans`` (the robot's lidar: the last scan at rest before each turn and the
  first after it registered, :func:`umbmark.realrobot.scanmatch.match_scans` with the coarse
  stage around the gyro's turn). ``scale`` is the least-squares ratio of the gyro's turns to the
  true ones.
* **Intervals** (95 %): from the scatter of the turns about the fitted ratio (Student t, one
  degree of freedom less than the turns used); with one turn, none (warned).

SI units. Imports numpy, scipy, :mod:`umbmark.model`, :mod:`umbmark.io` and the scan matcher.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.rosbag import GyroBag, SelfcalBag
from umbmark.model.dataset import WheelGeometry
from umbmark.model.se2 import compose, inverse
from umbmark.realrobot.scan_truth import SCAN_TRUTH_ICP, robot_displacement
from umbmark.realrobot.scanmatch import ICPConfig, match_scans
from umbmark.realrobot.selfcal import check_bag_motion

__all__ = ["GyroTurn", "GyroReference", "gyro_reference", "gyro_history_fields", "still_periods"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class GyroTurn:
    """One turn between two still periods.

    Attributes
    ----------
    source : str
        The bag.
    t_s : (float, float)
        Its start and end (the middles of the still periods around it) [s, the bag's clock].
    wheels_rad : float
        The nominal odometry's turn.
    gyro_rad : float
        The gyro's turn (bias removed).
    travel_m : float
        The wheels' mean travel (zero for a turn on the spot).
    on_the_spot : bool
        The wheels' mean travel is small beside the turn's arc.
    true_rad : float or None
        The true turn (whole turns, or from the lidar), when known.
    used : bool
        Used in the fit.
    """

    source: str
    t_s: tuple[float, float]
    wheels_rad: float
    gyro_rad: float
    travel_m: float
    on_the_spot: bool
    true_rad: float | None
    used: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values (degrees)."""
        return {
            "source": self.source,
            "t_s": list(self.t_s),
            "wheels_deg": math.degrees(self.wheels_rad),
            "gyro_deg": math.degrees(self.gyro_rad),
            "true_deg": None if self.true_rad is None else math.degrees(self.true_rad),
            "travel_mm": self.travel_m * 1e3,
            "on_the_spot": self.on_the_spot,
            "used": self.used,
        }


@dataclass(frozen=True)
class GyroReference:
    """The gyro's verdict on the wheelbase, and its own scale factor.

    Attributes
    ----------
    imu_topic : str
        The Imu topic.
    nominal_wheelbase_m : float
        The wheelbase the wheels' turns were computed with.
    wheelbase_m : float
        The effective wheelbase.
    wheelbase_m_ci95 : (float, float) or None
        Its 95 % interval.
    eb : float
        ``wheelbase_m / nominal_wheelbase_m``: the factor on the wheelbase in use
        (``wheel_separation_multiplier`` when the nominal one is ``wheel_separation``).
    eb_ci95 : (float, float) or None
    gyro_scale : float
        The gyro's scale factor (1 when it is assumed).
    gyro_scale_ci95 : (float, float) or None
    gyro_scale_source : str
        ``assumed``, ``full turns`` or ``lidar``.
    bias_radps, noise_radps : float
        The mean bias removed and the readings' standard deviation at rest.
    still_s : float
        The time at rest the bias was measured over.
    readings : int
        Gyro readings in all.
    turns : tuple of GyroTurn
    warnings : tuple of str
    """

    imu_topic: str
    nominal_wheelbase_m: float
    wheelbase_m: float
    wheelbase_m_ci95: tuple[float, float] | None
    eb: float
    eb_ci95: tuple[float, float] | None
    gyro_scale: float
    gyro_scale_ci95: tuple[float, float] | None
    gyro_scale_source: str
    bias_radps: float
    noise_radps: float
    still_s: float
    readings: int
    turns: tuple[GyroTurn, ...]
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The ``gyro`` block of ``umbmark replay --imu-topic ... --json``."""

        def pair(p: tuple[float, float] | None) -> list[float] | None:
            return None if p is None else [float(p[0]), float(p[1])]

        return {
            "imu_topic": self.imu_topic,
            "wheelbase_m": self.wheelbase_m,
            "wheelbase_m_ci95": pair(self.wheelbase_m_ci95),
            "nominal_wheelbase_m": self.nominal_wheelbase_m,
            "Eb": self.eb,
            "Eb_ci95": pair(self.eb_ci95),
            "wheel_separation_multiplier": self.eb,
            "gyro_scale": self.gyro_scale,
            "gyro_scale_ci95": pair(self.gyro_scale_ci95),
            "gyro_scale_source": self.gyro_scale_source,
            "bias_rad_per_s": self.bias_radps,
            "noise_rad_per_s": self.noise_radps,
            "still_s": self.still_s,
            "readings": self.readings,
            "turns_used": sum(t.used for t in self.turns),
            "turns": [t.to_dict() for t in self.turns],
            "warnings": list(self.warnings),
        }


EB_RANGE = (0.25, 4.0)
"""The effective wheelbase over the nominal one a robot's turns can imply (skid-steer included)."""


MAX_BIAS_RADPS = math.radians(20.0)
"""A gyro's zero-rate offset at rest is within this (a consumer MEMS gyro's data sheet: +-20 deg/s
at most) [rad/s]."""

SCALE_RANGE = (0.5, 2.0)
"""The gyro's own scale factor a gyro can have (data sheets: within a few per cent)."""


def _checked_eb(g: FloatArray, w: FloatArray, k: float, scale: float, bias_radps: float = 0.0) -> float:
    """``E_b = scale / k``; refused where the gyro turns cannot be a wheelbase's: turning the
    other way (an IMU upside down), an E_b outside :data:`EB_RANGE` that deg/s would put inside
    (deg/s published as rad/s), that rad/s divided by 57.3 (or wheel angles in degrees) would,
    or any other E_b outside it."""
    against = int(np.sum(np.sign(g) == -np.sign(w)))
    lo, hi = EB_RANGE
    deg = math.degrees(1.0)
    if k <= 0 or against > len(g) // 2:
        also = ""
        if k != 0 and not lo <= abs(scale / k) <= hi and lo <= abs(scale / k) * deg <= hi:
            also = f"; it also turned {abs(k):.1f} times as far: its rates look like deg/s published as rad/s"
        raise InputError(
            f"the gyro turned the other way from the wheels in {against} of {len(g)} turns: an IMU mounted "
            "upside down (its z axis pointing down), or the left and right wheels swapped; mount it z up or "
            f"turn its frame in its driver{also}"
        )
    eb = scale / k
    if not lo <= eb <= hi and lo <= eb * deg <= hi:
        raise InputError(
            f"the gyro turned {1.0 / eb:.1f} times as far as the wheels (E_b {eb:.3g}; read as deg/s, "
            f"{eb * deg:.3g}; its bias at rest {math.degrees(bias_radps):.3g} deg/s read as rad/s, "
            f"{bias_radps:.3g} deg/s as deg/s): its rates look like deg/s published as rad/s "
            "(sensor_msgs/Imu angular_velocity is in rad/s)"
        )
    if not lo <= eb <= hi and 0.5 <= eb / deg <= hi:  # not a nominal wheelbase a few times off
        raise InputError(
            f"the wheels turned {eb:.3g} times as far as the gyro (E_b {eb:.3g}; {eb / deg:.3g} with a factor "
            "57.3 out): the wheel angles look like degrees (JointState positions are radians), or the gyro's "
            "rates divided by 57.3 (converted from degrees to radians twice)"
        )
    if not lo <= eb <= hi:
        raise InputError(
            f"the wheels turned {eb:.3g} times as far as the gyro (E_b {eb:.3g}, outside {lo:g} to {hi:g}): check "
            "the nominal wheel diameter and wheelbase (units: millimetres or metres) and the Imu topic"
        )
    return eb


def _checked_scale(scale: float, source: str) -> None:
    """Refuse a gyro scale outside :data:`SCALE_RANGE` measured against ``source``."""
    lo, hi = SCALE_RANGE
    if lo <= scale <= hi:
        return
    deg = math.degrees(1.0)
    if scale < 0 and source == "lidar":
        cause = (
            "the lidar turns the other way from the gyro and the wheels: a lidar mounted upside down (its scans "
            "mirrored: its frame's z axis down)"
        )
    elif lo <= scale / deg <= hi:
        cause = "its rates look like deg/s published as rad/s"
    else:
        cause = "the lidar's turns or the counted turns are not the gyro's (check `sensor_pose` and the full turns)"
    raise InputError(
        f"the gyro turned {scale:.3g} times as far as the {source} (its scale; a gyro's is within "
        f"{lo:g} to {hi:g}): {cause}"
    )


def gyro_history_fields(
    d: dict[str, Any], paths: Sequence[str | Path] = (), file_hash: Callable[[str], str] | None = None
) -> dict[str, Any]:
    """The keyword arguments of :func:`umbmark.history.record_result` for a gyro result given
    as its JSON (``{"gyro": GyroReference.to_dict(), "warnings": [...]}``, the output of
    ``umbmark replay --imu-topic ... --json``).

    The gyro measures the effective wheelbase only: the record's wheel factors are 1 (the
    radius multipliers stay as they are) and it holds no E_d.

    Parameters
    ----------
    d : dict
        The gyro result's JSON.
    paths : sequence of str or Path
        The bags it was made from (the first is the record's source).
    file_hash : callable, optional
        The content hash of the first bag; None: no hash.

    Returns
    -------
    dict
        ``kind`` (``gyro``), ``method``, ``results``, ``parameters`` (``c_left``, ``c_right``,
        ``wheelbase_mm``, ``Eb``), ``parameters_in_use`` (the nominal ``wheelbase_mm``),
        ``source``, ``input_sha256``.

    Raises
    ------
    InputError
        If ``d`` is not a gyro result's JSON.
    """
    g = d.get("gyro") if isinstance(d, dict) else None
    need = ("wheelbase_m", "nominal_wheelbase_m", "Eb")
    if not isinstance(g, dict) or any(not isinstance(g.get(k), (int, float)) for k in need):
        raise InputError("not the JSON of a gyro result (a `gyro` block with wheelbase_m, nominal_wheelbase_m, Eb)")
    first = Path(paths[0]) if paths else None
    return {
        "kind": "gyro",
        "method": "gyro",
        "results": d,
        "parameters": {"c_left": 1.0, "c_right": 1.0, "wheelbase_mm": g["wheelbase_m"] * 1e3, "Eb": g["Eb"]},
        "parameters_in_use": {"wheelbase_mm": g["nominal_wheelbase_m"] * 1e3},
        "source": None if first is None else str(first),
        "input_sha256": None if first is None or file_hash is None else file_hash(str(first)),
    }


def still_periods(
    t_s: ArrayLike, left_rad: ArrayLike, right_rad: ArrayLike, still_s: float
) -> list[tuple[float, float]]:
    """The stretches in which neither wheel turns, at least ``still_s`` long.

    Parameters
    ----------
    t_s : array_like
        ``(K,)`` wheel stamps [s].
    left_rad, right_rad : array_like
        ``(K,)`` cumulative wheel angles.
    still_s : float
        The shortest stillness [s].

    Returns
    -------
    list of (float, float)
        ``(start, end)`` times: from the last sample of the motion before (or the first sample)
        to the sample before the next motion (or the last sample).
    """
    t = np.asarray(t_s, dtype=float)
    dl = np.diff(np.asarray(left_rad, dtype=float))
    dr = np.diff(np.asarray(right_rad, dtype=float))
    moving = np.concatenate([[False], (dl != 0) | (dr != 0)])
    idx = np.flatnonzero(moving)
    bounds = [0] + [int(i) for i in idx] + [len(t)]  # still from sample a to sample b - 1 between motions
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        lo, hi = float(t[a]), float(t[b - 1])
        if hi - lo >= still_s:
            out.append((lo, hi))
    return out


def _bias(bag: GyroBag, stills: list[tuple[float, float]], margin_s: float) -> tuple[FloatArray, float, float, float]:
    """The bias at every reading (interpolated between still periods), the mean bias, noise, still time."""
    t, w = bag.imu_t_s, bag.rate_z_radps
    dt = float(np.median(np.diff(t)))
    centres, levels, counts, resid, total = [], [], [], [], 0.0
    for lo, hi in stills:
        r = w[(t - dt >= lo + margin_s) & (t <= hi - margin_s)]
        if r.size < 3:
            continue
        med = float(np.median(r))
        spread = max(1.4826 * float(np.median(np.abs(r - med))), 1e-12)
        kept = r[np.abs(r - med) <= 4.0 * spread]  # not the readings of a robot turned by hand
        centres.append(0.5 * (lo + hi))
        levels.append(float(np.mean(kept)))
        counts.append(kept.size)
        resid.append(kept - levels[-1])
        total += hi - lo - 2 * margin_s
    if not centres:
        return np.zeros_like(t), 0.0, float("nan"), 0.0
    bias = np.interp(t, centres, levels)
    res = np.concatenate(resid)
    noise = float(np.sqrt(np.sum(res**2) / max(res.size - len(levels), 1)))
    return bias, float(np.average(levels, weights=counts)), noise, total


def _heading(bag: GyroBag, bias: FloatArray) -> Callable[[float], float]:
    """The gyro's integrated heading as a function of time (each reading over the period before it)."""
    t = bag.imu_t_s
    dt = np.diff(t, prepend=t[0] - float(np.median(np.diff(t))))
    psi = np.concatenate([[0.0], np.cumsum((bag.rate_z_radps - bias) * dt)])
    knots = np.concatenate([[t[0] - dt[0]], t])

    def at(time: float) -> float:
        return float(np.interp(time, knots, psi))

    return at


def _turns(
    bag: GyroBag,
    nominal: WheelGeometry,
    stills: list[tuple[float, float]],
    heading: Callable[[float], float],
    spin_travel: float,
    guard_s: float,
) -> list[GyroTurn]:
    t = bag.wheel_t_s
    sl = np.concatenate([[0.0], np.cumsum(np.diff(bag.left_rad))]) * 0.5 * nominal.diameter_left_m
    sr = np.concatenate([[0.0], np.cumsum(np.diff(bag.right_rad))]) * 0.5 * nominal.diameter_right_m
    dist = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(sl) + np.diff(sr)) / 2)])
    out = []
    for (a0, a1), (b0, b1) in zip(stills[:-1], stills[1:]):
        ta, tb = max(0.5 * (a0 + a1), a1 - guard_s), min(0.5 * (b0 + b1), b0 + guard_s)
        ia, ib = int(np.searchsorted(t, ta)), int(np.searchsorted(t, tb))
        ia, ib = min(ia, len(t) - 1), min(ib, len(t) - 1)
        wheels = float((sr[ib] - sl[ib]) - (sr[ia] - sl[ia])) / nominal.wheelbase_m
        travel = float(dist[ib] - dist[ia])
        arc = 0.5 * nominal.wheelbase_m * abs(wheels)
        out.append(
            GyroTurn(
                bag.source,
                (ta, tb),
                wheels,
                heading(tb) - heading(ta),
                travel,
                travel <= spin_travel * arc,
                None,
                False,
            )
        )
    return out


def _lidar_turn(
    turn: GyroTurn, stills: list[tuple[float, float]], scans: SelfcalBag, sensor_pose: FloatArray, config: ICPConfig
) -> tuple[float | None, str]:
    """The true turn from the scans at rest before and after it (None and why when it fails)."""
    st = scans.scan_t_s
    before = [s for s in stills if s[0] <= turn.t_s[0] <= s[1]][-1]
    after = [s for s in stills if s[0] <= turn.t_s[1] <= s[1]][0]
    i = np.flatnonzero((st >= before[0]) & (st <= before[1]))
    j = np.flatnonzero((st >= after[0]) & (st <= after[1]))
    if i.size == 0 or j.size == 0:
        return None, "no scan at rest before or after it"
    wrapped = math.remainder(turn.gyro_rad, 2.0 * math.pi)
    guess = compose(compose(inverse(sensor_pose), [0.0, 0.0, wrapped]), sensor_pose)
    m = match_scans(scans.ranges_m[int(i[-1])], scans.ranges_m[int(j[0])], scans.angles_rad, guess, config)
    if not m.converged:
        return None, m.reason
    d = robot_displacement(m.pose, sensor_pose)
    return float(d[2]) + 2.0 * math.pi * round((turn.gyro_rad - float(d[2])) / (2.0 * math.pi)), ""


def _ratio(y: FloatArray, x: FloatArray) -> tuple[float, float | None]:
    """Least-squares ``k`` of ``y = k x`` and its standard error (None with one point)."""
    k = float(np.dot(x, y) / np.dot(x, x))
    if x.size < 2:
        return k, None
    s2 = float(np.sum((y - k * x) ** 2)) / (x.size - 1)
    return k, math.sqrt(s2 / float(np.dot(x, x)))


def _ci(value: float, rel_sd: float | None, dof: int) -> tuple[float, float] | None:
    if rel_sd is None or dof < 1:
        return None
    from umbmark._stats import t_ppf

    half = t_ppf(0.975, dof) * rel_sd * value
    return (value - half, value + half)


@dataclass
class _Pooled:
    """What the bags give together: every turn, each bag's still periods and wheel start, the gyro at rest."""

    turns: list[GyroTurn] = field(default_factory=list)
    stills_of: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    starts: dict[str, float] = field(default_factory=dict)
    biases: list[float] = field(default_factory=list)
    noises: list[float] = field(default_factory=list)
    weights: list[float] = field(default_factory=list)
    readings: int = 0
    still_total: float = 0.0


def _pool_bags(
    bags: Sequence[GyroBag],
    nominal: WheelGeometry,
    still_s: float,
    margin_s: float,
    guard_s: float,
    spin_travel: float,
) -> tuple[_Pooled, list[str]]:
    """Each bag's still periods, gyro bias and turns, pooled; a warning for a bag without a still period."""
    pooled = _Pooled(starts={bag.source: float(bag.wheel_t_s[0]) for bag in bags if len(bag.wheel_t_s)})
    warnings: list[str] = []
    for bag in bags:
        name = Path(bag.source).name
        stills = still_periods(bag.wheel_t_s, bag.left_rad, bag.right_rad, still_s)
        pooled.stills_of[bag.source] = stills
        bias, mean, noise, total = _bias(bag, stills, margin_s)
        pooled.readings += len(bag.imu_t_s)
        if total == 0.0:
            warnings.append(
                f"{name}: no still period of {still_s:g} s with gyro readings: the gyro's bias is not removed "
                "(rest the robot a few seconds before and after each turn)"
            )
        else:
            pooled.biases.append(mean)
            pooled.noises.append(noise)
            pooled.weights.append(total)
            pooled.still_total += total
        pooled.turns += _turns(bag, nominal, stills, _heading(bag, bias), spin_travel, guard_s)
    return pooled, warnings


def _where(turn: GyroTurn, starts: dict[str, float]) -> str:
    """Where a turn is, in seconds from its bag's wheel data's start."""
    return f"at {turn.t_s[0] - starts.get(turn.source, turn.t_s[0]):.1f} s in {Path(turn.source).name}"


def _turns_used(turns: list[GyroTurn], min_turn_rad: float, still_s: float) -> tuple[list[int], list[str]]:
    """The turns fitted: those of ``min_turn_rad`` or more on the spot, else all of them (warned)."""
    big = [i for i, tr in enumerate(turns) if abs(tr.wheels_rad) >= min_turn_rad]
    spots = [i for i in big if turns[i].on_the_spot]
    if not big:
        raise InputError(
            f"no turn of {math.degrees(min_turn_rad):.0f} deg or more between two still periods of {still_s:g} s: "
            "spin the robot on the spot both ways, resting before and after each spin"
        )
    warnings: list[str] = []
    if not spots:
        warnings.append(
            "no turn on the spot: the wheelbase comes from turns while driving, where the wheel diameter "
            "ratio E_d turns the robot too (spin on the spot for the wheelbase)"
        )
        spots = big
    directions = {np.sign(turns[i].wheels_rad) for i in spots}
    if len(directions) < 2:
        warnings.append("every turn used goes one way: spin both ways, so that a gyro bias left over cancels")
    return spots, warnings


def _full_turns(
    turns: list[GyroTurn], spots: list[int], starts: dict[str, float]
) -> tuple[dict[int, float], list[str]]:
    """The true turns counted as whole revolutions (the gyro's, rounded), warning of a turn far from whole."""
    true: dict[int, float] = {}
    warnings: list[str] = []
    for i in spots:
        g = turns[i].gyro_rad
        n = round(g / (2.0 * math.pi))
        if n == 0:
            continue
        true[i] = 2.0 * math.pi * n
        if abs(g / true[i] - 1.0) > 0.03:
            warnings.append(
                f"the gyro turned {g / (2.0 * math.pi):.2f} revolutions in the turn {_where(turns[i], starts)} "
                "(given as whole turns): its scale is off by more than 3 %, or the turn was not whole"
            )
    if not true:
        raise InputError("counted full turns: no turn on the spot of a revolution or more")
    return true, warnings


def _lidar_turns(
    turns: list[GyroTurn],
    spots: list[int],
    pooled: _Pooled,
    scans: dict[str, SelfcalBag],
    sensor_pose: ArrayLike,
    config: ICPConfig,
) -> tuple[dict[int, float], list[str]]:
    """The true turns the lidar registered, warning of each registration that failed."""
    true: dict[int, float] = {}
    warnings: list[str] = []
    pose = np.asarray(sensor_pose, dtype=float)
    for i in spots:
        scan_bag = scans.get(turns[i].source)
        if scan_bag is None:
            continue
        val, why = _lidar_turn(turns[i], pooled.stills_of[turns[i].source], scan_bag, pose, config)
        if val is None:
            warnings.append(f"the turn {_where(turns[i], pooled.starts)}: the scan registration failed ({why})")
        else:
            true[i] = val
    return true, warnings


def _true_turns(
    turns: list[GyroTurn],
    spots: list[int],
    pooled: _Pooled,
    full_turns: bool,
    scans: dict[str, SelfcalBag] | None,
    sensor_pose: ArrayLike,
    config: ICPConfig,
) -> tuple[dict[int, float], str, list[str]]:
    """The true turns where known (counted full turns, or the lidar), where they came from, warnings."""
    if full_turns:
        true, warnings = _full_turns(turns, spots, pooled.starts)
        return true, "full turns", warnings
    if scans:
        true, warnings = _lidar_turns(turns, spots, pooled, scans, sensor_pose, config)
        if not true:
            warnings.append("no turn measured by the lidar: the gyro's scale is assumed 1")
            return true, "assumed", warnings
        return true, "lidar", warnings
    return {}, "assumed", []


def _gyro_scale(turns: list[GyroTurn], true: dict[int, float]) -> tuple[float, tuple[float, float] | None]:
    """The gyro's scale, the least-squares ratio of its turns to the true ones, and its interval (1 without any)."""
    if not true:
        return 1.0, None
    idx = sorted(true)
    scale, sd = _ratio(np.array([turns[i].gyro_rad for i in idx]), np.array([true[i] for i in idx]))
    return scale, _ci(scale, None if sd is None else sd / scale, len(idx) - 1)


def _wheelbase_factor(
    turns: list[GyroTurn], spots: list[int], scale: float, scale_ci: tuple[float, float] | None, bias: float = 0.0
) -> tuple[float, tuple[float, float] | None, list[str]]:
    """``E_b = scale / k`` of the turns fitted and its interval (none, warned, with one turn)."""
    g = np.array([turns[i].gyro_rad for i in spots])
    w = np.array([turns[i].wheels_rad for i in spots])
    k, k_sd = _ratio(g, w)
    eb = _checked_eb(g, w, k, scale, bias)
    rel = None
    warnings: list[str] = []
    if k_sd is not None:
        rel = math.hypot(k_sd / k, 0.0 if scale_ci is None else (scale_ci[1] - scale) / 1.96 / scale)
    else:
        warnings.append("one turn used: no interval (spin several times both ways)")
    return eb, _ci(eb, rel, len(spots) - 1), warnings


def gyro_reference(
    bags: Sequence[GyroBag],
    nominal: WheelGeometry,
    *,
    full_turns: bool = False,
    scans: dict[str, SelfcalBag] | None = None,
    sensor_pose: ArrayLike = (0.0, 0.0, 0.0),
    still_s: float = 0.3,
    margin_s: float = 0.1,
    guard_s: float = 0.5,
    min_turn_rad: float = math.radians(20.0),
    spin_travel: float = 0.1,
    config: ICPConfig = SCAN_TRUTH_ICP,
) -> GyroReference:
    """The effective wheelbase from the gyro's turns and the wheels' (module docstring).

    Parameters
    ----------
    bags : sequence of GyroBag
        The gyro and wheel data (pooled over bags).
    nominal : WheelGeometry
        The nominal wheels and wheelbase the wheels' turns are computed with.
    full_turns : bool
        Every turn on the spot was a whole number of revolutions: the gyro's scale from them.
    scans : dict, optional
        The scans of each bag (by ``source``): the gyro's scale from the lidar.
    sensor_pose : array_like
        The lidar's mounting pose ``(x_m, y_m, yaw_rad)`` (with ``scans``).
    still_s, margin_s : float
        The shortest stillness, and the time left out at either end of it for the bias [s].
    guard_s : float
        A turn is integrated from this long before the wheels start to this long after they
        stop (at most from the middle of the still periods around it) [s].
    min_turn_rad : float
        Turns below this are not used.
    spin_travel : float
        A turn is on the spot when the wheels' mean travel is below this fraction of its arc.
    config : ICPConfig
        The scan registration (with ``scans``).

    Returns
    -------
    GyroReference

    Raises
    ------
    InputError
        Both ``full_turns`` and ``scans``; no bags; no turn of ``min_turn_rad`` between two still
        periods; with ``full_turns``, no turn of a revolution or more.
    """
    if full_turns and scans:
        raise InputError("the gyro's scale comes from counted full turns or from the lidar, not both")
    if not bags:
        raise InputError("no bags with gyro readings")
    if not (math.isfinite(still_s) and still_s > 2 * margin_s >= 0):
        raise InputError(f"`still_s` must exceed twice the margin {margin_s:g} s, got {still_s!r}")
    warnings: list[str] = [f"{Path(bag.source).name}: {w}" for bag in bags for w in bag.warnings]
    pooled, w = _pool_bags(bags, nominal, still_s, margin_s, guard_s, spin_travel)
    warnings += w
    turns = pooled.turns
    spots, w = _turns_used(turns, min_turn_rad, still_s)
    warnings += w
    weights = pooled.weights
    bias = float(np.average(pooled.biases, weights=weights)) if weights else 0.0
    g = np.array([turns[i].gyro_rad for i in spots])
    _checked_eb(
        g,
        np.array([turns[i].wheels_rad for i in spots]),
        _ratio(g, np.array([turns[i].wheels_rad for i in spots]))[0],
        1.0,
        bias,
    )
    if abs(bias) > MAX_BIAS_RADPS:
        warnings.append(
            f"the gyro reads {math.degrees(bias):.3g} deg/s at rest: more than any gyro's bias "
            f"({math.degrees(MAX_BIAS_RADPS):g} deg/s): the robot turning while its wheels rest, or rates in "
            "another unit; check the Imu topic's readings at rest"
        )
    for scan_bag in (scans or {}).values():  # a lidar upside down, ranges or wheels in another unit
        d_m = 0.5 * (nominal.diameter_left_m + nominal.diameter_right_m)
        check_bag_motion(scan_bag, d_m, nominal.wheelbase_m, np.asarray(sensor_pose, dtype=float))
    true, source, w = _true_turns(turns, spots, pooled, full_turns, scans, sensor_pose, config)
    warnings += w
    scale, scale_ci = _gyro_scale(turns, true)
    if true:
        _checked_scale(scale, "lidar" if source == "lidar" else "counted full turns")
    eb, eb_ci, w = _wheelbase_factor(turns, spots, scale, scale_ci, bias)
    warnings += w
    used = set(spots)
    turns = [
        GyroTurn(t.source, t.t_s, t.wheels_rad, t.gyro_rad, t.travel_m, t.on_the_spot, true.get(i), i in used)
        for i, t in enumerate(turns)
    ]
    b = nominal.wheelbase_m
    return GyroReference(
        imu_topic=bags[0].imu_topic,
        nominal_wheelbase_m=b,
        wheelbase_m=eb * b,
        wheelbase_m_ci95=None if eb_ci is None else (eb_ci[0] * b, eb_ci[1] * b),
        eb=eb,
        eb_ci95=eb_ci,
        gyro_scale=scale,
        gyro_scale_ci95=scale_ci,
        gyro_scale_source=source,
        bias_radps=bias,
        noise_radps=float(np.average(pooled.noises, weights=weights)) if weights else float("nan"),
        still_s=pooled.still_total,
        readings=pooled.readings,
        turns=tuple(turns),
        warnings=tuple(dict.fromkeys(warnings)),
    )
