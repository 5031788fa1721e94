"""Plausibility of a log's run: its wheels against its ground truth (units, swapped wheels, a
ground truth that never moves). Shared by the log readers."""

from __future__ import annotations

import math

import numpy as np

from umbmark.errors import InputError
from umbmark.model.dataset import Run, WheelGeometry
from umbmark.model.geometry import nominal_slip

__all__ = ["wheels_against_truth", "check_tick_mode"]

# the ground truth of a run that moves less than this never moved (nothing was tracked)
_STILL_M = 1e-3
_STILL_RAD = math.radians(0.5)
# the wheels' travel against the ground truth's: outside these ratios the geometry's units are wrong
_TRAVEL_RATIO = (0.5, 2.0)
# compared every half second, so that the motion capture's jitter does not add up
_STEP_S = 0.5
_MIN_TURN_RAD = math.radians(90.0)
# the tick-mode check: runs of at least this many samples; a counter spans this many steps
_MIN_SAMPLES = 50
_COUNTER_SPAN = 20.0


def wheels_against_truth(
    run: Run, nominal: WheelGeometry, units_per_wheel_rev: float, travel_hint: str, turn_hint: str, degrees_hint: str
) -> list[str]:
    """The run's ground-truth track against its wheels and the nominal geometry.

    Parameters
    ----------
    run : Run
        A run with a ground-truth track (others are not checked).
    nominal : WheelGeometry
        The geometry the wheels are read with.
    units_per_wheel_rev : float
        Encoder units per wheel revolution.
    travel_hint, turn_hint : str
        What to check when the travels, or the turns, disagree (named in the warning).
    degrees_hint : str
        What to do about headings in degrees (named in the error).

    Returns
    -------
    list of str
        Warnings: travels differing by more than a factor of 2 (a unit of the positions or the
        geometry), turns in opposite senses (left and right swapped), turns differing by more
        than a factor of 2.

    Raises
    ------
    InputError
        The ground truth never moves while the wheels travel (nothing was tracked), or turns
        about 57 times what the wheels turn (headings in degrees: the start frame is then wrong).
    """
    if run.gt is None or len(run.t) < 2 or not np.isfinite(run.gt).all():
        return []
    src = run.source or run.name
    k = np.unique(np.searchsorted(run.t, np.arange(0.0, run.t[-1], _STEP_S)))
    k = np.append(k[k < len(run.t)], len(run.t) - 1)
    gx, gy, gth = run.gt[k, 0], run.gt[k, 1], run.gt[k, 2]
    gt_path = float(np.sum(np.hypot(np.diff(gx), np.diff(gy))))
    gt_dth = np.diff(gth)
    gt_turn = float(np.sum(np.abs(gt_dth)))
    dl = np.cumsum(run.d_left)[k] * math.pi * nominal.diameter_left_m / units_per_wheel_rev
    dr = np.cumsum(run.d_right)[k] * math.pi * nominal.diameter_right_m / units_per_wheel_rev
    wheel_path = float(np.sum(np.abs(np.diff(dl + dr)) / 2.0))
    wheel_dth = np.diff(dr - dl) / nominal.wheelbase_m
    wheel_turn = float(np.sum(np.abs(wheel_dth)))
    if not (math.isfinite(wheel_path) and math.isfinite(wheel_turn)):
        return []
    if gt_path < _STILL_M and gt_turn < _STILL_RAD and wheel_path > 100 * _STILL_M:
        raise InputError(
            f"the ground truth never moves (position and heading constant) while the wheels travel {wheel_path:.2f} m: "
            "the robot was not tracked in this run",
            src,
        )
    lo, hi = _TRAVEL_RATIO
    slip = nominal_slip("diameter", gt_path / wheel_path) if wheel_path > 0 and gt_path > 0 else None
    if gt_path > 100 * _STILL_M and (slip is not None or not lo <= wheel_path / gt_path <= hi):
        lead = (
            f"the nominal wheel diameter is {wheel_path / gt_path:.2f} times the one the travel shows: {slip} Else c"
            if slip
            else "c"
        )
        return [
            f"{src}: the wheels travel {wheel_path:.3g} m by the nominal geometry, the ground truth {gt_path:.3g} m: "
            f"{lead}heck {travel_hint}"
        ]
    if max(gt_turn, wheel_turn) < _MIN_TURN_RAD:
        return []
    norm = float(np.linalg.norm(gt_dth) * np.linalg.norm(wheel_dth))
    if norm > 0 and float(np.dot(gt_dth, wheel_dth)) < -0.5 * norm:
        return [
            f"{src}: the wheels turn the robot the other way than the ground truth does: the left and right wheel "
            "data look swapped"
        ]
    if wheel_turn > _MIN_TURN_RAD and lo * 180 / math.pi <= gt_turn / wheel_turn <= hi * 180 / math.pi:
        raise InputError(
            f"the ground truth turns {gt_turn:.3g} units in total, {gt_turn / wheel_turn:.0f} times what the wheels "
            f"turn in radians: its headings are degrees, read as radians ({degrees_hint})",
            src,
        )
    slip = nominal_slip("wheelbase", wheel_turn / gt_turn) if wheel_turn > 0 and gt_turn > 0 else None
    if slip is not None or not lo <= wheel_turn / max(gt_turn, 1e-12) <= hi:
        lead = (
            f"the nominal wheelbase is {gt_turn / wheel_turn:.2f} times the one the turns show: {slip} Else c"
            if slip
            else "c"
        )
        return [
            f"{src}: the wheels turn the robot by {math.degrees(wheel_turn):.3g} deg in total by the nominal geometry, "
            f"the ground truth by {math.degrees(gt_turn):.3g} deg: {lead}heck {turn_hint}"
        ]
    return []


