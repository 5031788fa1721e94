"""A damaged or foreign history database: one line naming the file and what is wrong, exit 2,
never a traceback; damage in one record leaves the others readable and names the damaged one.
Reading never creates a database; robot names match literally."""

import json
import os
import shutil
import sqlite3
import subprocess
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.history import History, HistoryError, open_history, record_analysis
from umbmark.history.base import DamagedRecord
from umbmark.model.geometry import ErrorParams
from umbmark.model.simulate import simulate_umbmark

READERS = [
    ["history"],
    ["history", "r1"],
    ["history", "r1", "--json"],
    ["history", "--show", "1"],
    ["history", "r1", "--export", "p.json"],
    ["history", "r1", "--plot", "p.png"],
    ["report", "--robot", "r1", "--out", "r.html"],
]


def _analysis(seed: int, ed: float = 1.002, eb: float = 0.99):
    from umbmark.correct.analysis import analyze

    runs = simulate_umbmark(ErrorParams(ed, eb), n_runs=5, noise="paper", seed=seed)
    return analyze(runs, 4.0, 0.34, "bf")


def _make_history(path, robots=("r1",), n=3):
    """A real history: ``n`` simulated analyses per robot, a day apart."""
    for k in range(n):
        a = _analysis(k)
        for robot in robots:
            record_analysis(robot, a, db=path, when=f"2026-05-0{k + 1}T10:00:00Z")
    with sqlite3.connect(path) as c:
        c.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return path


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    return _make_history(tmp_path_factory.mktemp("pristine") / "h.sqlite")


@pytest.fixture
def db(pristine, tmp_path, monkeypatch):
    """A copy of the pristine history in a fresh folder, the current folder."""
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "h.sqlite"
    shutil.copy(pristine, p)
    return p


def _run(argv, db, capsys):
    rc = main([*argv, "--db", str(db)])
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line_error(rc, err, *words):
    """Exit 2 and one error line (after any warnings, one line each) holding ``words``."""
    assert rc == 2, err
    lines = err.splitlines()
    assert err.endswith("\n") and "Traceback" not in err, err
    assert all(line.startswith("warning: ") for line in lines[:-1]), err
    assert lines[-1].startswith("umbmark: error: "), err
    for w in words:
        assert w in lines[-1], err


def _execute(db, *statements):
    with sqlite3.connect(db) as c:
        for s in statements:
            c.execute(s)


# -- the whole file ---------------------------------------------------------------------------------
def test_a_bit_flipped_database_is_one_line(db, capsys):
    data = bytearray(db.read_bytes())
    for i in range(100, len(data), 97):  # past the 100-byte header: the pages themselves
        data[i] ^= 0xFF
    db.write_bytes(bytes(data))
    for argv in READERS:
        rc, _, err = _run(argv, db, capsys)
        _one_line_error(rc, err, "h.sqlite", "damaged")


