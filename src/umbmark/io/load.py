"""Open a real-robot log in any supported format (optiodom folder, generic CSV, ROS bag).

The reader options are named as the command line's (``wheel_diameter_mm``, ``wheelbase_mm``,
``pulses_per_wheel_rev``, ``side_mm``, the bag topics, ...): :func:`load_logs` takes them as
keyword arguments and passes each format's reader what it needs.
"""

from __future__ import annotations

import math
from pathlib import Path

from umbmark.errors import InputError
from umbmark.model.dataset import Dataset, WheelGeometry, check_stop_s

__all__ = [
    "LOG_FORMATS",
    "detect_format",
    "nominal_geometry",
    "csv_recorded_geometry",
    "load_logs",
    "parse_ranges",
    "parse_joints",
]

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


def _either(opts: dict, mm_key: str, m_key: str, factor: float) -> float | None:
    """An option given in mm or in the ROS form in metres (``factor``: mm per unit of ``m_key``);
    both given: they must agree."""
    mm, m = opts.get(mm_key), opts.get(m_key)
    if m is None:
        return mm
    if mm is not None and not math.isclose(mm, m * factor, rel_tol=1e-6):
        raise InputError(f"`{mm_key}` {mm:g} and `{m_key}` {m:g} disagree ({m * factor:g} mm): give one of them")
    return m * factor


def nominal_geometry(opts: dict, source: str, fallback: WheelGeometry | None = None) -> WheelGeometry:
    """The nominal geometry of a log format that does not hold it, from the reader options.

    Parameters
    ----------
    opts : dict
        ``wheel_diameter_mm`` or ``wheel_radius_m`` (or ``left_diameter_mm`` /
        ``right_diameter_mm``), and ``wheelbase_mm`` or ``wheel_separation_m`` (ROS's
        ``wheel_radius`` and ``wheel_separation``, in metres).
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
        A diameter or the wheelbase is missing; the mm and metre forms of one disagree.
    """
    d = _either(opts, "wheel_diameter_mm", "wheel_radius_m", 2000.0)
    dl = opts.get("left_diameter_mm") or d
    dr = opts.get("right_diameter_mm") or d
    b = _either(opts, "wheelbase_mm", "wheel_separation_m", 1000.0)
    if fallback is not None:
        dl = fallback.diameter_left_m * 1e3 if dl is None else dl
        dr = fallback.diameter_right_m * 1e3 if dr is None else dr
        b = fallback.wheelbase_m * 1e3 if b is None else b
    if dl is None or dr is None or b is None:
        raise InputError(
            "this log format does not hold the nominal geometry: give `wheel_diameter_mm` (or "
            "`wheel_radius_m`, or `left_diameter_mm`/`right_diameter_mm`) and `wheelbase_mm` (or "
            "`wheel_separation_m`)",
            source=source,
        )
    return WheelGeometry(dl * 1e-3, dr * 1e-3, b * 1e-3)


def load_logs(paths, fmt: str = "auto", **opts) -> Dataset:
    """One data set from log files.

    Parameters
    ----------
    paths : str, Path or sequence of them
        An optiodom folder (one path), bags or CSV logs (one or more).
    fmt : str
        One of :data:`LOG_FORMATS` (``auto``: :func:`detect_format` of the first path).
    **opts
        Reader options: ``side_mm`` (square runs), the nominal geometry
        (:func:`nominal_geometry`; a CSV log's recorded geometry fills what is not given),
        ``pulses_per_wheel_rev``, ``ticks``; for bags ``joints``, ``joint_topic``,
        ``ticks_topic``, ``left_field``, ``right_field``, ``odom_topic``, ``gt_topic``,
        ``gt_frame``, ``gt_parent``, ``ranges``, ``split_stops``, ``stop_s``; for every
        format ``time_offset`` (the ground truth's delay, :mod:`umbmark.model.timing`). Several bags are
        the runs of one test (one data set; a run's name starts with its bag's).

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
    _check_log_numbers(opts)
    if fmt in ("optiodom", "csv"):
        ds = _load_optiodom(paths, side_m) if fmt == "optiodom" else _load_csv(paths, side_m, opts)
        if opts.get("time_offset") is None:
            return ds
        from umbmark.model.timing import align_truth

        return align_truth(ds, opts["time_offset"], "optiodom folder" if fmt == "optiodom" else "CSV log")
    return _load_bag(paths, side_m, opts)


# the largest square side (m) and encoder resolution (pulses per wheel revolution) a log of a
# robot can have
_MAX_SIDE_M = 1000.0
_MAX_UNITS_PER_REV = 1e9


def _check_log_numbers(opts: dict) -> None:
    """Refuse a side, an encoder resolution or a pause no robot's log has (before reading)."""
    if opts.get("stop_s") is not None:
        check_stop_s(opts["stop_s"])
    for key, most, unit in (
        ("side_mm", _MAX_SIDE_M * 1e3, "mm (a square of more than 1 km)"),
        ("pulses_per_wheel_rev", _MAX_UNITS_PER_REV, "pulses per wheel revolution"),
    ):
        v = opts.get(key)
        if v is None:
            continue
        if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 < v <= most):
            raise InputError(f"`{key}` must be a positive number of at most {most:g} {unit}, got {v!r}")


