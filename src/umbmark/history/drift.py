"""Drift of a robot's calibration over its recorded sessions: slow wear and sudden changes.

Every recorded calibration that holds a parameter with its 95 % interval (the self-calibration's
wheel diameters, wheelbase, ``Ed``, ``Eb`` and lidar pose, or the parameters another kind of
robot's self-calibration estimated, such as a tricycle's steering offset or a mecanum robot's
``lx_plus_ly_mm``; a replay's or an analysis's ``Ed``, ``Eb`` and wheelbase)
is a point of that parameter's time series: its value, its standard error
(the interval's half-width / 1.96) and its date.

The model of one series is a straight line in time (wear: a rate per day) with steps (a wheel
swapped, a payload added), all steps sharing the one rate, fitted by weighted least squares with
the sessions' standard errors. Steps are found by forward selection with a generalised
likelihood ratio test: for every session that could be the first after a step, the drop of the
weighted residual sum of squares when the step is added; the largest drop is a change when its
F test, Bonferroni-corrected for the number of sessions tried, is below the stated false-alarm
rate (the probability that a series with no step raises an alarm). The sessions' intervals are
trusted when the residuals agree with them and widened by the residuals' scatter when they do
not (the scale ``max(1, chi^2 / dof)``), so a robot whose intervals are too narrow raises no
false alarms from it. A segment between two steps holds at least two sessions (one odd session
in the middle of a history is an outlier, not a change); the latest session alone may follow a
step (a change on the last day is what a daily check is for).

A recording counts once: a record of the same content, kind and method as an older one, of a
part of the recording that overlaps it (:func:`umbmark.history.base.parts_overlap`; a history
refuses to add such a record now), is left out, with a note. Sessions that span less than
:data:`MIN_RATE_SPAN_DAYS` (recorded in one go, without their dates) give no wear rate per day:
their trend is fitted in the order of the sessions, and a note says why.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np

from umbmark.errors import InputError
from umbmark.history.base import KINDS, Record, parts_overlap, recording_part
from umbmark.kinds import kind_in

__all__ = [
    "DEFAULT_FALSE_ALARM",
    "SeriesPoint",
    "Series",
    "Change",
    "Trend",
    "DriftReport",
    "series_of",
    "detect_drift",
]

# the probability that one parameter's history with no step raises an alarm
DEFAULT_FALSE_ALARM = 1e-3
# a series needs this many sessions for a trend and a test
MIN_SESSIONS = 4
# sessions spanning less than this give no wear rate per day (recorded in one go, without dates)
MIN_RATE_SPAN_DAYS = 1.0
_Z95 = 1.959963984540054
_SECONDS_PER_DAY = 86400.0


@dataclass(frozen=True)
class SeriesPoint:
    """One session's value of one parameter."""

    record: int
    time_utc: str
    value: float
    sd: float | None

    @property
    def time(self) -> datetime:
        """The session's time (aware, UTC)."""
        return _parse_time(self.time_utc)


@dataclass(frozen=True)
class Series:
    """One parameter over a robot's sessions, oldest first."""

    parameter: str
    points: tuple[SeriesPoint, ...]

    @property
    def days(self) -> np.ndarray:
        """Each session's time in days after the first."""
        t = [_parse_time(p.time_utc) for p in self.points]
        return np.array([(x - t[0]).total_seconds() / _SECONDS_PER_DAY for x in t])

    @property
    def values(self) -> np.ndarray:
        """Each session's value."""
        return np.array([p.value for p in self.points])


@dataclass(frozen=True)
class Change:
    """A step in one parameter: the fitted level just before and just after it, at the time of
    the first session after it."""

    parameter: str
    record: int
    previous_record: int
    time_utc: str
    before: float
    after: float
    step: float
    step_ci95: tuple[float, float]
    p_value: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "record": self.record,
            "parameter": self.parameter,
            "before": self.before,
            "after": self.after,
            "step": self.step,
            "step_ci95": list(self.step_ci95),
            "relative_step": self.step / self.before if self.before else None,
            "previous_record": self.previous_record,
            "time_utc": self.time_utc,
            "p_value": self.p_value,
        }


