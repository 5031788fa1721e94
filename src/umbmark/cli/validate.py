"""``umbmark validate``: check a calibration on a real log against a SLAM reference (relations or
a TUM trajectory), before and after, as the calibrations of this project are judged.

The library does the work (:func:`umbmark.realrobot.validate.validate_log`); this module parses
the options, calls it, and prints its result's ``to_dict()`` or a table made from it. The options
that read the bag's wheel data and give the nominal geometry are ``umbmark selfcal``'s own (the
same click options, copied), read with :func:`umbmark.cli.options.wheel_source` as the bag readers
take them. No numerical module is imported before the command runs.
"""

from __future__ import annotations

import copy
import math
import re
from typing import TYPE_CHECKING, Any

import click

from umbmark._numbers import strict_float
from umbmark.cli.app import app, cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.cli.config import config_options
from umbmark.cli.guard import skip_check_option
from umbmark.cli.kinematic import joint_options, kind_options
from umbmark.cli.options import flag
from umbmark.cli.selfcal import selfcal_cmd
from umbmark.errors import InputError
from umbmark.kinds import KINDS, kind_in

if TYPE_CHECKING:
    from umbmark.io.wheels import WheelSource
    from umbmark.kinds import Kind

__all__ = ["validate_cmd", "LEGEND", "READ_OPTIONS", "FAIL_EXIT_STATUS"]

FAIL_EXIT_STATUS = 3
"""The exit status of ``--fail-on-worse`` when a rule fails."""

# selfcal's options that read the bag and give the nominal geometry, in the order shown
READ_OPTIONS = (
    "scan_topic",
    "joints",
    "joint_topic",
    "ticks_topic",
    "left_field",
    "right_field",
    "pulses_per_wheel_rev",
    "ticks",
    "odom_topic",
    "wheel_diameter_mm",
    "wheelbase_mm",
    "wheel_radius_m",
    "wheel_separation_m",
    "base_frame",
)

# READ_OPTIONS that only a differential drive's calibration reads (another kind's: its joints)
DIFF_DRIVE_OPTIONS = (
    "ticks_topic",
    "left_field",
    "right_field",
    "pulses_per_wheel_rev",
    "ticks",
    "odom_topic",
    "wheel_diameter_mm",
    "wheelbase_mm",
    "wheel_radius_m",
    "wheel_separation_m",
)

# the library's parameters of this command -> its flags (the shared ones are in umbmark.cli.app)
_FLAGS = {
    "wheel_diameter_m": "--wheel-diameter-mm",
    "wheelbase_m": "--wheelbase-mm",
    "window_s": "--window",
    "scan_delay_s": "--scan-delay",
    "short_max_s": "--short-max-s",
    "tolerance_s": "--stamp-tolerance-s",
    "relations_path": "--relations",
    "reference_path": "--reference",
    "reference_frame": "--reference-frame",
}
_NAME = re.compile(r"`(\w+)`")

LEGEND = (
    "MSE: the mean squared error of the relations (the benchmark's metric: translation in m^2, rotation in "
    "deg^2); short: relations spanning less than --short-max-s, long: the rest.",
    "distance scale, turn scale: how far and how much the odometry moves and turns against the reference "
    "(1 is right), over the short relations longer than 0.2 m / turning more than 10 deg.",
    "heading drift: the heading error per metre driven (0 is right; unequal wheels show there).",
    "before: the nominal geometry and sensor pose; after: the calibration's. A rule without relations does not apply.",
)

_ROWS = (
    ("short translation MSE [m²]", lambda f: f["short"]["translation"]["mse_m2"], 6),
    ("short rotation MSE [deg²]", lambda f: f["short"]["rotation"]["mse_deg2"], 4),
    ("long translation MSE [m²]", lambda f: f["long"]["translation"]["mse_m2"], 4),
    ("long rotation MSE [deg²]", lambda f: f["long"]["rotation"]["mse_deg2"], 2),
    ("short translation MAE [mm]", lambda f: _mm(f["short"]["translation"]["mae_m"]), 1),
    ("short rotation MAE [deg]", lambda f: f["short"]["rotation"]["mae_deg"], 3),
    ("distance scale", lambda f: f["distance_scale"], 4),
    ("turn scale", lambda f: f["turn_scale"], 4),
    ("heading drift [deg/m]", lambda f: f["heading_drift_deg_per_m"], 3),
)
_RULE_ROW = {
    "short_translation_mse": 0,
    "short_rotation_mse": 1,
    "long_translation_mse": 2,
    "distance_scale": 6,
    "turn_scale": 7,
}


