"""The options that say how to read a log (``replay``, ``convert``) and the reading of the logs
given into data sets.

The library does the work (:mod:`umbmark.io.load`); no numerical module is imported before a
command runs.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from umbmark.cli.app import LOG_FORMAT_CHOICES
from umbmark.cli.command_config import LogConfig
from umbmark.cli.config import option_of
from umbmark.cli.guard import skip_check_option
from umbmark.cli.progress import progress, track
from umbmark.model.defaults import TICK_MODES

if TYPE_CHECKING:
    from umbmark.model.dataset import Dataset

F = TypeVar("F", bound=Callable[..., Any])

__all__ = ["log_options", "datasets", "all_bags"]

_option = option_of(LogConfig)


def log_options(f: F) -> F:
    """Add the options that describe how to read a log (geometry for formats that lack it, bag
    topics) to a click command.

    Parameters
    ----------
    f : callable
        The command function; it receives ``log_format`` and the keyword arguments of
        :func:`umbmark.io.load.load_logs`.

    Returns
    -------
    callable
        The decorated command.
    """
    opts = [
        _option(
            "--format",
            "log_format",
            type=click.Choice(LOG_FORMAT_CHOICES),
            show_default=True,
            help="Log format: an optiodom data-set folder, a generic CSV log, a ROS 1/2 bag.",
        ),
        _option(
            "--side-mm",
            type=float,
            help="Square side: the runs are UMBmark squares (optiodom: from the metadata).",
        ),
        _option("--wheel-diameter-mm", type=float, help="Nominal wheel diameter (CSV, bags)."),
        _option("--wheel-radius-m", type=float, help="Nominal wheel radius, ROS's wheel_radius (instead)."),
        _option("--left-diameter-mm", type=float, help="Nominal left wheel diameter."),
        _option("--right-diameter-mm", type=float, help="Nominal right wheel diameter."),
        _option("--wheelbase-mm", type=float, help="Nominal wheelbase (CSV, bags)."),
        _option(
            "--wheel-separation-m",
            type=float,
            help="Nominal wheelbase, ROS's wheel_separation (instead).",
        ),
        _option(
            "--pulses-per-wheel-rev",
            type=float,
            help="Encoder pulses per wheel revolution (CSV, bag ticks).",
        ),
        _option(
            "--ticks",
            type=click.Choice(TICK_MODES),
            show_default=True,
            help="Encoder counts are a running counter or per-sample counts.",
        ),
        _option("--joints", metavar="LEFT,RIGHT", help="Bag: JointState names of the wheels."),
        _option("--joint-topic", show_default=True, help="Bag: JointState topic."),
        _option("--ticks-topic", help="Bag: topic with encoder counts."),
        _option("--left-field", help="Bag: field of the left count, e.g. data[0]."),
        _option("--right-field", help="Bag: field of the right count, e.g. data[1]."),
        _option(
            "--odom-topic",
            help="Bag: nav_msgs/Odometry as the wheels (its increments through the nominal geometry).",
        ),
        _option("--gt-topic", help="Bag: ground truth (PoseStamped, Odometry or /tf)."),
        _option("--gt-frame", help="Bag, /tf ground truth: the tracked child frame."),
        _option("--gt-parent", help="Bag, /tf ground truth: its parent frame (optional)."),
        _option(
            "--ranges",
            metavar="A-B,C-D",
            help="Bag: cut runs at these time ranges (seconds from the first wheel sample).",
        ),
        _option("--split-stops", is_flag=True, help="Bag: cut runs where both wheels stand still."),
        _option(
            "--stop-s",
            type=float,
            show_default=True,
            help="Bag: the stillness (seconds) that ends a run with --split-stops.",
        ),
        _option(
            "--time-offset",
            metavar="auto|SECONDS",
            help="How late the ground truth is against the wheels. Bags with --gt-topic: without it "
            "the offset is estimated (cross-correlation of the turn rates), reported in the JSON "
            "key time_offset and warned about when over 50 ms; auto subtracts the estimate; SECONDS "
            "subtracts that (positive: ground truth late). CSV logs, optiodom: applied when given.",
        ),
        skip_check_option,
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def _load(paths: Sequence[str], log_format: str, kw: Mapping[str, Any]) -> Dataset:
    from umbmark.cli.options import read_options
    from umbmark.io.load import load_logs

    return load_logs(paths, log_format, read_options(kw))


def datasets(paths: Iterable[str], log_format: str, kw: Mapping[str, Any]) -> list[Dataset]:
    """Each PATH is a data set, except CSV files and bags: all CSV files given form one data
    set, and so do all bags given (the runs of one test)."""
    paths = list(paths)
    if log_format in ("csv",) or (
        log_format == "auto" and all(Path(p).is_file() and Path(p).suffix.lower() == ".csv" for p in paths)
    ):
        with progress(f"reading {len(paths)} CSV log(s)"):
            return [_load(paths, "csv", kw)]
    if len(paths) > 1 and all_bags(paths, log_format):
        with progress(f"reading {len(paths)} bags"):
            return [_load(paths, "bag", kw)]
    return [_load([p], log_format, kw) for p in track(paths, "reading logs")]


def all_bags(paths: Iterable[str], log_format: str) -> bool:
    """Every path is a bag (told by its format, or by ``--format bag``)."""
    if log_format == "bag":
        return True
    if log_format != "auto":
        return False
    from umbmark.io.load import detect_format

    return all(detect_format(p) == "bag" for p in paths)
