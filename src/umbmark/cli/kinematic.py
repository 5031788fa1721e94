"""``umbmark selfcal --kinematics KIND`` and ``umbmark replay --kinematics KIND``: the geometry of a
robot of a kind with a module of its own (:mod:`umbmark.kinds`: a tricycle, a mecanum robot) from
its lidar (and the lidar's mounting pose), or against a ground truth (and the tracked marker's
pose), from ROS bags.

The library does the work (:mod:`umbmark.realrobot.kinematic`,
:mod:`umbmark.realrobot.kinematic_replay`); this module makes the kinds' options from the
registry (:data:`umbmark.kinds.KINDS`: ``--kinematics``'s choices, each kind's joints, sizes and
fit flags), checks the flags of the kind, calls the library with progress bars and prints the
result's ``to_dict()`` or a table made from it.
"""

from __future__ import annotations

import shlex
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from umbmark.cli.app import cli_message, console, emit_json, fmt, is_quiet, table
from umbmark.cli.command_config import KindConfig, kind_options
from umbmark.cli.config import option_of
from umbmark.cli.options import flag
from umbmark.errors import InputError
from umbmark.kinds import KINDS, Kind, kind_named

if TYPE_CHECKING:
    from umbmark.cli.command_config import SelfcalConfig
    from umbmark.realrobot.kinematic_settings import KinematicSettings

F = TypeVar("F", bound=Callable[..., Any])

_kind_option = option_of(KindConfig)

__all__ = [
    "kinematic_selfcal_cmd",
    "kinematic_replay_cmd",
    "kinematic_options",
    "joint_options",
    "kind_options",
    "refuse_kind_options",
    "joints_help",
    "export_formats",
    "own_kinds",
    "own_controllers",
    "steered_titles",
    "LEGEND",
]


def _nouns(kinds: Iterable[Kind], possessive: bool = False) -> str:
    """``a tricycle or mecanum robot`` (``a tricycle's or mecanum robot's``)."""
    s = "'s" if possessive else ""
    return "a " + " or ".join(f"{k.noun}{s}" for k in kinds)


def _kind_help() -> str:
    parts = []
    for k in KINDS.values():
        if k.differential:
            parts.append(f"a {k.noun} (or skid steer)")
            continue
        own = [f"{flag(j.option)} {j.metavar}" if len(j.roles) > 1 else flag(j.option) for j in k.joints]
        common = set.intersection(*(set(s.option for s in x.sizes) for x in KINDS.values()))
        own += [flag(s.option) for s in k.sizes if s.option not in common]
        parts.append(f"a {k.noun} ({', '.join(own)})")
    return f"The kind of robot: {', '.join(parts[:-1])} or {parts[-1]}."


def _option(name: str, kinds: tuple[Kind, ...]) -> Callable[[F], F]:
    """The click option of a kind's own option (its help prefixed by the kinds that have it), its
    default :class:`~umbmark.cli.command_config.KindConfig`'s."""
    who = ", ".join(k.title for k in kinds)
    k = kinds[0]
    for j in k.joints:
        if j.option == name:
            return _kind_option(flag(name), metavar=j.metavar, help=f"{who}: {j.help}")
    for f in k.fits:
        if f.option == name:
            return _kind_option(flag(name), is_flag=True, help=f"{who}: {f.help}")
    for s in k.sizes:
        if s.option == name:
            return _kind_option(flag(name), type=float, help=f"{who}: {s.help}")
        if s.alternative is not None and s.alternative.option == name:
            return _kind_option(flag(name), type=float, help=f"{who}: {s.label} [m].")
    raise AssertionError(name)  # an option the kind does not describe


def kinematic_options(f: F) -> F:
    """The options of the kind of robot (``selfcal`` and ``replay``): ``--kinematics`` (a choice of
    :data:`umbmark.kinds.KINDS`) and each kind's options the differential drive has not
    (``--drive-joint``, ``--steer-joint``, ``--lx-plus-ly-mm``, ``--fit-steering-scale``)."""
    options = [
        _kind_option(
            "--kinematics",
            type=click.Choice(list(KINDS)),
            show_default=True,
            help=_kind_help(),
        ),
        *(_option(name, kinds) for name, kinds in kind_options().items()),
    ]
    for option in reversed(options):
        f = option(f)
    return f


def joint_options(f: F) -> F:
    """The options naming the joints of the kinds that the differential drive's ``--joints`` does not
    (``--drive-joint``, ``--steer-joint``), for a command that takes the kind from its input
    (``umbmark validate``: the calibration's)."""
    joints = {j.option for k in KINDS.values() for j in k.joints}
    for name, kinds in reversed(list(kind_options().items())):
        if name in joints:
            f = _option(name, kinds)(f)
    return f


