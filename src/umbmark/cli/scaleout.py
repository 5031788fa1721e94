"""Shared CLI options for commands that run Monte Carlo sweeps through :mod:`umbmark.studies.sweep`:
``--workers N`` (local processes; default all cores) and ``--dask ADDRESS`` (a Dask scheduler
such as tcp://host:8786, or ``local``). Use ``@scale_options`` on a command; it receives
``workers`` and ``dask``; pass them to ``umbmark.studies.sweep.map(fn, items, workers=..., dask=...)``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

__all__ = ["scale_options"]

F = TypeVar("F", bound=Callable[..., Any])


def scale_options(f: F) -> F:
    """Add ``--workers N`` and ``--dask ADDRESS`` to a command (see the module docstring).

    Parameters
    ----------
    f : callable
        The command function (it receives ``workers`` and ``dask``).

    Returns
    -------
    callable
        ``f`` with the two options.
    """
    f = click.option(
        "--dask",
        "dask",
        metavar="ADDRESS",
        default=None,
        help="Run the sweep on a Dask cluster: a scheduler address (tcp://host:8786) or "
        "'local' (a cluster on the local machine). Needs: pip install -e \".[dask]\".",
    )(f)
    f = click.option(
        "--workers",
        type=click.IntRange(min=1),
        default=None,
        help="Local worker processes for the sweep (default: all cores; 1: no pool).",
    )(f)
    return f
