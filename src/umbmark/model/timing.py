"""Time stamps of logged streams: coverage, and the time offset between the wheel data and the
ground truth; the checks of both streams.

The checks of one stream live in :mod:`umbmark.model.stamps` (order, repeats, spikes),
:mod:`umbmark.model.arrival` (bursts, late messages, the sample clock) and
:mod:`umbmark.model.wheel_stream` (the wheel data's one check); their names are importable
from here too.

* :func:`coverage`: the part of the wheel data's time span a ground truth covers, and its
  longest gap.
* :func:`estimate_time_offset`: how late the ground truth's stamps are against the wheels',
  from the cross-correlation of the turn rates both give (refined between samples by
  parabolic interpolation of the correlation's peak).
* :func:`check_wheel_stream`: the order, repeats, bursts, late messages, values, spikes and
  resets of a log's wheel data (what every reader of wheel data runs on them, once).
* :func:`check_truth_stream`: the same for its ground truth, and the offset between the two,
  applied when asked (``time_offset``: ``None``, ``"auto"`` or seconds);
  :func:`check_streams`: both.
* :func:`align_truth`: the offset applied to a data set whose runs hold the wheels and the
  ground truth in the same rows (CSV logs, optiodom folders).

Sign of the offset: ``offset_s`` is the ground truth's stamp minus the wheels' stamp of the
same instant; positive when the ground truth is late (a motion-capture or localisation stream
delivered after the fact). Correcting it subtracts ``offset_s`` from the ground truth's stamps.

Pure numpy: imports only numpy, :mod:`umbmark.errors` and the model's stamp modules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from umbmark._check import refusal
from umbmark._numbers import strict_float
from umbmark.errors import InputError
from umbmark.model.stamps import MAX_REORDER_S, MAX_WHEEL_SPEED_MPS, ordered_stamps, wheel_spikes
from umbmark.model.stamps import in_stamp_order as _in_stamp_order
from umbmark.model.stamps import median_period as _median_period
from umbmark.model.wheel_stream import (
    JointStream,
    StreamReport,
    WheelStream,
    check_joint_stream,
    check_wheel_stream,
)

__all__ = [
    "MAX_WHEEL_SPEED_MPS",
    "MIN_COVERAGE",
    "LARGE_OFFSET_S",
    "MIN_CORRELATION",
    "MAX_REORDER_S",
    "ordered_stamps",
    "wheel_spikes",
    "coverage",
    "TimeOffset",
    "estimate_time_offset",
    "parse_time_offset",
    "given_offset_note",
    "WheelStream",
    "check_wheel_stream",
    "check_joint_stream",
    "JointStream",
    "StreamReport",
    "StreamCheck",
    "check_streams",
    "check_truth_stream",
    "align_truth",
]

MIN_COVERAGE = 0.9
"""A ground truth covering less of the wheel data's time span than this is warned about."""

LARGE_OFFSET_S = 0.05
"""A time offset larger than this (and than one ground-truth sample period) is warned about."""

MIN_CORRELATION = 0.5
"""Below this peak correlation of the turn rates the offset estimate is not trusted."""

_MAX_GRID = 400_000  # samples of the common time grid of the cross-correlation


def coverage(t_wheels: ArrayLike, t_truth: ArrayLike) -> tuple[float, float, float]:
    """How much of the wheel data's time span a ground truth covers.

    Parameters
    ----------
    t_wheels, t_truth : array_like
        Increasing stamps [s] of the wheel data and of the ground truth.

    Returns
    -------
    fraction : float
        The overlap of the two spans over the wheel span (1 for a single instant covered).
    gap_s : float
        The longest time without a ground-truth sample inside the overlap [s].
    gap_at_s : float
        Where that gap starts [s, on the wheels' clock].
    """
    tw = np.asarray(t_wheels, dtype=float)
    tg = np.asarray(t_truth, dtype=float)
    span = float(tw[-1] - tw[0])
    lo, hi = max(tw[0], tg[0]), min(tw[-1], tg[-1])
    frac = max(0.0, float(hi - lo)) / span if span > 0 else float(lo <= hi)
    inside = tg[(tg >= lo) & (tg <= hi)]
    if inside.size < 2:
        return frac, 0.0, float(lo)
    d = np.diff(inside)
    j = int(np.argmax(d))
    return frac, float(d[j]), float(inside[j])


