"""``umbmark simulate``, ``umbmark analyze`` and ``umbmark demo``."""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.markup import escape

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
from umbmark.cli.history import history_options, print_recorded, record_if_requested
from umbmark.cli.progress import progress
from umbmark.correct import METHODS
from umbmark.correct.analysis import Analysis
from umbmark.correct.analysis import analyze as analyze_runs
from umbmark.io.runs_csv import read_runs_csv, write_runs_csv
from umbmark.metrics import UMBmarkResult, umbmark
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry
from umbmark.model.simulate import NOISE_PRESETS, Motion, simulate_umbmark
from umbmark.studies.demo import demo as run_demo


def geometry_options(f):
    f = click.option(
        "--wheel-diameter-mm",
        type=float,
        default=LABMATE.wheel_diameter_m * 1e3,
        show_default=True,
        help="Nominal wheel diameter.",
    )(f)
    f = click.option("--side-mm", type=float, default=4000.0, show_default=True, help="Side of the square path.")(f)
    f = click.option(
        "--wheelbase-mm", type=float, default=LABMATE.wheelbase_m * 1e3, show_default=True, help="Nominal wheelbase."
    )(f)
    return f


def _prior(c_left, c_right, wheelbase_mm=None) -> Calibration | None:
    for name, v in (("--c-left", c_left), ("--c-right", c_right)):
        positive(name, v)
    if c_left == 1.0 and c_right == 1.0 and wheelbase_mm is None:
        return None
    return Calibration(c_left, c_right, None if wheelbase_mm is None else wheelbase_mm * 1e-3)


def _stats_table(title: str, res: UMBmarkResult):
    rows = []
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
    return table(title, ["direction", "n", "x_cg [mm]", "y_cg [mm]", "r_cg [mm]", "std [mm]", "SEM [mm]"], rows)


def _print_analysis(a: Analysis):
    c = console()
    d = a.to_dict()
    c.print(_stats_table("UMBmark return position errors (absolute - odometry)", a.result))
    rule = "-" if d["three_sem_mm"] is None else f"{d['three_sem_mm']:.1f} mm"
    c.print(
        f"E_max,syst = [bold]{d['emax_syst_mm']:.1f} mm[/bold]   3 x SEM = {rule}   "
        f"second pass recommended: {'yes' if d['second_pass_recommended'] else 'no'}"
    )
    corr = a.correction
    rows = []
    if corr.alpha is not None:
        ex = d
        rows += [
            ["alpha [deg]", fmt(ex.get("alpha_x_deg"), 4), fmt(ex.get("alpha_y_deg"), 4), fmt(d["alpha_deg"], 4)],
            ["beta [deg]", fmt(ex.get("beta_x_deg"), 4), fmt(ex.get("beta_y_deg"), 4), fmt(d["beta_deg"], 4)],
            ["E_d", fmt(ex.get("Ed_x"), 6), fmt(ex.get("Ed_y"), 6), fmt(d["Ed_pass"], 6)],
            ["E_b", fmt(ex.get("Eb_x"), 6), fmt(ex.get("Eb_y"), 6), fmt(d["Eb"], 6)],
        ]
        c.print(
            table(f"Correction ({corr.method}): from x, from y, used (average)", ["", "from x", "from y", "used"], rows)
        )
    out = [
        ["curvature radius R", "-" if d["radius_mm"] is None else f"{d['radius_mm'] / 1e3:.1f} m"],
        ["E_d = D_R/D_L", fmt(d["Ed"], 6)],
        ["E_b", fmt(d["Eb"], 6)],
        ["c_left", fmt(d["c_left"], 6)],
        ["c_right", fmt(d["c_right"], 6)],
        ["wheelbase", f"{a.wheelbase_m * 1e3:.2f} -> {d['wheelbase_corrected_mm']:.2f} mm"],
    ]
    for k in ("Ed_ci95", "Eb_ci95", "wheelbase_corrected_mm_ci95"):
        if d.get(k):
            out.append([f"{k} (95 %)", f"[{d[k][0]:.6g}, {d[k][1]:.6g}]"])
    if d.get("emax_syst_after_pred_measured_mm") is not None:
        out.append(
            [
                "predicted E_max,syst after (systematic / measured)",
                f"{d['emax_syst_after_pred_mm']:.1f} / {d['emax_syst_after_pred_measured_mm']:.1f} mm",
            ]
        )
    c.print(table("Calibration to load into the odometry", ["", "value"], out))
    for w in d.get("warnings", []):
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")


