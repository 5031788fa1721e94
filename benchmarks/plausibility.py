"""False alarms and detections of the runs plausibility checks (umbmark.correct.plausibility).

Clean runs files simulated with the paper's noise (E_d within 1 +- 0.01, E_b within 1 +- 0.05,
sides of 2, 4 and 6 m, seeded) must give no warning; the same robots' runs mislabelled (units,
labels, columns, frames) must. Prints one JSON object: per runs-per-direction the number of
clean files that warned, per mislabelling how many were flagged, and how many clean files of
robots with large wheelbase errors (E_b 0.6 to 4) warned.

    python benchmarks/plausibility.py --seeds 2000 --runs 3 5 10
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from umbmark.correct.plausibility import runs_warnings
from umbmark.model.geometry import LABMATE, ErrorParams
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import simulate_umbmark

SWAP = {"cw": "ccw", "ccw": "cw"}


def _with(r: RunsTable, **cols) -> RunsTable:
    base = dict(
        direction=list(r.direction),
        x_abs=r.x_abs,
        y_abs=r.y_abs,
        x_odo=r.x_odo,
        y_odo=r.y_odo,
        theta_abs=r.theta_abs,
        theta_odo=r.theta_odo,
        run=r.run,
    )
    base.update(cols)
    return RunsTable.from_columns(**base)


def _scale(r: RunsTable, k: float) -> RunsTable:
    return _with(r, x_abs=r.x_abs * k, y_abs=r.y_abs * k, x_odo=r.x_odo * k, y_odo=r.y_odo * k)


MISLABEL = {
    "metres": lambda r: _scale(r, 1e-3),
    "centimetres": lambda r: _scale(r, 0.1),
    "side_in_cm": lambda r: _scale(r, 10.0),
    "radians": lambda r: _with(r, theta_abs=r.theta_abs * math.pi / 180, theta_odo=r.theta_odo * math.pi / 180),
    "labels": lambda r: _with(r, direction=[SWAP[d] for d in r.direction]),
    "abs_odo": lambda r: _with(
        r, x_abs=r.x_odo, y_abs=r.y_odo, x_odo=r.x_abs, y_odo=r.y_abs, theta_abs=r.theta_odo, theta_odo=r.theta_abs
    ),
    "x_y": lambda r: _with(r, x_abs=r.y_abs, y_abs=r.x_abs, x_odo=r.y_odo, y_odo=r.x_odo),
    "x_y_no_headings": lambda r: _with(
        r, x_abs=r.y_abs, y_abs=r.x_abs, x_odo=r.y_odo, y_odo=r.x_odo, theta_abs=None, theta_odo=None
    ),
    "mirror": lambda r: _with(r, y_abs=-r.y_abs, y_odo=-r.y_odo),
}


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=1000)
    p.add_argument("--runs", type=int, nargs="+", default=[3, 5, 10])
    a = p.parse_args(argv)
    rng = np.random.default_rng(0)
    clean: dict[str, int] = {}
    for n in a.runs:
        fired = 0
        for seed in range(a.seeds):
            ed, eb = 1 + rng.uniform(-0.01, 0.01), 1 + rng.uniform(-0.05, 0.05)
            side = float(rng.choice([2.0, 4.0, 6.0]))
            runs = simulate_umbmark(ErrorParams(ed, eb, 1.0), LABMATE, side, n, None, "paper", seed=seed)
            fired += bool(runs_warnings(runs, side))
        clean[f"{n}_runs"] = fired
    # mislabelled: robots whose errors stand out of the noise (E_d 1 +- 0.0015..0.01, E_b 1 +- 0.01..0.05)
    flagged = dict.fromkeys(MISLABEL, 0)
    n_bad = max(a.seeds // 10, 1)
    for seed in range(n_bad):
        ed = 1 + rng.choice([-1, 1]) * rng.uniform(0.0015, 0.01)
        eb = 1 + rng.choice([-1, 1]) * rng.uniform(0.01, 0.05)
        runs = simulate_umbmark(ErrorParams(ed, eb, 1.0), LABMATE, 4.0, 5, None, "paper", seed=10_000 + seed)
        for k, f in MISLABEL.items():
            flagged[k] += bool(runs_warnings(f(runs), 4.0))
    # clean files of robots with large wheelbase errors (skid steering): 20 per E_b, 4 m square
    large: dict[str, int] = {}
    for eb in (0.6, 0.65, 0.7, 1.5, 2.0, 2.5, 3.0, 4.0):
        fired = 0
        for seed in range(20):
            ed = 1 + rng.uniform(-0.01, 0.01)
            runs = simulate_umbmark(ErrorParams(ed, eb, 1.0), LABMATE, 4.0, 5, None, "paper", seed=20_000 + seed)
            fired += bool(runs_warnings(runs, 4.0))
        large[f"Eb_{eb:g}"] = fired
    res = {
        "seeds": a.seeds,
        "clean_files_warned": clean,
        "mislabelled_files": n_bad,
        "mislabelled_flagged": flagged,
        "large_Eb_files": 20,
        "large_Eb_warned": large,
    }
    print(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