def joints_help(text: str) -> str:
    """``--joints``'s help: ``text`` and the order each other kind that names its joints with it wants."""
    other = [
        f"{k.name}: {j.metavar}" for k in KINDS.values() if not k.differential for j in k.joints if j.option == "joints"
    ]
    return f"{text} ({'; '.join(other)})." if other else f"{text}."


def refuse_kind_options(kw: dict, pop: bool = False) -> None:
    """Refuse the options of other kinds given to the default kind's command (``--steer-joint`` with
    no ``--kinematics``): one line naming the kinds that have it.

    Raises
    ------
    InputError
        The first such option given.
    """
    for name, kinds in kind_options().items():
        v = kw.pop(name, None) if pop else kw.get(name)
        if v is not None and v is not False:
            raise InputError(f"{flag(name)} needs --kinematics {' or '.join(k.name for k in kinds)}")


def _fit(kind: Kind, kw: dict) -> tuple[str, ...] | None:
    """The parameters to estimate: the kind's default ones and those its fit flags free."""
    for name, kinds in kind_options().items():
        if kw.get(name) is True and kind not in kinds:
            raise InputError(f"{flag(name)} is {_nouns(kinds, True)}")
    return kind.fit_of(f.option for f in kind.fits if kw.get(f.option))


def export_formats() -> tuple[str, ...]:
    """``umbmark export``'s formats: every kind's (:attr:`umbmark.kinds.Kind.export_formats`), the
    default kind's first."""
    return tuple(dict.fromkeys(f for k in KINDS.values() for f in k.export_formats))


def own_kinds(possessive: bool = True, steered: bool = False) -> str:
    """The kinds with a module of their own, as the help names them: ``a tricycle's or mecanum
    robot's`` (only those with a steering joint: ``steered``)."""
    return _nouns([k for k in KINDS.values() if not k.differential and (k.steered or not steered)], possessive)


def own_controllers() -> str:
    """Their controllers: ``tricycle_controller or mecanum_drive_controller``."""
    return " or ".join(k.controller for k in KINDS.values() if not k.differential)


def steered_titles() -> str:
    """How an option's help names the kinds with a steering joint (``Tricycle``)."""
    return ", ".join(k.title for k in KINDS.values() if k.steered)


LEGEND = {k.name: k.legend for k in KINDS.values() if not k.differential}
"""What the rows of each kind's table mean (:attr:`umbmark.kinds.Kind.legend`)."""

_COMMON = (
    "lidar x, y, yaw: where the lidar sits on the robot (x forward, y left of the robot's origin; yaw "
    "counter-clockwise from its heading).",
    "95 % interval: from the scatter of the intervals about the fit and between stretches of the recording; it "
    "does not cover errors shared by the whole recording: calibrate on another to see those.",
)

# flags of the differential drive's calibration the other kinds have no use for
# (and why: the kind's noun fills in)
_REFUSED = {
    "ticks_topic": "--ticks-topic reads two wheels' encoder counts: a {noun} is read from its joint states",
    "intervals_out": "--intervals-out writes two wheels' rotations (an intervals file's columns): a {noun}'s "
    "intervals hold its own joints; keep its result with --save",
}


def kinematic_settings(cfg: SelfcalConfig) -> KinematicSettings:
    """The :class:`~umbmark.realrobot.kinematic_settings.KinematicSettings` of selfcal's options for
    a robot of the kind ``--kinematics`` names, checked before anything is read (the fleet's too).

    Raises
    ------
    InputError
        An option of a differential drive's the kind has no use for, an odometry for a kind that
        reads none, the kind's sizes or joints missing or of another kind, the interval options.
    """
    from umbmark.cli.bags import interval_options
    from umbmark.cli.options import kinematic_joints, kinematic_nominal
    from umbmark.realrobot.kinematic_settings import KinematicSettings

    kind, kw = cfg.kind.kinematics, cfg.params()
    for key, why in _REFUSED.items():
        if kw.get(key):
            raise InputError(why.format(noun=kind_named(kind).noun))
    odom = cfg.wheels.odom_topic or None
    if odom and not kind_named(kind).reads_odometry:
        raise InputError(kind_named(kind).odometry_refusal())
    return KinematicSettings(
        kinematic_nominal(kind, kw),
        kinematic_joints(kind, kw),
        joint_topic=cfg.wheels.joint_topic,
        scan_topic=cfg.scans.scan_topic,
        scan_frame=cfg.scans.scan_frame,
        intervals=interval_options(cfg.keyframes, cfg.scans, cfg.fit.min_intervals),
        fit=_fit(kind_named(kind), kw),
        reject_outliers=not cfg.fit.keep_outliers,
        odom_topic=odom,
        skip_checks=frozenset(cfg.fit.skip_check),  # the command's own: also applied around it
    )


