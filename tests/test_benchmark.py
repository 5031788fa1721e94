import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.metrics import direction_stats, umbmark_figures
from umbmark.model.runs import RunsTable


def table(cw, ccw):
    rows = [("cw", *p) for p in cw] + [("ccw", *p) for p in ccw]
    d, xa, ya = zip(*rows)
    n = len(rows)
    return RunsTable.from_columns(d, xa, ya, np.zeros(n), np.zeros(n))


def test_hand_computed_example():
    r = umbmark_figures(table([(0.1, 0.0), (0.3, 0.0)], [(0.0, -0.2), (0.0, -0.4), (0.0, -0.3)]))
    assert r.cw.x_cg == pytest.approx(0.2) and r.cw.y_cg == 0
    assert r.ccw.y_cg == pytest.approx(-0.3)
    assert r.emax_syst == pytest.approx(0.3)
    # radial sample standard deviation: sqrt(sum |eps - cg|^2 / (n - 1))
    assert r.cw.std == pytest.approx(math.sqrt((0.01 + 0.01) / 1))
    assert r.ccw.std == pytest.approx(math.sqrt((0.01 + 0.01 + 0) / 2))
    assert r.ccw.sem == pytest.approx(r.ccw.std / math.sqrt(3))
    # the worst direction is ccw; its 3 SEM is 0.173 m < 0.3 m: second pass
    assert r.sem_rule == pytest.approx(3 * r.ccw.sem)
    assert r.second_pass_recommended


def test_rule_says_stop_when_cg_is_inside_the_noise():
    r = umbmark_figures(
        table([(0.01, 0.03), (-0.02, -0.02), (0.015, -0.01)], [(0.0, 0.02), (0.01, -0.03), (-0.02, 0.0)])
    )
    assert r.emax_syst < r.sem_rule
    assert not r.second_pass_recommended


def test_return_error_is_absolute_minus_calculated():
    t = RunsTable.from_columns(["cw", "ccw"], [1.0, 0.0], [0.5, 0.0], [0.8, 0.1], [0.7, -0.1])
    np.testing.assert_allclose(t.eps_x, [0.2, -0.1])
    np.testing.assert_allclose(t.eps_y, [-0.2, 0.1])


def test_missing_direction_is_an_error():
    t = RunsTable.from_columns(["cw", "cw"], [1, 2], [1, 2], [0, 0], [0, 0])
    with pytest.raises(InputError, match="no ccw runs"):
        umbmark_figures(t)


def test_single_run_has_unknown_spread():
    r = umbmark_figures(table([(0.1, 0.1)], [(0.1, 0.0), (0.2, 0.0)]))
    assert r.cw.std is None and r.warnings
    assert r.to_dict()["cw"]["std_mm"] is None


pts = st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=2, max_size=12)


@settings(max_examples=80, deadline=None)
@given(pts, st.floats(-1, 1), st.floats(-1, 1))
def test_spread_is_translation_invariant_and_cg_moves(p, dx, dy):
    ex, ey = np.array(p).T
    a = direction_stats("cw", ex, ey)
    b = direction_stats("cw", ex + dx, ey + dy)
    assert b.std == pytest.approx(a.std, abs=1e-9)
    assert b.x_cg == pytest.approx(a.x_cg + dx, abs=1e-12)
    assert a.std == pytest.approx(math.hypot(a.std_x, a.std_y))


@settings(max_examples=60, deadline=None)
@given(pts, pts)
def test_emax_is_the_larger_r_cg(cw, ccw):
    r = umbmark_figures(table(cw, ccw))
    assert r.emax_syst == max(r.cw.r_cg, r.ccw.r_cg)
    assert r.worst.r_cg == r.emax_syst