@dataclass(frozen=True)
class TimeOffset:
    """The time offset between the wheel data and the ground truth of one log.

    Attributes
    ----------
    estimated_s : float or None
        The ground truth's stamps minus the wheels' for the same instant (positive: the ground
        truth is late); None when it cannot be estimated (see ``reason``).
    correlation : float or None
        The normalised cross-correlation of the two turn rates at that offset (1: identical
        shapes).
    applied_s : float
        The offset subtracted from the ground truth's stamps (0: none).
    requested : str or None
        What was asked: ``"auto"``, the seconds given, or None (estimated and reported only).
    truth_period_s, wheel_period_s : float
        The median sample periods of the two streams [s].
    max_lag_s : float
        The largest offset searched [s].
    reason : str or None
        Why there is no estimate (e.g. the robot hardly turned).
    """

    estimated_s: float | None
    correlation: float | None
    applied_s: float
    requested: str | None
    truth_period_s: float
    wheel_period_s: float
    max_lag_s: float
    reason: str | None = None

    def to_dict(self) -> dict:
        """The JSON block ``time_offset`` of ``umbmark replay --json``."""
        return {
            "estimated_s": self.estimated_s,
            "applied_s": self.applied_s,
            "requested": self.requested,
            "correlation": self.correlation,
            "truth_period_s": self.truth_period_s,
            "wheel_period_s": self.wheel_period_s,
            "max_lag_s": self.max_lag_s,
            "method": "cross-correlation of the turn rates of the wheels and of the ground truth",
            "reason": self.reason,
        }


def estimate_time_offset(
    t_wheels: ArrayLike,
    heading_wheels: ArrayLike,
    t_truth: ArrayLike,
    heading_truth: ArrayLike,
    max_lag_s: float | None = None,
) -> tuple[float | None, float | None, float, str | None]:
    """How late the ground truth is against the wheels, from the turn rates.

    Both headings are resampled onto one time grid (the finer of the two sample periods),
    differentiated into turn rates (zero outside each stream's span), and cross-correlated;
    the peak within ``max_lag_s`` is refined between grid points by a parabola through it and
    its two neighbours. A scale error of the wheel heading (a wrong wheelbase) does not move
    the peak.

    Parameters
    ----------
    t_wheels, heading_wheels : array_like
        ``(N,)`` increasing stamps [s] and the heading [rad] the wheels give (any scale).
    t_truth, heading_truth : array_like
        ``(M,)`` increasing stamps [s] and the unwrapped ground-truth heading [rad].
    max_lag_s : float, optional
        The largest offset searched [s]; default a quarter of the wheel span, at most 10 s.

    Returns
    -------
    offset_s : float or None
        The ground truth's stamps minus the wheels' (positive: late); None without an estimate.
    correlation : float or None
        The normalised correlation at the peak.
    max_lag_s : float
        The largest offset searched.
    reason : str or None
        Why there is no estimate.
    """
    tw = np.asarray(t_wheels, dtype=float)
    hw = np.asarray(heading_wheels, dtype=float)
    tg = np.asarray(t_truth, dtype=float)
    hg = np.asarray(heading_truth, dtype=float)
    span_w = float(tw[-1] - tw[0]) if tw.size else 0.0
    if max_lag_s is None:
        max_lag_s = min(10.0, 0.25 * span_w)
    max_lag_s = float(max_lag_s)
    if tw.size < 3 or tg.size < 3:
        return None, None, max_lag_s, "too few samples to correlate"
    lo, hi = min(tw[0], tg[0]), max(tw[-1], tg[-1])
    dt = min(p for p in (_median_period(tw), _median_period(tg)) if p > 0) if span_w > 0 else 0.0
    if not dt > 0:
        return None, None, max_lag_s, "the stamps do not advance"
    dt = max(dt, (hi - lo) / _MAX_GRID)
    grid = lo + dt * np.arange(int((hi - lo) / dt) + 2)

    def rate(t: np.ndarray, h: np.ndarray) -> np.ndarray:
        inside = (grid >= t[0]) & (grid <= t[-1])
        r = np.zeros(grid.size)
        hh = np.interp(grid[inside], t, h)
        if hh.size >= 2:
            r[inside] = np.gradient(hh, dt)
        return r

    rw, rg = rate(tw, hw), rate(tg, hg)
    nw, ng = float(np.sqrt(np.sum(rw * rw))), float(np.sqrt(np.sum(rg * rg)))
    peak_w, peak_g = float(np.max(np.abs(rw))), float(np.max(np.abs(rg)))
    if not (peak_w > 0.05 and peak_g > 0.05):
        return None, None, max_lag_s, "the robot hardly turns (turn rate below 0.05 rad/s): nothing to correlate"
    n = grid.size
    size = 1 << int(math.ceil(math.log2(2 * n)))
    c = np.fft.irfft(np.conj(np.fft.rfft(rw, size)) * np.fft.rfft(rg, size), size) / (nw * ng)
    m = max(1, min(int(max_lag_s / dt), n - 2))
    lags = np.concatenate([np.arange(-m, 0), np.arange(0, m + 1)])
    vals = c[lags % size]
    j = int(np.argmax(vals))
    best = float(vals[j])
    shift = 0.0
    if 0 < j < len(vals) - 1:
        a, b, e = vals[j - 1], vals[j], vals[j + 1]
        den = a - 2 * b + e
        if den < 0:
            shift = float(np.clip(0.5 * (a - e) / den, -0.5, 0.5))
    offset = (lags[j] + shift) * dt
    if best < MIN_CORRELATION:
        worst = float(np.min(vals))
        if worst <= -MIN_CORRELATION:
            return (
                None,
                best,
                max_lag_s,
                f"the wheels turn the other way from the ground truth (their turn rates correlate {worst:.2f}): "
                "the left and right wheels swapped, or the ground truth's heading mirrored (a tracker's "
                "frame upside down)",
            )
        return (
            None,
            best,
            max_lag_s,
            f"the turn rates of the wheels and of the ground truth hardly agree (correlation {best:.2f} at best "
            f"within +-{max_lag_s:.3g} s)",
        )
    if abs(lags[j]) == m:
        return None, best, max_lag_s, f"the best match is at the end of the search (+-{max_lag_s:.3g} s)"
    fine, fine_best = _refine(tw, hw, tg, hg, offset, max(2 * dt, _median_period(tg)))
    if fine is not None:
        offset, best = fine, max(best, fine_best)
    return float(offset), best, max_lag_s, None


