#!/usr/bin/env python3
"""Coverage of the lidar self-calibration's 95 % intervals over many simulated robots and drives.

    python benchmarks/selfcal_coverage.py                          # into ./umbmark-bench-selfcal-coverage/
    python benchmarks/selfcal_coverage.py --bags 20 --jobs 2       # a quicker look
    python benchmarks/selfcal_coverage.py --out benchmarks/results

Each of ``--bags`` (default 60) bags is a different seeded robot and drive, written as a ROS 2
bag (mcap: /joint_states, /scan, /tf_static) into a temporary folder, calibrated with
``umbmark selfcal BAG --joints left_wheel_joint,right_wheel_joint --wheel-diameter-mm D
--wheelbase-mm B --json`` (the command itself, in a new process, with its default settings;
timed) and deleted. Drawn per bag:

- nominal wheel diameter 100-200 mm and wheelbase 250-500 mm (whole millimetres: the figures
  a user types); each true wheel diameter off the nominal by up to +-3 % (an E_d and a scale
  error), the true wheelbase off by up to +-5 %;
- the lidar at x +-200 mm, y +-100 mm, yaw +-5 deg; the /tf_static pose (the URDF, where the
  scan matching starts) off that by up to +-``--urdf-error-mm`` (20) in x and y and
  +-``--urdf-error-deg`` (2) in yaw, as a pose taken from a drawing is;
- a full-circle lidar of 180-720 beams at 5-15 Hz (first scan at a random offset), range noise
  5-15 mm, 0-1 % of the beams without a return, range 12 m;
- the wheels sampled at 50 or 100 Hz with encoder quantisation of 2048, 4096, 8192 or 16384
  pulses per wheel revolution, wheel-speed jitter of 0.5-3 % per sample (seen by the
  encoders) and random slip of 1e-4 to 5e-4 m per sqrt(m) of travel (not seen);
- 2-5 minutes (``--minutes``) of :func:`umbmark.model.drive.mixed_program` (straights, arcs
  both ways, spins both ways, pauses, planned along the true geometry to stay 0.6 m from the
  walls, as ``benchmarks/selfcal_bag.py`` drives) in one of three rooms: the simulator's
  10 x 8 m test room (:meth:`umbmark.model.sensors.Room.default`), a 7 x 5.5 m office and a
  14 x 9 m hall with pillars; the program is driven 0.6 to 1.1 times as fast as planned (the
  same path: every command's duration divided and its speeds multiplied by the factor), so the
  top speeds are 0.24-0.44 m/s and 0.7-1.3 rad/s.

The simulator's commands change speed at once (no acceleration) and its scans are
instantaneous (no motion during the sweep).

Reported per parameter (D_L, D_R, wheelbase, E_d, E_b, lidar x, y, yaw): the fraction of the
calibrated bags whose truth lies inside the printed 95 % interval, with its Clopper-Pearson
95 % interval; the median, 90th and 95th percentiles of the normalised error, |error| over the
distance from the estimate to the interval's end on the error's side (the half-width of a
symmetric interval; at most 1 inside the interval; 0.34 and 0.84 are the median and 90th
percentile for honest Gaussian intervals, the 95th percentile is the factor the intervals
would need for 95 % coverage); its median signed value and the fraction of positive errors
(a bias shows as both far from 0 and 0.5); the median signed error and the median and 90th
percentile of |error|, relative to the truth (D_L, D_R, wheelbase, E_d, E_b) or in mm and
degrees (the lidar pose, whose truth may be near zero); the bags that failed or warned and why
(the messages with their numbers replaced by ``#``, counted; the /tf_static pose warning is
expected, the draw puts the URDF off); and the bags with a parameter outside its interval by
room, range noise, beams, scan rate, speed, drive length and encoder resolution.

The 10 mm case (``--case-seeds``, default 5 drives): the LabMate of
``benchmarks/selfcal_bag.py`` (wheels 150 mm, wheelbase 340 mm nominal; E_d 1.01, E_b 1.03,
E_s 0.99; lidar at x 120 mm, y -30 mm, yaw 2 deg, in /tf_static; 2 % speed jitter, slip
3.35e-4 m per sqrt(m)) with a 360-beam lidar of 10 mm range noise at 10 Hz, 2.3 minutes in the
test room; each parameter's relative error and whether the truth lies in its interval, against
the target: D_L, D_R and the wheelbase within 0.15 % with the truth inside the intervals.

Bags run in ``--jobs`` worker processes (default: the cores available), each holding one drive
at a time (a worker and a calibration each peak near 260 MB); BLAS, OpenMP and numba use one
thread each. Measured on 2 cores (AMD EPYC): the default run (65 bags, 2-5 minute drives, not
shortened) takes 4.7 minutes on an otherwise idle machine and 7.5 minutes with other jobs on
the cores; a calibration takes 3-15 s (up to 19 s under that load). The results name the umbmark source
the calibrations ran (its folder, git commit and uncommitted changes, and whether it changed
during the run): run from a clean checkout (``PYTHONPATH=<checkout>/src``) to measure a commit
while the working tree is being edited. Writes selfcal_coverage.json (every bag's draw, truth,
result and timing, and the summaries) and selfcal_coverage.md into ``--out`` (created if
missing).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import re  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

JOINTS = "left_wheel_joint,right_wheel_joint"
ROOMS = ("test room", "office", "hall")
PULSES_PER_WHEEL_REV = (2048, 4096, 8192, 16384)
# (name, JSON key, unit of the absolute error, relative error reported)
PARAMETERS = (
    ("wheel_diameter_left_mm", "wheel_diameter_left_mm", "mm", True),
    ("wheel_diameter_right_mm", "wheel_diameter_right_mm", "mm", True),
    ("wheelbase_mm", "wheelbase_mm", "mm", True),
    ("Ed", "Ed", "", True),
    ("Eb", "Eb", "", True),
    ("sensor_x_mm", "x_mm", "mm", False),
    ("sensor_y_mm", "y_mm", "mm", False),
    ("sensor_yaw_deg", "yaw_deg", "deg", False),
)
TARGET_REL = 0.0015  # the 10 mm case: diameters and wheelbase within 0.15 % of the truth
TARGET_COVERAGE = 0.90
CASE_MINUTES = 2.3
SELFCAL_TIMEOUT_S = 1800.0  # a calibration still running after this is a failure


# ---------------------------------------------------------------- rooms
def _box_segments(cx_m: float, cy_m: float, length_m: float, width_m: float, yaw_deg: float = 0.0) -> np.ndarray:
    """The four walls ``(4, 4)`` of a ``length_m`` x ``width_m`` box centred at (cx_m, cy_m)."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float) * [length_m / 2, width_m / 2]
    v = np.column_stack([cx_m + c * half[:, 0] - s * half[:, 1], cy_m + s * half[:, 0] + c * half[:, 1]])
    return np.column_stack([v, np.roll(v, -1, axis=0)])


