"""The history's records: the kinds of record (:data:`KINDS`), one recorded calibration
(:class:`Record`), the history's errors (:class:`HistoryError`, :class:`NoHistory`,
:class:`DamagedRecord`), a robot's name as recorded (:func:`check_robot`) and a record's time
(:func:`session_time_problem`: a session's time that cannot date a record).

Part of the history's shared code (:mod:`umbmark.history.base`, which re-exports these names).
Imports only the standard library and :mod:`umbmark.errors`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from typing import Any

from umbmark.errors import InputError, UmbmarkError

__all__ = [
    "KINDS",
    "HistoryError",
    "NoHistory",
    "DamagedRecord",
    "Record",
    "CLOCK_SKEW",
    "session_time_problem",
    "check_robot",
]

KINDS = ("analyze", "replay", "calibrate", "measure", "selfcal", "gyro", "other")


class HistoryError(UmbmarkError):
    """The history database cannot be used (locked for too long, newer schema, not a database)."""


class NoHistory(HistoryError):
    """There is no history at the address yet: no file, an empty one, a database without tables
    (reading needs one; recording creates it)."""


CLOCK_SKEW = timedelta(minutes=5)
"""How far in the future a session's time may be (clocks a little apart) and still date a record."""


def session_time_problem(when: datetime) -> str | None:
    """Why ``when`` cannot date a record of a session: ``"is in the future"`` (beyond
    :data:`CLOCK_SKEW`) or ``"is before 1970"``; None when it can (UTC when it has no zone)."""
    if when.tzinfo is None:
        when = when.replace(tzinfo=timezone.utc)
    if when > datetime.now(timezone.utc) + CLOCK_SKEW:
        return "is in the future"
    if when.year < 1970:
        return "is before 1970"
    return None


def _now_utc() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def _utc_string(when: str | datetime | None) -> str:
    if when is None:
        return _now_utc()
    if isinstance(when, str):
        try:
            when = datetime.fromisoformat(when.replace("Z", "+00:00"))
        except ValueError:
            raise InputError(f"time {when!r} is not an ISO 8601 date/time (e.g. 2026-05-01T14:30)") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=timezone.utc)
    return when.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def _num(v: Any) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class Record:
    """One recorded calibration (a row of the ``calibrations`` table)."""

    id: int
    robot: str
    created_utc: str
    kind: str
    method: str
    software_version: str
    inputs: dict[str, Any]
    input_sha256: str | None
    source: str | None
    results: dict[str, Any]
    parameters: dict[str, Any]
    parameters_in_use: dict[str, Any]
    emax_syst_mm: float | None
    ed: float | None
    eb: float | None
    wheelbase_mm: float | None
    note: str | None = None
    host: str | None = None

    @property
    def time(self) -> datetime:
        """The record's time as an aware datetime (UTC)."""
        return datetime.fromisoformat(self.created_utc.replace("Z", "+00:00"))

    def to_dict(self, full: bool = True) -> dict[str, Any]:
        """The record as JSON-able values.

        Parameters
        ----------
        full : bool
            Also include the stored ``inputs`` and ``results``.

        Returns
        -------
        dict
        """
        d: dict[str, Any] = {
            "id": self.id,
            "robot": self.robot,
            "time_utc": self.created_utc,
            "kind": self.kind,
            "method": self.method,
            "software_version": self.software_version,
            "source": self.source,
            "input_sha256": self.input_sha256,
            "emax_syst_mm": self.emax_syst_mm,
            "Ed": self.ed,
            "Eb": self.eb,
            "wheelbase_mm": self.wheelbase_mm,
            "parameters": self.parameters,
            "parameters_in_use": self.parameters_in_use,
            "note": self.note,
            "host": self.host,
        }
        if full:
            d["inputs"] = self.inputs
            d["results"] = self.results
        return d


class DamagedRecord(HistoryError):
    """One record of the history cannot be read (corrupt JSON, a value of the wrong type).

    Attributes
    ----------
    record_id : int
        The record.
    problem : str
        What is wrong with it.
    """

    def __init__(self, record_id: int, problem: str, db: object) -> None:
        self.record_id = record_id
        self.problem = problem
        super().__init__(f"record #{record_id} in the history database {db} is damaged: {problem}")


def _short(v: object) -> str:
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def check_robot(robot: str | None) -> str:
    """A robot's name as recorded (surrounding spaces dropped).

    Parameters
    ----------
    robot : str
        The name given.

    Returns
    -------
    str

    Raises
    ------
    InputError
        No name, one of more than 200 characters, or one with control characters.
    """
    if robot is None or not str(robot).strip():
        raise InputError("a robot name is needed to record a calibration (`robot`)")
    robot = str(robot).strip()
    if len(robot) > 200 or any(ord(ch) < 32 for ch in robot):
        raise InputError(f"robot name {robot[:40]!r} must be at most 200 printable characters")
    return robot
