"""``umbmark history``, ``umbmark report``, ``umbmark guide``, ``umbmark measure``, and the
``--robot NAME`` / ``--record`` / ``--db PATH`` options any command can attach.

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
import math
import sys
from pathlib import Path

import click

from umbmark._numbers import strict_float
from umbmark.cli.app import (
    app,
    cli_message,
    console,
    emit_json,
    error_param,
    fmt,
    is_quiet,
    positive,
    prior_options,
    table,
)
from umbmark.errors import InputError

__all__ = ["history_options", "record_if_requested", "record_report_if_requested", "print_recorded"]


# -- the options other commands attach --------------------------------------------------------------
def history_options(f):
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
    def wrapper(*args, **kwargs):
        if kwargs.get("record") and not kwargs.get("robot"):
            raise click.UsageError("--record needs --robot NAME (the robot whose history gets the result)")
        return f(*args, **kwargs)

    wrapper = click.option(
        "--db",
        type=click.Path(dir_okay=False),
        default=None,
        help="History database (default: $UMBMARK_DB, else $XDG_DATA_HOME/umbmark/history.sqlite).",
    )(wrapper)
    wrapper = click.option(
        "--record", is_flag=True, help="Store the result in the robot's calibration history (needs --robot)."
    )(wrapper)
    wrapper = click.option(
        "--robot", metavar="NAME", default=None, help="Robot name, for the calibration history (see --record)."
    )(wrapper)
    return wrapper


def record_if_requested(
    robot, record, db, *, analysis=None, kind: str = "analyze", source=None, prior=None, note=None, **fields
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
    from umbmark.history import display_db, record_analysis, record_result, resolve_db

    path = resolve_db(db)
    if analysis is not None:
        rid = record_analysis(robot, analysis, kind=kind, source=source, db=path, prior=prior, note=note)
    else:
        rid = record_result(robot, kind=kind, db=path, source=source, note=note, **fields)
    return {"record_id": rid, "robot": robot, "db": display_db(path)}


def record_report_if_requested(
    robot, record, db, rep, paths, *, kind: str = "replay", method: str | None = None
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


def print_recorded(rec) -> None:
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
def history_cmd(robot, db, plot_path, export_path, limit, show_id, as_json):
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
            _print_warnings(h.warnings)
            emit_json({**rec.to_dict(full=True), "warnings": h.warnings})
            return
        if robot is None:
            if plot_path or export_path:
                raise click.UsageError("--plot and --export need a ROBOT")
            robots = h.robots()
            _print_warnings(h.warnings)
            if as_json:
                emit_json({"db": str(h.path), "robots": robots, "warnings": h.warnings})
            elif not is_quiet():
                _print_robots(h.path, robots)
            return
        # the newest record (an error naming the robots there are when it has none); the one
        # exported: a damaged newest record is an error, not an older record exported instead
        latest = h.latest(robot, strict=export_path is not None)
        recs = h.records(robot, limit=limit) or [latest]
        _print_warnings(h.warnings)
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


def _print_warnings(warnings: list[str]) -> None:
    """Each warning of the history (damaged records) on stderr, one line each."""
    for w in warnings:
        click.echo(f"warning: {cli_message(w)}", err=True)


def _print_robots(db_path, robots: list[dict]) -> None:
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


def _print_records(robot: str, recs, plot_path, exported) -> None:
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
    for r in recs:
        t.add_row(
            f"#{r.id}",
            r.created_utc[:16].replace("T", " "),
            escape(f"{r.kind}/{r.method}"),
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


# -- umbmark report ------------------------------------------------------------------------------------
@app.command("report")
@click.argument("runs_file", required=False, metavar="[FILE.csv]")
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True, help="HTML file to write.")
@click.option("--wheelbase-mm", type=float, default=None, help="With FILE.csv: wheelbase the odometry used.")
@click.option("--side-mm", type=float, default=None, help="With FILE.csv: side of the square.")
@click.option("--method", default="bf", show_default=True, help="With FILE.csv: correction method.")
@prior_options
@click.option(
    "--after",
    "after_file",
    type=click.Path(dir_okay=False),
    default=None,
    help="Runs file of a test after calibration (drawn in the same scatter).",
)
@click.option(
    "--attach",
    "attach",
    type=click.Path(dir_okay=False),
    multiple=True,
    help="Exported parameter file(s) to show in the report (repeatable).",
)
@click.option(
    "--bootstrap",
    "n_boot",
    type=click.IntRange(min=0),
    default=None,
    help="Bootstrap resamples for the intervals of E_d, E_b, wheelbase (0: none). Default: 1000 "
    "for bf; for exact 1000 where they take under 10 s, fewer or none on many runs; none for other "
    "methods (they may report their own intervals).",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Bootstrap seed.")
@click.option(
    "--robot",
    metavar="NAME",
    default=None,
    help="Without FILE.csv: report this robot's history. With FILE.csv: label the report.",
)
@click.option(
    "--id",
    "record_id",
    type=click.IntRange(min=1),
    default=None,
    help="Report one recorded analysis of the history (by its id).",
)
@click.option("--db", type=click.Path(dir_okay=False), default=None, help="History database (see umbmark history).")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary.")
def report_cmd(
    runs_file,
    out_path,
    wheelbase_mm,
    side_mm,
    method,
    c_left,
    c_right,
    after_file,
    attach,
    n_boot,
    seed,
    robot,
    record_id,
    db,
    as_json,
):
    """Write a self-contained HTML report (figures embedded): one analysis, or one robot's history.

    With FILE.csv: the UMBmark numbers with 95 % intervals, the scatter (before and, with
    --after, after calibration), the recommended parameters and any --attach'ed exported files.
    FILE may also be the JSON of replay --save (square runs): its runs before and after
    calibration and the calibration it found, no sizes needed; or the JSON of selfcal --save,
    of calibrate --json (its passes and the calibration to load) or of replay --imu-topic
    --save (the gyro's wheelbase and each turn). Bootstrap by default: bf
    1000 resamples; exact 1000 where they take under 10 s (fewer, or none, on many runs: the
    report says so).
    With --robot NAME and no file: the robot's calibration history (table, plot over time,
    latest parameters). With --id N: a recorded analysis, self-calibration or calibration loop.

    \b
    Examples:
      umbmark report runs.csv --wheelbase-mm 340 --side-mm 4000 --out report.html
      umbmark report replay-result.json --out replay-report.html
      umbmark report --robot r1 --out r1-history.html
    """
    if runs_file is None and record_id is None:
        if robot is None:
            raise click.UsageError("give a runs file FILE.csv, --robot NAME (history) or --id N (a record)")
        summary = _history_page(robot, db, out_path)
    elif (r := _result_input(runs_file, record_id, db)) is not None:
        given = _geometry_flags(wheelbase_mm, side_mm, c_left, c_right)
        given += [flag for flag, v in (("--after", after_file), ("--bootstrap", n_boot)) if v is not None]
        if given:
            holds = "a self-calibration holds its geometry and intervals"
            if r["kind"] != "selfcal":
                holds = f"a {r['kind']} result holds its geometry"
            raise click.UsageError(f"{holds}: drop {', '.join(given)}")
        summary = (
            _selfcal_page(r, out_path, attach, robot) if r["kind"] == "selfcal" else _other_page(r, out_path, robot)
        )
    else:
        if record_id is not None:
            if runs_file is not None:
                raise click.UsageError("give either FILE.csv or --id, not both")
            a = _record_analysis(record_id, db)
        else:
            a = _file_analysis(runs_file, wheelbase_mm, side_mm, method, c_left, c_right, robot)
        summary = _analysis_page(a, out_path, after_file, attach, n_boot, seed)
    if as_json:
        emit_json(summary)
    elif not is_quiet():
        from rich.markup import escape

        console().print(escape(f"report: {out_path}"))


def _result_input(runs_file, record_id, db) -> dict | None:
    """A self-calibration, calibration loop or gyro result to report: its JSON, ``kind``
    (``selfcal``, ``calibrate`` or ``gyro``) and where it came from; None for another kind (an
    analysis, a replay: the runs readers take those)."""
    import json

    from umbmark.viz.result_pages import is_calibrate_result, is_gyro_result
    from umbmark.viz.selfcal_report import is_selfcal_result

    if record_id is not None:
        from umbmark.history import open_history

        with open_history(db, create=False) as h:
            rec = h.get(record_id)
        if rec.method == "selfcal" and is_selfcal_result(rec.results):
            kind = "selfcal"
        elif rec.kind == "calibrate" and is_calibrate_result(rec.results):
            kind = "calibrate"
        elif rec.kind == "gyro" and is_gyro_result(rec.results):
            kind = "gyro"
        else:
            return None
        label = f"record #{rec.id} of {rec.created_utc[:16].replace('T', ' ')} UTC"
        return {"d": rec.results, "kind": kind, "source": None, "sha": rec.input_sha256, "robot": rec.robot,
                "label": label}  # fmt: skip
    if not _is_json(runs_file):
        return None
    try:
        d = json.loads(Path(runs_file).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        return None  # the replay reader says what is wrong with it
    kinds = (("selfcal", is_selfcal_result), ("calibrate", is_calibrate_result), ("gyro", is_gyro_result))
    found = next((k for k, is_kind in kinds if is_kind(d)), None)
    if found is None:
        return None
    from umbmark.history import file_sha256

    return {
        "d": d,
        "kind": found,
        "source": str(runs_file),
        "sha": file_sha256(runs_file),
        "robot": None,
        "label": None,
    }


def _other_page(r: dict, out_path, robot) -> dict:
    """Write the HTML page of a calibration loop or a gyro result; the JSON summary."""
    from umbmark.io.atomic import atomic_write
    from umbmark.viz.result_pages import calibrate_page, gyro_page

    robot = robot or r["robot"]
    what = r["label"] or (Path(r["source"]).name if r["source"] else r["kind"])
    opts = dict(source=r["source"], source_sha256=r["sha"], robot=robot)
    if r["kind"] == "calibrate":
        commands = _load_commands(r["source"], "calibrate")
        page = calibrate_page(r["d"], title=f"Calibration loop report: {what}", load_commands=commands, **opts)
    else:
        page = gyro_page(r["d"], title=f"Gyro report: {what}", **opts)
    atomic_write(out_path, page)
    return {"out": out_path, "kind": r["kind"]}


def _selfcal_page(sc: dict, out_path, attach, robot) -> dict:
    """Write the HTML page of a self-calibration; the JSON summary."""
    from umbmark.io.atomic import atomic_write
    from umbmark.viz.selfcal_report import selfcal_page

    robot = robot or sc["robot"]
    what = sc["label"] or (Path(sc["source"]).name if sc["source"] else "self-calibration")
    page = selfcal_page(
        sc["d"],
        title=f"Self-calibration report: {robot + ', ' if robot else ''}{what}",
        source=sc["source"],
        source_sha256=sc["sha"],
        robot=robot,
        exported=_attached(attach) or None,
        load_commands=_load_commands(sc["source"]),
    )
    atomic_write(out_path, page)
    d = sc["d"]
    figures = d.get("figures") if isinstance(d.get("figures"), dict) else {}
    return {
        "out": out_path,
        "kind": "selfcal",
        "wheel_diameter_left_mm": d.get("wheel_diameter_left_mm"),
        "wheel_diameter_right_mm": d.get("wheel_diameter_right_mm"),
        "wheelbase_mm": d.get("wheelbase_mm"),
        "sensor_pose": d.get("sensor_pose"),
        "maps": len(figures.get("maps") or []),
    }


_EXPORT_COMMANDS = {
    "selfcal": (
        "selfcal.json",
        "selfcal ... --save selfcal.json",
        (
            ("--format ros2 --out params.yaml", "diff_drive_controller"),
            ("--format urdf", "the lidar's <origin> in the URDF"),
            ("--format tf", "a static_transform_publisher line"),
        ),
    ),
    "calibrate": (
        "calibrate.json",
        "calibrate ... --json > calibrate.json",
        (
            ("--format ros2 --out params.yaml", "diff_drive_controller"),
            ("--format firmware", "constants for the firmware"),
        ),
    ),
}


def _load_commands(source: str | None, kind: str = "selfcal") -> str:
    """The commands that export a result of ``kind`` for the robot, naming its file."""
    import shlex

    default, made_by, commands = _EXPORT_COMMANDS[kind]
    name = shlex.quote(source) if source else default
    width = max(len(c) for c, _ in commands)
    text = "\n".join(f"umbmark export {name} {c.ljust(width)}   # {why}" for c, why in commands)
    if not source:
        text = f"# {default}: the result as saved by  umbmark {made_by}\n" + text
    return text


def _attached(attach) -> dict[str, str]:
    """File name -> text of the files given with --attach."""
    exported = {}
    for f in attach:
        p = Path(f)
        if not p.is_file():
            raise InputError("file not found", source=f)
        try:
            exported[p.name] = p.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise InputError("not a text file (only text exports can be shown)", source=f) from None
    return exported


def _history_page(robot: str, db, out_path) -> dict:
    """Write the HTML page of one robot's history; the JSON summary."""
    from umbmark.history import open_history
    from umbmark.io.atomic import atomic_write
    from umbmark.viz.report import history_report

    with open_history(db, create=False) as h:
        recs = h.records(robot)
        if not recs:
            h.latest(robot)  # an error naming the robots there are, or the damaged records
        warnings = list(h.warnings)
        page = history_report(recs, db_path=str(h.path))
    _print_warnings(warnings)
    atomic_write(out_path, page)
    return {"out": out_path, "robot": robot, "records": len(recs), "warnings": warnings}


