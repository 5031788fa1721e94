"""A log's wheel data checked once, as real robots record them: order, repeats, bursts, late
messages, spikes, counter resets and positions wrapped to one turn.

:func:`check_joint_stream` (any number of joints) and :func:`check_wheel_stream` (two wheels)
are what every reader of wheel data runs on them. In this order:

1. **Stamp order** (:func:`umbmark.model.stamps.ordered_stamps`): messages a little out of
   order are put in stamp order with a warning; a clock that jumped back is an error.
2. **Values** not finite: an error naming the message.
3. **Arrival bursts** (:mod:`umbmark.model.arrival`): a stream whose consecutive stamps are
   often far closer than its rate allows was stamped on arrival. Messages recorded twice (same
   stamp, same content) are dropped; the others of one stamp are distinct samples.
   Otherwise repeated stamps keep the last message (incremental counts add up).
4. **Late messages** (cumulative positions): content that goes back along the path while the
   next message continues from before it, a message stamped on arrival long after it was made,
   is dropped; so is a spike that goes out and back to no earlier content.
5. **Sample clock**: a stream in bursts gets the times its device sampled at back (the lower
   envelope of stamp against message index, :func:`umbmark.model.arrival.sample_clock`), kept
   at the recorded stamps' mean (a stream's constant delay is not in its stamps: the clock keeps
   the recording's, so that the scans' delay against it holds against the stamps as recorded).
6. **Running counters** read as increments: an error.
7. **Jumps faster than any wheel** (:data:`umbmark.model.stamps.MAX_WHEEL_SPEED_MPS`): an
   isolated spike is dropped; a jump that stays (a counter reset, an odometry started again)
   cuts the stream there and the longer part is used, with a warning.
8. **Positions wrapped to one turn** are unwrapped, with a warning.

What was done is in :class:`StreamReport` (rate, bursts, messages dropped and why), for the
commands' tables and JSON.

Pure numpy: imports only numpy, :mod:`umbmark.errors` and the model's stamp modules.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from umbmark._check import refusal
from umbmark.errors import InputError
from umbmark.model.arrival import (
    HEADING_LEVER_M,
    MIN_BURST_SHARE,
    PERIOD_MARGIN,
    burst_gaps,
    late_messages,
    sample_clock,
    steady_period,
)
from umbmark.model.stamps import MAX_WHEEL_SPEED_MPS, in_stamp_order, ordered_stamps, spike_kinds

__all__ = ["StreamReport", "WheelStream", "JointStream", "check_wheel_stream", "check_joint_stream"]


@dataclass
class StreamReport:
    """What the check of a wheel stream found and did (see :func:`check_joint_stream`).

    Attributes
    ----------
    what, topic : str
        The messages and their topic.
    messages : int
        Messages as recorded.
    kept : int
        Samples kept.
    rate_hz : float or None
        The stream's steady rate (messages per second over long windows).
    burst_gaps : int
        Consecutive stamps closer than a fifth of the period (arrivals in bursts).
    clock : str
        ``"as recorded"``, or ``"recovered"`` (a stream in bursts: each message's sample time
        from the lower envelope of its arrival stamps).
    clock_shift_max_s, clock_shift_median_s : float
        How far the recovered clock moved the stamps back: the most, and the median over the
        messages it moved [s].
    clock_moved : int
        Messages whose time the recovered clock moved.
    clock_anchor_s : float
        The recovered clock is the lower envelope moved later by this (the mean of the shifts),
        so that on average it keeps the recorded stamps: a delay of another stream measured
        against it (the scans') holds against the stamps as recorded too [s].
    reordered : int
        Messages put in stamp order.
    duplicates : int
        Messages that repeat the one before (same stamp, same content: recorded twice): dropped.
    repeated_stamps : int
        Messages of a stream on time that repeat the stamp before (the last kept; incremental
        counts added up).
    late : int
        Messages whose content is older than their stamp: dropped.
    late_max_age_s : float
        The oldest such content, against the message before it [s].
    spikes : int
        Messages that jump out and back to no earlier content: dropped.
    resets : int
        Jumps that stay (faster than any wheel turns): the stream is cut at them.
    kept_span_s : tuple of float or None
        Where there were resets: the part used, from and to [s after the first stamp].
    wrapped : bool
        Positions wrapped to one turn, unwrapped.
    """

    what: str
    topic: str
    messages: int
    kept: int = 0
    rate_hz: float | None = None
    burst_gaps: int = 0
    clock: str = "as recorded"
    clock_shift_max_s: float = 0.0
    clock_shift_median_s: float = 0.0
    clock_moved: int = 0
    clock_anchor_s: float = 0.0
    reordered: int = 0
    duplicates: int = 0
    repeated_stamps: int = 0
    late: int = 0
    late_max_age_s: float = 0.0
    spikes: int = 0
    resets: int = 0
    kept_span_s: tuple[float, float] | None = None
    wrapped: bool = False

    @property
    def dropped(self) -> int:
        """Messages not used: duplicates, late, spikes, the part cut off at a reset."""
        return self.messages - self.kept

    def to_dict(self) -> dict:
        """The JSON block ``wheel_stream``: every attribute (the kept span as ``[from, to]``)."""
        return {
            "topic": self.topic,
            "what": self.what,
            "messages": self.messages,
            "kept": self.kept,
            "rate_hz": None if self.rate_hz is None else round(self.rate_hz, 6),
            "burst_gaps": self.burst_gaps,
            "clock": self.clock,
            "clock_moved": self.clock_moved,
            "clock_shift_max_s": round(self.clock_shift_max_s, 6),
            "clock_shift_median_s": round(self.clock_shift_median_s, 6),
            "clock_anchor_s": round(self.clock_anchor_s, 6),
            "reordered": self.reordered,
            "duplicates": self.duplicates,
            "repeated_stamps": self.repeated_stamps,
            "late": self.late,
            "late_max_age_s": round(self.late_max_age_s, 6),
            "spikes": self.spikes,
            "resets": self.resets,
            "kept_span_s": None if self.kept_span_s is None else list(self.kept_span_s),
            "wrapped": self.wrapped,
        }

    @classmethod
    def from_dict(cls, d: dict) -> StreamReport:
        """The report back from its JSON block (:meth:`to_dict`); keys it does not know are ignored."""
        known = {f.name for f in fields(cls)}
        kw = {k: v for k, v in d.items() if k in known}
        if kw.get("kept_span_s") is not None:
            kw["kept_span_s"] = tuple(kw["kept_span_s"])
        return cls(**kw)

    def summary(self) -> str:
        """One line for a command's table: the rate, and what was done about the timing."""
        rate = f"{self.rate_hz:.1f} Hz" if self.rate_hz else "rate unknown"
        parts = [f"{self.kept} of {self.messages} messages used, {rate}"]
        if self.clock == "recovered":
            share = self.burst_gaps / max(self.messages - 1, 1)
            parts.append(
                f"arriving in bursts ({100 * share:.0f} % of the gaps under a fifth of the period): the sample "
                f"clock recovered ({self.clock_moved} stamps moved back, by {1e3 * self.clock_shift_median_s:.0f} ms "
                f"median, {1e3 * self.clock_shift_max_s:.0f} ms at most)"
            )
        for n, text in (
            (self.duplicates, "repeated (the same stamp and content)"),
            (self.late, f"late (content up to {self.late_max_age_s:.2f} s older than the stamp)"),
            (self.spikes, "spikes"),
        ):
            if n:
                parts.append(f"{n} {text} dropped")
        if self.resets and self.kept_span_s is not None:
            a, b = self.kept_span_s
            parts.append(f"cut at {self.resets} reset(s): {a:.1f} to {b:.1f} s used")
        return "; ".join(parts)


@dataclass(frozen=True)
class WheelStream:
    """A log's wheel data, checked (see :func:`check_wheel_stream`).

    Attributes
    ----------
    t : numpy.ndarray
        ``(K,)`` the sample times kept, in time order [s] (a stream in bursts: recovered).
    left, right : numpy.ndarray
        ``(K,)`` the cumulative positions kept (log units; incremental counts summed).
    warnings : tuple of str
        What was found and done (messages put in order, repeated stamps, bursts, late messages,
        wrapped positions unwrapped, spikes dropped, a reset cut).
    kept : numpy.ndarray or None
        ``(K,)`` the index of each sample kept in the stream as given (of incremental counts
        added up at one stamp, the last).
    report : StreamReport or None
        What was found and done, as figures.
    """

    t: np.ndarray
    left: np.ndarray
    right: np.ndarray
    warnings: tuple[str, ...] = ()
    kept: np.ndarray | None = None
    report: StreamReport | None = None


def check_wheel_stream(
    t,
    left,
    right,
    *,
    metres_per_unit: float,
    cumulative: bool = True,
    wrapped_turn: float | None = None,
    poses: bool = False,
    heading=None,
    what: str = "wheel positions",
    topic: str = "the wheel topic",
    source: str | None = None,
) -> WheelStream:
    """Check the stamps and values of a log's wheel data (every reader's one check of them).

    The steps of :func:`check_joint_stream` on two rolling joints.

    Parameters
    ----------
    t, left, right : array_like
        Wheel stamps [s] as recorded and the positions (cumulative, or incremental counts, in
        log units).
    metres_per_unit : float
        Rim travel per log unit [m] (the larger wheel's, nominal geometry).
    cumulative : bool
        The positions are cumulative (else per-message increments).
    wrapped_turn : float, optional
        One turn in log units, where the positions may be wrapped to one turn.
    poses : bool
        ``left`` and ``right`` are the x and y [m] of an odometry's poses (its spikes: the
        robot faster than :data:`MAX_WHEEL_SPEED_MPS`; ``metres_per_unit`` 1).
    heading : array_like, optional
        The odometry's heading [rad] with ``poses`` (part of the content late messages are
        judged on).
    what, topic : str
        Names for messages.
    source : str, optional
        The log, for messages.

    Returns
    -------
    WheelStream

    Raises
    ------
    InputError
        Stamps that go backwards, running counters read as increments, non-finite values,
        nothing left.
    """
    pos = np.column_stack([np.asarray(left, dtype=float).reshape(-1), np.asarray(right, dtype=float).reshape(-1)])
    chk = check_joint_stream(
        t,
        pos,
        (True, True),
        metres_per_unit=metres_per_unit,
        cumulative=cumulative,
        wrapped_turn=wrapped_turn,
        poses=poses,
        heading=heading,
        what=what,
        topic=topic,
        source=source,
    )
    return WheelStream(chk.t, chk.positions[:, 0], chk.positions[:, 1], chk.warnings, chk.kept, chk.report)


@dataclass(frozen=True)
class JointStream:
    """A log's joint data, checked (see :func:`check_joint_stream`).

    Attributes
    ----------
    t : numpy.ndarray
        ``(K,)`` the sample times kept, in time order [s].
    positions : numpy.ndarray
        ``(K, J)`` the positions kept (rolling joints cumulative, incremental counts summed).
    warnings : tuple of str
        What was found and done.
    kept : numpy.ndarray
        ``(K,)`` the index of each sample kept in the stream as given.
    report : StreamReport or None
        What was found and done, as figures.
    """

    t: np.ndarray
    positions: np.ndarray
    warnings: tuple[str, ...]
    kept: np.ndarray
    report: StreamReport | None = None


@dataclass
class _Stream:
    """The stream while it is checked: stamps, values, indices into the stream as given."""

    t: np.ndarray
    pos: np.ndarray
    kept: np.ndarray
    heading: np.ndarray | None

    def take(self, ok: np.ndarray) -> None:
        self.t, self.pos, self.kept = self.t[ok], self.pos[ok], self.kept[ok]
        if self.heading is not None:
            self.heading = self.heading[ok]


def check_joint_stream(
    t,
    positions,
    rolling,
    *,
    metres_per_unit: float,
    cumulative: bool = True,
    wrapped_turn: float | None = None,
    poses: bool = False,
    heading=None,
    what: str = "joint positions",
    topic: str = "the joint topic",
    source: str | None = None,
) -> JointStream:
    """Check the stamps and values of any number of joints (the steps of the module's docstring).

    Stamp order, repeated stamps, bursts and finite values concern every joint; running
    counters, late messages, spikes, resets and wrapped turns the rolling ones (a steering joint
    holds an angle).

    Parameters
    ----------
    t : array_like
        ``(K,)`` stamps [s] as recorded.
    positions : array_like
        ``(K, J)`` the joints' values (log units).
    rolling : sequence of bool
        ``(J,)`` which joints roll (a wheel) rather than hold an angle (a steering joint).
    metres_per_unit, cumulative, wrapped_turn, poses, heading, what, topic, source
        As for :func:`check_wheel_stream`.

    Returns
    -------
    JointStream

    Raises
    ------
    InputError
        As :func:`check_wheel_stream`.
    """
    warnings: list[str] = []
    t = np.asarray(t, dtype=float)
    pos = np.asarray(positions, dtype=float).reshape(t.size, -1)
    roll = np.asarray(rolling, dtype=bool)
    hd = None if heading is None else np.asarray(heading, dtype=float).reshape(-1)
    rep = StreamReport(what, topic, int(t.size))
    values = [pos, np.arange(t.size)] + ([hd] if hd is not None else [])
    t, values, _, _, _ = in_stamp_order(t, values, what, topic, source, warnings)
    rep.reordered = int(np.count_nonzero(np.diff(values[1]) < 0))
    s = _Stream(t, values[0], values[1], values[2] if hd is not None else None)
    _refuse_not_finite(s, what, topic, source)
    _drop_twice(s, rep, warnings)
    period, bursty = _rate(s.t, rep)
    wheels_at = np.flatnonzero(roll)
    if cumulative and wheels_at.size and _drop_late(s, wheels_at, wrapped_turn, poses, bursty, period, rep, warnings):
        period, bursty = _rate(s.t, rep)
    keep, nrep, first, _ = ordered_stamps(s.t, what, topic, source)
    if nrep:
        _repeated_stamps(s, keep, nrep, int(s.kept[first - 1]) + 1, bursty, cumulative, rep, warnings)
    raw_t = s.t
    if bursty and period is not None:
        tau = sample_clock(raw_t, PERIOD_MARGIN * period)
        _clock_note(raw_t, tau, rep, warnings)
        s.t = tau + rep.clock_anchor_s
    wheels = s.pos[:, roll]
    if not cumulative:
        wheels = _summed(s.t, wheels, metres_per_unit, what, topic, source)
    wheels = _jumps(s, wheels, metres_per_unit, cumulative, poses, rep, warnings, source)
    if wrapped_turn is not None and s.t.size > 1:
        wheels = _unwrapped(wheels, wrapped_turn, rep, warnings)
    out = s.pos.copy()
    out[:, roll] = wheels
    rep.kept = int(s.t.size)
    return JointStream(s.t, out, tuple(warnings), s.kept, rep)


def _rate(t: np.ndarray, rep: StreamReport) -> tuple[float | None, bool]:
    """The stream's steady period, and whether it arrives in bursts (both noted in ``rep``)."""
    period = steady_period(t)
    rep.rate_hz = None if period is None else 1.0 / period
    if period is None:
        return None, False
    rep.burst_gaps = burst_gaps(t, period)
    return period, rep.burst_gaps >= max(10, MIN_BURST_SHARE * (t.size - 1))


def _refuse_not_finite(s: _Stream, what: str, topic: str, source: str | None) -> None:
    ok = np.isfinite(s.pos).all(axis=1)
    if s.heading is not None:
        ok &= np.isfinite(s.heading)
    if not ok.all():
        k = int(np.flatnonzero(~ok)[0])
        raise InputError(
            f"the {what} on {topic} are not finite at t={s.t[k] - s.t[0]:.3f} s (message {int(s.kept[k]) + 1})",
            source,
        )


def _repeated_stamps(
    s: _Stream,
    keep: np.ndarray,
    nrep: int,
    first: int,
    bursty: bool,
    cumulative: bool,
    rep: StreamReport,
    warnings: list[str],
) -> None:
    """Messages that repeat the stamp before (with other content: :func:`_drop_twice` took the
    copies): in a stream in bursts they are kept (distinct samples of one arrival); else the last
    of each stamp is kept (incremental counts: different counts of one stamp added up)."""
    if bursty:  # distinct samples of one arrival
        return
    rep.repeated_stamps = nrep
    if cumulative:
        note = "the last of each stamp is kept"
        pos = s.pos[keep]
    else:  # incremental: identical copies count once, different counts of one stamp add up
        groups = np.concatenate([[0], keep[:-1] + 1])
        same = np.all(np.maximum.reduceat(s.pos, groups) == np.minimum.reduceat(s.pos, groups), axis=1)
        pos = np.where(same[:, None], s.pos[keep], np.add.reduceat(s.pos, groups))
        note = "identical copies are counted once, different counts of one stamp are added up"
    warnings.append(
        f"{nrep} of the {s.t.size} {rep.what} on {rep.topic} repeat the stamp of the message before "
        f"(first at message {first}): {note}; check the publisher's stamps"
    )
    s.take(keep)
    s.pos = pos


def _drop_twice(s: _Stream, rep: StreamReport, warnings: list[str]) -> None:
    """Drop the messages that repeat the one before: the same stamp and the same content (a
    message recorded twice; it says nothing new)."""
    if s.t.size < 2:
        return
    same = (np.diff(s.t) == 0) & np.all(np.diff(s.pos, axis=0) == 0, axis=1)
    if s.heading is not None:
        same &= np.diff(s.heading) == 0
    twice = np.concatenate([[False], same])
    rep.duplicates = int(twice.sum())
    if rep.duplicates:
        warnings.append(
            f"{rep.duplicates} of the {s.t.size} {rep.what} on {rep.topic} repeat the message before (the same "
            "stamp and content: a message recorded twice, or a stamp not updated while the robot stood): dropped"
        )
        s.take(~twice)


def _content(s: _Stream, wheels_at: np.ndarray, poses: bool) -> np.ndarray:
    """What each message says, in comparable units: the rolling joints, or an odometry's x, y and
    heading (times :data:`HEADING_LEVER_M`)."""
    x = s.pos[:, wheels_at]
    if poses and s.heading is not None:
        x = np.column_stack([x, HEADING_LEVER_M * np.unwrap(s.heading)])
    return x


def _drop_late(
    s: _Stream,
    wheels_at: np.ndarray,
    wrapped_turn: float | None,
    poses: bool,
    bursty: bool,
    period: float | None,
    rep: StreamReport,
    warnings: list[str],
) -> bool:
    """Drop the late messages and spikes found by their content (:func:`late_messages`); whether
    there were any."""
    x = _content(s, wheels_at, poses)
    if wrapped_turn is not None and _within_one_turn(x, wrapped_turn):
        x = np.unwrap(x, period=wrapped_turn, axis=0)
    runs = late_messages(x)
    if not runs:
        return False
    clock = sample_clock(s.t, PERIOD_MARGIN * period) if bursty and period is not None else s.t
    drop = np.zeros(s.t.size, dtype=bool)
    ages = []
    for r in runs:
        drop[r.start : r.stop] = True
        if r.earlier is not None:
            ages.append(float(clock[r.before] - clock[r.earlier]))
    rep.late = int(sum(r.stop - r.start for r in runs if r.late))
    rep.spikes = int(sum(r.stop - r.start for r in runs if not r.late))
    rep.late_max_age_s = max(ages, default=0.0)
    first = runs[0]
    at = f"the first at t={s.t[first.start] - s.t[0]:.3f} s (message {int(s.kept[first.start]) + 1})"
    if rep.late:
        warnings.append(
            f"{rep.late} of the {rep.what} on {rep.topic} carry content older than their stamp (up to "
            f"{rep.late_max_age_s:.2f} s: messages delivered late and stamped on arrival, or sent again), "
            f"{at if first.late else 'the first ' + _first_late(s, runs)}: dropped"
        )
    if rep.spikes:
        sp = next(r for r in runs if not r.late)
        jump = float(np.abs(x[sp.start] - x[sp.before]).max())
        warnings.append(
            f"{rep.spikes} spike(s) in the {rep.what} on {rep.topic}, the first at t={s.t[sp.start] - s.t[0]:.3f} s "
            f"(message {int(s.kept[sp.start]) + 1}; a jump of {jump:.3g} and back, to no earlier content: a corrupt "
            "message): dropped"
        )
    s.take(~drop)
    return True


def _first_late(s: _Stream, runs) -> str:
    r = next(r for r in runs if r.late)
    return f"at t={s.t[r.start] - s.t[0]:.3f} s (message {int(s.kept[r.start]) + 1})"


def _within_one_turn(x: np.ndarray, turn: float) -> bool:
    """Every column stays within one turn and some step is longer than half of one: wrapped."""
    span = x.max(axis=0) - x.min(axis=0)
    return bool(np.all(span <= turn * (1 + 1e-9)) and np.any(np.abs(np.diff(x, axis=0)) > 0.5 * turn))


def _clock_note(raw: np.ndarray, tau: np.ndarray, rep: StreamReport, warnings: list[str]) -> None:
    shift = raw - tau
    moved = shift > 1e-9
    rep.clock = "recovered"
    rep.clock_moved = int(moved.sum())
    rep.clock_shift_max_s = float(shift.max()) if shift.size else 0.0
    rep.clock_shift_median_s = float(np.median(shift[moved])) if moved.any() else 0.0
    rep.clock_anchor_s = float(np.mean(shift))
    share = rep.burst_gaps / max(raw.size - 1, 1)
    rate = f"{rep.rate_hz:.3g} Hz" if rep.rate_hz else "its rate"
    warnings.append(
        f"the {rep.what} on {rep.topic} arrive in bursts ({100 * share:.0f} % of consecutive stamps closer than a "
        f"fifth of the period, at {rate}): stamped on arrival; each message's sample time is recovered from the "
        f"lower envelope of the stamps ({rep.clock_moved} moved back, by up to {rep.clock_shift_max_s:.3f} s; the "
        f"clock then kept at the stamps' mean, {1e3 * rep.clock_anchor_s:.0f} ms later)"
    )


def _summed(t: np.ndarray, wheels: np.ndarray, metres_per_unit: float, what: str, topic: str, source) -> np.ndarray:
    """Incremental counts summed into positions; running counters read as increments refused."""
    from umbmark.model.stamps import spikes

    _refuse_running_counters(t, wheels, metres_per_unit, what, topic, source)
    summed = np.cumsum(wheels, axis=0)
    counter_jumps = spikes(t, summed, metres_per_unit)[0]
    if counter_jumps.size and not spikes(t, wheels, metres_per_unit)[0].size:
        err = refusal(
            "running_counters",
            f"summed as counts per message, the {what} on {topic} jump faster than {MAX_WHEEL_SPEED_MPS:g} m/s "
            f"at the wheel rim at t={t[int(counter_jumps[0])] - t[0]:.3f} s, while as a running counter they "
            'move as a wheel does: the counts look cumulative, running counters (`ticks="cumulative"`)',
            source,
        )
        if err is not None:
            raise err
    return summed


def _jumps(
    s: _Stream,
    wheels: np.ndarray,
    metres_per_unit: float,
    cumulative: bool,
    poses: bool,
    rep: StreamReport,
    warnings: list[str],
    source: str | None,
) -> np.ndarray:
    """Positions that jump faster than any wheel turns: an isolated spike of cumulative positions
    is dropped; a jump that stays (or any in incremental counts) cuts the stream there, the
    longer part kept."""
    isolated, stays = spike_kinds(s.t, wheels, metres_per_unit)
    if not cumulative:
        stays, isolated = np.sort(np.concatenate([stays, isolated])), isolated[:0]
    if isolated.size:
        k = int(isolated[0])
        jump = float(np.abs(wheels[k] - wheels[k - 1]).max())
        warnings.append(
            f"{isolated.size} spike(s) in the {rep.what} on {rep.topic}, the first at t={s.t[k] - s.t[0]:.3f} s "
            f"(sample {k + 1}) (a jump of {jump:.3g} and back): dropped"
        )
        rep.spikes += int(isolated.size)
        ok = np.ones(s.t.size, dtype=bool)
        ok[isolated] = False
        s.take(ok)
        wheels = wheels[ok]
        stays = spike_kinds(s.t, wheels, metres_per_unit)[1]
    if not stays.size:
        return wheels
    return _cut(s, wheels, stays, poses, rep, warnings, source)


def _cut(
    s: _Stream,
    wheels: np.ndarray,
    stays: np.ndarray,
    poses: bool,
    rep: StreamReport,
    warnings: list[str],
    source: str | None,
) -> np.ndarray:
    """The longest part of the stream between jumps that stay, with a warning naming the first."""
    t0 = float(s.t[0])
    k = int(stays[0])
    jump = float(np.abs(wheels[k] - wheels[k - 1]).max())
    edges = np.concatenate([[0], stays, [s.t.size]])
    spans = [(s.t[b - 1] - s.t[a], b - a, a, b) for a, b in zip(edges[:-1], edges[1:])]
    _, count, a, b = max(spans)
    if count < 2:
        raise InputError(
            f"the {rep.what} on {rep.topic} jump faster than {MAX_WHEEL_SPEED_MPS:g} m/s "
            f"{'' if poses else 'at the wheel rim '}{stays.size} times, leaving no two samples in a row",
            source,
        )
    rep.resets = int(stays.size)
    rep.kept_span_s = (round(float(s.t[a]) - t0, 6), round(float(s.t[b - 1]) - t0, 6))
    unit = " m" if poses else ""
    rim = "" if poses else " at the wheel rim"
    more = f" ({stays.size} such jumps in all)" if stays.size > 1 else ""
    warnings.append(
        f"the {rep.what} on {rep.topic} jump by {jump:.3g}{unit} at t={s.t[k] - t0:.3f} s (sample {k + 1}), faster "
        f"than {MAX_WHEEL_SPEED_MPS:g} m/s{rim}, and do not come back{more}: a counter reset, or the odometry "
        f"started again; only the longer part, {rep.kept_span_s[0]:.1f} to {rep.kept_span_s[1]:.1f} s "
        f"({count} of {s.t.size} samples), is used"
    )
    ok = np.zeros(s.t.size, dtype=bool)
    ok[a:b] = True
    s.take(ok)
    return wheels[a:b]


def _unwrapped(wheels: np.ndarray, turn: float, rep: StreamReport, warnings: list[str]) -> np.ndarray:
    jumps = int((np.abs(np.diff(wheels, axis=0)) > 0.5 * turn).sum())
    if not jumps:
        return wheels
    rep.wrapped = True
    warnings.append(
        f"the {rep.what} on {rep.topic} jump by more than half a turn {jumps} times between messages (wrapped to "
        "one turn?): unwrapped"
    )
    return np.unwrap(wheels, period=turn, axis=0)


def _refuse_running_counters(t, wheels, metres_per_unit: float, what: str, topic: str, source: str | None) -> None:
    """Refuse incremental counts whose median would turn a wheel rim faster than any wheel: they
    are running counters read per message (``wheels``: ``(K, J)``)."""
    if t.size <= 2:
        return
    dt = float(np.median(np.diff(t)))
    speed = float(np.median(np.abs(wheels).max(axis=1))) * metres_per_unit / dt if dt > 0 else 0.0
    err = refusal(
        "running_counters",
        f"read as counts per message, the {what} on {topic} would turn the wheel rims at {speed:.3g} m/s "
        f'(median): the counts look cumulative, they look like running counters (`ticks="cumulative"`)',
        source,
    )
    if err is not None and speed > MAX_WHEEL_SPEED_MPS:
        raise err
