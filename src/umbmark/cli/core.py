"""``umbmark simulate``, ``umbmark analyze`` and ``umbmark demo``.

Building these commands imports no numerical module: the library is imported when a command runs.
"""

from __future__ import annotations

import shlex
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from umbmark.cli.app import (
    LABMATE_WHEEL_DIAMETER_MM,
    LABMATE_WHEELBASE_MM,
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
    prior_options,
    table,
)
from umbmark.cli.history import history_options, print_recorded, record_if_requested, refuse_if_recorded
from umbmark.cli.progress import progress

if TYPE_CHECKING:
    from rich.table import Table

    from umbmark.correct.analysis import Analysis
    from umbmark.metrics import UMBmarkResult
    from umbmark.model.geometry import Calibration
    from umbmark.studies.demo import DemoResult

__all__ = ["analyze", "demo", "geometry_options", "prior_options", "simulate"]

F = TypeVar("F", bound=Callable[..., Any])


def geometry_options(f: F) -> F:
    """Add ``--wheelbase-mm``, ``--side-mm`` and ``--wheel-diameter-mm`` (the LabMate's by default).

    Parameters
    ----------
    f : callable
        The command function (it receives ``wheelbase_mm``, ``side_mm``, ``wheel_diameter_mm``).

    Returns
    -------
    callable
        ``f`` with the three options.
    """
    f = click.option(
        "--wheel-diameter-mm",
        type=float,
        default=LABMATE_WHEEL_DIAMETER_MM,
        show_default=True,
        help="Nominal wheel diameter.",
    )(f)
    f = click.option("--side-mm", type=float, default=4000.0, show_default=True, help="Side of the square path.")(f)
    f = click.option(
        "--wheelbase-mm", type=float, default=LABMATE_WHEELBASE_MM, show_default=True, help="Nominal wheelbase."
    )(f)
    return f


# a robot driving the square faster than this is not a test robot (metres per second)
MAX_SPEED_M_S = 10.0


def _speed(speed_m_s: float) -> float:
    """``--speed`` in m/s: positive and at most :data:`MAX_SPEED_M_S` (mm/s named as such)."""
    from umbmark.errors import InputError

    v = positive("--speed", speed_m_s)
    if v > MAX_SPEED_M_S:
        raise InputError(
            f"--speed {v:g} m/s is faster than a robot drives a test square (at most {MAX_SPEED_M_S:g} m/s): "
            f"given in mm/s? {v:g} mm/s is {v / 1000:g} m/s"
        )
    return v


def _prior(c_left: float, c_right: float, wheelbase_mm: float | None = None) -> Calibration | None:
    from umbmark.model.geometry import Calibration

    for name, v in (("--c-left", c_left), ("--c-right", c_right)):
        error_param(name, v)
    if c_left == 1.0 and c_right == 1.0 and wheelbase_mm is None:
        return None
    return Calibration(c_left, c_right, None if wheelbase_mm is None else wheelbase_mm * 1e-3)


# one line per figure a newcomer meets, printed under the table or line that shows it
LEGEND_RUNS = (
    "x_cg, y_cg: centre of gravity of the return errors of one direction (absolute - odometry: "
    "where the robot stopped, seen from where its odometry said it stopped); r_cg: its distance "
    "from the origin; std: radial spread of the runs about it; SEM = std / sqrt(runs)."
)
LEGEND_EMAX = (
    "E_max,syst: the larger r_cg of cw and ccw, the systematic odometry error (the paper's "
    "measure, Eq. 3.4). 3 x SEM: three standard errors of the direction that sets it; while "
    "E_max,syst is at least that, a calibration pass can still reduce it (the paper's rule)."
)
LEGEND_ANGLES = (
    "alpha: extra rotation in every 90 deg turn (a wrong wheelbase); beta: heading gained along "
    "each leg (unequal wheels)."
)
LEGEND_FROM_XY = (
    " from x, from y: the estimates from the x and from the y coordinates of the centres of "
    "gravity; used: their average."
)
LEGEND_CALIBRATION = (
    "E_d: right / left wheel diameter; E_b: effective / nominal wheelbase; c_left, c_right: "
    "multiply each wheel's distance per encoder pulse by these; wheelbase: the value the odometry "
    "should use instead of the one it ran with."
)
LEGEND_PREDICTED = (
    "predicted E_max,syst after, systematic / measured: what the uncertainty of this calibration "
    "leaves, and what a re-run with as many runs would measure."
)
LEGEND_DEMO = (
    "E_d, E_b used by the odometry: the right / left wheel-diameter ratio and the wheelbase / nominal "
    "wheelbase it assumes; c_left, c_right: the factors on each wheel's distance per encoder pulse "
    "that make its E_d so; wheelbase: the one it uses for turns."
)


