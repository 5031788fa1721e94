"""Real robots: replay logged runs with any geometry, calibrate, evaluate in sample and held
out, stream long logs (:mod:`~umbmark.realrobot.replay`, its results in
:mod:`~umbmark.realrobot.results`); the return pose from a tape measure
(:mod:`~umbmark.realrobot.measure`); the field procedure (:mod:`~umbmark.realrobot.guide`); 2D scan
registration (:mod:`~umbmark.realrobot.scanmatch`); the lidar self-calibration from a bag
(:mod:`~umbmark.realrobot.selfcal`, the wheel angles of a recording in
:mod:`~umbmark.realrobot.wheels`, its scans placed into a map and its residuals in
:mod:`~umbmark.realrobot.selfcal_map`; of a tricycle or mecanum robot :mod:`~umbmark.realrobot.kinematic`,
and against a ground truth :mod:`~umbmark.realrobot.kinematic_replay`); the lidar as the ground truth of square runs
(:mod:`~umbmark.realrobot.scan_truth`); the gyro as a rotation reference
(:mod:`~umbmark.realrobot.gyro`); a calibration checked on a real log against SLAM relations or
a trajectory (:mod:`~umbmark.realrobot.validate`).
"""

from umbmark.realrobot.guide import STEP_TITLES, guide_text
from umbmark.realrobot.measure import (
    MeasuredRuns,
    Measurement,
    RobotMarks,
    WallPose,
    distances_for_runs,
    format_measured_csv,
    measure,
    measure_runs,
)
from umbmark.realrobot.replay import (
    calibrate,
    detect_directions,
    evaluate,
    history_fields,
    method_names,
    pooled_report,
    prepare,
    replay,
    replay_report,
    square_runs,
    stream_log,
    stream_replay,
)
from umbmark.realrobot.results import (
    Calibrated,
    Evaluation,
    HeldOut,
    MultiReplayReport,
    PooledReport,
    ReplayReport,
    StreamReport,
)
from umbmark.realrobot.scanmatch import (
    ICPConfig,
    ScanMatch,
    ScanMatches,
    match_consecutive,
    match_scan_pairs,
    match_scans,
)
from umbmark.realrobot.selfcal import (
    KeyframeRule,
    ScanIntervals,
    SelfcalReport,
    bag_intervals,
    match_intervals,
    plan_intervals,
    selfcal_from_bags,
    selfcal_from_intervals,
    selfcal_report,
)
from umbmark.realrobot.validate import CheckedCalibration, Validation, read_calibration, validate, validate_log

__all__ = [
    "KeyframeRule",
    "ScanIntervals",
    "SelfcalReport",
    "bag_intervals",
    "match_intervals",
    "plan_intervals",
    "selfcal_from_bags",
    "selfcal_from_intervals",
    "selfcal_report",
    "CheckedCalibration",
    "Validation",
    "read_calibration",
    "validate",
    "validate_log",
    "ICPConfig",
    "ScanMatch",
    "ScanMatches",
    "match_consecutive",
    "match_scan_pairs",
    "match_scans",
    "guide_text",
    "STEP_TITLES",
    "RobotMarks",
    "WallPose",
    "Measurement",
    "MeasuredRuns",
    "measure",
    "measure_runs",
    "distances_for_runs",
    "format_measured_csv",
    "method_names",
    "replay",
    "detect_directions",
    "square_runs",
    "prepare",
    "calibrate",
    "evaluate",
    "replay_report",
    "pooled_report",
    "stream_replay",
    "stream_log",
    "history_fields",
    "Calibrated",
    "Evaluation",
    "HeldOut",
    "ReplayReport",
    "MultiReplayReport",
    "PooledReport",
    "StreamReport",
]
