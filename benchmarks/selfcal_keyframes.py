#!/usr/bin/env python3
"""Which keyframes should the lidar self-calibration use? Measured on simulated drives whose scans
are stamped on arrival (late and with jitter), as real lidar drivers stamp them.

    python benchmarks/selfcal_keyframes.py                  # into ./umbmark-bench-selfcal-keyframes/
    python benchmarks/selfcal_keyframes.py --out benchmarks/results

The robot of ``tests/test_selfcal_bag.py`` (a LabMate, wheels 150 mm and wheelbase 340 mm
nominal, E_d 1.01, E_b 1.03, E_s 0.99; a 360-beam lidar with 5 mm range noise at 10 Hz, 120 mm
ahead, 30 mm right, turned 2 deg) drives ``--drives`` (3) two-minute programs of straights,
arcs and spins in the test room. Each drive's scans are stamped 30 ms late with a jitter of
0, 10 and 20 ms (:meth:`umbmark.model.drive.DriveLog.stamped`; the wheels' joint states are
stamped when sampled), written as a ROS 1 bag, and calibrated by the library's pipeline
(:func:`umbmark.realrobot.selfcal.bag_intervals`: the delay estimated, the keyframes chosen on
the scan matches) with each keyframe rule. Reported per rule and jitter: the root mean square
of the relative errors of the wheel diameters and of the wheelbase, and the share of their
truths inside the 95 % intervals. Writes selfcal_keyframes.json and selfcal_keyframes.md.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

JITTERS_S = (0.0, 0.01, 0.02)
DELAY_S = 0.03


def rules() -> dict:
    from umbmark.realrobot.selfcal import DEFAULT_KEYFRAMES, KeyframeRule

    r = math.radians
    default = f"{DEFAULT_KEYFRAMES.describe()} (the default)"
    # (keyframes, the wheel data's jitter modelled)
    return {
        "every scan": (KeyframeRule(), True),
        "every scan, the wheel data taken as exact": (KeyframeRule(), False),
        "every 100 mm or 5 deg or 1 s": (KeyframeRule(0.1, r(5), 0.0, 1.0), True),
        "every 300 mm or 20 deg or 3 s": (KeyframeRule(0.3, r(20), 0.0, 3.0), True),
        "every 0.5 s": (KeyframeRule(0.0, 0.0, 0.0, 0.5), True),
        "every 1 s": (KeyframeRule(0.0, 0.0, 0.0, 1.0), True),
        default: (DEFAULT_KEYFRAMES, True),
        f"{default}, the wheel data taken as exact": (DEFAULT_KEYFRAMES, False),
        "every 100 mm or 10 deg or 3 s, at least 1 s apart": (KeyframeRule(0.1, r(10), 1.0, 3.0), True),
    }


def one_drive(seed: int) -> list[dict]:
    """Every rule on every jitter of one drive."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.rosbag_write import JOINT_NAMES, write_drive_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.model.drive import SimRobot, mixed_program, simulate_drive
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.sensors import Lidar, SensorPose
    from umbmark.realrobot.selfcal import IntervalOptions, bag_intervals, selfcal_report

    robot = SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
        sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
        lidar=Lidar(n_beams=360, range_noise_m=0.005),
    )
    d_nom, b_nom = LABMATE.wheel_diameter_m, LABMATE.wheelbase_m
    log = simulate_drive(mixed_program(120.0, seed=seed, robot=robot), robot, seed=seed + 1)
    true = log.true_geometry
    truth = {
        "r_left_m": true.diameter_left_m / 2,
        "r_right_m": true.diameter_right_m / 2,
        "wheelbase_m": true.wheelbase_m,
    }
    out = []
    for jitter in JITTERS_S:
        folder = Path(tempfile.mkdtemp(prefix="umbmark-keyframes-"))
        try:
            path = write_drive_bag(log.stamped(DELAY_S, jitter, seed=seed), folder / "drive.bag", storage="ros1")
            bag = read_selfcal_bag(path, wheels=WheelSource(joints=JOINT_NAMES))
            for name, (rule, modelled) in rules().items():
                t0 = time.perf_counter()
                si = bag_intervals(bag, d_nom, b_nom, IntervalOptions(keyframes=rule))
                res = selfcal_report([si], d_nom, b_nom, time_jitter=modelled).result
                row = {"drive": seed, "jitter_s": jitter, "rule": name, "seconds": time.perf_counter() - t0}
                row["wheel_jitter_s"] = res.wheel_jitter_s if modelled else None
                row["intervals"] = res.intervals_used
                row["delay_s"] = si.plan.scan_delay_s
                for key, value in truth.items():
                    est = getattr(res, key)
                    lo, hi = res.ci95[key]
                    row[key] = {"error": est / value - 1, "inside": bool(lo <= value <= hi)}
                out.append(row)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    return out


