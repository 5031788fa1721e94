#!/usr/bin/env python3
"""The first ``umbmark selfcal`` on a machine (the scan matcher compiled) and the runs after it.

    python benchmarks/first_run.py                          # 3 of each, into ./umbmark-bench-first-run/
    python benchmarks/first_run.py --out benchmarks/results

A simulated 2-minute drive (the example robot of the docs: 150 mm wheels, 340 mm wheelbase, a
360-beam lidar at 10 Hz, joint states) written as a ROS 2 bag, then
``umbmark -q selfcal BAG --joints left_wheel_joint,right_wheel_joint --wheel-diameter-mm 150
--wheelbase-mm 340`` in a fresh process: *first* with an empty ``NUMBA_CACHE_DIR`` (numba
compiles the kernels: the first run on a machine), *then* with the cache that run left (every
run after). The two take turns, ``--repeat`` times each; median and fastest wall-clock time.
Writes first_run.json and first_run.md into --out (created if missing).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, add_repeat, command, machine, machine_text, write_results  # noqa: E402
from startup import umbmark_command  # noqa: E402

DURATION_S = 120.0
ARGS = ["--joints", "left_wheel_joint,right_wheel_joint", "--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]


def write_bag(path: Path, seed: int = 1) -> None:
    """The simulated drive of the docs' example robot as a ROS 2 bag (joint states, scans, odometry)."""
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
    from umbmark.model.sensors import SensorPose

    log = simulate_drive(mixed_program(DURATION_S, seed=seed), EXAMPLE_ROBOT, seed=seed)
    write_drive_bag(dataclasses.replace(log, sensor_pose=SensorPose(0.10, 0.0, 0.0)), path, storage="mcap", odom=True)


def time_once(argv: list[str], cache: Path) -> float:
    """Wall-clock seconds of one run of ``argv`` with numba's cache in ``cache``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True, env=env)
    return time.perf_counter() - t0


def measure(bag: Path, work: Path, repeat: int) -> dict:
    """Time the first and a later run ``repeat`` times each, taking turns."""
    argv = umbmark_command() + ["-q", "selfcal", str(bag), *ARGS]
    times: dict[str, list[float]] = {"first": [], "then": []}
    for i in range(repeat):
        cache = work / f"cache-{i}"
        shutil.rmtree(cache, ignore_errors=True)
        times["first"].append(time_once(argv, cache))
        times["then"].append(time_once(argv, cache))
    return {
        "argv": [Path(argv[0]).name, *("BAG" if a == str(bag) else a for a in argv[1:])],
        **{k: {"median_s": statistics.median(t), "min_s": min(t), "times_s": t} for k, t in times.items()},
    }


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    r = res["runs"]
    shown = " ".join(r["argv"])
    return (
        "\n".join(
            [
                "# The first self-calibration on a machine",
                "",
                machine_text(res["machine"]),
                "",
                f"Command: `{res['command']}`. A simulated {DURATION_S:.0f} s drive (360 beams at 10 Hz, joint "
                f"states) as a ROS 2 bag; `{shown}` in a fresh process, first with an empty `NUMBA_CACHE_DIR` (the "
                f"scan matcher compiled), then with the cache it left; {res['repeat']} of each, taking turns.",
                "",
                "| run | median [s] | fastest [s] | each [s] |",
                "|---|---|---|---|",
                *(
                    f"| {label} | {r[k]['median_s']:.1f} | {r[k]['min_s']:.1f} | "
                    + ", ".join(f"{t:.1f}" for t in r[k]["times_s"])
                    + " |"
                    for k, label in (("first", "first (compiles)"), ("then", "then (cached)"))
                ),
            ]
        )
        + "\n"
    )


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_repeat(p, 3, "runs of each kind")
    add_out(p, "first-run")
    return p


def main(argv=None) -> int:
    """Measure, write first_run.json and first_run.md, print the medians."""
    a = parser().parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="umbmark-first-run-") as tmp:
        work = Path(tmp)
        write_bag(work / "drive")
        runs = measure(work / "drive", work, a.repeat)
    res = {"machine": machine("numba"), "command": command("first_run", argv), "repeat": a.repeat, "runs": runs}
    paths = write_results(a.out, "first_run", res, markdown(res))
    print(f"first run {runs['first']['median_s']:.1f} s, then {runs['then']['median_s']:.1f} s (medians)")
    print("written:", ", ".join(map(str, paths)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
