"""A campaign on the calibration history and its drift, run through the command line.

One recording counts once in a robot's history: recorded again (the same file, a copy, the
same bag's self-calibration through ``export --record``, the windows of a recording again) it
is refused in one line naming the record that holds it, before anything is computed; writers at
the same moment record it once (the check is inside the write transaction). ``umbmark drift``
refuses a kind no record has (a typo in a cron line) and a kind the robot has no records of,
instead of answering "no change"; sessions recorded in one go (seconds apart) give no wear rate
per day, with a note; a history written before the check that holds one recording twice counts
it once. Robot names with backtick spans are printed as stored by ``history --json``.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import subprocess
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

from umbmark.cli import main
from umbmark.history import open_history, record_result
from umbmark.io.intervals_csv import write_intervals_csv
from umbmark.studies.drift import draw_fleet, session_intervals

SQUARE = REPO / "data" / "optiodom" / "square"
START = datetime(2026, 3, 1, 9, 0, tzinfo=timezone.utc)
SIZES = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def refused(code: int, out: str, err: str) -> str:
    """The one line of a refusal: exit status 2, no traceback, nothing on stdout."""
    assert "Traceback" not in out + err
    assert code == 2 and out == "", (code, err[-600:])
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and "error:" in lines[0], err[-800:]
    return lines[0]


def _ids(db, robot) -> list[int]:
    with open_history(db) as h:
        return [r.id for r in h.records(robot)]


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> Path:
    """Two short intervals files of a simulated robot (30 s each, self-calibrated in half a second)."""
    d = tmp_path_factory.mktemp("sessions")
    robot = draw_fleet(1, 2, 0, seed=3)[0]
    for k in range(2):
        write_intervals_csv(session_intervals(robot.truth(k), seed=k, n=60), d / f"s{k}.csv")
    return d


# -- one recording once -------------------------------------------------------------------------------


def test_a_self_calibration_recorded_again_is_refused_before_it_runs(sessions, tmp_path):
    db = tmp_path / "h.sqlite"
    base = ["selfcal", sessions / "s0.csv", *SIZES, "--robot", "r1", "--record", "--db", db]
    assert run(*base)[0] == 0
    copy = tmp_path / "copy of s0.csv"
    shutil.copy(sessions / "s0.csv", copy)
    save = tmp_path / "again.json"
    for argv in (base, ["selfcal", copy, *SIZES, "--robot", "r1", "--record", "--db", db, "--save", save]):
        line = refused(*run(*argv))
        assert "holds this recording already: record #1 (selfcal, method selfcal" in line, line
        assert "nothing was recorded" in line and str(db) in line
    assert not save.exists()  # refused before the self-calibration ran: nothing written
    # the other robot, the other recording, and the two together are other records
    assert run("selfcal", sessions / "s0.csv", *SIZES, "--robot", "r2", "--record", "--db", db)[0] == 0
    assert run("selfcal", sessions / "s1.csv", *SIZES, "--robot", "r1", "--record", "--db", db)[0] == 0
    both = ["selfcal", sessions / "s0.csv", sessions / "s1.csv", *SIZES, "--robot", "r1", "--record", "--db", db]
    assert run(*both)[0] == 0
    assert "record #4 " in refused(*run(*both))
    assert _ids(db, "r1") == [1, 3, 4]


def test_the_windows_of_a_recording_are_recorded_once(sessions, tmp_path):
    db = tmp_path / "h.sqlite"
    argv = ["selfcal", sessions / "s0.csv", *SIZES, "--window", "10s", "--robot", "r", "--record", "--db", db]
    code, _, err = run(*argv, "--recorded-at", "2026-02-01T08:00")
    assert code == 0, err
    n = len(_ids(db, "r"))
    assert n >= 2
    with open_history(db) as h:
        recs = h.records("r")
    assert len({r.input_sha256 for r in recs}) == 1 and recs[0].inputs["window_s"][0] == 0
    line = refused(*run(*argv, "--recorded-at", "2026-02-02T08:00"))
    assert "holds 0-" in line and " s of this recording already: record #1 " in line
    # the whole recording overlaps its windows: refused as well, and windows of a recorded whole
    assert "holds 0-" in refused(*run(*argv[:6], *argv[8:]))
    assert run("selfcal", sessions / "s1.csv", *SIZES, "--robot", "r", "--record", "--db", db)[0] == 0
    line = refused(*run("selfcal", sessions / "s1.csv", *argv[2:]))
    assert f"holds this recording already: record #{n + 1} " in line
    assert len(_ids(db, "r")) == n + 1


def test_a_self_calibration_recorded_by_export_after_selfcal_is_refused(sessions, tmp_path):
    """Whoever writes it: selfcal --record, then export --record of the same self-calibration."""
    db, cal = tmp_path / "h.sqlite", tmp_path / "cal.json"
    argv = ["selfcal", sessions / "s1.csv", *SIZES, "--save", cal, "--robot", "r", "--record", "--db", db]
    assert run(*argv)[0] == 0
    line = refused(*run("export", cal, "--format", "json", "--robot", "r", "--record", "--db", db))
    assert "record #1 (selfcal" in line


def test_an_analysis_and_a_replay_recorded_again_are_refused(tmp_path):
    db = tmp_path / "h.sqlite"
    runs = tmp_path / "runs.csv"
    assert run("-q", "simulate", "--ed", "1.004", "--eb", "1.02", "--noise", "paper", "--out", runs)[0] == 0
    analyze = ["analyze", runs, "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r", "--record", "--db", db]
    assert run(*analyze)[0] == 0
    assert "record #1 (analyze, method bf" in refused(*run(*analyze))
    assert run(*analyze, "--method", "exact")[0] == 0  # another method: another record
    replay = ["replay", SQUARE / "230620202144", "--no-heldout", "--robot", "r", "--record", "--db", db]
    assert run(*replay)[0] == 0
    line = refused(*run(*replay))
    assert "record #3 (replay, method bf" in line and "230620202144" in line
    # one data set of two already recorded: the replay of both is refused, nothing recorded
    line = refused(*run("replay", SQUARE / "230620202042", *replay[1:]))
    assert "record #3 " in line
    assert _ids(db, "r") == [1, 2, 3]


WRITER = r"""
import os, sys, time
from umbmark.history import SameRecording, open_history

