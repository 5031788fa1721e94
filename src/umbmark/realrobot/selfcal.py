"""From a ROS bag to a lidar self-calibration: keyframes, scan matching, intervals, the estimate.

The method is that of Censi, Franchi, Marchionni, Oriolo, "Simultaneous calibration of odometry
and sensor parameters for mobile robots" (IEEE T-RO 29(2), 2013), estimated by
:func:`umbmark.correct.selfcal.selfcal`. This module makes its intervals from a recording
(:class:`umbmark.io.rosbag.SelfcalBag`, from :func:`umbmark.io.rosbag.read_selfcal_bag`):

1. **Wheel angles at the scans.** The cumulative wheel angles (JointState positions, or encoder
   counts) are interpolated linearly to the scans' header stamps. From ``nav_msgs/Odometry``
   they are made first: per increment of the odometry, the pose change gives the arc length
   ``ds`` and the heading change ``dth`` of the exact arc, the wheels rolled
   ``ds -/+ b dth / 2`` (``b`` the NOMINAL wheelbase) and turned that travel over the NOMINAL
   radius (:func:`umbmark.realrobot.wheels.recording_wheel_angles`). Joint positions wrapped to
   one turn were unwrapped by the reader. Scans outside the wheel data (by more than half a
   wheel sample), or inside a gap of it longer than ``max_wheel_gap_s``, are not used.
2. **Keyframes** (:class:`KeyframeRule`): the next keyframe once the nominal odometry has moved
   a distance or turned an angle, or a time has passed (by default :data:`DEFAULT_KEYFRAMES`:
   at least 0.5 s apart and 100 mm, 10 deg or 2 s; or every scan). An
   interval joins two consecutive keyframes; those in which neither wheel moved are set aside
   (they say nothing about the geometry).
3. **Scan matching** (:func:`umbmark.realrobot.scanmatch.match_scan_pairs`) of the two scans of
   each interval, starting from the nominal odometry's displacement seen from the sensor at
   its nominal pose ``l0`` (``l0^-1 (+) q (+) l0``). ``l0`` is the ``/tf_static`` chain from
   the base frame to the scan frame when the bag has it, else given, else zero (the matching
   needs a start, the calibration does not). Failed matches are dropped and counted.
4. **The scans' delay** (:func:`estimate_scan_delay`, by default): a scan is stamped when it
   arrives, after its sweep and the transfer, while the wheel data are stamped when read, so
   the scans are often late against the wheels by a fraction of a sweep. The matched turns are
   correlated with the wheels' turns read at ``stamp - d`` for trial delays ``d`` (on a sample
   of the intervals); the best ``d`` is applied and 1-3 run again.
5. :func:`umbmark.correct.selfcal.selfcal` on the intervals of all bags together (blocks of
   time per bag, :func:`interval_blocks`, for the covariance of errors shared within a
   recording).

:func:`plan_intervals` does 1-2, :func:`match_intervals` 3 (:func:`bag_intervals` 1-4),
:func:`selfcal_report` 5 and its report (:class:`SelfcalReport`, the JSON of
``umbmark selfcal``). :func:`selfcal_from_bags` and :func:`selfcal_from_intervals` run
everything from files; they are this module's own, and every name of the parts is importable
from here too:

* :mod:`umbmark.realrobot.selfcal_tf`: the lidar's nominal pose from ``/tf_static``;
* :mod:`umbmark.realrobot.selfcal_delay`: the scans' delay (its search and its parsing);
* :mod:`umbmark.realrobot.selfcal_plan`: keyframes and the planned intervals (steps 1-2);
* :mod:`umbmark.realrobot.selfcal_match`: the matching, the delay's estimate and one bag's
  intervals (steps 3-4);
* :mod:`umbmark.realrobot.selfcal_pool`: the intervals pooled, the estimate and its report
  (step 5);
* :mod:`umbmark.realrobot.selfcal_history`: the fields of its record in the history.

Imports :mod:`umbmark._files` (distinct inputs), :mod:`umbmark.io` (the bag and intervals
readers, when called) and those parts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from umbmark._files import check_distinct_inputs
from umbmark.io.wheels import WheelSource
from umbmark.realrobot.selfcal_delay import (
    MAX_SCAN_DELAY_S,
    SCAN_DELAY_SEARCH_S,
    ScanDelay,
    delay_from_turns,
    parse_scan_delay,
)
from umbmark.realrobot.selfcal_history import selfcal_history_fields
from umbmark.realrobot.selfcal_match import (
    PairMatches,
    ScanIntervals,
    bag_intervals,
    check_bag_motion,
    composed_matches,
    estimate_scan_delay,
    match_intervals,
    match_pairs,
    matched_motion,
)
from umbmark.realrobot.selfcal_plan import (
    DEFAULT_KEYFRAMES,
    DEFAULT_KEYFRAMES_M,
    DEFAULT_KEYFRAMES_MIN_S,
    DEFAULT_KEYFRAMES_RAD,
    DEFAULT_KEYFRAMES_S,
    STILL_M,
    IntervalOptions,
    IntervalPlan,
    KeyframeRule,
    StepProgress,
    plan_intervals,
)
from umbmark.realrobot.selfcal_plan import usable_scans as usable_scans
from umbmark.realrobot.selfcal_pool import MISREAD_COST as MISREAD_COST
from umbmark.realrobot.selfcal_pool import MISREAD_SIZE as MISREAD_SIZE
from umbmark.realrobot.selfcal_pool import POSE_WARN_M, POSE_WARN_RAD, SelfcalReport, interval_blocks, selfcal_report
from umbmark.realrobot.selfcal_pool import SIDEWAYS_RAD as SIDEWAYS_RAD
from umbmark.realrobot.selfcal_tf import BASE_FRAMES, MAX_TILT_RAD, sensor_pose_from_tf
from umbmark.realrobot.selfcal_tf import nominal_sensor_pose_of as nominal_sensor_pose_of

__all__ = [
    "selfcal_history_fields",
    "KeyframeRule",
    "IntervalOptions",
    "DEFAULT_KEYFRAMES",
    "DEFAULT_KEYFRAMES_M",
    "DEFAULT_KEYFRAMES_RAD",
    "DEFAULT_KEYFRAMES_MIN_S",
    "DEFAULT_KEYFRAMES_S",
    "IntervalPlan",
    "ScanIntervals",
    "ScanDelay",
    "estimate_scan_delay",
    "check_bag_motion",
    "delay_from_turns",
    "parse_scan_delay",
    "match_pairs",
    "PairMatches",
    "composed_matches",
    "matched_motion",
    "SelfcalReport",
    "sensor_pose_from_tf",
    "plan_intervals",
    "match_intervals",
    "bag_intervals",
    "interval_blocks",
    "selfcal_report",
    "selfcal_from_bags",
    "StageProgress",
    "selfcal_from_intervals",
    "BASE_FRAMES",
    "STILL_M",
    "MAX_TILT_RAD",
    "POSE_WARN_M",
    "POSE_WARN_RAD",
    "SCAN_DELAY_SEARCH_S",
    "MAX_SCAN_DELAY_S",
]


StageProgress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: a stage of a pipeline (``reading NAME``, ``matching scans of
NAME``, ``self-calibrating``) moved to ``done`` of ``total`` steps (``total`` 0: a stage without
steps has started)."""


