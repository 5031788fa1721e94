"""Drift of a robot's calibration over its sessions (``umbmark drift``, umbmark.history.drift):
steps found where they happened, no alarm from noise or wear, wear rates covered by their
intervals, intervals too narrow for the sessions' scatter widened, and the command's pinned
interface (``changes`` with record/parameter/before/after, ``trends`` per parameter, exit 3)."""

from __future__ import annotations

import contextlib
import io
import json
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.history import Record, open_history, record_result
from umbmark.history.drift import detect_drift, series_of
from umbmark.io.intervals_csv import write_intervals_csv
from umbmark.studies.drift import draw_fleet, record_fleet, score_fleet, session_intervals

START = datetime(2026, 3, 1, 9, 0, tzinfo=timezone.utc)


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


def _record_series(db, robot, values, sds, days=1.0, key="wheelbase_mm", kind="selfcal"):
    for k, (v, sd) in enumerate(zip(values, sds)):
        res = {key: float(v), f"{key}_ci95": [float(v - 1.96 * sd), float(v + 1.96 * sd)]}
        record_result(
            robot, kind=kind, method=kind, results=res, parameters={}, db=db, when=START + timedelta(days=days * k)
        )


def _fake(values, sds, days=1.0, key="wheelbase_mm"):
    """Records in memory (as the history returns them), for the statistical checks."""
    out = []
    for k, (v, sd) in enumerate(zip(values, sds)):
        when = (START + timedelta(days=days * k)).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
        res = {key: float(v), f"{key}_ci95": [float(v - 1.96 * sd), float(v + 1.96 * sd)]}
        out.append(
            Record(k + 1, "r", when, "selfcal", "selfcal", "0", {}, None, None, res, {}, {}, None, None, None, None)
        )
    return out


def _records(db, robot):
    with open_history(db) as h:
        return h.records(robot)


def _series(rng, n=30, level=300.0, sd=0.3, rate=0.0, step_at=None, step=0.0):
    k = np.arange(n)
    y = level + rate * k + sd * rng.standard_normal(n)
    if step_at is not None:
        y[step_at:] += step
    return y


@pytest.mark.parametrize("step_at", [2, 9, 17, 28, 29])
def test_a_step_is_found_where_it_happened(tmp_path, step_at):
    rng = np.random.default_rng(step_at)
    db = tmp_path / "h.sqlite"
    y = _series(rng, rate=-0.01, step_at=step_at, step=3.0)
    _record_series(db, "r", y, [0.3] * 30)
    rep = detect_drift(_records(db, "r"), robot="r")
    (c,) = rep.changes
    ids = [p.record for p in series_of(_records(db, "r"))["wheelbase_mm"].points]
    assert c.record == ids[step_at] and c.previous_record == ids[step_at - 1]
    assert c.parameter == "wheelbase_mm"
    assert c.step_ci95[0] < 3.0 < c.step_ci95[1]
    assert c.after - c.before == pytest.approx(c.step)
    assert c.p_value < 1e-3


def test_noise_and_wear_alone_raise_alarms_at_the_stated_rate():
    # 200 histories without a step at a false-alarm rate of 0.05: about 10 alarms expected
    rng = np.random.default_rng(7)
    alarms = 0
    for _ in range(200):
        sds = rng.uniform(0.1, 0.5, 30)
        y = 300.0 - 0.01 * np.arange(30) + sds * rng.standard_normal(30)
        alarms += detect_drift(_fake(y, sds), robot="r", false_alarm=0.05).alarm
    assert 1 <= alarms <= 20


def test_wear_rates_are_covered_by_their_intervals():
    rng = np.random.default_rng(3)
    covered = 0
    for _ in range(60):
        sds = rng.uniform(0.02, 0.08, 30)
        rate = -0.01  # per session, one session every 2 days
        y = 100.0 + rate * np.arange(30) + sds * rng.standard_normal(30)
        tr = detect_drift(_fake(y, sds, days=2.0, key="wheel_diameter_left_mm"), robot="r").trends[
            "wheel_diameter_left_mm"
        ]
        lo, hi = tr.rate_per_day_ci95
        covered += lo <= rate / 2.0 <= hi
        assert tr.span_days == pytest.approx(58.0)
    assert 51 <= covered <= 60  # 95 % intervals: 57 expected


