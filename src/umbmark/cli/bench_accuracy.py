"""``umbmark bench accuracy``. Registers on the ``bench`` group."""

from __future__ import annotations

from typing import Any

import click

from umbmark.cli.app import console, emit_json, fmt, is_quiet, table
from umbmark.cli.bench import BENCH_ACCURACY_OUT, bench
from umbmark.cli.progress import progress
from umbmark.cli.scaleout import scale_options

__all__ = ["accuracy"]


@bench.command("accuracy")
@click.option("--quick", is_flag=True, help="Small grid, 4 robots per cell, 50 ms sampling (seconds).")
@click.option(
    "--robots", type=click.IntRange(min=1), default=None, help="Robots per cell with noise (default 100; quick: 4)."
)
@click.option("--seed", type=click.IntRange(min=0), default=None, help="Seed (default 2026).")
@click.option(
    "--sample-period-ms",
    type=float,
    default=None,
    help="Sampling period of the noisy simulations (default 10 ms, the paper's; quick: 50 ms).",
)
@click.option(
    "--fixed-wheelbase",
    type=click.Choice(["true", "nominal"]),
    default="true",
    show_default=True,
    help="Hold the true wheelbase fixed (one physical robot, nominal = 340 mm / E_b) or the nominal one "
    "(true = E_b x 340 mm, e.g. a skid-steer robot's effective wheelbase).",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    default=BENCH_ACCURACY_OUT,
    show_default=True,
    help="Folder for accuracy.json/.csv/.md/.png (created if missing).",
)
@scale_options
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON object.")
def accuracy(
    quick: bool,
    robots: int | None,
    seed: int | None,
    sample_period_ms: float | None,
    fixed_wheelbase: str,
    out_dir: str,
    workers: int | None,
    dask: str | None,
    as_json: bool,
) -> None:
    """Accuracy of the corrections: bf one pass, bf two passes, exact one and two passes.

    Monte Carlo over a grid of true errors (|E_d - 1| from 0.05 % to 5 %, E_b from 0.5 to
    2.5, both signs) and noise levels (none, paper), seeded robots per cell: median
    E_max,syst after correction (fresh runs), parameter errors, interval coverage, and the two
    floors (estimation: bf on the smallest errors; perfect: true parameters). The full run
    takes several minutes on 2 cores; --quick takes seconds. The cells run on all local cores
    (--workers N; 1: no pool) or on a Dask cluster (--dask tcp://host:8786), with the same
    results on every backend.

    \b
    Example:
      umbmark bench accuracy --quick --out acc/
    """
    from dataclasses import replace

    from umbmark.studies.accuracy import QUICK, AccuracyConfig, run_accuracy, write_results

    cfg = QUICK if quick else AccuracyConfig()
    changes: dict[str, Any] = {k: v for k, v in (("robots", robots), ("seed", seed)) if v is not None}
    changes["workers"] = workers  # None: all local cores
    changes["fixed_wheelbase"] = fixed_wheelbase
    if sample_period_ms is not None:
        if not sample_period_ms > 0:
            from umbmark.errors import InputError

            raise InputError(f"--sample-period-ms must be positive, got {sample_period_ms!r}")
        changes["sample_period_s"] = sample_period_ms * 1e-3
    cfg = replace(cfg, **changes)
    n_cells = len(cfg.cells()) * len(cfg.noises)
    with progress(f"accuracy benchmark: {n_cells} cells", total=n_cells) as advance:
        res = run_accuracy(cfg, progress=lambda done, total: advance(), dask=dask)
    paths = write_results(res, out_dir)
    if as_json:
        emit_json(
            {
                "summary": res["summary"],
                "floors": res["floors"],
                "files": paths,
                "backend": res["backend"],
                "elapsed_s": res["elapsed_s"],
            }
        )
        return
    if is_quiet():
        return
    _print_accuracy(res, paths)


def _print_accuracy(res: dict, paths: dict) -> None:
    """The summary table of the accuracy benchmark and the files written."""
    rows = []
    for noise, s in res["summary"].items():
        fl = res["floors"][noise]
        cov = (
            "-"
            if s["exact_ed_coverage"] is None
            else f"{100 * s['exact_ed_coverage']:.1f} / {100 * s['exact_eb_coverage']:.1f}"
        )
        rows.append(
            [
                noise,
                s["cells"],
                s["robots"],
                fmt(fl["estimation_floor_mm"], 2),
                fmt(fl["perfect_floor_mm"], 2),
                f"{s['bf1_cells_within_1.15_estimation_floor']}/{s['cells']}",
                f"{s['exact_cells_within_1.15_estimation_floor']}/{s['cells']}",
                f"{s['exact2_cells_within_1.15_estimation_floor']}/{s['cells']}",
                fmt(s["exact_worst_over_estimation_floor"], 2),
                cov,
            ]
        )
    c = console()
    c.print(
        table(
            "Accuracy benchmark (cells within 1.15 x the estimation floor, medians over robots)",
            [
                "noise",
                "cells",
                "robots",
                "est. floor [mm]",
                "perfect floor [mm]",
                "bf1",
                "exact",
                "exact2",
                "exact worst ratio",
                "exact CI cover E_d/E_b [%]",
            ],
            rows,
        )
    )
    c.print(
        f"{res['elapsed_s']:.0f} s ({res['backend']}); written: {', '.join(paths.values())}",
        markup=False,
        soft_wrap=True,
    )
