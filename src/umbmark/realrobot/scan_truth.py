"""The robot's own lidar as the measuring instrument of a UMBmark test: each run's true
displacement from the scans taken at rest before and after it.

For every run of a square data set read from a bag (:func:`umbmark.io.load.load_logs` without
a ground truth), :func:`attach_scan_truth`:

* places the run in the bag's wheel stream (the run's samples are a stretch of the bag's: same
  relative times, same samples with wheel motion) and finds where the wheels start and stop
  turning;
* takes the **last scan before the wheels start** (the robot at rest at its start; one whose
  sweep, a scan period from its stamp, ends before they start, when there is one) and the
  **first scan after they stop** (at rest at its end), each inside the stillness around the
  run (a scan stamped while the wheels turn is never used);
* registers the end scan against the start scan (:func:`umbmark.realrobot.scanmatch.match_scans`
  with the coarse correlative stage around the odometry's prediction: return errors up to a
  metre and 30 degrees are found);
* maps the sensor's displacement to the robot centre through the lidar's mounting pose ``S``:
  ``D_robot = S D_sensor S^-1``;
* sets it as the run's measured end pose (``gt_end``, in the run's start frame, the heading
  unwrapped next to the odometry's).

Each run is measured against its own start: the experimenter may put the robot back near its
mark between runs or leave it where it stopped. A registration that does not converge, matches
too few points or leaves a large residual drops its run with a warning naming it (never a
silent number); no run left is an error.

The mounting pose: given (``sensor_pose``: ``(x_m, y_m, yaw_rad)``, or read from a
self-calibration JSON by :func:`read_sensor_pose`), else from the bag's ``/tf_static``
(``base_link`` or ``base_footprint`` to the scans' frame), else the robot centre, with a
warning. SI units; imports numpy, :mod:`umbmark.model`, :mod:`umbmark.io` and the scan matcher.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._numbers import strict_float
from umbmark.errors import InputError
from umbmark.io.rosbag import SelfcalBag, read_selfcal_bag
from umbmark.io.wheels import WheelSource
from umbmark.model.dataset import Dataset, Run
from umbmark.model.se2 import compose, inverse
from umbmark.realrobot.scanmatch import ICPConfig, match_scans
from umbmark.realrobot.selfcal import BASE_FRAMES, MAX_TILT_RAD, check_bag_motion, sensor_pose_from_tf

__all__ = [
    "SCAN_TRUTH_ICP",
    "MAX_RMS_M",
    "MIN_INLIER_FRACTION",
    "RunScanTruth",
    "ScanTruth",
    "parse_sensor_pose",
    "check_sensor_pose",
    "MAX_SENSOR_OFFSET_M",
    "read_sensor_pose",
    "robot_displacement",
    "attach_scan_truth",
]

SCAN_TRUTH_ICP = ICPConfig(
    coarse=True,
    coarse_range_m=1.2,
    coarse_range_rad=math.radians(35.0),
    max_correspondence_m=0.3,
    max_iterations=80,
    min_points=40,
)
"""The registration of a run's end scan against its start scan: the coarse correlative stage
over +-1.2 m and +-35 degrees around the odometry's prediction, then point-to-line ICP."""

MAX_RMS_M = 0.03
"""A registration whose point-to-line residual (root mean square) exceeds this drops its run."""

