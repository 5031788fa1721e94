"""Accuracy benchmark of the correction methods: Monte Carlo over a grid of true errors.

For every cell of the grid (true ``E_d``, ``E_b``) and every noise level, ``robots`` seeded
robots each run the bi-directional test (5 runs per direction), are corrected, and run it
again (fresh runs):

* ``bf1``: the paper's correction, one pass;
* ``bf2``: ``bf`` again on the runs of the once-corrected robot (composed), then fresh runs;
* ``exact``: method ``exact``, one pass;
* ``exact2``: ``exact`` again on the runs of the once-corrected robot, then fresh runs;
* ``perfect``: the robot corrected with its true parameters (the **perfect floor**);
* ``bound``: the robot corrected with parameters as good as *any* unbiased one-pass estimator
  could give: errors drawn from the Cramer-Rao bound of the cell (:func:`information_bound`).
  It is optimistic (Gaussian noise with the simulator's covariance known exactly, the model
  free of bias), so a cell whose ``bound`` exceeds 1.15 x the estimation floor is one where no
  one-pass estimator can reach it.

Reported per cell: the median E_max,syst after correction of each, the median absolute
parameter errors, and the coverage of ``exact``'s 95 % intervals. The **estimation floor** is
``bf1`` on the smallest errors of the grid (the four cells ``|E_d - 1| = |E_b - 1| = 0.05 %``),
where its linearisation is exact: what 5 noisy runs per direction allow.

Design choices (documented in the README):

* Every cell uses the same physical robot (true wheelbase 340 mm, LabMate wheels); ``E_b`` is
  set through the nominal wheelbase the odometry starts from, ``b_nominal = 340 mm / E_b``.
  So every cell has the same non-systematic noise and the floors are comparable across cells.
* Common random numbers: robot ``i`` uses the same seeds in every cell, and the corrected
  robots of ``bf1``, ``exact`` and ``perfect`` drive with the same seeds.
* Noise ``none`` uses the exact one-arc-per-segment model (one robot per cell: it is
  deterministic); noise ``paper`` uses a sampling period of 10 ms (the paper's robot sampled
  below 10 ms). Coarser sampling is faster but not neutral: the controller stops on the first
  sample past each target, so every leg overshoots by half a sample of travel on average (3 mm
  at 30 ms and 0.2 m/s). The odometry knows it, the runs file does not (the overshoot of all
  four legs leaves the odometry's end pose unchanged), so no fit can model it: at 30 ms it
  biases ``exact``'s E_d by about 0.07 % of its departure from 1 and costs up to 20 % in
  E_max,syst after correction where the legs curve strongly (measured; README).
* A correction that fails (no answer) leaves the robot uncorrected; failures are counted.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from umbmark.correct import correct_runs
from umbmark.correct.exact import _Problem
from umbmark.correct.result import compose
from umbmark.errors import InputError, UmbmarkError
from umbmark.jsonutil import dumps
from umbmark.metrics import umbmark_figures
from umbmark.model.geometry import LABMATE, ErrorParams, Geometry
from umbmark.model.simulate import Motion, simulate_umbmark
from umbmark.viz.text import fmt

__all__ = [
    "AccuracyConfig",
    "QUICK",
    "run_accuracy",
    "robot_trial",
    "coverage_trial",
    "format_markdown",
    "write_results",
]

ROWS = ("bf1", "bf2", "exact", "exact2", "perfect", "bound")
FITTED = ("bf1", "bf2", "exact", "exact2")


@dataclass(frozen=True)
class AccuracyConfig:
    """The grid, the robots and the simulation of the accuracy benchmark.

    Attributes
    ----------
    ed_departures : tuple of float
        ``|E_d - 1|`` of the grid; each is used with both signs.
    eb_values : tuple of float
        ``E_b`` of the grid.
    noises : tuple of str
        Noise presets; ``"none"`` runs one robot per cell (it is deterministic).
    robots : int
        Seeded robots per cell with noise.
    runs_per_direction : int
        Runs per direction of each test.
    side_m : float
        Side of the square.
    true_wheelbase_m : float
        The wheelbase held fixed (see ``fixed_wheelbase``).
    sample_period_s : float
        Sampling period of the noisy simulations.
    seed : int
        Seed of the benchmark (robot ``i`` uses ``[seed, i]`` in every cell).
    workers : int or None
        Local processes for the sweep over cells; ``None``: all cores.
    fixed_wheelbase : str
        ``"true"`` or ``"nominal"``: which wheelbase ``true_wheelbase_m`` is (see below).
    """

    ed_departures: tuple = (0.0005, 0.005, 0.02, 0.05)  # |E_d - 1|, both signs
    eb_values: tuple = (0.5, 0.95, 0.9995, 1.0005, 1.05, 1.5, 2.5)
    noises: tuple = ("none", "paper")
    robots: int = 100
    runs_per_direction: int = 5
    side_m: float = 4.0
    true_wheelbase_m: float = LABMATE.wheelbase_m  # the wheelbase held fixed (see fixed_wheelbase)
    sample_period_s: float = 0.01
    seed: int = 2026
    workers: int | None = None  # local processes for the sweep over cells; None: all cores
    # "true": one physical robot (true wheelbase fixed, nominal = true / E_b), so every cell has
    # the same noise; "nominal": the nominal wheelbase is fixed and the true (effective) one is
    # E_b times it, e.g. a skid-steer robot whose effective wheelbase exceeds its track (its
    # heading noise then shrinks as E_b grows)
    fixed_wheelbase: str = "true"

    def cells(self) -> list[tuple[float, float]]:
        """The grid's ``(E_d, E_b)`` cells, E_d ascending, then E_b in the order given."""
        eds = sorted({1.0 - d for d in self.ed_departures} | {1.0 + d for d in self.ed_departures})
        return [(ed, eb) for ed in eds for eb in self.eb_values]

    def validate(self) -> None:
        """Check the settings.

        Raises
        ------
        InputError
            If a setting is out of its range (robots, runs, workers, the grid, ``fixed_wheelbase``).
        """
        if self.robots < 1 or self.runs_per_direction < 2:
            raise InputError("the accuracy benchmark needs >= 1 robot per cell and >= 2 runs per direction")
        if self.workers is not None and (not isinstance(self.workers, int) or self.workers < 1):
            raise InputError(f"workers must be >= 1, got {self.workers!r}")
        for d in self.ed_departures:
            if not 0 < d < 0.2:
                raise InputError(f"E_d departure {d} out of range (0, 0.2)")
        for eb in self.eb_values:
            if not 0.2 <= eb <= 5:
                raise InputError(f"E_b {eb} out of range [0.2, 5]")
        if self.fixed_wheelbase not in ("true", "nominal"):
            raise InputError(f"fixed_wheelbase must be 'true' or 'nominal', got {self.fixed_wheelbase!r}")


