"""The library's quantiles (umbmark._stats, from scipy.special) against scipy.stats."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from umbmark._stats import chi2_isf, f_isf, t_ppf

probs = st.floats(1e-9, 1 - 1e-9)
dofs = st.floats(0.5, 1e4)


@settings(max_examples=200, deadline=None)
@given(p=probs, dof=dofs)
def test_t_quantile(p, dof):
    assert t_ppf(p, dof) == pytest.approx(float(stats.t.ppf(p, dof)), rel=1e-9, abs=1e-12)


@settings(max_examples=200, deadline=None)
@given(q=probs, dof=dofs)
def test_chi2_upper_quantile(q, dof):
    assert chi2_isf(q, dof) == pytest.approx(float(stats.chi2.isf(q, dof)), rel=1e-9, abs=1e-12)


@settings(max_examples=200, deadline=None)
@given(q=st.floats(1e-6, 0.5), dfn=st.floats(1.0, 50.0), dfd=st.floats(3.0, 1e4))
def test_f_upper_quantile(q, dfn, dfd):
    assert f_isf(q, dfn, dfd) == pytest.approx(float(stats.f.isf(q, dfn, dfd)), rel=1e-7)


def test_the_textbook_values():
    assert t_ppf(0.975, 1) == pytest.approx(12.7062047, rel=1e-8)
    assert chi2_isf(0.05, 3) == pytest.approx(7.8147279, rel=1e-8)
    assert f_isf(0.05, 3, 10) == pytest.approx(3.7082648, rel=1e-7)
