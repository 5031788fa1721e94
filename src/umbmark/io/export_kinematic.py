"""Write the self-calibration of a robot of a kind with a module of its own (:mod:`umbmark.kinds`:
a tricycle, a mecanum robot; its JSON's ``kinematics`` names the kind) in the forms its software loads.

Formats (the kind's :attr:`~umbmark.kinds.Kind.export_formats`):

* ``ros2``: the controller's parameter file (the kind's :attr:`~umbmark.kinds.Kind.controller`),
  its keys and types as in ros2_controllers' parameter definitions: the joints as the bag named
  them (the JSON's ``joints``, :meth:`~umbmark.kinds.Kind.ros2_joints`) and the
  calibrated values (:meth:`~umbmark.kinds.Kind.ros2_parameters`): every parameter the
  controller requires, a block that loads alone; a comment above it says that the controller's
  other parameters keep their defaults and how to keep one's own (load the file after them: a
  later parameter file overrides the keys it holds). Then, as comments, what the controller has
  no parameter for (:meth:`~umbmark.kinds.Kind.ros2_notes`):

  - tricycle_controller: ``traction_joint_name``, ``steering_joint_name``, ``wheelbase`` and
    ``wheel_radius`` (doubles, metres). The steering
    offset has no parameter there: it belongs to the steering joint's transmission in the
    ros2_control hardware description (``transmission_interface/SimpleTransmission``, whose
    joint position is ``actuator / mechanical_reduction + offset``): the file ends with the
    ``<joint>`` element of that transmission (named as the steering joint) as a comment, its
    ``<offset>`` the old one plus
    the estimate (and its ``<mechanical_reduction>`` the old one over the steering scale when
    that was estimated);
  - mecanum_drive_controller: each wheel's ``<wheel>_wheel_command_joint_name``,
    ``kinematics.wheels_radius`` (the four wheels' mean) and
    ``kinematics.sum_of_robot_center_projection_on_X_Y_axis`` (doubles, metres). The
    controller has one radius for all wheels: where the four diameters differ beyond their 95 %
    intervals the file says so and gives each wheel's factor ``r_i / r_mean``, applied by
    dividing that wheel's transmission ``mechanical_reduction`` by it (its joint then reads
    the travel of the mean wheel, and its commands follow).

  The lidar's URDF origin and ``static_transform_publisher`` command end the file as
  comments.
* ``json``: the controller's parameters (with the joints' names), the kind's own keys
  (:meth:`~umbmark.kinds.Kind.export_json`: a tricycle's steering offset and scale, a mecanum
  robot's per-wheel factors), the sensor pose.
* ``urdf``, ``tf``: the lidar's mounting pose (as for a differential drive).
* a parameter file of the robot's own software (:attr:`~umbmark.kinds.Kind.edited_files`: a
  car's ``vesc``): the user's file with the values the calibration changes written in
  (:meth:`~umbmark.kinds.Kind.edited_values`), every other line kept
  (:func:`umbmark.io.param_file.edit_parameter_file`): :func:`format_edited_file`.

The controller's parameters name the joints the recording shows (the JSON's ``joints``,
:meth:`~umbmark.kinds.Kind.ros2_joints`: a car's ``traction_joints_names`` and
``steering_joints_names``); a calibration read from an odometry has none, and the file says so.

The differential drive's formats that another kind has no standard for (``ros1``,
``firmware``) are refused with what to use instead.

Imports :mod:`umbmark.io.export` (its pose formats and the atomic writer), :mod:`umbmark.kinds`
and pyyaml when a parameter file is written.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from umbmark.errors import InputError
from umbmark.io.export import CONTROLLER_NAME, hash_comment, origin_element, transform_command, xml_comment
from umbmark.kinds import KINDS, Kind, kind_named
from umbmark.model.kinematics import Kinematics

__all__ = [
    "read_kinematic_json",
    "KinematicCalibration",
    "kinematic_calibration_from_dict",
    "format_kinematic_export",
    "format_edited_file",
]

# what a format of the differential drive's that another kind lacks would be
_NO_STANDARD = {"ros1": "ROS 1 controller", "firmware": "firmware"}


def _exported(kind: Any) -> Kind | None:
    """The kind of a JSON's ``kinematics`` when this module exports it (a kind of its own), else None."""
    k = KINDS.get(kind) if isinstance(kind, str) else None
    return None if k is None or k.differential else k


def _num(d: dict, key: str, src: str, noun: str) -> float:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{key!r} must be a number: not a {noun}'s calibration", source=src)
    return float(v)