# --quick: small grid, few robots, coarse sampling (tests and README examples)
QUICK = AccuracyConfig(
    ed_departures=(0.0005, 0.02), eb_values=(0.9995, 0.95, 2.5), robots=4, sample_period_s=0.05, workers=1
)


def _geometry(cfg: AccuracyConfig, eb: float) -> Geometry:
    """The nominal geometry of the cell's robot (the true one is ``ErrorParams(ed, eb)`` of it)."""
    b = cfg.true_wheelbase_m / eb if cfg.fixed_wheelbase == "true" else cfg.true_wheelbase_m
    return Geometry(LABMATE.wheel_diameter_m, b, LABMATE.pulses_per_motor_rev, LABMATE.gear_ratio)


def _correct(method, runs, side, wheelbase, prior=None):
    try:
        return correct_runs(method, runs, side, wheelbase, prior)
    except UmbmarkError:
        return None


# seed key of the bound's covariance runs and of its parameter draws (robots use [seed, i])
_BOUND_KEY = 0xC4B


def information_bound(cfg: AccuracyConfig, ed: float, eb: float, noise: str, runs_for_covariance: int = 200):
    """Cramer-Rao bound of one pass on the cell's robot: the covariance of (E_d, E_b) that an
    efficient unbiased estimator reaches from ``cfg.runs_per_direction`` runs per direction.

    The noise of one run's return error (x, y, heading) is measured per direction from
    ``runs_for_covariance`` simulated runs per direction (own seeds); the model's Jacobian is
    the exact closed-loop model's at the true parameters. Fisher information
    ``I = sum_d n J_d^T S_d^-1 J_d``.

    Parameters
    ----------
    cfg : AccuracyConfig
        The benchmark's settings.
    ed, eb : float
        The cell's true errors.
    noise : str
        The noise preset.
    runs_for_covariance : int
        Runs per direction simulated to measure the noise.

    Returns
    -------
    cov : numpy.ndarray or None
        ``I^-1`` (2 x 2, for E_d and E_b); ``None`` without noise.
    sds : dict
        ``{"ed_sd", "eb_sd"}``: the bound's standard deviations (0 without noise).
    """
    if noise == "none":
        return None, {"ed_sd": 0.0, "eb_sd": 0.0}
    geom = _geometry(cfg, eb)
    runs = simulate_umbmark(
        ErrorParams(ed, eb),
        geom,
        cfg.side_m,
        runs_for_covariance,
        None,
        noise,
        Motion(sample_period_s=cfg.sample_period_s),
        seed=np.random.SeedSequence([cfg.seed, _BOUND_KEY, _BOUND_KEY, 1]),
    )
    prob = _Problem(runs, cfg.side_m, geom.wheelbase_m, 1.0, runs.eps_theta is not None, 1.0)
    p = np.array([ed, eb])
    r = prob.residuals_matrix([ed], [eb])[0]
    J = prob.jacobian_runs(p)
    info = np.zeros((2, 2))
    for mask in (prob.is_cw, ~prob.is_cw):
        S = np.cov(r[mask], rowvar=False).reshape(prob.ncomp, prob.ncomp)
        Jd = J[mask].mean(axis=0)
        info += cfg.runs_per_direction * Jd.T @ np.linalg.solve(S, Jd)
    cov = np.linalg.inv(info)
    return cov, {"ed_sd": float(math.sqrt(cov[0, 0])), "eb_sd": float(math.sqrt(cov[1, 1]))}


