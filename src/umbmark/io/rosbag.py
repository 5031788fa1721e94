"""ROS 1 and ROS 2 bags (sqlite3 and mcap storage) through the ``rosbags`` package (no ROS
install needed).

Wheels: a :class:`~umbmark.io.wheels.WheelSource` says where they are (the wheel joints of
``sensor_msgs/JointState``, encoder counts in the fields of a topic's messages, or a
``nav_msgs/Odometry``). Every reader here decodes them the same way and checks them once with
:func:`umbmark.model.timing.check_wheel_stream` (stamp order, repeated stamps, values that are
not finite, joint angles wrapped to one turn, spikes, running counters read as counts per
message) into a :class:`~umbmark.io.wheels.WheelData`.

Ground truth (optional, :func:`read_bag`), on ``gt_topic``: ``geometry_msgs/PoseStamped``,
``nav_msgs/Odometry`` (its pose) or ``tf2_msgs/TFMessage`` (``/tf``: the transform whose
``child_frame_id`` is ``gt_frame``, optionally with parent ``gt_parent``), checked against the
wheels with :func:`umbmark.model.timing.check_truth_stream` (and its delay estimated). It is
linearly interpolated to the wheel sample times (the heading unwrapped first) and the run is
limited to the time span it covers. Times: message header stamps (the bag's receive time for
messages without a header).

Runs (:func:`read_bag`): the whole bag is one run, or it is cut by ``ranges`` (seconds from the
first wheel sample) or at ``stops`` (both wheels still for ``stop_s`` seconds). Each run is
brought into its start frame.

Lidar self-calibration (:func:`read_selfcal_bag`): the ``sensor_msgs/LaserScan`` messages of
``scan_topic`` (ranges that are not finite, below ``range_min``, or at or beyond ``range_max``,
many drivers' "no return", become ``inf``), the wheels, and the transforms of ``/tf_static``
(for the lidar's nominal mounting pose). :class:`SelfcalBag` holds the streams as recorded and
checked, in time order; an odometry stays poses (the self-calibration turns it into wheel
travel with the nominal geometry). Gyro (:func:`read_gyro_bag`): an IMU's turn rates beside the
wheels.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark._check import refusal
from umbmark.errors import InputError
from umbmark.io.wheels import ONE_WHEEL_SOURCE, WheelData, WheelSource
from umbmark.model.dataset import Dataset, Run, WheelGeometry, replay_increments, split_at_stops
from umbmark.model.wheel_stream import StreamReport

__all__ = [
    "read_bag",
    "wheel_source_hint",
    "bag_info",
    "BagInfo",
    "TopicInfo",
    "is_bag",
    "read_selfcal_bag",
    "SelfcalBag",
    "StaticTransform",
    "read_gyro_bag",
    "GyroBag",
    "read_joint_truth_bag",
    "JointTruthBag",
]

_GT_TYPES = ("PoseStamped", "Odometry", "TFMessage", "PoseWithCovarianceStamped")


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` is a bag: a ``.bag``, ``.mcap`` or ``.db3`` file, or a folder with a
    ROS 2 ``metadata.yaml``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    p = Path(path)
    if p.is_file():
        return p.suffix in (".bag", ".mcap", ".db3")
    return p.is_dir() and (p / "metadata.yaml").is_file()


def _open(path):
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # pragma: no cover
        raise InputError("reading bags needs the 'rosbags' package (pip install rosbags)") from None
    p = Path(path)
    if not p.exists():
        raise InputError("bag not found", source=str(path))
    # A ROS 2 storage file given directly: open its folder when it has the metadata.
    if p.is_file() and p.suffix in (".db3", ".mcap") and (p.parent / "metadata.yaml").is_file():
        p = p.parent
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as e:  # rosbags raises several error types for unreadable bags
        hint = ""
        if p.is_file() and p.suffix in (".db3", ".mcap"):
            hint = (
                f" (a ROS 2 {p.suffix} file without the metadata.yaml of its bag folder beside it: give the bag "
                "folder as recorded)"
            )
        raise InputError(
            f"cannot read as a ROS bag: {' '.join(str(e).split()) or type(e).__name__}{hint}", source=str(path)
        ) from None
    return reader


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag.

    Attributes
    ----------
    topic : str
        Its name.
    type : str
        The message type (e.g. ``sensor_msgs/msg/JointState``).
    messages : int
        How many messages it holds.
    rate_hz : float or None
        Messages per second over its time span in the bag (None: fewer than two messages).
    joint_names : tuple of str
        ``sensor_msgs/JointState``: the joint names its messages carry (first seen first).
    frame_id : str or None
        Messages with a header (poses, odometry, scans): the ``header.frame_id`` of the first.
    child_frame_id : str or None
        ``nav_msgs/Odometry``: the ``child_frame_id`` of the first message.
    transforms : tuple of (str, str)
        ``tf2_msgs/TFMessage``: the ``(parent, child)`` frames of its transforms.
    """

    topic: str
    type: str
    messages: int
    rate_hz: float | None = None
    joint_names: tuple[str, ...] = ()
    frame_id: str | None = None
    child_frame_id: str | None = None
    transforms: tuple[tuple[str, str], ...] = ()

    def to_dict(self) -> dict:
        """``topic``, ``type``, ``messages``, ``rate_hz``; ``joint_names`` (JointState),
        ``frame_id`` (messages with a header), ``child_frame_id`` (Odometry), ``transforms``
        (TFMessage: ``parent``, ``child``) where the topic has them."""
        d: dict = {"topic": self.topic, "type": self.type, "messages": self.messages, "rate_hz": self.rate_hz}
        kind = self.type.split("/")[-1]
        if kind == "JointState":
            d["joint_names"] = list(self.joint_names)
        if self.frame_id is not None:
            d["frame_id"] = self.frame_id
        if self.child_frame_id is not None:
            d["child_frame_id"] = self.child_frame_id
        if kind == "TFMessage":
            d["transforms"] = [{"parent": p, "child": c} for p, c in self.transforms]
        return d

    def describe(self) -> str:
        """What a topic's messages name, in words (joints, frames), for tables and messages."""
        if self.joint_names:
            return "joints " + ", ".join(self.joint_names)
        if self.transforms:
            return ", ".join(f"{p} -> {c}" for p, c in self.transforms)
        if self.child_frame_id is not None:
            return f"{self.frame_id} -> {self.child_frame_id}"
        if self.frame_id:
            return f"frame {self.frame_id}"
        return ""