def _room(outline: list[tuple[float, float]], inside: list[np.ndarray]):
    from umbmark.model.sensors import Room

    v = np.array(outline, dtype=float)
    return Room(np.vstack([np.column_stack([v, np.roll(v, -1, axis=0)]), *inside]), v)


def room(name: str):
    """One of :data:`ROOMS` as a :class:`umbmark.model.sensors.Room`.

    Parameters
    ----------
    name : str
        ``"test room"`` (the simulator's :meth:`~umbmark.model.sensors.Room.default`), ``"office"``
        (7 x 5.5 m: a desk, a cabinet, a pillar, a door niche) or ``"hall"`` (14 x 9 m with a cut
        corner, four pillars, two shelves and a crate turned by 20 degrees).

    Returns
    -------
    Room
    """
    from umbmark.model.sensors import Room

    if name == "test room":
        return Room.default()
    if name == "office":
        outline = [(0, 0), (7, 0), (7, 5.5), (4.2, 5.5), (4.2, 5.9), (3.3, 5.9), (3.3, 5.5), (0, 5.5)]
        inside = [
            _box_segments(1.1, 4.5, 1.6, 0.8),  # desk
            _box_segments(6.6, 1.2, 0.5, 1.4),  # cabinet
            _box_segments(5.3, 3.9, 0.3, 0.3),  # pillar
            np.array([[0.0, 1.6, 0.9, 1.6]]),  # stub wall
        ]
        return _room(outline, inside)
    if name == "hall":
        outline = [(0, 0), (14, 0), (14, 7.2), (12.2, 9), (0, 9)]
        inside = [
            *(_box_segments(x, y, 0.4, 0.4) for x, y in ((3.5, 2.5), (10.5, 2.5), (3.5, 6.5), (10.5, 6.8))),
            _box_segments(7.0, 0.5, 3.0, 0.5),  # shelf along the bottom wall
            _box_segments(0.6, 5.5, 0.6, 2.2),  # shelf along the left wall
            _box_segments(12.0, 4.5, 1.2, 0.8, 20.0),  # crate
        ]
        return _room(outline, inside)
    raise ValueError(name)


# ---------------------------------------------------------------- the draws
def draw_bag(seed: int, index: int, minutes: tuple[float, float], urdf_mm: float, urdf_deg: float) -> dict:
    """The robot, lidar, noise and drive of coverage bag ``index`` (SI units; see the module docstring).

    Parameters
    ----------
    seed : int
        The run's seed.
    index : int
        The bag's number.
    minutes : (float, float)
        The range of the drive's length [min].
    urdf_mm, urdf_deg : float
        The largest error of the /tf_static pose in x and y [mm] and in yaw [deg].

    Returns
    -------
    dict
        The draw: every figure :func:`simulate` needs.
    """
    rng = np.random.default_rng([seed, index])
    d_nom_m = round(rng.uniform(100.0, 200.0)) * 1e-3
    b_nom_m = round(rng.uniform(250.0, 500.0)) * 1e-3
    x_m, y_m, yaw_rad = rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1), math.radians(rng.uniform(-5.0, 5.0))
    return {
        "kind": "coverage",
        "index": index,
        "nominal_diameter_m": d_nom_m,
        "nominal_wheelbase_m": b_nom_m,
        "diameter_left_m": d_nom_m * (1.0 + rng.uniform(-0.03, 0.03)),
        "diameter_right_m": d_nom_m * (1.0 + rng.uniform(-0.03, 0.03)),
        "wheelbase_m": b_nom_m * (1.0 + rng.uniform(-0.05, 0.05)),
        "sensor_x_m": x_m,
        "sensor_y_m": y_m,
        "sensor_yaw_rad": yaw_rad,
        "urdf_x_m": x_m + rng.uniform(-1.0, 1.0) * urdf_mm * 1e-3,
        "urdf_y_m": y_m + rng.uniform(-1.0, 1.0) * urdf_mm * 1e-3,
        "urdf_yaw_rad": yaw_rad + math.radians(rng.uniform(-1.0, 1.0) * urdf_deg),
        "beams": int(rng.integers(180, 721)),
        "range_noise_m": rng.uniform(0.005, 0.015),
        "dropout_prob": rng.uniform(0.0, 0.01),
        "scan_rate_hz": round(rng.uniform(5.0, 15.0), 1),
        "scan_offset_frac": rng.uniform(0.0, 1.0),
        "wheel_rate_hz": float(rng.choice([50.0, 100.0])),
        "pulses_per_wheel_rev": int(rng.choice(PULSES_PER_WHEEL_REV)),
        "speed_rel_sd": rng.uniform(0.005, 0.03),
        "slip_m_per_sqrt_m": rng.uniform(1e-4, 5e-4),
        "duration_s": round(60.0 * rng.uniform(*minutes), 1),
        "speed_factor": rng.uniform(0.6, 1.1),
        "room": ROOMS[int(rng.integers(len(ROOMS)))],
        "program_seed": int(rng.integers(2**31)),
        "drive_seed": int(rng.integers(2**31)),
    }


