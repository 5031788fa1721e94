#!/usr/bin/env python3
"""Throughput of ``umbmark fleet``: simulated two-minute bags of a fleet self-calibrated on a
local cluster into one SQLite history.

    python benchmarks/fleet_throughput.py                      # 100 bags of 10 robots, 2 workers
    python benchmarks/fleet_throughput.py --bags 20            # a quicker look
    python benchmarks/fleet_throughput.py --out benchmarks/results

The fleet: ``--robots`` LabMates (wheels 150 mm, wheelbase 340 mm nominal), each with its own
systematic errors (E_d within 1 +- 1 %, E_b within 1 +- 3 %, drawn with the robot's seed) and
noisy wheels (2 % speed jitter seen by the encoders, slip 3.35e-4 m per sqrt(m) not seen), a
360-beam lidar with 5 mm range noise at 10 Hz; ``--bags`` drives of ``--minutes`` each (straights,
arcs and spins in the 10 x 8 m test room, every drive its own seed), shared out among the
robots, each written as a ROS 2 bag (mcap) with /joint_states, /scan and /tf_static into
``ROBOT/`` of a temporary fleet folder. Simulating and writing the bags is setup, not timed.

Timed: ``umbmark fleet FOLDER --joints ... --wheel-diameter-mm 150 --wheelbase-mm 340 --workers
N --db HISTORY --json`` as a command, in a new process (start-up, the local cluster's start, the
content hashes, every self-calibration and every record included), into a new SQLite history.
Reported: its wall time, the time per bag (wall time over bags), the records made, and how far
the recorded E_d and E_b are from each robot's truth. Target: 100 two-minute bags on 2 workers in
under 2 minutes. Also timed, to say where a bag's time goes: the stages of one bag's
self-calibration in this process, on one thread (reading it, the check of the wheels against
the lidar, the matched intervals, the estimate). Writes fleet_throughput.json and
fleet_throughput.md into --out.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

JOINTS = "left_wheel_joint,right_wheel_joint"


def robots(n: int) -> list:
    """The fleet's robots: LabMates with their own errors (seeded by their number)."""
    import numpy as np

    from umbmark.model.drive import SimRobot
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.sensors import Lidar, SensorPose

    out = []
    for i in range(n):
        rng = np.random.default_rng(1000 + i)
        errors = ErrorParams(ed=1 + float(rng.uniform(-0.01, 0.01)), eb=1 + float(rng.uniform(-0.03, 0.03)))
        pose = SensorPose(0.120, -0.030, math.radians(2.0))
        out.append(SimRobot(nominal=LABMATE, errors=errors, sensor_pose=pose, lidar=Lidar(range_noise_m=0.005)))
    return out


def make_fleet(root: Path, n_robots: int, n_bags: int, minutes: float) -> dict:
    """Simulate and write the bags: ``root/robot-NN/drive-MMM`` (ROS 2 bags). Returns each robot's
    true E_d and E_b and the setup's time and size."""
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import WheelNoise, mixed_program, simulate_drive

    fleet = robots(n_robots)
    t0 = time.perf_counter()
    for k in range(n_bags):
        i = k % n_robots
        r = fleet[i]
        prog = mixed_program(60.0 * minutes, seed=k, robot=r)
        log = simulate_drive(prog, r, noise=WheelNoise(speed_rel_sd=0.02, slip_m_per_sqrt_m=3.35e-4), seed=10_000 + k)
        folder = root / f"robot-{i:02d}"
        folder.mkdir(exist_ok=True)
        write_drive_bag(log, folder / f"drive-{k:03d}", storage="mcap", odom=False)
    size = sum(f.stat().st_size for f in root.rglob("*") if f.is_file())
    truth = {f"robot-{i:02d}": {"Ed": r.errors.ed, "Eb": r.errors.eb} for i, r in enumerate(fleet)}
    return {"setup_s": time.perf_counter() - t0, "bags_mb": size / 1e6, "truth": truth}


def stages(bag: Path) -> dict:
    """One bag's self-calibration in this process, stage by stage [s] (the second of two runs:
    the scan matcher's kernels loaded by the first)."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.realrobot.selfcal import bag_intervals, check_bag_motion, nominal_sensor_pose_of, selfcal_report

    out: dict = {}
    for _ in range(2):
        t = [time.perf_counter()]
        b = read_selfcal_bag(bag, wheels=WheelSource(joints=tuple(JOINTS.split(","))))
        t.append(time.perf_counter())
        pose = nominal_sensor_pose_of(b, None, None)[0]
        check_bag_motion(b, 0.15, 0.34, (pose[0], pose[1], pose[5]))
        t.append(time.perf_counter())
        si = bag_intervals(b, 0.15, 0.34)
        t.append(time.perf_counter())
        selfcal_report([si], 0.15, 0.34).to_dict()
        t.append(time.perf_counter())
        names = ("read_bag_s", "motion_check_s", "intervals_s", "estimate_s")
        out = {n: t[i + 1] - t[i] for i, n in enumerate(names)}
    out["total_s"] = out["read_bag_s"] + out["intervals_s"] + out["estimate_s"]  # the intervals include the check
    return out


def run_fleet(root: Path, db: Path, workers: int) -> tuple[float, dict, str]:
    """``umbmark fleet`` in a new process: (wall time, its JSON, its stderr)."""
    cmd = [
        sys.executable,
        "-m",
        "umbmark",
        "fleet",
        str(root),
        "--joints",
        JOINTS,
        "--wheel-diameter-mm",
        "150",
        "--wheelbase-mm",
        "340",
        "--workers",
        str(workers),
        "--db",
        str(db),
        "--json",
    ]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if not p.stdout.strip():
        raise SystemExit(f"umbmark fleet printed nothing (exit {p.returncode}): {p.stderr.strip()[-2000:]}")
    return wall, json.loads(p.stdout), p.stderr


def errors_of(db: Path, truth: dict) -> dict:
    """How far the recorded E_d and E_b are from each robot's truth (largest and median, in %)."""
    import statistics

    from umbmark.history import open_history

    ed, eb = [], []
    with open_history(db) as h:
        for rec in h.records():
            ed.append(100 * abs(rec.ed / truth[rec.robot]["Ed"] - 1))
            eb.append(100 * abs(rec.eb / truth[rec.robot]["Eb"] - 1))
    if not ed:
        return {}
    return {
        "Ed_error_pct_median": statistics.median(ed),
        "Ed_error_pct_max": max(ed),
        "Eb_error_pct_median": statistics.median(eb),
        "Eb_error_pct_max": max(eb),
    }


