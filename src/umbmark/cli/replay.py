"""``umbmark replay``: real-robot logs replayed with the nominal and the calibrated geometry, against
their ground truth (a motion-capture pose, the robot's lidar at rest, the gyro's turns).

The library does the work (:mod:`umbmark.realrobot.replay`, :mod:`umbmark.realrobot.scan_truth`,
:mod:`umbmark.realrobot.gyro`); this module parses the options, calls it, and prints its result's
``to_dict()`` or the tables of :mod:`umbmark.cli.replay_print`. No numerical module is imported
before the command runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from umbmark.model.dataset import Dataset
    from umbmark.realrobot.gyro import GyroReference
    from umbmark.realrobot.results import MultiReplayReport, PooledReport, ReplayReport
    from umbmark.realrobot.scan_truth import ScanTruth

from umbmark.cli.app import app, cli_message, emit_json, is_quiet
from umbmark.cli.command_config import ReplayConfig
from umbmark.cli.config import config_options, option_of
from umbmark.cli.history import (
    history_options,
    print_recorded,
    record_if_requested,
    record_report_if_requested,
    refuse_if_recorded,
)
from umbmark.cli.kinematic import kinematic_options, refuse_kind_options
from umbmark.cli.logs import all_bags, datasets, log_options
from umbmark.cli.progress import progress
from umbmark.cli.replay_print import print_gyro, print_replay, print_stream
from umbmark.errors import InputError
from umbmark.kinds import kind_named
from umbmark.model.defaults import LSQ_MODES, LSQ_SCALES

__all__ = ["REPLAY_METHOD_CHOICES", "replay"]

# umbmark.realrobot.replay.method_names(), written out so that building the command line imports
# no numerical module (tests/test_replay.py checks it against the library)
REPLAY_METHOD_CHOICES = ("bf", "exact", "lsq")


_option = option_of(ReplayConfig)


@app.command()
@click.argument("paths", nargs=-1, required=True, metavar="DATASET...")
@_option(
    "--method",
    type=click.Choice(REPLAY_METHOD_CHOICES),
    show_default=True,
    help="bf: the paper's correction; exact (when available); lsq: general-path least squares.",
)
@log_options
@_option(
    "--gt-scan-topic",
    metavar="TOPIC",
    help="Bag: the robot's lidar as the ground truth (LaserScan topic): each run's first scan after "
    "the wheels stop registered against its last scan before they start (the robot at rest).",
)
@_option(
    "--sensor-pose",
    metavar="X_MM,Y_MM,YAW_DEG|SELFCAL.json",
    help="--gt-scan-topic: the lidar's mounting pose in the robot frame, or the sensor_pose of a "
    "`umbmark selfcal` JSON (default: the bag's /tf_static).",
)
@_option(
    "--imu-topic",
    metavar="TOPIC",
    help="Bag: the gyro (sensor_msgs/Imu angular_velocity.z) as a rotation reference: the effective "
    "wheelbase (wheel_separation_multiplier; skid-steer robots too) from the turns on the spot, its "
    "bias removed at rest; the gyro's scale from the lidar (--gt-scan-topic) or --full-turns. "
    "Without a ground truth (or a square side), only this (JSON block `gyro`).",
)
@_option(
    "--full-turns",
    is_flag=True,
    help="--imu-topic: every spin on the spot was a whole number of revolutions (counted): the gyro's scale from them.",
)
@_option(
    "--pool", is_flag=True, help="lsq: fit one geometry to all data sets together (held out: leave-one-data-set-out)."
)
@_option(
    "--lsq-mode",
    type=click.Choice(LSQ_MODES),
    show_default=True,
    help="lsq: minimise errors at poses sampled along the path, or end-pose errors only.",
)
@_option(
    "--scale",
    type=click.Choice(LSQ_SCALES),
    show_default=True,
    help="lsq: fit D_L, D_R, b (fit), or E_d and b with D_avg at nominal (fixed).",
)
@_option(
    "--heading-weight-m",
    type=float,
    show_default=True,
    help="lsq: metres of position error worth one radian of heading error.",
)
@_option(
    "--points-per-run",
    type=click.IntRange(min=1),
    show_default=True,
    help="lsq, sampled mode: poses compared per run.",
)
@_option(
    "--fit-marker-offset/--no-fit-marker-offset",
    help="lsq, sampled mode: also fit where the tracked point sits relative to the axle midpoint "
    "[default: where the data determine it, with a warning saying so].",
)
@_option("--no-heldout", is_flag=True, help="Skip the held-out (leave-one-run-out) figures.")
@_option(
    "--noise",
    is_flag=True,
    help="Also estimate the odometry's random error (each wheel's variance per metre) from the ground "
    "truth's residuals over intervals of 0.1, 0.25, 0.5 and 1 s, with the ground truth's timing and each "
    "run's time offset (JSON odometry_noise_strides); where the per-metre model holds at every length, "
    "odometry_noise (export's covariances), else a warning.",
)
@_option(
    "--window",
    metavar="DURATION",
    help="Also group the runs of a long recording (a bag or CSV log cut into runs) into windows of about "
    "DURATION (10min, 600s, 1h) by the recording's clock and calibrate each (JSON key windows); with "
    "--record, each window is recorded with its own date (for `umbmark drift`).",
)
@_option(
    "--save",
    type=click.Path(dir_okay=False),
    help="Also write the JSON report to this file (input of `umbmark export`).",
)
@_option(
    "--stream",
    is_flag=True,
    help="Replay ONE long CSV log in bounded memory with the given geometry: "
    "end pose and errors only (no calibration).",
)
@_option("--decimate", type=click.IntRange(min=1), help="--stream: keep every N-th pose.")
@_option(
    "--poses-out",
    type=click.Path(dir_okay=False),
    help="--stream: write the kept poses (CSV) to this file.",
)
@_option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@kinematic_options
@history_options
@config_options
def replay(paths: tuple[str, ...], **params: Any) -> None:
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
    cfg = ReplayConfig.from_params(params)
    lsq, evaluation, stream, out = cfg.lsq, cfg.evaluation, cfg.stream, cfg.outputs
    history = robot, record, db = cfg.history.robot, cfg.history.record, cfg.history.db
    method, log_format = cfg.method, cfg.log.log_format
    if not (math.isfinite(lsq.heading_weight_m) and lsq.heading_weight_m >= 0):
        raise InputError(f"--heading-weight-m must be >= 0, got {lsq.heading_weight_m!r}")
    kinematics = cfg.kind.kinematics
    window_s = _window_s(evaluation.window, kinematics, lsq.pool, stream.stream, evaluation.noise)
    # the options that read the logs (and the kinds' own), in the order given
    reading = (set(cfg.log.params()) | set(cfg.references.params()) | set(cfg.kind.options)) - {"log_format"}
    kw = {k: v for k, v in params.items() if k in reading}
    if not kind_named(kinematics).differential:
        from umbmark.cli.kinematic import kinematic_replay_cmd

        kinematic_replay_cmd(kinematics, paths, method, out.save, out.as_json, record, kw)
        return
    refuse_kind_options(kw, pop=True)
    from umbmark._files import check_distinct_inputs

    check_distinct_inputs([p for p in paths if Path(p).exists()])
    if not stream.stream:  # the windows of a recording cover it: refused with it
        refuse_if_recorded(robot, record, db, kind="replay", method=method, paths=paths, each=True)
    if stream.stream or stream.decimate or stream.poses_out:
        if not stream.stream:
            raise InputError("--decimate and --poses-out work with --stream")
        if stream.poses_out and not stream.decimate:
            raise InputError("--poses-out needs --decimate N (keep the pose after every N-th sample)")
        _stream(paths, log_format, stream.decimate, stream.poses_out, out.as_json, kw)
        return
    gyro = None
    if kw.get("imu_topic") is not None or kw.get("full_turns"):
        gyro = _gyro(paths, log_format, kw)
        if kw.get("gt_topic") is None and (kw.get("gt_scan_topic") is None or kw.get("side_mm") is None):
            if window_s is not None:
                raise InputError(
                    "--window needs runs with a ground truth (--gt-topic, or --gt-scan-topic and --side-mm)"
                )
            _emit_gyro(gyro, out.save, out.as_json, history, list(paths))
            return
    scan_truth = None
    if kw.get("gt_scan_topic") is not None or kw.get("sensor_pose") is not None:
        sets, scan_truth = _scan_truth(paths, log_format, kw)
    else:
        sets = datasets(paths, log_format, kw)
    lsq_opts = {
        "mode": lsq.lsq_mode,
        "scale": lsq.scale,
        "heading_weight_m": lsq.heading_weight_m,
        "points_per_run": lsq.points_per_run,
        "fit_offset": lsq.fit_marker_offset,
    }
    heldout = not evaluation.no_heldout
    rep = _calibrate_sets(sets, method, lsq.pool, lsq_opts, heldout)
    if scan_truth is not None:
        rep = _with_warnings(rep, scan_truth.warnings)
    d = _report_dict(rep, scan_truth, gyro)
    rec, noise_fits = _replay_extras(
        d, sets, rep, (window_s, evaluation.noise), (method, lsq_opts, heldout), list(paths), history
    )
    if out.save:
        from umbmark.io.atomic import write_json

        write_json(out.save, d)
    if window_s is None:
        rec = record_report_if_requested(robot, record, db, rep, list(paths), kind="replay", method=method)
    if out.as_json:
        for w in dict.fromkeys(_json_warnings(d)):  # on stderr too, as every command's warnings
            click.echo(f"warning: {cli_message(w)}", err=True)
        emit_json(d if rec is None else {**d, "history": rec})
        return
    if not is_quiet():
        print_replay(rep, rec, scan_truth, gyro, d.get("windows"), noise_fits)


def _calibrate_sets(
    sets: list[Dataset], method: str, pool: bool, lsq_opts: dict[str, Any], heldout: bool
) -> ReplayReport | MultiReplayReport | PooledReport:
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


def _window_s(window: str | None, kinematics: str, pool: bool, stream: bool, noise: bool = False) -> float | None:
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


def _replay_extras(
    d: dict[str, Any],
    sets: list[Dataset],
    rep: ReplayReport | MultiReplayReport | PooledReport,
    asked: tuple[float | None, bool],
    calibration: tuple[str, dict[str, Any], bool],
    paths: list[str],
    history: tuple[str | None, bool, str | None],
) -> tuple[list | None, list | None]:
    """``--window`` and ``--noise``: the windows calibrated (recorded when asked) and the noise
    estimated, into the JSON ``d``; the windows' records and the noise's fits (or None). ``asked``
    is the window's length [s] and whether the noise is asked; ``calibration`` the method, the
    least squares' options and whether the held-out figures are; ``history`` ``--robot``,
    ``--record``, ``--db``."""
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


def _json_warnings(d: object) -> list[str]:
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


def _scan_truth(paths: tuple[str, ...], log_format: str, kw: dict[str, Any]) -> tuple[list[Dataset], ScanTruth]:
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
    sets = datasets(paths, log_format, kw)
    with progress("registering each run's scans"):
        return attach_scan_truth(sets, topic, sensor_pose=pose, sensor_pose_source=pose_src, wheels=wheel_source(kw))


def _with_warnings(
    rep: ReplayReport | MultiReplayReport | PooledReport, warnings: Sequence[str]
) -> ReplayReport | MultiReplayReport | PooledReport:
    """A replay report with more warnings first (each data set's report of several)."""
    from dataclasses import replace

    from umbmark.realrobot.results import MultiReplayReport, ReplayReport

    if not warnings:
        return rep
    if isinstance(rep, ReplayReport):
        return replace(rep, warnings=tuple(warnings) + tuple(rep.warnings))
    if isinstance(rep, MultiReplayReport):
        return replace(
            rep, reports=tuple(replace(r, warnings=tuple(warnings) + tuple(r.warnings)) for r in rep.reports)
        )
    for w in warnings:  # a pooled report has no warnings of its own
        click.echo(f"umbmark: warning: {cli_message(w)}", err=True)
    return rep


def _report_dict(
    rep: ReplayReport | MultiReplayReport | PooledReport,
    scan_truth: ScanTruth | None,
    gyro: GyroReference | None = None,
) -> dict:
    """The JSON of a replay report, with the lidar ground truth's ``scan_truth`` block and the
    gyro's ``gyro`` block."""
    d = rep.to_dict()
    if scan_truth is not None:
        d["scan_truth"] = scan_truth.to_dict()
    if gyro is not None:
        d["gyro"] = gyro.to_dict()
    return d


def _gyro(paths: tuple[str, ...], log_format: str, kw: dict[str, Any]) -> GyroReference:
    """``replay --imu-topic``: the gyro's effective wheelbase (and scale) from the bags' turns."""
    from umbmark.cli.options import read_options
    from umbmark.io.load import nominal_geometry
    from umbmark.io.rosbag import read_gyro_bag, read_selfcal_bag
    from umbmark.realrobot.gyro import gyro_reference
    from umbmark.realrobot.scan_truth import parse_sensor_pose

    topic = kw.get("imu_topic")
    if topic is None:
        raise InputError("--full-turns works with --imu-topic (the gyro)")
    if log_format not in ("auto", "bag") or not all_bags(paths, log_format if log_format == "bag" else "auto"):
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


def _emit_gyro(
    gyro: GyroReference,
    save: str | None,
    as_json: bool,
    history: tuple[str | None, bool, str | None],
    paths: list[str],
) -> None:
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
        print_gyro(gyro)
        print_recorded(rec)


def _stream(
    paths: tuple[str, ...],
    log_format: str,
    decimate: int | None,
    poses_out: str | None,
    as_json: bool,
    kw: dict[str, Any],
) -> None:
    """``replay --stream``: one long CSV log in bounded memory (no calibration)."""
    from umbmark.cli.options import read_options
    from umbmark.realrobot.replay import stream_log

    opts = read_options(kw)
    rep = stream_log(list(paths), decimate=decimate, fmt=log_format or "auto", poses_out=poses_out, options=opts)
    if as_json:
        emit_json(rep.to_dict())
    elif not is_quiet():
        print_stream(rep)