@dataclass(frozen=True)
class KinematicCalibration:
    """A robot's calibration of a kind of its own, as its export needs it (SI).

    Attributes
    ----------
    kind : str
        The kind's name (:data:`umbmark.kinds.KINDS`).
    geometry : Kinematics
        The estimated geometry.
    ci95 : dict
        Each geometry parameter's 95 % interval (SI), None where it was not estimated.
    sensor_pose : tuple of float
        ``(x, y, z, roll, pitch, yaw)`` of the lidar (z, roll, pitch from ``/tf_static``, else 0).
    sensor_height_known : bool
    base_frame, sensor_frame : str
    source : str
    warnings : tuple of str
        The calibration's own warnings.
    nominal : Kinematics, optional
        The nominal geometry the calibration started from (the JSON's ``nominal``).
    joints : dict, optional
        Each joint role's name in the recording (the JSON's ``joints``, else the joint data its
        bag part describes); None when it read none (an odometry) or does not say.
    """

    kind: str
    geometry: Kinematics
    ci95: dict[str, tuple[float, float] | None]
    sensor_pose: tuple[float, float, float, float, float, float]
    sensor_height_known: bool
    base_frame: str
    sensor_frame: str
    source: str
    warnings: tuple[str, ...] = ()
    nominal: Kinematics | None = None
    joints: dict[str, str] | None = None


# a joint's name as a parameter file and the transmission's XML may hold it
_JOINT_NAME = re.compile(r"[^\s\"'<>&`]+")
# how the self-calibration's JSON describes its joint data (``inputs[0].wheel_data``)
_WHEEL_DATA = re.compile(r"JointState (.+) on \S+")


def _joints(d: dict, roles: tuple[str, ...], source: str) -> dict[str, str] | None:
    """Each role's joint name in a self-calibration's JSON: ``joints`` (role -> name), else the
    joint data its bag part describes (a JSON of an older umbmark); None where it names none (a
    calibration read from an odometry).

    Raises
    ------
    InputError
        A ``joints`` that does not name each of the kind's roles with a joint's name.
    """
    given = d.get("joints")
    if given is None:
        inputs = d.get("inputs")
        first = inputs[0] if isinstance(inputs, list) and inputs and isinstance(inputs[0], dict) else {}
        m = _WHEEL_DATA.fullmatch(str(first.get("wheel_data", "")))
        names = m.group(1).split(", ") if m else []
        ok = len(names) == len(roles) and all(_JOINT_NAME.fullmatch(n) for n in names)
        return dict(zip(roles, names)) if ok else None
    if not (
        isinstance(given, dict)
        and set(given) == set(roles)
        and all(isinstance(v, str) and _JOINT_NAME.fullmatch(v) for v in given.values())
    ):
        raise InputError(f"'joints' must name the joint of each of {', '.join(roles)} (no spaces or quotes)", source)
    return {r: given[r] for r in roles}


def kinematic_calibration_from_dict(d: dict, source: str = "<json>") -> KinematicCalibration:
    """The calibration in the JSON of the self-calibration of a robot of a kind of its own (``umbmark selfcal``).

    Raises
    ------
    InputError
        Another JSON, or values that are not positive numbers where they must be.
    """
    kind = _exported(d.get("kinematics"))
    if kind is None:
        nouns = " or ".join(k.noun for k in KINDS.values() if not k.differential)
        raise InputError(f"no 'kinematics' of a {nouns}: not the JSON of umbmark selfcal", source)
    geometry, cis = kind.geometry_from_json(d, source)
    sp = d.get("sensor_pose")
    if not isinstance(sp, dict):
        raise InputError("no 'sensor_pose': not the JSON of umbmark selfcal", source)
    x, y, yaw = (
        _num(sp, "x_mm", source, kind.noun) * 1e-3,
        _num(sp, "y_mm", source, kind.noun) * 1e-3,
        math.radians(_num(sp, "yaw_deg", source, kind.noun)),
    )
    z = roll = pitch = 0.0
    known = False
    base_frame, sensor_frame = "base_link", "laser"
    inputs = d.get("inputs") if isinstance(d.get("inputs"), list) else []
    if inputs and isinstance(inputs[0], dict):
        first = inputs[0]
        got = first.get("nominal_sensor_pose")
        nsp: dict = got if isinstance(got, dict) else {}
        if str(nsp.get("source", "")).startswith("/tf_static"):
            z, known = _num(nsp, "z_mm", source, kind.noun) * 1e-3, True
            roll = math.radians(_num(nsp, "roll_deg", source, kind.noun))
            pitch = math.radians(_num(nsp, "pitch_deg", source, kind.noun))
        base_frame = str(first.get("base_frame") or base_frame)
        sensor_frame = str(first.get("scan_frame") or sensor_frame)
    warns = tuple(str(w) for w in d.get("warnings", []) if isinstance(w, str))
    nominal = d.get("nominal")
    return KinematicCalibration(
        kind.name,
        geometry,
        cis,
        (x, y, z, roll, pitch, yaw),
        known,
        base_frame,
        sensor_frame,
        source,
        warns,
        kind.geometry_from_json(nominal, source)[0] if isinstance(nominal, dict) else None,
        _joints(d, kind.geometry.joint_roles, source),
    )


