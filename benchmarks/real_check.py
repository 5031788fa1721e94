#!/usr/bin/env python3
"""The self-calibration on real logs, judged out of sample: each half of a log calibrates, the
other half checks, against the nominal odometry and against the best the calibrating half allows.

    python benchmarks/real_check.py                         # into ./umbmark-bench-real-check/
    python benchmarks/real_check.py --out benchmarks/results
    python benchmarks/real_check.py --logs mit-csail --extra=--keyframe-mm=300

For each log of ``data/slam2d/`` (the Freiburg SLAM benchmark's ACES and MIT CSAIL logs: laser
scans, the robot's ``/odom``, relations):

1. **Split**: the log is cut at the middle of its first and last scan stamps; each half becomes
   a ROS 1 bag of its own (the messages whose header stamps lie in it; ``/tf_static`` kept
   whole).
2. **Calibrate** each half, as a user would:
   ``umbmark selfcal HALF.bag --odom-topic /odom --wheel-diameter-mm 200 --wheelbase-mm 400
   --scan-delay auto --json`` (a new process, timed; ``--extra`` adds options).
3. **Odometry at the scans of the whole log**, read here from the bag itself (``rosbags``: the
   ``/odom`` header stamps and poses, the ``/scan`` header stamps; not umbmark's reader): the
   recorded poses interpolated linearly (heading unwrapped) at ``scan stamp - delay`` (the
   calibration's ``scan_delay[0].applied_s``); the increment between consecutive scans turned
   into wheel travel through the nominal geometry as an exact arc (the chord's length over
   ``sinc`` of half the heading change, signed by the direction of travel; left and right
   ``arc -/+ dth b / 2`` over the nominal radius), then integrated again as exact arcs.
   *Before*: the nominal geometry and the nominal (``/tf_static``) lidar pose; *after*: the
   calibration's diameters, wheelbase and lidar pose; *best*: the calibration fitted to the
   calibrating half's own short relations (:class:`real_oracle.RelationFit`: robust least
   squares of the relation errors, each component over its robust spread under the nominal
   odometry), all three with the calibration's delay.
4. **Relations of the other half** (both scans inside it, both within the odometry's time
   span): the odometry's relative pose between their scans seen from the lidar,
   ``l^-1 (+) q (+) l``, against the relation. Short: under 10 s; long: the rest.
5. **Figures**: translation MSE [m²] and rotation MSE [deg²] over the short relations,
   translation MSE over the long ones; the distance scale ``sum |t_odo| |t_rel| / sum |t_rel|²``
   over the short relations longer than 0.2 m; the turn scale, the same with the turns, over the
   short relations turning more than 10 deg (a relation's turn counted in whole turns as the
   odometry's is).
6. **Rules**: each short-relation MSE at most 5 % above the better of *before* and *best*; the
   long-relation MSE at most 10 % above the better of the two; each scale within 1.5 % of 1 or
   no farther from 1 than the farther of the two. *Best* passes every rule by construction.
7. **umbmark validate** on the same half (``--window``), for comparison: its before and after
   figures against those of step 5 (the largest relative difference).
8. **The halves agree?** For each parameter, the difference of the two halves' estimates over
   the combined half-width of their 95 % intervals (at most 1: they agree).

The nominal geometry (200 mm wheels, 400 mm wheelbase) is assumed: the robots' is not
published, and the check, like the calibration's factors, does not depend on it. Writes
real_check.json and real_check.md into --out (created if missing).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402
from real_oracle import RelationFit  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
LOGS = ("aces", "mit-csail")
D_NOM, B_NOM = 0.2, 0.4
NOMINAL = ["--wheel-diameter-mm", "200", "--wheelbase-mm", "400"]
SHORT_S = 10.0
MIN_DISTANCE_M, MIN_TURN_RAD = 0.2, math.radians(10.0)
SHORT_TOLERANCE, LONG_TOLERANCE, SCALE_TOLERANCE = 0.05, 0.10, 0.015
STAMP_TOLERANCE_S = 1e-3
FIGURES = (
    ("short_translation_mse", "short MSE t m²", "{:.5f}"),
    ("short_rotation_mse", "short MSE r deg²", "{:.3f}"),
    ("long_translation_mse", "long MSE t m²", "{:.4f}"),
    ("distance_scale", "distance scale", "{:.4f}"),
    ("turn_scale", "turn scale", "{:.4f}"),
)
PARAMS = (
    ("wheel_diameter_left_mm", None),
    ("wheel_diameter_right_mm", None),
    ("wheelbase_mm", None),
    ("Ed", None),
    ("Eb", None),
    ("x_mm", "sensor_pose"),
    ("y_mm", "sensor_pose"),
    ("yaw_deg", "sensor_pose"),
)


def header_stamp(msg) -> float | None:
    """A message's header stamp [s] (a TFMessage's first transform's), or None."""
    h = getattr(msg, "header", None)
    if h is None and getattr(msg, "transforms", None):
        h = msg.transforms[0].header
    if h is None:
        return None
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


