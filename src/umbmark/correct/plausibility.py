"""Plausibility checks: input that is well formed but probably means something else.

A runs file in metres, headings in radians, cw and ccw labels swapped, x and y swapped, the
absolute and odometry columns swapped, a wheelbase typed in metres where millimetres are
expected: each reads without an error and gives a plausible-looking, wrong calibration. The
checks here compare the inputs against each other and against the geometry of the square:

* :func:`check_geometry`: the side and the wheelbase against each other and against what a
  floor-driven UMBmark square can be (an error where no answer can mean anything, a warning
  where it is unusual);
* :func:`runs_warnings`: the runs against the square model. Each direction's centre of gravity
  lies, to first order, on a line fixed by the direction (cw: ``x = y``; ccw: ``x = -y``): the
  paper's x- and y-based estimates of alpha and beta agree exactly when it does. The model
  of the square with per-turn and per-leg errors (exact geometry, not linearised) is fitted to
  the two centres of gravity; the part of each centre that it cannot explain (the
  disagreement of the x- and y-based estimates, less the linearisation's share) is compared
  with its standard error from the runs' own scatter. With headings the heading errors must
  match the fitted square too (4 (alpha + beta) cw, 4 (beta - alpha) ccw), which ties the
  positions' unit to the side's and the headings' unit to degrees. When the runs fail, the
  likely mislabellings are tried (labels, columns, units) and the one that explains the runs
  is named. The scatter of the runs per metre driven, and the scatter of the odometry's end
  points against the measured ones, catch units and swapped columns the model cannot see.

Thresholds: a false-alarm probability of :data:`FALSE_ALARM` per check (Student's t on the runs'
pooled scatter), with :data:`MODEL_REL` of the centre of gravity added for what the model leaves
out; fits beyond :data:`MAX_ANGLE_RAD` in alpha or beta are not judged (robots turning far off
90 deg per corner: the fit from the linear estimates may end in another valley). The rates
measured on files simulated with the paper's noise (``benchmarks/plausibility.py``) are in
``docs/troubleshooting.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache, partial
from typing import Any

import numpy as np

from umbmark.errors import InputError
from umbmark.model.runs import RunsTable

__all__ = [
    "check_geometry",
    "check_units",
    "geometry_warnings",
    "runs_warnings",
    "copied_columns",
    "fits_lines_better",
    "consistency",
    "square_error",
    "FALSE_ALARM",
    "MAX_ANGLE_RAD",
    "t_limit",
    "MODEL_REL",
]

# the smallest wheelbase of a robot that drives a UMBmark square, and the largest square side
MIN_WHEELBASE_M = 0.01
MAX_SIDE_M = 1000.0
WARN_SIDE_M = 50.0
WARN_WHEELBASE_M = (0.05, 3.0)
MIN_SIDE_PER_WHEELBASE = 2.0

# the model check: a centre of gravity (or mean heading error) is inconsistent with the square
# when it misses the fitted model by more standard errors of the runs' scatter than Student's t
# allows at a false-alarm probability of FALSE_ALARM per check (see t_limit),
# where MODEL_REL of its size (and MODEL_FLOOR_M, MODEL_FLOOR_RAD) is added to the standard
# error for what the model leaves out (controller over- and undershoot, slip)
FALSE_ALARM = 1e-4
MAX_ANGLE_RAD = math.radians(50.0)  # the largest alpha or beta the check judges
MODEL_REL = 0.05
MODEL_FLOOR_M = 0.5e-3
MODEL_FLOOR_RAD = math.radians(0.05)

# scatter of the return positions per metre driven (radial standard deviation / 4 L): a robot
# and a tape measure give 0.25 mm to 10 mm per metre; outside, the units are probably wrong
MIN_SCATTER_PER_M = 2.5e-4
MAX_SCATTER_PER_M = 1.2e-2
NO_SCATTER_M = 1e-6  # runs that differ by less than a micrometre are copies of one run
SCATTER_MIN_RUNS = 3  # per direction: the spread of two runs varies too much to judge units by
# the odometry of a robot driving on its odometry ends nearly at the same point each run
ODO_SCATTER_RATIO = 3.0


def check_geometry(side_m: float, wheelbase_m: float) -> list[str]:
    """Refuse a side or wheelbase no UMBmark square can have; warn about unusual ones.

    Parameters
    ----------
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used [m].

    Returns
    -------
    list of str
        Warnings: a side shorter than twice the wheelbase, a side beyond 50 m, a wheelbase
        outside 50 to 3000 mm.

    Raises
    ------
    InputError
        A wheelbase below 10 mm (metres typed as millimetres), a side beyond 1 km, or a side
        not longer than the wheelbase.
    """
    check_units(side_m, wheelbase_m)
    b_mm, l_mm = wheelbase_m * 1e3, side_m * 1e3
    if side_m <= wheelbase_m:
        raise InputError(
            f"the side of the square ({l_mm:.6g} mm, `side_mm`) is not longer than the wheelbase "
            f"({b_mm:.6g} mm, `wheelbase_mm`): one of them is in the wrong unit (both in millimetres)"
        )
    return geometry_warnings(side_m, wheelbase_m)


def check_units(side_m: float, wheelbase_m: float) -> None:
    """Refuse a wheelbase below 10 mm and a side beyond 1 km (every correction method does).

    Parameters
    ----------
    side_m, wheelbase_m : float
        Side of the square and the wheelbase [m].

    Raises
    ------
    InputError
        A wheelbase below 10 mm (metres typed as millimetres) or a side beyond 1 km.
    """
    b_mm, l_mm = wheelbase_m * 1e3, side_m * 1e3
    if wheelbase_m < MIN_WHEELBASE_M:
        raise InputError(
            f"the wheelbase is {b_mm:.6g} mm (`wheelbase_mm`): no robot that drives a UMBmark square is that "
            f"narrow; metres given as millimetres? ({b_mm * 1e3:.6g} mm for {b_mm:.6g} m)"
        )
    if side_m > MAX_SIDE_M:
        raise InputError(
            f"the side of the square is {l_mm:.6g} mm (`side_mm`), more than 1 km: check the unit "
            "(millimetres; 4000 for a 4 m square)"
        )


def geometry_warnings(side_m: float, wheelbase_m: float) -> list[str]:
    """Warnings about a side and wheelbase that are possible but unusual (see :func:`check_geometry`).

    Parameters
    ----------
    side_m, wheelbase_m : float
        Side of the square and the wheelbase [m].

    Returns
    -------
    list of str
    """
    out = []
    b_mm, l_mm = wheelbase_m * 1e3, side_m * 1e3
    if side_m < MIN_SIDE_PER_WHEELBASE * wheelbase_m:
        out.append(
            f"the side of the square ({l_mm:.6g} mm, `side_mm`) is only {side_m / wheelbase_m:.2f} times the "
            f"wheelbase ({b_mm:.6g} mm, `wheelbase_mm`): a side in centimetres, or the wheelbase in the wrong "
            "unit? (both in millimetres; the paper's square has a side of 4000 mm)"
        )
    if wheelbase_m < WARN_WHEELBASE_M[0] or wheelbase_m > WARN_WHEELBASE_M[1]:
        out.append(
            f"the wheelbase is {b_mm:.6g} mm (`wheelbase_mm`), outside the 50 to 3000 mm of most robots: check the "
            "unit (millimetres; a wheelbase in centimetres gives an E_d 10 times too close to 1)"
        )
    if side_m > WARN_SIDE_M:
        out.append(f"the side of the square is {l_mm:.6g} mm (`side_mm`), more than 50 m: check the unit (millimetres)")
    return out


def square_error(alpha: float, beta: float, side_m: float, direction: str) -> tuple[float, float, float]:
    """The return error of the square with per-turn and per-leg errors (exact geometry).

    Four legs of ``side_m`` that each curve by ``beta`` (to the left when positive) and four
    on-the-spot turns that each fall short of 90 deg by ``alpha``; the odometry believes it
    drove the nominal square and ends at the start.

    Parameters
    ----------
    alpha, beta : float
        The paper's errors [rad].
    side_m : float
        Side of the square [m].
    direction : str
        ``cw`` or ``ccw``.

    Returns
    -------
    tuple of float
        ``(eps_x, eps_y, eps_theta)`` in the start frame [m, m, rad].
    """
    sign = -1.0 if direction == "cw" else 1.0
    x = y = th = 0.0
    if beta == 0.0:
        dx, dy = side_m, 0.0
    else:
        chord = 2.0 * side_m / beta * math.sin(beta / 2.0)
        dx, dy = chord * math.cos(beta / 2.0), chord * math.sin(beta / 2.0)
    for _ in range(4):
        c, s = math.cos(th), math.sin(th)
        x += dx * c - dy * s
        y += dx * s + dy * c
        th += beta + sign * (math.pi / 2.0 - alpha)
    return x, y, th - sign * 2.0 * math.pi


class _Dir:
    """One direction's figures: centre of gravity, mean odometry end point, covariance, headings."""

    def __init__(self, rows: RunsTable):
        self.n = len(rows)
        ex, ey = rows.eps_x, rows.eps_y
        self.c = np.array([ex.mean(), ey.mean()])
        self.odo = np.array([rows.x_odo.mean(), rows.y_odo.mean()])
        self.cov = np.cov(np.vstack([ex, ey])) if self.n >= 2 else None
        self.eth = rows.eps_theta


