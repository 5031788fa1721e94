"""What every bag reader shares: opening a ROS 1 or ROS 2 bag (``rosbags``), finding topics,
decoding stamps and fields, reading a ground truth, and the wheel messages decoded and checked
once (:class:`_WheelMessages`: :func:`umbmark.model.wheel_stream.check_joint_stream`).

The readers are :mod:`umbmark.io.rosbag` (runs, bag-info) and :mod:`umbmark.io.rosbag_lidar`
(the lidar self-calibration's streams, a ground truth of joints, a gyro).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io.wheels import ONE_WHEEL_SOURCE, WheelData, WheelSource

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
