"""``umbmark selfcal --kinematics tricycle|mecanum``: the lidar self-calibration of a tricycle's or
a mecanum robot's geometry and the lidar's mounting pose, from ROS bags.

The library does the work (:mod:`umbmark.realrobot.kinematic`); this module checks the flags
of the kind, calls it with progress bars and prints the result's ``to_dict()`` or a table made
from it.
"""

from __future__ import annotations

import shlex

from umbmark.cli.app import cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.errors import InputError

__all__ = ["kinematic_selfcal_cmd", "LEGEND"]

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

# flags of the differential drive's calibration a tricycle or mecanum robot has no use for
_REFUSED = {
    "ticks_topic": "--ticks-topic",
    "odom_topic": "--odom-topic",
    "intervals_out": "--intervals-out",
}


def kinematic_selfcal_cmd(kind: str, paths, min_intervals: int, keep_outliers: bool, save, as_json, record, kw) -> None:
    """Run the self-calibration of a tricycle or mecanum robot for ``umbmark selfcal``."""
    from umbmark.cli.options import kinematic_joints, kinematic_nominal
    from umbmark.cli.selfcal import _Bars, _interval_options, _kind_of, _start_kernels
    from umbmark.realrobot.kinematic import kinematic_selfcal_from_bags

    for key, flag in _REFUSED.items():
        if kw.get(key):
            raise InputError(f"{flag} is not for --kinematics {kind}")
    if record:
        raise InputError(f"--record keeps differential drives' calibrations; save a {kind}'s with --save")
    if _kind_of(paths) != "bags":
        raise InputError(f"--kinematics {kind} reads ROS bags (joint states and laser scans), not intervals files")
    nominal = kinematic_nominal(kind, kw)
    joints = kinematic_joints(kind, kw)
    fit = None
    if kind != "tricycle" and kw.get("fit_steering_scale"):
        raise InputError("--fit-steering-scale is a tricycle's")
    if kind == "tricycle" and kw.get("fit_steering_scale"):
        fit = ("wheel_diameter_m", "wheelbase_m", "steering_offset_rad", "steering_scale")
    options = _interval_options(kw, min_intervals)
    _start_kernels()
    with _Bars(enabled=not as_json) as bars:
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
    sp = d["sensor_pose"]
    rows = _rows(d) + [
        ["lidar x [mm]", fmt(sp["x_mm"], 2), _ci(sp["x_mm_ci95"], 2), ""],
        ["lidar y [mm]", fmt(sp["y_mm"], 2), _ci(sp["y_mm_ci95"], 2), ""],
        ["lidar yaw [deg]", fmt(sp["yaw_deg"], 3), _ci(sp["yaw_deg_ci95"], 3), ""],
    ]
    c.print(
        table(
            f"Self-calibration of a {d['kinematics']} from {d['intervals_used']} intervals "
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
