"""Does the reproduction study depend on its simulation shortcuts? And how long does it take?

The study (`umbmark reproduce`) simulates at a 50 ms sampling period with unquantised encoders
(exact stops). This script runs the same study (same seeds) three ways and compares the
distributions:

* 50 ms, exact stops (the study's default);
* 10 ms, exact stops;
* 10 ms, the `paper` preset as it is (quantised encoders: the robot stops at the first sample
  past its target; the paper's controller sampled below 10 ms);

and it times the default study (200 seeds, no report).

    python benchmarks/reproduce_sampling.py [--seeds 40] [--out FILE]

Writes reproduce_sampling.json into a new folder ./umbmark-bench-reproduce-sampling (or the file
--out, e.g. benchmarks/results/reproduce_sampling.json) and prints it. Takes about a minute.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from umbmark.model.simulate import NOISE_PRESETS
from umbmark.studies import reproduce as rep

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, write_json  # noqa: E402

KEYS = (
    "improvement_median",
    "improvement_p10",
    "improvement_p90",
    "emax_before_median_mm",
    "emax_after_median_mm",
    "emax_final_median_mm",
    "second_pass_fraction",
    "std_after_median_mm",
)


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40)
    add_out(ap, "reproduce-sampling", file="reproduce_sampling.json", what="JSON file to write")
    return ap


def main(argv=None):
    a = parser().parse_args(argv)
    out = {"seeds": a.seeds, "variants": {}}
    for name, period, noise in (
        ("50 ms, exact stops", 0.05, rep.STUDY_NOISE),
        ("10 ms, exact stops", 0.01, rep.STUDY_NOISE),
        ("10 ms, paper preset (quantised)", 0.01, NOISE_PRESETS["paper"]),
    ):
        t = time.perf_counter()
        cfg = rep.StudyConfig(seeds=a.seeds, sample_period_s=period, noise=noise)
        d = rep.run_study(cfg, pitfall=False).to_dict()["distribution"]
        out["variants"][name] = {k: d[k] for k in KEYS} | {"seconds": time.perf_counter() - t}
    t = time.perf_counter()
    rep.run_study(rep.StudyConfig(seeds=200))
    out["default_study_seconds"] = time.perf_counter() - t
    print(write_json(a.out, out))


if __name__ == "__main__":
    main()
