"""What every history backend shares: where the database is, the schema, the record type,
the rows, the base class of the backends, and the parameter export of a record.

Imports only the standard library, :mod:`umbmark.errors` and :mod:`umbmark.jsonutil` (and, when a
record of a robot of a kind of its own is exported, :mod:`umbmark.kinds`; for the type checker
only, :mod:`umbmark.model`)."""

from __future__ import annotations

import json
import math
import os
import re
import socket
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, Protocol, TypeVar

from umbmark._files import file_sha256
from umbmark._version import __version__
from umbmark.errors import InputError, UmbmarkError
from umbmark.jsonutil import dumps, jsonable

if TYPE_CHECKING:
    from umbmark.kinds import Kind
    from umbmark.model.geometry import Calibration
    from umbmark.model.runs import RunsTable

__all__ = [
    "ENV_VAR",
    "AnalysisLike",
    "check_robot",
    "KINDS",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "DamagedRecord",
    "HistoryError",
    "NoHistory",
    "SameRecording",
    "Record",
    "default_db_path",
    "display_db",
    "export_parameters",
    "file_sha256",
    "format_export",
    "is_url",
    "make_row",
    "mask_secrets",
    "parameters_from_analysis",
    "parts_overlap",
    "recording_part",
    "resolve_db",
    "resolve_db_path",
    "retry_while_locked",
    "runs_from_rows",
    "runs_to_rows",
]

ENV_VAR = "UMBMARK_DB"
KINDS = ("analyze", "replay", "calibrate", "measure", "selfcal", "gyro", "other")

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
_B = TypeVar("_B", bound="_Backend")


class _CorrectionLike(Protocol):
    """What the history reads of a correction (:class:`umbmark.correct.result.CorrectionResult`)."""

    @property
    def method(self) -> str: ...
    @property
    def ed(self) -> float: ...
    @property
    def eb(self) -> float: ...
    @property
    def calibration(self) -> Calibration: ...


class AnalysisLike(Protocol):
    """What the history reads of an analysis: :class:`umbmark.correct.analysis.Analysis` (a layer
    above the history, which does not import it)."""

    @property
    def runs(self) -> RunsTable: ...
    @property
    def side_m(self) -> float: ...
    @property
    def wheelbase_m(self) -> float: ...
    @property
    def correction(self) -> _CorrectionLike: ...
    def to_dict(self) -> dict[str, Any]: ...


class HistoryError(UmbmarkError):
    """The history database cannot be used (locked for too long, newer schema, not a database)."""


class NoHistory(HistoryError):
    """There is no history at the address yet: no file, an empty one, a database without tables
    (reading needs one; recording creates it)."""


def default_db_path() -> Path:
    """The per-user default location (without looking at ``UMBMARK_DB``).

    Returns
    -------
    Path
        ``$XDG_DATA_HOME/umbmark/history.sqlite`` (``~/.local/share`` by default),
        ``%LOCALAPPDATA%\\umbmark\\history.sqlite`` on Windows,
        ``~/Library/Application Support/umbmark/history.sqlite`` on macOS.
    """
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Application Support"
    else:
        xdg = os.environ.get("XDG_DATA_HOME")
        base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "umbmark" / "history.sqlite"


def is_url(db: object) -> bool:
    """True for an SQLAlchemy database URL (``postgresql+psycopg://...``, ``sqlite:///...``).

    Parameters
    ----------
    db : object
        A database file, URL or anything else.

    Returns
    -------
    bool
    """
    return isinstance(db, str) and "://" in db


# a libpq connection string (``host=... user=... password=...``): not a file name, not a URL
_KEY_VALUE = re.compile(
    r"(^|\s)(host|hostaddr|port|dbname|user|password|passfile|sslmode|service|connect_timeout)\s*=", re.IGNORECASE
)


