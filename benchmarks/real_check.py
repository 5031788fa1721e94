#!/usr/bin/env python3
"""The self-calibration on real logs, judged out of sample: each half of a log calibrates, the
other half checks.

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
3. **Check** on the other half: ``umbmark validate LOG.bag CAL.json --odom-topic /odom
   --relations LOG.relations --window OTHER_HALF --json``: the recorded odometry at the scans
   (the calibration's scan delay applied), its increments turned into wheel travel through the
   nominal geometry and integrated with the calibration's (after) or the nominal one
   (before); the relations of the other half, seen from the lidar; the rules (short-relation
   MSEs at most 2 % above before, long-relation translation MSE not above, each scale within
   1.5 % of 1 or no farther from 1 than before).
4. **The halves agree?** For each parameter, the difference of the two halves' estimates over
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
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
LOGS = ("aces", "mit-csail")
NOMINAL = ["--wheel-diameter-mm", "200", "--wheelbase-mm", "400"]
RULES = ("short_translation_mse", "short_rotation_mse", "long_translation_mse", "distance_scale", "turn_scale")
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


def run_log(name: str, extra: list[str], tmp: Path) -> dict:
    bag = REPO / "data" / "slam2d" / f"{name}.bag"
    rel = REPO / "data" / "slam2d" / f"{name}.relations"
    first, second, t0, mid, t1 = split_bag(bag, tmp)
    halves = {"first half": (first, f"0:{mid - t0:.6f}"), "second half": (second, f"{mid - t0:.6f}:{t1 - t0 + 1:.6f}")}
    out: dict = {"log": name, "split_s": mid - t0, "span_s": t1 - t0, "calibrations": {}, "tests": []}
    for label, (half, _) in halves.items():
        cal_path = tmp / f"{name}-{label.split()[0]}.json"
        d, dt = umbmark(
            "selfcal",
            str(half),
            "--odom-topic",
            "/odom",
            *NOMINAL,
            "--scan-delay",
            "auto",
            *extra,
            "--save",
            str(cal_path),
        )
        out["calibrations"][label] = {"result": d, "command_s": dt, "path": str(cal_path)}
    for cal_label, test_label in (("first half", "second half"), ("second half", "first half")):
        cal_path = out["calibrations"][cal_label]["path"]
        v, dt = umbmark(
            "validate",
            str(bag),
            cal_path,
            "--odom-topic",
            "/odom",
            "--relations",
            str(rel),
            "--window",
            halves[test_label][1],
        )
        out["tests"].append({"calibrated_on": cal_label, "tested_on": test_label, "validate": v, "command_s": dt})
    a, b = (out["calibrations"][k]["result"] for k in ("first half", "second half"))
    agree = {}
    for key, within in PARAMS:
        (va, ha), (vb, hb) = value_and_halfwidth(a, key, within), value_and_halfwidth(b, key, within)
        agree[key] = {"first": va, "second": vb, "z": abs(va - vb) / math.hypot(ha, hb) if ha or hb else math.inf}
    out["agreement"] = agree
    return out


def span_figures(v: dict) -> tuple[dict, dict]:
    """The figures of validate's one span, and its rules by key."""
    (span,) = v["spans"]
    return span, {r["rule"]: r for r in span["rules"]}


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
        "the other half checks (`umbmark validate LOG.bag CAL.json --odom-topic /odom --relations LOG.relations "
        "--window OTHER_HALF`). Before: the nominal geometry and lidar pose; after: the calibration's; both with "
        "the calibration's scan delay. MSE: short relations (< 10 s) translation m² and rotation deg², long ones "
        "translation m²; scales over short relations longer than 0.2 m and turning more than 10 deg. "
        "A figure marked **fail** breaks its rule.",
        "",
    ]
    for log in res["logs"]:
        lines += [f"## {log['log']}", ""]
        lines += [
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
            "| calibrated on, tested on | short MSE t m², before → after | short MSE r deg² | long MSE t m² | "
            "distance scale | turn scale | verdict |",
            "|---|---|---|---|---|---|---|",
        ]
        for t in log["tests"]:
            sp, ok = span_figures(t["validate"])
            b, a = sp["before"], sp["after"]
            cell = lambda key, get, fmt, b=b, a=a, ok=ok: (  # noqa: E731
                f"{fmt.format(get(b))} → {fmt.format(get(a))}" + ("" if ok[key]["passed"] else " **fail**")
            )
            lines.append(
                f"| {t['calibrated_on']}, {t['tested_on']} | "
                f"{cell('short_translation_mse', lambda e: e['short']['translation']['mse_m2'], '{:.5f}')} | "
                f"{cell('short_rotation_mse', lambda e: e['short']['rotation']['mse_deg2'], '{:.3f}')} | "
                f"{cell('long_translation_mse', lambda e: e['long']['translation']['mse_m2'], '{:.4f}')} | "
                f"{cell('distance_scale', lambda e: e['distance_scale'], '{:.4f}')} | "
                f"{cell('turn_scale', lambda e: e['turn_scale'], '{:.4f}')} | "
                f"{sp['verdict']} |"
            )
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
