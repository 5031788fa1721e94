"""Simulated bags for tests/test_bag_shapes.py and the documentation's examples
(tests/test_readme.py): the closed-loop simulator of tests/simlogs.py drives UMBmark squares; the
bags hold /joint_states and the robot's own /odom (nav_msgs/Odometry, one continuous odom frame)
at the wheel samples, and a motion capture /mocap/pose (PoseStamped, frame world, a rotated world
frame) at its own rate, not aligned with the wheels. Written with rosbags (ROS 2 sqlite3)."""

import math
from pathlib import Path

import numpy as np
import simlogs
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from umbmark.metrics import umbmark_figures
from umbmark.model.dataset import WheelGeometry, replay_increments
from umbmark.model.geometry import ErrorParams, Geometry, wrap_angle
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import square_program

DT = 0.02  # wheels and odometry at 50 Hz
SIDE_M = 2.0
D, B = simlogs.GEOM.wheel_diameter_m, simlogs.GEOM.wheelbase_m
NOMINAL = WheelGeometry(D, D, B)
GEOMETRY = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--side-mm", "2000"]
T0 = 1_760_000_000.0
YAW = 0.7  # the world frame of the motion capture, rotated against the start of the first run
TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
JOINTS = ["left_wheel_joint", "right_wheel_joint"]
NO_SCALE = ErrorParams(ed=simlogs.TRUE.ed, eb=simlogs.TRUE.eb)


def _compose(base, rel):
    """Poses ``rel`` (K, 3) in the frame of pose ``base``."""
    c, s = math.cos(base[2]), math.sin(base[2])
    return np.column_stack(
        [base[0] + c * rel[:, 0] - s * rel[:, 1], base[1] + s * rel[:, 0] + c * rel[:, 1], base[2] + rel[:, 2]]
    )


def _odometry(al, ar, geom=simlogs.GEOM):
    """The nominal geometry's odometry (what diff_drive_controller publishes) of wheel rotations [rad]."""
    nominal = WheelGeometry(geom.wheel_diameter_m, geom.wheel_diameter_m, geom.wheelbase_m)
    x, y, th = replay_increments(al, ar, nominal.params(2 * math.pi))
    return np.column_stack([x, y, th])


def session(
    directions, pause_s=3.0, carry=True, origin=(1.5, -0.8, YAW), errors=simlogs.TRUE, geom=simlogs.GEOM, turns=4
):
    """A session of UMBmark squares: wheel samples (times, cumulative angles), the true poses in the
    world frame and the robot's odometry (one continuous odom frame) at every wheel sample, with
    ``pause_s`` of standstill before, between and after the runs; during a pause the robot is
    carried back near its start mark (``carry``), which its odometry does not see.

    Returns the arrays and, per run, the true return error's inputs: (direction, true end pose in
    the start frame, odometry end pose in the start frame). ``turns`` below 4: runs that stop
    short of the last turns."""
    still = int(round(pause_s / DT))
    origin = np.asarray(origin, dtype=float)
    al_all, ar_all, world = [np.zeros(1)], [np.zeros(1)], [origin[None]]
    truth = []
    rng = np.random.default_rng(3)
    for d in directions:
        al, ar, pose = simlogs.simulate_wheels(square_program(d, SIDE_M, turns), errors, geom, dt=DT)
        here = world[-1][-1]
        start = origin + rng.normal(0, [0.05, 0.05, 0.05]) if carry else here
        half = still // 2
        world += [np.repeat(here[None], half, 0), np.repeat(start[None], still - half, 0)]
        al_all += [np.zeros(still)]
        ar_all += [np.zeros(still)]
        world.append(_compose(start, pose[1:]))
        al_all.append(al[1:])
        ar_all.append(ar[1:])
        odo = _odometry(al, ar, geom)[-1]
        truth.append((d, pose[-1], odo))
    world.append(np.repeat(world[-1][-1:], still, 0))
    al_all.append(np.zeros(still))
    ar_all.append(np.zeros(still))
    inc_l, inc_r = np.concatenate(al_all), np.concatenate(ar_all)
    t = np.arange(len(inc_l)) * DT
    odom = _compose(np.array([3.0, 4.0, -1.0]), _odometry(inc_l, inc_r, geom))  # the odom frame's own origin
    return t, np.cumsum(inc_l), np.cumsum(inc_r), np.concatenate(world), odom, truth


def true_emax(truth):
    """E_max,syst of the simulated runs: true end pose against the odometry's, in the start frame."""
    d = [r[0] for r in truth]
    tr = np.array([r[1] for r in truth])
    od = np.array([r[2] for r in truth])
    runs = RunsTable.from_columns(d, tr[:, 0], tr[:, 1], od[:, 0], od[:, 1], wrap_angle(tr[:, 2]), wrap_angle(od[:, 2]))
    return umbmark_figures(runs).emax_syst