def _refine(
    tw: np.ndarray, hw: np.ndarray, tg: np.ndarray, hg: np.ndarray, guess: float, half_s: float
) -> tuple[float | None, float]:
    """The offset near ``guess`` at which the ground truth's heading steps, sample to sample,
    best match the wheels' heading steps over the same intervals (the wheels interpolated at
    the ground truth's stamps minus the offset): no interpolation of the ground truth, so a slow
    ground truth is not smeared. A fine grid of +-``half_s`` and a parabola through its peak."""
    dg = np.diff(hg)
    grid = guess + np.linspace(-half_s, half_s, 41)
    scores = np.empty(grid.size)
    for i, tau in enumerate(grid):
        dw = np.diff(np.interp(tg - tau, tw, hw, left=np.nan, right=np.nan))
        ok = np.isfinite(dw)
        den = math.sqrt(float(np.sum(dw[ok] ** 2)) * float(np.sum(dg[ok] ** 2)))
        scores[i] = float(np.sum(dw[ok] * dg[ok])) / den if ok.sum() > 2 and den > 0 else -np.inf
    j = int(np.argmax(scores))
    if not np.isfinite(scores[j]) or j in (0, grid.size - 1):
        return None, float(scores[j])
    a, b, e = scores[j - 1], scores[j], scores[j + 1]
    den2 = a - 2 * b + e
    shift = float(np.clip(0.5 * (a - e) / den2, -0.5, 0.5)) if den2 < 0 else 0.0
    return float(grid[j] + shift * (grid[1] - grid[0])), float(b)


