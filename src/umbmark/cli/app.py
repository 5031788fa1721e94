"""The click group every subcommand module registers on, and the shared CLI helpers."""

from __future__ import annotations

import math
import os
import re
import sys
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import click

from umbmark import _check
from umbmark._version import __version__
from umbmark.cli.guard import GuardedGroup
from umbmark.errors import InputError
from umbmark.jsonutil import dumps
from umbmark.kinds import KINDS
from umbmark.model.defaults import LOG_FORMATS
from umbmark.viz.text import fmt

F = TypeVar("F", bound=Callable[..., Any])

if TYPE_CHECKING:
    from rich.console import Console
    from rich.table import Table

__all__ = [
    "CONTEXT",
    "ERROR_RANGES",
    "LABMATE_WHEEL_DIAMETER_MM",
    "LABMATE_WHEELBASE_MM",
    "LOG_FORMAT_CHOICES",
    "METHOD_CHOICES",
    "NOISE_CHOICES",
    "PARAM_FLAGS",
    "REPRODUCE_TAPE_LAYER_MM",
    "REPRODUCE_VARIATION",
    "app",
    "cli_message",
    "console",
    "emit_json",
    "error_param",
    "fmt",
    "is_quiet",
    "positive",
    "prior_options",
    "table",
]

# Names and defaults the option declarations show, written out here so that building the command
# line imports no numerical module (tests/test_cli_help.py checks each against the library).
METHOD_CHOICES = ("bf", "exact")  # sorted(umbmark.correct.METHODS)
NOISE_CHOICES = ("none", "paper")  # sorted(umbmark.model.simulate.NOISE_PRESETS)
LOG_FORMAT_CHOICES = LOG_FORMATS  # the library's (light: umbmark.model.defaults)
LABMATE_WHEEL_DIAMETER_MM = 150.0  # umbmark.model.geometry.LABMATE.wheel_diameter_m, in mm
LABMATE_WHEELBASE_MM = 340.0  # umbmark.model.geometry.LABMATE.wheelbase_m, in mm
REPRODUCE_TAPE_LAYER_MM = 0.02  # umbmark.studies.reproduce.TAPE_LAYER_M, in mm
REPRODUCE_VARIATION = 0.15  # umbmark.studies.reproduce.ROBOT_VARIATION

CONTEXT = dict(help_option_names=["-h", "--help"], max_content_width=100)


