"""Calibration history per robot, in an embedded SQLite database (standard library ``sqlite3``).

Every ``analyze`` / ``replay`` / ``calibrate`` result can be recorded: robot, time (UTC), kind of
command, method, inputs (the runs themselves, or a SHA-256 content hash of the logs and where
they came from), results, the parameters the robot ran with and the recommended ones, and the
umbmark version.

Where the database lives (first match): an explicit path (``--db``), the environment variable
``UMBMARK_DB``, ``$XDG_DATA_HOME/umbmark/history.sqlite`` (default
``~/.local/share/umbmark/history.sqlite``; ``%LOCALAPPDATA%\\umbmark`` on Windows,
``~/Library/Application Support/umbmark`` on macOS).

Integrity: the schema version is SQLite's ``user_version``; :data:`MIGRATIONS` upgrade an older
database in one transaction when it is opened; a database written by a newer umbmark is refused.
Every write is one ``BEGIN IMMEDIATE`` ... ``COMMIT`` transaction in WAL mode with
``synchronous=FULL`` and a busy timeout, so a writer killed mid-way leaves no partial record and
two processes writing at once queue up instead of failing (tests/test_history_concurrency.py
kills writers with SIGKILL and runs writers in parallel processes).

A database URL (``--db postgresql+psycopg://user@host/db``, or in ``UMBMARK_DB``) selects the
SQLAlchemy backend in :mod:`umbmark.history_sqlalchemy` (optional extras ``db`` / ``postgres``),
for a fleet sharing one PostgreSQL server.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import socket
import sqlite3
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from . import __version__
from .errors import InputError, UmbmarkError
from .jsonutil import dumps, jsonable

__all__ = [
    "SCHEMA_VERSION", "MIGRATIONS", "ENV_VAR", "KINDS", "Record", "History", "HistoryError",
    "default_db_path", "resolve_db_path", "resolve_db", "is_url", "display_db", "open_history", "make_row", "record_result",
    "record_analysis", "parameters_from_analysis",
    "file_sha256", "export_parameters", "format_export", "runs_to_rows", "runs_from_rows", "history_figure",
]

ENV_VAR = "UMBMARK_DB"
KINDS = ("analyze", "replay", "calibrate", "measure", "other")

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


class HistoryError(UmbmarkError):
    """The history database cannot be used (locked for too long, newer schema, not a database)."""


def default_db_path() -> Path:
    """The per-user default location (without looking at ``UMBMARK_DB``)."""
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Application Support"
    else:
        xdg = os.environ.get("XDG_DATA_HOME")
        base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "umbmark" / "history.sqlite"


def is_url(db) -> bool:
    """True for an SQLAlchemy database URL (``postgresql+psycopg://...``, ``sqlite:///...``)."""
    return isinstance(db, str) and "://" in db


def resolve_db(db=None):
    """``db`` if given, else ``$UMBMARK_DB``, else :func:`default_db_path`; a URL stays a string,
    a file becomes a :class:`Path`."""
    db = db or os.environ.get(ENV_VAR) or None
    if db is None:
        return default_db_path()
    if is_url(str(db)):
        return str(db)
    return Path(db).expanduser()


def display_db(db) -> str:
    """A database file or URL for messages, with any password in a URL masked."""
    import re

    return re.sub(r"(://[^:/@]*:)[^@]*@", r"\1***@", str(db))


def resolve_db_path(db=None) -> Path:
    """Like :func:`resolve_db`, for a database file (not a URL)."""
    r = resolve_db(db)
    if isinstance(r, str):
        raise InputError(f"{r!r} is a database URL, not a file")
    return r


def open_history(db=None, create: bool = True):
    """Open the history: :class:`History` (SQLite file, standard library) or, for a database URL,
    :class:`umbmark.history_sqlalchemy.SQLAlchemyHistory` (needs the ``db`` or ``postgres``
    extra). Both have the same methods."""
    r = resolve_db(db)
    if isinstance(r, str):
        from .history_sqlalchemy import SQLAlchemyHistory

        return SQLAlchemyHistory(r, create=create)
    return History(r, create=create)


def _now_utc() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def _utc_string(when) -> str:
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


def _dumps(o) -> str:
    return dumps(o, sort_keys=True)


def _num(v):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def file_sha256(path) -> str:
    """SHA-256 of a file's bytes, or of a folder's files (sorted relative paths and contents)."""
    p = Path(path)
    h = hashlib.sha256()
    if p.is_dir():
        for f in sorted(q for q in p.rglob("*") if q.is_file()):
            h.update(str(f.relative_to(p)).encode() + b"\0")
            with open(f, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
        return h.hexdigest()
    with open(p, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


@dataclass(frozen=True)
class Record:
    """One recorded calibration (a row of the ``calibrations`` table)."""

    id: int
    robot: str
    created_utc: str
    kind: str
    method: str
    software_version: str
    inputs: dict
    input_sha256: str | None
    source: str | None
    results: dict
    parameters: dict
    parameters_in_use: dict
    emax_syst_mm: float | None
    ed: float | None
    eb: float | None
    wheelbase_mm: float | None
    note: str | None = None
    host: str | None = None

    @property
    def time(self) -> datetime:
        return datetime.fromisoformat(self.created_utc.replace("Z", "+00:00"))

    def to_dict(self, full: bool = True) -> dict:
        d = {
            "id": self.id, "robot": self.robot, "time_utc": self.created_utc, "kind": self.kind,
            "method": self.method, "software_version": self.software_version, "source": self.source,
            "input_sha256": self.input_sha256, "emax_syst_mm": self.emax_syst_mm, "Ed": self.ed, "Eb": self.eb,
            "wheelbase_mm": self.wheelbase_mm, "parameters": self.parameters,
            "parameters_in_use": self.parameters_in_use, "note": self.note, "host": self.host,
        }
        if full:
            d["inputs"] = self.inputs
            d["results"] = self.results
        return d


_SELECT = """SELECT c.id, r.name, c.created_utc, c.kind, c.method, c.software_version, c.inputs_json,
                    c.input_sha256, c.source, c.results_json, c.parameters_json, c.parameters_in_use_json,
                    c.emax_syst_mm, c.ed, c.eb, c.wheelbase_mm, c.note, c.host
             FROM calibrations c JOIN robots r ON r.id = c.robot_id"""


def _record(row) -> Record:
    return Record(row[0], row[1], row[2], row[3], row[4], row[5], json.loads(row[6]), row[7], row[8],
                  json.loads(row[9]), json.loads(row[10]), json.loads(row[11]), row[12], row[13], row[14], row[15],
                  row[16], row[17])


def retry_while_locked(fn, timeout_s: float, errors):
    """Call ``fn`` until it does not raise a "database is locked" error (one of ``errors``) or
    ``timeout_s`` has passed. SQLite answers "locked" at once, without waiting for its busy
    timeout, in a few cases: two processes switching a new file to WAL at the same moment, or a
    read transaction that must become a write transaction."""
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
    :meth:`close`, :meth:`transaction`, ``_insert(conn, row)``, :meth:`records` and
    ``_robot_counts()`` (name, number of records, first and last time per robot)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def add(self, robot: str, *, kind: str, method: str, results: dict, parameters: dict,
            inputs: dict | None = None, input_sha256: str | None = None, source: str | None = None,
            parameters_in_use: dict | None = None, note: str | None = None, when=None,
            software_version: str | None = None) -> int:
        """Store one calibration in one transaction; returns its id."""
        row = self._row(robot, kind, method, results, parameters, inputs, input_sha256, source, parameters_in_use,
                        note, when, software_version)
        with self.transaction() as c:
            return self._insert(c, row)

    @staticmethod
    def _row(*args) -> dict:
        return make_row(*args)

    def latest(self, robot: str) -> Record:
        recs = self.records(robot, limit=1)
        if not recs:
            raise InputError(f"no calibrations of robot {robot!r} in the history database {self.path}"
                             + self._known_hint())
        return recs[0]

    def robots(self) -> list[dict]:
        """One summary per robot: name, number of records, first and last time, latest values."""
        out = []
        for name, n, first, last in self._robot_counts():
            d = {"robot": name, "records": n, "first_utc": first, "last_utc": last}
            if n:
                rec = self.latest(name)
                d.update({"latest_id": rec.id, "emax_syst_mm": rec.emax_syst_mm, "Ed": rec.ed, "Eb": rec.eb,
                          "wheelbase_mm": rec.wheelbase_mm})
            out.append(d)
        return out

    def _known_hint(self) -> str:
        names = [r["robot"] for r in self.robots()]
        return f" (robots: {', '.join(names)})" if names else " (it holds no robots yet)"


class History(_Backend):
    """An open history database. Use as a context manager, or call :meth:`close`."""

    def __init__(self, path=None, timeout_s: float = 60.0, create: bool = True):
        self.path = resolve_db_path(path)
        if not create and not self.path.exists():
            raise HistoryError(f"no history database at {self.path} (record a calibration with --robot NAME --record)")
        if self.path.is_dir():
            raise HistoryError(f"{self.path} is a folder, not a history database")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise HistoryError(f"cannot create the folder for the history database {self.path}: "
                               f"{e.strerror or e}") from None
        try:
            self._conn = sqlite3.connect(str(self.path), timeout=timeout_s, isolation_level=None)
        except sqlite3.Error as e:
            raise HistoryError(f"cannot open the history database {self.path}: {e}") from None
        def setup():
            self._conn.execute("PRAGMA foreign_keys = ON")
            self._conn.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
            self.journal_mode = self._conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            self._conn.execute("PRAGMA synchronous = FULL")
            self._migrate()

        try:
            retry_while_locked(setup, timeout_s, sqlite3.OperationalError)
        except sqlite3.DatabaseError as e:
            self._conn.close()
            raise HistoryError(f"{self.path} is not a usable umbmark history database: {e}") from None
        except BaseException:
            self._conn.close()
            raise

    # -- housekeeping --------------------------------------------------------------------------
    def close(self):
        self._conn.close()

    @contextmanager
    def transaction(self):
        """``BEGIN IMMEDIATE`` (takes the write lock, waiting up to the busy timeout) ... ``COMMIT``;
        ``ROLLBACK`` on any exception."""
        try:
            self._conn.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as e:
            raise HistoryError(f"history database {self.path} is busy: {e}") from None
        try:
            yield self._conn
        except BaseException:
            self._conn.execute("ROLLBACK")
            raise
        else:
            self._conn.execute("COMMIT")

    @property
    def schema_version(self) -> int:
        return self._conn.execute("PRAGMA user_version").fetchone()[0]

    def _migrate(self):
        if self.schema_version == SCHEMA_VERSION:
            return
        with self.transaction() as c:
            v = c.execute("PRAGMA user_version").fetchone()[0]
            if v > SCHEMA_VERSION:
                raise HistoryError(f"the history database {self.path} has schema version {v}, newer than this "
                                   f"umbmark ({__version__}, schema {SCHEMA_VERSION}): upgrade umbmark")
            if v == 0:
                tables = c.execute("SELECT count(*) FROM sqlite_master WHERE type = 'table'").fetchone()[0]
                if tables:
                    raise HistoryError(f"{self.path} is an SQLite database but not an umbmark history")
            for target in range(v + 1, SCHEMA_VERSION + 1):
                for stmt in MIGRATIONS[target]:
                    c.execute(stmt)
                c.execute(f"PRAGMA user_version = {target}")

    def integrity_check(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` ('ok' when the file is sound) plus a foreign-key check."""
        res = self._conn.execute("PRAGMA integrity_check").fetchall()
        fk = self._conn.execute("PRAGMA foreign_key_check").fetchall()
        text = "; ".join(r[0] for r in res)
        return text if not fk else f"{text}; foreign key violations: {len(fk)}"

    # -- writing -------------------------------------------------------------------------------
    def _insert(self, c, row: dict) -> int:
        """The statements of one record; call inside :meth:`transaction`."""
        c.execute("INSERT OR IGNORE INTO robots (name, created_utc) VALUES (?, ?)", (row["robot"], row["created_utc"]))
        robot_id = c.execute("SELECT id FROM robots WHERE name = ?", (row["robot"],)).fetchone()[0]
        cols = [k for k in row if k != "robot"]
        cur = c.execute(
            f"INSERT INTO calibrations (robot_id, {', '.join(cols)}) VALUES (?, {', '.join('?' for _ in cols)})",
            [robot_id] + [row[k] for k in cols])
        return int(cur.lastrowid)

    # -- reading -------------------------------------------------------------------------------
    def records(self, robot: str | None = None, limit: int | None = None) -> list[Record]:
        """Records, oldest first (of one robot, or of all); ``limit``: only the newest ``limit``."""
        q = _SELECT
        args: list = []
        if robot is not None:
            q += " WHERE r.name = ?"
            args.append(robot)
        q += " ORDER BY c.created_utc DESC, c.id DESC"
        if limit is not None:
            q += " LIMIT ?"
            args.append(int(limit))
        rows = self._conn.execute(q, args).fetchall()
        return [_record(r) for r in reversed(rows)]

    def get(self, record_id: int) -> Record:
        row = self._conn.execute(_SELECT + " WHERE c.id = ?", (int(record_id),)).fetchone()
        if row is None:
            raise InputError(f"no record #{record_id} in the history database {self.path}")
        return _record(row)

    def _robot_counts(self):
        return self._conn.execute(
            """SELECT r.name, count(c.id), min(c.created_utc), max(c.created_utc)
               FROM robots r LEFT JOIN calibrations c ON c.robot_id = r.id
               GROUP BY r.id ORDER BY r.name""").fetchall()

    def count(self) -> int:
        return self._conn.execute("SELECT count(*) FROM calibrations").fetchone()[0]


def make_row(robot, kind, method, results, parameters, inputs, input_sha256, source, parameters_in_use, note,
             when, software_version) -> dict:
    """The column values of one ``calibrations`` row (plus ``robot``), for any backend."""
    robot = _check_robot(robot)
    if kind not in KINDS:
        raise InputError(f"unknown record kind {kind!r} (one of {', '.join(KINDS)})")
    parameters = dict(parameters or {})
    results = dict(results or {})
    wb = _num(parameters.get("wheelbase_mm"))
    if wb is None and _num(parameters.get("wheelbase_m")) is not None:
        wb = _num(parameters.get("wheelbase_m")) * 1e3
    return {
        "robot": robot, "created_utc": _utc_string(when), "kind": kind, "method": str(method),
        "software_version": software_version or __version__,
        "inputs_json": _dumps(inputs or {}), "input_sha256": input_sha256,
        "source": None if source is None else str(source),
        "results_json": _dumps(results), "parameters_json": _dumps(parameters),
        "parameters_in_use_json": _dumps(parameters_in_use or {}),
        "emax_syst_mm": _num(results.get("emax_syst_mm")),
        "ed": _num(parameters.get("Ed", results.get("Ed"))),
        "eb": _num(parameters.get("Eb", results.get("Eb"))),
        "wheelbase_mm": wb, "note": note, "host": socket.gethostname(),
    }


def _check_robot(robot) -> str:
    if robot is None or not str(robot).strip():
        raise InputError("a robot name is needed to record a calibration (--robot NAME)")
    robot = str(robot).strip()
    if len(robot) > 200 or any(ord(ch) < 32 for ch in robot):
        raise InputError(f"robot name {robot[:40]!r} must be at most 200 printable characters")
    return robot


def record_result(robot: str, *, kind: str, method: str, results: dict, parameters: dict, db=None,
                  inputs: dict | None = None, input_sha256: str | None = None, source=None,
                  parameters_in_use: dict | None = None, note: str | None = None, when=None) -> int:
    """Open the history database (``db``, ``$UMBMARK_DB`` or the default), store one
    calibration in one transaction, close it; returns the record id.

    ``results``: the command's result dict (``emax_syst_mm`` is picked up for the plots);
    ``parameters``: the recommended odometry parameters, keys ``c_left``, ``c_right``,
    ``wheelbase_mm`` (or ``wheelbase_m``), ``Ed``, ``Eb``; ``parameters_in_use``: the ones the
    robot ran with; ``inputs``: the runs (or anything JSON) and/or ``input_sha256`` plus ``source``
    (the file or folder the input came from: see :func:`file_sha256`)."""
    with open_history(db) as h:
        return h.add(robot, kind=kind, method=method, results=results, parameters=parameters, inputs=inputs,
                     input_sha256=input_sha256, source=source, parameters_in_use=parameters_in_use, note=note,
                     when=when)


def parameters_from_analysis(analysis) -> tuple[dict, dict]:
    """``(recommended, in_use)`` parameter dicts of a :class:`umbmark.workflows.Analysis`."""
    corr = analysis.correction
    cal = corr.calibration
    recommended = {"c_left": cal.c_left, "c_right": cal.c_right, "wheelbase_mm": cal.wheelbase_m * 1e3,
                   "Ed": corr.ed, "Eb": corr.eb}
    in_use = {"wheelbase_mm": analysis.wheelbase_m * 1e3}
    return recommended, in_use


def runs_to_rows(runs) -> list[dict]:
    """A runs table as JSON-able rows in millimetres and degrees."""
    rows = []
    for i in range(len(runs)):
        r = {"run": str(runs.run[i]) if runs.run is not None else str(i + 1), "direction": str(runs.direction[i]),
             "x_abs": float(runs.x_abs[i]) * 1e3, "y_abs": float(runs.y_abs[i]) * 1e3,
             "x_odo": float(runs.x_odo[i]) * 1e3, "y_odo": float(runs.y_odo[i]) * 1e3}
        if runs.theta_abs is not None:
            r["theta_abs"] = math.degrees(float(runs.theta_abs[i]))
        if runs.theta_odo is not None:
            r["theta_odo"] = math.degrees(float(runs.theta_odo[i]))
        rows.append(r)
    return rows


def runs_from_rows(rows: list[dict]):
    """Inverse of :func:`runs_to_rows` (for reports of recorded analyses)."""
    import numpy as np

    from .runs import RunsTable

    g = lambda k: np.array([r[k] for r in rows], dtype=float) * 1e-3  # noqa: E731
    th = lambda k: np.radians([r[k] for r in rows]) if rows and all(k in r for r in rows) else None  # noqa: E731
    return RunsTable.from_columns([r["direction"] for r in rows], g("x_abs"), g("y_abs"), g("x_odo"), g("y_odo"),
                                  th("theta_abs"), th("theta_odo"), np.array([r["run"] for r in rows]))


def record_analysis(robot: str, analysis, *, kind: str = "analyze", source=None, db=None, prior=None,
                    note: str | None = None, when=None, extra_inputs: dict | None = None) -> int:
    """Record a :class:`umbmark.workflows.Analysis` (the runs are stored in the record; the
    source file, if given and readable, is hashed). ``prior``: the
    :class:`umbmark.kinematics.Calibration` the robot ran with, or None."""
    recommended, in_use = parameters_from_analysis(analysis)
    if prior is not None:
        in_use.update({"c_left": prior.c_left, "c_right": prior.c_right})
        if prior.wheelbase_m is not None:
            in_use["wheelbase_mm"] = prior.wheelbase_m * 1e3
    else:
        in_use.update({"c_left": 1.0, "c_right": 1.0})
    sha = None
    if source is not None and Path(source).exists():
        sha = file_sha256(source)
    inputs = {"runs": runs_to_rows(analysis.runs), "side_mm": analysis.side_m * 1e3,
              "wheelbase_mm": analysis.wheelbase_m * 1e3}
    inputs.update(extra_inputs or {})
    results = analysis.to_dict()
    return record_result(robot, kind=kind, method=analysis.correction.method, results=results,
                         parameters=recommended, db=db, inputs=inputs, input_sha256=sha,
                         source=None if source is None else str(Path(source).resolve()),
                         parameters_in_use=in_use, note=note, when=when)


def export_parameters(record: Record) -> dict:
    """The parameters to load into the robot's odometry, from one record (JSON-able)."""
    p = record.parameters
    wb_mm = _num(p.get("wheelbase_mm"))
    if wb_mm is None and _num(p.get("wheelbase_m")) is not None:
        wb_mm = _num(p.get("wheelbase_m")) * 1e3
    return {
        "robot": record.robot,
        "record_id": record.id,
        "time_utc": record.created_utc,
        "kind": record.kind,
        "method": record.method,
        "c_left": _num(p.get("c_left")),
        "c_right": _num(p.get("c_right")),
        "wheelbase_m": None if wb_mm is None else wb_mm * 1e-3,
        "wheelbase_mm": wb_mm,
        "Ed": record.ed,
        "Eb": record.eb,
        "emax_syst_mm_measured": record.emax_syst_mm,
        "software_version": record.software_version,
    }


def format_export(record: Record, fmt: str = "json") -> str:
    """:func:`export_parameters` as JSON or YAML text."""
    d = jsonable(export_parameters(record))
    if fmt == "json":
        return json.dumps(d, indent=2, allow_nan=False) + "\n"
    if fmt == "yaml":
        import yaml

        return yaml.safe_dump(d, sort_keys=False)
    raise InputError(f"unknown export format {fmt!r} (json or yaml)")


@dataclass
class _Series:
    """Time series of one robot's records, for plots."""

    times: list = field(default_factory=list)
    emax_syst_mm: list = field(default_factory=list)
    ed: list = field(default_factory=list)
    eb: list = field(default_factory=list)
    wheelbase_mm: list = field(default_factory=list)
    ids: list = field(default_factory=list)


def series(records: list[Record]) -> _Series:
    s = _Series()
    for r in records:
        s.times.append(r.time)
        s.emax_syst_mm.append(r.emax_syst_mm)
        s.ed.append(r.ed)
        s.eb.append(r.eb)
        s.wheelbase_mm.append(r.wheelbase_mm)
        s.ids.append(r.id)
    return s


def history_figure(records: list[Record], title: str | None = None):
    """E_max,syst, E_d, E_b and the recommended wheelbase over time (one panel each)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    s = series(records)
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    panels = [
        (s.emax_syst_mm, "E_max,syst [mm]\n(measured, before)"),
        (s.ed, "E_d = D_R / D_L"),
        (s.eb, "E_b"),
        (s.wheelbase_mm, "wheelbase [mm]\n(recommended)"),
    ]
    for ax, (vals, label) in zip(axes, panels):
        pts = [(t, v) for t, v in zip(s.times, vals) if v is not None]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", color="tab:blue", ms=5)
            for (t, v), rid in zip(pts, [i for i, v in zip(s.ids, vals) if v is not None]):
                ax.annotate(f"#{rid}", (t, v), textcoords="offset points", xytext=(4, 4), fontsize=7, color="0.35")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, lw=0.3)
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    axes[0].set_ylim(bottom=0)
    loc = mdates.AutoDateLocator()
    axes[-1].xaxis.set_major_locator(loc)
    axes[-1].xaxis.set_major_formatter(mdates.ConciseDateFormatter(loc))
    axes[-1].set_xlabel("time (UTC)")
    robot = records[0].robot if records else ""
    fig.suptitle(title or f"Calibration history of {robot} ({len(records)} records)")
    fig.tight_layout()
    return fig