def _mm(v: float | None) -> float | None:
    return None if v is None else v * 1e3


def _flags(text: str) -> str:
    """A library message in this command's words (its own parameters, then the shared ones)."""
    return cli_message(_NAME.sub(lambda m: _FLAGS.get(m.group(1), m.group(0)), text))


def _window(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    parts = text.split(":")
    try:
        lo, hi = (strict_float(p) for p in parts)
    except ValueError:
        raise InputError(f"--window needs START_S:END_S (seconds from the log's first scan), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InputError(f"--window needs START_S:END_S with END_S after START_S, got {text!r}")
    return lo, hi


def _cell(v: float | None, digits: int) -> str:
    return "" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt(v, digits)


def _print_report(d: dict) -> None:
    from rich.markup import escape

    c = console()
    ref, cal = d["reference"], d["calibration"]
    c.print(
        escape(
            f"{d['log']}: {d['scans']} scans over {d['log_duration_s']:.1f} s, wheels from {d['wheel_data']}; "
            f"scan delay {d['scan_delay_s']:g} s ({d['scan_delay_source']})"
        )
    )
    if ref["kind"] == "trajectory":
        what = (
            f"{ref['relations']} relations made from the trajectory {ref['path']} ({ref['poses']} poses of the "
            f"{ref['frame']} frame, {ref['mode']} at {ref['scans_with_pose']} scans)"
        )
    else:
        what = f"{ref['relations']} relations from {ref['path']}"
    c.print(
        escape(
            f"  reference: {what}; not used: {ref['unmatched']} without a scan at a stamp, "
            f"{ref['without_wheel_data']} without wheel data, {ref['outside_window']} outside the window"
        )
    )
    n, k = cal["nominal"], cal["calibrated"]
    ns, ks = cal["nominal_sensor_pose"], cal["sensor_pose"]
    own = kind_in(cal)
    if own is None:
        geometry = (
            f"D_L {k['diameter_left_mm']:.3f}, D_R {k['diameter_right_mm']:.3f}, wheelbase {k['wheelbase_mm']:.3f} mm "
            f"(nominal {n['diameter_left_mm']:g}, {n['diameter_right_mm']:g}, {n['wheelbase_mm']:g})"
        )
    else:
        geometry = f"a {own.noun}, {own.describe_json(k, False)} (nominal {own.describe_json(n, False)})"
    c.print(
        escape(
            f"  calibration {cal['path']} ({cal['kind']}): {geometry}; lidar x {ks['x_mm']:.1f} mm, y {ks['y_mm']:.1f} "
            f"mm, yaw {ks['yaw_deg']:.2f} deg (nominal {ns['x_mm']:.1f}, {ns['y_mm']:.1f}, {ns['yaw_deg']:.2f}: "
            f"{ns['source']})"
        )
    )
    for span in d["spans"]:
        rules = {r["rule"]: r for r in span["rules"]}
        by_row = {i: rules[key] for key, i in _RULE_ROW.items() if key in rules}
        rows = []
        for i, (label, get, digits) in enumerate(_ROWS):
            b, a = get(span["before"]), get(span["after"])
            r = by_row.get(i)
            verdict = "" if r is None else {True: "pass", False: "FAIL", None: "n/a"}[r["passed"]]
            rows.append([label, _cell(b, digits), _cell(a, digits), "" if r is None else r["test"], verdict])
        before = span["before"]
        title = (
            f"{span['label']}, {span['t_start_s']:.1f} to {span['t_end_s']:.1f} s: {span['relations_short']} short "
            f"and {span['relations_long']} long relations (the scales over {before['distance_relations']} and "
            f"{before['turn_relations']})"
        )
        c.print(table(title, ["", "before", "after", "rule", ""], rows))
        c.print(f"[bold]{escape(span['label'])}: {span['verdict']}[/bold]")
    for line in LEGEND:
        c.print(f"[dim]{escape(line)}[/dim]")
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(w)}")


@app.command("validate")
@click.argument("log", metavar="LOG")
@click.argument("calibration", metavar="CAL.json")
@click.option("--relations", default=None, metavar="FILE", help="Reference: a relations file of the SLAM benchmark.")
@click.option(
    "--reference",
    default=None,
    metavar="FILE",
    help="Reference: a planar trajectory file in the TUM format (timestamp x y z qx qy qz qw).",
)
@click.option(
    "--reference-frame",
    type=click.Choice(["base", "sensor"]),
    default=None,
    help="--reference: the poses are the robot's base frame as a SLAM publishes them (default; made the "
    "lidar's with the nominal sensor pose) or the lidar's.",
)
@click.option("--dataset", default=None, help="The data set to take from a replay JSON of several.")
@click.option(
    "--window", default=None, metavar="START_S:END_S", help="Check only this span (seconds from the first scan)."
)
@click.option("--halves", is_flag=True, help="Check the two halves (of the log or the window) apart.")
@click.option(
    "--short-max-s",
    type=float,
    default=10.0,
    show_default=True,
    help="Relations spanning less than this are short.",
)
@click.option(
    "--scan-delay",
    type=float,
    default=None,
    metavar="SECONDS",
    help="How late the scans are stamped against the wheel data (default: the calibration's, else 0).",
)
@click.option(
    "--stamp-tolerance-s",
    type=float,
    default=0.001,
    show_default=True,
    help="How far a relation's stamp may be from its scan's.",
)
@click.option(
    "--fail-on-worse",
    is_flag=True,
    help=f"Exit with status {FAIL_EXIT_STATUS} when a rule fails (default: 0 whatever the verdict).",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@joint_options
@config_options
@skip_check_option
def validate_cmd(
    log: str,
    calibration: str,
    relations: str | None,
    reference: str | None,
    reference_frame: str | None,
    dataset: str | None,
    window: str | None,
    halves: bool,
    short_max_s: float,
    scan_delay: float | None,
    stamp_tolerance_s: float,
    fail_on_worse: bool,
    as_json: bool,
    **kw: Any,
) -> None:
    """Check a calibration on a real log against a SLAM reference: the odometry's relation errors,
    distance and turn scale and heading drift, before (nominal geometry and lidar pose) and
    after (the calibration's), with pass rules.

    LOG is a ROS 1 or ROS 2 bag with laser scans and the robot's wheel data (--odom-topic,
    --joints or --ticks-topic, read as umbmark selfcal reads them). CAL.json is the JSON of
    `umbmark selfcal --save`, `umbmark replay --save` or `umbmark export --format json`. The
    calibration of another kind of robot (`selfcal --kinematics KIND --save`) is checked on its
    joints, with its kind's flags (a tricycle's --drive-joint and --steer-joint, a mecanum
    robot's --joints FL,FR,RL,RR; a car's also its own --odom-topic): their odometry with the
    nominal geometry and with the calibrated one. The
    reference: --relations (the SLAM benchmark's format) or --reference (a TUM trajectory, e.g.
    saved from slam_toolbox or cartographer; relations are made from it between the scans).
    --wheel-diameter-mm and --wheelbase-mm (or --wheel-radius-m, --wheel-separation-m) give the
    nominal geometry when CAL.json lacks it, or instead of its own.

    The rules, per span: the short-relation MSEs (translation, rotation) after at most 2 % above
    before; the long-relation translation MSE after not above before; each scale after within
    1.5 % of 1, or no farther from 1 than before. The exit status is 0 whatever the verdict, 3
    with --fail-on-worse when a rule fails, 2 on bad input.

    \b
    Example:
      umbmark validate mit-csail.bag selfcal.json --odom-topic /odom --relations mit-csail.relations
      umbmark validate robot_bag selfcal.json --joints left_wheel_joint,right_wheel_joint --reference slam.tum --halves
      umbmark validate robot_bag cal.json --odom-topic /odom --reference slam.tum --window 0:120 --json
    """
    from umbmark.realrobot.validate import calibration_kind, validate_log

    if reference_frame is not None and reference is None:
        raise InputError("--reference-frame is the frame of a --reference trajectory; the relations are the lidar's")
    wheels, joints, (d_m, b_m) = _wheel_data(calibration_kind(calibration), kw)
    try:
        v = validate_log(
            log,
            calibration,
            relations_path=relations,
            reference_path=reference,
            reference_frame=reference_frame or "base",
            dataset=dataset,
            wheel_diameter_m=d_m,
            wheelbase_m=b_m,
            window_s=_window(window),
            halves=halves,
            short_max_s=short_max_s,
            scan_delay_s=scan_delay,
            base_frame=kw["base_frame"],
            tolerance_s=stamp_tolerance_s,
            scan_topic=kw["scan_topic"],
            wheels=wheels,
            joints=joints,
            joint_topic=kw["joint_topic"],
            odom_topic=None if wheels is not None else kw["odom_topic"],
        )
    except InputError as e:
        raise InputError(_flags(e.message), e.source, e.line) from None
    d = v.to_dict()
    d["warnings"] = [_flags(w) for w in d["warnings"]]
    if as_json:
        emit_json(d)
    elif not is_quiet():
        _print_report(d)
    if fail_on_worse and v.verdict == "fail":
        raise click.exceptions.Exit(FAIL_EXIT_STATUS)


def _wheel_data(
    kind: Kind, kw: dict[str, Any]
) -> tuple[WheelSource | None, tuple[str, ...] | None, tuple[float | None, float | None]]:
    """The log's wheel data for a calibration of ``kind``: a differential drive's wheel source and
    the nominal sizes given, or another kind's joint names (its joint flags; the differential
    drive's flags refused with why).

    Returns
    -------
    tuple
        ``(wheels, joints, (wheel_diameter_m, wheelbase_m))``: one of ``wheels`` and ``joints`` None.
    """
    from umbmark.cli.options import given_nominal_m, kinematic_joints, wheel_source

    if kind.differential:
        for name in kind_options():
            if kw.get(name):
                raise InputError(f"{flag(name)} names a joint of another kind of robot: CAL.json is a {kind.noun}'s")
        if kw["pulses_per_wheel_rev"] is not None and not (
            math.isfinite(kw["pulses_per_wheel_rev"]) and kw["pulses_per_wheel_rev"] > 0
        ):
            raise InputError(f"--pulses-per-wheel-rev must be a positive number, got {kw['pulses_per_wheel_rev']!r}")
        return wheel_source(kw), None, given_nominal_m(kw)
    ctx = click.get_current_context(silent=True)
    for name in DIFF_DRIVE_OPTIONS:
        if name == "odom_topic" and kind.reads_odometry:
            continue  # a car's own odometry, in place of its joints
        if ctx is not None and ctx.get_parameter_source(name) not in (None, click.core.ParameterSource.DEFAULT):
            raise InputError(
                f"{flag(name)} is a differential drive's: CAL.json is a {kind.noun}'s calibration, which holds its "
                "nominal geometry, checked on its joints"
            )
    return None, kinematic_joints(kind.name, kw) or None, (None, None)


# selfcal's options that read the bag's wheel data and give the nominal geometry, after the arguments
_selfcal_params = {p.name: p for p in selfcal_cmd.params}
validate_cmd.params[2:2] = [copy.copy(_selfcal_params[name]) for name in READ_OPTIONS]
_joints = [p for p in validate_cmd.params if p.name in kind_options()]  # next to --joints
validate_cmd.params = [p for p in validate_cmd.params if p not in _joints]
_at = [p.name for p in validate_cmd.params].index("joints") + 1
validate_cmd.params[_at:_at] = _joints
for _p in validate_cmd.params[2 : 2 + len(READ_OPTIONS)]:
    if _p.name in DIFF_DRIVE_OPTIONS and isinstance(_p, click.Option) and _p.help:
        _text = _p.help.removeprefix("Bag: ")
        _who = [k.title for k in KINDS.values() if k.differential or (_p.name == "odom_topic" and k.reads_odometry)]
        _p.help = f"{', '.join(_who)}: {_text[:1].lower()}{_text[1:]}"
