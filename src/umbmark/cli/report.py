"""``umbmark report``: a self-contained HTML page of a runs file, a replay, a self-calibration,
a calibration loop, a gyro result or a record of the history, or of a robot's history.

The pages are the library's (:mod:`umbmark.viz`); this module finds what was given, reads it and
writes the page.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import click

from umbmark.cli.app import (
    app,
    console,
    emit_json,
    error_param,
    is_quiet,
    positive,
    prior_options,
)
from umbmark.cli.history import print_warnings
from umbmark.errors import InputError

__all__ = ["report_cmd"]


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
    runs_file: str | None,
    out_path: str,
    wheelbase_mm: float | None,
    side_mm: float | None,
    method: str,
    c_left: float,
    c_right: float,
    after_file: str | None,
    attach: tuple[str, ...],
    n_boot: int | None,
    seed: int,
    robot: str | None,
    record_id: int | None,
    db: str | None,
    as_json: bool,
) -> None:
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
            assert runs_file is not None  # neither given: the history's page above
            a = _file_analysis(runs_file, wheelbase_mm, side_mm, method, c_left, c_right, robot)
        summary = _analysis_page(a, out_path, after_file, attach, n_boot, seed)
    if as_json:
        emit_json(summary)
    elif not is_quiet():
        from rich.markup import escape

        console().print(escape(f"report: {out_path}"))


def _result_input(runs_file: str | None, record_id: int | None, db: str | None) -> dict | None:
    """A self-calibration, calibration loop or gyro result to report: its JSON, ``kind``
    (``selfcal``, ``calibrate`` or ``gyro``) and where it came from; None for another kind (an
    analysis, a replay: the runs readers take those)."""
    import json

    from umbmark.viz.kind_report import is_kind_selfcal_result
    from umbmark.viz.result_pages import is_calibrate_result, is_gyro_result
    from umbmark.viz.selfcal_report import is_selfcal_result

    def is_selfcal(d: object) -> bool:  # a self-calibration of any kind of robot
        return is_selfcal_result(d) or is_kind_selfcal_result(d)

    if record_id is not None:
        from umbmark.history import open_history

        with open_history(db, create=False) as h:
            rec = h.get(record_id)
        if rec.method == "selfcal" and is_selfcal(rec.results):
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
    if runs_file is None or not _is_json(runs_file):
        return None
    try:
        d = json.loads(Path(runs_file).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # not UTF-8, not JSON, a number of thousands of digits
        return None  # the replay reader says what is wrong with it
    kinds = (("selfcal", is_selfcal), ("calibrate", is_calibrate_result), ("gyro", is_gyro_result))
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


def _other_page(r: dict, out_path: str, robot: str | None) -> dict:
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


def _selfcal_page(sc: dict, out_path: str, attach: tuple[str, ...], robot: str | None) -> dict:
    """Write the HTML page of a self-calibration (of any kind of robot); the JSON summary: a
    differential drive's diameters and wheelbase, or another kind's ``kinematics`` and geometry."""
    from umbmark.io.atomic import atomic_write
    from umbmark.kinds import kind_in
    from umbmark.viz.kind_report import kind_selfcal_page
    from umbmark.viz.selfcal_report import selfcal_page

    robot = robot or sc["robot"]
    d = sc["d"]
    own = kind_in(d)
    what = sc["label"] or (Path(sc["source"]).name if sc["source"] else "self-calibration")
    page = (selfcal_page if own is None else kind_selfcal_page)(
        d,
        title=f"Self-calibration report: {robot + ', ' if robot else ''}{what}",
        source=sc["source"],
        source_sha256=sc["sha"],
        robot=robot,
        exported=_attached(attach) or None,
        load_commands=_load_commands(sc["source"], controller=None if own is None else own.controller),
    )
    atomic_write(out_path, page)
    figures = d.get("figures") if isinstance(d.get("figures"), dict) else {}
    if own is None:
        keys = ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm")
        geometry = {k: d.get(k) for k in keys}
    else:
        geometry = {"kinematics": own.name, **{k: d.get(k) for k in dict.fromkeys(p.key[0] for p in own.parameters)}}
    return {
        "out": out_path,
        "kind": "selfcal",
        **geometry,
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


def _load_commands(source: str | None, kind: str = "selfcal", controller: str | None = None) -> str:
    """The commands that export a result of ``kind`` for the robot, naming its file (``controller``:
    the controller of a robot of a kind of its own, which its ros2 export writes)."""
    import shlex

    default, made_by, commands = _EXPORT_COMMANDS[kind]
    if controller is not None:
        commands = tuple((c, controller if why == "diff_drive_controller" else why) for c, why in commands)
    name = shlex.quote(source) if source else default
    width = max(len(c) for c, _ in commands)
    text = "\n".join(f"umbmark export {name} {c.ljust(width)}   # {why}" for c, why in commands)
    if not source:
        text = f"# {default}: the result as saved by  umbmark {made_by}\n" + text
    return text


def _attached(attach: Iterable[str]) -> dict[str, str]:
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


def _history_page(robot: str, db: str | None, out_path: str) -> dict:
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
    print_warnings(warnings)
    atomic_write(out_path, page)
    return {"out": out_path, "robot": robot, "records": len(recs), "warnings": warnings}


def _record_analysis(record_id: int, db: str | None) -> dict:
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


def _is_json(path: str) -> bool:
    """Whether a file holds JSON (a replay result) rather than a runs table."""
    try:
        with open(path, "rb") as f:
            head = f.read(256).lstrip()
    except OSError:
        return False  # the reader says what is wrong with it
    return head.startswith(b"{")


def _any_json(path: str) -> bool:
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


def _geometry_flags(wheelbase_mm: float | None, side_mm: float | None, c_left: float, c_right: float) -> list[str]:
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


def _replay_file_analysis(
    runs_file: str,
    wheelbase_mm: float | None,
    side_mm: float | None,
    method: str,
    c_left: float,
    c_right: float,
    robot: str | None,
) -> dict:
    """What a report of a replay result (``replay --save``) needs (as :func:`_record_analysis`)."""
    from umbmark.history import file_sha256
    from umbmark.io._text import parse_json
    from umbmark.viz.report import replay_analysis

    given = _geometry_flags(wheelbase_mm, side_mm, c_left, c_right)
    if given:
        raise click.UsageError(f"a replay result holds its geometry and calibration: drop {', '.join(given)}")
    try:
        text = Path(runs_file).read_text(encoding="utf-8")
    except UnicodeDecodeError as e:
        raise InputError(f"not a replay result: {e}", source=str(runs_file)) from None
    d = parse_json(text, str(runs_file), "not a replay result")
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


def _file_analysis(
    runs_file: str,
    wheelbase_mm: float | None,
    side_mm: float | None,
    method: str,
    c_left: float,
    c_right: float,
    robot: str | None,
) -> dict:
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


def _analysis_page(
    a: dict, out_path: str, after_file: str | None, attach: tuple[str, ...], n_boot: int | None, seed: int
) -> dict:
    """Analyse the runs of ``a``, write the HTML page; the JSON summary."""
    from umbmark._files import same_inputs
    from umbmark.cli.progress import progress
    from umbmark.correct.analysis import analyze
    from umbmark.io.atomic import atomic_write
    from umbmark.io.runs_csv import read_runs_csv
    from umbmark.viz.report import analysis_report, bootstrap_intervals, default_bootstrap

    runs, method, prior, robot, source = a["runs"], a["method"], a["prior"], a["robot"], a["source"]
    side_m = positive("--side-mm", a["side_mm"]) * 1e-3
    wheelbase_m = positive("--wheelbase-mm", a["wheelbase_mm"]) * 1e-3
    analysis = a.get("analysis") or analyze(runs, side_m, wheelbase_m, method, prior)
    if (
        after_file
        and source
        and Path(source).is_file()
        and Path(after_file).is_file()
        and same_inputs([source, after_file])
    ):
        raise InputError(
            f"--after {after_file} is the same runs file as {source}: the test after calibration is a new test, "
            "driven with the new parameters"
        )
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