MIN_INLIER_FRACTION = 0.7
"""A registration matching fewer of the end scan's points than this drops its run."""

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RunScanTruth:
    """How one run's true displacement was measured with the lidar.

    Attributes
    ----------
    run : str
        The run's name.
    source : str
        The bag it was read from.
    start_scan_s, end_scan_s : float
        The stamps of the start and end scans, in seconds from the run's first wheel sample.
    motion_s : (float, float)
        When the wheels start and stop turning, in the same time.
    sensor_displacement : tuple of float
        The end scan's frame in the start scan's ``(x_m, y_m, yaw_rad)``.
    displacement : tuple of float or None
        The robot centre's displacement, the run's measured end pose (None: the run was dropped).
    rms_m, inlier_fraction : float
        The registration's residual and the fraction of the end scan's points it matched.
    converged : bool
        The registration passed every check.
    reason : str
        Why the run was dropped (empty when it was not).
    """

    run: str
    source: str
    start_scan_s: float
    end_scan_s: float
    motion_s: tuple[float, float]
    sensor_displacement: tuple[float, float, float]
    displacement: tuple[float, float, float] | None
    rms_m: float
    inlier_fraction: float
    converged: bool
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values (mm and degrees)."""

        def pose(p: tuple[float, float, float] | None) -> dict[str, float] | None:
            return None if p is None else {"x_mm": p[0] * 1e3, "y_mm": p[1] * 1e3, "theta_deg": math.degrees(p[2])}

        return {
            "run": self.run,
            "source": self.source,
            "start_scan_s": self.start_scan_s,
            "end_scan_s": self.end_scan_s,
            "motion_s": list(self.motion_s),
            "sensor_displacement": pose(self.sensor_displacement),
            "displacement": pose(self.displacement),
            "rms_mm": self.rms_m * 1e3,
            "inlier_fraction": self.inlier_fraction,
            "converged": self.converged,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class ScanTruth:
    """The lidar ground truth of a data set's runs.

    Attributes
    ----------
    scan_topic : str
        The LaserScan topic.
    sensor_pose : tuple of float
        The lidar's mounting pose used ``(x_m, y_m, yaw_rad)`` in the robot frame.
    sensor_pose_source : str
        Where it came from (``given``, a file, ``/tf_static ...``, ``none``).
    runs : tuple of RunScanTruth
        One per run, in order.
    warnings : tuple of str
        Dropped runs, an unknown mounting pose.
    """

    scan_topic: str
    sensor_pose: tuple[float, float, float]
    sensor_pose_source: str
    runs: tuple[RunScanTruth, ...]
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The ``scan_truth`` block of ``umbmark replay --json``."""
        x, y, yaw = self.sensor_pose
        return {
            "scan_topic": self.scan_topic,
            "sensor_pose": {"x_mm": x * 1e3, "y_mm": y * 1e3, "yaw_deg": math.degrees(yaw)},
            "sensor_pose_source": self.sensor_pose_source,
            "runs": [r.to_dict() for r in self.runs],
            "runs_dropped": sum(r.displacement is None for r in self.runs),
            "warnings": list(self.warnings),
        }


def read_sensor_pose(path: str | Path) -> tuple[float, float, float]:
    """The ``sensor_pose`` of a self-calibration JSON (``umbmark selfcal --json`` or ``--save``).

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    tuple of float
        ``(x_m, y_m, yaw_rad)``.

    Raises
    ------
    InputError
        Not JSON, or without a ``sensor_pose`` holding ``x_mm``, ``y_mm``, ``yaw_deg``.
    """
    from umbmark.io._text import parse_json, read_text

    d = parse_json(read_text(path), str(path))
    sp: Any = d.get("sensor_pose") if isinstance(d, dict) else None  # any JSON value: a bad one raises below
    try:
        vals = (float(sp["x_mm"]) * 1e-3, float(sp["y_mm"]) * 1e-3, math.radians(float(sp["yaw_deg"])))
    except (TypeError, KeyError, ValueError):
        raise InputError(
            'no "sensor_pose" with x_mm, y_mm, yaw_deg (the JSON a self-calibration writes)',
            source=str(path),
        ) from None
    if not all(math.isfinite(v) for v in vals):
        raise InputError('its "sensor_pose" is not three finite numbers', source=str(path))
    return vals