def _record_analysis(record_id: int, db) -> dict:
    """What a report of a recorded analysis needs: its runs and inputs, the prior it ran with."""
    from umbmark.history import open_history, runs_from_rows
    from umbmark.model.geometry import Calibration

    with open_history(db, create=False) as h:
        rec = h.get(record_id)
    rows = rec.inputs.get("runs") if isinstance(rec.inputs, dict) else None
    if not rows and isinstance(rec.results, dict) and "before" in rec.results and rec.results.get("kind") == "square":
        from umbmark.viz.report import replay_analysis  # a recorded replay: the runs it built

        analysis, after = replay_analysis(rec.results, f"record #{record_id}")
        return {
            "runs": analysis.runs,
            "side_mm": analysis.side_m * 1e3,
            "wheelbase_mm": analysis.wheelbase_m * 1e3,
            "method": analysis.correction.method,
            "robot": rec.robot,
            "source": rec.source,
            "sha": rec.input_sha256,
            "label": f"record #{rec.id} of {rec.created_utc[:16].replace('T', ' ')} UTC (replay)",
            "prior": None,
            "analysis": analysis,
            "after_runs": after,
        }
    if not rows or "side_mm" not in rec.inputs:
        raise InputError(f"record #{record_id} ({rec.kind}) does not hold runs to report")
    runs = runs_from_rows(rows)
    piu = rec.parameters_in_use or {}
    prior = None
    if piu.get("c_left", 1.0) != 1.0 or piu.get("c_right", 1.0) != 1.0:
        prior = Calibration(piu["c_left"], piu["c_right"], None)
    return {
        "runs": runs,
        "side_mm": rec.inputs["side_mm"],
        "wheelbase_mm": rec.inputs.get("wheelbase_mm"),
        "method": rec.method,
        "robot": rec.robot,
        "source": rec.source,
        "sha": rec.input_sha256,
        "label": f"record #{rec.id} of {rec.created_utc[:16].replace('T', ' ')} UTC",
        "prior": prior,
    }


