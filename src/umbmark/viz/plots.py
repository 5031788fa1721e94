"""Figures of runs, paths and studies. Axes in millimetres, equal aspect.

Every figure is a :class:`matplotlib.figure.Figure` made without pyplot: building and saving one
needs no display and leaves matplotlib's backend and pyplot's figures alone, so it works on a
headless server and in a notebook alike (there, with the inline backend, ``display(fig)`` shows
one); :func:`save_figure` writes one to a file.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import matplotlib.ticker
import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.io.atomic import atomic_path
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.runs import RunsTable

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from umbmark.model.geometry import ErrorParams

__all__ = [
    "scatter_figure",
    "save_figure",
    "trajectory_figure",
    "exaggerated_trajectory_figure",
    "pitfall_figure",
    "distribution_figure",
    "new_figure",
    "close_figure",
]

_STYLE = {
    "cw": dict(marker="s", color="tab:blue"),
    "ccw": dict(marker="o", color="tab:red"),
}


def new_figure(figsize: tuple[float, float]) -> Figure:
    """An empty figure of ``figsize`` inches, not registered with pyplot.

    Parameters
    ----------
    figsize : tuple of float
        Width and height in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return Figure(figsize=figsize)


def _draw_runs(ax: Axes, runs: RunsTable, label: str, filled: bool) -> UMBmarkResult:
    res = umbmark_figures(runs)
    for d, st in (("cw", res.cw), ("ccw", res.ccw)):
        rows = runs.direction_rows(d)
        style = _STYLE[d]
        face = style["color"] if filled else "none"
        ax.scatter(
            rows.eps_x * 1e3,
            rows.eps_y * 1e3,
            marker=style["marker"],
            facecolors=face,
            edgecolors=style["color"],
            s=36,
            label=f"{d} runs, {label}",
        )
        ax.scatter(
            [st.x_cg * 1e3],
            [st.y_cg * 1e3],
            marker="+" if filled else "x",
            s=260,
            linewidths=2.2,
            color=style["color"],
            label=f"{d} centre of gravity, {label} (r = {st.r_cg * 1e3:.0f} mm)",
        )
    return res


def scatter_figure(before: RunsTable, after: RunsTable | None = None, title: str | None = None) -> Figure:
    """Return-position errors (Eq. 3.1) of the cw and ccw runs with their centres of gravity,
    before (open markers) and after calibration (filled), like the paper's Figs. 6 and 11.

    Parameters
    ----------
    before : RunsTable
        The runs before calibration.
    after : RunsTable, optional
        The runs after calibration.
    title : str, optional
        The axes' title (default: "UMBmark return position errors").

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((8, 9))
    ax = fig.subplots()
    r0 = _draw_runs(ax, before, "before", filled=False)
    text = f"E_max,syst before: {r0.emax_syst * 1e3:.0f} mm"
    if after is not None:
        r1 = _draw_runs(ax, after, "after", filled=True)
        text += f"\nE_max,syst after: {r1.emax_syst * 1e3:.0f} mm"
    ax.axhline(0, color="0.6", lw=0.8)
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("return position error x [mm] (start frame, x along the first leg)")
    ax.set_ylabel("return position error y [mm]")
    ax.set_title(title or "UMBmark return position errors")
    ax.text(
        0.02, 0.98, text, transform=ax.transAxes, va="top", ha="left", bbox=dict(boxstyle="round", fc="white", ec="0.7")
    )
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=7, frameon=False)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


def trajectory_figure(trajectories: Sequence[dict[str, Any]], title: str | None = None) -> Figure:
    """True (solid) and odometry (dashed) paths of runs, with the start marked.

    Parameters
    ----------
    trajectories : list of dict
        One dict per run: ``true_x``, ``true_y``, ``odo_x``, ``odo_y`` (metres, 1-D) and an
        optional ``label``.
    title : str, optional
        The axes' title (default: "Trajectories").

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((7.5, 7.5))
    ax = fig.subplots()
    for i, t in enumerate(trajectories):
        c = f"C{i % 10}"
        lab = t.get("label", f"run {i + 1}")
        ax.plot(
            np.asarray(t["true_x"]) * 1e3, np.asarray(t["true_y"]) * 1e3, color=c, lw=1.4, label=f"{lab}: true path"
        )
        ax.plot(
            np.asarray(t["odo_x"]) * 1e3,
            np.asarray(t["odo_y"]) * 1e3,
            color=c,
            lw=1.0,
            ls="--",
            label=f"{lab}: odometry",
        )
    ax.plot([0], [0], "k*", ms=10, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title or "Trajectories")
    ax.legend(fontsize=7)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


