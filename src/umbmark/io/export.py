"""Write a calibration in the forms a robot's software loads.

Formats:

* ``ros2``: a ROS 2 ``diff_drive_controller`` parameter file
  (``<controller>: ros__parameters: {wheel_separation_multiplier, left_wheel_radius_multiplier,
  right_wheel_radius_multiplier}``);
* ``ros1``: the ROS 1 ``diff_drive_controller`` equivalent (``<controller>: {...}``);
* ``json``: wheel diameters, wheelbase, c_L, c_R, E_d, E_b (and mm per pulse when known);
* ``firmware``: a C header with the corrected millimetres per encoder pulse of each wheel
  and the corrected wheelbase;
* ``urdf``: the lidar's mounting pose as the ``<origin xyz="..." rpy="..."/>`` of its URDF
  joint (a lidar self-calibration only);
* ``tf``: the same pose as a ``static_transform_publisher`` command line (ROS 2 syntax; the
  ROS 1 one as a comment).

A lidar self-calibration (the JSON of ``umbmark selfcal``) also carries the sensor pose: the
``ros2`` and ``ros1`` exports then end with the URDF origin and the ``static_transform_publisher``
command as comments, ``json`` with the pose. Its wheel factors are the estimated diameters over
the nominal one (``c_L = D_L / D_n``, ``c_R = D_R / D_n``) and ``E_b``. The pose's height, roll
and pitch are not seen by a planar calibration: they are kept from the nominal mounting pose
(``/tf_static``), zero without it.

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
import re
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.io._text import parse_json
from umbmark.io.atomic import atomic_write
from umbmark.kinds import DEFAULT_KIND, KINDS
from umbmark.model.geometry import unit_slip

__all__ = [
    "ExportCalibration",
    "calibration_from_dict",
    "ros_multipliers",
    "format_export",
    "write_export",
    "FORMATS",
    "calibration_from_json",
    "urdf_origin",
    "origin_element",
    "static_transform_command",
    "transform_command",
    "export_warnings",
    "scale_note",
    "FACTOR_LIMITS",
    "PLAUSIBLE_FACTORS",
    "IN_USE_LIMITS",
]

FORMATS = KINDS[DEFAULT_KIND].export_formats
"""The formats of a differential drive's calibration: its kind's (:attr:`umbmark.kinds.Kind.export_formats`,
the registry the command line's choice of export formats is made from)."""
_SENSOR_FORMATS = ("urdf", "tf")
# the arguments of ROS 2's tf2_ros static_transform_publisher, in its order
_TF2_ARGS = ("x", "y", "z", "roll", "pitch", "yaw", "frame-id", "child-frame-id")


_FRAME = re.compile(r"[A-Za-z0-9_./][A-Za-z0-9_./-]*")
CONTROLLER_NAME = re.compile(r"[A-Za-z0-9_~/.][A-Za-z0-9_~/.-]*")
_PARAM_TICKS = re.compile(r"`([^`]*)`")

# a factor outside these is no correction of a wheel or a wheelbase: refused
FACTOR_LIMITS = (1e-3, 1e3)
# sizes and counts written (mm, pulses per revolution, mm per pulse): refused outside these
_SIZE_LIMITS = (1e-9, 1e12)
# factors beyond these are far from any calibration of a real robot: a warning
PLAUSIBLE_FACTORS = {"c": (0.8, 1.25), "Ed": (0.8, 1.25), "Eb": (0.5, 2.0)}
# a multiplier in use beyond these corrects a controller's wheel_radius or wheel_separation set an order
# of magnitude off (a unit slip in its configuration) or is a size typed for the multiplier: refused
IN_USE_LIMITS = (0.1, 10.0)
# a wheel travel variance per metre beyond this (10 cm after 1 m, one standard deviation) is no odometry
MAX_WHEEL_VARIANCE_M = 0.01
# the multipliers in use: parameter (as messages name it), the controller's name, the factor it scales
_IN_USE = (
    ("left_multiplier", "left_wheel_radius_multiplier", "c"),
    ("right_multiplier", "right_wheel_radius_multiplier", "c"),
    ("separation_multiplier", "wheel_separation_multiplier", "Eb"),
)


def _plain(text: object) -> str:
    """A string as one line of plain text: control characters, line and paragraph separators
    (a newline, NUL, U+2028 ...) and format characters written as escapes (``\\x0a``)."""
    out = []
    for ch in str(text):
        if unicodedata.category(ch) in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"):
            out.append(f"\\x{ord(ch):02x}" if ord(ch) < 256 else f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return "".join(out)


def _c_comment(text: str) -> str:
    """Text for the inside of a C comment: one line, no ``*/`` (nor ``/*``)."""
    return _plain(text).replace("*/", "*\\/").replace("/*", "/\\*")


def xml_comment(text: str) -> str:
    """Text for the inside of an XML comment: one line, no ``--``, not ending in ``-``."""
    t = re.sub(r"-(?=-)", "- ", _plain(text))
    return t + " " if t.endswith("-") else t


def _finite(name: str, v: object, source: str | None = None) -> float:
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
        raise InputError(f"{name} must be a finite number, got {v!r}", source=source)
    return float(v)


def _pos(name: str, v: object, source: str | None = None) -> float:
    return positive(name, v, source=source)


def _factor(name: str, v: object, source: str | None = None) -> float:
    """A correction factor: positive, finite, within :data:`FACTOR_LIMITS`."""
    v = _pos(name, v, source)
    lo, hi = FACTOR_LIMITS
    if not lo <= v <= hi:
        raise InputError(
            f"{name} = {v:.6g} is not a correction factor (a wheel or wheelbase {lo:g} to {hi:g} times the nominal "
            "one): refusing to export it",
            source=source,
        )
    return v


def _size(name: str, v: object, source: str | None = None) -> float:
    """A size or count to write: positive, finite, within :data:`_SIZE_LIMITS`."""
    v = _pos(name, v, source)
    lo, hi = _SIZE_LIMITS
    if not lo <= v <= hi:
        raise InputError(f"{name} = {v:.6g} is not a usable value ({lo:g} to {hi:g}): refusing to export it", source)
    return v


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
    sensor_pose : tuple of float or None
        The lidar's pose on the robot ``(x_m, y_m, yaw_rad)`` (a self-calibration).
    sensor_z_m, sensor_roll_rad, sensor_pitch_rad : float
        The rest of its mounting pose (not calibrated: the nominal one).
    base_frame, sensor_frame : str
        The frames of the transform (``base_link`` -> ``laser``).
    scale_observed : bool or None
        Whether the method measured the wheel scale (the mean diameter): False for ``bf`` and
        for ``exact`` without a straight run (a closed square hides it), True for ``lsq`` with
        the scale fitted and for a lidar self-calibration, None when unknown.
    odometry_noise_m : tuple of float or None
        Each wheel's travel variance per metre ``(k_left, k_right)`` [m^2/m] (a self-calibration
        that estimated the odometry's noise): the ``ros2``, ``ros1`` and ``json`` exports then
        carry ``pose_covariance_diagonal`` and ``twist_covariance_diagonal``.
    sensor_height_known : bool
        Whether ``sensor_z_m`` (and roll, pitch) came from somewhere (``/tf_static``, the
        user): False for a self-calibration whose bag had no ``/tf_static`` for the lidar.
    input_warnings : tuple of str
        The warnings the calibration's own JSON carried (``warnings``), passed on by the JSON
        export as ``input_warnings``.
    wheels_include_prior : bool
        ``c_left`` and ``c_right`` already include the wheel factors the robot ran with (the
        JSON of ``analyze`` given a prior calibration: they are relative to the nominal wheels).

    Raises
    ------
    InputError
        A factor or size that is not a positive number, a factor outside
        :data:`FACTOR_LIMITS`, a sensor pose that is not finite, a frame name with spaces,
        quotes or markup characters.
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
    sensor_pose: tuple[float, float, float] | None = None
    sensor_z_m: float = 0.0
    sensor_roll_rad: float = 0.0
    sensor_pitch_rad: float = 0.0
    base_frame: str = "base_link"
    sensor_frame: str = "laser"
    scale_observed: bool | None = None
    wheels_include_prior: bool = False
    input_warnings: tuple[str, ...] = ()
    sensor_height_known: bool = True
    odometry_noise_m: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for k in ("c_left", "c_right", "eb"):
            object.__setattr__(self, k, _factor(k, getattr(self, k), self.source))
        for k in ("nominal_diameter_left_m", "nominal_diameter_right_m", "nominal_wheelbase_m"):
            if getattr(self, k) is not None:
                _size(k[:-2] + "_mm", getattr(self, k) * 1e3, self.source)
                slip = unit_slip("wheelbase" if "wheelbase" in k else "diameter", getattr(self, k), "mm")
                if slip is not None:  # a size no robot has: written, it would be loaded as it is
                    raise InputError(f"{k[:-2]}_mm: {slip}: refusing to export it", self.source)
        if self.pulses_per_wheel_rev is not None:
            object.__setattr__(
                self, "pulses_per_wheel_rev", _size("pulses_per_wheel_rev", self.pulses_per_wheel_rev, self.source)
            )
        if self.source is not None:
            object.__setattr__(self, "source", str(self.source))
        if self.method is not None:
            object.__setattr__(self, "method", str(self.method))
        if self.sensor_pose is not None:
            pose = tuple(_finite("sensor_pose", v, self.source) for v in self.sensor_pose)
            if len(pose) != 3:
                raise InputError(f"sensor_pose must be (x_m, y_m, yaw_rad), got {self.sensor_pose!r}", self.source)
            object.__setattr__(self, "sensor_pose", pose)
        for k in ("sensor_z_m", "sensor_roll_rad", "sensor_pitch_rad"):
            object.__setattr__(self, k, _finite(k, getattr(self, k), self.source))
        if self.odometry_noise_m is not None:
            k2 = tuple(_finite("odometry noise", v, self.source) for v in self.odometry_noise_m)
            if len(k2) != 2 or min(k2) < 0 or max(k2) > MAX_WHEEL_VARIANCE_M:
                raise InputError(
                    f"odometry noise must be two variances per metre in [0, {MAX_WHEEL_VARIANCE_M:g}] m^2/m, "
                    f"got {self.odometry_noise_m!r}",
                    self.source,
                )
            object.__setattr__(self, "odometry_noise_m", k2)
        for k in ("base_frame", "sensor_frame"):
            v = getattr(self, k)
            if not isinstance(v, str) or not _FRAME.fullmatch(v):
                raise InputError(f"{k} must be a frame name (letters, digits, _ / . -), got {v!r}", self.source)

    @property
    def ed(self) -> float:
        """E_d = c_R / c_L."""
        return self.c_right / self.c_left


def _selfcal_calibration(d: dict, src: str) -> ExportCalibration:
    """The calibration in the JSON of ``umbmark selfcal``."""
    for k in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "nominal_wheel_diameter_mm", "sensor_pose"):
        if d.get(k) is None:
            raise InputError(f"no {k!r}: not the JSON of umbmark selfcal", source=src)
    dn = _pos("nominal_wheel_diameter_mm", d["nominal_wheel_diameter_mm"], src)
    dl = _pos("wheel_diameter_left_mm", d["wheel_diameter_left_mm"], src)
    dr = _pos("wheel_diameter_right_mm", d["wheel_diameter_right_mm"], src)
    bn = d.get("nominal_wheelbase_mm")
    if d.get("Eb") is not None:
        eb = d["Eb"]
    elif d.get("wheelbase_mm") is not None and bn is not None:
        eb = _pos("wheelbase_mm", d["wheelbase_mm"], src) / _pos("nominal_wheelbase_mm", bn, src)
    else:
        raise InputError("no 'Eb' or wheelbase figures", source=src)
    sp = d["sensor_pose"]
    if not isinstance(sp, dict):
        raise InputError(f"'sensor_pose' must be an object (x_mm, y_mm, yaw_deg), got {sp!r}", source=src)
    for k in ("x_mm", "y_mm", "yaw_deg"):
        _finite(f"sensor_pose {k}", sp.get(k), src)
    nom = d.get("nominal_sensor_pose") or {}
    if not isinstance(nom, dict):
        raise InputError(f"'nominal_sensor_pose' must be an object, got {nom!r}", source=src)
    rest = {k: _finite(f"nominal_sensor_pose {k}", nom.get(k, 0.0), src) for k in ("z_mm", "roll_deg", "pitch_deg")}
    return ExportCalibration(
        dl / dn,
        dr / dn,
        eb,
        dn * 1e-3,
        dn * 1e-3,
        None if bn is None else _pos("nominal_wheelbase_mm", bn, src) * 1e-3,
        None,
        src,
        "selfcal",
        (sp["x_mm"] * 1e-3, sp["y_mm"] * 1e-3, math.radians(sp["yaw_deg"])),
        rest["z_mm"] * 1e-3,
        math.radians(rest["roll_deg"]),
        math.radians(rest["pitch_deg"]),
        str(d.get("base_frame") or "base_link"),
        str(d.get("sensor_frame") or "laser"),
        scale_observed=True,
        sensor_height_known=str(nom.get("source") or "").startswith("/tf_static"),
        odometry_noise_m=_odometry_noise(d.get("odometry_noise"), src),
    )


def _odometry_noise(noise: object, src: str) -> tuple[float, float] | None:
    """Each wheel's variance per metre from a selfcal (or replay) JSON's ``odometry_noise``, None where absent."""
    if noise is None:
        return None
    keys = ("wheel_variance_left_m2_per_m", "wheel_variance_right_m2_per_m")
    if not isinstance(noise, dict) or any(k not in noise for k in keys):
        raise InputError(f"'odometry_noise' must be an object with {' and '.join(keys)}, got {noise!r}", source=src)
    left, right = (_finite(f"odometry_noise {k}", noise[k], src) for k in keys)
    return left, right


def _scale_observed(d: dict) -> bool | None:
    """Whether the method behind a replay or analyze JSON measured the wheel scale."""
    method = d.get("method")
    if method == "lsq":
        return bool(d["scale_fitted"]) if isinstance(d.get("scale_fitted"), bool) else None
    if method == "bf":
        return False
    if method == "exact":  # measured only with a straight run: E_s of the pass is then not exactly 1
        es = d.get("Es_pass")
        return isinstance(es, (int, float)) and not isinstance(es, bool) and es != 1.0
    return None


def _includes_prior(d: dict) -> bool:
    """An analyze JSON whose c_left, c_right compose a prior calibration with this pass's."""
    ed, ed_pass = d.get("Ed"), d.get("Ed_pass")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in (ed, ed_pass)):
        return False
    assert ed is not None and ed_pass is not None  # positive numbers, just checked
    return abs(ed / ed_pass - 1.0) > 1e-12


