"""The few distribution quantiles the library needs, from :mod:`scipy.special`.

``scipy.stats`` takes about a second to import (it builds every distribution's documentation);
the special functions behind the same quantiles take a fraction of that, which every command
that computes an interval would otherwise pay at start-up. Each function equals its
``scipy.stats`` counterpart to rounding (``tests/test_stats.py``).
"""

from __future__ import annotations

__all__ = ["t_ppf", "chi2_isf", "f_isf"]


def t_ppf(p: float, dof: float) -> float:
    """Quantile of Student's t: ``scipy.stats.t.ppf(p, dof)``.

    Parameters
    ----------
    p : float
        Probability in (0, 1).
    dof : float
        Degrees of freedom (> 0, need not be whole).

    Returns
    -------
    float
    """
    from scipy.special import stdtrit

    return float(stdtrit(dof, p))


def chi2_isf(q: float, dof: float) -> float:
    """Upper quantile of the chi-square distribution: ``scipy.stats.chi2.isf(q, dof)``.

    Parameters
    ----------
    q : float
        Upper tail probability in (0, 1).
    dof : float
        Degrees of freedom (> 0).

    Returns
    -------
    float
    """
    from scipy.special import chdtri

    return float(chdtri(dof, q))


def f_isf(q: float, dfn: float, dfd: float) -> float:
    """Upper quantile of the F distribution: ``scipy.stats.f.isf(q, dfn, dfd)``.

    Parameters
    ----------
    q : float
        Upper tail probability in (0, 1).
    dfn, dfd : float
        Degrees of freedom of the numerator and the denominator (> 0).

    Returns
    -------
    float
    """
    from scipy.special import betaincinv

    # W = dfd / (dfd + dfn F) is Beta(dfd / 2, dfn / 2): P(F > f) = P(W < w), exact for small q
    w = float(betaincinv(0.5 * dfd, 0.5 * dfn, q))
    return dfd * (1.0 - w) / (dfn * w)
