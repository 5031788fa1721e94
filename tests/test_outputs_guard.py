"""No command can write over one of its inputs or its history database (umbmark.cli.guard).

The commands and their parameters are read from the click application itself: a path
parameter missing from the guard's registry fails here, and every output option of every
command is run with its path equal to each input and to the history database.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import click
import pytest
from conftest import REPO

from umbmark.cli import app, main
from umbmark.cli.guard import PATH_ROLES, ROLES

EXAMPLES = REPO / "data" / "examples"
OPTIODOM = REPO / "data" / "optiodom" / "square" / "230620202144"


def commands(group: click.Group = app, prefix: str = ""):
    """(command path, command) for every command of the application."""
    for name, cmd in sorted(group.commands.items()):
        path = f"{prefix}{name}"
        if isinstance(cmd, click.Group):
            yield from commands(cmd, path + " ")
        else:
            yield path, cmd


def looks_like_path(p: click.Parameter) -> bool:
    """Parameters that may name a file: click paths, arguments, options whose help speaks of files."""
    if isinstance(p.type, click.Path) or isinstance(p, click.Argument):
        return True
    help_ = (getattr(p, "help", None) or "").lower()
    return any(w in help_ for w in ("file", "folder", "json", "directory"))


def flag(cmd: click.Command, name: str) -> str:
    (p,) = [p for p in cmd.params if p.name == name]
    return max(p.opts, key=len)


def test_every_path_parameter_is_classified():
    missing, stale = [], []
    for path, cmd in commands():
        roles = PATH_ROLES.get(path, {})
        names = {p.name for p in cmd.params}
        for p in cmd.params:
            if p.type is click.BOOL or getattr(p, "is_flag", False):
                continue
            if isinstance(p.type, (click.Choice, click.types.IntParamType, click.types.FloatParamType)):
                continue
            if looks_like_path(p) and p.name not in roles:
                missing.append(f"{path} {p.name}")
        stale += [f"{path} {k}" for k in roles if k not in names]
        assert set(roles.values()) <= set(ROLES), path
    assert not missing, "path parameters without a role in umbmark.cli.guard.PATH_ROLES: " + ", ".join(missing)
    assert not stale, "PATH_ROLES names parameters that do not exist: " + ", ".join(stale)
    assert set(PATH_ROLES) <= {p for p, _ in commands()}


def test_the_classification_reads_output_options_as_outputs():
    """Every option called like an output (--out, --save, --plot, --export, ...-out) is one."""
    for path, cmd in commands():
        for p in cmd.params:
            if isinstance(p, click.Option) and isinstance(p.type, click.Path):
                opt = max(p.opts, key=len)
                if opt in ("--out", "--save", "--plot", "--export", "--save-runs", "--report") or opt.endswith("-out"):
                    assert PATH_ROLES[path][p.name] in ("output", "output_dir"), f"{path} {opt}"


def digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Real inputs of every kind: a runs file, a distances file, a CSV log, an optiodom folder,
    a calibration JSON, a bag, and a history database with a record."""
    d = tmp_path_factory.mktemp("guard")
    cwd = os.getcwd()
    os.chdir(d)
    try:
        assert main(["-q", "simulate", "--seed", "3", "--out", "runs.csv"]) == 0
        shutil.copy(EXAMPLES / "distances.csv", "distances.csv")
        shutil.copytree(OPTIODOM, "optiodom")
        assert main(["-q", "convert", "optiodom", "--out", "log.csv"]) == 0
        assert main(["-q", "replay", "optiodom", "--save", "cal.json", "--no-heldout"]) == 0
        assert main(["-q", "analyze", "runs.csv", "--wheelbase-mm", "340", "--side-mm", "4000"]) == 0
        assert (
            main(
                ["-q", "analyze", "runs.csv", "--wheelbase-mm", "340", "--side-mm", "4000"]
                + ["--robot", "r1", "--record", "--db", "h.sqlite"]
            )
            == 0
        )
        shutil.copy(REPO / "data" / "slam2d" / "mit-csail.bag", "robot.bag")
        shutil.copy(REPO / "data" / "slam2d" / "mit-csail.relations", "robot.relations")
        Path("robot.yaml").write_text("replay:\n  method: bf\nselfcal:\n  keyframe-mm: 100\n")
        Path("vesc.yaml").write_text("/**:\n  ros__parameters:\n    speed_to_erpm_gain: 4614.0\n")
    finally:
        os.chdir(cwd)
    return d


