"""A campaign of the mistakes users make, run through the command line as they make them.

Every numeric option of the everyday commands given numbers no robot has (1e308, NaN, -inf,
a 5001-digit integer, ``1_0``), every wheel size and wheelbase option given in the other unit,
every input file missing, a folder, empty or binary, data strings that look like options, and
history URLs with passwords. Each case asserts: no traceback, exit 0 or 2, a refusal in one line
naming the real cause, the data printed as stored, and nothing secret echoed. The inputs are
small files the commands read in milliseconds, so the few hundred cases stay fast.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import shutil
from pathlib import Path

import click
import numpy as np
import pytest
import simlogs

from umbmark.cli import main
from umbmark.cli.app import app
from umbmark.io.generic_csv import format_generic_csv
from umbmark.io.intervals_csv import write_intervals_csv
from umbmark.model.geometry import ROBOT_SIZES_M, unit_slip

REPO = Path(__file__).resolve().parents[1]
MARKS = ["--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"]
SIM_GEOMETRY = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """The small inputs of the campaign: a runs file, distances, a CSV log, intervals, a
    calibration JSON and a history with one record."""
    d = tmp_path_factory.mktemp("campaign")
    f = {"dir": d}
    f["runs"] = d / "runs.csv"
    assert run("simulate", "--seed", "3", "--runs", "5", "--out", str(f["runs"]))[0] == 0
    f["distances"] = d / "distances.csv"
    shutil.copy(REPO / "data" / "examples" / "distances.csv", f["distances"])
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
    f["db"] = d / "history.sqlite"
    code, *_ = run("analyze", str(f["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1")
    assert code == 0
    code, *_ = run(
        "analyze", str(f["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1", "--record",
        "--db", str(f["db"]),
    )  # fmt: skip
    assert code == 0
    return f


def base_commands(f: dict[str, Path]) -> dict[str, list[str]]:
    """A command line of each everyday command that works on the campaign's files."""
    d = f["dir"]
    return {
        "history": ["history", "r1", "--db", str(f["db"])],
        "guide": ["guide"],
        "measure": ["measure", str(f["distances"]), *MARKS, "--out", str(d / "m.csv")],
        "simulate": ["simulate", "--out", str(d / "s.csv")],
        "analyze": ["analyze", str(f["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000"],
        "calibrate": ["calibrate", str(f["runs"]), "--wheelbase-mm", "340", "--side-mm", "4000"],
        "replay": ["replay", str(f["log"]), "--method", "lsq", "--no-heldout", *SIM_GEOMETRY],
        "convert": ["convert", str(f["log"]), "--out", str(d / "c.csv"), *SIM_GEOMETRY],
        "export": ["export", str(f["cal"]), "--format", "ros2"],
        "selfcal": ["selfcal", str(f["intervals"]), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"],
        "report": [
            "report",
            str(f["runs"]),
            "--wheelbase-mm",
            "340",
            "--side-mm",
            "4000",
            "--out",
            str(d / "r.html"),
        ],  # fmt: skip
    }


def _numeric_options(name: str) -> list[click.Option]:
    cmd = app.commands[name]
    return [
        p
        for p in cmd.params
        if isinstance(p, click.Option) and isinstance(p.type, (click.types.FloatParamType, click.types.IntParamType))
    ]


def with_option(base: list[str], opt: click.Option, value: str) -> list[str]:
    """``base`` with the option set to ``value`` (replaced where given, else added)."""
    flag = max(opt.opts, key=len)
    values = [value] * max(opt.nargs, 1)
    out = list(base)
    for i, a in enumerate(out):
        if a in opt.opts:
            out[i + 1 : i + 1 + len(values)] = values
            return out
    return [*out, flag, *values]


COMMANDS = ("history", "guide", "measure", "simulate", "analyze", "calibrate", "replay", "convert", "export",
            "selfcal", "report")  # fmt: skip
BAD_NUMBERS = ("1e308", "nan", "-inf", "1" + "0" * 5000, "1_0")
NUMBER_CASES = [
    (c, max(o.opts, key=len), v) for c in COMMANDS for o in _numeric_options(c) for v in BAD_NUMBERS
]  # fmt: skip


def _one_line_refusal(code: int, out: str, err: str) -> None:
    assert "Traceback" not in err and "Traceback" not in out
    assert code == 2, (code, err[-500:])
    lines = [x for x in err.splitlines() if x.strip()]
    assert lines and "error:" in lines[-1] and not [x for x in lines[:-1] if "error" in x], err[-800:]


@pytest.mark.parametrize("command, flag, value", NUMBER_CASES, ids=[f"{c}{f}={v[:8]}" for c, f, v in NUMBER_CASES])
def test_numbers_no_robot_has_are_refused_in_one_line(files, command, flag, value):
    """1e308, NaN, -inf, a 5001-digit integer and ``1_0`` in every numeric option: refused in one
    line naming the option (a huge value some options accept, e.g. a seed, runs without a
    traceback)."""
    opt = next(o for o in _numeric_options(command) if flag in o.opts)
    code, out, err = run(*with_option(base_commands(files)[command], opt, value))
    assert "Traceback" not in err
    if code == 0:  # accepted: only where the value is a legitimate one
        assert value == "1e308" and flag in ("--heading-weight-m", "--keyframe-s", "--max-wheel-gap-s"), err
        return
    _one_line_refusal(code, out, err)
    if value == "1_0":
        assert "'_' is not a digit" in err and flag in err


GEOMETRY_FLAGS = {
    "--wheel-diameter-mm": ("diameter", "mm"),
    "--left-diameter-mm": ("diameter", "mm"),
    "--right-diameter-mm": ("diameter", "mm"),
    "--wheel-radius-m": ("radius", "m"),
    "--wheelbase-mm": ("wheelbase", "mm"),
    "--model-wheelbase-mm": ("wheelbase", "mm"),
    "--wheel-separation-m": ("wheelbase", "m"),
}
SLIP_CASES = [
    (c, max(o.opts, key=len), how)
    for c in COMMANDS
    for o in _numeric_options(c)
    if max(o.opts, key=len) in GEOMETRY_FLAGS
    for how in ("other unit", "far too small", "far too large")
]


def _slip_value(flag: str, how: str) -> str:
    kind, unit = GEOMETRY_FLAGS[flag]
    lo, hi = ROBOT_SIZES_M["wheelbase" if kind == "wheelbase" else "diameter"]
    typical_m = {"diameter": 0.15, "radius": 0.075, "wheelbase": 0.34}[kind]
    scale = 1e3 if unit == "mm" else 1.0
    if how == "other unit":  # metres in a millimetre option, millimetres in a metre option
        return f"{typical_m if unit == 'mm' else typical_m * 1e3:g}"
    return f"{(lo / 10 if how == 'far too small' else hi * 10) * scale:g}"


@pytest.mark.parametrize("command, flag, how", SLIP_CASES, ids=[f"{c}{f}-{h}" for c, f, h in SLIP_CASES])
def test_wheel_sizes_in_the_other_unit_are_named_before_anything_runs(files, command, flag, how):
    """Every wheel size and wheelbase option of every command, given in the other unit or beyond
    any robot's: one line naming the option and, for the other unit, the value it would be."""
    opt = next(o for o in _numeric_options(command) if flag in o.opts)
    value = _slip_value(flag, how)
    code, out, err = run(*with_option(base_commands(files)[command], opt, value))
    _one_line_refusal(code, out, err)
    assert flag in err and " is no " in err
    if how == "other unit":
        assert "given in " in err


@pytest.mark.parametrize("unit", ["mm", "m"])
@pytest.mark.parametrize("kind", ["diameter", "radius", "wheelbase"])
def test_unit_slip_accepts_every_robot_and_names_the_other_unit(kind, unit):
    """unit_slip: silent over a robot's range, a sentence beyond it; a millimetre option given in
    metres (or the reverse) names the value in the right unit."""
    lo, hi = ROBOT_SIZES_M["wheelbase" if kind == "wheelbase" else "diameter"]
    if kind == "radius":
        lo, hi = lo / 2, hi / 2
    for v in np.geomspace(lo, hi, 25):
        assert unit_slip(kind, float(v), unit) is None
    small, large = unit_slip(kind, lo / 1.01, unit), unit_slip(kind, hi * 1.01, unit)
    assert small is not None and large is not None
    assert ("given in metres?" in small) == (unit == "mm")
    assert ("given in millimetres?" in large) == (unit == "m")
    assert unit_slip(kind, math.nan, unit) is None and unit_slip(kind, -1.0, unit) is None


def _input_arguments() -> list[tuple[str, int]]:
    """(command, index in its base command line) of each input file argument."""
    return [(c, 1) for c in ("measure", "analyze", "calibrate", "replay", "convert", "export", "selfcal", "report")]


FILE_DAMAGE = ("missing", "a folder", "empty", "binary", "truncated", "a header only")
FILE_CASES = [(c, i, how) for c, i in _input_arguments() for how in FILE_DAMAGE]


@pytest.mark.parametrize("command, index, how", FILE_CASES, ids=[f"{c}-{h}" for c, _, h in FILE_CASES])
def test_damaged_inputs_are_named_in_one_line(files, tmp_path, command, index, how):
    """Each command's input missing, a folder, empty, binary, cut in the middle of a line or
    only its header: one line naming the file; no output file is left behind."""
    argv = base_commands(files)[command]
    src = Path(argv[index])
    bad = tmp_path / f"bad{src.suffix}"
    text = src.read_bytes()
    if how == "a folder":
        bad.mkdir()
    elif how == "empty":
        bad.write_bytes(b"")
    elif how == "binary":
        bad.write_bytes(bytes(range(256)) * 8)
    elif how == "truncated":
        bad.write_bytes(text[: len(text) // 2 - 7])
    elif how == "a header only":
        lines = text.decode().splitlines(keepends=True)
        bad.write_text("".join(x for x in lines if x.startswith("#")) + next(x for x in lines if not x.startswith("#")))
    before = set(files["dir"].iterdir())
    code, out, err = run(*[*argv[:index], str(bad), *argv[index + 1 :]])
    assert "Traceback" not in err
    if how == "truncated" and code == 0:  # a cut at a line end is a shorter, valid file
        return
    _one_line_refusal(code, out, err)
    assert bad.name in err
    assert set(files["dir"].iterdir()) == before


ODD_NAMES = ("r`wheelbase_mm=5`", "`id`", "--robot", "Robö 7", "a\\nb", "x; rm -rf /", "名前")


@pytest.mark.parametrize("name", ODD_NAMES)
def test_robot_names_are_printed_as_given(files, tmp_path, name):
    """A robot named like a flag, with backticks, unicode or shell text: recorded and printed back
    exactly (text and JSON)."""
    db = tmp_path / "h.sqlite"
    argv = base_commands(files)["analyze"]
    code, out, err = run(*argv, "--robot", name, "--record", "--db", str(db), "--json")
    assert code == 0, err
    assert json.loads(out)["history"]["robot"] == name
    code, out, err = run("history", "--db", str(db), "--json", "--", name)  # a name like a flag after --
    assert code == 0, err
    assert json.loads(out)["robot"] == name


SECRET_DBS = (
    "host=db.example user=u password=hunter2",
    "dbname=x password=hunter2",
    "postgresql://u:hunter2@127.0.0.1:1/x",
    "password=hunter2",
    "u:hunter2@host/db",
    "sqlite:///h.sqlite?password=hunter2",
)


@pytest.mark.parametrize("db", SECRET_DBS)
def test_a_history_address_with_a_password_is_never_echoed(files, tmp_path, monkeypatch, db):
    """--db a libpq key=value string or a URL with a password: refused or failed in one line,
    the password never printed, no file created."""
    monkeypatch.chdir(tmp_path)
    argv = base_commands(files)["analyze"]
    code, out, err = run(*argv, "--robot", "r", "--record", "--db", db)
    assert "hunter2" not in out + err and "Traceback" not in err
    assert code == 2 and err.strip().count("\n") == 0
    assert list(tmp_path.iterdir()) == []


def _cell(path: Path, column: str, value: str, row: int = 3) -> str:
    """The CSV text of ``path`` with one cell of a data row replaced."""
    lines = path.read_text().splitlines()
    head = next(i for i, x in enumerate(lines) if not x.startswith("#"))
    k = lines[head].split(",").index(column)
    cells = lines[head + row].split(",")
    cells[k] = value
    lines[head + row] = ",".join(cells)
    return "\n".join(lines) + "\n"


HUGE_CELLS = (
    ("selfcal", "intervals", "left_rad"),
    ("selfcal", "intervals", "sensor_dx_m"),
    ("selfcal", "intervals", "dt_s"),
    ("replay", "log", "x_m"),
    ("replay", "log", "left_ticks"),
    ("measure", "distances", "end_back"),
    ("analyze", "runs", "x_abs"),
)


@pytest.mark.parametrize("command, key, column", HUGE_CELLS)
@pytest.mark.parametrize("value", ["1e308", "-1e300", "1_0"])
def test_huge_numbers_in_data_files_are_refused_with_file_and_line(files, tmp_path, command, key, column, value):
    """One cell of a data file at 1e308 (or 1_0): one line naming the file (and the column or line)."""
    argv = base_commands(files)[command]
    bad = tmp_path / f"bad{files[key].suffix}"
    bad.write_text(_cell(files[key], column, value))
    code, out, err = run(*[str(bad) if a == str(files[key]) else a for a in argv])
    if code == 0:  # a value that is a legitimate one is read as it is, without a traceback
        assert "Traceback" not in err and value == "-1e300" and column == "left_ticks", err
        return
    _one_line_refusal(code, out, err)
    assert bad.name in err


@pytest.mark.parametrize(
    "argv, match",
    [
        (["measure", "{distances}", "--front", "1_50,-120", "--rear", "-150,-120", "--back", "-200,0", "--out", "{m}"],
         "1_50,-120"),
        (["replay", "{log}", "--gt-scan-topic", "/scan", "--sensor-pose", "3_5,0,0", *SIM_GEOMETRY],
         "3_5,0,0"),
        (["calibrate", "{runs}", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000"], "is the same runs file as"),
        (["simulate", "--out", "{ro}/o.csv"], "cannot write"),
        (["analyze", "{runs}", "--wheelbase-mm", "340", "--side-mm", "4000", "--c-left", "99.9"], "a percentage?"),
        (["calibrate", "--side-mm", "4", "--seed", "1"], "not longer than the wheelbase"),
        (["simulate", "--speed", "200", "--out", "{m}"], "given in mm/s?"),
        (["guide", "--speed-m-s", "nan"], "--speed-m-s"),
        (["replay", "{log}", "--method", "lsq", "--stop-s", "2000", *SIM_GEOMETRY], "--stop-s"),
    ],
)  # fmt: skip
def test_more_slips_named_in_one_line(files, tmp_path, argv, match):
    """Underscored numbers in points and poses, one runs file as two passes, a folder that cannot be
    written (named, not the temporary file), a percentage as a factor, a side of millimetres, a
    speed in mm/s, a NaN speed in the guide, a pause of milliseconds."""
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        names = {k: str(v) for k, v in files.items()} | {"m": str(tmp_path / "m.csv"), "ro": str(ro)}
        code, out, err = run(*[a.format(**names) for a in argv])
        if "{ro}" in argv[-1] and code == 0:  # root writes into read-only folders
            return
        _one_line_refusal(code, out, err)
        assert match in err and "umbmark-tmp" not in err
    finally:
        ro.chmod(0o700)


def test_the_campaign_has_at_least_300_cases():
    """The acceptance asks for a campaign of at least 300 cases of these kinds."""
    n = len(NUMBER_CASES) + len(SLIP_CASES) + len(FILE_CASES) + len(ODD_NAMES) + len(SECRET_DBS) + 3 * len(HUGE_CELLS)
    assert n >= 300, n


def test_a_pooled_replay_given_to_report_says_what_it_is_and_what_to_do(tmp_path):
    """report of a pooled replay's JSON: one line naming it a pooled fit of N data sets and what
    to report instead; its calibration still exports."""
    sets = [REPO / "data" / "optiodom" / k / sorted(p.name for p in (REPO / "data" / "optiodom" / k).iterdir())[0]
            for k in ("circular", "free")]  # fmt: skip
    save = tmp_path / "pooled.json"
    code, _, err = run("replay", *map(str, sets), "--method", "lsq", "--pool", "--no-heldout", "--save", str(save))
    assert code == 0, err
    code, out, err = run("report", str(save), "--out", str(tmp_path / "r.html"))
    _one_line_refusal(code, out, err)
    assert "a pooled replay (one lsq fit of 2 data sets together)" in err and "without pooling" in err
    assert not (tmp_path / "r.html").exists()
    assert run("export", str(save), "--format", "ros2")[0] == 0


@pytest.mark.parametrize("text", ["[]", "null", '"x"', "3"])
def test_report_of_json_that_is_no_result_says_so(files, tmp_path, text):
    """report of a JSON file that is not a result: one line saying what it is not, not a demand for
    the runs file's geometry options."""
    bad = tmp_path / "w.json"
    bad.write_text(text)
    code, out, err = run("report", str(bad), "--out", str(tmp_path / "r.html"))
    _one_line_refusal(code, out, err)
    assert "JSON, but not a result umbmark saves" in err and "w.json" in err


def test_export_of_a_data_set_the_file_does_not_hold_is_refused(files):
    """export --dataset NAME of a one-calibration JSON that is not NAME: refused, not ignored."""
    code, out, err = run("export", str(files["cal"]), "--format", "ros2", "--dataset", "other")
    _one_line_refusal(code, out, err)
    assert "not a data set 'other'" in err


@pytest.mark.parametrize("name", ["two\nlines", "tab\there", "esc\x1b[31m", ""])
def test_a_refused_robot_name_creates_no_history(files, tmp_path, name):
    """A robot name the history refuses (control characters, empty): one line, and no database file
    is left behind."""
    db = tmp_path / "h.sqlite"
    code, out, err = run(*base_commands(files)["analyze"], "--robot", name, "--record", "--db", str(db))
    _one_line_refusal(code, out, err)
    assert not db.exists()