def _predict(alpha: float, beta: float, side_m: float, d: str, odo: np.ndarray) -> tuple[np.ndarray, float]:
    x, y, th = square_error(alpha, beta, side_m, d)
    c, s = math.cos(th), math.sin(th)
    # the odometry ends at ``odo``, not at the start: the true end is the error pose applied to it
    shift = np.array([(c - 1.0) * odo[0] - s * odo[1], s * odo[0] + (c - 1.0) * odo[1]])
    return np.array([x, y]) + shift, th


def _resid(dirs: dict[str, _Dir], side_m: float, q: np.ndarray) -> np.ndarray:
    return np.concatenate([_predict(q[0], q[1], side_m, d, dirs[d].odo)[0] - dirs[d].c for d in ("cw", "ccw")])


def _linear_start(dirs: dict[str, _Dir], side_m: float) -> np.ndarray:
    """The paper's linear estimates of alpha and beta (the averages of the x- and y-based ones)."""
    cw, ccw = dirs["cw"].c, dirs["ccw"].c
    k = -4.0 * side_m
    p = np.array(
        [
            0.5 * ((cw[0] + ccw[0]) + (cw[1] - ccw[1])) / k,
            0.5 * ((cw[0] - ccw[0]) + (cw[1] + ccw[1])) / k,
        ]
    )
    return np.clip(p, -1.0, 1.0)