def _calibrate_calibration(d: dict, src: str) -> ExportCalibration:
    """The final calibration in the JSON of ``umbmark calibrate``: its factors relative to the
    odometry of the first pass."""
    final, passes = d.get("final_calibration"), d.get("passes")
    if not isinstance(final, dict) or not isinstance(passes, list) or not passes or not isinstance(passes[0], dict):
        raise InputError("no final calibration: not the JSON of umbmark calibrate (or the loop made none)", src)
    first = passes[0].get("calibration_used")
    if not isinstance(first, dict):
        raise InputError("no 'calibration_used' in the first pass: not the JSON of umbmark calibrate", src)
    b0 = _pos("wheelbase_mm of the first pass", first.get("wheelbase_mm"), src)
    b = _pos("final wheelbase_mm", final.get("wheelbase_mm"), src)
    return ExportCalibration(
        _factor("c_left", final.get("c_left"), src),
        _factor("c_right", final.get("c_right"), src),
        b / b0,
        nominal_wheelbase_m=b0 * 1e-3,
        source=src,
        method=d.get("method"),
        scale_observed=False,
    )


def _history_calibration(d: dict, src: str) -> ExportCalibration:
    """The parameters of ``umbmark history ROBOT --export``: E_b from the corrected and the
    nominal wheelbase it names (a file without ``corrected_wheelbase_mm`` held the corrected
    wheelbase as ``wheelbase_mm``: its nominal one is that over E_b)."""
    mm = lambda k: None if d.get(k) is None else _pos(k, d[k], src) * 1e-3  # noqa: E731
    eb = _pos("Eb", d.get("Eb"), src)
    if "corrected_wheelbase_mm" in d:
        b, b0 = mm("corrected_wheelbase_mm"), mm("nominal_wheelbase_mm")
        eb = b / b0 if b is not None and b0 is not None else eb
    else:
        b = mm("wheelbase_mm")
        b0 = None if b is None else b / eb
    sp = d.get("sensor_pose")
    pose = None
    if isinstance(sp, dict):  # a self-calibration's lidar pose
        x, y, yaw = (_finite(f"sensor_pose {k}", sp.get(k), src) for k in ("x_mm", "y_mm", "yaw_deg"))
        pose = (x * 1e-3, y * 1e-3, math.radians(yaw))
    scale = d.get("scale_observed")
    in_use = d.get("parameters_in_use")
    piu = in_use if isinstance(in_use, dict) else {}
    prior = [piu.get(k) for k in ("c_left", "c_right")]  # the wheel factors the robot ran with
    with_prior = any(isinstance(v, (int, float)) and not isinstance(v, bool) and v != 1.0 for v in prior)
    dl0, dr0 = mm("nominal_diameter_left_mm"), mm("nominal_diameter_right_mm")
    return ExportCalibration(
        _factor("c_left", d.get("c_left"), src),
        _factor("c_right", d.get("c_right"), src),
        eb,
        dl0,
        dr0,
        b0,
        d.get("units_per_wheel_rev"),
        src,
        d.get("method"),
        pose,
        scale_observed=scale if isinstance(scale, bool) else None,
        wheels_include_prior=with_prior,
    )