def draw_case(seed: int, index: int) -> dict:
    """The 10 mm case, drive ``index``: the LabMate of ``benchmarks/selfcal_bag.py`` with 10 mm range noise.

    Parameters
    ----------
    seed : int
        The run's seed.
    index : int
        The drive's number.

    Returns
    -------
    dict
        As :func:`draw_bag`.
    """
    from umbmark.model.geometry import LABMATE, ErrorParams

    rng = np.random.default_rng([seed, 1_000_000 + index])
    d_left_m, d_right_m = ErrorParams(ed=1.01, eb=1.03, es=0.99).diameters_m(LABMATE)
    yaw_rad = math.radians(2.0)
    return {
        "kind": "case10",
        "index": index,
        "nominal_diameter_m": LABMATE.wheel_diameter_m,
        "nominal_wheelbase_m": LABMATE.wheelbase_m,
        "diameter_left_m": d_left_m,
        "diameter_right_m": d_right_m,
        "wheelbase_m": 1.03 * LABMATE.wheelbase_m,
        "sensor_x_m": 0.120,
        "sensor_y_m": -0.030,
        "sensor_yaw_rad": yaw_rad,
        "urdf_x_m": 0.120,
        "urdf_y_m": -0.030,
        "urdf_yaw_rad": yaw_rad,
        "beams": 360,
        "range_noise_m": 0.010,
        "dropout_prob": 0.0,
        "scan_rate_hz": 10.0,
        "scan_offset_frac": 0.0,
        "wheel_rate_hz": 100.0,
        "pulses_per_wheel_rev": None,
        "speed_rel_sd": 0.02,
        "slip_m_per_sqrt_m": 3.35e-4,
        "duration_s": 60.0 * CASE_MINUTES,
        "speed_factor": 1.0,
        "room": "test room",
        "program_seed": int(rng.integers(2**31)),
        "drive_seed": int(rng.integers(2**31)),
    }


# ---------------------------------------------------------------- one bag
def simulate(cfg: dict):
    """Drive the draw: the :class:`umbmark.model.drive.DriveLog` (its sensor pose the true one).

    Parameters
    ----------
    cfg : dict
        A draw of :func:`draw_bag` or :func:`draw_case`.

    Returns
    -------
    DriveLog
    """
    from umbmark.model.drive import Command, Program, SimRobot, WheelNoise, mixed_program, simulate_drive
    from umbmark.model.geometry import ErrorParams, Geometry
    from umbmark.model.sensors import Lidar, SensorPose

    pulses = cfg["pulses_per_wheel_rev"]
    nominal = Geometry(
        wheel_diameter_m=cfg["nominal_diameter_m"],
        wheelbase_m=cfg["nominal_wheelbase_m"],
        pulses_per_motor_rev=float(pulses) if pulses else 1000.0,
        gear_ratio=1.0,
    )
    d_l, d_r = cfg["diameter_left_m"], cfg["diameter_right_m"]
    errors = ErrorParams(
        ed=d_r / d_l,
        eb=cfg["wheelbase_m"] / cfg["nominal_wheelbase_m"],
        es=0.5 * (d_l + d_r) / nominal.wheel_diameter_m,
    )
    robot = SimRobot(
        nominal=nominal,
        errors=errors,
        sensor_pose=SensorPose(cfg["sensor_x_m"], cfg["sensor_y_m"], cfg["sensor_yaw_rad"]),
        lidar=Lidar(n_beams=cfg["beams"], range_noise_m=cfg["range_noise_m"], dropout_prob=cfg["dropout_prob"]),
    )
    k = cfg["speed_factor"]
    the_room = room(cfg["room"])
    # planned on a grid of 0.1 k s and driven k times as fast: the same path, durations in whole 0.1 s
    planned = mixed_program(cfg["duration_s"] * k, seed=cfg["program_seed"], robot=robot, room=the_room, step_s=0.1 * k)
    prog = Program(
        tuple(Command(c.duration_s / k, c.v_mps * k, c.omega_radps * k) for c in planned.commands), planned.start_pose
    )
    noise = WheelNoise(
        speed_rel_sd=cfg["speed_rel_sd"], slip_m_per_sqrt_m=cfg["slip_m_per_sqrt_m"], quantise=pulses is not None
    )
    return simulate_drive(
        prog,
        robot,
        the_room,
        wheel_rate_hz=cfg["wheel_rate_hz"],
        scan_rate_hz=cfg["scan_rate_hz"],
        scan_offset_s=cfg["scan_offset_frac"] / cfg["scan_rate_hz"],
        noise=noise,
        seed=cfg["drive_seed"],
    )