def given_offset_note(
    given_s: float, est_s: float | None, corr: float | None, period_s: float, what: str
) -> str | None:
    """A warning when a time offset given in seconds disagrees with the one the data show.

    Parameters
    ----------
    given_s : float
        The offset given (positive: the ground truth is late).
    est_s, corr : float or None
        The offset estimated from the turn rates and its correlation (:func:`estimate_time_offset`).
    period_s : float
        The ground truth's sample period: a difference within it (or within
        :data:`LARGE_OFFSET_S`) is no disagreement.
    what : str
        What is offset against what, for the message (``"the ground truth on /mocap against /joint_states"``).

    Returns
    -------
    str or None
        None when they agree or nothing was estimated; else the warning, naming a sign mixed up
        where the estimate is the given offset negated.
    """
    if est_s is None or not math.isfinite(given_s):
        return None
    tol = max(LARGE_OFFSET_S, period_s)
    if abs(est_s - given_s) <= tol:
        return None
    late = "late" if est_s > 0 else "early"
    text = (
        f"`time_offset` {given_s:g} s was given, but {what} is {abs(est_s):.3f} s {late} (cross-correlation of "
        f"the turn rates, correlation {corr if corr is not None else float('nan'):.2f})"
    )
    if given_s != 0 and abs(est_s + given_s) <= tol:
        return f"{text}: the sign mixed up? (positive: the ground truth is late); give {est_s:.3f} or auto"
    return f"{text}: the calibration is biased by the difference; give `time_offset=auto` or check the value"


def parse_time_offset(value) -> float | str | None:
    """``None``, ``"auto"`` or a number of seconds, from a value or its text.

    Parameters
    ----------
    value : None, str or float
        ``None``/``""`` (estimate and report only), ``"auto"`` (estimate and correct), or the
        seconds to correct (positive: the ground truth is late).

    Returns
    -------
    None, ``"auto"`` or float

    Raises
    ------
    InputError
        Anything else, or a number that is not finite.
    """
    if value is None or (isinstance(value, str) and not value.strip()):
        return None
    if isinstance(value, str):
        v = value.strip().lower()
        if v == "auto":
            return "auto"
        try:
            num = strict_float(v.removesuffix("s"))
        except ValueError:
            raise InputError(
                f"`time_offset` must be 'auto' or seconds (positive: the ground truth is late), got {value!r}"
            ) from None
    else:
        num = float(value)
    if not math.isfinite(num) or abs(num) > 3600:
        raise InputError(f"`time_offset` must be 'auto' or a finite number of seconds (within an hour), got {value!r}")
    return num


@dataclass(frozen=True)
class StreamCheck:
    """The wheel and ground-truth streams of one log, checked (see :func:`check_streams`).

    Attributes
    ----------
    t, left, right : numpy.ndarray
        The wheel stamps and cumulative positions kept, in time order.
    truth : numpy.ndarray or None
        ``(M, 4)`` ground truth ``(t, x, y, heading)`` kept, its stamps corrected by the applied
        offset.
    warnings : tuple of str
        What was found and done (repeated stamps dropped, spikes dropped, coverage, a large offset).
    time_offset : TimeOffset or None
        The offset estimated and applied (None without a ground truth).
    """

    t: np.ndarray
    left: np.ndarray
    right: np.ndarray
    truth: np.ndarray | None
    warnings: tuple[str, ...]
    time_offset: TimeOffset | None


def check_streams(
    t,
    left,
    right,
    truth=None,
    *,
    metres_per_unit_left: float,
    metres_per_unit_right: float,
    wheelbase_m: float,
    cumulative: bool = True,
    time_offset=None,
    wheel_what: str = "wheel positions",
    wheel_topic: str = "the wheel topic",
    truth_topic: str = "the ground-truth topic",
    source: str | None = None,
) -> StreamCheck:
    """Check the stamps and values of a log's wheel data and ground truth, and align them:
    :func:`check_wheel_stream`, then :func:`check_truth_stream`.

    Parameters
    ----------
    t, left, right : array_like
        Wheel stamps [s] as recorded and the positions (cumulative or incremental counts in log
        units).
    truth : array_like, optional
        ``(M, 4)`` ground truth ``(t, x, y, heading)`` as recorded (heading in radians, wrapped
        or not).
    metres_per_unit_left, metres_per_unit_right : float
        Rim travel per log unit of each wheel [m] (nominal geometry).
    wheelbase_m : float
        The nominal wheelbase (for the wheels' turn rate).
    cumulative : bool
        The positions are cumulative (else per-sample increments).
    time_offset : None, "auto" or float
        None: estimate and report; ``"auto"``: estimate and subtract it from the ground truth's
        stamps; seconds: subtract these (see :func:`parse_time_offset`).
    wheel_what, wheel_topic, truth_topic : str
        Names for messages.
    source : str, optional
        The log, for messages.

    Returns
    -------
    StreamCheck
        The wheel positions cumulative.

    Raises
    ------
    InputError
        As :func:`check_wheel_stream` and :func:`check_truth_stream`.
    """
    wheels = check_wheel_stream(
        t,
        left,
        right,
        metres_per_unit=max(metres_per_unit_left, metres_per_unit_right),
        cumulative=cumulative,
        what=wheel_what,
        topic=wheel_topic,
        source=source,
    )
    chk = check_truth_stream(
        wheels,
        truth,
        metres_per_unit_left=metres_per_unit_left,
        metres_per_unit_right=metres_per_unit_right,
        wheelbase_m=wheelbase_m,
        time_offset=time_offset,
        wheel_topic=wheel_topic,
        truth_topic=truth_topic,
        source=source,
    )
    return StreamCheck(chk.t, chk.left, chk.right, chk.truth, wheels.warnings + chk.warnings, chk.time_offset)


