"""Figures, reports and text: :mod:`~umbmark.viz.plots` (matplotlib figures made without pyplot),
:mod:`~umbmark.viz.history_plot`, :mod:`~umbmark.viz.report` (self-contained HTML pages) and
:mod:`~umbmark.viz.text` (the number formatter). Importing this package imports none of them."""

__all__: list[str] = []