def truth_of(log, cfg: dict) -> dict:
    """The true value of every reported parameter, in the units of the JSON."""
    g, p = log.true_geometry, log.sensor_pose
    return {
        "wheel_diameter_left_mm": g.diameter_left_m * 1e3,
        "wheel_diameter_right_mm": g.diameter_right_m * 1e3,
        "wheelbase_mm": g.wheelbase_m * 1e3,
        "Ed": g.diameter_right_m / g.diameter_left_m,
        "Eb": g.wheelbase_m / cfg["nominal_wheelbase_m"],
        "sensor_x_mm": p.x_m * 1e3,
        "sensor_y_mm": p.y_m * 1e3,
        "sensor_yaw_deg": math.degrees(p.yaw_rad),
    }


def selfcal_command(bag: Path, cfg: dict) -> list[str]:
    """``umbmark selfcal BAG --joints ... --wheel-diameter-mm D --wheelbase-mm B --json`` as a new process."""
    return [
        sys.executable,
        "-m",
        "umbmark",
        "selfcal",
        str(bag),
        "--joints",
        JOINTS,
        "--wheel-diameter-mm",
        f"{cfg['nominal_diameter_m'] * 1e3:.10g}",
        "--wheelbase-mm",
        f"{cfg['nominal_wheelbase_m'] * 1e3:.10g}",
        "--json",
    ]


def compare(d: dict, truth: dict) -> dict:
    """Per parameter: estimate, interval, truth, error, normalised error, inside or not.

    The normalised error is the error over the distance from the estimate to the interval's end
    on the error's side: its magnitude is at most 1 exactly when the truth is inside.
    """
    out = {}
    for name, key, _, _ in PARAMETERS:
        src = d["sensor_pose"] if name.startswith("sensor_") else d
        est, ci, true = src.get(key), src.get(key + "_ci95"), truth[name]
        row = {"estimate": est, "ci95": ci, "truth": true, "error": None, "z": None, "inside": False}
        if est is not None and math.isfinite(est):
            err = est - true
            row["error"] = err
            if ci is not None and all(v is not None and math.isfinite(v) for v in ci):
                lo, hi = ci
                row["inside"] = bool(lo <= true <= hi)
                side = est - lo if err > 0 else hi - est  # the truth lies below the estimate when err > 0
                row["z"] = err / side if side > 0 else (0.0 if err == 0 else math.copysign(math.inf, err))
                row["half_width"] = 0.5 * (hi - lo)
        out[name] = row
    return out


def _max_rss_mb(who: int) -> float:
    return resource.getrusage(who).ru_maxrss / 1024.0  # kB on Linux


def one_bag(cfg: dict, tmp_root: str | None = None) -> dict:
    """Simulate, write, calibrate (the command) and compare one bag; the bag is deleted after.

    Parameters
    ----------
    cfg : dict
        A draw of :func:`draw_bag` or :func:`draw_case`.
    tmp_root : str, optional
        Where the temporary bag folder is made (default: the system's).

    Returns
    -------
    dict
        ``config``; ``status`` (``ok``, ``failed`` or ``simulation failed``); ``message`` (the
        command's error line); the drive's ``scans``; ``timing_s`` (``simulate``, ``write_bag``,
        ``selfcal``), ``bag_mb``; the result's ``warnings``, ``pairs_matched``, ``pairs_failed``,
        ``failure_reasons``, ``intervals_used``, ``intervals_rejected``; ``parameters``
        (:func:`compare`); the peak memory of the worker and of the command.
    """
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.sensors import SensorPose

    row: dict = {"config": cfg, "status": "ok", "message": None, "timing_s": {}}
    t0 = time.perf_counter()
    try:
        log = simulate(cfg)
    except Exception as e:  # a drive that cannot be planned is reported, not fatal
        row.update(status="simulation failed", message=f"{type(e).__name__}: {e}")
        return row
    t1 = time.perf_counter()
    row["timing_s"]["simulate"] = t1 - t0
    row["scans"] = int(len(log.scan_t_s))
    truth = truth_of(log, cfg)
    urdf = SensorPose(cfg["urdf_x_m"], cfg["urdf_y_m"], cfg["urdf_yaw_rad"])
    with tempfile.TemporaryDirectory(prefix="selfcal-coverage-", dir=tmp_root) as tmp:
        bag = write_drive_bag(
            dataclasses.replace(log, sensor_pose=urdf), Path(tmp) / "drive", storage="mcap", odom=False
        )
        del log
        t2 = time.perf_counter()
        row["timing_s"]["write_bag"] = t2 - t1
        row["bag_mb"] = sum(f.stat().st_size for f in bag.rglob("*") if f.is_file()) / 1e6
        cmd = selfcal_command(bag, cfg)
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=SELFCAL_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            row["timing_s"]["selfcal"] = time.perf_counter() - t2
            row.update(status="failed", message=f"no result within {SELFCAL_TIMEOUT_S:g} s")
            return row
        row["timing_s"]["selfcal"] = time.perf_counter() - t2
    row["exit_status"] = proc.returncode
    row["worker_max_rss_mb"] = _max_rss_mb(resource.RUSAGE_SELF)
    row["selfcal_max_rss_mb"] = _max_rss_mb(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        lines = [s for s in proc.stderr.strip().splitlines() if s.strip()]
        row.update(status="failed", message=lines[-1] if lines else f"exit status {proc.returncode}")
        return row
    try:
        d = json.loads(proc.stdout)
        row["parameters"] = compare(d, truth)
    except (ValueError, KeyError, TypeError) as e:
        row.update(status="failed", message=f"unreadable JSON: {type(e).__name__}: {e}")
        return row
    row["warnings"] = list(d.get("warnings") or [])
    for key in ("pairs_matched", "pairs_failed", "intervals_still", "intervals_used", "scans_read"):
        row[key] = d.get(key)
    row["intervals_rejected"] = len(d.get("intervals_rejected") or [])
    reasons: Counter = Counter()
    for inp in d.get("inputs") or []:
        reasons.update(inp.get("failure_reasons") or {})
    row["failure_reasons"] = dict(reasons)
    return row


# ---------------------------------------------------------------- summaries
def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) binomial interval of a fraction ``k / n``.

    Parameters
    ----------
    k, n : int
        Successes and trials (``n`` > 0).
    level : float
        The interval's coverage.

    Returns
    -------
    (float, float)
        Its low and high end.
    """
    from scipy.stats import beta

    a = 0.5 * (1.0 - level)
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return lo, hi


def _template(message: str) -> str:
    """A warning or error with its numbers replaced by ``#`` (so like messages count together)."""
    return re.sub(r"[-+]?\d+(?:[.,]\d+)*(?:e[-+]?\d+)?", "#", message)


