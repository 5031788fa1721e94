#!/usr/bin/env python3
"""Accuracy of the lidar self-calibration against the Cramer-Rao bound, by kind of driving.

    python benchmarks/selfcal_accuracy.py                          # into ./umbmark-bench-selfcal/
    python benchmarks/selfcal_accuracy.py --quick                  # 40 robots per kind
    python benchmarks/selfcal_accuracy.py --out benchmarks/results

For each kind of driving, ``--robots`` seeded simulated robots (a LabMate-like nominal
geometry, 150 mm wheels and a 340 mm wheelbase, with random systematic errors E_d in
0.99-1.01, E_b in 0.97-1.03, E_s in 0.98-1.02, and a lidar at a random pose: x in +-0.2 m,
y in +-0.1 m, any yaw) drive a program of :mod:`umbmark.model.drive` for ``--duration``
seconds. The program is cut into 0.1 s intervals (one per scan); the wheels turn at the
commanded speeds with a random relative jitter per interval (``--jitter``, seen by the
encoders: a real robot never holds the commanded ratio exactly) and the robot moves along the
exact arcs of its true geometry. The sensor displacements get Gaussian noise like a scan
matcher's (``--noise-mm``, ``--noise-deg``: 1 mm, 1 mm, 0.05 deg).

Kinds: ``mixed`` (:func:`~umbmark.model.drive.mixed_program`: straights, arcs and spins both
ways), ``mixed+outliers`` (the same with 3 % of the intervals failed scan matches, 5-25 cm and
3-13 deg off; the bound is that of the good intervals), ``straights+spins`` (straight legs
back and forth with spins both ways between them), ``one-way``
(:func:`~umbmark.model.drive.one_way_turns`: counter-clockwise quarter arcs and quarter
spins), ``circles`` (counter-clockwise arcs of one radius), ``straights``
(:func:`~umbmark.model.drive.straight_only`) and ``spins``
(:func:`~umbmark.model.drive.spins_only`).

Reported per kind and parameter: the Cramer-Rao bound (root mean square over the robots of
the standard deviation the Fisher information of each robot's intervals allows at its truth),
the root mean square error of :func:`umbmark.correct.selfcal.selfcal` and of the paper's closed
form alone, the ratio of the estimator's error to the bound, the coverage of its 95 %
intervals, how many robots got identifiability warnings or were refused (a singular
problem), and how many failed scan matches were kept and good intervals rejected. Writes
selfcal_accuracy.json and selfcal_accuracy.md into ``--out`` (created if missing) and prints
the Markdown.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from umbmark.correct.selfcal import PARAMETERS, ClosedFormFailed, Limits, closed_form, fisher_information, selfcal
from umbmark.errors import InputError
from umbmark.model.drive import Command, Program, one_way_turns, spins_only, straight_only
from umbmark.model.geometry import Geometry
from umbmark.model.intervals import Intervals, intervals_from_motion

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, machine, machine_text, write_results  # noqa: E402

NOMINAL = Geometry(wheel_diameter_m=0.150, wheelbase_m=0.340)
STEP_S = 0.1
KINDS = ("mixed", "mixed+outliers", "straights+spins", "one-way", "circles", "straights", "spins")
OUTLIER_FRACTION = 0.03  # of the intervals of mixed+outliers: failed scan matches
# what the table shows per parameter: its unit and the factor from SI
UNITS = {
    "r_left_m": ("%", None),
    "r_right_m": ("%", None),
    "wheelbase_m": ("%", None),
    "sensor_x_m": ("mm", 1e3),
    "sensor_y_m": ("mm", 1e3),
    "sensor_yaw_rad": ("deg", 180 / math.pi),
}


def robot(rng: np.random.Generator) -> np.ndarray:
    """A random true robot: ``(r_L, r_R, b, x, y, yaw)`` around the nominal geometry."""
    ed, eb, es = rng.uniform(0.99, 1.01), rng.uniform(0.97, 1.03), rng.uniform(0.98, 1.02)
    d_avg = es * NOMINAL.wheel_diameter_m
    d_left = 2 * d_avg / (1 + ed)
    return np.array(
        [
            0.5 * d_left,
            0.5 * d_left * ed,
            eb * NOMINAL.wheelbase_m,
            rng.uniform(-0.2, 0.2),
            rng.uniform(-0.1, 0.1),
            rng.uniform(-math.pi, math.pi),
        ]
    )


def program(kind: str, duration_s: float, seed: int) -> Program:
    """The driving program of a kind (see the module docstring)."""
    if kind in ("mixed", "mixed+outliers"):
        from umbmark.model.drive import mixed_program

        return mixed_program(duration_s, seed=seed)
    if kind == "straights+spins":
        cycle = [Command(2.0 / 0.3, 0.3), Command(math.pi / 0.8, 0.0, 0.8)]
        cycle += [Command(2.0 / 0.3, 0.3), Command(math.pi / 0.8, 0.0, -0.8)]
        return _repeat(cycle, duration_s)
    if kind == "one-way":
        return one_way_turns(duration_s, step_s=STEP_S)
    if kind == "circles":
        return _repeat([Command(duration_s, 0.25, 0.25 / 1.0)], duration_s)
    if kind == "straights":
        return straight_only(duration_s, step_s=STEP_S)
    if kind == "spins":
        return spins_only(duration_s, step_s=STEP_S)
    raise ValueError(kind)


def _repeat(cycle: list[Command], duration_s: float) -> Program:
    out, left = [], round(duration_s / STEP_S)
    while left > 0:
        for c in cycle:
            n = min(round(c.duration_s / STEP_S), left)
            if n <= 0:
                break
            out.append(Command(n * STEP_S, c.v_mps, c.omega_radps))
            left -= n
    return Program(tuple(out))


def wheel_rotations(prog: Program, rng: np.random.Generator, jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """The wheel rotations of the program's 0.1 s intervals (nominal commands, jittered)."""
    n = [round(c.duration_s / STEP_S) for c in prog.commands]
    v = np.repeat([c.v_mps for c in prog.commands], n)
    w = np.repeat([c.omega_radps for c in prog.commands], n)
    r, half = 0.5 * NOMINAL.wheel_diameter_m, 0.5 * NOMINAL.wheelbase_m
    fl = (v - w * half) / r * STEP_S
    fr = (v + w * half) / r * STEP_S
    k = len(fl)
    return fl * (1 + jitter * rng.standard_normal(k)), fr * (1 + jitter * rng.standard_normal(k))


