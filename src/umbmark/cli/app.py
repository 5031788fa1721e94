"""The click group every subcommand module registers on, and the shared CLI helpers."""

from __future__ import annotations

import math
import sys

import click
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from .. import __version__
from ..jsonutil import dumps

CONTEXT = dict(help_option_names=["-h", "--help"], max_content_width=100)


@click.group(context_settings=CONTEXT)
@click.version_option(__version__, prog_name="umbmark")
@click.option("-q", "--quiet", is_flag=True, help="Print only errors (and --json output).")
@click.pass_context
def app(ctx, quiet):
    """Measure and correct the systematic odometry errors of differential-drive robots
    (UMBmark, Borenstein & Feng).

    \b
    Start with:
      umbmark demo                      simulate, benchmark, calibrate, re-benchmark
      umbmark simulate --ed 1.002 --eb 0.99 --out runs.csv
      umbmark analyze runs.csv --wheelbase-mm 340 --side-mm 4000

    Runs files are CSV in millimetres and degrees, in the start frame (x along the first
    leg, y to the left). Bad input: one line on stderr, exit status 2.
    """
    ctx.ensure_object(dict)
    ctx.obj["quiet"] = quiet


def console() -> Console:
    """Rich console on stdout; colour only on a terminal, 120 columns when not a terminal."""
    c = Console(highlight=False, soft_wrap=False)
    if not c.is_terminal:
        c = Console(highlight=False, soft_wrap=False, width=120, no_color=True)
    return c


def is_quiet() -> bool:
    ctx = click.get_current_context(silent=True)
    while ctx is not None:
        if ctx.obj and ctx.obj.get("quiet"):
            return True
        ctx = ctx.parent
    return False


def emit_json(obj) -> None:
    """Print one JSON object (NaN and infinities become null: strict JSON)."""
    sys.stdout.write(dumps(obj, indent=2) + "\n")


def fmt(v, digits: int = 1, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.{digits}f}{unit}"


def table(title: str, columns: list[str], rows: list[list], justify_first: str = "left") -> Table:
    t = Table(title=escape(title), title_justify="left", header_style="bold")
    for i, c in enumerate(columns):
        t.add_column(escape(c), justify=justify_first if i == 0 else "right")
    for r in rows:
        t.add_row(*[escape(str(x)) for x in r])
    return t


def prior_options(f):
    """``--c-left`` / ``--c-right``: the correction factors the robot's odometry ran with."""
    f = click.option("--c-right", type=float, default=1.0, show_default=True,
                     help="Right-wheel correction factor the robot's odometry ran with.")(f)
    f = click.option("--c-left", type=float, default=1.0, show_default=True,
                     help="Left-wheel correction factor the robot's odometry ran with.")(f)
    return f
