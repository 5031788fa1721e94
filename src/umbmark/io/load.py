"""Open a real-robot log in any supported format (optiodom folder, generic CSV, ROS bag).

:class:`LogOptions` says how (SI units): the nominal geometry for formats that do not hold it,
the encoder resolution of CSV logs, the wheel data (:class:`~umbmark.io.wheels.WheelSource`) and
ground truth (:class:`TruthSource`) of bags, how to cut runs, the ground truth's delay.
:func:`load_logs` passes each format's reader what it needs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from umbmark._numbers import strict_float
from umbmark.errors import InputError
from umbmark.io.wheels import TICK_MODES, WheelSource
from umbmark.model.dataset import Dataset, Run, WheelGeometry, check_stop_s
from umbmark.model.defaults import LOG_FORMATS, STOP_S

__all__ = [
    "LOG_FORMATS",
    "TruthSource",
    "LogOptions",
    "detect_format",
    "nominal_geometry",
    "csv_recorded_geometry",
    "load_logs",
    "parse_ranges",
]


def detect_format(path: str | Path) -> str:
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


@dataclass(frozen=True)
class TruthSource:
    """Where a bag's ground truth is.

    Parameters
    ----------
    topic : str, optional
        The topic: ``geometry_msgs/PoseStamped``, ``nav_msgs/Odometry`` or ``/tf`` (None: none).
    frame, parent : str, optional
        For ``/tf``: the tracked child frame and (optionally) its parent.
    """

    topic: str | None = None
    frame: str | None = None
    parent: str | None = None


@dataclass(frozen=True)
class LogOptions:
    """How to read a real-robot log (:func:`load_logs`), in SI units.

    Parameters
    ----------
    diameter_left_m, diameter_right_m, wheelbase_m : float, optional
        The nominal geometry, for the formats that do not hold it (CSV logs: what is not given
        comes from the geometry the log records in its header).
    pulses_per_wheel_rev : float, optional
        The encoder resolution of CSV logs (else the one the log records).
    ticks : str
        CSV logs: ``cumulative`` or ``incremental`` counts (:data:`~umbmark.io.wheels.TICK_MODES`).
    wheels : WheelSource
        Bags: the wheel data.
    truth : TruthSource
        Bags: the ground truth.
    side_m : float, optional
        The square's side: the runs are UMBmark squares (optiodom folders: their metadata's).
    ranges_s : tuple of (float, float), optional
        Bags: cut runs at these time ranges (seconds from the first wheel sample).
    split_stops : bool
        Bags: cut runs where both wheels stand still for ``stop_s`` seconds.
    stop_s : float
        The stillness that ends a run [s].
    time_offset : None, "auto" or float
        The ground truth's delay against the wheels (:mod:`umbmark.model.timing`).
    """

    diameter_left_m: float | None = None
    diameter_right_m: float | None = None
    wheelbase_m: float | None = None
    pulses_per_wheel_rev: float | None = None
    ticks: str = TICK_MODES[0]
    wheels: WheelSource = field(default_factory=WheelSource)
    truth: TruthSource = field(default_factory=TruthSource)
    side_m: float | None = None
    ranges_s: tuple[tuple[float, float], ...] | None = None
    split_stops: bool = False
    stop_s: float = STOP_S
    time_offset: float | str | None = None


def nominal_geometry(opts: LogOptions, source: str, fallback: WheelGeometry | None = None) -> WheelGeometry:
    """The nominal geometry of a log format that does not hold it, from the reader options.

    Parameters
    ----------
    opts : LogOptions
        Its ``diameter_left_m``, ``diameter_right_m`` and ``wheelbase_m``.
    source : str
        The log, for the error message.
    fallback : WheelGeometry, optional
        The geometry the log itself records (e.g. in a CSV log's header): what the options do
        not give is taken from it.

    Returns
    -------
    WheelGeometry

    Raises
    ------
    InputError
        A diameter or the wheelbase is missing.
    """
    dl, dr, b = opts.diameter_left_m, opts.diameter_right_m, opts.wheelbase_m
    if fallback is not None:
        dl = fallback.diameter_left_m if dl is None else dl
        dr = fallback.diameter_right_m if dr is None else dr
        b = fallback.wheelbase_m if b is None else b
    if dl is None or dr is None or b is None:
        raise InputError(
            "this log format does not hold the nominal geometry: give the wheel diameter (`wheel_diameter_mm` "
            "or `wheel_radius_m`, or `left_diameter_mm`/`right_diameter_mm`) and the wheelbase (`wheelbase_mm` "
            "or `wheel_separation_m`)",
            source=source,
        )
    return WheelGeometry(dl, dr, b)


def load_logs(
    paths: str | Path | Sequence[str | Path], fmt: str = "auto", options: LogOptions | None = None
) -> Dataset:
    """One data set from log files.

    Parameters
    ----------
    paths : str, Path or sequence of them
        An optiodom folder (one path), bags or CSV logs (one or more).
    fmt : str
        One of :data:`LOG_FORMATS` (``auto``: :func:`detect_format` of the first path).
    options : LogOptions, optional
        How to read them (default: as the formats say; bags need at least the wheels). Several
        bags are the runs of one test (one data set; a run's name starts with its bag's).

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
    opts = LogOptions() if options is None else options
    if not isinstance(opts, LogOptions):
        raise InputError(f"`options` must be LogOptions, got {type(opts).__name__}")
    if fmt not in LOG_FORMATS:
        raise InputError(f"unknown log format {fmt!r} (choose from {', '.join(LOG_FORMATS)})")
    if fmt == "auto":
        fmt = detect_format(paths[0])
    _check_log_numbers(opts)
    if fmt in ("optiodom", "csv"):
        ds = _load_optiodom(paths, opts.side_m) if fmt == "optiodom" else _load_csv(paths, opts)
        from umbmark.model.timing import align_truth

        return align_truth(ds, opts.time_offset, "optiodom folder" if fmt == "optiodom" else "CSV log")
    return _load_bag(paths, opts)


# the largest square side (m) and encoder resolution (pulses per wheel revolution) a log of a
# robot can have
_MAX_SIDE_M = 1000.0
_MAX_UNITS_PER_REV = 1e9


def _check_log_numbers(opts: LogOptions) -> None:
    """Refuse a side, an encoder resolution, a tick mode or a pause no robot's log has (before reading)."""
    check_stop_s(opts.stop_s)
    for key, v, most, unit in (
        (
            "side_mm",
            None if opts.side_m is None else opts.side_m * 1e3,
            _MAX_SIDE_M * 1e3,
            "mm (a square of more than 1 km)",
        ),
        ("pulses_per_wheel_rev", opts.pulses_per_wheel_rev, _MAX_UNITS_PER_REV, "pulses per wheel revolution"),
    ):
        if v is None:
            continue
        if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 < v <= most):
            raise InputError(f"`{key}` must be a positive number of at most {most:g} {unit}, got {v!r}")
    if opts.ticks not in TICK_MODES:
        raise InputError(f"ticks must be 'cumulative' or 'incremental', got {opts.ticks!r}")