def parse_sensor_pose(text: str) -> tuple[tuple[float, float, float], str]:
    """A mounting pose given as ``X_MM,Y_MM,YAW_DEG`` or as the path of a self-calibration JSON.

    Parameters
    ----------
    text : str
        Three comma-separated numbers (mm, mm, degrees), or an existing ``.json`` file.

    Returns
    -------
    pose : tuple of float
        ``(x_m, y_m, yaw_rad)``.
    source : str
        ``given`` or the file's path.

    Raises
    ------
    InputError
        Neither three finite numbers nor a readable self-calibration JSON.
    """
    p = Path(text)
    if p.suffix.lower() == ".json" or p.is_file():
        if not p.is_file():
            raise InputError("`sensor_pose` names a JSON file that does not exist", source=text)
        return read_sensor_pose(p), str(p)
    parts = [s.strip() for s in text.split(",")]
    try:
        x, y, yaw = (strict_float(s) for s in parts)
    except ValueError:
        raise InputError(
            f"`sensor_pose` needs X_MM,Y_MM,YAW_DEG (three numbers) or a selfcal JSON file, got {text!r}"
        ) from None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise InputError(f"`sensor_pose` needs three finite numbers, got {text!r}")
    pose = (x * 1e-3, y * 1e-3, math.radians(yaw))
    check_sensor_pose(pose)
    return pose, "given"


# a sensor on the robot is within this of the axle midpoint (metres)
MAX_SENSOR_OFFSET_M = 10.0


def check_sensor_pose(pose: tuple[float, float, float]) -> list[str]:
    """Refuse a given mounting pose no robot has; name one whose numbers look like other units.

    Parameters
    ----------
    pose : tuple of float
        ``(x_m, y_m, yaw_rad)`` as given (in millimetres and degrees, converted).

    Returns
    -------
    list of str
        Warnings: an offset under a millimetre (metres given as millimetres?), a yaw of pi or
        pi/2 degrees (radians given as degrees?).

    Raises
    ------
    InputError
        An offset beyond :data:`MAX_SENSOR_OFFSET_M` from the axle midpoint.
    """
    x, y, yaw = (float(v) for v in pose)
    far = math.hypot(x, y)
    if far > MAX_SENSOR_OFFSET_M:
        raise InputError(
            f"`sensor_pose` puts the sensor {1e3 * far:g} mm from the axle midpoint: a sensor on the robot is "
            f"within {1e3 * MAX_SENSOR_OFFSET_M:g} mm of it (X and Y are in millimetres, the yaw in degrees)"
        )
    notes = []
    if 0 < max(abs(x), abs(y)) < 1e-3:
        notes.append(
            f"`sensor_pose` puts the sensor {1e3 * x:g} mm ahead of and {1e3 * y:g} mm left of the axle midpoint: "
            f"metres given as millimetres? ({1e6 * x:g},{1e6 * y:g} if they are metres)"
        )
    deg = math.degrees(yaw)
    for rad in (math.pi, math.pi / 2):
        if abs(abs(deg) - rad) < 2e-3:
            notes.append(
                f"`sensor_pose` turns the sensor {deg:g} deg: radians given as degrees? "
                f"({math.degrees(math.copysign(rad, deg)):g} if they are radians; the yaw is in degrees)"
            )
    return notes


def robot_displacement(sensor_displacement: ArrayLike, sensor_pose: ArrayLike) -> FloatArray:
    """The robot centre's displacement from the sensor's: ``S D_sensor S^-1``.

    Parameters
    ----------
    sensor_displacement : array_like
        ``(..., 3)`` the sensor frame's end pose in its start pose.
    sensor_pose : array_like
        ``(3,)`` the sensor's mounting pose in the robot frame.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` the robot's end pose in its start pose (heading wrapped).
    """
    s = np.asarray(sensor_pose, dtype=float)
    return compose(compose(s, sensor_displacement), inverse(s))


def _sensor_pose(bag: SelfcalBag) -> tuple[tuple[float, float, float], str] | None:
    for f in BASE_FRAMES:
        tf = sensor_pose_from_tf(bag.static_transforms, f, bag.scan_frame)
        if tf is None:
            continue
        if abs(tf[3]) > MAX_TILT_RAD or abs(tf[4]) > MAX_TILT_RAD:
            raise InputError(
                f"/tf_static puts the scan frame {bag.scan_frame!r} at roll {math.degrees(tf[3]):.1f} deg, "
                f"pitch {math.degrees(tf[4]):.1f} deg in {f!r}: the lidar must be level, mounted upright",
                bag.source,
            )
        return (tf[0], tf[1], tf[5]), f"/tf_static {f} -> {bag.scan_frame}"
    return None


