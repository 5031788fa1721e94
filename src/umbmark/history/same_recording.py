"""The guard of one recording recorded once: which part of its recording a record was made from
(:func:`recording_part`), whether two parts share data (:func:`parts_overlap`), and the error of a
second record of one recording (:class:`SameRecording`: one recording twice would count as two
sessions of the robot, and a drift would be judged on it twice).

Part of the history's shared code (:mod:`umbmark.history.base`, which re-exports these names;
the backends' :meth:`~umbmark.history.base._Backend.add` refuses the second record). Imports only
:mod:`umbmark.history.records`.
"""

from __future__ import annotations

from typing import Any

from umbmark.history.records import HistoryError, Record, _num

__all__ = ["SameRecording", "recording_part", "parts_overlap"]


class SameRecording(HistoryError):
    """A robot's history holds a record of this recording already: the same content (its
    ``input_sha256``), kind and method, and a part of it that overlaps (:func:`parts_overlap`).

    Attributes
    ----------
    record_id : int
        The record that holds it.
    data : tuple of str
        The robot's name and the database, as stored (a front end prints them as they are).
    """

    def __init__(self, robot: str, record: Record, db: object) -> None:
        self.record_id = record.id
        self.data = (robot, str(db))
        part = recording_part(record.inputs)
        of = "this recording" if part is None else f"{part[0]:g}-{part[1]:g} s of this recording"
        source = f", {record.source}" if record.source else ""
        super().__init__(
            f"the history of robot {robot!r} in {db} holds {of} already: record #{record.id} "
            f"({record.kind}, method {record.method}, {record.created_utc[:16].replace('T', ' ')} UTC{source}, "
            "the same content); nothing was recorded (one recording twice would count as two sessions of the "
            "robot, and a drift would be judged on it twice)"
        )


def recording_part(inputs: Any) -> tuple[float, float] | None:
    """The part of its recording a record was made from: a window's ``window_s`` (start and end,
    seconds into the recording) in its inputs, else None (the whole recording).

    Parameters
    ----------
    inputs : dict
        A record's inputs.

    Returns
    -------
    tuple of float or None
    """
    w = inputs.get("window_s") if isinstance(inputs, dict) else None
    if not (isinstance(w, (list, tuple)) and len(w) == 2):
        return None
    a, b = (_num(v) for v in w)
    return None if a is None or b is None else (round(a, 3), round(b, 3))


def parts_overlap(a: tuple[float, float] | None, b: tuple[float, float] | None) -> bool:
    """Whether two parts of one recording (:func:`recording_part`; None: the whole) share data:
    the whole recording overlaps any window of it, two windows overlap when their spans do.

    Parameters
    ----------
    a, b : tuple of float or None
        ``(start_s, end_s)``, or None.

    Returns
    -------
    bool
    """
    return a is None or b is None or (a[0] < b[1] and b[0] < a[1])