def close_figure(fig: Figure) -> None:
    """Release a figure: close it in pyplot when pyplot manages it (a figure made elsewhere).

    The figures of this module are not registered with pyplot; they are freed with their last
    reference, and this does nothing to them. pyplot is not imported by this function.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    """
    import sys

    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:
        plt.close(fig)  # a no-op for a figure pyplot does not know


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Write a figure to a file atomically, in the format its suffix names, and release it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (one of this module's, or any other).
    path : str or Path
        The file; its suffix (``.png``, ``.svg``, ``.pdf``, ...) chooses the format, PNG when
        there is none. Written at 120 dpi.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        If matplotlib cannot write that format (nothing is written).
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    supported = fig.canvas.get_supported_filetypes()
    try:
        if fmt not in supported:
            raise InputError(
                f"cannot write a .{fmt} figure (use one of: {', '.join('.' + k for k in sorted(supported))})",
                source=str(path),
            )
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=fmt, dpi=120)
    finally:
        close_figure(fig)
    return path


# ---------------------------------------------------------------------------------------------
# Figures of the paper reproduction


def exaggerated_trajectory_figure(
    trajectories: Sequence[dict[str, Any]],
    exaggerate: float = 1.0,
    side_m: float | None = None,
    title: str | None = None,
) -> Figure:
    """True (solid) and odometry (dashed) paths of runs, like the paper's Figs. 3-5.

    Parameters
    ----------
    trajectories : list of dict
        As for :func:`trajectory_figure`.
    exaggerate : float
        Above 1, the true path is drawn as ``odometry + exaggerate * (true - odometry)``: the
        deviation (the curvature of the legs, the turn errors) is magnified; the odometry path
        is drawn as it is.
    side_m : float, optional
        Also draw the nominal square (cw and ccw) of this side.
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        If ``exaggerate`` is not a positive finite number.
    """
    if not (np.isfinite(exaggerate) and exaggerate > 0):
        raise ValueError(f"exaggeration must be positive, got {exaggerate!r}")
    fig = new_figure((7.5, 8.5))
    ax = fig.subplots()
    if side_m:
        s = side_m * 1e3
        ax.plot([0, s, s, 0, 0], [0, 0, s, s, 0], color="0.8", lw=3, zorder=0, label="nominal square (ccw)")
        ax.plot([0, s, s, 0, 0], [0, 0, -s, -s, 0], color="0.9", lw=3, zorder=0, label="nominal square (cw)")
    for i, t in enumerate(trajectories):
        c = f"C{i % 10}"
        lab = t.get("label", f"run {i + 1}")
        ox, oy = np.asarray(t["odo_x"]) * 1e3, np.asarray(t["odo_y"]) * 1e3
        tx = ox + exaggerate * (np.asarray(t["true_x"]) * 1e3 - ox)
        ty = oy + exaggerate * (np.asarray(t["true_y"]) * 1e3 - oy)
        what = "true path" if exaggerate == 1 else f"true path (deviation x{exaggerate:g})"
        ax.plot(tx, ty, color=c, lw=1.5, label=f"{lab}: {what}")
        ax.plot(ox, oy, color=c, lw=1.0, ls="--", label=f"{lab}: odometry")
        ax.plot([tx[-1]], [ty[-1]], marker="o", color=c, ms=6)
    ax.plot([0], [0], "k*", ms=12, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm] (start frame, x along the first leg)")
    ax.set_ylabel("y [mm]")
    ax.set_title(title or "True and odometry paths")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, frameon=False)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