@dataclass(frozen=True)
class BagInfo:
    """What a bag holds.

    Attributes
    ----------
    bag : str
        Its path.
    duration_s : float
        From its first to its last message (0 when it is empty).
    messages : int
        Messages in all.
    topics : tuple of TopicInfo
        Its topics, by name.
    """

    bag: str
    duration_s: float
    messages: int
    topics: tuple[TopicInfo, ...]

    def to_dict(self) -> dict:
        """The JSON of ``umbmark bag-info --json``."""
        return {
            "bag": self.bag,
            "duration_s": self.duration_s,
            "messages": self.messages,
            "topics": [t.to_dict() for t in self.topics],
        }


def bag_info(path: str | Path) -> BagInfo:
    """The topics, types, message counts and duration of a bag.

    Parameters
    ----------
    path : str or Path
        The bag.

    Returns
    -------
    BagInfo

    Raises
    ------
    InputError
        Not a readable bag, or the ``rosbags`` package missing.
    """
    reader = _open(path)
    try:
        counts: dict[str, list] = {}
        for c in reader.connections:
            counts.setdefault(c.topic, [c.msgtype, 0])[1] += c.msgcount
        span: dict[str, list] = {}
        seen: dict[str, dict] = {}
        for c, ns, raw in reader.messages():
            sp = span.setdefault(c.topic, [ns, ns])
            sp[0], sp[1] = min(sp[0], ns), max(sp[1], ns)
            info = seen.setdefault(c.topic, {"n": 0, "joints": [], "frame": None, "child": None, "tf": []})
            if info["n"] >= _LOOK_AT or c.msgtype.split("/")[-1] not in _DESCRIBED:
                continue
            info["n"] += 1
            try:
                _describe(reader.deserialize(raw, c.msgtype), info)
            except Exception:  # a message rosbags cannot decode: the topic is listed without details
                info["n"] = _LOOK_AT
        topics = []
        for name, (kind, n) in sorted(counts.items()):
            a, b = span.get(name, (0, 0))
            info = seen.get(name, {})
            topics.append(
                TopicInfo(
                    name,
                    kind,
                    n,
                    rate_hz=(n - 1) / ((b - a) * 1e-9) if n >= 2 and b > a else None,
                    joint_names=tuple(info.get("joints", ())),
                    frame_id=info.get("frame"),
                    child_frame_id=info.get("child"),
                    transforms=tuple(info.get("tf", ())),
                )
            )
        return BagInfo(
            bag=str(path),
            duration_s=reader.duration * 1e-9 if reader.message_count else 0.0,
            messages=reader.message_count,
            topics=tuple(topics),
        )
    finally:
        reader.close()