@dataclass(frozen=True)
class Trend:
    """A parameter's rate of change per day (common to its segments between steps)."""

    parameter: str
    rate_per_day: float | None
    rate_per_day_ci95: tuple[float, float] | None
    sessions: int
    span_days: float
    latest: float
    latest_ci95: tuple[float, float] | None
    scale: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "rate_per_day": self.rate_per_day,
            "rate_per_day_ci95": None if self.rate_per_day_ci95 is None else list(self.rate_per_day_ci95),
            "sessions": self.sessions,
            "span_days": self.span_days,
            "latest": self.latest,
            "latest_ci95": None if self.latest_ci95 is None else list(self.latest_ci95),
            "interval_scale": self.scale,
        }


@dataclass(frozen=True)
class DriftReport:
    """Changes and trends of one robot's parameters (see :func:`detect_drift`)."""

    robot: str
    kind: str | None
    false_alarm_rate: float
    changes: tuple[Change, ...]
    trends: dict[str, Trend]
    sessions: int
    fits: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    notes: tuple[str, ...] = ()
    series: dict[str, Series] = field(default_factory=dict, repr=False, compare=False)

    def fitted(self, parameter: str) -> np.ndarray:
        """The fitted model (levels between the changes, the common trend) at each session of a
        parameter, in the order of ``series[parameter].points``."""
        fit = self.fits[parameter]
        return np.asarray(_design(fit["t"], fit["cuts"], fit["slope"]) @ fit["coef"])

    @property
    def alarm(self) -> bool:
        """True when a change was found."""
        return bool(self.changes)

    def to_dict(self) -> dict[str, Any]:
        return {
            "robot": self.robot,
            "kind": self.kind,
            "sessions": self.sessions,
            "false_alarm_rate": self.false_alarm_rate,
            "alarm": self.alarm,
            "changes": [c.to_dict() for c in self.changes],
            "trends": {k: t.to_dict() for k, t in self.trends.items()},
            "notes": list(self.notes),
        }


def _parse_time(s: str) -> datetime:
    return datetime.fromisoformat(s.replace("Z", "+00:00"))


def _sd_of(ci: Any, value: float) -> float | None:
    if not (isinstance(ci, (list, tuple)) and len(ci) == 2):
        return None
    try:
        lo, hi = float(ci[0]), float(ci[1])
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
        return None
    sd = (hi - lo) / (2 * _Z95)
    return sd if sd > 0 else None


def _numbers(results: dict[str, Any]) -> Iterable[tuple[str, float, float | None]]:
    """``(parameter, value, sd)`` of every number of a result that has its 95 % interval: a robot of a
    kind of its own (its ``kinematics``) the parameters its self-calibration estimated, under their
    JSON keys (``wheel_diameters_mm.front_left``), and its sensor pose."""
    own = kind_in(results)
    if own is not None:
        for p, v, ci in own.estimates_json(results):
            if ci is not None:
                yield p.path, v, _sd_of(list(ci), v)
        sp = results.get("sensor_pose")
        results = {"sensor_pose": sp} if isinstance(sp, dict) else {}
    for key, v in results.items():
        if isinstance(v, dict):
            for sub, w in v.items():
                if isinstance(w, (int, float)) and not isinstance(w, bool) and f"{sub}_ci95" in v:
                    yield f"{key}.{sub}", float(w), _sd_of(v[f"{sub}_ci95"], float(w))
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and f"{key}_ci95" in results:
            yield key, float(v), _sd_of(results[f"{key}_ci95"], float(v))


def series_of(records: Sequence[Record], kind: str | None = None) -> dict[str, Series]:
    """The time series of every parameter the records hold with a 95 % interval.

    Parameters
    ----------
    records : sequence of Record
        One robot's records (any order; sorted by time here).
    kind : str, optional
        Only records of this kind (``selfcal``, ``replay``, ...).

    Returns
    -------
    dict of str to Series
        Keyed by the result's JSON key (``wheelbase_mm``; ``sensor_pose.x_mm`` for a nested one).
    """
    pts: dict[str, list[SeriesPoint]] = {}
    for r in sorted(records, key=lambda r: (r.time, r.id)):
        if kind is not None and r.kind != kind:
            continue
        results = r.results if isinstance(r.results, dict) else {}
        for name, value, sd in _numbers(results):
            if math.isfinite(value):
                pts.setdefault(name, []).append(SeriesPoint(r.id, r.created_utc, value, sd))
    return {k: Series(k, tuple(v)) for k, v in pts.items()}