def check_truth_stream(
    wheels: WheelStream,
    truth=None,
    *,
    metres_per_unit_left: float,
    metres_per_unit_right: float,
    wheelbase_m: float,
    time_offset=None,
    wheel_topic: str = "the wheel topic",
    truth_topic: str = "the ground-truth topic",
    source: str | None = None,
) -> StreamCheck:
    """Check a log's ground truth against its checked wheel data, and align them.

    * Ground-truth stamps as the wheels' (:func:`ordered_stamps`), values finite.
    * Ground-truth positions that jump faster than :data:`MAX_WHEEL_SPEED_MPS`: an isolated
      spike is dropped, a jump that stays is warned about (the tracker lost the robot).
    * The time offset between the wheels and the ground truth (:func:`estimate_time_offset`):
      estimated whenever there is a ground truth, applied when ``time_offset`` asks, warned
      about when it is larger than :data:`LARGE_OFFSET_S` and one ground-truth sample period
      and not corrected.
    * The ground truth's coverage of the wheel data (after the offset): a warning below
      :data:`MIN_COVERAGE` or with a gap longer than a second and 20 sample periods.

    Parameters
    ----------
    wheels : WheelStream
        The wheel data (:func:`check_wheel_stream`), cumulative.
    truth : array_like, optional
        ``(M, 4)`` ground truth ``(t, x, y, heading)`` as recorded (heading in radians, wrapped
        or not); None: the wheels alone.
    metres_per_unit_left, metres_per_unit_right : float
        Rim travel per log unit of each wheel [m] (nominal geometry).
    wheelbase_m : float
        The nominal wheelbase (for the wheels' turn rate).
    time_offset : None, "auto" or float
        None: estimate and report; ``"auto"``: estimate and subtract it from the ground truth's
        stamps; seconds: subtract these (see :func:`parse_time_offset`).
    wheel_topic, truth_topic : str
        Names for messages.
    source : str, optional
        The log, for messages.

    Returns
    -------
    StreamCheck
        The wheels as given, the ground truth kept and aligned, this check's warnings.

    Raises
    ------
    InputError
        Ground-truth stamps that go backwards, non-finite values, ``time_offset`` auto without
        an estimate, or a ground truth that does not overlap the wheels.
    """
    request = parse_time_offset(time_offset)
    warnings: list[str] = []
    t, cl, cr = wheels.t, wheels.left, wheels.right
    g = None
    offset = None
    if truth is not None:
        g = _checked_truth(truth, truth_topic, source, warnings)
        heading_w = (cr * metres_per_unit_right - cl * metres_per_unit_left) / wheelbase_m
        _refuse_degree_turns(t, heading_w, g, wheel_topic, truth_topic, source)
        offset, gp = _truth_offset(t, heading_w, g, request, wheel_topic, truth_topic, source, warnings)
        if offset.applied_s:
            g = g.copy()
            g[:, 0] -= offset.applied_s
        _check_truth_coverage(t, g, gp, wheel_topic, truth_topic, source, warnings)
    return StreamCheck(t, cl, cr, g, tuple(warnings), offset)