_LOOK_AT = 100  # messages per topic that bag_info decodes for joint names and frames
_DESCRIBED = ("JointState", "PoseStamped", "PoseWithCovarianceStamped", "Odometry", "TFMessage", "LaserScan", "Imu")


def _describe(msg, info: dict) -> None:
    """Collect the joint names and frames of one message into ``info``."""
    for j in getattr(msg, "name", None) or ():
        if isinstance(j, str) and j not in info["joints"]:
            info["joints"].append(j)
    h = getattr(msg, "header", None)
    if h is not None and info["frame"] is None:
        info["frame"] = h.frame_id.lstrip("/")
    child = getattr(msg, "child_frame_id", None)
    if isinstance(child, str) and info["child"] is None:
        info["child"] = child.lstrip("/")
    for tr in getattr(msg, "transforms", None) or ():
        pair = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
        if pair not in info["tf"] and len(info["tf"]) < 50:
            info["tf"].append(pair)


def _stamp(msg, bag_ns):
    h = getattr(msg, "header", None)
    if h is not None and hasattr(h, "stamp"):
        s = h.stamp
        sec = getattr(s, "sec", None)
        if sec is None:  # ROS 1 time
            sec, ns = s.secs, s.nsecs
        else:
            ns = s.nanosec
        if sec or ns:
            return sec + ns * 1e-9
    return bag_ns * 1e-9


_PATH = re.compile(r"([A-Za-z_]\w*)((?:\[\d+\])*)")


def _field(msg, path: str, source: str):
    obj = msg
    for part in path.split("."):
        m = _PATH.fullmatch(part)
        if not m:
            raise InputError(f"bad field path {path!r} (use names and [index], e.g. data[0] or left.count)", source)
        try:
            obj = getattr(obj, m.group(1))
            for idx in re.findall(r"\[(\d+)\]", m.group(2)):
                obj = obj[int(idx)]
        except (AttributeError, IndexError):
            raise InputError(f"messages have no field {path!r}", source) from None
    try:
        return float(obj)
    except (TypeError, ValueError):
        raise InputError(f"field {path!r} is not a number", source) from None


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _topic_conns(reader, topic, source, what):
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise InputError(f"no topic {topic!r} for the {what} (topics: {_topics_hint(reader)})", source)
    return conns