def _fit(dirs: dict[str, _Dir], side_m: float, start: np.ndarray) -> tuple[float, float]:
    """alpha, beta of the square model that best explains both centres of gravity (Gauss-Newton
    from ``start``)."""
    p = start.copy()

    def resid(q: np.ndarray) -> np.ndarray:
        return _resid(dirs, side_m, q)

    for _ in range(8):
        r = resid(p)
        h = 1e-7
        jac = np.column_stack([(resid(p + h * e) - r) / h for e in np.eye(2)])
        step, *_ = np.linalg.lstsq(jac, -r, rcond=None)
        if not np.all(np.isfinite(step)):
            break
        p = np.clip(p + step, -1.6, 1.6)
        if np.max(np.abs(step)) < 1e-10:
            break
    return float(p[0]), float(p[1])


# the directions in which each centre of gravity may move along the model (cw: x = y; ccw: x = -y)
_NORMAL = {"cw": np.array([1.0, -1.0]) / math.sqrt(2.0), "ccw": np.array([1.0, 1.0]) / math.sqrt(2.0)}


def consistency(runs: RunsTable, side_m: float) -> dict[str, float] | None:
    """How far the runs are from the square model, in standard errors of their own scatter.

    Parameters
    ----------
    runs : RunsTable
        Runs in both directions.
    side_m : float
        Side of the square [m].

    Returns
    -------
    dict or None
        ``t_cw``, ``t_ccw``: the part of each centre of gravity across the model's line (what
        makes the x- and y-based estimates differ), less the model's, over its standard error
        (with :data:`MODEL_REL` of the centre's size and :data:`MODEL_FLOOR_M` added);
        ``h_cw``, ``h_ccw`` (with headings): the same for the mean heading errors against the
        fitted square; ``alpha``, ``beta``: the fit [rad]. None with fewer than 2 runs in a
        direction (the scatter is unknown), or a fit beyond 50 deg in alpha or beta (errors the
        check is not calibrated for).
    """
    dirs = {d: _Dir(runs.direction_rows(d)) for d in ("cw", "ccw")}
    if any(v.n < 2 for v in dirs.values()):
        return None
    out = _stats(dirs, side_m, *_fit(dirs, side_m, _linear_start(dirs, side_m)))
    if max(abs(out["alpha"]), abs(out["beta"])) > MAX_ANGLE_RAD:
        return None  # beyond the errors the check was calibrated on
    return out


