"""The wheels' motion against the lidar's, before a self-calibration: units and signs.

The wheel data in another unit (joint positions in degrees, a wrong encoder resolution, counts
per message read as a running counter) or a lidar mounted upside down (its scans mirrored) do
not make a self-calibration fail where they are: the scan matching, started from an odometry
57 times too long, fails and asks to drive longer; a mirrored lidar gives a negative
wheelbase. :func:`check_wheels_against_scans` compares the two motions directly: consecutive
scans (a tenth of a second apart: the robot moved little) are matched from no motion at all,
whatever the wheels say, and the robot's travel and turns they show are set against the nominal
odometry's over the same scans.

* **Turning the other way**: in most of the scan pairs that turn, the lidar turns against the
  wheels: a lidar mounted upside down (or the wheels' joints given right before left).
* **Travel at another scale**: the wheels' travel over the lidar's beyond
  :data:`TRAVEL_RATIO` either way (the turns' beyond :data:`TURN_RATIO` when the robot only
  spins: a skid-steer robot turns less than its wheels say): the factor is named, 57.3 as
  degrees, a factor near nothing as counts per message read as a counter.
* **The joints read otherwise** (:func:`check_readings`): the joints given in another order,
  a drive and a steering joint exchanged, a steering zero a quarter turn off. Each reading's
  odometry is set against the lidar's motion (:func:`disagreement`: what is left of the lidar's
  travel and turn once each is scaled to fit best, so that a nominal size off does not count);
  a reading far closer to the lidar than the joints as given names itself.

The lidar's motion is matched once (:func:`lidar_motion`) and serves every check.

SI units. Imports numpy, :mod:`umbmark.model.se2`, :mod:`umbmark.kinds` (the causes each kind
names) and the scan matcher.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import refusal
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag
from umbmark.kinds import DEFAULT_KIND, kind_named
from umbmark.model import se2
from umbmark.realrobot.scanmatch import ICPConfig, match_scan_pairs

__all__ = [
    "check_wheels_against_scans",
    "check_readings",
    "lidar_motion",
    "disagreement",
    "LidarMotion",
    "TRAVEL_RATIO",
    "TURN_RATIO",
    "DEGREE",
    "READING_FAR",
]

FloatArray = NDArray[np.float64]

TRAVEL_RATIO = 3.0
"""The wheels' travel over the lidar's beyond this (or below its inverse) is another unit: a
nominal wheel within a factor of two of the true one, slip of a few per cent."""

TURN_RATIO = 6.0
"""The same for the turns alone: a skid-steer robot's effective wheelbase is up to four times
its track (:data:`umbmark.realrobot.gyro.EB_RANGE`)."""

DEGREE = math.degrees(1.0)
"""A quantity in degrees read as radians is this many times too large."""

_PAIRS = 120  # consecutive scan pairs matched (spread over the recording)
_MIN_TRAVEL_M = 0.3  # the lidar's summed travel over them that makes a travel ratio
_MIN_TURN_RAD = math.radians(30.0)  # ... and the summed turn that makes a turn ratio
_STRAIGHT_RAD = math.radians(1.0)  # a pair turning less counts for the travel ratio
_TURN_STEP_RAD = math.radians(0.5)  # a pair turning less is left out of the sign count
_STEP_M = 0.005  # a pair moving less than this forward is left out of the direction count
_AGAINST = 0.8  # the share of turning pairs turning the other way that names a mirror
_SURE_INLIERS = 0.8  # a match from no motion that matched less of the points is searched for widely

READING_FAR = 2.5
"""Another reading of the joints names itself when the joints as given are this many times
further from the lidar's travel or turn (:func:`disagreement`) where it agrees with the lidar,
and no further in the other."""
_READING_MARGIN = 0.06  # ... and further by at least this much
_READING_AGREES = 0.25  # ... where it leaves at most this share unexplained
_READING_NOT_WORSE = 0.05  # ... and it leaves at most this much more of the other unexplained
_READING_ROUGHLY = 0.5  # ... and at most this share of either
_READING_TIE = 1.25  # readings within this factor of the closest are as close (the driving cannot tell them)
_READING_EVEN = 0.02  # ... or this much
_READINGS_NAMED = 4  # at most this many of them named (a mecanum robot that never moves sideways: four orders alike)
_MIRROR_SLACK = 0.2  # a lidar upside down as close as the closest reading but this much (its pose is not mirrored)


def _pairs(usable: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Up to :data:`_PAIRS` consecutive usable scans, spread evenly over the recording (whatever
    the wheels say: wheel data in another unit may not move where the robot does)."""
    i = np.flatnonzero(usable[:-1] & usable[1:])
    if i.size == 0:
        return np.zeros(0, dtype=np.int64)
    take = np.unique(np.linspace(0, i.size - 1, min(_PAIRS, i.size)).round().astype(np.int64))
    return i[take]