def calibration_from_json(path: str | Path, dataset: str | None = None) -> ExportCalibration:
    """Read a calibration from the JSON of ``umbmark replay --json``, ``umbmark analyze --json``,
    ``umbmark calibrate --json`` or ``umbmark selfcal --json``.

    Parameters
    ----------
    path : str or Path
        The JSON file (one data set, a pooled fit, or several data sets).
    dataset : str, optional
        The data set to take from a report of several.

    Returns
    -------
    ExportCalibration
        With the nominal geometry when the JSON has it, and the sensor pose of a
        self-calibration.

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
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8) file", source=src) from None
    d = parse_json(text, src)
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
    elif dataset is not None and dataset != d.get("dataset"):
        name = d.get("dataset")
        raise InputError(
            f"holds one calibration{f' (of data set {name!r})' if isinstance(name, str) else ''}, not a data set "
            f"{dataset!r}: `dataset` chooses among the data sets of a replay of several; leave it out",
            source=src,
        )
    return calibration_from_dict(d, src)


def calibration_from_dict(d: dict, source: str = "<json>") -> ExportCalibration:
    """:func:`calibration_from_json` of one calibration's JSON object, already read.

    Parameters
    ----------
    d : dict
        The JSON of one data set or fit.
    source : str
        Its name in errors.

    Returns
    -------
    ExportCalibration
        With the JSON's warnings as ``input_warnings``.

    Raises
    ------
    InputError
        Not the JSON of a calibration.
    """
    cal = _calibration_from_dict(d, source)
    warns = d.get("warnings")
    if isinstance(warns, list) and warns:
        cal = replace(cal, input_warnings=tuple(str(w) for w in warns))
    return cal


def _calibration_from_dict(d: dict, src: str) -> ExportCalibration:
    """:func:`calibration_from_json` on the JSON object of one calibration."""
    if "record_id" in d and ("corrected_wheelbase_mm" in d or "emax_syst_mm_measured" in d):
        return _history_calibration(d, src)  # umbmark history ROBOT --export
    if d.get("method") == "selfcal" or ("sensor_pose" in d and "nominal_wheel_diameter_mm" in d):
        return _selfcal_calibration(d, src)
    if "final_calibration" in d:
        return _calibrate_calibration(d, src)
    if isinstance(d.get("gyro"), dict) and "c_left" not in d:
        return _gyro_calibration(d["gyro"], src)
    for k in ("c_left", "c_right"):
        if k not in d:
            raise InputError(f"no {k!r}: not the JSON of umbmark replay or analyze", source=src)
    nom = d.get("nominal") or {}
    if not isinstance(nom, dict):
        raise InputError(f"'nominal' must be an object of nominal figures, got {nom!r}", source=src)
    for k in ("diameter_left_mm", "diameter_right_mm", "wheelbase_mm", "units_per_wheel_rev"):
        if nom.get(k) is not None:
            _pos(f"nominal {k}", nom[k], src)
            slip = None if k == "units_per_wheel_rev" else unit_slip(k.split("_")[0], nom[k] * 1e-3, "mm")
            if slip is not None:  # before the factors, which such a size makes absurd
                raise InputError(f"nominal {k}: {slip}: refusing to export it", source=src)
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
        scale_observed=_scale_observed(d),
        wheels_include_prior=_includes_prior(d),
        odometry_noise_m=_odometry_noise(d.get("odometry_noise"), src),  # replay --noise, where it holds
    )


def _gyro_calibration(g: dict, src: str) -> ExportCalibration:
    """The gyro's result (``umbmark replay --imu-topic``): its E_b; the wheels as they are (a
    gyro sees no wheel scale or diameter ratio)."""
    eb = _pos("gyro Eb", g.get("Eb"), src)
    b = g.get("nominal_wheelbase_m")
    return ExportCalibration(
        1.0,
        1.0,
        eb,
        None,
        None,
        None if b is None else _pos("gyro nominal_wheelbase_m", b, src),
        None,
        src,
        "gyro",
        scale_observed=False,
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
        A multiplier (in use or new) that is not a positive number within :data:`FACTOR_LIMITS`.
    """
    for (param, ros, _), v in zip(_IN_USE, (left0, right0, separation0)):
        _pos(f"the {ros} in use (`{param}`)", v)
        lo, hi = IN_USE_LIMITS
        if not lo <= v <= hi:
            raise InputError(
                f"the {ros} in use (`{param}`) is {v:g}: no controller runs with a multiplier beyond {lo:g} to "
                f"{hi:g} (a size given for the multiplier?); give the controller's {ros} (1 unless it was changed)"
            )
    out = {
        "wheel_separation_multiplier": separation0 * cal.eb,
        "left_wheel_radius_multiplier": left0 * cal.c_left,
        "right_wheel_radius_multiplier": right0 * cal.c_right,
    }
    for k, v in out.items():
        _factor(k, v, cal.source)
    return out


