#!/usr/bin/env python3
"""Can a calibration pass the real-data rules at all? The calibration fitted to the benchmark's
own relations, judged as ``umbmark selfcal``'s is.

    python benchmarks/real_oracle.py                         # into ./umbmark-bench-real-oracle/
    python benchmarks/real_oracle.py --out benchmarks/results

``benchmarks/real_check.py`` calibrates each half of a log from its scans and judges the result on
the other half's relations (``umbmark validate``'s rules: short-relation translation and rotation
MSE at most 2 % above the nominal odometry's, long-relation translation MSE not above it, the
distance and turn scales within 1.5 % of 1 or no farther from 1 than before). This script asks
what the best any method could learn from a half would do under the same rules: it replaces the
lidar by the ground truth itself.

For each log of ``data/slam2d/`` and each half:

1. **The scans' delay** is the one ``umbmark selfcal`` estimates on that half (the check applies
   the calibration's delay before and after alike).
2. **The relation fit**: the diameters, the wheelbase and the lidar pose that make the recorded
   odometry (turned into wheel travel through the nominal 200 mm wheels and 400 mm wheelbase,
   integrated again with the fitted geometry, seen from the fitted lidar pose, as the check
   does) agree best with the half's own short relations: robust least squares (soft L1) of the
   relation errors ``relation^-1 (+) prediction``, each component over its robust standard
   deviation under the nominal odometry.
3. **Judged** with :func:`umbmark.realrobot.validate.validate` on the other half (out of sample)
   and on the same half (in sample: the calibration is then the best fit to the very relations
   that judge it).
4. **The whole log**: the same fit to the short relations of the whole log, and to every
   relation of it (short and long, each whitened by its own kind's robust standard deviation),
   judged on each half (the delay the mean of the halves').

A rule that such a calibration breaks in sample asks for something the log's relations
themselves do not support with one set of wheels, wheelbase and lidar pose. Writes
real_oracle.json and real_oracle.md into --out.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
LOGS = ("aces", "mit-csail")
D_NOM, B_NOM = 0.2, 0.4
SHORT_S = 10.0
MAD = 1.482602218505602
RULES = ("short_translation_mse", "short_rotation_mse", "long_translation_mse", "distance_scale", "turn_scale")


def halves(bag):
    """The bag's two halves (split at the middle of its first and last scan) and the split [s after the first]."""
    st = bag.scan_t_s
    mid = 0.5 * (st[0] + st[-1])
    parts = []
    for first in (True, False):
        sm = st < mid if first else st >= mid
        wm = bag.wheel_t_s < mid if first else bag.wheel_t_s >= mid
        wheels = {"odom_pose": bag.odom_pose[wm]}
        parts.append(replace(bag, scan_t_s=st[sm], ranges_m=bag.ranges_m[sm], wheel_t_s=bag.wheel_t_s[wm], **wheels))
    return mid - st[0], parts


def selfcal_delay(part) -> float:
    """The scans' delay ``umbmark selfcal`` estimates on a recording (default settings) [s]."""
    from umbmark.realrobot.selfcal import bag_intervals

    return float(bag_intervals(part, D_NOM, B_NOM).plan.scan_delay_s)


