"""Replay of logged runs, UMBmark on real square runs, calibration before/after, held out."""

import glob
import json
import math
from pathlib import Path

import numpy as np
import pytest
import simlogs

from umbmark.cli import main
from umbmark.io.optiodom import read_optiodom
from umbmark.realrobot.replay import detect_directions, replay, replay_report

PINNED = "square/230620202144"


def test_replay_with_true_geometry_reproduces_ground_truth():
    ds = simlogs.dataset([simlogs.general_program()])
    x, y, th, n = replay(ds, simlogs.true_geometry())
    g = ds.runs[0].gt
    assert np.allclose(x[0], g[:, 0], atol=1e-9) and np.allclose(y[0], g[:, 1], atol=1e-9)
    assert np.allclose(th[0], g[:, 2], atol=1e-9)
    # the nominal odometry does not
    x, y, _, _ = replay(ds, ds.nominal)
    assert np.hypot(x[0, -1] - g[-1, 0], y[0, -1] - g[-1, 1]) > 0.01


def test_directions_detected_from_total_turn():
    ds = simlogs.dataset(simlogs.squares(2), side_m=2.0)
    dirs, turn, warnings = detect_directions(ds)
    assert dirs == ["cw", "cw", "ccw", "ccw"]
    assert np.allclose(np.abs(np.degrees(turn)), 360.0)
    assert warnings == []
    # a wrongly declared direction is reported, the detected one used
    from dataclasses import replace

    bad = replace(ds, directions=("ccw", "cw", "ccw", "ccw"))
    assert any("differs from the declared" in w for w in detect_directions(bad)[2])


def test_simulated_square_bf_and_lsq():
    ds = simlogs.dataset(simlogs.squares(2), side_m=2.0)
    true = simlogs.true_geometry()
    bf = replay_report(ds, "bf").to_dict()
    assert bf["after"]["emax_syst_mm"] < bf["before"]["emax_syst_mm"] / 20
    assert bf["Ed"] == pytest.approx(true.ed, abs=2e-4)  # linearised: close, not exact
    lsq = replay_report(ds, "lsq").to_dict()
    assert lsq["Ed"] == pytest.approx(true.ed, abs=1e-6)
    assert lsq["wheelbase_corrected_mm"] == pytest.approx(true.wheelbase_m * 1e3, rel=1e-6)
    assert lsq["after"]["emax_syst_mm"] < 1e-3
    assert lsq["heldout"]["emax_syst_mm"] < 1e-3


@pytest.fixture(scope="module")
def square_reports():
    out = {}
    for d in sorted(glob.glob(str(simlogs_data() / "square/*"))):
        ds = read_optiodom(d)
        out[ds.name] = (ds, replay_report(ds, "bf").to_dict())
    return out


def simlogs_data():
    from pathlib import Path

    return Path(__file__).resolve().parents[1] / "data" / "optiodom"


def test_declared_directions_match_detected(square_reports):
    for name, (ds, rep) in square_reports.items():
        assert [r["direction"] for r in rep["runs"]] == list(ds.directions), name
        assert not rep["warnings"], name


def test_bf_at_least_five_fold_on_every_square_set(square_reports):
    for name, (_, rep) in square_reports.items():
        assert rep["after"]["emax_syst_mm"] * 5 <= rep["before"]["emax_syst_mm"], name
        assert "heldout" in rep and "emax_syst_mm" in rep["heldout"]
        if len(rep["runs"]) >= 4:  # leave-one-out needs 2 runs per direction
            assert rep["heldout"]["emax_syst_mm"] * 5 <= rep["before"]["emax_syst_mm"], name
        else:
            assert rep["heldout"]["emax_syst_mm"] is None and "both directions" in rep["heldout"]["reason"]