def _legend(text: str) -> str:
    from rich.markup import escape

    return f"[dim]{escape(text)}[/dim]"


def _stats_table(title: str, res: UMBmarkResult) -> Table:
    rows: list[list[object]] = []
    for st in (res.cw, res.ccw):
        d = st.to_dict()
        rows.append(
            [
                st.direction,
                st.n,
                fmt(d["x_cg_mm"]),
                fmt(d["y_cg_mm"]),
                fmt(d["r_cg_mm"]),
                fmt(d["std_mm"]),
                fmt(d["sem_mm"]),
            ]
        )
    return table(title, ["direction", "runs", "x_cg [mm]", "y_cg [mm]", "r_cg [mm]", "std [mm]", "SEM [mm]"], rows)


_CI_LABELS = {
    "Ed_ci95": ("E_d, 95 % interval", 6),
    "Eb_ci95": ("E_b, 95 % interval", 6),
    "wheelbase_corrected_mm_ci95": ("wheelbase [mm], 95 % interval", 2),
}


def _angles_table(a: Analysis, d: dict) -> tuple[Table, bool]:
    """alpha, beta, E_d, E_b of the correction: from x, from y and used (the bf method), or used only.

    Returns the table and whether it has the from x / from y columns.
    """
    spec = (
        ("alpha [deg]", "alpha_x_deg", "alpha_y_deg", "alpha_deg", 4),
        ("beta [deg]", "beta_x_deg", "beta_y_deg", "beta_deg", 4),
        ("E_d (this pass)", "Ed_x", "Ed_y", "Ed_pass", 6),
        ("E_b", "Eb_x", "Eb_y", "Eb", 6),
    )
    method = a.correction.method
    if any(d.get(kx) is not None for _, kx, _, _, _ in spec):
        rows = [[name, fmt(d.get(kx), n), fmt(d.get(ky), n), fmt(d.get(k), n)] for name, kx, ky, k, n in spec]
        title = f"Correction ({method}): from x, from y, used (average)"
        return table(title, ["", "from x", "from y", "used"], rows), True
    rows = [[name, fmt(d.get(k), n)] for name, _, _, k, n in spec]
    return table(f"Correction ({method})", ["", "value"], rows), False


def _calibration_rows(a: Analysis, d: dict) -> list[list[str]]:
    rows = [
        ["curvature radius of the legs R", "-" if d["radius_mm"] is None else f"{d['radius_mm'] / 1e3:.1f} m"],
        ["E_d = D_R / D_L", fmt(d["Ed"], 6)],
        ["E_b = b_actual / b_nominal", fmt(d["Eb"], 6)],
        ["c_left", fmt(d["c_left"], 6)],
        ["c_right", fmt(d["c_right"], 6)],
        ["wheelbase [mm]", f"{a.wheelbase_m * 1e3:.2f} -> {d['wheelbase_corrected_mm']:.2f}"],
    ]
    for key, (label, digits) in _CI_LABELS.items():
        if d.get(key):
            lo, hi = d[key]
            rows.append([label, f"[{fmt(lo, digits)}, {fmt(hi, digits)}]"])
    if d.get("emax_syst_after_pred_measured_mm") is not None:
        rows.append(
            [
                "predicted E_max,syst after [mm]",
                f"{d['emax_syst_after_pred_mm']:.1f} / {d['emax_syst_after_pred_measured_mm']:.1f}",
            ]
        )
    return rows


