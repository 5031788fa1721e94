"""The defaults and the named choices of the options a person sets on the library's settings:
where a recording's data are, when a scan becomes a keyframe, how many intervals a
self-calibration needs, how the replay's least squares weigh and sample its poses, the formats
of logs. One place for each value.

The library's settings types take their defaults and choices from here
(:class:`umbmark.io.wheels.WheelSource`, :class:`umbmark.io.load.LogOptions`,
:class:`umbmark.realrobot.selfcal_settings.SelfcalSettings`,
:class:`umbmark.realrobot.kinematic_settings.KinematicSettings`, :func:`umbmark.correct.lsq.fit_lsq`),
and so do the command line's typed configurations, whose options show them as their defaults.
Pure Python: the command line imports this module when it starts, and no numerical module with it.
"""

from __future__ import annotations

__all__ = [
    "JOINT_TOPIC",
    "SCAN_TOPIC",
    "TICK_MODES",
    "KEYFRAME_DISTANCE_M",
    "KEYFRAME_TURN_DEG",
    "KEYFRAME_MIN_INTERVAL_S",
    "KEYFRAME_MAX_INTERVAL_S",
    "MAX_WHEEL_GAP_S",
    "MIN_INTERVALS",
    "SCAN_DELAY",
    "LOG_FORMATS",
    "STOP_S",
    "LSQ_MODES",
    "LSQ_SCALES",
    "HEADING_WEIGHT_M",
    "POINTS_PER_RUN",
]

# ---------------------------------------------------------------- where a recording's data are
JOINT_TOPIC = "/joint_states"
"""The ``sensor_msgs/JointState`` topic of the wheels' (and joints') positions."""

SCAN_TOPIC = "/scan"
"""The ``sensor_msgs/LaserScan`` topic of the lidar."""

TICK_MODES = ("cumulative", "incremental")
"""How encoder counts are published: a running counter (the default), or the counts since the
last message."""

# ---------------------------------------------------------------- a self-calibration's intervals
KEYFRAME_DISTANCE_M = 0.1
"""The next keyframe after this much travel [m] (nominal odometry)."""

KEYFRAME_TURN_DEG = 10.0
"""... or this much turn [deg]."""

KEYFRAME_MAX_INTERVAL_S = 2.0
"""... or this much time [s]."""

KEYFRAME_MIN_INTERVAL_S = 0.5
"""The least time between keyframes [s]."""

MAX_WHEEL_GAP_S = 0.5
"""A scan inside a longer gap of the wheel data has no wheel data [s]."""

MIN_INTERVALS = 10
"""The fewest matched intervals a self-calibration accepts."""

SCAN_DELAY = "auto"
"""How late the scans are stamped against the wheel data: estimated."""

# ---------------------------------------------------------------- logs and their replay
LOG_FORMATS = ("auto", "optiodom", "csv", "bag")
"""The formats of logs (``auto``: told from the file)."""

STOP_S = 1.0
"""The stillness [s] that ends a run when a recording is cut where the wheels stand still."""

LSQ_MODES = ("auto", "sampled", "end")
"""The least squares along the path compare poses sampled along it, or the end poses (``auto``:
sampled where every run has a ground truth along its path)."""

LSQ_SCALES = ("auto", "fit", "fixed")
"""The least squares fit both wheels' diameters, or their ratio with the mean kept at nominal
(``auto``: fit where the runs fix the scale)."""

HEADING_WEIGHT_M = 0.5
"""Metres of position error worth one radian of heading error in the least squares."""

POINTS_PER_RUN = 100
"""The poses compared per run by the least squares in the sampled mode."""
