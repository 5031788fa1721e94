"""The calibration a check reads (step 1 of :mod:`umbmark.realrobot.validate`): the JSON that
``umbmark selfcal``, ``umbmark replay``, ``umbmark export`` (format json), ``umbmark analyze``,
``umbmark calibrate`` or a history export save, read into the nominal and the calibrated geometry,
the sensor poses and the scans' delay (:func:`read_calibration`, :class:`CheckedCalibration`), of a
differential drive or a robot of a kind of its own (:func:`calibration_kind`); a JSON that is no
calibration, or sizes no robot has, refused by name.

Part of the check of a calibration on a real log (:mod:`umbmark.realrobot.validate`, which
re-exports these names). Imports :mod:`umbmark.errors`, :mod:`umbmark.kinds`, the model's geometry
and :mod:`umbmark.io` (the JSON reader; :func:`umbmark.io.export.calibration_from_json` for the
factors of a replay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.io._text import parse_json, read_text
from umbmark.kinds import DEFAULT_KIND, KINDS, Kind, kind_in
from umbmark.model.geometry import WheelGeometry, nominal_slip, unit_slip
from umbmark.model.kinematics import Kinematics
from umbmark.model.se2 import Pose

__all__ = ["CheckedCalibration", "read_calibration", "calibration_kind"]

_EXPECTED = (
    "a calibration is the JSON that umbmark selfcal or umbmark replay save, or that umbmark export writes "
    "in the json format"
)


# a lidar further than this from the robot's origin [mm], or turned beyond a turn [deg], is no mounting
_MAX_SENSOR_MM = 1e4
_MAX_SENSOR_DEG = 360.0


def _pose_mm_deg(d: Any, key: str, src: str) -> Pose:
    """``(x_m, y_m, yaw_rad)`` of a JSON object ``{x_mm, y_mm, yaw_deg}``."""
    if not isinstance(d, dict):
        raise InputError(f"{key!r} must be an object with x_mm, y_mm, yaw_deg, got {d!r}", src)
    vals = []
    for k, most, unit in (
        ("x_mm", _MAX_SENSOR_MM, "mm"),
        ("y_mm", _MAX_SENSOR_MM, "mm"),
        ("yaw_deg", _MAX_SENSOR_DEG, "deg"),
    ):
        v = d.get(k)
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
            raise InputError(f"{key!r} {k} must be a finite number, got {v!r}", src)
        if abs(v) > most:
            what = f"{most:g} mm from the robot's origin" if unit == "mm" else f"a turn, {most:g} deg"
            raise InputError(f"{key!r} {k} is {v:g} {unit}: no lidar is mounted beyond {what} ({unit} expected)", src)
        vals.append(float(v))
    return (vals[0] * 1e-3, vals[1] * 1e-3, math.radians(vals[2]))


def _positive_mm(d: dict, key: str, src: str) -> float | None:
    """The value of ``key`` [mm] in metres (None when absent); a size no robot has is refused."""
    v = d.get(key)
    if v is None:
        return None
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
        raise InputError(f"{key!r} must be a positive number of millimetres, got {v!r}", src)
    slip = unit_slip("wheelbase" if "wheelbase" in key else "diameter", float(v) * 1e-3, "mm")
    if slip is not None:
        raise InputError(f"{key!r}: {slip}", src)
    return float(v) * 1e-3


_SIZE_KINDS = (("left wheel diameter", "diameter"), ("right wheel diameter", "diameter"), ("wheelbase", "wheelbase"))


def _check_sizes(
    factors: tuple[float, float, float], nominal: WheelGeometry, calibrated: WheelGeometry, src: str
) -> None:
    """Refuse sizes no robot has, and a calibration whose factor on its own nominal size no
    correction makes (:func:`umbmark.model.geometry.nominal_slip`: a size in another unit, a
    radius for a diameter)."""
    sizes = lambda g: (g.diameter_left_m, g.diameter_right_m, g.wheelbase_m)  # noqa: E731
    for (name, kind), f, n, c in zip(_SIZE_KINDS, factors, sizes(nominal), sizes(calibrated)):
        for what, v in (("nominal", n), ("calibrated", c)):
            slip = unit_slip(kind, v, "mm")
            if slip is not None:
                raise InputError(f"the {what} {name}: {slip}", src)
        slip = nominal_slip(kind, f)
        if slip is not None:
            raise InputError(
                f"the calibrated {name} is {f:.3g} times the calibration's nominal one: no calibration corrects a "
                f"robot's size that much ({slip})",
                src,
            )


@dataclass(frozen=True)
class CheckedCalibration:
    """A calibration to check: the nominal and the calibrated geometry and sensor pose, the scan delay.

    Parameters
    ----------
    kind : str
        What the JSON was: ``selfcal``, ``replay``, ``export``, ``analyze``, ``calibrate`` or
        ``history`` (a history export).
    nominal, calibrated : WheelGeometry or Kinematics
        The geometry the odometry was computed with, and the calibration's: a differential
        drive's, or the geometry of a robot of another kind (:mod:`umbmark.kinds`: its joints'
        odometry is replayed with each).
    nominal_sensor_pose : tuple of float or None
        ``(x_m, y_m, yaw_rad)`` of the lidar the calibration started from (a
        self-calibration's); None: the log's ``/tf_static``.
    nominal_sensor_pose_source : str or None
        Where the calibration's nominal sensor pose came from.
    sensor_pose : tuple of float or None
        The calibration's lidar pose; None: it calibrates the wheels only (the nominal pose
        is used after it too).
    scan_delay_s : float
        The scans' delay the calibration applied [s] (0 when it applied none).
    scan_delay_source : str
        ``calibration`` (``scan_delay[0].applied_s``) or ``none``.
    method : str or None
        The calibration method.
    source : str or None
        The JSON file.
    warnings : tuple of str
        What the reading noticed.
    """

    kind: str
    nominal: WheelGeometry | Kinematics
    calibrated: WheelGeometry | Kinematics
    nominal_sensor_pose: Pose | None = None
    nominal_sensor_pose_source: str | None = None
    sensor_pose: Pose | None = None
    scan_delay_s: float = 0.0
    scan_delay_source: str = "none"
    method: str | None = None
    source: str | None = None
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """As JSON (mm).

        Returns
        -------
        dict
            ``path``, ``kind``, ``method``, ``nominal`` and ``calibrated`` (``diameter_left_mm``,
            ``diameter_right_mm``, ``wheelbase_mm``), ``Ed``, ``Eb``, ``c_left``, ``c_right``
            (the calibrated geometry against the nominal), ``scan_delay_s``,
            ``scan_delay_source``. Another kind of robot: ``kinematics`` (its name) and its
            ``nominal`` and ``calibrated`` geometry under its JSON keys (a tricycle's
            ``wheel_diameter_mm``, ``wheelbase_mm``, ...) in place of the differential drive's
            sizes and factors.
        """
        both = self.kinematics
        if both is not None:
            own = self.robot_kind
            return {
                "path": self.source,
                "kind": self.kind,
                "method": self.method,
                "kinematics": own.name,
                "nominal": own.geometry_json(both[0]),
                "calibrated": own.geometry_json(both[1]),
                "scan_delay_s": self.scan_delay_s,
                "scan_delay_source": self.scan_delay_source,
            }
        assert isinstance(self.nominal, WheelGeometry) and isinstance(self.calibrated, WheelGeometry)
        rel = self.calibrated.relative_to(self.nominal)
        return {
            "path": self.source,
            "kind": self.kind,
            "method": self.method,
            "nominal": self.nominal.to_dict(),
            "calibrated": self.calibrated.to_dict(),
            **{k: rel[k] for k in ("Ed", "Eb", "c_left", "c_right")},
            "scan_delay_s": self.scan_delay_s,
            "scan_delay_source": self.scan_delay_source,
        }

    @property
    def kinematics(self) -> tuple[Kinematics, Kinematics] | None:
        """``(nominal, calibrated)`` of a robot of a kind of its own; None for a differential drive's."""
        nom, cal = self.nominal, self.calibrated
        if isinstance(nom, WheelGeometry) or isinstance(cal, WheelGeometry):
            return None
        return nom, cal

    @property
    def robot_kind(self) -> Kind:
        """The kind of robot (:data:`umbmark.kinds.KINDS`): the differential drive's for its geometry."""
        return KINDS[getattr(self.nominal, "kind", DEFAULT_KIND)]