def _is_json(path) -> bool:
    """Whether a file holds JSON (a replay result) rather than a runs table."""
    try:
        with open(path, "rb") as f:
            head = f.read(256).lstrip()
    except OSError:
        return False  # the reader says what is wrong with it
    return head.startswith(b"{")


def _any_json(path) -> bool:
    """Whether a file (of at most a megabyte) is JSON of any shape (``[]``, ``null``, ``"x"``)."""
    import json

    try:
        p = Path(path)
        if p.stat().st_size > 1 << 20:
            return False
        json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return False
    return True


def _geometry_flags(wheelbase_mm, side_mm, c_left, c_right) -> list[str]:
    """The geometry and calibration flags given (a saved result holds its own)."""
    return [
        flag
        for flag, v, default in (
            ("--wheelbase-mm", wheelbase_mm, None),
            ("--side-mm", side_mm, None),
            ("--c-left", c_left, 1.0),
            ("--c-right", c_right, 1.0),
        )
        if v != default
    ]


def _replay_file_analysis(runs_file, wheelbase_mm, side_mm, method, c_left, c_right, robot) -> dict:
    """What a report of a replay result (``replay --save``) needs (as :func:`_record_analysis`)."""
    import json

    from umbmark.history import file_sha256
    from umbmark.viz.report import replay_analysis

    given = _geometry_flags(wheelbase_mm, side_mm, c_left, c_right)
    if given:
        raise click.UsageError(f"a replay result holds its geometry and calibration: drop {', '.join(given)}")
    try:
        d = json.loads(Path(runs_file).read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"not a replay result: {e}", source=str(runs_file)) from None
    analysis, after = replay_analysis(d, str(runs_file))
    ctx = click.get_current_context(silent=True)
    explicit = ctx is not None and ctx.get_parameter_source("method") != click.core.ParameterSource.DEFAULT
    if explicit and method != analysis.correction.method:
        raise click.UsageError(
            f"the replay result was calibrated with {analysis.correction.method}; drop --method {method}"
        )
    return {
        "runs": analysis.runs,
        "side_mm": analysis.side_m * 1e3,
        "wheelbase_mm": analysis.wheelbase_m * 1e3,
        "method": analysis.correction.method,
        "robot": robot,
        "source": str(runs_file),
        "sha": file_sha256(runs_file),
        "label": f"replay of {d.get('dataset') or Path(runs_file).name}",
        "prior": None,
        "analysis": analysis,
        "after_runs": after,
    }