def _header(cal: ExportCalibration, comment: str) -> str:
    """The first comment line (plain text: the caller escapes it for its format)."""
    src = f" from {cal.source}" if cal.source else ""
    meth = f" (method {cal.method})" if cal.method else ""
    return (
        f"{comment} umbmark calibration{src}{meth}: E_d = {cal.ed:.6f}, c_L = {cal.c_left:.6f}, "
        f"c_R = {cal.c_right:.6f}, E_b = {cal.eb:.6f}\n"
    )


def scale_note(cal: ExportCalibration) -> str | None:
    """What the export says about the wheel scale when the method could not see it.

    Parameters
    ----------
    cal : ExportCalibration
        The calibration.

    Returns
    -------
    str or None
        None when the scale was measured (``scale_observed`` True) or nothing is known of
        the method; else one line saying the mean wheel diameter is the nominal one and how to
        measure it.
    """
    if cal.scale_observed is not False:
        return None
    if cal.method == "gyro":
        return (
            "wheels not measured: a gyro sees the turns only (the wheelbase), not the mean wheel diameter nor "
            "E_d, so the wheel factors stay 1; measure them with selfcal (a lidar) or replay with a ground truth"
        )
    how = _plain(cal.method) if cal.method else "this method"
    return (
        f"wheel scale not measured: {how} cannot see it (a closed square hides the mean wheel diameter), so "
        "the wheel factors keep the nominal mean diameter; measure the scale with a straight run of known "
        "length (analyze, method exact, `straight_mm`) or a ground-truth or lidar track (replay, method lsq)"
    )