def page(res: dict) -> str:
    r, s = res["run"], res["setup"]
    lines = [
        "# Fleet throughput: simulated bags self-calibrated on a local cluster into one SQLite history",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(res["machine"]),
        f"Load average at the end: {res['load_average_end']}.",
        "",
        f"Fleet: {res['bags']} bags of {res['minutes']:g} minutes (ROS 2, mcap; {s['bags_mb']:.0f} MB in all) "
        f"of {res['robots']} robots, each with its own E_d and E_b; simulated and written in {s['setup_s']:.0f} s "
        "(setup, not timed).",
        "",
        f"`{res['fleet_command']}` (a new process: start-up, the local cluster of {res['workers']} workers, "
        "the content hashes, every self-calibration and every record):",
        "",
        "| figure | value |",
        "|---|---|",
        f"| wall time | **{r['wall_s']:.1f} s** |",
        f"| time per bag (wall time / bags) | **{r['per_bag_s']:.2f} s** |",
        f"| recorded, already recorded, failed | {r['recorded']}, {r['skipped']}, {r['failed']} |",
        f"| target: {res['bags']} bags in under 120 s | {'met' if r['wall_s'] < 120 else 'missed'} |",
    ]
    e = res["accuracy"]
    if e:
        lines += [
            "",
            f"The records against each robot's truth: E_d off by {e['Ed_error_pct_median']:.3f} % "
            f"(median; at most {e['Ed_error_pct_max']:.3f} %), E_b by {e['Eb_error_pct_median']:.3f} % "
            f"(median; at most {e['Eb_error_pct_max']:.3f} %).",
        ]
    st = res["one_bag"]
    lines += [
        "",
        "Where a bag's time goes: one bag self-calibrated in this process on one thread (the second of two runs):",
        "",
        "| stage | [s] |",
        "|---|---|",
        f"| read the bag (`read_selfcal_bag`) | {st['read_bag_s']:.2f} |",
        f"| matched intervals (`bag_intervals`) | {st['intervals_s']:.2f} |",
        f"| of which the wheels against the lidar (`check_bag_motion`) | {st['motion_check_s']:.2f} |",
        f"| estimate and its report (`selfcal_report`, `to_dict`) | {st['estimate_s']:.2f} |",
        f"| **one bag** | **{st['total_s']:.2f}** |",
    ]
    if r["failures"]:
        lines += ["", "Failed:", *(f"- {f}" for f in r["failures"])]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bags", type=int, default=100, help="bags (default 100)")
    p.add_argument("--robots", type=int, default=10, help="robots sharing the bags (default 10)")
    p.add_argument("--minutes", type=float, default=2.0, help="minutes of driving per bag (default 2)")
    p.add_argument("--workers", type=int, default=2, help="the local cluster's processes (default 2)")
    add_out(p, "fleet-throughput")
    args = p.parse_args(argv)
    if args.bags < 1 or args.robots < 1 or args.workers < 1 or not args.minutes > 0:
        p.error("--bags, --robots and --workers must be at least 1, --minutes positive")
    start = machine("scipy", "numba", "rosbags", "distributed")
    with tempfile.TemporaryDirectory(prefix="umbmark-fleet-bench-") as tmp:
        root = Path(tmp) / "fleet"
        root.mkdir()
        setup = make_fleet(root, args.robots, args.bags, args.minutes)
        db = Path(tmp) / "history.sqlite"
        wall, out, _ = run_fleet(root, db, args.workers)
        accuracy = errors_of(db, setup["truth"])
        one_bag = stages(next(root.glob("robot-00/drive-*")))
    fleet_cmd = (
        f"umbmark fleet FLEET --joints {JOINTS} --wheel-diameter-mm 150 --wheelbase-mm 340 "
        f"--workers {args.workers} --db HISTORY.sqlite --json"
    )
    res = {
        "command": command("fleet_throughput", argv),
        "fleet_command": fleet_cmd,
        "machine": start,
        "load_average_end": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None,
        "bags": args.bags,
        "robots": args.robots,
        "minutes": args.minutes,
        "workers": args.workers,
        "setup": {k: v for k, v in setup.items() if k != "truth"},
        "run": {
            "wall_s": wall,
            "per_bag_s": wall / args.bags,
            "recorded": out["recorded"],
            "skipped": out["skipped"],
            "failed": out["failed"],
            "failures": [f"{o['robot']}: {Path(o['path']).name}: {o['error']}" for o in out["outcomes"] if o["error"]],
        },
        "accuracy": accuracy,
        "one_bag": one_bag,
    }
    for path in write_results(Path(args.out), "fleet_throughput", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
