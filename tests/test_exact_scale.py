"""Method ``exact`` as it runs (analytic Jacobians, the compiled model, the pseudo-runs of the
global search) against the reference computation (central differences, the search on every
run: ``exact_correction(..., _reference=True)``), on few runs and on many."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from umbmark.correct.exact import exact_correction
from umbmark.correct.exact import kernel as exact_kernel
from umbmark.correct.exact.model import _Problem, _square_errors_grad, square_errors
from umbmark.model.geometry import LABMATE, ErrorParams
from umbmark.model.simulate import Motion, simulate_umbmark
from umbmark.studies.accuracy import AccuracyConfig

# the calibration and its intervals: as the reference to 1e-9 (relative)
EXACT_KEYS = ("Ed_ci95", "Ed_pass_ci95", "Eb_ci95", "wheelbase_corrected_mm_ci95")
# derived from the heading weight, which the reference's positions-only fit (central
# differences) itself determines only to about 1e-8: standard errors and predictions
DERIVED_KEYS = ("Ed_se", "Eb_se", "emax_syst_after_pred_mm", "emax_syst_after_pred_measured_mm", "heading_weight_m")


def _cell_runs(ed: float, eb: float, n: int, seed: int = 3):
    """The accuracy benchmark's robot of a cell (true wheelbase fixed, nominal = true / E_b)."""
    geo = replace(LABMATE, wheelbase_m=LABMATE.wheelbase_m / eb)
    runs = simulate_umbmark(
        ErrorParams(ed, eb), geo, 4.0, n, noise="paper", motion=Motion(sample_period_s=0.05), seed=seed
    )
    return runs, geo.wheelbase_m


def _rel(a, b) -> float:
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))


def _assert_same(fast, ref, derived_rtol: float = 1e-7) -> None:
    # (whether the global search ran is not compared: where the first fit misses a centre of
    # gravity by 3 SEM to rounding, one implementation searches and the other does not, and the
    # search then finds the same answer; everything below must agree)
    assert _rel(fast.ed, ref.ed) < 1e-9 and _rel(fast.eb, ref.eb) < 1e-9
    assert _rel(fast.ed_pass, ref.ed_pass) < 1e-9
    assert _rel(fast.calibration.c_left, ref.calibration.c_left) < 1e-9
    assert _rel(fast.calibration.c_right, ref.calibration.c_right) < 1e-9
    assert _rel(fast.calibration.wheelbase_m, ref.calibration.wheelbase_m) < 1e-9
    fd, rd = fast.to_dict(), ref.to_dict()
    for k in EXACT_KEYS:
        assert (fd[k] is None) == (rd[k] is None), k
        if rd[k] is not None:
            assert _rel(fd[k], rd[k]) < 1e-9, k
    for k in DERIVED_KEYS:
        if rd[k] is not None:
            assert _rel(fd[k], rd[k]) < derived_rtol, k
    assert fast.warnings == ref.warnings
    alternatives = [np.array(c.details.alternatives, dtype=float).reshape(-1, 2) for c in (fast, ref)]
    np.testing.assert_allclose(*alternatives, rtol=1e-9)