def _next_commands(
    a: Analysis,
    runs_file: str,
    side_mm: float,
    method: str,
    c_left: float,
    c_right: float,
    loss: str | None,
    straight_mm: tuple[float, float] | None,
) -> tuple[str, str]:
    """The commands that analyse the calibrated robot's runs, and that save this analysis as JSON."""
    q = shlex.quote
    cal = a.correction.calibration
    assert cal.wheelbase_m is not None  # every correction method sets it
    common = f"--side-mm {side_mm:.10g}" + ("" if method == "bf" else f" --method {method}")
    if loss is not None:
        common += f" --loss {loss}"
    again = (
        f"umbmark analyze NEW.csv --wheelbase-mm {cal.wheelbase_m * 1e3:.2f} {common} "
        f"--c-left {fmt(cal.c_left, 6)} --c-right {fmt(cal.c_right, 6)}"
    )
    save = f"umbmark analyze {q(str(runs_file))} --wheelbase-mm {a.wheelbase_m * 1e3:.10g} {common}"
    if (c_left, c_right) != (1.0, 1.0):
        save += f" --c-left {c_left:.10g} --c-right {c_right:.10g}"
    if straight_mm:
        save += f" --straight-mm {straight_mm[0]:.10g} {straight_mm[1]:.10g}"
    export = f"{save} --json > cal.json && umbmark export cal.json --format ros2 --out params.yaml"
    return again, export


def _analysis_dict(a: Analysis, plausibility: list[str]) -> dict:
    """The analysis as a dict, its warnings after the plausibility checks' (each once)."""
    d = a.to_dict()
    d["warnings"] = list(dict.fromkeys(plausibility + d.get("warnings", [])))
    return d


def _print_analysis(a: Analysis, again: str, export: str, plausibility: list[str] | None = None) -> None:
    """The human output of ``umbmark analyze``: the figures, what each means, and what to do next.

    ``again``: the command that analyses the runs of the calibrated robot; ``export``: the
    command that writes this analysis as JSON for ``umbmark export``; ``plausibility``: the
    warnings of the plausibility checks.
    """
    from rich.markup import escape

    c = console()
    d = _analysis_dict(a, plausibility or [])
    res = a.result
    c.print(
        _stats_table(
            f"UMBmark return position errors (absolute - odometry), {res.cw.n} cw and {res.ccw.n} ccw runs", res
        )
    )
    c.print(_legend(LEGEND_RUNS))
    rule = "-" if d["three_sem_mm"] is None else f"{d['three_sem_mm']:.1f} mm"
    c.print(
        f"E_max,syst = [bold]{d['emax_syst_mm']:.1f} mm[/bold]   3 x SEM = {rule}   "
        f"second pass recommended: {'yes' if d['second_pass_recommended'] else 'no'}"
    )
    c.print(_legend(LEGEND_EMAX))
    if a.correction.alpha is not None:
        angles, from_xy = _angles_table(a, d)
        c.print(angles)
        c.print(_legend(LEGEND_ANGLES + (LEGEND_FROM_XY if from_xy else "")))
    c.print(table("Calibration to load into the odometry", ["", "value"], _calibration_rows(a, d)))
    c.print(_legend(LEGEND_CALIBRATION))
    if d.get("emax_syst_after_pred_measured_mm") is not None:
        c.print(_legend(LEGEND_PREDICTED))
    for w in d.get("warnings", []):
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
    load = (
        f"c_left = {fmt(d['c_left'], 6)}, c_right = {fmt(d['c_right'], 6)} and the wheelbase "
        f"{d['wheelbase_corrected_mm']:.2f} mm"
    )
    if d["second_pass_recommended"]:
        c.print(
            "[bold]Next[/bold]: E_max,syst is at least 3 x SEM, so this calibration should reduce it. "
            f"Load {load} into the robot's odometry, drive the test again and analyse the new runs "
            "with the calibration they ran with:"
        )
        c.print(f"  {escape(again)}", soft_wrap=True)
    else:
        c.print(
            "[bold]Next[/bold]: E_max,syst is below 3 x SEM: what is left is within the scatter of the "
            f"runs, and a further calibration is not expected to help. To load this one anyway: {load}."
        )
    c.print("For a ROS 2 diff_drive_controller, save this analysis and export it:")
    c.print(f"  {escape(export)}", soft_wrap=True)


