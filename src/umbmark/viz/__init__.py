"""Figures, reports and text: :mod:`~umbmark.viz.plots` (matplotlib figures made without pyplot),
:mod:`~umbmark.viz.history_plot`, :mod:`~umbmark.viz.report` (self-contained HTML pages),
:mod:`~umbmark.viz.selfcal_report` (the page of a lidar self-calibration: estimates, map,
residuals, the lidar on the robot) and :mod:`~umbmark.viz.text` (the number formatter).

The names below are loaded when first used: importing this package imports no matplotlib.
"""

from __future__ import annotations

from umbmark._lazy import lazy_names

_LAZY = {
    "scatter_figure": "umbmark.viz.plots",
    "trajectory_figure": "umbmark.viz.plots",
    "exaggerated_trajectory_figure": "umbmark.viz.plots",
    "pitfall_figure": "umbmark.viz.plots",
    "distribution_figure": "umbmark.viz.plots",
    "save_figure": "umbmark.viz.plots",
    "history_figure": "umbmark.viz.history_plot",
    "analysis_report": "umbmark.viz.report",
    "history_report": "umbmark.viz.report",
    "figure_data_uri": "umbmark.viz.report",
    "bootstrap_intervals": "umbmark.viz.report",
    "cg_intervals": "umbmark.viz.report",
    "selfcal_page": "umbmark.viz.selfcal_report",
    "is_selfcal_result": "umbmark.viz.selfcal_report",
    "fmt": "umbmark.viz.text",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = lazy_names("umbmark.viz", _LAZY, globals())
