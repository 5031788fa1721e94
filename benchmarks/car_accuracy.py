#!/usr/bin/env python3
"""Accuracy of the self-calibration of simulated cars, from their joint states and from their /odom,
and of the vesc driver's gains exported from it.

    python benchmarks/car_accuracy.py                        # 5 drives of each car
    python benchmarks/car_accuracy.py --drives 2 --jobs 2    # a quicker look
    python benchmarks/car_accuracy.py --out benchmarks/results

The cars are :data:`umbmark.studies.cars.CARS`: an F1TENTH-sized car (wheels 110 mm, wheelbase
330 mm, a 270-degree lidar), a larger car (250 mm, 650 mm) and a four-wheel Ackermann car (200 mm,
600 mm); each truly has its wheels 1 to 2.5 % off, a steering offset of about 1 deg and a steering
scale 3 to 4 % off, its lidar off its drawing. Each drive (a seed) is about 45 s of straights,
backing up, loops both ways near full lock and reversing arcs in the test room, with 1 % joint-speed
jitter and slip, written as a ROS 1 bag with the joint states and the car's /odom integrated as
F1TENTH's vesc_to_odom does. Each bag is calibrated by the command itself
(:func:`umbmark.cli.kinematic_args.car_selfcal_args`: ``umbmark selfcal BAG --kinematics bicycle
--drive-joint ... --steer-joint ... --wheel-diameter-mm D --wheelbase-mm L --fit-steering-scale
--json``, the same with ``--odom-topic /odom``, and ``--kinematics ackermann --traction-joints ...
--steering-joints ...``); a bicycle-model car's calibration from /odom is exported with ``umbmark
export CAL --format vesc --vesc-config vesc.yaml`` (F1TENTH's stock gains in use).

Reported per car and source: the largest error of the wheel diameter and the steering scale
(relative), the steering offset (deg), the lidar's position (mm) and yaw (deg), the warnings; of the
vesc export, the largest error of the two gains (relative) and of the servo offset; the targets:
0.3 %, 0.5 %, 0.1 deg, 5 mm, 0.3 deg, and 0.5 % and 0.003 for the gains.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

TARGETS = {
    "wheel_diameter_mm": ("rel", 0.003),
    "steering_scale": ("rel", 0.005),
    "steering_offset_deg": ("abs", 0.1),
    "sensor_pose.x_mm": ("abs", 5.0),
    "sensor_pose.y_mm": ("abs", 5.0),
    "sensor_pose.yaw_deg": ("abs", 0.3),
    "speed_to_erpm_gain": ("rel", 0.005),
    "steering_angle_to_servo_gain": ("rel", 0.005),
    "steering_angle_to_servo_offset": ("abs", 0.003),
}
"""Per value: how its error is measured (relative or absolute, in its unit) and the target."""


def _cli(args: list[str]) -> tuple[int, str]:
    from umbmark.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue() if code == 0 else err.getvalue().strip()


def _vesc_yaml(in_use: dict[str, float]) -> str:
    lines = ["/**:", "  ros__parameters:"] + [f"    {k}: {v!r}" for k, v in in_use.items()]
    return "\n".join(lines + ["    port: /dev/sensors/vesc", ""])


def _error(key: str, est: float, truth: float) -> float:
    return (est - truth) / truth if TARGETS[key][0] == "rel" else est - truth


def one(name: str, seed: int) -> list[dict]:
    """Drive, write and calibrate one car: a row per source (and its vesc export)."""
    import yaml

    from umbmark.cli.kinematic_args import car_selfcal_args
    from umbmark.studies.cars import SOURCES, VESC_IN_USE, car_bag, car_named, truth, vesc_truth

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        bag = car_bag(name, Path(tmp) / f"{name}-{seed}.bag", seed=seed)
        for source in SOURCES if car_named(name).reads_odometry else SOURCES[:1]:
            t0 = time.perf_counter()
            code, text = _cli(car_selfcal_args(name, bag, source))
            row: dict = {"car": name, "seed": seed, "source": source, "command_s": time.perf_counter() - t0}
            rows.append(row)
            if code != 0:
                row["error"] = text.splitlines()[-1:]
                continue
            d = json.loads(text)
            row["warnings"] = d["warnings"]
            row["errors"] = {}
            for key, t in truth(name).items():
                a, _, b = key.partition(".")
                row["errors"][key] = _error(key, d[a][b] if b else d[a], t)
            if source != "odom":
                continue
            cal, conf, new = Path(tmp) / f"cal-{source}.json", Path(tmp) / "vesc.yaml", Path(tmp) / "new.yaml"
            cal.write_text(text)
            conf.write_text(_vesc_yaml(VESC_IN_USE))
            code, err = _cli(
                ["-q", "export", str(cal), "--format", "vesc", "--vesc-config", str(conf), "--out", str(new)]
            )
            if code != 0:
                row["error"] = err.splitlines()[-1:]
                continue
            got = yaml.safe_load(new.read_text())["/**"]["ros__parameters"]
            for key, t in vesc_truth(name).items():
                row["errors"][key] = _error(key, got[key], t)
    return rows


def summarise(rows: list[dict]) -> dict:
    """Per car and source: the largest error of each value, the targets met, the warnings."""
    out: dict = {}
    for name, source in dict.fromkeys((r["car"], r["source"]) for r in rows):
        mine = [r for r in rows if r["car"] == name and r["source"] == source]
        ok = [r for r in mine if "errors" in r]
        worst = {k: max(abs(r["errors"][k]) for r in ok) for k in TARGETS if ok and k in ok[0]["errors"]}
        out[f"{name}/{source}"] = {
            "drives": len(mine),
            "failed": len(mine) - len(ok),
            "worst": worst,
            "met": all(v <= TARGETS[k][1] for k, v in worst.items()) and len(ok) == len(mine),
            "warnings": sorted({w for r in ok for w in r["warnings"]}),
            "command_s": max(r["command_s"] for r in mine),
        }
    return out


def _pct(w: dict, k: str) -> str:
    return f"{100 * w[k]:.3f} %" if k in w else "-"


def _num(w: dict, k: str, d: int) -> str:
    return f"{w[k]:.{d}f}" if k in w else "-"


def page(res: dict) -> str:
    lines = [
        "# Self-calibration of simulated cars",
        "",
        f"`{res['command']}`",
        "",
        machine_text(res["machine"]),
        "",
        "The largest error over the drives of each car: relative (%) for the wheel diameter, the steering scale "
        "and the vesc gains, degrees and millimetres otherwise. Targets: 0.3 %, 0.5 %, 0.1 deg, 5 mm, 0.3 deg; the "
        "gains 0.5 %, the servo offset 0.003.",
        "",
        "| car / source | drives | wheel diameter | steering scale | steering offset | lidar x, y | lidar yaw "
        "| erpm gain | servo gain | servo offset | targets met |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, s in res["summary"].items():
        w = s["worst"]
        xy = f"{max(w['sensor_pose.x_mm'], w['sensor_pose.y_mm']):.2f} mm" if "sensor_pose.x_mm" in w else "-"
        lines.append(
            f"| {key} | {s['drives']} | {_pct(w, 'wheel_diameter_mm')} | {_pct(w, 'steering_scale')} | "
            f"{_num(w, 'steering_offset_deg', 4)} deg | {xy} | {_num(w, 'sensor_pose.yaw_deg', 3)} deg | "
            f"{_pct(w, 'speed_to_erpm_gain')} | {_pct(w, 'steering_angle_to_servo_gain')} | "
            f"{_num(w, 'steering_angle_to_servo_offset', 5)} | {'yes' if s['met'] else 'no'} |"
        )
    warned = {k: s["warnings"] for k, s in res["summary"].items() if s["warnings"]}
    lines += ["", "Warnings: " + ("; ".join(f"{k}: {', '.join(v)}" for k, v in warned.items()) or "none"), ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--drives", type=int, default=5, help="drives (seeds) of each car (default 5)")
    p.add_argument("--jobs", type=int, default=len(os.sched_getaffinity(0)), help="worker processes")
    add_out(p, "car-accuracy")
    args = p.parse_args(argv)
    if args.drives < 1 or args.jobs < 1:
        p.error("--drives and --jobs must be at least 1")
    from umbmark.studies.cars import CARS

    t0 = time.perf_counter()
    tasks = [(c, s) for c in CARS for s in range(1, args.drives + 1)]
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = [r for rs in pool.map(one, *zip(*tasks)) for r in rs]
    res = {
        "command": command("car_accuracy", argv),
        "machine": machine("scipy", "numba", "rosbags"),
        "wall_s": time.perf_counter() - t0,
        "summary": summarise(rows),
        "drives": rows,
    }
    for path in write_results(Path(args.out), "car_accuracy", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
