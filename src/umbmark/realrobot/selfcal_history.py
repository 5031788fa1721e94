"""The fields a self-calibration is recorded with in the history (:func:`selfcal_history_fields`):
its kind, method, results, the parameters it recommends and those in use, its inputs and their
content hash, for a differential drive and for a robot of a kind of its own.

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports the
name). Imports :mod:`umbmark.errors`, :mod:`umbmark._files` (the inputs' hash) and
:mod:`umbmark.kinds`; not the history itself (a layer beside this one).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from umbmark._files import inputs_sha256
from umbmark.errors import InputError
from umbmark.kinds import Kind, kind_in

__all__ = ["selfcal_history_fields"]


def selfcal_history_fields(
    d: dict[str, Any], kind: str = "selfcal", file_hash: Callable[[str], str] | None = None
) -> dict[str, Any]:
    """The keyword arguments of :func:`umbmark.history.record_result` for a self-calibration
    given as its JSON (:meth:`SelfcalReport.to_dict`, the output of ``umbmark selfcal --json``), of
    any kind of robot: a differential drive's ``parameters`` are ``c_left``, ``c_right``,
    ``wheelbase_mm``, ``Ed``, ``Eb``; another kind's (its JSON's ``kinematics``) are ``kinematics``
    and its geometry under its JSON keys (a tricycle's ``wheel_diameter_mm``, ``wheelbase_mm``,
    ``steering_offset_deg``, ``steering_scale``), and ``parameters_in_use`` its nominal geometry;
    both with ``sensor_pose``.

    Parameters
    ----------
    d : dict
        The self-calibration's JSON.
    kind : str
        The record's kind.
    file_hash : callable, optional
        The content hash of an input file or folder; several inputs are hashed together
        (:func:`umbmark._files.inputs_sha256`); None: no hash.

    Returns
    -------
    dict
        As :meth:`SelfcalReport.history_fields`.

    Raises
    ------
    InputError
        If ``d`` is not a self-calibration's JSON.
    """
    own = kind_in(d)
    if own is not None:
        parameters, in_use = _kind_parameters(d, own)
    else:
        missing = [k for k in ("c_left", "c_right", "wheelbase_mm", "Ed", "Eb", "sensor_pose") if k not in d]
        if missing or not isinstance(d.get("sensor_pose"), dict):
            raise InputError(
                "not the JSON of a self-calibration (missing " + ", ".join(missing or ["sensor_pose"]) + ")"
            )
        parameters = {k: d[k] for k in ("c_left", "c_right", "wheelbase_mm", "Ed", "Eb")}
        in_use = {
            "wheel_diameter_mm": d.get("nominal_wheel_diameter_mm"),
            "wheelbase_mm": d.get("nominal_wheelbase_mm"),
            "sensor_pose": d.get("nominal_sensor_pose"),
        }
    paths = [i["path"] for i in d.get("inputs", []) if isinstance(i, dict) and "path" in i]
    sp = d["sensor_pose"]
    parameters["sensor_pose"] = {k: sp.get(k) for k in ("x_mm", "y_mm", "yaw_deg")}
    first = Path(paths[0]) if paths else None
    return {
        "kind": kind,
        "method": "selfcal",
        "results": d,
        "parameters": parameters,
        "parameters_in_use": in_use,
        "source": None if first is None else str(first.resolve() if first.exists() else first),
        "input_sha256": (
            inputs_sha256(paths, file_hash) if paths and file_hash and all(Path(p).exists() for p in paths) else None
        ),
        "inputs": {"paths": paths},
    }


def _kind_parameters(d: dict[str, Any], own: Kind) -> tuple[dict[str, Any], dict[str, Any]]:
    """The recommended parameters and those in use of the self-calibration of a robot of a kind of
    its own: ``kinematics`` and its geometry under the kind's JSON keys (the calibrated geometry,
    and the nominal one with the first bag's nominal sensor pose).

    Raises
    ------
    InputError
        No sensor pose, or a geometry that is not the kind's.
    """
    if not isinstance(d.get("sensor_pose"), dict):
        raise InputError(f"not the JSON of a {own.noun}'s self-calibration (missing sensor_pose)")
    own.geometry_from_json(d, "the self-calibration")
    got = d.get("nominal")
    nominal: dict[str, Any] = got if isinstance(got, dict) else {}
    inputs = [i for i in d.get("inputs") or [] if isinstance(i, dict)]
    keys = dict.fromkeys(p.key[0] for p in own.parameters)
    parameters: dict[str, Any] = {"kinematics": own.name}
    for k in keys:  # each estimate and its 95 % interval (null: not estimated)
        parameters.update({k: d[k], f"{k}_ci95": d.get(f"{k}_ci95")})
    in_use = {
        "kinematics": own.name,
        **{k: nominal.get(k) for k in keys},
        "sensor_pose": inputs[0].get("nominal_sensor_pose") if inputs else None,
    }
    return parameters, in_use
