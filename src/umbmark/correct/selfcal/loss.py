"""The noise models of the self-calibration, as objects in one table.

The maximum-likelihood fit (:mod:`umbmark.correct.selfcal.estimate`, and the kinematic fit of
:mod:`umbmark.correct.selfcal.kinematic`) asks its loss, by name in :data:`LOSS_TABLE`, for
everything that depends on the noise model:

* the **weight** of each interval in an expectation-maximisation step, from its squared
  Mahalanobis distance ``d^2`` under the fitted scatter (:meth:`Loss.weights`);
* the **information factor**: the expected Fisher information of the parameters is that
  factor times the whitened Gauss-Newton matrix (:meth:`Loss.information_factor`);
* its **degrees of freedom** and how they are fitted (:meth:`Loss.fit_dof`, the start
  :attr:`Loss.start_dof`, when a fit has settled :meth:`Loss.dof_settled`) and whether its
  scatter is a full matrix fitted with the weights (:attr:`Loss.full_scatter`);
* the **outlier threshold** on ``d^2`` at a tail probability (:meth:`Loss.outlier_threshold`);
* the **robust start**: whether the start is refined with a Cauchy loss
  (:meth:`Loss.start_loss`);
* its name and the **words** a report uses for the fitted noise (:meth:`Loss.words`,
  :func:`noise_words`).

The losses:

``student``
    Student t noise of ``nu`` degrees of freedom: interval ``k`` weighs
    ``(nu + 3) / (nu + d_k^2)``, the information factor is ``(nu + 3) / (nu + 5)``, ``nu`` is
    fitted by maximum likelihood within ``[DOF_MIN, DOF_MAX]``, an outlier lies beyond the
    ``1 - tail`` quantile of the F distribution of ``d^2 / 3`` (3 and at least
    :data:`OUTLIER_DOF_MIN` degrees of freedom), and the start is always refined with a Cauchy
    loss. Heavy tails (wheel data stamped a little off the scans, scenes the matcher half fails
    on) weigh little; on Gaussian noise ``nu`` grows large and the fit is least squares.
``gaussian``
    Gaussian noise: every interval weighs 1, the information factor is 1, no degrees of freedom
    (infinite), the scatter is each component's standard deviation (a full matrix where the
    intervals carry covariances of their own or the wheel data's jitter is modelled), an outlier
    lies beyond the ``1 - tail`` quantile of chi-square with 3 degrees of freedom, and the start
    is refined with a Cauchy loss only when outliers are rejected.

The noise is 3-variate: a sensor displacement ``(dx, dy, dyaw)``. The table follows the idea of
``scipy.optimize.least_squares``, whose robust losses are one small function each in one table.

Imports numpy and, when a fit runs, scipy.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError

__all__ = [
    "Loss",
    "StudentT",
    "Gaussian",
    "LOSS_TABLE",
    "LOSSES",
    "loss_named",
    "noise_words",
    "DIM",
    "DOF_MIN",
    "DOF_MAX",
    "DOF_START",
    "OUTLIER_DOF_MIN",
    "NEARLY_GAUSSIAN_DOF",
    "ROBUST_START",
]

FloatArray = NDArray[np.float64]

DIM = 3
"""The components of the noise: a sensor displacement ``(dx, dy, dyaw)``."""

DOF_MIN, DOF_MAX = 1.0, 1000.0
"""The bounds of the Student t degrees of freedom (1: Cauchy; 1000: Gaussian to all purposes)."""

DOF_START = 5.0
"""The Student t degrees of freedom a fit starts from."""

OUTLIER_DOF_MIN = 5.0
"""The outliers of Student t noise are judged with at least these degrees of freedom: a few gross
failures (a scan match in the wrong place) would otherwise make the fitted tails so heavy that
nothing lies beyond them."""

NEARLY_GAUSSIAN_DOF = 100.0
"""Beyond these degrees of freedom a report calls Student t noise Gaussian."""

ROBUST_START = "cauchy"
"""The loss of ``scipy.optimize.least_squares`` that refines a start robustly (failed scan
matches do not pull it)."""


class Loss:
    """A noise model of the self-calibration's maximum-likelihood fit (the module docstring).

    Attributes
    ----------
    name : str
        Its key in :data:`LOSS_TABLE` (the ``loss`` argument of the fits).
    title : str
        Its name in words (``"Student t"``, ``"Gaussian"``).
    heavy_tailed : bool
        Large residuals weigh less (the start is then always refined robustly).
    full_scatter : bool
        Its scatter is a full 3 x 3 matrix fitted with the weights, by expectation maximisation
        (else each component's standard deviation, unless the intervals carry covariances of
        their own or the wheel data's jitter is modelled).
    start_dof : float
        The degrees of freedom a fit starts from (``inf``: none).
    """

    name: ClassVar[str]
    title: ClassVar[str]
    heavy_tailed: ClassVar[bool]
    full_scatter: ClassVar[bool]
    start_dof: ClassVar[float]

    def weights(self, nu: float, d2: FloatArray) -> FloatArray:
        """Each interval's weight in an expectation-maximisation step.

        Parameters
        ----------
        nu : float
            The degrees of freedom.
        d2 : numpy.ndarray
            ``(K,)`` squared Mahalanobis distances of the residuals under the scatter.

        Returns
        -------
        numpy.ndarray
            ``(K,)``: the expectation of the interval's precision scale given its residual.
        """
        raise NotImplementedError

    def information_factor(self, nu: float) -> float:
        """The expected Fisher information over the whitened Gauss-Newton matrix ``J^T J``."""
        raise NotImplementedError

    def fit_dof(self, d2: FloatArray) -> float:
        """The degrees of freedom of most likelihood for squared distances ``d2`` (``inf``: none)."""
        raise NotImplementedError

    def dof_settled(self, new: float, old: float, tol: float) -> bool:
        """Whether the degrees of freedom moved by less than ``tol`` of themselves (always, without)."""
        raise NotImplementedError

    def outlier_threshold(self, tail: float, nu: float) -> float:
        """The squared Mahalanobis distance beyond which an interval is an outlier.

        Parameters
        ----------
        tail : float
            The tail probability of the fitted noise beyond the threshold.
        nu : float
            The fitted degrees of freedom.

        Returns
        -------
        float
            The ``1 - tail`` quantile of ``d^2``.
        """
        raise NotImplementedError

    def start_loss(self, reject_outliers: bool) -> str | None:
        """The ``scipy.optimize.least_squares`` loss that refines the start (:data:`ROBUST_START`),
        or None: a heavy-tailed loss or outliers to reject refine it robustly."""
        return ROBUST_START if self.heavy_tailed or reject_outliers else None

    def words(self, nu: float) -> str:
        """The fitted noise in a report's words, e.g. ``"heavy-tailed (Student t, 4.210 degrees of freedom)"``."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class StudentT(Loss):
    """Student t noise, its degrees of freedom fitted (the module docstring)."""

    name = "student"
    title = "Student t"
    heavy_tailed = True
    full_scatter = True
    start_dof = DOF_START

    def weights(self, nu: float, d2: FloatArray) -> FloatArray:
        return np.asarray((nu + DIM) / (nu + d2), dtype=float)

    def information_factor(self, nu: float) -> float:
        return (nu + DIM) / (nu + (DIM + 2))

    def log_likelihood(self, nu: float, d2: FloatArray) -> float:
        """The log-likelihood of squared distances ``d2`` under a 3-variate Student t of ``nu``
        degrees of freedom (up to the scatter's determinant)."""
        from scipy.special import gammaln

        return float(
            np.sum(
                gammaln(0.5 * (nu + DIM))
                - gammaln(0.5 * nu)
                - 0.5 * DIM * np.log(nu)
                - 0.5 * (nu + DIM) * np.log1p(d2 / nu)
            )
        )

    def fit_dof(self, d2: FloatArray) -> float:
        """The degrees of freedom of most likelihood within ``[DOF_MIN, DOF_MAX]`` (on a log scale)."""
        from scipy.optimize import minimize_scalar

        sol = minimize_scalar(
            lambda u: -self.log_likelihood(math.exp(u), d2),
            bounds=(math.log(DOF_MIN), math.log(DOF_MAX)),
            method="bounded",
        )
        return float(math.exp(sol.x))

    def dof_settled(self, new: float, old: float, tol: float) -> bool:
        return abs(math.log(new / old)) < tol

    def outlier_threshold(self, tail: float, nu: float) -> float:
        """``3 F^-1(1 - tail; 3, max(nu, OUTLIER_DOF_MIN))``: ``d^2 / 3`` of a Student t is F distributed."""
        from umbmark._stats import f_isf

        return DIM * f_isf(tail, DIM, max(nu, OUTLIER_DOF_MIN))

    def words(self, nu: float) -> str:
        if nu > NEARLY_GAUSSIAN_DOF:
            return "Gaussian"
        return f"heavy-tailed (Student t, {nu:.3f} degrees of freedom)"


class Gaussian(Loss):
    """Gaussian noise (the module docstring)."""

    name = "gaussian"
    title = "Gaussian"
    heavy_tailed = False
    full_scatter = False
    start_dof = math.inf

    def weights(self, nu: float, d2: FloatArray) -> FloatArray:
        return np.ones(len(d2))

    def information_factor(self, nu: float) -> float:
        return 1.0

    def fit_dof(self, d2: FloatArray) -> float:
        return math.inf

    def dof_settled(self, new: float, old: float, tol: float) -> bool:
        return True

    def outlier_threshold(self, tail: float, nu: float) -> float:
        """``chi2^-1(1 - tail; 3)``."""
        from umbmark._stats import chi2_isf

        return chi2_isf(tail, DIM)

    def words(self, nu: float) -> str:
        return "Gaussian"


LOSS_TABLE: dict[str, Loss] = {loss.name: loss for loss in (StudentT(), Gaussian())}
"""Every loss by its name."""

LOSSES = tuple(LOSS_TABLE)
"""The names of the losses (the ``loss`` argument of the fits)."""


def loss_named(name: str) -> Loss:
    """The loss of :data:`LOSS_TABLE` called ``name``.

    Raises
    ------
    InputError
        An unknown name (the message lists the known ones).
    """
    try:
        return LOSS_TABLE[name]
    except (KeyError, TypeError):
        raise InputError(f"`loss` must be one of {', '.join(LOSSES)}, got {name!r}") from None


def noise_words(dof: float | None) -> str:
    """A fitted noise in a report's words from its degrees of freedom (``None`` or ``inf``:
    Gaussian, as a result's JSON holds them)."""
    if dof is None or not math.isfinite(dof):
        return LOSS_TABLE["gaussian"].words(math.inf)
    return LOSS_TABLE["student"].words(dof)