def _stats(dirs: dict[str, _Dir], side_m: float, alpha: float, beta: float) -> dict[str, float]:
    """The t statistics of the runs against the square of ``alpha``, ``beta`` (see :func:`consistency`)."""
    dof = sum(v.n - 1 for v in dirs.values())
    out: dict[str, float] = {"alpha": alpha, "beta": beta, "dof": float(dof)}
    # one scatter for both directions (the same robot and floor): pooled over the runs
    pos_var = sum((v.n - 1) * float(_NORMAL[d] @ v.cov @ _NORMAL[d]) for d, v in dirs.items() if v.cov is not None)
    pos_var /= dof
    heads: dict[str, tuple[np.ndarray, float]] = {}
    for d, v in dirs.items():
        pred, th = _predict(alpha, beta, side_m, d, v.odo)
        nrm = _NORMAL[d]
        var = pos_var / v.n + (MODEL_REL * float(np.hypot(*v.c))) ** 2 + MODEL_FLOOR_M**2
        out[f"t_{d}"] = float(nrm @ (v.c - pred)) / math.sqrt(var)
        if v.eth is not None:  # each run's heading error off the model's, wrapped (a turn of 180 deg or more)
            heads[d] = (np.angle(np.exp(1j * (v.eth - th))), th)
    if len(heads) == 2:
        head_var = sum((len(r) - 1) * float(np.var(r, ddof=1)) for r, _ in heads.values()) / dof
        for d, (r, th) in heads.items():
            hvar = head_var / len(r) + (MODEL_REL * abs(th)) ** 2 + MODEL_FLOOR_RAD**2
            out[f"h_{d}"] = float(np.mean(r)) / math.sqrt(hvar)
    return out


@lru_cache(maxsize=256)
def t_limit(dof: int) -> float:
    """The limit on a check's t statistic: its two-sided false-alarm probability is
    :data:`FALSE_ALARM` per check for normal scatter (Student's t with ``dof`` degrees of freedom).

    Parameters
    ----------
    dof : int
        Degrees of freedom of the pooled scatter (runs less one per direction).

    Returns
    -------
    float
    """
    from umbmark._stats import t_ppf

    return t_ppf(1.0 - FALSE_ALARM / 2.0, max(dof, 1))


def _score(c: dict[str, float] | None) -> float:
    """The largest t statistic over its limit (inconsistent above 1)."""
    if c is None:
        return 0.0
    return max(abs(v) for k, v in c.items() if k[:2] in ("t_", "h_")) / t_limit(int(c["dof"]))