def kinematic_selfcal_cmd(paths: tuple[str, ...], cfg: SelfcalConfig, window_s: float | None) -> None:
    """Run the self-calibration of a robot of a kind of its own for ``umbmark selfcal``: ``window_s``
    the ``--window`` in seconds (or None)."""
    from umbmark._files import check_distinct_inputs
    from umbmark.cli.bags import Bars, kind_of, start_kernels
    from umbmark.cli.history import print_recorded, record_if_requested, refuse_if_recorded
    from umbmark.realrobot.kinematic_settings import kinematic_recordings

    kind, save, as_json = cfg.kind.kinematics, cfg.outputs.save, cfg.outputs.as_json
    history = robot, record, db = cfg.history.robot, cfg.history.record, cfg.history.db
    check_distinct_inputs([p for p in paths if Path(p).exists()])  # the repeat named before any other mistake
    settings = kinematic_settings(cfg)
    if kind_of(paths) != "bags":
        raise InputError(f"--kinematics {kind} reads ROS bags (joint states and laser scans), not intervals files")
    refuse_if_recorded(robot, record, db, kind="selfcal", method="selfcal", paths=paths)  # windows too: they cover it
    start_kernels()
    with Bars(enabled=not as_json) as bars:
        rep = kinematic_recordings(list(paths), settings, progress=bars)
    d = rep.to_dict()
    rec: dict | list | None = None
    if window_s is not None:
        from umbmark.cli.selfcal_windows import selfcal_windows_cmd

        d["windows"], rec = selfcal_windows_cmd(rep, window_s, {"reject_outliers": settings.reject_outliers}, *history)
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if record and window_s is None:
        from umbmark.history import file_sha256

        rec = record_if_requested(robot, record, db, **rep.history_fields(kind="selfcal", file_hash=file_sha256))
    if as_json:
        emit_json(d if rec is None else {**d, "history": rec})
        return
    if is_quiet():
        return
    _print(d, save)
    if window_s is not None:
        from umbmark.cli.selfcal_windows import print_windows

        print_windows(d["windows"])
    print_recorded(rec)


def _ci(lo_hi: Sequence[float] | None, digits: int) -> str:
    return "fixed" if lo_hi is None else f"{lo_hi[0]:.{digits}f} to {lo_hi[1]:.{digits}f}"


def _pose_rows(what: str, pose: dict) -> list[list[str]]:
    """The table rows of a pose on the robot (the lidar's, a marker's) with its intervals."""
    return [
        [f"{what} {k} [{unit}]", fmt(pose[f"{k}_{unit}"], n), _ci(pose[f"{k}_{unit}_ci95"], n), ""]
        for k, unit, n in (("x", "mm", 2), ("y", "mm", 2), ("yaw", "deg", 3))
    ]


def _at(d: dict, key: tuple[str, ...]) -> Any:
    v: Any = d
    for k in key:
        v = v[k]
    return v


def _rows(d: dict) -> list[list[str]]:
    """The table's rows of the kind's geometry (:attr:`umbmark.kinds.Kind.parameters`)."""
    n = d["nominal"]
    return [
        [p.table_label, fmt(_at(d, p.key), p.digits), _ci(_at(d, p.ci_key), p.digits), f"{_at(n, p.key):g}"]
        for p in kind_named(d["kinematics"]).parameters
    ]


def _print(d: dict, save: str | None) -> None:
    from rich.markup import escape

    c = console()
    for b in d["inputs"]:
        c.print(
            escape(
                f"{b['path']}: {b['scans_read']} scans on {b['scan_topic']} over {b['time_span_s']:.1f} s, joints "
                f"from {b['wheel_data']}; keyframes {d['keyframes']['description']}: {b['pairs_matched']} scan pairs "
                f"matched, {b['pairs_failed']} failed; scans' delay {1e3 * b['scan_delay']['applied_s']:.1f} ms"
            )
        )
        if b.get("wheel_stream"):
            from umbmark.cli.bags import stream_text

            c.print(escape(f"  joint data: {stream_text(b['wheel_stream'])}"))
    rows = _rows(d) + _pose_rows("lidar", d["sensor_pose"])
    c.print(
        table(
            f"Self-calibration of a {kind_named(d['kinematics']).noun} from {d['intervals_used']} intervals "
            f"({len(d['intervals_rejected'])} rejected as outliers)",
            ["", "estimate", "95 % interval", "nominal"],
            rows,
        )
    )
    for line in kind_named(d["kinematics"]).legend + _COMMON:
        c.print(f"[dim]{escape(line)}[/dim]")
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
    cal = shlex.quote(save or "selfcal.json")
    c.print("[bold]Next[/bold]: load the geometry into the controller's parameters and the lidar pose into the URDF:")
    if not save:
        c.print("  run again with --save selfcal.json, then")
    c.print(f"  {escape(f'umbmark export {cal} --format ros2 --out params.yaml')}", soft_wrap=True)
    c.print(f"  {escape(f'umbmark export {cal} --format urdf')}", soft_wrap=True)
    for e in kind_named(d["kinematics"]).edited_files:
        line = f"umbmark export {cal} --format {e.format} {flag(e.option)} {e.metavar} --out calibrated.yaml"
        c.print(f"  {escape(line)}", soft_wrap=True)