def test_intervals_too_narrow_are_widened_by_the_scatter():
    # the sessions scatter three times more than their intervals say: no alarm from that
    rng = np.random.default_rng(11)
    alarms = 0
    for _ in range(40):
        y = 300.0 + 0.9 * rng.standard_normal(30)
        rep = detect_drift(_fake(y, [0.3] * 30), robot="r")
        alarms += rep.alarm
        assert rep.trends["wheelbase_mm"].scale > 1.5
    assert alarms <= 1


def test_one_odd_session_in_the_middle_is_not_a_change(tmp_path):
    rng = np.random.default_rng(5)
    db = tmp_path / "h.sqlite"
    y = _series(rng)
    y[14] += 5.0
    _record_series(db, "r", y, [0.3] * 30)
    rep = detect_drift(_records(db, "r"), robot="r")
    assert not [c for c in rep.changes if c.record not in (15, 16)]  # never a step lasting one session


def test_kinds_are_not_mixed_and_short_histories_are_noted(tmp_path):
    rng = np.random.default_rng(2)
    db = tmp_path / "h.sqlite"
    _record_series(db, "r", _series(rng), [0.3] * 30)
    # a replay measures with another bias: recorded between the self-calibrations, not a change of them
    _record_series(db, "r", _series(rng, level=305.0, n=3), [0.3] * 3, kind="replay")
    recs = _records(db, "r")
    assert detect_drift(recs, robot="r").kind == "selfcal"
    assert not detect_drift(recs, robot="r").alarm
    short = detect_drift(recs, robot="r", kind="replay")
    assert not short.trends and "3 sessions" in short.notes[0]
    with pytest.raises(InputError, match="hold no Ed"):
        detect_drift(recs, robot="r", parameters=["Ed"])
    with pytest.raises(InputError, match="false-alarm"):
        detect_drift(recs, robot="r", false_alarm=0.7)


@pytest.mark.slow
def test_a_simulated_fleet(tmp_path):
    # the acceptance's fleet, smaller (8 robots, 20 sessions each; benchmarks/drift_fleet.py runs
    # the whole one): every session self-calibrated from its own intervals
    fleet = draw_fleet(8, 20, 3, seed=4)
    db = tmp_path / "fleet.sqlite"
    record_fleet(fleet, db, 20, seed=4)
    s = score_fleet(fleet, db)
    assert s["steps"] == 3 and s["steps_found"] == 3, s["details"]
    assert s["false_alarms"] == 0, s["details"]
    assert s["wear_rates_covered"] >= s["wear_rates_judged"] - 2


def test_the_command_records_sessions_and_raises_the_alarm(tmp_path):
    (robot,) = [r for r in draw_fleet(6, 12, 6, seed=9) if r.step and r.step.parameter == "wheelbase_mm"][:1]
    db = tmp_path / "h.sqlite"
    for k in range(12):
        f = tmp_path / f"s{k}.csv"
        write_intervals_csv(session_intervals(robot.truth(k), seed=k), f)
        when = (START + timedelta(days=k)).strftime("%Y-%m-%dT%H:%M")
        code, out, err = run(
            "-q", "selfcal", str(f), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300",
            "--robot", "r1", "--record", "--db", str(db), "--recorded-at", when,
        )  # fmt: skip
        assert code == 0, err
    code, out, err = run("drift", "r1", "--db", str(db), "--json", "--plot", str(tmp_path / "d.png"))
    assert code == 3, err
    d = json.loads(out)
    ids = [r["id"] for r in json.loads(run("history", "r1", "--db", str(db), "--json")[1])["records"]]
    first_after = ids[robot.step.session]
    wb = [c for c in d["changes"] if c["parameter"] == "wheelbase_mm"]
    assert len(wb) == 1 and wb[0]["record"] == first_after
    assert wb[0]["after"] / wb[0]["before"] - 1 == pytest.approx(0.015, abs=0.004)
    assert {"record", "parameter", "before", "after"} <= set(wb[0])
    tr = d["trends"]["wheel_diameter_left_mm"]
    assert tr["rate_per_day_ci95"][0] <= tr["rate_per_day"] <= tr["rate_per_day_ci95"][1]
    assert (tmp_path / "d.png").stat().st_size > 10_000
    # the text names the change and what to do; the status is the same
    code, out, _ = run("drift", "r1", "--db", str(db), "--parameter", "wheelbase_mm")
    assert code == 3 and "ALARM: wheelbase_mm changed at record" in out and "what to do" in out
    # the history page draws the same
    code, _, err = run("report", "--robot", "r1", "--db", str(db), "--out", str(tmp_path / "h.html"))
    assert code == 0, err
    page = (tmp_path / "h.html").read_text()
    assert "<h2>Drift</h2>" in page and "<b>wheelbase_mm</b> changed at record #" in page
    # without the changed parameter: no alarm
    code, out, _ = run("drift", "r1", "--db", str(db), "--parameter", "sensor_pose.x_mm", "--json")
    assert code == 0 and json.loads(out)["changes"] == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nobody"], "nobody"),
        (["r", "--false-alarm", "2"], "false-alarm rate must be above 0 and below 0.5"),
        (["r", "--false-alarm", "nan"], "false-alarm rate must be above 0 and below 0.5"),
        (["r", "--parameter", "wheelbase"], "hold no wheelbase with intervals"),
    ],
)
def test_command_errors_are_one_line(tmp_path, args, message):
    db = tmp_path / "h.sqlite"
    _record_series(db, "r", _series(np.random.default_rng(1)), [0.3] * 30)
    code, out, err = run("drift", *args, "--db", str(db))
    assert code == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1


