"""Real-robot commands: ``replay``, ``bag-info``, ``convert``, ``export``.

The library does the work (:mod:`umbmark.realrobot.replay`, :mod:`umbmark.io`); these commands
parse the options, call it, and print its result's ``to_dict()`` or a table made from it. No
numerical module is imported before a command runs.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:
    from umbmark.realrobot.results import MultiReplayReport, PooledReport, ReplayReport

from umbmark.cli.app import LOG_FORMAT_CHOICES, app, cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.cli.config import config_options
from umbmark.cli.export_kinds import (
    edited_file_options,
    emit_export,
    export_kinematic,
    kinematic_json,
    refuse_edited_files,
)
from umbmark.cli.guard import skip_check_option
from umbmark.cli.history import (
    history_options,
    print_recorded,
    record_if_requested,
    record_report_if_requested,
    refuse_if_recorded,
)
from umbmark.cli.kinematic import (
    export_formats,
    kinematic_options,
    own_controllers,
    own_kinds,
    refuse_kind_options,
    steered_titles,
)
from umbmark.cli.progress import progress, track
from umbmark.errors import InputError
from umbmark.kinds import DEFAULT_KIND, kind_named

__all__ = ["REPLAY_METHOD_CHOICES", "log_options", "replay", "bag_info_cmd", "convert", "export"]

# umbmark.realrobot.replay.method_names(), written out so that building the command line imports
# no numerical module (tests/test_replay.py checks it against the library)
REPLAY_METHOD_CHOICES = ("bf", "exact", "lsq")


def _mm(v: float | None) -> float | None:
    return None if v is None else v * 1e3


def log_options(f):
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
        click.option(
            "--format",
            "log_format",
            type=click.Choice(LOG_FORMAT_CHOICES),
            default="auto",
            show_default=True,
            help="Log format: an optiodom data-set folder, a generic CSV log, a ROS 1/2 bag.",
        ),
        click.option(
            "--side-mm",
            type=float,
            default=None,
            help="Square side: the runs are UMBmark squares (optiodom: from the metadata).",
        ),
        click.option("--wheel-diameter-mm", type=float, default=None, help="Nominal wheel diameter (CSV, bags)."),
        click.option(
            "--wheel-radius-m", type=float, default=None, help="Nominal wheel radius, ROS's wheel_radius (instead)."
        ),
        click.option("--left-diameter-mm", type=float, default=None, help="Nominal left wheel diameter."),
        click.option("--right-diameter-mm", type=float, default=None, help="Nominal right wheel diameter."),
        click.option("--wheelbase-mm", type=float, default=None, help="Nominal wheelbase (CSV, bags)."),
        click.option(
            "--wheel-separation-m",
            type=float,
            default=None,
            help="Nominal wheelbase, ROS's wheel_separation (instead).",
        ),
        click.option(
            "--pulses-per-wheel-rev",
            type=float,
            default=None,
            help="Encoder pulses per wheel revolution (CSV, bag ticks).",
        ),
        click.option(
            "--ticks",
            type=click.Choice(["cumulative", "incremental"]),
            default="cumulative",
            show_default=True,
            help="Encoder counts are a running counter or per-sample counts.",
        ),
        click.option("--joints", default=None, metavar="LEFT,RIGHT", help="Bag: JointState names of the wheels."),
        click.option("--joint-topic", default="/joint_states", show_default=True, help="Bag: JointState topic."),
        click.option("--ticks-topic", default=None, help="Bag: topic with encoder counts."),
        click.option("--left-field", default=None, help="Bag: field of the left count, e.g. data[0]."),
        click.option("--right-field", default=None, help="Bag: field of the right count, e.g. data[1]."),
        click.option(
            "--odom-topic",
            default=None,
            help="Bag: nav_msgs/Odometry as the wheels (its increments through the nominal geometry).",
        ),
        click.option("--gt-topic", default=None, help="Bag: ground truth (PoseStamped, Odometry or /tf)."),
        click.option("--gt-frame", default=None, help="Bag, /tf ground truth: the tracked child frame."),
        click.option("--gt-parent", default=None, help="Bag, /tf ground truth: its parent frame (optional)."),
        click.option(
            "--ranges",
            default=None,
            metavar="A-B,C-D",
            help="Bag: cut runs at these time ranges (seconds from the first wheel sample).",
        ),
        click.option("--split-stops", is_flag=True, help="Bag: cut runs where both wheels stand still."),
        click.option(
            "--stop-s",
            type=float,
            default=1.0,
            show_default=True,
            help="Bag: the stillness (seconds) that ends a run with --split-stops.",
        ),
        click.option(
            "--time-offset",
            default=None,
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


def _load(paths, log_format, kw):
    from umbmark.cli.options import read_options
    from umbmark.io.load import load_logs

    return load_logs(paths, log_format, read_options(kw))


def _datasets(paths, log_format, kw):
    """Each PATH is a data set, except CSV files and bags: all CSV files given form one data
    set, and so do all bags given (the runs of one test)."""
    paths = list(paths)
    if log_format in ("csv",) or (
        log_format == "auto" and all(Path(p).is_file() and Path(p).suffix.lower() == ".csv" for p in paths)
    ):
        with progress(f"reading {len(paths)} CSV log(s)"):
            return [_load(paths, "csv", kw)]
    if len(paths) > 1 and _all_bags(paths, log_format):
        with progress(f"reading {len(paths)} bags"):
            return [_load(paths, "bag", kw)]
    return [_load([p], log_format, kw) for p in track(paths, "reading logs")]


def _all_bags(paths, log_format) -> bool:
    if log_format == "bag":
        return True
    if log_format != "auto":
        return False
    from umbmark.io.load import detect_format

    return all(detect_format(p) == "bag" for p in paths)


def _escape(text) -> str:
    from rich.markup import escape

    return escape(str(text))


def _print_report(rep) -> None:
    """A :class:`~umbmark.realrobot.results.ReplayReport` as tables."""
    c = console()
    sq = rep.kind == "square"
    c.print(
        f"[bold]{_escape(rep.dataset)}[/bold] ({rep.format}, {len(rep.runs)} runs, "
        f"{'square ' + format(rep.side_m * 1e3, '.0f') + ' mm' if sq else 'general path'}), method "
        f"[bold]{_escape(rep.method)}[/bold]"
    )
    h = rep.heldout.summary if rep.heldout is not None else None
    rows = []
    if sq:
        rows.append(
            [
                "E_max,syst [mm]",
                fmt(_mm(rep.before.emax_syst_m)),
                fmt(_mm(rep.after.emax_syst_m)),
                fmt(None if h is None else _mm(h.emax_syst_m)),
            ]
        )
    rows += [
        [
            "end position RMS [mm]",
            fmt(_mm(rep.before.end_position_rms_m)),
            fmt(_mm(rep.after.end_position_rms_m)),
            fmt(None if h is None else _mm(h.end_position_rms_m)),
        ],
        [
            "along-path position RMS [mm]",
            fmt(_mm(rep.before.path_position_rms_m)),
            fmt(_mm(rep.after.path_position_rms_m)),
            fmt(None if h is None else _mm(h.path_position_rms_m)),
        ],
    ]
    c.print(table("Replayed odometry vs ground truth", ["", "nominal", "calibrated (in-sample)", "held out"], rows))
    if rep.heldout is not None and rep.heldout.reason:
        c.print(f"held out: {rep.heldout.reason}")
    n, cal = rep.nominal, rep.calibration
    g = cal.geometry
    cal_rows = [
        ["D_L [mm]", fmt(n.diameter_left_m * 1e3, 4), fmt(g.diameter_left_m * 1e3, 4)],
        ["D_R [mm]", fmt(n.diameter_right_m * 1e3, 4), fmt(g.diameter_right_m * 1e3, 4)],
        ["wheelbase [mm]", fmt(n.wheelbase_m * 1e3, 3), fmt(g.wheelbase_m * 1e3, 3)],
        ["E_d = D_R/D_L", "1", fmt(cal.ed, 6)],
        ["E_b", "1", fmt(cal.eb, 6)],
        ["c_left / c_right", "1 / 1", f"{cal.c_left:.6f} / {cal.c_right:.6f}"],
        [
            "wheelbase / mean diameter",
            fmt(n.wheelbase_m / n.diameter_avg_m, 4),
            fmt(cal.wheelbase_per_mean_diameter, 4),
        ],
    ]
    lsq = cal.lsq
    if lsq is not None:
        cal_rows.append(["fitted", "", lsq.fitted_parameters])
    c.print(table("Calibration", ["", "nominal", "corrected"], cal_rows))
    if lsq is not None:
        c.print(f"scale: {lsq.scale_reason}")
        if lsq.marker_offset_m is not None and lsq.marker_offset_std_m is not None:
            o = [v * 1e3 for v in lsq.marker_offset_m]
            e = [v * 1e3 for v in lsq.marker_offset_std_m]
            c.print(
                f"tracked point offset from the axle midpoint: x {o[0]:.1f} +- {e[0]:.1f} mm, "
                f"y {o[1]:.1f} +- {e[1]:.1f} mm (robot frame)"
            )
        s = rep.std
        if s is not None:
            c.print(
                f"jackknife std: D_L {s.diameter_left_m * 1e3:.3f} mm, D_R {s.diameter_right_m * 1e3:.3f} mm, "
                f"b {s.wheelbase_m * 1e3:.3f} mm, E_d {s.ed:.5f}"
            )
    from rich.markup import escape

    for o in rep.time_offset:
        est = "not estimated" if o["estimated_s"] is None else f"estimated {o['estimated_s'] * 1e3:.1f} ms"
        where = o.get("bag") or f"{o.get('log')} {o.get('run')}"
        c.print(
            f"ground truth late by: {est}, {o['applied_s'] * 1e3:.1f} ms subtracted from its stamps "
            f"({escape(str(where))})"
        )
    from umbmark.cli.bags import stream_text

    for o in rep.wheel_stream:
        if o["clock"] != "as recorded" or o["kept"] != o["messages"]:
            c.print(escape(f"wheel data ({o['bag']}): {stream_text(o)}"))
    for w in rep.warnings:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")


def _print_pooled(rep) -> None:
    """A :class:`~umbmark.realrobot.results.PooledReport` as a table and a line."""
    c = console()
    rows = [
        [
            p.dataset,
            fmt(_mm(p.before.end_position_rms_m)),
            fmt(_mm(p.after.end_position_rms_m)),
            fmt(None if p.heldout is None else _mm(p.heldout.end_position_rms_m)),
        ]
        for p in rep.per_dataset
    ]
    c.print(
        table(
            "lsq fitted to all data sets: end-position RMS [mm]",
            ["data set", "nominal", "pooled fit", "held out (fit on the others)"],
            rows,
        )
    )
    g, cal = rep.calibration.geometry, rep.calibration
    c.print(
        f"D_L = {g.diameter_left_m * 1e3:.3f} mm, D_R = {g.diameter_right_m * 1e3:.3f} mm, wheelbase = "
        f"{g.wheelbase_m * 1e3:.3f} mm, E_d = {cal.ed:.6f}, "
        f"fitted: {cal.lsq.fitted_parameters}"
    )


def _print_across(rep) -> None:
    """The across-data-set rows of a :class:`~umbmark.realrobot.results.MultiReplayReport`."""
    rows = [
        [a.calibrated_on, a.evaluated_on, fmt(_mm(a.evaluation.emax_syst_m)), fmt(_mm(a.evaluation.end_position_rms_m))]
        for a in rep.across
    ]
    console().print(
        table(
            "Held out across data sets",
            ["calibrated on", "evaluated on", "E_max,syst [mm]", "end position RMS [mm]"],
            rows,
        )
    )


def _print_stream(rep) -> None:
    """A :class:`~umbmark.realrobot.results.StreamReport` as a table and lines."""
    e, g = rep.end_pose, rep.end_truth or (None, None, None)
    rows = [
        ["x [mm]", fmt(e[0] * 1e3), fmt(_mm(g[0]))],
        ["y [mm]", fmt(e[1] * 1e3), fmt(_mm(g[1]))],
        ["theta [deg]", fmt(math.degrees(e[2]), 3), fmt(None if g[2] is None else math.degrees(g[2]), 3)],
    ]
    c = console()
    c.print(
        table(
            f"{rep.dataset}: {rep.samples} samples, {rep.duration_s:.1f} s, streamed in {rep.chunks} chunks",
            ["end pose", "odometry (nominal)", "ground truth"],
            rows,
        )
    )
    c.print(
        f"end position error {fmt(_mm(rep.end_position_error_m))} mm, along-path position RMS "
        f"{fmt(_mm(rep.path_position_rms_m))} mm"
    )
    if rep.poses_out is not None:
        c.print(f"wrote {len(rep.kept)} poses to {rep.poses_out}", markup=False, soft_wrap=True)


@app.command()
@click.argument("paths", nargs=-1, required=True, metavar="DATASET...")
@click.option(
    "--method",
    type=click.Choice(REPLAY_METHOD_CHOICES),
    default="bf",
    show_default=True,
    help="bf: the paper's correction; exact (when available); lsq: general-path least squares.",
)
@log_options
@click.option(
    "--gt-scan-topic",
    default=None,
    metavar="TOPIC",
    help="Bag: the robot's lidar as the ground truth (LaserScan topic): each run's first scan after "
    "the wheels stop registered against its last scan before they start (the robot at rest).",
)
@click.option(
    "--sensor-pose",
    default=None,
    metavar="X_MM,Y_MM,YAW_DEG|SELFCAL.json",
    help="--gt-scan-topic: the lidar's mounting pose in the robot frame, or the sensor_pose of a "
    "`umbmark selfcal` JSON (default: the bag's /tf_static).",
)
@click.option(
    "--imu-topic",
    default=None,
    metavar="TOPIC",
    help="Bag: the gyro (sensor_msgs/Imu angular_velocity.z) as a rotation reference: the effective "
    "wheelbase (wheel_separation_multiplier; skid-steer robots too) from the turns on the spot, its "
    "bias removed at rest; the gyro's scale from the lidar (--gt-scan-topic) or --full-turns. "
    "Without a ground truth (or a square side), only this (JSON block `gyro`).",
)
@click.option(
    "--full-turns",
    is_flag=True,
    help="--imu-topic: every spin on the spot was a whole number of revolutions (counted): the gyro's scale from them.",
)
@click.option(
    "--pool", is_flag=True, help="lsq: fit one geometry to all data sets together (held out: leave-one-data-set-out)."
)
@click.option(
    "--lsq-mode",
    type=click.Choice(["auto", "sampled", "end"]),
    default="auto",
    show_default=True,
    help="lsq: minimise errors at poses sampled along the path, or end-pose errors only.",
)
@click.option(
    "--scale",
    type=click.Choice(["auto", "fit", "fixed"]),
    default="auto",
    show_default=True,
    help="lsq: fit D_L, D_R, b (fit), or E_d and b with D_avg at nominal (fixed).",
)
@click.option(
    "--heading-weight-m",
    type=float,
    default=0.5,
    show_default=True,
    help="lsq: metres of position error worth one radian of heading error.",
)
@click.option(
    "--points-per-run",
    type=click.IntRange(min=1),
    default=100,
    show_default=True,
    help="lsq, sampled mode: poses compared per run.",
)
@click.option(
    "--fit-marker-offset/--no-fit-marker-offset",
    default=None,
    help="lsq, sampled mode: also fit where the tracked point sits relative to the axle midpoint "
    "[default: where the data determine it, with a warning saying so].",
)
@click.option("--no-heldout", is_flag=True, help="Skip the held-out (leave-one-run-out) figures.")
@click.option(
    "--noise",
    is_flag=True,
    help="Also estimate the odometry's random error (each wheel's variance per metre) from the ground "
    "truth's residuals over intervals of 0.1, 0.25, 0.5 and 1 s, with the ground truth's timing and each "
    "run's time offset (JSON odometry_noise_strides); where the per-metre model holds at every length, "
    "odometry_noise (export's covariances), else a warning.",
)
@click.option(
    "--window",
    metavar="DURATION",
    default=None,
    help="Also group the runs of a long recording (a bag or CSV log cut into runs) into windows of about "
    "DURATION (10min, 600s, 1h) by the recording's clock and calibrate each (JSON key windows); with "
    "--record, each window is recorded with its own date (for `umbmark drift`).",
)
@click.option(
    "--save",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write the JSON report to this file (input of `umbmark export`).",
)
@click.option(
    "--stream",
    is_flag=True,
    help="Replay ONE long CSV log in bounded memory with the given geometry: "
    "end pose and errors only (no calibration).",
)
@click.option("--decimate", type=click.IntRange(min=1), default=None, help="--stream: keep every N-th pose.")
@click.option(
    "--poses-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="--stream: write the kept poses (CSV) to this file.",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@kinematic_options
@history_options
@config_options
def replay(
    paths,
    method,
    log_format,
    pool,
    lsq_mode,
    scale,
    heading_weight_m,
    points_per_run,
    fit_marker_offset,
    no_heldout,
    save,
    as_json,
    window=None,
    noise=False,
    robot=None,
    record=False,
    db=None,
    stream=False,
    decimate=None,
    poses_out=None,
    **kw,
):
    """Replay real-robot logs, calibrate, and compare the odometry before and after.

    Each DATASET is an optiodom data-set folder; or (all together, the runs of one test) ROS
    bags, or CSV log files. The logged wheel increments (bags: joint states, encoder counts or
    the robot's own nav_msgs/Odometry) are replayed with the nominal geometry and with the
    calibrated one; the errors are measured against the logged ground truth, or against the
    robot's own lidar scans at rest before and after each run (--gt-scan-topic); --imu-topic adds
    the gyro's verdict on the wheelbase. Square runs (UMBmark) are benchmarked (E_max,syst;
    cw/ccw from the odometry's total turn). Held-out figures: leave-one-run-out, and across data
    sets when several are given.

    \b
    Examples:
      umbmark replay data/optiodom/square/230620202144 --method bf
      umbmark replay calibration_bag --joints left_wheel_joint,right_wheel_joint \\
        --gt-topic /mocap/robot/pose --split-stops --side-mm 2000 \\
        --wheel-radius-m 0.05 --wheel-separation-m 0.30 --method exact
      umbmark replay run1_bag run2_bag run3_bag --odom-topic /odom --gt-topic /mocap/pose \\
        --side-mm 2000 --wheel-diameter-mm 100 --wheelbase-mm 300 --method exact
      umbmark replay squares_bag --gt-scan-topic /scan --sensor-pose 35,0,0 --split-stops \\
        --joints left_wheel_joint,right_wheel_joint --side-mm 2000 \\
        --wheel-diameter-mm 150 --wheelbase-mm 340 --method exact
      umbmark replay spins_bag --imu-topic /imu --joints left_wheel_joint,right_wheel_joint \\
        --wheel-radius-m 0.1 --wheel-separation-m 0.4
    """
    if not (math.isfinite(heading_weight_m) and heading_weight_m >= 0):
        raise InputError(f"--heading-weight-m must be >= 0, got {heading_weight_m!r}")
    kinematics = kw.pop("kinematics", DEFAULT_KIND)
    window_s = _window_s(window, kinematics, pool, stream, noise)
    if not kind_named(kinematics).differential:
        from umbmark.cli.kinematic import kinematic_replay_cmd

        kinematic_replay_cmd(kinematics, paths, method, save, as_json, record, kw)
        return
    refuse_kind_options(kw, pop=True)
    from umbmark._files import check_distinct_inputs

    check_distinct_inputs([p for p in paths if Path(p).exists()])
    if not stream:  # the windows of a recording cover it: refused with it
        refuse_if_recorded(robot, record, db, kind="replay", method=method, paths=paths, each=True)
    if stream or decimate or poses_out:
        if not stream:
            raise InputError("--decimate and --poses-out work with --stream")
        if poses_out and not decimate:
            raise InputError("--poses-out needs --decimate N (keep the pose after every N-th sample)")
        _stream(paths, log_format, decimate, poses_out, as_json, kw)
        return
    gyro = None
    if kw.get("imu_topic") is not None or kw.get("full_turns"):
        gyro = _gyro(paths, log_format, kw)
        if kw.get("gt_topic") is None and (kw.get("gt_scan_topic") is None or kw.get("side_mm") is None):
            if window_s is not None:
                raise InputError(
                    "--window needs runs with a ground truth (--gt-topic, or --gt-scan-topic and --side-mm)"
                )
            _emit_gyro(gyro, save, as_json, (robot, record, db), list(paths))
            return
    scan_truth = None
    if kw.get("gt_scan_topic") is not None or kw.get("sensor_pose") is not None:
        sets, scan_truth = _scan_truth(paths, log_format, kw)
    else:
        sets = _datasets(paths, log_format, kw)
    lsq_opts = {
        "mode": lsq_mode,
        "scale": scale,
        "heading_weight_m": heading_weight_m,
        "points_per_run": points_per_run,
        "fit_offset": fit_marker_offset,
    }
    rep = _calibrate_sets(sets, method, pool, lsq_opts, not no_heldout)
    if scan_truth is not None:
        rep = _with_warnings(rep, scan_truth.warnings)
    d = _report_dict(rep, scan_truth, gyro)
    rec, noise_fits = _replay_extras(
        d, sets, rep, (window_s, noise), (method, lsq_opts, not no_heldout), list(paths), (robot, record, db)
    )
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if window_s is None:
        rec = record_report_if_requested(robot, record, db, rep, list(paths), kind="replay", method=method)
    if as_json:
        for w in dict.fromkeys(_json_warnings(d)):  # on stderr too, as every command's warnings
            click.echo(f"warning: {cli_message(w)}", err=True)
        emit_json(d if rec is None else {**d, "history": rec})
        return
    if not is_quiet():
        _print_replay(rep, rec, scan_truth, gyro, d.get("windows"), noise_fits)


def _calibrate_sets(sets, method, pool, lsq_opts, heldout) -> ReplayReport | MultiReplayReport | PooledReport:
    """The data sets replayed and calibrated: pooled (``--pool``, lsq) or each on its own."""
    from umbmark.realrobot.replay import pooled_report, replay_report

    if not pool:
        with progress("replaying and calibrating"):
            return replay_report(sets, method, lsq_opts, heldout=heldout)
    if method != "lsq":
        raise InputError("--pool works with --method lsq")
    with progress("fitting and replaying"):
        rep = pooled_report(sets, lsq_opts, heldout=heldout)
    for w in (w for ds in sets for w in ds.meta.get("warnings") or ()):  # the readers' (a pooled report has none)
        click.echo(f"warning: {cli_message(w)}", err=True)
    return rep


def _window_s(window, kinematics, pool, stream, noise=False) -> float | None:
    """``--window``'s length [s], or None; ``--window`` and ``--noise`` refused with the options
    they do not go with."""
    for asked, name in ((window is not None, "--window"), (noise, "--noise")):
        for given, flag in (
            (not kind_named(kinematics).differential, f"--kinematics {kinematics}"),
            (pool, "--pool"),
            (stream, "--stream"),
        ):
            if asked and given:
                raise InputError(f"{name} does not go with {flag}")
    if window is None:
        return None
    from umbmark.cli.selfcal_windows import window_seconds

    return window_seconds(window)


def _replay_extras(d, sets, rep, asked, calibration, paths, history) -> tuple[list | None, list | None]:
    """``--window`` and ``--noise``: the windows calibrated (recorded when asked) and the noise
    estimated, into the JSON ``d``; the windows' records and the noise's fits (or None)."""
    (window_s, noise), (method, lsq_opts, heldout) = asked, calibration
    rec, fits = None, None
    if noise:
        from umbmark.cli.replay_noise import replay_noise_cmd

        with progress("estimating the odometry's noise"):
            fits = replay_noise_cmd(sets, rep, d)
    if window_s is not None:
        from umbmark.cli.replay_windows import replay_windows_cmd

        with progress("calibrating the windows"):
            d["windows"], rec = replay_windows_cmd(sets, window_s, method, lsq_opts, heldout, paths, history)
    return rec, fits


def _print_replay(rep, rec, scan_truth, gyro, windows=None, noise_fits=None) -> None:
    """A replay's report as tables: a pooled fit, one data set's or several's; the lidar's and
    the gyro's lines; the noise's and the windows' tables."""
    from umbmark.realrobot.results import MultiReplayReport, PooledReport

    if isinstance(rep, PooledReport):
        _print_pooled(rep)
        print_recorded(rec)
        return
    print_recorded(rec)
    if isinstance(rep, MultiReplayReport):
        for r in rep.reports:
            _print_report(r)
        _print_across(rep)
    else:
        _print_report(rep)
    if scan_truth is not None:
        _print_scan_truth(scan_truth)
    if gyro is not None:
        _print_gyro(gyro)
    if noise_fits:
        from umbmark.cli.replay_noise import print_replay_noise

        print_replay_noise(noise_fits)
    if windows is not None:
        from umbmark.cli.replay_windows import print_replay_windows

        print_replay_windows(windows)


def _json_warnings(d) -> list[str]:
    """Every ``warnings`` entry of a replay's JSON, its data sets' and blocks' included, in order."""
    out: list[str] = []
    if isinstance(d, dict):
        for k, v in d.items():
            if k == "warnings" and isinstance(v, list):
                out += [w for w in v if isinstance(w, str)]
            else:
                out += _json_warnings(v)
    elif isinstance(d, list):
        for v in d:
            out += _json_warnings(v)
    return out


def _scan_truth(paths, log_format, kw):
    """``replay --gt-scan-topic``: the data sets with each run's end pose measured by the lidar."""
    from umbmark.cli.options import wheel_source
    from umbmark.realrobot.scan_truth import attach_scan_truth, check_sensor_pose, parse_sensor_pose

    topic = kw.get("gt_scan_topic")
    if topic is None:
        raise InputError("--sensor-pose works with --gt-scan-topic (the lidar as the ground truth)")
    if kw.get("gt_topic") is not None:
        raise InputError("give one ground truth: --gt-topic or --gt-scan-topic, not both")
    if log_format not in ("auto", "bag"):
        raise InputError("--gt-scan-topic reads the scans of ROS bags (--format bag)")
    pose, pose_src = (None, "given") if kw.get("sensor_pose") is None else parse_sensor_pose(kw["sensor_pose"])
    if pose is not None and pose_src == "given":
        for w in check_sensor_pose(pose):
            click.echo(f"warning: {cli_message(w)}", err=True)
    sets = _datasets(paths, log_format, kw)
    with progress("registering each run's scans"):
        return attach_scan_truth(sets, topic, sensor_pose=pose, sensor_pose_source=pose_src, wheels=wheel_source(kw))


def _with_warnings(rep, warnings):
    """A replay report with more warnings first (each data set's report of several)."""
    from dataclasses import replace

    from umbmark.realrobot.results import MultiReplayReport, ReplayReport

    if not warnings:
        return rep
    if isinstance(rep, ReplayReport):
        return replace(rep, warnings=tuple(warnings) + tuple(rep.warnings))
    if isinstance(rep, MultiReplayReport):
        return replace(rep, reports=tuple(_with_warnings(r, warnings) for r in rep.reports))
    for w in warnings:  # a pooled report has no warnings of its own
        click.echo(f"umbmark: warning: {cli_message(w)}", err=True)
    return rep


def _report_dict(rep, scan_truth, gyro=None) -> dict:
    """The JSON of a replay report, with the lidar ground truth's ``scan_truth`` block and the
    gyro's ``gyro`` block."""
    d = rep.to_dict()
    if scan_truth is not None:
        d["scan_truth"] = scan_truth.to_dict()
    if gyro is not None:
        d["gyro"] = gyro.to_dict()
    return d


def _print_scan_truth(st) -> None:
    """One line on how the lidar measured the runs."""
    kept = [r for r in st.runs if r.displacement is not None]
    x, y, yaw = st.sensor_pose
    line = (
        f"lidar ground truth ({st.scan_topic}): {len(kept)} of {len(st.runs)} runs measured, the lidar at "
        f"x {x * 1e3:.1f} mm, y {y * 1e3:.1f} mm, yaw {math.degrees(yaw):.2f} deg ({st.sensor_pose_source})"
    )
    if kept:
        rms = [r.rms_m * 1e3 for r in kept]
        frac = [r.inlier_fraction for r in kept]
        line += f"; residual {min(rms):.1f} to {max(rms):.1f} mm RMS, {min(frac):.0%} or more of each end scan matched"
    console().print(line)


def _gyro(paths, log_format, kw):
    """``replay --imu-topic``: the gyro's effective wheelbase (and scale) from the bags' turns."""
    from umbmark.cli.options import read_options
    from umbmark.io.load import nominal_geometry
    from umbmark.io.rosbag import read_gyro_bag, read_selfcal_bag
    from umbmark.realrobot.gyro import gyro_reference
    from umbmark.realrobot.scan_truth import parse_sensor_pose

    topic = kw.get("imu_topic")
    if topic is None:
        raise InputError("--full-turns works with --imu-topic (the gyro)")
    if log_format not in ("auto", "bag") or not _all_bags(paths, log_format if log_format == "bag" else "auto"):
        raise InputError("--imu-topic reads the gyro of ROS bags")
    if kw.get("full_turns") and kw.get("gt_scan_topic"):
        raise InputError("the gyro's scale comes from --full-turns or from the lidar (--gt-scan-topic), not both")
    opts = read_options(kw)
    wheel = opts.wheels
    nominal = nominal_geometry(opts, str(paths[0]))
    with progress("reading the gyro"):
        bags = [read_gyro_bag(p, imu_topic=topic, nominal=nominal, wheels=wheel) for p in paths]
    scans, pose = None, (0.0, 0.0, 0.0)
    if kw.get("gt_scan_topic"):
        with progress("reading the scans"):
            scans = {b.source: read_selfcal_bag(b.source, scan_topic=kw["gt_scan_topic"], wheels=wheel) for b in bags}
        if kw.get("sensor_pose") is not None:
            pose = parse_sensor_pose(kw["sensor_pose"])[0]
    return gyro_reference(bags, nominal, full_turns=bool(kw.get("full_turns")), scans=scans, sensor_pose=pose)


def _emit_gyro(gyro, save, as_json, history, paths) -> None:
    """``replay --imu-topic`` without a ground truth: the gyro's block alone (recorded with
    ``--robot NAME --record``)."""
    from umbmark.history import file_sha256
    from umbmark.realrobot.gyro import gyro_history_fields

    d = {"gyro": gyro.to_dict(), "warnings": list(gyro.warnings)}
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    robot, record, db = history
    rec = record_if_requested(robot, record, db, **gyro_history_fields(d, paths, file_sha256)) if record else None
    if as_json:
        emit_json(d if rec is None else {**d, "history": rec})
    elif not is_quiet():
        _print_gyro(gyro)
        print_recorded(rec)


def _print_gyro(g) -> None:
    """The gyro's verdict as a table and lines."""
    from rich.markup import escape

    def ci(p, f, k=1.0):
        return "-" if p is None else f"{f(p[0] * k)} .. {f(p[1] * k)}"

    rows = [
        [
            "wheelbase [mm]",
            fmt(g.nominal_wheelbase_m * 1e3, 2),
            fmt(g.wheelbase_m * 1e3, 2),
            ci(g.wheelbase_m_ci95, lambda v: fmt(v, 2), 1e3),
        ],
        ["E_b (wheel_separation_multiplier)", "1", fmt(g.eb, 5), ci(g.eb_ci95, lambda v: fmt(v, 5))],
        [f"gyro scale ({g.gyro_scale_source})", "1", fmt(g.gyro_scale, 5), ci(g.gyro_scale_ci95, lambda v: fmt(v, 5))],
    ]
    c = console()
    used = sum(t.used for t in g.turns)
    c.print(
        table(
            f"Gyro {g.imu_topic}: {used} turns used of {len(g.turns)}", ["", "nominal", "gyro", "95 % interval"], rows
        )
    )
    c.print(
        f"bias {math.degrees(g.bias_radps):.4f} deg/s removed (measured over {g.still_s:.1f} s at rest), "
        f"noise {fmt(math.degrees(g.noise_radps), 4)} deg/s per reading"
    )
    for w in g.warnings:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")


def _stream(paths, log_format, decimate, poses_out, as_json, kw) -> None:
    """``replay --stream``: one long CSV log in bounded memory (no calibration)."""
    from umbmark.cli.options import read_options
    from umbmark.realrobot.replay import stream_log

    opts = read_options(kw)
    rep = stream_log(list(paths), decimate=decimate, fmt=log_format or "auto", poses_out=poses_out, options=opts)
    if as_json:
        emit_json(rep.to_dict())
    elif not is_quiet():
        _print_stream(rep)


@app.command(name="bag-info")
@click.argument("bag")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bag_info_cmd(bag, as_json):
    """List the topics of a ROS 1 or ROS 2 bag (to choose --joints, --gt-topic ...): types,
    message counts and rates, the joint names of JointState topics, the frames of poses,
    odometry, scans and transforms.

    \b
    Example:
      umbmark bag-info recording.bag
      umbmark bag-info rosbag2_2026_11_21/ --json
    """
    from umbmark.io.rosbag import bag_info

    info = bag_info(bag)
    if as_json:
        emit_json(info.to_dict())
    elif not is_quiet():
        c = console()
        c.print(
            table(
                f"{bag}: {info.messages} messages, {info.duration_s:.1f} s",
                ["topic", "type", "messages", "rate [Hz]", "joints / frames"],
                [[t.topic, t.type, t.messages, fmt(t.rate_hz, 1), t.describe()] for t in info.topics],
            )
        )
        for t in info.topics:
            if t.joint_names:
                _print_joint_flags(c, t.topic, t.joint_names)


def _print_joint_flags(c, topic: str, names) -> None:
    """The joints of a JointState topic in the order each kind's flags want them (by their names)."""
    from rich.markup import escape

    from umbmark.kinds import joint_flags_for

    c.print(escape(f"The joints of {topic} as each kind's flags take them, in the order they want:"))
    for k, flags, found in joint_flags_for(names):
        kind = "" if k.differential else f"--kinematics {k.name} "
        how = "found by their names (check them)" if found else "the names do not tell which is which"
        c.print(escape(f"  {k.noun}: {kind}{cli_message(flags)}; {how}"), soft_wrap=True)
    c.print("selfcal sets the joints' motion against the lidar's and names another order that fits far better.")


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
def convert(paths, log_format, target, out, **kw):
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
    sets = _datasets(paths, log_format, kw)
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
            c.print(
                f"analyze it with: umbmark analyze {out} --wheelbase-mm {ds.nominal.wheelbase_m * 1e3:g} "
                f"--side-mm {ds.side_m * 1e3:g}",
                markup=False,
                soft_wrap=True,
            )
    for w in warnings:
        click.echo(f"warning: {cli_message(w)}", err=True)


def _ros_size_notes(cal, wheel_radius_m: float | None, wheel_separation_m: float | None) -> list[str]:
    """Warnings for --wheel-radius-m / --wheel-separation-m that look like another unit or
    quantity: millimetres given as metres, a diameter as the radius, or far from the
    calibration's nominal geometry."""
    out = []
    nom_d = cal.nominal_diameter_left_m
    if nom_d is not None and cal.nominal_diameter_right_m is not None:
        nom_d = 0.5 * (nom_d + cal.nominal_diameter_right_m)
    checks = (
        ("--wheel-radius-m", wheel_radius_m, None if nom_d is None else 0.5 * nom_d, "wheel radius", 1.0),
        ("--wheel-separation-m", wheel_separation_m, cal.nominal_wheelbase_m, "wheel separation", 5.0),
    )
    for flag, value, nominal, what, most in checks:
        if value is None or not math.isfinite(value) or value <= 0:
            continue
        if value > most:
            out.append(
                f"{flag} {value:g} is a {what} of {value:g} m: the option is in metres "
                f"({value / 1000:g} m if {value:g} is millimetres)"
            )
        elif nominal is not None and not 0.67 <= value / nominal <= 1.5:
            hint = (
                " (a diameter given as the radius?)"
                if flag == "--wheel-radius-m" and 1.8 < value / nominal < 2.2
                else ""
            )
            out.append(
                f"{flag} {value:g} m is {value / nominal:.2f} times the calibration's nominal {what} "
                f"({nominal:g} m){hint}: the written {what.replace(' ', '_')} will not match the odometry the "
                "calibration was made with"
            )
    return out


@app.command()
@click.argument("calibration", required=False, metavar="[CAL.json]")
@click.option(
    "--format",
    "out_format",
    type=click.Choice(export_formats()),
    required=True,
    help=f"ros2/ros1: diff_drive_controller parameters ({own_kinds()} self-calibration: "
    f"{own_controllers()}, ros2 only); json; firmware: C header (mm per pulse); "
    "urdf, tf: the lidar pose of a self-calibration (URDF origin, static_transform_publisher); vesc: a car's "
    "vesc.yaml (--vesc-config) with its gains calibrated.",
)
@click.option("--dataset", default=None, help="Data set to take from a replay JSON of several.")
@click.option("--c-left", type=float, default=None, help="Left wheel-travel factor (instead of CAL.json).")
@click.option("--c-right", type=float, default=None, help="Right wheel-travel factor (instead of CAL.json).")
@click.option("--eb", type=float, default=None, help="Wheelbase factor E_b (instead of CAL.json).")
@click.option(
    "--controller",
    default=None,
    help=f"Controller name (ros) [default: diff_drive_controller; {own_controllers()} for those kinds].",
)
@click.option(
    "--steering-offset-in-use-deg",
    type=float,
    default=0.0,
    show_default=True,
    help=f"{steered_titles()}: the offset of the steering joint's transmission when the bag was recorded.",
)
@click.option(
    "--steering-reduction-in-use",
    type=float,
    default=1.0,
    show_default=True,
    help=f"{steered_titles()}: the mechanical_reduction of the steering joint's transmission when the bag was "
    "recorded.",
)
@click.option(
    "--left-multiplier",
    type=float,
    default=1.0,
    show_default=True,
    help="left_wheel_radius_multiplier in use when the logs were recorded.",
)
@click.option(
    "--right-multiplier",
    type=float,
    default=1.0,
    show_default=True,
    help="right_wheel_radius_multiplier in use when the logs were recorded.",
)
@click.option(
    "--separation-multiplier",
    type=float,
    default=1.0,
    show_default=True,
    help="wheel_separation_multiplier in use when the logs were recorded.",
)
@click.option("--wheel-radius-m", type=float, default=None, help="Also write wheel_radius (ros).")
@click.option("--wheel-separation-m", type=float, default=None, help="Also write wheel_separation (ros).")
@click.option("--wheel-diameter-mm", type=float, default=None, help="Nominal wheel diameter (json, firmware).")
@click.option("--wheelbase-mm", type=float, default=None, help="Nominal wheelbase (json, firmware).")
@click.option("--pulses-per-wheel-rev", type=float, default=None, help="Encoder pulses per wheel rev (firmware).")
@click.option(
    "--sensor-z-mm",
    type=float,
    default=None,
    help="Height of the lidar above the base frame (urdf, tf, json of a self-calibration): default the "
    "bag's /tf_static, else 0 with a warning.",
)
@click.option(
    "--covariance-speed-mps",
    type=float,
    default=0.5,
    show_default=True,
    help="ros2, ros1, json of a self-calibration that measured the odometry's noise: the speed the "
    "twist_covariance_diagonal is computed at.",
)
@click.option(
    "--velocity-window-s",
    type=float,
    default=0.1,
    show_default=True,
    help="The time the controller averages its speeds over (velocity_rolling_window_size / update rate, "
    "10 / 100 Hz by default) for twist_covariance_diagonal.",
)
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="File to write (default: print).")
@edited_file_options
@history_options
def export(
    calibration,
    out_format,
    dataset,
    c_left,
    c_right,
    eb,
    controller,
    left_multiplier,
    right_multiplier,
    separation_multiplier,
    wheel_radius_m,
    wheel_separation_m,
    wheel_diameter_mm,
    wheelbase_mm,
    pulses_per_wheel_rev,
    sensor_z_mm,
    out,
    robot,
    record,
    db,
    steering_offset_in_use_deg=0.0,
    steering_reduction_in_use=1.0,
    covariance_speed_mps=0.5,
    velocity_window_s=0.1,
    **edited,
):
    """Write a calibration as ROS 2 / ROS 1 diff_drive_controller parameters, JSON or a
    firmware header; a lidar self-calibration also as the lidar's URDF origin or a
    static_transform_publisher command. The self-calibration of a robot of another kind becomes
    its controller's parameters (ros2: tricycle_controller, mecanum_drive_controller,
    bicycle_steering_controller, ackermann_steering_controller; the steering offset's
    transmission or the per-wheel factors in comments); a car's also its vesc.yaml with
    speed_to_erpm_gain, steering_angle_to_servo_gain and steering_angle_to_servo_offset
    calibrated (--format vesc --vesc-config VESC.yaml --out NEW.yaml).

    The calibration comes from CAL.json (the output of `umbmark replay --json`,
    `umbmark analyze --json` or `umbmark selfcal --json`) or from --c-left/--c-right/--eb. ROS
    multipliers are composed with those in use when the logs were recorded: new = old x
    factor. The ros2/ros1 files of a self-calibration end with the lidar pose as comments.
    --robot NAME --record stores a self-calibration in the robot's history (the other
    calibrations are recorded by the command that made them: replay, analyze, calibrate).

    \b
    Example:
      umbmark replay data/optiodom/square/230620202144 --save cal.json
      umbmark export cal.json --format ros2 --out params.yaml
      umbmark export selfcal.json --format urdf
      umbmark export car.json --format vesc --vesc-config vesc.yaml --out vesc_calibrated.yaml
    """

    from umbmark.io.export import (
        ExportCalibration,
        calibration_from_json,
        export_warnings,
        format_export,
    )

    flags = (c_left, c_right, eb)
    for flag, v in (("--left-multiplier", left_multiplier), ("--right-multiplier", right_multiplier),
                    ("--separation-multiplier", separation_multiplier), ("--wheel-radius-m", wheel_radius_m),
                    ("--wheel-separation-m", wheel_separation_m)):  # fmt: skip
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"{flag} must be a positive number, got {v!r}")
    if calibration is not None:
        kd = kinematic_json(calibration)
        if kd is not None:
            diff_drive_flags = dict(
                c_left=c_left, c_right=c_right, eb=eb, wheel_radius_m=wheel_radius_m,
                wheel_separation_m=wheel_separation_m, wheel_diameter_mm=wheel_diameter_mm, wheelbase_mm=wheelbase_mm,
                pulses_per_wheel_rev=pulses_per_wheel_rev, dataset=dataset, left_multiplier=left_multiplier,
                right_multiplier=right_multiplier, separation_multiplier=separation_multiplier,
            )  # fmt: skip
            rec = _record_selfcal(calibration, robot, record, db) if record else None
            export_kinematic(
                kd, str(calibration), out_format, controller, sensor_z_mm, out,
                (steering_offset_in_use_deg, steering_reduction_in_use), diff_drive_flags, edited,
            )  # fmt: skip
            _say_recorded(rec, out)
            return
    refuse_edited_files(edited, out_format)
    controller = "diff_drive_controller" if controller is None else controller
    if (steering_offset_in_use_deg, steering_reduction_in_use) != (0.0, 1.0):
        raise InputError(f"--steering-offset-in-use-deg and --steering-reduction-in-use are {own_kinds(steered=True)}")
    if calibration is not None:
        if any(v is not None for v in flags):
            raise InputError("give CAL.json or --c-left/--c-right/--eb, not both")
        cal = calibration_from_json(calibration, dataset)
    else:
        if any(v is None for v in flags):
            raise InputError("give CAL.json (from replay/analyze --json) or all of --c-left, --c-right, --eb")
        cal = ExportCalibration(c_left, c_right, eb, source="command line")
    cal = _with_nominal(cal, wheel_diameter_mm, wheelbase_mm, pulses_per_wheel_rev)
    cal, notes = _with_sensor_height(cal, sensor_z_mm, out_format)
    notes += _ros_size_notes(cal, wheel_radius_m, wheel_separation_m)
    covariances, cov_notes = _export_covariances(
        cal, out_format, wheel_separation_m, separation_multiplier, covariance_speed_mps, velocity_window_s
    )
    text = format_export(
        cal,
        out_format,
        controller,
        left_multiplier,
        right_multiplier,
        separation_multiplier,
        wheel_radius_m,
        wheel_separation_m,
        covariances,
    )
    notes += cov_notes
    rec = _record_selfcal(calibration, robot, record, db) if record else None
    emit_export(text, out, notes + export_warnings(cal, left_multiplier, right_multiplier, separation_multiplier))
    _say_recorded(rec, out)


