"""The HTML page of a self-calibration: the estimates with their intervals and what they mean,
the warnings and how well the data determine each parameter, the map before and after
calibration, the lidar on the robot, the residuals over time, and how to load the result.

The page is made from the self-calibration's JSON alone (``umbmark selfcal --save``, or a
history record): its ``figures`` carry the map and the residuals
(:mod:`umbmark.realrobot.selfcal_map`). Figures are made without pyplot, as in
:mod:`umbmark.viz.plots`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.viz.report import (
    SELFCAL_DEFINITIONS,
    _e,
    _header,
    _img,
    _load_section,
    _page,
    _table,
    _warnings_list,
    figure_data_uri,
)
from umbmark.viz.text import fmt, interval95

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

__all__ = [
    "is_selfcal_result",
    "selfcal_page",
    "PageParts",
    "page_sections",
    "lidar_figure",
    "map_figure",
    "mount_figure",
    "residuals_figure",
    "robust_sd",
]

_MEANING = (
    "95 % intervals: from the scatter of the intervals about the fit and between stretches of the recording "
    "(errors shared within a stretch count); they do not cover errors shared by the whole recording (one "
    "floor, one day): calibrate on another recording to see those."
)

_ROWS = (
    ("D_L [mm]", "wheel_diameter_left_mm", 3, "nominal_wheel_diameter_mm"),
    ("D_R [mm]", "wheel_diameter_right_mm", 3, "nominal_wheel_diameter_mm"),
    ("wheelbase [mm]", "wheelbase_mm", 3, "nominal_wheelbase_mm"),
    ("E_d = D_R / D_L", "Ed", 6, None),
    ("E_b", "Eb", 6, None),
)
_POSE_ROWS = (("lidar x [mm]", "x_mm", 2), ("lidar y [mm]", "y_mm", 2), ("lidar yaw [deg]", "yaw_deg", 3))
_PARAM_NAMES = ("r_L", "r_R", "b", "x", "y", "yaw")
_SELFCAL_EXPORTS = (("ros2", "params.yaml (ROS 2)"), ("urdf", "URDF origin"))


def is_selfcal_result(d: Any) -> bool:
    """Whether a JSON object is a self-calibration's (``umbmark selfcal --json`` or ``--save``)."""
    return isinstance(d, dict) and d.get("method") == "selfcal" and isinstance(d.get("sensor_pose"), dict)


def _ci(d: dict[str, Any], key: str, digits: int) -> str:
    lo_hi = interval95(d, f"{key}_ci95")
    if lo_hi is None:
        return "-"
    return f"{fmt(lo_hi[0], digits)} to {fmt(lo_hi[1], digits)}"


def _estimates_table(d: dict[str, Any]) -> str:
    nominal_pose = d.get("nominal_sensor_pose") or {}
    rows = []
    for label, key, digits, nom in _ROWS:
        rows.append([label, fmt(d.get(key), digits), _ci(d, key, digits), fmt(d.get(nom), digits) if nom else "1"])
    sp = d["sensor_pose"]
    for label, key, digits in _POSE_ROWS:
        rows.append([label, fmt(sp.get(key), digits), _ci(sp, key, digits), fmt(nominal_pose.get(key), digits)])
    delays = [s for s in (d.get("scan_delay") or []) if isinstance(s, dict)]
    for s in delays:
        applied = s.get("applied_s")
        how = "estimated" if s.get("requested") == "auto" else "given"
        name = Path(str(s.get("bag", ""))).name
        label = "scans' delay [ms]" + (f" ({name})" if len(delays) > 1 else "")
        rows.append([label, fmt(None if applied is None else applied * 1e3, 1), how, "0"])
    jitter = d.get("wheel_jitter_ms")
    rows.append(["wheel data jitter [ms]", fmt(jitter, 1) if jitter is not None else "not modelled", "estimated", "0"])
    return _table(["", "estimate", "95 % interval", "nominal"], rows)


