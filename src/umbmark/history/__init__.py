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
SQLAlchemy backend in :mod:`umbmark.history.sqlalchemy_backend` (optional extras ``db`` / ``postgres``),
for a fleet sharing one PostgreSQL server.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from umbmark.history.base import (
    ENV_VAR,
    KINDS,
    MIGRATIONS,
    SCHEMA_VERSION,
    AnalysisLike,
    HistoryError,
    NoHistory,
    Record,
    SameRecording,
    check_robot,
    default_db_path,
    display_db,
    export_parameters,
    file_sha256,
    format_export,
    is_url,
    make_row,
    parameters_from_analysis,
    resolve_db,
    resolve_db_path,
    runs_from_rows,
    runs_to_rows,
)
from umbmark.history.sqlite_backend import History

if TYPE_CHECKING:
    from umbmark.history.sqlalchemy_backend import SQLAlchemyHistory
    from umbmark.model.geometry import Calibration

__all__ = [
    "SCHEMA_VERSION",
    "MIGRATIONS",
    "ENV_VAR",
    "KINDS",
    "Record",
    "HistoryError",
    "NoHistory",
    "SameRecording",
    "default_db_path",
    "resolve_db_path",
    "resolve_db",
    "is_url",
    "display_db",
    "make_row",
    "parameters_from_analysis",
    "file_sha256",
    "export_parameters",
    "format_export",
    "runs_to_rows",
    "runs_from_rows",
    "History",
    "open_history",
    "record_result",
    "record_analysis",
    "refuse_recorded",
]


def open_history(db: str | Path | None = None, create: bool = True) -> History | SQLAlchemyHistory:
    """Open the history: :class:`History` (SQLite file, standard library) or, for a database URL,
    :class:`umbmark.history.sqlalchemy_backend.SQLAlchemyHistory` (needs the ``db`` or ``postgres``
    extra). Both have the same methods.

    Parameters
    ----------
    db : str or Path, optional
        A database file or URL (default: ``$UMBMARK_DB``, else :func:`default_db_path`).
    create : bool
        Create the database if it does not exist (else raise).

    Returns
    -------
    History or SQLAlchemyHistory
        An open history; use it as a context manager, or call its ``close``.

    Raises
    ------
    HistoryError
        If the database cannot be opened or used (see the backends).
    """
    r = resolve_db(db)
    if isinstance(r, str):
        from umbmark.history.sqlalchemy_backend import SQLAlchemyHistory

        return SQLAlchemyHistory(r, create=create)
    return History(r, create=create)


def record_result(
    robot: str,
    *,
    kind: str,
    method: str,
    results: dict[str, Any],
    parameters: dict[str, Any],
    db: str | Path | None = None,
    inputs: dict[str, Any] | None = None,
    input_sha256: str | None = None,
    source: str | Path | None = None,
    parameters_in_use: dict[str, Any] | None = None,
    note: str | None = None,
    when: str | datetime | None = None,
) -> int:
    """Open the history database (``db``, ``$UMBMARK_DB`` or the default), store one
    calibration in one transaction, close it; returns the record id.

    Parameters
    ----------
    robot : str
        The robot's name.
    kind : str
        One of :data:`KINDS` (the command that made the result).
    method : str
        The correction method.
    results : dict
        The command's result (``emax_syst_mm`` is picked up for the plots).
    parameters : dict
        The recommended odometry parameters: ``c_left``, ``c_right``, ``wheelbase_mm`` (or
        ``wheelbase_m``), ``Ed``, ``Eb``.
    db : str or Path, optional
        The database (see :func:`open_history`).
    inputs : dict, optional
        The runs (or anything JSON).
    input_sha256 : str, optional
        Content hash of the input (see :func:`file_sha256`).
    source : str or Path, optional
        The file or folder the input came from.
    parameters_in_use : dict, optional
        The parameters the robot ran with.
    note : str, optional
        A free note.
    when : str or datetime, optional
        The record's time (default: now; an ISO 8601 string or a datetime, UTC if naive).

    Returns
    -------
    int
        The record's id.

    Raises
    ------
    InputError
        For a missing robot name, an unknown kind or a bad time.
    HistoryError
        If the database cannot be used.
    """
    robot = check_robot(robot)  # before the database is opened: a refused name creates no file
    with open_history(db) as h:
        return h.add(
            robot,
            kind=kind,
            method=method,
            results=results,
            parameters=parameters,
            inputs=inputs,
            input_sha256=input_sha256,
            source=source,
            parameters_in_use=parameters_in_use,
            note=note,
            when=when,
        )


