"""Write a simulated drive as a ROS bag, with the ``rosbags`` package.

The drive: a differential drive's (:class:`umbmark.model.drive.DriveLog`) or any robot's
(:class:`umbmark.model.kinematic_drive.JointDriveLog`).

Imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.model` (the drive log and
:mod:`~umbmark.model.se2`); ``rosbags`` when a bag is written. Storage: a ROS 1 ``.bag`` file,
or a ROS 2 bag folder (``metadata.yaml`` and one ``.db3`` (sqlite3) or ``.mcap`` file).

Topics (header stamps and bag times are the sample times, from ``epoch_s``; a scan's, its
stamp :attr:`umbmark.model.drive.DriveLog.scan_stamps_s`, late or jittered when the drive was
:meth:`~umbmark.model.drive.DriveLog.stamped` so):

* ``/joint_states`` (``sensor_msgs/JointState``) at the wheel rate: a differential drive's joints
  ``left_wheel_joint`` and ``right_wheel_joint``, ``position`` the cumulative wheel angles
  [rad], ``velocity`` the mean wheel speed over the sample that ends there [rad/s]; a
  tricycle's or mecanum robot's (:class:`~umbmark.model.kinematic_drive.JointDriveLog`) its
  joints, the wheels' cumulative angles and the steering joint's angle;
* ``/scan`` (``sensor_msgs/LaserScan``, frame ``laser``) at the scan rate: ``angle_min``,
  ``angle_max``, ``angle_increment``, ``range_min``, ``range_max``, ``scan_time``, the ranges
  as float32 with ``inf`` for no return (``time_increment`` 0: the scans are instantaneous);
* ``/odom`` (``nav_msgs/Odometry``, ``odom`` -> ``base_link``, optional) at the wheel rate:
  the odometry of the nominal geometry, its twist in the robot frame (any robot's integrated
  exactly, or as a car's ``vesc_to_odom`` does: ``odom_scheme``,
  :meth:`umbmark.model.kinematic_drive.JointDriveLog.odometry`);
* ``/tf_static`` (``tf2_msgs/TFMessage``, optional), once at the start: ``base_link`` -> ``laser``, the
  sensor pose (latched in ROS 1, transient-local in ROS 2);
* ``/ground_truth`` (``geometry_msgs/PoseStamped``, frame ``map``, optional) at the wheel rate:
  the true robot pose in the room;
* ``/imu`` (``sensor_msgs/Imu``, frame ``base_link``, optional): the turn rates of a gyro
  (``angular_velocity.z`` [rad/s]; orientation unknown: ``orientation_covariance[0]`` is -1);
* ``/wheel_ticks`` (``geometry_msgs/Vector3Stamped``, optional) at the wheel rate: the wheel
  encoders' running counters, ``vector.x`` left and ``vector.y`` right (whole pulses,
  ``ticks_per_rev`` a revolution).

A bag is written into a temporary name beside its destination and moved there when complete:
a failed write leaves nothing behind, and an existing bag is never overwritten.
"""

from __future__ import annotations

import heapq
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from umbmark.errors import InputError
from umbmark.model.drive import DriveLog
from umbmark.model.kinematic_drive import ODOMETRY_SCHEMES, JointDriveLog

__all__ = [
    "STORAGES",
    "JOINT_NAMES",
    "LASER_FRAME",
    "BASE_FRAME",
    "EPOCH_S",
    "write_drive_bag",
    "storage_of",
]

STORAGES = ("ros1", "sqlite3", "mcap")
JOINT_NAMES = ("left_wheel_joint", "right_wheel_joint")
LASER_FRAME = "laser"
BASE_FRAME = "base_link"
ODOM_FRAME = "odom"
MAP_FRAME = "map"
EPOCH_S = 1.7e9  # a realistic wall-clock start (November 2023)

_T = {
    "joint": ("/joint_states", "sensor_msgs/msg/JointState"),
    "scan": ("/scan", "sensor_msgs/msg/LaserScan"),
    "odom": ("/odom", "nav_msgs/msg/Odometry"),
    "tf_static": ("/tf_static", "tf2_msgs/msg/TFMessage"),
    "truth": ("/ground_truth", "geometry_msgs/msg/PoseStamped"),
    "imu": ("/imu", "sensor_msgs/msg/Imu"),
    "ticks": ("/wheel_ticks", "geometry_msgs/msg/Vector3Stamped"),
}