def _file_analysis(runs_file, wheelbase_mm, side_mm, method, c_left, c_right, robot) -> dict:
    """What a report of a runs file or of a replay result needs (as :func:`_record_analysis`)."""
    from umbmark.history import file_sha256
    from umbmark.io.runs_csv import read_runs_csv
    from umbmark.model.geometry import Calibration

    if _is_json(runs_file):
        return _replay_file_analysis(runs_file, wheelbase_mm, side_mm, method, c_left, c_right, robot)
    if wheelbase_mm is None or side_mm is None:
        if _any_json(runs_file):
            raise InputError(
                "JSON, but not a result umbmark saves (a replay, self-calibration, calibration loop or gyro "
                "result): report one of those, or a runs file (CSV)",
                source=str(runs_file),
            )
        raise click.UsageError("with FILE.csv, --wheelbase-mm and --side-mm are required")
    runs = read_runs_csv(runs_file)
    sha = file_sha256(runs_file)
    for name, v in (("--c-left", c_left), ("--c-right", c_right)):
        error_param(name, v)
    prior = Calibration(c_left, c_right, None) if c_left != 1.0 or c_right != 1.0 else None
    return {
        "runs": runs,
        "side_mm": side_mm,
        "wheelbase_mm": wheelbase_mm,
        "method": method,
        "robot": robot,
        "source": str(runs_file),
        "sha": sha,
        "label": None,
        "prior": prior,
    }