# the replay flags a robot of a kind of its own against a ground truth has use for (and every
# kind's own options, :func:`_replay_keep`)
_REPLAY_KEEP = {
    "joints", "joint_topic", "wheel_diameter_mm", "wheel_radius_m", "wheelbase_mm", "wheel_separation_m", "gt_topic",
    "gt_frame", "gt_parent", "time_offset",
}  # fmt: skip


def _replay_keep() -> set[str]:
    return _REPLAY_KEEP | {name for k in KINDS.values() for name in k.option_names()}


def kinematic_replay_cmd(
    kind: str,
    paths: tuple[str, ...],
    method: str,
    save: str | None,
    as_json: bool,
    record: bool,
    kw: dict[str, Any],
) -> None:
    """Run ``umbmark replay --kinematics KIND``: the geometry and the marker's pose against the
    bag's ground truth (least squares along the path)."""
    from umbmark.cli.options import kinematic_joints, kinematic_nominal
    from umbmark.model.timing import parse_time_offset
    from umbmark.realrobot.kinematic_replay import kinematic_replay_from_bag

    if method != "lsq":
        raise InputError(f"--kinematics {kind} fits along the path: --method lsq (bf and exact are UMBmark squares)")
    if record:
        raise InputError(
            f"--record keeps self-calibrations and a differential drive's replays: save a {kind}'s replay against a "
            "ground truth with --save (its self-calibration records with umbmark selfcal --record)"
        )
    if len(paths) != 1:
        raise InputError(f"--kinematics {kind} replays one bag at a time, got {len(paths)}")
    ctx = click.get_current_context(silent=True)
    keep = _replay_keep()
    for key in kw:
        given = ctx is not None and ctx.get_parameter_source(key) not in (
            None,
            click.core.ParameterSource.DEFAULT,
            click.core.ParameterSource.DEFAULT_MAP,
        )
        if given and key not in keep:
            raise InputError(f"--{key.replace('_', '-')} is not for --kinematics {kind}")
    if not kw.get("gt_topic"):
        raise InputError(f"--kinematics {kind} replays against a ground truth: give --gt-topic TOPIC")
    nominal = kinematic_nominal(kind, kw)
    joints = kinematic_joints(kind, kw)
    fit = _fit(kind_named(kind), kw)
    offset = parse_time_offset(kw.get("time_offset"))
    rep = kinematic_replay_from_bag(
        paths[0],
        nominal,
        joints,
        gt_topic=kw["gt_topic"],
        gt_frame=kw.get("gt_frame"),
        gt_parent=kw.get("gt_parent"),
        joint_topic=kw.get("joint_topic") or "/joint_states",
        time_offset="auto" if offset in (None, "auto") else offset,
        fit=fit,
    )
    d = rep.to_dict()
    if save:
        from umbmark.io.atomic import write_json

        write_json(save, d)
    if as_json:
        emit_json(d)
        return
    if is_quiet():
        return
    from rich.markup import escape

    c = console()
    e = d["relative_pose_error"]
    c.print(
        escape(
            f"{d['path']}: {d['intervals_used']} stretches of the path fitted; ground truth "
            f"{'estimated' if d['time_offset_estimated'] else 'given'} {1e3 * d['time_offset_s']:.1f} ms late"
        )
    )
    rows = _rows(d) + _pose_rows("marker", d["marker_pose"])
    c.print(
        table(
            f"Geometry of a {kind_named(d['kinematics']).noun} against the ground truth",
            ["", "estimate", "95 % interval", "nominal"],
            rows,
        )
    )
    c.print(
        escape(
            f"dead reckoning over {e['window_s']:g} s windows ({e['windows']}): position error "
            f"{e['before_mm']:.1f} mm -> {e['after_mm']:.1f} mm RMS, heading {e['heading_before_deg']:.2f} -> "
            f"{e['heading_after_deg']:.2f} deg, nominal -> calibrated"
        )
    )
    for w in d["warnings"]:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