def storage_of(path: str | os.PathLike[str], storage: str | None = None) -> str:
    """The storage a bag at ``path`` is written in.

    Parameters
    ----------
    path : str or Path
        The bag: a ``.bag`` file (ROS 1) or a ROS 2 bag folder.
    storage : str, optional
        ``"ros1"``, ``"sqlite3"`` or ``"mcap"``; ``None``: ``"ros1"`` for a ``.bag`` name,
        else ``"sqlite3"``.

    Returns
    -------
    str

    Raises
    ------
    InputError
        An unknown storage, or a ROS 1 bag not named ``.bag`` (or a ROS 2 bag named so).
    """
    suffix = Path(path).suffix
    if storage is None:
        return "ros1" if suffix == ".bag" else "sqlite3"
    if storage not in STORAGES:
        raise InputError(f"unknown bag storage {storage!r} (choose from {', '.join(STORAGES)})", str(path))
    if (storage == "ros1") != (suffix == ".bag"):
        want = "a ROS 1 bag is a .bag file" if storage == "ros1" else "a ROS 2 bag is a folder, not a .bag file"
        raise InputError(f"storage {storage!r} does not fit the name: {want}", str(path))
    return storage


def _stamp_ns(epoch_s: float, t_s: np.ndarray) -> np.ndarray:
    """Integer nanoseconds of ``epoch_s + t_s`` (the epoch split first: no rounding at 1e18 ns)."""
    whole = math.floor(epoch_s)
    base = whole * 10**9 + int(round((epoch_s - whole) * 1e9))
    return base + np.round(np.asarray(t_s) * 1e9).astype(np.int64)


def _joint_positions(log: DriveLog | JointDriveLog) -> np.ndarray:
    """``(K, J)`` the joints as published: a differential drive's wheels, or any robot's joints."""
    if isinstance(log, JointDriveLog):
        return np.asarray(log.positions, dtype=float)
    return np.column_stack([log.left_rad, log.right_rad])


def _odom_twist(log: DriveLog | JointDriveLog) -> np.ndarray:
    """``(K, 3)`` the odometry's twist ``(v_x, v_y, omega)`` over the sample that ends at each stamp (0 first)."""
    dt = np.diff(log.t_s)[:, None]
    if isinstance(log, JointDriveLog):
        tw = log.nominal.twist(log.joint_steps().values) / dt
    else:
        g = log.nominal_geometry
        vl = 0.5 * g.diameter_left_m * np.diff(log.left_rad) / dt[:, 0]
        vr = 0.5 * g.diameter_right_m * np.diff(log.right_rad) / dt[:, 0]
        tw = np.column_stack([0.5 * (vl + vr), np.zeros_like(vl), (vr - vl) / g.wheelbase_m])
    return np.vstack([np.zeros((1, 3)), tw])


def _quat(T: Any, yaw: float) -> Any:
    return T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw))


