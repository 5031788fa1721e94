"""The registry of correction methods for square runs.

A method is a callable ``fn(runs, side_m, wheelbase_m, prior=None, **options)`` returning a
:class:`~umbmark.correct.result.CorrectionResult`; modules register theirs with
:func:`register`.
"""

from __future__ import annotations

from umbmark.errors import InputError

METHODS: dict = {}


def register(name: str):
    def deco(fn):
        METHODS[name] = fn
        return fn

    return deco


def correct_runs(method: str, runs, side_m: float, wheelbase_m: float, prior=None, **options):
    """Estimate a calibration from square runs with the named method."""
    try:
        fn = METHODS[method]
    except KeyError:
        raise InputError(f"unknown method {method!r} (choose from {', '.join(sorted(METHODS))})") from None
    return fn(runs, side_m, wheelbase_m, prior, **options)
