"""The calibration history of one robot over time, as a figure (made without pyplot, as in
:mod:`umbmark.viz.plots`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING, Any

from umbmark.history.base import Record
from umbmark.kinds import kind_in
from umbmark.viz.text import interval95

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

# a 95 % interval (low, high), or None
_Interval = tuple[float, float] | None

__all__ = ["series", "history_figure"]


@dataclass
class _Series:
    """Time series of one robot's records, for plots."""

    times: list[datetime] = field(default_factory=list)
    emax_syst_mm: list[float | None] = field(default_factory=list)
    ed: list[float | None] = field(default_factory=list)
    eb: list[float | None] = field(default_factory=list)
    wheelbase_mm: list[float | None] = field(default_factory=list)
    ids: list[int] = field(default_factory=list)


def series(records: Sequence[Record]) -> _Series:
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
        s.wheelbase_mm.append(None if kind_in(r.parameters) else r.wheelbase_mm)  # another kind's: its own panels
        s.ids.append(r.id)
    return s


def _date_axis(ax: Axes, times: Sequence[datetime]) -> None:
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
        # matplotlib converts datetimes through its units registry; its stubs type the limits as float only
        ax.set_xlim(lo - pad, hi + pad)  # type: ignore[arg-type]
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


def _ci(results: dict[str, Any], *keys: str) -> _Interval:
    """The first of ``keys`` in a record's results that holds a 95 % interval ``[low, high]``."""
    for k in keys:
        ci = interval95(results, k)
        if ci is not None:
            return ci
    return None


def _selfcal_value(r: Record, key: str, pose: bool = False) -> tuple[float | None, _Interval]:
    """A self-calibration record's figure and its interval (None, None for another kind)."""
    res = r.results if isinstance(r.results, dict) else {}
    if r.method != "selfcal":
        return None, None
    src = res.get("sensor_pose") if pose else res
    if not isinstance(src, dict) or not isinstance(src.get(key), (int, float)):
        return None, None
    return float(src[key]), _ci(src, f"{key}_ci95")


_Panel = tuple[str, list[tuple[str, list[float | None], list[_Interval]]]]


def _kind_panels(records: Sequence[Record]) -> list[_Panel]:
    """The panels of the parameters that the self-calibrations of another kind of robot estimated:
    one per JSON key (a mecanum robot's four wheel diameters in one), labelled with the kind."""
    out: list[_Panel] = []
    for own in dict.fromkeys(k for r in records if (k := kind_in(r.results)) is not None):
        got = [{p.name: (v, ci) for p, v, ci in own.estimates_json(r.results)} if kind_in(r.results) is own else {}
               for r in records]  # fmt: skip
        groups: dict[str, list[Any]] = {}
        for p in own.parameters:
            if any(g.get(p.name, (None, None))[1] is not None for g in got):
                groups.setdefault(p.key[0], []).append(p)
        for key, params in groups.items():
            what = params[0].label if len(params) == 1 else key.removesuffix(f"_{params[0].unit}").replace("_", " ")
            unit = f" [{params[0].unit}]" if params[0].unit else ""
            lines = [
                ("" if len(params) == 1 else p.key[-1].replace("_", " "),
                 [g.get(p.name, (None, None))[0] for g in got], [g.get(p.name, (None, None))[1] for g in got])
                for p in params
            ]  # fmt: skip
            out.append((f"{what}{unit}\n({own.noun})", lines))
    return out


def history_figure(records: Sequence[Record], title: str | None = None) -> Figure:
    """E_max,syst, E_d, E_b and the recommended wheelbase over time (one panel each), with the
    records' 95 % intervals where they hold them; with self-calibrations also the wheel
    diameters and the lidar's position. A panel no record has a value for is left out.

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
    res = [r.results if isinstance(r.results, dict) else {} for r in records]
    plain: list[_Interval] = [None] * len(records)
    # (label, [(line name, values, intervals), ...]) of each panel
    panels: list[_Panel] = [
        ("E_max,syst [mm]\n(measured, before)", [("", s.emax_syst_mm, plain)]),
        ("E_d = D_R / D_L", [("", s.ed, [_ci(x, "Ed_ci95") for x in res])]),
        ("E_b", [("", s.eb, [_ci(x, "Eb_ci95") for x in res])]),
        (
            "wheelbase [mm]\n(recommended)",
            [("", s.wheelbase_mm, [_ci(x, "wheelbase_mm_ci95", "wheelbase_corrected_mm_ci95") for x in res])],
        ),
    ]
    sc = [[_selfcal_value(r, k) for r in records] for k in ("wheel_diameter_left_mm", "wheel_diameter_right_mm")]
    pose = [[_selfcal_value(r, k, pose=True) for r in records] for k in ("x_mm", "y_mm")]
    if any(v is not None for v, _ in sc[0]):
        panels.append(
            (
                "wheel diameters [mm]\n(self-calibration)",
                [(lab, [v for v, _ in vals], [c for _, c in vals]) for lab, vals in zip(("D_L", "D_R"), sc)],
            )
        )
    panels += _kind_panels(records)
    if any(v is not None for v, _ in pose[0]):
        panels.append(
            (
                "lidar position [mm]\n(self-calibration)",
                [(lab, [v for v, _ in vals], [c for _, c in vals]) for lab, vals in zip(("x", "y"), pose)],
            )
        )
    panels = [p for p in panels if any(v is not None for _, vals, _ in p[1] for v in vals)]
    fig = new_figure((8, 2.2 * max(len(panels), 1) + 0.6))
    axes = fig.subplots(max(len(panels), 1), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (label, lines) in zip(axes, panels):
        for j, (name, vals, cis) in enumerate(lines):
            colour = ("tab:blue", "tab:orange", "tab:green", "tab:red")[j % 4]
            pts = [(t, v, c, i) for t, v, c, i in zip(s.times, vals, cis, s.ids) if v is not None]
            if not pts:
                continue
            ts, vs = [p[0] for p in pts], [p[1] for p in pts]
            ax.plot(ts, vs, "o-", color=colour, ms=5, label=name or None)
            for t, _v, c, _ in pts:
                if c is not None:
                    ax.plot([t, t], [c[0], c[1]], "-", color=colour, lw=2.5, alpha=0.45)
            if j == 0:
                for t, v, _, rid in pts:
                    ax.annotate(f"#{rid}", (t, v), textcoords="offset points", xytext=(4, 4), fontsize=7, color="0.35")
        if any(name for name, _, _ in lines):
            ax.legend(fontsize=7, loc="best")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, lw=0.3)
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
        if label.startswith("E_max"):
            ax.set_ylim(bottom=0)
    _date_axis(axes[-1], s.times)
    robot = records[0].robot if records else ""
    fig.suptitle(title or f"Calibration history of {robot} ({len(records)} records; bars: 95 % intervals)")
    fig.tight_layout()
    return fig