# each command's command line with its inputs; {x} is the input (or database) the outputs are aimed at
BASE = {
    "analyze": ["analyze", "{runs_file}", "--wheelbase-mm", "340", "--side-mm", "4000", "--db", "{db}"],
    "bag-info": ["bag-info", "{bag}"],
    "calibrate": ["calibrate", "{runs_files}", "--wheelbase-mm", "340", "--side-mm", "4000", "--db", "{db}"],
    "convert": ["convert", "{paths}"],
    "export": ["export", "{calibration}", "--format", "json", "--db", "{db}", "--vesc-config", "{vesc_config}"],
    "history": ["history", "r1", "--db", "{db}"],
    "drift": ["drift", "r1", "--db", "{db}"],
    "measure": [
        "measure",
        "{distances_file}",
        "--front",
        "150,-120",
        "--rear",
        "-150,-120",
        "--back",
        "-200,0",
    ],
    "replay": ["replay", "{paths}", "--sensor-pose", "{sensor_pose}", "--db", "{db}", "--config", "{config}"],
    "report": ["report", "{runs_file}", "--after", "{after_file}", "--attach", "{attach}", "--db", "{db}"],
    "selfcal": [
        "selfcal",
        "{paths}",
        "--odom-topic",
        "/odom",
        "--wheel-diameter-mm",
        "200",
        "--wheelbase-mm",
        "400",
        "--db",
        "{db}",
        "--config",
        "{config}",
    ],
    "validate": [
        "validate",
        "{log}",
        "{calibration}",
        "--odom-topic",
        "/odom",
        "--relations",
        "{relations}",
        "--reference",
        "{reference}",
        "--config",
        "{config}",
    ],
}
# the input file of each input parameter
INPUT_FILE = {
    ("analyze", "runs_file"): "runs.csv",
    ("bag-info", "bag"): "robot.bag",
    ("calibrate", "runs_files"): "runs.csv",
    ("convert", "paths"): "log.csv",
    ("export", "calibration"): "cal.json",
    ("export", "vesc_config"): "vesc.yaml",
    ("measure", "distances_file"): "distances.csv",
    ("replay", "paths"): "log.csv",
    ("replay", "sensor_pose"): "cal.json",
    ("report", "runs_file"): "runs.csv",
    ("report", "after_file"): "after.csv",
    ("report", "attach"): "cal.json",
    ("selfcal", "paths"): "robot.bag",
    ("replay", "config"): "robot.yaml",
    ("selfcal", "config"): "robot.yaml",
    ("validate", "log"): "robot.bag",
    ("validate", "calibration"): "cal.json",
    ("validate", "relations"): "robot.relations",
    ("validate", "reference"): "runs.csv",
    ("validate", "config"): "robot.yaml",
}
# options an output needs besides the base command line
NEEDS = {("replay", "poses_out"): ["--stream", "--decimate", "10"]}


def cases():
    out = []
    for path, _ in commands():
        roles = PATH_ROLES.get(path, {})
        for o, r in roles.items():
            if r != "output":
                continue
            targets = [k for k, rr in roles.items() if rr in ("input", "db")]
            for t in targets:
                out.append(pytest.param(path, o, t, id=f"{path}-{o}={t}"))
    return out


def test_every_output_is_covered_by_a_case():
    covered = {(c.values[0], c.values[1]) for c in cases()}
    outputs = {
        (p, o)
        for p, roles in PATH_ROLES.items()
        for o, r in roles.items()
        if r == "output" and {"input", "db"} & set(roles.values())
    }
    assert outputs == covered
    for p, _ in outputs:
        roles = PATH_ROLES[p]
        if True:
            assert p in BASE, f"no command line for {p}"
            for k, r in roles.items():
                if r == "input":
                    assert (p, k) in INPUT_FILE, (p, k)


