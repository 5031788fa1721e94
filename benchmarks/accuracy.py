#!/usr/bin/env python3
"""Accuracy benchmark of the correction methods; same as ``umbmark bench accuracy``.

    python benchmarks/accuracy.py            # full grid, 100 robots per cell (about 8 min on 2 cores)
    python benchmarks/accuracy.py --quick    # small grid, 4 robots per cell (seconds)
    python benchmarks/accuracy.py --out benchmarks/results    # the results kept in the repository

Writes accuracy.{json,csv,md,png} into --out (default: a new folder ./umbmark-bench-accuracy). See
umbmark.studies.accuracy for the definitions (floors, grid, seeds, sampling period).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out  # noqa: E402


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small grid, few robots (tests, examples)")
    p.add_argument("--robots", type=int, default=None, help="robots per cell with noise")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    p.add_argument(
        "--dask", default=None, metavar="ADDRESS", help="run the cells on a Dask cluster (tcp://host:8786, or 'local')"
    )
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--sample-period-ms", type=float, default=None)
    p.add_argument(
        "--coverage-robots",
        type=int,
        default=0,
        help="also measure interval coverage over this many random robots (10 ms sampling)",
    )
    p.add_argument(
        "--fixed-wheelbase",
        choices=("true", "nominal"),
        default="true",
        help="hold the true wheelbase fixed (one robot; default) or the nominal one (true = E_b x nominal)",
    )
    p.add_argument("--eb", type=float, nargs="+", default=None, help="E_b values of the grid (default: all)")
    p.add_argument("--stem", default="accuracy", help="file name stem of the results")
    add_out(p, "accuracy", type=str)
    return p


def main(argv=None) -> int:
    from umbmark.errors import InputError
    from umbmark.studies.accuracy import QUICK, AccuracyConfig, coverage_trial, run_accuracy, write_results

    a = parser().parse_args(argv)
    cfg = QUICK if a.quick else AccuracyConfig()
    changes = {k: v for k, v in (("robots", a.robots), ("seed", a.seed)) if v is not None}
    changes["workers"] = a.workers  # None: all local cores
    changes["fixed_wheelbase"] = a.fixed_wheelbase
    if a.eb:
        changes["eb_values"] = tuple(a.eb)
    if a.sample_period_ms is not None:
        changes["sample_period_s"] = a.sample_period_ms * 1e-3
    cfg = replace(cfg, **changes)
    try:
        res = run_accuracy(
            cfg, progress=lambda i, n: print(f"\rcell {i}/{n}", end="", file=sys.stderr, flush=True), dask=a.dask
        )
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(file=sys.stderr)
    if a.coverage_robots:
        res["coverage_random_robots"] = coverage_trial(a.coverage_robots, sample_period_s=0.01)
    paths = write_results(res, a.out, stem=a.stem)
    for noise, s in res["summary"].items():
        print(noise, s)
    if "coverage_random_robots" in res:
        print("coverage (random robots, 10 ms):", res["coverage_random_robots"])
    print("written:", ", ".join(paths.values()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
