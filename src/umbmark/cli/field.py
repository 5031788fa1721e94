"""The field procedure: ``umbmark guide`` (the UMBmark test step by step, or a ROS 2 node that
drives it) and ``umbmark measure`` (tape-measured wall distances into a runs file).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import click

from umbmark._numbers import strict_float
from umbmark.cli.app import (
    app,
    cli_message,
    console,
    emit_json,
    fmt,
    is_quiet,
    positive,
    table,
)
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.io.distances_csv import MeasuredRun
    from umbmark.realrobot.measure import RobotMarks

__all__ = ["guide_cmd", "measure_cmd", "POINT", "PointType"]


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
def guide_cmd(
    side_mm: float,
    runs: int,
    ros2_script: bool,
    speed_m_s: float,
    turn_rate_deg_s: float,
    cmd_vel_topic: str,
    odom_topic: str,
    stamped: bool,
    pause_s: float,
) -> None:
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
    check_run_plan(side_mm / 1000.0, speed_m_s, turn_rate_deg_s, pause_s, runs)  # with or without a script
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

    def convert(self, value: object, param: click.Parameter | None, ctx: click.Context | None) -> tuple[float, float]:
        """Parse ``value`` (a tuple is kept as it is); a bad value is a usage error."""
        if isinstance(value, tuple):
            return (value[0], value[1])
        parts = str(value).replace(";", ",").split(",")
        try:
            x, y = (strict_float(p) for p in parts)
        except ValueError:
            self.fail(f"{value!r} is not two numbers X,Y in millimetres (e.g. 150,-120)", param, ctx)
        if not (math.isfinite(x) and math.isfinite(y)):
            self.fail(f"{value!r} is not two finite numbers", param, ctx)
        return (x, y)


POINT = PointType()


class TypedNumber(click.ParamType):
    """A number typed at a prompt: digits only (``1_0`` is not 10), finite, from ``lo`` to ``hi``
    (``unit`` names the range); a bad answer is asked again."""

    name = "number"

    def __init__(self, lo: float, hi: float, unit: str, empty: bool = False):
        self.lo, self.hi, self.unit, self.empty = lo, hi, unit, empty

    def convert(self, value: object, param: click.Parameter | None, ctx: click.Context | None) -> float | str:
        """The number in ``value`` (``""`` for an empty answer where allowed); anything else
        fails (and click asks again)."""
        if isinstance(value, float):
            return value
        if self.empty and not str(value).strip():
            return str(value)
        try:
            v = strict_float(str(value))
        except ValueError:
            self.fail(f"{value!r} is not a number", param, ctx)
        if not (math.isfinite(v) and self.lo <= v <= self.hi):
            self.fail(f"{value!r} is not a number from {self.lo:g} to {self.hi:g} {self.unit}", param, ctx)
        return v


# what a tape and an odometry read after a square run (the bounds of the distances file's reader)
_TAPE_MM = TypedNumber(0.0, 1e6, "mm (a tape's reading)")
_ODO_MM = TypedNumber(-1e6, 1e6, "mm (the odometry's end, near the start)")
_ODO_DEG = TypedNumber(-720.0, 720.0, "deg (the odometry's end heading)")
_ODO_DEG_OR_NONE = TypedNumber(-720.0, 720.0, "deg (the odometry's end heading), or nothing", empty=True)


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
def measure_cmd(
    distances_file: str | None,
    front: tuple[float, float],
    rear: tuple[float, float],
    back: tuple[float, float],
    side_wall: str,
    resolution_mm: float,
    out_path: str,
    interactive: bool,
    n_runs: int,
    as_json: bool,
) -> None:
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
    marks = RobotMarks(_metres(front), _metres(rear), _metres(back))
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
    for w in res.warnings if as_json or not is_quiet() else ():
        click.echo(f"warning: {cli_message(w)}", err=True)
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


def _metres(point_mm: tuple[float, float]) -> tuple[float, float]:
    return point_mm[0] * 1e-3, point_mm[1] * 1e-3


def _interactive(
    marks: RobotMarks, side_wall: str, resolution_m: float, out_path: str, n_runs: int
) -> list[MeasuredRun]:
    """:func:`_prompt_runs`; the input ending (end of file) before the last run is an error
    naming the run and the files that hold the runs entered."""
    raw_path = str(Path(out_path).with_suffix("")) + ".distances.csv"
    rows: list[MeasuredRun] = []
    try:
        return _prompt_runs(marks, side_wall, resolution_m, out_path, n_runs, rows)
    except click.exceptions.Abort as e:
        if not isinstance(e.__context__, EOFError):
            raise  # Ctrl-C: aborted
        saved = f"the {len(rows)} runs entered are in {out_path} and {raw_path}" if rows else "no run was saved"
        raise InputError(
            f"--interactive: the input ended before run {len(rows) + 1} of {2 * n_runs} was complete; {saved}"
        ) from None


def _prompt_runs(
    marks: RobotMarks, side_wall: str, resolution_m: float, out_path: str, n_runs: int, rows: list[MeasuredRun]
) -> list[MeasuredRun]:
    """Prompt for every run; after each run, save the distances (``<out>.distances.csv``) and the
    runs file so far (``rows`` grows with the runs entered)."""
    from umbmark.io.atomic import atomic_write
    from umbmark.io.distances_csv import DIST_COLUMNS, MeasuredRun, format_distances_csv
    from umbmark.realrobot.measure import measure_runs

    raw_path = str(Path(out_path).with_suffix("")) + ".distances.csv"
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
                    x_odo = click.prompt("  odometry x at the end [mm]", type=_ODO_MM)
                    y_odo = click.prompt("  odometry y at the end [mm]", type=_ODO_MM)
                    th: str | float
                    if want_theta is None:
                        th = click.prompt(
                            "  odometry theta at the end [deg] (empty: not read)",
                            default="",
                            show_default=False,
                            type=_ODO_DEG_OR_NONE,
                        )
                        want_theta = bool(str(th).strip())
                    elif want_theta:
                        th = click.prompt("  odometry theta at the end [deg]", type=_ODO_DEG)
                    else:
                        th = ""
                default: float | None = prev[i] if (prev is not None and i < 3) else None
                vals[c] = click.prompt(f"  {labels[c]} [mm]", type=_TAPE_MM, default=default)
            theta = None
            if str(th).strip():
                theta = float(th)
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