def test_recorded_at_is_checked(tmp_path):
    f = tmp_path / "s.csv"
    write_intervals_csv(session_intervals(draw_fleet(1, 1, 0)[0].truth(0), seed=1), f)
    base = ["selfcal", str(f), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]
    db = tmp_path / "h.sqlite"
    for when, message in [
        ("2026-13-01", "not an ISO 8601 date"),
        ("2999-01-01", "in the future"),
        ("0999-01-01", "before 1970"),
    ]:
        code, _, err = run(*base, "--robot", "r", "--record", "--db", str(db), "--recorded-at", when)
        assert code == 2 and message in err
    assert not db.exists()
    code, _, err = run(*base, "--recorded-at", "2026-01-01")
    assert code == 2 and "needs --record" in err
    code, out, err = run(
        *base, "--robot", "r", "--record", "--db", str(db), "--recorded-at", "2026-01-02T03:04+02:00", "--json"
    )
    assert code == 0, err
    assert _records(db, "r")[0].created_utc.startswith("2026-01-02T01:04:00")


def test_windows_of_a_long_recording_are_calibrated_and_recorded_each(tmp_path):
    from umbmark.model.intervals import Intervals

    robot = draw_fleet(1, 1, 0, seed=1)[0]
    before = session_intervals(robot.truth(0), seed=1, n=480)
    after = session_intervals({**robot.truth(0), "wheelbase_mm": robot.truth(0)["wheelbase_mm"] * 1.03}, seed=2, n=480)
    cat = lambda a: np.concatenate([getattr(before, a), getattr(after, a)])  # noqa: E731
    f = tmp_path / "long.csv"
    write_intervals_csv(Intervals(cat("dt_s"), cat("left_rad"), cat("right_rad"), cat("sensor"), "long"), f)
    db = tmp_path / "h.sqlite"
    base = ["selfcal", str(f), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]
    code, out, err = run(*base, "--window", "2min", "--robot", "r", "--record", "--db", str(db),
                         "--recorded-at", "2026-02-01T08:00", "--json")  # fmt: skip
    assert code == 0, err
    d = json.loads(out)
    wins = d["windows"]
    assert len(wins) == 4 and [w["start_s"] for w in wins] == pytest.approx([0, 120, 240, 360])
    assert [w["start_utc"][:16] for w in wins] == [
        "2026-02-01T08:00",
        "2026-02-01T08:02",
        "2026-02-01T08:04",
        "2026-02-01T08:06",
    ]
    wb = [w["result"]["wheelbase_mm"] for w in wins]
    assert wb[3] / wb[0] - 1 == pytest.approx(0.03, abs=0.01)
    assert "figures" not in wins[0]["result"] and d["wheelbase_mm"] > 0  # the whole recording's result too
    recs = _records(db, "r")
    assert [r.time.strftime("%H:%M") for r in recs] == ["08:00", "08:02", "08:04", "08:06"]
    assert [w["history"]["record_id"] for w in wins] == [r.id for r in recs]
    assert recs[0].note.startswith("window 1 (0-120 s) of")
    # windows no shorter than 10 s, a duration as written; another kind's windows are of its bags
    for window, message in [("5s", "10 s to a week"), ("ten", "no duration"), ("1e9", "no duration")]:
        code, _, err = run(*base, "--window", window)
        assert code == 2 and message in err, err
    mecanum = ["--kinematics", "mecanum", "--joints", "a,b,c,d", "--lx-plus-ly-mm", "400"]
    code, _, err = run(*base[:4], "--window", "1min", *mecanum)
    assert code == 2 and "reads ROS bags" in err, err
