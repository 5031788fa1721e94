"""From a ROS bag to a lidar self-calibration of a robot of any kind (:mod:`umbmark.kinds`: a tricycle, a
mecanum robot).

The steps of :mod:`umbmark.realrobot.selfcal` with the joints of any kind of robot in place of
two wheels:

1. **The joints on one time grid**: the joint states' stamps and the scans' (less their delay),
   the joints interpolated linearly to it; per step of the grid a rolling joint's increment and
   a steering joint's mean angle (:class:`umbmark.model.kinematics.JointSteps`). The nominal
   odometry integrates them. A kind that reads the robot's own odometry
   (:attr:`umbmark.kinds.Kind.reads_odometry`: a car's ``/odom``) has its joints made from the
   odometry's poses (:meth:`umbmark.kinds.Kind.joints_from_odometry`: the rolling joints
   interpolated as recorded, a steering angle held over each step of the odometry as its
   integration held it). Before anything else, the joint states' motion is set against the
   lidar's between consecutive scans (:mod:`umbmark.realrobot.motion_check`): the other
   readings of the joints that the kind names (:meth:`umbmark.kinds.Kind.readings`: another
   order, a drive and a steering joint exchanged, a steering zero a quarter turn off) are
   tried, and one far closer to the lidar than the joints as given is named; then the units
   and signs.
2. **Every pair of consecutive scans matched** from the nominal odometry seen from the sensor
   at its nominal pose (``/tf_static``, given, or zero); from those matches the scans' delay
   (``auto``: :func:`umbmark.realrobot.selfcal.delay_from_turns`, the nominal odometry's
   heading against the matched turns) and the motion the keyframes are chosen on.
3. **Keyframes** (:class:`umbmark.realrobot.selfcal.KeyframeRule`, by default
   :data:`~umbmark.realrobot.selfcal.DEFAULT_KEYFRAMES`) on the composed matches; each
   interval's two scans matched from them (a pair that fails but whose consecutive scans all
   matched takes those matches composed); its motion is its grid steps composed.
4. :func:`umbmark.correct.selfcal.kinematic.kinematic_selfcal` on the intervals of every bag
   (blocks of time per bag).

:func:`kinematic_bag_intervals` does 1-3 for one bag, :func:`kinematic_selfcal_from_bags`
everything from files into a :class:`KinematicReport` (the JSON of ``umbmark selfcal
--kinematics``).

Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io`, :mod:`umbmark.correct.selfcal` and
:mod:`umbmark.realrobot`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark._files import check_distinct_inputs
from umbmark.correct.selfcal.kinematic import KinematicSelfcalResult, kinematic_residuals, kinematic_selfcal
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag, read_selfcal_bag
from umbmark.io.wheels import WheelSource
from umbmark.kinds import kind_of
from umbmark.model import se2
from umbmark.model.kinematics import (
    JointIntervals,
    JointSteps,
    Kinematics,
    integrate_steps,
    twist_displacement,
)
from umbmark.realrobot.motion_check import LidarMotion, check_readings, check_wheels_against_scans, lidar_motion
from umbmark.realrobot.selfcal import (
    STILL_M,
    IntervalOptions,
    KeyframeRule,
    PairMatches,
    ScanDelay,
    StageProgress,
    StepProgress,
    composed_matches,
    delay_from_turns,
    interval_blocks,
    match_pairs,
    nominal_sensor_pose_of,
    selfcal_history_fields,
    usable_scans,
)
from umbmark.realrobot.selfcal_match import bag_part_json, scan_delay_json

__all__ = [
    "check_joint_readings",
    "JointScanIntervals",
    "KinematicReport",
    "kinematic_bag_intervals",
    "kinematic_selfcal_from_bags",
    "joint_source",
    "scan_odometry",
    "odometry_joints",
    "unfitted_notes",
    "UNFITTED_REL",
]

FloatArray = NDArray[np.float64]


def joint_source(nominal: Kinematics, joints: Sequence[str], topic: str = "/joint_states") -> WheelSource:
    """The :class:`~umbmark.io.wheels.WheelSource` of a robot's joints, in its roles' order.

    Parameters
    ----------
    nominal : Kinematics
        The kind of robot (its :attr:`~umbmark.model.kinematics.Kinematics.joint_roles`).
    joints : sequence of str
        The joint names, one per role.
    topic : str
        The JointState topic.

    Returns
    -------
    WheelSource

    Raises
    ------
    InputError
        Not one name per role.
    """
    roles = nominal.joint_roles
    names = tuple(joints)
    if len(names) != len(roles):
        raise InputError(f"a {nominal.kind} needs {len(roles)} joints ({', '.join(roles)}), got {len(names)}")
    steer = tuple(n for n, rolls in zip(names, nominal.rolling) if not rolls)
    return WheelSource.robot_joints(names, steer, topic)


@dataclass(frozen=True, eq=False)
class _Grid:
    """The joints on the grid of wheel and scan stamps: the steps, each usable scan's grid index,
    the nominal odometry at the scans and the joints' positions there."""

    steps_values: FloatArray
    steps_dt: FloatArray
    scan_index: NDArray[np.intp]
    odometry: FloatArray
    at_scans: FloatArray


