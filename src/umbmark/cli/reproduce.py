"""``umbmark reproduce``: the paper's section 5 in simulation. Registers on ``app``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import click

from umbmark.cli.app import (
    REPRODUCE_TAPE_LAYER_MM,
    REPRODUCE_VARIATION,
    app,
    console,
    emit_json,
    fmt,
    is_quiet,
    table,
)
from umbmark.cli.progress import progress
from umbmark.cli.scaleout import scale_options

if TYPE_CHECKING:
    from rich.console import Console

    from umbmark.studies.reproduce import Study, StudyConfig

__all__ = ["reproduce_cmd", "DEFAULT_SEEDS"]

DEFAULT_SEEDS = 200


@app.command("reproduce")
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=1,
    show_default=True,
    help="First study seed: the Table I printed is this seed's.",
)
@click.option(
    "--seeds",
    type=click.IntRange(min=1),
    default=DEFAULT_SEEDS,
    show_default=True,
    help="Number of study seeds (seed, seed+1, ...) for the distribution.",
)
@click.option(
    "--runs",
    "n_runs",
    type=click.IntRange(min=2),
    default=5,
    show_default=True,
    help="Runs per direction in every test.",
)
@click.option(
    "--sample-period-ms",
    type=click.FloatRange(min=0, min_open=True, max=1000),
    default=50.0,
    show_default=True,
    help="Controller sampling period of the simulation.",
)
@click.option(
    "--quantise/--no-quantise",
    default=False,
    show_default=True,
    help="Quantised encoders (the paper preset's): the robot stops at the first sample past its target "
    "instead of exactly on it.",
)
@click.option(
    "--tape-thickness-mm",
    type=click.FloatRange(min=0, max=1, max_open=True),
    default=REPRODUCE_TAPE_LAYER_MM,
    show_default=True,
    help="Effective thickness of one loop of masking tape (experiments 7 and 8).",
)
@click.option(
    "--variation",
    type=click.FloatRange(min=0, max=1),
    default=REPRODUCE_VARIATION,
    show_default=True,
    help="Relative (log-normal) day-to-day variation of the robot's errors in experiments 2-6.",
)
@click.option("--no-pitfall", is_flag=True, help="Skip the uni-directional pitfall study.")
@click.option(
    "--report",
    "report_dir",
    type=click.Path(file_okay=False),
    default=None,
    help="Write an HTML report (index.html) with the figures (PNG, SVG) into this folder.",
)
@click.option(
    "--exaggerate",
    type=click.FloatRange(min=0, min_open=True, max=1e6),
    default=1.0,
    show_default=True,
    help="Magnify the deviation of the true paths from the odometry paths in the trajectory figure.",
)
@scale_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def reproduce_cmd(
    seed: int,
    seeds: int,
    n_runs: int,
    sample_period_ms: float,
    quantise: bool,
    tape_thickness_mm: float,
    variation: float,
    no_pitfall: bool,
    report_dir: str | None,
    exaggerate: float,
    workers: int | None,
    dask: str | None,
    as_json: bool,
) -> None:
    """Reproduce the paper's section 5 in simulation: Table I (eight experiments, the 3 x SEM
    rule and the second compensation pass), its distribution over many seeds, and the
    uni-directional pitfall of section 3.1.

    \b
    The seeds are simulated on all local cores (--workers N to choose, --workers 1 for no
    pool) or on a Dask cluster (--dask tcp://host:8786); the numbers are the same on every
    backend. The default study (200 seeds) takes 10-20 seconds on 2 cores. Examples:
      umbmark reproduce --seeds 20
      umbmark reproduce --workers 1 --seeds 20
      umbmark reproduce --json > study.json
      umbmark reproduce --report reproduce-report
    """
    from umbmark.model.simulate import NOISE_PRESETS
    from umbmark.studies import reproduce as rep

    noise = NOISE_PRESETS["paper"] if quantise else rep.STUDY_NOISE
    cfg = rep.StudyConfig(
        seed=seed,
        seeds=seeds,
        n_runs=n_runs,
        sample_period_s=sample_period_ms * 1e-3,
        noise=noise,
        tape_layer_m=tape_thickness_mm * 1e-3,
        variation=variation,
    )
    with progress(f"simulating {seeds} seeds x 8 experiments", total=seeds) as advance:
        shown = 0

        def on_progress(done: int, _total: int) -> None:  # seeds done so far -> advance the bar by the new ones
            nonlocal shown
            advance(done - shown)
            shown = done

        study = rep.run_study(cfg, pitfall=not no_pitfall, workers=workers, dask=dask, on_progress=on_progress)
    d = study.to_dict()
    command = _command(cfg, seeds, quantise, no_pitfall)
    d["command"] = command
    if report_dir is not None:
        from umbmark.studies.reproduce_report import write_report

        page_cmd = f"{command} --report {report_dir}" + (f" --exaggerate {exaggerate:g}" if exaggerate != 1 else "")
        with progress("writing the report"):
            page = write_report(study, report_dir, page_cmd, exaggerate)
        d["report"] = str(page)
    if as_json:
        emit_json(d)
        return
    if is_quiet():
        return
    _print(study, d)


def _command(cfg: StudyConfig, seeds: int, quantise: bool, no_pitfall: bool) -> str:
    from umbmark.studies import reproduce as rep

    parts = ["umbmark reproduce", f"--seed {cfg.seed}", f"--seeds {seeds}"]
    if cfg.n_runs != 5:
        parts.append(f"--runs {cfg.n_runs}")
    if cfg.sample_period_s != 0.05:
        parts.append(f"--sample-period-ms {cfg.sample_period_s * 1e3:g}")
    if quantise:
        parts.append("--quantise")
    if cfg.tape_layer_m != rep.TAPE_LAYER_M:
        parts.append(f"--tape-thickness-mm {cfg.tape_layer_m * 1e3:g}")
    if cfg.variation != rep.ROBOT_VARIATION:
        parts.append(f"--variation {cfg.variation:g}")
    if no_pitfall:
        parts.append("--no-pitfall")
    return " ".join(parts)


def _print(study: Study, d: dict) -> None:
    """The human output of ``umbmark reproduce``: Table I, the distribution, the second passes, the pitfall."""
    c = console()
    _print_table_i(c, d)
    _print_distribution(c, d)
    _print_second_passes(c, d)
    _print_pitfall(c, d)
    cfg = d["config"]
    tm = d["tape_model"]
    c.print(
        f"noise: {cfg['noise']['name']}, sampling {cfg['sample_period_ms']:g} ms; tape loop "
        f"{tm['layer_thickness_mm']:g} mm on {tm['wheel_diameter_mm']:g} mm wheels (exp 7 E_d "
        f"{tm['exp7']['Ed']:.5f}, exp 8 E_d {tm['exp8']['Ed']:.5f})"
    )
    c.print(f"re-run: {d['command']}", markup=False, soft_wrap=True)
    if "report" in d:
        c.print(f"report: {d['report']}", markup=False, soft_wrap=True)


def _print_table_i(c: Console, d: dict) -> None:
    """Table I of the first seed, the paper's numbers in brackets."""
    from umbmark.studies import reproduce as rep

    cfg = d["config"]
    rows = []
    for e, p in zip(d["experiments"], rep.PAPER_TABLE_I):
        sp = e["second_pass"]
        paper_imp = p["improvement"].replace("-fold", "")
        rows.append(
            [
                e["id"],
                f"{e['true_Ed']:.5f}",
                f"{e['true_wheelbase_mm']:.2f}",
                f"{e['emax_before_mm']:.0f} ({p['before_mm']:.0f})",
                f"{e['emax_after_mm']:.1f} ({p['after_mm']:.0f})",
                fmt(e["three_sem_after_mm"]),
                "2nd pass" if e["second_pass_recommended"] else "stop",
                ("-" if sp is None else f"{sp['emax_after_mm']:.1f}")
                + ("" if p["second_mm"] is None else f" ({p['second_mm']:.0f})"),
                f"{e['improvement_final']:.1f} ({paper_imp})",
            ]
        )
    c.print(
        table(
            f"Table I in simulation, seed {cfg['seed']} (the paper's numbers in brackets)",
            [
                "exp",
                "true E_d",
                "true b [mm]",
                "E_max before [mm]",
                "after 1st pass [mm]",
                "3 x SEM [mm]",
                "rule",
                "after 2nd pass [mm]",
                "improvement (final)",
            ],
            rows,
        )
    )


def _print_distribution(c: Console, d: dict) -> None:
    """Medians and percentiles over all seeds, the second-pass share and the spread."""
    from umbmark.studies import reproduce as rep

    dd = d["distribution"]
    drows = [
        ["E_max,syst before [mm]", dd["emax_before_median_mm"], dd["emax_before_p10_mm"], dd["emax_before_p90_mm"]],
        [
            "E_max,syst after 1st pass [mm]",
            dd["emax_after_median_mm"],
            dd["emax_after_p10_mm"],
            dd["emax_after_p90_mm"],
        ],
        ["E_max,syst final [mm]", dd["emax_final_median_mm"], dd["emax_final_p10_mm"], dd["emax_final_p90_mm"]],
        ["improvement, final", dd["improvement_median"], dd["improvement_p10"], dd["improvement_p90"]],
    ]
    c.print(
        table(
            f"Distribution over {dd['seeds']} seeds ({dd['seed_first']}..{dd['seed_last']}), "
            f"{dd['seeds'] * 8} experiments",
            ["", "median", "p10", "p90"],
            [[r[0]] + [fmt(v) for v in r[1:]] for r in drows],
        )
    )
    c.print(
        f"second pass called for: {dd['second_pass_fraction'] * 100:.1f}% of experiments; final improvement "
        f">= 10-fold: {dd['fraction_improvement_at_least_10'] * 100:.1f}%; median radial std after calibration "
        f"{dd['std_after_median_mm']:.1f} mm (paper: about {rep.PAPER_SIGMA_MM:g} mm)"
    )


def _print_second_passes(c: Console, d: dict) -> None:
    """The first experiments where the 3 x SEM rule called for a second pass."""
    ex = d["second_pass_examples"]
    if ex:
        c.print(
            table(
                f"The first {len(ex)} experiments (in seed order) where the 3 x SEM rule called for a second pass",
                [
                    "seed",
                    "exp",
                    "E_max before [mm]",
                    "after 1st pass [mm]",
                    "3 x SEM [mm]",
                    "after 2nd pass [mm]",
                    "improvement (final)",
                ],
                [
                    [
                        e["seed"],
                        e["id"],
                        fmt(e["emax_before_mm"], 0),
                        fmt(e["emax_after_mm"]),
                        fmt(e["three_sem_after_mm"]),
                        fmt(e["second_pass"]["emax_after_mm"]),
                        fmt(e["improvement_final"]),
                    ]
                    for e in ex
                ],
            )
        )


def _print_pitfall(c: Console, d: dict) -> None:
    """The uni-directional pitfall, when the study has it."""
    if "pitfall" in d:
        p = d["pitfall"]
        c.print(
            table(
                f"Uni-directional pitfall (Fig. 11 robot, true b {p['robot_wheelbase_mm']:.2f} mm): "
                f"wheelbase tuned on cw "
                f"runs only -> {p['tuned_wheelbase_mm']:.2f} mm",
                ["odometry", "cw r_cg [mm]", "ccw r_cg [mm]", "E_max,syst [mm]"],
                [
                    [name, fmt(v["cw_r_cg_mm"]), fmt(v["ccw_r_cg_mm"]), fmt(v["emax_syst_mm"])]
                    for name, v in (
                        ("uncalibrated", p["uncalibrated"]),
                        ("b tuned on cw only", p["uni_directionally_tuned"]),
                        ("UMBmark + paper's correction", p["bi_directional_bf"]),
                    )
                ],
            )
        )