def record_analysis(
    robot: str,
    analysis: AnalysisLike,
    *,
    kind: str = "analyze",
    source: str | Path | None = None,
    db: str | Path | None = None,
    prior: Calibration | None = None,
    note: str | None = None,
    when: str | datetime | None = None,
    extra_inputs: dict[str, Any] | None = None,
) -> int:
    """Record an analysis: its figures, the recommended parameters, the runs themselves, and the
    hash of the source file if given and readable.

    Parameters
    ----------
    robot : str
        The robot's name.
    analysis : umbmark.correct.analysis.Analysis
        The analysis.
    kind : str
        One of :data:`KINDS`.
    source : str or Path, optional
        The runs file (hashed, and stored as an absolute path).
    db : str or Path, optional
        The database (see :func:`open_history`).
    prior : Calibration, optional
        The calibration the robot ran with (default: uncalibrated).
    note : str, optional
        A free note.
    when : str or datetime, optional
        The record's time (default: now).
    extra_inputs : dict, optional
        Further entries of the stored inputs.

    Returns
    -------
    int
        The record's id.
    """
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
    inputs: dict[str, Any] = {
        "runs": runs_to_rows(analysis.runs),
        "side_mm": analysis.side_m * 1e3,
        "wheelbase_mm": analysis.wheelbase_m * 1e3,
    }
    inputs.update(extra_inputs or {})
    results = analysis.to_dict()
    return record_result(
        robot,
        kind=kind,
        method=analysis.correction.method,
        results=results,
        parameters=recommended,
        db=db,
        inputs=inputs,
        input_sha256=sha,
        source=None if source is None else str(Path(source).resolve()),
        parameters_in_use=in_use,
        note=note,
        when=when,
    )


def refuse_recorded(
    robot: str,
    *,
    kind: str,
    method: str,
    paths: Sequence[str | Path],
    each: bool = False,
    db: str | Path | None = None,
) -> None:
    """Refuse, before a command computes anything, a recording the robot's history holds already
    (the same content, kind and method): recorded again it would count as a second session.
    :meth:`History.add` checks again in its write transaction (two writers at once).

    Parameters
    ----------
    robot : str
        The robot's name.
    kind, method : str
        The record's kind and method.
    paths : sequence of str or Path
        The inputs (those that do not exist are left out).
    each : bool
        Each input is a record of its own (a replay's data sets); else the inputs make one record
        (their hash: :func:`umbmark._files.inputs_sha256`).
    db : str or Path, optional
        The database (see :func:`open_history`); a database that does not exist yet holds nothing.

    Raises
    ------
    SameRecording
        Naming the record that holds the recording.
    HistoryError
        If the database cannot be read (but for one that does not exist yet).
    """
    from umbmark._files import inputs_sha256

    robot = check_robot(robot)
    given = [p for p in paths if Path(p).exists()]
    if not given:
        return
    try:
        h = open_history(db, create=False)
    except NoHistory:
        return  # no history yet: nothing recorded in it
    with h:
        for group in ([p] for p in given) if each else [given]:
            rec = h.same_recording(robot, kind=kind, method=method, input_sha256=inputs_sha256(group))
            if rec is not None:
                raise SameRecording(robot, rec, h.path)
