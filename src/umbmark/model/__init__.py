"""The model layer: robots, runs, logs, odometry and the simulator, in SI units, without I/O.

Pure numpy (numba, when installed, for the batched simulator's kernel): the lowest layer, it
imports no other layer of umbmark.

* :mod:`~umbmark.model.geometry`: the robot types (:class:`Geometry`, :class:`WheelGeometry`,
  :class:`ErrorParams`, :class:`Calibration`, :class:`OdometryParams`) and :func:`wrap_angle`;
* :mod:`~umbmark.model.runs`: :class:`RunsTable`, the end poses of a bi-directional test;
* :mod:`~umbmark.model.dataset`: logged runs (:class:`Run`, :class:`Dataset`);
* :mod:`~umbmark.model.odometry`: the integrators (:func:`integrate`, :func:`integrate_pulses`,
  streaming :class:`Odometer`);
* :mod:`~umbmark.model.simulate`: the closed-loop simulator and its planner;
* :mod:`~umbmark.model.batch`: the same simulation for many robots at once;
* :mod:`~umbmark.model.drive`: a robot driving a program of commands in a room, with its
  wheel data, lidar scans and gyro (the simulated recordings of the real-robot tools);
* :mod:`~umbmark.model.kinematics`: the one interface of every kind of robot's kinematics (the
  kinds are :mod:`umbmark.kinds`), and the joints' steps of a self-calibration;
* :mod:`~umbmark.model.kinematic_drive`: a robot of any kind (a tricycle, a mecanum robot)
  driving in a room (its joint states, lidar scans and true poses);
* :mod:`~umbmark.model.sensors`: the room, the lidar and the gyro;
* :mod:`~umbmark.model.intervals`: the intervals of a self-calibration;
* :mod:`~umbmark.model.se2`: planar poses (compose, inverse, between);
* :mod:`~umbmark.model.timing`: the stamps of logged streams, their checks and time offsets
  (with :mod:`~umbmark.model.stamps`, :mod:`~umbmark.model.arrival` for streams stamped on
  arrival, and :mod:`~umbmark.model.wheel_stream` for the wheel data's one check).
* :mod:`~umbmark.model.defaults`: the defaults and choices of the options a person sets (topics,
  keyframes, the least squares' weights, log formats), shared by the library's settings and the
  command line's options.

The names below are importable from here (``from umbmark.model import simulate_batch``); each
module is imported when one of its names is first used, so importing a submodule costs only
that submodule.
"""

from __future__ import annotations

from umbmark._lazy import lazy_names

# public name -> module that defines it
_LAZY = {
    **dict.fromkeys(
        (
            "Geometry",
            "WheelGeometry",
            "ErrorParams",
            "Calibration",
            "OdometryParams",
            "LABMATE",
            "FIG11_ERRORS",
            "wrap_angle",
        ),
        "umbmark.model.geometry",
    ),
    **dict.fromkeys(("RunsTable", "DIRECTIONS"), "umbmark.model.runs"),
    **dict.fromkeys(
        (
            "Run",
            "Dataset",
            "to_start_frame",
            "wheel_travel_from_poses",
            "wheel_angles_from_poses",
            "split_at_stops",
            "replay_increments",
            "FAST_MIN_SAMPLES",
        ),
        "umbmark.model.dataset",
    ),
    **dict.fromkeys(
        (
            "INTEGRATORS",
            "KERNELS",
            "integrate",
            "integrate_end",
            "integrate_pulses",
            "integrate_pulses_end",
            "Odometer",
            "replay_stream",
            "StreamResult",
        ),
        "umbmark.model.odometry",
    ),
    **dict.fromkeys(
        (
            "NoiseModel",
            "NOISE_PRESETS",
            "noise_preset",
            "Motion",
            "Segment",
            "square_program",
            "straight_program",
            "spin_program",
            "SegmentPlan",
            "plan_program",
            "run_program",
            "SimResult",
            "simulate_runs",
            "simulate_umbmark",
            "run_seeds",
            "child_seeds",
            "runs_table",
        ),
        "umbmark.model.simulate",
    ),
    **dict.fromkeys(("ENGINES", "run_batch", "simulate_batch"), "umbmark.model.batch"),
    **dict.fromkeys(
        (
            "Command",
            "Program",
            "WheelNoise",
            "SimRobot",
            "EXAMPLE_ROBOT",
            "DriveLog",
            "simulate_drive",
            "integrate_wheels",
            "mixed_program",
            "straight_only",
            "spins_only",
            "one_way_turns",
            "default_start",
            "square_drive",
            "concatenate_drives",
            "skid_steer_robot",
            "simulate_gyro",
        ),
        "umbmark.model.drive",
    ),
    **dict.fromkeys(
        (
            "Kinematics",
            "JointSteps",
            "JointIntervals",
            "joint_intervals_from_motion",
            "twist_displacement",
            "compose_steps",
            "integrate_steps",
        ),
        "umbmark.model.kinematics",
    ),
    **dict.fromkeys(
        (
            "Move",
            "JointNoise",
            "KinematicRobot",
            "JointDriveLog",
            "simulate_kinematic_drive",
            "kinematic_program",
        ),
        "umbmark.model.kinematic_drive",
    ),
    **dict.fromkeys(("Room", "SensorPose", "Lidar", "Gyro", "cast_rays"), "umbmark.model.sensors"),
    **dict.fromkeys(
        ("Intervals", "IntervalSteps", "sensor_motion", "step_motion", "intervals_from_motion"),
        "umbmark.model.intervals",
    ),
    **dict.fromkeys(("Pose", "compose", "inverse", "between"), "umbmark.model.se2"),
    **dict.fromkeys(
        (
            "TimeOffset",
            "estimate_time_offset",
            "parse_time_offset",
            "WheelStream",
            "check_wheel_stream",
            "check_joint_stream",
            "JointStream",
            "StreamCheck",
            "StreamReport",
            "check_streams",
            "check_truth_stream",
            "align_truth",
        ),
        "umbmark.model.timing",
    ),
}

__all__ = list(_LAZY)

__getattr__, __dir__ = lazy_names("umbmark.model", _LAZY, globals())
