"""The relations file of the SLAM benchmark (umbmark.io.relations): parsing, errors with file and
line, the round trip, the scans each relation joins; and the two real files of data/slam2d."""

import math

import numpy as np
import pytest
from conftest import REPO
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.io.relations import (
    MAX_TILT_RAD,
    Relations,
    format_relations,
    parse_relations,
    read_relations,
    write_relations,
)
from umbmark.io.wheels import WheelSource  # noqa: E402

DATA = REPO / "data" / "slam2d"

GOOD = """\
# timestamp1 timestamp2 x y z roll pitch yaw
90.239599 90.719599 0.422330 -0.000750 0.000000 0.000000 0.000000 0.017260

90.719599 91.321399 0.213430 -0.014750 0.000000 0.000000 0.000000 -0.405780
"""


def test_parse_reads_si_values_and_line_numbers():
    r = parse_relations(GOOD, "x.relations")
    assert len(r) == 2
    assert r.t1_s.tolist() == [90.239599, 90.719599]
    assert r.t2_s.tolist() == [90.719599, 91.321399]
    assert r.pose.tolist() == [[0.42233, -0.00075, 0.01726], [0.21343, -0.01475, -0.40578]]
    assert r.lines.tolist() == [2, 4]  # the comment and the blank line are skipped, lines keep their numbers
    assert r.source == "x.relations"
    assert np.allclose(r.span_s, [0.48, 0.6018])


def test_tabs_and_runs_of_spaces_separate_fields():
    r = parse_relations("1\t2   0.5 0.25\t0 0 0   0.125\n")
    assert r.pose.tolist() == [[0.5, 0.25, 0.125]]


@pytest.mark.parametrize(
    "line, message",
    [
        ("1 2 3 4 5 6 7", "has 7 fields, expected 8"),
        ("1 2 3 4 5 6 7 8 9", "has 9 fields, expected 8"),
        ("1 2 a 0 0 0 0 0", "column x: 'a' is not a number"),
        ("1 2 0 0 0 0 0 nan", "column yaw: 'nan' is not a finite number"),
        ("1 inf 0 0 0 0 0 0", "column timestamp2: 'inf' is not a finite number"),
        ("1 2 20000 0 0 0 0 0", "column x: 20000 m is more than 10 km"),
        ("1 2 0 0 0 0 0 7", "column yaw: 7 is more than a full turn"),
        ("1 2 0 0 0 0.5 0 0", "column roll: 28.6 deg: not a planar relation"),
        ("1 2 0 0 0 0 -0.2 0", "column pitch: -11.5 deg: not a planar relation"),
        ("3 3 0 0 0 0 0 0", "timestamp1 and timestamp2 are equal"),
    ],
)
def test_bad_lines_name_file_and_line(line, message):
    text = "0 1 0 0 0 0 0 0\n# a comment\n" + line + "\n"
    with pytest.raises(InputError) as e:
        parse_relations(text, "bad.relations")
    assert e.value.source == "bad.relations"
    assert e.value.line == 3
    assert message in str(e.value)
    assert str(e.value).startswith("bad.relations:3: ")


def test_empty_and_missing_files(tmp_path):
    with pytest.raises(InputError, match="no data rows"):
        parse_relations("# only a comment\n\n", "e.relations")
    with pytest.raises(InputError, match="file not found"):
        read_relations(tmp_path / "none.relations")


def test_tilt_at_the_limit_is_accepted():
    r = parse_relations(f"1 2 0 0 0.3 {MAX_TILT_RAD * 0.999} {-MAX_TILT_RAD * 0.999} 0\n")
    assert r.pose.tolist() == [[0.0, 0.0, 0.0]]  # z, roll, pitch dropped


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)


@st.composite
def relations(draw):
    n = draw(st.integers(1, 30))
    t1 = np.array(draw(st.lists(st.floats(0, 2e9, allow_nan=False), min_size=n, max_size=n)))
    dt = np.array(draw(st.lists(st.floats(1e-3, 2e3, allow_nan=False), min_size=n, max_size=n)))
    xy = np.array(draw(st.lists(st.tuples(finite, finite), min_size=n, max_size=n)))
    yaw = np.array(draw(st.lists(angle, min_size=n, max_size=n)))
    t2 = t1 + dt
    keep = t2 != t1
    pose = np.column_stack([xy, yaw])
    return Relations(t1[keep], t2[keep], pose[keep]) if keep.any() else Relations(t1[:0], t2[:0], pose[:0])


@settings(max_examples=60, deadline=None)
@given(relations())
def test_format_then_parse_is_exact(rel):
    if len(rel) == 0:
        with pytest.raises(InputError):
            parse_relations(format_relations(rel))
        return
    back = parse_relations(format_relations(rel), "r")
    assert np.array_equal(back.t1_s, rel.t1_s)
    assert np.array_equal(back.t2_s, rel.t2_s)
    assert np.array_equal(back.pose, rel.pose)
    assert back.lines.tolist() == list(range(1, len(rel) + 1))