class RelationFit:
    """The odometry at the scans of a log and its relations, for fitting a geometry to them."""

    def __init__(self, left_rad: np.ndarray, right_rad: np.ndarray, scan_t_s: np.ndarray, rel):
        """From the cumulative wheel angles at the scans (over the nominal radius), the scans' stamps
        and the relations."""
        self.left, self.right = np.asarray(left_rad, dtype=float), np.asarray(right_rad, dtype=float)
        self.i1, self.i2 = rel.indices(scan_t_s, 1e-3)
        self.t = scan_t_s - scan_t_s[0]
        self.rel = rel

    @classmethod
    def from_bag(cls, bag, rel, delay_s: float) -> RelationFit:
        """The recorded odometry of a bag read by umbmark at ``scan stamp - delay_s``, turned into
        wheel angles through the nominal geometry as ``umbmark validate`` does."""
        from umbmark.model.dataset import wheel_angles_from_poses
        from umbmark.model.geometry import WheelGeometry
        from umbmark.realrobot.validate import recorded_odometry_at_scans

        nominal = WheelGeometry(D_NOM, D_NOM, B_NOM)
        left, right = wheel_angles_from_poses(recorded_odometry_at_scans(bag, delay_s), nominal)
        return cls(left, right, np.asarray(bag.scan_t_s, dtype=float), rel)

    def select(self, window: tuple[float, float], short_only: bool) -> np.ndarray:
        """The relations with both scans inside the window [s after the first scan] (and short)."""
        ok = (self.i1 >= 0) & (self.i2 >= 0) & (self.i1 != self.i2)
        t1, t2 = self.t[np.maximum(self.i1, 0)], self.t[np.maximum(self.i2, 0)]
        m = ok & (t1 >= window[0]) & (t1 < window[1]) & (t2 >= window[0]) & (t2 < window[1])
        return m & (self.rel.span_s < SHORT_S) if short_only else m

    def errors(self, p: np.ndarray, m: np.ndarray) -> np.ndarray:
        """``relation^-1 (+) prediction`` ``(n, 3)`` of the relations ``m`` for ``p`` =
        (left diameter, right diameter, wheelbase) [m] and the lidar pose (x, y [m], yaw [rad])."""
        from umbmark.model import se2
        from umbmark.model.drive import integrate_wheels
        from umbmark.realrobot.validate import in_sensor_frame

        pose = integrate_wheels(0.5 * p[0] * np.diff(self.left), 0.5 * p[1] * np.diff(self.right), p[2])
        q = in_sensor_frame(se2.between(pose[self.i1[m]], pose[self.i2[m]]), p[3:6])
        e = se2.between(self.rel.pose[m], q)
        e[:, 2] = np.remainder(e[:, 2] + math.pi, 2 * math.pi) - math.pi
        return e

    def fit(self, m: np.ndarray) -> np.ndarray:
        """The geometry and lidar pose of least robust (soft L1) whitened relation error over ``m``
        (short and long relations each whitened by their own robust standard deviations under the
        nominal odometry, so that the few long ones weigh as much per relation as the short)."""
        from scipy.optimize import least_squares

        p0 = np.array([D_NOM, D_NOM, B_NOM, 0.0, 0.0, 0.0])
        short = self.rel.span_s[m] < SHORT_S
        e0 = self.errors(p0, m)
        sd = np.empty_like(e0)
        for g in (short, ~short):
            if g.any():
                e = e0[g]
                sd[g] = np.maximum(MAD * np.median(np.abs(e - np.median(e, axis=0)), axis=0), 1e-6)
        # within a quarter of the nominal size and half a metre
        lo = np.array([0.75 * D_NOM, 0.75 * D_NOM, 0.75 * B_NOM, -0.5, -0.5, -math.pi])
        hi = np.array([1.25 * D_NOM, 1.25 * D_NOM, 1.25 * B_NOM, 0.5, 0.5, math.pi])
        fun = lambda p: (self.errors(p, m) / sd).ravel()  # noqa: E731
        sol = least_squares(fun, p0, loss="soft_l1", x_scale="jac", bounds=(lo, hi))
        return np.asarray(sol.x, dtype=float)


def judge(bag, rel, window, p: np.ndarray, delay_s: float) -> dict:
    """``umbmark validate``'s span of one geometry and lidar pose against the nominal, with the delay."""
    from umbmark.model.geometry import WheelGeometry
    from umbmark.realrobot.validate import CheckedCalibration, validate

    cc = CheckedCalibration(
        "export",
        WheelGeometry(D_NOM, D_NOM, B_NOM),
        WheelGeometry(float(p[0]), float(p[1]), float(p[2])),
        sensor_pose=(float(p[3]), float(p[4]), float(p[5])),
        scan_delay_s=delay_s,
        scan_delay_source="calibration",
    )
    (span,) = validate(bag, cc, rel, window_s=window).spans
    return {"verdict": span.verdict, "rules": [r.to_dict() for r in span.rules]}


def geometry(p: np.ndarray) -> dict:
    return {
        "wheel_diameter_left_mm": p[0] * 1e3,
        "wheel_diameter_right_mm": p[1] * 1e3,
        "wheelbase_mm": p[2] * 1e3,
        "wheel_scale": 0.5 * (p[0] + p[1]) / D_NOM,
        "Ed": p[1] / p[0],
        "Eb": p[2] / B_NOM,
        "sensor_pose": {"x_mm": p[3] * 1e3, "y_mm": p[4] * 1e3, "yaw_deg": math.degrees(p[5])},
    }


