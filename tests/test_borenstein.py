import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from umbmark.correct import bf_correction, compose
from umbmark.errors import CorrectionUndefined
from umbmark.metrics import umbmark_figures
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import Motion, simulate_umbmark

EXACT = Motion(sample_period_s=None)


def result_from_cgs(xcw, ycw, xccw, yccw):
    t = RunsTable.from_columns(["cw", "ccw"], [xcw, xccw], [ycw, yccw], [0, 0], [0, 0])
    return umbmark_figures(t)


def reference_formulas(xcw, ycw, xccw, yccw, L, b):
    """The reference sheet's equations, written out independently of the library."""
    beta = ((xcw - xccw) / (-4 * L) + (ycw + yccw) / (-4 * L)) / 2
    alpha = ((xcw + xccw) / (-4 * L) + (ycw - yccw) / (-4 * L)) / 2
    R = (L / 2) / math.sin(beta / 2)
    ed = (R + b / 2) / (R - b / 2)
    eb = 90 / (90 - math.degrees(alpha))
    return alpha, beta, R, ed, eb, 2 / (ed + 1), 2 / (1 / ed + 1), eb * b


cg = st.floats(-0.5, 0.5).filter(lambda v: abs(v) > 1e-6)


@settings(max_examples=200, deadline=None)
@given(cg, cg, cg, cg, st.floats(0.5, 10), st.floats(0.1, 1.0))
def test_matches_the_paper_formulas(xcw, ycw, xccw, yccw, L, b):
    assume((xcw - xccw) + (ycw + yccw) != 0)  # beta = 0 is tested separately (R infinite)
    alpha, beta, R, ed, eb, cl, cr, bnew = reference_formulas(xcw, ycw, xccw, yccw, L, b)
    c = bf_correction(result_from_cgs(xcw, ycw, xccw, yccw), L, b)
    for got, want in (
        (c.alpha, alpha),
        (c.beta, beta),
        (c.radius_m, R),
        (c.ed, ed),
        (c.eb, eb),
        (c.calibration.c_left, cl),
        (c.calibration.c_right, cr),
        (c.calibration.wheelbase_m, bnew),
    ):
        assert got == pytest.approx(want, rel=1e-9, abs=1e-15)


def test_beta_zero_gives_ed_one_exactly():
    c = bf_correction(result_from_cgs(-0.1, -0.1, -0.1, 0.1), 4.0, 0.34)
    assert c.beta == 0.0 and c.ed == 1.0 and math.isinf(c.radius_m)
    assert c.calibration.c_left == 1.0 and c.calibration.c_right == 1.0
    assert c.to_dict()["radius_mm"] is None


def test_undefined_geometry_is_an_error():
    with pytest.raises(CorrectionUndefined, match="undefined"):
        bf_correction(result_from_cgs(-3.0, -3.0, 3.0, -3.0), 0.5, 0.6)
    with pytest.raises(CorrectionUndefined, match="alpha"):
        bf_correction(result_from_cgs(-1e3, -1e3, -1e3, 1e3), 4.0, 0.34)


def test_sign_convention_bigger_right_wheel_gives_ed_above_one():
    runs = simulate_umbmark(ErrorParams(ed=1.003), n_runs=1, motion=EXACT)
    c = bf_correction(umbmark_figures(runs), 4.0, LABMATE.wheelbase_m)
    assert c.beta > 0  # legs curve to the left
    assert c.ed > 1 and c.calibration.c_right > 1 > c.calibration.c_left  # bigger right wheel: more travel per pulse


def test_sign_convention_smaller_wheelbase_turns_more():
    runs = simulate_umbmark(ErrorParams(eb=0.98), n_runs=1, motion=EXACT)
    c = bf_correction(umbmark_figures(runs), 4.0, LABMATE.wheelbase_m)
    assert c.alpha < 0  # alpha > 0 means turning less than commanded
    assert c.eb < 1