def _steps(odo: FloatArray) -> FloatArray:
    """The odometry's motion from each scan to the next, in the robot's frame."""
    return se2.between(odo[:-1], odo[1:]) if len(odo) > 1 else np.zeros((0, 3))


def _unit_cause(ratio: float, wheel_kind: str) -> str:
    """The likely unit mistake of a travel ratio far from 1."""
    if abs(ratio / DEGREE - 1.0) < 0.35:
        what = {
            "joints": "the joint positions look like degrees (JointState positions are radians)",
            "ticks": "`pulses_per_wheel_rev` 57.3 times too small, or counts in degrees",
            "odom": "the odometry's units",
        }.get(wheel_kind, "wheel angles in degrees")
        return f"{what}"
    if ratio < 1.0 / 20.0 and wheel_kind == "ticks":
        return 'the counts look like counts per message read as a running counter (`ticks="incremental"`)'
    if ratio < 1.0 / 20.0 and wheel_kind == "joints":
        return "the joints hardly move while the robot does: other joints than the wheels' (`joints`)"
    return (
        "the wheel data's units (joint positions in radians, `pulses_per_wheel_rev`) or the nominal wheel "
        "size (`wheel_diameter_mm`)"
    )


@dataclass(frozen=True, eq=False)
class LidarMotion:
    """The lidar's own motion between consecutive scans, matched from no motion at all.

    Attributes
    ----------
    index : numpy.ndarray
        ``(P,)`` the first scan of each pair that matched (the second is the next).
    seen : numpy.ndarray
        ``(P, 3)`` the robot's motion over each pair as the lidar saw it (at its nominal pose;
        pairs that hardly turn: the sensor's own travel, whatever its nominal position).
    mirrored : numpy.ndarray
        ``(P, 3)`` the same of the scans mirrored (what a lidar mounted upside down would have seen).
    """

    index: NDArray[np.int64]
    seen: FloatArray
    mirrored: FloatArray


def _robot_motion(raw: FloatArray, lidar: FloatArray) -> FloatArray:
    seen = se2.compose(lidar, se2.compose(raw, se2.inverse(lidar)))
    # the travel of pairs that hardly turn is the sensor's own, whatever its nominal pose
    c, si = math.cos(lidar[2]), math.sin(lidar[2])
    own = np.column_stack([c * raw[:, 0] - si * raw[:, 1], si * raw[:, 0] + c * raw[:, 1]])
    seen[:, :2] = np.where(np.abs(raw[:, 2:3]) < _STRAIGHT_RAD, own, seen[:, :2])
    return np.asarray(seen, dtype=float)