def split_bag(path: Path, folder: Path) -> tuple[Path, Path, float, float, float]:
    """The two halves of a ROS 1 bag by header stamps: (first, second, first scan, middle, last scan)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Writer

    with AnyReader([path]) as r:
        stamps = [
            header_stamp(r.deserialize(raw, c.msgtype))
            for c, _, raw in r.messages(connections=[c for c in r.connections if c.topic == "/scan"])
        ]
        t0, t1 = min(stamps), max(stamps)
        mid = 0.5 * (t0 + t1)
        out = (folder / f"{path.stem}-first.bag", folder / f"{path.stem}-second.bag")
        with Writer(out[0]) as w0, Writer(out[1]) as w1:
            conns = {
                c.id: tuple(
                    w.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest) for w in (w0, w1)
                )
                for c in r.connections
            }
            for con, t, raw in r.messages():
                a, b = conns[con.id]
                if con.topic == "/tf_static":
                    w0.write(a, t, raw)
                    w1.write(b, t, raw)
                    continue
                s = header_stamp(r.deserialize(raw, con.msgtype))
                w, c = (w0, a) if (s if s is not None else t * 1e-9) < mid else (w1, b)
                w.write(c, t, raw)
    return out[0], out[1], t0, mid, t1


# -- the log read and integrated again, as the check's text says ---------------------------------


@dataclass(frozen=True)
class Log:
    """A log's scan stamps and recorded odometry (header stamps, in time order) [s, m, rad]."""

    scan_t_s: np.ndarray
    odom_t_s: np.ndarray
    odom_pose: np.ndarray


def read_log(path: Path) -> Log:
    """The ``/scan`` header stamps and the ``/odom`` header stamps and poses of a bag."""
    from rosbags.highlevel import AnyReader

    scans, odom = [], []
    with AnyReader([path]) as r:
        for c, _, raw in r.messages(connections=[c for c in r.connections if c.topic in ("/scan", "/odom")]):
            msg = r.deserialize(raw, c.msgtype)
            t = header_stamp(msg)
            if c.topic == "/scan":
                scans.append(t)
            else:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
                odom.append((t, p.x, p.y, yaw))
    o = np.array(sorted(odom, key=lambda row: row[0]))
    keep = np.concatenate([[True], np.diff(o[:, 0]) > 0])  # one pose per stamp
    return Log(np.sort(np.array(scans)), o[keep, 0], o[keep, 1:])


def odometry_at_scans(log: Log, delay_s: float) -> np.ndarray:
    """The recorded poses interpolated linearly at ``scan stamp - delay_s`` (heading unwrapped)."""
    st = log.scan_t_s - delay_s
    yaw = np.unwrap(log.odom_pose[:, 2])
    return np.column_stack(
        [np.interp(st, log.odom_t_s, log.odom_pose[:, i]) for i in (0, 1)] + [np.interp(st, log.odom_t_s, yaw)]
    )


