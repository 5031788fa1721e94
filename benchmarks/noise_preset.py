"""Measure the per-run spread of return errors that the `paper` noise preset gives.

The preset is meant to reproduce the paper's sigma of about 25 mm per direction on the 4 x 4 m
square with the LabMate (0.2 m/s, 10 ms sampling). sigma is the radial sample standard
deviation defined in umbmark.metrics.

    python benchmarks/noise_preset.py [--runs 1000] [--seed 11] [--out FILE]

Writes noise_preset.json into a new folder ./umbmark-bench-noise-preset (or the file --out, e.g.
benchmarks/results/noise_preset.json) and prints it.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict
from pathlib import Path

from umbmark.metrics import umbmark_figures
from umbmark.model.geometry import FIG11_ERRORS
from umbmark.model.simulate import NOISE_PRESETS, Motion, simulate_umbmark

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, write_json  # noqa: E402


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000, help="runs per direction")
    ap.add_argument("--seed", type=int, default=11)
    add_out(ap, "noise-preset", file="noise_preset.json", what="JSON file to write")
    return ap


def main(argv=None):
    a = parser().parse_args(argv)
    out = {"preset": asdict(NOISE_PRESETS["paper"]), "runs_per_direction": a.runs, "seed": a.seed, "by_period": {}}
    for period in (0.01, 0.05):
        t = time.perf_counter()
        res = umbmark_figures(
            simulate_umbmark(
                FIG11_ERRORS, n_runs=a.runs, noise="paper", seed=a.seed, motion=Motion(sample_period_s=period)
            )
        )
        out["by_period"][f"{period * 1e3:g} ms"] = {
            "std_cw_mm": res.cw.std * 1e3,
            "std_ccw_mm": res.ccw.std * 1e3,
            "sem5_cw_mm": res.cw.std * 1e3 / 5**0.5,
            "sem5_ccw_mm": res.ccw.std * 1e3 / 5**0.5,
            "seconds": time.perf_counter() - t,
        }
    print(write_json(a.out, out))


if __name__ == "__main__":
    main()
