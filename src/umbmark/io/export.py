"""Write a calibration in the forms a robot's software loads.

Formats:

* ``ros2``: a ROS 2 ``diff_drive_controller`` parameter file
  (``<controller>: ros__parameters: {wheel_separation_multiplier, left_wheel_radius_multiplier,
  right_wheel_radius_multiplier}``);
* ``ros1``: the ROS 1 ``diff_drive_controller`` equivalent (``<controller>: {...}``);
* ``json``: wheel diameters, wheelbase, c_L, c_R, E_d, E_b (and mm per pulse when known);
* ``firmware``: a C header with the corrected millimetres per encoder pulse of each wheel
  and the corrected wheelbase.

Mapping (derivation in the README, "real robots"). diff_drive_controller computes the
travel of a wheel as ``wheel angle x wheel_radius x <side>_wheel_radius_multiplier`` and uses
``wheel_separation x wheel_separation_multiplier``. The logs were replayed with the odometry
the robot had (its multipliers ``m_L0``, ``m_R0``, ``m_b0``); the calibration says the
wheel travel of each side must be multiplied by ``c_L``, ``c_R`` and the wheelbase by ``E_b``:

    left_wheel_radius_multiplier  = m_L0 * c_L
    right_wheel_radius_multiplier = m_R0 * c_R
    wheel_separation_multiplier   = m_b0 * E_b
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from umbmark.errors import InputError
from umbmark.io.atomic import atomic_write

__all__ = ["ExportCalibration", "ros_multipliers", "format_export", "write_export", "FORMATS", "calibration_from_json"]

FORMATS = ("ros2", "ros1", "json", "firmware")


def _pos(name, v, source=None):
    if v is None or not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
        raise InputError(f"{name} must be a positive number, got {v!r}", source=source)
    return float(v)


@dataclass(frozen=True)
class ExportCalibration:
    """A correction relative to the odometry the data were recorded or replayed with.

    Attributes
    ----------
    c_left, c_right : float
        Factors on each wheel's travel.
    eb : float
        Factor on the wheelbase.
    nominal_diameter_left_m, nominal_diameter_right_m, nominal_wheelbase_m : float or None
        The nominal geometry (for ``json`` and ``firmware``).
    pulses_per_wheel_rev : float or None
        Encoder pulses per wheel revolution (for ``firmware``).
    source : str or None
        Where the calibration came from.
    method : str or None
        The method that computed it.

    Raises
    ------
    InputError
        A factor or size that is not a positive number.
    """

    c_left: float
    c_right: float
    eb: float
    nominal_diameter_left_m: float | None = None
    nominal_diameter_right_m: float | None = None
    nominal_wheelbase_m: float | None = None
    pulses_per_wheel_rev: float | None = None
    source: str | None = None
    method: str | None = None

    def __post_init__(self):
        for k in ("c_left", "c_right", "eb"):
            _pos(k, getattr(self, k), self.source)
        for k in ("nominal_diameter_left_m", "nominal_diameter_right_m", "nominal_wheelbase_m", "pulses_per_wheel_rev"):
            if getattr(self, k) is not None:
                _pos(k, getattr(self, k), self.source)

    @property
    def ed(self) -> float:
        """E_d = c_R / c_L."""
        return self.c_right / self.c_left


def calibration_from_json(path, dataset: str | None = None) -> ExportCalibration:
    """Read a calibration from the JSON of ``umbmark replay --json`` or ``umbmark analyze --json``.

    Parameters
    ----------
    path : str or Path
        The JSON file (one data set, a pooled fit, or several data sets).
    dataset : str, optional
        The data set to take from a report of several.

    Returns
    -------
    ExportCalibration
        With the nominal geometry when the JSON has it.

    Raises
    ------
    InputError
        Not such a JSON file; several data sets and no (or an unknown) ``dataset``.
    """
    src = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError("file not found" if not p.exists() else "not a file", source=src)
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8) file", source=src) from None
    except json.JSONDecodeError as e:
        raise InputError(f"not valid JSON: {e.msg}", source=src, line=e.lineno) from None
    except RecursionError:
        raise InputError("JSON nested too deeply: not the JSON of umbmark replay or analyze", source=src) from None
    if not isinstance(d, dict):
        raise InputError("expected a JSON object", source=src)
    if "datasets" in d and isinstance(d["datasets"], list) and d["datasets"] and isinstance(d["datasets"][0], dict):
        names = [x.get("dataset") for x in d["datasets"]]
        if dataset is None:
            raise InputError(
                f"holds {len(names)} data sets: choose one with `dataset` ({', '.join(map(str, names))})", source=src
            )
        if dataset not in names:
            raise InputError(f"no data set {dataset!r} (have {', '.join(map(str, names))})", source=src)
        d = d["datasets"][names.index(dataset)]
    for k in ("c_left", "c_right"):
        if k not in d:
            raise InputError(f"no {k!r}: not the JSON of umbmark replay or analyze", source=src)
    nom = d.get("nominal") or {}
    if not isinstance(nom, dict):
        raise InputError(f"'nominal' must be an object of nominal figures, got {nom!r}", source=src)
    for k in ("diameter_left_mm", "diameter_right_mm", "wheelbase_mm", "units_per_wheel_rev"):
        if nom.get(k) is not None:
            _pos(f"nominal {k}", nom[k], src)
    if "wheelbase_corrected_mm" in d and ("wheelbase_mm" in d or nom):
        used = nom.get("wheelbase_mm") if nom else d["wheelbase_mm"]
        eb = _pos("wheelbase_corrected_mm", d["wheelbase_corrected_mm"], src) / _pos("wheelbase_mm", used, src)
    elif "Eb" in d:
        eb = d["Eb"]
    else:
        raise InputError("no 'Eb' or wheelbase figures", source=src)
    mm = lambda v: None if v is None else v * 1e-3  # noqa: E731
    return ExportCalibration(
        d["c_left"],
        d["c_right"],
        eb,
        mm(nom.get("diameter_left_mm")),
        mm(nom.get("diameter_right_mm")),
        mm(nom.get("wheelbase_mm", d.get("wheelbase_mm"))),
        nom.get("units_per_wheel_rev"),
        src,
        d.get("method"),
    )


def ros_multipliers(cal: ExportCalibration, left0: float = 1.0, right0: float = 1.0, separation0: float = 1.0) -> dict:
    """The new diff_drive_controller multipliers, composed with those in use (see the module docstring).

    Parameters
    ----------
    cal : ExportCalibration
        The correction.
    left0, right0, separation0 : float
        The multipliers in use when the logs were recorded.

    Returns
    -------
    dict
        ``wheel_separation_multiplier``, ``left_wheel_radius_multiplier``,
        ``right_wheel_radius_multiplier``.

    Raises
    ------
    InputError
        A multiplier that is not a positive number.
    """
    for n, v in (("left multiplier", left0), ("right multiplier", right0), ("separation multiplier", separation0)):
        _pos(n, v)
    return {
        "wheel_separation_multiplier": separation0 * cal.eb,
        "left_wheel_radius_multiplier": left0 * cal.c_left,
        "right_wheel_radius_multiplier": right0 * cal.c_right,
    }


def _header(cal: ExportCalibration, comment: str) -> str:
    src = f" from {cal.source}" if cal.source else ""
    meth = f" (method {cal.method})" if cal.method else ""
    return (
        f"{comment} umbmark calibration{src}{meth}: E_d = {cal.ed:.6f}, c_L = {cal.c_left:.6f}, "
        f"c_R = {cal.c_right:.6f}, E_b = {cal.eb:.6f}\n"
    )


def format_export(
    cal: ExportCalibration,
    fmt: str,
    controller: str = "diff_drive_controller",
    left0: float = 1.0,
    right0: float = 1.0,
    separation0: float = 1.0,
    wheel_radius_m: float | None = None,
    wheel_separation_m: float | None = None,
) -> str:
    """The text of an export.

    Parameters
    ----------
    cal : ExportCalibration
        The correction.
    fmt : str
        One of :data:`FORMATS`.
    controller : str
        The controller's name (``ros2``, ``ros1``).
    left0, right0, separation0 : float
        The multipliers in use when the logs were recorded (``ros2``, ``ros1``).
    wheel_radius_m, wheel_separation_m : float, optional
        Also write ``wheel_radius`` / ``wheel_separation`` (``ros2``, ``ros1``).

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    InputError
        An unknown format, a bad controller name, a firmware export without the nominal
        diameters and pulses per revolution.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format {fmt!r} (choose from {', '.join(FORMATS)})")
    if fmt in ("ros2", "ros1"):
        if not controller or any(c in controller for c in ":{}[]#, \t\n"):
            raise InputError(f"bad controller name {controller!r}")
        params = ros_multipliers(cal, left0, right0, separation0)
        if wheel_radius_m is not None:
            params = {"wheel_radius": _pos("wheel radius", wheel_radius_m), **params}
        if wheel_separation_m is not None:
            params = {"wheel_separation": _pos("wheel separation", wheel_separation_m), **params}
        body = {controller: {"ros__parameters": params}} if fmt == "ros2" else {controller: params}
        note = (
            f"# composed with the multipliers in use: left {left0:.6g}, right {right0:.6g}, "
            f"separation {separation0:.6g}\n"
        )
        import yaml

        return _header(cal, "#") + note + yaml.safe_dump(body, sort_keys=False, default_flow_style=False)
    out = {"Ed": cal.ed, "Eb": cal.eb, "c_left": cal.c_left, "c_right": cal.c_right}
    if cal.nominal_diameter_left_m and cal.nominal_diameter_right_m:
        out["diameter_left_mm"] = cal.c_left * cal.nominal_diameter_left_m * 1e3
        out["diameter_right_mm"] = cal.c_right * cal.nominal_diameter_right_m * 1e3
    if cal.nominal_wheelbase_m:
        out["wheelbase_mm"] = cal.eb * cal.nominal_wheelbase_m * 1e3
    mmpp = None
    if cal.nominal_diameter_left_m and cal.nominal_diameter_right_m and cal.pulses_per_wheel_rev:
        k = math.pi / cal.pulses_per_wheel_rev * 1e3
        mmpp = (cal.c_left * cal.nominal_diameter_left_m * k, cal.c_right * cal.nominal_diameter_right_m * k)
        out["left_mm_per_pulse"], out["right_mm_per_pulse"] = mmpp
    if fmt == "json":
        return json.dumps(out, indent=2) + "\n"
    # firmware
    if mmpp is None:
        raise InputError(
            "the firmware export needs the nominal wheel diameters and encoder pulses per wheel "
            "revolution (give `wheel_diameter_mm` and `pulses_per_wheel_rev`, or use replay's JSON)"
        )
    lines = [
        "/* " + _header(cal, "").strip() + " */",
        "#ifndef UMBMARK_CALIBRATION_H",
        "#define UMBMARK_CALIBRATION_H",
        f"#define UMBMARK_LEFT_MM_PER_PULSE  {mmpp[0]:.9g}",
        f"#define UMBMARK_RIGHT_MM_PER_PULSE {mmpp[1]:.9g}",
    ]
    if "wheelbase_mm" in out:
        lines.append(f"#define UMBMARK_WHEELBASE_MM       {out['wheelbase_mm']:.6f}")
    lines.append("#endif")
    return "\n".join(lines) + "\n"


def write_export(text: str, path) -> None:
    """Write an export's text to a file, atomically.

    Parameters
    ----------
    text : str
        What :func:`format_export` gave.
    path : str or Path
        The file.
    """
    atomic_write(path, text)
