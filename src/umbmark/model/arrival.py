"""Time as recorded: how a stream's messages arrived, and the sample clock behind them.

Real robots do not record their wheel data the way a simulator writes it. A device that samples
at a steady rate often hands its messages to the recorder through a buffer (a serial line, a
wireless link, a busy computer), and the recorder stamps them when they **arrive**: in bursts,
several messages a fraction of a millisecond apart after a pause. Some messages arrive late
(their content is older than their stamp: a message held up, or sent twice), some are recorded
twice, and some are lost. This module finds each of these from the stamps and the content, and
gives back the times at which the device sampled.

* :func:`steady_period`: a stream's sample period from how many messages arrive over long
  windows (robust to bursts, which only move messages within a window).
* :func:`burst_gaps`: the consecutive stamps closer than a fifth of that period.
* :func:`sample_clock`: the sample clock recovered from arrival stamps: the **lower envelope** of
  stamp against message index (the idea of one-way clock synchronisation, TICSync: a message is
  never stamped before it was made, and the device made its messages at least a period apart),
  ``tau_k = min(s_k, tau_{k+1} - p)``. A message on time keeps its stamp; the messages of a
  burst are spread back a period apart from the last of it.
* :func:`late_messages`: runs of messages whose content goes back along the path the robot had
  already travelled while the message after them continues from before them (a late message
  stamped on arrival), and spikes that go out and back to no earlier content (a corrupt
  message). Judged on the content alone, message by message, so bursts do not hide them.

Pure numpy: imports only numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BURST_GAP",
    "MIN_BURST_SHARE",
    "PERIOD_MARGIN",
    "steady_period",
    "burst_gaps",
    "sample_clock",
    "LateRun",
    "late_messages",
    "HEADING_LEVER_M",
]

FloatArray = NDArray[np.float64]

BURST_GAP = 0.2
"""Consecutive stamps closer than this share of the stream's period arrived in one burst."""

MIN_BURST_SHARE = 0.02
"""A stream whose consecutive stamps are this often (and at least ten times) in one burst has
its sample clock recovered; a stream that arrives on time is left as recorded."""

PERIOD_MARGIN = 0.97
"""The spacing the recovered clock gives a burst, as a share of the measured period: the count
of messages over time overestimates the device's period by the share of messages lost, and
below the true period a message that arrives on time is never moved."""

HEADING_LEVER_M = 0.2
"""How far a turn of one radian moves an odometry's content, to compare headings with
positions [m] (the radius of a small robot)."""

_WINDOW = 200  # messages per window of steady_period
_LOCAL = 10  # steps either side of the local scale of late_messages
_MAX_RUN = 8  # the longest run of late messages looked for
_SEARCH = 400  # messages back searched for the content of a late message


