"""``umbmark fleet DIR``: every recording of every robot self-calibrated in parallel on Dask and
recorded once in one history."""

from __future__ import annotations

import contextlib
import io
import json
from typing import Any

import click

from umbmark.cli.app import app, console, emit_json, is_quiet
from umbmark.errors import InputError

__all__ = ["fleet_cmd"]


def _calibrate(job: Any) -> dict[str, Any]:
    """On a worker: ``umbmark selfcal RECORDING OPTIONS --json`` of one job, its JSON or its error."""
    from umbmark.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["selfcal", job.path, *job.args, "--json"])
    if code != 0:
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
        line = lines[-1] if lines else f"exit status {code}"
        return {"ok": False, "error": line.split(": error: ", 1)[-1]}
    try:
        return {"ok": True, "result": json.loads(out.getvalue())}
    except ValueError:
        return {"ok": False, "error": "the self-calibration printed no JSON"}


def _record(history: Any, job: Any, result: dict[str, Any]) -> int:
    from umbmark.realrobot.selfcal import selfcal_history_fields

    fields = selfcal_history_fields(result, "selfcal")
    fields["input_sha256"] = job.sha256
    fields["source"] = job.path
    fields["when"] = job.when
    return int(history.add(job.robot, **fields))


def _check_options(jobs: list, args: tuple[str, ...]) -> None:
    """The selfcal options, parsed against the first recording before anything is sent."""
    from umbmark.cli.guard import GuardedCommand
    from umbmark.cli.selfcal import selfcal_cmd as selfcal

    assert isinstance(selfcal, GuardedCommand)

    for j in {j.args: j for j in jobs}.values():
        try:
            with selfcal.make_context("selfcal", [j.path, *j.args], resilient_parsing=False) as ctx:
                selfcal.check_params(ctx)  # a size in the other unit named before any recording is sent
        except click.exceptions.Exit:
            raise InputError(f"{' '.join(j.args)}: not options of a self-calibration (--help is selfcal's)") from None
        except click.ClickException as e:
            raise InputError(f"the self-calibration's options ({j.robot}): {e.format_message()}") from None


@app.command(
    "fleet",
    context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
)
@click.argument("source", metavar="DIR|MANIFEST.yaml", type=click.Path(exists=True))
@click.option(
    "--db",
    default=None,
    help="History database: a file or a database URL (PostgreSQL for a fleet; default: $UMBMARK_DB, "
    "else $XDG_DATA_HOME/umbmark/history.sqlite).",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    default="local",
    show_default=True,
    help="The Dask scheduler (tcp://host:8786), or 'local' for a cluster of --workers processes here.",
)
@click.option("--workers", type=click.IntRange(1, 512), default=2, show_default=True, help="Local cluster: processes.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON (every recording's outcome).")
@click.pass_context
def fleet_cmd(ctx, source, db, scheduler, workers, as_json):
    """Self-calibrate every robot's recordings in parallel and record each once in one history.

    DIR holds one folder per robot (its name the robot's), each with the robot's recordings: bag
    files (.bag, .mcap, .db3), ROS 2 bag folders, intervals files (.csv). Or a manifest YAML:
    robots: {NAME: {recordings: [paths], args: [selfcal options]}}. Every option after the
    command's own goes to `umbmark selfcal` for each recording (the nominal geometry, the
    topics...). A recording the robot's history already holds (same content) is skipped, so a
    re-run does only what is new; a recording that fails is reported by name and the rest go on;
    a job a lost worker had is run again and recorded once. Exit status 0 when none failed, 2
    otherwise.

    \b
    Examples:
      umbmark fleet recordings/ --wheel-diameter-mm 100 --wheelbase-mm 300 --joints l,r --db fleet.sqlite
      umbmark fleet fleet.yaml --scheduler tcp://10.0.0.5:8786 --db postgresql+psycopg://u@host/umbmark
    """
    from pathlib import Path

    from umbmark.history import display_db, resolve_db
    from umbmark.studies.fleet import plan_fleet, read_manifest, run_fleet

    args = tuple(ctx.args)
    path = resolve_db(db)
    if Path(source).is_dir() and not (Path(source) / "metadata.yaml").is_file():
        jobs = plan_fleet(source, args)
    elif Path(source).suffix.lower() in (".yaml", ".yml"):
        if args:
            raise InputError(f"{source}: a manifest names each robot's options (`args:`); none after it")
        jobs = read_manifest(source)
    else:
        raise InputError(f"{source}: neither a fleet folder (one folder per robot) nor a manifest (.yaml)")
    _check_options(jobs, args)

    def told(outcome, done, total):
        if as_json or is_quiet():
            return
        mark = {"recorded": f"recorded as #{outcome.record_id}", "skipped": "already recorded"}.get(
            outcome.status, f"FAILED: {outcome.error}"
        )
        console().print(
            f"[{done}/{total}] {outcome.robot}: {outcome.path}: {mark}", markup=False, highlight=False, soft_wrap=True
        )

    summary = run_fleet(jobs, _calibrate, _record, path, dask=scheduler, workers=workers, on_outcome=told)
    if as_json:
        emit_json({"db": display_db(path), **summary.to_dict()})
    elif not is_quiet():
        console().print(
            f"{summary.count('recorded')} recorded, {summary.count('skipped')} already recorded, "
            f"{summary.count('failed')} failed ({display_db(path)})",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    return 2 if summary.count("failed") else 0