def _table(runs: RunsTable, **cols: Any) -> RunsTable:
    base: dict[str, Any] = dict(
        direction=runs.direction,
        x_abs=runs.x_abs,
        y_abs=runs.y_abs,
        x_odo=runs.x_odo,
        y_odo=runs.y_odo,
        theta_abs=runs.theta_abs,
        theta_odo=runs.theta_odo,
        run=runs.run,
    )
    base.update(cols)
    return RunsTable.from_columns(
        list(base["direction"]),
        base["x_abs"],
        base["y_abs"],
        base["x_odo"],
        base["y_odo"],
        base["theta_abs"],
        base["theta_odo"],
        base["run"],
    )


def _scaled(runs: RunsTable, k: float) -> RunsTable:
    return _table(runs, x_abs=runs.x_abs * k, y_abs=runs.y_abs * k, x_odo=runs.x_odo * k, y_odo=runs.y_odo * k)


def _heading_scaled(runs: RunsTable, k: float) -> RunsTable:
    assert runs.theta_abs is not None and runs.theta_odo is not None
    return _table(runs, theta_abs=runs.theta_abs * k, theta_odo=runs.theta_odo * k)


def _negated_headings(runs: RunsTable) -> RunsTable:
    assert runs.theta_abs is not None
    return _table(runs, theta_abs=-runs.theta_abs)


def _candidates(runs: RunsTable) -> list[tuple[str, Callable[[], RunsTable]]]:
    """The likely mislabellings: the message naming each, and the runs as they would then be."""
    swap = {"cw": "ccw", "ccw": "cw"}
    out: list[tuple[str, Callable[[], RunsTable]]] = [
        (
            "the cw and ccw labels look swapped (check the direction column: cw turns right after the first leg)",
            lambda: _table(runs, direction=[swap[d] for d in runs.direction]),
        ),
        (
            "x and y look swapped (check the columns: x along the first leg, y to the left)",
            lambda: _table(runs, x_abs=runs.y_abs, y_abs=runs.x_abs, x_odo=runs.y_odo, y_odo=runs.x_odo),
        ),
        (
            "y looks mirrored (check the frame: y must point to the left of the first leg)",
            lambda: _table(runs, y_abs=-runs.y_abs, y_odo=-runs.y_odo),
        ),
    ]
    if runs.theta_abs is not None and runs.theta_odo is not None:
        out.append(
            (
                "the measured headings (theta_abs) have the wrong sign (counter-clockwise is positive; in a "
                "distances file for umbmark measure: front and rear distances exchanged?)",
                partial(_negated_headings, runs),
            )
        )
        out.append(
            (
                "the headings look like radians (theta_abs and theta_odo are in degrees)",
                lambda: _heading_scaled(runs, 180.0 / math.pi),
            )
        )
        for k, ratio, cause in (
            (1000.0, "1000 times too small", "a runs file in metres?"),
            (100.0, "100 times too small", "a runs file in decimetres?"),
            (25.4, "25 times too small", "a runs file in inches?"),
            (10.0, "10 times too small", "a runs file in centimetres?"),
            (0.1, "10 times too large", "the side in centimetres?"),
            (1 / 25.4, "25 times too large", "the side in inches?"),
            (0.01, "100 times too large", "the side in decimetres?"),
            (0.001, "1000 times too large", "the side in metres?"),
        ):
            out.append(
                (
                    f"the positions are about {ratio} for the side of the square ({cause} positions and "
                    "`side_mm` are in millimetres)",
                    partial(_scaled, runs, k),
                )
            )
    return out