def steady_period(t: ArrayLike) -> float | None:
    """A stream's sample period from how many messages arrive over long windows [s].

    Over windows of up to 200 consecutive messages, the window's span over its messages: a
    burst moves messages within a window, not the count of messages in it, while a hole or a
    lost message lengthens it. The period is the tenth percentile of them (the windows with
    the fewest messages lost; a stream on time gives the same in every window). In a stream
    that arrives in bursts the windows then run from the last message of one burst to the last
    of another (the messages that arrive on time, just after they were made), so that the
    delays of the others do not shorten them.

    Parameters
    ----------
    t : array_like
        ``(N,)`` stamps [s], in order.

    Returns
    -------
    float or None
        The period; None with fewer than 20 messages or stamps that do not advance.

    Examples
    --------
    >>> t = 0.1 * (np.arange(100) // 4) * 4  # 10 Hz, arriving four at a time
    >>> round(steady_period(t), 3)
    0.1
    """
    t = np.asarray(t, dtype=float)
    if t.size < 20:
        return None
    w = int(min(_WINDOW, max(10, t.size // 5)))
    spans = (t[w:] - t[:-w]) / w
    p = float(np.percentile(spans, 10))
    if not (p > 0 and np.isfinite(p)):
        return None
    ends = np.flatnonzero(np.diff(t) >= BURST_GAP * p)  # the last message of each burst
    if ends.size >= 0.9 * (t.size - 1):  # on time: every message ends its "burst"
        return p
    far = np.searchsorted(ends, ends + w // 2)
    ok = far < ends.size
    if ok.sum() < 3:
        return p
    a, b = ends[ok], ends[far[ok]]
    q = float(np.percentile((t[b] - t[a]) / (b - a), 10))
    return q if q > 0 and np.isfinite(q) else p


def burst_gaps(t: ArrayLike, period_s: float) -> int:
    """How many consecutive stamps are closer than :data:`BURST_GAP` of ``period_s``.

    Parameters
    ----------
    t : array_like
        ``(N,)`` stamps [s], in order.
    period_s : float
        The stream's period (:func:`steady_period`).

    Returns
    -------
    int
    """
    d = np.diff(np.asarray(t, dtype=float))
    return int(np.count_nonzero(d < BURST_GAP * period_s))


def sample_clock(t: ArrayLike, spacing_s: float) -> FloatArray:
    """The sample clock of a steady stream stamped on arrival: ``tau_k = min(s_k, tau_{k+1} - p)``.

    The latest time each message can have been made at, if no message is stamped before it was
    made and the device made its messages at least ``p`` apart: the lower envelope of stamp
    against message index with slope ``p``. A stream that arrives on time (gaps of ``p`` or
    more) keeps its stamps; a burst is spread back ``p`` apart from its last message.

    Parameters
    ----------
    t : array_like
        ``(N,)`` arrival stamps [s], in order.
    spacing_s : float
        ``p``: the device's spacing (a little under its period: :data:`PERIOD_MARGIN`).

    Returns
    -------
    numpy.ndarray
        ``(N,)`` increasing sample times [s], each at most its stamp.

    Examples
    --------
    >>> sample_clock([0.0, 0.3, 0.3001, 0.3002, 0.4], 0.1)
    array([0. , 0.1, 0.2, 0.3, 0.4])
    """
    s = np.asarray(t, dtype=float)
    if s.size < 2:
        return s.copy()
    k = np.arange(s.size, dtype=float)
    # min over j >= k of (s_j - (j - k) p) = k p + min over j >= k of (s_j - j p)
    u = s - k * spacing_s
    env = np.minimum.accumulate(u[::-1])[::-1]
    return env + k * spacing_s


@dataclass(frozen=True)
class LateRun:
    """Messages whose content does not follow the path (see :func:`late_messages`).

    Attributes
    ----------
    start, stop : int
        The messages ``start`` to ``stop - 1`` (indices into the stream as given).
    before : int
        The message before them, which the one at ``stop`` continues from.
    earlier : int or None
        The earlier message whose content the first of them repeats (a late message); None
        when it repeats nothing (a spike).
    """

    start: int
    stop: int
    before: int
    earlier: int | None

    @property
    def late(self) -> bool:
        """The content is an earlier message's (a late message), not a spike."""
        return self.earlier is not None


def _sided_scales(step: FloatArray) -> tuple[FloatArray, FloatArray]:
    """For each step, the median of the ``_LOCAL`` steps before it and of those after it (the
    motion's scale on either side, without the step itself or its neighbour)."""
    pad = np.pad(step, _LOCAL, mode="edge")
    med = np.median(np.lib.stride_tricks.sliding_window_view(pad, _LOCAL), axis=1)
    ns = step.size
    return np.asarray(med[:ns], dtype=float), np.asarray(med[_LOCAL + 1 : _LOCAL + 1 + ns], dtype=float)


def late_messages(content: ArrayLike) -> list[LateRun]:
    """Runs of messages whose content leaves the path and the message after them continues it.

    Message by message (no stamps, so bursts do not matter), two signatures:

    * **one message off the path**: message ``k`` lies farther from the chord between messages
      ``k - 1`` and ``k + 1`` than that chord is long, and farther than one and a half of the
      steps on its quieter side (the median of the ten before it or of the ten after it, the
      smaller) and than the noise floor (four of the content's resolution, such as an encoder's
      count, and a quarter of its median moving step): on a real path the middle sample of three
      lies near their chord, within the shorter of its two steps;
    * **a run going back**: a step into message ``k`` six times the steps on its busier side (the
      larger median; and above the floor), after which, within :data:`_MAX_RUN` messages, a message comes back to within
      half that distance of message ``k - 1`` and within the few steps of motion the messages
      between them allow.

    The last message, reached by such a long step, is late where its content is an earlier
    message's. Each run's first message is looked for among the 400 before it: where its content is an
    earlier message's (closer to it than a quarter of its distance from message ``k - 1``; the
    latest such message), the run is late; else it is a spike.

    Parameters
    ----------
    content : array_like
        ``(N, D)`` what each message says, in comparable units (cumulative wheel positions; an
        odometry's x, y and heading times :data:`HEADING_LEVER_M`), in stamp order.

    Returns
    -------
    list of LateRun
        In order, not overlapping.

    Examples
    --------
    >>> x = np.arange(50.0)[:, None]
    >>> x[30] = x[20]  # message 30 repeats message 20's content
    >>> late_messages(x)
    [LateRun(start=30, stop=31, before=29, earlier=20)]
    """
    x = np.asarray(content, dtype=float)
    x = x.reshape(x.shape[0], -1)
    if x.shape[0] < 4:
        return []
    with np.errstate(over="ignore", invalid="ignore"):  # a corrupt value of 1e300 is a spike too
        return _late_runs(x)


def _late_runs(x: FloatArray) -> list[LateRun]:
    """:func:`late_messages` of finite ``(N, D)`` content."""
    n = x.shape[0]
    step = np.linalg.norm(np.diff(x, axis=0), axis=1)
    moving = step[step > 0]
    if moving.size < 3:
        return []
    floor = max(4.0 * _granularity(x), 0.25 * float(np.median(moving)))
    before, after = _sided_scales(step)
    dev, chord = _off_chord(x)
    around = np.minimum(before[:-1], after[1:])  # messages 1 .. n-2: the quieter side's steps
    single = (dev > chord) & (dev > 1.5 * around) & (dev > floor)
    busier = np.maximum(before, after)  # a long step: long against both sides (not a robot speeding up)
    far = np.flatnonzero(step > np.maximum(6.0 * busier, floor)) + 1  # messages reached by a long step
    runs: list[LateRun] = []
    for c in np.union1d(np.flatnonzero(single) + 1, far):
        k = int(c)
        if runs and k < runs[-1].stop + 1:
            continue
        if k < n - 1 and single[k - 1]:
            run: LateRun | None = LateRun(k, k + 1, k - 1, _earlier(x, k, k - 1))
        else:
            run = _run_from(x, k, busier, floor)
        if run is not None:
            runs.append(run)
    if far.size and far[-1] == n - 1 and not (runs and runs[-1].stop >= n - 1):
        last = _earlier(x, n - 1, n - 2)  # the last message: late only where its content is earlier
        if last is not None:
            runs.append(LateRun(n - 1, n, n - 2, last))
    return runs


def _granularity(x: FloatArray) -> float:
    """The content's resolution: the largest over its columns of the count an encoder's column
    changes by (each change a whole number of its smallest); 0 for values that are not counts."""
    out = 0.0
    for col in np.abs(np.diff(x, axis=0)).T:
        nz = col[col > 0]
        if nz.size < 3:
            continue
        q = float(nz.min())
        ratio = nz / q
        if np.mean(np.abs(ratio - np.round(ratio)) < 0.01) > 0.9:
            out = max(out, q)
    return out


def _off_chord(x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """For messages 1 to N-2: the distance of each from the segment between its neighbours, and
    that segment's length."""
    a, m, b = x[:-2], x[1:-1], x[2:]
    ab = b - a
    chord2 = np.einsum("ij,ij->i", ab, ab)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(chord2 > 0, np.einsum("ij,ij->i", m - a, ab) / chord2, 0.0)
    foot = a + np.clip(u, 0.0, 1.0)[:, None] * ab
    return np.linalg.norm(m - foot, axis=1), np.sqrt(chord2)


def _run_from(x: FloatArray, k: int, busier: FloatArray, floor: float) -> LateRun | None:
    """The run of late messages starting at ``k`` (reached by a long step from ``k - 1``), if one."""
    n = x.shape[0]
    f = k - 1
    out = np.linalg.norm(x[k : min(n, k + _MAX_RUN)] - x[f], axis=1)
    scale = max(float(busier[f]), floor / 4.0)
    for m in range(k + 1, min(n, k + _MAX_RUN + 1)):
        back = float(np.linalg.norm(x[m] - x[f]))
        away = float(out[: m - k].min())
        if back <= 0.5 * away and back <= 3.0 * (m - f) * scale + floor:
            return LateRun(k, m, f, _earlier(x, k, f))
    return None


def _earlier(x: FloatArray, k: int, f: int) -> int | None:
    """The latest earlier message (among the ``_SEARCH`` before ``f``) whose content message ``k``
    repeats: within a quarter of its distance from message ``f`` and twice the closest match."""
    lo = max(0, f - _SEARCH)
    if f - lo < 1:
        return None
    d = np.linalg.norm(x[lo:f] - x[k], axis=1)
    jump = float(np.linalg.norm(x[k] - x[f]))
    if not (np.isfinite(jump) and np.isfinite(d.min())):
        return None
    close = np.flatnonzero((d <= 0.25 * jump) & (d <= 2.0 * float(d.min()) + 1e-12 * jump))
    return lo + int(close[-1]) if close.size else None