@app.command()
@click.option("--ed", type=float, default=1.0, show_default=True, help="True E_d = D_R / D_L.")
@click.option("--eb", type=float, default=1.0, show_default=True, help="True E_b = b_actual / b_nominal.")
@click.option("--es", type=float, default=1.0, show_default=True, help="True E_s = D_avg / D_nominal.")
@click.option("--runs", "n_runs", type=click.IntRange(min=1), default=5, show_default=True, help="Runs per direction.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--noise",
    type=click.Choice(NOISE_CHOICES),
    default="none",
    show_default=True,
    help="Non-systematic errors: none, or the paper's (sigma about 25 mm on the 4 m square).",
)
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="Runs file to write (CSV, mm, deg).")
@geometry_options
@prior_options
@click.option(
    "--model-wheelbase-mm", type=float, default=None, help="Wheelbase the robot's odometry uses (default: nominal)."
)
@click.option("--sample-period-ms", type=float, default=10.0, show_default=True)
@click.option("--speed", "speed_m_s", type=float, default=0.2, show_default=True, help="Speed on the legs [m/s].")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary.")
def simulate(
    ed: float,
    eb: float,
    es: float,
    n_runs: int,
    seed: int,
    noise: str,
    out: str,
    wheelbase_mm: float,
    side_mm: float,
    wheel_diameter_mm: float,
    c_left: float,
    c_right: float,
    model_wheelbase_mm: float | None,
    sample_period_ms: float,
    speed_m_s: float,
    as_json: bool,
) -> None:
    """Simulate the bi-directional UMBmark test and write a runs file.

    A robot with true errors E_d, E_b (and E_s) drives the cw and ccw squares closed-loop on
    its own odometry (nominal, or the calibration given by --c-left/--c-right/
    --model-wheelbase-mm); the file records where it really stopped and what its odometry said.

    \b
    Example:
      umbmark simulate --ed 1.002 --eb 0.99 --runs 5 --seed 1 --noise paper --out runs.csv
    """
    from umbmark.io.runs_csv import write_runs_csv
    from umbmark.metrics import umbmark_figures
    from umbmark.model.geometry import LABMATE, ErrorParams, Geometry
    from umbmark.model.simulate import Motion, simulate_umbmark

    geom = Geometry(
        positive("--wheel-diameter-mm", wheel_diameter_mm) * 1e-3,
        positive("--wheelbase-mm", wheelbase_mm) * 1e-3,
        LABMATE.pulses_per_motor_rev,
        LABMATE.gear_ratio,
    )
    side_m = positive("--side-mm", side_mm) * 1e-3
    from umbmark.correct.plausibility import check_geometry

    for w in check_geometry(side_m, geom.wheelbase_m):
        click.echo(f"warning: {cli_message(w)}", err=True)
    if model_wheelbase_mm is not None:
        positive("--model-wheelbase-mm", model_wheelbase_mm)
    errors = ErrorParams(error_param("--ed", ed), error_param("--eb", eb), error_param("--es", es))
    motion = Motion(
        speed_m_s=_speed(speed_m_s),
        sample_period_s=positive("--sample-period-ms", sample_period_ms) * 1e-3,
    )
    with progress(f"simulating {n_runs} runs each way"):
        runs = simulate_umbmark(
            errors, geom, side_m, n_runs, _prior(c_left, c_right, model_wheelbase_mm), noise, motion, seed=seed
        )
    write_runs_csv(runs, out)
    res = umbmark_figures(runs)
    if as_json:
        emit_json({"out": str(out), "runs_per_direction": n_runs, "noise": noise, "seed": seed, **res.to_dict()})
    elif not is_quiet():
        c = console()
        c.print(f"Simulated runs written to {out}", markup=False, soft_wrap=True)  # the path on one line
        c.print(_stats_table("Simulated runs", res))
        c.print(f"E_max,syst = {res.emax_syst * 1e3:.1f} mm")


