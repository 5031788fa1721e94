"""A long recording's runs grouped into windows of time, each window replayed and calibrated on
its own: a change in the middle of a day shows as a step between windows (record each, then
``umbmark drift``).

A window holds the runs that start in it (a run is never cut): the recording's span, from its
first run's start to its last run's end, is cut into equal stretches of about the asked length
(runs over 25 minutes in windows of 10 give three of 8.3 minutes). The runs' starts come from
the recording's own clock (:attr:`umbmark.model.dataset.Run.clock_s`: a bag's stamps, a CSV
log's times); logs without one (optiodom's runs, each starting at 0 s) cannot be windowed. A
window whose runs the method cannot calibrate (no run, or a UMBmark square in one direction
only for ``bf``) is reported with the reason and the others go on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from datetime import datetime
from typing import Any, cast

import numpy as np

from umbmark.errors import InputError
from umbmark.model.dataset import Dataset
from umbmark.realrobot.replay import replay_report
from umbmark.realrobot.results import ReplayReport
from umbmark.realrobot.selfcal_windows import MIN_WINDOW_S, WALL_CLOCK_FROM_S, window_edges, window_start

__all__ = ["ReplayWindow", "replay_windows", "run_clocks"]


@dataclass(frozen=True)
class ReplayWindow:
    """One window of one data set: when it starts and ends (seconds into the recording), its
    wall-clock start when the recording's stamps are wall-clock times, its runs, and its
    replay report or why none."""

    dataset: str
    index: int
    start_s: float
    end_s: float
    stamp_s: float | None
    runs: tuple[str, ...]
    report: ReplayReport | None
    error: str | None = None

    def time(self, base: datetime | None = None) -> datetime:
        """The window's start as a date (:func:`~umbmark.realrobot.selfcal_windows.window_start`)."""
        return window_start(self.stamp_s, self.start_s, base)

    def to_dict(self, base: datetime | None = None) -> dict[str, Any]:
        """The window and its replay's JSON, or its error (``result`` None)."""
        return {
            "dataset": self.dataset,
            "window": self.index,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "start_utc": self.time(base).isoformat().replace("+00:00", "Z"),
            "runs": list(self.runs),
            "error": self.error,
            "result": None if self.report is None else self.report.to_dict(),
        }


def run_clocks(ds: Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Each run's start and end on the recording's clock [s].

    Parameters
    ----------
    ds : Dataset
        Runs that keep their recording's clock.

    Returns
    -------
    start_s, end_s : numpy.ndarray
        ``(R,)`` each.

    Raises
    ------
    InputError
        A run without a clock, or runs that overlap in time (several logs each starting at 0 s).
    """
    if any(r.clock_s is None for r in ds.runs):
        raise InputError(
            f"the runs of {ds.name} keep no clock of the recording (each starts at 0 s): windows need one "
            "long log (a bag, a CSV log) cut into runs; replay each session on its own and record it with its "
            "date instead",
            ds.source,
        )
    start = np.array([float(r.clock_s or 0.0) for r in ds.runs])
    end = start + np.array([float(r.t[-1]) for r in ds.runs])
    order = np.argsort(start, kind="stable")
    s, e = start[order], end[order]
    if np.any(s[1:] < e[:-1] - 1e-9):
        k = int(np.flatnonzero(s[1:] < e[:-1] - 1e-9)[0])
        a, b = ds.runs[order[k]].name, ds.runs[order[k + 1]].name
        raise InputError(
            f"runs {a} and {b} overlap in time on the recording's clock (logs each starting at 0 s?): "
            "windows need the runs of one recording",
            ds.source,
        )
    return start, end


def replay_windows(
    ds: Dataset,
    window_s: float,
    method: str = "bf",
    lsq_options: dict | None = None,
    heldout: bool = True,
) -> list[ReplayWindow]:
    """Group a data set's runs into windows of about ``window_s`` and replay and calibrate each.

    Parameters
    ----------
    ds : Dataset
        The runs of one recording (their :attr:`~umbmark.model.dataset.Run.clock_s` set).
    window_s : float
        The windows' length [s], at least :data:`MIN_WINDOW_S`.
    method, lsq_options, heldout
        As :func:`umbmark.realrobot.replay.replay_report`.

    Returns
    -------
    list of ReplayWindow
        In the order of time.

    Raises
    ------
    InputError
        A window shorter than :data:`MIN_WINDOW_S` or not finite; runs without a clock or
        overlapping in time.
    """
    if not (math.isfinite(window_s) and window_s >= MIN_WINDOW_S):
        raise InputError(f"a window of {window_s:g} s: windows are at least {MIN_WINDOW_S:g} s long")
    start, end = run_clocks(ds)
    t0 = float(start.min())
    edges, which = window_edges(start - t0, float(end.max()) - t0, window_s)
    out: list[ReplayWindow] = []
    for k in range(len(edges) - 1):
        sel = [i for i in np.argsort(start, kind="stable") if which[i] == k]
        a, b = float(edges[k]), float(edges[k + 1])
        stamp = t0 + a if t0 >= WALL_CLOCK_FROM_S else None
        names = tuple(ds.runs[i].name for i in sel)
        name = f"{ds.name} [{a:.0f} s, {b:.0f} s]"
        try:
            if not sel:
                raise InputError("no run starts in this window")
            sub = replace(ds.subset(sel), name=name)
            rep = cast(ReplayReport, replay_report(sub, method, lsq_options, heldout=heldout and len(sel) > 1))
            out.append(ReplayWindow(ds.name, k, a, b, stamp, names, rep))
        except InputError as e:
            out.append(ReplayWindow(ds.name, k, a, b, stamp, names, None, e.message))
    return out