def _load_optiodom(paths: list, side_m: float | None) -> Dataset:
    from umbmark.io.optiodom import read_optiodom

    if len(paths) != 1:
        raise InputError("one optiodom folder per data set")
    ds = read_optiodom(paths[0])
    return ds if side_m is None else replace(ds, side_m=side_m)


def csv_recorded_geometry(paths: list) -> tuple[WheelGeometry | None, float | None]:
    """The nominal geometry and pulses per wheel revolution the CSV logs record in their header
    comments (``umbmark convert`` writes them); (None, None) when they record none.

    Parameters
    ----------
    paths : list of str or Path
        The CSV logs of one data set.

    Returns
    -------
    tuple
        ``(WheelGeometry or None, pulses_per_wheel_rev or None)``.

    Raises
    ------
    InputError
        A bad geometry line; files that record different geometries.
    """
    from umbmark.io.generic_csv import read_csv_geometry

    read = [(p, read_csv_geometry(p)) for p in paths]
    found = [(p, g) for p, g in read if g is not None]
    if not found:
        return None, None
    p0, g0 = found[0]
    for p, g in found[1:]:
        if any(not math.isclose(g[k], g0[k], rel_tol=1e-9) for k in g0):
            raise InputError(f"records another nominal geometry than {p0} ({g} vs {g0})", source=str(p))
    geom = WheelGeometry(g0["left_diameter_mm"] * 1e-3, g0["right_diameter_mm"] * 1e-3, g0["wheelbase_mm"] * 1e-3)
    return geom, g0["pulses_per_wheel_rev"]