def robot_trial(cfg: AccuracyConfig, ed: float, eb: float, noise: str, robot: int, bound_cov=None) -> dict:
    """One seeded robot of one cell: before, bf1, bf2, exact, exact2, perfect and bound.

    Parameters
    ----------
    cfg : AccuracyConfig
        The benchmark's settings.
    ed, eb : float
        The cell's true errors.
    noise : str
        The noise preset.
    robot : int
        The robot's index (its seeds are ``[cfg.seed, robot]``).
    bound_cov : numpy.ndarray, optional
        The cell's :func:`information_bound` covariance: the robot is also corrected with
        parameter errors drawn from it.

    Returns
    -------
    dict
        E_max,syst after each correction (``emax_<method>_mm``), the parameter errors
        (``ed_err_<m>``, ``eb_err_<m>``), failures (``fail_<m>``), interval coverage of
        ``exact`` (``ed_covered``, ``eb_covered``, ``None`` without noise) and its prediction.
    """
    geom = _geometry(cfg, eb)
    errors = ErrorParams(ed, eb)
    motion = Motion(sample_period_s=None if noise == "none" else cfg.sample_period_s)
    s_before, s_after, s_after2 = np.random.SeedSequence([cfg.seed, robot]).spawn(3)
    n, side, b0 = cfg.runs_per_direction, cfg.side_m, geom.wheelbase_m

    def run(cal, seed):
        return simulate_umbmark(errors, geom, side, n, cal, noise, motion, seed=seed)

    def two_passes(method, name1, name2):
        """Correct, fresh runs (s_after), correct those runs again (composed), fresh runs (s_after2)."""
        c1 = _correct(method, before, side, b0)
        cal1 = c1.calibration if c1 else None
        after1 = run(cal1, s_after)
        c2 = _correct(method, after1, side, c1.calibration.wheelbase_m, c1.calibration) if c1 else None
        out[f"emax_{name1}_mm"] = umbmark_figures(after1).emax_syst * 1e3
        out[f"emax_{name2}_mm"] = umbmark_figures(run(c2.calibration if c2 else cal1, s_after2)).emax_syst * 1e3
        out[f"fail_{name1}"], out[f"fail_{name2}"] = c1 is None, c2 is None
        return c1, c2

    out = {"ed": ed, "eb": eb, "noise": noise, "robot": robot}
    before = run(None, s_before)
    out["emax_before_mm"] = umbmark_figures(before).emax_syst * 1e3
    bf1, bf2 = two_passes("bf", "bf1", "bf2")
    ex, ex2 = two_passes("exact", "exact", "exact2")
    out["emax_perfect_mm"] = umbmark_figures(run(errors.ideal_calibration(geom), s_after)).emax_syst * 1e3
    if bound_cov is None:
        out["emax_bound_mm"] = out["emax_perfect_mm"] if noise == "none" else math.nan
    else:
        g = np.random.default_rng(np.random.SeedSequence([cfg.seed, robot, _BOUND_KEY]))
        d_ed, d_eb = g.multivariate_normal(np.zeros(2), bound_cov)
        _, cal_bound = compose(ed + d_ed, eb + d_eb, b0, None)
        out["emax_bound_mm"] = umbmark_figures(run(cal_bound, s_after)).emax_syst * 1e3
    true_b = eb * b0
    for name, c in (("bf1", bf1), ("bf2", bf2), ("exact", ex), ("exact2", ex2)):
        out[f"ed_err_{name}"] = abs(c.ed - ed) if c else math.nan
        out[f"eb_err_{name}"] = abs(c.calibration.wheelbase_m / b0 - eb) if c else math.nan
    ci = None if ex is None else ex.intervals
    if noise != "none" and ci is not None:
        lo, hi = ci.ed
        out["ed_covered"] = bool(lo <= ed <= hi)
        lo, hi = ci.wheelbase_m
        out["eb_covered"] = bool(lo <= true_b <= hi)
        out["exact_pred_after_mm"] = ci.emax_syst_after_pred_measured_m * 1e3
    else:
        out["ed_covered"] = out["eb_covered"] = None
        out["exact_pred_after_mm"] = math.nan
    out["exact_warned"] = bool(ex.warnings) if ex else False
    return out


