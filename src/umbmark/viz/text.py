"""Numbers as text: the one formatter of every table, report and summary umbmark writes."""

from __future__ import annotations

import math

__all__ = ["fmt", "interval95"]


def fmt(value: float | None, digits: int = 1, unit: str = "", *, spec: str = "f", scale: float = 1.0) -> str:
    """A number as text with a fixed number of digits, or ``"-"`` when there is none.

    Parameters
    ----------
    value : float, int or None
        The number. ``None``, NaN and infinities are shown as ``"-"``.
    digits : int
        Digits after the decimal point (``spec="f"``) or significant digits (``spec="g"``).
    unit : str
        Appended to the number as it is (e.g. ``" mm"``); not appended to ``"-"``.
    spec : str
        The format type: ``"f"`` (fixed point) or ``"g"`` (general).
    scale : float
        ``value`` is divided by it first (e.g. ``1e6`` to show millions).

    Returns
    -------
    str
        For example ``fmt(327.41) == "327.4"``, ``fmt(1.0009561, 6) == "1.000956"``,
        ``fmt(0.000123, 2, spec="g") == "0.00012"``, ``fmt(None) == "-"``.
    """
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value / scale if scale != 1.0 else value:.{digits}{spec}}{unit}"


def interval95(d: object, key: str) -> tuple[float, float] | None:
    """The 95 % interval ``d[key]`` of a result's JSON as ``(low, high)``, or None when it holds
    none (missing, not two numbers).

    Parameters
    ----------
    d : dict
        The JSON object (anything else holds none).
    key : str
        The interval's key, e.g. ``"Ed_ci95"``.

    Returns
    -------
    tuple of float or None
    """
    v = d.get(key) if isinstance(d, dict) else None
    if isinstance(v, (list, tuple)) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
        return float(v[0]), float(v[1])
    return None
