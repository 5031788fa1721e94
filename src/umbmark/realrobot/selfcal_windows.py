"""A long recording cut into windows of time, each self-calibrated on its own: a change in the
middle of a day shows as a step between windows (record each, then ``umbmark drift``).

The windows of an input are equal stretches of about the asked length (a recording of 25
minutes in windows of 10 is three of 8.3 minutes); no window spans two inputs. A window too
short or too poor to calibrate is reported with the reason and the others go on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import numpy as np

from umbmark.correct.selfcal.kinematic import kinematic_selfcal
from umbmark.errors import InputError
from umbmark.realrobot.kinematic import KinematicReport
from umbmark.realrobot.selfcal import ScanIntervals, SelfcalReport, selfcal_report

__all__ = ["SelfcalWindow", "selfcal_windows", "window_edges", "window_start", "MIN_WINDOW_S", "WALL_CLOCK_FROM_S"]

# the shortest window asked for [s]
MIN_WINDOW_S = 10.0
# stamps from this on are wall-clock times (2001-09-09); below, a recording's own clock (a simulation)
WALL_CLOCK_FROM_S = 1e9


def window_start(stamp_s: float | None, start_s: float, base: datetime | None = None) -> datetime:
    """A window's start as a date: its wall-clock stamp when the recording has one, else ``base``
    (default now) plus its start in the recording ``start_s``."""
    if stamp_s is not None:
        return datetime.fromtimestamp(stamp_s, tz=timezone.utc)
    return (base or datetime.now(timezone.utc)) + timedelta(seconds=start_s)


def window_edges(start_s: np.ndarray, length_s: float, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The windows' edges over a recording and the window each item (an interval, a run) starts in.

    Parameters
    ----------
    start_s : numpy.ndarray
        ``(R,)`` the items' starts, from the recording's start [s].
    length_s : float
        The recording's span [s].
    window_s : float
        The asked length [s]: the span is cut into ``round(length_s / window_s)`` equal windows
        (at least one).

    Returns
    -------
    edges : numpy.ndarray
        ``(W + 1,)`` from 0 to ``length_s``.
    which : numpy.ndarray
        ``(R,)`` each item's window, 0 .. W - 1.
    """
    count = max(1, int(round(length_s / window_s)))
    edges = np.linspace(0.0, length_s, count + 1)
    which = np.clip(np.searchsorted(edges, start_s, side="right") - 1, 0, count - 1)
    return edges, which


@dataclass(frozen=True)
class SelfcalWindow:
    """One window of one input: when it starts and ends (seconds into the input), its wall-clock
    start when the recording's stamps are wall-clock times, and its self-calibration or why none."""

    input: str
    index: int
    start_s: float
    end_s: float
    stamp_s: float | None
    report: SelfcalReport | KinematicReport | None
    error: str | None = None

    def time(self, base: datetime | None = None) -> datetime:
        """The window's start as a date (:func:`window_start`)."""
        return window_start(self.stamp_s, self.start_s, base)

    def to_dict(self, base: datetime | None = None) -> dict[str, Any]:
        """The window and its self-calibration's JSON (without the figures), or its error."""
        out: dict[str, Any] = {
            "input": self.input,
            "window": self.index,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "start_utc": self.time(base).isoformat().replace("+00:00", "Z"),
            "error": self.error,
        }
        if self.report is not None:
            d = self.report.to_dict()
            d.pop("figures", None)
            out["result"] = d
        else:
            out["result"] = None
        return out


def _times(part: ScanIntervals | str, n: int, dt: np.ndarray) -> tuple[np.ndarray, float | None]:
    """Each interval's start in its input [s], and the input's wall-clock start stamp (or None)."""
    if isinstance(part, ScanIntervals):
        st = np.asarray(part.start_s, dtype=float)
        t0 = float(st[0]) if st.size else 0.0
        return st - t0, (t0 if t0 >= WALL_CLOCK_FROM_S else None)
    return np.cumsum(dt) - dt, None