def _design(t: np.ndarray, cuts: Sequence[int], slope: bool) -> np.ndarray:
    """Columns: one level per segment (cut before the given indices), then the common slope."""
    n = len(t)
    edges = [0, *sorted(cuts), n]
    cols = []
    for a, b in zip(edges[:-1], edges[1:]):
        c = np.zeros(n)
        c[a:b] = 1.0
        cols.append(c)
    if slope:
        cols.append(t)
    return np.column_stack(cols)


def _wls(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Weighted least squares: coefficients, weighted RSS, the unscaled covariance."""
    sw = np.sqrt(w)
    a = x * sw[:, None]
    coef, *_ = np.linalg.lstsq(a, y * sw, rcond=None)
    r = (y - x @ coef) * sw
    cov = np.linalg.pinv(a.T @ a)
    return coef, float(r @ r), cov


def _allowed(k: int, cuts: Sequence[int], n: int) -> bool:
    """A cut before index ``k`` leaves every segment two sessions long (the last may be one)."""
    edges = sorted([0, *cuts, k, n])
    if k in cuts or k < 2:
        return False
    lengths = np.diff(edges)
    return bool(np.all(lengths[:-1] >= 2) and lengths[-1] >= 1)


def _fit_series(s: Series, alpha: float, by_order: bool = False) -> dict[str, Any]:
    """Forward selection of steps in one series (see the module's description); ``by_order``:
    the trend in the order of the sessions (their dates too close for a rate per day)."""
    from scipy import stats

    days, y = s.days, s.values
    span = float(np.ptp(days))
    n = len(y)
    if by_order:
        t, slope = np.arange(n) / max(n - 1, 1), n > 1
    else:
        t, slope = (days / span if span > 0 else days), span > 0  # a slope per span, for conditioning
    sds = [p.sd for p in s.points]
    trusted = all(sd is not None for sd in sds)
    w = np.array([1.0 / sd**2 for sd in sds]) if trusted else np.ones(n)  # type: ignore[operator]
    cuts: list[int] = []
    p_values: dict[int, float] = {}
    while True:
        base = _design(t, cuts, slope)
        _, rss0, _ = _wls(base, y, w)
        best: tuple[float, int, float, int] | None = None
        tried = 0
        for k in range(1, n):
            if not _allowed(k, cuts, n):
                continue
            tried += 1
            x1 = _design(t, [*cuts, k], slope)
            _, rss1, _ = _wls(x1, y, w)
            dof = n - x1.shape[1]
            if dof < 1:
                continue
            scale = max(1.0, rss1 / dof) if trusted else rss1 / dof
            if scale <= 0:
                continue
            stat = (rss0 - rss1) / scale
            if best is None or stat > best[0]:
                best = (stat, k, scale, dof)
        if best is None:
            break
        stat, k, _, dof = best
        p = float(min(1.0, tried * stats.f.sf(stat, 1, dof)))
        if p >= alpha:
            break
        cuts.append(k)
        p_values[k] = p
    x = _design(t, cuts, slope)
    coef, rss, cov = _wls(x, y, w)
    dof = n - x.shape[1]
    scale = (max(1.0, rss / dof) if trusted else rss / dof) if dof > 0 else float("nan")
    return {
        "t": t,
        "y": y,
        "cuts": sorted(cuts),
        "p": p_values,
        "coef": coef,
        "cov": cov * scale,
        "dof": dof,
        "scale": scale,
        "span_days": span,
        "slope": slope,
        "per_day": slope and not by_order,
    }


def _quantile(dof: int) -> float:
    from scipy import stats

    return float(stats.t.ppf(0.975, dof)) if dof > 0 else float("inf")


def _changes(s: Series, fit: dict[str, Any]) -> list[Change]:
    t, coef, cov = fit["t"], fit["coef"], fit["cov"]
    q = _quantile(fit["dof"])
    slope = coef[-1] if len(coef) > len(fit["cuts"]) + 1 else 0.0
    out = []
    for j, k in enumerate(fit["cuts"]):
        before = coef[j] + slope * t[k]
        after = coef[j + 1] + slope * t[k]
        var = cov[j, j] + cov[j + 1, j + 1] - 2 * cov[j, j + 1]
        half = q * math.sqrt(max(var, 0.0))
        step = float(after - before)
        out.append(
            Change(
                parameter=s.parameter,
                record=s.points[k].record,
                previous_record=s.points[k - 1].record,
                time_utc=s.points[k].time_utc,
                before=float(before),
                after=float(after),
                step=step,
                step_ci95=(step - half, step + half),
                p_value=fit["p"][k],
            )
        )
    return out


def _trend(s: Series, fit: dict[str, Any]) -> Trend:
    t, coef, cov, dof = fit["t"], fit["coef"], fit["cov"], fit["dof"]
    q = _quantile(dof)
    has_slope = len(coef) > len(fit["cuts"]) + 1
    rate = ci = None
    if has_slope and dof > 0 and fit["per_day"]:
        rate = float(coef[-1]) / fit["span_days"]
        half = q * math.sqrt(max(cov[-1, -1], 0.0)) / fit["span_days"]
        ci = (rate - half, rate + half)
    # the latest level: the last segment's line at the last session
    g = np.zeros(len(coef))
    g[len(fit["cuts"])] = 1.0
    if has_slope:
        g[-1] = t[-1]
    latest = float(g @ coef)
    lhalf = q * math.sqrt(max(float(g @ cov @ g), 0.0)) if dof > 0 else None
    return Trend(
        parameter=s.parameter,
        rate_per_day=rate,
        rate_per_day_ci95=ci,
        sessions=len(t),
        span_days=float(fit["span_days"]),
        latest=latest,
        latest_ci95=None if lhalf is None else (latest - lhalf, latest + lhalf),
        scale=float(fit["scale"]),
    )


def _kind_of(records: Sequence[Record]) -> str | None:
    """The kind with the most records holding intervals (ties: the self-calibration)."""
    counts: dict[str, int] = {}
    for r in records:
        if isinstance(r.results, dict) and any(True for _ in _numbers(r.results)):
            counts[r.kind] = counts.get(r.kind, 0) + 1
    if not counts:
        return None
    return max(counts, key=lambda k: (counts[k], k == "selfcal"))


def _kinds_held(records: Sequence[Record]) -> str:
    """``12 selfcal, 3 replay``: the kinds of a robot's records and how many of each."""
    counts: dict[str, int] = {}
    for r in records:
        counts[r.kind] = counts.get(r.kind, 0) + 1
    return ", ".join(f"{n} {k}" for k, n in sorted(counts.items(), key=lambda kv: -kv[1])) or "none"


def _check_kind(records: Sequence[Record], robot: str, kind: str | None) -> str:
    """The kind to follow: the one given (known, and held by some of the records), else the
    kind with the most records holding intervals.

    Raises
    ------
    InputError
        A kind no record can have (a typo), a kind the robot has no records of, or no record
        holding a parameter with its interval.
    """
    import difflib

    held = _kinds_held(records)
    if kind is not None and kind not in KINDS:
        near = difflib.get_close_matches(kind, KINDS, n=1)
        raise InputError(
            f"no record is of the kind {kind!r}{f' ({near[0]}?)' if near else ''}: the kinds are "
            f"{', '.join(KINDS)}; the records of robot {robot!r}: {held}",
            data=(robot, kind),
        )
    if kind is not None and not any(r.kind == kind for r in records):
        raise InputError(
            f"robot {robot!r} has no {kind} records: no drift of them to follow (its records: {held})", data=(robot,)
        )
    found = kind if kind is not None else _kind_of(records)
    if found is None or not series_of(records, found):
        what = f"{kind} records" if kind is not None else "records"
        raise InputError(
            f"the {what} of robot {robot!r} hold no parameter with its 95 % interval: no drift to follow (its "
            f"records: {held}; a self-calibration records its intervals)",
            data=(robot,),
        )
    return found


def _one_per_recording(records: Sequence[Record]) -> tuple[list[Record], list[str]]:
    """The records, each stretch of a recording once: a later record of the same content, kind
    and method as an earlier one, of a part that overlaps it, is left out (a note names it)."""
    seen: dict[tuple[str, str, str], list[tuple[Any, int]]] = {}
    kept, notes = [], []
    for r in sorted(records, key=lambda r: (r.time, r.id)):
        part = recording_part(r.inputs)
        earlier = seen.setdefault((r.kind, r.method, r.input_sha256), []) if r.input_sha256 else []
        first = next((rid for p, rid in earlier if parts_overlap(p, part)), None)
        if first is not None:
            notes.append(
                f"record #{r.id} holds the recording of record #{first} again (the same content): counted once"
            )
            continue
        earlier.append((part, r.id))
        kept.append(r)
    return kept, notes


def _span_text(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def detect_drift(
    records: Sequence[Record],
    *,
    robot: str,
    kind: str | None = None,
    parameters: Sequence[str] | None = None,
    false_alarm: float = DEFAULT_FALSE_ALARM,
) -> DriftReport:
    """Steps and trends of every parameter of one robot's history.

    Parameters
    ----------
    records : sequence of Record
        The robot's records.
    robot : str
        Its name (for the report).
    kind : str, optional
        The kind of records to follow (default: the kind with the most records that hold
        intervals; a self-calibration and a replay measure with different biases, so one series
        holds one kind).
    parameters : sequence of str, optional
        Only these parameters (result keys; default: every one with intervals).
    false_alarm : float
        The probability that one parameter with no step raises an alarm (0 < a < 0.5).

    Returns
    -------
    DriftReport

    Raises
    ------
    InputError
        A false-alarm rate outside (0, 0.5); a kind no record can have, or one the robot has no
        records of; records that hold no parameter with its interval; a parameter the records do
        not hold.
    """
    if not (0.0 < false_alarm < 0.5):
        raise InputError(f"the false-alarm rate must be above 0 and below 0.5, got {false_alarm}")
    kind = _check_kind(records, robot, kind)
    once, notes = _one_per_recording([r for r in records if r.kind == kind])
    all_series = series_of(once, kind)
    if parameters:
        missing = [p for p in parameters if p not in all_series]
        if missing:
            known = ", ".join(sorted(all_series)) or "none"
            raise InputError(
                f"{robot}'s {kind} records hold no {', '.join(missing)} with intervals (they hold: {known})",
                data=(robot,),
            )
        all_series = {p: all_series[p] for p in parameters}
    times = [r.time for r in once]
    span_s = (max(times) - min(times)).total_seconds() if times else 0.0
    by_order = len(once) > 1 and span_s < MIN_RATE_SPAN_DAYS * _SECONDS_PER_DAY
    if by_order:
        notes.append(
            f"the {len(once)} sessions span {_span_text(span_s)}: too short a time for a wear rate per day "
            "(recorded in one go? give each session its date, `when`); the trends and steps are taken in the "
            "order of the sessions"
        )
    changes: list[Change] = []
    trends: dict[str, Trend] = {}
    fits: dict[str, Any] = {}
    for name, s in all_series.items():
        if len(s.points) < MIN_SESSIONS:
            notes.append(f"{name}: {len(s.points)} sessions, {MIN_SESSIONS} needed for a trend and a test")
            continue
        fit = _fit_series(s, false_alarm, by_order)
        fits[name] = fit
        changes += _changes(s, fit)
        trends[name] = _trend(s, fit)
    sessions = len({p.record for s in all_series.values() for p in s.points})
    changes.sort(key=lambda c: (c.time_utc, c.record, c.parameter))
    return DriftReport(robot, kind, false_alarm, tuple(changes), trends, sessions, fits, tuple(notes), all_series)
