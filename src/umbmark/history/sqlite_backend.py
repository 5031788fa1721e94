"""The history in an embedded SQLite file (standard library ``sqlite3``): WAL mode, one
``BEGIN IMMEDIATE`` transaction per write, schema migrations in one transaction."""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any
from urllib.parse import quote

from umbmark._version import __version__
from umbmark.history.address import resolve_db_path
from umbmark.history.base import _Backend
from umbmark.history.records import HistoryError, NoHistory
from umbmark.history.schema import _SELECT, MIGRATIONS, SCHEMA_VERSION, TABLE_COLUMNS, retry_while_locked

__all__ = ["History"]


class History(_Backend):
    """An open history database in an SQLite file. Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    path : str or Path, optional
        The file (default: ``$UMBMARK_DB``, else :func:`umbmark.history.base.default_db_path`).
    timeout_s : float
        How long a write waits for another writer (SQLite's busy timeout).
    create : bool
        Create the file (and its folder) if missing; else a missing file is an error.

    Raises
    ------
    HistoryError
        If the file is missing (``create=False``), a folder, not an umbmark history, of a newer
        schema, or cannot be opened.
    """

    path: Path
    journal_mode: str
    read_only: bool
    _conn: sqlite3.Connection

    def __init__(self, path: str | Path | None = None, timeout_s: float = 60.0, create: bool = True) -> None:
        self.path = resolve_db_path(path)
        self.read_only = False
        if not create and not self.path.exists():
            raise NoHistory(f"no history database at {self.path} (record a calibration with `robot` and `record=True`)")
        if self.path.is_dir():
            raise HistoryError(f"{self.path} is a folder, not a history database")
        if not create and self.path.stat().st_size == 0:  # reading does not make it a history
            raise NoHistory(
                f"no umbmark history in {self.path}: the file is empty "
                "(record a calibration with `robot` and `record=True`)"
            )
        if create:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise HistoryError(
                    f"cannot create the folder for the history database {self.path}: {e.strerror or e}"
                ) from None
        existed = self.path.exists()
        try:
            self._conn = sqlite3.connect(str(self.path), timeout=timeout_s, isolation_level=None)
        except sqlite3.Error as e:
            why = (
                ""
                if existed or os.access(self.path.parent, os.W_OK)
                else f" (its folder {self.path.parent} is read-only)"
            )
            raise HistoryError(f"cannot open the history database {self.path}: {e}{why}") from None

        def setup() -> None:
            self._conn.execute("PRAGMA foreign_keys = ON")
            self._conn.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
            self._refuse_foreign()  # before anything is written: another application's file stays as it is
            self.journal_mode = self._conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            self._conn.execute("PRAGMA synchronous = FULL")
            self._migrate()

        try:
            retry_while_locked(setup, timeout_s, sqlite3.OperationalError)
        except sqlite3.DatabaseError as e:
            self._conn.close()
            if not create and _unwritable(e):
                self._open_read_only(timeout_s)  # a read-only file or folder: reading still works
                return
            if not existed:
                self._remove_new()
            raise self._damaged(e) from None
        except BaseException:
            self._conn.close()
            if not existed:
                self._remove_new()
            raise

    def _remove_new(self) -> None:
        """Remove the file this open created (and SQLite's files beside it): a history that could
        not be set up leaves nothing behind."""
        for p in (
            self.path,
            self.path.with_name(self.path.name + "-wal"),
            self.path.with_name(self.path.name + "-shm"),
        ):
            try:
                p.unlink()
            except OSError:
                pass

    def _open_read_only(self, timeout_s: float) -> None:
        """Open the file for reading only: ``mode=ro``, or ``immutable=1`` when SQLite cannot
        even create the shared-memory file of a WAL database beside it (a read-only folder)."""
        uri = "file:" + quote(str(self.path.resolve()))
        last: sqlite3.Error | None = None
        for query in ("?mode=ro", "?mode=ro&immutable=1"):
            try:
                conn = sqlite3.connect(uri + query, uri=True, timeout=timeout_s, isolation_level=None)
            except sqlite3.Error as e:
                last = e
                continue
            try:
                self.journal_mode = conn.execute("PRAGMA journal_mode").fetchone()[0]
                self._conn = conn
                v = self.schema_version
                if v > SCHEMA_VERSION:
                    raise HistoryError(self._newer(v))
                if v < SCHEMA_VERSION:
                    raise HistoryError(
                        f"the history database {self.path} has schema version {v} and is read-only: "
                        "umbmark cannot upgrade it to read it (make it writable once)"
                    )
                self._check_schema(conn, v)
            except sqlite3.DatabaseError as e:
                conn.close()
                last = e
                continue
            except BaseException:
                conn.close()
                raise
            self.read_only = True
            return
        raise self._damaged(last) from None

    def _damaged(self, e: sqlite3.Error | None) -> HistoryError:
        """The error for an SQLite error ``e`` while reading or opening the file."""
        msg = str(e)
        if _unwritable(e):
            return HistoryError(
                f"cannot use the history database {self.path}: {msg} (the file or its folder is read-only)"
            )
        if "disk I/O error" in msg:
            return HistoryError(
                f"cannot use the history database {self.path}: {msg} (a full disk, or the file system failed)"
            )
        if "disk is full" in msg:
            return HistoryError(f"cannot write the history database {self.path}: no space left on device ({msg})")
        if "malformed" in msg or "corrupt" in msg:
            return HistoryError(f"the history database {self.path} is damaged: {msg}")
        return HistoryError(f"{self.path} is not a usable umbmark history database: {msg}")

    def _newer(self, v: int) -> str:
        return (
            f"the history database {self.path} has schema version {v}, newer than this "
            f"umbmark ({__version__}, schema {SCHEMA_VERSION}): upgrade umbmark"
        )

    def _query(self, sql: str, args: Sequence[Any] = ()) -> list[Any]:
        """``sql`` and all its rows; an SQLite error becomes a :class:`HistoryError`."""
        try:
            return self._conn.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as e:
            raise self._damaged(e) from None

    # -- housekeeping --------------------------------------------------------------------------
    def close(self) -> None:
        """Close the connection."""
        self._conn.close()

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """``BEGIN IMMEDIATE`` (takes the write lock, waiting up to the busy timeout) ... ``COMMIT``;
        ``ROLLBACK`` on any exception. An SQLite error in it becomes a :class:`HistoryError`."""
        if self.read_only:
            raise HistoryError(f"cannot write to the history database {self.path}: the file or its folder is read-only")
        try:
            self._conn.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as e:
            if _unwritable(e):
                raise self._write_error(e) from None
            raise HistoryError(f"history database {self.path} is busy: {e}") from None
        except sqlite3.DatabaseError as e:
            raise self._damaged(e) from None
        try:
            yield self._conn
        except BaseException as e:
            try:
                self._conn.execute("ROLLBACK")
            except sqlite3.Error:
                pass  # the transaction is gone already (SQLite rolled it back)
            if isinstance(e, sqlite3.DatabaseError):
                raise self._write_error(e) from None
            raise
        else:
            try:
                self._conn.execute("COMMIT")
            except sqlite3.DatabaseError as e:
                try:
                    self._conn.execute("ROLLBACK")
                except sqlite3.Error:
                    pass
                raise self._write_error(e) from None

    def _write_error(self, e: sqlite3.Error) -> HistoryError:
        if _unwritable(e):
            return HistoryError(
                f"cannot write to the history database {self.path}: {e} (the file or its folder is read-only)"
            )
        if isinstance(e, sqlite3.OperationalError) and "locked" in str(e):
            return HistoryError(f"history database {self.path} is busy: {e}")
        return self._damaged(e)

    @property
    def schema_version(self) -> int:
        """The schema version of the file (SQLite's ``user_version``)."""
        return self._conn.execute("PRAGMA user_version").fetchone()[0]

    def _refuse_foreign(self) -> None:
        """Raise for a file of a newer umbmark, another application's database or a damaged
        schema, reading only.

        The version and the tables are read in one read transaction: another process creating
        the schema of the same new file commits both at once, and reads outside a transaction
        could see the version before its commit and the tables after it."""
        self._conn.execute("BEGIN")
        try:
            v = self.schema_version
            if v > SCHEMA_VERSION:
                raise HistoryError(self._newer(v))
            if v == 0:
                if self._conn.execute("SELECT count(*) FROM sqlite_master WHERE type = 'table'").fetchone()[0]:
                    raise HistoryError(f"{self.path} is an SQLite database but not an umbmark history")
            else:
                self._check_schema(self._conn, v)
        finally:
            if self._conn.in_transaction:  # (a read transaction: nothing to keep)
                self._conn.execute("ROLLBACK")

    def _migrate(self) -> None:
        v = self.schema_version
        if v == SCHEMA_VERSION:
            self._check_schema(self._conn, v)
            return
        with self.transaction() as c:
            v = c.execute("PRAGMA user_version").fetchone()[0]
            if v > SCHEMA_VERSION:
                raise HistoryError(self._newer(v))
            if v == 0:
                tables = c.execute("SELECT count(*) FROM sqlite_master WHERE type = 'table'").fetchone()[0]
                if tables:
                    raise HistoryError(f"{self.path} is an SQLite database but not an umbmark history")
            else:
                self._check_schema(c, v)
            for target in range(v + 1, SCHEMA_VERSION + 1):
                for stmt in MIGRATIONS[target]:
                    c.execute(stmt)
                c.execute(f"PRAGMA user_version = {target}")

    def _check_schema(self, conn: sqlite3.Connection, version: int) -> None:
        """The tables and columns of schema ``version`` are there (another application's
        database may have the same ``user_version``; a table may have been dropped)."""
        found = {
            t: {r[1] for r in conn.execute(f"PRAGMA table_info({t})").fetchall()}  # noqa: S608  fixed names
            for t in TABLE_COLUMNS
        }
        if not any(found.values()):
            raise HistoryError(
                f"{self.path} is an SQLite database but not an umbmark history "
                f"(schema version {version}, no robots or calibrations table)"
            )
        for t, cols in TABLE_COLUMNS.items():
            if not found[t]:
                raise HistoryError(f"the history database {self.path} is damaged: its table {t!r} is missing")
            # columns added by a later migration are not expected in an older schema
            later = {
                stmt.split("ADD COLUMN ")[1].split()[0]
                for m in range(version + 1, SCHEMA_VERSION + 1)
                for stmt in MIGRATIONS[m]
                if f"ALTER TABLE {t} ADD COLUMN" in stmt
            }
            missing = [c for c in cols if c not in found[t] and c not in later]
            if missing:
                raise HistoryError(
                    f"the history database {self.path} is damaged or not an umbmark history: "
                    f"table {t!r} has no column {', '.join(missing)}"
                )

    def integrity_check(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` plus a foreign-key check.

        Returns
        -------
        str
            ``"ok"`` when the file is sound, else what is wrong.
        """
        res = self._conn.execute("PRAGMA integrity_check").fetchall()
        fk = self._conn.execute("PRAGMA foreign_key_check").fetchall()
        text = "; ".join(r[0] for r in res)
        return text if not fk else f"{text}; foreign key violations: {len(fk)}"

    # -- writing -------------------------------------------------------------------------------
    def _insert(self, c: sqlite3.Connection, row: dict[str, Any]) -> int:
        """The statements of one record; call inside :meth:`transaction`."""
        c.execute("INSERT OR IGNORE INTO robots (name, created_utc) VALUES (?, ?)", (row["robot"], row["created_utc"]))
        robot_id = c.execute("SELECT id FROM robots WHERE name = ?", (row["robot"],)).fetchone()[0]
        cols = [k for k in row if k != "robot"]
        cur = c.execute(
            f"INSERT INTO calibrations (robot_id, {', '.join(cols)}) VALUES (?, {', '.join('?' for _ in cols)})",
            [robot_id] + [row[k] for k in cols],
        )
        assert cur.lastrowid is not None  # set by the INSERT just made
        return int(cur.lastrowid)

    # -- reading -------------------------------------------------------------------------------
    def _fetch(self, robot: str | None = None, limit: int | None = None, record_id: int | None = None) -> list[Any]:
        """The rows of ``_SELECT``, newest first (the robot's name and the id matched exactly)."""
        q = _SELECT
        args: list[Any] = []
        if record_id is not None:
            q += " WHERE c.id = ?"
            args.append(int(record_id))
        elif robot is not None:
            q += " WHERE r.name = ?"
            args.append(str(robot))
        q += " ORDER BY c.created_utc DESC, c.id DESC"
        if limit is not None:
            q += " LIMIT ?"
            args.append(int(limit))
        return self._query(q, args)

    def _same_rows(self, conn: Any, robot: str, input_sha256: str, kind: str, method: str) -> list[Any]:
        sql = _SELECT + " WHERE r.name = ? AND c.input_sha256 = ? AND c.kind = ? AND c.method = ? ORDER BY c.id"
        args = (robot, input_sha256, kind, method)
        if conn is None:
            return self._query(sql, args)
        return conn.execute(sql, args).fetchall()

    def _robot_counts(self) -> list[Any]:
        return self._query(
            """SELECT r.name, count(c.id), min(c.created_utc), max(c.created_utc)
               FROM robots r LEFT JOIN calibrations c ON c.robot_id = r.id
               GROUP BY r.id ORDER BY r.name"""
        )

    def count(self) -> int:
        """Number of records of all robots."""
        return self._query("SELECT count(*) FROM calibrations")[0][0]


def _unwritable(e: object) -> bool:
    """An SQLite error that says the file or its folder cannot be written (or opened as such)."""
    m = str(e)
    return "readonly" in m or "read-only" in m or "unable to open database file" in m