class PitfallLike(Protocol):
    """What :func:`pitfall_figure` reads of :class:`umbmark.studies.reproduce.Pitfall` (a layer above
    the figures, which do not import it)."""

    @property
    def errors(self) -> ErrorParams: ...
    @property
    def grid_m(self) -> NDArray[np.float64]: ...
    @property
    def cw_r_cg(self) -> NDArray[np.float64]: ...
    @property
    def ccw_r_cg(self) -> NDArray[np.float64]: ...
    @property
    def tuned_wheelbase_m(self) -> float: ...
    @property
    def wheelbase_nominal_m(self) -> float: ...
    @property
    def tuned_runs(self) -> RunsTable: ...
    @property
    def tuned(self) -> UMBmarkResult: ...
    @property
    def bf_runs(self) -> RunsTable: ...
    @property
    def bf(self) -> UMBmarkResult: ...


def pitfall_figure(pitfall: PitfallLike, title: str | None = None) -> Figure:
    """The uni-directional pitfall (paper section 3.1) in two panels.

    (a) What the experimenter saw while tuning the wheelbase on cw runs only, and what the ccw
    runs would have shown; (b) the bi-directional test of the tuned robot against the paper's
    bi-directional correction.

    Parameters
    ----------
    pitfall : umbmark.studies.reproduce.Pitfall
        The study of :func:`umbmark.studies.reproduce.uni_directional_pitfall`.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((13, 6.2))
    a, b = fig.subplots(1, 2, gridspec_kw=dict(width_ratios=[1.1, 1]))
    g = pitfall.grid_m * 1e3
    a.plot(g, pitfall.cw_r_cg * 1e3, color=_STYLE["cw"]["color"], lw=1.8, label="cw runs (tuned on)")
    a.plot(
        g,
        pitfall.ccw_r_cg * 1e3,
        color=_STYLE["ccw"]["color"],
        lw=1.8,
        ls="--",
        label="ccw runs (never run by the experimenter)",
    )
    tb = pitfall.tuned_wheelbase_m * 1e3
    a.axvline(tb, color="k", lw=1, label=f"uni-directionally tuned b = {tb:.2f} mm")
    true_b = pitfall.errors.eb * pitfall.wheelbase_nominal_m * 1e3
    a.axvline(true_b, color="tab:green", lw=1, ls=":", label=f"true b = {true_b:.2f} mm")
    a.axvline(
        pitfall.wheelbase_nominal_m * 1e3,
        color="0.5",
        lw=1,
        ls="-.",
        label=f"nominal b = {pitfall.wheelbase_nominal_m * 1e3:.2f} mm",
    )
    a.set_xlabel("wheelbase b in the odometry [mm]")
    a.set_ylabel("distance of the centre of gravity from the origin, r_cg [mm]")
    a.set_title("(a) trial and error on the wheelbase, cw runs only")
    a.set_ylim(bottom=0)
    a.grid(True, lw=0.3)
    a.legend(fontsize=7, loc="upper center")
    for res, runs, lab, filled in (
        (pitfall.tuned, pitfall.tuned_runs, "b tuned on cw only", False),
        (pitfall.bf, pitfall.bf_runs, "UMBmark + paper's correction", True),
    ):
        for st in (res.cw, res.ccw):
            rows = runs.direction_rows(st.direction)
            sty = _STYLE[st.direction]
            b.scatter(
                rows.eps_x * 1e3,
                rows.eps_y * 1e3,
                marker=sty["marker"],
                s=34,
                facecolors=sty["color"] if filled else "none",
                edgecolors=sty["color"],
                label=f"{st.direction}, {lab} (r_cg = {st.r_cg * 1e3:.0f} mm)",
            )
    b.axhline(0, color="0.6", lw=0.8)
    b.axvline(0, color="0.6", lw=0.8)
    b.set_aspect("equal", adjustable="datalim")
    b.set_xlabel("return position error x [mm]")
    b.set_ylabel("return position error y [mm]")
    b.set_title("(b) the bi-directional test exposes it")
    b.grid(True, lw=0.3)
    b.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=1, frameon=False)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def distribution_figure(
    emax_before_mm: ArrayLike,
    emax_after_mm: ArrayLike,
    emax_final_mm: ArrayLike,
    improvement_final: ArrayLike,
    paper_after_mm: Sequence[float] = (),
    paper_improvement: Sequence[float] = (),
    title: str | None = None,
) -> Figure:
    """Histograms of the study over many seeds: E_max,syst after calibration (first pass and
    final) and the final improvement factor, with the paper's values marked.

    Parameters
    ----------
    emax_before_mm, emax_after_mm, emax_final_mm : array_like
        E_max,syst of every experiment before calibration, after the first pass and final (mm).
    improvement_final : array_like
        Final improvement factor of every experiment (non-finite values are left out).
    paper_after_mm, paper_improvement : sequence of float
        The paper's values, drawn as dashed lines.
    title : str, optional
        The figure's title (default: the number of experiments and the median before).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((12, 4.6))
    a, b = fig.subplots(1, 2)
    after = np.asarray(emax_after_mm, dtype=float).ravel()
    final = np.asarray(emax_final_mm, dtype=float).ravel()
    bins = np.linspace(0, max(80.0, float(np.percentile(after, 99.5))), 41)
    a.hist(after, bins=bins, color="tab:blue", alpha=0.5, label=f"after 1st pass (median {np.median(after):.1f} mm)")
    a.hist(
        final,
        bins=bins,
        histtype="step",
        color="k",
        lw=1.4,
        label=f"final, after rule-driven 2nd pass (median {np.median(final):.1f} mm)",
    )
    for i, v in enumerate(paper_after_mm):
        a.axvline(v, color="tab:red", lw=0.9, ls="--", label="paper, Table I (final)" if i == 0 else None)
    a.axvspan(12, 35, color="tab:red", alpha=0.06)
    a.set_xlabel("E_max,syst after calibration [mm]")
    a.set_ylabel("experiments (all seeds)")
    a.set_title("(a) E_max,syst after calibration")
    a.legend(fontsize=7)
    a.grid(True, lw=0.3)
    imp = np.asarray(improvement_final, dtype=float).ravel()
    imp = imp[np.isfinite(imp)]
    bins = np.logspace(np.log10(max(1.0, imp.min() * 0.9)), np.log10(imp.max() * 1.1), 41)
    b.hist(imp, bins=bins, color="tab:green", alpha=0.6, label=f"simulation (median {np.median(imp):.1f}-fold)")
    for i, v in enumerate(paper_improvement):
        b.axvline(v, color="tab:red", lw=0.9, ls="--", label="paper, Table I" if i == 0 else None)
    b.axvline(10, color="k", lw=1, label="10-fold")
    b.set_xscale("log")
    b.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    b.xaxis.set_minor_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}" if f"{v:g}"[0] in "235" else ""))
    for axis in (a, b):
        axis.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    b.set_xlabel("improvement factor E_max,syst before / final")
    b.set_ylabel("experiments (all seeds)")
    b.set_title("(b) final improvement")
    b.legend(fontsize=7)
    b.grid(True, lw=0.3)
    before = np.asarray(emax_before_mm, dtype=float).ravel()
    fig.suptitle(title or f"{before.size} simulated experiments; E_max,syst before: median {np.median(before):.0f} mm")
    fig.tight_layout()
    return fig