def check_db_address(db: str | Path) -> None:
    """Refuse a history address that is neither a file nor a URL, without repeating it.

    Parameters
    ----------
    db : str or Path
        The ``db`` given.

    Raises
    ------
    InputError
        A libpq key=value connection string (``host=h user=u password=p``), or a file name that
        holds ``password=``: taken as a file name it would create that file and print the
        password in every message.
    """
    s = str(db)
    if is_url(s):
        scheme, rest = s.split("://", 1)
        if scheme.lower().startswith("sqlite") and re.search(
            r"(^|&)(password|passwd|pwd)=", rest.partition("?")[2], re.I
        ):
            raise InputError(
                "an SQLite history has no password (the file is not encrypted): give the URL without it, and "
                "keep the file where only its users can read it; nothing was created"
            )
        return
    if re.match(r"^[^/@\s]*:[^/@\s]*@", s):
        raise InputError(
            "the history database looks like a URL without its scheme (USER:PASSWORD@HOST/DB): write "
            "postgresql+psycopg://USER@HOST/DB, the password in $PGPASSWORD or ~/.pgpass; nothing was created "
            "(the value is not repeated here: it holds a password)"
        )
    if _KEY_VALUE.search(s) or "password=" in s.lower():
        raise InputError(
            "the history database is a file or a URL (postgresql+psycopg://USER@HOST/DB, the password in "
            "$PGPASSWORD or ~/.pgpass), not a key=value connection string; nothing was created (the value "
            "is not repeated here: it holds a password or connection settings)"
        )


def resolve_db(db: str | Path | None = None) -> str | Path:
    """Where the history is: ``db`` if given, else ``$UMBMARK_DB``, else :func:`default_db_path`.

    Parameters
    ----------
    db : str or Path, optional
        A database file or URL.

    Returns
    -------
    str or Path
        A URL stays a string; a file becomes a :class:`Path` (``~`` expanded).
    """
    db = db or os.environ.get(ENV_VAR) or None
    if db is None:
        return default_db_path()
    check_db_address(db)
    if is_url(str(db)):
        return str(db)
    return Path(db).expanduser()


# query parameters of a database URL whose values are masked in messages and records
_SECRET_KEY = re.compile(r"pass|pwd|secret|token|key|auth|cred|sig", re.IGNORECASE)
_URL_IN_TEXT = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://[^\s'\"<>]+")


def _split_userinfo(rest: str) -> tuple[str | None, str | None, str]:
    """``user``, ``password`` and the remainder (host, path, query) of a URL after ``://``.

    The credentials end at the last ``@`` before the host: ``user:p@ss@host`` has the password
    ``p@ss``, and a ``?`` before any path is part of the password (``user:p?ss@host/db``), while
    an ``@`` in the query (``?user=a@b.org``) or in a path without a ``:`` before it is not a
    credential."""
    q = rest.find("?")
    at = rest.rfind("@", 0, q if q >= 0 else len(rest))
    if q >= 0 and "@" in rest[q:]:
        if "=" not in rest[q + 1 : rest.rfind("@")]:
            in_authority = True  # no query parameter before the last "@": the "?" is in the password
        elif at >= 0:
            in_authority = "/" not in rest[at + 1 : q]  # no path yet: the "?" is in the password
        else:
            head = rest[:q]
            in_authority = (
                ":" in head
                and not head.startswith("[")
                and "/" not in head.split(":", 1)[0]
                and re.match(r"[^:]*:\d+/", head) is None  # host:port/db?...: a real query
            )
        if in_authority:
            at = rest.rfind("@")
    if at < 0:
        return None, None, rest
    info = rest[:at]
    user, colon, pw = info.partition(":")
    if "/" in user:
        return None, None, rest  # a path with an "@" in it, not a user name
    return user, (pw if colon else None), rest[at + 1 :]


def _mask_query(query: str) -> str:
    parts = []
    for item in query.split("&"):
        k, eq, v = item.partition("=")
        parts.append(f"{k}=***" if eq and _SECRET_KEY.search(k) else item)
    return "&".join(parts)


def display_db(db: str | Path) -> str:
    """A database file or URL for messages and records: a URL's password and any query
    parameter named like one (``password``, ``passwd``, ``pwd``, ``secret``, ``token``, ...)
    are masked as ``***``.

    The URL is read with SQLAlchemy's parser (``make_url(...).render_as_string(hide_password=True)``)
    when SQLAlchemy is installed; the credentials are split off first at the last ``@`` before
    the host, so a password holding ``@`` (``user:p@ss@host``) is masked whole.

    Parameters
    ----------
    db : str or Path
        The database.

    Returns
    -------
    str
    """
    s = str(db)
    if "://" not in s:
        return s
    scheme, rest = s.split("://", 1)
    user, pw, tail = _split_userinfo(rest)
    where, qm, query = tail.partition("?")
    masked_query = _mask_query(query) if qm else ""
    info = "" if user is None else (user + (":***" if pw is not None else "") + "@")
    fallback = f"{scheme}://{info}{where}{qm}{masked_query}"
    if pw is None:
        return fallback  # nothing to mask but the query: the URL as it was written
    try:
        from sqlalchemy.engine import make_url
    except ImportError:
        return fallback
    try:
        u = make_url(f"{scheme}://{'' if user is None else user + (':x' if pw is not None else '') + '@'}{where}")
        text = u.render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001  not a URL SQLAlchemy reads: the masked text as it is
        return fallback
    return text + (qm + masked_query if qm else "")


