"""The bag options shared by ``umbmark selfcal``'s kinds of robot: inputs, progress bars, the
scan matcher's compile, the interval options of the bag flags.

Thin: no numerical module is imported before a command runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

import click

from umbmark._numbers import strict_float
from umbmark.cli.app import cli_message, is_quiet
from umbmark.cli.progress import progress
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.cli.command_config import KeyframesConfig, ScansConfig
    from umbmark.realrobot.selfcal import IntervalOptions

__all__ = ["float_list", "kind_of", "Bars", "start_kernels", "interval_options", "stream_text"]


KEYFRAME_BOUNDS = {
    "keyframe_mm": (5000.0, "two scans that far apart hardly see the same walls (a room is metres across)"),
    "keyframe_deg": (180.0, "a turn beyond half a revolution cannot be told from a turn the other way"),
    "keyframe_s": (60.0, "a minute between keyframes leaves the wheel odometry too far off for the scan matching"),
    "keyframe_min_s": (60.0, "a minute between keyframes leaves the wheel odometry too far off for the scan matching"),
}
"""The largest value of each keyframe flag, and why."""

WHEEL_GAP_S = (1e-3, 10.0)
"""The bounds of --max-wheel-gap-s [s]."""

MAX_MIN_INTERVALS = 100_000
"""The largest --min-intervals."""


def _shown(text: object, limit: int = 40) -> str:
    """``text`` quoted, cut to ``limit`` characters (a number of 5001 digits is not echoed whole)."""
    t = str(text)
    return repr(t) if len(t) <= limit else repr(t[:limit]) + f" ... ({len(t)} characters)"


def float_list(text: str, n: int, flag: str, meta: str) -> list[float]:
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [strict_float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{flag} needs {n} numbers {meta}, got {_shown(text)}")
    return vals


def kind_of(paths: Sequence[str | Path]) -> str:
    """``bags`` or ``intervals`` (CSV files): all inputs must be of one kind
    (:func:`umbmark.realrobot.selfcal_settings.recording_kind`)."""
    from umbmark.realrobot.selfcal_settings import recording_kind

    return recording_kind(paths)


class Bars:
    """Progress bars of the library's stages (:data:`umbmark.realrobot.selfcal.StageProgress`), each
    opened when the library first reports it (a spinner for a stage without steps); none with
    --json or --quiet."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.stack = ExitStack()
        self.bars: dict[str, tuple] = {}

    def __enter__(self) -> Bars:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stack.close()

    def __call__(self, stage: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        if stage not in self.bars:
            advance = self.stack.enter_context(progress(stage, total=total or None))
            self.bars[stage] = (advance, [0])
        advance, seen = self.bars[stage]
        if total:
            advance(done - seen[0])
            seen[0] = done


def start_kernels() -> None:
    """Start compiling the scan matcher where it is not yet compiled on this machine (in the
    background, while the bags are read), and say in one line on stderr when the matching will
    be slow (nothing with --quiet): numba missing, or the compile (only on a terminal)."""
    from umbmark.cli.progress import progress_enabled
    from umbmark.realrobot.scanmatch import kernel_state, start_compiling

    state = kernel_state()
    if state == "compile":
        start_compiling()
    if is_quiet():
        return
    if state == "interpreted":
        click.echo(
            "warning: numba is not installed: the scan matcher runs interpreted, about 100 times slower "
            "(pip install numba)",
            err=True,
        )
    elif state == "compile" and progress_enabled():
        click.echo("compiling the scan matcher (once per machine, about 10 s)", err=True)


def interval_options(keyframes: KeyframesConfig, scans: ScansConfig, min_intervals: int) -> IntervalOptions:
    """The :class:`~umbmark.realrobot.selfcal.IntervalOptions` of the bag options (keyframes, sensor
    pose, base frame, wheel gap, matcher, scans' delay), checked.

    Raises
    ------
    InputError
        A keyframe threshold, wheel gap or count of intervals out of its bounds, a bad sensor pose
        or scans' delay.
    """
    from umbmark.realrobot.scanmatch import ICPConfig
    from umbmark.realrobot.selfcal import IntervalOptions, KeyframeRule, parse_scan_delay

    for flag, (top, why) in KEYFRAME_BOUNDS.items():
        v = getattr(keyframes, flag)
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"--{flag.replace('_', '-')} must be a number >= 0, got {v!r}")
        if v > top:
            raise InputError(f"--{flag.replace('_', '-')} {v:g} is beyond {top:g}: {why}")
    v = keyframes.max_wheel_gap_s
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"--max-wheel-gap-s must be a positive number, got {v!r}")
    lo, hi = WHEEL_GAP_S
    if not lo <= v <= hi:
        raise InputError(
            f"--max-wheel-gap-s {v:g} is outside {lo:g} to {hi:g} s: wheel data come at most every millisecond, "
            "and in a gap of seconds the wheels' motion is not known (milliseconds given as seconds?)"
        )
    if min_intervals > MAX_MIN_INTERVALS:
        raise InputError(
            f"--min-intervals {min_intervals} is beyond {MAX_MIN_INTERVALS}: a self-calibration needs tens to "
            "hundreds of intervals (a recording of hours gives tens of thousands)"
        )
    k = keyframes
    if k.keyframe_s > 0 and k.keyframe_s < k.keyframe_min_s:
        raise InputError(f"--keyframe-s {k.keyframe_s:g} is below --keyframe-min-s {k.keyframe_min_s:g}")
    rule = KeyframeRule(
        min_distance_m=k.keyframe_mm * 1e-3,
        min_rotation_rad=math.radians(k.keyframe_deg),
        min_interval_s=k.keyframe_min_s,
        max_interval_s=k.keyframe_s if k.keyframe_s > 0 else math.inf,
    )
    pose = _sensor_pose(scans.sensor_pose)
    try:
        scan_delay = parse_scan_delay(scans.scan_delay)
    except InputError as err:
        if "beyond" in err.message:
            raise
        raise InputError(
            f"--scan-delay must be auto, off or seconds (positive: the scans are late), got {_shown(scans.scan_delay)}"
        ) from None
    return IntervalOptions(
        keyframes=rule,
        sensor_pose=pose,
        base_frame=scans.base_frame,
        max_wheel_gap_s=keyframes.max_wheel_gap_s,
        icp=ICPConfig(coarse=True) if scans.coarse else None,
        min_intervals=min_intervals,
        scan_delay=scan_delay,
    )


def _sensor_pose(text: str | None) -> tuple[float, float, float] | None:
    """The pose of ``--sensor-pose X_MM,Y_MM,YAW_DEG`` (metres, radians), warned about when it looks
    like another unit; None when not given."""
    if text is None:
        return None
    from umbmark.realrobot.scan_truth import check_sensor_pose

    x, y, yaw = float_list(text, 3, "--sensor-pose", "X_MM,Y_MM,YAW_DEG")
    if abs(yaw) > 360.0:
        raise InputError(
            f"--sensor-pose turns the sensor {yaw:g} deg: a mounting yaw is within +-360 deg (the yaw in degrees)"
        )
    pose = (x * 1e-3, y * 1e-3, math.radians(yaw))
    for w in check_sensor_pose(pose):
        click.echo(f"warning: {cli_message(w)}", err=True)
    return pose


def stream_text(d: dict) -> str:
    """One line of what the check of the wheel data found and did (its JSON block ``wheel_stream``)."""
    from umbmark.model.wheel_stream import StreamReport

    return StreamReport.from_dict(d).summary()
