"""The matching of a recording's intervals (steps 3-4 of :mod:`umbmark.realrobot.selfcal`): the
scans of planned pairs matched (:func:`match_pairs`, :class:`PairMatches`), a plan's intervals
matched (:func:`match_intervals`, :class:`ScanIntervals`), the scans' delay estimated from the
matches (:func:`estimate_scan_delay`), the nominal odometry checked against the lidar's own motion
(:func:`check_bag_motion`), matches of consecutive scans composed into a motion
(:func:`matched_motion`, :func:`composed_matches`) and the whole of it for one bag
(:func:`bag_intervals`).

Part of the self-calibration from a bag (:mod:`umbmark.realrobot.selfcal`, which re-exports these
names). Imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io.rosbag` (the bag's type),
:mod:`umbmark.kinds`, the scan matcher (:mod:`umbmark.realrobot.scanmatch`), the motion check
(:mod:`umbmark.realrobot.motion_check`), the recording's wheel angles
(:mod:`umbmark.realrobot.wheels`) and the other parts of the self-calibration
(:mod:`~umbmark.realrobot.selfcal_tf`, :mod:`~umbmark.realrobot.selfcal_delay`,
:mod:`~umbmark.realrobot.selfcal_plan`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag
from umbmark.kinds import DEFAULT_KIND, kind_named
from umbmark.model.drive import integrate_wheels
from umbmark.model.geometry import WheelGeometry
from umbmark.model.intervals import Intervals
from umbmark.realrobot.motion_check import check_readings, check_wheels_against_scans, lidar_motion
from umbmark.realrobot.scanmatch import ICPConfig, match_scan_pairs
from umbmark.realrobot.selfcal_delay import SCAN_DELAY_SEARCH_S, ScanDelay, delay_from_turns
from umbmark.realrobot.selfcal_plan import (
    IntervalOptions,
    IntervalPlan,
    KeyframeRule,
    StepProgress,
    _options,
    plan_intervals,
    usable_scans,
)
from umbmark.realrobot.selfcal_tf import nominal_sensor_pose_of
from umbmark.realrobot.wheels import recording_wheel_angles

__all__ = [
    "ScanIntervals",
    "match_intervals",
    "PairMatches",
    "match_pairs",
    "estimate_scan_delay",
    "check_bag_motion",
    "bag_intervals",
    "matched_motion",
    "composed_matches",
    "scan_delay_json",
    "bag_part_json",
]

_CHUNK = 500  # scan pairs per call of the matcher (the progress steps)

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ScanIntervals:
    """The intervals of one bag, matched (:func:`match_intervals`), and how they were made.

    Parameters
    ----------
    intervals : Intervals
        The intervals whose scans matched (source: the bag; the planning's warnings).
    plan : IntervalPlan
        The plan they came from.
    pairs_matched, pairs_failed : int
        Scan pairs that matched (or were chained), and that failed (dropped).
    failure_reasons : dict
        Why the failed ones failed: reason -> count.
    match_rms_m : float
        Median root-mean-square point-to-line residual of the matched pairs [m].
    pairs_chained : int
        Of ``pairs_matched``, the keyframe pairs whose two scans did not match but the
        consecutive scans between them did: their displacement is those matches composed.
    matched : numpy.ndarray
        ``(K,)`` booleans, one per planned pair: it matched (its interval is in ``intervals``).
    poses : numpy.ndarray
        ``(K, 3)`` the matcher's answer for every planned pair (also those that failed).
    covariances : numpy.ndarray
        ``(K, 3, 3)`` its covariance (of the composed matches for a chained pair).
    scan_delay : ScanDelay or None
        The delay estimated from this bag (:func:`estimate_scan_delay`), or None when it was
        given or not looked for.
    scan_delay_requested : str
        ``auto``, or the delay given in seconds (``0``: stamps as recorded).
    """

    intervals: Intervals
    plan: IntervalPlan
    pairs_matched: int
    pairs_failed: int
    failure_reasons: dict[str, int] = field(default_factory=dict)
    match_rms_m: float = math.nan
    pairs_chained: int = 0
    matched: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    poses: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    covariances: FloatArray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    scan_delay: ScanDelay | None = None
    scan_delay_requested: str = "0"

    @property
    def start_s(self) -> FloatArray:
        """``(K_matched,)`` the stamps of the intervals' first scans, delay applied [s]."""
        st = np.asarray(self.plan.bag.scan_t_s, dtype=float) - self.plan.scan_delay_s
        return np.asarray(st[self.plan.pairs[self.matched, 0]], dtype=float)

    def delay_dict(self) -> dict[str, Any]:
        """The scan delay of this bag as JSON (an element of ``scan_delay`` in the report).

        Returns
        -------
        dict
            ``bag``, ``requested`` (``auto`` or seconds), ``applied_s`` and, when estimated,
            :meth:`ScanDelay.to_dict`'s keys.
        """
        return scan_delay_json(self.plan.bag, self.scan_delay_requested, self.scan_delay, self.plan.scan_delay_s)

    def to_dict(self) -> dict[str, Any]:
        """What the pipeline did with the bag, as JSON.

        Returns
        -------
        dict
            ``path``, ``kind`` (``bag``), ``scan_topic``, ``scan_frame``, ``base_frame``,
            ``wheel_data``, ``scans_read``, ``scans_usable``, ``keyframes``, ``intervals_still``,
            ``pairs_matched``, ``pairs_chained``, ``pairs_failed``, ``failure_reasons``, ``match_rms_mm``,
            ``time_span_s``, ``wheel_stream`` (what the check of the wheel data found and did:
            :meth:`umbmark.model.wheel_stream.StreamReport.to_dict`), ``scan_delay``
            (:meth:`delay_dict`), ``nominal_sensor_pose``
            (``x_mm``, ``y_mm``, ``z_mm``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``, ``source``).
        """
        p = self.plan
        return bag_part_json(
            p.bag,
            p.base_frame,
            {
                "scans_usable": p.scans_usable,
                "keyframes": p.keyframes,
                "intervals_still": p.intervals_still,
                "pairs_matched": self.pairs_matched,
                "pairs_chained": self.pairs_chained,
                "pairs_failed": self.pairs_failed,
                "failure_reasons": dict(self.failure_reasons),
                "match_rms_mm": self.match_rms_m * 1e3,
                "time_span_s": p.time_span_s,
            },
            self.delay_dict(),
            p.nominal_sensor_pose,
            p.sensor_pose_source,
        )


def scan_delay_json(bag: SelfcalBag, requested: str, delay: ScanDelay | None, applied_s: float) -> dict[str, Any]:
    """A bag's scan delay as JSON (an element of a report's ``scan_delay``, any kind of robot):
    ``bag``, ``requested`` (``auto`` or seconds), the estimate's keys (:meth:`ScanDelay.to_dict`)
    when it was estimated, ``applied_s``."""
    out: dict[str, Any] = {"bag": bag.source, "requested": requested}
    if delay is not None:
        out.update(delay.to_dict())
    out["applied_s"] = applied_s
    return out


def bag_part_json(
    bag: SelfcalBag,
    base_frame: str,
    counts: dict[str, Any],
    delay: dict[str, Any],
    nominal_sensor_pose: Sequence[float],
    sensor_pose_source: str,
) -> dict[str, Any]:
    """What the pipeline did with one bag, as JSON (an element of a report's ``inputs``, any kind
    of robot; the keys of :meth:`ScanIntervals.to_dict`): the bag's own keys, then ``counts`` (in
    their order), the wheel data's check, ``delay`` (:func:`scan_delay_json`) and the nominal
    sensor pose ``(x, y, z, roll, pitch, yaw)`` the matching started from with its source."""
    x, y, z, roll, pitch, yaw = nominal_sensor_pose
    return {
        "path": bag.source,
        "kind": "bag",
        "scan_topic": bag.scan_topic,
        "scan_frame": bag.scan_frame,
        "base_frame": base_frame,
        "wheel_data": bag.wheel_description,
        "scans_read": bag.n_scans,
        **counts,
        "wheel_stream": None if bag.wheel_stream is None else bag.wheel_stream.to_dict(),
        "scan_delay": delay,
        "nominal_sensor_pose": {
            "x_mm": x * 1e3,
            "y_mm": y * 1e3,
            "z_mm": z * 1e3,
            "roll_deg": math.degrees(roll),
            "pitch_deg": math.degrees(pitch),
            "yaw_deg": math.degrees(yaw),
            "source": sensor_pose_source,
        },
    }


def match_intervals(
    plan: IntervalPlan,
    *,
    icp: ICPConfig | None = None,
    min_intervals: int = 10,
    progress: StepProgress | None = None,
) -> ScanIntervals:
    """Match the two scans of every planned interval; keep those that matched (step 3).

    Parameters
    ----------
    plan : IntervalPlan
        From :func:`plan_intervals`.
    icp : ICPConfig, optional
        Scan-matcher settings (default :class:`~umbmark.realrobot.scanmatch.ICPConfig`;
        ``coarse=True`` when the odometry is far off or the scans far apart).
    min_intervals : int
        Fewest matched intervals accepted.
    progress : callable, optional
        Called as ``progress(pairs_done, pairs_total)`` after each batch.

    Returns
    -------
    ScanIntervals

    Raises
    ------
    InputError
        Fewer than ``min_intervals`` intervals matched (the counts and the failures' reasons
        named).
    """
    bag = plan.bag
    m = match_pairs(bag, plan.pairs, plan.initial, plan.chained, plan.chained_covariance, icp=icp, progress=progress)
    n, ok, poses, covs = len(plan), m.ok, m.poses, m.covariances
    matched = int(ok.sum())
    warnings = m.judge(min_intervals, plan.intervals_still, plan.warnings, bag.source)
    iv = Intervals(
        plan.dt_s[ok],
        plan.left_rad[ok],
        plan.right_rad[ok],
        poses[ok],
        source=bag.source,
        warnings=tuple(warnings),
        steps=None if plan.steps is None else plan.steps.subset(np.flatnonzero(ok)),
        covariance=0.5 * (covs[ok] + np.swapaxes(covs[ok], 1, 2)),
        end_rates=None if plan.end_rates is None else plan.end_rates[ok],
    )
    return ScanIntervals(
        intervals=iv,
        plan=plan,
        pairs_matched=matched,
        pairs_failed=n - matched,
        pairs_chained=m.chained,
        failure_reasons=dict(m.reasons.most_common()),
        match_rms_m=float(np.median(m.rms_m[ok])),
        matched=ok,
        poses=poses,
        covariances=covs,
    )


@dataclass(frozen=True, eq=False)
class PairMatches:
    """The matches of planned scan pairs (:func:`match_pairs`).

    Attributes
    ----------
    poses : numpy.ndarray
        ``(K, 3)`` the matcher's answer (a chained pair's: the composed matches).
    covariances : numpy.ndarray
        ``(K, 3, 3)``.
    ok : numpy.ndarray
        ``(K,)`` matched, or chained.
    rms_m : numpy.ndarray
        ``(K,)`` root-mean-square point-to-line residual [m].
    reasons : collections.Counter
        Why the failed ones failed: reason -> count.
    chained : int
        Pairs that did not match but were chained.
    """

    poses: FloatArray
    covariances: FloatArray
    ok: NDArray[np.bool_]
    rms_m: FloatArray
    reasons: Counter[str]
    chained: int

    def judge(self, min_intervals: int, still: int, warnings: Sequence[str], source: str) -> list[str]:
        """The planning's warnings and one for many failures; an error when fewer than
        ``min_intervals`` matched (``still``: the pairs set aside without wheel motion)."""
        n, matched = len(self.ok), int(self.ok.sum())
        if matched < min_intervals:
            causes = "; ".join(f"{c} {r}" for r, c in self.reasons.most_common(3)) or "none failed"
            raise InputError(
                f"only {matched} usable intervals (fewer than {min_intervals}): {n} scan pairs with motion, "
                f"{n - matched} failed to match ({causes}), {still} without wheel motion; "
                "drive longer, in view of walls and objects",
                source,
            )
        out = list(warnings)
        if n - matched > 0.2 * n:
            out.append(
                f"{n - matched} of {n} scan pairs ({100 * (n - matched) / n:.0f} %) did not match "
                f"({'; '.join(f'{c} {r}' for r, c in self.reasons.most_common(2))}): drive slower, or near more "
                "structure"
            )
        return out


def match_pairs(
    bag: SelfcalBag,
    pairs: NDArray[np.int64],
    initial: FloatArray,
    chained: NDArray[np.bool_] | None = None,
    chained_covariance: FloatArray | None = None,
    *,
    icp: ICPConfig | None = None,
    progress: StepProgress | None = None,
) -> PairMatches:
    """Match the scans of each pair from its initial displacement; a pair that fails but is
    ``chained`` takes ``initial`` (the composed matches) with ``chained_covariance``.

    Parameters
    ----------
    bag : SelfcalBag
        The scans.
    pairs : numpy.ndarray
        ``(K, 2)`` scan indices.
    initial : numpy.ndarray
        ``(K, 3)`` the matcher's starts.
    chained, chained_covariance : numpy.ndarray, optional
        ``(K,)`` and ``(K, 3, 3)`` (:attr:`IntervalPlan.chained`).
    icp : ICPConfig, optional
    progress : callable, optional
        Called as ``progress(pairs_done, pairs_total)`` after each batch.

    Returns
    -------
    PairMatches
    """
    n = len(pairs)
    poses = np.empty((n, 3))
    covs = np.full((n, 3, 3), np.nan)
    ok = np.zeros(n, dtype=bool)
    rms = np.full(n, math.nan)
    why = [""] * n
    for s0 in range(0, n, _CHUNK):
        e = min(s0 + _CHUNK, n)
        a, b = pairs[s0:e, 0], pairs[s0:e, 1]
        m = match_scan_pairs(bag.ranges_m[a], bag.ranges_m[b], bag.angles_rad, initial[s0:e], icp)
        poses[s0:e] = m.poses
        covs[s0:e] = m.covariances
        ok[s0:e] = m.converged
        rms[s0:e] = m.rms_m
        why[s0:e] = [r.split(" (")[0] for r in m.reasons]
        if progress is not None:
            progress(e, n)
    direct = ok.copy()
    if chained is not None:
        assert chained_covariance is not None
        use = ~ok & chained
        poses[use] = initial[use]
        covs[use] = chained_covariance[use]
        ok |= use
    reasons: Counter[str] = Counter(r for r, c in zip(why, ok) if not c)
    return PairMatches(poses, covs, ok, rms, reasons, int((ok & ~direct).sum()))


def estimate_scan_delay(
    matches: ScanIntervals,
    wheel_diameter_m: float,
    wheelbase_m: float,
    *,
    search_s: float = SCAN_DELAY_SEARCH_S,
    step_s: float = 0.005,
) -> ScanDelay:
    """Estimate how late the scans are stamped against the wheel data, from the turns.

    For each trial delay ``d`` on a grid, the robot's turn between ``t_a - d`` and ``t_b - d``
    by the wheel data (the odometry's heading, or the wheel angles through the nominal
    geometry; interpolated linearly) is correlated with the matched turn between the scans
    stamped ``t_a``, ``t_b`` (the matches' intervals; the delay they were planned with is
    added back). The delay of the highest correlation, refined by a parabola through its
    neighbours, is the estimate. A turn's scale error does not move it (a correlation ignores
    scale); a delay shows because the wheels' turn of an interval is then partly that of its
    neighbours.

    Parameters
    ----------
    matches : ScanIntervals
        Matched intervals of one bag (:func:`match_intervals`).
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry [m].
    search_s : float
        The largest delay searched, either way [s], around the delay the matches were planned
        with.
    step_s : float
        The grid step [s].

    Returns
    -------
    ScanDelay

    Raises
    ------
    InputError
        A search range or step that is not positive, or fewer than 10 matched pairs that turn.
    """
    if not (isinstance(search_s, (int, float)) and search_s > 0 and isinstance(step_s, (int, float)) and step_s > 0):
        raise InputError(f"`search_s` and `step_s` must be positive, got {search_s!r} and {step_s!r}")
    plan = matches.plan
    bag = plan.bag
    ok = matches.matched
    turn = matches.poses[ok, 2]
    if ok.sum() < 10 or not np.any(turn):
        raise InputError(f"only {int(ok.sum())} matched scan pairs that turn: too few to estimate a delay", bag.source)
    if bag.wheel_kind == "odom":
        assert bag.odom_pose is not None
        heading = np.unwrap(np.asarray(bag.odom_pose, dtype=float)[:, 2])
    else:
        assert bag.left_rad is not None and bag.right_rad is not None
        left, right = recording_wheel_angles(bag, WheelGeometry(wheel_diameter_m, wheel_diameter_m, wheelbase_m))
        heading = 0.5 * wheel_diameter_m * (right - left) / wheelbase_m
    st = np.asarray(bag.scan_t_s, dtype=float)
    return delay_from_turns(
        np.asarray(bag.wheel_t_s, dtype=float),
        heading,
        st[plan.pairs[ok, 0]],
        st[plan.pairs[ok, 1]],
        turn,
        plan.scan_delay_s,
        search_s=search_s,
        step_s=step_s,
        source=bag.source,
    )


def check_bag_motion(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike,
    *,
    delay_s: float = 0.0,
    max_wheel_gap_s: float = 0.5,
) -> None:
    """The nominal odometry of a differential drive's recording at its scans against the lidar's
    own motion (:func:`umbmark.realrobot.motion_check.check_wheels_against_scans`; encoder
    counts read as a running counter are also tried as counts per message; wheel joints, in the
    other order: :func:`umbmark.realrobot.motion_check.check_readings`).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        The nominal geometry [m].
    sensor_pose : array_like
        ``(x_m, y_m, yaw_rad)``: the lidar's nominal mounting pose.
    delay_s : float
        How late the scans are stamped [s].
    max_wheel_gap_s : float
        Scans in longer gaps of the wheel data are left out [s].

    Raises
    ------
    InputError
        As :func:`~umbmark.realrobot.motion_check.check_wheels_against_scans`.
    """
    d_nom, b_nom = positive("`wheel_diameter_m`", wheel_diameter_m), positive("`wheelbase_m`", wheelbase_m)
    left, right = recording_wheel_angles(bag, WheelGeometry(d_nom, d_nom, b_nom))
    wt = np.asarray(bag.wheel_t_s, dtype=float)
    st = np.asarray(bag.scan_t_s, dtype=float) - delay_s
    period = float(np.median(np.diff(wt))) if len(wt) > 1 else 0.0
    usable = usable_scans(st, wt, period, max_wheel_gap_s, bag.source, [])
    r = 0.5 * d_nom

    def odometry(left: FloatArray, right: FloatArray) -> FloatArray:
        return integrate_wheels(r * np.diff(np.interp(st, wt, left)), r * np.diff(np.interp(st, wt, right)), b_nom)

    other = {}
    if bag.wheel_kind == "ticks" and "(cumulative" in bag.wheel_description:
        other['counts per message (`ticks="incremental"`)'] = odometry(np.cumsum(left), np.cumsum(right))
    seen = lidar_motion(bag, usable, sensor_pose)
    given = odometry(left, right)
    if bag.wheel_kind == "joints" and len(bag.joint_names) == 2:
        kind, wheels = kind_named(DEFAULT_KIND), (left, right)
        readings = [
            (kind.reading_cause(r, bag.joint_names), odometry(wheels[r.order[0]], wheels[r.order[1]]))
            for r in kind.readings()
        ]
        check_readings(seen, given, readings, bag.source)
    check_wheels_against_scans(bag, st, usable, given, sensor_pose, alternatives=other, motion=seen)


def bag_intervals(
    bag: SelfcalBag,
    wheel_diameter_m: float,
    wheelbase_m: float,
    options: IntervalOptions | None = None,
    *,
    progress: StepProgress | None = None,
) -> ScanIntervals:
    """The intervals of a bag, matched: steps 1-4 of the module docstring.

    1. Every pair of consecutive scans is planned (:func:`plan_intervals`, the stamps as
       recorded, or the delay given) and matched (:func:`match_intervals`).
    2. With ``options.scan_delay`` ``"auto"`` the scans' delay is estimated from those matches
       (:func:`estimate_scan_delay`).
    3. The keyframes are chosen on the matches composed (:func:`matched_motion`), not on the
       wheel data, whose errors would choose them; each interval's wheel rotations are read at
       the delayed stamps, and its two keyframes matched starting from the composed matches.
       Every scan a keyframe, the pairs are matched again from the delayed odometry when the
       delay moved it (the matcher stops within a small fraction of a standard deviation of
       the optimum on the side it started from, so a start off by the delay would pull every
       match a little the same way).

    Parameters
    ----------
    bag : SelfcalBag
        The recording.
    wheel_diameter_m, wheelbase_m : float
        Nominal geometry [m].
    options : IntervalOptions, optional
        The keyframes, sensor pose, base frame, wheel gap, matcher, fewest intervals and the
        scans' delay (default :class:`IntervalOptions`: the delay estimated).
    progress : callable, optional
        As :func:`match_intervals`.

    Returns
    -------
    ScanIntervals
        With the delay applied and, when estimated, :attr:`ScanIntervals.scan_delay`.

    Raises
    ------
    InputError
        As the two steps and :func:`estimate_scan_delay`.
    """
    opts = _options(options)
    want, rule, icp, min_intervals = opts.scan_delay, opts.keyframes, opts.icp, opts.min_intervals
    first = 0.0 if want == "auto" else float(want)
    pose = nominal_sensor_pose_of(bag, opts.sensor_pose, opts.base_frame)[0]
    check_bag_motion(
        bag,
        wheel_diameter_m,
        wheelbase_m,
        (pose[0], pose[1], pose[5]),
        delay_s=first,
        max_wheel_gap_s=opts.max_wheel_gap_s,
    )
    # every pair of consecutive scans matched: the scans' delay and the motion the keyframes are chosen on
    every = replace(opts, keyframes=KeyframeRule())
    plan = plan_intervals(bag, wheel_diameter_m, wheelbase_m, every, scan_delay_s=first)
    n0 = len(plan)
    pass1 = None if progress is None else (lambda done, total: progress(done, 2 * n0))  # noqa: E731
    si = match_intervals(plan, icp=icp, min_intervals=1 if not rule.every_scan else min_intervals, progress=pass1)
    est: ScanDelay | None = None
    delay = first
    if want == "auto":
        try:
            est = estimate_scan_delay(si, wheel_diameter_m, wheelbase_m)
            delay = est.delay_s
        except InputError as err:
            note = f"the scans' delay is not estimated ({err.message}): stamps as recorded"
            si = replace(si, plan=replace(si.plan, warnings=si.plan.warnings + (note,)))
    motion, links, link_cov = (None, None, None) if rule.every_scan else matched_motion(si)
    if rule.every_scan and delay == first:
        if len(si.intervals) < min_intervals:
            match_intervals(si.plan, icp=icp, min_intervals=min_intervals)  # raises, naming the failures
        return replace(si, scan_delay=est, scan_delay_requested="auto" if want == "auto" else f"{first:g}")
    plan2 = plan_intervals(
        bag,
        wheel_diameter_m,
        wheelbase_m,
        opts,
        scan_delay_s=delay,
        motion=motion,
        motion_links=links,
        motion_covariance=link_cov,
    )
    if est is None and want == "auto":
        plan2 = replace(plan2, warnings=si.plan.warnings)
    n1 = len(plan2)
    pass2 = None if progress is None else (lambda done, total: progress(n0 + round(done * n0 / max(n1, 1)), 2 * n0))  # noqa: E731
    out = match_intervals(plan2, icp=icp, min_intervals=min_intervals, progress=pass2)
    return replace(out, scan_delay=est, scan_delay_requested="auto" if want == "auto" else f"{first:g}")


def matched_motion(matches: ScanIntervals) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """The sensor's poses at every scan from matches of consecutive scans, composed.

    A pair that did not match moves by the nominal odometry's displacement seen from the sensor
    (the matcher's start); a pair the plan left out (no wheel motion, or no wheel data) by
    nothing. Keyframes never span a scan without wheel data, so the poses between two
    keyframes are always those of the matches between them.

    Parameters
    ----------
    matches : ScanIntervals
        Matches of consecutive scans (every scan a keyframe).

    Returns
    -------
    poses : numpy.ndarray
        ``(M, 3)`` poses in the frame of the first scan (heading accumulated).
    links : numpy.ndarray
        ``(M - 1,)`` booleans: the step from each scan to the next is a match, or the wheels
        did not move.
    covariance : numpy.ndarray
        ``(M - 1, 3, 3)`` each step's covariance (the match's; zero without one).
    """
    plan = matches.plan
    st = np.asarray(plan.bag.scan_t_s, dtype=float) - plan.scan_delay_s
    return composed_matches(
        st,
        np.asarray(plan.bag.wheel_t_s, dtype=float),
        plan.pairs,
        matches.matched,
        matches.poses,
        plan.initial,
        matches.covariances,
    )


def composed_matches(
    st: FloatArray,
    wt: FloatArray,
    pairs: NDArray[np.int64],
    matched: NDArray[np.bool_],
    poses: FloatArray,
    initial: FloatArray,
    covariances: FloatArray,
) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """:func:`matched_motion` of matches of consecutive scans: ``st`` the scans' stamps (delay
    applied), ``wt`` the wheel data's, ``pairs`` ``(K, 2)`` consecutive scan indices, then per
    pair whether it matched, the match, the matcher's start and the match's covariance."""
    n = len(st) - 1
    step = np.zeros((n, 3))
    step[pairs[:, 0]] = np.where(matched[:, None], poses, initial)
    links = np.ones(n, dtype=bool)
    links[pairs[:, 0]] = matched
    cov = np.zeros((n, 3, 3))
    cov[pairs[matched, 0]] = covariances[matched]
    links &= (st[1:] >= wt[0]) & (st[:-1] <= wt[-1])  # the wheels' data cover the step
    th = np.concatenate([[0.0], np.cumsum(step[:, 2])])
    c, s = np.cos(th[:-1]), np.sin(th[:-1])
    x = np.concatenate([[0.0], np.cumsum(c * step[:, 0] - s * step[:, 1])])
    y = np.concatenate([[0.0], np.cumsum(s * step[:, 0] + c * step[:, 1])])
    return np.column_stack([x, y, th]), links, cov
