"""Readers and writers: runs files, distances files, encoder logs (optiodom folders, the generic
CSV, ROS bags), the intervals file of a lidar self-calibration, the relations files of the SLAM
benchmark (ground-truth relative poses), trajectories in the TUM format, poses files, parameter exports,
simulated drives written as ROS bags, atomic file writes.

The readers return the data structures of :mod:`umbmark.model` (SI units) and check what they
read with its checks (the wheel data's stamps and values: :func:`umbmark.model.timing.check_wheel_stream`,
once, whatever reads them); the writers take them. Nothing here estimates anything. ``rosbags``
(bags) and ``PyYAML`` (ROS parameter files) are imported when used.
"""

from umbmark.io.atomic import atomic_path, atomic_write, write_json
from umbmark.io.distances_csv import MeasuredRun, format_distances_csv, parse_distances_csv, read_distances_csv
from umbmark.io.export import (
    FORMATS,
    ExportCalibration,
    calibration_from_json,
    format_export,
    ros_multipliers,
    static_transform_command,
    urdf_origin,
    write_export,
)
from umbmark.io.generic_csv import CsvChunk, format_generic_csv, iter_generic_csv, read_generic_csv
from umbmark.io.intervals_csv import format_intervals_csv, parse_intervals_csv, read_intervals_csv, write_intervals_csv
from umbmark.io.load import LOG_FORMATS, LogOptions, TruthSource, detect_format, load_logs, nominal_geometry
from umbmark.io.optiodom import read_optiodom
from umbmark.io.poses_csv import write_poses_csv
from umbmark.io.relations import Relations, format_relations, parse_relations, read_relations, write_relations
from umbmark.io.rosbag import (
    BagInfo,
    GyroBag,
    SelfcalBag,
    StaticTransform,
    bag_info,
    read_bag,
    read_gyro_bag,
    read_selfcal_bag,
)
from umbmark.io.rosbag_write import write_drive_bag
from umbmark.io.runs_csv import format_runs_csv, parse_runs_csv, read_runs_csv, write_runs_csv
from umbmark.io.tum import Trajectory, format_tum, parse_tum, read_tum, write_tum
from umbmark.io.wheels import WheelData, WheelSource

__all__ = [
    "atomic_path",
    "atomic_write",
    "write_json",
    "MeasuredRun",
    "read_distances_csv",
    "parse_distances_csv",
    "format_distances_csv",
    "FORMATS",
    "ExportCalibration",
    "calibration_from_json",
    "format_export",
    "ros_multipliers",
    "write_export",
    "CsvChunk",
    "read_generic_csv",
    "iter_generic_csv",
    "format_generic_csv",
    "read_intervals_csv",
    "parse_intervals_csv",
    "format_intervals_csv",
    "write_intervals_csv",
    "write_drive_bag",
    "LOG_FORMATS",
    "detect_format",
    "load_logs",
    "LogOptions",
    "TruthSource",
    "nominal_geometry",
    "read_optiodom",
    "write_poses_csv",
    "read_bag",
    "bag_info",
    "BagInfo",
    "Relations",
    "read_relations",
    "parse_relations",
    "format_relations",
    "write_relations",
    "read_selfcal_bag",
    "SelfcalBag",
    "read_gyro_bag",
    "GyroBag",
    "WheelSource",
    "WheelData",
    "StaticTransform",
    "urdf_origin",
    "static_transform_command",
    "read_runs_csv",
    "write_runs_csv",
    "parse_runs_csv",
    "format_runs_csv",
    "Trajectory",
    "read_tum",
    "parse_tum",
    "format_tum",
    "write_tum",
]
