"""``umbmark drift ROBOT``: changes and wear in a robot's recorded calibrations; exit status 3 on
an alarm."""

from __future__ import annotations

from typing import TYPE_CHECKING

import click

from umbmark.cli.app import app, cli_message, console, emit_json, fmt, is_quiet, table

if TYPE_CHECKING:
    from umbmark.history.drift import DriftReport

__all__ = ["drift_cmd", "ALARM_STATUS"]

# the exit status when a change is found (0: none; 2: an error)
ALARM_STATUS = 3


@app.command("drift")
@click.argument("robot", metavar="ROBOT")
@click.option(
    "--db",
    type=click.Path(dir_okay=False),
    default=None,
    help="History database (default: $UMBMARK_DB, else $XDG_DATA_HOME/umbmark/history.sqlite).",
)
@click.option(
    "--kind",
    default=None,
    metavar="KIND",
    help="Follow the records of this kind (selfcal, replay, analyze, gyro, ...; default: the kind "
    "with the most records holding intervals).",
)
@click.option(
    "--parameter",
    "parameters",
    multiple=True,
    metavar="KEY",
    help="Only this parameter (a result's JSON key: wheelbase_mm, wheel_diameter_left_mm, Ed, "
    "sensor_pose.x_mm, ...; repeatable; default: every one recorded with its interval).",
)
@click.option(
    "--false-alarm",
    type=float,
    default=None,
    metavar="P",
    help="The probability that one parameter with no change raises an alarm (default 0.001).",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Draw each parameter over time with its intervals, trend and changes (PNG, SVG or PDF).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON (keys: changes, trends, ...).")
def drift_cmd(
    robot: str,
    db: str | None,
    kind: str | None,
    parameters: tuple[str, ...],
    false_alarm: float | None,
    plot_path: str | None,
    as_json: bool,
) -> int:
    """Changes and wear in a robot's calibration history: exit status 3 on an alarm.

    Every recorded calibration holding a parameter with its 95 % interval is a point of that
    parameter's time series. Each series is fitted with one wear rate per day and steps where
    the data demand them (a generalised likelihood ratio test at the stated false-alarm rate per
    parameter); the sessions' intervals are widened by the scatter of the sessions when they are
    too narrow for it. A step is a change: a wheel swapped, a payload added, a bump.

    \b
    Exit status: 0 no change, 3 a change (an alarm, for cron jobs and robots' CI), 2 an error.

    \b
    Examples:
      umbmark selfcal today.csv --wheel-diameter-mm 100 --wheelbase-mm 300 --robot r1 --record
      umbmark drift r1
      umbmark drift r1 --json --plot r1-drift.png
    """
    from umbmark.history import open_history
    from umbmark.history.drift import DEFAULT_FALSE_ALARM, detect_drift

    with open_history(db, create=False) as h:
        h.latest(robot)  # an error naming the robots there are when this one has no record
        recs = h.records(robot)
        warnings = list(h.warnings)
        path = str(h.path)
    alpha = DEFAULT_FALSE_ALARM if false_alarm is None else false_alarm
    rep = detect_drift(recs, robot=robot, kind=kind, parameters=parameters or None, false_alarm=alpha)
    if plot_path:
        from umbmark.viz.drift_plot import drift_figure
        from umbmark.viz.plots import save_figure

        save_figure(drift_figure(rep), plot_path)
    for w in warnings:
        click.echo(f"warning: {w}", err=True)
    if as_json:
        emit_json({"db": path, **rep.to_dict(), "plot": plot_path, "warnings": warnings})
    elif not is_quiet():
        _print(rep, plot_path)
    return ALARM_STATUS if rep.alarm else 0


def _print(rep: DriftReport, plot_path: str | None) -> None:
    from rich.markup import escape

    from umbmark.history.drift import MIN_SESSIONS

    c = console()
    rows = []
    for name, t in rep.trends.items():
        rate = "-" if t.rate_per_day is None else f"{fmt(t.rate_per_day, 6)}"
        ci = (
            "-"
            if t.rate_per_day_ci95 is None
            else f"{fmt(t.rate_per_day_ci95[0], 6)} .. {fmt(t.rate_per_day_ci95[1], 6)}"
        )
        rows.append([name, t.sessions, fmt(t.latest, 6), rate, ci])
    c.print(
        table(
            f"Drift of {rep.robot} ({rep.kind or 'no'} records, {rep.sessions} sessions; "
            f"false-alarm rate {rep.false_alarm_rate:g} per parameter)",
            ["parameter", "sessions", "latest", "rate per day", "95 % interval"],
            rows,
        )
    )
    for n in rep.notes:
        c.print(escape(f"note: {cli_message(n)}"))
    if not rep.trends:
        c.print(f"no test yet: a parameter needs {MIN_SESSIONS} sessions of {rep.kind} records for a trend and a test")
    elif not rep.changes:
        c.print("no change: the history is one trend within its intervals")
    for ch in rep.changes:
        c.print(
            escape(
                f"ALARM: {ch.parameter} changed at record #{ch.record} ({ch.time_utc[:16].replace('T', ' ')} UTC): "
                f"{fmt(ch.before, 6)} -> {fmt(ch.after, 6)} (step {fmt(ch.step, 6)}, 95 % interval "
                f"{fmt(ch.step_ci95[0], 6)} .. {fmt(ch.step_ci95[1], 6)}; p = {ch.p_value:.2g})"
            )
        )
    if rep.changes:
        c.print("what to do: look at the robot (wheels, tyres, load), then calibrate again and load the new parameters")
    if plot_path:
        c.print(escape(f"plot: {plot_path}"))
