"""``umbmark calibrate``: iterate run / correct / re-run (simulator), or compose the passes of
a real robot from its runs files (:mod:`umbmark.studies.iterate`). No numerical module is
imported before the command runs."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from umbmark.cli.app import (
    METHOD_CHOICES,
    NOISE_CHOICES,
    app,
    cli_message,
    console,
    emit_json,
    error_param,
    fmt,
    is_quiet,
    positive,
    table,
)
from umbmark.cli.core import _prior, geometry_options, prior_options
from umbmark.cli.history import history_options, print_recorded, record_if_requested
from umbmark.cli.progress import progress
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.studies.iterate import LoopResult

__all__ = ["calibrate"]


def _pass_rows(loop: LoopResult) -> list[list[object]]:
    rows: list[list[object]] = []
    for p in loop.passes:
        cal = p.calibration_used
        used = "nominal" if cal is None else f"{cal.c_left:.5f}/{cal.c_right:.5f}"
        c = p.correction
        ci = "-"
        if c is not None and c.intervals is not None:
            lo, hi = c.intervals.wheelbase_m
            ci = f"[{lo * 1e3:.2f}, {hi * 1e3:.2f}]"
        rule = p.result.sem_rule
        rows.append(
            [
                p.index if p.source is None else f"{p.index} ({Path(p.source).name})",
                used,
                f"{p.wheelbase_used_m * 1e3:.2f}",
                fmt(p.result.emax_syst * 1e3),
                "-" if rule is None else fmt(rule * 1e3),
                "-" if c is None else fmt(c.ed, 6),
                "-" if c is None else f"{c.calibration.wheelbase_m * 1e3:.2f}",
                ci,
            ]
        )
    return rows


def _print_loop(loop: LoopResult, title: str) -> None:
    from rich.markup import escape

    c = console()
    c.print(
        table(
            title,
            [
                "pass",
                "c_left/c_right used",
                "b used [mm]",
                "E_max,syst [mm]",
                "3 x SEM [mm]",
                "E_d (total)",
                "b new [mm]",
                "b new 95 % [mm]",
            ],
            _pass_rows(loop),
        )
    )
    for p in loop.passes:
        c.print(f"pass {p.index}: {p.decision}", markup=False)
        if p.correction is not None:
            for w in p.correction.warnings:
                c.print(f"[yellow]warning:[/yellow] pass {p.index}: {escape(cli_message(w))}")
    cal = loop.final_calibration
    if cal is not None:
        c.print(
            f"final calibration: c_left = {cal.c_left:.6f}, c_right = {cal.c_right:.6f}, "
            f"wheelbase = {fmt(None if cal.wheelbase_m is None else cal.wheelbase_m * 1e3, 2)} mm (E_d = {cal.ed:.6f})"
        )
    if loop.errors is not None:
        e = loop.errors
        c.print(f"true robot: E_d = {e.ed:.6f}, wheelbase = {e.eb * loop.nominal_wheelbase_m * 1e3:.2f} mm")
    if not any(p.decision == loop.stopped for p in loop.passes):
        c.print(loop.stopped)


@app.command()
@click.argument("runs_files", nargs=-1, metavar="[PASS1.csv PASS2.csv ...]")
@click.option("--ed", type=float, default=1.02, show_default=True, help="Simulator: true E_d = D_R / D_L.")
@click.option("--eb", type=float, default=0.95, show_default=True, help="Simulator: true E_b = b_actual / b_nominal.")
@click.option(
    "--runs",
    "n_runs",
    type=click.IntRange(min=2),
    default=5,
    show_default=True,
    help="Simulator: runs per direction in each pass.",
)
@click.option("--noise", type=click.Choice(NOISE_CHOICES), default="paper", show_default=True)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--max-passes",
    type=click.IntRange(min=1),
    default=3,
    show_default=True,
    help="Simulator: at most this many corrections.",
)
@click.option("--method", type=click.Choice(METHOD_CHOICES), default="exact", show_default=True)
@click.option("--sample-period-ms", type=float, default=10.0, show_default=True)
@click.option(
    "--save-runs",
    type=click.Path(file_okay=False),
    default=None,
    help="Simulator: write each pass's runs file (pass1.csv, ...) into this existing folder.",
)
@geometry_options
@prior_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@history_options
def calibrate(
    runs_files: tuple[str, ...],
    ed: float,
    eb: float,
    n_runs: int,
    noise: str,
    seed: int,
    max_passes: int,
    method: str,
    sample_period_ms: float,
    save_runs: str | None,
    wheelbase_mm: float,
    side_mm: float,
    wheel_diameter_mm: float,
    c_left: float,
    c_right: float,
    as_json: bool,
    robot: str | None = None,
    record: bool = False,
    db: str | None = None,
) -> None:
    """Iterate the calibration until it stops paying.

    Without files (simulator): a robot with true errors --ed/--eb runs the test; while
    E_max,syst >= 3 x SEM (the paper's rule) the runs are corrected (--method), the correction
    is loaded into the robot's odometry and the test is run again, at most --max-passes times.

    With runs files (a real robot): PASS1.csv was made with the nominal odometry (or
    --c-left/--c-right and --wheelbase-mm), PASS2.csv with the calibration computed from pass 1
    loaded, and so on. Each pass is corrected relative to the odometry it ran with and the
    corrections are composed; the last line is the calibration to load.

    --robot NAME --record stores the final calibration in the robot's history (the runs of
    every pass, and the SHA-256 of the runs files, go with it).

    \b
    Examples:
      umbmark calibrate --ed 1.02 --eb 0.95 --seed 1
      umbmark calibrate pass1.csv pass2.csv --wheelbase-mm 340 --side-mm 4000
      umbmark calibrate pass1.csv pass2.csv --robot r1 --record
    """
    from umbmark.io.runs_csv import read_runs_csv, write_runs_csv
    from umbmark.studies.iterate import calibrate_loop, compose_passes, history_fields

    side_m = positive("--side-mm", side_mm) * 1e-3
    wheelbase_m = positive("--wheelbase-mm", wheelbase_mm) * 1e-3
    from umbmark.correct.plausibility import check_geometry

    for w in check_geometry(side_m, wheelbase_m):
        click.echo(f"warning: {cli_message(w)}", err=True)
    prior = _prior(c_left, c_right)
    # the simulated robot's options are checked with runs files too (a bad value is a mistake)
    wheel_diameter_m = positive("--wheel-diameter-mm", wheel_diameter_mm) * 1e-3
    true_ed, true_eb = error_param("--ed", ed), error_param("--eb", eb)
    sample_period_s = positive("--sample-period-ms", sample_period_ms) * 1e-3
    from umbmark.model.simulate import Motion

    motion = Motion(sample_period_s=sample_period_s)
    if runs_files:
        runs = [read_runs_csv(f) for f in runs_files]
        loop = compose_passes(runs, side_m, wheelbase_m, method, prior, sources=runs_files)
        title = f"Successive calibrations of {len(runs)} runs files ({method})"
    else:
        from umbmark.model.geometry import LABMATE, ErrorParams, Geometry

        if save_runs is not None and not Path(save_runs).is_dir():
            raise InputError(f"output folder {save_runs} does not exist")
        geom = Geometry(
            wheel_diameter_m,
            wheelbase_m,
            LABMATE.pulses_per_motor_rev,
            LABMATE.gear_ratio,
        )
        errors = ErrorParams(true_ed, true_eb)
        with progress(f"simulating up to {max_passes + 1} tests", total=max_passes + 1) as advance:
            loop = calibrate_loop(
                errors,
                geom,
                side_m,
                n_runs,
                noise,
                motion,
                method,
                max_passes,
                seed,
                prior,
                on_progress=lambda done, total: advance(),
            )
        if save_runs is not None:
            for p in loop.passes:
                write_runs_csv(p.runs, Path(save_runs) / f"pass{p.index}.csv")
        title = (
            f"Calibration loop ({method}): simulated robot E_d = {ed}, E_b = {eb}, noise '{noise}', "
            f"{n_runs} runs each way"
        )
    rec = record_if_requested(robot, record, db, **history_fields(loop)) if record else None
    if as_json:
        d = loop.to_dict()
        emit_json(d if rec is None else {**d, "history": rec})
    elif not is_quiet():
        _print_loop(loop, title)
        print_recorded(rec)
