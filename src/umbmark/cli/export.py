"""``umbmark export``: a calibration as the robot's parameters (ROS 2 / ROS 1 controllers, JSON, a
firmware header), a lidar self-calibration also as the lidar's URDF origin or a
static_transform_publisher command.

The library does the work (:mod:`umbmark.io.export`; a robot of a kind of its own's through
:mod:`umbmark.cli.export_kinds`); this module checks the options and writes or prints the
export. No numerical module is imported before the command runs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import click

from umbmark.cli.app import app, is_quiet
from umbmark.cli.export_kinds import (
    edited_file_options,
    emit_export,
    export_kinematic,
    kinematic_json,
    refuse_edited_files,
)
from umbmark.cli.history import history_options, print_recorded, record_if_requested
from umbmark.cli.kinematic import export_formats, own_controllers, own_kinds, steered_titles
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.io.export import ExportCalibration

__all__ = ["export"]


def _ros_size_notes(
    cal: ExportCalibration, wheel_radius_m: float | None, wheel_separation_m: float | None
) -> list[str]:
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
    calibration: str | None,
    out_format: str,
    dataset: str | None,
    c_left: float | None,
    c_right: float | None,
    eb: float | None,
    controller: str | None,
    left_multiplier: float,
    right_multiplier: float,
    separation_multiplier: float,
    wheel_radius_m: float | None,
    wheel_separation_m: float | None,
    wheel_diameter_mm: float | None,
    wheelbase_mm: float | None,
    pulses_per_wheel_rev: float | None,
    sensor_z_mm: float | None,
    out: str | None,
    robot: str | None,
    record: bool,
    db: str | None,
    steering_offset_in_use_deg: float = 0.0,
    steering_reduction_in_use: float = 1.0,
    covariance_speed_mps: float = 0.5,
    velocity_window_s: float = 0.1,
    **edited: str | None,
) -> None:
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
        if c_left is None or c_right is None or eb is None:
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


def _say_recorded(rec: dict | None, out: str | None) -> None:
    """The line of ``export --record`` (on stderr when the export went to stdout)."""
    if rec is not None and out:
        print_recorded(rec)
    elif rec is not None and not is_quiet():  # the export went to stdout: the note to stderr
        click.echo(f"recorded as #{rec['record_id']} in the history of {rec['robot']} ({rec['db']})", err=True)


def _with_nominal(
    cal: ExportCalibration,
    wheel_diameter_mm: float | None,
    wheelbase_mm: float | None,
    pulses_per_wheel_rev: float | None,
) -> ExportCalibration:
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


def _export_covariances(
    cal: ExportCalibration,
    out_format: str,
    wheel_separation_m: float | None,
    separation_multiplier: float,
    speed_mps: float,
    window_s: float,
) -> tuple[dict[str, list[float]] | None, list[str]]:
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


def _with_sensor_height(
    cal: ExportCalibration, sensor_z_mm: float | None, out_format: str
) -> tuple[ExportCalibration, list[str]]:
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


def _record_selfcal(calibration: str | None, robot: str | None, record: bool, db: str | None) -> dict | None:
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