db, go, tag = sys.argv[1], sys.argv[2], sys.argv[3]
h = open_history(db)
print("ready", flush=True)
while not os.path.exists(go):
    time.sleep(0.001)
try:
    rid = h.add("r", kind="selfcal", method="selfcal", input_sha256="ab" * 32, note=tag,
                results={"wheelbase_mm": 300.0}, parameters={"c_left": 1.0, "c_right": 1.0, "Eb": 1.0})
    print(f"recorded {rid}", flush=True)
except SameRecording as e:
    print(f"refused {e.record_id}", flush=True)
"""


def _databases(tmp_path, request) -> list:
    dbs: list = [tmp_path / "h.sqlite"]
    try:
        import sqlalchemy  # noqa: F401
    except ImportError:
        pass
    else:
        dbs.append(f"sqlite:///{tmp_path / 'sa.sqlite'}")
    if os.environ.get("UMBMARK_TEST_POSTGRES_URL"):
        dbs.append(request.getfixturevalue("postgres_url"))
    return dbs


def test_writers_at_the_same_moment_record_one_recording_once(tmp_path, request):
    """Three processes recording one recording of one robot at the same instant (as two fleets at
    once would): one record, two refusals naming it; on every backend."""
    for i, db in enumerate(_databases(tmp_path, request)):
        open_history(db).close()  # the schema exists: the race is the records'
        go = tmp_path / f"go{i}"
        ps = [
            subprocess.Popen([sys.executable, "-c", WRITER, str(db), str(go), f"w{k}"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
            for k in range(3)
        ]  # fmt: skip
        try:
            for p in ps:
                assert p.stdout.readline().strip() == "ready", p.stderr.read()
            go.touch()
            outs = [p.communicate(timeout=60)[0].split() for p in ps]
        finally:
            for p in ps:
                if p.poll() is None:
                    p.kill()
        recorded = [o for o in outs if o[0] == "recorded"]
        assert len(recorded) == 1, outs
        assert sorted(o[1] for o in outs) == [recorded[0][1]] * 3  # the refusals name the record
        assert len(_ids(db, "r")) == 1


# -- drift ------------------------------------------------------------------------------------------


def _record_series(db, values, seconds: float, robot: str = "r", kind: str = "selfcal") -> None:
    for k, v in enumerate(values):
        res = {"wheelbase_mm": float(v), "wheelbase_mm_ci95": [float(v) - 0.6, float(v) + 0.6]}
        when = START + timedelta(seconds=seconds * k)
        record_result(robot, kind=kind, method=kind, results=res, parameters={}, db=db, when=when)


@pytest.fixture(scope="module")
def history(tmp_path_factory) -> Path:
    db = tmp_path_factory.mktemp("drift") / "h.sqlite"
    _record_series(db, 300.0 + 0.3 * np.random.default_rng(1).standard_normal(12), 86400.0)
    record_result("r", kind="analyze", method="bf", results={"Ed": 1.0}, parameters={}, db=db)
    return db


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("selfcall", "no record is of the kind 'selfcall' (selfcal?): the kinds are analyze, replay"),
        ("replay", "robot 'r' has no replay records: no drift of them to follow (its records: 12 selfcal, 1 analyze)"),
        ("analyze", "the analyze records of robot 'r' hold no parameter with its 95 % interval"),
    ],
)
def test_a_kind_without_records_is_refused_not_answered_no_change(history, kind, message):
    line = refused(*run("drift", "r", "--db", history, "--kind", kind))
    assert message in line, line


def test_sessions_recorded_in_one_go_give_no_wear_rate_per_day(tmp_path):
    values = 300.0 + 0.02 * np.arange(10) + 0.05 * np.random.default_rng(4).standard_normal(10)
    apart = tmp_path / "days.sqlite"
    _record_series(apart, values, 86400.0)
    code, out, _ = run("drift", "r", "--db", apart, "--json")
    trend = json.loads(out)["trends"]["wheelbase_mm"]
    assert code == 0 and trend["rate_per_day"] == pytest.approx(0.02, abs=0.01)
    at_once = tmp_path / "seconds.sqlite"
    _record_series(at_once, values, 1.5)
    code, out, _ = run("drift", "r", "--db", at_once, "--json")
    d = json.loads(out)
    assert d["trends"]["wheelbase_mm"]["rate_per_day"] is None
    assert d["trends"]["wheelbase_mm"]["rate_per_day_ci95"] is None
    (note,) = [n for n in d["notes"] if "span" in n]
    assert "the 10 sessions span 14 s: too short a time for a wear rate per day" in note
    assert "--recorded-at" in note  # the flag, not the library's parameter
    code, out, _ = run("drift", "r", "--db", at_once)
    assert "give each session its date, --recorded-at" in " ".join(out.split())


def test_a_history_holding_one_recording_twice_counts_it_once(tmp_path):
    """A history written before the check: the same file recorded twice is one session."""
    db = tmp_path / "h.sqlite"
    values = [300.0, 300.1, 299.9, 300.0, 300.2]
    with open_history(db) as h:
        for k, v in enumerate([*values, values[2]]):
            sha = f"{min(k, 2) if k == 5 else k:064d}"  # the last one: the recording of the third again
            row = h._row(
                "r", "selfcal", "selfcal", {"wheelbase_mm": v, "wheelbase_mm_ci95": [v - 0.5, v + 0.5]}, {}, {},
                sha, None, None, None, START + timedelta(days=k), None,
            )  # fmt: skip
            with h.transaction() as c:
                h._insert(c, row)
    code, out, err = run("drift", "r", "--db", db, "--json")
    d = json.loads(out)
    assert code == 0, err
    assert d["sessions"] == 5 and d["trends"]["wheelbase_mm"]["sessions"] == 5
    assert "record #6 holds the recording of record #3 again (the same content): counted once" in d["notes"]


# -- history --json: robot names as stored -------------------------------------------------------------


@pytest.mark.parametrize("name", ["a`side_mm`b", "`robot`", "r`wheelbase_mm=5` `limit`"])
def test_history_json_prints_robot_names_with_backtick_spans_as_stored(tmp_path, name):
    db = tmp_path / "h.sqlite"
    record_result(name, kind="selfcal", method="selfcal", results={}, parameters={"c_left": 1.0}, db=db)
    for argv in (["history", "--db", db, "--json"], ["history", "--db", db, "--json", "--", name]):
        code, out, err = run(*argv)
        assert code == 0, err
        d = json.loads(out)
        names = [r["robot"] for r in d.get("robots", [])] or [d["robot"], *(r["robot"] for r in d["records"])]
        assert set(names) == {name}
    code, out, _ = run("history", "--db", db, "--show", "1")
    assert json.loads(out)["robot"] == name
    line = refused(*run("drift", "nobody", "--db", db))
    assert f"(robots: {name})" in line
