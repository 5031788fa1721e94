"""Progress bars for commands that take more than a second.

Drawn with rich on stderr, only when stderr is a terminal and ``--quiet`` is not given;
otherwise the helpers do nothing (so pipes, files and tests see no bar)::

    from umbmark.cli.progress import progress, track

    with progress("simulating", total=n) as advance:
        for i in range(n):
            ...
            advance()

    for item in track(items, "reading bags"):
        ...
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator, Sized
from contextlib import contextmanager
from typing import TYPE_CHECKING, TypeVar

from umbmark.cli.app import is_quiet

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["progress", "track", "progress_enabled"]

T = TypeVar("T")


def _console() -> Console:
    from rich.console import Console

    return Console(stderr=True, emoji=False)


def progress_enabled(console: Console | None = None) -> bool:
    """True when a bar would be drawn: stderr is a terminal and not --quiet.

    Parameters
    ----------
    console : rich.console.Console, optional
        The console the bar would use (default: one on stderr).

    Returns
    -------
    bool
    """
    c = console or _console()
    return c.is_terminal and not is_quiet()


@contextmanager
def progress(description: str, total: int | None = None) -> Iterator[Callable[..., None]]:
    """A bar (or a spinner when ``total`` is None) on stderr while the block runs.

    Parameters
    ----------
    description : str
        Shown beside the bar.
    total : int, optional
        Steps of the work.

    Yields
    ------
    callable
        ``advance(n=1)``: the work moved on by ``n`` steps (does nothing when no bar is drawn).
    """
    c = _console()
    if not progress_enabled(c):
        yield lambda n=1: None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    cols = [SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()]
    # rich would send whatever the command prints on stdout meanwhile through the bar's console
    # (stderr): only do that when stdout is the same kind of screen, never into a pipe or file
    with Progress(*cols, console=c, transient=True, redirect_stdout=_stdout_is_terminal(), redirect_stderr=False) as p:
        task = p.add_task(description, total=total)
        yield lambda n=1: p.advance(task, n)


def _stdout_is_terminal() -> bool:
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):
        return False


def track(iterable: Iterable[T], description: str, total: int | None = None) -> Iterator[T]:
    """Iterate with a progress bar (see :func:`progress`).

    Parameters
    ----------
    iterable : iterable
        The items.
    description : str
        Shown beside the bar.
    total : int, optional
        Number of items (default: ``len(iterable)`` when it has one).

    Yields
    ------
    object
        The items of ``iterable``.
    """
    if total is None and isinstance(iterable, Sized):
        total = len(iterable)
    with progress(description, total) as advance:
        for item in iterable:
            yield item
            advance()