def _say_recorded(rec, out) -> None:
    """The line of ``export --record`` (on stderr when the export went to stdout)."""
    if rec is not None and out:
        print_recorded(rec)
    elif rec is not None and not is_quiet():  # the export went to stdout: the note to stderr
        click.echo(f"recorded as #{rec['record_id']} in the history of {rec['robot']} ({rec['db']})", err=True)


def _with_nominal(cal, wheel_diameter_mm, wheelbase_mm, pulses_per_wheel_rev):
    """The calibration with the nominal geometry and pulses given on the command line."""
    from dataclasses import replace

    from umbmark.cli.app import positive

    for flag, v in (
        ("--wheel-diameter-mm", wheel_diameter_mm),
        ("--wheelbase-mm", wheelbase_mm),
        ("--pulses-per-wheel-rev", pulses_per_wheel_rev),
    ):
        if v is not None:
            positive(flag, v)
    if wheel_diameter_mm is not None:
        cal = replace(
            cal, nominal_diameter_left_m=wheel_diameter_mm * 1e-3, nominal_diameter_right_m=wheel_diameter_mm * 1e-3
        )
    if wheelbase_mm is not None:
        cal = replace(cal, nominal_wheelbase_m=wheelbase_mm * 1e-3)
    if pulses_per_wheel_rev is not None:
        cal = replace(cal, pulses_per_wheel_rev=pulses_per_wheel_rev)
    return cal


