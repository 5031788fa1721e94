"""Open a real-robot log in any supported format (optiodom folder, generic CSV, ROS bag)."""

from __future__ import annotations

from pathlib import Path

from umbmark.errors import InputError
from umbmark.model.dataset import Dataset, WheelGeometry

__all__ = ["LOG_FORMATS", "detect_format", "load_logs"]

LOG_FORMATS = ("auto", "optiodom", "csv", "bag")


def detect_format(path) -> str:
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


def _nominal(opts: dict, source: str) -> WheelGeometry:
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
    """One data set from ``paths`` (a folder or bag: one path; CSV: one or more files)."""
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
        from umbmark.io.optiodom import read_optiodom

        if len(paths) != 1:
            raise InputError("one optiodom folder per data set")
        ds = read_optiodom(paths[0])
        if side_m is not None:
            from dataclasses import replace

            ds = replace(ds, side_m=side_m)
        return ds
    if fmt == "csv":
        from umbmark.io.generic_csv import read_generic_csv

        ppr = opts.get("pulses_per_wheel_rev")
        if ppr is None:
            raise InputError(
                "the CSV log needs `pulses_per_wheel_rev` (encoder pulses per wheel revolution)", source=str(paths[0])
            )
        return read_generic_csv(paths, _nominal(opts, str(paths[0])), ppr, opts.get("ticks") or "cumulative", side_m)
    from umbmark.io.rosbag import read_bag

    if len(paths) != 1:
        raise InputError("one bag per data set")
    joints = opts.get("joints")
    if isinstance(joints, str):
        parts = [j.strip() for j in joints.split(",")]
        if len(parts) != 2 or not all(parts):
            raise InputError(f"`joints` needs two names LEFT,RIGHT, got {joints!r}")
        joints = tuple(parts)
    ranges = opts.get("ranges")
    if isinstance(ranges, str):
        ranges = parse_ranges(ranges)
    return read_bag(
        paths[0],
        nominal=_nominal(opts, str(paths[0])),
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


def parse_ranges(text: str):
    """``"0-10,12.5-30"`` -> [(0, 10), (12.5, 30)] (seconds)."""
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