def run_log(name: str) -> dict:
    from umbmark.io.relations import read_relations
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.wheels import WheelSource

    bag = read_selfcal_bag(REPO / "data" / "slam2d" / f"{name}.bag", wheels=WheelSource(odom_topic="/odom"))
    rel = read_relations(REPO / "data" / "slam2d" / f"{name}.relations")
    split_s, parts = halves(bag)
    windows = {"first half": (0.0, split_s), "second half": (split_s, 1e9)}
    delays = {label: selfcal_delay(part) for label, part in zip(windows, parts)}
    out: dict = {"log": name, "split_s": split_s, "delays_s": delays, "fits": []}
    for label, window in windows.items():
        other = next(k for k in windows if k != label)
        rf = RelationFit.from_bag(bag, rel, delays[label])
        m = rf.select(window, short_only=True)
        p = rf.fit(m)
        out["fits"].append(
            {
                "fitted_on": f"{label}, short relations",
                "relations": int(m.sum()),
                "delay_s": delays[label],
                "geometry": geometry(p),
                "tests": [
                    {"tested_on": other, **judge(bag, rel, windows[other], p, delays[label])},
                    {"tested_on": f"{label} (in sample)", **judge(bag, rel, window, p, delays[label])},
                ],
            }
        )
    delay = float(np.mean(list(delays.values())))
    rf = RelationFit.from_bag(bag, rel, delay)
    for what, short_only in (("whole log, short relations", True), ("whole log, every relation", False)):
        m = rf.select((0.0, 1e9), short_only=short_only)
        p = rf.fit(m)
        out["fits"].append(
            {
                "fitted_on": what,
                "relations": int(m.sum()),
                "delay_s": delay,
                "geometry": geometry(p),
                "tests": [
                    {"tested_on": f"{label} (in sample)", **judge(bag, rel, w, p, delay)}
                    for label, w in windows.items()
                ],
            }
        )
    return out


def _rule_cell(r: dict) -> str:
    before, after = r["before"], r["after"]
    if r["passed"] is None:
        return "-"
    fmt = "{:.4g}" if "mse" in r["rule"] else "{:.4f}"
    cell = f"{fmt.format(before)} → {fmt.format(after)}"
    return cell + (" **fail**" if r["passed"] is False else "")


def page(res: dict) -> str:
    lines = [
        "# The calibration fitted to the relations themselves",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(res["machine"]),
        f"Wall time {res['wall_s']:.0f} s.",
        "",
        "The diameters, wheelbase and lidar pose that fit a half's own short relations best (robust least "
        "squares of the relation errors, the odometry turned into wheel travel and integrated again as "
        "`umbmark validate` does, with the scans' delay `umbmark selfcal` estimates on that half), judged "
        "by `umbmark validate`'s rules on the other half and on the same half; and the fit to every relation "
        "of the log (its short ones, or all), judged on each half. Nominal: 200 mm wheels, 400 mm wheelbase, "
        "the lidar at the origin. "
        "MSE: short relations translation m² and rotation deg², long ones translation m². "
        "A figure marked **fail** breaks its rule.",
        "",
    ]
    for log in res["logs"]:
        lines += [f"## {log['log']}", ""]
        lines += [
            "| fitted on | relations | delay ms | D_L mm | D_R mm | wheelbase mm | E_d | lidar x, y mm, yaw deg |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for f in log["fits"]:
            g = f["geometry"]
            sp = g["sensor_pose"]
            lines.append(
                f"| {f['fitted_on']} | {f['relations']} | {f['delay_s'] * 1e3:.1f} | "
                f"{g['wheel_diameter_left_mm']:.2f} | {g['wheel_diameter_right_mm']:.2f} | {g['wheelbase_mm']:.2f} | "
                f"{g['Ed']:.5f} | {sp['x_mm']:.1f}, {sp['y_mm']:.1f}, {sp['yaw_deg']:.2f} |"
            )
        lines += [
            "",
            "| fitted on | tested on | short MSE t m² | short MSE r deg² | long MSE t m² | distance scale | "
            "turn scale | verdict |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for f in log["fits"]:
            for t in f["tests"]:
                rules = {r["rule"]: r for r in t["rules"]}
                cells = " | ".join(_rule_cell(rules[k]) if k in rules else "-" for k in RULES)
                lines.append(f"| {f['fitted_on']} | {t['tested_on']} | {cells} | {t['verdict']} |")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_out(p, "real-oracle")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    logs = [run_log(name) for name in LOGS]
    res = {
        "command": command("real_oracle", argv),
        "machine": machine("scipy", "numba", "rosbags"),
        "wall_s": time.perf_counter() - t0,
        "logs": logs,
    }
    for path in write_results(Path(args.out), "real_oracle", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
