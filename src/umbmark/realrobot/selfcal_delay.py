"""The delay of a recording's scan stamps behind its wheel data: the result (:class:`ScanDelay`), the
search that lines the wheels' turns up with the matched ones (:func:`delay_from_turns`), and a
delay as a user gives it (:func:`parse_scan_delay`). The estimate from a bag's matches is
:func:`umbmark.realrobot.selfcal_match.estimate_scan_delay`.

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports these
names). Imports numpy and :mod:`umbmark.errors`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark._numbers import strict_float
from umbmark.errors import InputError

__all__ = ["SCAN_DELAY_SEARCH_S", "MAX_SCAN_DELAY_S", "ScanDelay", "delay_from_turns", "parse_scan_delay"]

SCAN_DELAY_SEARCH_S = 0.3
"""How far either way the scans' delay is searched [s] (:func:`estimate_scan_delay`)."""

MAX_SCAN_DELAY_S = 1.0
"""The largest scan delay accepted when given [s]: a scan is stamped within a sweep of when it was
taken, and more points to milliseconds given as seconds."""

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ScanDelay:
    """The delay of the scans' stamps behind the wheel data's clock (:func:`estimate_scan_delay`).

    Parameters
    ----------
    delay_s : float
        The estimate [s]: a scan stamped ``t`` was taken when the wheel data say ``t - delay_s``.
    correlation : float
        Correlation of the scan-matched turns with the wheels' turns at that delay.
    correlation_at_zero : float
        The same with the stamps as recorded.
    pairs : int
        Matched scan pairs it was estimated from.
    search_s : float
        The delays searched: ``-search_s`` to ``search_s`` [s].
    """

    delay_s: float
    correlation: float
    correlation_at_zero: float
    pairs: int
    search_s: float

    def to_dict(self) -> dict[str, Any]:
        """As JSON.

        Returns
        -------
        dict
            ``delay_s``, ``correlation``, ``correlation_at_zero``, ``pairs``, ``search_s``.
        """
        return {
            "delay_s": self.delay_s,
            "correlation": self.correlation,
            "correlation_at_zero": self.correlation_at_zero,
            "pairs": self.pairs,
            "search_s": self.search_s,
        }


def delay_from_turns(
    wt: FloatArray,
    heading: FloatArray,
    ta: FloatArray,
    tb: FloatArray,
    turn: FloatArray,
    around_s: float,
    *,
    search_s: float = SCAN_DELAY_SEARCH_S,
    step_s: float = 0.005,
    source: str | None = None,
) -> ScanDelay:
    """The delay of the scans' stamps that best lines the wheels' turns up with the matched ones
    (the method of :func:`estimate_scan_delay`).

    Parameters
    ----------
    wt, heading : numpy.ndarray
        ``(W,)`` the wheel data's stamps and the heading they make [rad].
    ta, tb : numpy.ndarray
        ``(K,)`` the stamps of each matched pair's scans [s].
    turn : numpy.ndarray
        ``(K,)`` the matched turns [rad].
    around_s : float
        The centre of the delays searched [s].
    search_s, step_s : float
        The largest delay searched either way from ``around_s``, and the grid step [s].
    source : str, optional
        For messages.

    Returns
    -------
    ScanDelay

    Raises
    ------
    InputError
        The wheels do not turn between the matched scans.
    """
    n = int(math.floor(search_s / step_s + 1e-9))
    grid = around_s + np.arange(-n, n + 1) * step_s

    def corr(d: float) -> float:
        o = np.interp(tb - d, wt, heading) - np.interp(ta - d, wt, heading)
        if not np.any(o):
            return math.nan
        return float(np.corrcoef(o, turn)[0, 1])

    c = np.array([corr(float(d)) for d in grid])
    if not np.any(np.isfinite(c)):
        raise InputError("the wheels do not turn between the matched scans: no delay to estimate", source)
    k = int(np.nanargmax(c))
    best = float(grid[k])
    if 0 < k < len(grid) - 1 and np.all(np.isfinite(c[k - 1 : k + 2])):
        den = c[k - 1] - 2 * c[k] + c[k + 1]
        if den < 0:
            best += float(0.5 * (c[k - 1] - c[k + 1]) / den * step_s)
    return ScanDelay(best + 0.0, corr(best), corr(0.0), len(turn), float(search_s))


def parse_scan_delay(value: float | str | None) -> float | str:
    """``auto`` or a delay in seconds, from what a user gives (``None``: auto; ``off``: 0).

    Parameters
    ----------
    value : float, str or None
        ``auto``, ``off``/``none`` (the stamps as recorded), or seconds.

    Returns
    -------
    float or str
        ``"auto"`` or the delay [s].

    Raises
    ------
    InputError
        Anything else, or a delay beyond :data:`MAX_SCAN_DELAY_S`.
    """
    if value is None:
        return "auto"
    if isinstance(value, str):
        v = value.strip().lower()
        if v == "auto":
            return "auto"
        if v in ("off", "none"):
            return 0.0
        try:
            value = strict_float(v)
        except ValueError:
            raise InputError(f"`scan_delay` must be auto, off or seconds, got {value!r}") from None
    if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value)):
        raise InputError(f"`scan_delay` must be auto, off or seconds, got {value!r}")
    if abs(value) > MAX_SCAN_DELAY_S:
        raise InputError(
            f"`scan_delay` {value:g} s is beyond +-{MAX_SCAN_DELAY_S:g} s: a scan is stamped within a sweep of "
            "when it was taken (is it in milliseconds?)"
        )
    return float(value)