def _analysis_page(a: dict, out_path, after_file, attach, n_boot, seed) -> dict:
    """Analyse the runs of ``a``, write the HTML page; the JSON summary."""
    from umbmark.cli.progress import progress
    from umbmark.correct.analysis import analyze
    from umbmark.io.atomic import atomic_write
    from umbmark.io.runs_csv import read_runs_csv
    from umbmark.viz.report import analysis_report, bootstrap_intervals, default_bootstrap

    runs, method, prior, robot, source = a["runs"], a["method"], a["prior"], a["robot"], a["source"]
    side_m = positive("--side-mm", a["side_mm"]) * 1e-3
    wheelbase_m = positive("--wheelbase-mm", a["wheelbase_mm"]) * 1e-3
    analysis = a.get("analysis") or analyze(runs, side_m, wheelbase_m, method, prior)
    after = read_runs_csv(after_file) if after_file else a.get("after_runs")
    exported = _attached(attach)
    boot, note = None, None
    if n_boot is None:
        n_boot, note = default_bootstrap(method, len(runs))
    if n_boot and method not in ("bf", "exact") and "analysis" in a:
        raise click.UsageError(f"the bootstrap of a replay result works with bf and exact, not {method}")
    if n_boot:
        center = analysis.correction if "analysis" in a and method == "exact" else None
        with progress("bootstrap", total=n_boot) as advance:
            boot = bootstrap_intervals(
                runs, side_m, wheelbase_m, method, prior, n_boot, seed, advance=advance, center=center
            )
        if center is not None:
            note = (note + "; " if note else "") + (
                "the bootstrap refits exact on the replay's return errors (the result does not hold the "
                "odometry's end poses) and is shifted by that refit's difference from the replay's "
                f"calibration (E_d {boot['shift']['Ed']:+.2e}, E_b {boot['shift']['Eb']:+.2e})"
            )
    what = a["label"] or (Path(source).name if source else "runs")
    page = analysis_report(
        analysis,
        title=f"UMBmark report: {robot + ', ' if robot else ''}{what}",
        source=source,
        source_sha256=a["sha"],
        prior=prior,
        after_runs=after,
        exported=exported or None,
        boot=boot,
        robot=robot,
        boot_note=note,
    )
    atomic_write(out_path, page)
    summary = {"out": out_path, "emax_syst_mm": analysis.result.emax_syst * 1e3, "bootstrap": boot}
    if note:
        summary["bootstrap_note"] = note
    return summary