@pytest.mark.parametrize("command, output, target", cases())
def test_an_output_equal_to_an_input_is_refused(files, tmp_path, capsys, command, output, target):
    work = tmp_path / "w"
    shutil.copytree(files, work)
    shutil.copy(work / "runs.csv", work / "after.csv")
    roles = PATH_ROLES[command]
    (cmd,) = [c for p, c in commands() if p == command]
    paths = {k: INPUT_FILE[(command, k)] for k, r in roles.items() if r == "input"}
    paths.update({k: "h.sqlite" for k, r in roles.items() if r == "db"})
    victim = work / paths[target]
    before = {p.name: digest(p) for p in work.iterdir() if p.is_file()}
    args = [a.format(**paths) for a in BASE[command]]
    args += NEEDS.get((command, output), [])
    # the same file as the target, spelled differently: ./name
    args += [flag(cmd, output), "./" + paths[target]]
    cwd = os.getcwd()
    os.chdir(work)
    try:
        capsys.readouterr()
        code = main(args)
    finally:
        os.chdir(cwd)
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert flag(cmd, output) in lines[0] and "replace" in lines[0]
    after = {p.name: digest(p) for p in work.iterdir() if p.is_file()}
    assert after == before, "a file was written or changed"
    assert victim.exists()


def test_a_symbolic_link_or_hard_link_to_the_input_is_the_input(files, tmp_path, capsys):
    shutil.copy(files / "runs.csv", tmp_path / "runs.csv")
    os.symlink(tmp_path / "runs.csv", tmp_path / "soft.png")
    os.link(tmp_path / "runs.csv", tmp_path / "hard.png")
    before = digest(tmp_path / "runs.csv")
    for link in ("soft.png", "hard.png"):
        code = main(
            ["analyze", str(tmp_path / "runs.csv"), "--wheelbase-mm", "340", "--side-mm", "4000"]
            + ["--plot", str(tmp_path / link)]
        )
        assert code == 2
        assert "replace the input" in capsys.readouterr().err
    assert digest(tmp_path / "runs.csv") == before


def test_an_output_inside_an_input_folder_is_refused(files, tmp_path, capsys):
    shutil.copytree(files / "optiodom", tmp_path / "ds")
    before = sorted(p.name for p in (tmp_path / "ds").iterdir())
    first = sorted((tmp_path / "ds").iterdir())[0]
    for target in (first, tmp_path / "ds" / "cal.json"):
        code = main(["replay", str(tmp_path / "ds"), "--save", str(target)])
        assert code == 2
        assert "inside the input folder" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "ds").iterdir()) == before


def test_two_outputs_on_one_file_are_refused(files, tmp_path, capsys):
    code = main(
        ["selfcal", str(files / "robot.bag"), "--odom-topic", "/odom", "--wheel-diameter-mm", "200"]
        + ["--wheelbase-mm", "400", "--save", str(tmp_path / "x.json"), "--intervals-out", str(tmp_path / "x.json")]
    )
    assert code == 2
    assert "same file" in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def test_the_default_history_database_is_guarded_too(files, tmp_path, capsys, monkeypatch):
    db = tmp_path / "default.sqlite"
    shutil.copy(files / "h.sqlite", db)
    monkeypatch.setenv("UMBMARK_DB", str(db))
    before = digest(db)
    assert main(["history", "r1", "--export", str(db)]) == 2
    assert "history database" in capsys.readouterr().err
    assert digest(db) == before


def test_distinct_outputs_are_written(files, tmp_path):
    """The guard refuses only what would replace an input: a different file is written."""
    out = tmp_path / "cal-copy.json"
    assert main(["-q", "export", str(files / "cal.json"), "--format", "json", "--out", str(out)]) == 0
    assert out.read_text().startswith("{")
    png = tmp_path / "scatter.png"
    args = ["-q", "analyze", str(files / "runs.csv"), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(png)]
    assert main(args) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_stdout_as_output_is_not_an_input(files, capsys):
    """``-`` (stdout) and devices are written into, never compared as files."""
    assert main(["history", "r1", "--db", str(files / "h.sqlite"), "--export", "-"]) == 0
    assert json.loads(capsys.readouterr().out)


# -- sizes and file names ------------------------------------------------------------------------


