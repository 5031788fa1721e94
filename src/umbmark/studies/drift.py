"""A simulated fleet whose calibrations drift: every robot's tyres wear a little each session,
some robots change suddenly (a wheel swapped, a payload moving the wheels' contact), and every
session is self-calibrated from its own intervals and recorded with its date, so that
:func:`umbmark.history.drift.detect_drift` meets a known truth.

Each session is a drive of random forward, backward and turning intervals seen by a lidar at a
known pose, its displacements disturbed by noise whose size differs from session to session (a
long corridor one day, a cluttered room the next), on a robot whose true geometry is that
session's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import numpy as np

from umbmark.model.intervals import Intervals, intervals_from_motion

__all__ = [
    "Step",
    "FleetRobot",
    "draw_fleet",
    "session_intervals",
    "record_fleet",
    "score_fleet",
    "write_sessions",
    "STEP_KINDS",
    "EXAMPLE_ROBOT",
]

# what a sudden change does: the parameter it moves and by how much (relative)
STEP_KINDS = {"wheelbase": ("wheelbase_mm", 0.015), "left_wheel": ("wheel_diameter_left_mm", -0.008)}
NOMINAL_DIAMETER_M = 0.100
NOMINAL_WHEELBASE_M = 0.300
SENSOR_POSE = (0.10, 0.0, 0.0)


@dataclass(frozen=True)
class Step:
    """A sudden change: from session ``session`` on (0-based), ``parameter`` scaled by ``1 + relative``."""

    session: int
    parameter: str
    relative: float


@dataclass(frozen=True)
class FleetRobot:
    """One simulated robot: its geometry at the first session, its wear per session and its step."""

    name: str
    diameter_left_m: float
    diameter_right_m: float
    wheelbase_m: float
    wear_per_session: float
    step: Step | None

    def truth(self, session: int) -> dict[str, float]:
        """The true geometry at a session (0-based): diameters worn, the step applied."""
        wear = 1.0 - self.wear_per_session * session
        t = {
            "wheel_diameter_left_mm": 1e3 * self.diameter_left_m * wear,
            "wheel_diameter_right_mm": 1e3 * self.diameter_right_m * wear,
            "wheelbase_mm": 1e3 * self.wheelbase_m,
        }
        if self.step is not None and session >= self.step.session:
            t[self.step.parameter] *= 1.0 + self.step.relative
        return t


# the robot of the "keep it calibrated" guide: wheels 100.2 / 99.9 mm, wheelbase 302 mm, wearing
# 0.01 % a session, its left wheel swapped for one 0.8 % smaller before the 8th session
EXAMPLE_ROBOT = FleetRobot("r7", 0.1002, 0.0999, 0.302, 1e-4, Step(7, "wheel_diameter_left_mm", -0.008))


def write_sessions(
    folder: str | Path, robot: FleetRobot = EXAMPLE_ROBOT, n_sessions: int = 10, seed: int = 0
) -> list[Path]:
    """One intervals file per session (``day01.csv``, ...) of a robot, into ``folder``."""
    from umbmark.io.intervals_csv import write_intervals_csv

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for k in range(n_sessions):
        path = folder / f"day{k + 1:02d}.csv"
        write_intervals_csv(session_intervals(robot.truth(k), seed=seed * 1000 + k), path)
        out.append(path)
    return out


def draw_fleet(
    n_robots: int = 20,
    n_sessions: int = 30,
    n_steps: int = 5,
    wear_per_session: float = 1e-4,
    seed: int = 0,
) -> list[FleetRobot]:
    """Robots whose diameters differ by up to 0.3 % from the nominal 100 mm (wheelbase up to 1 %
    from 300 mm), all wearing ``wear_per_session`` of their diameters per session; ``n_steps`` of
    them change suddenly at a random session (2 to ``n_sessions`` - 1), the change drawn from
    :data:`STEP_KINDS`.
    """
    rng = np.random.default_rng(seed)
    stepped = set(rng.choice(n_robots, size=min(n_steps, n_robots), replace=False).tolist())
    kinds = sorted(STEP_KINDS)
    out = []
    for i in range(n_robots):
        step = None
        if i in stepped:
            parameter, relative = STEP_KINDS[kinds[int(rng.integers(len(kinds)))]]
            step = Step(int(rng.integers(2, n_sessions)), parameter, relative)
        d = NOMINAL_DIAMETER_M * (1 + rng.uniform(-3e-3, 3e-3, 2))
        out.append(
            FleetRobot(
                f"robot-{i:02d}",
                float(d[0]),
                float(d[1]),
                NOMINAL_WHEELBASE_M * (1 + float(rng.uniform(-0.01, 0.01))),
                wear_per_session,
                step,
            )
        )
    return out


def session_intervals(truth: dict[str, float], seed: int, n: int = 300, noise_m: float | None = None) -> Intervals:
    """One session's intervals on a robot of the given true geometry: random forward, backward
    and turning half-second intervals, the lidar's displacements disturbed by noise of
    ``noise_m`` (default: drawn from 1 to 3 mm, and as many milliradians)."""
    rng = np.random.default_rng(seed)
    dt = 0.5
    v = rng.uniform(-0.1, 0.5, n)
    w = rng.uniform(-1.0, 1.0, n)
    r, b = NOMINAL_DIAMETER_M / 2, NOMINAL_WHEELBASE_M
    left = (v - w * b / 2) * dt / r
    right = (v + w * b / 2) * dt / r
    iv = intervals_from_motion(
        left,
        right,
        dt,
        truth["wheel_diameter_left_mm"] / 2e3,
        truth["wheel_diameter_right_mm"] / 2e3,
        truth["wheelbase_mm"] / 1e3,
        SENSOR_POSE,
    )
    sd = float(rng.uniform(1e-3, 3e-3)) if noise_m is None else noise_m
    sensor = iv.sensor + sd * rng.standard_normal(iv.sensor.shape)
    return Intervals(iv.dt_s, iv.left_rad, iv.right_rad, sensor, f"session {seed}")


def record_fleet(
    fleet: Sequence[FleetRobot],
    db: str | Path,
    n_sessions: int,
    start: datetime | None = None,
    days_per_session: float = 1.0,
    seed: int = 0,
    n_intervals: int = 300,
) -> int:
    """Self-calibrate every session of every robot and record it, dated one session per
    ``days_per_session`` from ``start``. Returns the number of records."""
    from umbmark.history import open_history
    from umbmark.realrobot.selfcal import selfcal_report

    start = start or datetime(2026, 1, 1, 8, 0, tzinfo=timezone.utc)
    count = 0
    with open_history(db) as h:
        for i, robot in enumerate(fleet):
            for k in range(n_sessions):
                iv = session_intervals(robot.truth(k), seed=seed * 1_000_003 + i * 1000 + k, n=n_intervals)
                rep = selfcal_report(
                    [(f"{robot.name}-{k}", iv)], NOMINAL_DIAMETER_M, NOMINAL_WHEELBASE_M, reject_outliers=True
                )
                h.add(
                    robot.name, when=start + timedelta(days=days_per_session * k), **rep.history_fields(kind="selfcal")
                )
                count += 1
    return count


def score_fleet(
    fleet: Sequence[FleetRobot], db: str | Path, false_alarm: float | None = None, tolerance: int = 2
) -> dict[str, Any]:
    """Judge :func:`~umbmark.history.drift.detect_drift` on a recorded fleet.

    A step is found when a change of its parameter is reported within ``tolerance`` sessions of
    where it happened; every other change (another parameter than the step's and ``Ed`` / ``Eb``,
    which a step of a wheel or of the wheelbase moves too, or the right parameter far from the
    step) is a false alarm. The wear rate of each diameter is judged by its 95 % interval.
    """
    from umbmark.history import open_history
    from umbmark.history.drift import DEFAULT_FALSE_ALARM, detect_drift

    moved_by = {
        "wheelbase_mm": {"wheelbase_mm", "Eb"},
        "wheel_diameter_left_mm": {"wheel_diameter_left_mm", "Ed", "Eb"},
    }
    found = missed = false_alarms = 0
    covered = judged = 0
    rows = []
    with open_history(db) as h:
        for robot in fleet:
            recs = h.records(robot.name)
            index = {r.id: k for k, r in enumerate(sorted(recs, key=lambda r: (r.time, r.id)))}
            rep = detect_drift(recs, robot=robot.name, false_alarm=false_alarm or DEFAULT_FALSE_ALARM)
            hit = False
            for c in rep.changes:
                at = index[c.record]
                near = robot.step is not None and abs(at - robot.step.session) <= tolerance
                if near and c.parameter in moved_by[robot.step.parameter]:  # type: ignore[union-attr]
                    hit = hit or c.parameter == robot.step.parameter  # type: ignore[union-attr]
                else:
                    false_alarms += 1
                    rows.append({"robot": robot.name, "false_alarm": c.to_dict(), "session": at})
            if robot.step is not None:
                found += hit
                missed += not hit
                if not hit:
                    rows.append({"robot": robot.name, "missed": robot.step.__dict__})
            for name in ("wheel_diameter_left_mm", "wheel_diameter_right_mm"):
                tr = rep.trends.get(name)
                if tr is None or tr.rate_per_day_ci95 is None:
                    continue
                truth_rate = (robot.truth(1)[name] - robot.truth(0)[name]) / _days(recs)
                judged += 1
                lo, hi = tr.rate_per_day_ci95
                covered += lo <= truth_rate <= hi
    return {
        "robots": len(fleet),
        "steps": found + missed,
        "steps_found": found,
        "false_alarms": false_alarms,
        "wear_rates_judged": judged,
        "wear_rates_covered": covered,
        "details": rows,
    }


def _days(records: Sequence[Any]) -> float:
    """Days per session of a robot's evenly spaced records."""
    t = sorted(r.time for r in records)
    return (t[-1] - t[0]).total_seconds() / 86400.0 / max(len(t) - 1, 1)