def _cell_job(args):
    cfg, ed, eb, noise = args
    robots = 1 if noise == "none" else cfg.robots
    cov, sds = information_bound(cfg, ed, eb, noise)
    trials = [robot_trial(cfg, ed, eb, noise, i, cov) for i in range(robots)]
    for t in trials:
        t["bound_ed_sd"], t["bound_eb_sd"] = sds["ed_sd"], sds["eb_sd"]
    return trials


def _summarise(trials: list[dict]) -> dict:
    t = trials[0]
    row = {"noise": t["noise"], "Ed": t["ed"], "Eb": t["eb"], "robots": len(trials)}
    col = lambda k: np.array([x[k] for x in trials], dtype=float)  # noqa: E731
    row["emax_before_mm"] = float(np.median(col("emax_before_mm")))
    for m in ROWS:
        row[f"emax_{m}_mm"] = float(np.median(col(f"emax_{m}_mm")))
    for m in FITTED:
        e, b = col(f"ed_err_{m}"), col(f"eb_err_{m}")
        row[f"ed_abs_err_{m}"] = float(np.nanmedian(e)) if np.isfinite(e).any() else None
        row[f"eb_abs_err_{m}"] = float(np.nanmedian(b)) if np.isfinite(b).any() else None
        row[f"failures_{m}"] = int(sum(bool(x.get(f"fail_{m}")) for x in trials))
    cov = [x for x in trials if x["ed_covered"] is not None]
    row["exact_ci_robots"] = len(cov)
    row["exact_ed_coverage"] = float(np.mean([x["ed_covered"] for x in cov])) if cov else None
    row["exact_eb_coverage"] = float(np.mean([x["eb_covered"] for x in cov])) if cov else None
    row["exact_pred_after_mm"] = float(np.nanmedian(col("exact_pred_after_mm"))) if cov else None
    row["exact_warnings"] = int(sum(x["exact_warned"] for x in trials))
    row["bound_ed_sd"], row["bound_eb_sd"] = t["bound_ed_sd"], t["bound_eb_sd"]
    # root mean square parameter errors of exact, to compare with the bound's standard deviations
    row["exact_ed_rms_err"] = float(np.sqrt(np.nanmean(col("ed_err_exact") ** 2)))
    row["exact_eb_rms_err"] = float(np.sqrt(np.nanmean(col("eb_err_exact") ** 2)))
    return row


def _noise_summary_stats(cells: list[dict], trials: list[dict]) -> dict:
    """The summary of one noise level: cells within 1.15 x the floors and the bound, the worst
    cells, the largest parameter errors, interval coverage and failures."""
    cov = [t for t in trials if t["ed_covered"] is not None]
    worst = max(cells, key=lambda r: r["exact_over_estimation_floor"] or 0.0)
    return {
        "cells": len(cells),
        "robots": len(trials),
        "exact_worst_over_estimation_floor": worst["exact_over_estimation_floor"],
        "exact_worst_cell": [worst["Ed"], worst["Eb"]],
        "exact_cells_within_1.15_estimation_floor": sum(
            1
            for r in cells
            if r["exact_over_estimation_floor"] is not None and r["exact_over_estimation_floor"] <= 1.15
        ),
        "bf1_cells_within_1.15_estimation_floor": sum(
            1 for r in cells if r["bf1_over_estimation_floor"] is not None and r["bf1_over_estimation_floor"] <= 1.15
        ),
        "exact_max_ed_abs_err": max((r["ed_abs_err_exact"] or 0.0) for r in cells),
        "exact_max_eb_abs_err": max((r["eb_abs_err_exact"] or 0.0) for r in cells),
        "exact_ci_robots": len(cov),
        "exact_ed_coverage": float(np.mean([t["ed_covered"] for t in cov])) if cov else None,
        "exact_eb_coverage": float(np.mean([t["eb_covered"] for t in cov])) if cov else None,
        "exact2_cells_within_1.15_estimation_floor": sum(
            1
            for r in cells
            if r["exact2_over_estimation_floor"] is not None and r["exact2_over_estimation_floor"] <= 1.15
        ),
        "exact_cells_over_1.15": [
            [r["Ed"], r["Eb"], r["exact_over_estimation_floor"]]
            for r in cells
            if (r["exact_over_estimation_floor"] or 0.0) > 1.15
        ],
        "failures": {m: sum(r[f"failures_{m}"] for r in cells) for m in FITTED},
        # cells where even an efficient one-pass estimator cannot reach 1.15 x the floor
        "bound_cells_over_1.15": [
            [r["Ed"], r["Eb"], r["bound_over_estimation_floor"]]
            for r in cells
            if (r["bound_over_estimation_floor"] or 0.0) > 1.15
        ],
        "exact_worst_over_bound": max((r["exact_over_bound"] or 0.0) for r in cells) or None,
        "bound_worst_over_estimation_floor": max((r["bound_over_estimation_floor"] or 0.0) for r in cells),
        "exact_cells_within_1.15_bound": sum(
            1 for r in cells if r["exact_over_bound"] is not None and r["exact_over_bound"] <= 1.15
        ),
    }


