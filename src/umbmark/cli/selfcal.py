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
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from umbmark.cli.app import app, cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.cli.bags import Bars, interval_options, kind_of, start_kernels, stream_text
from umbmark.cli.command_config import SELFCAL, KeyframesConfig, SelfcalConfig
from umbmark.cli.config import config_options, option_of
from umbmark.cli.guard import skip_check_option
from umbmark.cli.history import history_options, print_recorded, record_if_requested, refuse_if_recorded
from umbmark.cli.kinematic import joints_help, kinematic_options, refuse_kind_options
from umbmark.errors import InputError
from umbmark.kinds import kind_named
from umbmark.model.defaults import TICK_MODES

if TYPE_CHECKING:
    from umbmark.realrobot.selfcal import SelfcalReport
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

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


def _next_command(paths: Sequence[str], save: str | None, d_m: float, b_m: float, flags: list[str]) -> tuple[str, str]:
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


def _ci(lo_hi: Sequence[float], digits: int) -> str:
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


_option = option_of(SelfcalConfig)


@app.command("selfcal")
@click.argument("paths", nargs=-1, required=True, metavar="INPUT...")
@kinematic_options
@_option("--scan-topic", show_default=True, help="Bag: the sensor_msgs/LaserScan topic.")
@_option(
    "--joints",
    metavar="LEFT,RIGHT",
    help=joints_help("Bag: JointState names of the wheels"),
)
@_option("--joint-topic", show_default=True, help="Bag: JointState topic.")
@_option("--ticks-topic", help="Bag: topic with encoder counts (instead of --joints).")
@_option("--left-field", help="Bag: field of the left count, e.g. data[0].")
@_option("--right-field", help="Bag: field of the right count, e.g. data[1].")
@_option("--pulses-per-wheel-rev", type=float, help="Bag: encoder pulses per wheel revolution.")
@_option(
    "--ticks",
    type=click.Choice(TICK_MODES),
    show_default=True,
    help="Bag: encoder counts are a running counter or per-message counts.",
)
@_option(
    "--odom-topic",
    help="Bag: nav_msgs/Odometry of the wheels (instead of --joints), turned into wheel travel "
    "with the nominal geometry.",
)
@_option("--wheel-diameter-mm", type=float, help="Nominal wheel diameter.")
@_option("--wheelbase-mm", type=float, help="Nominal wheelbase.")
@_option("--wheel-radius-m", type=float, help="Nominal wheel radius (instead of --wheel-diameter-mm).")
@_option("--wheel-separation-m", type=float, help="Nominal wheel separation (instead of --wheelbase-mm).")
@_option(
    "--sensor-pose",
    metavar="X_MM,Y_MM,YAW_DEG",
    help="Bag: the lidar pose the scan matching starts from (default: /tf_static, else zero).",
)
@_option("--base-frame", help="Bag: the robot frame in /tf_static (default base_link, base_footprint).")
@_option("--scan-frame", help="Bag: refuse scans in another frame than this.")
@_option(
    "--keyframe-mm",
    type=float,
    show_default=True,
    help="Bag: the next keyframe after this much travel (0: no travel condition; all four 0: every scan).",
)
@_option("--keyframe-deg", type=float, show_default=True, help="Bag: ... or this much turn.")
@_option("--keyframe-s", type=float, show_default=True, help="Bag: ... or this much time (0: none).")
@_option("--keyframe-min-s", type=float, show_default=True, help="Bag: least time between keyframes.")
@_option(
    "--max-wheel-gap-s",
    type=float,
    show_default=True,
    help="Bag: scans in longer gaps of the wheel data are not used.",
)
@_option(
    "--coarse",
    is_flag=True,
    help="Bag: search widely before each scan match (odometry far off, or keyframes far apart).",
)
@_option(
    "--scan-delay",
    show_default=True,
    metavar="auto|off|SECONDS",
    help="Bag: how late the scans are stamped against the wheel data. auto estimates it (the "
    "scan-matched turns against the wheels' turns, within +-0.3 s) and subtracts it from the scans' "
    "stamps; off (or 0) takes the stamps as recorded; a number of seconds is applied as given. "
    "Printed per bag; JSON key scan_delay.",
)
@_option("--min-intervals", type=click.IntRange(min=3), show_default=True, help="Fewest matched intervals.")
@_option("--keep-outliers", is_flag=True, help="Fit every interval (no outlier rejection).")
@_option(
    "--wheel-jitter/--no-wheel-jitter",
    show_default=True,
    help="Model errors in the wheel data from their stamps' jitter against the scans' (estimated with the "
    "noise; bags, and intervals files with the wheel-rate columns; JSON key wheel_jitter_ms). Taken as "
    "exact, such errors make the wheels and turns come out small.",
)
@_option(
    "--save",
    type=click.Path(dir_okay=False),
    help="Also write the JSON result to this file (input of `umbmark export`).",
)
@_option(
    "--intervals-out",
    type=click.Path(dir_okay=False),
    help="Bag: write the matched intervals as an intervals file (CSV).",
)
@_option(
    "--window",
    metavar="DURATION",
    help="Also cut each input into windows of about DURATION (10min, 600s, 1h) and self-calibrate each "
    "(JSON key windows); with --record, each window is recorded with its own date (for `umbmark drift`).",
)
@_option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@skip_check_option
@history_options
@config_options
def selfcal_cmd(paths: tuple[str, ...], **params: Any) -> None:
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
    cfg = SelfcalConfig.from_params(params)
    window_s = None
    if cfg.outputs.window is not None:
        from umbmark.cli.selfcal_windows import window_seconds

        window_s = window_seconds(cfg.outputs.window)
    kind = kind_named(cfg.kind.kinematics)
    if not kind.differential:
        from umbmark.cli.kinematic import kinematic_selfcal_cmd

        if not cfg.fit.wheel_jitter:
            raise InputError(
                f"--no-wheel-jitter: the self-calibration of a {kind.noun} takes the joint data "
                "as exact already (it models no jitter of their stamps; a differential drive's does)"
            )
        kinematic_selfcal_cmd(paths, cfg, window_s)
        return
    robot, record, db = cfg.history.robot, cfg.history.record, cfg.history.db
    inputs = functools.cache(lambda: kind_of(paths))
    settings = selfcal_settings(cfg, lambda: {inputs()})
    refuse_if_recorded(robot, record, db, kind="selfcal", method="selfcal", paths=paths)  # windows too: they cover it
    bags = inputs() == "bags"
    rep = _selfcal(paths, settings, bags, cfg.outputs.intervals_out, cfg.outputs.as_json)
    d = rep.to_dict()
    rec: dict | list | None = None
    if window_s is not None:
        from umbmark.cli.selfcal_windows import selfcal_windows_cmd

        d["windows"], rec = selfcal_windows_cmd(rep, window_s, settings.fit_options, robot, record, db)
    if cfg.outputs.save:
        from umbmark.io.atomic import write_json

        write_json(cfg.outputs.save, d)
    if record and window_s is None:
        from umbmark.history import file_sha256

        fields = rep.history_fields(kind="selfcal", file_hash=file_sha256)
        rec = record_if_requested(robot, record, db, **fields)
    if cfg.outputs.as_json:
        emit_json(d if rec is None else {**d, "history": rec})
        return
    if is_quiet():
        return
    d_m, b_m = settings.wheel_diameter_m, settings.wheelbase_m
    _print_report(d, *_next_command(paths, cfg.outputs.save, d_m, b_m, _fit_flags(cfg, bags)))
    if window_s is not None:
        from umbmark.cli.selfcal_windows import print_windows

        print_windows(d["windows"])
    print_recorded(rec)