def one_robot(kind: str, seed: int, a: argparse.Namespace, sigma: np.ndarray) -> dict:
    """Simulate, calibrate and bound one robot."""
    rng = np.random.default_rng([seed, KINDS.index(kind)])
    truth = robot(rng)
    fl, fr = wheel_rotations(program(kind, a.duration, seed), rng, a.jitter)
    exact = intervals_from_motion(fl, fr, STEP_S, truth[0], truth[1], truth[2], truth[3:])
    s = exact.sensor + rng.standard_normal(exact.sensor.shape) * sigma
    good = np.ones(len(fl), dtype=bool)
    if kind == "mixed+outliers":
        bad = rng.choice(len(fl), round(OUTLIER_FRACTION * len(fl)), replace=False)
        jump = rng.uniform(-1, 1, (len(bad), 3)) * [0.2, 0.2, math.radians(10)]
        s[bad] += jump + np.sign(jump) * [0.05, 0.05, math.radians(3)]
        good[bad] = False
    iv = Intervals(exact.dt_s, fl, fr, s)
    info = fisher_information(truth, fl[good], fr[good], sigma)  # the bound of the good intervals
    try:
        crb = np.diag(np.linalg.inv(info))
        crb = np.where(crb > 0, crb, np.inf)
        if np.linalg.cond(info * np.outer(_scale(), _scale())) > 1e12:
            crb = np.full(6, np.inf)
    except np.linalg.LinAlgError:
        crb = np.full(6, np.inf)
    out: dict = {"seed": seed, "intervals": len(iv), "crb_var": crb.tolist()}
    try:
        cf = closed_form(fl, fr, iv.sensor)
        out["closed_form_error"] = _error(cf, truth).tolist()
    except ClosedFormFailed:
        out["closed_form_error"] = None
    t0 = time.perf_counter()
    try:
        res = selfcal(iv, NOMINAL.wheel_diameter_m, NOMINAL.wheelbase_m)
    except InputError as e:
        out.update(refused=str(e), seconds=time.perf_counter() - t0)
        return out
    out["seconds"] = time.perf_counter() - t0
    err = _error(res.params, truth)
    half = res.t_quantile * res.sd
    out.update(
        refused=None,
        error=err.tolist(),
        covered=(np.abs(err) <= half).tolist(),
        warnings=res.warnings,
        rejected=len(res.intervals_rejected),
        outliers_missed=int(np.sum(~good & ~np.isin(np.arange(len(fl)), res.intervals_rejected))),
        good_rejected=int(np.sum(good[list(res.intervals_rejected)])),
    )
    return out