def run_accuracy(cfg: AccuracyConfig = AccuracyConfig(), progress=None, dask=None) -> dict:
    """Run the benchmark over every cell and noise level.

    The cells (one noise level, ``E_d``, ``E_b`` each) are the items of a sweep
    (:func:`umbmark.studies.sweep.map`). Robot ``i`` of a cell carries its own seed, so every
    backend gives the same numbers.

    Parameters
    ----------
    cfg : AccuracyConfig
        The settings; ``cfg.workers`` local processes (``None``: all cores) run the cells.
    progress : callable, optional
        ``progress(done, total)``, called as cells finish.
    dask : str or distributed.Client, optional
        Run the cells on a Dask cluster instead: an address, ``"local"`` or a client.

    Returns
    -------
    dict
        ``config`` (the settings), ``cells`` (one row of medians per cell), ``floors`` and
        ``summary`` (per noise level), ``backend`` and ``elapsed_s``.

    Raises
    ------
    InputError
        If the settings are out of range (:meth:`AccuracyConfig.validate`).
    """
    from umbmark.studies import sweep

    cfg.validate()
    t0 = time.time()
    jobs = [(cfg, ed, eb, noise) for noise in cfg.noises for ed, eb in cfg.cells()]
    results = sweep.map(_cell_job, jobs, workers=cfg.workers, dask=dask, on_progress=progress)
    rows = [_summarise(r) for r in results]
    small_ed, small_eb = min(cfg.ed_departures), min(abs(e - 1) for e in cfg.eb_values)
    floors, summary = {}, {}
    for noise in cfg.noises:
        trials = [t for r in results for t in r if t["noise"] == noise]
        smallest = [
            t for t in trials if abs(abs(t["ed"] - 1) - small_ed) < 1e-12 and abs(abs(t["eb"] - 1) - small_eb) < 1e-12
        ]
        est = float(np.median([t["emax_bf1_mm"] for t in smallest]))
        perf = float(np.median([t["emax_perfect_mm"] for t in trials]))
        floors[noise] = {
            "estimation_floor_mm": est,
            "perfect_floor_mm": perf,
            "estimation_floor_cells": sorted({(t["ed"], t["eb"]) for t in smallest}),
        }
        cells = [r for r in rows if r["noise"] == noise]
        for r in cells:
            for m in FITTED + ("bound",):
                r[f"{m}_over_estimation_floor"] = r[f"emax_{m}_mm"] / est if est > 0 else None
                r[f"{m}_over_perfect_floor"] = r[f"emax_{m}_mm"] / perf if perf > 0 else None
            b = r["emax_bound_mm"]
            # without noise both are round-off (the bound is the perfect robot): no ratio
            r["exact_over_bound"] = r["emax_exact_mm"] / b if noise != "none" and b > 0 and math.isfinite(b) else None
        summary[noise] = _noise_summary_stats(cells, trials)
    cfg_d = asdict(cfg)
    return {
        "config": cfg_d,
        "cells": rows,
        "floors": floors,
        "summary": summary,
        "backend": sweep.describe_backend(cfg.workers, dask),
        "elapsed_s": time.time() - t0,
    }