def selfcal_windows(report: SelfcalReport | KinematicReport, window_s: float, **options: Any) -> list[SelfcalWindow]:
    """Cut the inputs of a self-calibration into windows of about ``window_s`` and self-calibrate each.

    Parameters
    ----------
    report : SelfcalReport or KinematicReport
        The self-calibration of the whole inputs (its intervals and inputs are cut): a
        differential drive's, or another kind of robot's (each window estimates the parameters
        the whole did).
    window_s : float
        The windows' length [s], at least :data:`MIN_WINDOW_S`.
    **options
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal` (another kind:
        ``reject_outliers``).

    Returns
    -------
    list of SelfcalWindow
        In the order of the inputs and of time.

    Raises
    ------
    InputError
        A window shorter than :data:`MIN_WINDOW_S` or not finite.
    """
    if not (math.isfinite(window_s) and window_s >= MIN_WINDOW_S):
        raise InputError(f"a window of {window_s:g} s: windows are at least {MIN_WINDOW_S:g} s long")
    if isinstance(report, KinematicReport):
        return _kinematic_windows(report, window_s, **options)
    r = report.result
    sizes = report.sizes or (len(report.intervals.dt_s),)
    out: list[SelfcalWindow] = []
    first = 0
    for part, n in zip(report.parts, sizes):
        idx = np.arange(first, first + n)
        first += n
        iv = report.intervals.subset(idx)
        name = part.intervals.source if isinstance(part, ScanIntervals) else str(part)
        t, stamp0 = _times(part, n, np.asarray(iv.dt_s, dtype=float))
        length = float(t[-1] + iv.dt_s[-1]) if n else 0.0
        edges, which = window_edges(t, length, window_s)
        for k in range(len(edges) - 1):
            sel = np.flatnonzero(which == k)
            a, b = float(edges[k]), float(edges[k + 1])
            stamp = None if stamp0 is None else stamp0 + a
            label = f"{Path(str(name)).name} [{a:.0f} s, {b:.0f} s]"
            try:
                if sel.size == 0:
                    raise InputError("no intervals in this window")
                rep = selfcal_report(
                    [(label, iv.subset(sel))], r.nominal_wheel_diameter_m, r.nominal_wheelbase_m, **options
                )
                out.append(SelfcalWindow(str(name), k, a, b, stamp, rep))
            except InputError as e:
                out.append(SelfcalWindow(str(name), k, a, b, stamp, None, str(e)))
    return out


def _kinematic_windows(report: KinematicReport, window_s: float, reject_outliers: bool = True) -> list[SelfcalWindow]:
    """:func:`selfcal_windows` of another kind of robot: each bag's intervals cut by their start."""
    r = report.result
    fit = tuple(n for n in r.nominal.parameter_names if n in r.parameters)
    out: list[SelfcalWindow] = []
    for part in report.parts:
        st = np.asarray(part.start_s, dtype=float)
        t0 = float(np.asarray(part.bag.scan_t_s, dtype=float)[0])
        t = st - t0
        length = float(t[-1] + part.intervals.dt_s[-1]) if len(t) else 0.0
        edges, which = window_edges(t, length, window_s)
        name = str(part.bag.source)
        for k in range(len(edges) - 1):
            sel = np.flatnonzero(which == k)
            a, b = float(edges[k]), float(edges[k + 1])
            stamp = t0 + a if t0 >= WALL_CLOCK_FROM_S else None
            try:
                if sel.size == 0:
                    raise InputError("no intervals in this window")
                iv = part.intervals.subset(sel)
                res = kinematic_selfcal(iv, r.nominal, fit=fit, reject_outliers=reject_outliers)
                rep = KinematicReport(res, (part,), draw=False, intervals=iv)
                out.append(SelfcalWindow(name, k, a, b, stamp, rep))
            except InputError as e:
                out.append(SelfcalWindow(name, k, a, b, stamp, None, str(e)))
    return out
