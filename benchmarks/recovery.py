#!/usr/bin/env python3
"""Noise-free recovery of the exact method over many random robots (what the hypothesis test
in tests/test_exact.py checks on 60 examples, here on as many as you like).

    python benchmarks/recovery.py --cases 700 --seed 12            # the test's whole domain
    python benchmarks/recovery.py --cases 700 --seed 11 --blind    # next to the blind spot
    python benchmarks/recovery.py --cases 300 --seed 5 --edge      # E_b at 0.5, any E_d
    python benchmarks/recovery.py --cases 200 --seed 3 --narrow    # side / wheelbase 100 to 150

Each case: simulated exact-arc (or 10 ms sampled) runs of a random robot written as a runs
file and read back (mm, deg), with or without headings; the exact fit must give E_d within
1e-5 and E_b within 1e-4, or list the truth among its alternatives and say "ambiguous".
``--blind``: E_b 0.5 (+ 0, +-1e-6, 1e-3 or 1e-2) and |E_d - 1| log-uniform in 1e-6 to 1e-2,
exact-arc or sampled. ``--edge``: the same E_b, E_d anywhere in the domain (0.95 to 1.05) and the
wheelbase log-uniform from the smallest the domain allows to 1 m: each turn about 180 deg, legs
that curve by up to several turns on narrow robots. ``--narrow``: the whole domain of E_d and E_b
on the high side / wheelbase end (100 to 150, sides 7.5 to 10 m: legs that curve by whole turns).
Prints every miss and a one-line summary; exit
status 1 if any case missed.
``--answers FILE``: also write every case and its answers, one JSON object a line (to compare
two versions of the fit case by case).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time


def draw_case(rng, blind: bool, edge: bool = False, narrow: bool = False) -> dict:
    """One random robot and test: the domain of the hypothesis test (side / wheelbase <= 150)."""
    if blind:
        ed = 1.0 + float(rng.choice([-1.0, 1.0])) * 10.0 ** rng.uniform(-6.0, -2.0)
        eb = 0.5 + float(rng.choice([0.0, 1e-6, -1e-6, 1e-3, 1e-2]))
    elif edge:
        ed = float(rng.uniform(0.95, 1.05))
        eb = 0.5 + float(rng.choice([0.0, 1e-6, 1e-3, 1e-2]))
    else:
        ed, eb = rng.uniform(0.95, 1.05), rng.uniform(0.5, 2.5)
    side = rng.uniform(7.5, 10.0) if narrow else rng.uniform(0.5, 10.0)
    lo = max(0.05, side / 150.0)
    if narrow:
        b = side / rng.uniform(100.0, 150.0)
    else:
        b = lo * (1.0 / lo) ** rng.uniform() if edge else lo + rng.uniform() * (1.0 - lo)
    return {
        "ed": float(ed),
        "eb": float(eb),
        "side_m": float(side),
        "wheelbase_m": float(b),
        "runs": int(rng.integers(1, 8)),
        "heading": bool(rng.integers(2)),
        "sampled": bool(rng.integers(2)),
    }


def recovered(case: dict) -> tuple[bool, list]:
    from umbmark.correct import correct_runs
    from umbmark.io.runs_csv import format_runs_csv, parse_runs_csv
    from umbmark.model.geometry import ErrorParams, Geometry
    from umbmark.model.simulate import Motion, simulate_umbmark

    motion = Motion(sample_period_s=0.01 if case["sampled"] else None)
    runs = simulate_umbmark(
        ErrorParams(case["ed"], case["eb"]),
        Geometry(0.1, case["wheelbase_m"]),
        case["side_m"],
        n_runs=case["runs"],
        motion=motion,
    )
    runs = parse_runs_csv(format_runs_csv(runs))
    if not case["heading"]:
        runs = dataclasses.replace(runs, theta_abs=None, theta_odo=None)
    c = correct_runs("exact", runs, case["side_m"], case["wheelbase_m"])
    answers = [(c.ed, c.eb)] + list(c.details.alternatives)
    ok = any(abs(e - case["ed"]) < 1e-5 and abs(f - case["eb"]) < 1e-4 for e, f in answers)
    if len(answers) > 1 and not any("ambiguous" in w for w in c.warnings):
        ok = False
    return ok, answers


def main(argv=None) -> int:
    import numpy as np

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--blind", action="store_true", help="robots next to the blind spot E_d = 1, E_b = 0.5")
    g.add_argument("--edge", action="store_true", help="robots with E_b at 0.5 and any E_d")
    g.add_argument("--narrow", action="store_true", help="side / wheelbase 100 to 150 (sides 7.5 to 10 m)")
    p.add_argument("--answers", metavar="FILE", help="write every case and its answers here (JSON lines)")
    a = p.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    t0 = time.perf_counter()
    misses = 0
    out = open(a.answers, "w") if a.answers else None
    for _ in range(a.cases):
        case = draw_case(rng, a.blind, a.edge, a.narrow)
        ok, answers = recovered(case)
        if out is not None:
            out.write(json.dumps({"case": case, "ok": ok, "answers": answers}) + "\n")
        if not ok:
            misses += 1
            print(f"miss: {case} -> {answers}")
    if out is not None:
        out.close()
    kind = (
        "next to the blind spot"
        if a.blind
        else "E_b at 0.5"
        if a.edge
        else "side / wheelbase 100 to 150"
        if a.narrow
        else "whole domain"
    )
    print(f"{kind}, seed {a.seed}: {misses} of {a.cases} missed ({time.perf_counter() - t0:.0f} s)")
    return 1 if misses else 0


if __name__ == "__main__":
    sys.exit(main())