def _stage(progress: StageProgress | None, stage: str) -> StepProgress | None:
    return None if progress is None else (lambda done, total: progress(stage, done, total))


def selfcal_from_bags(
    paths: str | Path | Sequence[str | Path],
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    wheels: WheelSource,
    scan_topic: str = "/scan",
    scan_frame: str | None = None,
    options: IntervalOptions | None = None,
    selfcal_options: dict[str, Any] | None = None,
    progress: StageProgress | None = None,
) -> SelfcalReport:
    """Self-calibrate from one or several bags (their intervals pooled): for each bag, read it
    (:func:`umbmark.io.rosbag.read_selfcal_bag`) and make its intervals (:func:`bag_intervals`),
    then estimate from all of them (:func:`selfcal_report`).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The bags.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    wheels : WheelSource
        The bags' wheel data (:mod:`umbmark.io.wheels`).
    scan_topic, scan_frame
        As :func:`umbmark.io.rosbag.read_selfcal_bag`.
    options : IntervalOptions, optional
        How each bag becomes intervals (:func:`bag_intervals`; the delay estimated per bag by
        default).
    selfcal_options : dict, optional
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.
    progress : callable, optional
        Told each stage's progress (:data:`StageProgress`).

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        One recording given twice; as the reader and the steps.
    """
    from umbmark.io.rosbag import read_selfcal_bag

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    check_distinct_inputs([p for p in items if Path(p).exists()])
    parts = []
    for p in items:
        name = Path(p).name
        bag = read_selfcal_bag(
            p, wheels=wheels, scan_topic=scan_topic, scan_frame=scan_frame, progress=_stage(progress, f"reading {name}")
        )
        progress_of = _stage(progress, f"matching scans of {name}")
        parts.append(bag_intervals(bag, wheel_diameter_m, wheelbase_m, options, progress=progress_of))
    if progress is not None:
        progress("self-calibrating", 0, 0)
    return selfcal_report(parts, wheel_diameter_m, wheelbase_m, **(selfcal_options or {}))


def selfcal_from_intervals(
    paths: str | Path | Sequence[str | Path],
    wheel_diameter_m: float,
    wheelbase_m: float,
    **options: Any,
) -> SelfcalReport:
    """Self-calibrate from one or several intervals files (pooled).

    Parameters
    ----------
    paths : str, Path or sequence of them
        Intervals files (:mod:`umbmark.io.intervals_csv`).
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    **options
        Keyword arguments of :func:`umbmark.correct.selfcal.selfcal`.

    Returns
    -------
    SelfcalReport

    Raises
    ------
    InputError
        A bad file, or what :func:`umbmark.correct.selfcal.selfcal` refuses.
    """
    from umbmark.io.intervals_csv import read_intervals_csv

    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    return selfcal_report([(str(p), read_intervals_csv(p)) for p in items], wheel_diameter_m, wheelbase_m, **options)