def _scatter_warnings(runs: RunsTable, side_m: float) -> list[str]:
    out: list[str] = []
    stds, odo_stds = [], []
    for d in ("cw", "ccw"):
        rows = runs.direction_rows(d)
        if len(rows) < SCATTER_MIN_RUNS:
            return out
        stds.append(math.hypot(float(np.std(rows.eps_x, ddof=1)), float(np.std(rows.eps_y, ddof=1))))
        ax, ay = float(np.std(rows.x_abs, ddof=1)), float(np.std(rows.y_abs, ddof=1))
        ox, oy = float(np.std(rows.x_odo, ddof=1)), float(np.std(rows.y_odo, ddof=1))
        odo_stds.append((math.hypot(ax, ay), math.hypot(ox, oy)))
    per_m = float(np.mean(stds)) / (4.0 * side_m)
    if max(stds) < NO_SCATTER_M:
        return out  # identical runs (a noise-free simulation): no scatter to judge the units by
    if per_m < MIN_SCATTER_PER_M:
        out.append(
            f"the runs scatter by only {np.mean(stds) * 1e3:.3g} mm after {4 * side_m:.3g} m of driving "
            f"({per_m * 1e3:.3g} mm per metre; robots scatter by 0.25 to 10): the positions look like metres, "
            "centimetres or inches, or the side is in the wrong unit (positions and `side_mm` are in millimetres)"
        )
    elif per_m > MAX_SCATTER_PER_M:
        out.append(
            f"the runs scatter by {np.mean(stds) * 1e3:.3g} mm after {4 * side_m:.3g} m of driving "
            f"({per_m * 1e3:.3g} mm per metre; robots scatter by 0.25 to 10): the side looks too short for "
            "the positions (a side in centimetres? positions and `side_mm` are in millimetres), or an outlier run"
        )
    if all(o > ODO_SCATTER_RATIO * max(a, 1e-6) for a, o in odo_stds):
        out.append(
            "the odometry end points scatter more than the measured ones in both directions (the odometry of "
            "a robot driving on its odometry ends at nearly the same point every run): the absolute (x_abs, "
            "y_abs) and odometry (x_odo, y_odo) columns look swapped"
        )
    return out


def copied_columns(runs: RunsTable) -> str | None:
    """A warning when a measured column equals the odometry's in every run, while another does
    not: ``x_abs`` a copy of ``x_odo`` (a measured position never meets the odometry's to the
    micrometre in every run; a perfect robot's runs meet it in every column).

    Parameters
    ----------
    runs : RunsTable
        The runs (SI units).

    Returns
    -------
    str or None
    """
    pairs = [("x", runs.x_abs, runs.x_odo, NO_SCATTER_M), ("y", runs.y_abs, runs.y_odo, NO_SCATTER_M)]
    if runs.theta_abs is not None and runs.theta_odo is not None:
        pairs.append(("theta", runs.theta_abs, runs.theta_odo, MODEL_FLOOR_RAD * 1e-3))
    same = [name for name, a, o, tol in pairs if np.all(np.abs(np.asarray(a) - np.asarray(o)) <= tol)]
    if len(runs) < 2 or not same or len(same) == len(pairs):
        return None
    cols = " and ".join(f"{n}_abs equals {n}_odo" for n in same)
    return (
        f"{cols} in every run, to the micrometre: a column copied? (x_abs, y_abs, theta_abs are the measured "
        "return pose, x_odo, y_odo, theta_odo the odometry's; a measured pose never meets the odometry's exactly)"
    )


def _line_chi2(runs: RunsTable) -> float | None:
    """How far each direction's centre of gravity is from its line (cw: x = y, ccw: x = -y, to first
    order, whatever the side): the sum of the squared t statistics (None: fewer than
    :data:`SCATTER_MIN_RUNS` runs in a direction)."""
    chi2 = 0.0
    for d, sign in (("cw", 1.0), ("ccw", -1.0)):
        rows = runs.direction_rows(d)
        if len(rows) < SCATTER_MIN_RUNS:
            return None
        u = rows.eps_x - sign * rows.eps_y
        centre = math.hypot(float(np.mean(rows.eps_x)), float(np.mean(rows.eps_y)))
        se2 = float(np.var(u, ddof=1)) / len(u) + (MODEL_REL * centre) ** 2 + MODEL_FLOOR_M**2
        chi2 += float(np.mean(u)) ** 2 / se2
    return chi2