def _correlations(
    d: dict[str, Any],
    names: Sequence[str] = _PARAM_NAMES,
    meaning: str = "r_L, r_R: wheel radii; b: wheelbase; x, y, yaw: the lidar on the robot.",
    what: str = "spins both ways for the wheelbase against the lidar's x; arcs both ways",
) -> str:
    """The correlations of the estimates (``names``, in the order of the JSON's ``covariance``),
    those beyond 0.9 named with what to drive (``what``)."""
    cov = d.get("covariance")
    n = len(names)
    try:
        c = np.asarray(cov, dtype=float)
    except (TypeError, ValueError):
        return ""
    if c.shape != (n, n) or not np.all(np.isfinite(c)):
        return ""
    sd = np.sqrt(np.maximum(np.diag(c), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = c / np.outer(sd, sd)
    rows = [[names[i]] + [fmt(rho[i, j], 2) if i != j else "1" for j in range(n)] for i in range(n)]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n) if abs(rho[i, j]) > 0.9]
    strong = [f"{names[i]} and {names[j]} ({rho[i, j]:+.2f})" for i, j in pairs]
    note = (
        "<p>The data tell these apart poorly (|correlation| over 0.9): " + _e(", ".join(strong)) + ". Drive more of "
        f"what separates them ({_e(what)}).</p>"
        if strong
        else "<p>No two parameters correlate beyond 0.9: the drive determined each of them.</p>"
    )
    return (
        "<h3>How the estimates depend on each other</h3>"
        + _table(["correlation", *names], rows)
        + note
        + f'<p class="meta">{_e(meaning)}</p>'
    )


def robust_sd(v: ArrayLike) -> float:
    """1.4826 times the median absolute deviation from the median (nan when empty)."""
    x = np.asarray(v, dtype=float)
    x = x[np.isfinite(x)]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else math.nan


def _noise(d: dict[str, Any], res: dict[str, NDArray[Any]] | None) -> str:
    from umbmark.correct.selfcal.loss import noise_words

    nsd = d.get("noise_sd") or {}
    tail = noise_words(d.get("noise_dof"))
    out = ""
    if res is not None and len(res["t_s"]):
        ok = ~np.asarray(res["rejected"], dtype=bool)
        sd = {k: robust_sd(res[k][ok]) for k in ("dx_mm", "dy_mm", "dyaw_deg")}
        out = (
            f"<p>Spread of the residuals (robust standard deviation of the used intervals): dx "
            f"{_e(fmt(sd['dx_mm'], 3))} mm, dy {_e(fmt(sd['dy_mm'], 3))} mm, dyaw {_e(fmt(sd['dyaw_deg'], 3))} deg.</p>"
        )
    return out + (
        f"<p>The fit's noise scale (added to each match's own uncertainty where the input has it): dx "
        f"{_e(fmt(nsd.get('dx_mm'), 3))} mm, dy {_e(fmt(nsd.get('dy_mm'), 3))} mm, dyaw "
        f"{_e(fmt(nsd.get('dyaw_deg'), 3))} deg; {_e(tail)}.</p>"
    )