def _matched_from_rest(bag: SelfcalBag, i: NDArray[np.int64]) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The scans ``i`` matched to the next ones from no motion: the plain matcher first, the wide
    search (a hundred times the cost) where it did not converge or matched less than
    :data:`_SURE_INLIERS` of the points (a local minimum a wide search may leave)."""
    ref, cur = bag.ranges_m[i], bag.ranges_m[i + 1]
    m = match_scan_pairs(ref, cur, bag.angles_rad, None, ICPConfig())
    poses = np.array(m.poses, dtype=float)
    ok = np.asarray(m.converged, dtype=bool).copy()
    again = np.flatnonzero(~ok | (np.asarray(m.inlier_fraction) < _SURE_INLIERS))
    if again.size:
        w = match_scan_pairs(ref[again], cur[again], bag.angles_rad, None, ICPConfig(coarse=True))
        poses[again] = w.poses
        ok[again] = w.converged
    return poses, ok


def lidar_motion(bag: SelfcalBag, usable: ArrayLike, sensor_pose: ArrayLike) -> LidarMotion | None:
    """Up to :data:`_PAIRS` consecutive usable scans (spread over the recording) matched from no
    motion (the plain matcher, the wide search where it is not sure), in the robot's frame.

    Parameters
    ----------
    bag : SelfcalBag
        The recording (its scans).
    usable : array_like
        ``(M,)`` the scans with wheel data around them.
    sensor_pose : array_like
        ``(3,)`` the lidar's nominal mounting pose ``(x_m, y_m, yaw_rad)``.

    Returns
    -------
    LidarMotion or None
        None: fewer than ten pairs matched (too little to judge from).
    """
    i = _pairs(np.asarray(usable, dtype=bool))
    if i.size < 10:
        return None
    poses, ok = _matched_from_rest(bag, i)
    if ok.sum() < 10:
        return None
    lidar = np.asarray(sensor_pose, dtype=float)
    raw = poses[ok]
    return LidarMotion(i[ok], _robot_motion(raw, lidar), _robot_motion(raw * [1.0, -1.0, -1.0], lidar))


def check_wheels_against_scans(
    bag: SelfcalBag,
    st: ArrayLike,
    usable: ArrayLike,
    odometry: ArrayLike,
    sensor_pose: ArrayLike,
    *,
    kind: str = DEFAULT_KIND,
    alternatives: Mapping[str, ArrayLike] | None = None,
    motion: LidarMotion | None = None,
) -> None:
    """Refuse wheel data whose motion the lidar contradicts (module docstring).

    Parameters
    ----------
    bag : SelfcalBag
        The recording (its scans).
    st : array_like
        ``(M,)`` the scans' times on the wheels' clock [s] (unused but for their count).
    usable : array_like
        ``(M,)`` the scans with wheel data around them.
    odometry : array_like
        ``(M, 3)`` the nominal odometry's robot pose at each scan.
    sensor_pose : array_like
        ``(3,)`` the lidar's nominal mounting pose ``(x_m, y_m, yaw_rad)``.
    kind : str
        The kind of robot (:data:`umbmark.kinds.KINDS`): the wording of a mirror's causes.
    alternatives : dict, optional
        Other readings of the wheel data (how they would be read, in words -> their ``(M, 3)``
        odometry at the scans): the one the lidar agrees with is named as the cause.
    motion : LidarMotion, optional
        The lidar's motion when it was matched already (:func:`lidar_motion` of the same scans
        and pose); None: matched here.

    Raises
    ------
    InputError
        The lidar turns the other way from the wheels, or the wheels travel (turn) a factor
        beyond :data:`TRAVEL_RATIO` (:data:`TURN_RATIO`) from what the lidar saw.
    """
    odo = np.asarray(odometry, dtype=float)
    if odo.shape != (len(np.asarray(st)), 3) or len(bag.ranges_m) != len(odo):
        raise InputError(f"`odometry` must hold one pose per scan, got {odo.shape}", bag.source)
    lm = lidar_motion(bag, usable, sensor_pose) if motion is None else motion
    if lm is None:
        return
    wheel = _steps(odo)[lm.index]
    _check_turn_signs(wheel, lm.seen, kind, bag)
    other = {k: _steps(np.asarray(v, dtype=float))[lm.index] for k, v in (alternatives or {}).items()}
    _check_scale(wheel, lm.seen, bag, other)


def disagreement(wheel: ArrayLike, seen: ArrayLike) -> FloatArray:
    """How far the wheels' motion over pairs of scans is from the lidar's: the lidar's travel and
    its turn each scaled to fit best (a scale at least 0, so that a nominal size off does not
    count) and the share of each left unexplained (0: the same motion; 1: the wheels explain
    none of it).

    Parameters
    ----------
    wheel, seen : array_like
        ``(P, 3)`` the wheels' and the lidar's motions over the pairs, in the robot's frame.

    Returns
    -------
    numpy.ndarray
        ``(2,)`` the shares of the travel and of the turn; NaN where the lidar hardly saw it
        (under 0.3 m of travel, 30 deg of turn over the pairs).
    """
    w, s = np.asarray(wheel, dtype=float), np.asarray(seen, dtype=float)
    out = np.full(2, np.nan)
    for k, (part, least) in enumerate(((slice(0, 2), _MIN_TRAVEL_M), (slice(2, 3), _MIN_TURN_RAD))):
        ws, ss = w[:, part], s[:, part]
        total = float(np.sum(np.linalg.norm(ss, axis=1)))
        if total >= least:
            a = max(float(np.sum(ws * ss)) / max(float(np.sum(ws * ws)), 1e-300), 0.0)
            out[k] = min(float(np.sum(np.linalg.norm(a * ws - ss, axis=1))) / total, 1.0)  # no worse than none
    return out


def _far_closer(other: FloatArray, given: FloatArray) -> bool:
    """Whether a reading is far closer to the lidar than the joints as given: no component
    further, none far from the lidar (:data:`_READING_ROUGHLY`), one :data:`READING_FAR` times
    closer (and by :data:`_READING_MARGIN`) and agreeing with the lidar (:data:`_READING_AGREES`)."""
    both = np.isfinite(other) & np.isfinite(given)
    o, g = other[both], given[both]
    if o.size == 0 or np.any(o > g + _READING_NOT_WORSE) or np.any(o > _READING_ROUGHLY):
        return False
    return bool(np.any((o <= _READING_AGREES) & (g >= READING_FAR * o) & (g - o >= _READING_MARGIN)))


def _shares(d: FloatArray) -> str:
    """A disagreement in words: ``travel 60 %, turn 1 %``."""
    return ", ".join(f"{what} {100 * v:.0f} %" for what, v in zip(("travel", "turn"), d) if np.isfinite(v))


def check_readings(
    motion: LidarMotion | None,
    odometry: ArrayLike,
    readings: Sequence[tuple[tuple[str, str], ArrayLike]],
    source: str,
) -> None:
    """Refuse joints whose motion the lidar contradicts where another reading of them agrees
    (module docstring): the closest reading's cause named (several, when the driving cannot tell
    them apart), and a lidar mounted upside down beside it when the mirrored scans agree as well
    (then, where the lidar turns against the joints, as the check ``turn_direction``).

    Parameters
    ----------
    motion : LidarMotion or None
        The lidar's motion (:func:`lidar_motion`); None: nothing to judge from.
    odometry : array_like
        ``(M, 3)`` the nominal odometry of the joints as given at each scan.
    readings : sequence of ((str, str), array_like)
        The other readings: what each means and what to do (a message's words: ``(words,
        remedy)``, :meth:`umbmark.kinds.Kind.reading_cause`), and its ``(M, 3)`` odometry at the
        scans.
    source : str
        The recording, for the message.

    Raises
    ------
    InputError
        Another reading far closer to the lidar's motion (:func:`disagreement`: no part of it
        further, one part :data:`READING_FAR` times closer): the check ``joint_order``, or
        ``turn_direction`` beside a lidar upside down.
    """
    if motion is None or not readings:
        return
    wheel = _steps(np.asarray(odometry, dtype=float))[motion.index]
    given = disagreement(wheel, motion.seen)
    scores = [disagreement(_steps(np.asarray(o, dtype=float))[motion.index], motion.seen) for _, o in readings]
    closer = sorted((float(np.nansum(d)), i) for i, d in enumerate(scores) if _far_closer(d, given))
    if not closer:
        return
    best = closer[0][0]
    near = [readings[i][0] for total, i in closer if total <= _READING_TIE * best + _READING_EVEN]
    cause = _causes(near[:_READINGS_NAMED])
    mirror = disagreement(wheel, motion.mirrored) - scores[closer[0][1]]
    if np.all(np.nan_to_num(mirror) <= _MIRROR_SLACK):
        # a lidar upside down moves the robot alike: both named, as the turns against each other show
        where = _turns_against(wheel, motion.seen)
        if where is not None:
            _refuse("turn_direction", f"{where}: {_UPSIDE_DOWN}, or {cause}", source)
            return
        cause += f"; or {_UPSIDE_DOWN}, which moves the robot alike"
    _refuse(
        "joint_order",
        f"the joints as given move the robot otherwise than the lidar sees it move (unexplained over "
        f"{len(motion.index)} pairs of consecutive scans: {_shares(given)} of its motion; read otherwise, "
        f"{_shares(scores[closer[0][1]])}): {cause}",
        source,
    )


def _causes(near: list[tuple[str, str]]) -> str:
    """The causes of the closest readings in words: one, or those the driving cannot tell apart
    (the remedies of the same words together)."""
    if len(near) == 1:
        return f"{near[0][0]}: {near[0][1]}"
    by_words: dict[str, list[str]] = {}
    for words, remedy in near:
        by_words.setdefault(words, []).append(remedy)
    parts = [f"{words}: {'; or '.join(remedies)}" for words, remedies in by_words.items()]
    return f"one of these, which the driving cannot tell apart: {'; or '.join(parts)}"


_UPSIDE_DOWN = (
    "a lidar mounted upside down (its scans mirrored: its frame's z axis down; turn it over in the URDF or the driver)"
)


def _turns_against(wheel: FloatArray, seen: FloatArray) -> str | None:
    """Where the lidar turns the other way from the wheels in most scan pairs that turn
    (:data:`_AGAINST` of them, at least five), in words; else None."""
    turning = (np.abs(seen[:, 2]) > _TURN_STEP_RAD) & (np.abs(wheel[:, 2]) > 0.1 * _TURN_STEP_RAD)
    n = int(turning.sum())
    against = int(np.sum(np.sign(seen[turning, 2]) != np.sign(wheel[turning, 2])))
    if n < 5 or against < _AGAINST * n:
        return None
    return f"the lidar turns the other way from the wheels in {against} of {n} scan pairs that turn"


def _check_turn_signs(wheel: FloatArray, seen: FloatArray, kind: str, bag: SelfcalBag) -> None:
    """Refuse turns the other way: mirrored scans (the lidar upside down) or wheels exchanged
    when the robot's forward travel agrees; wheels counted backwards when it does not."""
    where = _turns_against(wheel, seen)
    if where is None:
        return
    ahead = (np.abs(seen[:, 0]) > _STEP_M) & (np.abs(wheel[:, 0]) > 0.1 * _STEP_M)
    back = int(np.sum(np.sign(seen[ahead, 0]) != np.sign(wheel[ahead, 0])))
    causes = kind_named(kind)
    if ahead.sum() >= 5 and back >= _AGAINST * ahead.sum():
        backwards = causes.turn_backwards
        _refuse("turn_direction", f"{where}, and it moves back where they drive forward: {backwards}", bag.source)
        return
    _refuse("turn_direction", f"{where}: {_UPSIDE_DOWN}, or {causes.turn_mirrored}", bag.source)


