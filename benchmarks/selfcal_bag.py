#!/usr/bin/env python3
"""Speed (and accuracy) of the lidar self-calibration from a ROS bag, end to end, on one core.

    python benchmarks/selfcal_bag.py                        # into ./umbmark-bench-selfcal-bag/
    python benchmarks/selfcal_bag.py --minutes 2            # a shorter drive
    python benchmarks/selfcal_bag.py --out benchmarks/results

The drive: a LabMate (wheels 150 mm, wheelbase 340 mm nominal) with E_d 1.01, E_b 1.03, E_s 0.99
and noisy wheels (2 % speed jitter seen by the encoders, slip 3.35e-4 m per sqrt(m) not seen),
a 360-beam lidar with 5 mm range noise at 10 Hz mounted at x 120 mm, y -30 mm, yaw 2 deg,
``--minutes`` (default 20: 12,001 scans, 120,001 joint states) of straights, arcs and spins in
the 10 x 8 m test room; written as a ROS 2 bag (``--storage``, default mcap) with /joint_states,
/scan, /odom and /tf_static.

Timed, on one core (the process is pinned to one CPU and the BLAS / OpenMP pools to one thread
before numpy loads): the stages of :mod:`umbmark.realrobot.selfcal` (reading the bag, planning
the intervals, scan matching, the estimate) and ``umbmark selfcal BAG --joints ... --json`` as a
command (a new process: start-up and imports included). The scan matcher's numba kernel is
compiled or loaded from its cache before the timing (timed apart as ``numba_first_call_s``).
The simulation and the bag writing are timed as setup. Writes selfcal_bag.json and
selfcal_bag.md into --out (created if missing).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, pin_one_core, write_results  # noqa: E402


def robot():
    from umbmark.model.drive import SimRobot
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.sensors import Lidar, SensorPose

    return SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
        sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
        lidar=Lidar(n_beams=360, range_noise_m=0.005),
    )


def make_bag(folder: Path, minutes: float, storage: str, seed: int) -> tuple[dict, object, Path]:
    """Simulate the drive and write its bag: (setup timings, the drive log, the bag)."""
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import WheelNoise, mixed_program, simulate_drive

    r = robot()
    t0 = time.perf_counter()
    prog = mixed_program(60.0 * minutes, seed=seed, robot=r)
    log = simulate_drive(prog, r, noise=WheelNoise(speed_rel_sd=0.02, slip_m_per_sqrt_m=3.35e-4), seed=seed + 1)
    t1 = time.perf_counter()
    path = write_drive_bag(log, folder / ("drive.bag" if storage == "ros1" else "drive"), storage=storage, odom=True)
    t2 = time.perf_counter()
    size = sum(f.stat().st_size for f in path.rglob("*")) if path.is_dir() else path.stat().st_size
    return {"simulate_s": t1 - t0, "write_bag_s": t2 - t1, "bag_mb": size / 1e6}, log, path


def run_stages(path: Path) -> tuple[dict, dict]:
    """One calibration of the bag through the library, stage by stage: (timings, its JSON)."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.realrobot.selfcal import match_intervals, plan_intervals, selfcal_report

    t = [time.perf_counter()]
    bag = read_selfcal_bag(path, wheels=WheelSource(joints=("left_wheel_joint", "right_wheel_joint")))
    t.append(time.perf_counter())
    plan = plan_intervals(bag, 0.15, 0.34)
    t.append(time.perf_counter())
    si = match_intervals(plan)
    t.append(time.perf_counter())
    rep = selfcal_report([si], 0.15, 0.34)
    t.append(time.perf_counter())
    names = ("read_bag_s", "plan_s", "match_s", "estimate_s")
    out = {n: t[i + 1] - t[i] for i, n in enumerate(names)}
    out["total_s"] = t[-1] - t[0]
    return out, rep.to_dict()


def run_cli(path: Path) -> float:
    """Wall-clock time of ``umbmark selfcal BAG --joints ... --json`` in a new process."""
    cmd = [
        sys.executable,
        "-m",
        "umbmark",
        "selfcal",
        str(path),
        "--joints",
        "left_wheel_joint,right_wheel_joint",
        "--wheel-diameter-mm",
        "150",
        "--wheelbase-mm",
        "340",
        "--json",
    ]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.perf_counter() - t0


def accuracy(d: dict, log) -> dict:
    """Estimate minus truth, and whether the truth is inside each 95 % interval."""
    true, pose = log.true_geometry, log.sensor_pose
    truth = {
        "wheel_diameter_left_mm": true.diameter_left_m * 1e3,
        "wheel_diameter_right_mm": true.diameter_right_m * 1e3,
        "wheelbase_mm": true.wheelbase_m * 1e3,
        "Ed": true.diameter_right_m / true.diameter_left_m,
        "Eb": true.wheelbase_m / 0.34,
    }
    out = {}
    for k, v in truth.items():
        lo, hi = d[k + "_ci95"]
        out[k] = {"estimate": d[k], "truth": v, "error": d[k] - v, "in_ci95": lo <= v <= hi}
    for k, v in (("x_mm", pose.x_m * 1e3), ("y_mm", pose.y_m * 1e3), ("yaw_deg", math.degrees(pose.yaw_rad))):
        lo, hi = d["sensor_pose"][k + "_ci95"]
        e = d["sensor_pose"][k]
        out[f"sensor_{k}"] = {"estimate": e, "truth": v, "error": e - v, "in_ci95": lo <= v <= hi}
    return out


