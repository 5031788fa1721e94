"""``umbmark history``, and the ``--robot NAME`` / ``--record`` / ``--db PATH`` options any
command can attach.

Attaching the history options to another command::

    from umbmark.cli.history import history_options, print_recorded, record_if_requested

    @app.command()
    ...
    @history_options                      # adds robot, record, db keyword arguments
    def mycommand(..., robot=None, record=False, db=None):
        ...
        rec = record_if_requested(robot, record, db, **fields)   # the fields of a library result
        # or, with an Analysis:  record_if_requested(robot, record, db, analysis=a, kind="analyze",
        #                                            source=runs_file, prior=prior)
        if as_json: emit_json({**result.to_dict(), "history": rec})   # rec: None or {"record_id", "robot", "db"}
        else: print_recorded(rec)

A replay report (``umbmark replay``) is recorded with :func:`record_report_if_requested`: one
record per data set, with the SHA-256 of its log file or folder
(:func:`umbmark.realrobot.replay.history_fields`).

``--record`` without ``--robot`` is a usage error raised before the command body runs.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

import click

from umbmark.cli.app import (
    app,
    cli_message,
    console,
    emit_json,
    fmt,
    is_quiet,
    table,
)
from umbmark.cli.command_config import HistoryConfig
from umbmark.cli.config import option_of

if TYPE_CHECKING:
    from umbmark.history import AnalysisLike, Record
    from umbmark.model.geometry import Calibration
    from umbmark.realrobot.results import MultiReplayReport, PooledReport, ReplayReport

F = TypeVar("F", bound=Callable[..., Any])

__all__ = [
    "history_options",
    "record_if_requested",
    "record_report_if_requested",
    "refuse_if_recorded",
    "print_recorded",
    "print_warnings",
]


# -- the options other commands attach --------------------------------------------------------------
_RECORDED_AT = "umbmark.recorded_at"


def _recorded_at(text: str) -> str:
    """``--recorded-at`` checked: an ISO 8601 time, not in the future (UTC when no zone)."""
    from datetime import datetime, timezone

    from umbmark.history.base import session_time_problem

    try:
        when = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise click.BadParameter(
            f"{text!r} is not an ISO 8601 date/time (e.g. 2026-05-01 or 2026-05-01T14:30:00Z)",
            param_hint="'--recorded-at'",
        ) from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=timezone.utc)
    problem = session_time_problem(when)
    if problem == "is in the future":
        raise click.BadParameter(
            f"{text} is in the future (a record dates a session that happened)", param_hint="'--recorded-at'"
        )
    if problem is not None:
        raise click.BadParameter(f"{text} {problem}: a year typed wrong?", param_hint="'--recorded-at'")
    return when.isoformat()


def _when() -> str | None:
    ctx = click.get_current_context(silent=True)
    return None if ctx is None else ctx.find_root().meta.get(_RECORDED_AT)


def history_options(f: F) -> F:
    """Add ``--robot NAME``, ``--record`` and ``--db PATH`` to a click command.

    Parameters
    ----------
    f : callable
        The command function; it receives the keyword arguments ``robot``, ``record`` and ``db``.

    Returns
    -------
    callable
        The decorated command (``--record`` without ``--robot`` is a usage error).
    """

    @functools.wraps(f)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if kwargs.get("record") and not kwargs.get("robot"):
            raise click.UsageError("--record needs --robot NAME (the robot whose history gets the result)")
        when = kwargs.pop("recorded_at", None)
        if when is not None:
            if not kwargs.get("record"):
                raise click.UsageError("--recorded-at dates a record: it needs --record")
            click.get_current_context().meta[_RECORDED_AT] = _recorded_at(when)
        return f(*args, **kwargs)

    _option = option_of(HistoryConfig)
    wrapper = _option(
        "--recorded-at",
        metavar="ISO8601",
        help="--record: the session's date and time (e.g. 2026-05-01T14:30, UTC unless a zone is given; "
        "default: now). For a history of sessions recorded later, as for `umbmark drift`.",
    )(wrapper)
    wrapper = _option(
        "--db",
        type=click.Path(dir_okay=False),
        help="History database (default: $UMBMARK_DB, else $XDG_DATA_HOME/umbmark/history.sqlite).",
    )(wrapper)
    wrapper = _option(
        "--record", is_flag=True, help="Store the result in the robot's calibration history (needs --robot)."
    )(wrapper)
    wrapper = _option("--robot", metavar="NAME", help="Robot name, for the calibration history (see --record).")(
        wrapper
    )
    return cast(F, wrapper)


def record_if_requested(
    robot: str | None,
    record: bool,
    db: str | None,
    *,
    analysis: AnalysisLike | None = None,
    kind: str = "analyze",
    source: str | Path | None = None,
    prior: Calibration | None = None,
    note: str | None = None,
    **fields: Any,
) -> dict | None:
    """Record a result in the robot's history when ``--record`` was given.

    Parameters
    ----------
    robot, record, db
        The values of ``--robot``, ``--record`` and ``--db``.
    analysis : Analysis, optional
        Record this analysis (:func:`umbmark.history.record_analysis`, with ``kind``,
        ``source``, ``prior`` and ``note``).
    **fields
        Otherwise: the keyword arguments of :func:`umbmark.history.record_result` (as a library
        result's history fields give them).

    Returns
    -------
    dict or None
        ``{"record_id", "robot", "db"}``, or None without ``--record``. Nothing is printed (see
        :func:`print_recorded`).
    """
    if not record:
        return None
    assert robot is not None  # --record needs --robot (history_options)
    from umbmark.history import display_db, record_analysis, record_result, resolve_db

    path = resolve_db(db)
    if analysis is not None:
        rid = record_analysis(robot, analysis, kind=kind, source=source, db=path, prior=prior, note=note, when=_when())
    else:
        if fields.get("when") is None:
            fields["when"] = _when()
        rid = record_result(robot, kind=kind, db=path, source=source, note=note, **fields)
    return {"record_id": rid, "robot": robot, "db": display_db(path)}


def refuse_if_recorded(
    robot: str | None,
    record: bool,
    db: str | None,
    *,
    kind: str,
    method: str,
    paths: Iterable[str | Path],
    each: bool = False,
) -> None:
    """With ``--record``: refuse, before the command computes anything, inputs the robot's history
    holds already (:func:`umbmark.history.refuse_recorded`; ``each``: one record per input)."""
    if record:
        from umbmark.history import refuse_recorded, resolve_db

        assert robot is not None  # --record needs --robot (history_options)
        refuse_recorded(robot, kind=kind, method=method, paths=list(paths), each=each, db=resolve_db(db))


def record_report_if_requested(
    robot: str | None,
    record: bool,
    db: str | None,
    rep: ReplayReport | MultiReplayReport | PooledReport | dict,
    paths: Sequence[str | Path],
    *,
    kind: str = "replay",
    method: str | None = None,
) -> list[dict] | None:
    """Record a replay report when ``--record`` was given: one record per data set.

    Parameters
    ----------
    robot, record, db
        The values of ``--robot``, ``--record`` and ``--db``.
    rep : ReplayReport, MultiReplayReport, PooledReport or dict
        The report, or its JSON (``umbmark replay --json``).
    paths : sequence of str or Path
        The logs the report was made from (each hashed with SHA-256).
    kind, method : str
        The records' kind and method (default method: the report's).

    Returns
    -------
    list of dict or None
        ``{"record_id", "robot", "db"}`` per record, or None without ``--record``.
    """
    if not record:
        return None
    from umbmark.history import file_sha256
    from umbmark.realrobot.replay import history_fields

    records = [
        record_if_requested(robot, True, db, **fields)
        for fields in history_fields(rep, paths, kind=kind, method=method, file_hash=file_sha256)
    ]
    return [r for r in records if r is not None]


def print_recorded(rec: dict | list[dict] | list[dict | None] | None) -> None:
    """Print one line per record unless ``--quiet``.

    Parameters
    ----------
    rec : dict, list of dict or None
        What :func:`record_if_requested` or :func:`record_report_if_requested` returned.
    """
    if isinstance(rec, list):
        for r in rec:
            print_recorded(r)
        return
    if rec and not is_quiet():
        from rich.markup import escape

        console().print(escape(f"recorded as #{rec['record_id']} in the history of {rec['robot']} ({rec['db']})"))


# -- umbmark history ----------------------------------------------------------------------------------
@app.command("history")
@click.argument("robot", required=False, metavar="[ROBOT]")
@click.option(
    "--db",
    type=click.Path(dir_okay=False),
    default=None,
    help="History database (default: $UMBMARK_DB, else $XDG_DATA_HOME/umbmark/history.sqlite).",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Plot E_max,syst, E_d, E_b and the wheelbase over time (PNG, SVG or PDF).",
)
@click.option(
    "--export",
    "export_path",
    type=click.Path(dir_okay=False, allow_dash=True),
    default=None,
    help="Write the latest recommended parameters (JSON, or YAML for .yaml/.yml; '-' = stdout).",
)
@click.option("--limit", type=click.IntRange(min=1), default=None, help="Only the newest N records.")
@click.option(
    "--show",
    "show_id",
    type=click.IntRange(min=1),
    default=None,
    help="Print one record in full (inputs and results) as JSON.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def history_cmd(
    robot: str | None,
    db: str | None,
    plot_path: str | None,
    export_path: str | None,
    limit: int | None,
    show_id: int | None,
    as_json: bool,
) -> None:
    """List the recorded calibrations (all robots, or one robot's history).

    Results get into the history with --robot NAME --record on analyze (and replay, calibrate).
    The database is SQLite; --db, or the UMBMARK_DB environment variable, choose the file.

    \b
    Examples:
      umbmark history                                   robots and their latest calibration
      umbmark history r1 --plot r1-history.png          one robot, with a plot over time
      umbmark history r1 --export r1-params.json        the latest parameters to load
      umbmark history --show 3                          one record in full
    """
    from umbmark.history import format_export, open_history

    with open_history(db, create=False) as h:
        if show_id is not None:
            rec = h.get(show_id)
            print_warnings(h.warnings)
            emit_json({**rec.to_dict(full=True), "warnings": h.warnings})
            return
        if robot is None:
            if plot_path or export_path:
                raise click.UsageError("--plot and --export need a ROBOT")
            robots = h.robots()
            print_warnings(h.warnings)
            if as_json:
                emit_json({"db": str(h.path), "robots": robots, "warnings": h.warnings})
            elif not is_quiet():
                _print_robots(h.path, robots)
            return
        # the newest record (an error naming the robots there are when it has none); the one
        # exported: a damaged newest record is an error, not an older record exported instead
        latest = h.latest(robot, strict=export_path is not None)
        recs = h.records(robot, limit=limit) or [latest]
        print_warnings(h.warnings)
        if plot_path:
            from umbmark.viz.history_plot import history_figure
            from umbmark.viz.plots import save_figure

            save_figure(history_figure(recs), plot_path)
        exported = None
        if export_path:
            suffix = Path(export_path).suffix.lower()
            text = format_export(latest, "yaml" if suffix in (".yaml", ".yml") else "json", db=h.path)
            if export_path == "-":
                sys.stdout.write(text)
            else:
                from umbmark.io.atomic import atomic_write

                atomic_write(export_path, text)
                exported = export_path
        if as_json:
            emit_json(
                {
                    "db": str(h.path),
                    "robot": robot,
                    "records": [r.to_dict(full=False) for r in recs],
                    "plot": plot_path,
                    "export": exported,
                    "warnings": h.warnings,
                }
            )
            return
        if is_quiet() or export_path == "-":
            return
        _print_records(robot, recs, plot_path, exported)


def print_warnings(warnings: list[str]) -> None:
    """Each warning of the history (damaged records) on stderr, one line each."""
    for w in warnings:
        click.echo(f"warning: {cli_message(w)}", err=True)


def _print_robots(db_path: str | Path, robots: list[dict]) -> None:
    """The robots of a history (:meth:`History.robots`) as a table."""
    rows = [
        [
            r["robot"],
            r["records"],
            (r["last_utc"] or "-")[:16].replace("T", " "),
            fmt(r.get("emax_syst_mm")),
            fmt(r.get("Ed"), 6),
            fmt(r.get("Eb"), 6),
            fmt(r.get("wheelbase_mm"), 2),
        ]
        for r in robots
    ]
    console().print(
        table(
            f"Robots in {db_path}",
            ["robot", "records", "last (UTC)", "E_max,syst [mm]", "E_d", "E_b", "wheelbase [mm]"],
            rows,
        )
    )


def _print_records(robot: str, recs: Sequence[Record], plot_path: str | None, exported: str | None) -> None:
    """One robot's records as a table, and the files written."""
    from rich.markup import escape
    from rich.table import Table

    t = Table(
        title=escape(f"Calibration history of {robot} ({len(recs)} records, oldest first)"),
        title_justify="left",
        header_style="bold",
    )
    for i, col in enumerate(
        ["id", "time (UTC)", "kind/method", "E_max,syst [mm]", "E_d", "E_b", "wheelbase [mm]", "c_left", "c_right"]
    ):
        t.add_column(escape(col), justify="left" if i < 3 else "right", no_wrap=i < 3)
    from umbmark.kinds import kind_in

    for r in recs:
        own = kind_in(r.parameters)  # another kind of robot's record: named
        t.add_row(
            f"#{r.id}",
            r.created_utc[:16].replace("T", " "),
            escape(f"{r.kind}/{r.method}" + ("" if own is None else f" ({own.noun})")),
            fmt(r.emax_syst_mm),
            fmt(r.ed, 6),
            fmt(r.eb, 6),
            fmt(r.wheelbase_mm, 2),
            fmt(r.parameters.get("c_left"), 6),
            fmt(r.parameters.get("c_right"), 6),
        )
    c = console()
    c.print(t)
    if plot_path:
        c.print(escape(f"plot: {plot_path}"))
    if exported:
        c.print(escape(f"latest parameters (record #{recs[-1].id}): {exported}"))
