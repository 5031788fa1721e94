"""One self-calibration of a robot of a kind of its own (:mod:`umbmark.kinds`: a tricycle, a mecanum
robot) as a value: :class:`KinematicSettings` (the nominal geometry, the joints, how the bags are
read and cut into intervals, the fit's options) and :func:`kinematic_recordings`, which
self-calibrates bags with them.

``umbmark selfcal --kinematics KIND`` calls :func:`kinematic_recordings` with the settings its
options make, checked before anything is read; a fleet's workers can take the same settings as
they are (frozen, picklable) and record each result with
:meth:`~umbmark.realrobot.kinematic.KinematicReport.history_fields`, as a differential drive's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from umbmark._check import CHECKS, skipping_checks
from umbmark.errors import InputError
from umbmark.kinds import kind_of
from umbmark.model.defaults import JOINT_TOPIC, SCAN_TOPIC
from umbmark.model.kinematics import Kinematics
from umbmark.realrobot.kinematic import KinematicReport, joint_source, kinematic_selfcal_from_bags
from umbmark.realrobot.selfcal import IntervalOptions, StageProgress

__all__ = ["KinematicSettings", "kinematic_recordings"]


@dataclass(frozen=True)
class KinematicSettings:
    """What the self-calibration of a robot of a kind of its own needs besides its recordings.

    Parameters
    ----------
    nominal : Kinematics
        The nominal geometry (its kind: :attr:`kind`).
    joints : tuple of str
        The joint names in the kind's roles' order (:attr:`umbmark.kinds.Kind.joints`); none with
        ``odom_topic``.
    joint_topic, scan_topic : str
        Where the joint states and the laser scans are.
    scan_frame : str, optional
        Refuse scans in another frame than this.
    intervals : IntervalOptions
        How the scans and joints become matched intervals.
    fit : tuple of str, optional
        The geometry's parameters to estimate (default: the kind's,
        :meth:`umbmark.kinds.Kind.default_fit`).
    reject_outliers : bool
        Set aside intervals far beyond the rest.
    skip_checks : frozenset of str
        The plausibility checks (:data:`umbmark._check.CHECKS`) that let the recordings through.
    odom_topic : str, optional
        Read the robot's own odometry (``nav_msgs/Odometry``) in place of joint states: a kind
        that reads one (:attr:`umbmark.kinds.Kind.reads_odometry`).

    Raises
    ------
    InputError
        Not one joint per role (or joints and an odometry both), a kind that reads no odometry
        given one, a parameter the kind has not, an unknown check.
    """

    nominal: Kinematics
    joints: tuple[str, ...]
    joint_topic: str = JOINT_TOPIC
    scan_topic: str = SCAN_TOPIC
    scan_frame: str | None = None
    intervals: IntervalOptions = field(default_factory=IntervalOptions)
    fit: tuple[str, ...] | None = None
    reject_outliers: bool = True
    skip_checks: frozenset[str] = frozenset()
    odom_topic: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "skip_checks", frozenset(self.skip_checks))
        if self.odom_topic is None:
            joint_source(self.nominal, self.joints, self.joint_topic)  # one name per role
        elif self.joints:
            raise InputError("give the joints or an odometry (`odom_topic`), not both")
        elif not kind_of(self.nominal).reads_odometry:
            raise InputError(kind_of(self.nominal).odometry_refusal())
        names = self.nominal.parameter_names
        unknown = [n for n in self.fit or () if n not in names]
        if unknown:
            raise InputError(f"`fit`: a {self.kind} has no {unknown[0]!r} (it has {', '.join(names)})")
        bad = sorted(self.skip_checks - set(CHECKS))
        if bad:
            raise InputError(f"`skip_checks`: no check named {bad[0]!r} (checks: {', '.join(CHECKS)})")

    @property
    def kind(self) -> str:
        """The kind's name (:data:`umbmark.kinds.KINDS`)."""
        return kind_of(self.nominal).name


def kinematic_recordings(
    paths: str | Path | Sequence[str | Path],
    settings: KinematicSettings,
    progress: StageProgress | None = None,
) -> KinematicReport:
    """Self-calibrate bags (:func:`umbmark.realrobot.kinematic.kinematic_selfcal_from_bags`), pooled,
    with ``settings`` (its skipped checks skipped, besides those the caller skips already).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The bags.
    settings : KinematicSettings
    progress : callable, optional
        Told each stage's progress.

    Returns
    -------
    KinematicReport

    Raises
    ------
    InputError
        As the self-calibration.
    """
    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    with skipping_checks(settings.skip_checks):
        return kinematic_selfcal_from_bags(
            items,
            settings.nominal,
            settings.joints,
            joint_topic=settings.joint_topic,
            scan_topic=settings.scan_topic,
            scan_frame=settings.scan_frame,
            options=settings.intervals,
            fit=settings.fit,
            reject_outliers=settings.reject_outliers,
            progress=progress,
            odom_topic=settings.odom_topic,
        )
