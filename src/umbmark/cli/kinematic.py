"""``umbmark selfcal --kinematics tricycle|mecanum`` and ``umbmark replay --kinematics ...``: a
tricycle's or mecanum robot's geometry from its lidar (and the lidar's mounting pose), or against
a ground truth (and the tracked marker's pose), from ROS bags.

The library does the work (:mod:`umbmark.realrobot.kinematic`,
:mod:`umbmark.realrobot.kinematic_replay`); this module checks the flags of the kind, calls it
with progress bars and prints the result's ``to_dict()`` or a table made from it.
"""

from __future__ import annotations

import shlex

import click

from umbmark.cli.app import cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.errors import InputError

__all__ = ["kinematic_selfcal_cmd", "kinematic_replay_cmd", "kinematic_options", "LEGEND"]


def kinematic_options(f):
    """The options of the kind of robot (``selfcal`` and ``replay``): ``--kinematics``,
    ``--drive-joint``, ``--steer-joint``, ``--lx-plus-ly-mm``, ``--fit-steering-scale``."""
    options = [
        click.option(
            "--kinematics",
            type=click.Choice(["diff_drive", "tricycle", "mecanum"]),
            default="diff_drive",
            show_default=True,
            help="The kind of robot: a differential drive (or skid steer), a tricycle (--drive-joint, "
            "--steer-joint, --wheelbase-mm) or a mecanum robot (--joints FL,FR,RL,RR, --lx-plus-ly-mm).",
        ),
        click.option("--drive-joint", default=None, help="Tricycle: JointState name of the traction wheel."),
        click.option(
            "--steer-joint",
            default=None,
            help="Tricycle: JointState name of the steering joint (radians, counter-clockwise positive, 0 straight).",
        ),
        click.option(
            "--lx-plus-ly-mm",
            type=float,
            default=None,
            help="Mecanum: nominal half wheelbase plus half track (sum_of_robot_center_projection_on_X_Y_axis).",
        ),
        click.option(
            "--fit-steering-scale",
            is_flag=True,
            help="Tricycle: also estimate the steering scale (true over measured angle; needs large steering angles).",
        ),
    ]
    for option in reversed(options):
        f = option(f)
    return f


LEGEND = {
    "tricycle": (
        "wheel diameter: the traction wheel's; wheelbase: from the rear axle's midpoint to the steered wheel; "
        "steering offset: the true steering angle less the measured one (counter-clockwise positive), the "
        "number that makes a measured 0 drive straight.",
    ),
    "mecanum": (
        "wheel diameters: each wheel's effective rolling diameter; lx + ly: half the wheelbase plus half the "
        "track (mecanum_drive_controller's sum_of_robot_center_projection_on_X_Y_axis).",
    ),
}
_COMMON = (
    "lidar x, y, yaw: where the lidar sits on the robot (x forward, y left of the robot's origin; yaw "
    "counter-clockwise from its heading).",
    "95 % interval: from the scatter of the intervals about the fit and between stretches of the recording; it "
    "does not cover errors shared by the whole recording: calibrate on another to see those.",
)

_NOUN = {"tricycle": "tricycle", "mecanum": "mecanum robot"}

# flags of the differential drive's calibration a tricycle or mecanum robot has no use for
_REFUSED = {
    "ticks_topic": "--ticks-topic",
    "odom_topic": "--odom-topic",
    "intervals_out": "--intervals-out",
}


