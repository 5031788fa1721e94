"""The parameters of the history's records: what an analysis recommends and what the robot ran with
(:func:`parameters_from_analysis`, :class:`AnalysisLike`), its runs as rows and back
(:func:`runs_to_rows`, :func:`runs_from_rows`), and the parameters to load into a robot's odometry
from one record (:func:`export_parameters`; a robot of a kind of its own with its kind's values),
as JSON or YAML (:func:`format_export`).

Part of the history's shared code (:mod:`umbmark.history.base`, which re-exports these names).
Imports only the standard library, :mod:`umbmark.errors`, :mod:`umbmark.jsonutil` and
:mod:`umbmark.history.records` (and, when called, numpy and :mod:`umbmark.model.runs` for the
runs, :mod:`umbmark.kinds` for a robot of a kind of its own, PyYAML for YAML; for the type
checker only, :mod:`umbmark.model`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from umbmark.errors import InputError
from umbmark.history.address import display_db
from umbmark.history.records import HistoryError, Record, _num, _short
from umbmark.jsonutil import jsonable

if TYPE_CHECKING:
    from umbmark.kinds import Kind
    from umbmark.model.geometry import Calibration
    from umbmark.model.runs import RunsTable

__all__ = [
    "AnalysisLike",
    "parameters_from_analysis",
    "runs_to_rows",
    "runs_from_rows",
    "export_parameters",
    "format_export",
]


class _CorrectionLike(Protocol):
    """What the history reads of a correction (:class:`umbmark.correct.result.CorrectionResult`)."""

    @property
    def method(self) -> str: ...
    @property
    def ed(self) -> float: ...
    @property
    def eb(self) -> float: ...
    @property
    def calibration(self) -> Calibration: ...


class AnalysisLike(Protocol):
    """What the history reads of an analysis: :class:`umbmark.correct.analysis.Analysis` (a layer
    above the history, which does not import it)."""

    @property
    def runs(self) -> RunsTable: ...
    @property
    def side_m(self) -> float: ...
    @property
    def wheelbase_m(self) -> float: ...
    @property
    def correction(self) -> _CorrectionLike: ...
    def to_dict(self) -> dict[str, Any]: ...


def parameters_from_analysis(analysis: AnalysisLike) -> tuple[dict[str, Any], dict[str, Any]]:
    """The parameters an analysis recommends, and those the robot ran with.

    Parameters
    ----------
    analysis : umbmark.correct.analysis.Analysis
        The analysis.

    Returns
    -------
    recommended : dict
        ``c_left``, ``c_right``, ``wheelbase_mm``, ``Ed``, ``Eb``.
    in_use : dict
        ``wheelbase_mm`` the odometry used.
    """
    corr = analysis.correction
    cal = corr.calibration
    assert cal.wheelbase_m is not None, "a correction's calibration holds the corrected wheelbase"
    recommended: dict[str, Any] = {
        "c_left": cal.c_left,
        "c_right": cal.c_right,
        "wheelbase_mm": cal.wheelbase_m * 1e3,
        "Ed": corr.ed,
        "Eb": corr.eb,
    }
    in_use: dict[str, Any] = {"wheelbase_mm": analysis.wheelbase_m * 1e3}
    return recommended, in_use


def runs_to_rows(runs: RunsTable) -> list[dict[str, Any]]:
    """A runs table as JSON-able rows in millimetres and degrees.

    Parameters
    ----------
    runs : RunsTable
        The runs.

    Returns
    -------
    list of dict
        One dict per run: ``run``, ``direction``, ``x_abs``, ``y_abs``, ``x_odo``, ``y_odo`` and
        the headings when the table has them.
    """
    rows = []
    for i in range(len(runs)):
        r: dict[str, Any] = {
            "run": str(runs.run[i]) if runs.run is not None else str(i + 1),
            "direction": str(runs.direction[i]),
            "x_abs": float(runs.x_abs[i]) * 1e3,
            "y_abs": float(runs.y_abs[i]) * 1e3,
            "x_odo": float(runs.x_odo[i]) * 1e3,
            "y_odo": float(runs.y_odo[i]) * 1e3,
        }
        if runs.theta_abs is not None:
            r["theta_abs"] = math.degrees(float(runs.theta_abs[i]))
        if runs.theta_odo is not None:
            r["theta_odo"] = math.degrees(float(runs.theta_odo[i]))
        rows.append(r)
    return rows


def runs_from_rows(rows: list[dict[str, Any]]) -> RunsTable:
    """Inverse of :func:`runs_to_rows` (for reports of recorded analyses).

    Parameters
    ----------
    rows : list of dict
        Rows as :func:`runs_to_rows` writes them.

    Returns
    -------
    RunsTable
    """
    import numpy as np

    from umbmark.model.runs import RunsTable

    if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
        raise InputError("the stored runs are not a list of runs (a damaged record)")
    g = lambda k: np.array([r[k] for r in rows], dtype=float) * 1e-3  # noqa: E731
    th = lambda k: np.radians(np.array([r[k] for r in rows], dtype=float)) if all(k in r for r in rows) else None  # noqa: E731
    try:
        return RunsTable.from_columns(
            [str(r["direction"]) for r in rows],
            g("x_abs"),
            g("y_abs"),
            g("x_odo"),
            g("y_odo"),
            th("theta_abs"),
            th("theta_odo"),
            np.array([str(r["run"]) for r in rows]),
        )
    except KeyError as e:
        raise InputError(f"a stored run has no {e.args[0]!r} (a damaged record)") from None
    except (TypeError, ValueError) as e:
        raise InputError(f"the stored runs hold a value that is not a number (a damaged record): {e}") from None


def export_parameters(record: Record) -> dict[str, Any]:
    """The parameters to load into the robot's odometry, from one record, saying what each
    holds: the wheel factors and E_b relative to the odometry the record's data were made
    with, the wheelbase that odometry used (``nominal_wheelbase_mm``) and the corrected one
    (``corrected_wheelbase_mm``), so that a reader (``umbmark export``) applies E_b once.

    Parameters
    ----------
    record : Record
        The record.

    Returns
    -------
    dict
        JSON-able: the record's ``robot``, ``record_id``, ``time_utc``, ``kind`` and ``method``;
        ``c_left``, ``c_right`` (factors on the nominal wheel diameters, any prior calibration
        included), ``Ed``, ``Eb`` (corrected over nominal wheelbase); ``nominal_wheelbase_mm``
        (the wheelbase the odometry used: the record's ``parameters_in_use``),
        ``corrected_wheelbase_mm`` and ``corrected_wheelbase_m`` (the one to load); the nominal
        wheel diameters and encoder units per wheel revolution when the record has them
        (``nominal_diameter_left_mm``, ``nominal_diameter_right_mm``, ``units_per_wheel_rev``);
        a self-calibration's ``sensor_pose`` (``x_mm``, ``y_mm``, ``yaw_deg``);
        ``scale_observed`` (whether the method measured the mean wheel scale; None: not known);
        ``parameters_in_use`` (what the robot ran with, as recorded); the measured
        ``emax_syst_mm_measured`` and the ``software_version`` that made it.
    """
    from umbmark.kinds import kind_in

    own = kind_in(record.parameters)
    if own is not None:
        return _kind_export(record, own)
    p = record.parameters
    wb_mm = _num(p.get("wheelbase_mm"))
    wb_m = _num(p.get("wheelbase_m"))
    if wb_mm is None and wb_m is not None:
        wb_mm = wb_m * 1e3
    piu = record.parameters_in_use if isinstance(record.parameters_in_use, dict) else {}
    nominal_wb = _num(piu.get("wheelbase_mm"))
    eb = record.eb if record.eb is not None else _num(p.get("Eb"))
    if nominal_wb is None and wb_mm is not None and eb:
        nominal_wb = wb_mm / eb  # the record holds the corrected wheelbase and E_b only
    d: dict[str, Any] = {
        "robot": record.robot,
        "record_id": record.id,
        "time_utc": record.created_utc,
        "kind": record.kind,
        "method": record.method,
        "c_left": _num(p.get("c_left")),
        "c_right": _num(p.get("c_right")),
        "Ed": record.ed,
        "Eb": eb,
        "nominal_wheelbase_mm": nominal_wb,
        "corrected_wheelbase_mm": wb_mm,
        "corrected_wheelbase_m": None if wb_mm is None else wb_mm * 1e-3,
    }
    dl = _num(piu.get("diameter_left_mm", piu.get("wheel_diameter_mm")))
    dr = _num(piu.get("diameter_right_mm", piu.get("wheel_diameter_mm")))
    if dl is not None and dr is not None:
        d["nominal_diameter_left_mm"], d["nominal_diameter_right_mm"] = dl, dr
    units = _num(piu.get("units_per_wheel_rev"))
    if units is not None:
        d["units_per_wheel_rev"] = units
    sp = p.get("sensor_pose")
    if isinstance(sp, dict) and all(_num(sp.get(k)) is not None for k in ("x_mm", "y_mm", "yaw_deg")):
        d["sensor_pose"] = {k: _num(sp[k]) for k in ("x_mm", "y_mm", "yaw_deg")}
    d.update(
        {
            "scale_observed": _scale_observed(record),
            "parameters_in_use": piu,
            "emax_syst_mm_measured": record.emax_syst_mm,
            "software_version": record.software_version,
        }
    )
    return d


def _kind_export(record: Record, own: Kind) -> dict[str, Any]:
    """:func:`export_parameters` of a record of a robot of a kind of its own: its geometry (the
    kind's JSON keys), its controller's parameters and the kind's own values to load
    (:meth:`umbmark.kinds.Kind.ros2_parameters`, :meth:`~umbmark.kinds.Kind.export_json`: as
    ``umbmark export --format json`` writes them), the lidar's pose and what the robot ran with.

    Raises
    ------
    HistoryError
        A geometry that is not the kind's (nothing to load).
    """
    p = record.parameters
    try:
        g, cis = own.geometry_from_json(p, f"record #{record.id}")
    except InputError as e:
        raise HistoryError(f"record #{record.id} of robot {record.robot!r} holds no usable geometry: {e}") from None
    sp = p.get("sensor_pose")
    d: dict[str, Any] = {
        "robot": record.robot,
        "record_id": record.id,
        "time_utc": record.created_utc,
        "kind": record.kind,
        "method": record.method,
        "kinematics": own.name,
        **own.geometry_json(g),
        "controller": own.controller,
        "controller_parameters": own.ros2_parameters(g),
        **own.export_json(g, {n: ci for n, ci in cis.items() if ci is not None}),
    }
    if isinstance(sp, dict) and all(_num(sp.get(k)) is not None for k in ("x_mm", "y_mm", "yaw_deg")):
        d["sensor_pose"] = {k: _num(sp[k]) for k in ("x_mm", "y_mm", "yaw_deg")}
    d["parameters_in_use"] = record.parameters_in_use if isinstance(record.parameters_in_use, dict) else {}
    d["software_version"] = record.software_version
    return d


def _scale_observed(record: Record) -> bool | None:
    """Whether the method behind a record measured the mean wheel scale (None: not known)."""
    res = record.results if isinstance(record.results, dict) else {}
    if record.kind == "selfcal":
        return True
    if record.kind in ("calibrate", "gyro") or record.method == "bf":
        return False
    if record.method == "lsq":
        return res.get("scale_fitted") if isinstance(res.get("scale_fitted"), bool) else None
    if record.method == "exact":
        es = res.get("Es_pass")
        return isinstance(es, (int, float)) and not isinstance(es, bool) and es != 1.0
    return None


def format_export(record: Record, fmt: str = "json", db: str | Path | None = None) -> str:
    """:func:`export_parameters` as JSON or YAML text.

    Parameters
    ----------
    record : Record
        The record.
    fmt : str
        ``"json"`` or ``"yaml"``.
    db : str or Path, optional
        The database the record is from (named in the message of a record with nothing to load).

    Returns
    -------
    str

    Raises
    ------
    InputError
        For another format.
    HistoryError
        If the record holds no usable wheel factors or E_b (nothing to load).
    """
    d = jsonable(export_parameters(record))
    for k in () if "kinematics" in d else ("c_left", "c_right", "Eb"):
        if not (d.get(k) is not None and d[k] > 0):
            raise HistoryError(
                f"record #{record.id} of robot {record.robot!r}"
                + ("" if db is None else f" in the history database {display_db(db)}")
                + f" holds no usable {k} "
                f"({_short(d.get(k))}): nothing exported"
            )
    if fmt == "json":
        return json.dumps(d, indent=2, allow_nan=False) + "\n"
    if fmt == "yaml":
        import yaml

        return yaml.safe_dump(d, sort_keys=False)
    raise InputError(f"unknown export format {fmt!r} (json or yaml)")