# a command line of each command with --wheel-diameter-mm that would run (files from the fixture)
SIZE_ARGS = {
    "calibrate": ["calibrate", "--seed", "1"],
    "convert": ["convert", "log.csv", "--out", "new.csv"],
    "export": ["export", "--c-left", "1", "--c-right", "1", "--eb", "1", "--format", "firmware"]
    + ["--pulses-per-wheel-rev", "100", "--out", "new.h"],
    "replay": ["replay", "log.csv", "--save", "new.json"],
    "selfcal": ["selfcal", "robot.bag", "--odom-topic", "/odom", "--wheelbase-mm", "400", "--save", "new.json"],
    "simulate": ["simulate", "--out", "new.csv"],
    "validate": ["validate", "robot.bag", "cal.json", "--odom-topic", "/odom", "--relations", "robot.relations"],
}


def size_options():
    for path, cmd in commands():
        for p in cmd.params:
            if isinstance(p, click.Option) and p.name == "wheel_diameter_mm":
                yield path


def test_every_command_with_a_wheel_diameter_has_a_size_case():
    assert set(size_options()) == set(SIZE_ARGS)


@pytest.mark.parametrize("command", sorted(SIZE_ARGS))
@pytest.mark.parametrize("value", ["1e308", "-1e308", "nan", "inf", "-inf", "2e12"])
def test_an_absurd_size_is_one_line(files, command, value, capsys, monkeypatch):
    monkeypatch.chdir(files)
    code = main([*SIZE_ARGS[command], "--wheel-diameter-mm", value])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert "--wheel-diameter-mm" in err and "Traceback" not in err
    assert not list(files.glob("new.*"))


