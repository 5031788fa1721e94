"""The SQLAlchemy history backend (a database URL in --db / UMBMARK_DB): SQLite through
SQLAlchemy always, PostgreSQL when UMBMARK_TEST_POSTGRES_URL is set."""

import json
import sys

import pytest

from umbmark.cli import main
from umbmark.history import SCHEMA_VERSION, HistoryError, display_db, open_history
from umbmark.io.runs_csv import write_runs_csv
from umbmark.model.geometry import ErrorParams
from umbmark.model.simulate import simulate_umbmark

sa = pytest.importorskip("sqlalchemy", reason="SQLAlchemy not installed (optional extra 'db')")


@pytest.fixture(params=["sqlalchemy-sqlite", "postgresql"])
def url(request, tmp_path):
    if request.param == "sqlalchemy-sqlite":
        return f"sqlite:///{tmp_path / 'sa.sqlite'}"
    return request.getfixturevalue("postgres_url")


def test_same_interface_as_the_sqlite_file(url):
    with open_history(url) as h:
        assert type(h).__name__ == "SQLAlchemyHistory" and h.schema_version == SCHEMA_VERSION
        for when, e in (("2026-03-01", 3.0), ("2026-01-01", 1.0), ("2026-02-01", 2.0)):
            h.add(
                "r",
                kind="analyze",
                method="bf",
                results={"emax_syst_mm": e, "x": float("inf")},
                parameters={"wheelbase_m": 0.336, "Ed": 1.001},
                when=when,
                inputs={"runs": [1]},
            )
        h.add("other", kind="replay", method="bf", results={}, parameters={})
        recs = h.records("r")
        assert [r.emax_syst_mm for r in recs] == [1.0, 2.0, 3.0]
        assert recs[0].created_utc == "2026-01-01T00:00:00.000000Z" and recs[0].results["x"] is None
        assert recs[0].wheelbase_mm == pytest.approx(336.0) and recs[0].inputs == {"runs": [1]}
        assert [r.emax_syst_mm for r in h.records("r", limit=2)] == [2.0, 3.0]
        assert h.latest("r").emax_syst_mm == 3.0 and h.get(recs[0].id).emax_syst_mm == 1.0
        assert {d["robot"]: d["records"] for d in h.robots()} == {"r": 3, "other": 1}
        assert h.count() == 4 and h.integrity_check() == "ok"
        with pytest.raises(Exception, match="no calibrations of robot 'x'"):
            h.latest("x")
        with pytest.raises(RuntimeError):
            with h.transaction() as c:
                h._insert(c, h._row("r", "analyze", "bf", {}, {}, {}, None, None, None, "doomed", None, None))
                raise RuntimeError("crash before the commit")
        assert h.count() == 4


def test_cli_with_a_database_url(url, tmp_path, capsys):
    for k in range(3):
        p = tmp_path / f"w{k}.csv"
        write_runs_csv(simulate_umbmark(ErrorParams(1.001 + k * 1e-3, 0.99), n_runs=5, noise="paper", seed=k), p)
        assert (
            main(
                [
                    "analyze",
                    str(p),
                    "--wheelbase-mm",
                    "340",
                    "--side-mm",
                    "4000",
                    "--robot",
                    "r1",
                    "--record",
                    "--db",
                    url,
                    "--json",
                ]
            )
            == 0
        )
        assert json.loads(capsys.readouterr().out)["history"]["record_id"] == k + 1
    assert (
        main(["history", "r1", "--db", url, "--export", str(tmp_path / "p.json"), "--plot", str(tmp_path / "p.png")])
        == 0
    )
    assert "Calibration history of r1 (3 records" in capsys.readouterr().out
    assert json.loads((tmp_path / "p.json").read_text())["record_id"] == 3
    assert main(["report", "--robot", "r1", "--db", url, "--out", str(tmp_path / "h.html")]) == 0
    assert main(["report", "--id", "2", "--db", url, "--bootstrap", "0", "--out", str(tmp_path / "2.html")]) == 0


def test_refusals(tmp_path):
    newer = f"sqlite:///{tmp_path / 'newer.sqlite'}"
    open_history(newer).close()
    eng = sa.create_engine(newer)
    with eng.begin() as c:
        c.exec_driver_sql(f"UPDATE umbmark_schema SET version = {SCHEMA_VERSION + 1}")
    eng.dispose()
    with pytest.raises(HistoryError, match="newer than this umbmark"):
        open_history(newer)
    foreign = f"sqlite:///{tmp_path / 'foreign.sqlite'}"
    eng = sa.create_engine(foreign)
    with eng.begin() as c:
        c.exec_driver_sql("CREATE TABLE robots (x)")
    eng.dispose()
    with pytest.raises(HistoryError, match="not an umbmark history"):
        open_history(foreign)
    with pytest.raises(HistoryError, match="no umbmark history"):
        open_history(f"sqlite:///{tmp_path / 'none.sqlite'}", create=False)
    assert not (tmp_path / "none.sqlite").exists()  # reading creates nothing


def test_bad_urls_and_missing_driver_are_one_line_errors(tmp_path, capsys, monkeypatch):
    assert main(["history", "--db", "nosuchdialect://u:topsecret@host/db"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "topsecret" not in err and "***" in err
    monkeypatch.setitem(sys.modules, "sqlalchemy", None)  # as if the extra were not installed
    assert main(["history", "--db", f"sqlite:///{tmp_path / 'x.sqlite'}"]) == 2
    assert "pip install 'umbmark[db]'" in capsys.readouterr().err


def test_display_db_masks_passwords():
    assert display_db("postgresql+psycopg://me:s3cret@db.example/umb") == "postgresql+psycopg://me:***@db.example/umb"
    assert display_db("/home/me/history.sqlite") == "/home/me/history.sqlite"
