"""The history's tables and how a record is stored and read back, for every backend: the schema
and its migrations (:data:`MIGRATIONS`, :data:`SCHEMA_VERSION`, :data:`TABLE_COLUMNS`), the query of
the records, a row made from a calibration's fields (:func:`make_row`; any database URL in it
masked), a record read from a row (a value no umbmark wrote: :class:`~umbmark.history.records.DamagedRecord`),
and a call retried while SQLite answers "locked" (:func:`retry_while_locked`).

Part of the history's shared code (:mod:`umbmark.history.base`, which re-exports these names).
Imports only the standard library, :mod:`umbmark.errors`, :mod:`umbmark.jsonutil`,
:mod:`umbmark.history.records` and :mod:`umbmark.history.address` (the masking).
"""

from __future__ import annotations

import json
import math
import socket
import time
from collections.abc import Callable, Sequence
from datetime import datetime
from pathlib import Path
from typing import Any, NoReturn, TypeVar

from umbmark._version import __version__
from umbmark.errors import InputError
from umbmark.history.address import _mask_obj, mask_secrets
from umbmark.history.records import KINDS, DamagedRecord, Record, _num, _short, _utc_string, check_robot
from umbmark.jsonutil import dumps

__all__ = ["MIGRATIONS", "SCHEMA_VERSION", "TABLE_COLUMNS", "MAX_INT", "make_row", "retry_while_locked"]

# Schema migrations: MIGRATIONS[v] upgrades a database at version v - 1 to version v.
MIGRATIONS: dict[int, list[str]] = {
    1: [
        """CREATE TABLE robots (
               id INTEGER PRIMARY KEY,
               name TEXT NOT NULL UNIQUE,
               created_utc TEXT NOT NULL)""",
        """CREATE TABLE calibrations (
               id INTEGER PRIMARY KEY,
               robot_id INTEGER NOT NULL REFERENCES robots(id),
               created_utc TEXT NOT NULL,
               kind TEXT NOT NULL,
               method TEXT NOT NULL,
               software_version TEXT NOT NULL,
               inputs_json TEXT NOT NULL,
               input_sha256 TEXT,
               source TEXT,
               results_json TEXT NOT NULL,
               parameters_json TEXT NOT NULL,
               parameters_in_use_json TEXT NOT NULL,
               emax_syst_mm REAL,
               ed REAL,
               eb REAL,
               wheelbase_mm REAL)""",
    ],
    2: [
        "ALTER TABLE calibrations ADD COLUMN note TEXT",
        "ALTER TABLE calibrations ADD COLUMN host TEXT",
        "CREATE INDEX calibrations_robot_time ON calibrations (robot_id, created_utc, id)",
    ],
}
SCHEMA_VERSION = max(MIGRATIONS)

_T = TypeVar("_T")


def _dumps(o: Any) -> str:
    return dumps(o, sort_keys=True)


_SELECT = """SELECT c.id, r.name, c.created_utc, c.kind, c.method, c.software_version, c.inputs_json,
                    c.input_sha256, c.source, c.results_json, c.parameters_json, c.parameters_in_use_json,
                    c.emax_syst_mm, c.ed, c.eb, c.wheelbase_mm, c.note, c.host
             FROM calibrations c JOIN robots r ON r.id = c.robot_id"""


# the columns each table must have (the schema of :data:`MIGRATIONS`)
TABLE_COLUMNS = {
    "robots": ("id", "name", "created_utc"),
    "calibrations": (
        "id",
        "robot_id",
        "created_utc",
        "kind",
        "method",
        "software_version",
        "inputs_json",
        "input_sha256",
        "source",
        "results_json",
        "parameters_json",
        "parameters_in_use_json",
        "emax_syst_mm",
        "ed",
        "eb",
        "wheelbase_mm",
        "note",
        "host",
    ),
}

# the largest id or limit a database integer holds (SQLite and PostgreSQL: 64 bits)
MAX_INT = 2**63 - 1