def _scale() -> np.ndarray:
    r, b = 0.5 * NOMINAL.wheel_diameter_m, NOMINAL.wheelbase_m
    return np.array([r, r, b, b, b, 1.0])


def _error(p: np.ndarray, truth: np.ndarray) -> np.ndarray:
    e = np.asarray(p, float) - truth
    e[5] = math.remainder(e[5], 2 * math.pi)
    return e


def summarise(kind: str, rows: list[dict]) -> dict:
    """Bound, errors, ratios, coverage and warnings of one kind."""
    fitted = [r for r in rows if r["refused"] is None]
    crb = np.sqrt(np.mean([r["crb_var"] for r in rows], axis=0))
    per: dict = {}
    for j, name in enumerate(PARAMETERS):
        rms = float(np.sqrt(np.mean([r["error"][j] ** 2 for r in fitted]))) if fitted else math.nan
        cfs = [r["closed_form_error"][j] for r in rows if r["closed_form_error"] is not None]
        cf = float(np.sqrt(np.mean(np.square(cfs)))) if cfs else math.nan
        per[name] = {
            "crb_sd": float(crb[j]),
            "rms_error": rms,
            "ratio": rms / crb[j] if math.isfinite(crb[j]) and crb[j] > 0 else math.nan,
            "closed_form_rms_error": cf,
            "closed_form_ratio": cf / crb[j] if math.isfinite(crb[j]) and crb[j] > 0 else math.nan,
            "coverage95": float(np.mean([r["covered"][j] for r in fitted])) if fitted else math.nan,
        }
    warned = [r for r in fitted if r["warnings"]]
    # well posed: the bound is within the limits beyond which selfcal warns
    lim = Limits()
    allowed = np.array([*(lim.relative_sd * _scale()[:3]), lim.position_sd_m, lim.position_sd_m, lim.yaw_sd_rad])
    well_posed = bool(np.all(crb <= allowed))
    return {
        "kind": kind,
        "robots": len(rows),
        "intervals_per_robot": rows[0]["intervals"],
        "well_posed": well_posed,
        "refused": len(rows) - len(fitted),
        "warned": len(warned),
        "example_message": (
            next((r["refused"] for r in rows if r["refused"]), None) or next((r["warnings"][0] for r in warned), None)
        ),
        "seconds_per_fit_median": float(np.median([r["seconds"] for r in rows])),
        "outliers_missed": int(sum(r["outliers_missed"] for r in fitted)),
        "good_intervals_rejected": int(sum(r["good_rejected"] for r in fitted)),
        "parameters": per,
    }


