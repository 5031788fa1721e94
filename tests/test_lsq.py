"""General-path least squares: exact on noise-free simulated logs, the scale question, and
consistency with the square calibration on the real optiodom data."""

import glob
import math
from pathlib import Path

import numpy as np
import pytest
import simlogs

from umbmark.correct.lsq import fit_lsq
from umbmark.errors import InputError
from umbmark.io.optiodom import read_optiodom
from umbmark.model.dataset import to_start_frame
from umbmark.model.geometry import ErrorParams
from umbmark.model.simulate import Segment, straight_program
from umbmark.realrobot.replay import pooled_report, replay_report

DATA = Path(__file__).resolve().parents[1] / "data" / "optiodom"


def test_general_path_noise_free_is_exact():
    ds = simlogs.dataset([simlogs.general_program()])
    res = fit_lsq(ds)
    true = simlogs.true_geometry()
    assert res.mode == "sampled" and res.scale_fitted
    assert res.geometry.ed == pytest.approx(true.ed, abs=1e-9)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-9)
    assert res.geometry.diameter_left_m == pytest.approx(true.diameter_left_m, rel=1e-9)
    assert res.std.ed < 1e-9
    d = res.to_dict()
    assert d["fitted_parameters"] == "D_L, D_R, b" and d["Es"] == pytest.approx(0.99, rel=1e-9)


def _tracked_at(ds, off):
    """The data set with its ground truth that of a point at ``off`` (x, y) [m] in the robot frame."""
    runs = []
    for r in ds.runs:
        g = r.gt
        c, s = np.cos(g[:, 2]), np.sin(g[:, 2])
        m = np.column_stack([g[:, 0] + c * off[0] - s * off[1], g[:, 1] + s * off[0] + c * off[1], g[:, 2]])
        runs.append(type(r)(r.name, r.t, r.d_left, r.d_right, np.column_stack(to_start_frame(*m.T))))
    return ds.with_runs(runs)


def test_tracked_point_offset_is_recovered():
    ds = simlogs.dataset([simlogs.general_program()])
    off = np.array([0.03, -0.02])  # a marker 30 mm ahead of and 20 mm right of the axle midpoint
    ds = _tracked_at(ds, off)
    true = simlogs.true_geometry()
    plain = fit_lsq(ds)
    assert abs(plain.geometry.wheelbase_m / true.wheelbase_m - 1) > 1e-4  # the offset biases a plain fit
    res = fit_lsq(ds, fit_offset=True)
    assert np.allclose(res.marker_offset_m, off, atol=1e-9)
    assert res.geometry.ed == pytest.approx(true.ed, abs=1e-9)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-9)
    with pytest.raises(InputError, match="sampled"):
        fit_lsq(ds, mode="end", fit_offset=True)


def test_closed_paths_end_poses_do_not_fix_the_scale():
    errors = ErrorParams(ed=1.004, eb=1.02, es=1.0)  # D_avg right: the fixed-scale fit can be exact
    ds = simlogs.dataset(simlogs.squares(1), errors=errors, side_m=2.0)
    res = fit_lsq(ds, mode="end")
    true = simlogs.true_geometry(errors)
    assert not res.scale_fitted and "near their start" in res.scale_reason
    assert res.to_dict()["fitted_parameters"].startswith("E_d, b")
    assert res.geometry.diameter_avg_m == pytest.approx(ds.nominal.diameter_avg_m, rel=1e-12)
    assert res.geometry.ed == pytest.approx(true.ed, abs=1e-8)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-8)
    # with E_s != 1 the end poses of closed squares hardly see the scale: fixing D_avg at nominal
    # still gives E_d and the wheelbase relative to the wheel size closely
    ds = simlogs.dataset(simlogs.squares(1), side_m=2.0)
    res = fit_lsq(ds, mode="end")
    true = simlogs.true_geometry()
    assert not res.scale_fitted
    assert res.geometry.ed == pytest.approx(true.ed, abs=1e-4)
    assert res.geometry.wheelbase_m / res.geometry.diameter_avg_m == pytest.approx(
        true.wheelbase_m / true.diameter_avg_m, rel=1e-3
    )


def test_open_path_end_poses_fix_the_scale():
    progs = [
        straight_program(2.0),
        (Segment("straight", 1.0), Segment("turn", 1.0), Segment("straight", 1.0)),
        (Segment("straight", 1.5), Segment("turn", -2.0), Segment("straight", 0.5)),
    ]
    ds = simlogs.dataset(progs)
    res = fit_lsq(ds, mode="end")
    assert res.scale_fitted
    true = simlogs.true_geometry()
    assert res.geometry.diameter_left_m == pytest.approx(true.diameter_left_m, rel=1e-6)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-6)


def test_bad_options():
    ds = simlogs.dataset([simlogs.general_program()])
    with pytest.raises(InputError):
        fit_lsq(ds, mode="middle")
    with pytest.raises(InputError):
        fit_lsq(ds, heading_weight_m=-1)


def _square_bf_ratio():
    vals = []
    for d in glob.glob(str(DATA / "square/*")):
        ds = read_optiodom(d)
        vals.append(replay_report(ds, "bf", heldout=False).calibration.wheelbase_per_mean_diameter)
    return float(np.mean(vals))


