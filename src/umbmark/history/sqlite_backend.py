"""The history in an embedded SQLite file (standard library ``sqlite3``): WAL mode, one
``BEGIN IMMEDIATE`` transaction per write, schema migrations in one transaction."""

from __future__ import annotations

import sqlite3
from contextlib import contextmanager

from umbmark._version import __version__
from umbmark.errors import InputError
from umbmark.history.base import (
    _SELECT,
    MIGRATIONS,
    SCHEMA_VERSION,
    HistoryError,
    Record,
    _Backend,
    _record,
    resolve_db_path,
    retry_while_locked,
)

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

    def __init__(self, path=None, timeout_s: float = 60.0, create: bool = True):
        self.path = resolve_db_path(path)
        if not create and not self.path.exists():
            raise HistoryError(
                f"no history database at {self.path} (record a calibration with `robot` and `record=True`)"
            )
        if self.path.is_dir():
            raise HistoryError(f"{self.path} is a folder, not a history database")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise HistoryError(
                f"cannot create the folder for the history database {self.path}: {e.strerror or e}"
            ) from None
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
    def close(self) -> None:
        """Close the connection."""
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
        """The schema version of the file (SQLite's ``user_version``)."""
        return self._conn.execute("PRAGMA user_version").fetchone()[0]

    def _migrate(self):
        if self.schema_version == SCHEMA_VERSION:
            return
        with self.transaction() as c:
            v = c.execute("PRAGMA user_version").fetchone()[0]
            if v > SCHEMA_VERSION:
                raise HistoryError(
                    f"the history database {self.path} has schema version {v}, newer than this "
                    f"umbmark ({__version__}, schema {SCHEMA_VERSION}): upgrade umbmark"
                )
            if v == 0:
                tables = c.execute("SELECT count(*) FROM sqlite_master WHERE type = 'table'").fetchone()[0]
                if tables:
                    raise HistoryError(f"{self.path} is an SQLite database but not an umbmark history")
            for target in range(v + 1, SCHEMA_VERSION + 1):
                for stmt in MIGRATIONS[target]:
                    c.execute(stmt)
                c.execute(f"PRAGMA user_version = {target}")

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
    def _insert(self, c, row: dict) -> int:
        """The statements of one record; call inside :meth:`transaction`."""
        c.execute("INSERT OR IGNORE INTO robots (name, created_utc) VALUES (?, ?)", (row["robot"], row["created_utc"]))
        robot_id = c.execute("SELECT id FROM robots WHERE name = ?", (row["robot"],)).fetchone()[0]
        cols = [k for k in row if k != "robot"]
        cur = c.execute(
            f"INSERT INTO calibrations (robot_id, {', '.join(cols)}) VALUES (?, {', '.join('?' for _ in cols)})",
            [robot_id] + [row[k] for k in cols],
        )
        return int(cur.lastrowid)

    # -- reading -------------------------------------------------------------------------------
    def records(self, robot: str | None = None, limit: int | None = None) -> list[Record]:
        """Records, oldest first.

        Parameters
        ----------
        robot : str, optional
            Only this robot's (default: all).
        limit : int, optional
            Only the newest ``limit`` records.

        Returns
        -------
        list of Record
        """
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
            If there is no such record.
        """
        row = self._conn.execute(_SELECT + " WHERE c.id = ?", (int(record_id),)).fetchone()
        if row is None:
            raise InputError(f"no record #{record_id} in the history database {self.path}")
        return _record(row)

    def _robot_counts(self):
        return self._conn.execute(
            """SELECT r.name, count(c.id), min(c.created_utc), max(c.created_utc)
               FROM robots r LEFT JOIN calibrations c ON c.robot_id = r.id
               GROUP BY r.id ORDER BY r.name"""
        ).fetchall()

    def count(self) -> int:
        """Number of records of all robots."""
        return self._conn.execute("SELECT count(*) FROM calibrations").fetchone()[0]