class _Messages:
    """Builds the messages of one drive for one typestore (ROS 1 headers carry a sequence number)."""

    def __init__(
        self,
        log: DriveLog | JointDriveLog,
        ts: Any,
        ros1: bool,
        epoch_s: float,
        joints: tuple[str, ...],
        gyro: tuple[np.ndarray, np.ndarray] | None = None,
        ticks_per_rev: float | None = None,
        odom_scheme: str = "exact",
    ) -> None:
        self.log, self.T, self.ros1, self.joints = log, ts.types, ros1, list(joints)
        self.odom_scheme = odom_scheme
        self.separate_joints = False
        self.positions = _joint_positions(log)
        self.counts = None
        if ticks_per_rev is not None:
            pulse = 2.0 * math.pi / ticks_per_rev
            self.counts = np.floor(self.positions / pulse + 1e-9)
        self.wheel_ns = _stamp_ns(epoch_s, log.t_s)
        self.scan_ns = _stamp_ns(epoch_s, log.scan_stamps_s)
        dt = np.diff(log.t_s)
        self.vel = np.vstack([np.zeros((1, self.positions.shape[1])), np.diff(self.positions, axis=0) / dt[:, None]])
        self._odom: np.ndarray | None = None
        self._twist = np.zeros((0, 3))
        self._seq: dict[str, int] = {}
        self.gyro: tuple[np.ndarray, np.ndarray] | None = gyro
        self.gyro_ns = None if gyro is None else _stamp_ns(epoch_s, gyro[0])

    def header(self, ns: int, frame: str, key: str) -> Any:
        T = self.T
        stamp = T["builtin_interfaces/msg/Time"](sec=int(ns // 10**9), nanosec=int(ns % 10**9))
        if self.ros1:
            seq = self._seq.get(key, 0)
            self._seq[key] = seq + 1
            return T["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id=frame)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def joint(self, k: int) -> Any:
        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(int(self.wheel_ns[k]), "", "joint"),
            name=self.joints,
            position=np.array(self.positions[k]),
            velocity=np.array(self.vel[k]),
            effort=np.array([], dtype=float),
        )

    def ticks(self, k: int) -> Any:
        T = self.T
        assert self.counts is not None
        left, right = self.counts[k]
        return T["geometry_msgs/msg/Vector3Stamped"](
            header=self.header(int(self.wheel_ns[k]), "", "ticks"),
            vector=T["geometry_msgs/msg/Vector3"](x=float(left), y=float(right), z=0.0),
        )

    def scan(self, m: int) -> Any:
        lidar = self.log.lidar
        return self.T["sensor_msgs/msg/LaserScan"](
            header=self.header(int(self.scan_ns[m]), LASER_FRAME, "scan"),
            angle_min=float(lidar.first_angle_rad),
            angle_max=float(lidar.last_angle_rad),
            angle_increment=float(lidar.angle_increment_rad),
            time_increment=0.0,
            scan_time=1.0 / self.log.scan_rate_hz,
            range_min=float(lidar.min_range_m),
            range_max=float(lidar.max_range_m),
            ranges=self.log.ranges_m[m].astype(np.float32),
            intensities=np.array([], dtype=np.float32),
        )

    def odom(self, k: int) -> Any:
        T, log = self.T, self.log
        if self._odom is None:
            self._odom = log.odometry(scheme=self.odom_scheme) if isinstance(log, JointDriveLog) else log.odometry()
            self._twist = _odom_twist(log)
        x, y, yaw = self._odom[k]
        vx, vy, wz = self._twist[k]
        vec = T["geometry_msgs/msg/Vector3"]
        cov = np.zeros(36)
        return T["nav_msgs/msg/Odometry"](
            header=self.header(int(self.wheel_ns[k]), ODOM_FRAME, "odom"),
            child_frame_id=BASE_FRAME,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=self._pose(x, y, yaw), covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=vec(x=float(vx), y=float(vy), z=0.0),
                    angular=vec(x=0.0, y=0.0, z=float(wz)),
                ),
                covariance=cov,
            ),
        )

    def _pose(self, x: float, y: float, yaw: float) -> Any:
        T = self.T
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0), orientation=_quat(T, float(yaw))
        )

    def truth(self, k: int) -> Any:
        x, y, yaw = self.log.true_pose[k]
        return self.T["geometry_msgs/msg/PoseStamped"](
            header=self.header(int(self.wheel_ns[k]), MAP_FRAME, "truth"), pose=self._pose(x, y, yaw)
        )

    def tf_static(self) -> Any:
        T, p = self.T, self.log.sensor_pose
        tr = T["geometry_msgs/msg/TransformStamped"](
            header=self.header(int(self.wheel_ns[0]), BASE_FRAME, "tf_static"),
            child_frame_id=LASER_FRAME,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=float(p.x_m), y=float(p.y_m), z=0.0),
                rotation=_quat(T, float(p.yaw_rad)),
            ),
        )
        return T["tf2_msgs/msg/TFMessage"](transforms=[tr])

    def imu(self, k: int) -> Any:
        T = self.T
        assert self.gyro is not None and self.gyro_ns is not None  # imu messages are made only with a gyro
        t_s, rate = self.gyro
        vec = T["geometry_msgs/msg/Vector3"]
        cov = np.zeros(9)
        return T["sensor_msgs/msg/Imu"](
            header=self.header(int(self.gyro_ns[k]), BASE_FRAME, "imu"),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.array([-1.0] + [0.0] * 8),
            angular_velocity=vec(x=0.0, y=0.0, z=float(rate[k])),
            angular_velocity_covariance=cov,
            linear_acceleration=vec(x=0.0, y=0.0, z=9.81),
            linear_acceleration_covariance=cov,
        )

    def stream(self, odom: bool, truth: bool, tf_static: bool = True):
        """``(ns, key, message factory)`` of every message, in time order (ties: in topic order)."""
        n = len(self.log.t_s)
        wheel = (
            [("joint", self.joint)]
            + ([("odom", self.odom)] if odom else [])
            + ([("truth", self.truth)] if truth else [])
            + ([("ticks", self.ticks)] if self.counts is not None else [])
        )
        streams = [[(int(self.wheel_ns[0]), 0, "tf_static", -1)]] if tf_static else []
        for order, (key, _) in enumerate(wheel, start=1):
            streams.append([(int(self.wheel_ns[k]), order, key, k) for k in range(n)])
        streams.append([(int(self.scan_ns[m]), len(wheel) + 1, "scan", m) for m in range(len(self.log.scan_t_s))])
        make = dict(wheel, scan=self.scan)
        if self.gyro is not None:
            assert self.gyro_ns is not None  # the gyro's stamps
            streams.append([(int(ns), len(wheel) + 2, "imu", k) for k, ns in enumerate(self.gyro_ns)])
            make["imu"] = self.imu
        for ns, _, key, i in heapq.merge(*streams):
            if key == "joint" and self.separate_joints:
                for j in range(len(self.joints)):
                    yield ns, key, self.joint_part(i, j)
                continue
            yield ns, key, (self.tf_static() if key == "tf_static" else make[key](i))

    def joint_part(self, k: int, j: int) -> Any:
        """Sample ``k`` of joint ``j`` alone in a JointState message (a publisher per joint)."""
        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(int(self.wheel_ns[k]), "", "joint"),
            name=[self.joints[j]],
            position=np.array([self.positions[k, j]]),
            velocity=np.array([self.vel[k, j]]),
            effort=np.array([], dtype=float),
        )