def _load_json(path: str | Path) -> dict:
    src = str(path)
    d = parse_json(read_text(path), src, _EXPECTED)
    if not isinstance(d, dict):
        raise InputError(f"a JSON {type(d).__name__}, not an object; {_EXPECTED}", src)
    return d


def _kind(d: dict) -> str | None:
    """What a JSON object is (None: nothing umbmark writes as a calibration)."""
    if "spans" in d and "reference" in d and "calibration" in d:
        return "validate"
    if "topics" in d and "messages" in d:
        return "bag-info"
    if "wheel_diameter_left_mm" in d and "sensor_pose" in d:
        return "selfcal"
    if "scale_observed" in d and "c_left" in d and not {"nominal", "dataset", "datasets", "record_id"} & set(d):
        return "export"
    if "record_id" in d:
        return "history"
    if "final_calibration" in d:
        return "calibrate"
    if "dataset" in d or "datasets" in d or d.get("pooled") is True:
        return "replay"
    if "c_left" in d and "c_right" in d:
        return "analyze"
    return None


def _selfcal_delay(d: dict, src: str) -> tuple[float, str, list[str]]:
    """``scan_delay[0].applied_s`` of a self-calibration's JSON (0 without one)."""
    delays = d.get("scan_delay")
    if delays is None:
        return 0.0, "none", []
    if not isinstance(delays, list) or not all(isinstance(x, dict) for x in delays):
        raise InputError(f"'scan_delay' must be a list of objects (one per bag, with applied_s), got {delays!r}", src)
    applied = []
    for x in delays:
        v = x.get("applied_s")
        if v is None:
            continue
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
            raise InputError(f"'scan_delay' applied_s must be a finite number of seconds, got {v!r}", src)
        applied.append(float(v))
    if not delays or delays[0].get("applied_s") is None:
        return 0.0, "none", []
    warnings = []
    if len(set(applied)) > 1:
        warnings.append(
            f"the calibration applied {len(applied)} scan delays (one per bag: "
            f"{', '.join(f'{v:g}' for v in applied)} s): the first, {applied[0]:g} s, is used; give `scan_delay_s`"
        )
    return applied[0], "calibration", warnings