def measure(minutes: float, storage: str, repeat: int, seed: int) -> dict:
    from umbmark.realrobot.scanmatch import match_scans

    res: dict = {}
    t0 = time.perf_counter()
    a = np.linspace(-math.pi, math.pi, 90, endpoint=False)
    match_scans(np.full(90, 2.0), np.full(90, 2.0), a)  # numba: compile or load from the cache
    res["numba_first_call_s"] = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="selfcal-bench-") as tmp:
        setup, log, path = make_bag(Path(tmp), minutes, storage, seed)
        res["setup"] = setup
        res["drive"] = {
            "minutes": minutes,
            "scans": int(len(log.scan_t_s)),
            "joint_states": int(len(log.t_s)),
            "beams": int(log.ranges_m.shape[1]),
            "storage": storage,
        }
        runs, d = [], None
        for _ in range(repeat):
            stages, d = run_stages(path)
            stages["cli_s"] = run_cli(path)
            runs.append(stages)
        res["runs"] = runs
        res["median"] = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        assert d is not None
        res["result"] = {
            k: d[k] for k in ("intervals_used", "pairs_matched", "pairs_failed", "intervals_still", "scans_read")
        }
        res["result"]["rejected"] = len(d["intervals_rejected"])
        res["result"]["warnings"] = d["warnings"]
        res["accuracy"] = accuracy(d, log)
    return res


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    m, r, dr = res["machine"], res["results"], res["results"]["drive"]
    med = r["median"]
    lines = [
        "# Lidar self-calibration from a ROS bag: speed",
        "",
        machine_text(m, f"pinned to one core (CPU {res['pinned_cpu']})"),
        "",
        f"Command: `{res['command']}`. Median of {res['repeat']} run(s).",
        "",
        f"Drive: {dr['minutes']:g} minutes, {dr['scans']:,} scans of {dr['beams']} beams, {dr['joint_states']:,} "
        f"joint states, ROS 2 bag ({dr['storage']}, {r['setup']['bag_mb']:.0f} MB, with /odom). Setup (not in "
        f"the times below): simulation {r['setup']['simulate_s']:.1f} s, bag writing "
        f"{r['setup']['write_bag_s']:.1f} s; numba kernel compile or cache load {r['numba_first_call_s']:.2f} s.",
        "",
        "| stage | median [s] |",
        "|---|---|",
        f"| read the bag (`read_selfcal_bag`) | {med['read_bag_s']:.2f} |",
        f"| wheel angles at the scans, keyframes (`plan_intervals`) | {med['plan_s']:.2f} |",
        f"| scan matching (`match_intervals`) | {med['match_s']:.2f} |",
        f"| estimate (`selfcal`) | {med['estimate_s']:.2f} |",
        f"| **library, end to end** | **{med['total_s']:.2f}** |",
        f"| **`umbmark selfcal BAG --json` (new process)** | **{med['cli_s']:.2f}** |",
        "",
        f"Intervals: {r['result']['pairs_matched']:,} scan pairs matched, {r['result']['pairs_failed']} failed, "
        f"{r['result']['intervals_still']} without wheel motion; {r['result']['intervals_used']:,} used, "
        f"{r['result']['rejected']} rejected as outliers. Warnings: {r['result']['warnings'] or 'none'}.",
        "",
        "| figure | estimate | truth | error | truth in the 95 % interval |",
        "|---|---|---|---|---|",
    ]
    for k, v in r["accuracy"].items():
        lines.append(f"| {k} | {v['estimate']:.6g} | {v['truth']:.6g} | {v['error']:+.3g} | {v['in_ci95']} |")
    return "\n".join(lines) + "\n"


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--minutes", type=float, default=20.0, help="length of the drive (default 20)")
    p.add_argument("--storage", choices=("mcap", "sqlite3", "ros1"), default="mcap", help="bag storage (default mcap)")
    p.add_argument("--repeat", type=int, default=1, help="timed calibrations of the bag (default 1)")
    p.add_argument("--seed", type=int, default=7, help="seed of the drive (default 7)")
    add_out(p, "selfcal-bag")
    return p


def main(argv=None) -> int:
    """Measure, write selfcal_bag.json and selfcal_bag.md, print the page."""
    a = parser().parse_args(argv)
    if a.repeat < 1 or not (a.minutes > 0):
        print("error: --repeat must be at least 1 and --minutes positive", file=sys.stderr)
        return 2
    info = machine("numba", "scipy", "rosbags")
    cpu = pin_one_core()
    results = measure(a.minutes, a.storage, a.repeat, a.seed)
    res = {
        "machine": info,
        "pinned_cpu": cpu,
        "command": command("selfcal_bag", argv),
        "repeat": a.repeat,
        "results": results,
    }
    write_results(a.out, "selfcal_bag", res, markdown(res), show=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