def _track_length(run: Run) -> float | None:
    """The ground-truth track's length, sampled every half second (None without a track)."""
    if run.gt is None or len(run.t) < 2 or not np.isfinite(run.gt).all():
        return None
    k = np.unique(np.searchsorted(run.t, np.arange(0.0, run.t[-1], _STEP_S)))
    k = np.append(k[k < len(run.t)], len(run.t) - 1)
    return float(np.sum(np.hypot(np.diff(run.gt[k, 0]), np.diff(run.gt[k, 1]))))


def check_tick_mode(
    raw: np.ndarray,
    ticks: str,
    run: Run,
    nominal: WheelGeometry,
    units_per_wheel_rev: float,
    side_m: float | None,
    line: int,
) -> None:
    """Refuse ticks read in the wrong mode: the travel they give is off by far from the ground
    truth's track (or the square's four sides), and the other mode matches it.

    Parameters
    ----------
    raw : numpy.ndarray
        The run's left and right tick cells, shape (K, 2).
    ticks : str
        The mode they are read in: ``cumulative`` or ``incremental``.
    run : Run
        The run read from them (its ground truth and source).
    nominal : WheelGeometry
        The nominal geometry.
    units_per_wheel_rev : float
        Encoder pulses per wheel revolution.
    side_m : float or None
        The square's side, when the runs are squares.
    line : int
        The run's first line, for the message.

    Raises
    ------
    InputError
        The other tick mode explains the travel and this one does not.
    """
    expected = _track_length(run)
    if expected is None or expected < 100 * _STILL_M:
        expected = None if side_m is None else 4.0 * side_m
    if expected is None or len(raw) < _MIN_SAMPLES:
        return
    kl = math.pi * nominal.diameter_left_m / units_per_wheel_rev
    kr = math.pi * nominal.diameter_right_m / units_per_wheel_rev

    def travel(d: np.ndarray) -> float:
        return float(np.sum(np.abs(d[:, 0] * kl + d[:, 1] * kr)) / 2.0)

    d = np.diff(raw, axis=0)
    cum = travel(d)
    inc = travel(raw[1:])
    this, other, name = (cum, inc, "incremental") if ticks == "cumulative" else (inc, cum, "cumulative")
    # and the ticks themselves: a counter's values span many times its largest step (the
    # whole travel), pulses per sample hardly more than their largest change
    span = np.ptp(raw, axis=0) / np.maximum(np.max(np.abs(d), axis=0), 1e-12)
    counter = bool(np.max(span) >= _COUNTER_SPAN)
    looks = not counter if ticks == "cumulative" else counter
    if looks and not 0.1 <= this / expected <= 10.0 and 0.67 <= other / expected <= 1.5:
        raise InputError(
            f"read as {ticks} ticks the wheels travel {this:.3g} m, as {name} ticks {other:.3g} m, and the robot "
            f'travelled about {expected:.3g} m: the ticks look {name} (`ticks="{name}"`)',
            run.source,
            line,
        )
