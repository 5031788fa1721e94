"""Plausibility of optiodom folders: metadata in the wrong unit, N against the run files,
conflicting rows, ground-truth headings in degrees, a ground truth that never moves."""

from __future__ import annotations

import glob
import shutil

import numpy as np
import pytest

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.optiodom import read_optiodom

SET = "square/230620202042"
META = "230620202042_metadata.csv"


def _copy(optiodom, tmp_path):
    dst = tmp_path / "230620202042"
    shutil.copytree(optiodom / SET, dst)
    return dst


def _edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def _run_rows(path):
    return np.loadtxt(path, delimiter=",")


def _write_rows(path, a):
    np.savetxt(path, a, delimiter=",", fmt="%.9g")


def test_the_shipped_data_sets_give_no_warning(repo_root):
    for folder in sorted(glob.glob(str(repo_root / "data/optiodom/*/*/"))):
        assert read_optiodom(folder).meta["warnings"] == (), folder


@pytest.mark.parametrize(
    "old, new, msg, line",
    [
        ("Di,0.084,0.084", "Di,84,84", "Di is in metres", 5),
        ("Li,0.2", "Li,200", "Li is in metres", 4),
    ],
)
def test_geometry_in_millimetres_is_an_error(optiodom, tmp_path, old, new, msg, line):
    d = _copy(optiodom, tmp_path)
    _edit(d / META, old, new)
    with pytest.raises(InputError, match=msg) as e:
        read_optiodom(d)
    assert e.value.line == line


def test_two_conflicting_n_rows_are_an_error(optiodom, tmp_path):
    d = _copy(optiodom, tmp_path)
    (d / META).write_text((d / META).read_text() + "N,4\n")
    with pytest.raises(InputError, match="'N' appears twice with different values") as e:
        read_optiodom(d)
    assert e.value.source == str(d / META)


def test_a_repeated_identical_row_is_fine(optiodom, tmp_path):
    d = _copy(optiodom, tmp_path)
    (d / META).write_text((d / META).read_text() + "N,6\n")
    assert len(read_optiodom(d).runs) == 6


def test_n_odd_and_n_below_the_run_files_warn(optiodom, tmp_path, capsys):
    d = _copy(optiodom, tmp_path)
    _edit(d / META, "\nN,6", "\nN,5")
    ds = read_optiodom(d)
    w = " ".join(ds.meta["warnings"])
    assert "N = 5 runs is odd" in w
    assert "also holds 230620202042_run-06.csv" in w
    assert main(["replay", str(d), "--format", "optiodom", "--method", "bf", "--json"]) == 0
    out = capsys.readouterr()
    assert "is odd" in out.out


def test_a_ground_truth_that_never_moves_is_an_error(optiodom, tmp_path, capsys):
    d = _copy(optiodom, tmp_path)
    f = d / "230620202042_run-02.csv"
    a = _run_rows(f)
    a[:, 1:4] = a[0, 1:4]
    _write_rows(f, a)
    with pytest.raises(InputError, match="ground truth never moves") as e:
        read_optiodom(d)
    assert e.value.source == str(f)
    assert main(["replay", str(d), "--format", "optiodom"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "never moves" in err


def test_theta_gt_in_degrees_is_an_error(optiodom, tmp_path):
    d = _copy(optiodom, tmp_path)
    f = d / "230620202042_run-01.csv"
    a = _run_rows(f)
    a[:, 3] = np.degrees(np.unwrap(a[:, 3]))
    _write_rows(f, a)
    with pytest.raises(InputError, match="headings are degrees, read as radians \\(theta_gt is in radians\\)") as e:
        read_optiodom(d)
    assert e.value.source == str(f)


def test_wheels_against_ground_truth_name_the_metadata(optiodom, tmp_path):
    """Di or the encoder figures off by a factor: the wheels' travel disagrees with the ground
    truth's; Li off: the turns disagree."""
    d = _copy(optiodom, tmp_path)
    _edit(d / META, "Di,0.084,0.084", "Di,0.84,0.84")
    w = read_optiodom(d).meta["warnings"]
    assert len(w) == 6 and all("check Di" in x for x in w)
    _edit(d / META, "Di,0.84,0.84", "Di,0.084,0.084")
    _edit(d / META, "Li,0.2", "Li,2")
    w = read_optiodom(d).meta["warnings"]
    assert len(w) == 6 and all("check Li" in x for x in w)
