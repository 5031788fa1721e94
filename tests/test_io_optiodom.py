"""The optiodom data-set reader: format, start frame, directions, and one-line errors."""

import shutil

import numpy as np
import pytest

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.optiodom import read_optiodom

SET = "square/230620202042"


def test_reads_square_set(optiodom):
    ds = read_optiodom(optiodom / SET)
    assert ds.name == "230620202042"
    assert len(ds.runs) == 6
    assert ds.side_m == pytest.approx(0.75)
    assert ds.nominal.wheelbase_m == pytest.approx(0.2)
    assert ds.nominal.diameter_left_m == pytest.approx(0.084)
    assert ds.units_per_wheel_rev == pytest.approx(43.7 * 64)
    assert ds.directions == ("cw",) * 3 + ("ccw",) * 3
    r = ds.runs[0]
    assert r.gt.shape == (len(r), 3)
    assert np.allclose(r.gt[0], 0.0)  # start frame
    assert r.t[0] == 0.0 and np.all(np.diff(r.t) > 0)
    # ticks per sample (not cumulative): small numbers
    assert np.abs(r.d_left).max() < 200


def test_right_then_left_columns(optiodom, tmp_path):
    """Column 5 is the right wheel, column 6 the left: a cw run turns right, so the left wheel
    rolls more in total."""
    ds = read_optiodom(optiodom / SET)
    cw = ds.runs[0]
    assert cw.d_left.sum() > cw.d_right.sum()


def test_wrong_nominal_metadata(optiodom):
    ds = read_optiodom(optiodom / "square/230620202258")
    assert ds.nominal.wheelbase_m == pytest.approx(0.205)
    assert ds.nominal.diameter_right_m == pytest.approx(0.085)


def _copy(optiodom, tmp_path):
    dst = tmp_path / "230620202042"
    shutil.copytree(optiodom / SET, dst)
    return dst


@pytest.mark.parametrize(
    "edit, msg, line",
    [
        (("metadata", "Li,0.2", "Li,abc"), "'abc' is not a number", 4),
        (("metadata", "Li,0.2", "Li,-0.2"), "must be a positive number", 4),
        (("metadata", "Di,0.084,0.084", "Di,0.084"), "needs 2 values", 5),
        (("run-01", "\n", "\n0.1,0,0,0,x,1\n", 1), "column ticks_right: 'x' is not a number", 2),
        (("run-01", "\n", "\n0.1,0,0,0\n", 1), "has 4 fields, expected 6", 2),
        (("run-01", "\n", "\n0.0,0,0,0,1,1\n", 1), "does not increase", 2),
        (("run-01", "\n", "\n0.01,0,0,0,1.5,1\n", 1), "not a whole number", 2),
    ],
)
def test_errors_name_file_and_line(optiodom, tmp_path, edit, msg, line):
    d = _copy(optiodom, tmp_path)
    which, old, new, *count = edit
    f = d / ("230620202042_metadata.csv" if which == "metadata" else "230620202042_run-01.csv")
    text = f.read_text()
    f.write_text(text.replace(old, new, *(count or [-1])))
    with pytest.raises(InputError) as e:
        read_optiodom(d)
    assert msg in str(e.value)
    assert e.value.source == str(f)
    assert e.value.line == line


def test_missing_run_file(optiodom, tmp_path):
    d = _copy(optiodom, tmp_path)
    (d / "230620202042_run-06.csv").unlink()
    with pytest.raises(InputError, match="run-06.csv is missing"):
        read_optiodom(d)


def test_cli_error_is_one_line_exit_2(optiodom, tmp_path, capsys):
    d = _copy(optiodom, tmp_path)
    f = d / "230620202042_run-03.csv"
    f.write_text(f.read_text().replace("\n", "\n0.1,0,0,0,1\n", 1))
    assert main(["replay", str(d), "--format", "optiodom", "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{f}:2:" in err and "fields" in err
    assert main(["replay", str(tmp_path / "nope"), "--format", "optiodom"]) == 2
    assert "not found" in capsys.readouterr().err