def _sensor_lines(cal: KinematicCalibration) -> list[str]:
    out = [
        f"the lidar's mounting pose ({cal.base_frame} -> {cal.sensor_frame}), for its URDF joint:",
        f"  {origin_element(cal.sensor_pose)}",
        "or published without the URDF:",
        f"  {transform_command(cal.sensor_pose, cal.base_frame, cal.sensor_frame)}",
    ]
    if not cal.sensor_height_known:
        out.append("its height, roll and pitch are 0: the bag had no /tf_static for the lidar (give them in the URDF)")
    return out


def format_kinematic_export(
    cal: KinematicCalibration,
    fmt: str,
    controller: str | None = None,
    *,
    steering_offset0_rad: float = 0.0,
    steering_reduction0: float = 1.0,
) -> str:
    """The text of an export of the calibration of a robot of a kind of its own.

    Parameters
    ----------
    cal : KinematicCalibration
    fmt : str
        One of the kind's :attr:`~umbmark.kinds.Kind.export_formats`.
    controller : str, optional
        The controller's name in the parameter file (default the kind's,
        :attr:`~umbmark.kinds.Kind.controller`).
    steering_offset0_rad, steering_reduction0 : float
        A steered robot's steering transmission in use when the bag was recorded (offset, reduction).

    Returns
    -------
    str

    Raises
    ------
    InputError
        An unknown or unsupported format, a bad controller name.
    """
    kind = kind_named(cal.kind)
    formats = kind.export_formats
    if fmt in _NO_STANDARD and fmt not in formats:
        usable = [f"{f} ({kind.controller})" if f == "ros2" else f for f in formats]
        raise InputError(
            f"no standard {_NO_STANDARD[fmt]} for a {cal.kind}: export it as {', '.join(usable[:-1])} or {usable[-1]}"
        )
    if fmt not in formats:
        raise InputError(f"unknown export format {fmt!r} (choose from {', '.join(formats)})")
    if not (math.isfinite(steering_offset0_rad) and math.isfinite(steering_reduction0) and steering_reduction0 != 0):
        raise InputError("the steering transmission in use needs a finite offset and a non-zero reduction")
    if abs(steering_offset0_rad) > math.pi:
        raise InputError(
            f"the steering offset in use, {math.degrees(steering_offset0_rad):g} deg ({steering_offset0_rad:g} "
            "rad), is beyond half a turn: no steering transmission's offset (an angle in another unit?)"
        )
    head = f"umbmark self-calibration of a {kind.noun} from {cal.source}"
    edited = [e for e in kind.edited_files if e.format == fmt]
    if edited:
        raise InputError(f"`fmt={fmt}` edits {edited[0].describe}: give it (`{edited[0].option}`)")
    if fmt == "urdf":
        warn = "".join(f"<!-- warning: {xml_comment(w)} -->\n" for w in cal.warnings)
        return f"<!-- {xml_comment(head)} -->\n{warn}{origin_element(cal.sensor_pose)}\n"
    if fmt == "tf":
        return hash_comment(head) + transform_command(cal.sensor_pose, cal.base_frame, cal.sensor_frame) + "\n"
    if fmt == "json":
        return json.dumps(_json(cal), indent=2) + "\n"
    name = controller or kind.controller
    if not CONTROLLER_NAME.fullmatch(name):
        raise InputError(f"bad controller name {name!r} (letters, digits, _ / ~ . -)")
    import yaml

    notes = kind.ros2_notes(cal.geometry, cal.ci95, (steering_offset0_rad, steering_reduction0), cal.joints)
    params = _parameters(cal)
    text = hash_comment(head) + "".join(hash_comment("warning: " + w) for w in cal.warnings)
    text += "".join(hash_comment(line) for line in _load_note(cal, name, params))
    text += yaml.safe_dump({name: {"ros__parameters": params}}, sort_keys=False, default_flow_style=False)
    return text + "".join(hash_comment(line) for line in notes + _sensor_lines(cal))