def kinematic_selfcal_cmd(kind: str, paths, min_intervals: int, keep_outliers: bool, save, as_json, record, kw) -> None:
    """Run the self-calibration of a tricycle or mecanum robot for ``umbmark selfcal``."""
    from umbmark.cli.bags import Bars, interval_options, kind_of, start_kernels
    from umbmark.cli.options import kinematic_joints, kinematic_nominal
    from umbmark.realrobot.kinematic import kinematic_selfcal_from_bags

    for key, flag in _REFUSED.items():
        if kw.get(key):
            raise InputError(f"{flag} is not for --kinematics {kind}")
    if record:
        raise InputError(f"--record keeps differential drives' calibrations; save a {kind}'s with --save")
    if kind_of(paths) != "bags":
        raise InputError(f"--kinematics {kind} reads ROS bags (joint states and laser scans), not intervals files")
    nominal = kinematic_nominal(kind, kw)
    joints = kinematic_joints(kind, kw)
    fit = None
    if kind != "tricycle" and kw.get("fit_steering_scale"):
        raise InputError("--fit-steering-scale is a tricycle's")
    if kind == "tricycle" and kw.get("fit_steering_scale"):
        fit = ("wheel_diameter_m", "wheelbase_m", "steering_offset_rad", "steering_scale")
    options = interval_options(kw, min_intervals)
    start_kernels()
    with Bars(enabled=not as_json) as bars:
        rep = kinematic_selfcal_from_bags(
            list(paths),
            nominal,
            joints,
            joint_topic=kw["joint_topic"],
            scan_topic=kw["scan_topic"],
            scan_frame=kw["scan_frame"],
            options=options,
            fit=fit,
            reject_outliers=not keep_outliers,
            progress=bars,
        )
    d = rep.to_dict()
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if as_json:
        emit_json(d)
        return
    if not is_quiet():
        _print(d, save)


def _ci(lo_hi, digits: int) -> str:
    return "fixed" if lo_hi is None else f"{lo_hi[0]:.{digits}f} to {lo_hi[1]:.{digits}f}"


def _pose_rows(what: str, pose: dict) -> list[list[str]]:
    """The table rows of a pose on the robot (the lidar's, a marker's) with its intervals."""
    return [
        [f"{what} {k} [{unit}]", fmt(pose[f"{k}_{unit}"], n), _ci(pose[f"{k}_{unit}_ci95"], n), ""]
        for k, unit, n in (("x", "mm", 2), ("y", "mm", 2), ("yaw", "deg", 3))
    ]


def _rows(d: dict) -> list[list[str]]:
    n = d["nominal"]
    if d["kinematics"] == "tricycle":
        return [
            [
                "wheel diameter [mm]",
                fmt(d["wheel_diameter_mm"], 3),
                _ci(d["wheel_diameter_mm_ci95"], 3),
                f"{n['wheel_diameter_mm']:g}",
            ],
            ["wheelbase [mm]", fmt(d["wheelbase_mm"], 3), _ci(d["wheelbase_mm_ci95"], 3), f"{n['wheelbase_mm']:g}"],
            ["steering offset [deg]", fmt(d["steering_offset_deg"], 3), _ci(d["steering_offset_deg_ci95"], 3), "0"],
            ["steering scale", fmt(d["steering_scale"], 5), _ci(d["steering_scale_ci95"], 5), "1"],
        ]
    rows = []
    for role, label in (("front_left", "FL"), ("front_right", "FR"), ("rear_left", "RL"), ("rear_right", "RR")):
        rows.append(
            [
                f"wheel diameter {label} [mm]",
                fmt(d["wheel_diameters_mm"][role], 3),
                _ci(d["wheel_diameters_mm_ci95"][role], 3),
                f"{n['wheel_diameters_mm'][role]:g}",
            ]
        )
    rows.append(
        ["lx + ly [mm]", fmt(d["lx_plus_ly_mm"], 3), _ci(d["lx_plus_ly_mm_ci95"], 3), f"{n['lx_plus_ly_mm']:g}"]
    )
    return rows


def _print(d: dict, save) -> None:
    from rich.markup import escape

    c = console()
    for b in d["inputs"]:
        c.print(
            escape(
                f"{b['path']}: {b['scans_read']} scans on {b['scan_topic']} over {b['time_span_s']:.1f} s, joints "
                f"from {b['wheel_data']}; keyframes {d['keyframes']['description']}: {b['pairs_matched']} scan pairs "
                f"matched, {b['pairs_failed']} failed; scans' delay {1e3 * b['scan_delay']['applied_s']:.1f} ms"
            )
        )
    rows = _rows(d) + _pose_rows("lidar", d["sensor_pose"])
    c.print(
        table(
            f"Self-calibration of a {_NOUN[d['kinematics']]} from {d['intervals_used']} intervals "
            f"({len(d['intervals_rejected'])} rejected as outliers)",
            ["", "estimate", "95 % interval", "nominal"],
            rows,
        )
    )
    for line in LEGEND[d["kinematics"]] + _COMMON:
        c.print(f"[dim]{escape(line)}[/dim]")
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
    cal = shlex.quote(save or "selfcal.json")
    c.print("[bold]Next[/bold]: load the geometry into the controller's parameters and the lidar pose into the URDF:")
    if not save:
        c.print("  run again with --save selfcal.json, then")
    c.print(f"  {escape(f'umbmark export {cal} --format ros2 --out params.yaml')}", soft_wrap=True)
    c.print(f"  {escape(f'umbmark export {cal} --format urdf')}", soft_wrap=True)