def _bag_motion(bag: SelfcalBag) -> tuple[FloatArray, NDArray[np.int8]]:
    """The bag's wheel stamps and, per sample, the sign of its turn (``+2``/``-2``, ``+-1`` for
    straight motion, 0 at rest): ``sign(d_right - d_left) * 2`` when the wheels turn unequally,
    else ``sign(d_left)``."""
    if bag.left_rad is not None and bag.right_rad is not None:
        dl = np.diff(bag.left_rad, prepend=bag.left_rad[0])
        dr = np.diff(bag.right_rad, prepend=bag.right_rad[0])
        return np.asarray(bag.wheel_t_s, dtype=float), _signature(dl, dr, dr - dl)
    pose = np.asarray(bag.odom_pose, dtype=float)
    d = np.diff(pose, axis=0, prepend=pose[:1])
    c, s_ = np.cos(pose[:, 2] - 0.5 * d[:, 2]), np.sin(pose[:, 2] - 0.5 * d[:, 2])
    forward = c * d[:, 0] + s_ * d[:, 1]
    dth = np.angle(np.exp(1j * d[:, 2]))
    return np.asarray(bag.wheel_t_s, dtype=float), _signature(forward, forward, dth)


def _signature(dl: ArrayLike, dr: ArrayLike, turn: ArrayLike) -> NDArray[np.int8]:
    turn = np.asarray(turn, dtype=float)
    tiny = 1e-12 * max(float(np.max(np.abs(turn), initial=0.0)), 1e-300)
    sig = np.where(np.abs(turn) > tiny, 2 * np.sign(turn), np.sign(np.asarray(dl) + np.asarray(dr)))
    moving = (np.asarray(dl) != 0) | (np.asarray(dr) != 0) | (np.abs(turn) > tiny)
    return np.where(moving, sig, 0).astype(np.int8)


def _place(run: Run, t: FloatArray, sig: NDArray[np.int8], start: int) -> int | None:
    """The bag sample (from ``start`` on) where ``run`` starts: the same relative times and, sample
    by sample, the same sign of the motion (:func:`_bag_motion`)."""
    n = len(run)
    if start + n > len(t):
        return None
    run_sig = _signature(run.d_left, run.d_right, run.d_right - run.d_left)
    run_sig[0] = 0
    tol = 1e-6 + 1e-9 * abs(float(run.t[-1]))
    dur = t[start + n - 1 :] - t[start : len(t) - n + 1]
    cand = start + np.flatnonzero(np.abs(dur - float(run.t[-1])) <= tol)
    moving = sig != 0
    count = np.concatenate([[0], np.cumsum(moving)])
    cand = cand[(count[cand + n] - count[cand + 1]) == int(np.count_nonzero(run_sig))]
    for a in cand:
        if np.array_equal(sig[a + 1 : a + n], run_sig[1:]) and np.allclose(
            t[a : a + n] - t[a], run.t, rtol=0, atol=tol
        ):
            return int(a)
    return None


def _still_scan(scan_t: FloatArray, lo: float, hi: float, last: bool) -> int | None:
    """The last (or first) scan with a stamp in ``[lo, hi]``."""
    idx = np.flatnonzero((scan_t >= lo) & (scan_t <= hi))
    if idx.size == 0:
        return None
    return int(idx[-1] if last else idx[0])


def _odometry_end(ds: Dataset, run: Run) -> FloatArray:
    from umbmark.model.dataset import replay_increments

    x, y, th = replay_increments(run.d_left, run.d_right, ds.nominal.params(ds.units_per_wheel_rev), end=True)
    return np.array([float(x), float(y), float(th)])