def wheel_angles(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative wheel angles (over the nominal radius) of the increments between the poses,
    each an exact arc through the nominal wheelbase: the chord's length over ``sinc(dth / 2)``,
    signed by the direction of travel; the wheels ``arc -/+ dth b / 2``."""
    d = np.diff(pose, axis=0)
    dth = d[:, 2]
    mid = pose[:-1, 2] + 0.5 * dth
    sign = np.where(d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid) < 0, -1.0, 1.0)
    arc = sign * np.hypot(d[:, 0], d[:, 1]) / np.sinc(dth / (2 * math.pi))
    zero = np.zeros(1)
    r = 0.5 * D_NOM
    return (
        np.concatenate([zero, np.cumsum(arc - 0.5 * B_NOM * dth)]) / r,
        np.concatenate([zero, np.cumsum(arc + 0.5 * B_NOM * dth)]) / r,
    )


def integrate(left: np.ndarray, right: np.ndarray, d_left: float, d_right: float, b: float) -> np.ndarray:
    """Poses from cumulative wheel angles with the diameters and wheelbase [m]: exact arcs."""
    sl, sr = 0.5 * d_left * np.diff(left), 0.5 * d_right * np.diff(right)
    ds, dth = 0.5 * (sl + sr), (sr - sl) / b
    th0 = np.concatenate([[0.0], np.cumsum(dth)])
    chord = ds * np.sinc(dth / (2 * math.pi))
    mid = th0[:-1] + 0.5 * dth
    x = np.concatenate([[0.0], np.cumsum(chord * np.cos(mid))])
    y = np.concatenate([[0.0], np.cumsum(chord * np.sin(mid))])
    return np.column_stack([x, y, th0])


def _wrap(a):
    return np.remainder(np.asarray(a) + math.pi, 2 * math.pi) - math.pi


def _between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a^-1 (+) b`` row by row (headings not wrapped)."""
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, b[:, 2] - a[:, 2]])


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a (+) b`` row by row (``a`` or ``b`` one pose or as many rows)."""
    a, b = np.broadcast_arrays(np.atleast_2d(a), np.atleast_2d(b))
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack(
        [a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1], a[:, 2] + b[:, 2]]
    )


def figures(odo: np.ndarray, i1, i2, rel_pose: np.ndarray, short: np.ndarray, lidar) -> dict:
    """The figures of step 5 of one odometry at the scans, seen from the lidar at ``lidar``."""
    lx, ly, lt = lidar
    linv = np.array([-lx * math.cos(lt) - ly * math.sin(lt), lx * math.sin(lt) - ly * math.cos(lt), -lt])
    turn = odo[i2, 2] - odo[i1, 2]
    q = _compose(linv, _compose(_between(odo[i1], odo[i2]), np.array(lidar)))
    c, s = np.cos(rel_pose[:, 2]), np.sin(rel_pose[:, 2])
    inv_rel = np.column_stack(
        [-c * rel_pose[:, 0] - s * rel_pose[:, 1], s * rel_pose[:, 0] - c * rel_pose[:, 1], -rel_pose[:, 2]]
    )
    e = _compose(inv_rel, q)
    et2, er = e[:, 0] ** 2 + e[:, 1] ** 2, _wrap(e[:, 2])
    dist = np.hypot(rel_pose[:, 0], rel_pose[:, 1])
    rel_turn = turn + _wrap(rel_pose[:, 2] - turn)  # the relation's turn nearest the odometry's
    dsel, tsel = short & (dist > MIN_DISTANCE_M), short & (np.abs(rel_turn) > MIN_TURN_RAD)
    tq = np.hypot(q[:, 0], q[:, 1])
    return {
        "short_relations": int(short.sum()),
        "long_relations": int((~short).sum()),
        "short_translation_mse": float(et2[short].mean()),
        "short_rotation_mse": float(np.degrees(er[short]) @ np.degrees(er[short]) / short.sum()),
        "long_translation_mse": float(et2[~short].mean()) if (~short).any() else math.nan,
        "distance_scale": float(tq[dsel] @ dist[dsel] / (dist[dsel] @ dist[dsel])),
        "turn_scale": float(np.abs(turn[tsel]) @ np.abs(rel_turn[tsel]) / (rel_turn[tsel] @ rel_turn[tsel])),
    }


def judge(before: dict, after: dict, best: dict) -> dict:
    """Step 6: each rule's bound and whether *after* meets it (None: no relations for it)."""
    out = {}
    for key, _, _ in FIGURES:
        b, a, o = before[key], after[key], best[key]
        if not math.isfinite(a):
            out[key] = {"bound": math.nan, "passed": None}
            continue
        if key.endswith("mse"):
            bound = (1 + (SHORT_TOLERANCE if key.startswith("short") else LONG_TOLERANCE)) * min(b, o)
            out[key] = {"bound": bound, "passed": bool(a <= bound)}
        else:
            far = max(abs(b - 1), abs(o - 1))
            out[key] = {"bound": max(far, SCALE_TOLERANCE), "passed": bool(abs(a - 1) <= max(far, SCALE_TOLERANCE))}
    return out