def test_lsq_on_circular_and_free_is_consistent_with_squares_and_helps_held_out():
    ref = _square_bf_ratio()
    for d in sorted(glob.glob(str(DATA / "circular/*"))) + sorted(glob.glob(str(DATA / "free/*"))):
        ds = read_optiodom(d)
        rep = replay_report(ds, "lsq").to_dict()  # the JSON of umbmark replay --method lsq
        assert rep["scale_fitted"]
        assert abs(rep["wheelbase_per_mean_diameter"] / ref - 1) < 0.02, ds.name
        assert abs(math.log(rep["Ed"])) < 2e-3, ds.name
        assert rep["after"]["end_position_rms_mm"] < rep["before"]["end_position_rms_mm"], ds.name
        if len(ds.runs) >= 4:
            assert rep["heldout"]["end_position_rms_mm"] < rep["before"]["end_position_rms_mm"] / 1.5, ds.name


@pytest.mark.slow
def test_pooled_circular_and_free_held_out_by_data_set():
    dirs = sorted(glob.glob(str(DATA / "circular/*"))) + sorted(glob.glob(str(DATA / "free/*")))
    sets = [read_optiodom(d) for d in dirs]
    rep = pooled_report(sets, {"points_per_run": 50}).to_dict()  # the JSON of umbmark replay --pool
    ref = _square_bf_ratio()
    assert abs(rep["wheelbase_per_mean_diameter"] / ref - 1) < 0.01
    assert rep["heldout"]["end_position_rms_mm"] < rep["before"]["end_position_rms_mm"] / 3
    better = [p["heldout"]["end_position_rms_mm"] < p["before"]["end_position_rms_mm"] for p in rep["per_dataset"]]
    assert all(better)


@pytest.mark.parametrize("far_m", [1e3, 1e6, -1e6])
def test_diverging_fit_is_a_clear_error_not_a_silly_geometry(far_m):
    """An end pose the wheels cannot explain: a clear InputError, not diameters of 1e-11 m or
    1e107 m (nor an overflow)."""
    from dataclasses import replace

    ds = simlogs.dataset([simlogs.general_program()])
    bad = replace(ds.runs[0], gt=None, gt_end=np.array([far_m, 0.0, 0.3]))
    with pytest.raises(InputError, match="did not converge"):
        fit_lsq(ds.with_runs([bad]), mode="end", scale="fit")


@pytest.mark.parametrize("factor", [2.0, 0.5, 4.0])
def test_a_nominal_wheel_in_another_quantity_is_recovered_and_named(factor):
    """Nominal diameters twice the true ones (a diameter given as the radius), half or four times:
    the fit starts from the ground truth's own headings and distances, so it reaches the true
    geometry, and the replay says the nominal size is off."""
    from dataclasses import replace

    ds = simlogs.dataset([simlogs.general_program()] * 2)
    true = simlogs.true_geometry()
    n = ds.nominal
    bad = replace(ds, nominal=type(n)(factor * n.diameter_left_m, factor * n.diameter_right_m, n.wheelbase_m))
    res = fit_lsq(bad)
    assert res.geometry.diameter_left_m == pytest.approx(true.diameter_left_m, rel=1e-9)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-9)
    notes = replay_report(bad, "lsq", heldout=False).warnings
    assert any("nominal size is likely in another unit" in w for w in notes)
    assert any("a diameter given as the radius" in w for w in notes) == (factor == 2.0)
    assert replay_report(ds, "lsq", heldout=False).warnings == ()


def test_a_marker_ahead_of_the_axle_is_fitted_by_default_and_named():
    """Motion capture of a marker 120 mm ahead of the axle: by default its offset is fitted (the
    data determine it) with a warning saying so, E_b is the truth and the replayed odometry is
    judged at the axle; fitted without its offset (``fit_offset=False``) E_b comes out wrong, and
    the warning names the offset the data show and the E_b it gives; a marker on the axle gives
    no such warning."""
    errors = ErrorParams(ed=1.004, eb=1.03, es=0.99)
    ds = simlogs.dataset([simlogs.general_program()] * 3, errors=errors)
    off = np.array([0.12, 0.0])
    marker = _tracked_at(ds, off)
    auto = replay_report(marker, "lsq", heldout=False)
    assert auto.calibration.eb == pytest.approx(1.03, rel=1e-9)
    assert auto.after.path_position_rms_m < 1e-6
    (note,) = auto.warnings
    assert "120 mm ahead of" in note and "fitted with the geometry" in note and "`fit_offset=False`" in note
    rep = replay_report(marker, "lsq", {"fit_offset": False}, heldout=False)
    assert abs(rep.calibration.eb - 1.03) > 0.01
    (note,) = [w for w in rep.warnings if "off the axle" in w]
    assert "120 mm ahead of" in note and "E_b is 1.0300" in note and "(`fit_offset`)" in note
    assert replay_report(ds, "lsq", heldout=False).warnings == ()
    fixed = replay_report(marker, "lsq", {"fit_offset": True}, heldout=False)
    assert fixed.calibration.eb == pytest.approx(1.03, rel=1e-9) and fixed.warnings == ()