@settings(max_examples=40, deadline=None)
@given(st.floats(0.995, 1.005), st.floats(0.98, 1.02))
def test_noise_free_recovery_and_15_fold_improvement(ed, eb):
    e = ErrorParams(ed=ed, eb=eb)
    before = umbmark_figures(simulate_umbmark(e, n_runs=1, motion=EXACT))
    c = bf_correction(before, 4.0, LABMATE.wheelbase_m)
    assert abs(c.ed - ed) <= 3e-4
    assert abs(c.eb - eb) <= 3e-3
    after = umbmark_figures(simulate_umbmark(e, n_runs=1, motion=EXACT, calibration=c.calibration))
    assert after.emax_syst * 15 <= before.emax_syst or before.emax_syst < 1e-9


def test_paper_check_corrected_wheelbase():
    runs = simulate_umbmark(ErrorParams(ed=1.00084, eb=336.17 / 340), n_runs=5, noise="none")
    c = bf_correction(umbmark_figures(runs), 4.0, 0.340)
    assert c.calibration.wheelbase_m * 1e3 == pytest.approx(336.17, abs=0.5)
    assert c.ed == pytest.approx(1.00084, abs=3e-5)


def test_second_pass_composes_and_improves():
    e = ErrorParams(ed=1.005, eb=0.98)
    r1 = umbmark_figures(simulate_umbmark(e, n_runs=1, motion=EXACT))
    c1 = bf_correction(r1, 4.0, 0.34)
    r2 = umbmark_figures(simulate_umbmark(e, n_runs=1, motion=EXACT, calibration=c1.calibration))
    c2 = bf_correction(r2, 4.0, c1.calibration.wheelbase_m, prior=c1.calibration)
    assert c2.ed == pytest.approx(c1.ed * c2.ed_pass, rel=1e-12)
    assert c2.calibration.wheelbase_m == pytest.approx(c1.calibration.wheelbase_m * c2.eb, rel=1e-12)
    r3 = umbmark_figures(simulate_umbmark(e, n_runs=1, motion=EXACT, calibration=c2.calibration))
    assert r3.emax_syst < r2.emax_syst / 3
    assert abs(c2.ed - 1.005) < abs(c1.ed - 1.005)


@given(st.floats(0.9, 1.1), st.floats(0.9, 1.1), st.floats(0.95, 1.05))
def test_compose_keeps_mean_factor_and_multiplies_ratios(ed0, ed1, scale):
    prior = Calibration(scale * 2 / (ed0 + 1), scale * 2 * ed0 / (ed0 + 1), 0.3)
    total, cal = compose(ed1, 1.01, 0.3, prior)
    assert total == pytest.approx(ed0 * ed1, rel=1e-12)
    assert cal.c_right / cal.c_left == pytest.approx(total, rel=1e-12)
    assert (cal.c_left + cal.c_right) / 2 == pytest.approx(scale, rel=1e-12)
    assert cal.wheelbase_m == pytest.approx(0.303)


def test_warns_far_beyond_small_angles():
    """One run 1 km off gives alpha = -895 deg: a warning says the paper's formulas do not
    apply and names the other method by its parameter (the CLI shows its flag). Ordinary runs:
    no warning."""
    from umbmark.io.runs_csv import parse_runs_csv

    head = "direction,x_abs,y_abs,x_odo,y_odo\n"
    ok = parse_runs_csv(head + "cw,-60,-60,0,0\ncw,-50,-70,0,0\nccw,60,-60,0,0\nccw,70,-50,0,0\n")
    assert bf_correction(umbmark_figures(ok), 4.0, 0.34).warnings == ()
    bad = parse_runs_csv(head + "cw,-60,-60,0,0\ncw,1000000,-70,0,0\nccw,60,-60,0,0\nccw,70,-50,0,0\n")
    c = bf_correction(umbmark_figures(bad), 4.0, 0.34)
    assert math.degrees(c.alpha) < -90
    assert len(c.warnings) == 1 and 'try `method="exact"`' in c.warnings[0]
    from umbmark.cli.app import cli_message

    assert "try --method exact)" in cli_message(c.warnings[0])
