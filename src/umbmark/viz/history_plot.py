"""The calibration history of one robot over time, as a figure (made without pyplot, as in
:mod:`umbmark.viz.plots`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from umbmark.history.base import Record

__all__ = ["series", "history_figure"]


@dataclass
class _Series:
    """Time series of one robot's records, for plots."""

    times: list = field(default_factory=list)
    emax_syst_mm: list = field(default_factory=list)
    ed: list = field(default_factory=list)
    eb: list = field(default_factory=list)
    wheelbase_mm: list = field(default_factory=list)
    ids: list = field(default_factory=list)


def series(records: list[Record]) -> _Series:
    """The records' times, E_max,syst, E_d, E_b, recommended wheelbase and ids, as lists.

    Parameters
    ----------
    records : list of Record
        One robot's records, oldest first.

    Returns
    -------
    _Series
        One list per quantity, in the order of ``records`` (``None`` where a record has no value).
    """
    s = _Series()
    for r in records:
        s.times.append(r.time)
        s.emax_syst_mm.append(r.emax_syst_mm)
        s.ed.append(r.ed)
        s.eb.append(r.eb)
        s.wheelbase_mm.append(r.wheelbase_mm)
        s.ids.append(r.id)
    return s


def _date_axis(ax, times: list) -> None:
    """Label the time axis with dates (and times of day, and seconds where the records are
    that close), never with an offset: records seconds apart read ``2026-05-04 12:00:05``,
    not ``5 ... 9`` beside an offset label.

    The view spans at least 20 s around the records, so the ticks fall on whole seconds.
    """
    from datetime import timedelta

    import matplotlib.dates as mdates

    if times:
        lo, hi = min(times), max(times)
        pad = max((hi - lo) * 0.05, timedelta(seconds=10))
        ax.set_xlim(lo - pad, hi + pad)
        span = hi - lo + 2 * pad
    else:
        span = timedelta(days=1)
    if span > timedelta(days=3):
        fmt = "%Y-%m-%d"
    elif span > timedelta(hours=3):
        fmt = "%Y-%m-%d\n%H:%M"
    else:
        fmt = "%Y-%m-%d\n%H:%M:%S"
    loc = mdates.AutoDateLocator(minticks=3, maxticks=6)
    if span <= timedelta(minutes=10):  # whole seconds only (the automatic locator may pick fractions)
        loc.intervald[mdates.SECONDLY] = [1, 2, 5, 10, 15, 30]
        loc.intervald[mdates.MICROSECONDLY] = []
    ax.xaxis.set_major_locator(loc)
    ax.xaxis.set_major_formatter(mdates.DateFormatter(fmt))
    ax.tick_params(axis="x", labelsize=7)
    ax.set_xlabel("time (UTC)")


def history_figure(records: list[Record], title: str | None = None):
    """E_max,syst, E_d, E_b and the recommended wheelbase over time (one panel each).

    Parameters
    ----------
    records : list of Record
        One robot's records, oldest first.
    title : str, optional
        The figure's title (default: the robot's name and the number of records).

    Returns
    -------
    matplotlib.figure.Figure
    """

    from umbmark.viz.plots import new_figure

    s = series(records)
    fig = new_figure((8, 9))
    axes = fig.subplots(4, 1, sharex=True)
    panels = [
        (s.emax_syst_mm, "E_max,syst [mm]\n(measured, before)"),
        (s.ed, "E_d = D_R / D_L"),
        (s.eb, "E_b"),
        (s.wheelbase_mm, "wheelbase [mm]\n(recommended)"),
    ]
    for ax, (vals, label) in zip(axes, panels):
        pts = [(t, v) for t, v in zip(s.times, vals) if v is not None]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", color="tab:blue", ms=5)
            for (t, v), rid in zip(pts, [i for i, v in zip(s.ids, vals) if v is not None]):
                ax.annotate(f"#{rid}", (t, v), textcoords="offset points", xytext=(4, 4), fontsize=7, color="0.35")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, lw=0.3)
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    axes[0].set_ylim(bottom=0)
    _date_axis(axes[-1], s.times)
    robot = records[0].robot if records else ""
    fig.suptitle(title or f"Calibration history of {robot} ({len(records)} records)")
    fig.tight_layout()
    return fig
