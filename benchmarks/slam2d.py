#!/usr/bin/env python3
"""The lidar self-calibration on the two real logs of data/slam2d, against the benchmark's ground truth.

    python benchmarks/slam2d.py                       # into ./umbmark-bench-slam2d/
    python benchmarks/slam2d.py --out benchmarks/results

For each log (ACES Building: 7374 scans, 1366 s; MIT CSAIL Building: 1988 scans, 424 s) the study of
:mod:`umbmark.studies.slam2d`: calibrate on one half of the log (by time), compare the robot's
odometry before (recomputed with the nominal geometry) and after (recomputed with the calibrated
one) with the ground-truth relations inside the other half, both ways; the benchmark's errors
(Kümmerle et al. 2009) over short and long relations, the systematic distance, turn and drift
fits, the scan matcher itself against the relations. Three runs per log:

* ``recorded``: the scans' stamps as recorded, nominal geometry ``--nominal-mm`` (default
  wheels 200 mm, wheelbase 400 mm: the robots' geometry is not published; an assumption);
* ``delay``: the same with the scans' delay behind the odometry estimated on each calibration
  half (:func:`umbmark.realrobot.selfcal.estimate_scan_delay`);
* ``other nominal``: ``recorded`` with the nominal geometry ``--other-nominal-mm`` (default
  150 mm, 300 mm), to show which results depend on the assumption.

Also: the logs themselves (path, turns, how far the odometry's increments are from arcs, the
stamps), a plain point-to-line ICP (scipy cKDTree, in Python) on the same short-relation scan
pairs as umbmark's matcher, and full-log calibrations with keyframes every 300 mm or 10 deg or
3 s.

Timed on one core (the process pinned, BLAS / OpenMP pools at one thread): the self-calibration
of each full log through the library, stage by stage, and ``umbmark selfcal LOG --scan-topic /scan
--odom-topic /odom ... --json`` as a command (a new process: start-up and imports included),
median of ``--repeat`` runs; the numba kernel's first call apart. Writes slam2d.json and slam2d.md
into --out (created if missing).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import shlex  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import machine as _machine  # noqa: E402
from _common import pin_one_core  # noqa: E402

DEFAULT_OUT = "umbmark-bench-slam2d"
REPO = Path(__file__).resolve().parent.parent
LOGS = ("aces", "mit-csail")


def run_stages(bag_path: Path, d_m: float, b_m: float) -> dict:
    """One self-calibration of a full log through the library, stage by stage [s]."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.realrobot.selfcal import match_intervals, plan_intervals, selfcal_report

    t = [time.perf_counter()]
    bag = read_selfcal_bag(bag_path, scan_topic="/scan", wheels=WheelSource(odom_topic="/odom"))
    t.append(time.perf_counter())
    plan = plan_intervals(bag, d_m, b_m)
    t.append(time.perf_counter())
    si = match_intervals(plan)
    t.append(time.perf_counter())
    selfcal_report([si], d_m, b_m)
    t.append(time.perf_counter())
    names = ("read_bag_s", "plan_s", "match_s", "estimate_s")
    out = {n: t[i + 1] - t[i] for i, n in enumerate(names)}
    out["total_s"] = t[-1] - t[0]
    out["pairs_matched"] = si.pairs_matched
    out["pairs_failed"] = si.pairs_failed
    return out


def cli_command(bag_path: Path, d_m: float, b_m: float) -> list[str]:
    return [
        sys.executable,
        "-m",
        "umbmark",
        "selfcal",
        str(bag_path),
        "--scan-topic",
        "/scan",
        "--odom-topic",
        "/odom",
        "--wheel-diameter-mm",
        f"{d_m * 1e3:g}",
        "--wheelbase-mm",
        f"{b_m * 1e3:g}",
        "--json",
    ]


def run_cli(bag_path: Path, d_m: float, b_m: float) -> float:
    """Wall-clock time of ``umbmark selfcal LOG ... --json`` in a new process [s]."""
    t0 = time.perf_counter()
    subprocess.run(cli_command(bag_path, d_m, b_m), check=True, capture_output=True)
    return time.perf_counter() - t0


