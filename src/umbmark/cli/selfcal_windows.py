"""``umbmark selfcal --window DURATION``: the windows of a long recording, each self-calibrated
(and recorded with its own date)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from umbmark.cli.app import console, fmt, table
from umbmark.cli.history import _when, record_if_requested
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.kinds import Kind

__all__ = ["window_seconds", "selfcal_windows_cmd", "record_windows"]

_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "min": 60.0, "m": 60.0, "h": 3600.0, "hr": 3600.0}


def window_seconds(text: str) -> float:
    """A duration such as ``10min``, ``600s``, ``1.5h`` or ``600`` (seconds), in seconds.

    Raises
    ------
    click.BadParameter
        Not such a duration, or under 10 s or over a week.
    """
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]+)?)\s*([a-z]*)\s*", str(text).lower())
    if not m or m.group(2) not in _UNITS:
        raise click.BadParameter(f"{text!r} is no duration (e.g. 10min, 600s, 1h)", param_hint="'--window'")
    s = float(m.group(1)) * _UNITS[m.group(2)]
    if not (math.isfinite(s) and 10.0 <= s <= 7 * 86400.0):
        raise click.BadParameter(f"{text} is {s:g} s: a window is 10 s to a week long", param_hint="'--window'")
    return s


def selfcal_windows_cmd(
    rep: Any, window_s: float, opts: dict, robot: str | None, record: bool, db: str | None
) -> tuple[list[dict], list]:
    """Self-calibrate the windows of ``rep``'s inputs; record each calibrated one when asked.

    Returns
    -------
    tuple
        The windows' JSON (each with its ``history`` record when recorded), and the records.
    """
    from umbmark.history import file_sha256
    from umbmark.realrobot.selfcal_windows import selfcal_windows

    def fields_of(w: Any) -> tuple[dict, str]:
        fields = w.report.history_fields(kind="selfcal")
        if Path(w.input).exists():  # the window's recording: its content and where it is
            fields.update(input_sha256=file_sha256(w.input), source=str(Path(w.input).resolve()))
        return fields, w.input

    wins = selfcal_windows(rep, window_s, **opts)
    return record_windows(wins, window_s, "self-calibrated", fields_of, (robot, record, db))


def record_windows(
    wins: list, window_s: float, done: str, fields_of: Callable[[Any], tuple[dict, str]], history: tuple
) -> tuple[list[dict], list]:
    """The windows' JSON, each calibrated one recorded with its own date when ``--record`` was given.

    Parameters
    ----------
    wins : list
        Windows with ``report`` (None: not calibrated, ``error`` says why), ``index``, ``start_s``,
        ``end_s``, ``time(base)`` and ``to_dict(base)``.
    window_s : float
        The asked length [s] (for the error).
    done : str
        What a window's calibration is called (for the error): ``self-calibrated``, ``calibrated``.
    fields_of : callable
        A calibrated window -> its history fields and the name of what it is a window of.
    history : tuple
        ``--robot``, ``--record`` and ``--db``.

    Returns
    -------
    tuple
        The windows' JSON (each with its ``history`` record when recorded), and the records.

    Raises
    ------
    InputError
        No window could be calibrated.
    """
    robot, record, db = history
    when = _when()
    base = datetime.fromisoformat(when) if when else None
    if not any(w.report is not None for w in wins):
        raise InputError(f"no window of {window_s:g} s could be {done}: {wins[0].error}")
    out, recs = [], []
    for w in wins:
        d = w.to_dict(base)
        if record and w.report is not None:
            fields, of = fields_of(w)
            fields["when"] = w.time(base)
            fields["note"] = f"window {w.index + 1} ({w.start_s:.0f}-{w.end_s:.0f} s) of {of}"
            fields["inputs"] = {**(fields.get("inputs") or {}), "window_s": [w.start_s, w.end_s]}
            rec = record_if_requested(robot, record, db, **fields)
            d["history"] = rec
            recs.append(rec)
        out.append(d)
    return out, recs


def print_windows(windows: list[dict]) -> None:
    """The windows as a table: when, the diameters, the wheelbase, E_d, E_b, the lidar (another kind of
    robot: its geometry in words, the lidar)."""
    from umbmark.kinds import kind_in

    own = next((kind_in(w["result"]) for w in windows if w["result"] is not None), None)
    if own is not None:
        _print_kind_windows(windows, own)
        return
    rows = []
    for w in windows:
        r = w["result"]
        if r is None:
            rows.append([w["window"] + 1, w["start_utc"][:19].replace("T", " "), "-", "-", "-", "-", w["error"]])
            continue
        rows.append(
            [
                w["window"] + 1,
                w["start_utc"][:19].replace("T", " "),
                f"{fmt(r['wheel_diameter_left_mm'], 3)} / {fmt(r['wheel_diameter_right_mm'], 3)}",
                fmt(r["wheelbase_mm"], 2),
                fmt(r["Ed"], 6),
                fmt(r["Eb"], 6),
                f"x {fmt(r['sensor_pose']['x_mm'], 1)}, y {fmt(r['sensor_pose']['y_mm'], 1)} mm",
            ]
        )
    console().print(
        table(
            "Windows (each self-calibrated on its own)",
            ["#", "start (UTC)", "D_L / D_R [mm]", "wheelbase [mm]", "E_d", "E_b", "lidar / why not"],
            rows,
        )
    )


def _print_kind_windows(windows: list[dict], own: Kind) -> None:
    rows = []
    for w in windows:
        r = w["result"]
        start = w["start_utc"][:19].replace("T", " ")
        if r is None:
            rows.append([w["window"] + 1, start, "-", w["error"]])
            continue
        lidar = f"x {fmt(r['sensor_pose']['x_mm'], 1)}, y {fmt(r['sensor_pose']['y_mm'], 1)} mm"
        rows.append([w["window"] + 1, start, own.describe_json(r), lidar])
    title = f"Windows (each self-calibrated on its own; a {own.noun})"
    console().print(table(title, ["#", "start (UTC)", "geometry", "lidar / why not"], rows))