def map_figure(maps: Sequence[dict[str, Any]], title: str | None = None) -> Figure:
    """The scans placed by the nominal odometry beside the same scans placed by the calibrated one.

    Parameters
    ----------
    maps : list of dict
        Decoded maps (:func:`umbmark.realrobot.selfcal_map.decode_map`); one row of panels each.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from umbmark.realrobot.selfcal_map import map_points
    from umbmark.viz.plots import new_figure

    n = len(maps)
    fig = new_figure((11.0, 5.2 * n))
    axes = np.atleast_2d(fig.subplots(n, 2, squeeze=False))
    for row, m in zip(axes, maps):
        for ax, which in zip(row, ("nominal", "calibrated")):
            base = m[f"base_{which}"]
            pts = map_points(base, m[f"sensor_{which}"], m["points_m"], m["counts"])
            ax.scatter(pts[:, 0], pts[:, 1], s=0.6, c=pts[:, 2], cmap="viridis", linewidths=0, rasterized=True)
            ax.plot(base[:, 0], base[:, 1], color="tab:red", lw=0.7, label="robot path")
            ax.plot(base[:1, 0], base[:1, 1], "k*", ms=8, label="start")
            spread = (m.get("spread_mm") or {}).get(which)
            label = "nominal geometry and lidar pose" if which == "nominal" else "calibrated"
            name = Path(str(m.get("bag", ""))).name
            ax.set_title(f"{name}: {label}\nwall spread {fmt(spread, 3)} mm", fontsize=9)
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.grid(True, lw=0.3)
            ax.legend(fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def _ellipse(ax: Axes, cx: float, cy: float, cov: NDArray[np.float64], scale: float, **kw: Any) -> None:
    vals, vecs = np.linalg.eigh(cov)
    t = np.linspace(0.0, 2.0 * math.pi, 80)
    circle = np.stack([np.cos(t), np.sin(t)])
    pts = vecs @ (np.sqrt(np.maximum(vals, 0.0))[:, None] * circle) * scale
    ax.plot(cx + pts[0], cy + pts[1], **kw)


def mount_figure(d: dict[str, Any]) -> Figure:
    """The robot from above: its wheels at the calibrated wheelbase and diameters, and the lidar
    at its nominal and its estimated pose (the estimate's 95 % ellipse, drawn 10 x larger).

    Parameters
    ----------
    d : dict
        The self-calibration's JSON.

    Returns
    -------
    matplotlib.figure.Figure
    """
    b = float(d["wheelbase_mm"])
    b_nom = float(d.get("nominal_wheelbase_mm") or b)
    fig, ax, half_len = lidar_figure(d, b_nom, d.get("nominal_sensor_pose") or {}, (3, 4))
    for side, key in ((1, "wheel_diameter_left_mm"), (-1, "wheel_diameter_right_mm")):
        dia = float(d[key])
        ax.add_patch(_rect(-dia / 2, side * b / 2 - 0.04 * b_nom, dia, 0.08 * b_nom, fc="0.25", ec="0.1"))
    fig.tight_layout()
    return fig


def lidar_figure(
    d: dict[str, Any], size_mm: float, nom: dict[str, Any], xy: tuple[int, int] | None
) -> tuple[Figure, Axes, float]:
    """The robot from above (a box about its origin of about ``size_mm``) and its lidar at the
    nominal pose ``nom`` and the estimated one (``d``'s ``sensor_pose``; its 95 % ellipse from the
    covariance's entries ``xy``, drawn 10 x larger): the figure, its axes and the box's half length."""
    from umbmark._stats import chi2_isf
    from umbmark.viz.plots import new_figure

    fig = new_figure((5.6, 5.0))
    ax = fig.subplots()
    sp = d["sensor_pose"]
    xs = [float(sp["x_mm"]), float(nom.get("x_mm", 0.0)), 0.0]
    half_len = max(0.6 * size_mm, 1.3 * max(abs(v) for v in xs))
    half_w = 0.5 * size_mm + 0.12 * size_mm
    ax.add_patch(_rect(-half_len, -half_w, 2 * half_len, 2 * half_w, fill=False, ec="0.4", lw=1.2))
    ax.plot([0], [0], "k+", ms=10)
    ax.annotate("", xy=(0.45 * half_len, 0), xytext=(0, 0), arrowprops=dict(arrowstyle="->", color="0.3"))
    arrow = 0.25 * half_len
    for pose, colour, label, style in (
        (nom, "0.45", "nominal (the matching's start)", dict(mfc="none", ms=12, mew=1.5)),
        (sp, "tab:red", "estimated", dict(ms=6)),
    ):
        if "x_mm" not in pose:
            continue
        x, y, yaw = float(pose["x_mm"]), float(pose["y_mm"]), math.radians(float(pose["yaw_deg"]))
        ax.plot([x], [y], "o", color=colour, label=f"lidar, {label}", **style)
        ax.annotate(
            "",
            xy=(x + arrow * math.cos(yaw), y + arrow * math.sin(yaw)),
            xytext=(x, y),
            arrowprops=dict(arrowstyle="->", color=colour, lw=1.5),
        )
    try:
        if xy is None:
            raise ValueError("no covariance of the lidar's position")
        i, j = xy
        c = np.asarray(d.get("covariance"), dtype=float)[[i, j]][:, [i, j]] * 1e6  # m^2 -> mm^2
        if c.shape == (2, 2) and np.all(np.isfinite(c)):
            k95 = math.sqrt(chi2_isf(0.05, 2))  # the 95 % ellipse of a 2-D Gaussian, in standard deviations
            _ellipse(ax, float(sp["x_mm"]), float(sp["y_mm"]), c, 10 * k95, color="tab:red", lw=0.8, ls="--")
    except (TypeError, ValueError, IndexError):
        pass
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm] (forward)")
    ax.set_ylabel("y [mm] (left)")
    ax.set_title("The lidar on the robot (95 % ellipse drawn 10 x larger)", fontsize=9)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, loc="lower right")
    return fig, ax, half_len


def _rect(x: float, y: float, w: float, h: float, **kw: Any) -> Rectangle:
    from matplotlib.patches import Rectangle

    return Rectangle((x, y), w, h, **kw)


def residuals_figure(res: dict[str, NDArray[Any]], names: Sequence[str] | None = None) -> Figure:
    """Each interval's residual over time, per component; rejected intervals marked.

    Parameters
    ----------
    res : dict
        Decoded residuals (:func:`umbmark.realrobot.selfcal_map.decode_residuals`).
    names : list of str, optional
        The inputs' names (one panel column of time per input, joined end to end).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from umbmark.viz.plots import new_figure

    fig = new_figure((10.0, 6.6))
    axes = fig.subplots(3, 1, sharex=True)
    t = np.asarray(res["t_s"], dtype=float).copy()
    which = np.asarray(res["input"], dtype=int)
    offsets = []
    start = 0.0
    for i in np.unique(which):  # inputs end to end on one time axis
        sel = which == i
        t[sel] += start - (t[sel].min() if sel.any() else 0.0)
        offsets.append(start)
        start = float(t[sel].max()) + 5.0 if sel.any() else start
    bad = np.asarray(res["rejected"], dtype=bool)
    for ax, key, unit in zip(axes, ("dx_mm", "dy_mm", "dyaw_deg"), ("dx [mm]", "dy [mm]", "dyaw [deg]")):
        v = np.asarray(res[key], dtype=float)
        ax.plot(t[~bad], v[~bad], ".", ms=2.5, color="tab:blue", label="used")
        if bad.any():
            ax.plot(t[bad], v[bad], "x", ms=4, color="tab:red", label="rejected")
        s = robust_sd(v[~bad])
        if math.isfinite(s) and s > 0:
            ax.axhline(2 * s, color="0.5", lw=0.6, ls="--")
            ax.axhline(-2 * s, color="0.5", lw=0.6, ls="--", label="+-2 robust sd")
        ok = v[~bad]
        if ok.size:
            lim = 4.0 * float(np.percentile(np.abs(ok), 95)) or 1.0
            ax.set_ylim(-lim, lim)
        ax.set_ylabel(unit)
        ax.grid(True, lw=0.3)
        for o in offsets[1:]:
            ax.axvline(o - 2.5, color="k", lw=0.5)
    axes[0].legend(fontsize=7, loc="upper right", ncol=3)
    label = "time in the recording [s]"
    if names and len(names) > 1:
        label = "time in each input, inputs end to end [s]: " + ", ".join(names)
    axes[-1].set_xlabel(label)
    axes[0].set_title("Residuals of the intervals (measured by the lidar minus predicted from the wheels)", fontsize=9)
    fig.tight_layout()
    return fig


@dataclass(frozen=True, eq=False)
class PageParts:
    """What a self-calibration's page shows of its kind of robot (the rest is every kind's).

    Attributes
    ----------
    box : str
        The result in one box (HTML).
    estimates : str
        The table of the estimates and what they mean (HTML).
    correlations : str
        How the estimates depend on each other (HTML).
    mount : Figure
        The lidar on the robot.
    load : list of str
        How to load the result into the robot (HTML).
    definitions : str
        The words of the page.
    """

    box: str
    estimates: str
    correlations: str
    mount: Figure
    load: list[str]
    definitions: str


def page_sections(d: dict[str, Any], parts: PageParts, exported: dict[str, str] | None) -> list[str]:
    """The sections of a self-calibration's page (any kind of robot's JSON, :class:`PageParts` its
    own): what it was made from, the result, the estimates, the noise, the warnings and
    identifiability, the map before and after, the lidar on the robot, the residuals over time,
    how to load it, the attached files, the definitions."""
    from umbmark.realrobot.selfcal_map import decode_map, decode_residuals

    body: list[str] = []
    inputs = [i for i in (d.get("inputs") or []) if isinstance(i, dict)]
    names = [Path(str(i.get("path", "?"))).name for i in inputs]
    used = d.get("intervals_used")
    rejected = d.get("intervals_rejected") or []
    span = d.get("time_span_s")
    if span is None and inputs:
        spans = [v for i in inputs if isinstance(v := i.get("time_span_s"), (int, float))]
        span = sum(spans) if len(spans) == len(inputs) else None
    summary = f"From {used} intervals ({len(rejected)} rejected as outliers)"
    if names:
        summary += " of " + ", ".join(names)
    if span:
        summary += f", {fmt(span / 60.0, 3)} minutes of driving"
    body.append(f"<p>{_e(summary)}.</p>")
    body.append(parts.box)
    body.append("<h2>Estimates</h2>")
    body.append(parts.estimates)
    figures = d.get("figures")
    if not isinstance(figures, dict):
        figures = {}
    try:
        res = decode_residuals(figures["residuals"])
    except (ValueError, KeyError, TypeError):
        res = None
    body.append(_noise(d, res))
    warnings = [w for w in (d.get("warnings") or []) if isinstance(w, str)]
    body.append("<h2>Warnings and identifiability</h2>")
    body.append(_warnings_list(warnings))
    body.append(parts.correlations)
    body.append("<h2>The map, before and after</h2>")
    maps: list[dict[str, Any]] = []
    broken = False
    for m in figures.get("maps") or []:
        try:
            maps.append(decode_map(m))
        except (ValueError, KeyError, TypeError):
            broken = True
    if maps:
        body.append(
            "<p>The same scans placed by the wheel odometry: on the left with the nominal geometry and lidar pose, on "
            "the right with the calibrated ones. Where the calibration is right the walls come out sharp. Wall "
            "spread: the median distance from a point to the nearest point of another scan (points within "
            "0.3 m of one).</p>"
        )
        body.append(_img(figure_data_uri(map_figure(maps[:4])), "map before and after calibration"))
        if len(maps) > 4:
            body.append(f"<p>{len(maps) - 4} more bags are not drawn.</p>")
    elif broken:
        body.append('<p class="warn">The result\'s map is damaged and is not drawn.</p>')
    else:
        body.append("<p>No map: this result was made from intervals files (no scans), or by an older umbmark.</p>")
    body.append("<h2>The lidar on the robot</h2>")
    body.append(_img(figure_data_uri(parts.mount), "the lidar on the robot"))
    body.append("<h2>Residuals over time</h2>")
    if res is not None and len(res["t_s"]):
        body.append(
            "<p>Where the matches failed or the wheels slipped the residuals leave the band; rejected intervals "
            "(outliers) are crosses.</p>"
        )
        body.append(_img(figure_data_uri(residuals_figure(res, names)), "residuals over time"))
    else:
        body.append("<p>No residuals in this result.</p>")
    body.extend(parts.load)
    if exported:
        body.append("<h2>Attached files</h2>")
        for name, text in exported.items():
            body.append(f"<h3>{_e(name)}</h3><pre>{_e(text)}</pre>")
    body.append(f'<h2>Definitions</h2><p class="meta">{_e(parts.definitions)}</p>')
    return body


def selfcal_page(
    d: dict[str, Any],
    *,
    title: str | None = None,
    source: str | None = None,
    source_sha256: str | None = None,
    robot: str | None = None,
    when: str | None = None,
    exported: dict[str, str] | None = None,
    load_commands: str | None = None,
) -> str:
    """The HTML page of a self-calibration.

    Parameters
    ----------
    d : dict
        Its JSON (:meth:`umbmark.realrobot.selfcal.SelfcalReport.to_dict`).
    title : str, optional
        The page's title (default: "Self-calibration report").
    source : str, optional
        The file it was read from (the export commands name it), or a record's label.
    source_sha256 : str, optional
        The input's content hash, shown in the header.
    robot : str, optional
        The robot's name.
    when : str, optional
        When the page was made (default: now, UTC).
    exported : dict, optional
        File name -> text of exported parameter files (shown verbatim).
    load_commands : str, optional
        The shell commands that export the result for the robot (shown verbatim above the texts
        they write).

    Returns
    -------
    str
        One self-contained HTML document.
    """
    sp = d["sensor_pose"]
    box = (
        '<div class="box"><p class="big">'
        f"D_L = {_e(fmt(d.get('wheel_diameter_left_mm'), 3))} mm, D_R = {_e(fmt(d.get('wheel_diameter_right_mm'), 3))}"
        f" mm, wheelbase = {_e(fmt(d.get('wheelbase_mm'), 3))} mm</p>"
        f"<p>lidar at x = {_e(fmt(sp.get('x_mm'), 2))} mm, y = {_e(fmt(sp.get('y_mm'), 2))}"
        f" mm, yaw = {_e(fmt(sp.get('yaw_deg'), 3))} deg; c_left = {_e(fmt(d.get('c_left'), 6))}, "
        f"c_right = {_e(fmt(d.get('c_right'), 6))}, E_b = {_e(fmt(d.get('Eb'), 6))}</p></div>"
    )
    title = title or "Self-calibration report"
    parts = PageParts(
        box=box,
        estimates=_estimates_table(d) + f'<p class="meta">{_e(_MEANING)}</p>',
        correlations=_correlations(d),
        mount=mount_figure(d),
        load=_load_section(d, source or "<selfcal>", load_commands, _SELFCAL_EXPORTS),
        definitions=SELFCAL_DEFINITIONS,
    )
    body = _header(title, when, robot, f"result {source}" if source else None, source_sha256)
    body += page_sections(d, parts, exported)
    return _page(title, "\n".join(body))