def _read_truth(reader, gt_topic: str, gt_frame, gt_parent, src: str) -> list[tuple[float, float, float, float]]:
    """``(time, x, y, yaw)`` of every ground-truth pose on ``gt_topic``."""
    gconns = _topic_conns(reader, gt_topic, src, "ground truth")
    gtype = gconns[0].msgtype.split("/")[-1]
    if gtype not in _GT_TYPES:
        raise InputError(
            f"ground-truth topic {gt_topic} has type {gconns[0].msgtype}; expected PoseStamped, Odometry or "
            f"TFMessage (topics: {_topics_hint(reader)})",
            src,
        )
    if gtype == "TFMessage" and not gt_frame:
        raise InputError("ground truth from /tf needs the tracked frame (`gt_frame`)", src)
    gt = []
    pairs: set[tuple[str, str]] = set()
    for c, ns, raw in reader.messages(connections=gconns):
        msg = reader.deserialize(raw, c.msgtype)
        if gtype == "TFMessage":
            for tr in msg.transforms:
                if len(pairs) < 50:
                    pairs.add((tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/")))
                if tr.child_frame_id.lstrip("/") != gt_frame.lstrip("/"):
                    continue
                if gt_parent and tr.header.frame_id.lstrip("/") != gt_parent.lstrip("/"):
                    continue
                p, q = tr.transform.translation, tr.transform.rotation
                gt.append((_stamp(tr, ns), p.x, p.y, _yaw(q)))
        else:
            pose = msg.pose.pose if gtype in ("Odometry", "PoseWithCovarianceStamped") else msg.pose
            gt.append((_stamp(msg, ns), pose.position.x, pose.position.y, _yaw(pose.orientation)))
    if not gt:
        frame = f" for frame {gt_frame!r}" if gt_frame else ""
        have = ""
        if gtype == "TFMessage":
            have = " (transforms there: " + (", ".join(f"{a} -> {b}" for a, b in sorted(pairs)) or "none") + ")"
        raise InputError(f"no ground-truth poses on {gt_topic}{frame}{have}", src)
    return gt


class _WheelMessages:
    """The wheel messages of a bag (a :class:`WheelSource`), decoded as they come and checked once
    (:func:`umbmark.model.timing.check_wheel_stream`) into a :class:`WheelData`.

    Its connections go into the reader's loop beside the others' (scans, transforms, a gyro):
    :meth:`add` takes each of their messages.
    """

    def __init__(self, reader, wheels: WheelSource, source: str, two_wheels: bool = True):
        if not wheels.given:
            raise InputError(
                f"give the wheel data: {ONE_WHEEL_SOURCE}{_wheel_hint(reader)} (topics: {_topics_hint(reader)})",
                source,
            )
        wheels.check(source, two_wheels)
        self.wheels, self.src = wheels, source
        kind = wheels.kind
        if kind == "joints":
            self.conns = _typed_conns(reader, wheels.joint_topic, ("JointState",), source, "wheel joints")
        elif kind == "ticks":
            self.conns = _topic_conns(reader, str(wheels.ticks_topic), source, "encoder ticks")
        else:
            self.conns = _typed_conns(reader, str(wheels.odom_topic), ("Odometry",), source, "wheel odometry")
        self.ids = {id(c) for c in self.conns}
        self.t: list[float] = []
        self.a: list[float] = []
        self.b: list[float] = []
        self.yaw: list[float] = []
        self.rest: list[list[float]] = []  # the joints beyond the first two
        self.names_seen: set[str] = set()
        self.partial: dict[str, list[tuple[float, float]]] = {}  # joint -> (stamp, position), one at a time
        self.joined = ""
        self.no_position = 0
        self.child_frames: set[str] = set()

    def add(self, msg, ns: int) -> None:
        """Take one message of :attr:`conns`."""
        w = self.wheels
        if w.kind == "joints":
            assert w.joints is not None
            names = list(getattr(msg, "name", []))
            if all(j in names for j in w.joints):
                pos = msg.position
                cols = [names.index(j) for j in w.joints]
                if len(pos) <= max(cols):
                    self.no_position += 1
                    return
                self.t.append(_stamp(msg, ns))
                self.a.append(float(pos[cols[0]]))
                self.b.append(float(pos[cols[1]]) if len(cols) > 1 else 0.0)
                self.rest.append([float(pos[c]) for c in cols[2:]])
            else:
                if not w.two_wheels:  # a joint per message, or a few: joined in finish()
                    pos = msg.position
                    for i, n in enumerate(names):
                        if n in w.joints and i < len(pos):
                            self.partial.setdefault(n, []).append((_stamp(msg, ns), float(pos[i])))
                if len(self.names_seen) < 50:
                    self.names_seen.update(names)
        elif w.kind == "ticks":
            self.t.append(_stamp(msg, ns))
            self.a.append(_field(msg, str(w.left_field), self.src))
            self.b.append(_field(msg, str(w.right_field), self.src))
        else:
            p = msg.pose.pose
            self.t.append(_stamp(msg, ns))
            self.a.append(p.position.x)
            self.b.append(p.position.y)
            self.yaw.append(_yaw(p.orientation))
            self.child_frames.add(msg.child_frame_id.lstrip("/"))

    def read(self, reader) -> WheelData:
        """Read the wheel messages alone, then :meth:`finish`."""
        for c, ns, raw in reader.messages(connections=self.conns):
            self.add(reader.deserialize(raw, c.msgtype), ns)
        return self.finish()

    def _join_partial(self) -> None:
        """The joints of separate JointState messages on one time base: the stamps of the first
        joint's messages, the others interpolated linearly (rolling joints unwrapped first)."""
        w = self.wheels
        assert w.joints is not None
        series = {}
        for n, rolls in zip(w.joints, w.rolling):
            pts = sorted(self.partial.get(n, []))
            if len(pts) < 2:
                return
            t, v = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
            series[n] = (t, np.unwrap(v) if rolls else v)
        base = series[w.joints[0]][0]
        inside = np.ones(len(base), dtype=bool)
        for t, _ in series.values():
            inside &= (base >= t[0]) & (base <= t[-1])
        if inside.sum() < 2:
            return
        base = base[inside]
        cols = [np.interp(base, *series[n]) for n in w.joints]
        self.t = base.tolist()
        self.a = cols[0].tolist()
        self.b = cols[1].tolist() if len(cols) > 1 else [0.0] * len(base)
        self.rest = np.column_stack(cols[2:]).tolist() if len(cols) > 2 else [[] for _ in base]
        self.joined = (
            f"the joints come in separate JointState messages on {w.joint_topic}: joined at the stamps of "
            f"{w.joints[0]!r}, the others interpolated"
        )

    def _refuse_empty(self) -> None:
        w, src = self.wheels, self.src
        if not self.t and self.partial:
            self._join_partial()
        if self.t:
            return
        if w.kind == "joints":
            assert w.joints is not None
            named = " and ".join(f"{j!r}" for j in w.joints) if len(w.joints) == 2 else ", ".join(map(repr, w.joints))
            if self.no_position:
                raise InputError(
                    f"the JointState messages on {w.joint_topic} name the joints {named} but carry no positions: "
                    "record the wheel positions, or use the odometry (`odom_topic`)",
                    src,
                )
            every = "both joints" if len(w.joints) == 2 else "every joint of"
            takes = "`joints` takes LEFT,RIGHT" if w.two_wheels else "check the joint names"
            raise InputError(
                f"no JointState message on {w.joint_topic} names {every} {named} "
                f"(joints there: {', '.join(sorted(self.names_seen)) or 'none'}; {takes})",
                src,
            )
        raise InputError(f"no messages on {w.topic} for the wheel data", src)

    def finish(self) -> WheelData:
        """The wheel data read, checked: in stamp order, repeats and spikes dropped (with
        warnings), incremental counts summed, joint angles wrapped to one turn unwrapped.

        Raises
        ------
        InputError
            No message with the wheel data, fewer than two samples kept, or what
            :func:`umbmark.model.timing.check_wheel_stream` refuses.
        """
        from umbmark.model.timing import check_joint_stream

        w, src = self.wheels, self.src
        self._refuse_empty()
        odom = w.kind == "odom"
        n_joints = len(w.joints) if w.joints is not None else 2
        pos = np.column_stack([self.a, self.b] + ([np.asarray(self.rest, dtype=float)] if n_joints > 2 else []))
        rolling = w.rolling if w.joints is not None else (True, True)
        chk = check_joint_stream(
            self.t,
            pos[:, :n_joints],
            rolling,
            # a joint turns 2 pi per revolution: its rim goes 30 m/s at 3000 rad/s on a 2 cm wheel
            metres_per_unit=1.0 if odom else 0.01 * 2.0 * math.pi / w.units_per_wheel_rev,
            cumulative=w.cumulative,
            wrapped_turn=2.0 * math.pi if w.kind == "joints" else None,
            poses=odom,
            heading=np.asarray(self.yaw, dtype=float) if odom else None,
            what=w.what,
            topic=w.topic,
            source=src,
        )
        warnings = list(chk.warnings)
        if self.no_position:
            warnings.append(f"{self.no_position} JointState messages on {w.topic} without positions: dropped")
        if self.joined:
            warnings.append(self.joined)
        if chk.t.size < 2:
            raise InputError(f"fewer than two {w.what} on {w.topic}", src)
        p = chk.positions
        if not odom:
            joints = p if w.kind == "joints" else None
            if not w.two_wheels:
                return WheelData(w, chk.t, None, None, warnings=tuple(warnings), joints=joints, stream=chk.report)
            return WheelData(w, chk.t, p[:, 0], p[:, 1], warnings=tuple(warnings), joints=joints, stream=chk.report)
        pose = np.column_stack([p[:, 0], p[:, 1], np.asarray(self.yaw, dtype=float)[chk.kept]])
        if not np.all(np.isfinite(pose)):
            raise InputError(f"the odometry poses on {w.topic} contain NaN or infinite values", src)
        child = sorted(self.child_frames)[0] if len(self.child_frames) == 1 else None
        return WheelData(w, chk.t, None, None, pose, child, tuple(warnings), stream=chk.report)


def _wheel_hint(reader) -> str:
    """The wheel sources a bag offers, for the message that asks for one."""
    kinds: dict[str, list[str]] = {}
    for c in reader.connections:
        kinds.setdefault(c.msgtype.split("/")[-1], []).append(c.topic)
    hints = []
    if "Odometry" in kinds:
        hints.append(f"its nav_msgs/Odometry (`odom_topic`, e.g. `odom_topic={sorted(kinds['Odometry'])[0]}`)")
    if "JointState" in kinds:
        hints.append(f"the wheel joints of its JointState topic {sorted(kinds['JointState'])[0]} (`joints`)")
    return (": this bag offers " + " or ".join(hints)) if hints else ""


def wheel_source_hint(path: str | Path) -> str:
    """The wheel sources a bag offers (its Odometry and JointState topics), as the end of a
    message that asks for one; empty when it offers none or cannot be read.

    Parameters
    ----------
    path : str or Path
        The bag.

    Returns
    -------
    str
    """
    try:
        reader = _open(path)
    except InputError:
        return ""
    try:
        return _wheel_hint(reader)
    finally:
        reader.close()


def _whole_run(t, pl, pr, gt, src: str) -> Run:
    """The bag as one run: the checked wheel samples (cumulative, in time order) as increments,
    and the ground truth interpolated to the wheel samples (the run limited to its span)."""
    t, pl, pr = np.asarray(t, dtype=float), np.asarray(pl, dtype=float), np.asarray(pr, dtype=float)
    dl = np.diff(pl, prepend=pl[0])
    dr = np.diff(pr, prepend=pr[0])
    gtk = None
    if gt is not None:
        g = np.asarray(sorted(gt), dtype=float)
        g = g[np.concatenate([[True], np.diff(g[:, 0]) > 0])]
        th = np.unwrap(g[:, 3])
        inside = (t >= g[0, 0]) & (t <= g[-1, 0])
        if inside.sum() < 2:
            raise InputError("the ground truth does not overlap the wheel samples in time", src)
        a, b = np.flatnonzero(inside)[[0, -1]]
        t, dl, dr = t[a : b + 1], dl[a : b + 1].copy(), dr[a : b + 1].copy()
        dl[0] = dr[0] = 0.0
        gtk = np.column_stack(
            [np.interp(t, g[:, 0], g[:, 1]), np.interp(t, g[:, 0], g[:, 2]), np.interp(t, g[:, 0], th)]
        )
        _truth_at_rest(t, dl, dr, g[:, 0], np.column_stack([g[:, 1], g[:, 2], th]), gtk)
    return Run("bag", t - t[0], dl, dr, gtk, None, src, float(t[0]))


def _truth_at_rest(t, dl, dr, tg, poses, gtk) -> None:
    """Where the wheels stand still from sample i to sample j, the robot is at rest from t[i]
    to t[j]: the ground truth at i (at j) becomes its first (last) measurement in that time,
    in place of the interpolation across the start (end) of the stop, which blends in a pose
    measured while moving when the ground truth is sampled more slowly than the wheels. (A
    robot carried during a pause is measured before and after it is carried.)"""
    still = np.concatenate([[False], (dl[1:] == 0) & (dr[1:] == 0), [False]])
    edges = np.flatnonzero(np.diff(still.astype(np.int8)))
    first_inc, last_inc = edges[0::2] + 1, edges[1::2]  # still increments first_inc..last_inc
    i, j = first_inc - 1, last_inc
    lo = np.searchsorted(tg, t[i], side="left")
    hi = np.searchsorted(tg, t[j], side="right") - 1
    ok = lo <= hi
    gtk[i[ok]] = poses[lo[ok]]
    gtk[j[ok]] = poses[hi[ok]]


def _turn_deg(run: Run, nominal: WheelGeometry, units_per_wheel_rev: float) -> float:
    """The total turn of a run's nominal odometry [deg]."""
    th = replay_increments(run.d_left, run.d_right, nominal.params(units_per_wheel_rev), end=True)[2]
    return math.degrees(float(np.reshape(th, -1)[0]))


def _one_square(turn_deg: float) -> bool:
    return abs(abs(turn_deg) - 360.0) <= 45.0


def _square_runs(
    whole: Run, nominal: WheelGeometry, units_per_wheel_rev: float, stop_s: float, src: str, warnings: list
):
    """The runs of a square bag cut neither by time ranges nor at stops: the whole bag when it
    turns about one revolution, else the pieces between its stops when each of them does."""
    turn = _turn_deg(whole, nominal, units_per_wheel_rev)
    if _one_square(turn):
        return [whole.slice(0, len(whole), name="run-01")]
    pieces = split_at_stops(whole, units_per_wheel_rev, stop_s=stop_s)
    turns = [_turn_deg(p, nominal, units_per_wheel_rev) for p in pieces]
    if len(pieces) >= 2 and all(_one_square(t) for t in turns):
        n_cw = sum(t < 0 for t in turns)
        warnings.append(
            f"{src}: the odometry turns {turn:.0f} deg over the whole bag, not about +-360 deg as on one "
            f"UMBmark square: split where both wheels stand still for {stop_s:g} s into {len(pieces)} runs "
            f"({n_cw} cw, {len(pieces) - n_cw} ccw); give `split_stops` to split it so without this warning"
        )
        return pieces
    found = ", ".join(f"{t:.0f}" for t in turns) or "none"
    raise InputError(
        f"the odometry turns {turn:.0f} deg over the whole bag, not about +-360 deg as on one UMBmark square, "
        f"and the pauses of at least {stop_s:g} s do not cut it into squares (turns of the pieces [deg]: {found}): "
        "cut the runs with `ranges` (START-END seconds from the first wheel sample), or with `split_stops` "
        "and a `stop_s` shorter than the pauses between runs and longer than the stops inside a run",
        src,
    )


def _cut_runs(
    whole: Run,
    ranges: Sequence[tuple[float, float]] | None,
    stops: bool,
    stop_s: float,
    units_per_wheel_rev: float,
    src: str,
    square: tuple[WheelGeometry, list] | None = None,
) -> list[Run]:
    """The runs of the bag: cut at time ranges, or at stops, or the whole bag (for squares,
    ``square=(nominal, warnings)``: split at stops when the whole bag is not one square)."""
    if ranges:
        runs = []
        for n, (a, b) in enumerate(ranges, 1):
            idx = np.flatnonzero((whole.t >= a) & (whole.t <= b))
            if idx.size < 2:
                raise InputError(f"time range {a:g}-{b:g} s holds fewer than two wheel samples", src)
            runs.append(whole.slice(int(idx[0]), int(idx[-1]) + 1, name=f"range-{n}"))
        return runs
    if stops:
        runs = split_at_stops(whole, units_per_wheel_rev, stop_s=stop_s)
        if not runs:
            raise InputError("no motion found to split at stops", src)
        return runs
    if square is not None:
        return _square_runs(whole, square[0], units_per_wheel_rev, stop_s, src, square[1])
    return [whole.slice(0, len(whole), name="run-01")]


def read_bag(
    path: str | Path,
    *,
    nominal: WheelGeometry,
    wheels: WheelSource,
    gt_topic: str | None = None,
    gt_frame: str | None = None,
    gt_parent: str | None = None,
    ranges: Sequence[tuple[float, float]] | None = None,
    stops: bool = False,
    stop_s: float = 1.0,
    side_m: float | None = None,
    name: str | None = None,
    time_offset: float | str | None = None,
) -> Dataset:
    """Read one bag into a data set (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
    nominal : WheelGeometry
        The nominal geometry the robot ran with.
    wheels : WheelSource
        The wheel data (:mod:`umbmark.io.wheels`): joint states and odometries in radians (an
        odometry's pose increments turned back into wheel angles through the nominal geometry,
        so that the replay with it is the recorded odometry), encoder counts in pulses.
    gt_topic : str, optional
        The ground-truth topic (PoseStamped, Odometry or /tf).
    gt_frame, gt_parent : str, optional
        For /tf: the tracked child frame and (optionally) its parent.
    ranges : list of (float, float), optional
        Cut runs at these times (seconds from the first wheel sample).
    stops : bool
        Cut runs where both wheels stand still for ``stop_s`` seconds.
    stop_s : float
        The stillness that ends a run.
    side_m : float, optional
        The side of the square: the runs are UMBmark squares. Without ``ranges`` and
        ``stops``, a bag whose nominal odometry does not turn about one revolution is split at
        its stops when every piece does (with a warning in ``meta["warnings"]``), else refused
        with what to give.
    name : str, optional
        The data set's name (default: the bag's).
    time_offset : None, "auto" or float
        The ground truth's delay against the wheels [s]: None estimates and reports it (a
        warning when it is large), ``"auto"`` also subtracts the estimate from the ground
        truth's stamps, a number subtracts that (:func:`umbmark.model.timing.check_streams`).

    Returns
    -------
    Dataset

    Raises
    ------
    InputError
        Unreadable bags, missing topics, joints or fields, and bad content.
    """
    src = str(path)
    if wheels.given:
        wheels.check(src)  # before the bag is opened
    reader = _open(path)
    try:
        wd = _WheelMessages(reader, wheels, src).read(reader)
        gt = None if gt_topic is None else _read_truth(reader, gt_topic, gt_frame, gt_parent, src)
    finally:
        reader.close()
    from umbmark.model.timing import WheelStream, check_truth_stream

    upr = wheels.units_per_wheel_rev
    left, right = wd.positions(nominal)
    chk = check_truth_stream(
        WheelStream(wd.t_s, left, right, wd.warnings),
        None if gt is None else np.asarray(gt, dtype=float),
        metres_per_unit_left=math.pi * nominal.diameter_left_m / upr,
        metres_per_unit_right=math.pi * nominal.diameter_right_m / upr,
        wheelbase_m=nominal.wheelbase_m,
        time_offset=time_offset,
        wheel_topic=wheels.topic,
        truth_topic=str(gt_topic),
        source=src,
    )
    gt = None if chk.truth is None else [tuple(row) for row in chk.truth.tolist()]
    whole = _whole_run(chk.t, chk.left, chk.right, gt, src)
    warnings: list[str] = [f"{src}: {w}" for w in wd.warnings + chk.warnings]
    square = None if side_m is None else (nominal, warnings)
    runs = _cut_runs(whole, ranges, stops, stop_s, upr, src, square)
    meta: dict[str, object] = {"format": "bag", "warnings": tuple(warnings)}
    if chk.time_offset is not None:
        meta["time_offset"] = ({"bag": src, **chk.time_offset.to_dict()},)
    if wd.stream is not None:
        meta["wheel_stream"] = ({"bag": src, **wd.stream.to_dict()},)
    return Dataset(name or Path(path).stem, nominal, upr, tuple(runs), side_m, src, meta=meta)


# -- lidar self-calibration ------------------------------------------------------------------------


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


def _topics_hint(reader) -> str:
    have = ", ".join(f"{t} ({k.split('/')[-1]})" for t, k in sorted({(c.topic, c.msgtype) for c in reader.connections}))
    return have or "none"


def _typed_conns(reader, topic: str, types: tuple[str, ...], source: str, what: str):
    """The connections of ``topic``; an error listing the bag's topics when it is missing or of another type."""
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise InputError(f"no topic {topic!r} for the {what} (topics: {_topics_hint(reader)})", source)
    kinds = {c.msgtype.split("/")[-1] for c in conns}
    if not kinds <= set(types):
        raise InputError(
            f"topic {topic} has type {conns[0].msgtype}, not {' or '.join(types)} for the {what} "
            f"(topics: {_topics_hint(reader)})",
            source,
        )
    if not sum(c.msgcount for c in conns):
        raise InputError(f"topic {topic} holds no messages for the {what} (topics: {_topics_hint(reader)})", source)
    return conns


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
