"""Streaming replay of one long generic CSV log: chunked reading gives the batch figures, in
bounded memory; errors name the file and line."""

import json
import math

import numpy as np
import pytest
import simlogs
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.generic_csv import format_generic_csv, iter_generic_csv, read_generic_csv
from umbmark.model.dataset import WheelGeometry
from umbmark.realrobot.replay import evaluate, replay, stream_replay


def _one_run_csv(tmp_path, whole_pulses=True, world=True):
    ds = simlogs.dataset([simlogs.general_program()])
    r = ds.runs[0]
    dl, dr = (np.round(r.d_left), np.round(r.d_right)) if whole_pulses else (r.d_left, r.d_right)
    gt = r.gt
    if world:  # the CSV may hold the ground truth in any fixed frame
        w = simlogs.world(gt)
        gt = np.column_stack([w[:, 0], w[:, 1], w[:, 2] + 4 * math.pi])  # wrapped by 2 turns: unwrapped by the reader
    ds = ds.with_runs([type(r)(r.name, r.t, dl, dr, gt)])
    f = tmp_path / "run.csv"
    f.write_text(format_generic_csv(ds))
    return f, read_generic_csv(f, ds.nominal, ds.units_per_wheel_rev)


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 300), st.booleans(), st.integers(1, 50))
def test_stream_equals_batch_for_any_chunking(tmp_path_factory, chunk_rows, whole, decimate):
    f, batch = _one_run_csv(tmp_path_factory.mktemp("s"), whole_pulses=whole)
    ev = evaluate(batch, batch.nominal)
    x, y, th, _ = replay(batch, batch.nominal)
    rep = stream_replay(
        iter_generic_csv(f, chunk_rows=chunk_rows), batch.nominal, batch.units_per_wheel_rev, decimate=decimate
    )
    s, ev = rep.to_dict(), ev.to_dict()
    assert s["samples"] == len(batch.runs[0])
    assert s["chunks"] == -(-s["samples"] // chunk_rows)
    assert s["end_pose"]["x_mm"] == pytest.approx(x[0, -1] * 1e3, abs=1e-6)
    assert s["end_pose"]["y_mm"] == pytest.approx(y[0, -1] * 1e3, abs=1e-6)
    assert math.radians(s["end_pose"]["theta_deg"]) == pytest.approx(th[0, -1], abs=1e-9)
    assert s["end_position_error_mm"] == pytest.approx(ev["end_position_rms_mm"], rel=1e-9)
    assert abs(s["end_heading_error_deg"]) == pytest.approx(ev["end_heading_rms_deg"], rel=1e-9)
    assert s["path_position_rms_mm"] == pytest.approx(ev["path_position_rms_mm"], rel=1e-9)
    k = rep.kept
    assert s["kept_poses"] == len(k) and s["decimate"] == decimate
    assert np.array_equal(k.sample, np.arange(decimate - 1, s["samples"], decimate))
    assert np.allclose(k.x_m, x[0, k.sample], atol=1e-9) and np.allclose(k.theta_rad, th[0, k.sample], atol=1e-12)
    assert np.allclose(k.t_s, batch.runs[0].t[k.sample])
    # the SI fields are what the JSON reports
    assert rep.end_pose[0] * 1e3 == s["end_pose"]["x_mm"] and rep.path_position_rms_m * 1e3 == s["path_position_rms_mm"]


def test_end_pose_only_and_incremental_ticks(tmp_path):
    # incremental ticks; only the last row has ground truth: a taped end pose in the start frame
    inc = np.array([[0, 0]] + [[10, 11]] * 200 + [[12, 9]] * 100)
    f = tmp_path / "taped.csv"
    rows = ["time_s,left_ticks,right_ticks,x_m,y_m,theta_deg"]
    for i, (a, b) in enumerate(inc):
        rows.append(f"{0.01 * i:.2f},{a},{b}" + (",1.5,0.2,10" if i == len(inc) - 1 else ",,,"))
    f.write_text("\n".join(rows) + "\n")
    nom = WheelGeometry(0.1, 0.1, 0.3)
    batch = read_generic_csv(f, nom, 1000.0, ticks="incremental")
    ev = evaluate(batch, nom).to_dict()
    for chunk in (1, 17, 1000):
        s = stream_replay(iter_generic_csv(f, ticks="incremental", chunk_rows=chunk), nom, 1000.0).to_dict()
        assert s["end_truth"] == pytest.approx({"x_mm": 1500.0, "y_mm": 200.0, "theta_deg": 10.0})
        assert s["end_position_error_mm"] == pytest.approx(ev["end_position_rms_mm"], rel=1e-9)
        assert s["path_position_rms_mm"] is None


@pytest.mark.parametrize(
    "body, line, msg",
    [
        ("time_s,left_ticks,right_ticks\n0,0,0\n0.1,5,x\n", 3, "not a number"),
        ("time_s,left_ticks,right_ticks\n0,0,0\n0.1,5,5\n0.1,6,6\n", 4, "does not increase"),
        ("run,time_s,left_ticks,right_ticks\na,0,0,0\na,0.1,5,5\nb,0.2,6,6\n", 4, "one run per file"),
        (
            "time_s,left_ticks,right_ticks,x_m,y_m,theta_rad\n0,0,0,,,\n0.1,5,5,1,1,0\n0.2,6,6,,,\n",
            3,
            "must start at the first row",
        ),
        ("time_s,left_ticks,right_ticks,x_m,y_m,theta_rad\n0,0,0,0,0,0\n0.1,5,5,1,,0\n", 3, "all given or all empty"),
        ("time_s,left_ticks\n0,0\n", None, "lacks column(s) right_ticks"),
        ("time_s,left_ticks,right_ticks\n0,0,0\n", None, "at least two rows"),
    ],
)
def test_stream_errors_name_file_and_line(tmp_path, body, line, msg):
    f = tmp_path / "bad.csv"
    f.write_text(body)
    with pytest.raises(InputError) as e:
        stream_replay(iter_generic_csv(f, chunk_rows=2), WheelGeometry(0.1, 0.1, 0.3), 1000.0)
    assert msg in str(e.value)
    assert "bad.csv" in str(e.value)
    if line is not None:
        assert f"bad.csv:{line}" in str(e.value)


def test_cli_stream(tmp_path, capsys):
    f, batch = _one_run_csv(tmp_path)
    geo = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]
    out = tmp_path / "poses.csv"
    assert main(["replay", str(f), "--stream", *geo, "--decimate", "10", "--poses-out", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["mode"] == "stream" and d["samples"] == len(batch.runs[0])
    assert d["kept_poses"] == len(batch.runs[0]) // 10
    poses = np.loadtxt(out, delimiter=",", skiprows=1)
    assert poses.shape == (d["kept_poses"], 5)
    assert poses[-1, 2] == pytest.approx(replay(batch, batch.nominal)[0][0, int(poses[-1, 0])], abs=1e-9)
    assert main(["replay", str(f), "--stream", *geo]) == 0
    assert "end position error" in capsys.readouterr().out
    # errors: one line, exit 2, no output file left behind
    bad = tmp_path / "nope.csv"
    assert main(["replay", str(f), "--decimate", "3", *geo]) == 2
    assert "--stream" in capsys.readouterr().err
    assert main(["replay", str(f), "--stream", *geo, "--poses-out", str(bad)]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not bad.exists()
    assert main(["replay", str(f), "--stream", *geo, "--side-mm", "2000"]) == 2
    assert "squares" in capsys.readouterr().err
