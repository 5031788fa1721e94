"""``umbmark selfcal``: the lidar self-calibration of the wheels, the wheelbase and the lidar's
mounting pose, from ROS bags (LaserScan and wheel data) or intervals files.

The library does the work (:mod:`umbmark.realrobot.selfcal`, :mod:`umbmark.io.rosbag`,
:mod:`umbmark.correct.selfcal`); this module parses the options, shows progress bars on long
bags, and prints the report's ``to_dict()`` or a table made from it. No numerical module is
imported before the command runs.
"""

from __future__ import annotations

import functools
import math
import shlex
from collections.abc import Callable, Collection
from pathlib import Path

import click

from umbmark.cli.app import app, cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.cli.bags import Bars, interval_options, kind_of, start_kernels, stream_text
from umbmark.cli.config import config_options
from umbmark.cli.guard import skip_check_option
from umbmark.cli.history import history_options, print_recorded, record_if_requested, refuse_if_recorded
from umbmark.cli.kinematic import joints_help, kinematic_options, refuse_kind_options
from umbmark.errors import InputError
from umbmark.kinds import kind_named

__all__ = ["selfcal_cmd", "selfcal_settings", "LEGEND"]

LEGEND = (
    "D_L, D_R: the wheel diameters, and wheelbase: the effective distance between the wheels, that make the "
    "wheel odometry move as the lidar saw the robot move.",
    "E_d = D_R / D_L and E_b = wheelbase / nominal wheelbase: the two systematic errors of UMBmark.",
    "lidar x, y, yaw: where the lidar sits on the robot (x forward, y left of the midpoint between the "
    "wheels; yaw counter-clockwise from the robot's heading); nominal: the pose the scan matching started from.",
    "95 % interval: from the scatter of the intervals about the fit and between stretches of the recording "
    "(errors shared within a stretch, such as a room the scan matching measures a little short, count); it does "
    "not cover errors shared by the whole recording (one floor, one day): calibrate on another to see those.",
    "wheel data jitter: how far the wheel data's stamps scatter against the scans' (the errors it puts in the "
    "wheels' rotation at the ends of each interval are part of the fit; --no-wheel-jitter takes them as exact).",
    "wheel noise: each wheel's random travel error, one standard deviation after rolling 1 m (it grows with the "
    "square root of the distance); umbmark export writes it as the controller's covariances.",
)


def _next_command(paths, save, d_m, b_m, flags: list[str]) -> tuple[str, str]:
    """The command that saves this result (when it was not saved), and the export command."""
    q = shlex.quote
    cal = save or "selfcal.json"
    again = ""
    if not save:
        again = (
            f"umbmark selfcal {' '.join(q(str(p)) for p in paths)} {' '.join(flags)} "
            f"--wheel-diameter-mm {d_m * 1e3:.10g} --wheelbase-mm {b_m * 1e3:.10g} --save {q(cal)}"
        ).replace("  ", " ")
    return again, f"umbmark export {q(cal)} --format ros2 --out params.yaml"


def _delay_text(d: dict) -> str:
    """How late the scans' stamps were taken to be, and where that came from."""
    applied = f"{d['applied_s'] * 1e3:.1f} ms"
    if d.get("requested") != "auto":
        return f"{applied} (given)" if d["applied_s"] else f"{applied} (stamps as recorded)"
    return (
        f"{applied}, estimated (the matched turns correlate {d['correlation']:.4f} with the wheels' then, "
        f"{d['correlation_at_zero']:.4f} as stamped; --scan-delay off for the stamps as recorded)"
    )


def _ci(lo_hi, digits: int) -> str:
    return f"{lo_hi[0]:.{digits}f} to {lo_hi[1]:.{digits}f}"