def _measure_run(
    ds: Dataset,
    run: Run,
    bag: SelfcalBag,
    t: FloatArray,
    sig: NDArray[np.int8],
    start: int,
    pose: FloatArray,
    config: ICPConfig,
    max_rms_m: float,
    min_inlier_fraction: float,
) -> tuple[int, RunScanTruth]:
    where = f"{Path(bag.source).name}/{run.name}"
    a = _place(run, t, sig, start)
    moving = sig != 0
    if a is None:
        raise InputError(
            f"run {run.name}: cannot find its wheel samples in the bag's wheel data (read both with the same "
            "wheel options)",
            bag.source,
        )
    n = len(run)
    mv = np.flatnonzero(moving[a + 1 : a + n]) + a + 1
    if mv.size == 0:
        raise InputError(f"run {run.name}: the wheels do not turn", bag.source)
    first, last = int(mv[0]), int(mv[-1])
    before = np.flatnonzero(moving[:first])
    after = np.flatnonzero(moving[last + 1 :])
    rest_from = t[before[-1]] if before.size else -math.inf  # the wheels still from here ...
    rest_to = t[last + 1 + after[0] - 1] if after.size else math.inf  # ... and until here
    t0 = float(t[a])
    # a scan is stamped at its start: the start scan should be complete before the wheels turn
    period = float(np.median(np.diff(bag.scan_t_s))) if len(bag.scan_t_s) > 1 else 0.0
    i = _still_scan(bag.scan_t_s, rest_from, float(t[first - 1]) - period, last=True)
    if i is None:
        i = _still_scan(bag.scan_t_s, rest_from, float(t[first - 1]), last=True)
    j = _still_scan(bag.scan_t_s, float(t[last]), rest_to, last=False)
    motion = (float(t[first - 1]) - t0, float(t[last]) - t0)
    if i is None or j is None:
        which = "before the wheels start" if i is None else "after the wheels stop"
        raise InputError(
            f"run {where}: no scan on {bag.scan_topic} while the robot is at rest {which} "
            "(pause a few seconds before and after each run)",
            bag.source,
        )
    odo = _odometry_end(ds, run)
    s = pose
    guess = compose(compose(inverse(s), odo), s)  # the odometry's prediction of the sensor's motion
    m = match_scans(bag.ranges_m[i], bag.ranges_m[j], bag.angles_rad, guess, config)
    sensor = (float(m.pose[0]), float(m.pose[1]), float(m.pose[2]))
    reason = ""
    if not m.converged:
        reason = m.reason
    elif not (m.rms_m <= max_rms_m):
        reason = f"residual {m.rms_m * 1e3:.1f} mm RMS above {max_rms_m * 1e3:g} mm"
    elif m.inlier_fraction < min_inlier_fraction:
        reason = f"only {m.inlier_fraction:.0%} of the end scan's points matched (at least {min_inlier_fraction:.0%})"
    disp = None
    if not reason:
        d = robot_displacement(sensor, s)
        th = float(d[2]) + 2.0 * math.pi * round((odo[2] - float(d[2])) / (2.0 * math.pi))
        disp = (float(d[0]), float(d[1]), th)
    return a + n - 1, RunScanTruth(
        run=run.name,
        source=bag.source,
        start_scan_s=float(bag.scan_t_s[i]) - t0,
        end_scan_s=float(bag.scan_t_s[j]) - t0,
        motion_s=motion,
        sensor_displacement=sensor,
        displacement=disp,
        rms_m=float(m.rms_m),
        inlier_fraction=float(m.inlier_fraction),
        converged=not reason,
        reason=reason,
    )


