"""Calibration history: records, schema migrations, the CLI (history, --record on analyze)."""

import json
import sqlite3

import pytest

from umbmark.cli import main
from umbmark.history import (
    ENV_VAR,
    MIGRATIONS,
    SCHEMA_VERSION,
    History,
    HistoryError,
    SameRecording,
    default_db_path,
    export_parameters,
    record_result,
    resolve_db_path,
    runs_from_rows,
    runs_to_rows,
)
from umbmark.io.runs_csv import write_runs_csv
from umbmark.model.geometry import ErrorParams
from umbmark.model.simulate import simulate_umbmark

ANALYZE = ["--wheelbase-mm", "340", "--side-mm", "4000"]


@pytest.fixture
def three_runs_files(tmp_path):
    """Three tests of one robot whose wheels wear: E_d drifts, E_b drifts."""
    paths = []
    for k, (ed, eb) in enumerate([(1.001, 0.990), (1.002, 0.991), (1.003, 0.992)]):
        p = tmp_path / f"runs{k + 1}.csv"
        write_runs_csv(simulate_umbmark(ErrorParams(ed, eb), n_runs=5, noise="paper", seed=k), p)
        paths.append(p)
    return paths


def test_db_path_resolution(monkeypatch, tmp_path):
    monkeypatch.delenv(ENV_VAR, raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert default_db_path() == tmp_path / "xdg" / "umbmark" / "history.sqlite"
    assert resolve_db_path() == default_db_path()
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "env.sqlite"))
    assert resolve_db_path() == tmp_path / "env.sqlite"
    assert resolve_db_path(tmp_path / "opt.sqlite") == tmp_path / "opt.sqlite"


def test_add_and_read_back(tmp_path):
    db = tmp_path / "h.sqlite"
    rid = record_result(
        "r1",
        kind="analyze",
        method="bf",
        db=db,
        results={"emax_syst_mm": 300.0, "nan": float("nan")},
        parameters={"c_left": 0.999, "c_right": 1.001, "wheelbase_m": 0.336, "Ed": 1.002, "Eb": 0.988},
        inputs={"runs": [1, 2]},
        input_sha256="ab" * 32,
        source="/x/runs.csv",
        parameters_in_use={"c_left": 1.0},
        when="2026-01-02T03:04:05Z",
    )
    with History(db) as h:
        r = h.get(rid)
        assert h.schema_version == SCHEMA_VERSION
        assert h.journal_mode == "wal"
    assert (r.robot, r.kind, r.method, r.created_utc) == ("r1", "analyze", "bf", "2026-01-02T03:04:05.000000Z")
    assert r.wheelbase_mm == pytest.approx(336.0) and r.ed == 1.002 and r.eb == 0.988 and r.emax_syst_mm == 300.0
    assert r.results["nan"] is None and r.inputs == {"runs": [1, 2]} and r.software_version
    ex = export_parameters(r)
    assert ex["corrected_wheelbase_m"] == pytest.approx(0.336) and ex["c_left"] == 0.999 and ex["record_id"] == rid
    # no wheelbase in use recorded: the nominal one is the corrected one over E_b
    assert ex["nominal_wheelbase_mm"] == pytest.approx(336.0 / 0.988) and "wheelbase_mm" not in ex


def test_records_are_ordered_by_time_and_latest(tmp_path):
    db = tmp_path / "h.sqlite"
    with History(db) as h:
        for when, e in (("2026-03-01", 3.0), ("2026-01-01", 1.0), ("2026-02-01", 2.0)):
            h.add("r", kind="analyze", method="bf", results={"emax_syst_mm": e}, parameters={}, when=when)
        h.add("other", kind="replay", method="bf", results={}, parameters={})
        assert [r.emax_syst_mm for r in h.records("r")] == [1.0, 2.0, 3.0]
        assert [r.emax_syst_mm for r in h.records("r", limit=2)] == [2.0, 3.0]
        assert h.latest("r").emax_syst_mm == 3.0
        assert {d["robot"]: d["records"] for d in h.robots()} == {"r": 3, "other": 1}
        with pytest.raises(Exception, match="no calibrations of robot 'nobody'.*robots: other, r"):
            h.latest("nobody")


@pytest.mark.parametrize("bad", ["", "   ", "a\nb"])
def test_bad_robot_names(tmp_path, bad):
    with pytest.raises(Exception, match="robot"):
        record_result(bad, kind="analyze", method="bf", results={}, parameters={}, db=tmp_path / "h.sqlite")


def test_migration_from_schema_1_keeps_records(tmp_path):
    db = tmp_path / "old.sqlite"
    con = sqlite3.connect(db)
    for stmt in MIGRATIONS[1]:
        con.execute(stmt)
    con.execute("INSERT INTO robots (name, created_utc) VALUES ('old', '2025-01-01T00:00:00.000000Z')")
    con.execute("""INSERT INTO calibrations (robot_id, created_utc, kind, method, software_version, inputs_json,
                   results_json, parameters_json, parameters_in_use_json, emax_syst_mm, ed, eb, wheelbase_mm)
                   VALUES (1, '2025-01-01T00:00:00.000000Z', 'analyze', 'bf', '0.0.1', '{}', '{}',
                   '{"c_left": 0.99}', '{}', 42.0, 1.001, 0.99, 336.0)""")
    con.execute("PRAGMA user_version = 1")
    con.commit()
    con.close()
    with History(db) as h:
        assert h.schema_version == SCHEMA_VERSION
        r = h.latest("old")
        assert r.emax_syst_mm == 42.0 and r.note is None and r.parameters == {"c_left": 0.99}
        h.add("old", kind="analyze", method="bf", results={}, parameters={}, note="new")
        assert [x.note for x in h.records("old")] == [None, "new"]


def test_newer_schema_and_foreign_databases_are_refused(tmp_path):
    newer = tmp_path / "newer.sqlite"
    History(newer).close()
    con = sqlite3.connect(newer)
    con.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    con.commit()
    con.close()
    with pytest.raises(HistoryError, match="newer than this umbmark"):
        History(newer)
    foreign = tmp_path / "foreign.sqlite"
    con = sqlite3.connect(foreign)
    con.execute("CREATE TABLE t (x)")
    con.commit()
    con.close()
    with pytest.raises(HistoryError, match="not an umbmark history"):
        History(foreign)
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    with pytest.raises(HistoryError, match="not a usable umbmark history"):
        History(junk)


def test_failed_write_rolls_back(tmp_path):
    db = tmp_path / "h.sqlite"
    with History(db) as h:
        h.add("r", kind="analyze", method="bf", results={}, parameters={})
        with pytest.raises(RuntimeError):
            with h.transaction() as c:
                h._insert(c, h._row("r", "analyze", "bf", {}, {}, {}, None, None, None, "doomed", None, None))
                raise RuntimeError("crash between the statements and the commit")
        assert h.count() == 1 and h.integrity_check() == "ok"


def test_runs_rows_round_trip():
    runs = simulate_umbmark(ErrorParams(1.002, 0.99), n_runs=3, noise="paper", seed=3)
    back = runs_from_rows(json.loads(json.dumps(runs_to_rows(runs))))
    assert (back.x_abs == pytest.approx(runs.x_abs)) and (back.theta_odo == pytest.approx(runs.theta_odo))


def test_three_calibrations_table_plot_export(tmp_path, three_runs_files, capsys, monkeypatch):
    """Acceptance: a history of three calibrations of one robot shows in a table and a plot."""
    db = tmp_path / "fleet.sqlite"
    monkeypatch.setenv(ENV_VAR, str(db))  # the environment variable picks the database
    for p in three_runs_files:
        assert main(["analyze", str(p), *ANALYZE, "--robot", "r1", "--record"]) == 0
    out = capsys.readouterr().out
    assert "recorded as #3 in the history of r1" in out
    assert main(["analyze", str(three_runs_files[0]), *ANALYZE, "--robot", "r2", "--record", "--json"]) == 0
    j = json.loads(capsys.readouterr().out)
    assert j["history"] == {"record_id": 4, "robot": "r2", "db": str(db)}

    assert main(["history"]) == 0
    out = capsys.readouterr().out
    assert "r1" in out and "r2" in out
    png, exp = tmp_path / "r1.png", tmp_path / "r1.json"
    assert main(["history", "r1", "--plot", str(png), "--export", str(exp)]) == 0
    out = capsys.readouterr().out
    assert "Calibration history of r1 (3 records" in out
    for name in ("#1", "#2", "#3", "analyze/bf", "E_max,syst [mm]", "wheelbase [mm]"):
        assert name in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000
    exported = json.loads(exp.read_text())
    assert exported["record_id"] == 3 and exported["robot"] == "r1"

    # the history's numbers are analyze's numbers
    assert main(["analyze", str(three_runs_files[2]), *ANALYZE, "--json"]) == 0
    a = json.loads(capsys.readouterr().out)
    assert exported["c_left"] == pytest.approx(a["c_left"], rel=1e-12)
    assert exported["corrected_wheelbase_mm"] == pytest.approx(a["wheelbase_corrected_mm"], rel=1e-12)
    assert exported["nominal_wheelbase_mm"] == pytest.approx(a["wheelbase_mm"], rel=1e-12)

    assert main(["history", "r1", "--json"]) == 0
    h = json.loads(capsys.readouterr().out)
    assert [r["id"] for r in h["records"]] == [1, 2, 3]
    assert h["records"][0]["source"].endswith("runs1.csv") and len(h["records"][0]["input_sha256"]) == 64
    assert [r["Ed"] for r in h["records"]] == sorted(r["Ed"] for r in h["records"])  # the drift shows

    yml = tmp_path / "p.yaml"
    assert main(["--quiet", "history", "r1", "--export", str(yml)]) == 0
    assert capsys.readouterr().out == ""
    import yaml

    assert yaml.safe_load(yml.read_text())["record_id"] == 3
    assert main(["history", "r1", "--export", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["record_id"] == 3
    assert main(["history", "--show", "2"]) == 0
    full = json.loads(capsys.readouterr().out)
    assert len(full["inputs"]["runs"]) == 10 and full["results"]["emax_syst_mm"] > 0


def test_cli_errors(tmp_path, capsys, three_runs_files):
    db = tmp_path / "h.sqlite"
    assert main(["analyze", str(three_runs_files[0]), *ANALYZE, "--record", "--db", str(db)]) == 2
    assert "--record needs --robot" in capsys.readouterr().err
    assert not db.exists()
    assert main(["history", "--db", str(db)]) == 2
    assert "no history database" in capsys.readouterr().err
    assert main(["analyze", str(three_runs_files[0]), *ANALYZE, "--robot", "r1", "--record", "--db", str(db)]) == 0
    capsys.readouterr()
    assert main(["history", "ghost", "--db", str(db)]) == 2
    assert "no calibrations of robot 'ghost'" in capsys.readouterr().err
    assert main(["history", "--plot", "x.png", "--db", str(db)]) == 2
    assert "need a ROBOT" in capsys.readouterr().err
    assert main(["history", "--show", "99", "--db", str(db)]) == 2
    assert "no record #99" in capsys.readouterr().err
    # without --record nothing is written
    assert main(["analyze", str(three_runs_files[1]), *ANALYZE, "--robot", "r1", "--db", str(db), "--json"]) == 0
    assert "history" not in json.loads(capsys.readouterr().out)
    with History(db) as h:
        assert h.count() == 1


def test_history_options_decorator_on_another_command(tmp_path):
    """What replay/calibrate do: attach the options, record raw fields (a log's hash)."""
    import click
    from click.testing import CliRunner

    from umbmark.cli.history import history_options, record_if_requested
    from umbmark.history import file_sha256

    log = tmp_path / "bag"
    log.mkdir()
    (log / "a.db3").write_bytes(b"\x00\x01" * 100)

    @click.command()
    @click.argument("src")
    @history_options
    def fake_replay(src, robot, record, db):
        rec = record_if_requested(
            robot,
            record,
            db,
            kind="replay",
            method="bf",
            results={"emax_syst_mm": 12.5},
            parameters={"c_left": 0.99, "c_right": 1.01, "wheelbase_m": 0.3, "Ed": 1.02, "Eb": 1.0},
            input_sha256=file_sha256(src),
            source=src,
        )
        click.echo(json.dumps(rec))

    db = tmp_path / "h.sqlite"
    r = CliRunner().invoke(fake_replay, [str(log), "--robot", "bot", "--record", "--db", str(db)])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["record_id"] == 1
    r = CliRunner().invoke(fake_replay, [str(log), "--record"])
    assert r.exit_code == 2 and "--record needs --robot" in r.output
    r = CliRunner().invoke(fake_replay, [str(log), "--robot", "bot", "--db", str(db)])
    assert r.exit_code == 0 and r.output.strip() == "null"
    with History(db) as h:
        rec = h.latest("bot")
    assert rec.kind == "replay" and rec.wheelbase_mm == pytest.approx(300.0) and rec.emax_syst_mm == 12.5
    assert rec.input_sha256 == file_sha256(log) and len(rec.input_sha256) == 64
    (log / "a.db3").write_bytes(b"\x00\x02" * 100)
    assert file_sha256(log) != rec.input_sha256  # the hash follows the content


def test_record_a_replay_report(tmp_path, optiodom, capsys):
    """What `replay --robot NAME --record` stores: one record per data set, the log folder hashed."""
    from umbmark.cli.history import record_report_if_requested
    from umbmark.history import file_sha256

    sets = [optiodom / "square" / "230620202042", optiodom / "square" / "230620202144"]
    save = tmp_path / "rep.json"
    assert main(["-q", "replay", *map(str, sets), "--method", "bf", "--no-heldout", "--save", str(save)]) == 0
    rep = json.loads(save.read_text())
    db = tmp_path / "h.sqlite"
    assert record_report_if_requested("opti", False, db, rep, sets) is None
    recs = record_report_if_requested("opti", True, db, rep, sets, method="bf")
    assert [r["record_id"] for r in recs] == [1, 2]
    with History(db) as h:
        stored = h.records("opti")
    for r, part, path in zip(stored, rep["datasets"], sets):
        assert r.kind == "replay" and r.method == "bf"
        assert r.input_sha256 == file_sha256(path) and r.source == str(path.resolve())
        assert r.ed == pytest.approx(part["Ed"]) and r.wheelbase_mm == pytest.approx(part["wheelbase_corrected_mm"])
        assert r.emax_syst_mm == pytest.approx(part["before"]["emax_syst_mm"])
        assert r.parameters_in_use == part["nominal"] and r.parameters_in_use["wheelbase_mm"] > 0
    # a single-data-set report: of a recording this robot's history holds already (refused), and of another robot
    assert main(["-q", "replay", str(sets[1]), "--method", "bf", "--no-heldout", "--save", str(save)]) == 0
    with pytest.raises(SameRecording, match="holds this recording already: record #2 "):
        record_report_if_requested("opti", True, db, json.loads(save.read_text()), [sets[1]])
    one = record_report_if_requested("opti-2", True, db, json.loads(save.read_text()), [sets[1]])
    assert one[0]["record_id"] == 3
    with History(db) as h:
        assert h.get(3).ed == pytest.approx(stored[1].ed)


def _cli_json(capsys, *argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _cli_text(capsys, *argv):
    assert main(list(argv)) == 0, capsys.readouterr().err
    return capsys.readouterr().out


def test_history_export_chain_gives_the_recorded_parameters(tmp_path, optiodom, capsys, monkeypatch):
    """analyze (with a prior), replay and calibrate --record, then history --export, then export
    json / ros2 / firmware: the parameters the first command printed, E_b applied once."""
    import yaml

    monkeypatch.chdir(tmp_path)
    db = ["--db", "h.sqlite"]
    write_runs_csv(simulate_umbmark(ErrorParams(1.004, 0.985), n_runs=5, noise="paper", seed=7), tmp_path / "runs.csv")
    firsts = {
        "r1": _cli_json(
            capsys,
            "analyze",
            "runs.csv",
            *ANALYZE,
            "--c-left",
            "1.01",
            "--c-right",
            "0.99",
            "--robot",
            "r1",
            "--record",
            *db,
        ),
        "opti": _cli_json(
            capsys,
            "replay",
            str(optiodom / "square" / "230620202144"),
            "--method",
            "bf",
            "--no-heldout",
            "--robot",
            "opti",
            "--record",
            *db,
        ),
        "sim": _cli_json(
            capsys, "calibrate", "--seed", "1", "--runs", "2", "--max-passes", "2", "--robot", "sim", "--record", *db
        ),
    }
    for robot, first in firsts.items():
        if robot == "sim":
            f = first["final_calibration"]
            want = {"c_left": f["c_left"], "c_right": f["c_right"], "wheelbase_mm": f["wheelbase_mm"]}
            nominal_wb = first["passes"][0]["calibration_used"]["wheelbase_mm"]
        else:
            want = {
                "c_left": first["c_left"],
                "c_right": first["c_right"],
                "wheelbase_mm": first["wheelbase_corrected_mm"],
            }
            nominal_wb = first["nominal"]["wheelbase_mm"] if robot == "opti" else first["wheelbase_mm"]
        _cli_text(capsys, "history", robot, *db, "--export", f"{robot}.json")
        exported = json.loads((tmp_path / f"{robot}.json").read_text())
        assert exported["corrected_wheelbase_mm"] == pytest.approx(want["wheelbase_mm"], rel=1e-12)
        assert exported["nominal_wheelbase_mm"] == pytest.approx(nominal_wb, rel=1e-12)
        assert "wheelbase_mm" not in exported  # no key that could be read as either

        out = json.loads(_cli_text(capsys, "export", f"{robot}.json", "--format", "json"))
        for k, v in want.items():
            assert out[k] == pytest.approx(v, rel=1e-9), (robot, k)
        assert out["Eb"] == pytest.approx(want["wheelbase_mm"] / nominal_wb, rel=1e-9)

        ros = yaml.safe_load(_cli_text(capsys, "export", f"{robot}.json", "--format", "ros2"))
        p = ros["diff_drive_controller"]["ros__parameters"]
        assert p["left_wheel_radius_multiplier"] == pytest.approx(want["c_left"], rel=1e-12)
        assert p["right_wheel_radius_multiplier"] == pytest.approx(want["c_right"], rel=1e-12)
        assert p["wheel_separation_multiplier"] * nominal_wb == pytest.approx(want["wheelbase_mm"], rel=1e-9)

        extra = [] if robot == "opti" else ["--wheel-diameter-mm", "150", "--pulses-per-wheel-rev", "4096"]
        header = _cli_text(capsys, "export", f"{robot}.json", "--format", "firmware", *extra)
        defines = dict(
            line.split()[1:3]
            for line in header.splitlines()
            if line.startswith("#define UMBMARK_") and "_H" not in line
        )
        assert float(defines["UMBMARK_WHEELBASE_MM"]) == pytest.approx(want["wheelbase_mm"], abs=1e-6)
        if robot == "opti":  # the same header as the replay's own JSON gives
            (tmp_path / "first.json").write_text(json.dumps(first))
            direct = _cli_text(capsys, "export", "first.json", "--format", "firmware")
            assert [ln for ln in header.splitlines() if ln.startswith("#define")] == [
                ln for ln in direct.splitlines() if ln.startswith("#define")
            ]
        else:
            import math

            k = math.pi * 150 / 4096
            assert float(defines["UMBMARK_LEFT_MM_PER_PULSE"]) == pytest.approx(want["c_left"] * k, rel=1e-8)
            assert float(defines["UMBMARK_RIGHT_MM_PER_PULSE"]) == pytest.approx(want["c_right"] * k, rel=1e-8)

    # r1's wheel factors include the prior it ran with: composing them with multipliers says so
    assert (
        main(["export", "r1.json", "--format", "ros2", "--left-multiplier", "1.01", "--right-multiplier", "0.99"]) == 0
    )
    assert "already include the wheel factors the robot ran with" in capsys.readouterr().err
    assert main(["export", "opti.json", "--format", "ros2", "--left-multiplier", "1.01"]) == 0
    assert "already include" not in capsys.readouterr().err

    # a history export written before the keys said what they hold: wheelbase_mm was the corrected one
    old = json.loads((tmp_path / "r1.json").read_text())
    legacy = {k: old[k] for k in ("robot", "record_id", "time_utc", "kind", "method", "c_left", "c_right", "Ed", "Eb")}
    legacy.update(wheelbase_mm=old["corrected_wheelbase_mm"], emax_syst_mm_measured=1.0)
    (tmp_path / "legacy.json").write_text(json.dumps(legacy))
    out = json.loads(_cli_text(capsys, "export", "legacy.json", "--format", "json"))
    assert out["wheelbase_mm"] == pytest.approx(firsts["r1"]["wheelbase_corrected_mm"], rel=1e-9)


def test_history_export_chain_of_a_self_calibration(tmp_path, capsys, monkeypatch):
    """selfcal --record of a simulated bag, history --export, export json / urdf / ros2: the same
    parameters and lidar pose as exporting the selfcal JSON itself."""
    import math

    pytest.importorskip("rosbags")
    import yaml

    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import SimRobot, mixed_program, simulate_drive
    from umbmark.model.geometry import LABMATE
    from umbmark.model.sensors import Lidar, SensorPose

    robot = SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.006, eb=1.015, es=1.0),
        sensor_pose=SensorPose(0.08, -0.01, math.radians(2.0)),
        lidar=Lidar(n_beams=180, range_noise_m=0.003),
    )
    monkeypatch.chdir(tmp_path)
    bag = write_drive_bag(
        simulate_drive(mixed_program(40.0, seed=4, robot=robot), robot, seed=5),
        tmp_path / "drive",
        storage="mcap",
        odom=True,
    )
    argv = ["selfcal", str(bag), "--joints", "left_wheel_joint,right_wheel_joint", "--wheel-diameter-mm", "150"]
    argv += ["--wheelbase-mm", "340", "--robot", "s1", "--record", "--db", "h.sqlite", "--save", "selfcal.json"]
    first = _cli_json(capsys, *argv)
    _cli_text(capsys, "history", "s1", "--db", "h.sqlite", "--export", "s1.json")
    via_history = json.loads(_cli_text(capsys, "export", "s1.json", "--format", "json"))
    direct = json.loads(_cli_text(capsys, "export", "selfcal.json", "--format", "json"))
    for k in ("c_left", "c_right", "wheelbase_mm", "diameter_left_mm", "diameter_right_mm", "Eb"):
        assert via_history[k] == pytest.approx(direct[k], rel=1e-9), k
    assert via_history["wheelbase_mm"] == pytest.approx(first["wheelbase_mm"], rel=1e-9)
    for k in ("x_mm", "y_mm", "yaw_deg"):
        assert via_history["sensor_pose"][k] == pytest.approx(first["sensor_pose"][k], rel=1e-9, abs=1e-9)
    assert via_history["scale_observed"] is True
    origin = [ln for ln in _cli_text(capsys, "export", "s1.json", "--format", "urdf").splitlines() if "<origin" in ln]
    assert origin == [
        ln for ln in _cli_text(capsys, "export", "selfcal.json", "--format", "urdf").splitlines() if "<origin" in ln
    ]
    p = yaml.safe_load(_cli_text(capsys, "export", "s1.json", "--format", "ros2"))["diff_drive_controller"][
        "ros__parameters"
    ]
    assert p["wheel_separation_multiplier"] == pytest.approx(first["wheelbase_mm"] / 340, rel=1e-9)