def test_a_file_name_starting_with_a_dash(files, tmp_path, capsys, monkeypatch):
    shutil.copy(files / "runs.csv", tmp_path / "-x.csv")
    monkeypatch.chdir(tmp_path)
    code = main(["analyze", "-x.csv", "--wheelbase-mm", "340", "--side-mm", "4000"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "./-x.csv" in err and "--" in err
    for args in (["./-x.csv"], ["--wheelbase-mm", "340", "--side-mm", "4000", "--", "-x.csv"]):
        full = args if "--" in args else [*args, "--wheelbase-mm", "340", "--side-mm", "4000"]
        assert main(["-q", "analyze", *full]) == 0, capsys.readouterr().err
    # an option that does not exist is still named as such
    assert main(["analyze", "runs.csv", "--no-such-flag"]) == 2
    assert "No such option" in capsys.readouterr().err


def test_a_file_that_cannot_be_read_is_one_line(files, tmp_path, capsys):
    """An unreadable file (permissions, or a folder where a file is expected): one line, exit 2."""
    f = tmp_path / "locked.csv"
    shutil.copy(files / "runs.csv", f)
    f.chmod(0)
    cases = [["analyze", str(tmp_path), "--wheelbase-mm", "340", "--side-mm", "4000"]]
    cases.append(["export", str(tmp_path), "--format", "json"])
    cases.append(["measure", str(tmp_path), "--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"])
    if not os.access(f, os.R_OK):  # not root
        cases.append(["analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000"])
        cases.append(["export", str(f), "--format", "json"])
    try:
        for args in cases:
            code = main(args)
            err = capsys.readouterr().err
            assert code == 2, (args, err)
            assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (args, err)
    finally:
        f.chmod(0o644)


# -- temporary files of killed writers -----------------------------------------------------------


def _long_log(path: Path, rows: int) -> None:
    """A generic CSV log of one slow arc: ``rows`` samples."""
    import numpy as np

    t = np.arange(rows) * 0.01
    left, right = t * 100.0, t * 101.0  # pulses
    d = (left + right) / 2 * (math.pi * 0.1 / 1000)
    th = (right - left) * (math.pi * 0.1 / 1000) / 0.3
    body = np.column_stack([t, left, right, d * np.cos(th), d * np.sin(th), th])
    with open(path, "w") as f:
        f.write("time_s,left_ticks,right_ticks,x_m,y_m,theta_rad\n")
        np.savetxt(f, body, delimiter=",", fmt="%.9g")


def test_killed_stream_writers_leave_no_temporary_files_behind(tmp_path):
    """SIGKILL while ``replay --stream --poses-out`` writes: the next write removes what the
    killed ones left (recognisable names beside the output), and the output is whole."""
    log, out = tmp_path / "long.csv", tmp_path / "poses.csv"
    _long_log(log, 300_000)
    cmd = [sys.executable, "-m", "umbmark", "replay", str(log), "--stream", "--decimate", "1"]
    cmd += ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]
    cmd += ["--poses-out", str(out)]
    pattern = ".poses.csv.umbmark-tmp.*"
    killed = 0
    for _ in range(3):
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and p.poll() is None and not list(tmp_path.glob(pattern)):
            time.sleep(0.002)
        if p.poll() is None:
            p.send_signal(signal.SIGKILL)
            killed += 1
        p.wait()
    left = list(tmp_path.glob(pattern))
    # each write removed the file the one killed before it left: only the last one's is there
    assert killed == 3 and len(left) == 1, "the writes were not caught in the act"
    assert not out.exists()
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert not list(tmp_path.glob(pattern))
    assert sum(1 for _ in open(out)) == 300_000 + 1


def test_only_temporaries_of_dead_writers_are_removed(tmp_path):
    from umbmark.io.atomic import atomic_write, remove_stale_temporaries

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead_pid = int(dead.stdout)
    target = tmp_path / "out.json"
    stale = tmp_path / f".out.json.umbmark-tmp.{dead_pid}.abc.json"
    live = tmp_path / f".out.json.umbmark-tmp.{os.getpid()}.def.json"
    other = tmp_path / f".other.json.umbmark-tmp.{dead_pid}.ghi.json"
    unrelated = tmp_path / ".out.json.mine"
    for f in (stale, live, other, unrelated):
        f.write_text("x")
    assert remove_stale_temporaries(target) == [stale]
    assert live.exists() and other.exists() and unrelated.exists()
    stale.write_text("x")
    atomic_write(target, "{}\n")  # a write cleans up too
    assert not stale.exists() and target.read_text() == "{}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["out.json", live.name, other.name, unrelated.name])


def test_the_default_database_file_is_guarded(files, tmp_path, capsys, monkeypatch):
    """Without --db or $UMBMARK_DB, the per-user default file is the history."""
    monkeypatch.delenv("UMBMARK_DB", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    default = tmp_path / "xdg" / "umbmark" / "history.sqlite"
    default.parent.mkdir(parents=True)
    shutil.copy(files / "h.sqlite", default)
    before = digest(default)
    assert main(["history", "r1", "--export", str(default)]) == 2
    assert "history database" in capsys.readouterr().err
    args = ["analyze", str(files / "runs.csv"), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(default)]
    assert main(args) == 2
    assert digest(default) == before


def test_a_database_url_names_its_file(files, tmp_path, capsys):
    db = tmp_path / "h.sqlite"
    shutil.copy(files / "h.sqlite", db)
    assert main(["history", "r1", "--db", f"sqlite:///{db}", "--export", str(db)]) == 2
    assert "history database" in capsys.readouterr().err


def test_a_file_the_system_refuses_to_read_is_one_line(files, tmp_path, capsys, monkeypatch):
    """The permission error itself (as a non-root user gets it from a chmod 000 file), raised by
    the operating-system calls that open the file: one line naming the file, exit 2."""
    import builtins
    import pathlib

    f = tmp_path / "locked.csv"
    shutil.copy(files / "runs.csv", f)
    real_open, real_read_text, real_read_bytes = builtins.open, pathlib.Path.read_text, pathlib.Path.read_bytes

    def refused(path) -> bool:
        try:
            return os.path.samefile(path, f)
        except (OSError, TypeError, ValueError):
            return False

    def deny(path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(builtins, "open", lambda p, *a, **k: deny(p) if refused(p) else real_open(p, *a, **k))
    monkeypatch.setattr(
        pathlib.Path, "read_text", lambda p, *a, **k: deny(p) if refused(p) else real_read_text(p, *a, **k)
    )
    monkeypatch.setattr(
        pathlib.Path, "read_bytes", lambda p, *a, **k: deny(p) if refused(p) else real_read_bytes(p, *a, **k)
    )
    for args in (
        ["analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000"],
        ["export", str(f), "--format", "json"],
        [
            "measure",
            str(f),
            "--front",
            "150,-120",
            "--rear",
            "-150,-120",
            "--back",
            "-200,0",
            "--out",
            str(tmp_path / "m.csv"),
        ],
        ["report", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--out", str(tmp_path / "r.html")],
    ):
        code = main(args)
        err = capsys.readouterr().err
        assert code == 2, (args, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (args, err)
        assert "locked.csv" in err and "ermission denied" in err, (args, err)