def _outside(name: str, v: float, key: str) -> str | None:
    lo, hi = PLAUSIBLE_FACTORS[key]
    if lo <= v <= hi:
        return None
    return (
        f"{name} = {v:.6g} is far outside the corrections of real robots ({lo:g} to {hi:g}): check the "
        "calibration (units, the nominal geometry it was made with) before loading it"
    )


def export_warnings(
    cal: ExportCalibration, left0: float = 1.0, right0: float = 1.0, separation0: float = 1.0
) -> list[str]:
    """The warnings an export of ``cal`` carries: implausible factors, an unmeasured scale.

    Parameters
    ----------
    cal : ExportCalibration
        The calibration.
    left0, right0, separation0 : float
        The diff_drive_controller multipliers in use (``ros2``, ``ros1``).

    Returns
    -------
    list of str
        One message per finding (parameters named in backticks).
    """
    found = [
        _outside("c_left", cal.c_left, "c"),
        _outside("c_right", cal.c_right, "c"),
        _outside("E_d = c_right / c_left", cal.ed, "Ed"),
        _outside("E_b", cal.eb, "Eb"),
    ]
    if (left0, right0, separation0) != (1.0, 1.0, 1.0):
        m = ros_multipliers(cal, left0, right0, separation0)
        for (param, ros, key), v in zip(_IN_USE, (left0, right0, separation0)):
            lo, hi = PLAUSIBLE_FACTORS[key]
            if lo <= v <= hi:
                found.append(_outside(ros, m[ros], key))
            else:  # the one in use, not the calibration, is far out
                found.append(
                    f"the {ros} in use (`{param}`) is {v:g}, far outside the corrections of real robots ({lo:g} to "
                    f"{hi:g}): check it is the controller's own value (the written {ros} is {m[ros]:.6g})"
                )
    if cal.wheels_include_prior and (left0, right0) != (1.0, 1.0):
        found.append(
            "c_left and c_right of this calibration already include the wheel factors the robot ran with "
            "(its analysis was given them): they are relative to the nominal wheels, and composing them with "
            "the wheel multipliers in use applies those twice unless the multipliers are something else"
        )
    found.append(scale_note(cal))
    return [w for w in found if w]


