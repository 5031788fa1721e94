"""One self-calibration of recordings as a value: :class:`SelfcalSettings` (the nominal geometry,
how the bags are read and cut into intervals, the fit's options) and
:func:`selfcal_recordings`, which self-calibrates bags or intervals files with them.

``umbmark selfcal`` and the fleet (:mod:`umbmark.fleet`) both call :func:`selfcal_recordings`:
the settings are made and checked once (by the command line, from its options) and travel to
the workers as they are (frozen, picklable).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from umbmark._check import CHECKS, positive, skipping_checks
from umbmark.errors import InputError
from umbmark.io.wheels import WheelSource
from umbmark.kinds import DEFAULT_KIND, kind_named
from umbmark.model.defaults import SCAN_TOPIC
from umbmark.realrobot.selfcal import IntervalOptions, SelfcalReport, StageProgress

__all__ = ["SelfcalSettings", "recording_kind", "selfcal_recordings"]


@dataclass(frozen=True)
class SelfcalSettings:
    """What a self-calibration needs besides its recordings.

    Parameters
    ----------
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry [m].
    wheels : WheelSource
        Bags: where the wheel data are (:mod:`umbmark.io.wheels`).
    scan_topic : str
        Bags: the ``sensor_msgs/LaserScan`` topic.
    scan_frame : str, optional
        Bags: refuse scans in another frame than this.
    intervals : IntervalOptions
        Bags: how the scans and wheel data become matched intervals (keyframes, sensor pose,
        base frame, wheel gaps, matcher, scans' delay, the fewest intervals).
    reject_outliers : bool
        Reject outlying intervals (:func:`umbmark.correct.selfcal.selfcal`).
    time_jitter : bool
        Model the wheel data's stamp jitter against the scans'.
    skip_checks : frozenset of str
        The plausibility checks (:data:`umbmark._check.CHECKS`) that let the recordings through.
    kind : str
        The kind of robot (:func:`umbmark.kinds.kind_named`): one calibrated by the differential
        drive's pipeline (a tricycle's and a mecanum robot's self-calibration is
        :func:`umbmark.realrobot.kinematic.kinematic_selfcal_from_bags`).

    Raises
    ------
    InputError
        A nominal size that is not a positive number, an unknown check, a kind of another pipeline.
    """

    wheel_diameter_m: float
    wheelbase_m: float
    wheels: WheelSource = field(default_factory=WheelSource)
    scan_topic: str = SCAN_TOPIC
    scan_frame: str | None = None
    intervals: IntervalOptions = field(default_factory=IntervalOptions)
    reject_outliers: bool = True
    time_jitter: bool = True
    skip_checks: frozenset[str] = frozenset()
    kind: str = DEFAULT_KIND

    def __post_init__(self) -> None:
        positive("`wheel_diameter_m`", self.wheel_diameter_m)
        positive("`wheelbase_m`", self.wheelbase_m)
        object.__setattr__(self, "skip_checks", frozenset(self.skip_checks))
        unknown = sorted(self.skip_checks - set(CHECKS))
        if unknown:
            raise InputError(f"`skip_checks`: no check named {unknown[0]!r} (checks: {', '.join(CHECKS)})")
        if not kind_named(self.kind).differential:
            raise InputError(f"`kind` {self.kind!r}: these settings are a differential drive's self-calibration")

    @property
    def fit_options(self) -> dict[str, bool]:
        """The keyword arguments of :func:`umbmark.correct.selfcal.selfcal`."""
        return {"reject_outliers": self.reject_outliers, "time_jitter": self.time_jitter}


def recording_kind(paths: Sequence[str | Path]) -> str:
    """``bags`` or ``intervals`` (CSV files): every input of one self-calibration is of one kind.

    Raises
    ------
    InputError
        An input that does not exist, that is neither a bag nor a ``.csv`` file, inputs of both
        kinds, one recording given twice.
    """
    from umbmark._files import check_distinct_inputs
    from umbmark.io.rosbag import is_bag

    kinds = set()
    for p in paths:
        q = Path(p)
        if not q.exists():
            raise InputError("not found", source=str(p))
        if q.is_file() and q.suffix.lower() == ".csv":
            kinds.add("intervals")
        elif is_bag(q):
            kinds.add("bags")
        else:
            raise InputError(
                "not a ROS bag (.bag, .mcap, .db3, or a folder with metadata.yaml) nor an intervals file (.csv)",
                source=str(p),
            )
    if len(kinds) > 1:
        raise InputError("give bags or intervals files, not both")
    if not kinds:
        raise InputError("no recording to self-calibrate")
    check_distinct_inputs(paths)
    return kinds.pop()


def selfcal_recordings(
    paths: str | Path | Sequence[str | Path],
    settings: SelfcalSettings,
    progress: StageProgress | None = None,
) -> SelfcalReport:
    """Self-calibrate bags (:func:`umbmark.realrobot.selfcal.selfcal_from_bags`) or intervals
    files (:func:`umbmark.realrobot.selfcal.selfcal_from_intervals`), pooled, with ``settings``
    (its skipped checks skipped, besides those the caller skips already).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The recordings: bags, or intervals files (:func:`recording_kind`).
    settings : SelfcalSettings
    progress : callable, optional
        Told each stage's progress (:data:`umbmark.realrobot.selfcal.StageProgress`).

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        As :func:`recording_kind` and the self-calibration.
    """
    from umbmark.realrobot.selfcal import selfcal_from_bags, selfcal_from_intervals

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    d, b = settings.wheel_diameter_m, settings.wheelbase_m
    with skipping_checks(settings.skip_checks):
        if recording_kind(items) == "intervals":
            if progress is not None:
                progress("self-calibrating", 0, 0)
            return selfcal_from_intervals(items, d, b, **settings.fit_options)
        return selfcal_from_bags(
            items,
            d,
            b,
            wheels=settings.wheels,
            scan_topic=settings.scan_topic,
            scan_frame=settings.scan_frame,
            options=settings.intervals,
            selfcal_options=settings.fit_options,
            progress=progress,
        )