# the centres of gravity of runs as some mistake would have them fit the square this much better
# (the drop of the sum of squared t statistics: chi-square of 2 at 5e-5) than as given: named
LINES_BETTER_CHI2 = 20.0


def fits_lines_better(given: RunsTable, candidate: RunsTable) -> bool:
    """Whether ``candidate`` (the runs as a mislabelling undone would have them) fits the
    square's first-order lines decisively better than ``given`` (by :data:`LINES_BETTER_CHI2`)
    and within the false-alarm limit (:data:`FALSE_ALARM`). Needs no side: for the runs of
    ``umbmark measure``, before any side is known.

    Parameters
    ----------
    given, candidate : RunsTable
        The runs as given, and as they would be.

    Returns
    -------
    bool
    """
    a, b = _line_chi2(given), _line_chi2(candidate)
    if a is None or b is None:
        return False
    dof = len(given) - 2
    return a - b > LINES_BETTER_CHI2 and b <= t_limit(dof) ** 2


def _judged(runs: RunsTable) -> bool:
    """Whether both directions have the 2 runs the model check needs."""
    return all(len(runs.direction_rows(d)) >= 2 for d in ("cw", "ccw"))


def _explanations(runs: RunsTable, side_m: float, candidates: list[tuple[str, Callable[[], RunsTable]]]) -> str:
    """The (at most two) mislabellings whose correction makes the runs fit the square, best first."""
    fits = []
    for msg, make in candidates:
        try:
            cand = consistency(make(), side_m)
        except InputError:
            continue
        if cand is not None and _score(cand) <= 1.0:
            fits.append((_score(cand), msg))
    return "; or ".join(m for _, m in sorted(fits)[:2])


def runs_warnings(runs: RunsTable, side_m: float) -> list[str]:
    """Warnings about runs that are well formed but probably mislabelled (see the module docstring).

    Parameters
    ----------
    runs : RunsTable
        Runs in both directions (SI units).
    side_m : float
        Side of the square [m].

    Returns
    -------
    list of str
        Each names the likely cause and what to check; empty for runs that fit the square.
    """
    copied = copied_columns(runs)
    out = ([copied] if copied else []) + _scatter_warnings(runs, side_m)
    c = consistency(runs, side_m)
    if c is None and runs.theta_abs is not None and runs.theta_odo is not None and _judged(runs):
        # beyond the errors the model judges as given; rescaled, the positions may fit the headings
        scales = [(m, f) for m, f in _candidates(runs) if "times too" in m]
        named = _explanations(runs, side_m, scales)
        if named and out:
            out[-1] += f" (by the headings: {named})"
        elif named:
            out.append(f"the runs fit no square with plausible errors as given: {named}")
    if c is None or _score(c) <= 1.0:
        return out
    worst = max((k for k in c if k[:2] in ("t_", "h_")), key=lambda k: abs(c[k]))
    what = "heading errors" if worst.startswith("h_") else "centre of gravity"
    head = (
        f"the {worst[2:]} {what} misses the square model by {abs(c[worst]):.0f} standard errors of the runs' "
        "scatter (the x- and y-based estimates disagree far beyond it)"
    )
    if what == "heading errors":
        head = (
            f"the {worst[2:]} heading errors do not match the positions ({abs(c[worst]):.0f} standard errors "
            "off the square that explains the positions)"
        )
    named = _explanations(runs, side_m, _candidates(runs))
    if named:
        out.append(f"{head}: {named}; the calibration from these runs is wrong")
    else:
        out.append(
            f"{head}: check the units (mm, deg), the direction labels, and the x, y, abs and odo columns; "
            "the calibration from these runs is unreliable"
        )
    return out