@app.command()
@click.argument("runs_file", metavar="FILE.csv")
@click.option(
    "--wheelbase-mm",
    type=float,
    required=True,
    help="Wheelbase the robot's odometry used during the runs (nominal for a first pass).",
)
@click.option("--side-mm", type=float, required=True, help="Side of the square path.")
@click.option(
    "--method",
    type=click.Choice(METHOD_CHOICES),
    default="bf",
    show_default=True,
    help="bf: the paper's linearised correction; exact: non-linear fit of the closed-loop model with 95 % intervals.",
)
@prior_options
@click.option(
    "--loss",
    type=click.Choice(["linear", "soft_l1", "huber", "cauchy", "arctan"]),
    default=None,
    help="exact only: least-squares loss (a robust one resists outlier runs). [default: linear]",
)
@click.option(
    "--straight-mm",
    type=float,
    nargs=2,
    default=None,
    metavar="ODO MEASURED",
    help="exact only: a straight-line run, distance by odometry and measured, to estimate E_s.",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write the return-error scatter plot (PNG or SVG).",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@history_options
def analyze(
    runs_file: str,
    wheelbase_mm: float,
    side_mm: float,
    method: str,
    c_left: float,
    c_right: float,
    loss: str | None,
    straight_mm: tuple[float, float] | None,
    plot_path: str | None,
    as_json: bool,
    robot: str | None = None,
    record: bool = False,
    db: str | None = None,
) -> None:
    """Benchmark a runs file (UMBmark) and compute the calibration.

    FILE.csv has columns direction (cw/ccw), x_abs, y_abs, x_odo, y_odo in millimetres
    (optional run, theta_abs, theta_odo in degrees). If the robot already ran with correction
    factors, give them (--c-left/--c-right, and its wheelbase as --wheelbase-mm): the result
    is composed with them (second pass).

    With --robot NAME --record the result is stored in the robot's calibration history
    (see umbmark history).

    \b
    Examples:
      umbmark analyze runs.csv --wheelbase-mm 340 --side-mm 4000 --json
      umbmark analyze runs.csv --wheelbase-mm 340 --side-mm 4000 --robot r1 --record
    """
    from umbmark.correct.analysis import analyze as analyze_runs
    from umbmark.correct.plausibility import check_geometry, runs_warnings
    from umbmark.io.runs_csv import read_runs_csv

    side_m = positive("--side-mm", side_mm) * 1e-3
    wheelbase_m = positive("--wheelbase-mm", wheelbase_mm) * 1e-3
    plausibility = check_geometry(side_m, wheelbase_m)
    options: dict[str, Any] = {}
    if loss is not None:
        options["loss"] = loss
    if straight_mm:
        options["straight_m"] = (straight_mm[0] * 1e-3, straight_mm[1] * 1e-3)
    if options and method != "exact":
        from umbmark.errors import InputError

        raise InputError("--loss and --straight-mm need --method exact")
    runs = read_runs_csv(runs_file)
    refuse_if_recorded(robot, record, db, kind="analyze", method=method, paths=[runs_file])
    prior = _prior(c_left, c_right)
    plausibility += runs_warnings(runs, side_m)
    a = analyze_runs(runs, side_m, wheelbase_m, method, prior, check=False, **options)
    if plot_path:
        from umbmark.viz.plots import save_figure, scatter_figure

        save_figure(scatter_figure(runs, title=f"UMBmark: {Path(runs_file).name}"), plot_path)
    rec = record_if_requested(robot, record, db, analysis=a, kind="analyze", source=runs_file, prior=prior)
    if as_json:
        out = {"file": str(runs_file), **_analysis_dict(a, plausibility)}
        if rec:
            out["history"] = rec
        for w in out["warnings"]:
            click.echo(f"warning: {cli_message(w)}", err=True)
        emit_json(out)
    elif not is_quiet():
        _print_analysis(
            a, *_next_commands(a, runs_file, side_mm, method, c_left, c_right, loss, straight_mm), plausibility
        )
        if plot_path:
            console().print(f"scatter plot: {plot_path}", markup=False, soft_wrap=True)
        print_recorded(rec)


@app.command()
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    default=".",
    show_default=True,
    help="Folder for the scatter plot and the runs files.",
)
@click.option("--seed", type=click.IntRange(min=0), default=1, show_default=True)
@click.option("--runs", "n_runs", type=click.IntRange(min=2), default=5, show_default=True, help="Runs per direction.")
@click.option("--noise", type=click.Choice(NOISE_CHOICES), default="paper", show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def demo(out_dir: str, seed: int, n_runs: int, noise: str, as_json: bool) -> None:
    """The paper's experiment in simulation, end to end.

    A simulated LabMate (wheelbase 340 mm) with the errors of the paper's Fig. 11
    (E_d = 1.00084, b = 336.17 mm) runs the 4 x 4 m UMBmark test, 5 runs each way with the
    paper's non-systematic noise; the paper's correction is computed and loaded into the
    robot's odometry, and the test is run again. Writes umbmark-demo-scatter.png (like the
    paper's Fig. 11) and the two runs files into --out.

    \b
    Example:
      umbmark demo --out results/
    """
    from umbmark.studies.demo import demo as run_demo

    if not Path(out_dir).is_dir():
        from umbmark.errors import InputError

        raise InputError(f"output folder {Path(out_dir)} does not exist")
    with progress("simulating the test before and after calibration"):
        result = run_demo(n_runs=n_runs, noise=noise, seed=seed)
    result = result.save(out_dir)
    if as_json:
        emit_json(result.to_dict())
    elif not is_quiet():
        _print_demo(result)


def _print_demo(r: DemoResult) -> None:
    """The human output of ``umbmark demo``: the figures, what each means, and what to do next."""
    from rich.markup import escape

    d = r.to_dict()
    before, after = d["before"], d["after"]
    cal = r.before.correction.calibration
    side = f"{d['side_mm'] / 1e3:g}"
    c = console()
    c.print(
        f"[bold]umbmark demo[/bold]: a simulated LabMate with the errors of the paper's Fig. 11 (true E_d = "
        f"{d['true_Ed']:.5f}, true E_b = {d['true_Eb']:.5f}: wheelbase {d['true_wheelbase_mm']:.2f} mm, nominal "
        f"{d['nominal_wheelbase_mm']:.2f} mm) drives the {side} x {side} m square {d['runs_per_direction']} times "
        f"each way, noise '{escape(str(d['noise']))}', seed {d['seed']}. Its odometry is calibrated from these "
        "runs (the paper's correction) and the test is run again."
    )
    c.print(_stats_table("Before calibration", r.before.result))
    c.print(_stats_table("After calibration (correction loaded into the odometry, fresh runs)", r.after))
    c.print(_legend(LEGEND_RUNS))
    yes_no = lambda v: "yes" if v else "no"  # noqa: E731
    assert cal.wheelbase_m is not None  # every correction method sets it
    rows = [
        ["E_max,syst [mm]", fmt(before["emax_syst_mm"]), fmt(after["emax_syst_mm"])],
        ["3 x SEM [mm]", fmt(before["three_sem_mm"]), fmt(after["three_sem_mm"])],
        [
            "second pass recommended",
            yes_no(before["second_pass_recommended"]),
            yes_no(after["second_pass_recommended"]),
        ],
        ["E_d used by the odometry", "1.000000", fmt(cal.ed, 6)],
        ["E_b used by the odometry", "1.000000", fmt(before["Eb"], 6)],
        ["wheelbase used by the odometry [mm]", fmt(d["nominal_wheelbase_mm"], 2), fmt(cal.wheelbase_m * 1e3, 2)],
        ["c_left / c_right", "1 / 1", f"{fmt(cal.c_left, 6)} / {fmt(cal.c_right, 6)}"],
    ]
    c.print(table("Before / after", ["", "before", "after"], rows))
    c.print(_legend(LEGEND_EMAX))
    c.print(_legend(LEGEND_DEMO))
    imp = d["improvement"]
    imp_text = "inf" if imp == float("inf") else f"{imp:.1f}"
    c.print(f"improvement: [bold]{imp_text}-fold[/bold]  (paper, Fig. 11: 317 mm -> 21 mm, 15-fold)")
    files = d["files"]
    c.print(f"scatter plot: {escape(files['scatter_png'])}", soft_wrap=True)
    c.print(f"runs files: {escape(files['before_csv'])}, {escape(files['after_csv'])}", soft_wrap=True)
    c.print("[bold]Next[/bold]: calibrate a real robot the same way:")
    for line in (
        "umbmark guide                         how to drive and measure the test",
        "umbmark analyze RUNS.csv --wheelbase-mm 340 --side-mm 4000 --json > cal.json",
        "umbmark export cal.json --format ros2 --out params.yaml",
    ):
        c.print(f"  {line}", soft_wrap=True, markup=False)
    c.print(
        "The analysis prints c_left, c_right and the wheelbase to load into the odometry; the export writes "
        "them as ROS 2 diff_drive_controller parameters (or --format ros1, json, firmware)."
    )
