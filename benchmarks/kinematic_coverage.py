#!/usr/bin/env python3
"""Accuracy and coverage of the self-calibration of simulated tricycle and mecanum robots.

    python benchmarks/kinematic_coverage.py                        # 50 robots of each kind
    python benchmarks/kinematic_coverage.py --robots 10 --jobs 2   # a quicker look
    python benchmarks/kinematic_coverage.py --out benchmarks/results

Each robot is drawn by :func:`umbmark.studies.kinematic.draw_robot` (a tricycle: traction wheel
150-300 mm, wheelbase 400-1000 mm, the truth off by up to 3 % and 5 %, a steering offset up to
3 deg; a mecanum robot: wheels 70-150 mm each off by up to 2 %, ``lx + ly`` 200-500 mm off by up
to 5 %; the lidar up to 200 mm / 100 mm / 5 deg from the origin, the URDF's guess of it 20 mm
and 2 deg off; a 360-beam lidar at 10 Hz with 5 mm range noise; joint-speed jitter, slip and
steering-reading noise; 2-3 minutes of every move the kind makes, both ways, in the test
room), written as a ROS 1 bag in a temporary folder and calibrated by the command itself in a
new process (:func:`umbmark.cli.kinematic_args.selfcal_args`: ``umbmark selfcal BAG
--kinematics tricycle --steer-joint ... --drive-joint ... --wheel-diameter-mm D --wheelbase-mm
L --sensor-pose URDF --json``, or ``--kinematics mecanum --joints FL,FR,RL,RR
--wheel-diameter-mm D --lx-plus-ly-mm S``).

Reported per kind and parameter: the fraction of robots whose truth lies inside the printed
95 % interval (with its Clopper-Pearson interval), the largest and the 90th percentile of the
error (relative for the lengths, in degrees and millimetres for the angles and the lidar), and
the targets: diameters and wheelbase / ``lx + ly`` within 0.3 %, the steering offset within
0.1 deg, the lidar within 5 mm and 0.3 deg, coverage of at least 90 %; and the warnings the
robots drew (they should be none: every drive excites every parameter).

Robots run in ``--jobs`` processes (default the cores available); BLAS and numba use one thread
each.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

TIMEOUT_S = 600

TARGETS = {
    "wheel_diameter_mm": ("rel", 0.003),
    "wheel_diameters_mm.front_left": ("rel", 0.003),
    "wheel_diameters_mm.front_right": ("rel", 0.003),
    "wheel_diameters_mm.rear_left": ("rel", 0.003),
    "wheel_diameters_mm.rear_right": ("rel", 0.003),
    "wheelbase_mm": ("rel", 0.003),
    "lx_plus_ly_mm": ("rel", 0.003),
    "steering_offset_deg": ("abs", 0.1),
    "sensor_x_mm": ("abs", 5.0),
    "sensor_y_mm": ("abs", 5.0),
    "sensor_yaw_deg": ("abs", 0.3),
}
"""Per parameter: how its error is measured (relative or absolute, in the key's unit) and the target."""


def one(kind: str, seed: int) -> dict:
    """Draw, simulate, write and calibrate one robot; its truth, estimates and intervals."""
    from umbmark.cli.kinematic_args import selfcal_args
    from umbmark.studies.kinematic import draw_robot, estimate_of, simulated_bag, truth_of

    drawn = draw_robot(kind, seed)
    with tempfile.TemporaryDirectory() as tmp:
        bag = simulated_bag(drawn, Path(tmp) / f"{kind}-{seed}.bag")
        t0 = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "umbmark", *selfcal_args(drawn, bag)],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        wall = time.perf_counter() - t0
    out: dict = {"kind": kind, "seed": seed, "command_s": wall}
    if proc.returncode != 0:
        out["error"] = (proc.stderr or proc.stdout).strip().splitlines()[-1:]
        return out
    d = json.loads(proc.stdout)
    out["warnings"] = d["warnings"]
    out["params"] = {}
    for key, truth in truth_of(drawn).items():
        est, ci = estimate_of(d, key)
        how, _ = TARGETS[key]
        err = (est - truth) / truth if how == "rel" else est - truth
        out["params"][key] = {
            "truth": truth,
            "estimate": est,
            "ci95": ci,
            "error": err,
            "inside": ci[0] <= truth <= ci[1],
        }
    return out