def _checked_truth(truth: ArrayLike, truth_topic: str, source: str | None, warnings: list[str]) -> np.ndarray:
    """The ground truth in stamp order, finite, its isolated spikes dropped and its heading unwrapped."""
    g = np.asarray(truth, dtype=float).reshape(-1, 4)
    what = "ground-truth poses"
    _, (g,), gkeep, grep, gfirst = _in_stamp_order(g[:, 0], [g], what, truth_topic, source, warnings)
    if grep:
        warnings.append(
            f"{grep} of the {len(g)} ground-truth poses on {truth_topic} repeat the stamp of the pose before "
            f"(first at message {gfirst}): the last of each stamp is kept; check the publisher's stamps"
        )
    g = g[gkeep]
    if not np.all(np.isfinite(g)):
        raise InputError(f"the ground-truth poses on {truth_topic} contain NaN or infinite values", source)
    gbad, gisolated = wheel_spikes(g[:, 0], g[:, 1], g[:, 2], 1.0)  # the robot faster than 30 m/s
    if gbad.size:
        k = int(gbad[0])
        jump = float(np.hypot(*(g[k, 1:3] - g[k - 1, 1:3])))
        where = f"at t={g[k, 0] - g[0, 0]:.3f} s (pose {k + 1})"
        if gisolated:
            warnings.append(
                f"{gbad.size} spike(s) in the ground-truth poses on {truth_topic}, the first {where} (a jump of "
                f"{jump:.3g} m and back): dropped"
            )
            ok = np.ones(len(g), dtype=bool)
            ok[gbad] = False
            g = g[ok]
        else:
            warnings.append(
                f"the ground-truth poses on {truth_topic} jump by {jump:.3g} m {where}, faster than "
                f"{MAX_WHEEL_SPEED_MPS:g} m/s, and stay there: the tracker lost or re-initialised the robot; "
                "check the runs around it"
            )
    g[:, 3] = np.unwrap(g[:, 3])
    return g


def _refuse_degree_turns(
    t: np.ndarray, heading_w: np.ndarray, g: np.ndarray, wheel_topic: str, truth_topic: str, source: str | None
) -> None:
    """Refuse wheels that turn 57.3 times as far as the ground truth (within a factor of two:
    any wheelbase error): wheel angles in degrees. The headings are compared every 0.2 s or
    more (a tracker's noise does not add up)."""
    inside = g[(g[:, 0] >= t[0]) & (g[:, 0] <= t[-1])]
    if len(inside) < 3:
        return
    step = max(1, int(math.ceil(0.2 / max(_median_period(inside[:, 0]), 1e-9))))
    tg, hg = inside[::step, 0], inside[::step, 3]
    turn_g = float(np.sum(np.abs(np.diff(hg))))
    turn_w = float(np.sum(np.abs(np.diff(np.interp(tg, t, heading_w)))))
    if turn_g < 0.5:
        return
    ratio = turn_w / turn_g
    err = refusal(
        "degree_turns",
        f"the wheel data on {wheel_topic} turn {ratio:.3g} times as far as the ground truth on {truth_topic} "
        "(the nominal geometry): the wheel angles look like degrees (JointState positions are radians; encoder "
        "counts: `pulses_per_wheel_rev` 57.3 times too small)",
        source,
    )
    if err is not None and 0.5 <= ratio / math.degrees(1.0) <= 2.0:
        raise err


def _truth_offset(
    t: np.ndarray,
    heading_w: np.ndarray,
    g: np.ndarray,
    request: float | str | None,
    wheel_topic: str,
    truth_topic: str,
    source: str | None,
    warnings: list[str],
) -> tuple[TimeOffset, float]:
    """The time offset of the ground truth against the wheels, estimated and chosen as requested, with the ground
    truth's median sample period."""
    est, corr, max_lag, reason = estimate_time_offset(t, heading_w, g[:, 0], g[:, 3])
    applied = 0.0
    if request == "auto":
        if est is None:
            raise InputError(
                f"`time_offset` auto: cannot estimate the offset between {wheel_topic} and {truth_topic}: "
                f"{reason}; give it in seconds",
                source,
            )
        applied = est
    elif request is not None:
        applied = float(request)
    gp, wp = _median_period(g[:, 0]), _median_period(t)
    offset = TimeOffset(
        None if est is None else round(est, 6) + 0.0,
        None if corr is None else round(corr, 4),
        applied,
        None if request is None else (request if isinstance(request, str) else f"{request:g}"),
        round(gp, 9),
        round(wp, 9),
        max_lag,
        reason,
    )
    if est is not None and request is None and abs(est) > max(LARGE_OFFSET_S, gp):
        late = "late" if est > 0 else "early"
        warnings.append(
            f"the ground truth on {truth_topic} is {abs(est):.3f} s {late} against the wheel data on "
            f"{wheel_topic} (cross-correlation of the turn rates, correlation {corr:.2f}): the calibration "
            "is biased by it; give `time_offset=auto` to correct it"
        )
    if isinstance(request, float):
        pair = f"the ground truth on {truth_topic} against {wheel_topic}"
        given = given_offset_note(request, est, corr, gp, pair)
        if given is not None:
            warnings.append(given)
    if est is None and corr is not None and request is None:
        warnings.append(
            f"the turn rates of the wheel data on {wheel_topic} and of the ground truth on {truth_topic} do not "
            f"line up: {reason}; a ground truth of another robot or frame, or an offset beyond the search? "
            "Check the topics, or give `time_offset` in seconds"
        )
    return offset, gp


