"""``umbmark convert``: logs to the generic CSV log, or square runs to a runs file for ``analyze``.

The library does the work (:mod:`umbmark.io`, :mod:`umbmark.realrobot.replay`); no numerical
module is imported before the command runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from umbmark.cli.app import app, cli_message, console, is_quiet
from umbmark.cli.logs import datasets, log_options
from umbmark.errors import InputError

__all__ = ["convert"]


@app.command()
@click.argument("paths", nargs=-1, required=True, metavar="LOG...")
@log_options
@click.option(
    "--to",
    "target",
    type=click.Choice(["csv", "runs"]),
    default="csv",
    show_default=True,
    help="csv: the generic log CSV; runs: a UMBmark runs file (square runs, nominal odometry).",
)
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="File to write.")
def convert(paths: tuple[str, ...], log_format: str, target: str, out: str, **kw: Any) -> None:
    """Convert logs: to the generic CSV log, or (square runs) to a runs file for `analyze`.

    Several bags (or CSV logs) are the runs of one data set. The generic CSV log records the
    nominal geometry in a comment line; `umbmark replay` of it uses that geometry for what its
    options do not give.

    \b
    Examples:
      umbmark convert data/optiodom/square/230620202144 --to runs --out runs.csv
      umbmark convert run1_bag run2_bag --odom-topic /odom --gt-topic /mocap/pose \\
        --wheel-diameter-mm 100 --wheelbase-mm 300 --out log.csv
    """
    from umbmark._files import check_distinct_inputs
    from umbmark.io.atomic import atomic_write
    from umbmark.io.generic_csv import format_generic_csv
    from umbmark.io.runs_csv import write_runs_csv
    from umbmark.realrobot.replay import prepare, square_runs

    check_distinct_inputs([p for p in paths if Path(p).exists()])
    sets = datasets(paths, log_format, kw)
    if len(sets) != 1:
        raise InputError("convert takes one data set (one optiodom folder, or bags, or CSV logs)")
    ds = sets[0]
    warnings = list(ds.meta.get("warnings") or ())
    if target == "csv":
        atomic_write(out, format_generic_csv(ds))
    else:
        if not ds.is_square:
            raise InputError("a runs file needs square runs (give --side-mm)", source=ds.source)
        ds, warnings, _ = prepare(ds)
        assert ds.directions is not None  # prepare gives square runs their directions
        write_runs_csv(square_runs(ds, ds.nominal, ds.directions), out)
    if not is_quiet():
        c = console()
        c.print(f"wrote {out} ({len(ds.runs)} runs)", markup=False, soft_wrap=True)
        if target == "runs":
            assert ds.side_m is not None  # square runs have their side
            c.print(
                f"analyze it with: umbmark analyze {out} --wheelbase-mm {ds.nominal.wheelbase_m * 1e3:g} "
                f"--side-mm {ds.side_m * 1e3:g}",
                markup=False,
                soft_wrap=True,
            )
    for w in warnings:
        click.echo(f"warning: {cli_message(w)}", err=True)