def _held(bag: Any) -> bool:
    """Whether the bag's steering joints hold their angle over each step that ends at a stamp (made
    from an odometry) rather than move linearly between the stamps (joint states)."""
    return getattr(bag, "wheel_kind", "joints") == "odom"


def _grid(bag: SelfcalBag, nominal: Kinematics, st: FloatArray, usable: NDArray[np.bool_]) -> _Grid:
    assert bag.joint_positions is not None
    wt, pos = np.asarray(bag.wheel_t_s, float), np.asarray(bag.joint_positions, float)
    return _grid_of(wt, pos, nominal, st, usable, _held(bag))


def _grid_of(
    wt: FloatArray, pos: FloatArray, nominal: Kinematics, st: FloatArray, usable: NDArray[np.bool_], held: bool = False
) -> _Grid:
    """The joints ``pos`` at ``wt`` on the grid of ``wt`` and the usable times ``st`` (steering
    angles ``held`` over each step that ends at a stamp of ``wt``, else linear between them)."""
    g = np.unique(np.concatenate([wt, st[usable]]))
    at = np.column_stack([np.interp(g, wt, pos[:, j]) for j in range(pos.shape[1])])
    vals = np.empty((len(g) - 1, pos.shape[1]))
    ends = np.searchsorted(wt, g[1:], side="left").clip(0, len(wt) - 1)
    for j, rolls in enumerate(nominal.rolling):
        if rolls:
            vals[:, j] = np.diff(at[:, j])
        else:
            vals[:, j] = pos[ends, j] if held else 0.5 * (at[1:, j] + at[:-1, j])
    odo = integrate_steps(twist_displacement(nominal.twist(vals)))
    idx = np.searchsorted(g, st).clip(0, len(g) - 1)
    return _Grid(vals, np.diff(g), idx, odo[idx], at[idx])


def _wheel_odometry(bag: Any, nominal: Kinematics) -> FloatArray:
    """``(W, 3)`` the nominal odometry at the joint states' stamps (of a bag with ``joint_positions``)."""
    assert bag.joint_positions is not None
    pos = np.asarray(bag.joint_positions, dtype=float)
    vals = np.empty((len(pos) - 1, pos.shape[1]))
    for j, rolls in enumerate(nominal.rolling):
        if rolls:
            vals[:, j] = np.diff(pos[:, j])
        else:
            vals[:, j] = pos[1:, j] if _held(bag) else 0.5 * (pos[1:, j] + pos[:-1, j])
    return integrate_steps(twist_displacement(nominal.twist(vals)))


def scan_odometry(bag: SelfcalBag, geometries: Sequence[Kinematics], scan_delay_s: float = 0.0) -> list[FloatArray]:
    """The odometry of each geometry at every scan of a bag of joint states: the joints on the grid
    of the joint and scan stamps (step 1 of the module docstring), integrated from the first.

    Parameters
    ----------
    bag : SelfcalBag
        With joint states in the kind's roles' order.
    geometries : sequence of Kinematics
        Of one kind (the first gives the joints' roles).
    scan_delay_s : float
        How late the scans are stamped [s]: the joints are read at ``stamp - scan_delay_s``.

    Returns
    -------
    list of numpy.ndarray
        Per geometry ``(M, 3)`` poses at the ``M`` scans (a scan beyond the joint data: the pose
        at its end).
    """
    st = np.asarray(bag.scan_t_s, dtype=float) - float(scan_delay_s)
    grid = _grid(bag, geometries[0], st, np.ones(len(st), dtype=bool))
    return [integrate_steps(twist_displacement(g.twist(grid.steps_values)))[grid.scan_index] for g in geometries]


