"""Figures (matplotlib, headless Agg backend). Axes in millimetres, equal aspect."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .benchmark import umbmark  # noqa: E402
from .io.atomic import atomic_path  # noqa: E402
from .runs import RunsTable  # noqa: E402

__all__ = ["scatter_figure", "save_figure", "trajectory_figure"]

_STYLE = {
    "cw": dict(marker="s", color="tab:blue"),
    "ccw": dict(marker="o", color="tab:red"),
}


def _draw_runs(ax, runs: RunsTable, label: str, filled: bool):
    res = umbmark(runs)
    for d, st in (("cw", res.cw), ("ccw", res.ccw)):
        rows = runs.direction_rows(d)
        style = _STYLE[d]
        face = style["color"] if filled else "none"
        ax.scatter(rows.eps_x * 1e3, rows.eps_y * 1e3, marker=style["marker"], facecolors=face,
                   edgecolors=style["color"], s=36, label=f"{d} runs, {label}")
        ax.scatter([st.x_cg * 1e3], [st.y_cg * 1e3], marker="+" if filled else "x", s=260, linewidths=2.2,
                   color=style["color"],
                   label=f"{d} centre of gravity, {label} (r = {st.r_cg * 1e3:.0f} mm)")
    return res


def scatter_figure(before: RunsTable, after: RunsTable | None = None, title: str | None = None):
    """Return-position errors (Eq. 3.1) of the cw and ccw runs with their centres of gravity,
    before (open markers) and after calibration (filled), like the paper's Figs. 6 and 11."""
    fig, ax = plt.subplots(figsize=(8, 9))
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
    ax.text(0.02, 0.98, text, transform=ax.transAxes, va="top", ha="left",
            bbox=dict(boxstyle="round", fc="white", ec="0.7"))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=7, frameon=False)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


def trajectory_figure(trajectories: list[dict], title: str | None = None):
    """True (solid) and odometry (dashed) paths; each item: dict with ``true_x``, ``true_y``,
    ``odo_x``, ``odo_y`` (metres, 1-D) and optional ``label``."""
    fig, ax = plt.subplots(figsize=(7.5, 7.5))
    for i, t in enumerate(trajectories):
        c = f"C{i % 10}"
        lab = t.get("label", f"run {i + 1}")
        ax.plot(np.asarray(t["true_x"]) * 1e3, np.asarray(t["true_y"]) * 1e3, color=c, lw=1.4, label=f"{lab}: true path")
        ax.plot(np.asarray(t["odo_x"]) * 1e3, np.asarray(t["odo_y"]) * 1e3, color=c, lw=1.0, ls="--",
                label=f"{lab}: odometry")
    ax.plot([0], [0], "k*", ms=10, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title or "Trajectories")
    ax.legend(fontsize=7)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


def save_figure(fig, path) -> Path:
    """Save (format from the suffix: .png, .svg, .pdf) atomically and close the figure."""
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=120)
    finally:
        plt.close(fig)
    return path