# -- umbmark guide -------------------------------------------------------------------------------------
@app.command("guide")
@click.option("--side-mm", type=float, default=4000.0, show_default=True, help="Side of the square.")
@click.option("--runs", type=click.IntRange(min=1), default=5, show_default=True, help="Runs per direction.")
@click.option(
    "--ros2-script",
    is_flag=True,
    help="Print instead a ROS 2 Python node that drives the runs, closed loop on the robot's odometry.",
)
@click.option("--speed-m-s", type=float, default=0.2, show_default=True, help="--ros2-script: speed on the legs.")
@click.option(
    "--turn-rate-deg-s", type=float, default=30.0, show_default=True, help="--ros2-script: turn rate on the spot."
)
@click.option("--cmd-vel-topic", default="/cmd_vel", show_default=True, help="--ros2-script: velocity command topic.")
@click.option("--odom-topic", default="/odom", show_default=True, help="--ros2-script: the odometry it drives on.")
@click.option("--stamped", is_flag=True, help="--ros2-script: publish TwistStamped instead of Twist.")
@click.option(
    "--pause-s", type=float, default=8.0, show_default=True, help="--ros2-script: rest between runs (seconds)."
)
def guide_cmd(side_mm, runs, ros2_script, speed_m_s, turn_rate_deg_s, cmd_vel_topic, odom_topic, stamped, pause_s):
    """Print the field procedure of the UMBmark test, step by step.

    Where to start, how to measure the return position with a tape in the start frame, 5 runs
    each way, and what to type into the distances or runs file. With --ros2-script: a ROS 2
    node that drives the runs (each leg and turn ends on the robot's own odometry, a rest
    between runs).

    \b
    Examples:
      umbmark guide
      umbmark guide --side-mm 2000 > procedure.txt
      umbmark guide --ros2-script --side-mm 2000 --odom-topic /diff_drive_controller/odom > umbmark_runs.py
    """
    from umbmark.realrobot.guide import check_run_plan, guide_text, ros2_runs_script

    positive("--side-mm", side_mm)
    check_run_plan(side_mm / 1000.0, speed_m_s, turn_rate_deg_s, pause_s)  # with or without a script
    if ros2_script:
        text = ros2_runs_script(
            side_mm / 1000.0, runs, speed_m_s, turn_rate_deg_s, cmd_vel_topic, odom_topic, stamped, pause_s
        )
        click.echo(text, nl=False)
    else:
        click.echo(guide_text(side_mm, runs), nl=False)