def _header(t, frame):
    sec = int(t)
    stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))
    return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)


def _pose(x, y, th):
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
    )


def _interp_poses(t_new, t, poses):
    th = np.unwrap(poses[:, 2])
    return np.column_stack(
        [np.interp(t_new, t, poses[:, 0]), np.interp(t_new, t, poses[:, 1]), np.interp(t_new, t, th)]
    )


def write_bag(
    path,
    t,
    pl,
    pr,
    world,
    odom,
    *,
    mocap_hz=30.0,
    mocap_delay_s=0.013,
    joints=True,
    odometry=True,
    positions=None,
    mocap_topic="/mocap/pose",
    noise=None,
    late_s=0.0,
):
    """A ROS 2 sqlite3 bag: /joint_states and /odom at the wheel samples, /mocap/pose
    (PoseStamped, frame world) at ``mocap_hz`` from ``mocap_delay_s`` after the first wheel
    sample (not aligned with the wheels). ``positions(k, pos)`` may damage JointState message k;
    ``noise=(position_m, heading_rad, seed)``: Gaussian motion-capture noise; ``late_s``: the
    motion capture's stamps that much after the poses' true times (a late ground truth)."""
    msgs = []
    for k in range(len(t)):
        tk = T0 + t[k]
        ns = int(round(tk * 1e9))
        if joints:
            pos = np.array([pl[k], pr[k]])
            if positions is not None:
                pos = positions(k, pos)
            js = T["sensor_msgs/msg/JointState"](
                header=_header(tk, ""),
                name=JOINTS,
                position=pos,
                velocity=np.array([], float),
                effort=np.array([], float),
            )
            msgs.append((ns, "/joint_states", "sensor_msgs/msg/JointState", js))
        if odometry:
            cov = np.zeros(36)
            zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            od = T["nav_msgs/msg/Odometry"](
                header=_header(tk, "odom"),
                child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(*odom[k]), covariance=cov),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=cov
                ),
            )
            msgs.append((ns, "/odom", "nav_msgs/msg/Odometry", od))
    tm = np.arange(t[0] + mocap_delay_s, t[-1], 1.0 / mocap_hz)
    mocap = _interp_poses(tm, t, world)
    if noise is not None:
        rng = np.random.default_rng(noise[2])
        mocap = mocap + rng.normal(0.0, [noise[0], noise[0], noise[1]], mocap.shape)
    for tt, p in zip(tm, mocap):
        ps = T["geometry_msgs/msg/PoseStamped"](header=_header(T0 + tt + late_s, "world"), pose=_pose(*p))
        msgs.append((int(round((T0 + tt + late_s) * 1e9)), mocap_topic, "geometry_msgs/msg/PoseStamped", ps))
    msgs.sort(key=lambda m: m[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {}
        for ns, topic, kind, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, kind, typestore=TS)
            w.write(conns[topic], ns, TS.serialize_cdr(msg, kind))
    return path


# -- the documentation's example: one bag per run, odometry and motion capture -----------------------

# The robot of docs/ros.md (nominal wheel_radius 0.05 m, wheel_separation 0.30 m; true wheels 99.3
# and 99.7 mm, true wheelbase 306 mm), six runs (cw, ccw, ...), one ROS 2 bag each in odom_runs/:
# /joint_states and /odom at 50 Hz, /mocap/robot/pose at 120 Hz with 0.5 mm and 0.1 deg noise.
DOC_GEOM = Geometry(wheel_diameter_m=0.100, wheelbase_m=0.300, pulses_per_motor_rev=1000.0, gear_ratio=1.0)
DOC_TRUE = ErrorParams(ed=0.0997 / 0.0993, eb=0.306 / 0.300, es=(0.0993 + 0.0997) / 2 / 0.100)


def write_odom_run_bags(folder) -> list[Path]:
    """The six one-run bags of the documentation in ``folder``/odom_runs/run1 ... run6."""
    out = Path(folder) / "odom_runs"
    out.mkdir()
    bags, odom_start = [], np.array([0.0, 0.0, 0.0])
    for i, direction in enumerate(["cw", "ccw"] * 3):
        t, pl, pr, world, _, _ = session(
            [direction], pause_s=1.0, carry=False, origin=(1.5, -0.8, 0.6), errors=DOC_TRUE, geom=DOC_GEOM
        )
        odom = _compose(odom_start, _odometry(np.diff(pl, prepend=pl[0]), np.diff(pr, prepend=pr[0]), DOC_GEOM))
        odom_start = odom[-1]
        bags.append(
            write_bag(
                out / f"run{i + 1}",
                t,
                pl,
                pr,
                world,
                odom,
                mocap_hz=120.0,
                mocap_delay_s=0.003,
                mocap_topic="/mocap/robot/pose",
                noise=(5e-4, math.radians(0.1), 20 + i),
            )
        )
    return bags
