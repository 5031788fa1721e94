"""The self-calibration's noise models (umbmark.correct.selfcal.loss): each loss's weights against
their closed form and the posterior of the noise's scale, its information factor against a
numerical Fisher information of simulated samples, its degrees of freedom fitted back from
simulated samples, its outlier threshold, and the fits asking the table."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats
from scipy.integrate import quad

from umbmark.correct.selfcal import kinematic_selfcal, selfcal
from umbmark.correct.selfcal.loss import (
    DIM,
    DOF_MAX,
    DOF_MIN,
    LOSS_TABLE,
    LOSSES,
    OUTLIER_DOF_MIN,
    ROBUST_START,
    Gaussian,
    StudentT,
    loss_named,
    noise_words,
)
from umbmark.errors import InputError
from umbmark.kinds import DiffDrive
from umbmark.model.intervals import Intervals, intervals_from_motion
from umbmark.model.kinematics import JointIntervals, JointSteps, joint_intervals_from_motion

STUDENT, GAUSSIAN = StudentT(), Gaussian()
CHECKED = settings(max_examples=60, deadline=None, derandomize=True)


def student_samples(rng: np.random.Generator, nu: float, n: int) -> np.ndarray:
    """``(n, 3)`` draws of a 3-variate Student t of unit scatter: Gaussian over the square root of
    its precision scale ``tau ~ chi2(nu) / nu``."""
    return rng.standard_normal((n, DIM)) / np.sqrt(rng.chisquare(nu, (n, 1)) / nu)


def posterior_mean_scale(nu: float, d2: float) -> float:
    """E[tau | d^2] by quadrature: ``tau ~ Gamma(nu / 2, rate nu / 2)``, the noise ``N(0, I / tau)``
    (the expectation step's weight of a Student t as a scale mixture of Gaussians)."""
    a, b = 0.5 * (nu + DIM), 0.5 * (nu + d2)  # the posterior's exponents: tau^(a - 1) exp(-b tau)
    mode = (a - 1) / b
    peak = (a - 1) * math.log(mode) - b * mode

    def h(t: float, power: int) -> float:
        return t**power * math.exp((a - 1) * math.log(t) - b * t - peak) if t > 0 else 0.0

    top = mode + 60 * math.sqrt(a) / b
    z = quad(h, 0, top, args=(0,), points=[mode], limit=200, epsabs=0, epsrel=1e-11)[0]
    return quad(h, 0, top, args=(1,), points=[mode], limit=200, epsabs=0, epsrel=1e-11)[0] / z


# ---- the table


def test_the_table_holds_each_loss_under_its_name():
    assert LOSSES == ("student", "gaussian")
    for name, loss in LOSS_TABLE.items():
        assert loss.name == name and loss_named(name) is loss
    assert isinstance(LOSS_TABLE["student"], StudentT) and isinstance(LOSS_TABLE["gaussian"], Gaussian)


@pytest.mark.parametrize("bad", ["cauchy", "Student", "", None, 3])
def test_an_unknown_loss_is_refused_with_the_known_ones(bad):
    with pytest.raises(InputError, match="`loss` must be one of student, gaussian"):
        loss_named(bad)


def test_the_fits_refuse_an_unknown_loss():
    rng = np.random.default_rng(3)
    fl, fr = rng.uniform(-3, 3, (2, 20))
    iv = intervals_from_motion(fl, fr, 0.1, 0.05, 0.05, 0.3, [0.1, 0.0, 0.2])
    with pytest.raises(InputError, match="got 'huber'"):
        selfcal(iv, 0.1, 0.3, loss="huber")


def test_the_start_is_refined_robustly_for_heavy_tails_or_outliers():
    assert STUDENT.start_loss(True) == STUDENT.start_loss(False) == ROBUST_START == "cauchy"
    assert GAUSSIAN.start_loss(True) == ROBUST_START and GAUSSIAN.start_loss(False) is None


def test_the_words_of_the_report():
    assert STUDENT.words(4.21) == "heavy-tailed (Student t, 4.210 degrees of freedom)"
    assert STUDENT.words(250.0) == "Gaussian" and GAUSSIAN.words(math.inf) == "Gaussian"
    assert noise_words(None) == noise_words(math.inf) == "Gaussian"
    assert noise_words(2.5) == "heavy-tailed (Student t, 2.500 degrees of freedom)"
    assert STUDENT.title == "Student t" and GAUSSIAN.title == "Gaussian"


# ---- weights


@CHECKED
@given(nu=st.floats(DOF_MIN, DOF_MAX), d2=st.floats(0.0, 1e4))
def test_student_weights_are_the_closed_form_and_the_posterior_mean_of_the_noise_scale(nu, d2):
    w = STUDENT.weights(nu, np.array([d2]))
    assert w.shape == (1,) and w[0] == (nu + 3) / (nu + d2)
    assert w[0] == pytest.approx(posterior_mean_scale(nu, d2), rel=1e-8)


@CHECKED
@given(nu=st.floats(DOF_MIN, DOF_MAX), d2=st.floats(1e-3, 1e4))
def test_student_weights_are_the_slope_of_its_log_likelihood(nu, d2):
    """An expectation-maximisation weight of a scale mixture is ``-2 d log f / d d^2``."""
    h = 1e-6 * d2
    slope = (STUDENT.log_likelihood(nu, np.array([d2 + h])) - STUDENT.log_likelihood(nu, np.array([d2 - h]))) / (2 * h)
    assert STUDENT.weights(nu, np.array([d2]))[0] == pytest.approx(-2.0 * slope, rel=1e-5, abs=1e-9)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(nu=st.floats(DOF_MIN, 50.0), seed=st.integers(0, 2**16))
def test_student_log_likelihood_is_scipys_density(nu, seed):
    x = student_samples(np.random.default_rng(seed), nu, 5)
    d2 = (x * x).sum(axis=1)
    ref = stats.multivariate_t(loc=np.zeros(DIM), shape=np.eye(DIM), df=nu).logpdf(x).sum()
    # up to the constant -3/2 log(pi) per sample (the scatter's part of the density)
    assert STUDENT.log_likelihood(nu, d2) - 1.5 * len(x) * math.log(math.pi) == pytest.approx(ref, rel=1e-9)


@CHECKED
@given(d2=st.lists(st.floats(0.0, 1e6), min_size=1, max_size=20))
def test_gaussian_weights_are_one(d2):
    w = GAUSSIAN.weights(math.inf, np.array(d2))
    assert w.shape == (len(d2),) and np.all(w == 1.0)


@pytest.mark.parametrize("loss", [STUDENT, GAUSSIAN], ids=lambda x: x.name)
def test_the_weights_of_a_losss_own_noise_average_one(loss):
    """E[tau] = 1: on its own noise a loss weighs the intervals one on average."""
    rng = np.random.default_rng(5)
    nu = 4.0 if loss.heavy_tailed else math.inf
    x = student_samples(rng, nu, 50_000) if loss.heavy_tailed else rng.standard_normal((50_000, DIM))
    assert np.mean(loss.weights(nu, (x * x).sum(axis=1))) == pytest.approx(1.0, abs=0.01)


# ---- information factor


def numerical_fisher(logpdf, x: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """The Fisher information of the location: the mean outer product of the scores, each by
    central differences of the log-density."""
    scores = np.empty_like(x)
    for i in range(DIM):
        e = np.zeros(DIM)
        e[i] = h
        scores[:, i] = (logpdf(x - e) - logpdf(x + e)) / (2 * h)  # d/d mu of log f(x - mu)
    return scores.T @ scores / len(x)


@pytest.mark.parametrize("nu", [1.0, 2.5, 5.0, 20.0])
def test_student_information_factor_is_the_fisher_information_of_simulated_samples(nu):
    dist = stats.multivariate_t(loc=np.zeros(DIM), shape=np.eye(DIM), df=nu)
    x = student_samples(np.random.default_rng(7), nu, 60_000)
    info = numerical_fisher(dist.logpdf, x)
    factor = STUDENT.information_factor(nu)
    assert factor == (nu + 3) / (nu + 5)
    np.testing.assert_allclose(info, factor * np.eye(DIM), atol=0.025)


def test_gaussian_information_factor_is_the_fisher_information_of_simulated_samples():
    dist = stats.multivariate_normal(np.zeros(DIM), np.eye(DIM))
    x = np.random.default_rng(7).standard_normal((60_000, DIM))
    np.testing.assert_allclose(
        numerical_fisher(dist.logpdf, x), GAUSSIAN.information_factor(math.inf) * np.eye(DIM), atol=0.025
    )
    assert GAUSSIAN.information_factor(math.inf) == 1.0


# ---- degrees of freedom


@pytest.mark.parametrize("nu", [1.5, 3.0, 6.0, 12.0])
def test_the_dof_fit_recovers_the_dof_of_simulated_samples(nu):
    for seed in range(3):
        x = student_samples(np.random.default_rng([11, seed]), nu, 5000)
        assert abs(math.log(STUDENT.fit_dof((x * x).sum(axis=1)) / nu)) < 0.25


def test_the_dof_fit_stays_within_its_bounds():
    rng = np.random.default_rng(13)
    x = student_samples(rng, 0.5, 3000)  # tails heavier than Cauchy's
    assert STUDENT.fit_dof((x * x).sum(axis=1)) == pytest.approx(DOF_MIN, rel=1e-3)
    z = rng.standard_normal((3000, DIM))  # Gaussian
    assert 100 < STUDENT.fit_dof((z * z).sum(axis=1)) <= DOF_MAX
    assert GAUSSIAN.fit_dof((z * z).sum(axis=1)) == math.inf and GAUSSIAN.start_dof == math.inf


def test_the_dof_settle_when_they_stop_moving():
    assert STUDENT.dof_settled(5.0, 5.0 * (1 + 1e-8), 1e-7) and not STUDENT.dof_settled(5.0, 5.1, 1e-4)
    assert GAUSSIAN.dof_settled(math.inf, math.inf, 1e-7)


# ---- outliers


@pytest.mark.parametrize("nu", [1.0, OUTLIER_DOF_MIN, 12.0])
def test_student_outlier_threshold_is_its_f_quantile(nu):
    tail = 0.01
    thr = STUDENT.outlier_threshold(tail, nu)
    assert thr == pytest.approx(3 * stats.f.isf(tail, 3, max(nu, OUTLIER_DOF_MIN)), rel=1e-9)
    x = student_samples(np.random.default_rng(17), max(nu, OUTLIER_DOF_MIN), 100_000)
    assert np.mean((x * x).sum(axis=1) > thr) == pytest.approx(tail, rel=0.1)


def test_gaussian_outlier_threshold_is_its_chi2_quantile():
    tail = 0.01
    thr = GAUSSIAN.outlier_threshold(tail, math.inf)
    assert thr == pytest.approx(stats.chi2.isf(tail, 3), rel=1e-9)
    z = np.random.default_rng(19).standard_normal((100_000, DIM))
    assert np.mean((z * z).sum(axis=1) > thr) == pytest.approx(tail, rel=0.1)


# ---- the fits ask the table


class _FixedDof(StudentT):
    """Student t noise of 4 degrees of freedom, not fitted."""

    name = "student4"

    def fit_dof(self, d2):
        return 4.0


def test_every_fit_asks_the_table(monkeypatch):
    """A loss put in the table is the one the differential drive's and the kinematic fits use."""
    monkeypatch.setitem(LOSS_TABLE, _FixedDof.name, _FixedDof())
    rng = np.random.default_rng(23)
    p = np.array([0.0752, 0.0749, 0.345, 0.12, -0.03, 0.05])
    k = 120
    ds, dth = 0.03 * rng.uniform(0.2, 1.0, k), 0.1 * rng.uniform(-1.0, 1.0, k)
    fl, fr = (ds - 0.5 * p[2] * dth) / p[0], (ds + 0.5 * p[2] * dth) / p[1]
    noise = rng.standard_normal((k, 3)) * [1e-3, 1e-3, 1e-3]
    iv = intervals_from_motion(fl, fr, 0.1, p[0], p[1], p[2], p[3:])
    res = selfcal(Intervals(iv.dt_s, fl, fr, iv.sensor + noise), 0.15, 0.34, loss="student4")
    assert res.noise_dof == 4.0
    np.testing.assert_allclose(res.params[:3], p[:3], rtol=0.01)
    steps = JointSteps(np.column_stack([fl, fr]), np.arange(k + 1), np.full(k, 0.1))
    joint = joint_intervals_from_motion(steps, DiffDrive(2 * p[0], 2 * p[1], p[2]), p[3:])
    kin = kinematic_selfcal(
        JointIntervals(joint.dt_s, steps, joint.sensor + noise), DiffDrive(0.15, 0.15, 0.34), loss="student4"
    )
    assert kin.noise_dof == 4.0
    np.testing.assert_allclose(kin.kinematics.vector(), [2 * p[0], 2 * p[1], p[2]], rtol=0.01)