def _static_qos() -> list[Any]:
    """The QoS a ROS 2 recorder offers for ``/tf_static`` (transient local, keep last 1)."""
    try:
        from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    except ImportError:  # pragma: no cover - rosbags before QoS profiles were typed
        return []
    never = QosTime(sec=2147483647, nsec=4294967295)
    return [
        Qos(
            history=QosHistory.KEEP_LAST,
            depth=1,
            reliability=QosReliability.RELIABLE,
            durability=QosDurability.TRANSIENT_LOCAL,
            deadline=never,
            lifespan=never,
            liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=never,
            avoid_ros_namespace_conventions=False,
        )
    ]


def _write(
    log: DriveLog | JointDriveLog,
    target: Path,
    storage: str,
    epoch_s: float,
    joints,
    odom: bool,
    truth: bool,
    tf_static: bool = True,
    gyro: tuple[np.ndarray, np.ndarray] | None = None,
    ticks_per_rev: float | None = None,
    separate_joints: bool = False,
    odom_scheme: str = "exact",
) -> None:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ros1 = storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if _T["tf_static"][1] not in ts.types:  # the ROS 1 store has no tf2_msgs: its definition
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", _T["tf_static"][1]))
    msgs = _Messages(log, ts, ros1, epoch_s, joints, gyro, ticks_per_rev, odom_scheme)
    msgs.separate_joints = separate_joints
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        writer: Any = Writer1(target)
        serialize = ts.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Writer2

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(target, version=9, storage_plugin=plugin)
        serialize = ts.serialize_cdr
    with writer:
        conns = {}
        for key in ("tf_static", "joint", "odom", "truth", "ticks", "scan", "imu"):
            if (key == "odom" and not odom) or (key == "truth" and not truth):
                continue
            if key == "ticks" and ticks_per_rev is None:
                continue
            if (key == "tf_static" and not tf_static) or (key == "imu" and gyro is None):
                continue
            topic, mtype = _T[key]
            if key == "tf_static":
                extra = {"latching": 1} if ros1 else {"offered_qos_profiles": _static_qos()}
            else:
                extra = {}
            conns[key] = writer.add_connection(topic, mtype, typestore=ts, **extra)
        for ns, key, msg in msgs.stream(odom, truth, tf_static):
            writer.write(conns[key], ns, serialize(msg, _T[key][1]))