def test_accuracy_cells_as_the_benchmark_runs_them_agree_with_the_reference():
    """5 runs per direction (the accuracy benchmark's tests): the first, a middle and the last
    cell."""
    cells = list(AccuracyConfig().cells())
    for ed, eb in (cells[0], cells[len(cells) // 2], cells[-1]):
        runs, b = _cell_runs(ed, eb, 5)
        fast = exact_correction(runs, 4.0, b)
        ref = exact_correction(runs, 4.0, b, _reference=True)
        _assert_same(fast, ref)


def test_accuracy_cells_with_many_runs_agree_with_the_reference():
    """33 runs per direction (the search's pseudo-runs then hold far fewer than the runs) on
    every cell of the accuracy benchmark, the far ones searched globally."""
    searched = 0
    for ed, eb in AccuracyConfig().cells():
        runs, b = _cell_runs(ed, eb, 33)
        fast = exact_correction(runs, 4.0, b)
        ref = exact_correction(runs, 4.0, b, _reference=True)
        _assert_same(fast, ref)
        assert fast.details.global_search == ref.details.global_search  # these cells are not on the edge
        searched += bool(ref.details.global_search)
    assert searched >= 10  # the cells of E_b 0.5 and 2.5 and more: the search's path is covered


@settings(max_examples=4, deadline=None)
@example(ed=1.1, eb=1.9, side=1.5, b=0.419921875, n=33, heading=True, seed=133)  # a first fit at 3 SEM to rounding
@given(
    ed=st.floats(0.9, 1.1),
    eb=st.floats(0.4, 3.0),
    side=st.floats(1.0, 6.0),
    b=st.floats(0.15, 0.6),
    n=st.integers(33, 45),
    heading=st.booleans(),
    seed=st.integers(0, 2**16),
)
@pytest.mark.slow
def test_random_robots_with_many_runs_agree_with_the_reference(ed, eb, side, b, n, heading, seed):
    geo = replace(LABMATE, wheelbase_m=b)
    runs = simulate_umbmark(
        ErrorParams(ed, eb), geo, side, n, noise="paper", motion=Motion(sample_period_s=0.05), seed=seed
    )
    if not heading:
        runs = replace(runs, theta_abs=None, theta_odo=None)
    try:
        ref = exact_correction(runs, side, b, _reference=True)
    except Exception as e:  # the reference refuses: the fast path must refuse the same way
        with pytest.raises(type(e)):
            exact_correction(runs, side, b)
        return
    _assert_same(exact_correction(runs, side, b), ref)


def test_robust_loss_with_many_runs_agrees_with_the_reference():
    runs, b = _cell_runs(1.02, 1.5, 40, seed=8)
    fast = exact_correction(runs, 4.0, b, loss="soft_l1")
    ref = exact_correction(runs, 4.0, b, loss="soft_l1", _reference=True)
    _assert_same(fast, ref)


def _problem(n: int = 30, heading: bool = True, seed: int = 1) -> _Problem:
    runs, b = _cell_runs(1.01, 1.3, n, seed=seed)
    return _Problem(runs, 4.0, b, 1.0, heading, None)


def test_analytic_jacobian_matches_central_differences():
    rng = np.random.default_rng(4)
    ed, eb = rng.uniform(0.9, 1.1, (6, 1)), rng.uniform(0.3, 3.0, (6, 1))
    sign = np.where(rng.random(9) < 0.5, 1.0, -1.0)[None]
    adjs = [rng.normal(0, 0.02, (1, 9)) for _ in range(4)]
    value, grad = _square_errors_grad(ed, eb, 4.0, 0.34, sign, 1.003, adjs)
    assert np.allclose(value, np.array(square_errors(ed, eb, 4.0, 0.34, sign, 1.003, adjs)), rtol=0, atol=1e-13)
    for j, step in enumerate(((1e-6, 0.0), (0.0, 1e-6))):
        hi = np.array(square_errors(ed + step[0], eb + step[1], 4.0, 0.34, sign, 1.003, adjs))
        lo = np.array(square_errors(ed - step[0], eb - step[1], 4.0, 0.34, sign, 1.003, adjs))
        fd = (hi - lo) / 2e-6
        assert np.allclose(grad[..., j], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


@pytest.mark.skipif(not exact_kernel.available(), reason="the compiled model needs numba")
@pytest.mark.parametrize("heading", [True, False])
def test_compiled_model_matches_numpy(heading):
    prob = _problem(heading=heading)
    ed, eb = np.array([1.0, 1.01, 0.97, 1.1]), np.array([1.0, 1.5, 0.6, 0.3])
    r0, J0 = prob.residuals_matrix(ed, eb), prob.model_jacobian(ed, eb)
    r1, J1 = exact_kernel.residuals_jacobian(prob, ed, eb, 2)
    assert np.allclose(r1, r0, rtol=0, atol=1e-12)
    assert np.allclose(J1, J0, rtol=0, atol=1e-12 * np.abs(J0).max())
    cost = exact_kernel.residuals_jacobian(prob, ed, eb, 0)[0]
    assert np.allclose(cost, np.sum(r0**2, axis=(1, 2)), rtol=1e-12)
    sums = exact_kernel.residuals_jacobian(prob, ed, eb, 3)[0]
    jtj = np.einsum("pnci,pncj->pij", J0, J0)
    jtr = np.einsum("pnci,pnc->pi", J0, r0)
    assert np.allclose(sums[:, 1], jtj[:, 0, 0], rtol=1e-12)
    assert np.allclose(sums[:, 2], jtj[:, 0, 1], rtol=1e-12)
    assert np.allclose(sums[:, 3], jtj[:, 1, 1], rtol=1e-12)
    assert np.allclose(sums[:, 4:], jtr, rtol=1e-10, atol=1e-12 * np.abs(jtr).max())


@pytest.mark.parametrize("heading", [True, False])
def test_pseudo_runs_have_the_cost_of_the_runs_up_to_a_constant(heading):
    """The pseudo-runs' cost differs from the runs' by a constant: to a tiny fraction of how
    much the cost varies near the minimum (the same minimum, far fewer runs), and roughly far
    from it (where headings off by about pi wrap differently)."""
    runs, b = _cell_runs(1.01, 1.3, 100, seed=1)
    prob = _Problem(runs, 4.0, b, 1.0, heading, None)
    small = prob.compressed()
    assert small is not None and small.n <= 16
    rng = np.random.default_rng(0)
    ed = np.r_[rng.uniform(0.9, 1.1, 2000), 1.01 + rng.normal(0, 1e-3, 200)]
    eb = np.r_[rng.uniform(0.3, 4.0, 2000), 1.3 + rng.normal(0, 1e-2, 200)]
    full = np.sum(prob.residuals_matrix(ed, eb) ** 2, axis=(1, 2))
    approx = np.sum(small.weighted(small.residuals_matrix(ed, eb)) ** 2, axis=(1, 2))
    diff = full - approx
    near = full < 20 * full.min()
    assert near.sum() > 20
    assert np.ptp(diff[near]) < 1e-6 * np.ptp(full[near])
    assert np.ptp(diff) < (1e-2 if heading else 1e-7) * np.ptp(full)
    assert np.argmin(full) == np.argmin(approx)


def test_pseudo_runs_of_runs_whose_odometry_turns_do_not_vary():
    """Noise-free runs: every run of a direction has the same turns; one pseudo-run each."""
    runs = simulate_umbmark(ErrorParams(1.01, 1.2), LABMATE, 4.0, 40)
    prob = _Problem(runs, 4.0, LABMATE.wheelbase_m, 1.0, True, None)
    small = prob.compressed()
    assert small is not None and small.n == 2
    assert small.sw is not None and np.allclose(small.sw**2, [40, 40])
    p = np.array([1.003]), np.array([1.1])
    one_each = prob.residuals_matrix(*p)[:, [int(np.argmax(prob.is_cw)), int(np.argmin(prob.is_cw))]]
    assert np.allclose(small.weighted(small.residuals_matrix(*p)) ** 2, 40 * one_each**2)


@pytest.mark.parametrize("cell", [(1.05, 2.5), (0.995, 1.05)])
def test_many_runs_without_numba_agree_with_the_reference(monkeypatch, cell):
    """Without numba the same path runs on the numpy model and its analytic Jacobian (and the
    refit on the runs by scipy)."""
    runs, b = _cell_runs(*cell, 33, seed=5)
    ref = exact_correction(runs, 4.0, b, _reference=True)
    monkeypatch.setattr(exact_kernel, "available", lambda: False)
    _assert_same(exact_correction(runs, 4.0, b), ref)