def mask_secrets(text: str) -> str:
    """Every URL in a text as :func:`display_db` shows it (passwords and secret query values
    masked).

    Parameters
    ----------
    text : str
        Any message.

    Returns
    -------
    str
    """
    s = str(text)
    if "://" not in s:
        return s

    def one(m: re.Match[str]) -> str:
        url = m.group(0)
        core = url.rstrip(".,:;)]}")
        return display_db(core) + url[len(core) :]

    return _URL_IN_TEXT.sub(one, s)


def _mask_obj(o: Any) -> Any:
    """``o`` with :func:`mask_secrets` applied to every string in it (dicts, lists)."""
    if isinstance(o, str):
        return mask_secrets(o) if "://" in o else o
    if isinstance(o, dict):
        return {k: _mask_obj(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_mask_obj(v) for v in o]
    return o


def resolve_db_path(db: str | Path | None = None) -> Path:
    """Like :func:`resolve_db`, for a database file (not a URL).

    Parameters
    ----------
    db : str or Path, optional
        A database file.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        If the database is a URL.
    """
    r = resolve_db(db)
    if isinstance(r, str):
        raise InputError(f"{display_db(r)!r} is a database URL, not a file")
    return r


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


def _dumps(o: Any) -> str:
    return dumps(o, sort_keys=True)


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


def _short(v: object) -> str:
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


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


class _Backend:
    """What every history backend shares. A backend provides ``path`` (for messages),
    :meth:`close`, :meth:`transaction`, ``_insert(conn, row)``, ``_fetch(robot, limit,
    record_id)`` (the rows of :data:`_SELECT`, newest first) and ``_robot_counts()`` (name,
    number of records, first and last time per robot).

    Reading skips a damaged record (a value no umbmark wrote: corrupt JSON, a time that is not
    a time, text where a number belongs) and says so in :attr:`warnings`; :meth:`get` of a
    damaged record raises :class:`DamagedRecord`."""

    path: str | Path
    journal_mode: str | None

    def __enter__(self: _B) -> _B:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- what each backend provides ----------------------------------------------------------
    def close(self) -> None:
        """Close the database (release its connections)."""
        raise NotImplementedError

    def transaction(self) -> AbstractContextManager[Any]:
        """One write transaction, rolled back on any exception; yields the connection to pass to
        ``_insert``."""
        raise NotImplementedError

    def _insert(self, conn: Any, row: dict[str, Any]) -> int:
        """Store the row of :func:`make_row` inside :meth:`transaction`; returns the record's id."""
        raise NotImplementedError

    def _fetch(
        self, robot: str | None = None, limit: int | None = None, record_id: int | None = None
    ) -> Sequence[Sequence[Any]]:
        """The rows of :data:`_SELECT`, newest first (the robot's name and the id matched exactly)."""
        raise NotImplementedError

    def _same_rows(self, conn: Any, robot: str, input_sha256: str, kind: str, method: str) -> Sequence[Sequence[Any]]:
        """The rows of :data:`_SELECT` of the robot's records of one content, kind and method, on
        ``conn`` (a write transaction's connection, or None: a connection of its own)."""
        raise NotImplementedError

    def _robot_counts(self) -> Sequence[Sequence[Any]]:
        """Name, number of records, first and last time of each robot, by name."""
        raise NotImplementedError

    @property
    def warnings(self) -> list[str]:
        """The damaged records reading skipped (one message each, naming the record, the
        database and what is wrong)."""
        return list(self.__dict__.setdefault("_warnings", []))

    def _warn(self, msg: str) -> None:
        w = self.__dict__.setdefault("_warnings", [])
        if msg not in w:
            w.append(msg)

    def _decode(self, row: Sequence[Any], strict: bool = False) -> Record | None:
        """The record of one row; a damaged one is a warning and None (``strict``: raised)."""
        try:
            return _record(row, self.path)
        except DamagedRecord as e:
            if strict:
                raise
            self._warn(f"{e}: skipped")
            return None

    def add(
        self,
        robot: str,
        *,
        kind: str,
        method: str,
        results: dict[str, Any],
        parameters: dict[str, Any],
        inputs: dict[str, Any] | None = None,
        input_sha256: str | None = None,
        source: str | Path | None = None,
        parameters_in_use: dict[str, Any] | None = None,
        note: str | None = None,
        when: str | datetime | None = None,
        software_version: str | None = None,
    ) -> int:
        """Store one calibration in one transaction.

        Parameters
        ----------
        robot, kind, method, results, parameters, inputs, input_sha256, source, parameters_in_use, note, when
            As for :func:`umbmark.history.record_result`.
        software_version : str, optional
            The umbmark version that made the result (default: this one).

        Returns
        -------
        int
            The record's id.

        Raises
        ------
        InputError
            For a missing robot name, an unknown kind or a bad time.
        HistoryError
            If the database cannot be written (read-only, damaged).
        """
        row = self._row(
            robot,
            kind,
            method,
            results,
            parameters,
            inputs,
            input_sha256,
            source,
            parameters_in_use,
            note,
            when,
            software_version,
        )
        with self.transaction() as c:
            same = self._same(c, row["robot"], row["input_sha256"], row["kind"], row["method"], inputs)
            if same is not None:
                raise SameRecording(row["robot"], same, self.path)
            return self._insert(c, row)

    def same_recording(
        self, robot: str, *, kind: str, method: str, input_sha256: str | None, inputs: dict[str, Any] | None = None
    ) -> Record | None:
        """The robot's record of this recording, if it holds one: the same content hash, kind and
        method, and a part that overlaps this one (:func:`parts_overlap`: the whole recording, or
        the window of ``inputs``). :meth:`add` refuses a second one.

        Parameters
        ----------
        robot, kind, method, input_sha256, inputs
            As for :meth:`add`.

        Returns
        -------
        Record or None
            None also without a content hash (nothing to compare).
        """
        return self._same(None, check_robot(robot), input_sha256, kind, mask_secrets(str(method)), inputs)

    def _same(
        self, conn: Any, robot: str, sha: str | None, kind: str, method: str, inputs: dict[str, Any] | None
    ) -> Record | None:
        if not sha:
            return None
        part = recording_part(inputs)
        for row in self._same_rows(conn, robot, sha, kind, method):
            rec = self._decode(row)
            if rec is not None and parts_overlap(recording_part(rec.inputs), part):
                return rec
        return None

    @staticmethod
    def _row(*args: Any) -> dict[str, Any]:
        return make_row(*args)

    def records(self, robot: str | None = None, limit: int | None = None) -> list[Record]:
        """Records, oldest first; a damaged record is skipped (see :attr:`warnings`).

        Parameters
        ----------
        robot : str, optional
            Only this robot's (default: all). The name is matched literally.
        limit : int, optional
            Only the newest ``limit`` records.

        Returns
        -------
        list of Record

        Raises
        ------
        InputError
            A ``limit`` below 0 or above :data:`MAX_INT`.
        HistoryError
            If the database cannot be read.
        """
        if limit is not None and not 0 <= int(limit) <= MAX_INT:
            raise InputError(
                f"`limit` must be from 0 to {MAX_INT} (the most records the history database "
                f"{self.path} can count), got {limit}"
            )
        recs = [self._decode(r) for r in self._fetch(robot=robot, limit=limit)]
        return [r for r in reversed(recs) if r is not None]

    def get(self, record_id: int) -> Record:
        """One record by its id.

        Parameters
        ----------
        record_id : int
            The id.

        Returns
        -------
        Record

        Raises
        ------
        InputError
            If there is no such record (also for an id no database integer holds).
        DamagedRecord
            If the record is damaged.
        """
        rid = int(record_id)
        rows = self._fetch(record_id=rid) if 1 <= rid <= MAX_INT else []
        if not rows:
            raise InputError(f"no record #{record_id} in the history database {self.path}")
        rec = self._decode(rows[0], strict=True)
        assert rec is not None
        return rec

    def latest(self, robot: str, strict: bool = False) -> Record:
        """The robot's newest readable record.

        Parameters
        ----------
        robot : str
            The robot's name.
        strict : bool
            Raise when the newest record is damaged (else: the newest readable one, and a
            warning).

        Returns
        -------
        Record

        Raises
        ------
        InputError
            If the robot has no records (the message lists the robots there are).
        DamagedRecord
            ``strict`` and the newest record is damaged; or every record of the robot is.
        """
        rows = self._fetch(robot=robot, limit=1)
        if not rows:
            raise InputError(
                f"no calibrations of robot {robot!r} in the history database {self.path}" + self._known_hint(),
                data=[robot, self.path, *(str(r[0]) for r in self._robot_counts())],
            )
        rec = self._decode(rows[0], strict=strict)
        if rec is None:
            for row in self._fetch(robot=robot)[1:]:
                rec = self._decode(row)
                if rec is not None:
                    break
        if rec is None:
            _record(rows[0], self.path)  # raises: every record of the robot is damaged
            raise AssertionError  # pragma: no cover
        return rec

    def robots(self) -> list[dict[str, Any]]:
        """One summary per robot, by name.

        Returns
        -------
        list of dict
            ``robot``, ``records``, ``first_utc``, ``last_utc`` and, when it has a readable
            record, the latest one's ``latest_id``, ``emax_syst_mm``, ``Ed``, ``Eb``,
            ``wheelbase_mm``.

        Raises
        ------
        DamagedRecord
            If the database holds records and not one of them is readable.
        """
        out: list[dict[str, Any]] = []
        damaged: DamagedRecord | None = None
        for name, n, first, last in self._robot_counts():
            name = str(name)
            first, last = (t if t is None or isinstance(t, str) else _short(t) for t in (first, last))
            d: dict[str, Any] = {"robot": name, "records": n, "first_utc": first, "last_utc": last}
            if n:
                try:
                    rec = self.latest(name)
                except DamagedRecord as e:
                    self._warn(f"{e}: skipped")
                    damaged = e
                else:
                    d.update(
                        {
                            "latest_id": rec.id,
                            "emax_syst_mm": rec.emax_syst_mm,
                            "Ed": rec.ed,
                            "Eb": rec.eb,
                            "wheelbase_mm": rec.wheelbase_mm,
                        }
                    )
            out.append(d)
        if damaged is not None and not any("latest_id" in d for d in out):
            raise damaged  # records, and not one of them readable
        return out

    def _known_hint(self) -> str:
        names = [str(r[0]) for r in self._robot_counts()]
        return f" (robots: {', '.join(names)})" if names else " (it holds no robots yet)"


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


def parameters_from_analysis(analysis: AnalysisLike) -> tuple[dict[str, Any], dict[str, Any]]:
    """The parameters an analysis recommends, and those the robot ran with.

    Parameters
    ----------
    analysis : umbmark.correct.analysis.Analysis
        The analysis.

    Returns
    -------
    recommended : dict
        ``c_left``, ``c_right``, ``wheelbase_mm``, ``Ed``, ``Eb``.
    in_use : dict
        ``wheelbase_mm`` the odometry used.
    """
    corr = analysis.correction
    cal = corr.calibration
    assert cal.wheelbase_m is not None, "a correction's calibration holds the corrected wheelbase"
    recommended: dict[str, Any] = {
        "c_left": cal.c_left,
        "c_right": cal.c_right,
        "wheelbase_mm": cal.wheelbase_m * 1e3,
        "Ed": corr.ed,
        "Eb": corr.eb,
    }
    in_use: dict[str, Any] = {"wheelbase_mm": analysis.wheelbase_m * 1e3}
    return recommended, in_use


def runs_to_rows(runs: RunsTable) -> list[dict[str, Any]]:
    """A runs table as JSON-able rows in millimetres and degrees.

    Parameters
    ----------
    runs : RunsTable
        The runs.

    Returns
    -------
    list of dict
        One dict per run: ``run``, ``direction``, ``x_abs``, ``y_abs``, ``x_odo``, ``y_odo`` and
        the headings when the table has them.
    """
    rows = []
    for i in range(len(runs)):
        r: dict[str, Any] = {
            "run": str(runs.run[i]) if runs.run is not None else str(i + 1),
            "direction": str(runs.direction[i]),
            "x_abs": float(runs.x_abs[i]) * 1e3,
            "y_abs": float(runs.y_abs[i]) * 1e3,
            "x_odo": float(runs.x_odo[i]) * 1e3,
            "y_odo": float(runs.y_odo[i]) * 1e3,
        }
        if runs.theta_abs is not None:
            r["theta_abs"] = math.degrees(float(runs.theta_abs[i]))
        if runs.theta_odo is not None:
            r["theta_odo"] = math.degrees(float(runs.theta_odo[i]))
        rows.append(r)
    return rows


def runs_from_rows(rows: list[dict[str, Any]]) -> RunsTable:
    """Inverse of :func:`runs_to_rows` (for reports of recorded analyses).

    Parameters
    ----------
    rows : list of dict
        Rows as :func:`runs_to_rows` writes them.

    Returns
    -------
    RunsTable
    """
    import numpy as np

    from umbmark.model.runs import RunsTable

    if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
        raise InputError("the stored runs are not a list of runs (a damaged record)")
    g = lambda k: np.array([r[k] for r in rows], dtype=float) * 1e-3  # noqa: E731
    th = lambda k: np.radians(np.array([r[k] for r in rows], dtype=float)) if all(k in r for r in rows) else None  # noqa: E731
    try:
        return RunsTable.from_columns(
            [str(r["direction"]) for r in rows],
            g("x_abs"),
            g("y_abs"),
            g("x_odo"),
            g("y_odo"),
            th("theta_abs"),
            th("theta_odo"),
            np.array([str(r["run"]) for r in rows]),
        )
    except KeyError as e:
        raise InputError(f"a stored run has no {e.args[0]!r} (a damaged record)") from None
    except (TypeError, ValueError) as e:
        raise InputError(f"the stored runs hold a value that is not a number (a damaged record): {e}") from None


def export_parameters(record: Record) -> dict[str, Any]:
    """The parameters to load into the robot's odometry, from one record, saying what each
    holds: the wheel factors and E_b relative to the odometry the record's data were made
    with, the wheelbase that odometry used (``nominal_wheelbase_mm``) and the corrected one
    (``corrected_wheelbase_mm``), so that a reader (``umbmark export``) applies E_b once.

    Parameters
    ----------
    record : Record
        The record.

    Returns
    -------
    dict
        JSON-able: the record's ``robot``, ``record_id``, ``time_utc``, ``kind`` and ``method``;
        ``c_left``, ``c_right`` (factors on the nominal wheel diameters, any prior calibration
        included), ``Ed``, ``Eb`` (corrected over nominal wheelbase); ``nominal_wheelbase_mm``
        (the wheelbase the odometry used: the record's ``parameters_in_use``),
        ``corrected_wheelbase_mm`` and ``corrected_wheelbase_m`` (the one to load); the nominal
        wheel diameters and encoder units per wheel revolution when the record has them
        (``nominal_diameter_left_mm``, ``nominal_diameter_right_mm``, ``units_per_wheel_rev``);
        a self-calibration's ``sensor_pose`` (``x_mm``, ``y_mm``, ``yaw_deg``);
        ``scale_observed`` (whether the method measured the mean wheel scale; None: not known);
        ``parameters_in_use`` (what the robot ran with, as recorded); the measured
        ``emax_syst_mm_measured`` and the ``software_version`` that made it.
    """
    from umbmark.kinds import kind_in

    own = kind_in(record.parameters)
    if own is not None:
        return _kind_export(record, own)
    p = record.parameters
    wb_mm = _num(p.get("wheelbase_mm"))
    wb_m = _num(p.get("wheelbase_m"))
    if wb_mm is None and wb_m is not None:
        wb_mm = wb_m * 1e3
    piu = record.parameters_in_use if isinstance(record.parameters_in_use, dict) else {}
    nominal_wb = _num(piu.get("wheelbase_mm"))
    eb = record.eb if record.eb is not None else _num(p.get("Eb"))
    if nominal_wb is None and wb_mm is not None and eb:
        nominal_wb = wb_mm / eb  # the record holds the corrected wheelbase and E_b only
    d: dict[str, Any] = {
        "robot": record.robot,
        "record_id": record.id,
        "time_utc": record.created_utc,
        "kind": record.kind,
        "method": record.method,
        "c_left": _num(p.get("c_left")),
        "c_right": _num(p.get("c_right")),
        "Ed": record.ed,
        "Eb": eb,
        "nominal_wheelbase_mm": nominal_wb,
        "corrected_wheelbase_mm": wb_mm,
        "corrected_wheelbase_m": None if wb_mm is None else wb_mm * 1e-3,
    }
    dl = _num(piu.get("diameter_left_mm", piu.get("wheel_diameter_mm")))
    dr = _num(piu.get("diameter_right_mm", piu.get("wheel_diameter_mm")))
    if dl is not None and dr is not None:
        d["nominal_diameter_left_mm"], d["nominal_diameter_right_mm"] = dl, dr
    units = _num(piu.get("units_per_wheel_rev"))
    if units is not None:
        d["units_per_wheel_rev"] = units
    sp = p.get("sensor_pose")
    if isinstance(sp, dict) and all(_num(sp.get(k)) is not None for k in ("x_mm", "y_mm", "yaw_deg")):
        d["sensor_pose"] = {k: _num(sp[k]) for k in ("x_mm", "y_mm", "yaw_deg")}
    d.update(
        {
            "scale_observed": _scale_observed(record),
            "parameters_in_use": piu,
            "emax_syst_mm_measured": record.emax_syst_mm,
            "software_version": record.software_version,
        }
    )
    return d


def _kind_export(record: Record, own: Kind) -> dict[str, Any]:
    """:func:`export_parameters` of a record of a robot of a kind of its own: its geometry (the
    kind's JSON keys), its controller's parameters and the kind's own values to load
    (:meth:`umbmark.kinds.Kind.ros2_parameters`, :meth:`~umbmark.kinds.Kind.export_json`: as
    ``umbmark export --format json`` writes them), the lidar's pose and what the robot ran with.

    Raises
    ------
    HistoryError
        A geometry that is not the kind's (nothing to load).
    """
    p = record.parameters
    try:
        g, cis = own.geometry_from_json(p, f"record #{record.id}")
    except InputError as e:
        raise HistoryError(f"record #{record.id} of robot {record.robot!r} holds no usable geometry: {e}") from None
    sp = p.get("sensor_pose")
    d: dict[str, Any] = {
        "robot": record.robot,
        "record_id": record.id,
        "time_utc": record.created_utc,
        "kind": record.kind,
        "method": record.method,
        "kinematics": own.name,
        **own.geometry_json(g),
        "controller": own.controller,
        "controller_parameters": own.ros2_parameters(g),
        **own.export_json(g, {n: ci for n, ci in cis.items() if ci is not None}),
    }
    if isinstance(sp, dict) and all(_num(sp.get(k)) is not None for k in ("x_mm", "y_mm", "yaw_deg")):
        d["sensor_pose"] = {k: _num(sp[k]) for k in ("x_mm", "y_mm", "yaw_deg")}
    d["parameters_in_use"] = record.parameters_in_use if isinstance(record.parameters_in_use, dict) else {}
    d["software_version"] = record.software_version
    return d


def _scale_observed(record: Record) -> bool | None:
    """Whether the method behind a record measured the mean wheel scale (None: not known)."""
    res = record.results if isinstance(record.results, dict) else {}
    if record.kind == "selfcal":
        return True
    if record.kind in ("calibrate", "gyro") or record.method == "bf":
        return False
    if record.method == "lsq":
        return res.get("scale_fitted") if isinstance(res.get("scale_fitted"), bool) else None
    if record.method == "exact":
        es = res.get("Es_pass")
        return isinstance(es, (int, float)) and not isinstance(es, bool) and es != 1.0
    return None


def format_export(record: Record, fmt: str = "json", db: str | Path | None = None) -> str:
    """:func:`export_parameters` as JSON or YAML text.

    Parameters
    ----------
    record : Record
        The record.
    fmt : str
        ``"json"`` or ``"yaml"``.
    db : str or Path, optional
        The database the record is from (named in the message of a record with nothing to load).

    Returns
    -------
    str

    Raises
    ------
    InputError
        For another format.
    HistoryError
        If the record holds no usable wheel factors or E_b (nothing to load).
    """
    d = jsonable(export_parameters(record))
    for k in () if "kinematics" in d else ("c_left", "c_right", "Eb"):
        if not (d.get(k) is not None and d[k] > 0):
            raise HistoryError(
                f"record #{record.id} of robot {record.robot!r}"
                + ("" if db is None else f" in the history database {display_db(db)}")
                + f" holds no usable {k} "
                f"({_short(d.get(k))}): nothing exported"
            )
    if fmt == "json":
        return json.dumps(d, indent=2, allow_nan=False) + "\n"
    if fmt == "yaml":
        import yaml

        return yaml.safe_dump(d, sort_keys=False)
    raise InputError(f"unknown export format {fmt!r} (json or yaml)")