# the options that read bags, in the order the next command names them
_BAG_OPTIONS = (
    "scan_topic", "joints", "joint_topic", "ticks_topic", "left_field", "right_field", "odom_topic",
    "pulses_per_wheel_rev", "sensor_pose", "base_frame", "scan_frame", "intervals_out", "ticks", "scan_delay",
    "keyframe_mm", "keyframe_deg", "keyframe_s", "keyframe_min_s", "max_wheel_gap_s", "coarse",
)  # fmt: skip


def _bag_flags(cfg: SelfcalConfig) -> list[str]:
    """The options that read the bags given other values than their defaults, as flags (for the
    command shown as the next step)."""
    given, default = cfg.params(), SelfcalConfig.defaults()
    numbers = set(KeyframesConfig.defaults())
    out = []
    for name in _BAG_OPTIONS:
        v = given[name]
        if name == "scan_delay" and str(v).strip().lower() == default[name]:
            continue
        if v == default[name]:
            continue
        flag = f"--{name.replace('_', '-')}"
        if isinstance(v, bool):
            out.append(flag)
        elif name in numbers:
            out.append(f"{flag} {v:g}")
        else:
            out.append(f"{flag} {shlex.quote(str(v))}")
    return out


def _fit_flags(cfg: SelfcalConfig, bags: bool) -> list[str]:
    """The options of the bags and of the fit given other values than their defaults, as flags."""
    flags = _bag_flags(cfg) if bags else []
    if cfg.fit.keep_outliers:
        flags.append("--keep-outliers")
    if cfg.fit.min_intervals != SELFCAL.fit.min_intervals:
        flags.append(f"--min-intervals {cfg.fit.min_intervals}")
    return flags + ([] if cfg.fit.wheel_jitter else ["--no-wheel-jitter"])


