"""``umbmark export`` of the self-calibration of a robot of a kind with a module of its own
(:mod:`umbmark.kinds`: a tricycle, a mecanum robot, a car), and the writing of any export.

The library does the work (:mod:`umbmark.io.export_kinematic`): the controller's parameters, the
lidar's pose, and the parameter files of the robots' own software that a kind's export edits
(:attr:`umbmark.kinds.Kind.edited_files`: a car's ``vesc.yaml``, given with ``--vesc-config``;
the options are made from the registry). This module checks the flags of the kind, reads the
user's file, and writes the export to ``--out`` (atomically) or prints it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, TypeVar

import click

from umbmark.cli.app import cli_message, console, is_quiet
from umbmark.cli.options import flag
from umbmark.errors import InputError
from umbmark.kinds import KINDS, EditedFile, Kind, kind_named

F = TypeVar("F", bound=Callable[..., Any])

__all__ = [
    "edited_file_options",
    "edited_files",
    "kinematic_json",
    "export_kinematic",
    "refuse_edited_files",
    "emit_export",
]


def edited_files() -> dict[str, tuple[EditedFile, tuple[Kind, ...]]]:
    """Every kind's edited parameter files by option (:attr:`umbmark.kinds.Kind.edited_files`),
    with the kinds that have each."""
    out: dict[str, tuple[EditedFile, tuple[Kind, ...]]] = {}
    for k in KINDS.values():
        for e in k.edited_files:
            spec, kinds = out.get(e.option, (e, ()))
            out[e.option] = (spec, (*kinds, k))
    return out


def edited_file_options(f: F) -> F:
    """``umbmark export``'s options naming the user's parameter files it edits (``--vesc-config``)."""
    for option, (e, kinds) in reversed(list(edited_files().items())):
        f = click.option(
            flag(option),
            type=click.Path(dir_okay=False),
            default=None,
            metavar=e.metavar,
            help=f"{', '.join(k.title for k in kinds)}: {e.describe}, for --format {e.format}: written to --out with "
            f"{', '.join(e.changed)} calibrated from the values in use it holds, every other line kept.",
        )(f)
    return f


def kinematic_json(path: str | Path) -> dict | None:
    """The JSON of the self-calibration of a robot of a kind of its own (a tricycle's), else None."""
    from umbmark.io.export_kinematic import read_kinematic_json

    return read_kinematic_json(path)


def _edited_path(kind: Kind, out_format: str, files: Mapping[str, str | None], src: str) -> str | None:
    """The user's parameter file that ``--format`` edits (None: a format that edits none)."""
    spec = next((e for e in kind.edited_files if e.format == out_format), None)
    for option, v in files.items():
        if v is not None and (spec is None or option != spec.option):
            raise InputError(
                f"{flag(option)} is for --format {edited_files()[option][0].format}, not {out_format}", src
            )
    if spec is None:
        if out_format not in kind.export_formats:
            _refuse_edited_format(out_format)
        return None
    if files.get(spec.option) is None:
        raise InputError(f"--format {out_format} edits {spec.describe}: give it, {flag(spec.option)} {spec.metavar}")
    return str(files[spec.option])


def export_kinematic(
    d: dict,
    src: str,
    out_format: str,
    controller: str | None,
    sensor_z_mm: float | None,
    out: str | None,
    steering: tuple[float, float],
    given: Mapping[str, object],
    files: Mapping[str, str | None],
) -> None:
    """``umbmark export`` of the self-calibration of a robot of a kind of its own (:mod:`umbmark.kinds`):
    ``steering`` is the steering joint's offset [deg] and reduction in use, ``given`` the options of a
    differential drive's export (refused), ``files`` the parameter files to edit by option."""
    from dataclasses import replace

    from umbmark.cli.kinematic import own_kinds
    from umbmark.io.export_kinematic import (
        format_edited_file,
        format_kinematic_export,
        kinematic_calibration_from_dict,
    )

    for name, v in given.items():
        if v is not None and not (name.endswith("_multiplier") and v == 1.0):
            raise InputError(f"--{name.replace('_', '-')} is a differential drive's: not for a {d['kinematics']}", src)
    cal = kinematic_calibration_from_dict(d, src)
    if sensor_z_mm is not None:
        if not math.isfinite(sensor_z_mm):
            raise InputError(f"--sensor-z-mm must be a number of millimetres, got {sensor_z_mm}")
        x, y, _, roll, pitch, yaw = cal.sensor_pose
        cal = replace(cal, sensor_pose=(x, y, sensor_z_mm * 1e-3, roll, pitch, yaw), sensor_height_known=True)
    offset_deg, reduction = steering
    if not kind_named(cal.kind).steered and (offset_deg, reduction) != (0.0, 1.0):
        raise InputError(
            f"--steering-offset-in-use-deg and --steering-reduction-in-use are {own_kinds(steered=True)}", src
        )
    path = _edited_path(kind_named(cal.kind), out_format, files, src)
    if path is not None:
        from umbmark.io._text import read_text

        text, lines = format_edited_file(cal, out_format, read_text(path), path)
        for line in lines:
            if line.startswith("warning: ") or not is_quiet():
                click.echo(cli_message(line), err=True)
        emit_export(text, out, cal.warnings)
        return
    text = format_kinematic_export(
        cal,
        out_format,
        controller,
        steering_offset0_rad=math.radians(offset_deg),
        steering_reduction0=reduction,
    )
    emit_export(text, out, cal.warnings)


def _refuse_edited_format(out_format: str) -> None:
    """Refuse a format that edits a parameter file of another kind's."""
    for e, kinds in edited_files().values():
        if e.format == out_format:
            nouns = " or ".join(f"{k.noun}'s" for k in kinds)
            raise InputError(f"--format {out_format} edits {e.describe} from a {nouns} self-calibration")


def refuse_edited_files(files: dict, out_format: str) -> None:
    """Refuse a parameter file to edit, or its format, with a calibration whose kind edits none (a
    differential drive's)."""
    _refuse_edited_format(out_format)
    for option, v in files.items():
        if v is not None:
            e, kinds = edited_files()[option]
            nouns = " or ".join(f"{k.noun}'s" for k in kinds)
            raise InputError(f"{flag(option)} is for --format {e.format} of a {nouns} self-calibration")


def emit_export(text: str, out: str | None, warnings: Iterable[str]) -> None:
    """The warnings on stderr, then the export written to ``out`` (said) or printed."""
    from umbmark.io.export import write_export

    for w in warnings:
        click.echo(f"warning: {cli_message(w)}", err=True)
    if out:
        write_export(text, out)
        if not is_quiet():
            console().print(f"wrote {out}", markup=False, soft_wrap=True)
    else:
        click.echo(text, nl=False)