def _record(row: Sequence[Any], db: object) -> Record:
    """A record from the columns of :data:`_SELECT`.

    Raises
    ------
    DamagedRecord
        For a value no umbmark wrote: corrupt JSON, a time that is not ISO 8601, a text column
        holding bytes, a number column (or a number of the parameters) holding text, bytes or
        an infinity.
    """
    rid = row[0]

    def bad(problem: str) -> NoReturn:
        raise DamagedRecord(rid, problem, db)

    def text(i: int, col: str) -> str:
        v = row[i]
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return str(v)
        if not isinstance(v, str):
            bad(f"column {col} holds {_short(v)}, not text")
        return v

    def opt_text(i: int, col: str) -> str | None:
        return None if row[i] is None else text(i, col)

    def obj(i: int, col: str) -> dict[str, Any]:
        v = row[i]
        if isinstance(v, (bytes, bytearray, memoryview)):
            try:
                v = bytes(v).decode("utf-8")
            except UnicodeDecodeError:
                bad(f"column {col} holds bytes that are not UTF-8 text")
        if not isinstance(v, str):
            bad(f"column {col} holds {_short(v)}, not JSON text")
        try:
            d = json.loads(v)
        except (ValueError, RecursionError):
            bad(f"column {col} is not valid JSON ({_short(v)})")
        if not isinstance(d, dict):
            bad(f"column {col} holds {_short(d)}, not a JSON object")
        return d

    def number(i: int, col: str) -> float | None:
        v = row[i]
        if v is None:
            return None
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
            bad(f"column {col} holds {_short(v)}, not a number")
        return float(v)

    def numbers_in(d: dict[str, Any], col: str) -> dict[str, Any]:
        # the numbers every reader of a record uses (tables, plots, reports, the export)
        for k in ("c_left", "c_right", "wheelbase_mm", "wheelbase_m", "Ed", "Eb"):
            v = d.get(k)
            if v is not None and not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                bad(f"{k} in {col} holds {_short(v)}, not a number")
        return d

    name = text(1, "robot name")
    when = text(2, "created_utc")
    try:
        datetime.fromisoformat(when.replace("Z", "+00:00"))
    except ValueError:
        bad(f"its time {_short(when)} is not an ISO 8601 time")
    rec = Record(
        rid,
        name,
        when,
        text(3, "kind"),
        text(4, "method"),
        text(5, "software_version"),
        obj(6, "inputs_json"),
        opt_text(7, "input_sha256"),
        opt_text(8, "source"),
        obj(9, "results_json"),
        numbers_in(obj(10, "parameters_json"), "parameters_json"),
        numbers_in(obj(11, "parameters_in_use_json"), "parameters_in_use_json"),
        number(12, "emax_syst_mm"),
        number(13, "ed"),
        number(14, "eb"),
        number(15, "wheelbase_mm"),
        opt_text(16, "note"),
        opt_text(17, "host"),
    )
    return rec


def retry_while_locked(
    fn: Callable[[], _T], timeout_s: float, errors: type[BaseException] | tuple[type[BaseException], ...]
) -> _T:
    """Call ``fn`` until it does not raise a "database is locked" error (one of ``errors``) or
    ``timeout_s`` has passed. SQLite answers "locked" at once, without waiting for its busy
    timeout, in a few cases: two processes switching a new file to WAL at the same moment, or a
    read transaction that must become a write transaction.

    Parameters
    ----------
    fn : callable
        Called without arguments.
    timeout_s : float
        How long to keep retrying.
    errors : exception class or tuple
        The errors that may say "locked".

    Returns
    -------
    object
        What ``fn`` returns.
    """
    deadline = time.monotonic() + timeout_s
    delay = 0.01
    while True:
        try:
            return fn()
        except errors as e:
            if "locked" not in str(e) or time.monotonic() > deadline:
                raise
            time.sleep(delay)
            delay = min(2 * delay, 0.25)


def make_row(
    robot: str,
    kind: str,
    method: str,
    results: dict[str, Any] | None,
    parameters: dict[str, Any] | None,
    inputs: dict[str, Any] | None,
    input_sha256: str | None,
    source: str | Path | None,
    parameters_in_use: dict[str, Any] | None,
    note: str | None,
    when: str | datetime | None,
    software_version: str | None,
) -> dict[str, Any]:
    """The column values of one ``calibrations`` row (plus ``robot``), for any backend.

    Parameters
    ----------
    robot, kind, method, results, parameters, inputs, input_sha256, source, parameters_in_use, note, when
        As for :func:`umbmark.history.record_result`.
    software_version : str or None
        The umbmark version that made the result (default: this one).

    Returns
    -------
    dict
        Column name -> value (JSON columns as text; the host is this one's name).

    Raises
    ------
    InputError
        For a missing or unprintable robot name, an unknown kind or a bad time.
    """
    robot = check_robot(robot)
    if kind not in KINDS:
        raise InputError(f"unknown record kind {kind!r} (one of {', '.join(KINDS)})")
    # a database URL anywhere in a record is stored with its password masked
    parameters = _mask_obj(dict(parameters or {}))
    results = _mask_obj(dict(results or {}))
    inputs = _mask_obj(inputs or {})
    parameters_in_use = _mask_obj(parameters_in_use or {})
    source = None if source is None else mask_secrets(str(source))
    note = None if note is None else mask_secrets(str(note))
    wb = _num(parameters.get("wheelbase_mm"))
    wb_m = _num(parameters.get("wheelbase_m"))
    if wb is None and wb_m is not None:
        wb = wb_m * 1e3
    return {
        "robot": robot,
        "created_utc": _utc_string(when),
        "kind": kind,
        "method": mask_secrets(str(method)),
        "software_version": software_version or __version__,
        "inputs_json": _dumps(inputs),
        "input_sha256": input_sha256,
        "source": source,
        "results_json": _dumps(results),
        "parameters_json": _dumps(parameters),
        "parameters_in_use_json": _dumps(parameters_in_use),
        "emax_syst_mm": _num(results.get("emax_syst_mm")),
        "ed": _num(parameters.get("Ed", results.get("Ed"))),
        "eb": _num(parameters.get("Eb", results.get("Eb"))),
        "wheelbase_mm": wb,
        "note": note,
        "host": socket.gethostname(),
    }