_Sizes = tuple[float | None, float | None, float | None]  # left and right wheel diameters, wheelbase [m]


def _geometry(
    kind: str,
    src: str,
    factors: tuple[float, float, float],
    nominal: _Sizes,
    calibrated: _Sizes,
    wheel_diameter_m: float | None,
    wheelbase_m: float | None,
) -> tuple[WheelGeometry, WheelGeometry, list[str]]:
    """The nominal geometry (given, else the calibration's) and the calibrated one (the
    calibration's absolute sizes, else its factors on its nominal geometry, else on the given one)."""
    given = (wheel_diameter_m, wheel_diameter_m, wheelbase_m)
    names = ("left wheel diameter", "right wheel diameter", "wheelbase")
    params = ("wheel_diameter_m", "wheel_diameter_m", "wheelbase_m")
    nom: list[float] = []
    cal: list[float] = []
    warnings: list[tuple[str, str]] = []
    for name, param, f, n, c, g in zip(names, params, factors, nominal, calibrated, given):
        if n is None and g is None:
            raise InputError(
                f"the calibration ({kind}) does not hold the nominal {name}: give `{param}` (the geometry the "
                "odometry was computed with)",
                src,
            )
        if g is not None and n is not None and abs(g / n - 1) > 1e-6 and param not in [w[0] for w in warnings]:
            warnings.append(
                (
                    param,
                    f"the nominal {name} given ({g * 1e3:g} mm) is not the calibration's ({n * 1e3:g} mm): the "
                    f"odometry is turned into wheel travel with {g * 1e3:g} mm and the calibration keeps its own",
                )
            )
        nom.append(g if g is not None else n)
        cal.append(c if c is not None else f * (n if n is not None else g))
    return WheelGeometry(*nom), WheelGeometry(*cal), [w for _, w in warnings]


