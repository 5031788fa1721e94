"""The accuracy benchmark (reduced sizes) and the coverage of the exact method's intervals."""

import json
from dataclasses import replace

import pytest

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.studies.accuracy import QUICK, AccuracyConfig, coverage_trial, robot_trial, run_accuracy, write_results


def test_noise_free_cell_shows_where_bf_fails():
    """E_d 1.02, E_b 0.95: bf one pass leaves about a metre, exact nothing."""
    t = robot_trial(AccuracyConfig(), 1.02, 0.95, "none", 0)
    assert 500 < t["emax_bf1_mm"] < 2000
    assert t["emax_exact_mm"] < 1e-6
    assert t["ed_err_exact"] < 1e-9 and t["eb_err_exact"] < 1e-9
    assert t["emax_perfect_mm"] < 1e-6


def test_tiny_benchmark_structure(tmp_path):
    cfg = replace(QUICK, ed_departures=(0.0005, 0.02), eb_values=(0.9995, 0.95), robots=2)
    res = run_accuracy(cfg)
    assert {r["noise"] for r in res["cells"]} == {"none", "paper"}
    assert len(res["cells"]) == 2 * 4 * 2
    fl = res["floors"]["paper"]
    assert 0 < fl["perfect_floor_mm"] < 50 and 0 < fl["estimation_floor_mm"] < 50
    none = [r for r in res["cells"] if r["noise"] == "none"]
    assert max(r["emax_exact_mm"] for r in none) < 1e-6
    assert res["summary"]["none"]["exact_ed_coverage"] is None  # no intervals without noise
    paths = write_results(res, tmp_path / "out")
    for k in ("json", "csv", "md", "png"):
        assert (tmp_path / "out" / f"accuracy.{k}").stat().st_size > 100
    assert json.loads(open(paths["json"]).read())["config"]["robots"] == 2
    header = open(paths["csv"]).readline().strip().split(",")
    assert "exact_over_estimation_floor" in header and "exact_over_perfect_floor" in header
    assert {"emax_bound_mm", "exact_over_bound", "bound_eb_sd"} <= set(header)
    paper = [r for r in res["cells"] if r["noise"] == "paper"]
    assert all(r["emax_bound_mm"] > 0 and r["bound_eb_sd"] > 0 for r in paper)
    assert all(r["emax_bound_mm"] == r["emax_perfect_mm"] for r in none)  # no noise: nothing to estimate
    assert "Information bound" in open(paths["md"]).read()