def odometry_joints(bag: SelfcalBag, nominal: Kinematics) -> SelfcalBag:
    """A bag of a robot's own odometry with the joints that odometry turned into its poses
    (:meth:`umbmark.kinds.Kind.joints_from_odometry`, through the nominal geometry).

    Raises
    ------
    InputError
        A bag without odometry poses, a kind that reads none, an odometry the kind refuses.
    """
    if bag.odom_pose is None:
        raise InputError("the bag's wheel data are not an odometry", bag.source)
    kind = kind_of(nominal)
    if not kind.reads_odometry:
        raise InputError(kind.odometry_refusal(), bag.source)
    try:
        pos = kind.joints_from_odometry(nominal, np.asarray(bag.odom_pose, dtype=float))
    except InputError as err:
        raise InputError(f"{bag.wheel_topic}: {err.message}", bag.source) from None
    names = tuple(f"{role} of {bag.wheel_topic}" for role in nominal.joint_roles)
    return replace(bag, joint_positions=pos, joint_names=names)


def _steps_of(grid: _Grid, pairs: NDArray[np.int64]) -> JointSteps:
    a, b = grid.scan_index[pairs[:, 0]], grid.scan_index[pairs[:, 1]]
    counts = b - a
    take = np.repeat(a, counts) + np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    return JointSteps(grid.steps_values[take], np.concatenate([[0], np.cumsum(counts)]), grid.steps_dt[take])


@dataclass(frozen=True, eq=False)
class JointScanIntervals:
    """The matched intervals of one bag of any kind of robot, and how they were made.

    Attributes
    ----------
    intervals : JointIntervals
        The intervals whose scans matched.
    bag : SelfcalBag
    pairs : numpy.ndarray
        ``(K, 2)`` their scan indices.
    scan_delay_s : float
        The scans' delay applied [s].
    scan_delay : ScanDelay or None
        The delay estimated (None when given).
    scan_delay_requested : str
        ``auto`` or the seconds given.
    keyframe_rule : KeyframeRule
    keyframes, scans_usable, intervals_still, pairs_matched, pairs_chained, pairs_failed : int
    failure_reasons : dict
    match_rms_m : float
    nominal_sensor_pose : tuple of float
        ``(x, y, z, roll, pitch, yaw)`` the matching started from.
    sensor_pose_source, base_frame : str
    time_span_s : float
    start_s : numpy.ndarray
        ``(K,)`` the stamps of the intervals' first scans, delay applied [s].
    """

    intervals: JointIntervals
    bag: SelfcalBag
    pairs: NDArray[np.int64]
    scan_delay_s: float
    scan_delay: ScanDelay | None
    scan_delay_requested: str
    keyframe_rule: KeyframeRule
    keyframes: int
    scans_usable: int
    intervals_still: int
    pairs_matched: int
    pairs_chained: int
    pairs_failed: int
    failure_reasons: dict[str, int]
    match_rms_m: float
    nominal_sensor_pose: tuple[float, float, float, float, float, float]
    sensor_pose_source: str
    base_frame: str
    time_span_s: float
    start_s: FloatArray

    def to_dict(self) -> dict[str, Any]:
        """What the pipeline did with the bag, as JSON (the keys of a differential drive's bag part)."""
        return bag_part_json(
            self.bag,
            self.base_frame,
            {
                "scans_usable": self.scans_usable,
                "keyframes": self.keyframes,
                "intervals_still": self.intervals_still,
                "pairs_matched": self.pairs_matched,
                "pairs_chained": self.pairs_chained,
                "pairs_failed": self.pairs_failed,
                "failure_reasons": dict(self.failure_reasons),
                "match_rms_mm": self.match_rms_m * 1e3,
                "time_span_s": self.time_span_s,
            },
            scan_delay_json(self.bag, self.scan_delay_requested, self.scan_delay, self.scan_delay_s),
            self.nominal_sensor_pose,
            self.sensor_pose_source,
        )


def _moving(grid: _Grid, pairs: NDArray[np.int64], nominal: Kinematics) -> NDArray[np.bool_]:
    roll = np.array(nominal.rolling)
    radii = 0.5 * np.asarray(nominal.rolling_diameters_m(), dtype=float)
    d = np.abs(grid.at_scans[pairs[:, 1]][:, roll] - grid.at_scans[pairs[:, 0]][:, roll]) * radii
    return np.asarray(np.any(d > STILL_M, axis=1))


