"""``umbmark fleet DIR``: every recording of every robot self-calibrated in parallel on Dask and
recorded once in one history.

The library does the work (:mod:`umbmark.fleet`); this module parses the selfcal options each
robot is given (once per set of options, before any job starts) into the self-calibration's
settings, refusing those that would write elsewhere or break the fleet's own bookkeeping, and
prints the outcomes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import click

from umbmark.cli.app import app, cli_message, console, emit_json, is_quiet
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.fleet import FleetJob, FleetOutcome
    from umbmark.realrobot.kinematic_settings import KinematicSettings
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

__all__ = ["fleet_cmd", "NOT_FOR_THE_FLEET"]

NOT_FOR_THE_FLEET = {
    "robot": "the fleet names each robot by its folder (or its manifest entry)",
    "record": "the fleet records every recording itself, in its own history",
    "db": "the fleet records into one history, the fleet's own --db (given once)",
    "recorded_at": "the fleet dates each record by its recording's file time",
    "save": "every recording's result would replace that one file (the fleet keeps each in its history)",
    "intervals_out": "every recording's intervals would replace that one file",
    "write_config": "it writes a configuration file instead of calibrating (run umbmark selfcal with it)",
    "as_json": "the fleet prints its own JSON (umbmark fleet --json)",
    "window": "the fleet records each recording whole (umbmark selfcal --window --record cuts one into windows)",
}
"""The selfcal options the fleet refuses among a robot's options, and why."""


def _flag(command: click.Command, name: str) -> str:
    p = next(p for p in command.params if p.name == name)
    return max(getattr(p, "opts", [name]), key=len)


def _parse(args: tuple[str, ...], path: str, where: str) -> click.Context:
    """selfcal's parse of one set of options (given for ``path``), the refused ones named."""
    from umbmark.cli.guard import GuardedCommand
    from umbmark.cli.selfcal import selfcal_cmd as selfcal

    assert isinstance(selfcal, GuardedCommand)
    try:
        ctx = selfcal.make_context("selfcal", [*args, "--", path], resilient_parsing=False)
    except click.exceptions.Exit:
        raise InputError(f"{' '.join(args)}: not options of a self-calibration (--help is selfcal's)") from None
    except click.ClickException as e:
        raise InputError(f"the self-calibration's options{where}: {e.format_message()}") from None
    default = click.core.ParameterSource.DEFAULT
    for name, why in NOT_FOR_THE_FLEET.items():
        if ctx.get_parameter_source(name) not in (default, None):
            raise InputError(f"{_flag(selfcal, name)} among the self-calibration's options{where}: {why}")
    extra = [p for p in ctx.params["paths"] if p != path]
    if extra:
        raise InputError(f"the self-calibration's options{where} hold {extra[0]}, not an option (a recording?)")
    try:
        selfcal.check_params(ctx)  # a size in the other unit named before any recording is sent
    except click.ClickException as e:
        raise InputError(f"the self-calibration's options{where}: {e.format_message()}") from None
    return ctx


def _settings(ctx: click.Context, kinds: set[str]) -> SelfcalSettings | KinematicSettings:
    """The settings of one set of selfcal's options: a differential drive's, or a robot's of
    another kind (from bags only)."""
    from umbmark.cli.command_config import SelfcalConfig
    from umbmark.cli.kinematic import kinematic_settings
    from umbmark.cli.selfcal import selfcal_settings
    from umbmark.kinds import kind_named

    cfg = SelfcalConfig.from_params(ctx.params)
    kind = cfg.kind.kinematics
    if kind_named(kind).differential:
        return selfcal_settings(cfg, kinds)
    if kinds != {"bags"}:
        raise InputError(f"--kinematics {kind} reads ROS bags (joint states and laser scans), not intervals files")
    if not cfg.fit.wheel_jitter:
        noun = kind_named(kind).noun
        raise InputError(f"--no-wheel-jitter: the self-calibration of a {noun} takes the joint data as exact")
    return kinematic_settings(cfg)


def _with_kind(job: FleetJob, where: str) -> tuple[str, ...]:
    """A job's selfcal options with the kind its manifest names (``kind:``) as ``--kinematics``."""
    if job.kind is None:
        return tuple(job.args)
    if any(a == "--kinematics" or a.startswith("--kinematics=") for a in job.args):
        raise InputError(f"--kinematics among the self-calibration's options{where}: the manifest's `kind:` names it")
    return ("--kinematics", job.kind, *job.args)