def selfcal_settings(cfg: SelfcalConfig, kinds: Collection[str] | Callable[[], Collection[str]]) -> SelfcalSettings:
    """The :class:`~umbmark.realrobot.selfcal_settings.SelfcalSettings` of selfcal's options for
    a differential drive, checked before anything is read: no option of another kind, the
    nominal geometry, no bag option when every input is an intervals file, the interval options
    and the wheel data's source when one is a bag.

    Parameters
    ----------
    cfg : SelfcalConfig
        The options.
    kinds : collection of str, or a callable returning one
        The inputs' kinds (``bags``, ``intervals``); a callable is asked once the geometry is
        checked.

    Raises
    ------
    InputError
        As the checks above.
    """
    from umbmark.cli.options import nominal_m, wheel_source
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

    refuse_kind_options(dict(cfg.kind.options))
    d_m, b_m = nominal_m(cfg.nominal.params())
    given = set(kinds() if callable(kinds) else kinds)
    fit = cfg.fit
    skip = frozenset(fit.skip_check)  # the command's own: applied around it
    if "bags" not in given:
        flags = _bag_flags(cfg)
        if flags:
            raise InputError(f"{flags[0].split()[0]} reads bags; the inputs are intervals files")
        return SelfcalSettings(
            d_m, b_m, reject_outliers=not fit.keep_outliers, time_jitter=fit.wheel_jitter, skip_checks=skip
        )
    options = interval_options(cfg.keyframes, cfg.scans, cfg.fit.min_intervals)
    wheels = wheel_source(cfg.wheels.params())
    if wheels.given:
        wheels.check()  # before anything is compiled or read
    return SelfcalSettings(
        d_m,
        b_m,
        wheels=wheels,
        scan_topic=cfg.scans.scan_topic,
        scan_frame=cfg.scans.scan_frame,
        intervals=options,
        reject_outliers=not fit.keep_outliers,
        time_jitter=fit.wheel_jitter,
        skip_checks=skip,
    )


def _selfcal(
    paths: tuple[str, ...], settings: SelfcalSettings, bags: bool, intervals_out: str | None, as_json: bool
) -> SelfcalReport:
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