def _match(
    bag: SelfcalBag,
    grid: _Grid,
    pairs: NDArray[np.int64],
    initial: FloatArray,
    opts: IntervalOptions,
    min_intervals: int,
    chained: tuple[NDArray[np.bool_], FloatArray] | None,
    progress: StepProgress | None,
    warnings: list[str],
    still: int,
):
    m = match_pairs(
        bag,
        pairs,
        initial,
        None if chained is None else chained[0],
        None if chained is None else chained[1],
        icp=opts.icp,
        progress=progress,
    )
    notes = m.judge(min_intervals, still, warnings, bag.source)
    ok = m.ok
    st_pairs = pairs[ok]
    cov = 0.5 * (m.covariances[ok] + np.swapaxes(m.covariances[ok], 1, 2))
    steps = _steps_of(grid, st_pairs)
    dt = np.add.reduceat(steps.dt_s, steps.start[:-1]) if steps.dt_s is not None else np.zeros(len(st_pairs))
    iv = JointIntervals(dt, steps, m.poses[ok], bag.source, tuple(notes), cov)
    return iv, m


class _Pipeline:
    """The steps of :func:`kinematic_bag_intervals` on one bag."""

    def __init__(self, bag: SelfcalBag, nominal: Kinematics, opts: IntervalOptions):
        self.bag, self.nominal, self.opts = bag, nominal, opts
        self.wt = np.asarray(bag.wheel_t_s, dtype=float)
        self.period = float(np.median(np.diff(self.wt))) if len(self.wt) > 1 else 0.0
        self.pose, self.pose_src, self.base, self.pose_warn = nominal_sensor_pose_of(
            bag, opts.sensor_pose, opts.base_frame
        )
        self.l0 = np.array([self.pose[0], self.pose[1], self.pose[5]])
        want = opts.scan_delay
        self.first = 0.0 if want == "auto" else float(want)
        self.requested = "auto" if want == "auto" else f"{self.first:g}"
        self.delay = self.first
        self.est: ScanDelay | None = None

    def plan(self, delay: float) -> tuple[FloatArray, NDArray[np.bool_], _Grid, list[str]]:
        """Step 1 with the scans' delay ``delay``: stamps, usable scans, the grid, the warnings."""
        warnings: list[str] = list(self.bag.warnings) + self.pose_warn
        st = np.asarray(self.bag.scan_t_s, dtype=float) - delay
        usable = usable_scans(st, self.wt, self.period, self.opts.max_wheel_gap_s, self.bag.source, warnings)
        return st, usable, _grid(self.bag, self.nominal, st, usable), warnings

    def estimate_delay(self, st: FloatArray, pairs: NDArray[np.int64], m: PairMatches, warnings: list[str]) -> None:
        """Step 2's delay, from the matches of consecutive scans (``auto`` only)."""
        if self.opts.scan_delay != "auto":
            return
        heading = _wheel_odometry(self.bag, self.nominal)[:, 2]
        ok = m.ok
        ta, tb = st[pairs[ok, 0]] + self.first, st[pairs[ok, 1]] + self.first
        try:
            self.est = delay_from_turns(self.wt, heading, ta, tb, m.poses[ok, 2], self.first, source=self.bag.source)
            self.delay = self.est.delay_s
        except InputError as err:
            warnings.append(f"the scans' delay is not estimated ({err.message}): stamps as recorded")

    def done(
        self, iv: JointIntervals, m: PairMatches, pairs: NDArray[np.int64], still: int, st: FloatArray, usable
    ) -> JointScanIntervals:
        idx = np.flatnonzero(usable)
        return JointScanIntervals(
            intervals=iv,
            bag=self.bag,
            pairs=pairs[m.ok],
            scan_delay_s=self.delay,
            scan_delay=self.est,
            scan_delay_requested=self.requested,
            keyframe_rule=self.opts.keyframes,
            keyframes=int(np.unique(pairs).size),
            scans_usable=int(usable.sum()),
            intervals_still=still,
            pairs_matched=int(m.ok.sum()),
            pairs_chained=m.chained,
            pairs_failed=int((~m.ok).sum()),
            failure_reasons=dict(m.reasons.most_common()),
            match_rms_m=float(np.median(m.rms_m[m.ok])) if m.ok.any() else math.nan,
            nominal_sensor_pose=self.pose,
            sensor_pose_source=self.pose_src,
            base_frame=self.base,
            time_span_s=float(st[idx[-1]] - st[idx[0]]),
            start_s=st[pairs[m.ok, 0]],
        )


