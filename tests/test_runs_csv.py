import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.io.runs_csv import format_runs_csv, parse_runs_csv, read_runs_csv, write_runs_csv
from umbmark.model.runs import RunsTable

GOOD = """direction,x_abs,y_abs,x_odo,y_odo
cw,10,20,1,2
ccw,-5,7.5,0,0
"""


def test_reads_mm_into_metres():
    t = parse_runs_csv(GOOD)
    np.testing.assert_allclose(t.x_abs, [0.010, -0.005])
    np.testing.assert_allclose(t.eps_y, [0.018, 0.0075])
    assert t.theta_abs is None


def test_optional_and_extra_columns():
    t = parse_runs_csv(
        "note,run,direction,x_abs,y_abs,x_odo,y_odo,theta_abs,theta_odo\n"
        "a,r1,CW,1,2,3,4,90,-180\n"
        "b,r2, ccw ,1,2,3,4,0,0\n"
    )
    assert list(t.direction) == ["cw", "ccw"]
    assert t.theta_abs[0] == pytest.approx(math.pi / 2)
    assert list(t.run) == ["r1", "r2"]


def test_comments_blank_lines_and_empty_optional_column():
    t = parse_runs_csv(
        "# UMBmark 2026-11-21\n\ndirection,x_abs,y_abs,x_odo,y_odo,theta_abs\ncw,1,2,3,4,\n\nccw,1,2,3,4,\n"
    )
    assert len(t) == 2 and t.theta_abs is None


@pytest.mark.parametrize(
    "text, line, match",
    [
        ("cw,1,2,3,4\nccw,1,2,3,4\n", 1, "no header"),
        ("direction,x_abs,y_abs,x_odo\ncw,1,2,3\n", 1, "missing y_odo"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\nleft,1,2,3,4\n", 3, "unknown direction 'left'"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\nccw,1,abc,3,4\n", 3, "y_abs: 'abc' is not a number"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,nan\nccw,1,2,3,4\n", 2, "not a finite number"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,inf\nccw,1,2,3,4\n", 2, "not a finite number"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3\nccw,1,2,3,4\n", 2, "has 4 fields"),
        ("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,,3,4\nccw,1,2,3,4\n", 2, "y_abs is empty"),
        ("direction,x_abs,y_abs,x_odo,y_odo,theta_abs\ncw,1,2,3,4,5\nccw,1,2,3,4,\n", 3, "theta_abs is empty"),
        ("direction,x_abs,y_abs,x_odo,y_odo\n", 1, "no runs"),
    ],
)
def test_bad_content_names_the_line(text, line, match):
    with pytest.raises(InputError, match=match) as e:
        parse_runs_csv(text, source="f.csv")
    assert e.value.line == line
    assert str(e.value).startswith(f"f.csv:{line}: ")


def test_direction_without_runs():
    with pytest.raises(InputError, match="no ccw runs"):
        parse_runs_csv("direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\n", source="f.csv")


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_runs_csv(tmp_path / "nope.csv")
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(InputError, match="empty file"):
        read_runs_csv(tmp_path / "e.csv")
    (tmp_path / "b.csv").write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match="UTF-8"):
        read_runs_csv(tmp_path / "b.csv")


mm = st.floats(-1e4, 1e4, allow_nan=False)
row = st.tuples(st.sampled_from(["cw", "ccw"]), mm, mm, mm, mm, st.floats(-179, 180), st.floats(-179, 180))