def attach_scan_truth(
    datasets: Sequence[Dataset],
    scan_topic: str,
    *,
    sensor_pose: ArrayLike | None = None,
    sensor_pose_source: str = "given",
    wheels: WheelSource,
    config: ICPConfig = SCAN_TRUTH_ICP,
    max_rms_m: float = MAX_RMS_M,
    min_inlier_fraction: float = MIN_INLIER_FRACTION,
) -> tuple[list[Dataset], ScanTruth]:
    """Each run's measured end pose from the lidar scans at rest before and after it (module docstring).

    Parameters
    ----------
    datasets : sequence of Dataset
        Runs read from bags (each run's ``source``, else its data set's, names its bag).
    scan_topic : str
        The ``sensor_msgs/LaserScan`` topic.
    sensor_pose : array_like, optional
        ``(x_m, y_m, yaw_rad)``: the lidar's mounting pose in the robot frame (None: from
        ``/tf_static``, else the robot centre with a warning).
    sensor_pose_source : str
        Where a given ``sensor_pose`` came from (for the report).
    wheels : WheelSource
        The wheel data, as the data sets were read (:mod:`umbmark.io.wheels`).
    config : ICPConfig
        The registration's settings.
    max_rms_m, min_inlier_fraction : float
        Registrations beyond these drop their run.

    Returns
    -------
    datasets : list of Dataset
        The data sets with each kept run's ``gt_end`` set and the dropped runs left out.
    truth : ScanTruth
        How each run was measured, and the warnings.

    Raises
    ------
    InputError
        A run not found in its bag's wheel data, no scan at rest before or after a run, a bad
        ``sensor_pose``, no run left in a data set; the bag errors of
        :func:`~umbmark.io.rosbag.read_selfcal_bag`.
    """
    warnings: list[str] = []
    pose_used: tuple[float, float, float] | None = None
    pose_src = sensor_pose_source
    if sensor_pose is not None:
        p = np.asarray(sensor_pose, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InputError("`sensor_pose` must be three finite numbers (x_m, y_m, yaw_rad)")
        pose_used = (float(p[0]), float(p[1]), float(p[2]))
    bags: dict[str, SelfcalBag] = {}
    motion: dict[str, tuple[FloatArray, NDArray[np.int8]]] = {}
    next_sample: dict[str, int] = {}
    checked: set[str] = set()
    out, records = [], []
    for ds in datasets:
        kept = []
        for run in ds.runs:
            src = run.source or ds.source
            if src is None:
                raise InputError(f"run {run.name}: the lidar ground truth needs the bag it was read from")
            if src not in bags:
                bag = read_selfcal_bag(src, wheels=wheels, scan_topic=scan_topic)
                bags[src] = bag
                motion[src] = _bag_motion(bag)
                next_sample[src] = 0
                warnings += [f"{Path(src).name}: {w}" for w in bag.warnings]
                if sensor_pose is None:
                    found = _sensor_pose(bag)
                    if found is None and pose_used is None:
                        warnings.append(
                            f"{Path(src).name}: no /tf_static transform from {' or '.join(BASE_FRAMES)} to the "
                            f"scan frame {bag.scan_frame!r}: the lidar is taken to sit at the robot's centre "
                            "(give `sensor_pose`)"
                        )
                        pose_used, pose_src = (0.0, 0.0, 0.0), "none"
                    elif found is not None and pose_used is None:
                        pose_used, pose_src = found
            bag = bags[src]
            if src not in checked:
                nom = ds.nominal
                d_m = 0.5 * (nom.diameter_left_m + nom.diameter_right_m)
                check_bag_motion(bag, d_m, nom.wheelbase_m, pose_used or (0.0, 0.0, 0.0))
                checked.add(src)
            t, mv = motion[src]
            next_sample[src], rec = _measure_run(
                ds,
                run,
                bag,
                t,
                mv,
                next_sample[src],
                np.asarray(pose_used, dtype=float),
                config,
                max_rms_m,
                min_inlier_fraction,
            )
            records.append(rec)
            if rec.displacement is None:
                warnings.append(
                    f"run {Path(src).name}/{run.name}: the scan registration failed ({rec.reason}): run dropped"
                )
                continue
            kept.append(replace(run, gt=None, gt_end=np.array(rec.displacement)))
        if not kept:
            raise InputError(f"no run of {ds.name} has a lidar ground truth: every scan registration failed", ds.source)
        dirs = None
        if ds.directions is not None:
            names = {r.name for r in kept}
            dirs = tuple(d for r, d in zip(ds.runs, ds.directions) if r.name in names)
        out.append(replace(ds, runs=tuple(kept), directions=dirs))
    assert pose_used is not None or not records
    return out, ScanTruth(
        scan_topic, pose_used or (0.0, 0.0, 0.0), pose_src, tuple(records), tuple(dict.fromkeys(warnings))
    )