def test_corrected_geometries_agree_and_wrong_nominal_pulled_back(square_reports):
    ratio = {n: rep["wheelbase_per_mean_diameter"] for n, (_, rep) in square_reports.items()}
    right = [
        n
        for n, (ds, _) in square_reports.items()
        if ds.nominal.wheelbase_m == pytest.approx(0.2) and ds.nominal.diameter_left_m == pytest.approx(0.084)
    ]
    ref = np.mean([ratio[n] for n in right])
    for n, r in ratio.items():
        assert abs(r / ref - 1) < 0.01, n  # wheelbase within 1 % once the diameter scale is accounted for
    for n, (ds, rep) in square_reports.items():
        nominal_ratio = ds.nominal.wheelbase_m / ds.nominal.diameter_avg_m
        if abs(nominal_ratio / ref - 1) > 0.01:  # the wrong-nominal sets
            assert abs(rep["wheelbase_per_mean_diameter"] - ref) < 0.2 * abs(nominal_ratio - ref), n
    wrong_b = square_reports["230620202144"][1]
    assert abs(wrong_b["wheelbase_corrected_mm"] - 200) < abs(205 - 200) / 2


# one set per side length (0.75 m and 1.7 m), the 1.7 m set with only 2 runs (no leave-one-out)
PINNED_SETS = ["square/230620202144", "square/231220200029", "square/231220200045"]
PINNED_NUMBERS = ("Ed", "Eb", "wheelbase_corrected_mm", "diameter_left_mm", "diameter_right_mm")


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@pytest.mark.parametrize("method", ["bf", "exact", "lsq"])
@pytest.mark.parametrize("dataset", PINNED_SETS)
def test_pinned_cli_json(optiodom, capsys, dataset, method):
    """The pinned JSON interface of replay, for every method on one set per side length."""
    assert main(["replay", str(optiodom / dataset), "--format", "optiodom", "--method", method, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for k in PINNED_NUMBERS:
        assert _is_number(d[k]), (k, d.get(k))
    assert d["diameter_right_mm"] / d["diameter_left_mm"] == pytest.approx(d["Ed"], rel=1e-9)
    for k in ("before", "after"):
        assert _is_number(d[k]["emax_syst_mm"]), (k, d[k]["emax_syst_mm"])
    assert d["after"]["emax_syst_mm"] < d["before"]["emax_syst_mm"] / 2  # lsq on 1.7 m squares: 2.2-fold
    ho = d["heldout"]
    assert "emax_syst_mm" in ho
    n_runs = len(d["runs"])
    if n_runs >= 4:  # 2 runs per direction: leave-one-run-out works
        assert _is_number(ho["emax_syst_mm"]), ho.get("reason")
        assert ho["emax_syst_mm"] < d["before"]["emax_syst_mm"] / 2
    else:  # it cannot: null, and the JSON says why
        assert ho["emax_syst_mm"] is None
        assert "both directions" in ho["reason"] and "1 cw and 1 ccw" in ho["reason"]


def test_several_sets_held_out_across(optiodom, capsys):
    sets = [str(optiodom / "square" / s) for s in ("230620202042", "230620202144", "230620202258")]
    assert main(["replay", *sets, "--method", "bf", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["datasets"]) == 3 and len(d["across"]) == 6
    for rep in d["datasets"]:
        a = rep["heldout"]["across_datasets"]
        assert len(a["from"]) == 2
        # a calibration from another set (even one with a wrong nominal) beats the nominal odometry
        assert a["emax_syst_mm_max"] < rep["before"]["emax_syst_mm"]
    assert main(["replay", *sets, "--method", "bf"]) == 0
    assert "Held out across data sets" in capsys.readouterr().out


def test_bf_on_a_general_path_is_refused(optiodom, capsys):
    assert main(["replay", str(optiodom / "free/030120210006"), "--method", "bf"]) == 2
    err = capsys.readouterr().err
    assert "square" in err and err.count("\n") == 1


# --- properties of the log maths -------------------------------------------------------------

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from umbmark.model.dataset import to_start_frame, wheel_travel_from_poses  # noqa: E402
from umbmark.studies.reference import integrate  # noqa: E402  (the per-sample oracle)

_travel = st.lists(st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)), min_size=1, max_size=40)


@settings(max_examples=60, deadline=None)
@given(_travel, st.floats(0.1, 1.0))
def test_wheel_travel_from_poses_inverts_integrate(travel, b):
    t = np.array([(0.0, 0.0)] + travel)
    x, y, th = integrate(t[:, 0], t[:, 1], b)
    dl, dr = wheel_travel_from_poses(x, y, th, b)
    assert np.allclose(dl[1:], t[1:, 0], atol=1e-9) and np.allclose(dr[1:], t[1:, 1], atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(-20, 20)), min_size=2, max_size=20))
