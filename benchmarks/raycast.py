#!/usr/bin/env python3
"""Speed of the simulated lidar robot: ray casting, whole drives and bag writing.

    python benchmarks/raycast.py                           # into ./umbmark-bench-raycast/
    python benchmarks/raycast.py --quick                   # without the 20-minute drive
    python benchmarks/raycast.py --out benchmarks/results

Cases (default test room, 360-beam lidar, 10 Hz scans, 100 Hz wheels):

* ``cast_rays`` alone on 1,200 and 12,000 sensor poses, engines numba and numpy;
* ``mixed_program`` + ``simulate_drive`` of a 2-minute and a 20-minute drive (noisy wheels and
  lidar), planning and simulation timed apart;
* ``write_drive_bag`` of the 2-minute drive in each storage (ROS 1, sqlite3, mcap).

Each case runs --repeat times after one warm-up run (the numba kernel compiled or loaded from
its cache then, timed as ``numba_first_call_s``); the median and fastest wall-clock times are
reported. Writes raycast.json and raycast.md into --out (created if missing).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from umbmark.io.rosbag_write import write_drive_bag
from umbmark.model.drive import EXAMPLE_ROBOT, WheelNoise, mixed_program, simulate_drive
from umbmark.model.sensors import Lidar, Room, cast_rays, have_numba

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, add_repeat, command, machine, machine_text, write_results  # noqa: E402

NOISE = WheelNoise(speed_rel_sd=0.02, slip_m_per_sqrt_m=3.35e-4)


def timed(fn, repeat: int) -> dict:
    """Median and fastest of ``repeat`` timed calls of ``fn`` after one warm-up call."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {"median_s": statistics.median(times), "min_s": min(times), "times_s": times}


def poses(n: int, seed: int = 0) -> np.ndarray:
    """``n`` random sensor poses inside the default room, at least 0.5 m from its walls."""
    room = Room.default()
    rng = np.random.default_rng(seed)
    out = np.empty((0, 3))
    while len(out) < n:
        p = np.column_stack([rng.uniform(0, 10, n), rng.uniform(0, 8, n), rng.uniform(-np.pi, np.pi, n)])
        ok = room.contains(p[:, :2]) & (room.distance_to_walls(p[:, :2]) >= 0.5)
        out = np.vstack([out, p[ok]])
    return out[:n]


def measure(repeat: int, quick: bool) -> dict:
    """Time every case."""
    room, angles = Room.default(), Lidar().angles_rad
    res: dict = {"cast_rays": [], "drives": [], "bags": []}
    engines = ["numba", "numpy"] if have_numba() else ["numpy"]
    if have_numba():
        t0 = time.perf_counter()
        cast_rays(room, poses(1), angles, 12.0, engine="numba")
        res["numba_first_call_s"] = time.perf_counter() - t0
    for n in (1200, 12000):
        p = poses(n)
        for engine in engines:
            t = timed(lambda p=p, e=engine: cast_rays(room, p, angles, 12.0, engine=e), repeat)
            res["cast_rays"].append({"poses": n, "beams": len(angles), "segments": len(room), "engine": engine, **t})
    for minutes in (2,) if quick else (2, 20):
        d = 60.0 * minutes
        plan = timed(lambda d=d: mixed_program(d, seed=1), repeat)
        prog = mixed_program(d, seed=1)
        sim = timed(lambda prog=prog: simulate_drive(prog, EXAMPLE_ROBOT, noise=NOISE, seed=1), repeat)
        log = simulate_drive(prog, EXAMPLE_ROBOT, noise=NOISE, seed=1)
        res["drives"].append(
            {
                "duration_s": d,
                "scans": len(log.scan_t_s),
                "wheel_samples": len(log.t_s),
                "plan": plan,
                "simulate": sim,
            }
        )
    log = simulate_drive(mixed_program(120.0, seed=1), EXAMPLE_ROBOT, noise=NOISE, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        for storage in ("ros1", "sqlite3", "mcap"):
            count = iter(range(10**6))

            def write(storage=storage, count=count):
                name = f"{storage}-{next(count)}" + (".bag" if storage == "ros1" else "")
                write_drive_bag(log, Path(tmp) / name, storage=storage, truth=True)

            res["bags"].append({"duration_s": 120.0, "storage": storage, "topics": 5, **timed(write, repeat)})
    return res


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    m = res["machine"]
    lines = [
        "# Simulated lidar robot: speed",
        "",
        machine_text(m),
        "",
        f"Command: `{res['command']}`. Median and fastest of {res['repeat']} runs after one warm-up run.",
        "",
        "## Ray casting (`cast_rays`, default room)",
        "",
        "| poses | beams | segments | engine | median [s] | fastest [s] | rays per second |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in res["results"]["cast_rays"]:
        rate = c["poses"] * c["beams"] / c["median_s"]
        lines.append(
            f"| {c['poses']:,} | {c['beams']} | {c['segments']} | {c['engine']} | {c['median_s']:.3f} | "
            f"{c['min_s']:.3f} | {rate:.3g} |"
        )
    if "numba_first_call_s" in res["results"]:
        lines += ["", f"First numba call (compile or load from cache): {res['results']['numba_first_call_s']:.2f} s."]
    lines += [
        "",
        "## Drives (`mixed_program` + `simulate_drive`, noisy wheels and lidar)",
        "",
        "| drive | scans | wheel samples | plan median [s] | simulate median [s] | simulate fastest [s] |",
        "|---|---|---|---|---|---|",
    ]
    for d in res["results"]["drives"]:
        lines.append(
            f"| {d['duration_s'] / 60:g} min | {d['scans']:,} | {d['wheel_samples']:,} | {d['plan']['median_s']:.3f} | "
            f"{d['simulate']['median_s']:.3f} | {d['simulate']['min_s']:.3f} |"
        )
    lines += [
        "",
        "## Bags (`write_drive_bag`, 2-minute drive, 5 topics with /odom and /ground_truth)",
        "",
        "| storage | median [s] | fastest [s] |",
        "|---|---|---|",
    ]
    for b in res["results"]["bags"]:
        lines.append(f"| {b['storage']} | {b['median_s']:.2f} | {b['min_s']:.2f} |")
    return "\n".join(lines) + "\n"


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_repeat(p, 3, "timed runs of each case")
    p.add_argument("--quick", action="store_true", help="skip the 20-minute drive")
    add_out(p, "raycast")
    return p


def main(argv=None) -> int:
    """Measure, write raycast.json and raycast.md, print the page."""
    a = parser().parse_args(argv)
    info = machine("numba")
    results = measure(a.repeat, a.quick)
    res = {"machine": info, "command": command("raycast", argv), "repeat": a.repeat, "results": results}
    write_results(a.out, "raycast", res, markdown(res), show=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
