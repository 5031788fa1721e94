"""Argument checks every layer shares: a number that must be positive (or non-negative), finite;
and the plausibility checks of recorded data that a user may skip.

One place for the rule and its message: ``NAME must be a positive number, got VALUE``. ``NAME``
is given as the message should show it: a library parameter in backticks (```wheelbase_m```,
which the command line turns into its flag), a flag (``--side-mm``), or a key of a file
(``'wheelbase_mm'``). Booleans are not numbers here; numpy scalars are.

**Skippable checks.** A check of recorded data that refuses it (the wheels moving 57 times as
far as the lidar sees: degrees) judges from evidence, and a working robot's odd recording could
still trip it. Each such check has a name in :data:`CHECKS`; its refusal
(:func:`refusal`) names the check and says that ``skip_checks=NAME`` overrides it (the
command line's ``--skip-check NAME``); inside :func:`skipping_checks` the named checks let the
data through.

Imports :mod:`umbmark.errors` only.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from umbmark.errors import InputError

__all__ = ["positive", "positive_or_none", "CHECKS", "refusal", "skipping_checks", "skipped"]

CHECKS: dict[str, str] = {
    "stamp_order": "a stream's stamps go back for longer than a late message (a clock that jumped back)",
    "wheel_units": "the wheels' travel or turn against the lidar's at another scale (another unit)",
    "turn_direction": "the lidar turning against the wheels (a lidar upside down, wheels exchanged)",
    "joint_order": "the joints moving the robot as the lidar sees it only in another order or role",
    "degree_turns": "the wheels turning 57.3 times as far as the ground truth (angles in degrees)",
    "running_counters": "counts per message that move as a running counter does",
    "scan_units": "lidar ranges in millimetres or centimetres",
}
"""The plausibility checks of recorded data that may be skipped, by name: what each refuses."""

_SKIPPED: ContextVar[frozenset[str]] = ContextVar("umbmark_skipped_checks", default=frozenset())


def positive(
    name: str, value: Any, *, allow_zero: bool = False, allow_inf: bool = False, source: str | None = None
) -> float:
    """``value`` as a float, or an :class:`~umbmark.errors.InputError` naming ``name``.

    Parameters
    ----------
    name : str
        The argument, as the message names it.
    value : Any
        The value.
    allow_zero : bool
        0 passes (non-negative).
    allow_inf : bool
        Infinity passes.
    source : str, optional
        The file or log the value came from, for the message.

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not a real number (None, a boolean, text), NaN, infinite (unless ``allow_inf``), or not
        above 0 (at least 0 with ``allow_zero``).
    """
    v = math.nan
    if value is not None and not isinstance(value, (bool, str, bytes)):
        try:
            v = float(value)  # ints, floats and numpy's scalars
        except (TypeError, ValueError, OverflowError):
            v = math.nan
    if not ((v >= 0 if allow_zero else v > 0) and (allow_inf or math.isfinite(v))):
        kind = "non-negative" if allow_zero else "positive"
        raise InputError(f"{name} must be a {kind} number, got {value!r}", source)
    return v


def positive_or_none(
    name: str, value: Any, *, allow_zero: bool = False, allow_inf: bool = False, source: str | None = None
) -> float | None:
    """None passes; anything else as :func:`positive`.

    Returns
    -------
    float or None
    """
    if value is None:
        return None
    return positive(name, value, allow_zero=allow_zero, allow_inf=allow_inf, source=source)


@contextmanager
def skipping_checks(names: Iterable[str]) -> Iterator[None]:
    """Within this block, the named checks (:data:`CHECKS`) let the data through.

    Parameters
    ----------
    names : iterable of str
        Check names.

    Raises
    ------
    InputError
        A name that is no check (the message lists them).
    """
    given = frozenset(names)
    unknown = sorted(given - set(CHECKS))
    if unknown:
        raise InputError(f"`skip_checks`: no check named {', '.join(map(repr, unknown))} (checks: {', '.join(CHECKS)})")
    token = _SKIPPED.set(_SKIPPED.get() | given)
    try:
        yield
    finally:
        _SKIPPED.reset(token)


def skipped(check: str) -> bool:
    """Whether the named check is skipped here (:func:`skipping_checks`)."""
    return check in _SKIPPED.get()


def refusal(check: str, message: str, source: str | None = None) -> InputError | None:
    """The refusal of a skippable check, naming it and its override; None where it is skipped.

    Parameters
    ----------
    check : str
        The check's name (a key of :data:`CHECKS`).
    message : str
        What the data show and its likely cause.
    source : str, optional
        The recording.

    Returns
    -------
    InputError or None
        Raise it; None: the check is skipped, go on with the data.
    """
    assert check in CHECKS, check
    if skipped(check):
        return None
    return InputError(
        f"{message} (the check {check}; if the recording is right, `skip_checks={check}` lets it through)", source
    )