@settings(max_examples=60, deadline=None)
@given(st.lists(row, min_size=2, max_size=20))
def test_round_trip(rows):
    rows = [("cw",) + rows[0][1:]] + [("ccw",) + rows[1][1:]] + rows[2:]
    d, xa, ya, xo, yo, ta, to = zip(*rows)
    t = RunsTable.from_columns(
        d,
        np.array(xa) / 1e3,
        np.array(ya) / 1e3,
        np.array(xo) / 1e3,
        np.array(yo) / 1e3,
        np.radians(ta),
        np.radians(to),
    )
    back = parse_runs_csv(format_runs_csv(t))
    assert list(back.direction) == list(t.direction)
    for k in ("x_abs", "y_abs", "x_odo", "y_odo"):  # written to 1e-6 mm
        np.testing.assert_allclose(getattr(back, k), getattr(t, k), atol=1e-9)
    for k in ("theta_abs", "theta_odo"):  # written to 1e-6 deg
        np.testing.assert_allclose(getattr(back, k), getattr(t, k), atol=1e-8)


@settings(max_examples=100, deadline=None)
@given(st.text(max_size=200))
def test_parser_never_crashes_on_garbage(text):
    try:
        parse_runs_csv(text)
    except InputError:
        pass


def test_write_is_atomic(tmp_path):
    t = parse_runs_csv(GOOD)
    p = tmp_path / "out.csv"
    write_runs_csv(t, p)
    assert parse_runs_csv(p.read_text()).x_abs[0] == pytest.approx(0.010)
    assert [f.name for f in tmp_path.iterdir()] == ["out.csv"]
    assert p.stat().st_mode & 0o044  # readable by others (umask permitting), not mkstemp's 0600
    with pytest.raises(InputError, match="does not exist"):
        write_runs_csv(t, tmp_path / "no" / "out.csv")


def test_write_through_links_and_into_special_files(tmp_path):
    """Found by fuzzing: a symlink was replaced by a regular file (its target left stale), and
    /dev/full (as root) was replaced by a regular file instead of reporting no space."""
    import os

    t = parse_runs_csv(GOOD)
    target = tmp_path / "target.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    write_runs_csv(t, link)
    assert link.is_symlink() and parse_runs_csv(target.read_text()).x_abs[0] == pytest.approx(0.010)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["link.csv", "target.csv"]
    # a named pipe gets the content written into it
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    r = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        write_runs_csv(t, fifo)
        got = os.read(r, 1 << 16).decode()
        assert parse_runs_csv(got).x_abs[0] == pytest.approx(0.010)
    finally:
        os.close(r)
    assert fifo.exists() and not fifo.is_file()
    if os.path.exists("/dev/full"):
        with pytest.raises(OSError, match="No space left") as e:
            write_runs_csv(t, "/dev/full")
        assert e.value.filename == "/dev/full"
        assert not Path("/dev/full").is_file()
    with pytest.raises(InputError, match="it is a folder"):
        write_runs_csv(t, tmp_path)
    with pytest.raises(InputError, match="no file name"):
        write_runs_csv(t, "")


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.text(alphabet=st.sampled_from(list('#ab1 ,"\n\r;') + ["\u2028"]), min_size=1, max_size=8).filter(
            lambda s: s.strip() and s == s.strip()
        ),
        min_size=2,
        max_size=4,
    )
)
def test_run_labels_round_trip_even_when_they_look_like_comments(labels):
    """A run label that starts with '#' (or holds quotes, commas, line breaks) is data: written
    quoted, read back unchanged, never skipped as a comment line."""
    n = len(labels)
    runs = RunsTable(
        np.array(["cw", "ccw"] * n)[:n],
        np.arange(n, dtype=float) * 1e-3,
        np.full(n, 2e-3),
        np.zeros(n),
        np.zeros(n),
        run=np.array(labels, dtype=object),
    )
    back = parse_runs_csv(format_runs_csv(runs), "r.csv")
    assert list(back.run) == labels
    assert list(back.direction) == list(runs.direction)


def test_comment_lines_are_still_comments():
    text = (
        "# a comment\nrun,direction,x_abs,y_abs,x_odo,y_odo\n  # indented comment\n"
        "1,cw,1,2,0,0\n#2,ccw,1,2,0,0\n3,ccw,1,2,0,0\n"
    )
    back = parse_runs_csv(text, "r.csv")
    assert [str(r) for r in back.run] == ["1", "3"]
