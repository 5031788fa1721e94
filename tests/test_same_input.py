"""One recording given twice is refused: the same file or folder by two paths, or a copy."""

import os
import shutil

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark._files import check_distinct_inputs, file_sha256, same_inputs
from umbmark.cli import main
from umbmark.errors import InputError


def test_same_file_by_two_paths_a_copy_and_a_folder(tmp_path):
    a = tmp_path / "a.bag"
    a.write_bytes(b"x" * 100)
    b = tmp_path / "b.bag"
    b.write_bytes(b"y" * 100)  # the same size, another content
    link = tmp_path / "link.bag"
    os.symlink(a, link)
    copy = tmp_path / "copy.bag"
    shutil.copy(a, copy)
    d1 = tmp_path / "d1"
    d1.mkdir()
    (d1 / "metadata.yaml").write_text("m")
    (d1 / "d1_0.mcap").write_bytes(b"z" * 10)
    d2 = tmp_path / "d2"
    shutil.copytree(d1, d2)
    assert same_inputs([a, b]) == []
    assert same_inputs([a, b, link]) == [(str(a), str(link))]
    assert same_inputs([a, str(tmp_path / "." / "a.bag")]) == [(str(a), str(tmp_path / "." / "a.bag"))]
    assert same_inputs([copy, b, a]) == [(str(copy), str(a))]
    assert same_inputs([d1, a, d2]) == [(str(d1), str(d2))]
    with pytest.raises(InputError, match="is the same recording as"):
        check_distinct_inputs([a, copy])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.binary(min_size=0, max_size=8), min_size=1, max_size=6))
def test_repeats_are_exactly_the_equal_contents(tmp_path_factory, contents):
    folder = tmp_path_factory.mktemp("files")
    paths = []
    for i, c in enumerate(contents):
        p = folder / f"f{i}"
        p.write_bytes(c)
        paths.append(p)
    got = same_inputs(paths)
    firsts = {}
    want = []
    for p, c in zip(paths, contents):
        if c in firsts:
            want.append((str(firsts[c]), str(p)))
        else:
            firsts[c] = p
    assert got == want
    assert all(file_sha256(a) == file_sha256(b) for a, b in got)


def test_selfcal_of_one_bag_twice_is_refused(tmp_path, capsys):
    from test_readme import _write_lidar_bag

    bag = tmp_path / "drive"
    _write_lidar_bag(bag, duration_s=20.0, seed=1, urdf_pose=(0.1, 0.0, 0.0))
    copy = tmp_path / "drive_copy"
    shutil.copytree(bag, copy)
    geo = ["--joints", "left_wheel_joint,right_wheel_joint", "--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]
    assert main(["selfcal", str(bag), str(copy), *geo]) == 2
    err = capsys.readouterr().err.strip()
    assert "is the same recording as" in err and "drive_copy" in err and len(err.splitlines()) == 1


def test_replay_of_one_recording_twice_is_refused(tmp_path, capsys):
    from pathlib import Path

    run = Path(__file__).resolve().parents[1] / "data" / "optiodom" / "square" / "230620202144"
    copy = tmp_path / "copy_of_run"
    shutil.copytree(run, copy)
    assert main(["replay", str(run), str(copy), "--method", "exact"]) == 2
    err = capsys.readouterr().err.strip()
    assert "copy_of_run is the same recording as" in err and len(err.splitlines()) == 1
