"""The streams of a bag beside the wheels: laser scans and ``/tf_static`` for the lidar
self-calibration (:func:`read_selfcal_bag`), a ground truth for joints of any kind
(:func:`read_joint_truth_bag`), a gyro (:func:`read_gyro_bag`). See :mod:`umbmark.io.rosbag`
(which re-exports these names) for the bags and the wheels.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark._check import refusal
from umbmark.errors import InputError
from umbmark.io.bag_core import _open, _read_truth, _stamp, _typed_conns, _WheelMessages
from umbmark.io.wheels import WheelSource
from umbmark.model.dataset import WheelGeometry
from umbmark.model.wheel_stream import StreamReport

__all__ = [
    "read_selfcal_bag",
    "SelfcalBag",
    "StaticTransform",
    "read_gyro_bag",
    "GyroBag",
    "read_joint_truth_bag",
    "JointTruthBag",
    "MAX_MEDIAN_RANGE_M",
]


@dataclass(frozen=True)
class StaticTransform:
    """One transform of ``/tf_static``: the pose of ``child`` in ``parent``.

    Attributes
    ----------
    parent, child : str
        The frames (leading ``/`` removed).
    translation : tuple of float
        ``(x, y, z)`` [m].
    rotation : tuple of float
        The quaternion ``(x, y, z, w)``.
    """

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


@dataclass(frozen=True, eq=False)
class SelfcalBag:
    """The streams of one bag a lidar self-calibration uses, in time order.

    Attributes
    ----------
    source : str
        The bag.
    scan_topic : str
        The LaserScan topic.
    scan_frame : str
        The scans' ``header.frame_id``.
    scan_t_s : numpy.ndarray
        ``(M,)`` header stamps of the scans [s since 1970, or the bag's clock].
    ranges_m : numpy.ndarray
        ``(M, n_beams)`` float32 ranges [m]; ``inf`` where a beam has no valid return.
    angles_rad : numpy.ndarray
        ``(n_beams,)`` beam angles in the scan frame.
    wheel_kind : str
        ``"joints"``, ``"ticks"`` or ``"odom"``.
    wheel_topic : str
        The topic of the wheel data.
    wheel_description : str
        Where the wheel data come from, in words (for reports).
    wheel_t_s : numpy.ndarray
        ``(K,)`` stamps of the wheel data [s].
    left_rad, right_rad : numpy.ndarray or None
        ``(K,)`` cumulative wheel angles [rad] (JointState, encoder counts); None for odometry.
    odom_pose : numpy.ndarray or None
        ``(K, 3)`` odometry poses ``(x_m, y_m, yaw_rad)`` (yaw as recorded, in (-pi, pi]);
        None for wheel angles.
    odom_child_frame : str or None
        The odometry's ``child_frame_id`` (the robot's base frame).
    static_transforms : tuple of StaticTransform
        Every transform on ``/tf_static`` (empty when the bag has none).
    topics : tuple of str
        The bag's topics, for messages.
    warnings : tuple of str
        What the reader dropped or noticed (scans of another beam layout, repeated stamps).
    joint_positions : numpy.ndarray or None
        ``(K, J)`` every joint's position [rad] at ``wheel_t_s`` (joint states; rolling joints
        cumulative, steering joints their angle).
    joint_names : tuple of str
        Their names (empty without joint states).
    wheel_stream : StreamReport or None
        What the check of the wheel data found and did (rate, bursts, messages dropped and why).
    """

    source: str
    scan_topic: str
    scan_frame: str
    scan_t_s: np.ndarray
    ranges_m: np.ndarray
    angles_rad: np.ndarray
    wheel_kind: str
    wheel_topic: str
    wheel_description: str
    wheel_t_s: np.ndarray
    left_rad: np.ndarray | None
    right_rad: np.ndarray | None
    odom_pose: np.ndarray | None
    odom_child_frame: str | None
    static_transforms: tuple[StaticTransform, ...]
    topics: tuple[str, ...]
    warnings: tuple[str, ...] = ()
    joint_positions: np.ndarray | None = None
    joint_names: tuple[str, ...] = ()
    wheel_stream: StreamReport | None = None

    @property
    def n_scans(self) -> int:
        """The number of scans read."""
        return len(self.scan_t_s)


def _same_layout(a: tuple[int, float, float], b: tuple[int, float, float]) -> bool:
    return a[0] == b[0] and abs(a[1] - b[1]) <= 1e-6 and abs(a[2] - b[2]) <= 1e-9


class _Scans:
    """Collects LaserScan messages: one beam layout (the first scan's), ranges made ``inf`` where invalid."""

    def __init__(self, topic: str, scan_frame: str | None, source: str):
        self.topic, self.expected, self.src = topic, scan_frame, source
        self.t: list[float] = []
        self.ranges: list[np.ndarray] = []
        self.layout: tuple[int, float, float] | None = None
        self.frame: str | None = None
        self.other_layout = 0
        self.limits: tuple[float, float] | None = None  # the first kept scan's range_min, range_max
        self.raw_medians: list[float] = []  # each kept scan's median finite range, as published

    def add(self, msg, ns: int) -> None:
        frame = msg.header.frame_id.lstrip("/")
        if self.expected is not None and frame != self.expected.lstrip("/"):
            raise InputError(
                f"the scans on {self.topic} are in frame {frame!r}, not `scan_frame` {self.expected!r}", self.src
            )
        if self.frame is None:
            self.frame = frame
        elif frame != self.frame:
            raise InputError(
                f"the scans on {self.topic} change frame, from {self.frame!r} to {frame!r} at scan "
                f"{len(self.t) + 1}: one lidar per topic",
                self.src,
            )
        r = np.asarray(msg.ranges, dtype=np.float32)
        layout = (r.size, float(msg.angle_min), float(msg.angle_increment))
        if self.layout is None:
            if r.size < 3 or not (math.isfinite(layout[2]) and layout[2] != 0):
                raise InputError(
                    f"the first scan on {self.topic} has {r.size} beams and angle_increment {layout[2]!r}: "
                    "not a usable LaserScan",
                    self.src,
                )
            self.layout = layout
        elif not _same_layout(layout, self.layout):
            self.other_layout += 1
            return
        lo, hi = float(msg.range_min), float(msg.range_max)
        if self.limits is None:
            self.limits = (lo, hi)
        fin = r[np.isfinite(r)]
        if fin.size:
            self.raw_medians.append(float(np.median(fin)))
        with np.errstate(invalid="ignore"):
            # a range at range_max is the driver's "no return" (a far wall would not be at it exactly)
            bad = ~np.isfinite(r) | (r < lo) | (r >= hi)
        if bad.any():
            r = r.copy()
            r[bad] = np.inf
        self.t.append(_stamp(msg, ns))
        self.ranges.append(r)

    def checked(self, topics: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """The scans read: stamps, ranges ``(M, n_beams)`` and warnings (other layouts dropped,
        repeated stamps dropped); an error for stamps that go backwards, fewer than two scans or
        no valid range."""
        warnings: list[str] = []
        if self.other_layout:
            warnings.append(
                f"{self.other_layout} scans on {self.topic} with another beam layout than the first were dropped"
            )
        if len(self.t) < 2:
            raise InputError(f"fewer than two usable scans on {self.topic} (topics: {', '.join(topics)})", self.src)
        st = np.asarray(self.t, dtype=float)
        keep, repeated = _ordered(st, "scans", self.topic, self.src)
        if repeated:
            warnings.append(f"{repeated} scans on {self.topic} repeat the stamp of the scan before: dropped")
        ranges = np.stack(self.ranges)[keep]
        self._check_units(ranges)
        if not np.isfinite(ranges).any():
            raise InputError(
                f"every range of the {len(keep)} scans on {self.topic} is infinite, NaN or outside "
                "[range_min, range_max): the lidar saw nothing",
                self.src,
            )
        return st[keep], ranges, warnings

    def _check_units(self, ranges: np.ndarray) -> None:
        """Refuse ranges in millimetres (or centimetres): a median range beyond
        :data:`MAX_MEDIAN_RANGE_M`, or every range beyond ``range_max`` where a thousandth of it
        would be within ``[range_min, range_max)``."""
        lo, hi = self.limits if self.limits is not None else (0.0, math.inf)
        fin = ranges[np.isfinite(ranges)]
        med = float(np.median(fin)) if fin.size else math.nan
        raw = float(np.median(self.raw_medians)) if self.raw_medians else math.nan
        unit = "millimetres (or centimetres)"
        err = (
            refusal(
                "scan_units",
                f"the ranges on {self.topic} look like {unit}, not metres: their median is {med:.6g} "
                f"(range_max {hi:g}), where a lidar sees the walls around it within tens of metres "
                f"(no 2D lidar's median beyond {MAX_MEDIAN_RANGE_M:g} m); LaserScan ranges are in metres: "
                "publish them in metres",
                self.src,
            )
            if med > MAX_MEDIAN_RANGE_M
            else None
        )
        if err is not None:
            raise err
        if not fin.size and raw >= hi and lo <= raw / 1000.0 < hi:
            raise InputError(
                f"every range on {self.topic} is at or beyond range_max {hi:g}: their median is {raw:.6g}, "
                f"{raw / 1000.0:.3g} if it is millimetres: the ranges look like millimetres, range_max like "
                "metres; LaserScan ranges are in metres: publish them in metres",
                self.src,
            )


MAX_MEDIAN_RANGE_M = 100.0
"""The median range of a lidar's scans beyond which they are refused as millimetres [m]: walls
in view (a self-calibration's, a ground truth's) are within tens of metres."""


def _ordered(t: np.ndarray, what: str, topic: str, source: str) -> tuple[np.ndarray, int]:
    """Refuse stamps that go backwards; the indices of the samples kept (repeated stamps dropped)."""
    d = np.diff(t)
    back = np.flatnonzero(d < 0)
    if back.size:
        i = int(back[0])
        raise InputError(
            f"the stamps of the {what} on {topic} go backwards at message {i + 2}: {t[i + 1]:.6f} s after "
            f"{t[i]:.6f} s ({back.size} times in all): record with one clock, or cut the bag there",
            source,
        )
    keep = np.concatenate([[True], d > 0])
    return np.flatnonzero(keep), int((~keep).sum())


def read_selfcal_bag(
    path: str | Path,
    *,
    wheels: WheelSource,
    scan_topic: str = "/scan",
    scan_frame: str | None = None,
    tf_topic: str = "/tf_static",
    progress: Callable[[int, int], None] | None = None,
    two_wheels: bool = True,
) -> SelfcalBag:
    """Read the scans, the wheel data and the static transforms of a bag for a lidar self-calibration.

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
    wheels : WheelSource
        The wheel data (:mod:`umbmark.io.wheels`).
    scan_topic : str
        The ``sensor_msgs/LaserScan`` topic.
    scan_frame : str, optional
        The frame the scans must be in (default: whatever the first scan says).
    tf_topic : str
        The topic of the static transforms (read when the bag has it).
    progress : callable, optional
        Called as ``progress(messages_read, messages_total)`` while reading.
    two_wheels : bool
        Only a differential drive's two wheels will do (``False``: the joints of any kind of
        robot, :attr:`SelfcalBag.joint_positions`).

    Returns
    -------
    SelfcalBag

    Raises
    ------
    InputError
        An unreadable bag; a missing topic, one of another type or without messages (the
        message lists the bag's topics); not exactly one source of wheel data; missing joints
        or fields; scans in another frame than ``scan_frame`` or changing frame; stamps that go
        backwards; fewer than two scans or wheel samples; no scan with a valid range;
        non-finite wheel data.
    """
    src = str(path)
    if wheels.given:
        wheels.check(src, two_wheels)  # before the bag is opened
    reader = _open(path)
    try:
        topics = tuple(sorted({c.topic for c in reader.connections}))
        scan_conns = _typed_conns(reader, scan_topic, ("LaserScan",), src, "laser scans")
        wheel_msgs = _WheelMessages(reader, wheels, src, two_wheels)
        tf_conns = [c for c in reader.connections if c.topic == tf_topic and c.msgtype.endswith("TFMessage")]
        conns = scan_conns + wheel_msgs.conns + tf_conns
        total = sum(c.msgcount for c in conns)
        scans = _Scans(scan_topic, scan_frame, src)
        tfs: dict[tuple[str, str], StaticTransform] = {}
        scan_ids = {id(c) for c in scan_conns}
        done = 0
        for c, ns, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, c.msgtype)
            if id(c) in scan_ids:
                scans.add(msg, ns)
            elif id(c) in wheel_msgs.ids:
                wheel_msgs.add(msg, ns)
            else:
                for tr in msg.transforms:
                    t, q = tr.transform.translation, tr.transform.rotation
                    parent, child = tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/")
                    tfs[(parent, child)] = StaticTransform(parent, child, (t.x, t.y, t.z), (q.x, q.y, q.z, q.w))
            done += 1
            if progress is not None and (done % 2000 == 0 or done == total):
                progress(done, total)
    finally:
        reader.close()
    st, ranges, warnings = scans.checked(topics)
    wd = wheel_msgs.finish()
    assert scans.layout is not None  # set by the first of the scans checked() kept
    first, inc = scans.layout[1], scans.layout[2]
    k = 2.0 * math.pi / wheels.units_per_wheel_rev  # counts to radians (1 for joint angles)
    return SelfcalBag(
        source=src,
        scan_topic=scan_topic,
        scan_frame=str(scans.frame),
        scan_t_s=st,
        ranges_m=ranges,
        angles_rad=first + inc * np.arange(ranges.shape[1]),
        wheel_kind=wheels.kind,
        wheel_topic=wheels.topic,
        wheel_description=wheels.description,
        wheel_t_s=wd.t_s,
        left_rad=None if wd.left is None else wd.left * k,
        right_rad=None if wd.right is None else wd.right * k,
        odom_pose=wd.odom_pose,
        odom_child_frame=wd.odom_child_frame,
        static_transforms=tuple(tfs.values()),
        topics=topics,
        warnings=tuple(warnings) + wd.warnings,
        joint_positions=wd.joints,
        joint_names=tuple(wheels.joints or ()),
        wheel_stream=wd.stream,
    )


@dataclass(frozen=True, eq=False)
class JointTruthBag:
    """The joint states and a ground truth of one bag (a tricycle or mecanum robot against a tracker).

    Attributes
    ----------
    source : str
        The bag.
    joint_names : tuple of str
        The joints, in the order of the columns.
    wheel_t_s : numpy.ndarray
        ``(K,)`` the joint states' stamps [s].
    joint_positions : numpy.ndarray
        ``(K, J)`` the joints [rad] (rolling joints cumulative, steering joints their angle).
    truth : numpy.ndarray
        ``(M, 4)`` ``(t_s, x_m, y_m, yaw_rad)`` of the tracked point, in stamp order, yaw unwrapped.
    wheel_description, truth_topic : str
        Where they came from.
    warnings : tuple of str
        What the reading found and did.
    """

    source: str
    joint_names: tuple[str, ...]
    wheel_t_s: np.ndarray
    joint_positions: np.ndarray
    truth: np.ndarray
    wheel_description: str
    truth_topic: str
    warnings: tuple[str, ...] = ()


def read_joint_truth_bag(
    path: str | Path,
    *,
    wheels: WheelSource,
    gt_topic: str,
    gt_frame: str | None = None,
    gt_parent: str | None = None,
) -> JointTruthBag:
    """Read the joint states of any kind of robot and a ground truth from a bag.

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
    wheels : WheelSource
        The joints (:meth:`~umbmark.io.wheels.WheelSource.robot_joints`).
    gt_topic : str
        The ground truth (PoseStamped, Odometry or /tf).
    gt_frame, gt_parent : str, optional
        For /tf: the tracked frame and its parent.

    Returns
    -------
    JointTruthBag

    Raises
    ------
    InputError
        An unreadable bag, missing topics or joints, joint data the stream checks refuse, a
        ground truth that is not finite or goes back in time, fewer than two ground-truth poses.
    """
    from umbmark.model.timing import ordered_stamps

    src = str(path)
    wheels.check(src, two_wheels=False)
    if wheels.kind != "joints":
        raise InputError("the joints of a tricycle or mecanum robot come from joint states (JointState)", src)
    reader = _open(path)
    try:
        wd = _WheelMessages(reader, wheels, src, two_wheels=False).read(reader)
        gt = np.asarray(_read_truth(reader, gt_topic, gt_frame, gt_parent, src), dtype=float)
    finally:
        reader.close()
    warnings = list(wd.warnings)
    if not np.all(np.isfinite(gt)):
        raise InputError(f"the ground truth on {gt_topic} is not finite in places", src)
    keep, rep, _, (moved, _) = ordered_stamps(gt[:, 0], "ground-truth poses", gt_topic, src)
    if moved:
        gt = gt[np.argsort(gt[:, 0], kind="stable")]
        keep, rep, _, _ = ordered_stamps(gt[:, 0], "ground-truth poses", gt_topic, src)
        warnings.append(f"{moved} ground-truth poses on {gt_topic} out of stamp order: put in order")
    if rep:
        warnings.append(f"{rep} ground-truth poses on {gt_topic} repeat a stamp: the last of each kept")
    gt = gt[keep]
    if len(gt) < 2:
        raise InputError(f"fewer than two ground-truth poses on {gt_topic}", src)
    gt[:, 3] = np.unwrap(gt[:, 3])
    assert wd.joints is not None
    return JointTruthBag(
        source=src,
        joint_names=tuple(wheels.joints or ()),
        wheel_t_s=wd.t_s,
        joint_positions=wd.joints,
        truth=gt,
        wheel_description=wheels.description,
        truth_topic=gt_topic,
        warnings=tuple(warnings),
    )


# -- gyro ------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GyroBag:
    """The gyro and wheel streams of one bag, in time order (header stamps).

    Attributes
    ----------
    source : str
        The bag.
    imu_topic : str
        The ``sensor_msgs/Imu`` topic.
    imu_frame : str
        Its ``header.frame_id``.
    imu_t_s : numpy.ndarray
        ``(G,)`` stamps of the readings [s].
    rate_z_radps : numpy.ndarray
        ``(G,)`` ``angular_velocity.z`` [rad/s].
    wheel_t_s : numpy.ndarray
        ``(K,)`` stamps of the wheel data [s].
    left_rad, right_rad : numpy.ndarray
        ``(K,)`` cumulative wheel angles [rad] (odometry: through the nominal geometry).
    wheel_description : str
        Where the wheel data come from, in words.
    warnings : tuple of str
        What the reading of the wheel data found and did.
    """

    source: str
    imu_topic: str
    imu_frame: str
    imu_t_s: np.ndarray
    rate_z_radps: np.ndarray
    wheel_t_s: np.ndarray
    left_rad: np.ndarray
    right_rad: np.ndarray
    wheel_description: str
    warnings: tuple[str, ...] = ()


def read_gyro_bag(path: str | Path, *, imu_topic: str, nominal: WheelGeometry, wheels: WheelSource) -> GyroBag:
    """Read the turn rates of an IMU and the wheel data of a bag (for the gyro as a rotation reference).

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
    imu_topic : str
        The ``sensor_msgs/Imu`` topic (its ``angular_velocity.z``).
    nominal : WheelGeometry
        The nominal geometry (turns odometry poses back into wheel angles).
    wheels : WheelSource
        The wheel data (:mod:`umbmark.io.wheels`).

    Returns
    -------
    GyroBag

    Raises
    ------
    InputError
        An unreadable bag; a missing topic or one of another type (the message lists the bag's
        topics); not exactly one wheel source; fewer than two readings or wheel samples; stamps
        that go backwards; values that are not finite.
    """
    src = str(path)
    if wheels.given:
        wheels.check(src)  # before the bag is opened
    reader = _open(path)
    try:
        iconns = _typed_conns(reader, imu_topic, ("Imu",), src, "gyro")
        it, iw, frames = [], [], set()
        for c, ns, raw in reader.messages(connections=iconns):
            msg = reader.deserialize(raw, c.msgtype)
            it.append(_stamp(msg, ns))
            iw.append(float(msg.angular_velocity.z))
            frames.add(msg.header.frame_id.lstrip("/"))
        wd = _WheelMessages(reader, wheels, src).read(reader)
    finally:
        reader.close()
    g_t = np.asarray(it, dtype=float)
    keep, _ = _ordered(g_t, "gyro readings", imu_topic, src)
    g_t, g_w = g_t[keep], np.asarray(iw, dtype=float)[keep]
    if len(g_t) < 2:
        raise InputError(f"fewer than two gyro readings on {imu_topic}", src)
    if not np.all(np.isfinite(g_w)):
        raise InputError(f"the gyro readings on {imu_topic} contain NaN or infinite values", src)
    left, right = wd.angles(nominal)
    return GyroBag(
        source=src,
        imu_topic=imu_topic,
        imu_frame=sorted(frames)[0] if frames else "",
        imu_t_s=g_t,
        rate_z_radps=g_w,
        wheel_t_s=wd.t_s,
        left_rad=left,
        right_rad=right,
        wheel_description=wheels.description,
        warnings=wd.warnings,
    )