def _print_report(d: dict, again: str, export: str) -> None:
    """The human output: what was read, the figures with their intervals and meaning, what next."""
    from rich.markup import escape

    c = console()
    bags = [i for i in d["inputs"] if i["kind"] == "bag"]
    if bags:
        for b in bags:
            c.print(
                escape(
                    f"{b['path']}: {b['scans_read']} scans on {b['scan_topic']} (frame {b['scan_frame']}) over "
                    f"{b['time_span_s']:.1f} s, wheels from {b['wheel_data']}; keyframes "
                    f"{d['keyframe_rule']['description']}: "
                    f"{b['pairs_matched']} scan pairs matched"
                    + (f" ({b['pairs_chained']} through the scans between them)" if b.get("pairs_chained") else "")
                    + f", {b['pairs_failed']} failed, "
                    f"{b['intervals_still']} without wheel motion set aside"
                )
            )
            if b.get("wheel_stream"):
                c.print(escape(f"  wheel data: {stream_text(b['wheel_stream'])}"))
            if b["failure_reasons"]:
                why = "; ".join(f"{n} {r}" for r, n in b["failure_reasons"].items())
                c.print(escape(f"  failed matches: {why}"))
            c.print(escape(f"  scans' delay: {_delay_text(b['scan_delay'])}"))
            n = b["nominal_sensor_pose"]
            src = "no transform to the scans' frame: zero" if n["source"] == "none" else n["source"]
            c.print(
                escape(
                    f"  matching started from the sensor pose x {n['x_mm']:.1f} mm, y {n['y_mm']:.1f} mm, "
                    f"yaw {n['yaw_deg']:.2f} deg ({src})"
                )
            )
    else:
        c.print(escape(f"intervals from {', '.join(i['path'] for i in d['inputs'])}"))
    sp = d["sensor_pose"]
    nd, nb = d["nominal_wheel_diameter_mm"], d["nominal_wheelbase_mm"]
    nsp = d.get("nominal_sensor_pose") or {}
    nom = lambda k, digits: fmt(nsp.get(k), digits) if nsp else ""  # noqa: E731
    rows = [
        ["D_L [mm]", fmt(d["wheel_diameter_left_mm"], 3), _ci(d["wheel_diameter_left_mm_ci95"], 3), f"{nd:g}"],
        ["D_R [mm]", fmt(d["wheel_diameter_right_mm"], 3), _ci(d["wheel_diameter_right_mm_ci95"], 3), f"{nd:g}"],
        ["wheelbase [mm]", fmt(d["wheelbase_mm"], 3), _ci(d["wheelbase_mm_ci95"], 3), f"{nb:g}"],
        ["E_d = D_R/D_L", fmt(d["Ed"], 6), _ci(d["Ed_ci95"], 6), "1"],
        ["E_b", fmt(d["Eb"], 6), _ci(d["Eb_ci95"], 6), "1"],
        ["lidar x [mm]", fmt(sp["x_mm"], 2), _ci(sp["x_mm_ci95"], 2), nom("x_mm", 2)],
        ["lidar y [mm]", fmt(sp["y_mm"], 2), _ci(sp["y_mm_ci95"], 2), nom("y_mm", 2)],
        ["lidar yaw [deg]", fmt(sp["yaw_deg"], 3), _ci(sp["yaw_deg_ci95"], 3), nom("yaw_deg", 3)],
    ]
    for delay in d.get("scan_delay") or []:
        label = "scans' delay [ms]" if len(bags) == 1 else f"delay of {Path(delay['bag']).name} [ms]"
        how = "estimated" if delay.get("requested") == "auto" else "given"
        rows.append([label, fmt(1e3 * delay["applied_s"], 1), how, "0"])
    if d.get("wheel_jitter_ms") is not None:
        rows.append(["wheel data jitter [ms]", fmt(d["wheel_jitter_ms"], 1), "estimated", "0"])
    for side in ("left", "right") if d.get("odometry_noise") else ():
        noise = d["odometry_noise"]
        lo, hi = (1e3 * math.sqrt(max(v, 0.0)) for v in noise[f"wheel_variance_{side}_m2_per_m_ci95"])
        rows.append([f"{side} wheel noise [mm/sqrt(m)]", fmt(noise[f"wheel_sd_{side}_mm_per_sqrt_m"], 2),
                     _ci((lo, hi), 2), ""])  # fmt: skip
    c.print(
        table(
            f"Self-calibration from {d['intervals_used']} intervals "
            f"({len(d['intervals_rejected'])} rejected as outliers)",
            ["", "estimate", "95 % interval", "nominal"],
            rows,
        )
    )
    for line in LEGEND:
        c.print(f"[dim]{escape(line)}[/dim]")
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
    c.print(
        f"[bold]Next[/bold]: load the wheel factors c_left = {fmt(d['c_left'], 6)}, c_right = "
        f"{fmt(d['c_right'], 6)} and E_b = {fmt(d['Eb'], 6)} into the odometry, and the lidar pose into the URDF:"
    )
    if again:
        c.print(f"  {escape(again)}", soft_wrap=True)
    c.print(f"  {escape(export)}", soft_wrap=True)
    c.print(f"  {escape(export.replace('--format ros2 --out params.yaml', '--format urdf'))}", soft_wrap=True)