def _ratio(wheel: FloatArray, seen: FloatArray) -> tuple[float, float, str, str] | None:
    """The wheels' travel over the lidar's (their turn over its, when the robot hardly
    travels), its bound, what was compared and how much the lidar saw; None: too little motion."""
    straight = np.abs(seen[:, 2]) < _STRAIGHT_RAD  # the lever arm of a wrong sensor pose does not count there
    travel_seen = float(np.sum(np.hypot(seen[straight, 0], seen[straight, 1])))
    turn_seen = float(np.sum(np.abs(seen[:, 2])))
    if travel_seen >= _MIN_TRAVEL_M:
        travel_wheel = float(np.sum(np.hypot(wheel[straight, 0], wheel[straight, 1])))
        return travel_wheel / travel_seen, TRAVEL_RATIO, "travel", f"{travel_seen:.2f} m"
    if turn_seen >= _MIN_TURN_RAD:
        turn_wheel = float(np.sum(np.abs(wheel[:, 2])))
        return turn_wheel / turn_seen, TURN_RATIO, "turn", f"{math.degrees(turn_seen):.0f} deg"
    return None


def _check_scale(wheel: FloatArray, seen: FloatArray, bag: SelfcalBag, alternatives: dict[str, FloatArray]) -> None:
    found = _ratio(wheel, seen)
    if found is None:
        return
    ratio, bound, what, seen_text = found
    cause = None
    if not 0.5 <= ratio <= 2.0:  # another reading the lidar agrees with names itself
        for reading, steps in alternatives.items():
            other = _ratio(steps, seen)
            if other is not None and other[2] == what and 1.0 / 1.5 <= other[0] <= 1.5:
                cause = f"they look like {reading} (read so, they {what} {other[0]:.3g} times as far)"
                break
    if cause is None:
        if 1.0 / bound <= ratio <= bound:
            return
        cause = _unit_cause(ratio, bag.wheel_kind)
    _refuse(
        "wheel_units",
        f"the wheels {what} {ratio:.3g} times as far as the lidar sees the robot {what} ({seen_text} over "
        f"{len(seen)} pairs of consecutive scans): {cause}",
        bag.source,
    )


def _refuse(check: str, message: str, source: str) -> None:
    """Raise the named check's refusal unless it is skipped."""
    err = refusal(check, message, source)
    if err is not None:
        raise err