def test_another_applications_sqlite_file_with_user_version_2(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    foreign = tmp_path / "other.sqlite"
    _execute(foreign, "CREATE TABLE notes (id INTEGER PRIMARY KEY, text TEXT)", "PRAGMA user_version = 2")
    for argv in READERS:
        rc, _, err = _run(argv, foreign, capsys)
        _one_line_error(rc, err, "other.sqlite", "not an umbmark history")
    runs = tmp_path / "runs.csv"
    from umbmark.io.runs_csv import write_runs_csv

    write_runs_csv(simulate_umbmark(ErrorParams(1.002, 0.99), n_runs=5, noise="paper", seed=1), runs)
    argv = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1", "--record"]
    rc, _, err = _run(argv, foreign, capsys)
    _one_line_error(rc, err, "other.sqlite", "not an umbmark history")
    with sqlite3.connect(foreign) as c:  # the foreign file is left as it was, journal mode included
        assert [r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type = 'table'")] == ["notes"]
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    pytest.importorskip("sqlalchemy", reason="SQLAlchemy not installed (optional extra 'db')")
    rc, _, err = _run(["history"], f"sqlite:///{foreign}", capsys)  # the same through SQLAlchemy
    _one_line_error(rc, err, "other.sqlite", "not an umbmark history")
    with sqlite3.connect(foreign) as c:
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "delete"


@pytest.mark.parametrize("table", ["calibrations", "robots"])
def test_a_dropped_table(db, capsys, table):
    _execute(db, "PRAGMA foreign_keys = OFF", f"DROP TABLE {table}")
    for argv in READERS:
        rc, _, err = _run(argv, db, capsys)
        _one_line_error(rc, err, "h.sqlite", f"table '{table}' is missing")


def test_a_dropped_column(db, capsys):
    _execute(db, "ALTER TABLE calibrations DROP COLUMN results_json")
    rc, _, err = _run(["history", "r1"], db, capsys)
    _one_line_error(rc, err, "h.sqlite", "results_json")


# -- one record --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("column", "value", "problem"),
    [
        ("parameters_json", "'{\"c_left\": 1.0'", "parameters_json is not valid JSON"),
        ("results_json", "'[1, 2]'", "results_json holds [1, 2], not a JSON object"),
        ("inputs_json", "X'ff00ff'", "inputs_json holds bytes that are not UTF-8"),
        ("parameters_in_use_json", "12", "parameters_in_use_json holds 12, not a JSON object"),
        ("created_utc", "'last tuesday'", "is not an ISO 8601 time"),
        ("kind", "X'01'", "column kind holds"),
    ],
)
def test_corrupt_record_others_stay_readable(db, capsys, column, value, problem):
    _execute(db, f"UPDATE calibrations SET {column} = {value} WHERE id = 2")
    # listing: the other records, and a warning naming #2 and the file
    rc, out, err = _run(["history", "r1", "--json"], db, capsys)
    assert rc == 0, err
    j = json.loads(out)
    assert [r["id"] for r in j["records"]] == [1, 3]
    assert len(j["warnings"]) == 1 and "record #2" in j["warnings"][0] and problem in j["warnings"][0]
    assert f"warning: record #2 in the history database {db} is damaged" in err and problem in err
    rc, out, err = _run(["history", "r1"], db, capsys)
    assert rc == 0 and "#1" in out and "#3" in out and "#2" not in out and "record #2" in err
    # the damaged record itself: one line, exit 2
    rc, _, err = _run(["history", "--show", "2"], db, capsys)
    _one_line_error(rc, err, "record #2", "h.sqlite", problem)
    rc, _, err = _run(["report", "--id", "2", "--out", "r.html"], db, capsys)
    _one_line_error(rc, err, "record #2", "h.sqlite")
    # the others: shown, exported, plotted, reported
    rc, out, _ = _run(["history", "--show", "3"], db, capsys)
    assert rc == 0 and json.loads(out)["id"] == 3
    rc, _, err = _run(["history", "r1", "--export", "p.json", "--plot", "p.png"], db, capsys)
    if column == "created_utc":
        # "last tuesday" sorts after every ISO time: the damaged record is the newest, and the
        # newest is the one to load: refused (not an older record exported instead)
        _one_line_error(rc, err, "record #2", problem)
        rc, _, err = _run(["history", "r1", "--plot", "p.png"], db, capsys)
        assert rc == 0 and "record #2" in err
    else:
        assert rc == 0 and json.loads(open("p.json").read())["record_id"] == 3 and "record #2" in err
    assert open("p.png", "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    rc, _, err = _run(["report", "--robot", "r1", "--out", "r.html"], db, capsys)
    assert rc == 0, err
    assert "warning: record #2" in err and problem in err  # the page leaves it out, and says so
    html = open("r.html", encoding="utf-8").read()
    assert "#3" in html and "#1" in html
    rc, out, err = _run(["report", "--robot", "r1", "--out", "r2.html", "--json"], db, capsys)
    assert rc == 0 and any("record #2" in w for w in json.loads(out)["warnings"])
    rc, out, err = _run(["history", "--json"], db, capsys)
    assert rc == 0 and json.loads(out)["robots"][0]["latest_id"] == 3


def test_a_damaged_latest_record_is_not_exported(db, capsys):
    """The newest record is the one to load: damaged, nothing is exported (not an older one)."""
    _execute(db, "UPDATE calibrations SET parameters_json = 'c_left=1' WHERE id = 3")
    rc, _, err = _run(["history", "r1", "--export", "p.json"], db, capsys)
    _one_line_error(rc, err, "record #3", "h.sqlite", "parameters_json is not valid JSON")
    assert not os.path.exists("p.json")
    rc, out, err = _run(["history", "r1", "--json"], db, capsys)  # listing still works
    assert rc == 0 and [r["id"] for r in json.loads(out)["records"]] == [1, 2]
    rc, out, err = _run(["history", "--json"], db, capsys)  # the summary: the newest readable one
    assert rc == 0 and json.loads(out)["robots"][0]["latest_id"] == 2 and "record #3" in err


def test_every_record_damaged(db, capsys):
    _execute(db, "UPDATE calibrations SET results_json = '{'")
    for argv in (
        ["history", "r1"],
        ["history", "r1", "--export", "p.json"],
        ["report", "--robot", "r1", "--out", "r.html"],
    ):
        rc, _, err = _run(argv, db, capsys)
        _one_line_error(rc, err, "h.sqlite", "damaged")
    rc, _, err = _run(["history", "--json"], db, capsys)  # records, and not one readable
    _one_line_error(rc, err, "h.sqlite", "damaged")


def test_a_robot_whose_every_record_is_damaged_beside_a_sound_one(pristine, tmp_path, capsys):
    p = _make_history(tmp_path / "two.sqlite", robots=("r1", "r2"), n=2)
    _execute(p, "UPDATE calibrations SET results_json = '{' WHERE robot_id = (SELECT id FROM robots WHERE name = 'r1')")
    rc, out, err = _run(["history", "--json"], p, capsys)
    assert rc == 0, err
    robots = {r["robot"]: r for r in json.loads(out)["robots"]}
    assert "latest_id" not in robots["r1"] and robots["r1"]["records"] == 2 and robots["r2"]["latest_id"] == 4
    assert "record #3" in err  # r1's newest, named
    rc, _, err = _run(["history", "r1"], p, capsys)
    _one_line_error(rc, err, "two.sqlite", "damaged")
    rc, out, _ = _run(["history", "r2", "--json"], p, capsys)
    assert rc == 0 and [r["id"] for r in json.loads(out)["records"]] == [2, 4]


@pytest.mark.parametrize(
    ("assignment", "problem"),
    [
        ("emax_syst_mm = 'abc'", "column emax_syst_mm holds 'abc', not a number"),
        ("ed = X'00ff'", "column ed holds b'\\x00\\xff', not a number"),
        ("eb = 1e999", "column eb holds inf, not a number"),
        ("wheelbase_mm = 'x'", "column wheelbase_mm holds 'x', not a number"),
        ('parameters_json = \'{"c_left": "zz", "c_right": 1.0}\'', "c_left in parameters_json holds 'zz'"),
        ('parameters_json = \'{"c_left": 1.0, "Eb": true}\'', "Eb in parameters_json holds True"),
    ],
)
def test_odd_column_values(db, capsys, assignment, problem):
    """Text, bytes and infinities where numbers belong: that record is named and skipped;
    plots, reports and listings go on with the others."""
    _execute(db, f"UPDATE calibrations SET {assignment} WHERE id = 2")
    rc, out, err = _run(["history", "r1", "--json"], db, capsys)
    assert rc == 0, err
    j = json.loads(out)
    assert [r["id"] for r in j["records"]] == [1, 3] and all(r["emax_syst_mm"] > 0 for r in j["records"])
    assert len(j["warnings"]) == 1 and "record #2" in j["warnings"][0] and problem in j["warnings"][0], j["warnings"]
    for argv in (
        ["history", "r1", "--plot", "p.png"],
        ["report", "--robot", "r1", "--out", "r.html"],
        ["history", "r1"],
    ):
        rc, _, err = _run(argv, db, capsys)
        assert rc == 0, err
    assert open("p.png", "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    rc, _, err = _run(["history", "--show", "2"], db, capsys)
    _one_line_error(rc, err, "record #2", "h.sqlite", problem)
    # the only record odd: nothing to plot or report, one line
    _execute(db, "DELETE FROM calibrations WHERE id <> 2")
    for argv in (["history", "r1", "--plot", "p2.png"], ["report", "--robot", "r1", "--out", "r2.html"]):
        rc, _, err = _run(argv, db, capsys)
        _one_line_error(rc, err, "record #2", "h.sqlite", problem)
    assert not os.path.exists("p2.png") and not os.path.exists("r2.html")


def test_a_record_without_wheel_factors_is_not_exported(db, capsys):
    _execute(db, "UPDATE calibrations SET parameters_json = '{\"Eb\": 1.0}' WHERE id = 3")
    rc, _, err = _run(["history", "r1", "--export", "p.json"], db, capsys)
    _one_line_error(rc, err, "record #3", "h.sqlite", "no usable c_left")
    assert not os.path.exists("p.json")


def test_stored_runs_that_are_not_runs(db, capsys):
    _execute(db, 'UPDATE calibrations SET inputs_json = \'{"runs": [{"run": 1}], "side_mm": 4000}\' WHERE id = 3')
    rc, _, err = _run(["report", "--id", "3", "--out", "r.html"], db, capsys)
    _one_line_error(rc, err, "damaged record")
    rc, _, err = _run(["report", "--robot", "r1", "--out", "r.html"], db, capsys)
    assert rc == 0, err


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    column=st.sampled_from(
        [
            "inputs_json",
            "results_json",
            "parameters_json",
            "parameters_in_use_json",
            "emax_syst_mm",
            "ed",
            "eb",
            "wheelbase_mm",
            "method",
            "created_utc",
            "source",
        ]
    ),
    value=st.one_of(
        st.none(),
        st.text(max_size=30),
        st.binary(max_size=30),
        st.integers(min_value=-(2**63), max_value=2**63 - 1),
        st.floats(allow_nan=False),
        st.recursive(
            st.none() | st.booleans() | st.floats(allow_nan=False) | st.text(max_size=5),
            lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
            max_leaves=8,
        ).map(json.dumps),
    ),
)
def test_any_value_in_any_column_is_read_or_named(pristine, tmp_path, column, value):
    """Whatever a column holds, reading gives records with numbers that are finite or missing,
    or a DamagedRecord naming the record; the other records are always there."""
    # a file of its own per example (tmp_path is shared by the examples: an earlier example's
    # journal beside a fresh copy would read as a damaged file)
    p = Path(tempfile.mkdtemp(dir=tmp_path)) / "any.sqlite"
    shutil.copy(pristine, p)
    c = sqlite3.connect(p)
    try:
        with c:
            c.execute(f"UPDATE calibrations SET {column} = ? WHERE id = 2", (value,))
    except sqlite3.IntegrityError:
        return  # a NOT NULL column refuses None: nothing to read
    finally:
        c.close()
    with History(p, create=False) as h:
        recs = h.records("r1")
        assert {1, 3} <= {r.id for r in recs}
        for r in recs:
            for v in (
                r.emax_syst_mm,
                r.ed,
                r.eb,
                r.wheelbase_mm,
                *(r.parameters.get(k) for k in ("c_left", "c_right")),
            ):
                assert v is None or (isinstance(v, float) and abs(v) < float("inf")) or isinstance(v, int)
            assert isinstance(r.inputs, dict) and isinstance(r.results, dict) and isinstance(r.method, str)
        if 2 not in {r.id for r in recs}:
            assert any("record #2" in w for w in h.warnings)
            with pytest.raises(DamagedRecord, match="record #2"):
                h.get(2)


# -- ids, limits, names ------------------------------------------------------------------------------
def test_huge_ids_and_limits(db, capsys):
    rc, _, err = _run(["history", "--show", "99999999999999999999"], db, capsys)
    _one_line_error(rc, err, "no record #99999999999999999999", "h.sqlite")
    rc, _, err = _run(["history", "r1", "--limit", "99999999999999999999"], db, capsys)
    _one_line_error(rc, err, "--limit must be from 0 to 9223372036854775807", "h.sqlite", "99999999999999999999")
    rc, out, err = _run(["history", "r1", "--limit", str(2**63 - 1), "--json"], db, capsys)
    assert rc == 0, err
    assert [r["id"] for r in json.loads(out)["records"]] == [1, 2, 3]
    rc, out, _ = _run(["history", "r1", "--limit", "1", "--json"], db, capsys)
    assert [r["id"] for r in json.loads(out)["records"]] == [3]


@pytest.fixture(params=["sqlite", "sqlalchemy-sqlite", "postgresql"])
def any_db(request, tmp_path):
    if request.param == "sqlite":
        return tmp_path / "h.sqlite"
    pytest.importorskip("sqlalchemy", reason="SQLAlchemy not installed (optional extra 'db')")
    if request.param == "sqlalchemy-sqlite":
        return f"sqlite:///{tmp_path / 'h.sqlite'}"
    return request.getfixturevalue("postgres_url")


def test_robot_names_with_like_wildcards_match_literally(any_db, capsys):
    names = ["r%", "r_", "r1", "rx", "R%", "r%%", "r\\%"]
    with open_history(any_db) as h:
        for i, name in enumerate(names):
            h.add(name, kind="other", method="m", results={"emax_syst_mm": float(i)}, parameters={})
    with open_history(any_db, create=False) as h:
        for i, name in enumerate(names):
            recs = h.records(name)
            assert [(r.robot, r.emax_syst_mm) for r in recs] == [(name, float(i))]
            assert h.latest(name).robot == name
        assert h.records("r") == [] and h.records("%") == []
    db = str(any_db)
    for name in ("r%", "r_"):
        assert main(["history", name, "--db", db, "--json"]) == 0
        recs = json.loads(capsys.readouterr().out)["records"]
        assert [r["robot"] for r in recs] == [name]
    assert main(["history", "%", "--db", db]) == 2
    assert "no calibrations of robot '%'" in capsys.readouterr().err


def test_damaged_record_on_every_backend(any_db):
    """The same reading rules through SQLAlchemy (PostgreSQL and SQLite)."""
    with open_history(any_db) as h:
        for k in range(3):
            h.add("r1", kind="other", method="m", results={"emax_syst_mm": k}, parameters={}, when=f"2026-01-0{k + 1}")
    if isinstance(any_db, str):
        import sqlalchemy as sa

        eng = sa.create_engine(any_db)
        with eng.begin() as c:
            c.exec_driver_sql("UPDATE calibrations SET results_json = '{oops' WHERE id = 2")
        eng.dispose()
    else:
        _execute(any_db, "UPDATE calibrations SET results_json = '{oops' WHERE id = 2")
    with open_history(any_db, create=False) as h:
        assert [r.id for r in h.records("r1")] == [1, 3]
        assert len(h.warnings) == 1 and "record #2" in h.warnings[0] and "results_json" in h.warnings[0]
        with pytest.raises(DamagedRecord, match=r"record #2 .* results_json is not valid JSON"):
            h.get(2)
        with pytest.raises(Exception, match="no record #99999999999999999999"):
            h.get(99999999999999999999)
        assert len(h.records("r1", limit=2**63 - 1)) == 2
        with pytest.raises(Exception, match="`limit` must be from 0"):
            h.records("r1", limit=99999999999999999999)


# -- reading creates nothing; a database that cannot be written --------------------------------------
def test_reading_a_missing_database_creates_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for db in ("missing.sqlite", "nodir/missing.sqlite", f"sqlite:///{tmp_path / 'url.sqlite'}"):
        for argv in READERS:
            rc = main([*argv, "--db", db])
            _one_line_error(rc, capsys.readouterr().err, "missing" if "missing" in db else "url.sqlite")
    monkeypatch.setenv("UMBMARK_DB", str(tmp_path / "env" / "h.sqlite"))
    assert main(["history"]) == 2
    capsys.readouterr()
    monkeypatch.delenv("UMBMARK_DB")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert main(["history", "r1"]) == 2
    capsys.readouterr()
    assert sorted(os.listdir(tmp_path)) == [], os.listdir(tmp_path)
    empty = tmp_path / "empty.sqlite"
    empty.touch()
    for argv in READERS:
        rc = main([*argv, "--db", str(empty)])
        _one_line_error(rc, capsys.readouterr().err, "empty.sqlite", "empty")
    assert empty.read_bytes() == b"" and sorted(os.listdir(tmp_path)) == ["empty.sqlite"]
    pytest.importorskip("sqlalchemy", reason="SQLAlchemy not installed (optional extra 'db')")
    assert main(["history", "--db", f"sqlite:///{empty}"]) == 2
    assert "no umbmark history" in capsys.readouterr().err and empty.read_bytes() == b""


def _make_immutable(path):
    """Make ``path`` (a file or folder) unwritable, also for root (``chattr +i``); returns the
    undo. Skips where that cannot be done (root without chattr on this file system)."""
    if os.geteuid() != 0:
        mode = path.stat().st_mode
        path.chmod(0o555 if path.is_dir() else 0o444)
        return lambda: path.chmod(mode)
    chattr = shutil.which("chattr")
    if chattr is None or subprocess.run([chattr, "+i", str(path)], capture_output=True).returncode != 0:
        pytest.skip("running as root and chattr +i is not available here: cannot make a file read-only")
    return lambda: subprocess.run([chattr, "-i", str(path)], check=True)


def test_an_immutable_database_file(db, tmp_path, capsys):
    from umbmark.io.runs_csv import write_runs_csv

    runs = tmp_path / "runs.csv"
    write_runs_csv(simulate_umbmark(ErrorParams(1.002, 0.99), n_runs=5, noise="paper", seed=1), runs)
    before = db.read_bytes()
    undo = _make_immutable(db)
    try:
        rc, out, err = _run(["history", "r1", "--json"], db, capsys)  # reading works
        assert rc == 0 and len(json.loads(out)["records"]) == 3, err
        argv = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1", "--record"]
        rc, _, err = _run(argv, db, capsys)
        _one_line_error(rc, err, "h.sqlite", "read-only")
        with pytest.raises(HistoryError, match="read-only"):
            with History(db) as h:
                h.add("r1", kind="other", method="m", results={}, parameters={})
    finally:
        undo()
    assert db.read_bytes() == before


def test_a_database_in_a_read_only_folder_is_still_read(db, tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    shutil.copy(db, folder / "h.sqlite")
    undo = _make_immutable(folder)
    try:
        rc, out, err = _run(["history", "r1", "--json"], folder / "h.sqlite", capsys)
        assert rc == 0 and len(json.loads(out)["records"]) == 3, err
        rc, out, err = _run(["history", "--show", "2"], folder / "h.sqlite", capsys)
        assert rc == 0 and json.loads(out)["id"] == 2, err
        with pytest.raises(HistoryError, match="read-only"):
            with History(folder / "h.sqlite") as h:
                h.add("r1", kind="other", method="m", results={}, parameters={})
    finally:
        undo()
    assert sorted(os.listdir(folder)) == ["h.sqlite"]


def test_a_dropped_table_on_every_backend(any_db, capsys):
    with open_history(any_db) as h:
        h.add("r1", kind="other", method="m", results={}, parameters={"c_left": 1.0, "c_right": 1.0, "Eb": 1.0})
    if isinstance(any_db, str):
        import sqlalchemy as sa

        eng = sa.create_engine(any_db)
        with eng.begin() as c:
            c.exec_driver_sql("DROP TABLE calibrations" + (" CASCADE" if eng.dialect.name == "postgresql" else ""))
        eng.dispose()
    else:
        _execute(any_db, "PRAGMA foreign_keys = OFF", "DROP TABLE calibrations")
    for argv in (["history"], ["history", "r1"], ["history", "--show", "1"], ["history", "r1", "--export", "-"]):
        rc = main([*argv, "--db", str(any_db)])
        err = capsys.readouterr().err
        _one_line_error(rc, err, "calibrations")