def umbmark(*args: str) -> tuple[dict, float]:
    """``umbmark ARGS --json`` in a new process: its JSON and its wall-clock time."""
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "umbmark", *args, "--json"], capture_output=True, text=True)
    dt = time.perf_counter() - t
    if p.returncode != 0:
        raise SystemExit(f"umbmark {' '.join(args)} failed ({p.returncode}): {p.stderr.strip()}")
    return json.loads(p.stdout), dt


def value_and_halfwidth(d: dict, key: str, within: str | None) -> tuple[float, float]:
    src = d[within] if within else d
    lo, hi = src[key + "_ci95"]
    return float(src[key]), 0.5 * (hi - lo)


def calibration_pose(
    d: dict,
) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    """A self-calibration's geometry [m], lidar pose and nominal lidar pose [m, rad]."""
    geo = tuple(d[k] * 1e-3 for k in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm"))
    pose = lambda p: (p["x_mm"] * 1e-3, p["y_mm"] * 1e-3, math.radians(p["yaw_deg"]))  # noqa: E731
    return geo, pose(d["sensor_pose"]), pose(d["nominal_sensor_pose"])  # type: ignore[return-value]


def validate_figures(v: dict) -> dict:
    """``umbmark validate``'s before and after figures in the keys of :func:`figures`."""
    (span,) = v["spans"]
    out = {}
    for which in ("before", "after"):
        e = span[which]
        out[which] = {
            "short_translation_mse": e["short"]["translation"]["mse_m2"],
            "short_rotation_mse": e["short"]["rotation"]["mse_deg2"],
            "long_translation_mse": e["long"]["translation"]["mse_m2"],
            "distance_scale": e["distance_scale"],
            "turn_scale": e["turn_scale"],
        }
    return out


def check_split(log: Log, rel, cal: dict, calibrating, tested) -> dict:
    """Steps 3-6 for one self-calibration's JSON: the figures before, after and best on the tested half."""
    geo, pose, nominal_pose = calibration_pose(cal)
    return check_geometry(
        log, rel, geo, pose, nominal_pose, float(cal["scan_delay"][0]["applied_s"]), calibrating, tested
    )


def check_geometry(log: Log, rel, geo, pose, nominal_pose, delay: float, calibrating, tested) -> dict:
    """Steps 3-6 for one geometry ``(D_L, D_R, b)`` [m] and lidar pose ``(x, y, yaw)`` [m, rad]
    calibrated with the scans' delay ``delay`` [s] on the half of stamps ``calibrating(t)``,
    tested on the half ``tested(t)``: the figures before, after and best, the rules."""
    left, right = wheel_angles(odometry_at_scans(log, delay))
    st = log.scan_t_s
    covered = (st - delay >= log.odom_t_s[0]) & (st - delay <= log.odom_t_s[-1])
    rf = RelationFit(left, right, st, rel)
    ok = (rf.i1 != rf.i2) & covered[rf.i1] & covered[rf.i2]
    inside = lambda half: ok & half(st[rf.i1]) & half(st[rf.i2])  # noqa: E731
    own, test = inside(calibrating), inside(tested)
    short = rel.span_s < SHORT_S
    best_p = rf.fit(own & short)
    args = (rf.i1[test], rf.i2[test], rel.pose[test], short[test])
    before = figures(integrate(left, right, D_NOM, D_NOM, B_NOM), *args, nominal_pose)
    after = figures(integrate(left, right, *geo), *args, pose)
    best = figures(integrate(left, right, *best_p[:3]), *args, tuple(best_p[3:]))
    rules = judge(before, after, best)
    return {
        "delay_s": delay,
        "best": {
            "fitted_relations": int((own & short).sum()),
            "wheel_diameter_left_mm": best_p[0] * 1e3,
            "wheel_diameter_right_mm": best_p[1] * 1e3,
            "wheelbase_mm": best_p[2] * 1e3,
            "sensor_pose": {"x_mm": best_p[3] * 1e3, "y_mm": best_p[4] * 1e3, "yaw_deg": math.degrees(best_p[5])},
        },
        "figures": {"before": before, "after": after, "best": best},
        "rules": rules,
        "verdict": "pass" if all(r["passed"] is not False for r in rules.values()) else "fail",
    }


def run_log(name: str, extra: list[str], tmp: Path) -> dict:
    from umbmark.io.relations import read_relations

    bag = REPO / "data" / "slam2d" / f"{name}.bag"
    rel = read_relations(REPO / "data" / "slam2d" / f"{name}.relations")
    log = read_log(bag)
    first, second, t0, mid, t1 = split_bag(bag, tmp)
    halves = {
        "first half": (first, f"0:{mid - t0:.6f}", lambda t: t < mid),
        "second half": (second, f"{mid - t0:.6f}:{t1 - t0 + 1:.6f}", lambda t: t >= mid),
    }
    out: dict = {"log": name, "split_s": mid - t0, "span_s": t1 - t0, "calibrations": {}, "tests": []}
    for label, (half, _, _) in halves.items():
        cal_path = tmp / f"{name}-{label.split()[0]}.json"
        args = ("selfcal", str(half), "--odom-topic", "/odom", *NOMINAL, "--scan-delay", "auto", *extra)
        d, dt = umbmark(*args, "--save", str(cal_path))
        out["calibrations"][label] = {"result": d, "command_s": dt, "path": str(cal_path)}
    for cal_label, test_label in (("first half", "second half"), ("second half", "first half")):
        cal = out["calibrations"][cal_label]
        test = check_split(log, rel, cal["result"], halves[cal_label][2], halves[test_label][2])
        v, dt = umbmark(
            "validate",
            str(bag),
            cal["path"],
            "--odom-topic",
            "/odom",
            "--relations",
            str(rel.source),
            "--window",
            halves[test_label][1],
        )
        vf = validate_figures(v)
        diff = max(abs(vf[w][k] / test["figures"][w][k] - 1) for w in ("before", "after") for k, _, _ in FIGURES)
        out["tests"].append(
            {"calibrated_on": cal_label, "tested_on": test_label, **test, "validate": vf, "validate_rel_diff": diff}
        )
    a, b = (out["calibrations"][k]["result"] for k in ("first half", "second half"))
    agree = {}
    for key, within in PARAMS:
        (va, ha), (vb, hb) = value_and_halfwidth(a, key, within), value_and_halfwidth(b, key, within)
        agree[key] = {"first": va, "second": vb, "z": abs(va - vb) / math.hypot(ha, hb) if ha or hb else math.inf}
    out["agreement"] = agree
    return out


def _calibration_rows(log: dict) -> list[str]:
    lines = [
        "| calibrated on | command s | scan delay ms | D_L mm [95 %] | D_R mm [95 %] | wheelbase mm [95 %] | E_b | "
        "lidar x, y mm, yaw deg | noise dof | intervals used / rejected |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, c in log["calibrations"].items():
        d = c["result"]
        ci = lambda k, d=d: f"{d[k]:.2f} [{d[k + '_ci95'][0]:.2f}, {d[k + '_ci95'][1]:.2f}]"  # noqa: E731
        sp = d["sensor_pose"]
        delay = d["scan_delay"][0]["applied_s"] * 1e3
        lines.append(
            f"| {label} | {c['command_s']:.1f} | {delay:.1f} | {ci('wheel_diameter_left_mm')} | "
            f"{ci('wheel_diameter_right_mm')} | {ci('wheelbase_mm')} | {d['Eb']:.4f} | "
            f"{sp['x_mm']:.1f}, {sp['y_mm']:.1f}, {sp['yaw_deg']:.2f} | "
            f"{d['noise_dof'] if d.get('noise_dof') is None else round(d['noise_dof'], 2)} | "
            f"{d['intervals_used']} / {len(d['intervals_rejected'])} |"
        )
    lines += [
        "",
        "The best the calibrating half allows (fitted to its own short relations, with the calibration's delay):",
        "",
        "| calibrated on | relations fitted | D_L mm | D_R mm | wheelbase mm | lidar x, y mm, yaw deg |",
        "|---|---|---|---|---|---|",
    ]
    for t in log["tests"]:
        b = t["best"]
        sp = b["sensor_pose"]
        lines.append(
            f"| {t['calibrated_on']} | {b['fitted_relations']} | {b['wheel_diameter_left_mm']:.2f} | "
            f"{b['wheel_diameter_right_mm']:.2f} | {b['wheelbase_mm']:.2f} | "
            f"{sp['x_mm']:.1f}, {sp['y_mm']:.1f}, {sp['yaw_deg']:.2f} |"
        )
    return lines


def _test_rows(log: dict) -> list[str]:
    lines = [
        "| calibrated on, tested on | figure | before | after | best | bound | rule |",
        "|---|---|---|---|---|---|---|",
    ]
    for t in log["tests"]:
        f = t["figures"]
        for key, label, fmt in FIGURES:
            r = t["rules"][key]
            verdict = {True: "pass", False: "**fail**", None: "-"}[r["passed"]]
            bound = ("≤ " + fmt.format(r["bound"])) if key.endswith("mse") else f"\\|x − 1\\| ≤ {r['bound']:.4f}"
            lines.append(
                f"| {t['calibrated_on']}, {t['tested_on']} | {label} | {fmt.format(f['before'][key])} | "
                f"{fmt.format(f['after'][key])} | {fmt.format(f['best'][key])} | {bound} | {verdict} |"
            )
    lines += [
        "",
        "| calibrated on, tested on | verdict | umbmark validate's figures against these: "
        "largest relative difference |",
    ]
    lines += ["|---|---|---|"]
    for t in log["tests"]:
        lines.append(f"| {t['calibrated_on']}, {t['tested_on']} | {t['verdict']} | {t['validate_rel_diff']:.2e} |")
    return lines


def page(res: dict) -> str:
    m = res["machine"]
    lines = [
        "# The self-calibration on real logs, out of sample",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(m),
        "",
        "Each half of a log calibrates (`umbmark selfcal HALF.bag --odom-topic /odom --wheel-diameter-mm 200 "
        "--wheelbase-mm 400 --scan-delay auto" + (" " + " ".join(res["extra"]) if res["extra"] else "") + "`) and "
        "the other half checks, by a re-integration of the log's own `/odom` read from the bag (the script's "
        "steps 3-6): *before* the nominal geometry and lidar pose, *after* the calibration's, *best* the "
        "calibration fitted to the calibrating half's own short relations; all with the calibration's scan delay. "
        "MSE: short relations (< 10 s) translation m² and rotation deg², long ones translation m²; scales over "
        "short relations longer than 0.2 m and turning more than 10 deg. Rules: short MSE at most 5 % above the "
        "better of before and best, long MSE at most 10 %; a scale within 1.5 % of 1 or no farther from 1 than "
        "the farther of before and best.",
        "",
    ]
    for log in res["logs"]:
        lines += [f"## {log['log']}", "", *_calibration_rows(log), "", *_test_rows(log)]
        lines += [
            "",
            "The halves' estimates: difference over the combined half-width of their 95 % intervals "
            "(at most 1: they agree).",
            "",
            "| parameter | first half | second half | difference / combined half-width |",
            "|---|---|---|---|",
        ]
        for key, g in log["agreement"].items():
            lines.append(
                f"| {key} | {g['first']:.4f} | {g['second']:.4f} | {g['z']:.2f}{'' if g['z'] <= 1 else ' **apart**'} |"
            )
        lines.append("")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_out(p, "real-check")
    p.add_argument("--logs", nargs="+", default=list(LOGS), choices=LOGS, help="the logs of data/slam2d/")
    p.add_argument("--extra", action="append", default=[], help="an option added to every selfcal command")
    args = p.parse_args(argv)
    extra = [e for x in args.extra for e in x.split("=", 1)] if args.extra else []
    with tempfile.TemporaryDirectory(prefix="umbmark-real-check-") as tmp:
        logs = [run_log(name, extra, Path(tmp)) for name in args.logs]
    res = {
        "command": command("real_check", argv),
        "machine": machine("rosbags", "scipy", "numba"),
        "extra": extra,
        "logs": logs,
    }
    for path in write_results(Path(args.out), "real_check", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