def studies(data: Path, nominal: tuple[float, float], other: tuple[float, float]) -> dict:
    from umbmark.studies.slam2d import study_log

    out: dict = {}
    for name in LOGS:
        bag, rel = data / f"{name}.bag", data / f"{name}.relations"
        print(f"{name}: study", file=sys.stderr, flush=True)
        out[name] = {
            "recorded": study_log(bag, rel, *nominal).to_dict(),
            "delay": study_log(bag, rel, *nominal, scan_delay_s="estimate").to_dict(),
            "other nominal": study_log(bag, rel, *other).to_dict(),
        }
    return out


def log_facts(data: Path) -> dict:
    """Path, turns, stamps and the odometry increments' sideways part of each log."""
    from umbmark.io.relations import read_relations
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.model import se2

    out = {}
    for name in LOGS:
        bag = read_selfcal_bag(data / f"{name}.bag", scan_topic="/scan", wheels=WheelSource(odom_topic="/odom"))
        rel = read_relations(data / f"{name}.relations")
        d = se2.between(bag.odom_pose[:-1], bag.odom_pose[1:])
        half = 0.5 * d[:, 2]
        along = d[:, 0] * np.cos(half) + d[:, 1] * np.sin(half)
        side = -d[:, 0] * np.sin(half) + d[:, 1] * np.cos(half)
        step = np.hypot(d[:, 0], d[:, 1])
        moving = step > 0.01
        ratio = np.abs(side[moving]) / np.abs(along[moving])
        wt, st = bag.wheel_t_s, bag.scan_t_s
        k = np.clip(np.searchsorted(wt, st), 1, len(wt) - 1)
        nearest = np.where(np.abs(wt[k] - st) < np.abs(wt[k - 1] - st), wt[k] - st, wt[k - 1] - st)
        out[name] = {
            "scans": int(bag.n_scans),
            "beams": int(bag.ranges_m.shape[1]),
            "beam_step_deg": float(np.degrees(np.median(np.diff(bag.angles_rad)))),
            "duration_s": float(st[-1] - st[0]),
            "odometry_messages": int(len(wt)),
            "path_m": float(step.sum()),
            "turns_deg": float(np.degrees(np.abs(d[:, 2]).sum())),
            "sideways_over_along_p50_p90_p99": [float(v) for v in np.percentile(ratio, [50, 90, 99])],
            "odometry_minus_scan_stamp_s_p10_p50_p90": [float(v) for v in np.percentile(nearest, [10, 50, 90])],
            "relations": len(rel),
            "relations_short": int((rel.span_s < 10.0).sum()),
            "relation_span_s_max": float(rel.span_s.max()),
        }
    return out