def test_start_frame_keeps_relative_geometry(poses):
    p = np.array(poses)
    x, y, th = to_start_frame(p[:, 0], p[:, 1], p[:, 2])
    assert x[0] == 0 and y[0] == 0 and th[0] == 0
    # distances from the start and turn angles are unchanged
    assert np.allclose(np.hypot(x, y), np.hypot(p[:, 0] - p[0, 0], p[:, 1] - p[0, 1]), atol=1e-9)
    d = np.mod(th - (np.unwrap(p[:, 2]) - p[0, 2]) + np.pi, 2 * np.pi) - np.pi
    assert np.allclose(d, 0, atol=1e-9)


def test_replay_records_into_history(tmp_path, capsys):
    from umbmark.cli import main

    db = tmp_path / "h.sqlite"
    ds = str(Path(__file__).resolve().parents[1] / "data" / "optiodom" / "square" / "230620202144")
    code = main(
        ["replay", ds, "--method", "bf", "--no-heldout", "--robot", "optibot", "--record", "--db", str(db), "--json"]
    )
    out = capsys.readouterr().out
    assert code == 0
    rec = json.loads(out)["history"]
    assert rec and rec[0]["robot"] == "optibot"
    assert main(["history", "optibot", "--db", str(db), "--json"]) == 0
    hist = json.loads(capsys.readouterr().out)
    assert "replay" in json.dumps(hist) and "201.4" in json.dumps(hist)


# --- the fast odometry path ----------------------------------------------------------


