#!/usr/bin/env python3
"""The lidar self-calibration on bags recorded as real robots record them: the same truth as the
clean bag?

    python benchmarks/recorded_artefacts.py                 # into ./umbmark-bench-recorded-artefacts/
    python benchmarks/recorded_artefacts.py --out benchmarks/results --seeds 3

The drive: a LabMate (wheels 150 mm, wheelbase 340 mm nominal) with E_d 1.01, E_b 1.03, E_s 0.99,
a 360-beam lidar with 5 mm range noise at 10 Hz mounted at x 120 mm, y -30 mm, yaw 2 deg, two
minutes of straights, arcs and spins (``--seeds`` drives), written as a ROS 2 bag with
/joint_states (100 Hz), /odom (its nominal odometry), /scan and /tf_static. Each bag is then
edited message by message (``tests/bagedit.py``) into the artefacts of real recordings, and
self-calibrated (``umbmark.realrobot.selfcal.selfcal_from_bags``, the scans' delay estimated):

* joint states stamped on arrival, 4 at a time (bursts);
* every 150th joint state sent again 0.6 s later under a new stamp (late messages);
* 2 % of the joint states recorded twice; a 1.5 s hole; 3 % of the scans lost;
* all of these at once;
* /odom thinned to 10 Hz, arriving over a wireless link: mostly in pairs, sometimes 3 to 7 at
  once, 1 % followed by a copy of a message 0.2 to 1 s old (the wheel data of the SLAM
  benchmark's older logs look like this);
* the same /odom stamped as made (no bursts), for comparison.

Reported: the errors of the diameters and the wheelbase (% of the truth), of the lidar pose
(mm, deg), and what the check of the wheel data did (``wheel_stream``). The pinned accuracy of
the clean bag is 0.3 %, 5 mm and 0.3 deg. Writes recorded_artefacts.json and .md into --out.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # the bag edits of the tests
import bagedit  # noqa: E402
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

from umbmark.io.rosbag_write import JOINT_NAMES, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import SimRobot, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.selfcal import selfcal_from_bags  # noqa: E402

ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
    sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
    lidar=Lidar(n_beams=360, range_noise_m=0.005),
)
JOINTS = WheelSource(joints=JOINT_NAMES)
ODOM = WheelSource(odom_topic="/odom")
CASES = {
    "clean (joint states)": (JOINTS, {}),
    "bursts of 4": (JOINTS, {"joint_states": bagedit.arrival_bursts(4)}),
    "late copies (every 150th, 0.6 s)": (JOINTS, {"joint_states": bagedit.late_copies(150, 0.6)}),
    "2 % twice, a 1.5 s hole, 3 % of scans lost": (
        JOINTS,
        {
            "joint_states": bagedit.chain(bagedit.hole(40.0, 1.5), bagedit.duplicated(0.02)),
            "scan": bagedit.dropped(0.03),
        },
    ),
    "all of these": (
        JOINTS,
        {
            "joint_states": bagedit.chain(
                bagedit.hole(40.0, 1.5),
                bagedit.late_copies(150, 0.6),
                bagedit.arrival_bursts(4),
                bagedit.duplicated(0.02),
            ),
            "scan": bagedit.dropped(0.03),
        },
    ),
    "/odom, 10 Hz, as made": (ODOM, {"odom": bagedit.wireless_odometry(late_share=0.0, bursts=False)}),
    "/odom, 10 Hz, wireless": (ODOM, {"odom": bagedit.wireless_odometry()}),
}


def _errors(d: dict, log) -> dict:
    true, pose = log.true_geometry, log.sensor_pose
    sp = d["sensor_pose"]
    return {
        "d_left_pct": 100 * (d["wheel_diameter_left_mm"] / (true.diameter_left_m * 1e3) - 1),
        "d_right_pct": 100 * (d["wheel_diameter_right_mm"] / (true.diameter_right_m * 1e3) - 1),
        "wheelbase_pct": 100 * (d["wheelbase_mm"] / (true.wheelbase_m * 1e3) - 1),
        "x_mm": sp["x_mm"] - pose.x_m * 1e3,
        "y_mm": sp["y_mm"] - pose.y_m * 1e3,
        "yaw_deg": sp["yaw_deg"] - math.degrees(pose.yaw_rad),
    }


def run(seeds: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(seeds):
            log = simulate_drive(mixed_program(120.0, seed=21 + 2 * seed, robot=ROBOT), ROBOT, seed=22 + 2 * seed)
            clean = write_drive_bag(log, Path(tmp) / f"clean{seed}", storage="sqlite3", odom=True)
            for k, (name, (wheels, edits)) in enumerate(CASES.items()):
                bag = bagedit.edit_bag(clean, Path(tmp) / f"b{seed}_{k}", **edits) if edits else clean
                t0 = time.perf_counter()
                try:
                    d = selfcal_from_bags(bag, LABMATE.wheel_diameter_m, LABMATE.wheelbase_m, wheels=wheels).to_dict()
                except Exception as e:  # a refusal is a result here
                    rows.append({"case": name, "seed": seed, "error": str(e)})
                    continue
                rows.append(
                    {
                        "case": name,
                        "seed": seed,
                        "seconds": time.perf_counter() - t0,
                        **_errors(d, log),
                        "wheel_stream": d["inputs"][0]["wheel_stream"],
                        "warnings": d["warnings"],
                    }
                )
    return rows


def page(rows: list[dict], m: dict, cmd: str) -> str:
    lines = [
        "# The self-calibration on bags recorded as real robots record them",
        "",
        f"Command: `{cmd}`  ",
        machine_text(m),
        "",
        "Errors of the estimate against the truth (the pinned accuracy of the clean bag: diameters and wheelbase "
        "within 0.3 %, the lidar within 5 mm and 0.3 deg), and what the check of the wheel data did.",
        "",
        "| case | seed | D_L % | D_R % | wheelbase % | lidar x, y mm | yaw deg | clock | late | repeated | kept |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | {r['seed']} | refused: {r['error']} | | | | | | | | |")
            continue
        w = r["wheel_stream"]
        lines.append(
            f"| {r['case']} | {r['seed']} | {r['d_left_pct']:+.3f} | {r['d_right_pct']:+.3f} | "
            f"{r['wheelbase_pct']:+.3f} | {r['x_mm']:+.2f}, {r['y_mm']:+.2f} | {r['yaw_deg']:+.3f} | {w['clock']} | "
            f"{w['late']} | {w['duplicates']} | {w['kept']} of {w['messages']} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=1, help="drives (default 1)")
    add_out(p, "recorded-artefacts")
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    rows = run(a.seeds)
    m = machine("rosbags", "scipy", "numba")
    cmd = command("recorded_artefacts", argv)
    res = {"command": cmd, "machine": m, "wall_s": time.perf_counter() - t0, "rows": rows}
    write_results(a.out, "recorded_artefacts", res, page(rows, m, cmd), show=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