def _parameters(cal: KinematicCalibration) -> dict[str, Any]:
    """The controller's parameters: the joints' names (when the calibration has them) and the
    calibrated values."""
    kind = kind_named(cal.kind)
    joints = {} if cal.joints is None else kind.ros2_joints(cal.joints)
    return {**joints, **kind.ros2_parameters(cal.geometry)}


def _load_note(cal: KinematicCalibration, name: str, params: dict[str, Any]) -> list[str]:
    """How the block is loaded: alone (every parameter the controller requires), or merged."""
    kind = kind_named(cal.kind)
    later = "load this file after yours (a later parameter file overrides the keys it holds)"
    if cal.joints is not None and len(params) > len(kind.ros2_parameters(cal.geometry)):
        return [
            f"a complete {name} block, loadable alone: the joints as the bag named them and the calibrated",
            f"values, every parameter {kind.controller} requires. Its other parameters keep their defaults:",
            f"to keep your own, {later}.",
        ]
    return [
        f"the calibrated values only (the calibration names no joints): merge them into your {name}",
        f"parameters, which name the joints, or {later}.",
    ]


def _json(cal: KinematicCalibration) -> dict[str, Any]:
    x, y, z, roll, pitch, yaw = cal.sensor_pose
    kind = kind_named(cal.kind)
    out: dict[str, Any] = {
        "kinematics": cal.kind,
        "source": cal.source,
        "parameters": _parameters(cal),
        **kind.export_json(cal.geometry, cal.ci95),
    }
    out["sensor_pose"] = {"x_m": x, "y_m": y, "z_m": z, "roll_rad": roll, "pitch_rad": pitch, "yaw_rad": yaw}
    out["warnings"] = list(cal.warnings)
    return out


def read_kinematic_json(path: str | Path) -> dict | None:
    """The JSON object of a file when it is the self-calibration of a robot of a kind of its own (a
    tricycle's, a mecanum robot's), else None (the file unread or another JSON: the differential
    drive's export reads and judges it)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # ValueError: not UTF-8, not JSON, a number of 5000 digits
        return None
    return d if isinstance(d, dict) and _exported(d.get("kinematics")) is not None else None


def format_edited_file(cal: KinematicCalibration, fmt: str, text: str, source: str) -> tuple[str, list[str]]:
    """A parameter file of the robot's own software with the values the calibration changes written in.

    Parameters
    ----------
    cal : KinematicCalibration
        With its nominal geometry.
    fmt : str
        One of the kind's :attr:`~umbmark.kinds.Kind.edited_files` formats (a car's ``vesc``).
    text : str
        The user's file, as read.
    source : str
        Its name.

    Returns
    -------
    tuple
        ``(new_text, lines)``: the file to write and what changed, in words.

    Raises
    ------
    InputError
        A format the kind does not edit this way, a calibration without its nominal geometry, a
        file without the values in use or with values that are not numbers or cannot be
        calibrated (:func:`umbmark.io.param_file.edit_parameter_file`).
    """
    from umbmark.io.param_file import edit_parameter_file, number_text

    kind = kind_named(cal.kind)
    spec = next((e for e in kind.edited_files if e.format == fmt), None)
    if spec is None:
        raise InputError(
            f"a {kind.noun}'s calibration edits no {fmt} file (its formats: {', '.join(kind.export_formats)})"
        )
    nominal = cal.nominal
    if nominal is None:
        raise InputError("no 'nominal' geometry: not the JSON of umbmark selfcal", cal.source)

    def compute(in_use):
        return kind.edited_values(fmt, cal.geometry, nominal, in_use)

    header = f"{', '.join(spec.changed)} calibrated by umbmark from {cal.source}:"
    new, edits = edit_parameter_file(text, source, spec.keys, compute, spec.describe, header)
    lines = [
        f"{e.key}{f' ({e.block})' if e.block else ''}: {number_text(e.old)} -> {number_text(e.new)}" for e in edits
    ]
    lines += [f"note: {n}" for n in kind.edited_notes(fmt, cal.geometry, cal.ci95)]
    if cal.joints is not None and spec.from_joints:
        lines.append(f"warning: {spec.from_joints}")
    return new, lines