def _check_truth_coverage(
    t: np.ndarray,
    g: np.ndarray,
    gp: float,
    wheel_topic: str,
    truth_topic: str,
    source: str | None,
    warnings: list[str],
) -> None:
    """Refuse a ground truth that does not overlap the wheels; warn about a low coverage or a long gap."""
    frac, gap, gap_at = coverage(t, g[:, 0])
    if frac <= 0:
        raise InputError(
            f"the ground truth on {truth_topic} does not overlap the wheel data on {wheel_topic} in time "
            f"(wheels {t[0]:.3f}-{t[-1]:.3f} s, ground truth {g[0, 0]:.3f}-{g[-1, 0]:.3f} s)",
            source,
        )
    span = float(t[-1] - t[0])
    if frac < MIN_COVERAGE:
        a, b = max(0.0, g[0, 0] - t[0]), min(span, g[-1, 0] - t[0])
        warnings.append(
            f"the ground truth on {truth_topic} covers only {100 * frac:.0f} % of the wheel data on {wheel_topic} "
            f"({a:.1f}-{b:.1f} s of {span:.1f} s): the runs are cut to it; record the ground truth for the "
            "whole drive"
        )
    if gap > max(1.0, 20 * gp):
        warnings.append(
            f"the ground truth on {truth_topic} has a gap of {gap:.2f} s at t={gap_at - t[0]:.2f} s: the poses "
            "are interpolated across it"
        )


def _unaligned_note(ds, runs: list, found: list, what: str):
    """The data set as it is, with a warning when every run's ground truth is late (or early) by more than
    :data:`LARGE_OFFSET_S` and a sample period, by estimates of one sign (``meta["truth_delay_s"]``: their
    median)."""
    from dataclasses import replace

    est = [f[0] for f in found]
    periods = [_median_period(r.t[np.all(np.isfinite(r.gt), axis=1)]) for r in runs]
    if not est or any(e is None for e in est):
        return ds
    late = all(e > max(LARGE_OFFSET_S, p) for e, p in zip(est, periods))
    early = all(e < -max(LARGE_OFFSET_S, p) for e, p in zip(est, periods))
    if not (late or early):
        return ds
    med = float(np.median(est))
    corr = min(float(f[1]) for f in found)
    note = (
        f"the ground truth of every run of this {what} is {abs(med):.3f} s {'late' if late else 'early'} against the "
        f"wheels (cross-correlation of the turn rates, correlation {corr:.2f} or more): the calibration is biased by "
        f"it; give `time_offset=auto` (or `time_offset={med:.3f}`, positive: the ground truth is late) to correct it"
    )
    meta = {**ds.meta, "truth_delay_s": med, "warnings": (*(ds.meta.get("warnings") or ()), note)}
    return replace(ds, meta=meta)


