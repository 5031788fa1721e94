"""Open a real-robot log in any supported format (optiodom folder, generic CSV, ROS bag).

The reader options are named as the command line's (``wheel_diameter_mm``, ``wheelbase_mm``,
``pulses_per_wheel_rev``, ``side_mm``, the bag topics, ...): :func:`load_logs` takes them as
keyword arguments and passes each format's reader what it needs.
"""

from __future__ import annotations

from pathlib import Path

from umbmark.errors import InputError
from umbmark.model.dataset import Dataset, WheelGeometry

__all__ = ["LOG_FORMATS", "detect_format", "nominal_geometry", "load_logs", "parse_ranges", "parse_joints"]

LOG_FORMATS = ("auto", "optiodom", "csv", "bag")


def detect_format(path) -> str:
    """The format of a log from what is at ``path``.

    Parameters
    ----------
    path : str or Path
        A folder, a file or a ROS 2 bag folder.

    Returns
    -------
    str
        ``optiodom``, ``bag`` or ``csv``.

    Raises
    ------
    InputError
        Nothing at ``path``, or none of the formats.
    """
    from umbmark.io.optiodom import is_optiodom
    from umbmark.io.rosbag import is_bag

    p = Path(path)
    if not p.exists():
        raise InputError("not found", source=str(path))
    if is_optiodom(p):
        return "optiodom"
    if is_bag(p):
        return "bag"
    if p.is_file() and p.suffix.lower() in (".csv", ".txt"):
        return "csv"
    raise InputError(
        "cannot tell the log format (an optiodom folder, a .csv log or a ROS bag); give `fmt`", source=str(path)
    )


def nominal_geometry(opts: dict, source: str) -> WheelGeometry:
    """The nominal geometry of a log format that does not hold it, from the reader options.

    Parameters
    ----------
    opts : dict
        ``wheel_diameter_mm`` (or ``left_diameter_mm`` / ``right_diameter_mm``) and
        ``wheelbase_mm``.
    source : str
        The log, for the error message.

    Returns
    -------
    WheelGeometry

    Raises
    ------
    InputError
        A diameter or the wheelbase is missing.
    """
    d = opts.get("wheel_diameter_mm")
    dl = opts.get("left_diameter_mm") or d
    dr = opts.get("right_diameter_mm") or d
    b = opts.get("wheelbase_mm")
    if dl is None or dr is None or b is None:
        raise InputError(
            "this log format does not hold the nominal geometry: give `wheel_diameter_mm` (or "
            "`left_diameter_mm`/`right_diameter_mm`) and `wheelbase_mm`",
            source=source,
        )
    return WheelGeometry(dl * 1e-3, dr * 1e-3, b * 1e-3)


def load_logs(paths, fmt: str = "auto", **opts) -> Dataset:
    """One data set from log files.

    Parameters
    ----------
    paths : str, Path or sequence of them
        An optiodom folder or a bag (one path), or CSV logs (one or more files).
    fmt : str
        One of :data:`LOG_FORMATS` (``auto``: :func:`detect_format` of the first path).
    **opts
        Reader options: ``side_mm`` (square runs), the nominal geometry
        (:func:`nominal_geometry`), ``pulses_per_wheel_rev``, ``ticks``; for bags ``joints``,
        ``joint_topic``, ``ticks_topic``, ``left_field``, ``right_field``, ``gt_topic``,
        ``gt_frame``, ``gt_parent``, ``ranges``, ``split_stops``, ``stop_s``.

    Returns
    -------
    Dataset

    Raises
    ------
    InputError
        An unknown format, a missing option, or a bad log (file and line named).
    """
    if isinstance(paths, (str, Path)):
        paths = [paths]
    paths = list(paths)
    if fmt not in LOG_FORMATS:
        raise InputError(f"unknown log format {fmt!r} (choose from {', '.join(LOG_FORMATS)})")
    if fmt == "auto":
        fmt = detect_format(paths[0])
    side = opts.get("side_mm")
    side_m = None if side is None else side * 1e-3
    if fmt == "optiodom":
        return _load_optiodom(paths, side_m)
    if fmt == "csv":
        return _load_csv(paths, side_m, opts)
    return _load_bag(paths, side_m, opts)


def _load_optiodom(paths: list, side_m: float | None) -> Dataset:
    from dataclasses import replace

    from umbmark.io.optiodom import read_optiodom

    if len(paths) != 1:
        raise InputError("one optiodom folder per data set")
    ds = read_optiodom(paths[0])
    return ds if side_m is None else replace(ds, side_m=side_m)


def _load_csv(paths: list, side_m: float | None, opts: dict) -> Dataset:
    from umbmark.io.generic_csv import read_generic_csv

    ppr = opts.get("pulses_per_wheel_rev")
    if ppr is None:
        raise InputError(
            "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(paths[0])
        )
    nominal = nominal_geometry(opts, str(paths[0]))
    return read_generic_csv(paths, nominal, ppr, opts.get("ticks") or "cumulative", side_m)


def _load_bag(paths: list, side_m: float | None, opts: dict) -> Dataset:
    from umbmark.io.rosbag import read_bag

    if len(paths) != 1:
        raise InputError("one bag per data set")
    joints = opts.get("joints")
    if isinstance(joints, str):
        joints = parse_joints(joints)
    ranges = opts.get("ranges")
    if isinstance(ranges, str):
        ranges = parse_ranges(ranges)
    return read_bag(
        paths[0],
        nominal=nominal_geometry(opts, str(paths[0])),
        joints=joints,
        joint_topic=opts.get("joint_topic") or "/joint_states",
        ticks_topic=opts.get("ticks_topic"),
        left_field=opts.get("left_field"),
        right_field=opts.get("right_field"),
        ticks=opts.get("ticks") or "cumulative",
        units_per_rev=opts.get("pulses_per_wheel_rev"),
        gt_topic=opts.get("gt_topic"),
        gt_frame=opts.get("gt_frame"),
        gt_parent=opts.get("gt_parent"),
        ranges=ranges,
        stops=bool(opts.get("split_stops")),
        stop_s=opts.get("stop_s") or 1.0,
        side_m=side_m,
    )


def parse_joints(text: str) -> tuple[str, str]:
    """``"left_wheel,right_wheel"`` -> ``("left_wheel", "right_wheel")``.

    Parameters
    ----------
    text : str
        Two joint names separated by a comma.

    Returns
    -------
    tuple of str

    Raises
    ------
    InputError
        Not two non-empty names.
    """
    parts = [j.strip() for j in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise InputError(f"`joints` needs two names LEFT,RIGHT, got {text!r}")
    return parts[0], parts[1]


def parse_ranges(text: str) -> list[tuple[float, float]]:
    """``"0-10,12.5-30"`` -> ``[(0, 10), (12.5, 30)]`` (seconds).

    Parameters
    ----------
    text : str
        Comma-separated ``START-END`` ranges in seconds.

    Returns
    -------
    list of (float, float)

    Raises
    ------
    InputError
        A range that is not two numbers with ``0 <= START < END``.
    """
    out = []
    for part in text.split(","):
        try:
            a, b = (float(x) for x in part.strip().split("-"))
        except ValueError:
            raise InputError(f"bad time range {part.strip()!r} (use START-END in seconds, e.g. 0-10,12-30)") from None
        if not b > a >= 0:
            raise InputError(f"bad time range {part.strip()!r}: need 0 <= START < END")
        out.append((a, b))
    return out