def _fmt(name: str, v: float) -> str:
    if not math.isfinite(v):
        return "inf" if v == math.inf else "-"
    unit, f = UNITS[name]
    if f is None:  # relative to the nominal value, in percent
        ref = 0.5 * NOMINAL.wheel_diameter_m if name != "wheelbase_m" else NOMINAL.wheelbase_m
        x = 100 * v / ref
    else:
        x = v * f
    return f"{x:.3g}" if abs(x) < 1e4 else f"{x:.1e}"


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    m = res["machine"]
    s = res["settings"]
    lines = [
        "# Lidar self-calibration: accuracy against the Cramer-Rao bound",
        "",
        machine_text(m, load=False),
        "",
        f"Command: `{res['command']}`.",
        "",
        f"{s['robots']} seeded robots per kind of driving, {s['duration_s']:g} s each in {STEP_S:g} s intervals; "
        f"sensor-displacement noise {s['noise_mm']:g} mm, {s['noise_mm']:g} mm, {s['noise_deg']:g} deg; "
        f"wheel-speed jitter {100 * s['jitter']:g} % per interval. Radii and wheelbase in % of the nominal "
        "(75 mm, 340 mm), sensor position in mm, yaw in degrees. CRB: root mean square of each robot's "
        "Cramer-Rao standard deviation; ML: root mean square error of `selfcal`; CF: of the paper's closed "
        "form alone; ratio: ML / CRB; cover: fraction of the 95 % intervals holding the truth.",
        "",
    ]
    for k in res["kinds"]:
        lines += [
            f"## {k['kind']}: {k['intervals_per_robot']} intervals per robot, "
            + ("well posed" if k["well_posed"] else "not well posed (the bound exceeds the warning limits)"),
            "",
            f"Refused (singular): {k['refused']} of {k['robots']}; warned: {k['warned']} of "
            f"{k['robots'] - k['refused']} fitted; median time per fit {k['seconds_per_fit_median'] * 1e3:.0f} ms; "
            f"failed scan matches kept: {k['outliers_missed']}, good intervals rejected: "
            f"{k['good_intervals_rejected']} (of {k['intervals_per_robot'] * (k['robots'] - k['refused'])}).",
            "",
        ]
        if k["example_message"]:
            lines += [f"Example message: {k['example_message']}", ""]
        lines += [
            "| parameter | unit | CRB | ML | ratio | CF | CF ratio | cover |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for name, p in k["parameters"].items():
            ratio = f"{p['ratio']:.2f}" if math.isfinite(p["ratio"]) else "-"
            cfr = f"{p['closed_form_ratio']:.2f}" if math.isfinite(p["closed_form_ratio"]) else "-"
            cover = f"{p['coverage95']:.3f}" if math.isfinite(p["coverage95"]) else "-"
            lines.append(
                f"| {name} | {UNITS[name][0]} | {_fmt(name, p['crb_sd'])} | {_fmt(name, p['rms_error'])} | {ratio} "
                f"| {_fmt(name, p['closed_form_rms_error'])} | {cfr} | {cover} |"
            )
        lines.append("")
    good = [k for k in res["kinds"] if k["well_posed"]]
    worst = max((p["ratio"] for k in good for p in k["parameters"].values()), default=math.nan)
    lines += [
        "## Summary",
        "",
        f"Largest ML / CRB ratio over the well-posed kinds ({', '.join(k['kind'] for k in good)}): {worst:.2f} "
        f"(goal: at most 1.2).",
        "",
    ]
    return "\n".join(lines)


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=200, help="robots per kind (default 200)")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of driving per robot (default 60)")
    ap.add_argument("--noise-mm", type=float, default=1.0, help="sd of the sensor dx, dy [mm] (default 1)")
    ap.add_argument("--noise-deg", type=float, default=0.05, help="sd of the sensor dyaw [deg] (default 0.05)")
    ap.add_argument("--jitter", type=float, default=0.02, help="relative wheel-speed jitter per interval (0.02)")
    ap.add_argument("--kinds", default=",".join(KINDS), help="comma-separated kinds of driving")
    ap.add_argument("--quick", action="store_true", help="40 robots per kind")
    add_out(ap, "selfcal", what="folder to write into")
    return ap


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (see the module docstring); 0 on success."""
    a = parser().parse_args(argv)
    if a.quick:
        a.robots = min(a.robots, 40)
    sigma = np.array([a.noise_mm * 1e-3, a.noise_mm * 1e-3, math.radians(a.noise_deg)])
    kinds = [k.strip() for k in a.kinds.split(",") if k.strip()]
    info = machine("scipy")
    t0 = time.perf_counter()
    res = {
        "machine": info,
        "command": "python benchmarks/selfcal_accuracy.py " + " ".join(shlex.quote(x) for x in (argv or sys.argv[1:])),
        "settings": {
            "robots": a.robots,
            "duration_s": a.duration,
            "noise_mm": a.noise_mm,
            "noise_deg": a.noise_deg,
            "jitter": a.jitter,
            "nominal": {"wheel_diameter_m": NOMINAL.wheel_diameter_m, "wheelbase_m": NOMINAL.wheelbase_m},
        },
        "kinds": [],
    }
    for kind in kinds:
        rows = [one_robot(kind, seed, a, sigma) for seed in range(a.robots)]
        res["kinds"].append(summarise(kind, rows))
    res["seconds"] = time.perf_counter() - t0
    md = markdown(res)
    write_results(a.out, "selfcal_accuracy", res, md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
