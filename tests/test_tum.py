"""The TUM trajectory file (umbmark.io.tum): parsing, planar poses from quaternions, errors with file
and line, the round trip."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.io.tum import MAX_TILT_RAD, Trajectory, format_tum, parse_tum, read_tum, write_tum


def q_yaw(yaw: float) -> str:
    return f"0 0 {math.sin(yaw / 2)!r} {math.cos(yaw / 2)!r}"


GOOD = f"""\
# timestamp x y z qx qy qz qw
100.0 1.5 -2.0 0.1 {q_yaw(0.5)}

100.1   1.6\t-2.0 0.1 {q_yaw(-3.0)}
"""


def test_parse_reads_planar_poses_and_line_numbers():
    t = parse_tum(GOOD, "a.tum")
    assert t.t_s.tolist() == [100.0, 100.1]
    assert np.allclose(t.pose, [[1.5, -2.0, 0.5], [1.6, -2.0, -3.0]], atol=1e-12)
    assert t.lines.tolist() == [2, 4]
    assert t.source == "a.tum" and len(t) == 2


def test_a_small_tilt_is_accepted_and_the_yaw_kept():
    # yaw 0.3 then a roll of 5 deg (fixed axes x, y, z as in ROS: q = q_yaw * q_roll)
    r, y = math.radians(5.0), 0.3
    qx, qy = math.cos(y / 2) * math.sin(r / 2), math.sin(y / 2) * math.sin(r / 2)
    qz, qw = math.sin(y / 2) * math.cos(r / 2), math.cos(y / 2) * math.cos(r / 2)
    t = parse_tum(f"0 0 0 0 {qx!r} {qy!r} {qz!r} {qw!r}\n1 0 0 0 0 0 0 1\n")
    assert t.pose[0, 2] == pytest.approx(0.3, abs=1e-12)


@pytest.mark.parametrize(
    "line, message",
    [
        ("1 0 0 0 0 0 0.3", "has 7 fields, a TUM trajectory has 8"),
        ("1 0 0 0 0 0 0 1 5", "has 9 fields, expected 8"),
        ("1 0 0 0 0 0 0 2", "has norm 2, not 1"),
        ("1 0 0 0 0 0 0.5 0.5", "has norm 0.707107, not 1"),
        ("1 0 0 0 0 0 0 0", "has norm 0, not 1"),
        ("1 0 0 0 0.2588190 0 0 0.9659258", "roll 30.0 deg, pitch 0.0 deg: not a planar trajectory"),
        (f"1 0 0 0 {math.cos(0.2)!r} 0 0 {math.sin(0.2)!r}", "is the quaternion written qw first?"),
        ("1 a 0 0 0 0 0 1", "column x: 'a' is not a number"),
        ("1 0 nan 0 0 0 0 1", "column y: 'nan' is not a finite number"),
        ("1 2e6 0 0 0 0 0 1", "more than 100 km"),
        ("0 0 0 0 0 0 0 1", "time 0 s does not increase"),
    ],
)
def test_bad_lines_name_file_and_line(line, message):
    text = "0 0 0 0 0 0 0 1\n# a comment\n" + line + "\n"
    with pytest.raises(InputError) as e:
        parse_tum(text, "bad.tum")
    assert e.value.source == "bad.tum"
    assert e.value.line == 3
    assert str(e.value).startswith("bad.tum:3: ")
    assert message in str(e.value)


def test_empty_missing_and_binary_files(tmp_path):
    with pytest.raises(InputError, match="no data rows"):
        parse_tum("# nothing\n\n", "e.tum")
    with pytest.raises(InputError, match="file not found"):
        read_tum(tmp_path / "none.tum")
    (tmp_path / "b.tum").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(InputError, match="not a text"):
        read_tum(tmp_path / "b.tum")


def test_the_trajectory_checks_its_arrays():
    with pytest.raises(InputError, match="shape"):
        Trajectory(np.arange(3.0), np.zeros((2, 3)))
    with pytest.raises(InputError, match="not finite"):
        Trajectory(np.arange(2.0), np.array([[0, 0, 0], [np.nan, 0, 0]]))
    with pytest.raises(InputError, match="does not increase"):
        Trajectory(np.array([1.0, 1.0]), np.zeros((2, 3)))


def test_the_tilt_limit_is_the_documented_one():
    a = MAX_TILT_RAD * 0.999
    ok = f"1 0 0 0 {math.sin(a / 2)!r} 0 0 {math.cos(a / 2)!r}\n"
    assert len(parse_tum(ok)) == 1
    a = MAX_TILT_RAD * 1.001
    with pytest.raises(InputError, match="not a planar trajectory"):
        parse_tum(f"1 0 0 0 0 {math.sin(a / 2)!r} 0 {math.cos(a / 2)!r}\n")


poses = st.lists(
    st.tuples(
        st.floats(-1e4, 1e4, allow_nan=False),
        st.floats(-1e4, 1e4, allow_nan=False),
        st.floats(-math.pi + 1e-9, math.pi, allow_nan=False),
    ),
    min_size=1,
    max_size=20,
)


@settings(max_examples=60, deadline=None)
@given(poses, st.floats(0.0, 2e9), st.floats(1e-3, 10.0))
def test_round_trip(tmp_path_factory, ps, t0, dt):
    t = t0 + dt * np.arange(len(ps))
    if np.any(np.diff(t) <= 0):
        return
    traj = Trajectory(t, np.array(ps, dtype=float))
    path = tmp_path_factory.mktemp("tum") / "t.tum"
    write_tum(traj, path)
    back = read_tum(path)
    assert back.t_s.tolist() == traj.t_s.tolist()
    assert np.array_equal(back.pose[:, :2], traj.pose[:, :2])
    err = np.remainder(back.pose[:, 2] - traj.pose[:, 2] + math.pi, 2 * math.pi) - math.pi
    assert np.all(np.abs(err) < 1e-12)
    assert format_tum(back) == format_tum(read_tum(path))