def _load_csv(paths: list, opts: LogOptions) -> Dataset:
    from umbmark.io.generic_csv import read_generic_csv

    recorded, recorded_ppr = csv_recorded_geometry(paths)
    ppr = opts.pulses_per_wheel_rev or recorded_ppr
    if ppr is None:
        raise InputError(
            "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(paths[0])
        )
    nominal = nominal_geometry(opts, str(paths[0]), recorded)
    return read_generic_csv(paths, nominal, ppr, opts.ticks, opts.side_m)


def _load_bag(paths: list, opts: LogOptions) -> Dataset:
    """One bag, or several bags as the runs of one test (each bag one run, or cut into runs)."""
    if len(paths) == 1:
        return _read_one_bag(paths[0], opts)
    sets = [_read_one_bag(p, opts) for p in paths]
    runs: list[Run] = []
    names: set[str] = set()
    warnings: list[str] = []
    for ds in sets:
        warnings += ds.meta.get("warnings") or ()
        for r in ds.runs:
            if len(ds.runs) == 1:
                name = ds.name
            elif "#" in r.name:  # a piece between stops: "bag#3" -> "<bag's name>#3"
                name = ds.name + r.name[r.name.index("#") :]
            else:
                name = f"{ds.name}/{r.name}"
            base, k = name, 2
            while name in names:
                name, k = f"{base}~{k}", k + 1
            names.add(name)
            runs.append(replace(r, name=name))
    first = sets[0]
    return Dataset(
        f"{first.name}..{sets[-1].name}",
        first.nominal,
        first.units_per_wheel_rev,
        tuple(runs),
        opts.side_m,
        first.source,
        meta={
            "format": "bag",
            "warnings": tuple(warnings),
            "sources": tuple(str(p) for p in paths),
            "time_offset": tuple(o for ds in sets for o in ds.meta.get("time_offset") or ()),
            "wheel_stream": tuple(o for ds in sets for o in ds.meta.get("wheel_stream") or ()),
        },
    )


def _read_one_bag(path: str | Path, opts: LogOptions) -> Dataset:
    from umbmark.io.rosbag import read_bag, wheel_source_hint

    try:
        nominal = nominal_geometry(opts, str(path))
    except InputError as e:
        if opts.wheels.given:
            raise
        hint = wheel_source_hint(path)  # no wheel source either: say which the bag offers
        raise InputError(e.message + (f"; and the wheel data{hint}" if hint else ""), source=e.source) from None
    ds = read_bag(
        path,
        nominal=nominal,
        wheels=opts.wheels,
        gt_topic=opts.truth.topic,
        gt_frame=opts.truth.frame,
        gt_parent=opts.truth.parent,
        ranges=None if opts.ranges_s is None else list(opts.ranges_s),
        stops=opts.split_stops,
        stop_s=opts.stop_s,
        side_m=opts.side_m,
        time_offset=opts.time_offset,
    )
    return _bag_wheels_against_truth(ds)


def _bag_wheels_against_truth(ds: Dataset) -> Dataset:
    """A bag's runs with a ground-truth track checked against their wheels and the nominal
    geometry (:func:`umbmark.io._checks.wheels_against_truth`): the warnings added to the data set's."""
    from umbmark.io._checks import wheels_against_truth

    found: list[str] = []
    for r in ds.runs:
        try:
            found += wheels_against_truth(
                r,
                ds.nominal,
                ds.units_per_wheel_rev,
                "the ground truth's topic and frame (metres), the wheel diameters and the wheel data's unit",
                "the wheelbase, and that the ground truth's frame is the robot's",
                "the ground truth's orientation",
            )
        except InputError:
            continue  # the bag reader's own checks judge a ground truth that does not move
    if not found:
        return ds
    found = list(dict.fromkeys(found))  # the runs of one bag say the same
    return replace(ds, meta={**ds.meta, "warnings": (*(ds.meta.get("warnings") or ()), *found)})


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
            a, b = (strict_float(x) for x in part.strip().split("-"))
        except ValueError:
            raise InputError(f"bad time range {part.strip()!r} (use START-END in seconds, e.g. 0-10,12-30)") from None
        if not b > a >= 0:
            raise InputError(f"bad time range {part.strip()!r}: need 0 <= START < END")
        out.append((a, b))
    return out
