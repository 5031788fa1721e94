"""A robot's parameters over its sessions with their 95 % intervals, the fitted trend and the
detected changes (:func:`umbmark.history.drift.detect_drift`), as a figure."""

from __future__ import annotations

from typing import TYPE_CHECKING

from umbmark.history.drift import DriftReport

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["drift_figure"]

_Z95 = 1.959963984540054


def drift_figure(report: DriftReport, title: str | None = None) -> Figure:
    """One panel per parameter of the report: each session's value and 95 % interval, the fitted
    levels and trend (a line per segment between changes), each change marked where it happened
    with its step.

    Parameters
    ----------
    report : DriftReport
        What :func:`umbmark.history.drift.detect_drift` found.
    title : str, optional
        The figure's title (default: the robot, its sessions and the alarm).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from umbmark.viz.history_plot import _date_axis
    from umbmark.viz.plots import new_figure

    names = [n for n in report.series if n in report.fits]
    fig = new_figure((8, 2.0 * max(len(names), 1) + 0.7))
    axes = fig.subplots(max(len(names), 1), 1, sharex=True, squeeze=False)[:, 0]
    times = []
    for ax, name in zip(axes, names):
        s = report.series[name]
        ts = [p.time for p in s.points]
        times += ts
        vs = [p.value for p in s.points]
        ax.plot(ts, vs, "o", color="tab:blue", ms=4, zorder=3)
        for t, p in zip(ts, s.points):
            if p.sd is not None:
                ax.plot([t, t], [p.value - _Z95 * p.sd, p.value + _Z95 * p.sd], "-", color="tab:blue", lw=2, alpha=0.4)
        fitted = report.fitted(name)
        edges = [0, *report.fits[name]["cuts"], len(ts)]
        for a, b in zip(edges[:-1], edges[1:]):
            ax.plot(ts[a:b], fitted[a:b], "-", color="tab:orange", lw=1.5, zorder=2)
        for c in report.changes:
            if c.parameter == name:
                k = [p.record for p in s.points].index(c.record)
                ax.axvline(ts[k], color="tab:red", lw=1, ls="--")
                ax.annotate(
                    f"#{c.record}: {c.step:+.4g}",
                    (ts[k], c.after),
                    textcoords="offset points",
                    xytext=(4, 4),
                    fontsize=7,
                    color="tab:red",
                )
        ax.set_ylabel(name, fontsize=8)
        ax.grid(True, lw=0.3)
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    _date_axis(axes[-1], times)
    state = f"{len(report.changes)} change(s)" if report.changes else "no change"
    fig.suptitle(
        title
        or f"Drift of {report.robot}: {report.sessions} sessions, {state}\n"
        "(bars: 95 % intervals; lines: levels and trend)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig
