"""A campaign of mistakes on every input and output path, run through the command line.

The same recording given twice (by two paths, a link or a copy) to every command that pools
several inputs; data strings (robot names, paths) that look like options, markup or emoji codes
printed as stored; history addresses with passwords given to every command that takes --db;
every writer on a full disk and in a read-only folder, and the standard output on a full disk;
numbers no robot has in every numeric column of every data file (1e308, NaN, infinity, a
5001-digit integer, ``1_0``); the interactive tape measurement ending or answered with garbage;
SIGTERM in the middle of a streaming write; the font cache of a plot; a field guide planned
beyond what a robot drives. Each case asserts no traceback, the exit status, a refusal in one
line naming the real cause and the user's file, nothing secret echoed, nothing half-written.
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click
import numpy as np
import pytest
import simlogs

from umbmark.cli import main
from umbmark.cli.app import app
from umbmark.io.generic_csv import format_generic_csv
from umbmark.io.intervals_csv import write_intervals_csv

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"
MARKS = ["--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"]
SIM = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]
BIG = "1" + "0" * 5000


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


def refused(code: int, out: str, err: str) -> str:
    """The one line of a refusal (exit status 2, no traceback; warnings the command printed
    before it may precede it)."""
    assert "Traceback" not in out + err
    assert code == 2, (code, err[-600:])
    lines = [x for x in err.splitlines() if x.strip() and not x.startswith("warning: ")]
    assert len(lines) == 1 and "error:" in lines[0] and err.strip().endswith(lines[0]), err[-800:]
    return lines[0]


def cli(*args: str, env: dict | None = None, **kw) -> subprocess.CompletedProcess:
    """The console script in a process of its own (for encodings, signals and file descriptors)."""
    e = {**os.environ, "PYTHONPATH": str(SRC), **(env or {})}
    if "stdout" not in kw:
        kw["capture_output"] = True
    return subprocess.run([sys.executable, "-m", "umbmark", *args], env=e, text=True, **kw)


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """Small inputs: a runs file of a robot with errors, a CSV log, intervals, a calibration, the
    example distances, an optiodom folder and a short mecanum bag with its lidar."""
    d = tmp_path_factory.mktemp("robust")
    f = {"dir": d}
    f["runs"] = d / "runs.csv"
    assert run("simulate", "--ed", "1.004", "--eb", "1.02", "--seed", "3", "--out", str(f["runs"]))[0] == 0
    f["log"] = d / "log.csv"
    f["log"].write_text(format_generic_csv(simlogs.dataset([simlogs.general_program()])))
    from test_selfcal import TRUTH, mixed, simulate

    rng = np.random.default_rng(16)
    fl, fr = mixed(rng, 120, 0.05, 0.3)
    f["intervals"] = d / "intervals.csv"
    write_intervals_csv(simulate(rng, TRUTH, fl, fr), f["intervals"])
    f["cal"] = d / "cal.json"
    code, out, _ = run("analyze", str(f["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    assert code == 0
    f["cal"].write_text(out)
    f["distances"] = d / "distances.csv"
    shutil.copy(REPO / "data" / "examples" / "distances.csv", f["distances"])
    f["optiodom"] = d / "230620202144"
    shutil.copytree(REPO / "data" / "optiodom" / "square" / "230620202144", f["optiodom"])
    f["bag"] = d / "mecanum.bag"
    _small_mecanum_bag(f["bag"])
    return f


def _small_mecanum_bag(path: Path) -> None:
    import kinematic_bags

    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.kinematic_drive import KinematicRobot, kinematic_program, simulate_kinematic_drive
    from umbmark.model.sensors import Lidar

    spec = kinematic_bags.ROBOTS["mecanum"]
    robot = KinematicRobot(spec["nominal"], spec["true"], spec["lidar"], Lidar(n_beams=90, range_noise_m=0.005))
    moves, start = kinematic_program(robot, 8.0, seed=1)
    log = simulate_kinematic_drive(moves, robot, start_pose=start, joint_names=spec["joints"], seed=1)
    write_drive_bag(log, path, truth=True, odom=False)


# -- 1. one recording given twice -----------------------------------------------------------------
POOLING = {
    "selfcal": (["selfcal", "{a}", "{b}", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"], "intervals"),
    "selfcal mecanum": (
        ["selfcal", "{a}", "{b}", "--kinematics", "mecanum", "--wheel-diameter-mm", "100", "--lx-plus-ly-mm", "400"],
        "bag",
    ),
    "replay": (["replay", "{a}", "{b}", "--method", "lsq", "--no-heldout", *SIM], "log"),
    "replay --pool": (["replay", "{a}", "{b}", "--method", "lsq", "--pool", "--no-heldout", *SIM], "log"),
    "convert": (["convert", "{a}", "{b}", "--out", "{out}", *SIM], "log"),
    "calibrate": (["calibrate", "{a}", "{b}", "--wheelbase-mm", "340", "--side-mm", "4000"], "runs"),
    "report --after": (
        ["report", "{a}", "--after", "{b}", "--wheelbase-mm", "340", "--side-mm", "4000", "--out", "{out}"],
        "runs",
    ),
}
TWICE = ("a copy", "the same path", "another spelling", "a link")
TWICE_CASES = [(c, how) for c in POOLING for how in TWICE]


@pytest.mark.parametrize("command, how", TWICE_CASES, ids=[f"{c}-{h}" for c, h in TWICE_CASES])
def test_one_recording_given_twice_is_refused_naming_both(files, tmp_path, command, how):
    """Every command that pools several inputs refuses one recording given twice (a copy, the same
    path, ``dir/./name``, a symbolic link): one line naming the repeat; no output is written."""
    argv, key = POOLING[command]
    a = files[key]
    if how == "a copy":
        b = tmp_path / f"copy_of_{a.name}"
        shutil.copy(a, b)
    elif how == "the same path":
        b = a
    elif how == "another spelling":
        b = a.parent / "." / a.name
    else:
        b = tmp_path / f"link_to_{a.name}"
        os.symlink(a, b)
    out = tmp_path / ("r.html" if "report" in command else "c.csv")
    line = refused(*run(*[x.format(a=a, b=b, out=out) for x in argv]))
    assert "the same" in line and str(b) in line, line
    assert not out.exists()


def test_distinct_recordings_are_pooled(files, tmp_path):
    """Two different logs of the same length are two recordings: converted together."""
    other = tmp_path / "other.csv"
    errors = simlogs.ErrorParams(ed=1.01, eb=0.98)
    other.write_text(format_generic_csv(simlogs.dataset([simlogs.general_program()], errors=errors)))
    code, _, err = run("convert", str(files["log"]), str(other), "--out", str(tmp_path / "c.csv"), *SIM)
    assert code == 0, err
    assert (tmp_path / "c.csv").exists()


# -- 2. data strings printed as stored --------------------------------------------------------------
ODD_NAMES = ("r`wheelbase_mm=5`", "```id```", "[bold]r1[/bold]", ":smile:", "a\\[b]", "[red]")


@pytest.mark.parametrize("name", ODD_NAMES)
def test_robot_names_are_printed_as_stored_in_text_and_json(files, tmp_path, name):
    """A robot name with backticks, rich markup or an emoji code: the text tables, the record line,
    the JSON and a refusal listing the robots all show it as typed."""
    db = str(tmp_path / "h.sqlite")
    argv = ["analyze", str(files["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", name]
    code, out, err = run(*argv, "--record", "--db", db)
    assert code == 0, err
    assert f"history of {name} (" in " ".join(out.split())
    code, out, err = run("history", "--db", db)
    assert code == 0 and name in out, out
    code, out, err = run("history", "--db", db, "--", name)
    assert code == 0 and f"Calibration history of {name} (" in " ".join(out.split()), out
    code, out, err = run("history", "--db", db, "--json", "--", name)
    assert json.loads(out)["robot"] == name
    line = refused(*run("history", "--db", db, "nobody"))
    assert f"(robots: {name})" in line, line


NAMED_INPUTS = {
    "analyze": ["analyze", "{f}", "--wheelbase-mm", "340", "--side-mm", "4000"],
    "calibrate": ["calibrate", "{f}", "--wheelbase-mm", "340", "--side-mm", "4000"],
    "replay": ["replay", "{f}", "--method", "lsq", *SIM],
    "convert": ["convert", "{f}", "--out", "{out}", *SIM],
    "selfcal": ["selfcal", "{f}", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"],
    "measure": ["measure", "{f}", *MARKS, "--out", "{out}"],
    "export": ["export", "{f}", "--format", "ros2"],
    "report": ["report", "{f}", "--wheelbase-mm", "340", "--side-mm", "4000", "--out", "{out}"],
    "validate": ["validate", "{f}", "{f}", "--reference", "{f}"],
}


@pytest.mark.parametrize("command", sorted(NAMED_INPUTS))
@pytest.mark.parametrize("name", ["m`wheelbase_mm`.csv", "```id```.csv"])
def test_a_missing_file_is_named_as_typed(tmp_path, command, name):
    """A missing input whose name holds backticks: the refusal names it as typed, not with the
    message wording's flags."""
    f = tmp_path / name
    line = refused(*run(*[x.format(f=f, out=tmp_path / "o.csv") for x in NAMED_INPUTS[command]]))
    assert str(f) in line and "--wheelbase-mm.csv" not in line, line


@pytest.mark.parametrize(
    "argv",
    [
        ["convert", "{log}", "--out", "{d}/[bold]c.csv", *SIM],
        ["export", "{cal}", "--format", "ros2", "--out", "{d}/[b]p.yaml"],
        ["simulate", "--out", "{d}/[bold]s.csv"],
        ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", "{d}/[b]:smile:.png"],
    ],
    ids=["convert", "export", "simulate", "analyze --plot"],
)
def test_output_paths_are_printed_as_given(files, tmp_path, argv):
    """An output file named like markup or an emoji code: the 'wrote' line names it as given."""
    names = {k: str(v) for k, v in files.items()} | {"d": str(tmp_path)}
    args = [x.format(**names) for x in argv]
    code, out, err = run(*args)
    assert code == 0, err
    target = next(a for a in args if a.startswith(str(tmp_path)))
    assert target in out, out
    assert Path(target).exists()


# -- 3. history addresses that are no path or URL ------------------------------------------------------
SECRET_DBS = (
    "host=db.example user=u password=hunter2",
    "dbname=x password=hunter2",
    "password=hunter2",
    "u:hunter2@host/db",
    "sqlite:///h.sqlite?password=hunter2",
)
DB_COMMANDS = {
    "history": ["history"],
    "history ROBOT": ["history", "r1"],
    "history --export": ["history", "r1", "--export", "e.json"],
    "analyze": ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r", "--record"],
    "calibrate": ["calibrate", "--seed", "1", "--robot", "r", "--record"],
    "export": ["export", "{cal}", "--format", "ros2", "--robot", "r", "--record"],
    "selfcal": [
        "selfcal",
        "{intervals}",
        "--wheel-diameter-mm",
        "100",
        "--wheelbase-mm",
        "300",
        "--robot",
        "r",
        "--record",
    ],  # fmt: skip
    "replay": ["replay", "{log}", "--method", "lsq", "--no-heldout", *SIM, "--robot", "r", "--record"],
    "report ROBOT": ["report", "--robot", "r", "--out", "x.html"],
    "drift": ["drift", "r1"],
    "fleet": ["fleet", "{dir}", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"],
    "report --id": ["report", "--id", "1", "--out", "x.html"],
}
DB_CASES = [(c, db, via) for c in DB_COMMANDS for db in SECRET_DBS for via in ("--db", "UMBMARK_DB")]


def test_every_command_with_a_history_is_in_the_campaign():
    """A command that gains --db joins the campaign below."""
    with_db = {n for n, c in app.commands.items() if any("--db" in getattr(p, "opts", ()) for p in c.params)}
    assert with_db == {c.split()[0] for c in DB_COMMANDS}, with_db


@pytest.mark.parametrize("command, db, via", DB_CASES, ids=[f"{c}-{d[:14]}-{v}" for c, d, v in DB_CASES])
def test_a_history_address_with_a_password_is_refused_unechoed(files, tmp_path, monkeypatch, command, db, via):
    """--db (or $UMBMARK_DB) a libpq key=value string, a URL without its scheme or an SQLite URL
    with a password: one line, the password never printed, nothing created."""
    monkeypatch.chdir(tmp_path)
    names = {k: str(v) for k, v in files.items()}
    argv = [x.format(**names) for x in DB_COMMANDS[command]]
    if via == "--db":
        argv += ["--db", db]
    else:
        monkeypatch.setenv("UMBMARK_DB", db)
    code, out, err = run(*argv)
    assert "hunter2" not in out + err
    line = refused(code, out, err)
    if command != "export":  # export refuses recording an analysis's JSON first
        assert "history" in line or "database" in line or "SQLite" in line, line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["replay", "selfcal"])
@pytest.mark.parametrize("db", ["postgresql://u:hunter2@127.0.0.1:1/db", "sqlite:///x.sqlite?token=hunter2"])
def test_a_config_file_keeps_no_password(files, tmp_path, command, db):
    """--write-config with a --db holding a password: refused unechoed, no file written; the
    same URL without the password is written as given."""
    names = {k: str(v) for k, v in files.items()}
    argv = [x.format(**names) for x in DB_COMMANDS[command]]
    cfg = tmp_path / "c.yaml"
    code, out, err = run(*argv, "--db", db, "--write-config", str(cfg))
    assert "hunter2" not in out + err
    assert "holds a password, which a config file does not keep" in refused(code, out, err)
    assert not cfg.exists()
    plain = db.replace(":hunter2", "").replace("?token=hunter2", "")
    code, _, err = run(*argv, "--db", plain, "--write-config", str(cfg))
    assert code == 0, err
    assert f"db: {plain}" in cfg.read_text()


# -- 4. writers on a full disk or in a read-only folder -------------------------------------------------
WRITERS = {
    "simulate --out": (["simulate", "--out", "{o}/a.csv"], "a.csv"),
    "measure --out": (["measure", "{distances}", *MARKS, "--out", "{o}/m.csv"], "m.csv"),
    "convert --out": (["convert", "{log}", "--out", "{o}/c.csv", *SIM], "c.csv"),
    "convert --to runs": (["convert", "{optiodom}", "--to", "runs", "--out", "{o}/r.csv"], "r.csv"),
    "export --out": (["export", "{cal}", "--format", "ros2", "--out", "{o}/p.yaml"], "p.yaml"),
    "report --out": (
        ["report", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--bootstrap", "0", "--out", "{o}/r.html"],
        "r.html",
    ),  # fmt: skip
    "replay --save": (["replay", "{log}", "--method", "lsq", "--no-heldout", *SIM, "--save", "{o}/s.json"], "s.json"),
    "replay --poses-out": (
        ["replay", "{log}", "--stream", "--decimate", "5", "--poses-out", "{o}/p.csv", *SIM],
        "p.csv",
    ),  # fmt: skip
    "selfcal --save": (
        ["selfcal", "{intervals}", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--save", "{o}/sc.json"],
        "sc.json",
    ),  # fmt: skip
    "selfcal --write-config": (
        [
            "selfcal",
            "{intervals}",
            "--wheel-diameter-mm",
            "100",
            "--wheelbase-mm",
            "300",
            "--write-config",
            "{o}/cfg.yaml",
        ],
        "cfg.yaml",
    ),  # fmt: skip
    "analyze --plot": (
        ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", "{o}/p.png"],
        "p.png",
    ),  # fmt: skip
    "calibrate --save-runs": (["calibrate", "--seed", "1", "--save-runs", "{o}"], "pass1.csv"),
    "history --export": (["history", "r1", "--db", "{db}", "--export", "{o}/h.json"], "h.json"),
    "demo --out": (["demo", "--out", "{o}"], "umbmark-demo-before.csv"),
    "reproduce --report": (["reproduce", "--seeds", "1", "--runs", "3", "--report", "{o}/rep"], "rep/scatter.png"),
    "replay --write-config": (["replay", "{log}", "--method", "lsq", *SIM, "--write-config", "{o}/r.yaml"], "r.yaml"),
    "validate --write-config": (["validate", "{bag}", "{cal}", "--write-config", "{o}/v.yaml"], "v.yaml"),
}
WRITE_CASES = [(w, how) for w in WRITERS for how in ("full disk", "read-only folder")]


@pytest.fixture(scope="module")
def history_db(files) -> Path:
    db = files["dir"] / "h.sqlite"
    argv = ["analyze", str(files["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1"]
    assert run(*argv, "--record", "--db", str(db))[0] == 0
    return db


@contextlib.contextmanager
def _full_disk():
    """Files may grow to 64 bytes: a longer write fails in the kernel (EFBIG, reported without a
    file name, as a full disk's ENOSPC is), at whatever layer writes (Python, numpy, matplotlib)."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    old = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (64, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old)


def _read_only(monkeypatch) -> None:
    """Creating a file in the output folder fails as in a read-only folder (root writes anywhere)."""
    real = tempfile.mkstemp

    def mkstemp(*a, **kw):
        if ".umbmark-tmp." in str(kw.get("prefix", "")):
            name = os.path.join(str(kw.get("dir")), kw["prefix"] + "x" + kw.get("suffix", ""))
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), name)
        return real(*a, **kw)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)


@pytest.mark.parametrize("writer, how", WRITE_CASES, ids=[f"{w}-{h}" for w, h in WRITE_CASES])
def test_a_failed_write_names_the_users_file_and_leaves_nothing(files, history_db, tmp_path, monkeypatch, writer, how):
    """Every writer on a full disk (the write fails without a file name) or in a read-only folder:
    one line naming the user's file and the cause, never the temporary file; nothing left."""
    argv, name = WRITERS[writer]
    o = tmp_path / "out"
    o.mkdir()
    names = {k: str(v) for k, v in files.items()} | {"o": str(o), "db": str(history_db)}
    args = [x.format(**names) for x in argv]
    if how == "full disk":
        with _full_disk():
            result = run(*args)
    else:
        _read_only(monkeypatch)
        result = run(*args)
    line = refused(*result)
    if writer == "history --export" and how == "full disk":  # SQLite cannot even open its shared memory
        assert f"cannot use the history database {history_db}: disk I/O error (a full disk" in line, line
    else:
        assert f"cannot write {o / name}" in line, line
        assert os.strerror(errno.EFBIG if how == "full disk" else errno.EROFS) in line, line
    assert "umbmark-tmp" not in line
    assert list(o.iterdir()) == [], list(o.iterdir())


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--json"],
        ["guide", "--ros2-script"],
        ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000"],
    ],
    ids=["json", "script", "text"],
)
def test_the_standard_output_on_a_full_disk_is_named(files, argv):
    """``> out.json`` on a full disk: one line naming the standard output, exit status 2."""
    with open("/dev/full", "w") as full:
        p = cli(*[x.format(runs=files["runs"]) for x in argv], stdout=full, stderr=subprocess.PIPE)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == "umbmark: error: cannot write the standard output: No space left on device"


def test_a_new_history_that_cannot_be_set_up_is_removed(files, tmp_path, monkeypatch):
    """A full disk while a new history database is set up: the disk named, no file left."""
    import sqlite3

    from umbmark.history.sqlite_backend import History

    def full(self):
        raise sqlite3.OperationalError("database or disk is full")

    monkeypatch.setattr(History, "_migrate", full)
    db = tmp_path / "new.sqlite"
    argv = ["analyze", str(files["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r"]
    line = refused(*run(*argv, "--record", "--db", str(db)))
    assert f"cannot write the history database {db}: no space left on device" in line, line
    assert list(tmp_path.iterdir()) == []


# -- 5. numbers no robot has, in every numeric column of every data file ------------------------------
DATA_FILES = {
    "runs": ["analyze", "{f}", "--wheelbase-mm", "340", "--side-mm", "4000"],
    "intervals": ["selfcal", "{f}", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"],
    "log": ["replay", "{f}", "--method", "lsq", "--no-heldout", *SIM],
    "distances": ["measure", "{f}", *MARKS, "--out", "{out}"],
}
LABELS = {"run", "direction"}  # text columns: a label, not a number


def _columns(path: Path) -> list[str]:
    head = next(x for x in path.read_text().splitlines() if not x.startswith("#"))
    return [c for c in head.split(",") if c not in LABELS]


def _with_cell(path: Path, column: str, value: str, row: int = 3) -> str:
    lines = path.read_text().splitlines()
    head = next(i for i, x in enumerate(lines) if not x.startswith("#"))
    k = lines[head].split(",").index(column)
    cells = lines[head + row].split(",")
    cells[k] = value
    lines[head + row] = ",".join(cells)
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def columns(files) -> dict[str, list[str]]:
    return {k: _columns(files[k]) for k in DATA_FILES}


COLUMN_NAMES = {
    "runs": ["x_abs", "y_abs", "x_odo", "y_odo", "theta_abs", "theta_odo"],
    "intervals": ["dt_s", "left_rad", "right_rad", "sensor_dx_m", "sensor_dy_m", "sensor_dyaw_rad"],
    "log": ["time_s", "left_ticks", "right_ticks", "x_m", "y_m", "theta_rad"],
    "distances": [
        "start_front",
        "start_rear",
        "start_back",
        "end_front",
        "end_rear",
        "end_back",
        "x_odo",
        "y_odo",
        "theta_odo",
    ],  # fmt: skip
}
CELL_VALUES = ("1e308", "-1e308", "nan", "inf", "1_0", BIG)
CELL_CASES = [(k, c, v) for k in COLUMN_NAMES for c in COLUMN_NAMES[k] for v in CELL_VALUES]


def test_the_campaign_covers_every_numeric_column(columns):
    assert columns == COLUMN_NAMES


@pytest.mark.parametrize(
    "key, column, value", CELL_CASES, ids=[f"{k}-{c}-{v[:8]}" for k, c, v in CELL_CASES]
)  # fmt: skip
def test_a_number_no_robot_has_in_any_column_is_refused_with_file_and_line(files, tmp_path, key, column, value):
    """One cell at 1e308, -1e308, NaN, infinity, ``1_0`` or 5001 digits: one line naming the file,
    the line and the column; a 5001-digit number shown by its first digits and its length."""
    bad = tmp_path / f"bad{files[key].suffix}"
    bad.write_text(_with_cell(files[key], column, value))
    out = tmp_path / "o.csv"
    line = refused(*run(*[x.format(f=bad, out=out) for x in DATA_FILES[key]]))
    assert f"{bad.name}:" in line and column in line, line
    assert len(line) < 600, line[:200]
    if value == "1_0":
        assert "'1_0'" in line, line
    assert not out.exists()


@pytest.mark.parametrize("stream", [False, True])
@pytest.mark.parametrize("column", ["theta_rad", "theta_deg"])
def test_a_heading_no_robot_has_in_a_log_is_refused(files, tmp_path, stream, column):
    """A ground-truth heading of 1e7 rad (1e9 degrees) in a CSV log, read whole or streamed."""
    text = files["log"].read_text()
    if column == "theta_deg":
        text = text.replace(",theta_rad", ",theta_deg")
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    bad.write_text(_with_cell(bad, column, "1e7" if column == "theta_rad" else "1e9"))
    argv = ["replay", str(bad), *SIM] + (["--stream"] if stream else ["--method", "lsq", "--no-heldout"])
    line = refused(*run(*argv))
    assert "bad.csv:" in line and column in line and "no robot's heading" in line, line


def test_a_clean_log_with_an_unwrapped_heading_is_read(files, tmp_path):
    """A heading unwrapped over many turns (tens of radians) is a robot's: read without a word."""
    text = files["log"].read_text().splitlines()
    head = next(i for i, x in enumerate(text) if not x.startswith("#"))
    k = text[head].split(",").index("theta_rad")
    for i in range(head + 1, len(text)):
        cells = text[i].split(",")
        cells[k] = repr(float(cells[k]) + 20 * np.pi)
        text[i] = ",".join(cells)
    p = tmp_path / "turned.csv"
    p.write_text("\n".join(text) + "\n")
    code, _, err = run("replay", str(p), "--method", "lsq", "--no-heldout", *SIM)
    assert code == 0 and "error" not in err, err


@pytest.mark.parametrize(
    "argv, named",
    [
        (["replay", "{log}", "--method", "lsq", *SIM, "--ranges", "0-1_0"], "'0-1_0'"),
        (["validate", "{bag}", "{cal}", "--window", "1_0:20"], "'1_0:20'"),
        (["guide", "--runs", BIG], "(5001 digits)"),
        (["simulate", "--seed", BIG, "--out", "{d}/s.csv"], "(5001 digits)"),
        (["export", "{cal}", "--format", "ros2", "--left-multiplier", BIG], "--left-multiplier"),
    ],
    ids=["ranges", "window", "runs", "seed", "multiplier"],
)
def test_underscored_and_endless_numbers_in_option_texts(files, tmp_path, argv, named):
    """``1_0`` in a time range or a window is no number; a 5001-digit option value is shown by its
    first digits and its length (or named as the option)."""
    names = {k: str(v) for k, v in files.items()} | {"d": str(tmp_path)}
    line = refused(*run(*[x.format(**names) for x in argv]))
    assert named in line and len(line) < 400, line[:300]


def test_underscored_number_in_optiodom_metadata(files, tmp_path):
    folder = tmp_path / files["optiodom"].name
    shutil.copytree(files["optiodom"], folder)
    meta = folder / f"{folder.name}_metadata.csv"
    meta.write_text(meta.read_text().replace("ngear,43.7", "ngear,4_37"))
    line = refused(*run("convert", str(folder), "--to", "runs", "--out", str(tmp_path / "r.csv")))
    assert "'4_37'" in line and "metadata" in line, line


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "Robö 名前", "--record",
         "--db", "{db}"],
        ["history", "--db", "{db}"],
        ["history", "Robö 名前", "--db", "{db}"],
        ["history", "Robö", "--db", "{db}"],
        ["history", "Robö 名前", "--db", "{db}", "--json"],
    ],
    ids=["record", "robots", "history", "unknown", "json"],
)  # fmt: skip
def test_unicode_names_on_an_ascii_terminal(files, tmp_path_factory, argv):
    """PYTHONIOENCODING=ascii: a Unicode robot name printed as escapes, never a traceback."""
    db = tmp_path_factory.getbasetemp() / "unicode.sqlite"
    p = cli(*[x.format(runs=files["runs"], db=db) for x in argv], env={"PYTHONIOENCODING": "ascii"})
    assert "Traceback" not in p.stderr and "UnicodeEncodeError" not in p.stderr, p.stderr[-800:]
    if argv[1] == "Robö":
        assert p.returncode == 2 and "Rob\\xf6" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    else:
        assert p.returncode == 0, p.stderr
        assert "Rob\\xf6" in p.stdout or "Rob\\u00f6" in p.stdout, p.stdout[-500:]


# -- 6. measure ---------------------------------------------------------------------------------------
INTERACTIVE = {
    "nothing": "",
    "garbage": "garbage\nfoo\n",
    "underscore": "1_0\n",
    "1e308": "1e308\n",
    "nan": "nan\n-5\n",
    "one run": "369\n370\n406\n43.7\n44.9\n-1.29\n243\n227\n524\n",
    "one run, garbage heading": "369\n370\n406\n43.7\n44.9\nabc\n\n243\n227\n524\n",
    "huge odometry": "369\n370\n406\n1e9\n",
}


@pytest.mark.parametrize("name", INTERACTIVE)
def test_interactive_measure_asks_again_and_ends_with_one_line(tmp_path, monkeypatch, name):
    """Garbage, ``1_0``, 1e308 or NaN at a prompt is asked again; the input ending is an error
    (exit status 2) naming the run it ended in and the files that hold the runs entered."""
    monkeypatch.setattr(sys, "stdin", io.StringIO(INTERACTIVE[name]))
    out_csv = tmp_path / "m.csv"
    code, out, err = run("measure", "--interactive", *MARKS, "--out", str(out_csv))
    line = refused(code, out, err)
    assert "--interactive: the input ended before run" in line, line
    if name.startswith("one run"):
        assert "run 2 of 10" in line and str(out_csv) in line
        assert out_csv.exists() and (tmp_path / "m.distances.csv").exists()
        theta = (tmp_path / "m.distances.csv").read_text().splitlines()[1].split(",")[-1]
        assert theta == ("-1.29" if name == "one run" else "")
    else:
        assert "run 1 of 10" in line and "no run was saved" in line and list(tmp_path.iterdir()) == []
    if name in ("garbage", "underscore", "1e308", "nan", "huge odometry"):
        assert "is not a number" in out, out


def test_front_and_rear_exchanged_are_named_by_analyze(files, tmp_path):
    """The example distances measured and analysed: silent; with the front and rear columns
    exchanged, analyze names the headings' sign and the exchanged distances first."""
    text = files["distances"].read_text().splitlines()
    head = next(i for i, x in enumerate(text) if not x.startswith("#"))
    swapped = text[: head + 1]
    for row in text[head + 1 :]:
        c = row.split(",")
        c[2], c[3], c[5], c[6] = c[3], c[2], c[6], c[5]
        swapped.append(",".join(c))
    for name, lines in (("clean", text), ("swapped", swapped)):
        d = tmp_path / f"{name}.csv"
        d.write_text("\n".join(lines) + "\n")
        runs = tmp_path / f"{name}-runs.csv"
        assert run("measure", str(d), *MARKS, "--out", str(runs))[0] == 0
        code, out, err = run("analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000")
        assert code == 0
        said = " ".join((out + err).split())
        if name == "clean":
            assert "warning" not in said, said
        else:
            assert "the measured headings (theta_abs) have the wrong sign" in said, said
            assert "front and rear distances exchanged" in said
            assert "radians" not in said or said.index("wrong sign") < said.index("radians")


@pytest.mark.parametrize(
    "column, value", [("end_back", "1e308"), ("x_odo", "1e308"), ("y_odo", "-5e9"), ("theta_odo", "1e5")]
)
def test_measure_refuses_absurd_distances_and_odometry(files, tmp_path, column, value):
    bad = tmp_path / "d.csv"
    bad.write_text(_with_cell(files["distances"], column, value))
    line = refused(*run("measure", str(bad), *MARKS, "--out", str(tmp_path / "m.csv")))
    assert "d.csv:" in line and ("distance" in line or column in line), line


MARK_SLIPS = [
    (["--front", "1e300,0", "--rear", "-150,-120", "--back", "-200,0"], "no robot is that large"),
    (["--front", "150000,-120", "--rear", "-150,-120", "--back", "-200,0"], "no robot is that large"),
    (["--front", "0.15,-0.12", "--rear", "-0.15,-0.12", "--back", "-0.2,0"], "metres where millimetres"),
    (["--front", "-150,-120", "--rear", "150,-120", "--back", "-200,0"], "front and rear exchanged?"),
    (["--front", "150,-120", "--rear", "-150,-120", "--back", "200,0"], "the sign of its x?"),
    (["--front", "150,-120", "--rear", "150,-120", "--back", "-200,0"], "at least 1 mm apart"),
]


@pytest.mark.parametrize("marks, cause", MARK_SLIPS, ids=[c for _, c in MARK_SLIPS])
def test_marks_no_robot_carries_are_named(files, tmp_path, marks, cause):
    """Reference points beyond any robot, in metres, or with front and rear (or the back mark's
    sign) exchanged: one line naming it, before any distance is read (also --interactive)."""
    for how in ([str(files["distances"])], ["--interactive"]):
        line = refused(*run("measure", *how, *marks, "--out", str(tmp_path / "m.csv")))
        assert cause in line, line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("side", ["left", "right"])
def test_marks_of_either_side_measure_silently(files, tmp_path, side):
    """Marks on the robot's left side (y > 0) measure as the right's mirror image: no word."""
    y = "120" if side == "left" else "-120"
    marks = ["--front", f"150,{y}", "--rear", f"-150,{y}", "--back", "-200,0"]
    code, _, err = run("measure", str(files["distances"]), *marks, "--out", str(tmp_path / "m.csv"))
    assert code == 0 and err == "", err


# -- SIGTERM, font cache ------------------------------------------------------------------------------
def test_sigterm_during_a_streaming_write_leaves_no_temporary_file(tmp_path):
    """SIGTERM while replay --stream writes its poses: exit status 143, one line, neither the
    temporary file nor the output left."""
    n = 400_000
    t = np.arange(n) * 0.01
    log = tmp_path / "long.csv"
    with open(log, "w") as f:
        f.write(
            "# umbmark nominal geometry: left_diameter_mm=100.0 right_diameter_mm=100.0 wheelbase_mm=300.0 "
            "pulses_per_wheel_rev=1000.0\ntime_s,left_ticks,right_ticks\n"
        )
        np.savetxt(f, np.column_stack([t, np.arange(n), np.arange(n) * 1.001]), fmt="%.2f,%.0f,%.3f")
    out = tmp_path / "poses.csv"
    e = {**os.environ, "PYTHONPATH": str(SRC)}
    argv = [sys.executable, "-m", "umbmark", "replay", str(log), "--stream", "--decimate", "1", "--poses-out", str(out)]
    p = subprocess.Popen(argv, env=e, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not [q for q in tmp_path.iterdir() if ".umbmark-tmp." in q.name]:
        assert p.poll() is None and time.monotonic() < deadline, "the write never started"
        time.sleep(0.02)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert err.strip() == "umbmark: terminated (SIGTERM); no output file was left half-written"
    assert sorted(q.name for q in tmp_path.iterdir()) == ["long.csv"]


@pytest.mark.parametrize("user_cache", [False, True])
def test_plots_create_no_font_cache_outside_the_outputs(files, tmp_path, user_cache):
    """Without MPLCONFIGDIR and without a matplotlib cache, a plot leaves nothing in the home
    folder nor in the temporary folder; a user's MPLCONFIGDIR is used as matplotlib uses it."""
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    home.mkdir()
    tmp.mkdir()
    env = {"HOME": str(home), "TMPDIR": str(tmp), "XDG_CACHE_HOME": "", "MPLCONFIGDIR": ""}
    if user_cache:
        env["MPLCONFIGDIR"] = str(tmp_path / "mine")
    png = tmp_path / "p.png"
    p = cli("-q", "analyze", str(files["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(png),
            env=env)  # fmt: skip
    assert p.returncode == 0, p.stderr
    assert png.exists()
    assert list(home.iterdir()) == [] and list(tmp.iterdir()) == []
    if user_cache:
        assert [q.name for q in (tmp_path / "mine").iterdir() if q.name.startswith("fontlist")]


# -- 7. the field guide bounded to what a robot drives ---------------------------------------------------
GUIDE_BAD = [
    ("--speed-m-s", "200"),
    ("--speed-m-s", "1e308"),
    ("--speed-m-s", "0.0001"),
    ("--speed-m-s", "1e-300"),
    ("--side-mm", "2"),
    ("--side-mm", "1000000"),
    ("--side-mm", "1e308"),
    ("--turn-rate-deg-s", "3000"),
    ("--turn-rate-deg-s", "0.001"),
    ("--runs", "100000"),
    ("--pause-s", "1e9"),
    ("--pause-s", "-1"),
]
GUIDE_CASES = [(f, v, s) for f, v in GUIDE_BAD for s in (False, True)]


@pytest.mark.parametrize("flag, value, script", GUIDE_CASES, ids=[f"{f}={v}-{s}" for f, v, s in GUIDE_CASES])
def test_guide_refuses_what_no_robot_drives(flag, value, script):
    line = refused(*run("guide", *(["--ros2-script"] if script else []), flag, value))
    assert flag in line or ("side" in line and flag == "--side-mm"), line


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["--ros2-script"],
        ["--ros2-script", "--side-mm", "2000", "--speed-m-s", "0.1", "--turn-rate-deg-s", "20", "--runs", "10"],
        ["--ros2-script", "--side-mm", "250", "--speed-m-s", "0.02", "--turn-rate-deg-s", "5"],
        ["--ros2-script", "--runs", "50"],
    ],
)
def test_guide_plans_robots_drive_are_silent(argv):
    code, out, err = run("guide", *argv)
    assert code == 0 and err == "" and out


def test_the_campaign_counts_its_cases():
    """This file's share of the campaign of at least 300 cases."""
    n = (
        len(TWICE_CASES) + len(ODD_NAMES) + 2 * len(NAMED_INPUTS) + 4 + len(DB_CASES) + len(WRITE_CASES) + 3
        + len(CELL_CASES) + 4 + 5 + len(INTERACTIVE) + 4 + len(MARK_SLIPS) + len(GUIDE_CASES)
    )  # fmt: skip
    assert n >= 300, n


def test_every_writer_option_is_in_the_campaign():
    """The output options of the commands (files the commands write) are all exercised above."""
    writers = {
        (n, max(p.opts, key=len))
        for n, c in app.commands.items()
        for p in c.params
        if isinstance(p, click.Option) and max(p.opts, key=len) in ("--out", "--save", "--poses-out", "--plot")
    }
    flags = ("--out", "--save", "--poses-out", "--plot")
    covered = {(w.split()[0], a) for w, (argv, _) in WRITERS.items() for a in argv if a in flags}
    # history --plot draws as analyze --plot does (reading the history needs room for SQLite)
    assert writers - covered <= {("history", "--plot"), ("drift", "--plot")}, writers - covered