# the replay flags a tricycle or mecanum robot against a ground truth has use for
_REPLAY_KEEP = {
    "joints", "joint_topic", "drive_joint", "steer_joint", "wheel_diameter_mm", "wheel_radius_m", "wheelbase_mm",
    "wheel_separation_m", "lx_plus_ly_mm", "fit_steering_scale", "gt_topic", "gt_frame", "gt_parent", "time_offset",
}  # fmt: skip


def kinematic_replay_cmd(kind: str, paths, method: str, save, as_json, record, kw) -> None:
    """Run ``umbmark replay --kinematics tricycle|mecanum``: the geometry and the marker's pose
    against the bag's ground truth (least squares along the path)."""
    from umbmark.cli.options import kinematic_joints, kinematic_nominal
    from umbmark.model.timing import parse_time_offset
    from umbmark.realrobot.kinematic_replay import kinematic_replay_from_bag

    if method != "lsq":
        raise InputError(f"--kinematics {kind} fits along the path: --method lsq (bf and exact are UMBmark squares)")
    if record:
        raise InputError(f"--record keeps differential drives' calibrations; save a {kind}'s with --save")
    if len(paths) != 1:
        raise InputError(f"--kinematics {kind} replays one bag at a time, got {len(paths)}")
    ctx = click.get_current_context(silent=True)
    for key in kw:
        given = ctx is not None and ctx.get_parameter_source(key) not in (
            None,
            click.core.ParameterSource.DEFAULT,
            click.core.ParameterSource.DEFAULT_MAP,
        )
        if given and key not in _REPLAY_KEEP:
            raise InputError(f"--{key.replace('_', '-')} is not for --kinematics {kind}")
    if not kw.get("gt_topic"):
        raise InputError(f"--kinematics {kind} replays against a ground truth: give --gt-topic TOPIC")
    nominal = kinematic_nominal(kind, kw)
    joints = kinematic_joints(kind, kw)
    fit = None
    if kind != "tricycle" and kw.get("fit_steering_scale"):
        raise InputError("--fit-steering-scale is a tricycle's")
    if kw.get("fit_steering_scale"):
        fit = ("wheel_diameter_m", "wheelbase_m", "steering_offset_rad", "steering_scale")
    offset = parse_time_offset(kw.get("time_offset"))
    rep = kinematic_replay_from_bag(
        paths[0],
        nominal,
        joints,
        gt_topic=kw["gt_topic"],
        gt_frame=kw.get("gt_frame"),
        gt_parent=kw.get("gt_parent"),
        joint_topic=kw.get("joint_topic") or "/joint_states",
        time_offset="auto" if offset in (None, "auto") else offset,
        fit=fit,
    )
    d = rep.to_dict()
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if as_json:
        emit_json(d)
        return
    if is_quiet():
        return
    from rich.markup import escape

    c = console()
    e = d["relative_pose_error"]
    c.print(
        escape(
            f"{d['path']}: {d['intervals_used']} stretches of the path fitted; ground truth "
            f"{'estimated' if d['time_offset_estimated'] else 'given'} {1e3 * d['time_offset_s']:.1f} ms late"
        )
    )
    rows = _rows(d) + _pose_rows("marker", d["marker_pose"])
    c.print(
        table(
            f"Geometry of a {_NOUN[d['kinematics']]} against the ground truth",
            ["", "estimate", "95 % interval", "nominal"],
            rows,
        )
    )
    c.print(
        escape(
            f"dead reckoning over {e['window_s']:g} s windows ({e['windows']}): position error "
            f"{e['before_mm']:.1f} mm -> {e['after_mm']:.1f} mm RMS, heading {e['heading_before_deg']:.2f} -> "
            f"{e['heading_after_deg']:.2f} deg, nominal -> calibrated"
        )
    )
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
