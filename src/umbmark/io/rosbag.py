"""ROS 1 and ROS 2 bags (sqlite3 and mcap storage) through the ``rosbags`` package (no ROS
install needed).

Wheels (one of):

* ``sensor_msgs/JointState`` on ``joint_topic`` (default ``/joint_states``): the positions
  [rad] of the joints named ``joints=(left, right)``; log units are radians (2 pi per wheel
  revolution);
* encoder counts: fields ``left_field``/``right_field`` of the messages on ``ticks_topic``
  (attribute paths such as ``left_ticks`` or ``data[0]``), ``cumulative`` (default) or
  ``incremental``; ``units_per_rev`` pulses per wheel revolution.

Ground truth (optional), on ``gt_topic``: ``geometry_msgs/PoseStamped``,
``nav_msgs/Odometry`` (its pose) or ``tf2_msgs/TFMessage`` (``/tf``: the transform whose
``child_frame_id`` is ``gt_frame``, optionally with parent ``gt_parent``). It is linearly
interpolated to the wheel sample times (the heading unwrapped first) and the run is limited
to the time span it covers. Times: message header stamps (the bag's receive time for
messages without a header).

Runs: the whole bag is one run, or it is cut by ``ranges`` (seconds from the first wheel
sample) or at ``stops`` (both wheels still for ``stop_s`` seconds). Each run is brought into
its start frame.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.model.dataset import Dataset, Run, WheelGeometry, split_at_stops

__all__ = ["read_bag", "bag_info", "BagInfo", "TopicInfo", "is_bag"]

_GT_TYPES = ("PoseStamped", "Odometry", "TFMessage", "PoseWithCovarianceStamped")


def is_bag(path) -> bool:
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
        raise InputError(
            f"cannot read as a ROS bag: {' '.join(str(e).split()) or type(e).__name__}", source=str(path)
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
    """

    topic: str
    type: str
    messages: int

    def to_dict(self) -> dict:
        """``topic``, ``type``, ``messages``."""
        return {"topic": self.topic, "type": self.type, "messages": self.messages}


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


def bag_info(path) -> BagInfo:
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
        return BagInfo(
            bag=str(path),
            duration_s=reader.duration * 1e-9 if reader.message_count else 0.0,
            messages=reader.message_count,
            topics=tuple(TopicInfo(name, kind, n) for name, (kind, n) in sorted(counts.items())),
        )
    finally:
        reader.close()


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
        have = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
        raise InputError(f"no topic {topic!r} for the {what} (topics: {have})", source)
    return conns


def _read_joints(reader, joints, joint_topic: str, src: str):
    """Times and positions [rad] of the two wheel joints in JointState messages."""
    left, right = joints
    conns = _topic_conns(reader, joint_topic, src, "wheel joints")
    t, pl, pr = [], [], []
    for c, ns, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, c.msgtype)
        names = list(getattr(msg, "name", []))
        if left in names and right in names:
            pos = msg.position
            t.append(_stamp(msg, ns))
            pl.append(float(pos[names.index(left)]))
            pr.append(float(pos[names.index(right)]))
    if not t:
        raise InputError(f"no JointState message on {joint_topic} names both joints {left!r} and {right!r}", src)
    return t, pl, pr


def _read_ticks(reader, ticks_topic: str, left_field, right_field, src: str):
    """Times and counts of the two wheels' encoders in the messages of ``ticks_topic``."""
    conns = _topic_conns(reader, ticks_topic, src, "encoder ticks")
    t, pl, pr = [], [], []
    for c, ns, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, c.msgtype)
        t.append(_stamp(msg, ns))
        pl.append(_field(msg, left_field, src))
        pr.append(_field(msg, right_field, src))
    return t, pl, pr


def _read_truth(reader, gt_topic: str, gt_frame, gt_parent, src: str) -> list[tuple[float, float, float, float]]:
    """``(time, x, y, yaw)`` of every ground-truth pose on ``gt_topic``."""
    gconns = _topic_conns(reader, gt_topic, src, "ground truth")
    gtype = gconns[0].msgtype.split("/")[-1]
    if gtype not in _GT_TYPES:
        raise InputError(
            f"ground-truth topic {gt_topic} has type {gconns[0].msgtype}; expected PoseStamped, Odometry or TFMessage",
            src,
        )
    if gtype == "TFMessage" and not gt_frame:
        raise InputError("ground truth from /tf needs the tracked frame (`gt_frame`)", src)
    gt = []
    for c, ns, raw in reader.messages(connections=gconns):
        msg = reader.deserialize(raw, c.msgtype)
        if gtype == "TFMessage":
            for tr in msg.transforms:
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
        raise InputError(f"no ground-truth poses on {gt_topic}{frame}", src)
    return gt