def read_calibration(
    path: str | Path,
    *,
    dataset: str | None = None,
    wheel_diameter_m: float | None = None,
    wheelbase_m: float | None = None,
) -> CheckedCalibration:
    """Read the calibration to check from its JSON.

    * ``umbmark selfcal``: ``wheel_diameter_left_mm``, ``wheel_diameter_right_mm``,
      ``wheelbase_mm``, ``sensor_pose`` (``x_mm``, ``y_mm``, ``yaw_deg``),
      ``nominal_wheel_diameter_mm``, ``nominal_wheelbase_mm``, ``nominal_sensor_pose``,
      ``scan_delay`` (one per bag; the first's ``applied_s``).
    * ``umbmark export`` (format json): ``c_left``, ``c_right``, ``Eb`` and, when the nominal
      geometry was known, the calibrated ``diameter_left_mm``, ``diameter_right_mm``,
      ``wheelbase_mm`` (the nominal one is these over the factors); a self-calibration's
      ``sensor_pose``.
    * ``umbmark replay`` (one data set, one of several with ``dataset``, or a pooled fit), and
      also ``umbmark analyze``, ``umbmark calibrate`` and a history export: the factors
      ``c_left``, ``c_right``, ``E_b`` on the nominal geometry
      (:func:`umbmark.io.export.calibration_from_json`).

    Parameters
    ----------
    path : str or Path
        The JSON file.
    dataset : str, optional
        The data set to take from a replay of several.
    wheel_diameter_m, wheelbase_m : float, optional
        The nominal geometry [m], for a calibration that does not hold it, or instead of the
        calibration's (the calibrated geometry stays the calibration's).

    Returns
    -------
    CheckedCalibration

    Raises
    ------
    InputError
        A missing or unreadable file, not JSON, a JSON that is no calibration (what it is
        named), bad values, a nominal geometry neither in the JSON nor given.
    """
    src = str(path)
    for name, v in (("wheel_diameter_m", wheel_diameter_m), ("wheelbase_m", wheelbase_m)):
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise InputError(f"`{name}` must be a positive number, got {v!r}")
    d = _load_json(path)
    own = kind_in(d)
    if own is not None:
        return _kind_calibration(d, own, src, wheel_diameter_m, wheelbase_m)
    kind = _kind(d)
    if kind == "validate":
        raise InputError(f"this is the output of umbmark validate, a report, not a calibration; {_EXPECTED}", src)
    if kind == "bag-info":
        raise InputError(f"this is the output of umbmark bag-info, not a calibration; {_EXPECTED}", src)
    if kind is None:
        keys = ", ".join(sorted(map(str, d))[:8]) or "none"
        raise InputError(f"a JSON object without the figures of a calibration (its keys: {keys}); {_EXPECTED}", src)
    nominal: _Sizes
    cal_w: _Sizes
    pose: Pose | None
    npose: Pose | None
    nsrc: str | None
    method: str | None
    if kind == "selfcal":
        dl, dr, b = (
            _positive_mm(d, k, src) for k in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm")
        )
        if dl is None or dr is None or b is None:
            raise InputError(
                "a self-calibration without wheel_diameter_left_mm, wheel_diameter_right_mm, wheelbase_mm", src
            )
        dn, bn = _positive_mm(d, "nominal_wheel_diameter_mm", src), _positive_mm(d, "nominal_wheelbase_mm", src)
        factors = (dl / dn if dn else 1.0, dr / dn if dn else 1.0, b / bn if bn else 1.0)
        nominal, cal_w = (dn, dn, bn), (dl, dr, b)
        pose = _pose_mm_deg(d["sensor_pose"], "sensor_pose", src)
        nsp = d.get("nominal_sensor_pose")
        npose = None if nsp is None else _pose_mm_deg(nsp, "nominal_sensor_pose", src)
        nsrc = None if not isinstance(nsp, dict) else str(nsp.get("source") or "the calibration")
        delay, delay_src, warnings = _selfcal_delay(d, src)
        method = str(d.get("method") or "selfcal")
    elif kind == "export":
        factors = (
            positive("'c_left'", d.get("c_left"), source=src),
            positive("'c_right'", d.get("c_right"), source=src),
            positive("'Eb'", d.get("Eb"), source=src),
        )
        dl, dr, b = (_positive_mm(d, k, src) for k in ("diameter_left_mm", "diameter_right_mm", "wheelbase_mm"))
        cal_w = (dl, dr, b)
        n_dl, n_dr, n_b = (None if v is None else v / f for v, f in zip(cal_w, factors))
        nominal = (n_dl, n_dr, n_b)
        sp = d.get("sensor_pose")
        pose = None if sp is None else _pose_mm_deg(sp, "sensor_pose", src)
        npose, nsrc, delay, delay_src, warnings = None, None, 0.0, "none", []
        method = None if d.get("method") is None else str(d["method"])
    else:
        from umbmark.io.export import calibration_from_json

        cal = calibration_from_json(path, dataset)
        factors = (cal.c_left, cal.c_right, cal.eb)
        nominal = (cal.nominal_diameter_left_m, cal.nominal_diameter_right_m, cal.nominal_wheelbase_m)
        cal_w = (None, None, None)
        pose, npose, nsrc, delay, delay_src, warnings = cal.sensor_pose, None, None, 0.0, "none", []
        method = cal.method
    nom_g, cal_g, geo_warnings = _geometry(kind, src, factors, nominal, cal_w, wheel_diameter_m, wheelbase_m)
    _check_sizes(factors, nom_g, cal_g, src)
    return CheckedCalibration(
        kind=kind,
        nominal=nom_g,
        calibrated=cal_g,
        nominal_sensor_pose=npose,
        nominal_sensor_pose_source=nsrc,
        sensor_pose=pose,
        scan_delay_s=delay,
        scan_delay_source=delay_src,
        method=method,
        source=src,
        warnings=tuple(warnings + geo_warnings),
    )