def format_export(
    cal: ExportCalibration,
    fmt: str,
    controller: str = "diff_drive_controller",
    left0: float = 1.0,
    right0: float = 1.0,
    separation0: float = 1.0,
    wheel_radius_m: float | None = None,
    wheel_separation_m: float | None = None,
    covariances: Mapping[str, Sequence[float]] | None = None,
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
    covariances : mapping, optional
        ``pose_covariance_diagonal`` and ``twist_covariance_diagonal`` (six variances each: x, y,
        z, roll, pitch, yaw; see :func:`umbmark.correct.noise.controller_covariances`): written
        as the controller's parameters with the matching robot_localization settings as comments
        (``ros2``, ``ros1``), as ``odometry_covariances`` (``json``).

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    InputError
        An unknown format, a bad controller name, a firmware export without the nominal
        diameters and pulses per revolution, a ``urdf`` or ``tf`` export without a sensor pose,
        a value to write that is not finite, not positive or absurd (see :data:`FACTOR_LIMITS`).

    Notes
    -----
    Every string of the calibration (its source, its method) is written as data: through the
    YAML and JSON libraries, or as one line of plain text in a comment escaped for the format
    (no line breaks, no ``*/`` in C, no ``--`` in XML). The warnings of :func:`export_warnings`
    (implausible factors, a wheel scale the method could not see) are comments in the file
    (``warnings`` and ``scale_note`` in ``json``).
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format {fmt!r} (choose from {', '.join(FORMATS)})")
    cov = _covariances(covariances)
    notes = [_PARAM_TICKS.sub(r"\1", w) for w in export_warnings(cal, left0, right0, separation0)]
    if fmt in _SENSOR_FORMATS:
        return _sensor_export(cal, fmt, notes)
    if fmt in ("ros2", "ros1"):
        return _ros_export(
            cal, fmt, notes, controller, (left0, right0, separation0), (wheel_radius_m, wheel_separation_m), cov
        )
    out, mmpp = _corrected_values(cal)
    if fmt == "json":
        if cov:
            out["odometry_covariances"] = cov
        return _json_export(cal, out, notes)
    return _firmware_export(cal, out, mmpp, notes)


def _sensor_export(cal: ExportCalibration, fmt: str, notes: list[str]) -> str:
    """The ``urdf`` or ``tf`` export: the lidar's mounting pose."""
    if cal.sensor_pose is None:
        raise InputError(
            f"the {fmt} export is the lidar's mounting pose: it needs the JSON of a self-calibration (umbmark selfcal)"
        )
    if fmt == "urdf":
        comments = "".join(f"<!-- warning: {xml_comment(w)} -->\n" for w in notes)
        return f"<!-- {xml_comment(_header(cal, '').strip())} -->\n{comments}{urdf_origin(cal)}\n"
    return (
        hash_comment(_header(cal, "").strip())
        + "".join(hash_comment("warning: " + w) for w in notes)
        + f"# the pose of {cal.sensor_frame} in {cal.base_frame}; ROS 1: {static_transform_command(cal, ros=1)}\n"
        + static_transform_command(cal)
        + "\n"
    )


def _ros_export(
    cal: ExportCalibration,
    fmt: str,
    notes: list[str],
    controller: str,
    in_use: tuple[float, float, float],
    sizes: tuple[float | None, float | None],
    covariances: dict[str, list[float]],
) -> str:
    """The ``ros2`` or ``ros1`` export: a diff_drive_controller parameter file."""
    if not isinstance(controller, str) or not CONTROLLER_NAME.fullmatch(controller):
        raise InputError(f"bad controller name {controller!r} (letters, digits, _ / ~ . -)")
    left0, right0, separation0 = in_use
    wheel_radius_m, wheel_separation_m = sizes
    params: dict[str, object] = {**ros_multipliers(cal, left0, right0, separation0), **covariances}
    if wheel_radius_m is not None:
        params = {"wheel_radius": _size("wheel radius", wheel_radius_m * 1e3) * 1e-3, **params}
    if wheel_separation_m is not None:
        params = {"wheel_separation": _size("wheel separation", wheel_separation_m * 1e3) * 1e-3, **params}
    body = {controller: {"ros__parameters": params}} if fmt == "ros2" else {controller: params}
    note = (
        f"# composed with the multipliers in use: left {left0:.6g}, right {right0:.6g}, separation {separation0:.6g}\n"
    )
    import yaml

    text = (
        hash_comment(_header(cal, "").strip())
        + "".join(hash_comment("warning: " + w) for w in notes)
        + note
        + yaml.safe_dump(body, sort_keys=False, default_flow_style=False)
    )
    return text + _localization_comment(controller, covariances) + _sensor_comment(cal, 2 if fmt == "ros2" else 1)


_COVARIANCE_KEYS = ("pose_covariance_diagonal", "twist_covariance_diagonal")


def _covariances(covariances: Mapping[str, Sequence[float]] | None) -> dict[str, list[float]]:
    """The two covariance diagonals checked: six non-negative finite variances each."""
    if covariances is None:
        return {}
    if set(covariances) != set(_COVARIANCE_KEYS):
        raise InputError(f"covariances must be {' and '.join(_COVARIANCE_KEYS)}, got {sorted(covariances)}")
    out = {}
    for k in _COVARIANCE_KEYS:
        v = [_finite(k, x) for x in covariances[k]]
        if len(v) != 6 or min(v) < 0:
            raise InputError(f"{k} must be six non-negative variances (x, y, z, roll, pitch, yaw), got {v}")
        out[k] = v
    return out


def _localization_comment(controller: str, covariances: dict[str, list[float]]) -> str:
    """robot_localization's settings for an odometry with these covariances (comments)."""
    if not covariances:
        return ""
    lines = [
        "the covariances above are the odometry's measured noise (umbmark selfcal: each wheel's variance per "
        "metre); the pose's after 1 m straight, the twist's at the speed and averaging time given",
        "robot_localization (ekf_node): fuse the twist, whose covariance holds; the pose's grows without bound:",
        f"  odom0: /{controller}/odom",
        "  odom0_config: [false, false, false,  false, false, false,  true, true, false,  false, false, true,  "
        "false, false, false]",
        "  odom0_differential: false",
        "  odom0_relative: false",
    ]
    return "".join(f"# {line}\n" for line in lines)  # (the controller's name is checked: no line breaks)


def _corrected_values(cal: ExportCalibration) -> tuple[dict[str, object], tuple[float, float] | None]:
    """The corrected figures of the ``json`` and ``firmware`` exports, and the millimetres per pulse when known."""
    out: dict[str, object] = {"Ed": cal.ed, "Eb": cal.eb, "c_left": cal.c_left, "c_right": cal.c_right}
    if cal.nominal_diameter_left_m and cal.nominal_diameter_right_m:
        out["diameter_left_mm"] = _size("diameter_left_mm", cal.c_left * cal.nominal_diameter_left_m * 1e3)
        out["diameter_right_mm"] = _size("diameter_right_mm", cal.c_right * cal.nominal_diameter_right_m * 1e3)
    if cal.nominal_wheelbase_m:
        out["wheelbase_mm"] = _size("wheelbase_mm", cal.eb * cal.nominal_wheelbase_m * 1e3)
    mmpp = None
    if cal.nominal_diameter_left_m and cal.nominal_diameter_right_m and cal.pulses_per_wheel_rev:
        k = math.pi / cal.pulses_per_wheel_rev * 1e3
        mmpp = (
            _size("left_mm_per_pulse", cal.c_left * cal.nominal_diameter_left_m * k),
            _size("right_mm_per_pulse", cal.c_right * cal.nominal_diameter_right_m * k),
        )
        out["left_mm_per_pulse"], out["right_mm_per_pulse"] = mmpp
    if cal.sensor_pose is not None:
        x, y, yaw = cal.sensor_pose
        out["sensor_pose"] = {
            "x_mm": x * 1e3,
            "y_mm": y * 1e3,
            "z_mm": cal.sensor_z_m * 1e3,
            "roll_deg": math.degrees(cal.sensor_roll_rad),
            "pitch_deg": math.degrees(cal.sensor_pitch_rad),
            "yaw_deg": math.degrees(yaw),
        }
        out["base_frame"], out["sensor_frame"] = cal.base_frame, cal.sensor_frame
    return out, mmpp


def _json_export(cal: ExportCalibration, out: dict[str, object], notes: list[str]) -> str:
    """The ``json`` export: the corrected figures, the scale note, the method, the source and the warnings."""
    out["scale_observed"] = cal.scale_observed
    if scale_note(cal):
        out["scale_note"] = _PARAM_TICKS.sub(r"\1", scale_note(cal) or "")
    out["method"], out["source"] = cal.method, cal.source
    out["warnings"] = notes
    out["input_warnings"] = list(cal.input_warnings)
    return json.dumps(out, indent=2) + "\n"


def _firmware_export(
    cal: ExportCalibration, out: dict[str, object], mmpp: tuple[float, float] | None, notes: list[str]
) -> str:
    """The ``firmware`` export: a C header with the millimetres per pulse and the wheelbase."""
    if mmpp is None:
        held = (
            "this gyro result (`imu_topic`) holds the wheelbase only; "
            if cal.method == "gyro"
            else "this calibration does not hold them; "
            if cal.source and cal.source != "command line"
            else ""
        )
        raise InputError(
            "the firmware export needs the nominal wheel diameters and encoder pulses per wheel "
            f"revolution ({held}give `wheel_diameter_mm` and `pulses_per_wheel_rev`, or export the JSON of a "
            "replay of a log that holds them)"
        )
    lines = ["/* " + _c_comment(_header(cal, "").strip()) + " */"]
    lines += ["/* warning: " + _c_comment(w) + " */" for w in notes]
    lines += [
        "#ifndef UMBMARK_CALIBRATION_H",
        "#define UMBMARK_CALIBRATION_H",
        f"#define UMBMARK_LEFT_MM_PER_PULSE  {mmpp[0]:.9g}",
        f"#define UMBMARK_RIGHT_MM_PER_PULSE {mmpp[1]:.9g}",
    ]
    if "wheelbase_mm" in out:
        lines.append(f"#define UMBMARK_WHEELBASE_MM       {out['wheelbase_mm']:.6f}")
    lines.append("#endif")
    return "\n".join(lines) + "\n"


def hash_comment(text: str) -> str:
    """One ``#`` comment line (YAML, shell) holding ``text`` as plain text."""
    return f"# {_plain(text)}\n"


def _n(v: float) -> str:
    """A number for URDF and command lines: 6 decimals, trailing zeros dropped, no ``-0``."""
    s = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _sensor_values(cal: ExportCalibration) -> tuple[float, float, float, float, float, float]:
    if cal.sensor_pose is None:
        raise InputError(
            "no sensor pose in this calibration: it needs the JSON of a self-calibration (umbmark selfcal)"
        )
    x, y, yaw = cal.sensor_pose
    return x, y, cal.sensor_z_m, cal.sensor_roll_rad, cal.sensor_pitch_rad, yaw


def urdf_origin(cal: ExportCalibration) -> str:
    """The sensor's mounting pose as the ``<origin/>`` element of its URDF joint.

    Parameters
    ----------
    cal : ExportCalibration
        A calibration with a sensor pose.

    Returns
    -------
    str
        ``<origin xyz="x y z" rpy="roll pitch yaw"/>`` (metres, radians).

    Raises
    ------
    InputError
        If the calibration has no sensor pose.
    """
    return origin_element(_sensor_values(cal))


def origin_element(pose: tuple[float, float, float, float, float, float]) -> str:
    """``<origin xyz="x y z" rpy="roll pitch yaw"/>`` of a mounting pose ``(x, y, z, roll, pitch, yaw)``
    (metres, radians)."""
    x, y, z, roll, pitch, yaw = pose
    return f'<origin xyz="{_n(x)} {_n(y)} {_n(z)}" rpy="{_n(roll)} {_n(pitch)} {_n(yaw)}"/>'


def static_transform_command(cal: ExportCalibration, ros: int = 2) -> str:
    """The ``tf2_ros static_transform_publisher`` command that publishes the sensor's pose.

    Parameters
    ----------
    cal : ExportCalibration
        A calibration with a sensor pose.
    ros : int
        2: ``ros2 run`` with named arguments; 1: ``rosrun`` with the positional ones
        (x y z yaw pitch roll parent child).

    Returns
    -------
    str
        The command line.

    Raises
    ------
    InputError
        If the calibration has no sensor pose, or ``ros`` is not 1 or 2.
    """
    return transform_command(_sensor_values(cal), cal.base_frame, cal.sensor_frame, ros)


def transform_command(
    pose: tuple[float, float, float, float, float, float], parent: str, child: str, ros: int = 2
) -> str:
    """The ``static_transform_publisher`` command of a mounting pose ``(x, y, z, roll, pitch, yaw)``
    of ``child`` in ``parent`` (see :func:`static_transform_command`).

    Raises
    ------
    InputError
        ``ros`` not 1 or 2, or a frame name with spaces, quotes or markup characters.
    """
    for name in (parent, child):
        if not isinstance(name, str) or not _FRAME.fullmatch(name):
            raise InputError(f"a frame name is letters, digits, _ / . -; got {name!r}")
    x, y, z, roll, pitch, yaw = pose
    if ros == 1:
        values = " ".join(_n(v) for v in (x, y, z, yaw, pitch, roll))
        return f"rosrun tf2_ros static_transform_publisher {values} {parent} {child}"
    if ros != 2:
        raise InputError(f"ros must be 1 or 2, got {ros!r}")
    named = [_n(v) for v in (x, y, z, roll, pitch, yaw)] + [parent, child]
    args = " ".join(f"--{name} {v}" for name, v in zip(_TF2_ARGS, named))
    return f"ros2 run tf2_ros static_transform_publisher {args}"


def _sensor_comment(cal: ExportCalibration, ros: int) -> str:
    """The sensor pose as comment lines of a parameter file (nothing without a sensor pose)."""
    if cal.sensor_pose is None:
        return ""
    return (
        f"# the lidar's mounting pose ({cal.base_frame} -> {cal.sensor_frame}), for its URDF joint:\n"
        f"#   {urdf_origin(cal)}\n"
        "# or published without the URDF:\n"
        f"#   {static_transform_command(cal, ros)}\n"
    )


def write_export(text: str, path: str | Path) -> None:
    """Write an export's text to a file, atomically.

    Parameters
    ----------
    text : str
        What :func:`format_export` gave.
    path : str or Path
        The file.
    """
    atomic_write(path, text)
