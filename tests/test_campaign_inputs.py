"""A campaign of older cases, run through the command line: the standard output closed, a
calibration or result JSON holding a number of 5001 digits, the cw and ccw labels of a distances
file exchanged, a runs file whose measured column is a copy of the odometry's.

Each case asserts no traceback, a refusal in one line naming the cause (exit status 2), or a
warning naming the mistake where the data can still be used; and that the right data draw no
warning.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO

from umbmark.cli import main

SRC = REPO / "src"
DISTANCES = REPO / "data" / "examples" / "distances.csv"
MARKS = ["--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"]
DIGITS = "1" + "0" * 5000


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def refused(code: int, out: str, err: str) -> str:
    assert "Traceback" not in out + err
    assert code == 2, (code, err[-600:])
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and "error:" in lines[0], err[-800:]
    return lines[0]


def warnings_of(err: str) -> list[str]:
    return [x[len("warning: ") :] for x in err.splitlines() if x.startswith("warning: ")]


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Path:
    f = tmp_path_factory.mktemp("inputs") / "runs.csv"
    assert run("-q", "simulate", "--ed", "1.004", "--eb", "1.02", "--noise", "paper", "--seed", "4", "--out", f)[0] == 0
    return f


# -- the standard output closed ---------------------------------------------------------------------


@pytest.mark.parametrize("json_flag", [[], ["--json"]], ids=["text", "json"])
def test_a_closed_standard_output_is_one_line(runs, json_flag):
    """``umbmark analyze ... >&-``: one line naming the standard output, exit status 2."""
    argv = [sys.executable, "-m", "umbmark", "analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000"]
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    p = subprocess.run([*argv, *json_flag], env=env, stderr=subprocess.PIPE, text=True,
                       preexec_fn=lambda: os.close(1))  # fmt: skip
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == (
        "umbmark: error: cannot write the standard output: it is closed (>&-): give it a file, or /dev/null"
    )


def test_a_command_that_prints_nothing_runs_with_the_standard_output_closed(tmp_path):
    out = tmp_path / "s.csv"
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    p = subprocess.run([sys.executable, "-m", "umbmark", "-q", "simulate", "--out", str(out)], env=env,
                       stderr=subprocess.PIPE, text=True, preexec_fn=lambda: os.close(1))  # fmt: skip
    assert p.returncode == 0 and p.stderr == "" and out.stat().st_size > 0


# -- a number of 5001 digits in a calibration JSON ------------------------------------------------------


@pytest.mark.parametrize("fmt", ["json", "ros2", "firmware"])
def test_a_5001_digit_factor_in_a_calibration_is_one_line(tmp_path, fmt):
    cal = tmp_path / "cal.json"
    cal.write_text(f'{{"c_left": {DIGITS}, "c_right": 1.0, "Ed": 1.0, "Eb": 1.0}}\n')
    line = refused(*run("export", cal, "--format", fmt))
    assert "cal.json: a number of 5001 digits: no value a robot's file holds" in line, line


def test_a_5001_digit_number_in_a_result_to_report_is_one_line(tmp_path):
    res = tmp_path / "replay.json"
    res.write_text(f'{{"dataset": "d", "Ed": {DIGITS}}}\n')
    line = refused(*run("report", res, "--out", tmp_path / "r.html"))
    assert "replay.json: a number of 5001 digits: no value a robot's file holds; not a replay result" in line
    assert not (tmp_path / "r.html").exists()


def test_a_5001_digit_size_in_a_calibration_to_validate_is_one_line(tmp_path):
    cal = tmp_path / "cal.json"
    cal.write_text(f'{{"wheel_diameter_left_mm": {DIGITS}, "sensor_pose": {{}}}}\n')
    line = refused(*run("validate", tmp_path / "none.bag", cal, "--relations", tmp_path / "r", "--odom-topic", "/o"))
    assert "cal.json: a number of 5001 digits" in line and "a calibration is the JSON" in line


# -- umbmark measure: the cw and ccw labels exchanged ----------------------------------------------------


def _exchanged(path: Path, out: Path) -> Path:
    swap = {"cw": "ccw", "ccw": "cw"}
    lines = []
    for ln in path.read_text().splitlines():
        cells = ln.split(",")
        if len(cells) > 1 and cells[1] in swap:
            cells[1] = swap[cells[1]]
        lines.append(",".join(cells))
    out.write_text("\n".join(lines) + "\n")
    return out


def test_measure_names_cw_and_ccw_labels_exchanged(tmp_path):
    code, out, err = run("measure", DISTANCES, *MARKS, "--out", tmp_path / "ok.csv", "--json")
    assert code == 0 and warnings_of(err) == [] and json.loads(out)["warnings"] == []
    swapped = _exchanged(DISTANCES, tmp_path / "swapped.csv")
    code, out, err = run("measure", swapped, *MARKS, "--out", tmp_path / "runs.csv", "--json")
    assert code == 0, err
    (w,) = warnings_of(err)
    assert w.startswith("the runs fit the square far better with the cw and ccw labels exchanged (and with them")
    assert json.loads(out)["warnings"] == [w]
    code, out, err = run("measure", swapped, *MARKS, "--out", tmp_path / "runs.csv")
    assert code == 0 and warnings_of(err) == [w]


# -- a runs file whose measured column is a copy of the odometry's ------------------------------------------


def _copied(runs: Path, out: Path, column: str, drop: tuple[str, ...] = ()) -> Path:
    lines = [ln for ln in runs.read_text().splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    keep = [i for i, c in enumerate(head) if c not in drop]
    rows = []
    for ln in lines[1:]:
        cells = ln.split(",")
        cells[head.index(f"{column}_abs")] = cells[head.index(f"{column}_odo")]
        rows.append(",".join(cells[i] for i in keep))
    out.write_text("\n".join([",".join(head[i] for i in keep), *rows]) + "\n")
    return out


@pytest.mark.parametrize(
    ("column", "drop"), [("x", ()), ("y", ()), ("x", ("theta_abs", "theta_odo"))], ids=["x", "y", "x-no-headings"]
)
def test_a_measured_column_copied_from_the_odometry_is_named(runs, tmp_path, column, drop):
    code, _, err = run("analyze", runs, "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    assert code == 0 and warnings_of(err) == []
    f = _copied(runs, tmp_path / "copied.csv", column, drop)
    code, out, err = run("analyze", f, "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    assert code == 0, err
    assert json.loads(out)["warnings"][0].startswith(f"{column}_abs equals {column}_odo in every run")


def test_a_perfect_simulated_robot_is_no_copy(tmp_path):
    """Runs whose measured pose equals the odometry's in every column (no errors, no noise)."""
    f = tmp_path / "ideal.csv"
    assert run("-q", "simulate", "--out", f)[0] == 0
    code, out, err = run("analyze", f, "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    assert code == 0 and not any("copied" in w for w in json.loads(out)["warnings"])