def coverage_trial(
    robots: int = 200,
    seed: int = 7,
    sample_period_s: float = 0.02,
    noise: str = "paper",
    ed_max_departure: float = 0.05,
    eb_range=(0.5, 2.5),
    side_m: float = 4.0,
    runs_per_direction: int = 5,
) -> dict:
    """Coverage of ``exact``'s 95 % intervals over seeded robots with random true errors.

    Parameters
    ----------
    robots : int
        Number of robots (robot ``i`` is seeded ``[seed, i]``).
    seed : int
        Seed of the errors and the runs.
    sample_period_s : float
        Sampling period of the simulation.
    noise : str
        The noise preset.
    ed_max_departure : float
        E_d is uniform in ``1 +- ed_max_departure``.
    eb_range : tuple of float
        E_b is log-uniform in this range.
    side_m : float
        Side of the square.
    runs_per_direction : int
        Runs per direction.

    Returns
    -------
    dict
        ``robots`` (those with intervals), ``ed_coverage``, ``eb_coverage`` and the mean and
        standard deviation of the standardised errors ``z_mean``, ``z_std`` (``None`` when no
        robot had intervals).
    """
    rng = np.random.default_rng(seed)
    hit_d = hit_b = n = 0
    z = []
    for i in range(robots):
        ed = 1.0 + rng.uniform(-ed_max_departure, ed_max_departure)
        eb = float(np.exp(rng.uniform(math.log(eb_range[0]), math.log(eb_range[1]))))
        runs = simulate_umbmark(
            ErrorParams(ed, eb),
            LABMATE,
            side_m,
            runs_per_direction,
            None,
            noise,
            Motion(sample_period_s=sample_period_s),
            seed=np.random.SeedSequence([seed, i]),
        )
        c = correct_runs("exact", runs, side_m, LABMATE.wheelbase_m)
        ci = c.intervals
        if ci is None:
            continue
        n += 1
        hit_d += ci.ed[0] <= ed <= ci.ed[1]
        hit_b += ci.eb[0] <= eb <= ci.eb[1]
        z.append(((c.ed - ed) / ci.ed_se, (c.eb - eb) / ci.eb_se))
    zz = np.array(z) if z else np.zeros((0, 2))
    return {
        "robots": n,
        "ed_coverage": hit_d / n if n else None,
        "eb_coverage": hit_b / n if n else None,
        "z_mean": zz.mean(axis=0).tolist() if n else None,
        "z_std": zz.std(axis=0).tolist() if n else None,
    }


TITLE = "# Accuracy benchmark of the correction methods (umbmark)"


def format_markdown(res: dict) -> str:
    """The results as Markdown: the grid, then per noise level the floors, the summary and the cells.

    Parameters
    ----------
    res : dict
        The output of :func:`run_accuracy`.

    Returns
    -------
    str
        One Markdown page (see :data:`TITLE`), ending with a newline.
    """
    lines = [TITLE, ""]
    c = res["config"]
    lines.append(
        f"Grid: |E_d - 1| in {list(c['ed_departures'])} (both signs), E_b in {list(c['eb_values'])}; "
        f"{c['robots']} robots per cell with noise (1 without), {c['runs_per_direction']} runs per "
        f"direction, {c['side_m']} m square, {_design(c)}, sampling period "
        f"{c['sample_period_s'] * 1e3:.0f} ms with noise, "
        f"seed {c['seed']}. Elapsed {res['elapsed_s']:.0f} s."
    )
    lines.append("")
    for noise, fl in res["floors"].items():
        lines += [f"## noise: {noise}", "", _noise_summary(noise, fl, res["summary"][noise]), ""]
        if noise != "none":
            lines += _by_eb(res, noise)
        lines += _cells_table(res, noise)
        lines.append("")
    return "\n".join(lines) + "\n"


def _noise_summary(noise: str, fl: dict, sm: dict) -> str:
    """The paragraph of one noise level: the floors, the cells within them, coverage, the bound."""
    text = (
        f"Estimation floor (bf one pass, smallest errors): {fl['estimation_floor_mm']:.4g} mm; "
        f"perfect floor (true parameters): {fl['perfect_floor_mm']:.4g} mm. "
        f"exact within 1.15 x estimation floor in {sm['exact_cells_within_1.15_estimation_floor']} / "
        f"{sm['cells']} cells (worst {fmt(sm['exact_worst_over_estimation_floor'], 3)} at "
        f"E_d {sm['exact_worst_cell'][0]}, E_b {sm['exact_worst_cell'][1]}); bf one pass in "
        f"{sm['bf1_cells_within_1.15_estimation_floor']}, exact two passes in "
        f"{sm['exact2_cells_within_1.15_estimation_floor']}. exact 95 % interval coverage over "
        f"{sm['exact_ci_robots']} robots: E_d {fmt(sm['exact_ed_coverage'] and 100 * sm['exact_ed_coverage'])} %, "
        f"E_b {fmt(sm['exact_eb_coverage'] and 100 * sm['exact_eb_coverage'])} %. Failures (no answer): "
        f"{sm['failures']}."
    )
    if noise == "none":
        return text
    return text + (
        f" Information bound (an efficient unbiased one-pass estimator, Cramer-Rao): above 1.15 x the "
        f"estimation floor in {len(sm['bound_cells_over_1.15'])} cells"
        f"{_cells(sm['bound_cells_over_1.15'])}; exact within 1.15 x the bound in "
        f"{sm['exact_cells_within_1.15_bound']} / {sm['cells']} cells (worst "
        f"{fmt(sm['exact_worst_over_bound'], 2)})."
    )


