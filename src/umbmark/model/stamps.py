"""The stamps and values of a logged stream, message by message: order, repeats and spikes.

* :func:`ordered_stamps`: refuse stamps that go backwards (naming the message), and find the
  messages that repeat the stamp of the one before.
* :func:`in_stamp_order`: a stream put in stamp order, with a warning.
* :func:`wheel_spikes`: samples whose wheel positions jump by more than a wheel can turn
  between two messages (a corrupt message), and whether each is an isolated spike (the next
  sample comes back) or a jump that stays.

Pure numpy: imports only numpy, :mod:`umbmark.errors` and :mod:`umbmark.model.arrival`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from umbmark._check import refusal
from umbmark.errors import InputError
from umbmark.model.arrival import steady_period

__all__ = [
    "MAX_WHEEL_SPEED_MPS",
    "MAX_REORDER_S",
    "MAX_LATE_RUN",
    "MAX_LATE_S",
    "ordered_stamps",
    "in_stamp_order",
    "wheel_spikes",
    "median_period",
    "spikes",
    "spike_kinds",
]

MAX_WHEEL_SPEED_MPS = 30.0
"""A wheel rim faster than this between two samples [m/s] is a corrupt message, not motion."""

MAX_REORDER_S = 0.1
"""Messages stamped up to this much (and five sample periods) before the one received before
them are put in stamp order; a longer step back is an error (a clock that jumped)."""


MAX_LATE_RUN = 3
"""Messages in a row stamped before the ones received before them that are late deliveries (put
in stamp order), not a clock that jumped back."""

MAX_LATE_S = 2.0
"""The most a late delivery is stamped before the messages received before it [s]."""


def _late_stamps_only(t: np.ndarray) -> bool:
    """The messages out of stamp order are single deliveries out of turn, not a clock gone back:
    beside the longest run of the stream in stamp order (its longest non-decreasing
    subsequence), the others come at most :data:`MAX_LATE_RUN` in a row, each stamped within
    :data:`MAX_LATE_S` of the messages received around it."""
    from bisect import bisect_right

    tails: list[float] = []  # the smallest last stamp of an ordered run of each length
    ends: list[int] = []  # ... its message
    prev = np.full(t.size, -1)
    for i, v in enumerate(t.tolist()):
        j = bisect_right(tails, v)
        if j > 0:
            prev[i] = ends[j - 1]
        if j == len(tails):
            tails.append(v)
            ends.append(i)
        else:
            tails[j], ends[j] = v, i
    member = np.zeros(t.size, dtype=bool)
    k = ends[-1]
    while k >= 0:
        member[k] = True
        k = int(prev[k])
    edges = np.diff(np.concatenate([[0], (~member).astype(np.int8), [0]]))
    runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
    if runs.size and runs.max() > MAX_LATE_RUN:
        return False
    idx = np.flatnonzero(member)
    out = np.flatnonzero(~member)
    pos = np.searchsorted(idx, out)  # the ordered messages received around each out of turn
    before = t[idx[np.clip(pos - 1, 0, idx.size - 1)]]
    after = t[idx[np.clip(pos, 0, idx.size - 1)]]
    lag = np.minimum(np.abs(t[out] - before), np.abs(t[out] - after))
    return bool(np.all(lag <= MAX_LATE_S))


def median_period(t: np.ndarray) -> float:
    """The median of a stream's positive gaps [s] (0 without one)."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if d.size else 0.0


def ordered_stamps(
    t: ArrayLike, what: str, topic: str, source: str | None = None
) -> tuple[np.ndarray, int, int, tuple[int, float]]:
    """Check that a stream's stamps do not jump backwards; find the repeated ones.

    Messages a little out of order (each step back shorter than :data:`MAX_REORDER_S` and five
    sample periods: delivered late over a network) are put in stamp order, and so are single
    messages delivered late with the stamp they were made at (at most :data:`MAX_LATE_RUN` in a
    row behind the stamps before them, by at most :data:`MAX_LATE_S`); a longer step back is a
    clock that jumped, an error (the check ``stamp_order``).

    Parameters
    ----------
    t : array_like
        ``(N,)`` stamps [s] in the order the messages were recorded.
    what : str
        What the messages are (``joint states``, ``ground-truth poses``), for messages.
    topic : str
        Their topic, for messages.
    source : str, optional
        The log, for messages.

    Returns
    -------
    keep : numpy.ndarray
        Indices of the messages kept, in stamp order: the last of each run of equal stamps.
    repeated : int
        How many messages repeat the stamp of the one before (not kept).
    first_repeat : int
        The 1-based index of the first such message (0: none).
    reordered : (int, float)
        How many messages were out of order, and the longest step back [s].

    Raises
    ------
    InputError
        A step back longer than that (the message, both stamps, how often and by how much in
        all), or a stamp that is not finite.
    """
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise InputError(f"the {what} on {topic} have a stamp that is not a number at message {k + 1}", source)
    d = np.diff(t)
    back = np.flatnonzero(d < 0)
    order = np.arange(t.size)
    reordered = (0, 0.0)
    if back.size:
        longest = -float(d.min())
        period = max(median_period(t), steady_period(t) or 0.0)  # (a stream in bursts: its rate's)
        if longest > min(MAX_REORDER_S, 5 * period) and not _late_stamps_only(t):
            i = int(back[0])
            err = refusal(
                "stamp_order",
                f"the stamps of the {what} on {topic} go backwards at message {i + 2} of {t.size}: "
                f"{t[i + 1] - t[0]:.6f} s after {t[i] - t[0]:.6f} s (from the first stamp; "
                f"{'once' if back.size == 1 else f'{back.size} times'} in all, by up to {longest:.3f} s): "
                "a clock that jumped back (or messages stamped far out of turn); record with one clock, or cut "
                "the bag there",
                source,
            )
            if err is not None:
                raise err
        order = np.argsort(t, kind="stable")
        reordered = (int(back.size), longest)
    ts = t[order]
    same = np.diff(ts) == 0
    keep = order[np.concatenate([~same, [True]])]
    first = int(order[np.flatnonzero(same)[0] + 1]) + 1 if same.any() else 0
    return keep, int(same.sum()), first, reordered


