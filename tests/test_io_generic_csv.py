"""The generic CSV log: round trip, cumulative vs incremental ticks, start frame, errors."""

import math

import numpy as np
import pytest
import simlogs
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.generic_csv import format_generic_csv, read_generic_csv
from umbmark.model.dataset import WheelGeometry, to_start_frame

NOM = WheelGeometry(0.1, 0.1, 0.3)


def test_round_trip_of_simulated_runs(tmp_path):
    ds = simlogs.dataset(simlogs.squares(1), side_m=2.0)
    # whole pulses, as an encoder log holds
    ds = ds.with_runs([type(r)(r.name, r.t, np.round(r.d_left), np.round(r.d_right), r.gt) for r in ds.runs])
    f = tmp_path / "log.csv"
    f.write_text(format_generic_csv(ds))
    back = read_generic_csv(f, ds.nominal, ds.units_per_wheel_rev, side_m=2.0)
    assert [r.name for r in back.runs] == ["run-01", "run-02"]
    for a, b in zip(ds.runs, back.runs):
        assert np.allclose(a.d_left, b.d_left) and np.allclose(a.d_right, b.d_right)
        assert np.allclose(a.gt, b.gt, atol=1e-8)
        assert np.allclose(a.t, b.t)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)), min_size=2, max_size=30),
    st.floats(-3, 3),
    st.floats(-5, 5),
    st.floats(-5, 5),
)
def test_cumulative_and_incremental_agree_and_start_frame(tmp_path_factory, inc, yaw, x0, y0):
    inc = np.array(inc, dtype=float)
    inc[0] = 0
    cum = np.cumsum(inc, axis=0) + 1000  # a counter need not start at zero
    t = np.arange(len(inc)) * 0.1
    rng = np.random.default_rng(len(inc))
    xs, ys, ths = x0 + rng.normal(size=len(inc)), y0 + rng.normal(size=len(inc)), yaw + rng.normal(size=len(inc))
    d = tmp_path_factory.mktemp("csv")
    fc, fi = d / "c.csv", d / "i.csv"
    for f, ticks in ((fc, cum), (fi, inc)):
        rows = ["time_s,left_ticks,right_ticks,x_m,y_m,theta_rad"]
        cols = (t, ticks[:, 0], ticks[:, 1], xs, ys, ths)
        rows += [",".join(repr(float(c[k])) for c in cols) for k in range(len(t))]
        f.write_text("\n".join(rows) + "\n")
    a = read_generic_csv(fc, NOM, 1000, "cumulative").runs[0]
    b = read_generic_csv(fi, NOM, 1000, "incremental").runs[0]
    assert np.allclose(a.d_left, inc[:, 0]) and np.allclose(b.d_left, inc[:, 0])
    assert np.allclose(a.d_right, b.d_right)
    assert np.allclose(a.gt[0], 0.0, atol=1e-9)
    # distances between poses are preserved by the change of frame
    assert np.allclose(np.hypot(np.diff(a.gt[:, 0]), np.diff(a.gt[:, 1])), np.hypot(np.diff(xs), np.diff(ys)))
    ex = np.column_stack(to_start_frame(xs, ys, ths))
    assert np.allclose(a.gt, ex)


def test_end_pose_only_and_degrees(tmp_path):
    f = tmp_path / "taped.csv"
    f.write_text(
        "# a taped end pose\ntime_s,left_ticks,right_ticks,x_m,y_m,theta_deg\n0,0,0,,,\n1,100,120,,,\n"
        "2,200,230,0.5,0.1,10\n"
    )
    r = read_generic_csv(f, NOM, 1000).runs[0]
    assert r.gt is None and not r.has_trajectory
    assert np.allclose(r.end_truth, [0.5, 0.1, math.radians(10)])


@pytest.mark.parametrize(
    "text, msg, line",
    [
        ("time,left,right\n0,0,0\n", "header lacks column(s) time_s, left_ticks, right_ticks", 1),
        ("time_s,left_ticks,right_ticks\n0,0,0\n0.1,1,zz\n", "column right_ticks: 'zz' is not a number", 3),
        ("time_s,left_ticks,right_ticks\n0,0,0\n0.1,1\n", "has 2 fields", 3),
        ("time_s,left_ticks,right_ticks\n0,0,0\n0,1,1\n", "does not increase", 3),
        ("time_s,left_ticks,right_ticks,x_m,y_m,theta_rad\n0,0,0,0,0,0\n0.1,1,1,1,,0\n", "all given or all empty", 3),
        ("time_s,left_ticks,right_ticks,x_m,y_m\n0,0,0,0,0\n", "needs x_m, y_m and theta", 1),
        ("run,time_s,left_ticks,right_ticks\na,0,0,0\na,1,1,1\nb,0,0,0\nb,1,1,1\na,2,2,2\n", "not consecutive", 6),
    ],
)
def test_errors_name_file_and_line(tmp_path, text, msg, line):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(InputError) as e:
        read_generic_csv(f, NOM, 1000)
    assert msg in str(e.value)
    assert e.value.source == str(f) and e.value.line == line


def test_cli_convert_optiodom_to_csv_and_replay_it(optiodom, tmp_path, capsys):
    out = tmp_path / "log.csv"
    assert main(["convert", str(optiodom / "square/230620202144"), "--out", str(out)]) == 0
    capsys.readouterr()
    common = ["--method", "bf", "--json"]
    assert main(["replay", str(optiodom / "square/230620202144"), *common]) == 0
    import json

    ref = json.loads(capsys.readouterr().out)
    assert (
        main(
            [
                "replay",
                str(out),
                "--wheel-diameter-mm",
                "84",
                "--wheelbase-mm",
                "205",
                "--pulses-per-wheel-rev",
                str(43.7 * 64),
                "--side-mm",
                "750",
                *common,
            ]
        )
        == 0
    )
    got = json.loads(capsys.readouterr().out)
    for k in ("Ed", "Eb", "wheelbase_corrected_mm"):
        assert got[k] == pytest.approx(ref[k], rel=1e-9)
    assert got["before"]["emax_syst_mm"] == pytest.approx(ref["before"]["emax_syst_mm"], rel=1e-6)
    # the geometry convert recorded in the header is used when none is given
    assert main(["replay", str(out), "--side-mm", "750", *common]) == 0
    rec = json.loads(capsys.readouterr().out)
    for k in ("Ed", "Eb", "wheelbase_corrected_mm"):
        assert rec[k] == pytest.approx(ref[k], rel=1e-9)
    # CSV without the geometry: one-line error, exit 2
    bare = tmp_path / "bare.csv"
    bare.write_text("".join(ln for ln in out.read_text().splitlines(True) if not ln.startswith("#")))
    assert main(["replay", str(bare), "--method", "bf"]) == 2
    assert "--pulses-per-wheel-rev" in capsys.readouterr().err