def calibration_kind(path: str | Path) -> Kind:
    """The kind of robot of a calibration's JSON (its ``kinematics``): another kind's, else the
    differential drive's.

    Raises
    ------
    InputError
        A file that is missing, unreadable or not a JSON object (as :func:`read_calibration`).
    """
    return kind_in(_load_json(path)) or KINDS[DEFAULT_KIND]


def _kind_calibration(
    d: dict, own: Kind, src: str, wheel_diameter_m: float | None, wheelbase_m: float | None
) -> CheckedCalibration:
    """The calibration of a robot of a kind of its own: the JSON of its self-calibration
    (``umbmark selfcal --kinematics KIND --save``) or of its replay against a ground truth (whose
    ``sensor_pose`` is the marker's: the lidar keeps its nominal pose)."""
    given = [n for n, v in (("wheel_diameter_m", wheel_diameter_m), ("wheelbase_m", wheelbase_m)) if v is not None]
    if given:
        raise InputError(
            f"a {own.noun}'s calibration holds its own nominal geometry: `{given[0]}` is a differential drive's", src
        )
    if not isinstance(d.get("nominal"), dict):
        what = "export" if "parameters" in d else "calibration"
        raise InputError(
            f"a {own.noun}'s {what} without the nominal geometry the odometry ran with ('nominal'): check the JSON "
            "that its self-calibration (umbmark selfcal) saved",
            src,
        )
    calibrated, _ = own.geometry_from_json(d, src)
    nominal, _ = own.geometry_from_json(d["nominal"], src)
    for size in own.sizes:
        idx = [own.geometry.parameter_names.index(p) for p in size.parameters]
        n, c = (float(sum(g.vector()[i] for i in idx)) / len(idx) for g in (nominal, calibrated))
        for what, v in (("nominal", n), ("calibrated", c)):
            slip = unit_slip(size.quantity, v, "mm")
            if slip is not None:
                raise InputError(f"the {what} {size.label}: {slip}", src)
        slip = nominal_slip(size.quantity, c / n)
        if slip is not None:
            raise InputError(
                f"the calibrated {size.label} is {c / n:.3g} times the calibration's nominal one: no calibration "
                f"corrects a robot's size that much ({slip})",
                src,
            )
    replay = "marker_pose" in d
    inputs = [i for i in d.get("inputs") or [] if isinstance(i, dict)]
    nsp = inputs[0].get("nominal_sensor_pose") if inputs else None
    delay, delay_src, warnings = _selfcal_delay(d, src)
    return CheckedCalibration(
        kind="replay" if replay else "selfcal",
        nominal=nominal,
        calibrated=calibrated,
        nominal_sensor_pose=None if not isinstance(nsp, dict) else _pose_mm_deg(nsp, "nominal_sensor_pose", src),
        nominal_sensor_pose_source=None if not isinstance(nsp, dict) else str(nsp.get("source") or "the calibration"),
        sensor_pose=None if replay else _pose_mm_deg(d.get("sensor_pose"), "sensor_pose", src),
        scan_delay_s=delay,
        scan_delay_source=delay_src,
        method=str(d.get("method") or "selfcal"),
        source=src,
        warnings=tuple(warnings),
    )
