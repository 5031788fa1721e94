"""Argument checks every layer shares: a number that must be positive (or non-negative), finite.

One place for the rule and its message: ``NAME must be a positive number, got VALUE``. ``NAME``
is given as the message should show it: a library parameter in backticks (```wheelbase_m```,
which the command line turns into its flag), a flag (``--side-mm``), or a key of a file
(``'wheelbase_mm'``). Booleans are not numbers here; numpy scalars are.

Imports :mod:`umbmark.errors` only.
"""

from __future__ import annotations

import math
from typing import Any

from umbmark.errors import InputError

__all__ = ["positive", "positive_or_none"]


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
