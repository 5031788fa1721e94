"""Plausibility of generic CSV logs: left and right tick columns swapped, x_m holding
millimetres, a tick beyond any counter, per-sample ticks read as cumulative counters. The logs
are simulated (tests/simlogs.py) and written with the project's writer, then mislabelled."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest
import simlogs
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.generic_csv import format_generic_csv, read_generic_csv

GEOM = simlogs.dataset(simlogs.squares(1), side_m=2.0).nominal
UPR = simlogs.GEOM.pulses_per_motor_rev * simlogs.GEOM.gear_ratio


def _rows(tmp_path):
    ds = simlogs.dataset(simlogs.squares(1), side_m=2.0)
    text = format_generic_csv(ds)
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    header, *rows = list(csv.reader(lines))
    return header, rows


def _write(tmp_path, header, rows, name="log.csv"):
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    f = tmp_path / name
    f.write_text(out.getvalue())
    return f


def _read(f, ticks="cumulative"):
    return read_generic_csv(f, GEOM, UPR, ticks=ticks, side_m=2.0)


def test_clean_simulated_log_gives_no_warning(tmp_path):
    header, rows = _rows(tmp_path)
    assert "warnings" not in _read(_write(tmp_path, header, rows)).meta


def test_left_and_right_swapped_in_the_header(tmp_path):
    header, rows = _rows(tmp_path)
    i, j = header.index("left_ticks"), header.index("right_ticks")
    header[i], header[j] = header[j], header[i]
    w = _read(_write(tmp_path, header, rows)).meta["warnings"]
    assert w and all("left and right wheel data look swapped" in x for x in w)


def test_x_m_holding_millimetres(tmp_path):
    header, rows = _rows(tmp_path)
    for r in rows:
        for c in ("x_m", "y_m"):
            k = header.index(c)
            r[k] = repr(float(r[k]) * 1000) if r[k] else r[k]
    w = _read(_write(tmp_path, header, rows)).meta["warnings"]
    assert w and all("x_m and y_m are in metres" in x for x in w)


def test_a_tick_beyond_any_counter_is_an_error_on_its_line(tmp_path, capsys):
    header, rows = _rows(tmp_path)
    rows[10][header.index("right_ticks")] = "1e308"
    f = _write(tmp_path, header, rows)
    with pytest.raises(InputError, match="right_ticks: 1e\\+308 is beyond any encoder counter") as e:
        _read(f)
    assert e.value.line == 12  # the header is line 1
    args = ["replay", str(f), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "beyond any encoder counter" in err


def test_per_sample_ticks_read_as_cumulative_name_the_tick_mode(tmp_path, capsys):
    header, rows = _rows(tmp_path)
    for c in ("left_ticks", "right_ticks"):
        k = header.index(c)
        v = np.array([float(r[k]) for r in rows])
        inc = np.diff(v, prepend=v[0])
        for r, x in zip(rows, inc):
            r[k] = repr(float(x))
    f = _write(tmp_path, header, rows)
    assert len(_read(f, "incremental").runs) == 2  # right with the right mode
    with pytest.raises(InputError, match='the ticks look incremental \\(`ticks="incremental"`\\)'):
        _read(f)
    args = ["replay", str(f), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]
    assert main([*args, "--method", "lsq"]) == 2
    assert "--ticks incremental" in capsys.readouterr().err


def test_streaming_reader_refuses_the_same_ticks(tmp_path, capsys):
    header, rows = _rows(tmp_path)
    one = [r for r in rows if r[header.index("run")] == rows[0][header.index("run")]]
    one[10][header.index("left_ticks")] = "-1e308"
    f = _write(tmp_path, header, one)
    args = ["replay", str(f), "--stream", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]
    assert main([*args, "--pulses-per-wheel-rev", "1000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{f}:12: column left_ticks: -1e+308 is beyond any encoder counter" in err


def test_counters_read_as_per_sample_ticks_name_the_tick_mode(tmp_path):
    header, rows = _rows(tmp_path)
    f = _write(tmp_path, header, rows)
    with pytest.raises(InputError, match='the ticks look cumulative \\(`ticks="cumulative"`\\)'):
        _read(f, "incremental")


def test_without_ground_truth_the_squares_sides_are_the_travel(tmp_path):
    header, rows = _rows(tmp_path)
    keep = [header.index(c) for c in ("run", "time_s", "left_ticks", "right_ticks")]
    f = _write(tmp_path, [header[k] for k in keep], [[r[k] for k in keep] for r in rows])
    assert len(_read(f).runs) == 2
    with pytest.raises(InputError, match="the ticks look cumulative"):
        _read(f, "incremental")


# --- the property: mislabelled simulated logs flagged, clean ones (in any world frame) not ------

LOG_MISLABEL = ("swap_wheels", "x_in_mm", "theta_in_deg", "per_sample_as_counter", "counter_as_per_sample")


def _log_file(tmp_path, ed, eb, yaw, how):
    from umbmark.model.geometry import ErrorParams

    ds = simlogs.dataset(simlogs.squares(1, 1.0), errors=ErrorParams(ed, eb, 1.0), side_m=1.0)
    header = ["run", "time_s", "left_ticks", "right_ticks", "x_m", "y_m", "theta_rad"]
    rows = []
    for r in ds.runs:
        pose = simlogs.world(r.gt, yaw=yaw)  # the ground truth in a rotated world frame
        left, right = np.cumsum(r.d_left) + 5000, np.cumsum(r.d_right) + 5000
        if how == "swap_wheels":
            left, right = right, left
        if how == "x_in_mm":
            pose = pose * [1000.0, 1000.0, 1.0]
        if how == "theta_in_deg":
            pose = pose * [1.0, 1.0, 180 / np.pi]
        if how == "per_sample_as_counter":
            left, right = r.d_left, r.d_right
        rows += [[r.name, t, a, b, *p] for t, a, b, p in zip(r.t, left, right, pose)]
    f = _write(tmp_path, header, [[x if isinstance(x, str) else repr(float(x)) for x in row] for row in rows])
    return f, ("incremental" if how == "counter_as_per_sample" else "cumulative")


@settings(max_examples=15, deadline=None, derandomize=True)
@given(
    ed=st.floats(0.99, 1.01),
    eb=st.floats(0.95, 1.05),
    yaw=st.floats(-3.0, 3.0),
    how=st.sampled_from(("clean",) + LOG_MISLABEL),
)
def test_property_mislabelled_logs_are_flagged_clean_ones_not(tmp_path_factory, ed, eb, yaw, how):
    f, ticks = _log_file(tmp_path_factory.mktemp("log"), ed, eb, yaw, how)
    try:
        warned = bool(_read(f, ticks).meta.get("warnings"))
    except InputError:
        warned = True
    assert warned == (how != "clean")
