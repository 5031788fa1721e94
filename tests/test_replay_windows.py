"""`umbmark replay --window`: the runs of one long bag grouped into windows of time by the bag's
stamps, each window calibrated on its own runs and recorded with its own date; a wheelbase that
changes in the middle of the recording shows as a step between windows and `umbmark drift`
finds it."""

import contextlib
import io
import json
import math
from dataclasses import replace
from datetime import datetime

import numpy as np
import pytest
import simlogs
import test_bag_shapes_sim as sim
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.model.geometry import ErrorParams
from umbmark.realrobot.replay_windows import replay_windows, run_clocks
from umbmark.realrobot.selfcal_windows import window_edges

BAG = ["--joints", "left_wheel_joint,right_wheel_joint", "--gt-topic", "/mocap/pose", "--split-stops"]
GEOMETRY = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--side-mm", "2000"]
A = sim.NO_SCALE  # no scale error: a square sees the wheelbase against the mean wheel
B = ErrorParams(ed=A.ed, eb=A.eb * 1.015)  # the wheelbase 1.5 % longer (a payload)


def _long_bag(path, errors, noise_seed=5):
    """One bag of several sessions of four squares (cw, ccw, cw, ccw) driven one after the other,
    each session with its own true geometry; motion capture with 0.5 mm and 0.05 deg noise."""
    t_all, pl, pr, world, odom = [], [], [], [], []
    t0 = l0 = r0 = 0.0
    for e in errors:
        t, a, b, w, o, _ = sim.session(["cw", "ccw", "cw", "ccw"], errors=e)
        t_all.append(t + t0)
        pl.append(a + l0)
        pr.append(b + r0)
        world.append(w)
        odom.append(o)
        t0, l0, r0 = t_all[-1][-1] + sim.DT, pl[-1][-1], pr[-1][-1]
    t = np.concatenate(t_all)
    noise = (0.0005, math.radians(0.05), noise_seed)
    return sim.write_bag(str(path), t, *(np.concatenate(x) for x in (pl, pr, world, odom)), odometry=False, noise=noise)


def run(*args) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def _json(args):
    code, out, err = run(*args)
    assert code == 0, err
    return json.loads(out)


@pytest.fixture(scope="module")
def step_bag(tmp_path_factory):
    return _long_bag(tmp_path_factory.mktemp("win") / "step", [A, A, A, A, B, B])


@pytest.mark.slow
def test_windows_follow_the_bag_clock_and_show_the_step(step_bag):
    d = _json(["replay", step_bag, *BAG, *GEOMETRY, "--method", "exact", "--window", "190s", "--json"])
    wins = d["windows"]
    assert [w["window"] for w in wins] == list(range(6))
    assert all(len(w["runs"]) == 4 and w["error"] is None for w in wins)
    # runs are grouped by time: the first window holds the bag's first four runs
    assert wins[0]["runs"] == ["bag#1", "bag#2", "bag#3", "bag#4"]
    # the dates are the bag's own stamps, one session apart
    t = [datetime.fromisoformat(w["start_utc"].replace("Z", "+00:00")) for w in wins]
    assert 0.0 <= t[0].timestamp() - sim.T0 < 5.0  # the first run starts after the bag's first pause
    gaps = np.diff([x.timestamp() for x in t])
    assert np.all(np.abs(gaps - gaps[0]) < 1e-3) and 150 < gaps[0] < 250
    eb = np.array([w["result"]["Eb"] for w in wins])
    # each window recovers its own session's wheelbase: before the step A's, after it B's
    assert np.allclose(eb[:4], A.eb, rtol=3e-3) and np.allclose(eb[4:], B.eb, rtol=3e-3)
    assert eb[4:].mean() / eb[:4].mean() == pytest.approx(1.015, abs=3e-3)
    # the whole recording's calibration mixes both
    assert eb[:4].mean() < d["Eb"] < eb[4:].mean()


@pytest.mark.slow
def test_recorded_windows_and_drift_find_the_step(step_bag, tmp_path):
    db = str(tmp_path / "h.sqlite")
    args = ["replay", step_bag, *BAG, *GEOMETRY, "--method", "exact", "--window", "190s"]
    d = _json([*args, "--robot", "r1", "--record", "--db", db, "--json"])
    ids = [w["history"]["record_id"] for w in d["windows"]]
    assert len(set(ids)) == 6
    assert d["history"] == [w["history"] for w in d["windows"]]
    h = _json(["history", "r1", "--db", db, "--json"])
    recs = h["records"] if isinstance(h, dict) else h
    assert len(recs) == 6
    assert [r["time_utc"][:16] for r in recs] == [w["start_utc"][:16] for w in d["windows"]]
    code, text, err = run("drift", "r1", "--db", db, "--json")
    assert code == 3, err
    out = json.loads(text)
    eb = [c for c in out["changes"] if c["parameter"].endswith("Eb")]
    assert eb and eb[0]["record"] == ids[4]
    assert eb[0]["after"] / eb[0]["before"] == pytest.approx(1.015, abs=3e-3)


def test_one_window_is_the_whole_recording(step_bag):
    d = _json(["replay", step_bag, *BAG, *GEOMETRY, "--method", "bf", "--window", "2h", "--json"])
    (w,) = d["windows"]
    assert len(w["runs"]) == 24
    assert w["result"]["Eb"] == pytest.approx(d["Eb"], rel=1e-12)