@app.command("selfcal")
@click.argument("paths", nargs=-1, required=True, metavar="INPUT...")
@kinematic_options
@click.option("--scan-topic", default="/scan", show_default=True, help="Bag: the sensor_msgs/LaserScan topic.")
@click.option(
    "--joints",
    default=None,
    metavar="LEFT,RIGHT",
    help=joints_help("Bag: JointState names of the wheels"),
)
@click.option("--joint-topic", default="/joint_states", show_default=True, help="Bag: JointState topic.")
@click.option("--ticks-topic", default=None, help="Bag: topic with encoder counts (instead of --joints).")
@click.option("--left-field", default=None, help="Bag: field of the left count, e.g. data[0].")
@click.option("--right-field", default=None, help="Bag: field of the right count, e.g. data[1].")
@click.option("--pulses-per-wheel-rev", type=float, default=None, help="Bag: encoder pulses per wheel revolution.")
@click.option(
    "--ticks",
    type=click.Choice(["cumulative", "incremental"]),
    default="cumulative",
    show_default=True,
    help="Bag: encoder counts are a running counter or per-message counts.",
)
@click.option(
    "--odom-topic",
    default=None,
    help="Bag: nav_msgs/Odometry of the wheels (instead of --joints), turned into wheel travel "
    "with the nominal geometry.",
)
@click.option("--wheel-diameter-mm", type=float, default=None, help="Nominal wheel diameter.")
@click.option("--wheelbase-mm", type=float, default=None, help="Nominal wheelbase.")
@click.option(
    "--wheel-radius-m", type=float, default=None, help="Nominal wheel radius (instead of --wheel-diameter-mm)."
)
@click.option(
    "--wheel-separation-m", type=float, default=None, help="Nominal wheel separation (instead of --wheelbase-mm)."
)
@click.option(
    "--sensor-pose",
    default=None,
    metavar="X_MM,Y_MM,YAW_DEG",
    help="Bag: the lidar pose the scan matching starts from (default: /tf_static, else zero).",
)
@click.option(
    "--base-frame", default=None, help="Bag: the robot frame in /tf_static (default base_link, base_footprint)."
)
@click.option("--scan-frame", default=None, help="Bag: refuse scans in another frame than this.")
@click.option(
    "--keyframe-mm",
    type=float,
    default=100.0,
    show_default=True,
    help="Bag: the next keyframe after this much travel (0: no travel condition; all four 0: every scan).",
)
@click.option("--keyframe-deg", type=float, default=10.0, show_default=True, help="Bag: ... or this much turn.")
@click.option("--keyframe-s", type=float, default=2.0, show_default=True, help="Bag: ... or this much time (0: none).")
@click.option("--keyframe-min-s", type=float, default=0.5, show_default=True, help="Bag: least time between keyframes.")
@click.option(
    "--max-wheel-gap-s",
    type=float,
    default=0.5,
    show_default=True,
    help="Bag: scans in longer gaps of the wheel data are not used.",
)
@click.option(
    "--coarse",
    is_flag=True,
    help="Bag: search widely before each scan match (odometry far off, or keyframes far apart).",
)
@click.option(
    "--scan-delay",
    default="auto",
    show_default=True,
    metavar="auto|off|SECONDS",
    help="Bag: how late the scans are stamped against the wheel data. auto estimates it (the "
    "scan-matched turns against the wheels' turns, within +-0.3 s) and subtracts it from the scans' "
    "stamps; off (or 0) takes the stamps as recorded; a number of seconds is applied as given. "
    "Printed per bag; JSON key scan_delay.",
)
@click.option(
    "--min-intervals", type=click.IntRange(min=3), default=10, show_default=True, help="Fewest matched intervals."
)
@click.option("--keep-outliers", is_flag=True, help="Fit every interval (no outlier rejection).")
@click.option(
    "--wheel-jitter/--no-wheel-jitter",
    default=True,
    show_default=True,
    help="Model errors in the wheel data from their stamps' jitter against the scans' (estimated with the "
    "noise; bags, and intervals files with the wheel-rate columns; JSON key wheel_jitter_ms). Taken as "
    "exact, such errors make the wheels and turns come out small.",
)
@click.option(
    "--save",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write the JSON result to this file (input of `umbmark export`).",
)
@click.option(
    "--intervals-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Bag: write the matched intervals as an intervals file (CSV).",
)
@click.option(
    "--window",
    metavar="DURATION",
    default=None,
    help="Also cut each input into windows of about DURATION (10min, 600s, 1h) and self-calibrate each "
    "(JSON key windows); with --record, each window is recorded with its own date (for `umbmark drift`).",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@skip_check_option
@history_options
@config_options
def selfcal_cmd(
    paths,
    kinematics,
    wheel_diameter_mm,
    wheelbase_mm,
    wheel_radius_m,
    wheel_separation_m,
    min_intervals,
    keep_outliers,
    wheel_jitter,
    save,
    as_json,
    robot=None,
    record=False,
    db=None,
    **kw,
):
    """Self-calibrate the wheel diameters, the wheelbase and the lidar's mounting pose from the
    lidar's own motion (Censi et al., IEEE T-RO 2013).

    INPUT is a ROS 1 or ROS 2 bag with laser scans and wheel data (several bags are pooled), or
    intervals files (CSV: dt_s, left_rad, right_rad, sensor_dx_m, sensor_dy_m,
    sensor_dyaw_rad). Drive straights, arcs and spins both ways near walls for a few minutes.
    The wheel data: --joints (JointState), --ticks-topic (encoder counts) or --odom-topic
    (nav_msgs/Odometry). The result exports with `umbmark export` (diff_drive_controller
    parameters, the URDF origin of the lidar, a static_transform_publisher line). Tricycles,
    mecanum robots and cars: --kinematics with their joints (a car also from its --odom-topic).

    \b
    Example:
      umbmark selfcal drive_bag --joints left_wheel_joint,right_wheel_joint --wheel-diameter-mm 150 --wheelbase-mm 340
      umbmark selfcal drive_bag --odom-topic /odom --wheel-radius-m 0.075 --wheel-separation-m 0.34 --save cal.json
      umbmark export cal.json --format urdf
    """
    window = kw.pop("window", None)
    window_s = None
    if window is not None:
        from umbmark.cli.selfcal_windows import window_seconds

        window_s = window_seconds(window)
    if not kind_named(kinematics).differential:
        from umbmark.cli.kinematic import kinematic_selfcal_cmd

        if not wheel_jitter:
            raise InputError(
                f"--no-wheel-jitter: the self-calibration of a {kind_named(kinematics).noun} takes the joint data "
                "as exact already (it models no jitter of their stamps; a differential drive's does)"
            )
        sizes = dict(
            wheel_diameter_mm=wheel_diameter_mm,
            wheel_radius_m=wheel_radius_m,
            wheelbase_mm=wheelbase_mm,
            wheel_separation_m=wheel_separation_m,
        )
        history = (robot, record, db)
        kinematic_selfcal_cmd(
            kinematics, paths, min_intervals, keep_outliers, save, as_json, history, window_s, {**kw, **sizes}
        )
        return
    params = dict(
        kw,
        wheel_diameter_mm=wheel_diameter_mm,
        wheel_radius_m=wheel_radius_m,
        wheelbase_mm=wheelbase_mm,
        wheel_separation_m=wheel_separation_m,
        min_intervals=min_intervals,
        keep_outliers=keep_outliers,
        wheel_jitter=wheel_jitter,
    )
    kind = functools.cache(lambda: kind_of(paths))
    settings = selfcal_settings(params, lambda: {kind()})
    refuse_if_recorded(robot, record, db, kind="selfcal", method="selfcal", paths=paths)  # windows too: they cover it
    rep = _selfcal(paths, settings, kind() == "bags", kw["intervals_out"], as_json)
    opts = settings.fit_options
    flags = _bag_flags(kw) if kind() == "bags" else []
    if keep_outliers:
        flags.append("--keep-outliers")
    if min_intervals != 10:
        flags.append(f"--min-intervals {min_intervals}")
    d = rep.to_dict()
    rec: dict | list | None = None
    if window_s is not None:
        from umbmark.cli.selfcal_windows import selfcal_windows_cmd

        d["windows"], rec = selfcal_windows_cmd(rep, window_s, opts, robot, record, db)
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if record and window_s is None:
        from umbmark.history import file_sha256

        fields = rep.history_fields(kind="selfcal", file_hash=file_sha256)
        rec = record_if_requested(robot, record, db, **fields)
    if as_json:
        emit_json(d if rec is None else {**d, "history": rec})
        return
    if is_quiet():
        return
    d_m, b_m = settings.wheel_diameter_m, settings.wheelbase_m
    _print_report(d, *_next_command(paths, save, d_m, b_m, flags + ([] if wheel_jitter else ["--no-wheel-jitter"])))
    if window_s is not None:
        from umbmark.cli.selfcal_windows import print_windows

        print_windows(d["windows"])
    print_recorded(rec)


def _bag_flags(kw) -> list[str]:
    """The options that read the bags, for the command shown as the next step."""
    q = shlex.quote
    out = []
    for name in ("scan_topic", "joints", "joint_topic", "ticks_topic", "left_field", "right_field", "odom_topic"):
        v = kw[name]
        default = {"scan_topic": "/scan", "joint_topic": "/joint_states"}.get(name)
        if v is not None and v != default:
            out.append(f"--{name.replace('_', '-')} {q(str(v))}")
    for name in (
        "pulses_per_wheel_rev",
        "sensor_pose",
        "base_frame",
        "scan_frame",
        "intervals_out",
    ):
        if kw[name] is not None:
            out.append(f"--{name.replace('_', '-')} {q(str(kw[name]))}")
    if kw["ticks"] != "cumulative":
        out.append(f"--ticks {kw['ticks']}")
    if str(kw["scan_delay"]).strip().lower() != "auto":
        out.append(f"--scan-delay {q(str(kw['scan_delay']))}")
    for name, usual in (
        ("keyframe_mm", 100.0),
        ("keyframe_deg", 10.0),
        ("keyframe_s", 2.0),
        ("keyframe_min_s", 0.5),
        ("max_wheel_gap_s", 0.5),
    ):
        if kw[name] != usual:
            out.append(f"--{name.replace('_', '-')} {kw[name]:g}")
    if kw["coarse"]:
        out.append("--coarse")
    return out


def selfcal_settings(kw: dict, kinds: Collection[str] | Callable[[], Collection[str]]):
    """The :class:`~umbmark.realrobot.selfcal_settings.SelfcalSettings` of selfcal's options for
    a differential drive, checked before anything is read: no option of another kind, the
    nominal geometry, no bag option when every input is an intervals file, the interval options
    and the wheel data's source when one is a bag.

    Parameters
    ----------
    kw : dict
        The parsed options (``wheel_diameter_mm``, ..., ``min_intervals``, ``keep_outliers``,
        ``wheel_jitter`` and the bag options).
    kinds : collection of str, or a callable returning one
        The inputs' kinds (``bags``, ``intervals``); a callable is asked once the geometry is
        checked.
    """
    from umbmark.cli.options import nominal_m, wheel_source
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

    refuse_kind_options(kw)
    d_m, b_m = nominal_m(kw)
    given = set(kinds() if callable(kinds) else kinds)
    common = dict(
        reject_outliers=not kw["keep_outliers"],
        time_jitter=kw["wheel_jitter"],
        skip_checks=frozenset(kw.get("skip_check") or ()),  # the command's own: applied around it
    )
    if "bags" not in given:
        flags = _bag_flags(kw)
        if flags:
            raise InputError(f"{flags[0].split()[0]} reads bags; the inputs are intervals files")
        return SelfcalSettings(d_m, b_m, **common)
    options = interval_options(kw, kw["min_intervals"])
    wheels = wheel_source(kw)
    if wheels.given:
        wheels.check()  # before anything is compiled or read
    return SelfcalSettings(
        d_m,
        b_m,
        wheels=wheels,
        scan_topic=kw["scan_topic"],
        scan_frame=kw["scan_frame"],
        intervals=options,
        **common,
    )


def _selfcal(paths, settings, bags: bool, intervals_out, as_json):
    """The self-calibration (:func:`umbmark.realrobot.selfcal_settings.selfcal_recordings`) with
    progress bars; the matched intervals written when ``--intervals-out`` asks."""
    from umbmark.realrobot.selfcal_settings import selfcal_recordings

    if bags:
        start_kernels()
    with Bars(enabled=not as_json) as bars:
        rep = selfcal_recordings(list(paths), settings, progress=bars)
    if bags and intervals_out:
        from umbmark.io.intervals_csv import write_intervals_csv

        write_intervals_csv(rep.intervals, intervals_out)
    return rep