def _load_optiodom(paths: list, side_m: float | None) -> Dataset:
    from dataclasses import replace

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

    found = [(p, read_csv_geometry(p)) for p in paths]
    found = [(p, g) for p, g in found if g is not None]
    if not found:
        return None, None
    p0, g0 = found[0]
    for p, g in found[1:]:
        if any(not math.isclose(g[k], g0[k], rel_tol=1e-9) for k in g0):
            raise InputError(f"records another nominal geometry than {p0} ({g} vs {g0})", source=str(p))
    geom = WheelGeometry(g0["left_diameter_mm"] * 1e-3, g0["right_diameter_mm"] * 1e-3, g0["wheelbase_mm"] * 1e-3)
    return geom, g0["pulses_per_wheel_rev"]


def _load_csv(paths: list, side_m: float | None, opts: dict) -> Dataset:
    from umbmark.io.generic_csv import read_generic_csv

    recorded, recorded_ppr = csv_recorded_geometry(paths)
    ppr = opts.get("pulses_per_wheel_rev") or recorded_ppr
    if ppr is None:
        raise InputError(
            "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(paths[0])
        )
    nominal = nominal_geometry(opts, str(paths[0]), recorded)
    return read_generic_csv(paths, nominal, ppr, opts.get("ticks") or "cumulative", side_m)


def _load_bag(paths: list, side_m: float | None, opts: dict) -> Dataset:
    """One bag, or several bags as the runs of one test (each bag one run, or cut into runs)."""
    if len(paths) == 1:
        return _read_one_bag(paths[0], side_m, opts)
    from dataclasses import replace

    sets = [_read_one_bag(p, side_m, opts) for p in paths]
    runs, names, warnings = [], set(), []
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
        first.units_per_rev,
        tuple(runs),
        side_m,
        first.source,
        meta={
            "format": "bag",
            "warnings": tuple(warnings),
            "sources": tuple(str(p) for p in paths),
            "time_offset": tuple(o for ds in sets for o in ds.meta.get("time_offset") or ()),
        },
    )


def _read_one_bag(path, side_m: float | None, opts: dict) -> Dataset:
    from umbmark.io.rosbag import read_bag, wheel_source_hint

    try:
        nominal = nominal_geometry(opts, str(path))
    except InputError as e:
        if any(opts.get(k) for k in ("joints", "ticks_topic", "odom_topic")):
            raise
        hint = wheel_source_hint(path)  # no wheel source either: say which the bag offers
        raise InputError(e.message + (f"; and the wheel data{hint}" if hint else ""), source=e.source) from None

    ranges = opts.get("ranges")
    if isinstance(ranges, str):
        ranges = parse_ranges(ranges)
    return read_bag(
        path,
        nominal=nominal,
        **wheel_source(opts),
        gt_topic=opts.get("gt_topic"),
        gt_frame=opts.get("gt_frame"),
        gt_parent=opts.get("gt_parent"),
        ranges=ranges,
        stops=bool(opts.get("split_stops")),
        stop_s=opts.get("stop_s") or 1.0,
        side_m=side_m,
        time_offset=opts.get("time_offset"),
    )


def wheel_source(opts: dict) -> dict:
    """The wheel-data keywords of the bag readers (:func:`umbmark.io.rosbag.read_bag`,
    ``read_selfcal_bag``, ``read_gyro_bag``, :func:`umbmark.realrobot.scan_truth.attach_scan_truth`)
    from the log options of :func:`load_logs`: ``joints`` (``"L,R"`` parsed), ``joint_topic``,
    ``ticks_topic``, ``left_field``, ``right_field``, ``ticks``, ``units_per_rev`` (from
    ``pulses_per_wheel_rev``) and ``odom_topic``, with the readers' defaults where not given.

    Parameters
    ----------
    opts : dict
        The log options.

    Returns
    -------
    dict
    """
    joints = opts.get("joints")
    return dict(
        joints=parse_joints(joints) if isinstance(joints, str) else joints,
        joint_topic=opts.get("joint_topic") or "/joint_states",
        ticks_topic=opts.get("ticks_topic"),
        left_field=opts.get("left_field"),
        right_field=opts.get("right_field"),
        ticks=opts.get("ticks") or "cumulative",
        units_per_rev=opts.get("pulses_per_wheel_rev"),
        odom_topic=opts.get("odom_topic"),
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