def _pct(values: list[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def summarise(rows: list[dict]) -> dict:
    """Coverage and error statistics per parameter, failures and warnings, over the coverage bags."""
    ok = [r for r in rows if r["status"] == "ok"]
    per: dict = {}
    for name, _, unit, relative in PARAMETERS:
        ps = [r["parameters"][name] for r in ok]
        inside = sum(p["inside"] for p in ps)
        n = len(ps)
        z = [p["z"] for p in ps if p["z"] is not None]
        az = [abs(v) for v in z]
        err = [p["error"] for p in ps if p["error"] is not None]
        rel = [abs(p["error"] / p["truth"]) for p in ps if p["error"] is not None and p["truth"] != 0]
        half = [p["half_width"] for p in ps if p.get("half_width") is not None]
        lo, hi = clopper_pearson(inside, n) if n else (None, None)
        per[name] = {
            "bags": n,
            "inside": inside,
            "coverage": inside / n if n else None,
            "coverage_ci95": [lo, hi],
            "no_interval": sum(p["z"] is None for p in ps),
            "z_abs_median": _pct(az, 50),
            "z_abs_p90": _pct(az, 90),
            "z_abs_p95": _pct(az, 95),
            "z_median": _pct(z, 50),
            "z_mean": float(np.mean([v for v in z if math.isfinite(v)])) if z else None,
            "positive_fraction": float(np.mean([e > 0 for e in err])) if err else None,
            "rel_error_median": _pct(rel, 50) if relative else None,
            "signed_rel_error_median": (
                _pct([p["error"] / p["truth"] for p in ps if p["error"] is not None and p["truth"] != 0], 50)
                if relative
                else None
            ),
            "signed_error_median": _pct(err, 50),
            "rel_error_p90": _pct(rel, 90) if relative else None,
            "abs_error_median": _pct([abs(e) for e in err], 50),
            "abs_error_p90": _pct([abs(e) for e in err], 90),
            "half_width_median": _pct(half, 50),
            "unit": unit,
        }
    warn = Counter()
    for r in ok:
        warn.update({_template(w) for w in r["warnings"]})
    fails = Counter(_template(r["message"] or "") for r in rows if r["status"] != "ok")
    tf_only = lambda w: w.startswith("the estimated sensor pose differs from /tf_static")  # noqa: E731
    reasons: Counter = Counter()
    for r in ok:
        reasons.update(r.get("failure_reasons") or {})
    times = [r["timing_s"]["selfcal"] for r in ok]
    return {
        "bags": len(rows),
        "calibrated": len(ok),
        "failed": len(rows) - len(ok),
        "failures": dict(fails.most_common()),
        "warned": sum(bool(r["warnings"]) for r in ok),
        "warned_other_than_tf_static": sum(any(not tf_only(w) for w in r["warnings"]) for r in ok),
        "warnings": dict(warn.most_common()),
        "bags_all_inside": sum(all(p["inside"] for p in r["parameters"].values()) for r in ok),
        "pairs_failed_total": int(sum(r.get("pairs_failed") or 0 for r in ok)),
        "pairs_matched_total": int(sum(r.get("pairs_matched") or 0 for r in ok)),
        "match_failure_reasons": dict(reasons.most_common()),
        "selfcal_s_median": _pct(times, 50),
        "selfcal_s_max": max(times) if times else None,
        "parameters": per,
    }


def by_condition(rows: list[dict], minutes: tuple[float, float]) -> list[dict]:
    """The bags with a parameter outside its interval, by room, noise, beams, scan rate, speed, length, encoder.

    Parameters
    ----------
    rows : list of dict
        The coverage bags (:func:`one_bag`).
    minutes : (float, float)
        The range of the drives' lengths [min].

    Returns
    -------
    list of dict
        Per condition and group (thirds of the drawn range, or the values drawn): ``bags``,
        ``bags_with_a_miss`` and ``misses`` per parameter.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    groups = [
        ("room", lambda c: c["room"], ROOMS),
        ("range noise", lambda c: _third(c["range_noise_m"] * 1e3, 5.0, 15.0, "mm"), None),
        ("beams", lambda c: _third(c["beams"], 180, 720, ""), None),
        ("scan rate", lambda c: _third(c["scan_rate_hz"], 5.0, 15.0, "Hz"), None),
        ("speed factor", lambda c: _third(c["speed_factor"], 0.6, 1.1, ""), None),
        ("drive", lambda c: _third(c["duration_s"] / 60.0, *minutes, "min"), None),
        ("pulses per wheel rev", lambda c: str(c["pulses_per_wheel_rev"]), None),
    ]
    out = []
    for label, key, order in groups:
        counts: dict = {}
        for r in ok:
            entry = counts.setdefault(key(r["config"]), [0, 0, Counter()])
            outside = [name for name, p in r["parameters"].items() if not p["inside"]]
            entry[0] += 1
            entry[1] += bool(outside)
            entry[2].update(outside)
        for g in [k for k in (order or sorted(counts, key=_sort_key)) if k in counts]:
            n, miss, miss_by = counts[g]
            out.append({"by": label, "group": g, "bags": n, "bags_with_a_miss": miss, "misses": dict(miss_by)})
    return out


def _third(v: float, lo: float, hi: float, unit: str) -> str:
    """The third of ``[lo, hi]`` that ``v`` lies in, as ``a-b unit``."""
    edges = np.linspace(lo, hi, 4)
    k = int(np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 2))
    return f"{edges[k]:.3g}-{edges[k + 1]:.3g}{(' ' + unit) if unit else ''}"


def _sort_key(g: str):
    m = re.match(r"[-+]?\d+(?:\.\d+)?", g)
    return (0, float(m.group())) if m else (1, g)


def summarise_case(rows: list[dict]) -> dict:
    """The 10 mm case: per drive and parameter the relative error and whether the truth is inside."""
    drives = []
    for r in rows:
        item = {"index": r["config"]["index"], "status": r["status"], "message": r["message"]}
        if r["status"] == "ok":
            item["parameters"] = {
                name: {
                    "rel_error": (p["error"] / p["truth"]) if p["error"] is not None and p["truth"] else None,
                    "error": p["error"],
                    "inside": p["inside"],
                    "z": p["z"],
                }
                for name, p in r["parameters"].items()
            }
            core = ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm")
            item["within_target"] = all(
                item["parameters"][k]["rel_error"] is not None and abs(item["parameters"][k]["rel_error"]) <= TARGET_REL
                for k in core
            )
            item["all_inside"] = all(p["inside"] for p in r["parameters"].values())
            item["warnings"] = r["warnings"]
            item["selfcal_s"] = r["timing_s"]["selfcal"]
        drives.append(item)
    good = [d for d in drives if d["status"] == "ok"]
    return {
        "drives": drives,
        "meets_target": sum(d["within_target"] and d["all_inside"] for d in good),
        "within_target": sum(d["within_target"] for d in good),
        "all_inside": sum(d["all_inside"] for d in good),
        "calibrated": len(good),
    }


# ---------------------------------------------------------------- the page
def _f(v, digits: int = 3, pct: bool = False) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if pct:
        x = 100 * v
        return f"{x:.0f} %" if abs(x) >= 10**digits else f"{x:.{digits}g} %"
    return f"{v:.{digits}g}"


def _code_text(c: dict) -> str:
    head = f"Code: umbmark from `{c['source']}`"
    if c["commit"]:
        head += f", commit {c['commit'][:12]}"
        head += (
            f" with {len(c['modified'])} uncommitted changes there ({'; '.join(m.strip() for m in c['modified'])})"
            if c["modified"]
            else ", no uncommitted changes"
        )
    if c["changed_during_run"]:
        head += "; **the source changed during the run**"
    return head + "."


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    s, cs, st = res["summary"], res["case10"], res["settings"]
    lines = [
        "# Lidar self-calibration: do the 95 % intervals hold the truth?",
        "",
        machine_text(res["machine"], f"{st['jobs']} worker processes"),
        "",
        _code_text(res["code"]),
        "",
        f"Command: `{res['command']}`. Wall-clock time {res['seconds'] / 60:.1f} min "
        f"(the calibrations: median {_f(s['selfcal_s_median'])} s, longest {_f(s['selfcal_s_max'])} s per bag, "
        f"`umbmark selfcal BAG --joints {JOINTS} --wheel-diameter-mm D --wheelbase-mm B --json` in a new process, "
        f"default settings; peak memory of a worker {res['max_rss_mb']['worker']:.0f} MB, of a calibration "
        f"{res['max_rss_mb']['selfcal']:.0f} MB).",
        "",
        f"{s['bags']} simulated bags (seed {st['seed']}), each a different robot and drive: nominal wheels "
        "100-200 mm and wheelbase 250-500 mm, true wheels +-3 % and wheelbase +-5 % off; lidar at x +-200 mm, "
        f"y +-100 mm, yaw +-5 deg (/tf_static off that by up to {st['urdf_error_mm']:g} mm, "
        f"{st['urdf_error_deg']:g} deg); 180-720 beams at 5-15 Hz, 5-15 mm range noise, 0-1 % dropouts; "
        "joint states at 50 or 100 Hz, 2048-16384 pulses per wheel revolution, 0.5-3 % speed jitter, "
        f"slip 1e-4 to 5e-4 m per sqrt(m); {st['minutes'][0]:g}-{st['minutes'][1]:g} minutes of straights, arcs "
        "and spins both ways at 0.6-1.1 times the planned speeds, in the 10 x 8 m test room, a 7 x 5.5 m office "
        "or a 14 x 9 m hall (see the script's docstring).",
        "",
        f"Calibrated: {s['calibrated']} of {s['bags']}; failed: {s['failed']}; all eight truths inside their "
        f"intervals: {s['bags_all_inside']} of {s['calibrated']}. Scan pairs: {s['pairs_matched_total']:,} "
        f"matched, {s['pairs_failed_total']:,} failed.",
        "",
        "## Coverage",
        "",
        "cover: share of the bags whose truth is inside the printed 95 % interval (Clopper-Pearson 95 % "
        "interval); |z|: |error| over the distance from the estimate to the interval's end on the error's side "
        "(the half-width of a symmetric interval; inside: at most 1; honest Gaussian intervals: median 0.34, "
        "90th percentile 0.84; the 95th percentile is the factor the intervals would need); median z and "
        "error > 0: the sign of the errors (a bias: far from 0 and from 50 %); median error (signed), |error|: "
        "relative to the truth, for the lidar pose in mm and deg.",
        "",
        "| parameter | cover | its 95 % interval | \\|z\\| median | \\|z\\| p90 | \\|z\\| p95 | median z | error > 0 "
        "| median error | \\|error\\| median | \\|error\\| p90 | half-width median |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, p in s["parameters"].items():
        lo, hi = p["coverage_ci95"]
        flag = "" if p["coverage"] is not None and p["coverage"] >= TARGET_COVERAGE else " **<90 %**"
        if p["rel_error_median"] is not None:
            em, e90 = _f(p["rel_error_median"], 2, True), _f(p["rel_error_p90"], 2, True)
            es = _f(p["signed_rel_error_median"], 2, True)
        else:
            em, e90 = f"{_f(p['abs_error_median'])} {p['unit']}", f"{_f(p['abs_error_p90'])} {p['unit']}"
            es = f"{_f(p['signed_error_median'], 2)} {p['unit']}"
        lines.append(
            f"| {name} | {p['inside']}/{p['bags']} = {_f(p['coverage'], 3, True)}{flag} | "
            f"{_f(lo, 3, True)} to {_f(hi, 3, True)} | {_f(p['z_abs_median'])} | {_f(p['z_abs_p90'])} | "
            f"{_f(p['z_abs_p95'])} | {_f(p['z_median'], 2)} | {_f(p['positive_fraction'], 2, True)} | {es} | {em} | "
            f"{e90} | "
            f"{_f(p['half_width_median'])}{(' ' + p['unit']) if p['unit'] else ''} |"
        )
    miss = [n for n, p in s["parameters"].items() if p["coverage"] is None or p["coverage"] < TARGET_COVERAGE]
    lines += [
        "",
        f"Below the aim of {TARGET_COVERAGE:.0%} coverage: {', '.join(miss) if miss else 'none'}.",
        "",
        "## Failures and warnings",
        "",
        f"Failed bags: {s['failed']}" + (":" if s["failures"] else "."),
    ]
    lines += [f"- {n} x {m}" for m, n in s["failures"].items()]
    lines += [
        "",
        f"Bags with warnings: {s['warned']} of {s['calibrated']} ({s['warned_other_than_tf_static']} with a "
        "warning other than the /tf_static one, which the URDF error of the draw makes expected)"
        + (":" if s["warnings"] else "."),
    ]
    lines += [f"- {n} x {m}" for m, n in s["warnings"].items()]
    if s["match_failure_reasons"]:
        lines += [
            "",
            "Failed scan matches by reason: " + "; ".join(f"{n} {m}" for m, n in s["match_failure_reasons"].items()),
        ]
    lines += [
        "",
        "## Misses by condition",
        "",
        "Bags with at least one parameter outside its interval, and which parameters.",
        "",
        "| by | group | bags | with a miss | misses |",
        "|---|---|---|---|---|",
    ]
    for g in res["by_condition"]:
        m = ", ".join(f"{k} {v}" for k, v in sorted(g["misses"].items(), key=lambda kv: -kv[1]))
        lines.append(f"| {g['by']} | {g['group']} | {g['bags']} | {g['bags_with_a_miss']} | {m or '-'} |")
    lines += [
        "",
        "## The 10 mm case",
        "",
        f"The LabMate of `benchmarks/selfcal_bag.py` (150 / 340 mm nominal, E_d 1.01, E_b 1.03, E_s 0.99, lidar at "
        f"120, -30 mm, 2 deg), 360 beams with 10 mm range noise at 10 Hz, {CASE_MINUTES:g} minutes in the test room, "
        f"{len(cs['drives'])} drives (seeds of the run). Target: D_L, D_R and the wheelbase within "
        f"{100 * TARGET_REL:g} % of the truth, every truth inside its interval. Met by {cs['meets_target']} of "
        f"{len(cs['drives'])} (within {100 * TARGET_REL:g} %: {cs['within_target']}; all inside: "
        f"{cs['all_inside']}). Relative error (lidar pose: error in mm, deg), then z (|z| > 1: outside).",
        "",
        "| parameter | " + " | ".join(f"drive {d['index']}" for d in cs["drives"]) + " |",
        "|---|" + "---|" * len(cs["drives"]),
    ]
    for name, _, unit, relative in PARAMETERS:
        cells = []
        for d in cs["drives"]:
            if d["status"] != "ok":
                cells.append(d["status"])
                continue
            p = d["parameters"][name]
            e = _f(p["rel_error"], 2, True) if relative else f"{_f(p['error'], 2)} {unit}"
            mark = "" if p["inside"] else " **out**"
            cells.append(f"{e}, z {_f(p['z'], 2)}{mark}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    warned = [d for d in cs["drives"] if d.get("warnings")]
    if warned:
        lines += ["", "Warnings: " + "; ".join(f"drive {d['index']}: {' / '.join(d['warnings'])}" for d in warned)]
    failed = [d for d in cs["drives"] if d["status"] != "ok"]
    if failed:
        lines += ["", "Failed: " + "; ".join(f"drive {d['index']}: {d['message']}" for d in failed)]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- the run
def _git(src: Path, *args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(src), *args], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout if out.returncode == 0 else None


def code_state() -> dict:
    """Which umbmark the calibrations run: its source folder, the git commit and what differs from it.

    Returns
    -------
    dict
        ``source`` (the folder ``umbmark`` is imported from), ``commit`` (``None`` outside a git
        checkout), ``modified`` (the ``git status --porcelain`` lines of that folder) and
        ``diff_sha256`` (of the uncommitted changes and the untracked files' names there: equal
        before and after a run when the code did not change during it).
    """
    import hashlib

    import umbmark

    src = Path(umbmark.__file__).resolve().parent.parent
    commit = _git(src, "rev-parse", "HEAD")
    status = _git(src, "status", "--porcelain", "--", ".")
    diff = (_git(src, "diff", "HEAD", "--", ".") or "") + (
        _git(src, "ls-files", "--others", "--exclude-standard", "--", ".") or ""
    )
    return {
        "source": str(src),
        "commit": commit.strip() if commit else None,
        "modified": status.splitlines() if status else [],
        "diff_sha256": hashlib.sha256(diff.encode()).hexdigest(),
    }


def _work(item: tuple[dict, str | None]) -> dict:
    return one_bag(*item)


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bags", type=int, default=60, help="simulated bags (default 60)")
    p.add_argument("--seed", type=int, default=2024, help="seed of the draws (default 2024)")
    p.add_argument(
        "--minutes", default="2,5", metavar="MIN,MAX", help="range of the drives' lengths in minutes (default 2,5)"
    )
    p.add_argument("--case-seeds", type=int, default=5, help="drives of the 10 mm case (default 5; 0: none)")
    p.add_argument("--urdf-error-mm", type=float, default=20.0, help="largest /tf_static error in x and y (20 mm)")
    p.add_argument("--urdf-error-deg", type=float, default=2.0, help="largest /tf_static error in yaw (2 deg)")
    default_jobs = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    p.add_argument("--jobs", type=int, default=default_jobs, help=f"worker processes (default {default_jobs})")
    p.add_argument("--tmp", default=None, help="folder of the temporary bags (default: the system's)")
    add_out(p, "selfcal-coverage")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (see the module docstring), write its results, print the page; 0 on success."""
    a = parser().parse_args(argv)
    try:
        minutes = tuple(float(v) for v in a.minutes.split(","))
    except ValueError:
        minutes = ()
    if len(minutes) != 2 or not (0 < minutes[0] <= minutes[1]):
        print("error: --minutes must be MIN,MAX with 0 < MIN <= MAX", file=sys.stderr)
        return 2
    if a.bags < 1 or a.jobs < 1 or a.case_seeds < 0:
        print("error: --bags and --jobs must be at least 1, --case-seeds at least 0", file=sys.stderr)
        return 2
    info = machine("numba", "scipy", "rosbags")
    code_before = code_state()
    cfgs = [draw_case(a.seed, i) for i in range(a.case_seeds)]
    cfgs += [draw_bag(a.seed, i, minutes, a.urdf_error_mm, a.urdf_error_deg) for i in range(a.bags)]
    t0 = time.perf_counter()
    rows: list[dict] = []
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(a.jobs, maxtasksperchild=8) as pool:
        for i, row in enumerate(pool.imap_unordered(_work, [(c, a.tmp) for c in cfgs]), start=1):
            rows.append(row)
            c = row["config"]
            took = sum(row["timing_s"].values())
            print(
                f"[{i}/{len(cfgs)}] {c['kind']} {c['index']}: {row['status']}"
                + (f" ({row['message']})" if row["message"] else "")
                + f", {took:.1f} s",
                file=sys.stderr,
                flush=True,
            )
    seconds = time.perf_counter() - t0
    code_after = code_state()
    rows.sort(key=lambda r: (r["config"]["kind"] != "case10", r["config"]["index"]))
    coverage = [r for r in rows if r["config"]["kind"] == "coverage"]
    case = [r for r in rows if r["config"]["kind"] == "case10"]
    res = {
        "machine": info,
        "command": ("PYTHONPATH=" + os.environ["PYTHONPATH"] + " " if os.environ.get("PYTHONPATH") else "")
        + command("selfcal_coverage", argv),
        "code": {**code_before, "changed_during_run": code_after != code_before},
        "seconds": seconds,
        "settings": {
            "bags": a.bags,
            "seed": a.seed,
            "minutes": list(minutes),
            "case_seeds": a.case_seeds,
            "urdf_error_mm": a.urdf_error_mm,
            "urdf_error_deg": a.urdf_error_deg,
            "jobs": a.jobs,
            "selfcal_command": f"umbmark selfcal BAG --joints {JOINTS} --wheel-diameter-mm D --wheelbase-mm B --json",
        },
        "max_rss_mb": {
            "worker": max((r.get("worker_max_rss_mb") or 0.0) for r in rows),
            "selfcal": max((r.get("selfcal_max_rss_mb") or 0.0) for r in rows),
        },
        "summary": summarise(coverage),
        "by_condition": by_condition(coverage, minutes),
        "case10": summarise_case(case),
        "bags": rows,
    }
    write_results(a.out, "selfcal_coverage", res, markdown(res), show=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
