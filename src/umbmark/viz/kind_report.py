"""The HTML page of the self-calibration of a robot of a kind of its own (:mod:`umbmark.kinds`: a
tricycle, a mecanum robot): the sections of a differential drive's page
(:func:`umbmark.viz.selfcal_report.page_sections`: the map before and after, the residuals, the
warnings) with the kind's estimates (:attr:`umbmark.kinds.Kind.parameters`: their labels, units,
intervals and nominal values), the lidar on the robot and the kind's exports.

Made from the self-calibration's JSON alone (``umbmark selfcal --kinematics KIND --save``, or a
history record).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from umbmark.errors import InputError
from umbmark.kinds import Kind, kind_in
from umbmark.viz.report import _e, _header, _load_section, _page, _table
from umbmark.viz.selfcal_report import PageParts, _correlations, lidar_figure, page_sections
from umbmark.viz.text import fmt

__all__ = ["is_kind_selfcal_result", "kind_selfcal_page", "KIND_EXPORTS"]

KIND_EXPORTS = (("ros2", "the controller's parameter file (ROS 2)"), ("urdf", "URDF origin"))
"""The exports a kind's page shows (the formats of :func:`umbmark.io.export_kinematic.format_kinematic_export`)."""

_MEANING = (
    "95 % interval: from the scatter of the intervals about the fit and between stretches of the recording; "
    "fixed: not estimated (at its nominal value). The intervals do not cover errors shared by the whole recording "
    "(one floor, one day): calibrate on another recording to see those."
)
_POSE = (("lidar x [mm]", "x_mm", 2), ("lidar y [mm]", "y_mm", 2), ("lidar yaw [deg]", "yaw_deg", 3))
_SENSOR_LABELS = {"sensor_x_m": "x", "sensor_y_m": "y", "sensor_yaw_rad": "yaw"}


def is_kind_selfcal_result(d: Any) -> bool:
    """Whether a JSON object is the self-calibration of a robot of a kind of its own (``umbmark
    selfcal --kinematics KIND --json`` or ``--save``; not its replay against a ground truth)."""
    return kind_in(d) is not None and isinstance(d.get("sensor_pose"), dict) and "marker_pose" not in d


def _ci(lo_hi: Any, digits: int) -> str:
    if not (isinstance(lo_hi, (list, tuple)) and len(lo_hi) == 2):
        return "fixed"
    return f"{fmt(lo_hi[0], digits)} to {fmt(lo_hi[1], digits)}"


def _nominal_pose(d: dict[str, Any]) -> dict[str, Any]:
    inputs = [i for i in (d.get("inputs") or []) if isinstance(i, dict)]
    nsp = inputs[0].get("nominal_sensor_pose") if inputs else None
    return nsp if isinstance(nsp, dict) else {}


def _nominal(d: dict[str, Any]) -> dict[str, Any]:
    got = d.get("nominal")
    return got if isinstance(got, dict) else {}


def _estimates(d: dict[str, Any], own: Kind) -> str:
    nominal = _nominal(d)
    got = {p.name: v for p, v, _ in own.estimates_json(nominal)}
    rows = [
        [p.table_label, fmt(v, p.digits), _ci(ci, p.digits), fmt(got.get(p.name), p.digits)]
        for p, v, ci in own.estimates_json(d)
    ]
    sp, nom = d["sensor_pose"], _nominal_pose(d)
    for label, key, digits in _POSE:
        rows.append([label, fmt(sp.get(key), digits), _ci(sp.get(f"{key}_ci95"), digits), fmt(nom.get(key), digits)])
    delays = [s for s in (d.get("scan_delay") or []) if isinstance(s, dict)]
    for s in delays:
        applied = s.get("applied_s")
        label = "scans' delay [ms]" + (f" ({Path(str(s.get('bag', ''))).name})" if len(delays) > 1 else "")
        how = "estimated" if s.get("requested") == "auto" else "given"
        rows.append([label, fmt(None if applied is None else applied * 1e3, 1), how, "0"])
    legend = "".join(f'<p class="meta">{_e(line)}</p>' for line in own.legend)
    return _table(["", "estimate", "95 % interval", "nominal"], rows) + legend + f'<p class="meta">{_e(_MEANING)}</p>'


def _load(d: dict[str, Any], source: str | None, commands: str | None) -> list[str]:
    """How to load it: the commands, and the texts they write (the kind's exports)."""
    from umbmark.io.export_kinematic import format_kinematic_export, kinematic_calibration_from_dict

    return _load_section(
        d, source or "<selfcal>", commands, KIND_EXPORTS, kinematic_calibration_from_dict, format_kinematic_export
    )


def _mount(d: dict[str, Any], own: Kind) -> Any:
    """The lidar on the robot: a box of the robot's largest nominal length about its origin."""
    nominal = _nominal(d)
    lengths = [v for p, v, _ in own.estimates_json(nominal) if p.unit == "mm"] or [500.0]
    names = [str(n) for n in d.get("parameters") or []]
    xy = (names.index("sensor_x_m"), names.index("sensor_y_m")) if {"sensor_x_m", "sensor_y_m"} <= set(names) else None
    fig, _, _ = lidar_figure(d, max(lengths), _nominal_pose(d), xy)
    fig.tight_layout()
    return fig


def kind_selfcal_page(
    d: dict[str, Any],
    *,
    title: str | None = None,
    source: str | None = None,
    source_sha256: str | None = None,
    robot: str | None = None,
    when: str | None = None,
    exported: dict[str, str] | None = None,
    load_commands: str | None = None,
) -> str:
    """The HTML page of the self-calibration of a robot of a kind of its own.

    Parameters
    ----------
    d : dict
        Its JSON (:meth:`umbmark.realrobot.kinematic.KinematicReport.to_dict`).
    title, source, source_sha256, robot, when, exported, load_commands
        As :func:`umbmark.viz.selfcal_report.selfcal_page`.

    Returns
    -------
    str
        One self-contained HTML document.

    Raises
    ------
    InputError
        A JSON that is not such a self-calibration.
    """
    own = kind_in(d)
    if own is None or not is_kind_selfcal_result(d):
        raise InputError("not the self-calibration of a robot of a kind of its own (no `kinematics`, `sensor_pose`)")
    sp = d["sensor_pose"]
    box = (
        f'<div class="box"><p class="big">A {_e(own.noun)}: {_e(own.describe_json(d))}</p>'
        f"<p>lidar at x = {_e(fmt(sp.get('x_mm'), 2))} mm, y = {_e(fmt(sp.get('y_mm'), 2))} mm, yaw = "
        f"{_e(fmt(sp.get('yaw_deg'), 3))} deg</p></div>"
    )
    short = {p.name: p.label for p in own.parameters} | _SENSOR_LABELS
    names = [short.get(str(n), str(n)) for n in d.get("parameters") or []]
    parts = PageParts(
        box=box,
        estimates=_estimates(d, own),
        correlations=_correlations(
            d, names, "x, y, yaw: the lidar on the robot; the rest: the kind's parameters", "every move both ways"
        ),
        mount=_mount(d, own),
        load=_load(d, source, load_commands),
        definitions=" ".join(own.legend)
        + " The lidar's pose: x forward and y to the left of the robot's origin, yaw counter-clockwise from its "
        "heading. Residual: the lidar's measured displacement over an interval minus the one the estimate "
        "predicts from the joints, in the lidar's frame at the interval's start.",
    )
    title = title or f"Self-calibration report ({own.noun})"
    body = _header(title, when, robot, f"result {source}" if source else None, source_sha256)
    body += page_sections(d, parts, exported)
    return _page(title, "\n".join(body))