def _clopper(k: int, n: int) -> tuple[float, float]:
    from scipy.stats import beta

    lo = 0.0 if k == 0 else float(beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(0.975, k + 1, n - k))
    return lo, hi


def summarise(rows: list[dict]) -> dict:
    """Per kind and parameter: coverage, error percentiles, the targets met."""
    import numpy as np

    out: dict = {}
    for kind in sorted({r["kind"] for r in rows}):
        ok = [r for r in rows if r["kind"] == kind and "params" in r]
        failed = [r for r in rows if r["kind"] == kind and "params" not in r]
        per: dict = {}
        for key in ok[0]["params"] if ok else []:
            inside = sum(r["params"][key]["inside"] for r in ok)
            err = np.abs([r["params"][key]["error"] for r in ok])
            how, target = TARGETS[key]
            scale = 100.0 if how == "rel" else 1.0
            lo, hi = _clopper(inside, len(ok))
            per[key] = {
                "coverage": inside / len(ok),
                "coverage_ci95": [lo, hi],
                "max_error": float(err.max()) * scale,
                "p90_error": float(np.percentile(err, 90)) * scale,
                "unit": "%" if how == "rel" else key.rsplit("_", 1)[-1],
                "target": target * scale,
                "within_target": int((err <= target).sum()),
            }
        warned = [r for r in ok if r["warnings"]]
        out[kind] = {
            "robots": len(ok) + len(failed),
            "calibrated": len(ok),
            "failed": [{"seed": r["seed"], "error": r["error"]} for r in failed],
            "warned": [{"seed": r["seed"], "warnings": r["warnings"]} for r in warned],
            "command_s_median": float(np.median([r["command_s"] for r in ok])) if ok else math.nan,
            "parameters": per,
        }
    return out


def page(res: dict) -> str:
    lines = [
        "# Self-calibration of simulated tricycle and mecanum robots",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(res["machine"]),
        f"Wall time {res['wall_s'] / 60:.1f} min.",
        "",
        "Each robot a different seeded draw (`umbmark.studies.kinematic.draw_robot`), its bag calibrated by "
        "`umbmark selfcal --kinematics ... --json` in a new process. Coverage: the robots whose truth lies in "
        "the printed 95 % interval (Clopper-Pearson interval). Errors relative (%) for the lengths, in degrees "
        "and millimetres otherwise. Target: the acceptance of the kind's calibration.",
        "",
    ]
    for kind, s in res["summary"].items():
        lines += [
            f"## {kind}",
            "",
            f"{s['calibrated']} of {s['robots']} robots calibrated; median command time {s['command_s_median']:.1f} s; "
            f"{len(s['warned'])} with warnings.",
            "",
            "| parameter | coverage | its 95 % interval | max error | 90th percentile | target | within target |",
            "|---|---|---|---|---|---|---|",
        ]
        for key, p in s["parameters"].items():
            lo, hi = p["coverage_ci95"]
            lines.append(
                f"| {key} | {100 * p['coverage']:.0f} % | {100 * lo:.0f}-{100 * hi:.0f} % | "
                f"{p['max_error']:.3g} {p['unit']} | {p['p90_error']:.3g} {p['unit']} | {p['target']:g} {p['unit']} | "
                f"{p['within_target']} of {s['calibrated']} |"
            )
        for f in s["failed"]:
            lines.append(f"\nFailed: seed {f['seed']}: {' '.join(f['error'])}")
        for w in s["warned"]:
            lines.append(f"\nWarned: seed {w['seed']}: {'; '.join(w['warnings'])}")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", type=int, default=50, help="robots of each kind (default 50)")
    p.add_argument("--kinds", default="tricycle,mecanum", help="the kinds (default tricycle,mecanum)")
    p.add_argument("--jobs", type=int, default=len(os.sched_getaffinity(0)), help="worker processes")
    add_out(p, "kinematic-coverage")
    args = p.parse_args(argv)
    if args.robots < 1 or args.jobs < 1:
        p.error("--robots and --jobs must be at least 1")
    t0 = time.perf_counter()
    tasks = [(k, s) for k in args.kinds.split(",") for s in range(args.robots)]
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(one, *zip(*tasks)))
    res = {
        "command": command("kinematic_coverage", argv),
        "machine": machine("scipy", "numba", "rosbags"),
        "wall_s": time.perf_counter() - t0,
        "summary": summarise(rows),
        "robots": rows,
    }
    for path in write_results(Path(args.out), "kinematic_coverage", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
