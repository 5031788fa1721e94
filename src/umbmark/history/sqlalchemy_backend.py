"""The calibration history on any SQLAlchemy database (PostgreSQL for a fleet), selected by a
database URL in ``--db`` or ``UMBMARK_DB``, e.g. ``postgresql+psycopg://user:pw@host/umbmark``.

Needs the optional extra ``db`` (SQLAlchemy) or ``postgres`` (SQLAlchemy + psycopg). Same tables
and columns as the SQLite backend (:mod:`umbmark.history.sqlite_backend`); the schema version is kept in a
one-row table ``umbmark_schema`` (SQLite's ``user_version`` is not portable). Each record is one
transaction; on PostgreSQL a client killed mid-transaction is rolled back by the server, and two
writers creating the same robot at once are resolved with a savepoint (the loser re-reads the
winner's row).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, TypeVar

from umbmark._version import __version__
from umbmark.errors import InputError
from umbmark.history.address import _split_userinfo, display_db, mask_secrets
from umbmark.history.base import _Backend
from umbmark.history.records import HistoryError, NoHistory
from umbmark.history.schema import SCHEMA_VERSION, TABLE_COLUMNS, retry_while_locked

if TYPE_CHECKING:  # SQLAlchemy is an optional dependency: imported at run time by _import only
    from sqlalchemy import URL, Connection, Engine, MetaData, Select, Table

__all__ = ["SQLAlchemyHistory"]

# the columns of a record row: the calibration's, with the robot's name in place of its id
_COLS = ("id", "name", *TABLE_COLUMNS["calibrations"][2:])

_T = TypeVar("_T")


def _import() -> ModuleType:
    try:
        import sqlalchemy as sa
    except ImportError:
        raise HistoryError(
            "a database URL needs SQLAlchemy: pip install 'umbmark[db]' (or 'umbmark[postgres]' for PostgreSQL)"
        ) from None
    return sa


def _parse_url(sa: ModuleType, url: str) -> URL:
    """The SQLAlchemy URL, with the credentials split off at the last ``@`` before the host (as
    :func:`umbmark.history.base.display_db` does): SQLAlchemy's parser ends the password at its
    first ``@`` and would take the rest of it for the host."""
    from urllib.parse import unquote

    scheme, _, rest = url.partition("://")
    user, pw, tail = _split_userinfo(rest)
    if pw is None:
        return sa.engine.make_url(url)
    return sa.engine.make_url(f"{scheme}://{user}@{tail}").set(password=unquote(pw))


def _tables(sa: ModuleType) -> tuple[MetaData, Table, Table, Table]:
    md = sa.MetaData()
    schema = sa.Table("umbmark_schema", md, sa.Column("version", sa.Integer, nullable=False))
    robots = sa.Table(
        "robots",
        md,
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("created_utc", sa.String(32), nullable=False),
    )
    cal = sa.Table(
        "calibrations",
        md,
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("created_utc", sa.String(32), nullable=False),
        sa.Column("kind", sa.String(20), nullable=False),
        sa.Column("method", sa.String(100), nullable=False),
        sa.Column("software_version", sa.String(64), nullable=False),
        sa.Column("inputs_json", sa.Text, nullable=False),
        sa.Column("input_sha256", sa.String(64)),
        sa.Column("source", sa.Text),
        sa.Column("results_json", sa.Text, nullable=False),
        sa.Column("parameters_json", sa.Text, nullable=False),
        sa.Column("parameters_in_use_json", sa.Text, nullable=False),
        sa.Column("emax_syst_mm", sa.Float),
        sa.Column("ed", sa.Float),
        sa.Column("eb", sa.Float),
        sa.Column("wheelbase_mm", sa.Float),
        sa.Column("note", sa.Text),
        sa.Column("host", sa.String(255)),
        sa.Index("calibrations_robot_time", "robot_id", "created_utc", "id"),
    )
    return md, schema, robots, cal


_SCHEMA_LOCK = 0x756D626D  # the advisory lock that serialises schema creation on PostgreSQL ("umbm")
# the advisory lock every write transaction takes first on PostgreSQL: umbmark's writes are a few
# rows each, so one at a time costs nothing, and two writers can never deadlock on the rows and
# indexes of the robots and calibrations tables ("umbw")
_WRITE_LOCK = 0x756D6277


class SQLAlchemyHistory(_Backend):
    """Same interface as :class:`umbmark.history.sqlite_backend.History`, on an SQLAlchemy engine.

    Parameters
    ----------
    url : str
        The database URL, e.g. ``postgresql+psycopg://user:pw@host/umbmark``.
    timeout_s : float
        How long to retry while the database is locked (SQLite: also its busy timeout).
    create : bool
        Create the tables if the database has none; else that is an error.

    Raises
    ------
    InputError
        If ``url`` is not a database URL.
    HistoryError
        If SQLAlchemy or the driver is missing, the database cannot be reached, holds other
        tables of the same names, or has a newer schema.
    """

    path: str
    _engine: Engine

    def __init__(self, url: str, timeout_s: float = 60.0, create: bool = True) -> None:
        sa = self._sa = _import()
        try:
            u = _parse_url(sa, url)
        except Exception:  # noqa: BLE001  sqlalchemy.exc.ArgumentError (its message holds the URL)
            raise InputError(f"not a database URL: {display_db(url)!r}") from None
        self._shown = self.path = display_db(url)
        kwargs: dict[str, Any] = {}
        if u.get_backend_name() == "sqlite":
            kwargs["connect_args"] = {"timeout": timeout_s}
            f = u.database
            if (
                not create
                and f
                and f != ":memory:"
                and not f.startswith("file:")
                and not (Path(f).is_file() and Path(f).stat().st_size > 0)
            ):
                # reading must not create the file (SQLite would, on connecting)
                raise NoHistory(
                    f"no umbmark history in {self._shown}: no such file, or an empty one "
                    "(record a calibration with `robot` and `record=True`)"
                )
        try:
            self._engine = sa.create_engine(u, **kwargs)
        except Exception as e:  # noqa: BLE001  missing driver etc.
            raise HistoryError(f"cannot use the history database {self._shown}: {self._message(e)}") from None
        if u.get_backend_name() == "sqlite":
            # pysqlite's implicit transactions start too late for concurrent writers: take the
            # write lock at BEGIN, as the standard-library backend does
            @sa.event.listens_for(self._engine, "connect")
            def _connect(dbapi_conn: Any, record: Any) -> None:
                dbapi_conn.isolation_level = None
                # WAL (a setting kept in the file) only for a new file or an umbmark history:
                # another application's database, refused below, is left as it was
                tables = {r[0] for r in dbapi_conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
                wal = not tables or "umbmark_schema" in tables
                for pragma in ("foreign_keys = ON", "journal_mode = WAL" if wal else None, "synchronous = FULL"):
                    if pragma:
                        dbapi_conn.execute(f"PRAGMA {pragma}")

            @sa.event.listens_for(self._engine, "begin")
            def _begin(conn: Connection) -> None:
                conn.exec_driver_sql("BEGIN IMMEDIATE" if conn.info.get("umbmark_write") else "BEGIN")

        self._md, self._schema, self._robots, self._cal = _tables(sa)
        self.journal_mode = None
        try:
            self._migrating = True
            retry_while_locked(lambda: self._migrate(create), timeout_s, self._sa.exc.OperationalError)
            self._migrating = False
        except HistoryError:
            self._engine.dispose()
            raise
        except sa.exc.SQLAlchemyError as e:
            self._engine.dispose()
            raise self._error(e) from None

    @staticmethod
    def _message(e: BaseException) -> str:
        """The first line of an error, any URL in it masked."""
        lines = str(e).strip().splitlines()
        return mask_secrets(lines[0] if lines else e.__class__.__name__)

    def _error(self, e: BaseException) -> HistoryError:
        """The :class:`HistoryError` for a database error ``e``."""
        return HistoryError(
            f"cannot use the history database {self._shown}: {e.__class__.__name__}: {self._message(e)}"
        )

    def _run(self, fn: Callable[[Connection], _T]) -> _T:
        """``fn(conn)`` on a connection; a database error becomes a :class:`HistoryError`."""
        try:
            with self._engine.connect() as conn:
                return fn(conn)
        except self._sa.exc.SQLAlchemyError as e:
            raise self._error(e) from None

    def close(self) -> None:
        """Release the engine's connections."""
        self._engine.dispose()

    @contextmanager
    def transaction(self) -> Iterator[Connection]:
        """One write transaction (on SQLite: ``BEGIN IMMEDIATE``; on PostgreSQL: holding the write
        advisory lock, so writers take turns); rolled back on any exception."""
        try:
            with self._engine.connect() as conn:
                conn.info["umbmark_write"] = True
                try:
                    with conn.begin():
                        if self._engine.dialect.name == "postgresql":
                            conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({_WRITE_LOCK})")
                        yield conn
                finally:
                    conn.info.pop("umbmark_write", None)
        except self._sa.exc.SQLAlchemyError as e:
            if self.__dict__.get("_migrating"):
                raise  # the schema creation retries these (locked; two creators at once)
            raise self._error(e) from None

    def _version(self, conn: Connection) -> int | None:
        sa = self._sa
        if not sa.inspect(conn).has_table("umbmark_schema"):
            return None
        return conn.execute(sa.select(self._schema.c.version)).scalar()

    def _migrate(self, create: bool) -> None:
        sa = self._sa
        with self._engine.connect() as conn:
            if self._version(conn) == SCHEMA_VERSION:
                return  # nothing to do: no write lock needed
        for attempt in range(2):
            try:
                with self.transaction() as conn:
                    if self._engine.dialect.name == "postgresql":
                        # one creator at a time: the tables of a schema another process is still
                        # creating must not look like a foreign database
                        conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({_SCHEMA_LOCK})")
                    v = self._version(conn)
                    if v is None:
                        names = set(sa.inspect(conn).get_table_names())
                        if not create and names and not names & {"robots", "calibrations"}:
                            raise HistoryError(
                                f"{self._shown} holds other tables but not an umbmark history "
                                "(record a calibration with `robot` and `record=True`)"
                            )
                        if not create and not names:
                            raise NoHistory(
                                f"no umbmark history in {self._shown} "
                                "(record a calibration with `robot` and `record=True`)"
                            )
                        if names & {"robots", "calibrations"}:
                            raise HistoryError(
                                f"{self._shown} has robots/calibrations tables but no umbmark schema "
                                "version: not an umbmark history"
                            )
                        self._md.create_all(conn)
                        conn.execute(self._schema.insert().values(version=SCHEMA_VERSION))
                        return
                    if v > SCHEMA_VERSION:
                        raise HistoryError(
                            f"the history database {self._shown} has schema version {v}, newer than "
                            f"this umbmark ({__version__}, schema {SCHEMA_VERSION}): upgrade umbmark"
                        )
                    # versions below the current one do not exist on this backend yet
                    return
            except sa.exc.IntegrityError:
                continue  # another process created the schema at the same moment: look again
            except sa.exc.ProgrammingError:
                if attempt:
                    raise
                continue

    @property
    def schema_version(self) -> int:
        """The schema version in ``umbmark_schema`` (0 when there is none)."""
        with self._engine.connect() as conn:
            return self._version(conn) or 0

    def integrity_check(self) -> str:
        """SQLite's integrity check (on SQLite) and a check for records without a robot.

        Returns
        -------
        str
            ``"ok"`` when the database is sound, else what is wrong.
        """
        sa = self._sa
        with self._engine.connect() as conn:
            if self._engine.dialect.name == "sqlite":
                res = "; ".join(r[0] for r in conn.exec_driver_sql("PRAGMA integrity_check"))
            else:
                res = "ok"
            orphans = conn.execute(
                sa.select(sa.func.count())
                .select_from(self._cal.outerjoin(self._robots))
                .where(self._robots.c.id.is_(None))
            ).scalar()
        return res if not orphans else f"{res}; records without a robot: {orphans}"

    def _insert(self, conn: Connection, row: dict[str, Any]) -> int:
        sa = self._sa
        name = row["robot"]
        rid = conn.execute(sa.select(self._robots.c.id).where(self._robots.c.name == name)).scalar()
        if rid is None:
            try:
                with conn.begin_nested():
                    conn.execute(self._robots.insert().values(name=name, created_utc=row["created_utc"]))
            except sa.exc.IntegrityError:
                pass  # created by a concurrent writer
            rid = conn.execute(sa.select(self._robots.c.id).where(self._robots.c.name == name)).scalar_one()
        values = {k: v for k, v in row.items() if k != "robot"}
        res = conn.execute(self._cal.insert().values(robot_id=rid, **values))
        pk = res.inserted_primary_key
        assert pk is not None  # set by the single-row INSERT just made
        return int(pk[0])

    def _select(self) -> Select:
        sa = self._sa
        c, r = self._cal.c, self._robots.c
        cols = [c.id, r.name] + [getattr(c, k) for k in _COLS[2:]]
        return sa.select(*cols).select_from(self._cal.join(self._robots))

    def _fetch(
        self, robot: str | None = None, limit: int | None = None, record_id: int | None = None
    ) -> list[tuple[Any, ...]]:
        """The rows of the record query, newest first (the robot's name and the id matched exactly)."""
        q = self._select()
        if record_id is not None:
            q = q.where(self._cal.c.id == int(record_id))
        elif robot is not None:
            q = q.where(self._robots.c.name == str(robot))
        q = q.order_by(self._cal.c.created_utc.desc(), self._cal.c.id.desc())
        if limit is not None:
            q = q.limit(int(limit))
        return self._run(lambda conn: [tuple(x) for x in conn.execute(q).all()])

    def _same_rows(
        self, conn: Connection | None, robot: str, input_sha256: str, kind: str, method: str
    ) -> list[tuple[Any, ...]]:
        c = self._cal.c
        q = (
            self._select()
            .where(self._robots.c.name == robot, c.input_sha256 == input_sha256, c.kind == kind, c.method == method)
            .order_by(c.id)
        )
        if conn is None:
            return self._run(lambda cn: [tuple(x) for x in cn.execute(q).all()])
        return [tuple(x) for x in conn.execute(q).all()]

    def _robot_counts(self) -> Sequence[Sequence[Any]]:
        sa = self._sa
        c, r = self._cal.c, self._robots.c
        q = (
            sa.select(r.name, sa.func.count(c.id), sa.func.min(c.created_utc), sa.func.max(c.created_utc))
            .select_from(self._robots.outerjoin(self._cal))
            .group_by(r.id, r.name)
            .order_by(r.name)
        )
        return self._run(lambda conn: conn.execute(q).all())

    def count(self) -> int:
        """Number of records of all robots."""
        sa = self._sa
        n = self._run(lambda conn: conn.execute(sa.select(sa.func.count()).select_from(self._cal)).scalar())
        assert n is not None  # count() answers one row
        return n