# -- umbmark measure -----------------------------------------------------------------------------------
class PointType(click.ParamType):
    """A point ``X,Y`` in millimetres (``;`` also separates), as a tuple of two finite floats."""

    name = "X,Y"

    def convert(self, value, param, ctx):
        """Parse ``value`` (a tuple is kept as it is); a bad value is a usage error."""
        if isinstance(value, tuple):
            return value
        parts = str(value).replace(";", ",").split(",")
        try:
            x, y = (strict_float(p) for p in parts)
        except ValueError:
            self.fail(f"{value!r} is not two numbers X,Y in millimetres (e.g. 150,-120)", param, ctx)
        if not (math.isfinite(x) and math.isfinite(y)):
            self.fail(f"{value!r} is not two finite numbers", param, ctx)
        return (x, y)


POINT = PointType()


@app.command("measure")
@click.argument("distances_file", required=False, metavar="[DISTANCES.csv]")
@click.option("--front", type=POINT, required=True, help="Front side mark in the robot frame [mm] (x fwd, y left).")
@click.option("--rear", type=POINT, required=True, help="Rear side mark in the robot frame [mm].")
@click.option("--back", type=POINT, required=True, help="Back mark in the robot frame [mm].")
@click.option(
    "--side-wall",
    type=click.Choice(["auto", "left", "right"]),
    default="auto",
    show_default=True,
    help="Side of the robot the side wall is on. auto: left for cw runs, right for ccw runs "
    "(the square turns away from it; marks mirrored to that side).",
)
@click.option(
    "--resolution-mm",
    type=float,
    default=1.0,
    show_default=True,
    help="Tape resolution; readings taken as uniform within +-resolution/2.",
)
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True, help="Runs file to write.")
@click.option("--interactive", is_flag=True, help="Type the distances at prompts (saved after every run).")
@click.option(
    "--runs",
    "n_runs",
    type=click.IntRange(min=1),
    default=5,
    show_default=True,
    help="With --interactive: runs per direction.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def measure_cmd(distances_file, front, rear, back, side_wall, resolution_mm, out_path, interactive, n_runs, as_json):
    """Turn tape-measured wall distances into a runs file (the paper's section 3.1).

    The start is near the corner of two perpendicular walls. Before and after each run, measure
    (mm) the front and rear side marks to the side wall and the back mark to the back wall.
    From these six distances and the odometry's end pose, writes the runs-file row in the start
    frame, with the standard deviations propagated from the tape resolution (extra columns
    x_abs_sd, y_abs_sd [mm], theta_abs_sd [deg]). See `umbmark guide`.

    DISTANCES.csv columns: run, direction, start_front, start_rear, start_back, end_front,
    end_rear, end_back, x_odo, y_odo[, theta_odo] (mm, deg; empty start cells reuse the previous
    start of the same direction). Or --interactive.

    \b
    Examples:
      umbmark measure distances.csv --front 150,-120 --rear -150,-120 --back -200,0 --out runs.csv
      umbmark measure --interactive --front 150,-120 --rear -150,-120 --back -200,0 --out runs.csv
    """
    from umbmark.io.distances_csv import read_distances_csv
    from umbmark.realrobot.measure import RobotMarks, measure_runs

    if resolution_mm is None or not (math.isfinite(resolution_mm) and 0 <= resolution_mm <= 100):
        raise InputError(
            f"--resolution-mm must be a number from 0 to 100 (a tape's resolution in mm), got {resolution_mm!r}"
        )
    marks = RobotMarks(tuple(v * 1e-3 for v in front), tuple(v * 1e-3 for v in rear), tuple(v * 1e-3 for v in back))
    resolution_m = resolution_mm * 1e-3
    if interactive:
        if distances_file:
            raise click.UsageError("give DISTANCES.csv or --interactive, not both")
        rows = _interactive(marks, side_wall, resolution_m, out_path, n_runs)
        source = "<interactive>"
    else:
        if not distances_file:
            raise click.UsageError("give a DISTANCES.csv file, or --interactive")
        rows = read_distances_csv(distances_file)
        source = distances_file
    res = measure_runs(marks, rows, resolution_m, source=source, side_wall=side_wall).write(out_path)
    if as_json:
        emit_json(res.to_dict())
        return
    if is_quiet():
        return
    runs, m = res.runs, res.measurement
    assert runs.run is not None and runs.theta_abs is not None  # measured runs are named, with headings
    trows = [
        [
            str(runs.run[i]),
            str(runs.direction[i]),
            f"{runs.x_abs[i] * 1e3:.1f} ± {m.x_sd[i] * 1e3:.1f}",
            f"{runs.y_abs[i] * 1e3:.1f} ± {m.y_sd[i] * 1e3:.1f}",
            f"{math.degrees(runs.theta_abs[i]):.2f} ± {math.degrees(m.theta_sd[i]):.2f}",
            fmt(runs.x_odo[i] * 1e3),
            fmt(runs.y_odo[i] * 1e3),
            fmt((runs.x_abs[i] - runs.x_odo[i]) * 1e3),
            fmt((runs.y_abs[i] - runs.y_odo[i]) * 1e3),
        ]
        for i in range(len(runs))
    ]
    console().print(
        table(
            f"Return poses in the start frame (± 1 sd from a {resolution_mm:g} mm tape), written to {out_path}",
            ["run", "dir", "x_abs [mm]", "y_abs [mm]", "theta_abs [deg]", "x_odo", "y_odo", "eps_x", "eps_y"],
            trows,
        )
    )


def _interactive(marks, side_wall, resolution_m, out_path, n_runs):
    """Prompt for every run; after each run, save the distances (``<out>.distances.csv``) and the
    runs file so far."""
    from umbmark.io.atomic import atomic_write
    from umbmark.io.distances_csv import DIST_COLUMNS, MeasuredRun, format_distances_csv
    from umbmark.realrobot.measure import measure_runs

    raw_path = str(Path(out_path).with_suffix("")) + ".distances.csv"
    rows: list[MeasuredRun] = []
    prev = None
    echo = click.echo
    echo(
        f"Entering {n_runs} cw and {n_runs} ccw runs. Distances in mm, perpendicular to the wall. "
        f"Saved after every run to {out_path} and {raw_path}."
    )
    labels = {
        "start_front": "START front mark -> side wall",
        "start_rear": "START rear mark -> side wall",
        "start_back": "START back mark -> back wall",
        "end_front": "END front mark -> side wall",
        "end_rear": "END rear mark -> side wall",
        "end_back": "END back mark -> back wall",
    }
    want_theta = None  # asked on the first run; then on every run or on none
    for direction in ("cw", "ccw"):
        wall = side_wall if side_wall != "auto" else ("left" if direction == "cw" else "right")
        prev = None  # the cw and ccw runs start at different corners
        for k in range(1, n_runs + 1):
            echo(f"\n{direction} run {k}/{n_runs} (side wall on the robot's {wall})")
            vals = {}
            for i, c in enumerate(DIST_COLUMNS):
                if i == 3:
                    echo("  reset the odometry, drive the square, then:")
                    x_odo = click.prompt("  odometry x at the end [mm]", type=float)
                    y_odo = click.prompt("  odometry y at the end [mm]", type=float)
                    th: str | float
                    if want_theta is None:
                        th = click.prompt(
                            "  odometry theta at the end [deg] (empty: not read)", default="", show_default=False
                        )
                        want_theta = bool(str(th).strip())
                    elif want_theta:
                        th = click.prompt("  odometry theta at the end [deg]", type=float)
                    else:
                        th = ""
                default = prev[i] if (prev is not None and i < 3) else None
                vals[c] = click.prompt(f"  {labels[c]} [mm]", type=float, default=default)
            theta = None
            if str(th).strip():
                try:
                    theta = float(th)
                except ValueError:
                    raise InputError(f"odometry theta {th!r} is not a number") from None
            d = tuple(vals[c] for c in DIST_COLUMNS)
            prev = d
            row = MeasuredRun(str(k), direction, d, x_odo, y_odo, theta)
            res = measure_runs(marks, rows + [row], resolution_m, source="<interactive>", side_wall=side_wall)
            rows.append(row)
            runs = res.runs
            assert runs.theta_abs is not None  # measured runs have their headings
            echo(
                f"  -> x_abs = {runs.x_abs[-1] * 1e3:.1f} mm, y_abs = {runs.y_abs[-1] * 1e3:.1f} mm, "
                f"theta_abs = {math.degrees(runs.theta_abs[-1]):.2f} deg"
            )
            atomic_write(raw_path, format_distances_csv(rows))
            res.write(out_path)
    return rows