def test_bench_accuracy_cli(tmp_path, capsys):
    assert main(["bench", "accuracy", "--quick", "--robots", "1", "--out", str(tmp_path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["summary"]) == {"none", "paper"}
    assert (tmp_path / "accuracy.md").exists()
    assert main(["bench", "accuracy", "--quick", "--sample-period-ms", "0", "--out", str(tmp_path)]) == 2


def test_bad_config():
    with pytest.raises(InputError):
        run_accuracy(replace(QUICK, eb_values=(7.0,)))
    with pytest.raises(InputError):
        run_accuracy(replace(QUICK, runs_per_direction=1))
    with pytest.raises(InputError):
        run_accuracy(replace(QUICK, fixed_wheelbase="track"))


def test_which_wheelbase_is_held_fixed():
    """Default: one physical robot (true 340 mm, the odometry starts from 340 / E_b); 'nominal':
    the odometry starts from 340 mm and the true (effective) wheelbase is E_b x 340 mm."""
    from umbmark.model.geometry import ErrorParams
    from umbmark.studies.accuracy import _geometry

    for fixed, nominal, true in (("true", 0.136, 0.34), ("nominal", 0.34, 0.85)):
        cfg = replace(AccuracyConfig(), fixed_wheelbase=fixed)
        g = _geometry(cfg, 2.5)
        assert g.wheelbase_m == pytest.approx(nominal)
        assert ErrorParams(1.0, 2.5).true_params(g).wheelbase_m == pytest.approx(true)


@pytest.mark.slow
def test_interval_coverage_over_200_robots():
    """Acceptance: 95 % intervals contain the true E_d and E_b 90 - 99 % of the time
    (200 seeded robots, E_d in 1 +- 5 %, E_b in [0.5, 2.5], paper noise, 20 ms sampling)."""
    c = coverage_trial(200, seed=7, sample_period_s=0.02)
    assert c["robots"] == 200
    assert 0.90 <= c["ed_coverage"] <= 0.99, c
    assert 0.90 <= c["eb_coverage"] <= 0.99, c


def test_benchmark_script_runs_on_its_own(tmp_path, repo_root):
    import subprocess
    import sys

    r = subprocess.run(
        [
            sys.executable,
            str(repo_root / "benchmarks" / "accuracy.py"),
            "--quick",
            "--robots",
            "1",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "accuracy.csv").exists() and "paper" in r.stdout


def test_information_bound_matches_the_analytic_bound_for_measurement_noise():
    """With only measurement noise (2 mm, 0.4 deg, independent) the run covariance is known, so
    the Cramer-Rao bound is (sum_d n J_d^T S^-1 J_d)^-1 with S diagonal: the estimated bound
    (200 simulated runs per direction) must agree within the sampling error of S (~10 %)."""
    import math

    import numpy as np

    from umbmark.correct.exact import _Problem
    from umbmark.model.geometry import ErrorParams
    from umbmark.model.simulate import Motion, NoiseModel, simulate_umbmark
    from umbmark.studies.accuracy import _geometry, information_bound

    cfg = AccuracyConfig()
    ed, eb = 1.01, 1.3
    nm = NoiseModel(abs_xy_std_m=2e-3, abs_theta_std_rad=math.radians(0.4))
    cov, sds = information_bound(cfg, ed, eb, nm)
    geom = _geometry(cfg, eb)
    runs = simulate_umbmark(ErrorParams(ed, eb), geom, cfg.side_m, 1, None, "none", Motion(sample_period_s=None))
    prob = _Problem(runs, cfg.side_m, geom.wheelbase_m, 1.0, True, 1.0)
    J = prob.jacobian_runs(np.array([ed, eb]))
    Sinv = np.diag([1 / 2e-3**2, 1 / 2e-3**2, 1 / math.radians(0.4) ** 2])
    info = sum(cfg.runs_per_direction * J[i].T @ Sinv @ J[i] for i in range(2))
    want = np.sqrt(np.diag(np.linalg.inv(info)))
    assert sds["ed_sd"] == pytest.approx(want[0], rel=0.12)
    assert sds["eb_sd"] == pytest.approx(want[1], rel=0.12)
    assert information_bound(cfg, ed, eb, "none") == (None, {"ed_sd": 0.0, "eb_sd": 0.0})


def test_exact_is_near_the_information_bound():
    """The bound is a bound: over 40 seeded robots (paper noise) exact's rms parameter errors are
    neither far below the Cramer-Rao standard deviations (which would mean a wrong bound) nor far
    above (an inefficient fit)."""
    import numpy as np

    from umbmark.studies.accuracy import information_bound

    cfg = replace(AccuracyConfig(), sample_period_s=0.03)
    cov, sds = information_bound(cfg, 1.005, 0.95, "paper")
    t = [robot_trial(cfg, 1.005, 0.95, "paper", i, cov) for i in range(40)]
    rms_d = float(np.sqrt(np.mean([x["ed_err_exact"] ** 2 for x in t])))
    rms_b = float(np.sqrt(np.mean([x["eb_err_exact"] ** 2 for x in t])))
    assert 0.7 < rms_d / sds["ed_sd"] < 1.6, (rms_d, sds)
    assert 0.7 < rms_b / sds["eb_sd"] < 1.6, (rms_b, sds)
    assert all(x["emax_bound_mm"] > 0 for x in t)