def summary(rows: list[dict]) -> list[dict]:
    out = []
    for name in dict.fromkeys(r["rule"] for r in rows):
        for jitter in JITTERS_S:
            sel = [r for r in rows if r["rule"] == name and r["jitter_s"] == jitter]
            d = np.array([[r[k]["error"] for k in ("r_left_m", "r_right_m")] for r in sel]).ravel()
            b = np.array([r["wheelbase_m"]["error"] for r in sel])
            inside = np.array([r[k]["inside"] for r in sel for k in ("r_left_m", "r_right_m", "wheelbase_m")])
            out.append(
                {
                    "rule": name,
                    "jitter_s": jitter,
                    "drives": len(sel),
                    "rms_diameter_error": float(np.sqrt(np.mean(d * d))),
                    "rms_wheelbase_error": float(np.sqrt(np.mean(b * b))),
                    "inside": float(inside.mean()),
                    "intervals": float(np.mean([r["intervals"] for r in sel])),
                    "wheel_jitter_s": None
                    if sel[0]["wheel_jitter_s"] is None
                    else float(np.median([r["wheel_jitter_s"] for r in sel])),
                }
            )
    return out


def page(res: dict) -> str:
    lines = [
        "# Lidar self-calibration: keyframes against scans stamped on arrival",
        "",
        machine_text(res["machine"]),
        "",
        f"Command: `{res['command']}`. {res['drives']} two-minute drives of the LabMate of "
        "`tests/test_selfcal_bag.py` (360 beams, 5 mm range noise, 10 Hz), the scans stamped "
        f"{DELAY_S * 1e3:.0f} ms late with the jitter below; each calibrated by the pipeline (delay estimated, "
        "keyframes chosen on the scan matches) with each rule. Errors: root mean square of the relative "
        "errors of the two diameters, and of the wheelbase; inside: the share of the three truths inside "
        f"their 95 % intervals; jitter found: the median of the wheel data jitter the fit estimated "
        f"(the wheel data taken as exact: none). Wall time {res['wall_s']:.0f} s.",
        "",
        "| keyframes | jitter ms | intervals | diameters rms error | wheelbase rms error | inside | jitter found ms |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in res["summary"]:
        d, b = 100 * s["rms_diameter_error"], 100 * s["rms_wheelbase_error"]
        found = "" if s["wheel_jitter_s"] is None else f"{s['wheel_jitter_s'] * 1e3:.1f}"
        lines.append(
            f"| {s['rule']} | {s['jitter_s'] * 1e3:.0f} | {s['intervals']:.0f} | {d:.3f} % | {b:.3f} % | "
            f"{100 * s['inside']:.0f} % | {found} |"
        )
    lines += [
        "",
        "The wheels' rotation between two stamps carries the jitter's error at both ends, of the size of the "
        "motion over it: a fit that takes the wheels as exact turns it into a wheel scale percents small with "
        "every scan an interval (longer intervals weigh it less). The fit models it: the jitter is estimated "
        "with the noise and the bias it gives is taken off.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_out(p, "selfcal-keyframes")
    p.add_argument("--drives", type=int, default=3, help="drives (seeds 11, 13, ...)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    seeds = [11 + 2 * k for k in range(args.drives)]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = [r for part in pool.map(one_drive, seeds) for r in part]
    res = {
        "command": command("selfcal_keyframes", argv),
        "machine": machine("scipy", "numba", "rosbags"),
        "drives": args.drives,
        "wall_s": time.perf_counter() - t0,
        "summary": summary(rows),
        "rows": rows,
    }
    for path in write_results(Path(args.out), "selfcal_keyframes", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