def align_truth(ds, time_offset, what: str = "log"):
    """A data set whose ground-truth trajectories are moved in time against the wheels.

    For logs that hold the wheels and the ground truth in the same rows (CSV, optiodom): each
    run's ground truth is re-interpolated at ``t + offset`` (positive ``offset``: the ground
    truth is late), and the run is cut to the samples where that time is inside it (then
    brought into its new start frame). With ``"auto"`` the offset of each run with a
    trajectory is estimated from the turn rates (:func:`estimate_time_offset`) and the median
    over the runs is applied to all of them.

    Parameters
    ----------
    ds : umbmark.model.dataset.Dataset
        The logged runs.
    time_offset : None, "auto" or float
        See :func:`parse_time_offset`. None: the runs are left as they are, with a warning when
        every run's ground truth is late (or early) by more than :data:`LARGE_OFFSET_S`.
    what : str
        What the runs were read from, for messages.

    Returns
    -------
    umbmark.model.dataset.Dataset
        The runs moved; ``meta["time_offset"]`` one entry per run with a trajectory (``log``,
        ``run`` and :meth:`TimeOffset.to_dict`); ``meta["warnings"]`` also names the runs cut
        where the robot moves (their ground truth ends before the wheels').

    Raises
    ------
    InputError
        No run with a ground-truth trajectory; ``auto`` without an estimate; an offset that
        leaves a run fewer than two samples.
    """
    from dataclasses import replace

    request = parse_time_offset(time_offset)
    if request is None and not any(r.has_trajectory for r in ds.runs):
        return ds
    g = ds.nominal
    mpu_l = math.pi * g.diameter_left_m / ds.units_per_wheel_rev
    mpu_r = math.pi * g.diameter_right_m / ds.units_per_wheel_rev
    runs = [r for r in ds.runs if r.has_trajectory]
    if not runs:
        raise InputError(f"`time_offset` needs a ground-truth trajectory; this {what} has none", ds.source)
    found = []
    for r in runs:
        ok = np.all(np.isfinite(r.gt), axis=1)
        heading = np.cumsum(r.d_right * mpu_r - r.d_left * mpu_l) / g.wheelbase_m
        found.append(estimate_time_offset(r.t, heading, r.t[ok], r.gt[ok, 2]))
    good = [f[0] for f in found if f[0] is not None]
    if request is None:
        return _unaligned_note(ds, runs, found, what)
    if request == "auto":
        if not good:
            why = next(f[3] for f in found if f[3] is not None)
            raise InputError(f"`time_offset` auto: cannot estimate the offset in this {what}: {why}", ds.source)
        applied = float(np.median(good))
    else:
        applied = float(request)
    new_runs, entries = [], []
    notes: list[str] = []
    estimates = iter(found)
    for r in ds.runs:
        if not r.has_trajectory:
            new_runs.append(r)
            continue
        est, corr, max_lag, reason = next(estimates)
        ok = np.all(np.isfinite(r.gt), axis=1)
        period = _median_period(r.t[ok])
        lo, hi = r.t[ok][0], r.t[ok][-1]
        tt = r.t + applied
        inside = (tt >= lo - 0.5 * period) & (tt <= hi + 0.5 * period)  # half a sample: the edge pose
        tt = np.clip(tt, lo, hi)
        moving = (np.abs(r.d_left) + np.abs(r.d_right)) > 0
        moving[0] = False
        if np.any(moving & ~inside):
            notes.append(
                f"{r.name}: a time offset of {applied:.3f} s leaves {int((~inside).sum())} samples of the wheels "
                "without a ground truth where the robot moves: the run is cut to the rest (a square may be "
                "left open); for a bag give `time_offset` when reading it, or log past the stops"
            )
        if inside.sum() < 2:
            raise InputError(
                f"a time offset of {applied:.3f} s leaves run {r.name} fewer than two samples with a ground truth",
                r.source or ds.source,
            )
        gt = np.full_like(r.gt, np.nan)
        for c in range(3):
            gt[inside, c] = np.interp(tt[inside], r.t[ok], r.gt[ok, c])
        a, b = np.flatnonzero(inside)[[0, -1]]
        moved = replace(r, gt=gt, gt_end=None).slice(int(a), int(b) + 1, name=r.name)
        new_runs.append(moved)
        off = TimeOffset(
            None if est is None else round(est, 6) + 0.0,
            None if corr is None else round(corr, 4),
            applied,
            request if isinstance(request, str) else f"{request:g}",
            round(period, 9),
            round(_median_period(r.t), 9),
            max_lag,
            reason,
        )
        entries.append({"log": r.source or ds.source, "run": r.name, **off.to_dict()})
        if isinstance(request, float):
            note = given_offset_note(request, est, corr, period, f"the ground truth of run {r.name}")
            if note is not None:
                notes.append(note)
    meta = {**ds.meta, "time_offset": tuple(entries), "warnings": (*(ds.meta.get("warnings") or ()), *notes)}
    return replace(ds, runs=tuple(new_runs), meta=meta)