def test_write_is_readable(tmp_path):
    rel = parse_relations(GOOD)
    write_relations(rel, tmp_path / "r.relations")
    back = read_relations(tmp_path / "r.relations")
    assert np.array_equal(back.pose, rel.pose)
    assert back.source == str(tmp_path / "r.relations")


def test_relations_validate():
    with pytest.raises(InputError, match="differ in shape"):
        Relations(np.zeros(2), np.ones(3), np.zeros((2, 3)))
    with pytest.raises(InputError, match="shape"):
        Relations(np.zeros(2), np.ones(2), np.zeros((2, 2)))
    with pytest.raises(InputError, match="not finite"):
        Relations(np.zeros(1), np.ones(1), np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(InputError, match="to itself") as e:
        Relations(np.array([0.0, 1.0]), np.array([1.0, 1.0]), np.zeros((2, 3)), "f", np.array([4, 9]))
    assert e.value.line == 9


def test_subset_keeps_lines():
    rel = parse_relations(GOOD, "g")
    sub = rel.subset(np.array([False, True]))
    assert len(sub) == 1 and sub.lines.tolist() == [4] and sub.source == "g"
    assert rel.subset([1, 0]).t1_s.tolist() == [90.719599, 90.239599]
    with pytest.raises(InputError, match="shape"):
        rel.subset(np.array([True]))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.01, 1.0), min_size=2, max_size=40),
    st.floats(0, 1e9),
    st.data(),
)
def test_indices_find_the_nearest_stamp(gaps, t0, data):
    stamps = t0 + np.concatenate([[0.0], np.cumsum(gaps)])
    m = len(stamps)
    a = np.array(data.draw(st.lists(st.integers(0, m - 1), min_size=1, max_size=20)))
    b = np.array(data.draw(st.lists(st.integers(0, m - 1), min_size=len(a), max_size=len(a))))
    keep = a != b
    if not keep.any():
        return
    a, b = a[keep], b[keep]
    jitter = data.draw(st.floats(-4e-3, 4e-3))  # less than half the smallest gap: the nearest is the one
    rel = Relations(stamps[a] + jitter, stamps[b] - jitter, np.zeros((len(a), 3)))
    i1, i2 = rel.indices(stamps, tolerance_s=5e-3)
    assert i1.tolist() == a.tolist() and i2.tolist() == b.tolist()


def test_indices_errors_name_the_relation_line():
    rel = parse_relations("0 1 0 0 0 0 0 0\n1 2.5 0 0 0 0 0 0\n", "f.relations")
    with pytest.raises(InputError, match="timestamp2 2.500000 s has no stamp within 0.001 s") as e:
        rel.indices(np.array([0.0, 1.0, 2.0]))
    assert e.value.line == 2
    assert rel.indices(np.array([0.0, 1.0, 2.0]), tolerance_s=0.5)[1].tolist() == [1, 2]
    with pytest.raises(InputError, match="increasing"):
        rel.indices(np.array([0.0, 0.0, 1.0]))
    with pytest.raises(InputError, match="empty"):
        rel.indices(np.array([]))
    with pytest.raises(InputError, match="tolerance_s"):
        rel.indices(np.array([0.0, 1.0]), tolerance_s=-1)


@pytest.mark.parametrize("name, count", [("aces", 1279), ("mit-csail", 1172)])
def test_the_benchmark_files(name, count):
    rel = read_relations(DATA / f"{name}.relations")
    assert len(rel) == count
    assert np.all(rel.t2_s > rel.t1_s)
    assert np.all(np.abs(rel.pose[:, 2]) <= math.pi)
    # short ones join scans a few apart, long ones span loops
    assert np.median(rel.span_s) < 1.0 and rel.span_s.max() > 300


@pytest.mark.parametrize("name", ["aces", "mit-csail"])
def test_every_relation_joins_two_scans_of_its_bag(name):
    pytest.importorskip("rosbags")
    from umbmark.io.rosbag import read_selfcal_bag

    bag = read_selfcal_bag(DATA / f"{name}.bag", wheels=WheelSource(odom_topic="/odom"))
    rel = read_relations(DATA / f"{name}.relations")
    i1, i2 = rel.indices(bag.scan_t_s, tolerance_s=1e-5)
    assert np.all(i2 > i1)
    assert np.abs(bag.scan_t_s[i1] - rel.t1_s).max() < 1e-5
    # and not those of the other log
    other = "mit-csail" if name == "aces" else "aces"
    with pytest.raises(InputError, match="are these the relations of this log"):
        read_relations(DATA / f"{other}.relations").indices(bag.scan_t_s)