def _export_covariances(cal, out_format, wheel_separation_m, separation_multiplier, speed_mps, window_s):
    """The controller's covariance diagonals for a calibration that measured the odometry's noise
    (None otherwise), and notes on why none could be written."""
    for flag, v, top in (("--covariance-speed-mps", speed_mps, 20.0), ("--velocity-window-s", window_s, 10.0)):
        if not (math.isfinite(v) and 0 < v <= top):
            raise InputError(f"{flag} must be in (0, {top:g}], got {v:g}")
    if cal.odometry_noise_m is None or out_format not in ("ros2", "ros1", "json"):
        return None, []
    from umbmark.correct.noise import controller_covariances

    if cal.nominal_wheelbase_m is not None:
        wheelbase_m = cal.nominal_wheelbase_m * cal.eb
    elif wheel_separation_m is not None:
        wheelbase_m = wheel_separation_m * separation_multiplier * cal.eb
    else:
        return None, [
            "the calibration holds the odometry's noise but no wheelbase: give --wheel-separation-m for "
            "pose_covariance_diagonal and twist_covariance_diagonal"
        ]
    return controller_covariances(cal.odometry_noise_m, wheelbase_m, speed_mps, window_s), []


def _with_sensor_height(cal, sensor_z_mm, out_format):
    """The calibration with the lidar's height of ``--sensor-z-mm``, and notes on that height."""
    from dataclasses import replace

    notes = []
    if sensor_z_mm is not None:
        if cal.sensor_pose is None:
            raise InputError("--sensor-z-mm is the lidar's height: it needs a self-calibration's JSON")
        if not math.isfinite(sensor_z_mm):
            raise InputError(f"--sensor-z-mm must be a number of millimetres, got {sensor_z_mm}")
        cal = replace(cal, sensor_z_m=sensor_z_mm * 1e-3, sensor_height_known=True)
        if 0 < abs(sensor_z_mm) < 5 or abs(sensor_z_mm) > 5000:
            notes.append(
                f"--sensor-z-mm {sensor_z_mm:g} puts the lidar {sensor_z_mm:g} mm above {cal.base_frame}: "
                "the option is in millimetres (a height in metres would be 1000 times smaller)"
            )
    elif out_format in ("urdf", "tf") and cal.sensor_pose is not None and not cal.sensor_height_known:
        notes.append(
            f"the lidar's height is 0 mm: the calibration holds none (its bag had no /tf_static for "
            f"{cal.sensor_frame}); give --sensor-z-mm, or the pose puts the lidar at the height of {cal.base_frame}"
        )
    return cal, notes


def _record_selfcal(calibration, robot, record, db):
    """Record the self-calibration in CAL.json in the robot's history (``export --record``)."""
    from umbmark.history import file_sha256
    from umbmark.io._text import parse_json, read_text
    from umbmark.realrobot.selfcal import selfcal_history_fields

    if calibration is None:
        raise InputError("--record stores the self-calibration of a CAL.json (from `umbmark selfcal --json`)")
    d = parse_json(read_text(calibration), str(calibration))
    if not isinstance(d, dict) or d.get("method", "selfcal") != "selfcal" or "sensor_pose" not in d:
        raise InputError(
            f"{calibration}: --record stores self-calibrations; record this calibration with the command "
            "that made it (replay, analyze or calibrate with --robot NAME --record)"
        )
    return record_if_requested(robot, record, db, **selfcal_history_fields(d, file_hash=file_sha256))