def _with_settings(jobs: list[FleetJob], where_of: Callable[[FleetJob], str]) -> list[FleetJob]:
    """Each job with the settings of its options, each set of options parsed and checked once."""
    from dataclasses import replace

    jobs = [replace(j, args=_with_kind(j, where_of(j))) for j in jobs]
    groups: dict[tuple[str, ...], list[FleetJob]] = {}
    for j in jobs:
        groups.setdefault(j.args, []).append(j)
    settings: dict[tuple[str, ...], SelfcalSettings | KinematicSettings] = {}
    for args, group in groups.items():
        where = where_of(group[0])
        ctx = _parse(args, group[0].path, where)
        kinds = {"intervals" if j.is_intervals else "bags" for j in group}
        try:
            settings[args] = _settings(ctx, kinds)
        except InputError as e:
            raise InputError(f"the self-calibration's options{where}: {e}") from None
    return [replace(j, settings=settings[j.args]) for j in jobs]


def _jobs(source: str, args: tuple[str, ...]) -> list[FleetJob]:
    """The jobs of a fleet folder or a manifest, with their settings."""
    from pathlib import Path

    from umbmark.fleet import plan_fleet, read_manifest

    if Path(source).is_dir() and not (Path(source) / "metadata.yaml").is_file():
        jobs = plan_fleet(source, args)
        return _with_settings(jobs, lambda j: "")
    if Path(source).suffix.lower() in (".yaml", ".yml"):
        if args:
            raise InputError(f"{source}: a manifest names each robot's options (`args:`); none after it")
        jobs = read_manifest(source)
        return _with_settings(jobs, lambda j: f" of robot {j.robot} ({j.origin})")
    raise InputError(f"{source}: neither a fleet folder (one folder per robot) nor a manifest (.yaml)")


class _Once(click.Option):
    """An option given at most once: a second value would silently replace the first (the history's
    address shown without its password)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["multiple"] = True
        super().__init__(*args, **kwargs)

    def process_value(self, ctx: click.Context, value: Any) -> Any:
        from umbmark.history import display_db

        values = tuple(super().process_value(ctx, value) or ())
        if len(set(values)) > 1:
            shown = " and ".join(display_db(v) for v in values)
            raise click.BadParameter(f"given twice ({shown}): the fleet has one", ctx=ctx, param=self)
        return values[-1] if values else None


def _told(as_json: bool) -> Callable[[FleetOutcome, int, int], None]:
    def told(outcome: FleetOutcome, done: int, total: int) -> None:
        if as_json or is_quiet():
            return
        mark = {"recorded": f"recorded as #{outcome.record_id}", "skipped": "already recorded"}.get(
            outcome.status, f"FAILED: {cli_message(str(outcome.error))}"
        )
        console().print(
            f"[{done}/{total}] {outcome.robot}: {outcome.path}: {mark}", markup=False, highlight=False, soft_wrap=True
        )

    return told


@app.command(
    "fleet",
    context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
)
@click.argument("source", metavar="DIR|MANIFEST.yaml", type=click.Path(exists=True))
@click.option(
    "--db",
    cls=_Once,
    help="History database: a file or a database URL (PostgreSQL for a fleet; default: $UMBMARK_DB, "
    "else $XDG_DATA_HOME/umbmark/history.sqlite).",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    cls=_Once,
    help="The Dask scheduler (tcp://host:8786), or 'local' for a cluster of --workers processes here [default: local].",
)
@click.option("--workers", type=click.IntRange(1, 512), default=2, show_default=True, help="Local cluster: processes.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON (every recording's outcome).")
@click.pass_context
def fleet_cmd(
    ctx: click.Context, source: str, db: str | None, scheduler: str | None, workers: int, as_json: bool
) -> int:
    """Self-calibrate every robot's recordings in parallel and record each once in one history.

    DIR holds one folder per robot (its name the robot's), each with the robot's recordings: bag
    files (.bag, .mcap, .db3), ROS 2 bag folders, intervals files (.csv). Or a manifest YAML:
    robots: {NAME: {recordings: [paths], args: [selfcal options]}}. Every option after the
    command's own goes to `umbmark selfcal` for each recording (the nominal geometry, the
    topics...); they are checked before any recording is sent, and those that would write
    elsewhere (--robot, --record, --db, --save, --write-config, --recorded-at, --json...) are
    refused. A recording the robot's history already holds (same content) is skipped, so a
    re-run does only what is new; a recording that fails is reported by name and the rest go on;
    a job a lost worker had is run again and recorded once. Each record is dated by its
    recording's file time. Needs Dask (pip install 'umbmark[dask]'). Exit status 0 when none
    failed, 2 otherwise.

    \b
    Examples:
      umbmark fleet recordings/ --wheel-diameter-mm 100 --wheelbase-mm 300 --joints l,r --db fleet.sqlite
      umbmark fleet fleet.yaml --scheduler tcp://10.0.0.5:8786 --db postgresql+psycopg://u@host/umbmark
    """
    from umbmark.fleet import check_scheduler, require_dask, run_fleet
    from umbmark.history import display_db, resolve_db

    require_dask()
    check_scheduler(scheduler or "local")
    path = resolve_db(db)
    jobs = _jobs(source, tuple(ctx.args))
    summary = run_fleet(jobs, path, dask=scheduler or "local", workers=workers, on_outcome=_told(as_json))
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