def _numbers(a, b, path=""):
    """Pairs of numbers at the same place in two JSON-like objects."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            yield from _numbers(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            yield from _numbers(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        yield path, a, b
    else:
        assert a == b, path


@pytest.mark.parametrize("method", ["bf", "lsq"])
def test_fast_kernels_give_the_same_report(monkeypatch, method):
    """Forcing the chunked kernels of umbmark.model.odometry (used on long logs) on a real optiodom set
    changes no reported figure beyond rounding."""
    import umbmark.model.dataset as logs

    ds = read_optiodom(simlogs_data() / PINNED)
    slow = replay_report(ds, method).to_dict()
    monkeypatch.setattr(logs, "FAST_MIN_SAMPLES", 0)
    fast = replay_report(ds, method).to_dict()
    worst = max(abs(x - y) / max(abs(x), 1e-3) for _, x, y in _numbers(slow, fast))
    assert worst < 1e-6


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 3), st.integers(2, 400), st.booleans(), st.integers(0, 2**32 - 1))
def test_replay_increments_dispatch_matches_the_oracle(rows, k, integral, seed):
    """Above FAST_MIN_SAMPLES the fast kernels (table kernel for whole-number increments, float
    kernel otherwise) give the poses of the per-sample oracle."""
    import umbmark.model.dataset as logs
    from umbmark.model.geometry import OdometryParams

    rng = np.random.default_rng(seed)
    dl = rng.integers(-3, 40, (rows, k)).astype(float)
    dr = rng.integers(-3, 40, (rows, k)).astype(float)
    if not integral:
        dl += rng.uniform(-0.5, 0.5, dl.shape)
    p = OdometryParams(1.1e-4, 0.9e-4, 0.21)
    per_row = [integrate(a, c, p.wheelbase_m) for a, c in zip(dl * p.left_m_per_pulse, dr * p.right_m_per_pulse)]
    ref = [np.array(v) for v in zip(*per_row)]  # x, y, theta, each (rows, k)
    old = logs.FAST_MIN_SAMPLES
    try:
        logs.FAST_MIN_SAMPLES = 0
        got = logs.replay_increments(dl, dr, p)
        end = logs.replay_increments(dl, dr, p, end=True)
    finally:
        logs.FAST_MIN_SAMPLES = old
    for r, g, e in zip(ref, got, end):
        assert np.allclose(g, r, rtol=0, atol=1e-10)
        assert np.allclose(e, r[..., -1], rtol=0, atol=1e-10)


# --- the library's results: SI dataclasses whose to_dict() is the JSON ---------------------------


def test_replay_method_choices_are_the_librarys():
    from umbmark.cli.replay import REPLAY_METHOD_CHOICES
    from umbmark.realrobot.replay import method_names

    assert list(REPLAY_METHOD_CHOICES) == method_names()


def test_report_fields_are_si_and_to_dict_is_the_json(square_reports):
    ds = read_optiodom(simlogs_data() / PINNED)
    rep = replay_report(ds, "bf")
    d = rep.to_dict()
    assert d == square_reports[ds.name][1]
    assert rep.before.emax_syst_m * 1e3 == d["before"]["emax_syst_mm"]
    assert rep.after.end_heading_rms_rad is not None
    assert math.degrees(rep.after.end_heading_rms_rad) == d["after"]["end_heading_rms_deg"]
    assert rep.calibration.geometry.wheelbase_m * 1e3 == d["wheelbase_corrected_mm"]
    assert rep.calibration.c_left == d["c_left"] and rep.calibration.ed == d["Ed"] and rep.calibration.eb == d["Eb"]
    assert rep.improvement == d["improvement"] > 5
    assert [r.direction for r in rep.runs] == [r["direction"] for r in d["runs"]]
    jk = rep.heldout.jackknife_std
    assert jk is not None and jk.wheelbase_m * 1e3 == pytest.approx(d["heldout"]["jackknife_std"]["wheelbase_mm"])
    assert rep.heldout.emax_syst_m * 1e3 == d["heldout"]["emax_syst_mm"]


def test_history_fields_of_single_several_and_pooled_reports(optiodom):
    from umbmark.realrobot.replay import history_fields, pooled_report

    paths = [optiodom / "free" / "030120210006", optiodom / "free" / "020120212354"]
    sets = [read_optiodom(p) for p in paths]
    pooled = pooled_report(sets, {"points_per_run": 20}, heldout=False)
    fields = history_fields(pooled, paths, file_hash=lambda p: f"hash of {Path(p).name}")
    assert [f["inputs"]["dataset"] for f in fields] == [s.name for s in sets]
    assert [f["input_sha256"] for f in fields] == [f"hash of {p.name}" for p in paths]
    assert [f["source"] for f in fields] == [str(p.resolve()) for p in paths]
    for f in fields:  # the pooled geometry is each data set's recommendation
        assert f["method"] == "lsq" and f["kind"] == "replay"
        assert f["parameters"]["wheelbase_mm"] == pooled.calibration.geometry.wheelbase_m * 1e3
        assert f["parameters"]["Ed"] == pooled.calibration.ed
    one = replay_report(sets[0], "lsq", {"points_per_run": 20}, heldout=False)
    [f] = history_fields(one, paths[:1])
    assert f["input_sha256"] is None and f["results"]["dataset"] == sets[0].name
    assert f["parameters_in_use"] == one.to_dict()["nominal"]
    assert history_fields(one.to_dict(), paths[:1]) == [f]
