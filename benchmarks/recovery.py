#!/usr/bin/env python3
"""Noise-free recovery of the exact method over many random robots (what the hypothesis test
in tests/test_exact.py checks on 60 examples, here on as many as you like).

    python benchmarks/recovery.py --cases 700 --seed 12            # the test's whole domain
    python benchmarks/recovery.py --cases 700 --seed 11 --blind    # next to the blind spot

Each case: simulated exact-arc (or 10 ms sampled) runs of a random robot written as a runs
file and read back (mm, deg), with or without headings; the exact fit must give E_d within
1e-5 and E_b within 1e-4, or list the truth among its alternatives and say "ambiguous".
``--blind``: E_b 0.5 (+ 0, +-1e-6, 1e-3 or 1e-2) and |E_d - 1| log-uniform in 1e-6 to 1e-2,
exact-arc or sampled. Prints every miss and a one-line summary; exit status 1 if any case missed.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time


def draw_case(rng, blind: bool) -> dict:
    """One random robot and test: the domain of the hypothesis test (side / wheelbase <= 150)."""
    if blind:
        ed = 1.0 + float(rng.choice([-1.0, 1.0])) * 10.0 ** rng.uniform(-6.0, -2.0)
        eb = 0.5 + float(rng.choice([0.0, 1e-6, -1e-6, 1e-3, 1e-2]))
    else:
        ed, eb = rng.uniform(0.95, 1.05), rng.uniform(0.5, 2.5)
    side = rng.uniform(0.5, 10.0)
    lo = max(0.05, side / 150.0)
    b = lo + rng.uniform() * (1.0 - lo)
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
    answers = [(c.ed, c.eb)] + [(a["Ed_pass"], a["Eb_pass"]) for a in c.extra["alternatives"]]
    ok = any(abs(e - case["ed"]) < 1e-5 and abs(f - case["eb"]) < 1e-4 for e, f in answers)
    if len(answers) > 1 and not any("ambiguous" in w for w in c.extra["warnings"]):
        ok = False
    return ok, answers


def main(argv=None) -> int:
    import numpy as np

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--blind", action="store_true", help="robots next to the blind spot E_d = 1, E_b = 0.5")
    a = p.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    t0 = time.perf_counter()
    misses = 0
    for _ in range(a.cases):
        case = draw_case(rng, a.blind)
        ok, answers = recovered(case)
        if not ok:
            misses += 1
            print(f"miss: {case} -> {answers}")
    kind = "next to the blind spot" if a.blind else "whole domain"
    print(f"{kind}, seed {a.seed}: {misses} of {a.cases} missed ({time.perf_counter() - t0:.0f} s)")
    return 1 if misses else 0


if __name__ == "__main__":
    sys.exit(main())
