#!/usr/bin/env python3
"""Method ``exact`` on many runs: ``python benchmarks/exact_scale.py [--quick] [--out DIR]``.

Times :func:`umbmark.correct.exact.exact_correction` on 1,000, 10,000 and 100,000 simulated
runs (half cw, half ccw; paper noise, 50 ms sampling) of two cells of the accuracy benchmark:
``typical`` (E_d 1.005, E_b 1.05: the fit from the paper's estimate explains the runs) and
``far`` (E_d 1.05, E_b 2.5: the global search runs through all its stages, as it does on many
runs wherever the model misses the centres of gravity by more than 3 SEM). Pinned to one
core; the first call of the process (numba's compiled kernel loaded from its cache, scipy
imported) is made on 100 runs before the timings. Also timed:

* the reference computation (``_reference=True``: central differences, the search on every
  run) on 400 runs (200 with --quick), and the largest relative difference of the
  answers and intervals from it;
* ``umbmark analyze FILE --method exact --json`` on a 10,000-run file in a new process
  (imports, reading, the kernel's cache: the user's wait);
* one bootstrap resample of ``exact`` as a report makes it (:func:`umbmark.viz.report.exact_resample_options`)
  on 10, 100 and 1,000 runs, and the least-squares line ``a + b * runs`` through them: the cost
  model of the report's default bootstrap (``EXACT_RESAMPLE_COST_S`` in umbmark/viz/report.py).

Writes exact_scale.json and exact_scale.md into --out (default ./umbmark-bench-exact_scale;
``--out benchmarks/results`` for the results kept in the repository).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, command, machine, machine_text, pin_one_core, write_results  # noqa: E402

CELLS = {"typical": (1.005, 1.05), "far": (1.05, 2.5)}
KEYS = ("Ed_ci95", "Eb_ci95", "wheelbase_corrected_mm_ci95", "Ed_se", "Eb_se", "emax_syst_after_pred_mm")


def _runs(cell: str, n_runs: int, seed: int = 3):
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.simulate import Motion, simulate_umbmark

    ed, eb = CELLS[cell]
    geo = replace(LABMATE, wheelbase_m=LABMATE.wheelbase_m / eb)  # the accuracy benchmark's robot
    runs = simulate_umbmark(
        ErrorParams(ed, eb), geo, 4.0, n_runs // 2, noise="paper", motion=Motion(sample_period_s=0.05), seed=seed
    )
    return runs, geo.wheelbase_m


def _timed(f):
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def _rel(a, b) -> float:
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return float(np.max(np.abs(a - b) / np.abs(b)))


def _differences(fast, ref) -> dict:
    d = {"Ed": _rel(fast.ed, ref.ed), "Eb": _rel(fast.eb, ref.eb)}
    fd, rd = fast.to_dict(), ref.to_dict()
    for k in KEYS:
        if rd.get(k) is not None:
            d[k] = _rel(fd[k], rd[k])
    return d


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="1,000 and 10,000 runs only, the reference on 200 runs")
    add_out(p, "exact_scale")
    a = p.parse_args(argv)
    cpu = pin_one_core()
    info = machine("scipy", "numba")
    from umbmark.correct.exact import exact_correction
    from umbmark.io.runs_csv import write_runs_csv
    from umbmark.viz.report import exact_resample_options

    sizes = (1000, 10000) if a.quick else (1000, 10000, 100000)
    ref_n = 200 if a.quick else 400
    warm_runs, warm_b = _runs("typical", 100)
    _, first_call_s = _timed(lambda: exact_correction(warm_runs, 4.0, warm_b))
    res: dict = {"machine": info, "pinned_cpu": cpu, "command": command("exact_scale", argv), "cells": {}}
    res["first_call_100_runs_s"] = first_call_s
    for cell in CELLS:
        rows = []
        for n in sizes:
            runs, b = _runs(cell, n)
            r, dt = _timed(lambda runs=runs, b=b: exact_correction(runs, 4.0, b))
            rows.append(
                {
                    "runs": n,
                    "seconds": dt,
                    "ms_per_run": dt / n * 1e3,
                    "global_search": r.details.global_search,
                    "Ed": r.ed,
                    "Eb": r.eb,
                }
            )
            print(f"{cell} {n} runs: {dt:.2f} s", file=sys.stderr)
        runs, b = _runs(cell, ref_n)
        fast, t_fast = _timed(lambda runs=runs, b=b: exact_correction(runs, 4.0, b))
        ref, t_ref = _timed(lambda runs=runs, b=b: exact_correction(runs, 4.0, b, _reference=True))
        print(f"{cell} reference {ref_n} runs: {t_ref:.2f} s", file=sys.stderr)
        res["cells"][cell] = {
            "Ed_true": CELLS[cell][0],
            "Eb_true": CELLS[cell][1],
            "timings": rows,
            "reference": {
                "runs": ref_n,
                "seconds": t_ref,
                "fast_seconds": t_fast,
                "speedup": t_ref / t_fast,
                "max_relative_difference": _differences(fast, ref),
            },
        }
    # the user's wait: a new process reading a 10,000-run file
    runs, b = _runs("far", 10000)
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "runs.csv"
        write_runs_csv(runs, f)
        cmd = [sys.executable, "-m", "umbmark", "analyze", str(f), "--wheelbase-mm", f"{b * 1e3:.6f}"]
        cmd += ["--side-mm", "4000", "--method", "exact", "--json"]
        proc, t_cli = _timed(lambda: subprocess.run(cmd, capture_output=True, text=True))
        if proc.returncode != 0:
            raise SystemExit(proc.stderr)
    res["cli_far_10000_runs_s"] = t_cli
    # the report's bootstrap: one resample of exact
    boot = []
    for n in (10, 100, 1000):
        runs, b = _runs("typical", n)
        opts = exact_resample_options(exact_correction(runs, 4.0, b))
        rng = np.random.default_rng(0)
        idx = {d: np.flatnonzero(runs.direction == d) for d in ("cw", "ccw")}
        k = 40
        t = time.perf_counter()
        for _ in range(k):
            pick = np.concatenate([rng.choice(idx[d], size=idx[d].size) for d in ("cw", "ccw")])
            exact_correction(runs.select(pick), 4.0, b, **opts)
        boot.append({"runs": n, "seconds_per_resample": (time.perf_counter() - t) / k})
    x = np.array([r["runs"] for r in boot], dtype=float)
    y = np.array([r["seconds_per_resample"] for r in boot])
    slope, intercept = np.polyfit(x, y, 1)
    res["bootstrap"] = {"resamples": boot, "cost_model_s": [float(intercept), float(slope)]}
    write_results(Path(a.out), "exact_scale", res, _page(res, cpu), show=True)
    return 0


def _page(res: dict, cpu) -> str:
    note = f"pinned to CPU {cpu}" if cpu is not None else "not pinned"
    lines = [
        "# exact on many runs",
        "",
        machine_text(res["machine"], note),
        "",
        f"Command: `{res['command']}`",
        "",
        "Wall time of `exact_correction` on simulated runs (paper noise, 50 ms sampling; half cw, half ccw), "
        f"after a first call of the process on 100 runs ({res['first_call_100_runs_s']:.2f} s: the compiled "
        "kernel loaded from numba's cache, scipy imported). Cells of the accuracy benchmark: `typical` "
        "E_d 1.005, E_b 1.05; `far` E_d 1.05, E_b 2.5 (its global search runs through all stages).",
        "",
        "| cell | runs | seconds | ms per run | global search | E_d | E_b |",
        "|---|---|---|---|---|---|---|",
    ]
    for cell, c in res["cells"].items():
        for r in c["timings"]:
            lines.append(
                f"| {cell} | {r['runs']:,} | {r['seconds']:.2f} | {r['ms_per_run']:.3f} | "
                f"{'yes' if r['global_search'] else 'no'} | {r['Ed']:.6f} | {r['Eb']:.6f} |"
            )
    lines += ["", "## Against the reference computation", ""]
    lines += [
        "| cell | runs | reference s | this s | speed-up | largest relative difference |",
        "|---|---|---|---|---|---|",
    ]
    for cell, c in res["cells"].items():
        r = c["reference"]
        worst = max(r["max_relative_difference"].items(), key=lambda kv: kv[1])
        lines.append(
            f"| {cell} | {r['runs']:,} | {r['seconds']:.2f} | {r['fast_seconds']:.2f} | {r['speedup']:.0f}x | "
            f"{worst[1]:.1e} ({worst[0]}); E_d {r['max_relative_difference']['Ed']:.1e}, "
            f"E_b {r['max_relative_difference']['Eb']:.1e} |"
        )
    lines += [
        "",
        "## The command line",
        "",
        f"`umbmark analyze FILE --method exact --json` on 10,000 runs of the `far` cell in a new process: "
        f"{res['cli_far_10000_runs_s']:.2f} s (start-up, imports, reading the file, the fit).",
        "",
        "## Bootstrap (the report's cost model)",
        "",
        "| runs | ms per resample |",
        "|---|---|",
    ]
    for r in res["bootstrap"]["resamples"]:
        lines.append(f"| {r['runs']:,} | {r['seconds_per_resample'] * 1e3:.1f} |")
    a, b = res["bootstrap"]["cost_model_s"]
    lines += ["", f"Least-squares line: {a * 1e3:.1f} ms + {b * 1e6:.1f} us per run.", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