def point_to_line_icp(ref: np.ndarray, cur: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """Plain point-to-line ICP (scipy cKDTree): normals from the 5 nearest reference points, 0.3 m gate,
    the worst 10 % trimmed, Gauss-Newton to 1e-6; ``ref``, ``cur`` (n, 2) points; the pose of ``cur`` in ``ref``."""
    from scipy.spatial import cKDTree

    tree = cKDTree(ref)
    _, nb = tree.query(ref, k=5)
    q = ref[nb] - ref[nb].mean(axis=1, keepdims=True)
    normals = np.linalg.eigh(np.einsum("nki,nkj->nij", q, q))[1][:, :, 0]
    x = np.array(guess, dtype=float)
    for _ in range(30):
        c, s = math.cos(x[2]), math.sin(x[2])
        rot = cur @ np.array([[c, s], [-s, c]])
        p = rot + x[:2]
        dist, i = tree.query(p, distance_upper_bound=0.3)
        ok = np.isfinite(dist)
        if ok.sum() < 10:
            break
        n = normals[i[ok]]
        r = np.einsum("ij,ij->i", n, p[ok] - ref[i[ok]])
        keep = np.abs(r) <= np.quantile(np.abs(r), 0.9)
        n, r, qk = n[keep], r[keep], rot[ok][keep]
        jac = np.column_stack([n, n[:, 1] * qk[:, 0] - n[:, 0] * qk[:, 1]])
        step = np.linalg.solve(jac.T @ jac, -jac.T @ r)
        x += step
        if math.hypot(step[0], step[1]) < 1e-6 and abs(step[2]) < 1e-6:
            break
    return x


def scan_points(bag, k: int) -> np.ndarray:
    """The valid returns of scan ``k`` as (n, 2) points in the laser frame."""
    r = bag.ranges_m[k].astype(float)
    v = np.isfinite(r)
    return np.column_stack([r[v] * np.cos(bag.angles_rad[v]), r[v] * np.sin(bag.angles_rad[v])])


def matcher_cross_check(data: Path, nominal: tuple[float, float]) -> dict:
    """umbmark's matcher and a plain point-to-line ICP on the scan pairs of the short relations."""
    from umbmark.io.relations import read_relations
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.model import se2
    from umbmark.model.geometry import WheelGeometry
    from umbmark.realrobot.scanmatch import match_scan_pairs
    from umbmark.realrobot.wheels import scan_wheel_angles
    from umbmark.studies.slam2d import (
        ErrorStats,
        SystematicErrors,
        odometry_from_wheels,
        relation_errors,
    )

    out = {}
    for name in LOGS:
        print(f"{name}: matchers", file=sys.stderr, flush=True)
        bag = read_selfcal_bag(data / f"{name}.bag", scan_topic="/scan", wheels=WheelSource(odom_topic="/odom"))
        rel = read_relations(data / f"{name}.relations")
        i1, i2 = rel.indices(bag.scan_t_s)
        short = np.flatnonzero(rel.span_s < 10.0)
        left, right = scan_wheel_angles(bag, WheelGeometry(nominal[0], nominal[0], nominal[1]))
        odo = odometry_from_wheels(left, right, nominal[0] / 2, nominal[0] / 2, nominal[1])
        q0 = se2.between(odo[i1[short]], odo[i2[short]])  # the laser at the origin (/tf_static)
        m = match_scan_pairs(bag.ranges_m[i1[short]], bag.ranges_m[i2[short]], bag.angles_rad, q0)
        ok = np.asarray(m.converged, dtype=bool)

        t0 = time.perf_counter()
        icp = np.array(
            [point_to_line_icp(scan_points(bag, i1[j]), scan_points(bag, i2[j]), q0[n]) for n, j in enumerate(short)]
        )
        icp_s = time.perf_counter() - t0
        ref = rel.pose[short]
        res = {"relations": int(short.size), "umbmark_converged": int(ok.sum()), "scipy_icp_s": icp_s}
        for who, poses, sel in (
            ("umbmark (converged)", np.asarray(m.poses), ok),
            ("point-to-line ICP, same pairs", icp, ok),
            ("point-to-line ICP, all pairs", icp, np.ones(short.size, dtype=bool)),
            ("odometry, same pairs", q0, ok),
        ):
            et, er = relation_errors(poses[sel], ref[sel])
            res[who] = {
                "errors": ErrorStats.from_errors(et, er).to_dict(),
                "systematic": SystematicErrors.fit(poses[sel], ref[sel]).to_dict(),
            }
        out[name] = res
    return out


def keyframe_runs(data: Path, nominal: tuple[float, float]) -> dict:
    """Full-log calibrations with keyframes every 300 mm or 10 deg or 3 s (stamps as recorded)."""
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource
    from umbmark.realrobot.selfcal import IntervalOptions, KeyframeRule, bag_intervals, selfcal_report

    rule = KeyframeRule(min_distance_m=0.3, min_rotation_rad=math.radians(10.0), max_interval_s=3.0)
    out = {"rule": rule.describe()}
    for name in LOGS:
        bag = read_selfcal_bag(data / f"{name}.bag", scan_topic="/scan", wheels=WheelSource(odom_topic="/odom"))
        d = selfcal_report([bag_intervals(bag, *nominal, IntervalOptions(keyframes=rule))], *nominal).to_dict()
        out[name] = {k: d[k] for k in ("c_left", "c_right", "Ed", "Ed_ci95", "Eb", "Eb_ci95", "sensor_pose")}
        out[name]["pairs_matched"], out[name]["pairs_failed"] = d["pairs_matched"], d["pairs_failed"]
    return out


def timings(data: Path, nominal: tuple[float, float], repeat: int) -> dict:
    from umbmark.realrobot.scanmatch import match_scans

    res: dict = {}
    t0 = time.perf_counter()
    a = np.linspace(-math.pi / 2, math.pi / 2, 180)
    match_scans(np.full(180, 2.0), np.full(180, 2.0), a)  # numba: compile or load from the cache
    res["numba_first_call_s"] = time.perf_counter() - t0
    for name in LOGS:
        bag = data / f"{name}.bag"
        print(f"{name}: timing", file=sys.stderr, flush=True)
        runs = []
        for _ in range(repeat):
            stages = run_stages(bag, *nominal)
            stages["cli_s"] = run_cli(bag, *nominal)
            runs.append(stages)
        res[name] = {
            "runs": runs,
            "median": {k: statistics.median(r[k] for r in runs) for k in runs[0]},
            "command": shlex.join(["umbmark", *cli_command(bag.relative_to(REPO), *nominal)[3:]]),
        }
    return res


# ---------------------------------------------------------------------------------------------
# the report


def f(v, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.{digits}f}"


def ci(v, lo_hi, digits: int = 3) -> str:
    return f"{f(v, digits)} [{f(lo_hi[0], digits)}, {f(lo_hi[1], digits)}]"


def calibration_table(study: dict) -> list[str]:
    rows = [
        "| calibrated on | scans | delay s | c_left | c_right | E_d [95 %] | E_b [95 %] | wheelbase mm [95 %] "
        "| lidar x mm [95 %] | lidar y mm [95 %] | lidar yaw deg [95 %] | intervals used / rejected | pairs failed |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in study["calibrations"]:
        sp = c["sensor_pose"]
        rows.append(
            f"| {c['label']} | {c['scans']} | {f(c['scan_delay_s'])} | {f(c['c_left'], 4)} | {f(c['c_right'], 4)} "
            f"| {ci(c['Ed'], c['Ed_ci95'], 4)} | {ci(c['Eb'], c['Eb_ci95'], 4)} "
            f"| {ci(c['wheelbase_mm'], c['wheelbase_mm_ci95'], 1)} | {ci(sp['x_mm'], sp['x_mm_ci95'], 1)} "
            f"| {ci(sp['y_mm'], sp['y_mm_ci95'], 1)} | {ci(sp['yaw_deg'], sp['yaw_deg_ci95'], 2)} "
            f"| {c['intervals_used']} / {c['intervals_rejected']} | {c['pairs_failed']} |"
        )
    return rows


LABELS = {
    "recorded@/tf_static": "robot's odometry as recorded",
    "nominal@/tf_static": "**before**: nominal geometry, laser at /tf_static",
    "nominal@estimated": "nominal geometry, laser at the estimated pose",
}


def label_of(key: str, test: dict) -> str:
    if key in LABELS:
        return LABELS[key]
    cal = key.split("(")[1].split(")")[0]
    where = "the estimated pose" if key.endswith("@estimated") else "/tf_static"
    role = "**after**: " if key == test["after"] else ""
    if cal == test["calibrated_on"]:
        sample = "out of sample"
    elif cal == test["label"]:
        sample = "in sample"
    else:
        sample = "partly in sample"
    return f"{role}calibrated on the {cal} ({sample}), laser at {where}"


def mm(v):
    return None if v is None else v * 1e3


def test_table(test: dict) -> list[str]:
    rows = [
        "| odometry | short: MSE t m² | MSE r deg² | MAE t mm | MAE r deg | distance scale | turn scale "
        "| drift deg/m | long: MSE t m² | MSE r deg² |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for e in test["evaluations"]:
        s, lg, y = e["short"], e["long"], e["systematic"]
        rows.append(
            f"| {label_of(e['key'], test)} | {f(s['translation']['mse_m2'], 5)} | {f(s['rotation']['mse_deg2'], 2)} "
            f"| {f(mm(s['translation']['mae_m']), 1)} "
            f"| {f(s['rotation']['mae_deg'], 2)} "
            f"| {ci(y['distance_scale'], y['distance_scale_ci95'], 3)} "
            f"| {ci(y['turn_scale'], y['turn_scale_ci95'], 3)} "
            f"| {ci(y['drift_deg_per_m'], y['drift_deg_per_m_ci95'], 2)} "
            f"| {f(lg['translation']['mse_m2'], 3)} | {f(lg['rotation']['mse_deg2'], 1)} |"
        )
    return rows


def study_section(name: str, study: dict, title: str) -> list[str]:
    out = [f"### {name}: {title}", ""]
    out += calibration_table(study)
    out.append("")
    for t in study["tests"]:
        head = (
            f"Test on the **{t['label']}** ({f(t['t_start_s'], 0)} to {f(t['t_end_s'], 0)} s; "
            f"{t['relations_short']} short, {t['relations_long']} long relations; odometry read "
            f"{f(t['scan_delay_s'])} s before the scans' stamps)"
        )
        head += f", calibrated on the {t['calibrated_on']}:" if t["calibrated_on"] else ", calibrated on itself:"
        out += [head, ""] + test_table(t) + [""]
    warns = sorted({w for c in study["calibrations"] for w in c["warnings"]} | set(study["warnings"]))
    if warns:
        out += ["Warnings:", ""] + [f"- {w}" for w in warns] + [""]
    return out


def matcher_section(res: dict) -> list[str]:
    out = [
        "## The scan matcher against the relations",
        "",
        "The two scans of each short relation matched from the nominal odometry (converged matches), "
        "next to the nominal odometry on the same relations (stamps as recorded):",
        "",
        "| log | converged | who | MAE t mm | MAE r deg | distance scale | turn scale |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        c = res["studies"][name]["recorded"]["scan_matching"]
        for who in ("matcher", "odometry"):
            e, y = c[who], c[f"{who}_systematic"]
            out.append(
                f"| {name} | {c['converged']} / {c['relations']} | {who} | {f(mm(e['translation']['mae_m']), 1)} "
                f"| {f(e['rotation']['mae_deg'], 2)} | {ci(y['distance_scale'], y['distance_scale_ci95'])} "
                f"| {ci(y['turn_scale'], y['turn_scale_ci95'])} |"
            )
    out += [
        "",
        "The turn regression of the intervals each calibration used (sensor turn on nominal wheel turn, "
        "and the inverse of the reverse regression; equal when the wheel data are exact):",
        "",
        "| log | stamps | calibrated on | sensor on wheels | 1 / (wheels on sensor) | correlation | c_mean / E_b |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        for run in ("recorded", "delay"):
            for c in res["studies"][name][run]["calibrations"]:
                r = c["turn_regression"]
                out.append(
                    f"| {name} | {run} | {c['label']} | {f(r['sensor_on_wheels'])} "
                    f"| {f(r['inverse_wheels_on_sensor'])} | {f(r['correlation'], 4)} "
                    f"| {f(0.5 * (c['c_left'] + c['c_right']) / c['Eb'])} |"
                )
    return out + [""]


def data_section(res: dict) -> list[str]:
    out = [
        "## The logs",
        "",
        "| log | scans | beams (step deg) | s | odometry messages | path m | turns deg | odometry increment sideways / "
        "along, p50 / p90 / p99 | nearest odometry stamp - scan stamp s, p10 / p50 / p90 | relations (short) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        g = res["logs"][name]
        side = " / ".join(f(v, 3) for v in g["sideways_over_along_p50_p90_p99"])
        stamp = " / ".join(f(v, 3) for v in g["odometry_minus_scan_stamp_s_p10_p50_p90"])
        out.append(
            f"| {name} | {g['scans']} | {g['beams']} ({f(g['beam_step_deg'], 4)}) | {f(g['duration_s'], 0)} "
            f"| {g['odometry_messages']} | {f(g['path_m'], 1)} | {f(g['turns_deg'], 0)} | {side} | {stamp} "
            f"| {g['relations']} ({g['relations_short']}) |"
        )
    return out + [""]


def cross_check_section(res: dict) -> list[str]:
    out = [
        "## umbmark's matcher and a plain point-to-line ICP on the short relations",
        "",
        "The scans of each short relation matched from the nominal odometry; the ICP is scipy cKDTree "
        "point-to-line (normals of 5 neighbours, 0.3 m gate, 10 % trimmed), in Python:",
        "",
        "| log | matcher | relations | MAE t mm | MAE r deg | distance scale | turn scale |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        c = res["matchers"][name]
        for who in ("umbmark (converged)", "point-to-line ICP, same pairs", "point-to-line ICP, all pairs"):
            e, y = c[who]["errors"], c[who]["systematic"]
            out.append(
                f"| {name} | {who} | {e['count']} | {f(mm(e['translation']['mae_m']), 1)} "
                f"| {f(e['rotation']['mae_deg'], 2)} | {ci(y['distance_scale'], y['distance_scale_ci95'])} "
                f"| {ci(y['turn_scale'], y['turn_scale_ci95'])} |"
            )
    k = res["keyframes"]
    out += [
        "",
        f"Full-log calibrations with keyframes {k['rule']} (stamps as recorded):",
        "",
        "| log | pairs matched / failed | c_left | c_right | E_d [95 %] | E_b [95 %] | lidar x mm |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        d = k[name]
        out.append(
            f"| {name} | {d['pairs_matched']} / {d['pairs_failed']} | {f(d['c_left'], 4)} | {f(d['c_right'], 4)} "
            f"| {ci(d['Ed'], d['Ed_ci95'], 4)} | {ci(d['Eb'], d['Eb_ci95'], 4)} | {f(d['sensor_pose']['x_mm'], 1)} |"
        )
    return out + [""]


def nominal_section(res: dict) -> list[str]:
    a_d, a_b = res["nominal_mm"]
    o_d, o_b = res["other_nominal_mm"]
    out = [
        "## What depends on the assumed nominal geometry",
        "",
        f"Calibration on the full log (stamps as recorded) with the nominal wheels {a_d:g} mm / wheelbase "
        f"{a_b:g} mm and with {o_d:g} mm / {o_b:g} mm:",
        "",
        f"| log | quantity | {a_d:g} / {a_b:g} | {o_d:g} / {o_b:g} | ratio |",
        "|---|---|---|---|---|",
    ]
    for name in LOGS:
        a = res["studies"][name]["recorded"]
        b = res["studies"][name]["other nominal"]
        ca, cb = a["calibrations"][2], b["calibrations"][2]
        items = [
            ("wheel diameter left mm", ca["wheel_diameter_left_mm"], cb["wheel_diameter_left_mm"]),
            ("wheelbase mm", ca["wheelbase_mm"], cb["wheelbase_mm"]),
            ("c_left", ca["c_left"], cb["c_left"]),
            ("c_right", ca["c_right"], cb["c_right"]),
            ("E_b", ca["Eb"], cb["Eb"]),
            ("E_d - 1", ca["Ed"] - 1, cb["Ed"] - 1),
            ("lidar x mm", ca["sensor_pose"]["x_mm"], cb["sensor_pose"]["x_mm"]),
            ("lidar yaw deg", ca["sensor_pose"]["yaw_deg"], cb["sensor_pose"]["yaw_deg"]),
        ]
        for t in (0, 1):
            ea, eb = a["tests"][t], b["tests"][t]
            after_a = next(e for e in ea["evaluations"] if e["key"] == ea["after"])
            after_b = next(e for e in eb["evaluations"] if e["key"] == eb["after"])
            before_a = next(e for e in ea["evaluations"] if e["key"] == ea["before"])
            before_b = next(e for e in eb["evaluations"] if e["key"] == eb["before"])
            items += [
                (
                    f"{ea['label']}: before, short MSE t m²",
                    before_a["short"]["translation"]["mse_m2"],
                    before_b["short"]["translation"]["mse_m2"],
                ),
                (
                    f"{ea['label']}: after, short MSE t m²",
                    after_a["short"]["translation"]["mse_m2"],
                    after_b["short"]["translation"]["mse_m2"],
                ),
                (
                    f"{ea['label']}: after, short MSE r deg²",
                    after_a["short"]["rotation"]["mse_deg2"],
                    after_b["short"]["rotation"]["mse_deg2"],
                ),
            ]
        for q, va, vb in items:
            ratio = va / vb if vb else math.nan
            out.append(f"| {name} | {q} | {f(va, 5)} | {f(vb, 5)} | {f(ratio, 4)} |")
    return out + [""]


def timing_section(res: dict) -> list[str]:
    t = res["timings"]
    out = [
        "## Time of a full-log self-calibration (one core)",
        "",
        f"Median of {res['repeat']} runs; the numba kernel's first call in this process: "
        f"{f(t['numba_first_call_s'], 2)} s (apart).",
        "",
        "| log | scans | read bag s | plan s | scan matching s | estimate s | library total s | command s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in LOGS:
        m = t[name]["median"]
        scans = res["studies"][name]["recorded"]["scans"]
        out.append(
            f"| {name} | {scans} | {f(m['read_bag_s'], 2)} | {f(m['plan_s'], 3)} | {f(m['match_s'], 2)} "
            f"| {f(m['estimate_s'], 2)} | {f(m['total_s'], 2)} | {f(m['cli_s'], 2)} |"
        )
    out += ["", "The commands timed:", ""] + [f"    {t[name]['command']}" for name in LOGS] + [""]
    return out


def markdown(res: dict) -> str:
    m = res["machine"]
    d, b = res["nominal_mm"]
    lines = [
        "# The lidar self-calibration on real logs (Freiburg SLAM benchmark)",
        "",
        f"Command: `{res['command']}`  ",
        f"Machine: {m['cpu_model']}, {m['cores_available']} of {m['nproc']} cores available, run pinned to CPU "
        f"{m['pinned_cpu']}, "
        f"Python {m['python']}, numpy {m['numpy']}, numba {m['numba']}, scipy {m['scipy']}, rosbags {m['rosbags']}, "
        f"{m['platform']}; load average at the start {m.get('load_average')}.  ",
        f"Wall time of the whole benchmark: {f(res['wall_s'], 1)} s.",
        "",
        f"Nominal geometry assumed (the robots' is not published): wheels {d:g} mm, wheelbase {b:g} mm. "
        "MSE: the benchmark's mean squared error of the relative poses (translation m², rotation deg²); MAE: mean "
        "absolute error. Short relations span less than 10 s (a few scans), long ones the rest (loops). The "
        "systematic fits (95 % intervals assuming independent relations): distance scale and turn scale of the "
        "odometry against the relations (1 is right), heading drift per metre driven (0 is right).",
        "",
    ]
    lines += data_section(res)
    lines += [
        "## Calibrated on one half, tested on the other",
        "",
    ]
    for name in LOGS:
        lines += study_section(name, res["studies"][name]["recorded"], "stamps as recorded")
        lines += study_section(name, res["studies"][name]["delay"], "scans' delay estimated on the calibration half")
    lines += matcher_section(res)
    lines += cross_check_section(res)
    lines += nominal_section(res)
    lines += timing_section(res)
    return "\n".join(lines)


def parse_mm(text: str) -> tuple[float, float]:
    d, b = (float(v) for v in text.split(","))
    return d * 1e-3, b * 1e-3


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=DEFAULT_OUT, help=f"folder for slam2d.json and slam2d.md (default ./{DEFAULT_OUT})")
    p.add_argument("--data", default=str(REPO / "data" / "slam2d"), help="folder of the bags and relations")
    p.add_argument("--nominal-mm", default="200,400", help="nominal wheel diameter and wheelbase [mm]")
    p.add_argument("--other-nominal-mm", default="150,300", help="a second nominal geometry [mm]")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per log")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    info = _machine("numba", "scipy", "rosbags")
    info["pinned_cpu"] = pin_one_core()
    data = Path(args.data)
    nominal, other = parse_mm(args.nominal_mm), parse_mm(args.other_nominal_mm)
    res = {
        "command": shlex.join(["python", "benchmarks/slam2d.py", *(sys.argv[1:] if argv is None else argv)]),
        "machine": info,
        "nominal_mm": [v * 1e3 for v in nominal],
        "other_nominal_mm": [v * 1e3 for v in other],
        "repeat": args.repeat,
        "timings": timings(data, nominal, args.repeat),
        "studies": studies(data, nominal, other),
        "logs": log_facts(data),
        "matchers": matcher_cross_check(data, nominal),
        "keyframes": keyframe_runs(data, nominal),
    }
    res["wall_s"] = time.perf_counter() - t0
    from umbmark.jsonutil import dumps

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "slam2d.json").write_text(dumps(res, indent=1) + "\n", encoding="utf-8")
    (out / "slam2d.md").write_text(markdown(json.loads(dumps(res))) + "\n", encoding="utf-8")
    print(f"wrote {out / 'slam2d.json'} and {out / 'slam2d.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
