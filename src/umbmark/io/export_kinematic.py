"""Write a tricycle's or mecanum robot's self-calibration (its JSON, ``kinematics`` ``tricycle`` or
``mecanum``) in the forms its software loads.

Formats:

* ``ros2``: the controller's parameter file, its keys and types as in ros2_controllers'
  parameter definitions:

  - tricycle_controller: ``wheelbase`` and ``wheel_radius`` (doubles, metres). The steering
    offset has no parameter there: it belongs to the steering joint's transmission in the
    ros2_control hardware description (``transmission_interface/SimpleTransmission``, whose
    joint position is ``actuator / mechanical_reduction + offset``): the file ends with the
    ``<joint>`` element of that transmission as a comment, its ``<offset>`` the old one plus
    the estimate (and its ``<mechanical_reduction>`` the old one over the steering scale when
    that was estimated);
  - mecanum_drive_controller: ``kinematics.wheels_radius`` (the four wheels' mean) and
    ``kinematics.sum_of_robot_center_projection_on_X_Y_axis`` (doubles, metres). The
    controller has one radius for all wheels: where the four diameters differ beyond their 95 %
    intervals the file says so and gives each wheel's factor ``r_i / r_mean``, applied by
    dividing that wheel's transmission ``mechanical_reduction`` by it (its joint then reads
    the travel of the mean wheel, and its commands follow).

  The lidar's URDF origin and ``static_transform_publisher`` command end the file as
  comments.
* ``json``: the geometry in SI units and millimetres, the sensor pose, the per-wheel factors.
* ``urdf``, ``tf``: the lidar's mounting pose (as for a differential drive).

No ROS 1 controller of these kinds is standard: ``ros1`` and ``firmware`` are refused with
what to use instead.

Imports :mod:`umbmark.io.export` (its pose formats and the atomic writer) and pyyaml when a
parameter file is written.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from umbmark.errors import InputError
from umbmark.io.export import CONTROLLER_NAME, hash_comment, origin_element, transform_command, xml_comment

__all__ = [
    "read_kinematic_json",
    "KinematicCalibration",
    "kinematic_calibration_from_dict",
    "format_kinematic_export",
    "KINEMATIC_FORMATS",
    "CONTROLLERS",
    "wheel_factors",
]

KINEMATIC_FORMATS = ("ros2", "json", "urdf", "tf")
"""The export formats of a tricycle's or mecanum robot's calibration."""

CONTROLLERS = {"tricycle": "tricycle_controller", "mecanum": "mecanum_drive_controller"}
"""The ros2_controllers controller of each kind (the parameter file's default name)."""

_ROLES = ("front_left", "front_right", "rear_left", "rear_right")


def _num(d: dict, key: str, src: str) -> float:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{key!r} must be a number: not a tricycle's or mecanum robot's calibration", source=src)
    return float(v)


def _interval(v: Any) -> tuple[float, float] | None:
    if isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
        return float(v[0]), float(v[1])
    return None


@dataclass(frozen=True)
class KinematicCalibration:
    """A tricycle's or mecanum robot's calibration, as its export needs it (SI).

    Attributes
    ----------
    kind : str
        ``tricycle`` or ``mecanum``.
    wheel_diameters_m : tuple of float
        The traction wheel's (one) or the four wheels' (FL, FR, RL, RR).
    diameter_ci95_m : tuple
        Their 95 % intervals (``None`` where unknown).
    wheelbase_m : float or None
        A tricycle's.
    steering_offset_rad, steering_scale : float
        A tricycle's (offset 0, scale 1 otherwise).
    steering_scale_estimated : bool
    lx_plus_ly_m : float or None
        A mecanum robot's.
    sensor_pose : tuple of float
        ``(x, y, z, roll, pitch, yaw)`` of the lidar (z, roll, pitch from ``/tf_static``, else 0).
    sensor_height_known : bool
    base_frame, sensor_frame : str
    source : str
    warnings : tuple of str
        The calibration's own warnings.
    """

    kind: str
    wheel_diameters_m: tuple[float, ...]
    diameter_ci95_m: tuple[tuple[float, float] | None, ...]
    wheelbase_m: float | None
    steering_offset_rad: float
    steering_scale: float
    steering_scale_estimated: bool
    lx_plus_ly_m: float | None
    sensor_pose: tuple[float, float, float, float, float, float]
    sensor_height_known: bool
    base_frame: str
    sensor_frame: str
    source: str
    warnings: tuple[str, ...] = ()


def kinematic_calibration_from_dict(d: dict, source: str = "<json>") -> KinematicCalibration:
    """The calibration in the JSON of a tricycle's or mecanum robot's self-calibration (``umbmark selfcal``).

    Raises
    ------
    InputError
        Another JSON, or values that are not positive numbers where they must be.
    """
    kind = d.get("kinematics")
    if kind not in CONTROLLERS:
        raise InputError("no 'kinematics' of a tricycle or mecanum robot: not the JSON of umbmark selfcal", source)
    if kind == "tricycle":
        dia: tuple[float, ...] = (_num(d, "wheel_diameter_mm", source) * 1e-3,)
        cis: tuple[tuple[float, float] | None, ...] = (_interval(d.get("wheel_diameter_mm_ci95")),)
        base: float | None = _num(d, "wheelbase_mm", source) * 1e-3
        offset = math.radians(_num(d, "steering_offset_deg", source))
        scale = _num(d, "steering_scale", source) if d.get("steering_scale") is not None else 1.0
        scaled = d.get("steering_scale_ci95") is not None
        k = None
    else:
        wd, wci = d.get("wheel_diameters_mm"), d.get("wheel_diameters_mm_ci95") or {}
        if not isinstance(wd, dict) or set(wd) != set(_ROLES):
            raise InputError("'wheel_diameters_mm' must hold front_left, front_right, rear_left, rear_right", source)
        dia = tuple(_num(wd, r, source) * 1e-3 for r in _ROLES)
        cis = tuple(None if (c := _interval(wci.get(r))) is None else (c[0] * 1e-3, c[1] * 1e-3) for r in _ROLES)
        base, offset, scale, scaled = None, 0.0, 1.0, False
        k = _num(d, "lx_plus_ly_mm", source) * 1e-3
    if kind == "tricycle" and cis[0] is not None:
        lo_hi = cis[0]
        cis = ((lo_hi[0] * 1e-3, lo_hi[1] * 1e-3),)
    for v in dia + tuple(x for x in (base, k) if x is not None):
        if not v > 0:
            raise InputError("a diameter, wheelbase or lx + ly that is not positive", source)
    sp = d.get("sensor_pose")
    if not isinstance(sp, dict):
        raise InputError("no 'sensor_pose': not the JSON of umbmark selfcal", source)
    x, y, yaw = (
        _num(sp, "x_mm", source) * 1e-3,
        _num(sp, "y_mm", source) * 1e-3,
        math.radians(_num(sp, "yaw_deg", source)),
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
            z, known = _num(nsp, "z_mm", source) * 1e-3, True
            roll, pitch = math.radians(_num(nsp, "roll_deg", source)), math.radians(_num(nsp, "pitch_deg", source))
        base_frame = str(first.get("base_frame") or base_frame)
        sensor_frame = str(first.get("scan_frame") or sensor_frame)
    warns = tuple(str(w) for w in d.get("warnings", []) if isinstance(w, str))
    return KinematicCalibration(
        kind, dia, cis, base, offset, scale, scaled, k, (x, y, z, roll, pitch, yaw), known, base_frame, sensor_frame,
        source, warns,
    )  # fmt: skip


def wheel_factors(cal: KinematicCalibration) -> tuple[tuple[float, ...], bool]:
    """Each wheel's diameter over the mean, and whether they differ beyond their 95 % intervals
    (some wheel's interval leaves out the mean)."""
    mean = sum(cal.wheel_diameters_m) / len(cal.wheel_diameters_m)
    factors = tuple(d / mean for d in cal.wheel_diameters_m)
    apart = any(ci is not None and not ci[0] <= mean <= ci[1] for ci in cal.diameter_ci95_m)
    return factors, apart and len(factors) > 1


def _params(cal: KinematicCalibration) -> dict[str, Any]:
    if cal.kind == "tricycle":
        assert cal.wheelbase_m is not None
        return {"wheelbase": float(cal.wheelbase_m), "wheel_radius": float(0.5 * cal.wheel_diameters_m[0])}
    assert cal.lx_plus_ly_m is not None
    mean = sum(cal.wheel_diameters_m) / 4.0
    return {
        "kinematics": {
            "wheels_radius": float(0.5 * mean),
            "sum_of_robot_center_projection_on_X_Y_axis": float(cal.lx_plus_ly_m),
        }
    }


def _steering_note(cal: KinematicCalibration, offset0: float, reduction0: float) -> list[str]:
    # true = scale (actuator / reduction0 + offset0) + offset
    #      = actuator / (reduction0 / scale) + (scale offset0 + offset)
    scale = cal.steering_scale if cal.steering_scale_estimated else 1.0
    off = scale * offset0 + cal.steering_offset_rad
    red = reduction0 / scale
    return [
        f"the steering offset {math.degrees(cal.steering_offset_rad):.4f} deg "
        f"({cal.steering_offset_rad:.6f} rad: true angle = measured + offset) belongs to the steering joint's",
        "transmission in the ros2_control hardware description (SimpleTransmission: joint = actuator /",
        f"mechanical_reduction + offset), composed with the one in use ({offset0:g} rad, reduction {reduction0:g}):",
        '  <joint name="STEERING_JOINT" role="joint1">',
        f"    <mechanical_reduction>{red:.9g}</mechanical_reduction>",
        f"    <offset>{off:.9g}</offset>",
        "  </joint>",
    ]


def _wheel_note(cal: KinematicCalibration) -> list[str]:
    factors, apart = wheel_factors(cal)
    if not apart:
        return [
            "the four wheel diameters agree within their 95 % intervals: wheels_radius is their mean "
            f"({', '.join(f'{d * 1e3:.3f}' for d in cal.wheel_diameters_m)} mm)"
        ]
    lines = [
        "the four wheel diameters differ beyond their 95 % intervals "
        f"({', '.join(f'{r} {d * 1e3:.3f} mm' for r, d in zip(_ROLES, cal.wheel_diameters_m))});",
        "mecanum_drive_controller has one radius (their mean): make each wheel's joint read the mean wheel's",
        "travel by dividing the mechanical_reduction of its transmission by its factor (r_i / r_mean):",
    ]
    lines += [f"  {r}: {f:.6f}" for r, f in zip(_ROLES, factors)]
    return lines


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
    """The text of an export of a tricycle's or mecanum robot's calibration.

    Parameters
    ----------
    cal : KinematicCalibration
    fmt : str
        One of :data:`KINEMATIC_FORMATS`.
    controller : str, optional
        The controller's name in the parameter file (default the kind's, :data:`CONTROLLERS`).
    steering_offset0_rad, steering_reduction0 : float
        A tricycle's steering transmission in use when the bag was recorded (offset, reduction).

    Returns
    -------
    str

    Raises
    ------
    InputError
        An unknown or unsupported format, a bad controller name.
    """
    if fmt in ("ros1", "firmware"):
        raise InputError(
            f"no standard {'ROS 1 controller' if fmt == 'ros1' else 'firmware'} for a {cal.kind}: export it as "
            f"ros2 ({CONTROLLERS[cal.kind]}), json, urdf or tf"
        )
    if fmt not in KINEMATIC_FORMATS:
        raise InputError(f"unknown export format {fmt!r} (choose from {', '.join(KINEMATIC_FORMATS)})")
    if not (math.isfinite(steering_offset0_rad) and math.isfinite(steering_reduction0) and steering_reduction0 != 0):
        raise InputError("the steering transmission in use needs a finite offset and a non-zero reduction")
    if abs(steering_offset0_rad) > math.pi:
        raise InputError(
            f"the steering offset in use, {math.degrees(steering_offset0_rad):g} deg ({steering_offset0_rad:g} "
            "rad), is beyond half a turn: no steering transmission's offset (an angle in another unit?)"
        )
    noun = "tricycle" if cal.kind == "tricycle" else "mecanum robot"
    head = f"umbmark self-calibration of a {noun} from {cal.source}"
    if fmt == "urdf":
        warn = "".join(f"<!-- warning: {xml_comment(w)} -->\n" for w in cal.warnings)
        return f"<!-- {xml_comment(head)} -->\n{warn}{origin_element(cal.sensor_pose)}\n"
    if fmt == "tf":
        return hash_comment(head) + transform_command(cal.sensor_pose, cal.base_frame, cal.sensor_frame) + "\n"
    if fmt == "json":
        return json.dumps(_json(cal), indent=2) + "\n"
    name = controller or CONTROLLERS[cal.kind]
    if not CONTROLLER_NAME.fullmatch(name):
        raise InputError(f"bad controller name {name!r} (letters, digits, _ / ~ . -)")
    import yaml

    notes = (
        _steering_note(cal, steering_offset0_rad, steering_reduction0) if cal.kind == "tricycle" else _wheel_note(cal)
    )
    text = hash_comment(head) + "".join(hash_comment("warning: " + w) for w in cal.warnings)
    text += yaml.safe_dump({name: {"ros__parameters": _params(cal)}}, sort_keys=False, default_flow_style=False)
    return text + "".join(hash_comment(line) for line in notes + _sensor_lines(cal))


def _json(cal: KinematicCalibration) -> dict[str, Any]:
    x, y, z, roll, pitch, yaw = cal.sensor_pose
    out: dict[str, Any] = {"kinematics": cal.kind, "source": cal.source, "parameters": _params(cal)}
    if cal.kind == "tricycle":
        out["steering_offset_rad"] = cal.steering_offset_rad
        out["steering_scale"] = cal.steering_scale
    else:
        factors, apart = wheel_factors(cal)
        out["wheel_diameters_mm"] = {r: d * 1e3 for r, d in zip(_ROLES, cal.wheel_diameters_m)}
        out["wheel_factors"] = dict(zip(_ROLES, factors))
        out["wheels_differ"] = apart
    out["sensor_pose"] = {"x_m": x, "y_m": y, "z_m": z, "roll_rad": roll, "pitch_rad": pitch, "yaw_rad": yaw}
    out["warnings"] = list(cal.warnings)
    return out


def read_kinematic_json(path: str | Path) -> dict | None:
    """The JSON object of a file when it is a tricycle's or mecanum robot's self-calibration, else None
    (the file unread or another JSON: the differential drive's export reads and judges it)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # ValueError: not UTF-8, not JSON, a number of 5000 digits
        return None
    return d if isinstance(d, dict) and d.get("kinematics") in CONTROLLERS else None