# the cells table: (header, key, digits, spec) per column; key None: the coverage column
_CELL_COLUMNS = (
    ("E_d", "Ed", 4, "f"),
    ("E_b", "Eb", 4, "f"),
    ("before [mm]", "emax_before_mm", 1, "f"),
    ("bf1 [mm]", "emax_bf1_mm", 1, "f"),
    ("bf2 [mm]", "emax_bf2_mm", 1, "f"),
    ("exact [mm]", "emax_exact_mm", 2, "f"),
    ("exact2 [mm]", "emax_exact2_mm", 2, "f"),
    ("perfect [mm]", "emax_perfect_mm", 2, "f"),
    ("exact / est. floor", "exact_over_estimation_floor", 2, "f"),
    ("exact / perfect", "exact_over_perfect_floor", 2, "f"),
    ("exact2 / est. floor", "exact2_over_estimation_floor", 2, "f"),
    ("bf1 / est. floor", "bf1_over_estimation_floor", 2, "f"),
    ("exact abs err E_d", "ed_abs_err_exact", 2, "g"),
    ("exact abs err E_b", "eb_abs_err_exact", 2, "g"),
    ("bf1 abs err E_d", "ed_abs_err_bf1", 2, "g"),
    ("bf1 abs err E_b", "eb_abs_err_bf1", 2, "g"),
    ("exact CI cover E_d / E_b", None, 0, "f"),
    ("bound [mm]", "emax_bound_mm", 2, "f"),
    ("bound / est. floor", "bound_over_estimation_floor", 2, "f"),
    ("exact / bound", "exact_over_bound", 2, "f"),
    ("bound sd E_d", "bound_ed_sd", 2, "g"),
    ("exact rms err E_d", "exact_ed_rms_err", 2, "g"),
    ("bound sd E_b", "bound_eb_sd", 2, "g"),
    ("exact rms err E_b", "exact_eb_rms_err", 2, "g"),
)


def _cells_table(res: dict, noise: str) -> list[str]:
    """One Markdown row per cell of one noise level (see :data:`_CELL_COLUMNS`)."""
    lines = ["| " + " | ".join(h for h, *_ in _CELL_COLUMNS) + " |", "|" + "---|" * len(_CELL_COLUMNS)]
    for r in res["cells"]:
        if r["noise"] != noise:
            continue
        cells = []
        for _, key, digits, spec in _CELL_COLUMNS:
            if key is None:
                cov = r["exact_ed_coverage"]
                cells.append("-" if cov is None else f"{100 * cov:.0f} / {100 * r['exact_eb_coverage']:.0f} %")
            elif key in ("Ed", "Eb"):
                cells.append(f"{r[key]:.4f}")
            else:
                cells.append(fmt(r[key], digits, spec=spec))
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _by_eb(res: dict, noise: str) -> list[str]:
    """Ranges over the E_d values of each true E_b: the ratios to the floors and the bound."""
    rows = [r for r in res["cells"] if r["noise"] == noise]
    cols = (
        ("exact_over_estimation_floor", "exact / est. floor"),
        ("bound_over_estimation_floor", "bound / est. floor"),
        ("exact_over_bound", "exact / bound"),
        ("exact_over_perfect_floor", "exact / perfect"),
        ("exact2_over_estimation_floor", "exact2 / est. floor"),
        ("bf1_over_estimation_floor", "bf1 / est. floor"),
    )
    out = [
        "By true E_b (ranges over the E_d values):",
        "",
        "| true E_b | " + " | ".join(c[1] for c in cols) + " |",
        "|---|" + "---|" * len(cols),
    ]
    for eb in sorted({r["Eb"] for r in rows}):
        cells = [r for r in rows if r["Eb"] == eb]
        parts = []
        for key, _ in cols:
            v = [r[key] for r in cells if r.get(key) is not None]
            lo, hi = (_ratio(min(v)), _ratio(max(v))) if v else ("-", "-")
            parts.append(lo if lo == hi else f"{lo} - {hi}")
        out.append(f"| {eb:g} | " + " | ".join(parts) + " |")
    return out + [""]


def _design(c: dict) -> str:
    b = c["true_wheelbase_m"] * 1e3
    if c.get("fixed_wheelbase", "true") == "true":
        return f"true wheelbase {b:.0f} mm (nominal = true / E_b: one physical robot)"
    return f"nominal wheelbase {b:.0f} mm (true = E_b x nominal: e.g. a skid-steer robot's effective wheelbase)"


def _ratio(v):
    return f"{v:.0f}" if v >= 100 else f"{v:.2f}"


def _cells(cells):
    return "" if not cells else " (" + ", ".join(f"E_d {c[0]:g} / E_b {c[1]:g}: {c[2]:.2f}" for c in cells) + ")"