MAX_STEERING_RAD = math.pi
"""No steering joint turns further than this from straight ahead [rad]: beyond it, degrees."""


def _steering_top(pos: FloatArray, nominal: Kinematics) -> tuple[int, float] | None:
    """The steering joint that turns furthest beyond :data:`MAX_STEERING_RAD` and how far, or None."""
    worst = None
    for j, rolls in enumerate(nominal.rolling):
        if rolls or not pos.size:
            continue
        top = float(np.max(np.abs(pos[:, j])))
        if top > MAX_STEERING_RAD and (worst is None or top > worst[1]):
            worst = (j, top)
    return worst


def _check_steering(bag: SelfcalBag, nominal: Kinematics) -> None:
    """Refuse a steering joint beyond :data:`MAX_STEERING_RAD` (degrees published as radians)."""
    assert bag.joint_positions is not None
    found = _steering_top(np.asarray(bag.joint_positions, dtype=float), nominal)
    if found is None:
        return
    j, top = found
    name = bag.joint_names[j] if j < len(bag.joint_names) else f"joint {j + 1}"
    raise InputError(
        f"the steering joint {name} reaches {top:.4g} rad ({math.degrees(top):.4g} deg): no steering "
        f"turns further than {math.degrees(MAX_STEERING_RAD):g} deg from straight; its positions look "
        f"like degrees ({top:.4g} deg is {math.radians(top):.3g} rad): JointState positions are radians",
        bag.source,
    )


def _check_readings(
    bag: SelfcalBag,
    nominal: Kinematics,
    st: FloatArray,
    usable: NDArray[np.bool_],
    grid: _Grid,
    motion: LidarMotion | None,
) -> None:
    """The kind's other readings of the joints given (:meth:`umbmark.kinds.Kind.readings`) against
    the lidar's motion (:func:`umbmark.realrobot.motion_check.check_readings`); a reading that
    turns a steering joint beyond :data:`MAX_STEERING_RAD` is not one. Joints made from the
    robot's own odometry (:func:`odometry_joints`) are in their roles already: not judged."""
    if motion is None or _held(bag):
        return
    assert bag.joint_positions is not None
    kind = kind_of(nominal)
    pos, wt = np.asarray(bag.joint_positions, dtype=float), np.asarray(bag.wheel_t_s, dtype=float)
    names = tuple(bag.joint_names) or tuple(f"joint {j + 1}" for j in range(pos.shape[1]))
    readings = []
    for r in kind.readings():
        p = r.apply(pos, nominal.rolling)
        if _steering_top(p, nominal) is None:
            readings.append((kind.reading_cause(r, names), _grid_of(wt, p, nominal, st, usable).odometry))
    check_readings(motion, grid.odometry, readings, bag.source)


def _require_joints(bag: SelfcalBag, nominal: Kinematics) -> None:
    if bag.joint_positions is None or bag.joint_positions.shape[1] != len(nominal.joint_roles):
        raise InputError(
            f"the bag's joint data are not a {nominal.kind}'s ({', '.join(nominal.joint_roles)})", bag.source
        )


def check_joint_readings(
    bag: SelfcalBag,
    nominal: Kinematics,
    options: IntervalOptions | None = None,
    *,
    motion: LidarMotion | None = None,
) -> LidarMotion | None:
    """The joints as given against the other readings their kind names, on the lidar's own motion
    between consecutive scans: the first check of :func:`kinematic_bag_intervals`, alone.

    Parameters
    ----------
    bag : SelfcalBag
        With joint states in the kind's roles' order (:func:`joint_source`).
    nominal : Kinematics
        The nominal geometry.
    options : IntervalOptions, optional
        The lidar's nominal pose, the base frame and the wheel gap (the rest unused).
    motion : LidarMotion, optional
        The lidar's motion when it was matched already (the same scans and lidar pose).

    Returns
    -------
    LidarMotion or None
        The lidar's motion (to pass again for another reading of the same bag); None: too few
        scan pairs matched to judge from.

    Raises
    ------
    InputError
        Another reading far closer to the lidar's motion (the check ``joint_order``: its cause and
        the options to give), or beside a lidar upside down (``turn_direction``).
    """
    _require_joints(bag, nominal)
    pipe = _Pipeline(bag, nominal, IntervalOptions() if options is None else options)
    st, usable, grid, _ = pipe.plan(pipe.first)
    seen = lidar_motion(bag, usable, pipe.l0) if motion is None else motion
    _check_readings(bag, nominal, st, usable, grid, seen)
    return seen