def wheel_spikes(t: ArrayLike, left: ArrayLike, right: ArrayLike, metres_per_unit: float) -> tuple[np.ndarray, bool]:
    """Samples at which cumulative wheel positions jump faster than a wheel can turn.

    Parameters
    ----------
    t : array_like
        ``(N,)`` increasing stamps [s].
    left, right : array_like
        ``(N,)`` cumulative wheel positions in log units.
    metres_per_unit : float
        Rim travel per log unit [m] (the nominal wheel radius for radians).

    Returns
    -------
    bad : numpy.ndarray
        Indices of the implausible samples: for an isolated spike the sample itself; for a jump
        that stays, the first sample after it.
    isolated : bool
        True when every one is an isolated spike (the samples before and after it agree, so
        dropping it loses nothing).
    """
    pos = np.column_stack([np.asarray(left, dtype=float), np.asarray(right, dtype=float)])
    return spikes(np.asarray(t, dtype=float), pos, metres_per_unit)


def spikes(t: np.ndarray, pos: np.ndarray, metres_per_unit: float) -> tuple[np.ndarray, bool]:
    """:func:`wheel_spikes` of ``(N, J)`` positions (no joint: none)."""
    isolated, stays = spike_kinds(t, pos, metres_per_unit)
    return np.sort(np.concatenate([isolated, stays])), stays.size == 0


def spike_kinds(t: np.ndarray, pos: np.ndarray, metres_per_unit: float) -> tuple[np.ndarray, np.ndarray]:
    """The samples reached faster than :data:`MAX_WHEEL_SPEED_MPS`, by kind.

    Parameters
    ----------
    t : numpy.ndarray
        ``(N,)`` increasing stamps [s].
    pos : numpy.ndarray
        ``(N, J)`` cumulative positions in log units (no joint: none found).
    metres_per_unit : float
        Rim travel per log unit [m].

    Returns
    -------
    isolated : numpy.ndarray
        The isolated spikes: samples whose neighbours agree with each other, or after which the
        next sample comes back to within half the jump of the one before.
    stays : numpy.ndarray
        The first sample after each jump that does not come back.
    """
    none = np.array([], dtype=int)
    if len(t) < 2 or pos.shape[1] == 0:
        return none, none
    dt = np.diff(t)
    with np.errstate(over="ignore", invalid="ignore"):
        speed = np.abs(np.diff(pos, axis=0)).max(axis=1) * metres_per_unit / dt
    fast = ~(speed <= MAX_WHEEL_SPEED_MPS)  # NaN and inf count as fast
    if not fast.any():
        return none, none
    isolated: list[int] = []
    stays: list[int] = []
    n = len(dt)
    i = 0
    while i < n:
        if not fast[i]:
            i += 1
            continue
        k = i + 1  # the sample the fast step leads to
        if k < n and fast[k]:
            with np.errstate(over="ignore", invalid="ignore"):
                across = np.abs(pos[k + 1] - pos[k - 1]).max() * metres_per_unit / (t[k + 1] - t[k - 1])
            if across <= MAX_WHEEL_SPEED_MPS:
                isolated.append(k)
                i += 2
                continue
        if k < n and np.abs(pos[k + 1] - pos[k - 1]).max() < 0.5 * np.abs(pos[k] - pos[k - 1]).max():
            isolated.append(k)  # the next sample comes back (a late message, however slowly)
            i += 2
            continue
        stays.append(k)
        i += 1
    return np.asarray(isolated, dtype=int), np.asarray(stays, dtype=int)


def in_stamp_order(
    t: np.ndarray, values: list[np.ndarray], what: str, topic: str, source: str | None, warnings: list[str]
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, int, int]:
    """The stream put in stamp order (a little out of order: sorted, with a warning; a clock that
    jumped back: an error) and :func:`ordered_stamps`' ``keep``, ``repeated`` and ``first_repeat``."""
    keep, rep, first, (moved, back_s) = ordered_stamps(t, what, topic, source)
    if moved:
        warnings.append(
            f"{moved} of the {t.size} {what} on {topic} arrive out of stamp order (by up to "
            f"{back_s * 1e3:.1f} ms): put in stamp order"
        )
        order = np.argsort(t, kind="stable")
        t, values = t[order], [v[order] for v in values]
        keep, rep, first, _ = ordered_stamps(t, what, topic, source)
    return t, values, keep, rep, first