def test_a_window_the_method_cannot_calibrate_is_named_and_the_others_go_on():
    ds = simlogs.dataset([simlogs.square_program("cw", 2.0)] * 2 + [simlogs.square_program("ccw", 2.0)] * 2, side_m=2.0)
    runs = tuple(replace(r, clock_s=100.0 * i) for i, r in enumerate(ds.runs))  # each run 100 s after the last
    ds = replace(ds, runs=runs)
    wins = replay_windows(ds, 200.0, "bf", heldout=False)
    assert len(wins) == 2  # span 300 s + the last run (about 60 s)
    assert wins[0].report is None and "ccw" in (wins[0].error or "")  # the first window: two cw runs only
    assert wins[1].report is None
    assert [w.runs for w in wins] == [("run-01", "run-02"), ("run-03", "run-04")]
    paths = simlogs.dataset([simlogs.general_program()] * 4)  # general paths: lsq, one direction is enough
    paths = replace(paths, runs=tuple(replace(r, clock_s=100.0 * i) for i, r in enumerate(paths.runs)))
    lsq = replay_windows(paths, 200.0, "lsq", heldout=False)
    assert [len(w.runs) for w in lsq] == [2, 2]
    true = simlogs.true_geometry()
    for w in lsq:
        assert w.report is not None, w.error
        g = w.report.calibration.geometry
        assert g.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-3)
        assert g.diameter_right_m / g.diameter_left_m == pytest.approx(simlogs.TRUE.ed, rel=1e-4)


def test_runs_without_a_clock_or_overlapping_are_refused():
    ds = simlogs.dataset([simlogs.square_program("cw", 2.0)] * 2, side_m=2.0)
    with pytest.raises(InputError, match="no clock"):
        run_clocks(ds)
    same = replace(ds, runs=tuple(replace(r, clock_s=0.0) for r in ds.runs))
    with pytest.raises(InputError, match="overlap in time"):
        run_clocks(same)
    with pytest.raises(InputError, match="at least 10 s"):
        replay_windows(replace(ds, runs=tuple(replace(r, clock_s=1e3 * i) for i, r in enumerate(ds.runs))), 5.0)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--window", "10min"], "no clock"),  # optiodom: each run starts at 0 s
        (["--window", "10min", "--pool", "--method", "lsq"], "--window does not go with --pool"),
        (["--window", "5s"], "10 s to a week"),
        (["--window", "ten minutes"], "no duration"),
    ],
)
def test_cli_refusals_are_one_line(optiodom, extra, message):
    code, out, err = run("replay", optiodom / "square" / "230620202144", *extra)
    assert code == 2 and out == ""
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


@settings(max_examples=200, deadline=None)
@given(
    gaps=st.lists(st.floats(0.0, 500.0), min_size=1, max_size=30),
    lengths=st.lists(st.floats(1.0, 300.0), min_size=30, max_size=30),
    window_s=st.floats(10.0, 2000.0),
)
def test_every_run_in_one_window_in_time_order(gaps, lengths, window_s):
    start = np.cumsum(np.array(gaps) + np.array(lengths[: len(gaps)])) - gaps[0] - lengths[0]
    start -= start[0]
    length = float(start[-1] + lengths[len(gaps) - 1])
    edges, which = window_edges(start, length, window_s)
    count = len(edges) - 1
    assert count == max(1, round(length / window_s))
    assert edges[0] == 0.0 and edges[-1] == pytest.approx(length)
    assert np.all((0 <= which) & (which < count))
    assert np.all(np.diff(which) >= 0)  # later runs never in earlier windows
    inside = (edges[which] <= start + 1e-9) & ((start < edges[which + 1]) | (which == count - 1))
    assert np.all(inside)


def _csv_log(path, clocks):
    """One CSV log of general-path runs told apart by a ``run`` column, run i's time_s from
    ``clocks[i]``; cumulative ticks and the true pose."""
    ds = simlogs.dataset([simlogs.general_program()] * len(clocks))
    lines = ["time_s,left_ticks,right_ticks,x_m,y_m,theta_rad,run"]
    for clock, r in zip(clocks, ds.runs):
        left, right = np.cumsum(r.d_left), np.cumsum(r.d_right)
        for k in range(len(r)):
            x, y, th = r.gt[k]
            lines.append(f"{clock + r.t[k]:.3f},{left[k]:.6f},{right[k]:.6f},{x:.6f},{y:.6f},{th:.8f},{r.name}")
    path.write_text("\n".join(lines) + "\n")
    return path


CSV_GEOMETRY = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--pulses-per-wheel-rev", "1000"]


def test_a_csv_log_is_windowed_by_its_own_time(tmp_path):
    log = _csv_log(tmp_path / "day.csv", [1.7e9 + 100.0 * i for i in range(4)])
    d = _json(["replay", log, *CSV_GEOMETRY, "--method", "lsq", "--window", "200s", "--json"])
    assert [w["runs"] for w in d["windows"]] == [["run-01", "run-02"], ["run-03", "run-04"]]
    t = [datetime.fromisoformat(w["start_utc"].replace("Z", "+00:00")).timestamp() - 1.7e9 for w in d["windows"]]
    assert t[0] == pytest.approx(0.0, abs=1e-3) and 100.0 < t[1] <= 200.0  # the log's clock: run-03 at 200 s
    true = simlogs.true_geometry()
    for w in d["windows"]:
        assert w["result"]["wheelbase_corrected_mm"] == pytest.approx(true.wheelbase_m * 1e3, rel=1e-3)
    # every run starting at 0 s: no clock shared by the runs, refused in one line
    same = _csv_log(tmp_path / "zero.csv", [0.0] * 4)
    code, out, err = run("replay", same, *CSV_GEOMETRY, "--method", "lsq", "--window", "200s")
    assert code == 2 and out == "" and "overlap in time" in err and len(err.strip().splitlines()) == 1