def write_drive_bag(
    log: DriveLog | JointDriveLog,
    path: str | os.PathLike[str],
    *,
    storage: str | None = None,
    odom: bool = True,
    truth: bool = False,
    epoch_s: float = EPOCH_S,
    joints: tuple[str, ...] | None = None,
    tf_static: bool = True,
    gyro: tuple[ArrayLike, ArrayLike] | None = None,
    ticks_per_rev: float | None = None,
    separate_joints: bool = False,
    odom_scheme: str = "exact",
) -> Path:
    """Write ``log`` as a ROS bag (see the module docstring for the topics).

    Parameters
    ----------
    log : DriveLog or JointDriveLog
        The simulated drive (a differential drive's, or any kind of robot's).
    path : str or Path
        The bag to create: a ``.bag`` file for ROS 1, a folder for ROS 2. It must not exist.
    storage : str, optional
        ``"ros1"``, ``"sqlite3"`` or ``"mcap"`` (see :func:`storage_of`).
    odom : bool
        Write ``/odom`` (the nominal geometry's odometry).
    truth : bool
        Write ``/ground_truth`` (the true robot pose in the room).
    epoch_s : float
        The time of the drive's start [s since 1970].
    joints : tuple of str, optional
        The joints' names (default a differential drive's ``left_wheel_joint`` and
        ``right_wheel_joint``; a :class:`~umbmark.model.kinematic_drive.JointDriveLog`'s own
        :attr:`~umbmark.model.kinematic_drive.JointDriveLog.joint_names`).
    tf_static : bool
        Write ``/tf_static`` (the lidar's mounting pose).
    gyro : (array_like, array_like), optional
        Write ``/imu``: the times [s, from the drive's start] and turn rates [rad/s] of a gyro
        (e.g. :meth:`umbmark.model.sensors.Gyro.measure`).
    ticks_per_rev : float, optional
        Write ``/wheel_ticks``: encoder counters of this many pulses per wheel revolution.
    separate_joints : bool
        Publish each joint in a JointState message of its own (as a publisher per joint does).
    odom_scheme : str
        How ``/odom`` integrates a :class:`~umbmark.model.kinematic_drive.JointDriveLog`'s joints:
        ``"exact"`` (as ros2_controllers do) or ``"euler"`` (as a car's ``vesc_to_odom`` does).

    Returns
    -------
    Path
        The bag written.

    Raises
    ------
    InputError
        ``path`` exists, its folder does not, a bad storage or epoch, gyro arrays of different
        lengths or not finite, or the ``rosbags`` package missing.
    """
    if joints is None:
        joints = log.joint_names if isinstance(log, JointDriveLog) else JOINT_NAMES
    if len(joints) != _joint_positions(log).shape[1]:
        raise InputError(f"`joints` must name the drive's {_joint_positions(log).shape[1]} joints, got {joints!r}")
    rates = None
    if gyro is not None:
        g_t, g_w = (np.asarray(a, dtype=float).reshape(-1) for a in gyro)
        if g_t.shape != g_w.shape or not (np.all(np.isfinite(g_t)) and np.all(np.isfinite(g_w))):
            raise InputError("`gyro` must be two finite arrays of one length (times, turn rates)")
        rates = (g_t, g_w)
    if odom_scheme not in ODOMETRY_SCHEMES:
        raise InputError(f"`odom_scheme` must be one of {', '.join(ODOMETRY_SCHEMES)}, got {odom_scheme!r}")
    if ticks_per_rev is not None and not (math.isfinite(ticks_per_rev) and ticks_per_rev > 0):
        raise InputError(f"`ticks_per_rev` must be a positive number, got {ticks_per_rev!r}")
    dest = Path(path)
    fmt = storage_of(dest, storage)
    if not (math.isfinite(epoch_s) and epoch_s >= 0):
        raise InputError(f"`epoch_s` must be a non-negative number of seconds, got {epoch_s!r}")
    if dest.exists() or dest.is_symlink():
        raise InputError("exists already: not overwriting a bag", str(dest))
    parent = dest.parent if str(dest.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write the bag: folder {parent} does not exist", str(dest))
    try:
        import rosbags  # noqa: F401
    except ImportError:  # pragma: no cover
        raise InputError("writing bags needs the 'rosbags' package (pip install rosbags)") from None
    work = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", dir=parent))
    try:
        target = work / dest.name
        _write(
            log, target, fmt, epoch_s, tuple(joints), odom, truth, tf_static, rates, ticks_per_rev, separate_joints,
            odom_scheme,
        )  # fmt: skip
        if dest.exists() or dest.is_symlink():
            raise InputError("appeared while the bag was written: not overwriting it", str(dest))
        os.rename(target, dest)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return dest