@click.group(context_settings=CONTEXT, cls=GuardedGroup)
@click.version_option(__version__, prog_name="umbmark")
@click.option("-q", "--quiet", is_flag=True, help="Print only errors (and --json output).")
@click.pass_context
def app(ctx: click.Context, quiet: bool) -> None:
    """Measure and correct the systematic odometry errors of wheeled robots of every kind:
    differential drives (UMBmark, Borenstein & Feng), tricycles, mecanum robots and cars
    (selfcal --kinematics tricycle|mecanum|bicycle|ackermann).

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
    """The rich console on stdout the commands print to.

    Colour only on a terminal. Off a terminal (a pipe, a file) the width is ``$COLUMNS`` when
    set, else 120 columns.

    Returns
    -------
    rich.console.Console
    """
    from rich.console import Console

    c = Console(highlight=False, soft_wrap=False, emoji=False)
    if not c.is_terminal:
        columns = os.environ.get("COLUMNS", "")
        width = int(columns) if columns.isdigit() and int(columns) > 0 else 120
        c = Console(highlight=False, soft_wrap=False, width=width, no_color=True, emoji=False)
    return c


def is_quiet() -> bool:
    """True when ``--quiet`` was given to the running command (or a group above it)."""
    ctx = click.get_current_context(silent=True)
    while ctx is not None:
        if ctx.obj and ctx.obj.get("quiet"):
            return True
        ctx = ctx.parent
    return False


# library parameters (named in messages as `name` or `name=value`) -> the flags that set them
PARAM_FLAGS = {
    "base_frame": "--base-frame",
    "cmd_vel_topic": "--cmd-vel-topic",
    "dask": "--dask",
    "dataset": "--dataset",
    "fit_offset": "--fit-marker-offset",
    "fmt": "--format",
    "gt_frame": "--gt-frame",
    "gt_scan_topic": "--gt-scan-topic",
    "gt_topic": "--gt-topic",
    "imu_topic": "--imu-topic",
    "joints": "--joints",
    "kinematics": "--kinematics",
    "left_diameter_mm": "--left-diameter-mm",
    "left_field": "--left-field",
    "left_multiplier": "--left-multiplier",
    "limit": "--limit",
    "max_wheel_gap_s": "--max-wheel-gap-s",
    "method": "--method",
    "odom_topic": "--odom-topic",
    "pause_s": "--pause-s",
    "pulses_per_wheel_rev": "--pulses-per-wheel-rev",
    "ranges": "--ranges",
    "record": "--record",
    "right_diameter_mm": "--right-diameter-mm",
    "right_field": "--right-field",
    "right_multiplier": "--right-multiplier",
    "robot": "--robot NAME",
    "runs": "--runs",
    "scale": "--scale",
    "scan_delay": "--scan-delay",
    "scan_frame": "--scan-frame",
    "separation_multiplier": "--separation-multiplier",
    "sensor_pose": "--sensor-pose",
    "skip_checks": "--skip-check",
    "side_mm": "--side-mm",
    "speed_m_s": "--speed-m-s",
    "split_stops": "--split-stops",
    "stop_s": "--stop-s",
    "straight_mm": "--straight-mm",
    "stream": "--stream",
    "ticks": "--ticks",
    "ticks_topic": "--ticks-topic",
    "time_offset": "--time-offset",
    "turn_rate_deg_s": "--turn-rate-deg-s",
    "wheel_diameter_mm": "--wheel-diameter-mm",
    "wheel_radius_m": "--wheel-radius-m",
    "wheel_separation_m": "--wheel-separation-m",
    "wheelbase_mm": "--wheelbase-mm",
    "when": "--recorded-at",
}
# every kind's own options (umbmark.kinds: --lx-plus-ly-mm, --drive-joint, ...)
PARAM_FLAGS.update(
    {n: "--" + n.replace("_", "-") for k in KINDS.values() for n in k.option_names() if n not in PARAM_FLAGS}
)
# the parameter files of the robots' own software an export edits (umbmark.kinds: --vesc-config)
PARAM_FLAGS.update({e.option: "--" + e.option.replace("_", "-") for k in KINDS.values() for e in k.edited_files})
# boolean parameters set False by a flag of their own
PARAM_NO_FLAGS = {"fit_offset": "--no-fit-marker-offset"}
_PARAM = re.compile(r"`(\w+)(?:=([^`]*))?`")


# the strings of the command line (paths, robot names, topics) and of the data read that hold a
# backtick: printed as given inside messages, never taken for a library's parameter name
_GIVEN: list[str] = []


def keep_as_given(strings: Iterable[object], reset: bool = False) -> None:
    """Mark strings (the command line's arguments, a file's name) as data: :func:`cli_message`
    prints them as given.

    Parameters
    ----------
    strings : iterable of str
        Any strings; only those holding a backtick matter.
    reset : bool
        Forget the strings marked before (a new command line).
    """
    if reset:
        _GIVEN.clear()
    for s in strings:
        for part in (s, s.partition("=")[2]) if isinstance(s, str) else ():
            if "`" in part and part not in _GIVEN:
                _GIVEN.append(part)
    _GIVEN.sort(key=len, reverse=True)


def cli_message(text: str) -> str:
    """A library message in the CLI's words: `name` becomes its flag, `name="v"` the flag and v.

    Parameters
    ----------
    text : str
        The message; parameters are named in backticks (see :data:`PARAM_FLAGS`). The data in
        it that the command line gave (see :func:`keep_as_given`) is kept as given.

    Returns
    -------
    str
        The message with each known parameter replaced by its flag (unknown names are kept).
    """
    for given in _GIVEN:
        if given in text:
            head, _, tail = text.partition(given)
            return cli_message(head) + given + cli_message(tail)

    def flag(m: re.Match) -> str:
        name, value = m.group(1), m.group(2)
        if name not in PARAM_FLAGS:
            return m.group(0)[1:-1]  # a library name without a flag: plain text
        f = PARAM_FLAGS[name]
        if value is None or value == "True":
            return f
        if value == "False" and name in PARAM_NO_FLAGS:
            return PARAM_NO_FLAGS[name]
        return f"{f} {value.strip(chr(34) + chr(39))}"

    return _PARAM.sub(flag, text)


# the keys whose values are data (names, paths, topics), printed as stored: the messages'
# wording for the command line (cli_message) is not applied to them
_DATA_KEYS = frozenset(
    {"robot", "source", "path", "paths", "bag", "bags", "db", "log", "name", "note", "host", "label", "file",
     "input_sha256", "software_version", "time_utc", "created_utc"}
)  # fmt: skip


def _is_data_key(key: object) -> bool:
    return isinstance(key, str) and (key in _DATA_KEYS or key.endswith(("_topic", "_frame", "_path")))


def _cli_strings(obj: Any) -> Any:
    if isinstance(obj, str):
        return cli_message(obj)
    if isinstance(obj, dict):
        return {k: (v if _is_data_key(k) else _cli_strings(v)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_cli_strings(v) for v in obj]
    return obj


def emit_json(obj: Any) -> None:
    """Print one JSON object on stdout, indented.

    NaN and infinities become null (strict JSON); the messages in it name the command's flags
    (see :func:`cli_message`); data (robot names, paths, topics, frames, notes) are printed as
    stored.

    Parameters
    ----------
    obj : dict
        JSON-able values (numpy values and paths allowed).
    """
    sys.stdout.write(dumps(_cli_strings(obj), indent=2) + "\n")


def table(
    title: str,
    columns: list[str],
    rows: list[list],
    justify_first: Literal["default", "left", "center", "right", "full"] = "left",
) -> Table:
    """A rich table: a title, a header of ``columns``, the ``rows`` (any values, shown with ``str``).

    Parameters
    ----------
    title : str
        Shown above the table.
    columns : list of str
        The headers.
    rows : list of list
        The cells of each row.
    justify_first : str
        Justification of the first column; the others are right-justified.

    Returns
    -------
    rich.table.Table
        No markup is read in the title, the headers or the cells.
    """
    from rich.markup import escape
    from rich.table import Table

    t = Table(title=escape(title), title_justify="left", header_style="bold")
    for i, c in enumerate(columns):
        t.add_column(escape(c), justify=justify_first if i == 0 else "right")
    for r in rows:
        t.add_row(*[escape(str(x)) for x in r])
    return t


def prior_options(f: F) -> F:
    """Add ``--c-left`` / ``--c-right`` (the correction factors the robot's odometry ran with) to a command.

    Parameters
    ----------
    f : callable
        The command function (it receives ``c_left`` and ``c_right``).

    Returns
    -------
    callable
        ``f`` with the two options.
    """
    f = click.option(
        "--c-right",
        type=float,
        default=1.0,
        show_default=True,
        help="Right-wheel correction factor the robot's odometry ran with.",
    )(f)
    f = click.option(
        "--c-left",
        type=float,
        default=1.0,
        show_default=True,
        help="Left-wheel correction factor the robot's odometry ran with.",
    )(f)
    return f


def positive(name: str, value: float) -> float:
    """A finite positive number from the command line.

    Parameters
    ----------
    name : str
        The flag, for the message.
    value : float
        The value.

    Returns
    -------
    float

    Raises
    ------
    InputError
        If ``value`` is missing, not finite or not positive.
    """
    return _check.positive(name, value)


# the true errors a simulated robot may have: wheels differing by up to a factor of 2, an
# effective wheelbase from 1/20 to 20 times the nominal one, a mean wheel scale 0.5 to 2; the
# correction factors an odometry ran with are factors of that size too
ERROR_RANGES = {
    "--ed": (0.5, 2.0),
    "--eb": (0.05, 20.0),
    "--es": (0.5, 2.0),
    "--c-left": (0.5, 2.0),
    "--c-right": (0.5, 2.0),
}


def error_param(name: str, value: float) -> float:
    """A true error factor from the command line, within :data:`ERROR_RANGES`.

    Parameters
    ----------
    name : str
        The flag: ``--ed``, ``--eb`` or ``--es``.
    value : float
        The value.

    Returns
    -------
    float

    Raises
    ------
    InputError
        If ``value`` is outside the flag's range.
    """
    lo, hi = ERROR_RANGES[name]
    if value is None or not (math.isfinite(value) and lo <= value <= hi):
        hint = ""
        if value is not None and math.isfinite(value) and 100 * lo <= value <= 100 * hi:
            hint = f" (a percentage? {value:g} % is {value / 100:g})"
        raise InputError(f"{name} must be a number from {lo:g} to {hi:g}, got {value!r}{hint}")
    return float(value)
