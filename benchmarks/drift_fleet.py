#!/usr/bin/env python3
"""Change and wear detection on simulated fleets (``umbmark drift``).

    python benchmarks/drift_fleet.py                       # 5 fleets of 20 robots x 30 sessions
    python benchmarks/drift_fleet.py --fleets 1            # a quicker look
    python benchmarks/drift_fleet.py --out benchmarks/results

Each fleet is drawn by :func:`umbmark.studies.drift.draw_fleet` (its seed the fleet's number):
20 robots, their diameters up to 0.3 % and their wheelbase up to 1 % from the nominal 100 mm and
300 mm, every robot's diameters wearing 0.01 % per session, 5 robots changing suddenly at a random
session (the wheelbase +1.5 % or the left wheel -0.8 %). Every session (one a day) is a drive of
300 half-second intervals seen by a lidar with 1-3 mm of noise, self-calibrated by the library
(:func:`umbmark.realrobot.selfcal.selfcal_report`) and recorded in a temporary history with its
date; :func:`umbmark.history.drift.detect_drift` then judges each robot at its default
false-alarm rate (0.001 per parameter).

Reported per fleet (:func:`umbmark.studies.drift.score_fleet`): the steps found within 2 sessions
of where they happened, the false alarms (a change anywhere else, on any parameter), and the
robots' diameter wear rates inside their 95 % intervals. Targets: every step found, at most 1
false alarm per fleet, the wear rates' coverage near 95 %.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

ROBOTS, SESSIONS, STEPS = 20, 30, 5


def one(seed: int) -> dict:
    from umbmark.studies.drift import draw_fleet, record_fleet, score_fleet

    fleet = draw_fleet(ROBOTS, SESSIONS, STEPS, seed=seed)
    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "fleet.sqlite"
        t0 = time.perf_counter()
        record_fleet(fleet, db, SESSIONS, seed=seed)
        t1 = time.perf_counter()
        score = score_fleet(fleet, db)
        t2 = time.perf_counter()
    return {"seed": seed, **score, "record_s": t1 - t0, "drift_s": t2 - t1}


def page(res: dict) -> str:
    lines = [
        "# Change and wear detection on simulated fleets",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(res["machine"]),
        f"Wall time {res['wall_s'] / 60:.1f} min.",
        "",
        f"Each fleet: {ROBOTS} robots x {SESSIONS} daily sessions, wear 0.01 % of the diameters per session, "
        f"{STEPS} robots with a step (wheelbase +1.5 % or left wheel -0.8 %) at a random session; every session "
        "self-calibrated and recorded, then `detect_drift` per robot (false-alarm rate 0.001 per parameter). "
        "A step is found when its parameter's change is reported within 2 sessions of it; any other change "
        "is a false alarm. Wear: the diameters' true rate per day inside the reported 95 % interval.",
        "",
        "| fleet (seed) | steps found | false alarms | wear rates covered | drift time [s] |",
        "|---|---|---|---|---|",
    ]
    for r in res["fleets"]:
        lines.append(
            f"| {r['seed']} | {r['steps_found']} of {r['steps']} | {r['false_alarms']} | "
            f"{r['wear_rates_covered']} of {r['wear_rates_judged']} | {r['drift_s']:.2f} |"
        )
    t = res["total"]
    lines += [
        f"| all | {t['steps_found']} of {t['steps']} | {t['false_alarms']} | "
        f"{t['wear_rates_covered']} of {t['wear_rates_judged']} ({100 * t['coverage']:.0f} %) | |",
        "",
    ]
    for r in res["fleets"]:
        for d in r["details"]:
            lines.append(f"- fleet {r['seed']}: {d}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fleets", type=int, default=5, help="fleets (seeds 1..N; default 5)")
    add_out(p, "drift-fleet")
    args = p.parse_args(argv)
    if args.fleets < 1:
        p.error("--fleets must be at least 1")
    t0 = time.perf_counter()
    fleets = [one(seed) for seed in range(1, args.fleets + 1)]
    keys = ("steps", "steps_found", "false_alarms", "wear_rates_judged", "wear_rates_covered")
    total = {k: sum(f[k] for f in fleets) for k in keys}
    total["coverage"] = total["wear_rates_covered"] / max(total["wear_rates_judged"], 1)
    res = {
        "command": command("drift_fleet", argv),
        "machine": machine("scipy"),
        "wall_s": time.perf_counter() - t0,
        "fleets": fleets,
        "total": total,
    }
    for path in write_results(Path(args.out), "drift_fleet", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