CSV_COLUMNS = (
    "noise",
    "Ed",
    "Eb",
    "robots",
    "emax_before_mm",
    "emax_bf1_mm",
    "emax_bf2_mm",
    "emax_exact_mm",
    "emax_exact2_mm",
    "emax_perfect_mm",
    "bf1_over_estimation_floor",
    "bf2_over_estimation_floor",
    "exact_over_estimation_floor",
    "exact2_over_estimation_floor",
    "exact_over_perfect_floor",
    "bf1_over_perfect_floor",
    "ed_abs_err_bf1",
    "eb_abs_err_bf1",
    "ed_abs_err_bf2",
    "eb_abs_err_bf2",
    "ed_abs_err_exact",
    "eb_abs_err_exact",
    "ed_abs_err_exact2",
    "eb_abs_err_exact2",
    "exact_ed_coverage",
    "exact_eb_coverage",
    "exact_pred_after_mm",
    "emax_bound_mm",
    "bound_over_estimation_floor",
    "exact_over_bound",
    "bound_ed_sd",
    "bound_eb_sd",
    "exact_ed_rms_err",
    "exact_eb_rms_err",
    "failures_bf1",
    "failures_bf2",
    "failures_exact",
    "failures_exact2",
    "exact_warnings",
)


def format_csv(res: dict) -> str:
    """The cells as CSV, one row per cell, the columns of :data:`CSV_COLUMNS` (floats as ``repr``).

    Parameters
    ----------
    res : dict
        The output of :func:`run_accuracy`.

    Returns
    -------
    str
    """
    out = [",".join(CSV_COLUMNS)]
    for r in res["cells"]:
        out.append(
            ",".join(
                "" if r.get(k) is None else (repr(r[k]) if isinstance(r[k], float) else str(r[k])) for k in CSV_COLUMNS
            )
        )
    return "\n".join(out) + "\n"


def figure(res: dict):
    """Median E_max,syst after correction per cell (noise 'paper' if present), log scale.

    Parameters
    ----------
    res : dict
        The output of :func:`run_accuracy`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from umbmark.viz.plots import new_figure

    noise = "paper" if "paper" in res["floors"] else next(iter(res["floors"]))
    cells = [r for r in res["cells"] if r["noise"] == noise]
    cells.sort(key=lambda r: (r["Eb"], r["Ed"]))
    x = np.arange(len(cells))
    fig = new_figure((max(8, 0.22 * len(cells) + 3), 5))
    ax = fig.subplots()
    for m, style in (
        ("bf1", "o-"),
        ("bf2", "s-"),
        ("exact", "^-"),
        ("exact2", "v-"),
        ("perfect", "x:"),
        ("bound", "d--"),
    ):
        ax.plot(x, [max(r[f"emax_{m}_mm"], 1e-9) for r in cells], style, label=f"{m} (median)", ms=4)
    fl = res["floors"][noise]
    ax.axhline(fl["estimation_floor_mm"], color="k", ls="--", lw=1, label="estimation floor")
    ax.axhline(1.15 * fl["estimation_floor_mm"], color="grey", ls=":", lw=1, label="1.15 x estimation floor")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([f"{r['Ed']:.4f}\n{r['Eb']:.4g}" for r in cells], fontsize=6, rotation=90)
    ax.set_xlabel("cell: true E_d / E_b")
    ax.set_ylabel("E_max,syst after correction [mm] (fresh runs)")
    ax.set_title(f"Accuracy of one/two correction passes, noise '{noise}', {res['config']['robots']} robots per cell")
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


def write_results(res: dict, out_dir, stem: str = "accuracy") -> dict:
    """Write ``<stem>.json``, ``.csv``, ``.md`` and ``.png`` into a folder.

    Parameters
    ----------
    res : dict
        The output of :func:`run_accuracy`.
    out_dir : str or Path
        The folder (created if missing).
    stem : str
        The files' name without suffix.

    Returns
    -------
    dict
        ``{"json", "csv", "md", "png"}`` -> the path written, as a string.

    Raises
    ------
    InputError
        If ``out_dir`` exists and is a file.
    """
    from pathlib import Path

    from umbmark.io.atomic import atomic_path, atomic_write

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"output folder {out} is a file")
    out.mkdir(parents=True, exist_ok=True)

    paths = {k: out / f"{stem}.{k}" for k in ("json", "csv", "md", "png")}
    atomic_write(paths["json"], dumps(res, indent=1) + "\n")
    atomic_write(paths["csv"], format_csv(res))
    atomic_write(paths["md"], format_markdown(res))
    fig = figure(res)
    with atomic_path(paths["png"]) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return {k: str(v) for k, v in paths.items()}