def kinematic_bag_intervals(
    bag: SelfcalBag,
    nominal: Kinematics,
    options: IntervalOptions | None = None,
    *,
    progress: StepProgress | None = None,
) -> JointScanIntervals:
    """The matched intervals of a bag of any kind of robot (steps 1-3 of the module docstring).

    Parameters
    ----------
    bag : SelfcalBag
        With joint states (:attr:`~umbmark.io.rosbag.SelfcalBag.joint_positions` in the kind's
        roles' order: :func:`joint_source`).
    nominal : Kinematics
        The nominal geometry.
    options : IntervalOptions, optional
        Keyframes, sensor pose, base frame, wheel gap, matcher, fewest intervals, scans' delay.
    progress : callable, optional
        ``progress(done, total)`` over both passes of matching.

    Returns
    -------
    JointScanIntervals

    Raises
    ------
    InputError
        A bag without the joints, scans and joints that do not overlap, no motion, too few
        matches.
    """
    opts = IntervalOptions() if options is None else options
    src = bag.source
    _require_joints(bag, nominal)
    pipe = _Pipeline(bag, nominal, opts)
    rule = opts.keyframes
    # 1-2: every pair of consecutive scans, matched from the nominal odometry (the joints first
    # read every way the kind names against the lidar's own motion, then their units and signs)
    st, usable, grid, warnings = pipe.plan(pipe.first)
    seen = lidar_motion(bag, usable, pipe.l0)
    _check_readings(bag, nominal, st, usable, grid, seen)
    _check_steering(bag, nominal)
    check_wheels_against_scans(bag, st, usable, grid.odometry, pipe.l0, kind=nominal.kind, motion=seen)
    every = np.array(KeyframeRule().select(st, grid.odometry, usable), dtype=np.int64).reshape(-1, 2)
    moving = _moving(grid, every, nominal)
    if not moving.any():
        raise InputError(
            f"the wheels do not move between the scans ({bag.wheel_description}): nothing to calibrate from; "
            "record while the robot drives",
            src,
        )
    pairs1, still1 = every[moving], int((~moving).sum())
    init1 = se2.compose(
        se2.inverse(pipe.l0),
        se2.compose(se2.between(grid.odometry[pairs1[:, 0]], grid.odometry[pairs1[:, 1]]), pipe.l0),
    )
    n0 = len(pairs1)
    pass1 = None if progress is None else (lambda d, t: progress(d, 2 * n0))  # noqa: E731
    least = 1 if not rule.every_scan else opts.min_intervals
    iv1, m1 = _match(bag, grid, pairs1, init1, opts, least, None, pass1, warnings, still1)
    pipe.estimate_delay(st, pairs1, m1, warnings)
    if rule.every_scan and pipe.delay == pipe.first:
        return pipe.done(iv1, m1, pairs1, still1, st, usable)
    # 3: keyframes on the composed matches, matched from them
    motion, links, link_cov = composed_matches(st, pipe.wt, pairs1, m1.ok, m1.poses, init1, m1.covariances)
    if pipe.delay != pipe.first:
        st, usable, grid, warnings = pipe.plan(pipe.delay)
    pairs = np.array(rule.select(st, motion, usable), dtype=np.int64).reshape(-1, 2)
    moving = _moving(grid, pairs, nominal)
    pairs2 = pairs[moving]
    init2 = se2.between(motion[pairs2[:, 0]], motion[pairs2[:, 1]])
    bad = np.concatenate([[0], np.cumsum(~links)])
    chained = bad[pairs2[:, 1]] - bad[pairs2[:, 0]] == 0
    cum = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(np.nan_to_num(link_cov), axis=0)])
    chain = (chained, cum[pairs2[:, 1]] - cum[pairs2[:, 0]])
    n1 = len(pairs2)
    pass2 = None if progress is None else (lambda d, t: progress(n0 + round(d * n0 / max(n1, 1)), 2 * n0))  # noqa: E731
    still2 = int((~moving).sum())
    iv2, m2 = _match(bag, grid, pairs2, init2, opts, opts.min_intervals, chain, pass2, warnings, still2)
    return pipe.done(iv2, m2, pairs2, still2, st, usable)