@app.command()
@click.option("--ed", type=float, default=1.0, show_default=True, help="True E_d = D_R / D_L.")
@click.option("--eb", type=float, default=1.0, show_default=True, help="True E_b = b_actual / b_nominal.")
@click.option("--es", type=float, default=1.0, show_default=True, help="True E_s = D_avg / D_nominal.")
@click.option("--runs", "n_runs", type=click.IntRange(min=1), default=5, show_default=True, help="Runs per direction.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--noise",
    type=click.Choice(sorted(NOISE_PRESETS)),
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
    ed,
    eb,
    es,
    n_runs,
    seed,
    noise,
    out,
    wheelbase_mm,
    side_mm,
    wheel_diameter_mm,
    c_left,
    c_right,
    model_wheelbase_mm,
    sample_period_ms,
    speed_m_s,
    as_json,
):
    """Simulate the bi-directional UMBmark test and write a runs file.

    A robot with true errors E_d, E_b (and E_s) drives the cw and ccw squares closed-loop on
    its own odometry (nominal, or the calibration given by --c-left/--c-right/
    --model-wheelbase-mm); the file records where it really stopped and what its odometry said.

    \b
    Example:
      umbmark simulate --ed 1.002 --eb 0.99 --runs 5 --seed 1 --noise paper --out runs.csv
    """
    geom = Geometry(
        positive("--wheel-diameter-mm", wheel_diameter_mm) * 1e-3,
        positive("--wheelbase-mm", wheelbase_mm) * 1e-3,
        LABMATE.pulses_per_rev,
        LABMATE.gear_ratio,
    )
    side_m = positive("--side-mm", side_mm) * 1e-3
    if model_wheelbase_mm is not None:
        positive("--model-wheelbase-mm", model_wheelbase_mm)
    errors = ErrorParams(error_param("--ed", ed), error_param("--eb", eb), error_param("--es", es))
    motion = Motion(
        speed_m_s=positive("--speed", speed_m_s),
        sample_period_s=positive("--sample-period-ms", sample_period_ms) * 1e-3,
    )
    with progress(f"simulating {n_runs} runs each way"):
        runs = simulate_umbmark(
            errors, geom, side_m, n_runs, _prior(c_left, c_right, model_wheelbase_mm), noise, motion, seed=seed
        )
    write_runs_csv(runs, out)
    res = umbmark(runs)
    if as_json:
        emit_json({"out": str(out), "runs_per_direction": n_runs, "noise": noise, "seed": seed, **res.to_dict()})
    elif not is_quiet():
        c = console()
        c.print(_stats_table(f"Simulated runs written to {out}", res))
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
    type=click.Choice(sorted(METHODS)),
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
    runs_file,
    wheelbase_mm,
    side_mm,
    method,
    c_left,
    c_right,
    loss,
    straight_mm,
    plot_path,
    as_json,
    robot=None,
    record=False,
    db=None,
):
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
    side_m = positive("--side-mm", side_mm) * 1e-3
    wheelbase_m = positive("--wheelbase-mm", wheelbase_mm) * 1e-3
    options = {}
    if loss is not None:
        options["loss"] = loss
    if straight_mm:
        options["straight_m"] = (straight_mm[0] * 1e-3, straight_mm[1] * 1e-3)
    if options and method != "exact":
        from umbmark.errors import InputError

        raise InputError("--loss and --straight-mm need --method exact")
    runs = read_runs_csv(runs_file)
    prior = _prior(c_left, c_right)
    a = analyze_runs(runs, side_m, wheelbase_m, method, prior, **options)
    if plot_path:
        from umbmark.viz.plots import save_figure, scatter_figure

        save_figure(scatter_figure(runs, title=f"UMBmark: {Path(runs_file).name}"), plot_path)
    rec = record_if_requested(robot, record, db, analysis=a, kind="analyze", source=runs_file, prior=prior)
    if as_json:
        out = {"file": str(runs_file), **a.to_dict()}
        if rec:
            out["history"] = rec
        emit_json(out)
    elif not is_quiet():
        _print_analysis(a)
        if plot_path:
            console().print(f"scatter plot: {plot_path}")
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
@click.option("--noise", type=click.Choice(sorted(NOISE_PRESETS)), default="paper", show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def demo(out_dir, seed, n_runs, noise, as_json):
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
    out = Path(out_dir)
    if not out.is_dir():
        from umbmark.errors import InputError

        raise InputError(f"output folder {out} does not exist")
    with progress("simulating the test before and after calibration"):
        d = run_demo(n_runs=n_runs, noise=noise, seed=seed)
    from umbmark.viz.plots import save_figure, scatter_figure

    png = out / "umbmark-demo-scatter.png"
    before_csv, after_csv = out / "umbmark-demo-before.csv", out / "umbmark-demo-after.csv"
    write_runs_csv(d.before.runs, before_csv)
    write_runs_csv(d.after_runs, after_csv)
    save_figure(
        scatter_figure(
            d.before.runs, d.after_runs, title="UMBmark, simulated LabMate (paper's Fig. 11 errors): before and after"
        ),
        png,
    )
    cal = d.before.correction.calibration
    summary = {
        "true_Ed": d.errors.ed,
        "true_Eb": d.errors.eb,
        "true_wheelbase_mm": d.errors.eb * d.geometry.wheelbase_m * 1e3,
        "nominal_wheelbase_mm": d.geometry.wheelbase_m * 1e3,
        "side_mm": d.side_m * 1e3,
        "runs_per_direction": n_runs,
        "noise": noise,
        "seed": seed,
        "before": d.before.to_dict(),
        "after": d.after.to_dict(),
        "improvement": d.improvement,
        "files": {"scatter_png": str(png), "before_csv": str(before_csv), "after_csv": str(after_csv)},
    }
    if as_json:
        emit_json(summary)
        return
    if is_quiet():
        return
    c = console()
    c.print(
        f"[bold]umbmark demo[/bold]: simulated LabMate, true E_d = {d.errors.ed:.5f}, true wheelbase = "
        f"{summary['true_wheelbase_mm']:.2f} mm (nominal {summary['nominal_wheelbase_mm']:.2f} mm), "
        f"4 x 4 m square, {n_runs} runs each way, noise '{noise}', seed {seed}"
    )
    c.print(_stats_table("Before calibration", d.before.result))
    c.print(_stats_table("After calibration (correction loaded into the odometry, fresh runs)", d.after))
    rows = [
        ["E_max,syst [mm]", fmt(d.before.result.emax_syst * 1e3), fmt(d.after.emax_syst * 1e3)],
        ["E_d used by odometry", "1.000000", fmt(cal.ed, 6)],
        ["wheelbase used by odometry [mm]", fmt(d.geometry.wheelbase_m * 1e3, 2), fmt(cal.wheelbase_m * 1e3, 2)],
        ["c_left / c_right", "1 / 1", f"{cal.c_left:.6f} / {cal.c_right:.6f}"],
        [
            "second pass recommended (3 x SEM rule)",
            "yes" if d.before.result.second_pass_recommended else "no",
            "yes" if d.after.second_pass_recommended else "no",
        ],
    ]
    c.print(table("Before / after", ["", "before", "after"], rows))
    imp = "inf" if math.isinf(d.improvement) else f"{d.improvement:.1f}"
    c.print(f"improvement: [bold]{imp}-fold[/bold]  (paper, Fig. 11: 317 mm -> 21 mm, 15-fold)")
    c.print(f"scatter plot: {png}\nruns files: {before_csv}, {after_csv}")