def _whole_run(t, pl, pr, cumulative: bool, gt, src: str) -> Run:
    """The bag as one run: wheel samples in time order (repeated times dropped), increments,
    and the ground truth interpolated to the wheel samples (the run limited to its span)."""
    t = np.asarray(t)
    order = np.argsort(t, kind="stable")
    t, pl, pr = t[order], np.asarray(pl)[order], np.asarray(pr)[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, pl, pr = t[keep], pl[keep], pr[keep]
    if len(t) < 2:
        raise InputError("fewer than two wheel samples", src)
    if not (np.all(np.isfinite(pl)) and np.all(np.isfinite(pr))):
        raise InputError("wheel positions/ticks contain NaN or infinite values", src)
    if cumulative:
        dl = np.diff(pl, prepend=pl[0])
        dr = np.diff(pr, prepend=pr[0])
    else:
        dl, dr = pl.copy(), pr.copy()
        dl[0] = dr[0] = 0.0
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
    return Run("bag", t - t[0], dl, dr, gtk, None, src)


def _cut_runs(whole: Run, ranges, stops: bool, stop_s: float, units_per_rev: float, src: str) -> list[Run]:
    """The runs of the bag: cut at time ranges, or at stops, or the whole bag."""
    if ranges:
        runs = []
        for n, (a, b) in enumerate(ranges, 1):
            idx = np.flatnonzero((whole.t >= a) & (whole.t <= b))
            if idx.size < 2:
                raise InputError(f"time range {a:g}-{b:g} s holds fewer than two wheel samples", src)
            runs.append(whole.slice(int(idx[0]), int(idx[-1]) + 1, name=f"range-{n}"))
        return runs
    if stops:
        runs = split_at_stops(whole, units_per_rev, stop_s=stop_s)
        if not runs:
            raise InputError("no motion found to split at stops", src)
        return runs
    return [whole.slice(0, len(whole), name="run-01")]


def read_bag(
    path,
    *,
    nominal: WheelGeometry,
    joints=None,
    joint_topic: str = "/joint_states",
    ticks_topic: str | None = None,
    left_field: str | None = None,
    right_field: str | None = None,
    ticks: str = "cumulative",
    units_per_rev: float | None = None,
    gt_topic: str | None = None,
    gt_frame: str | None = None,
    gt_parent: str | None = None,
    ranges=None,
    stops: bool = False,
    stop_s: float = 1.0,
    side_m: float | None = None,
    name: str | None = None,
) -> Dataset:
    """Read one bag into a data set (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
    nominal : WheelGeometry
        The nominal geometry the robot ran with.
    joints : (str, str), optional
        The left and right wheel joints of ``sensor_msgs/JointState`` messages; or:
    ticks_topic, left_field, right_field : str, optional
        A topic of encoder counts and the fields of the left and right count.
    joint_topic : str
        The JointState topic.
    ticks : str
        ``cumulative`` or ``incremental`` counts.
    units_per_rev : float, optional
        Encoder pulses per wheel revolution (needed with ``ticks_topic``).
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
        The side of the square: the runs are UMBmark squares.
    name : str, optional
        The data set's name (default: the bag's).

    Returns
    -------
    Dataset

    Raises
    ------
    InputError
        Unreadable bags, missing topics, joints or fields, and bad content.
    """
    src = str(path)
    if (joints is None) == (ticks_topic is None):
        raise InputError("give either the wheel joint names (JointState) or a ticks topic with its fields", src)
    if ticks not in ("cumulative", "incremental"):
        raise InputError(f"ticks must be 'cumulative' or 'incremental', got {ticks!r}", src)
    reader = _open(path)
    try:
        if joints is not None:
            t, pl, pr = _read_joints(reader, joints, joint_topic, src)
            cumulative, upr = True, 2.0 * math.pi
        else:
            if not left_field or not right_field:
                raise InputError("a ticks topic needs `left_field` and `right_field`", src)
            if units_per_rev is None:
                raise InputError("encoder ticks need the pulses per wheel revolution", src)
            t, pl, pr = _read_ticks(reader, ticks_topic, left_field, right_field, src)
            cumulative, upr = ticks == "cumulative", float(units_per_rev)
        gt = None if gt_topic is None else _read_truth(reader, gt_topic, gt_frame, gt_parent, src)
    finally:
        reader.close()
    whole = _whole_run(t, pl, pr, cumulative, gt, src)
    runs = _cut_runs(whole, ranges, stops, stop_s, upr, src)
    return Dataset(name or Path(path).stem, nominal, upr, tuple(runs), side_m, src, meta={"format": "bag"})
