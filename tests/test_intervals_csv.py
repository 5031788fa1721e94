"""The intervals file (read, write, round trip, bad input) and the Intervals type it gives."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from umbmark.errors import InputError
from umbmark.io.intervals_csv import (
    COLUMNS,
    format_intervals_csv,
    parse_intervals_csv,
    read_intervals_csv,
    write_intervals_csv,
)
from umbmark.model import se2
from umbmark.model.intervals import Intervals, intervals_from_motion, sensor_motion

GOOD = """dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad
0.1,0.5,0.6,0.04,0.001,0.02
0.1,-0.2,0.2,0.0,0.0,-0.1
"""


def test_reads_the_columns():
    iv = parse_intervals_csv(GOOD, "f.csv")
    assert len(iv) == 2
    np.testing.assert_array_equal(iv.dt_s, [0.1, 0.1])
    np.testing.assert_array_equal(iv.left_rad, [0.5, -0.2])
    np.testing.assert_array_equal(iv.right_rad, [0.6, 0.2])
    np.testing.assert_array_equal(iv.sensor, [[0.04, 0.001, 0.02], [0, 0, -0.1]])
    assert iv.source == "f.csv"
    assert iv.warnings == ()


def test_any_order_extra_columns_comments_blank_lines_bom_case(tmp_path):
    text = (
        "\ufeff# recorded on a test robot\n\n"
        "Sensor_DYaw_Rad, note ,dt_s,right_rad,left_rad,sensor_dy_m,sensor_dx_m\n"
        "0.02,a,0.1,0.6,0.5,0.001,0.04\n"
        "# a comment between rows\n\n"
        "-0.1,b,0.1,0.2,-0.2,0,0\n"
    )
    p = tmp_path / "iv.csv"
    p.write_bytes(text.encode("utf-8"))
    iv = read_intervals_csv(p)
    ref = parse_intervals_csv(GOOD)
    for name in ("dt_s", "left_rad", "right_rad", "sensor"):
        np.testing.assert_array_equal(getattr(iv, name), getattr(ref, name))
    assert iv.source == str(p)


def test_crlf_line_endings():
    iv = parse_intervals_csv(GOOD.replace("\n", "\r\n"))
    assert len(iv) == 2


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m\n0.1,1,1,0,0\n", 1, "missing sensor_dyaw_rad"),
        (GOOD.replace("0.1,0.5", "0.1,abc"), 2, "column left_rad: 'abc' is not a number"),
        (GOOD.replace("0.1,0.5", "0.1,"), 2, "column left_rad is empty"),
        (GOOD.replace("-0.1\n", "nan\n"), 3, "column sensor_dyaw_rad: 'nan' is not a finite number"),
        (GOOD.replace("0.1,-0.2", "inf,-0.2"), 3, "column dt_s: 'inf' is not a finite number"),
        (GOOD.replace("0.1,-0.2", "-0.1,-0.2"), 3, "column dt_s: -0.1 s is negative"),
        (GOOD + "0.1,1,1\n", 4, "has 3 fields, the header has 6"),
        ("dt_s,dt_s,left_rad,right_rad,sensor_dx_m,sensor_dy_m,sensor_dyaw_rad\n", 1, "column dt_s appears twice"),
        (GOOD.splitlines()[0] + "\n# nothing\n", 1, "no intervals after the header"),
    ],
)
def test_bad_content_names_file_and_line(text, line, message):
    with pytest.raises(InputError) as e:
        parse_intervals_csv(text, "x.csv")
    assert e.value.source == "x.csv"
    assert e.value.line == line
    assert message in str(e.value)
    assert str(e.value).startswith(f"x.csv:{line}: ")


def test_empty_and_missing_files(tmp_path):
    with pytest.raises(InputError, match="empty file"):
        parse_intervals_csv("\n# only a comment\n", "e.csv")
    with pytest.raises(InputError, match="file not found"):
        read_intervals_csv(tmp_path / "nope.csv")
    with pytest.raises(InputError, match="folder"):
        read_intervals_csv(tmp_path)


def test_suspicious_values_are_warnings_not_errors():
    text = (
        ",".join(COLUMNS) + "\n"
        "0,0.1,0.1,0.01,0,0\n"  # line 2: zero duration
        "0.1,0.1,0.1,0.01,0,45\n"  # line 3: degrees
        "0.1,2000,2000,0.01,0,0\n"  # line 4: ticks
        "0.1,0.1,0.1,40,0,0\n"  # line 5: millimetres
        "0.1,0.1,0.1,0.01,0,0.01\n"
    )
    iv = parse_intervals_csv(text, "w.csv")
    assert len(iv) == 5
    w = "\n".join(iv.warnings)
    assert len(iv.warnings) == 4
    assert "w.csv: 1 interval (line 2) of zero duration" in w
    assert "(line 3)" in w and "degrees instead of radians" in w
    assert "(line 4)" in w and "encoder ticks" in w
    assert "(line 5)" in w and "millimetres" in w


def test_warning_lists_first_lines_and_counts_the_rest():
    rows = "".join("0,0.1,0.1,0.01,0,0\n" for _ in range(5))
    iv = parse_intervals_csv(",".join(COLUMNS) + "\n" + rows, "z.csv")
    assert iv.warnings == ("z.csv: 5 intervals (line 2, 3, 4 and 2 more) of zero duration (`dt_s` = 0)",)


finite = st.floats(-1e5, 1e5, allow_nan=False, allow_infinity=False, width=64)  # the reader refuses beyond 1e6


@settings(max_examples=100, deadline=None)
@given(
    hnp.arrays(np.float64, st.tuples(st.integers(1, 30), st.just(6)), elements=finite),
    st.floats(0, 10, allow_nan=False),
)
def test_round_trip_is_exact(a, dt0):
    a[:, 0] = np.abs(a[:, 0]) + dt0  # durations are not negative
    iv = Intervals(a[:, 0], a[:, 1], a[:, 2], a[:, 3:])
    back = parse_intervals_csv(format_intervals_csv(iv))
    for name in ("dt_s", "left_rad", "right_rad", "sensor"):
        np.testing.assert_array_equal(getattr(back, name), getattr(iv, name))
    assert format_intervals_csv(back) == format_intervals_csv(iv)


def test_write_is_atomic_and_reads_back(tmp_path):
    iv = parse_intervals_csv(GOOD)
    p = tmp_path / "out.csv"
    write_intervals_csv(iv, p)
    assert p.read_text().splitlines()[0] == ",".join(COLUMNS)
    np.testing.assert_array_equal(read_intervals_csv(p).sensor, iv.sensor)
    with pytest.raises(InputError, match="does not exist"):
        write_intervals_csv(iv, tmp_path / "no" / "out.csv")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["out.csv"]  # no temporary left


# ---- the Intervals type


def test_intervals_validate_shapes_and_values():
    ok = dict(dt_s=[0.1, 0.1], left_rad=[1, 2], right_rad=[1, 2], sensor=np.zeros((2, 3)))
    iv = Intervals(**ok)
    assert iv.left_rad.dtype == float and not iv.left_rad.flags.writeable
    with pytest.raises(InputError, match="`right_rad` has 1 intervals, `dt_s` has 2"):
        Intervals(**{**ok, "right_rad": [1]})
    with pytest.raises(InputError, match=r"`sensor` must have shape \(K, 3\)"):
        Intervals(**{**ok, "sensor": np.zeros((2, 2))})
    with pytest.raises(InputError, match="`left_rad` of interval 1 is not a finite number"):
        Intervals(**{**ok, "left_rad": [1, np.nan]})
    with pytest.raises(InputError, match="`sensor` of interval 0 is not a finite number"):
        Intervals(**{**ok, "sensor": [[0, np.inf, 0], [0, 0, 0]]})
    with pytest.raises(InputError, match="`dt_s` of interval 0 is negative"):
        Intervals(**{**ok, "dt_s": [-1, 0.1]})
    with pytest.raises(InputError, match="one-dimensional"):
        Intervals(**{**ok, "dt_s": [[0.1, 0.1]]})
    assert len(Intervals([], [], [], np.zeros((0, 3)))) == 0


def test_intervals_do_not_share_the_callers_arrays():
    left = np.array([1.0, 2.0])
    iv = Intervals([0.1, 0.1], left, [1, 2], np.zeros((2, 3)))
    left[0] = 99.0
    assert iv.left_rad[0] == 1.0


def test_subset_by_mask_and_index():
    iv = parse_intervals_csv(GOOD, "s.csv")
    one = iv.subset([False, True])
    assert len(one) == 1 and one.left_rad[0] == -0.2 and one.source == "s.csv"
    rev = iv.subset([1, 0])
    np.testing.assert_array_equal(rev.right_rad, [0.2, 0.6])
    with pytest.raises(InputError, match="mask"):
        iv.subset([True])


def test_intervals_from_motion_is_the_conjugated_arc():
    rng = np.random.default_rng(3)
    left, right = rng.normal(size=50), rng.normal(size=50)
    rl, rr, b, pose = 0.05, 0.051, 0.3, np.array([0.1, -0.05, 2.5])
    iv = intervals_from_motion(left, right, 0.1, rl, rr, b, pose)
    q = se2.arc(rl * left, rr * right, b)
    # the sensor motion seen from the robot frame is the robot's motion: l (+) s = q (+) l
    lhs = se2.compose(pose, iv.sensor)
    rhs = se2.compose(q, pose)
    np.testing.assert_allclose(lhs[:, :2], rhs[:, :2], atol=1e-14)
    np.testing.assert_allclose(np.angle(np.exp(1j * (lhs[:, 2] - rhs[:, 2]))), 0, atol=1e-14)
    np.testing.assert_array_equal(iv.dt_s, np.full(50, 0.1))
    # a sensor at the robot's origin, facing forward, sees the robot's own motion
    np.testing.assert_allclose(sensor_motion(left, right, rl, rr, b, [0, 0, 0])[:, :2], q[:, :2], atol=1e-15)


def test_spin_seen_by_an_offset_sensor():
    # a quarter turn on the spot: a sensor 0.2 m ahead, facing forward, ends 0.2 m to the left
    # of the robot's origin, facing left; in its start frame that is (-0.2, 0.2), turned by pi/2
    b, r = 0.4, 0.05
    phi = (math.pi / 2) * b / (2 * r)
    s = sensor_motion(-phi, phi, r, r, b, [0.2, 0.0, 0.0])
    np.testing.assert_allclose(s, [-0.2, 0.2, math.pi / 2], atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.integers(1, 5), min_size=1, max_size=8),
    st.integers(0, 2**32 - 1),
)
def test_intervals_of_several_steps_round_trip_exactly(counts, seed):
    """Intervals with steps: one row per step, the sensor cells on each interval's last; read back
    they are the same intervals with the same steps."""
    from umbmark.model.intervals import IntervalSteps

    rng = np.random.default_rng(seed)
    n = sum(counts)
    steps = IntervalSteps(
        rng.normal(size=n), rng.normal(size=n), np.concatenate([[0], np.cumsum(counts)]), rng.uniform(0, 1, n)
    )
    tl, tr = steps.totals
    dt = np.add.reduceat(steps.dt_s, steps.start[:-1])
    iv = Intervals(dt, tl, tr, rng.normal(size=(len(counts), 3)), steps=steps)
    text = format_intervals_csv(iv)
    assert len(text.splitlines()) == 1 + n
    back = parse_intervals_csv(text)
    for name in ("dt_s", "left_rad", "right_rad", "sensor"):
        np.testing.assert_allclose(getattr(back, name), getattr(iv, name), rtol=1e-12, atol=1e-15)
    if max(counts) > 1:
        np.testing.assert_array_equal(back.steps.start, steps.start)
        np.testing.assert_array_equal(back.steps.left_rad, steps.left_rad)
        np.testing.assert_array_equal(back.steps.dt_s, steps.dt_s)
    else:
        assert back.steps is None


@pytest.mark.parametrize(
    "tail, line, message",
    [
        ("0.1,0.1,0.1,,,\n", 4, "a step row without a row of the interval after it"),
        ("0.1,0.1,0.1,0.2,,\n", 4, "some sensor cells are empty"),
        ("0.1,0.1,x,,,\n0.1,0.1,0.1,0.1,0.1,0.1\n", 4, "column right_rad"),
    ],
)
def test_step_rows_in_error_name_the_line(tail, line, message):
    with pytest.raises(InputError, match=f"f.csv:{line}: .*{message}"):
        parse_intervals_csv(GOOD + tail, "f.csv")


def test_covariance_columns_round_trip_and_are_checked():
    cov = np.array([[[4e-6, 1e-7, 0.0], [1e-7, 1e-6, 2e-9], [0.0, 2e-9, 1e-8]]] * 2)
    a = parse_intervals_csv(GOOD)
    iv = Intervals(a.dt_s, a.left_rad, a.right_rad, a.sensor, covariance=cov)
    text = format_intervals_csv(iv)
    assert text.splitlines()[0].endswith("cov_dx_dx,cov_dx_dy,cov_dx_dyaw,cov_dy_dy,cov_dy_dyaw,cov_dyaw_dyaw")
    np.testing.assert_array_equal(parse_intervals_csv(text).covariance, cov)
    assert parse_intervals_csv(GOOD).covariance is None
    with pytest.raises(InputError, match="f.csv:1: covariance columns cov_dx_dx without cov_dx_dy"):
        parse_intervals_csv(
            GOOD.replace("sensor_dyaw_rad", "sensor_dyaw_rad,cov_dx_dx").replace("\n0", ",1\n0"), "f.csv"
        )
    lines = text.splitlines()
    lines[2] = lines[2].rsplit(",", 6)[0] + ",1,2,0,1,0,1"  # |xy| beyond the variances: not a covariance
    with pytest.raises(InputError, match="f.csv:3: the covariance is not positive semi-definite"):
        parse_intervals_csv("\n".join(lines) + "\n", "f.csv")