@dataclass(frozen=True, eq=False)
class KinematicReport:
    """A self-calibration of a tricycle or mecanum robot from bags, and how its intervals were made.

    Attributes
    ----------
    result : KinematicSelfcalResult
    parts : tuple of JointScanIntervals
    draw : bool
        Its JSON holds the data of the report's figures (:attr:`figures`); a window of a longer
        recording's has none.
    intervals : JointIntervals, optional
        The pooled intervals the estimate was made from (default: the parts', pooled).
    """

    result: KinematicSelfcalResult
    parts: tuple[JointScanIntervals, ...]
    draw: bool = True
    intervals: JointIntervals | None = None

    @cached_property
    def figures(self) -> dict[str, Any]:
        """The data of the report's figures (as a differential drive's,
        :func:`umbmark.realrobot.selfcal_map.selfcal_figures`): each interval's residual over time,
        and a map per bag: its keyframes placed by the joints' odometry with the nominal geometry
        and lidar pose, and with the calibrated ones."""
        from umbmark.realrobot.selfcal_map import encode_map, encode_residuals, map_keys

        r = self.result
        iv = self.intervals or JointIntervals.concatenate([p.intervals for p in self.parts])
        times, maps = [], []
        for p in self.parts:
            scan_t = np.asarray(p.bag.scan_t_s, dtype=float)
            times.append(np.asarray(p.start_s, dtype=float) - scan_t[0])
            keys = map_keys(p.pairs)
            nominal, calibrated = scan_odometry(p.bag, (r.nominal, r.kinematics), p.scan_delay_s)
            bases = tuple(se2.compose(se2.inverse(b[keys[0]]), b[keys]) for b in (nominal, calibrated))
            x, y, _, _, _, yaw = p.nominal_sensor_pose
            maps.append(encode_map(p.bag, keys, (bases[0], bases[1]), ((x, y, yaw), r.sensor_pose)))
        which = np.repeat(np.arange(len(self.parts)), [len(p.intervals) for p in self.parts])
        t = np.concatenate(times) if times else np.zeros(0)
        return {"residuals": encode_residuals(kinematic_residuals(iv, r), r.intervals_rejected, t, which), "maps": maps}

    def to_dict(self) -> dict[str, Any]:
        """The result's JSON (:meth:`KinematicSelfcalResult.to_dict`) with ``joints`` (each role's
        joint name, as the bags' joint states name them: the controller's parameters of an export
        name them; null when read from an odometry), ``inputs`` (each bag's
        :meth:`JointScanIntervals.to_dict`), ``keyframes``, ``scan_delay`` (per bag,
        ``applied_s``) and ``figures`` (:attr:`figures`, what ``umbmark report`` draws; not of a
        window)."""
        out = self.result.to_dict()
        first = self.parts[0].bag if self.parts else None
        roles = self.result.nominal.joint_roles
        named = first is not None and first.wheel_kind == "joints" and len(first.joint_names) == len(roles)
        out["joints"] = dict(zip(roles, first.joint_names)) if named and first is not None else None
        out["inputs"] = [p.to_dict() for p in self.parts]
        out["keyframes"] = self.parts[0].keyframe_rule.to_dict() if self.parts else None
        out["scan_delay"] = [p.to_dict()["scan_delay"] for p in self.parts]
        if self.draw:
            out["figures"] = self.figures
        return out

    def history_fields(self, kind: str = "selfcal", file_hash: Callable[[str], str] | None = None) -> dict[str, Any]:
        """The keyword arguments of :func:`umbmark.history.record_result` for this result, as a
        differential drive's (:meth:`umbmark.realrobot.selfcal.SelfcalReport.history_fields`): its
        ``parameters`` the kind's own (:func:`umbmark.realrobot.selfcal.selfcal_history_fields`)."""
        return selfcal_history_fields(self.to_dict(), kind, file_hash)


