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

The readers share :mod:`umbmark.io.bag_core` (opening bags, the wheel messages); the lidar's,
the joint ground truth's and the gyro's live in :mod:`umbmark.io.rosbag_lidar`, and their names
are importable from here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from umbmark.errors import InputError
from umbmark.io.bag_core import _open, _read_truth, _wheel_hint, _WheelMessages, is_bag
from umbmark.io.rosbag_lidar import (
    GyroBag,
    JointTruthBag,
    SelfcalBag,
    StaticTransform,
    read_gyro_bag,
    read_joint_truth_bag,
    read_selfcal_bag,
)
from umbmark.io.wheels import WheelSource
from umbmark.model.dataset import Dataset, Run, WheelGeometry, replay_increments, split_at_stops

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