def kinematic_selfcal_from_bags(
    paths: Sequence[str | Path],
    nominal: Kinematics,
    joints: Sequence[str],
    *,
    joint_topic: str = "/joint_states",
    scan_topic: str = "/scan",
    scan_frame: str | None = None,
    options: IntervalOptions | None = None,
    fit: Sequence[str] | None = None,
    reject_outliers: bool = True,
    progress: StageProgress | None = None,
    odom_topic: str | None = None,
) -> KinematicReport:
    """Self-calibrate a tricycle or mecanum robot (any kind) from bags: read, match, estimate.

    Parameters
    ----------
    paths : sequence of path
        The bags (distinct).
    nominal : Kinematics
        The nominal geometry.
    joints : sequence of str
        The joint names in the kind's roles' order (a tricycle's drive and steering joints; a
        mecanum robot's front left, front right, rear left and rear right wheels); empty with
        ``odom_topic``.
    joint_topic, scan_topic, scan_frame : str
        Where the joint states and scans are.
    options : IntervalOptions, optional
    fit : sequence of str, optional
        The geometry parameters to estimate (default :func:`kinematic_selfcal`'s).
    reject_outliers : bool
        Set aside intervals far beyond the rest (failed matches).
    progress : callable, optional
        ``progress(stage, done, total)``.
    odom_topic : str, optional
        Read the robot's own odometry (``nav_msgs/Odometry``) in place of joint states: a kind
        that reads one (:attr:`umbmark.kinds.Kind.reads_odometry`, :func:`odometry_joints`).

    Returns
    -------
    KinematicReport

    Raises
    ------
    InputError
        As the reader, :func:`kinematic_bag_intervals` and :func:`kinematic_selfcal`.
    """
    if not paths:
        raise InputError("give at least one bag")
    check_distinct_inputs([str(p) for p in paths])
    if odom_topic is not None:
        if tuple(joints):
            raise InputError("give the joints or an odometry (`odom_topic`), not both")
        if not kind_of(nominal).reads_odometry:
            raise InputError(kind_of(nominal).odometry_refusal())
        source = WheelSource.odometry(odom_topic)
    else:
        source = joint_source(nominal, joints, joint_topic)
    parts = []
    for p in paths:
        read = None if progress is None else (lambda d, t, p=p: progress(f"reading {p}", d, t))
        bag = read_selfcal_bag(
            p, wheels=source, scan_topic=scan_topic, scan_frame=scan_frame, progress=read, two_wheels=False
        )
        if odom_topic is not None:
            bag = odometry_joints(bag, nominal)
        step = None if progress is None else (lambda d, t, p=p: progress(f"matching {p}", d, t))
        parts.append(kinematic_bag_intervals(bag, nominal, options, progress=step))
    ivs = [p.intervals for p in parts]
    blocks = interval_blocks(parts)
    iv = JointIntervals.concatenate(ivs, source=", ".join(str(p) for p in paths))
    result = kinematic_selfcal(iv, nominal, fit=fit, blocks=blocks, reject_outliers=reject_outliers)
    notes = unfitted_notes(iv, nominal, fit, blocks, reject_outliers)
    if notes:
        result = replace(result, warnings=[*result.warnings, *notes])
    return KinematicReport(result, tuple(parts))


UNFITTED_REL = 0.005
"""A parameter held at its nominal value that the data put this far from it (relative, and beyond
its 95 % interval) is named (:func:`unfitted_notes`)."""


def unfitted_notes(
    iv: JointIntervals,
    nominal: Kinematics,
    fit: Sequence[str] | None,
    blocks: Any = None,
    reject_outliers: bool = True,
) -> list[str]:
    """The parameters held at their nominal values that the data say are not: each of the kind's
    fits to check (:attr:`umbmark.kinds.FitOption.check`) not asked for is estimated as well, and
    named when it comes out more than :data:`UNFITTED_REL` from its nominal value and beyond its
    95 % interval (the estimates held it and rest on it)."""
    kind = kind_of(nominal)
    used = set(kind.default_fit() if fit is None else fit)
    values = dict(zip(nominal.parameter_names, nominal.vector()))
    out = []
    for f in kind.fits:
        if not f.check or f.parameter in used:
            continue
        wider = tuple(n for n in nominal.parameter_names if n in used or n == f.parameter)
        try:
            r = kinematic_selfcal(iv, nominal, fit=wider, blocks=blocks, reject_outliers=reject_outliers)
        except InputError:
            continue
        est, ci, v0 = dict(zip(r.parameters, r.estimate))[f.parameter], r.ci95.get(f.parameter), values[f.parameter]
        if ci is None or ci[0] <= v0 <= ci[1] or abs(est - v0) <= UNFITTED_REL * abs(v0):
            continue
        out.append(
            f"held at {v0:g}, `{f.parameter}` comes out {est:.4g} (95 % interval {ci[0]:.4g} to {ci[1]:.4g}) when "
            f"estimated: the estimates above rest on it; run again with `{f.option}`"
        )
    return out
