"""The calibration loop (simulator) and the composition of successive passes (real robots)."""

import json

import numpy as np
import pytest

from umbmark.cli import main
from umbmark.correct import correct_runs
from umbmark.io.runs_csv import write_runs_csv
from umbmark.model.geometry import LABMATE, ErrorParams
from umbmark.model.simulate import Motion, simulate_umbmark
from umbmark.studies.iterate import calibrate_loop, compose_passes

EXACT_ARC = Motion(sample_period_s=None)


def test_noise_free_exact_loop_stops_after_one_correction():
    e = ErrorParams(1.02, 0.95)
    loop = calibrate_loop(e, noise="none", motion=EXACT_ARC, method="exact", max_passes=3)
    assert loop.corrections == 1
    assert len(loop.passes) == 2 and "tolerance" in loop.passes[-1].decision
    ideal = e.ideal_calibration(LABMATE)
    assert loop.final_calibration.c_left == pytest.approx(ideal.c_left, abs=1e-9)
    assert loop.final_calibration.wheelbase_m == pytest.approx(ideal.wheelbase_m, abs=1e-9)
    assert loop.passes[-1].result.emax_syst < 1e-6


def test_noise_free_bf_loop_hits_the_pass_limit():
    loop = calibrate_loop(ErrorParams(1.02, 0.95), noise="none", motion=EXACT_ARC, method="bf", max_passes=2)
    assert loop.corrections == 2
    assert "2 correction passes done" in loop.stopped
    # each pass ran with the calibration computed from the one before
    assert loop.passes[1].calibration_used == loop.passes[0].correction.calibration
    assert loop.passes[2].calibration_used == loop.passes[1].correction.calibration
    # and each bf pass brings E_max,syst down
    e = [p.result.emax_syst for p in loop.passes]
    assert e[0] > e[1] > e[2]


def test_noisy_loop_stops_on_the_three_sem_rule():
    loop = calibrate_loop(
        ErrorParams(1.02, 0.95),
        noise="paper",
        motion=Motion(sample_period_s=0.03),
        method="exact",
        max_passes=3,
        seed=2,
    )
    last = loop.passes[-1]
    assert last.correction is None
    assert "3 x SEM" in last.decision
    if "unlikely" in last.decision:
        assert last.result.emax_syst < last.result.sem_rule
    assert loop.corrections >= 1


def test_compose_passes_matches_sequential_corrections(tmp_path):
    e = ErrorParams(1.013, 0.97)
    p1 = simulate_umbmark(e, n_runs=5, noise="paper", motion=Motion(sample_period_s=0.03), seed=1)
    c1 = correct_runs("bf", p1, 4.0, 0.34)
    p2 = simulate_umbmark(
        e, n_runs=5, calibration=c1.calibration, noise="paper", motion=Motion(sample_period_s=0.03), seed=2
    )
    c2 = correct_runs("bf", p2, 4.0, c1.calibration.wheelbase_m, c1.calibration)
    loop = compose_passes([p1, p2], 4.0, 0.34, "bf")
    assert loop.final_calibration == c2.calibration
    assert loop.passes[1].wheelbase_used_m == c1.calibration.wheelbase_m
    # the composed calibration is closer to the truth than the first pass
    ideal = e.ideal_calibration(LABMATE)
    assert abs(c2.calibration.wheelbase_m - ideal.wheelbase_m) < abs(c1.calibration.wheelbase_m - ideal.wheelbase_m)

    # the CLI does the same from files
    f1, f2 = tmp_path / "p1.csv", tmp_path / "p2.csv"
    write_runs_csv(p1, f1)
    write_runs_csv(p2, f2)
    assert (
        main(["calibrate", str(f1), str(f2), "--wheelbase-mm", "340", "--side-mm", "4000", "--method", "bf", "--json"])
        == 0
    )


def test_compose_exact_second_pass_is_near_identity():
    e = ErrorParams(0.97, 1.8)
    p1 = simulate_umbmark(e, n_runs=2, motion=EXACT_ARC)
    loop1 = compose_passes([p1], 4.0, 0.34, "exact")
    p2 = simulate_umbmark(e, n_runs=2, calibration=loop1.final_calibration, motion=EXACT_ARC)
    loop = compose_passes([p1, p2], 4.0, 0.34, "exact")
    c = loop.passes[1].correction
    assert c.ed_pass == pytest.approx(1.0, abs=1e-9) and c.eb == pytest.approx(1.0, abs=1e-9)
    assert loop.final_calibration.wheelbase_m == pytest.approx(1.8 * 0.34, rel=1e-9)


def test_calibrate_cli_json_and_saved_runs(tmp_path, capsys):
    assert (
        main(
            [
                "calibrate",
                "--ed",
                "1.01",
                "--eb",
                "1.05",
                "--noise",
                "none",
                "--seed",
                "1",
                "--save-runs",
                str(tmp_path),
                "--json",
            ]
        )
        == 0
    )
    d = json.loads(capsys.readouterr().out)
    assert d["method"] == "exact" and d["corrections"] == 1
    assert d["final_calibration"]["wheelbase_mm"] == pytest.approx(357.0, abs=1e-3)
    assert (tmp_path / "pass1.csv").exists() and (tmp_path / "pass2.csv").exists()


def test_calibrate_cli_errors(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err
    assert main(["calibrate", "--ed", "-1"]) == 2
    assert "--ed" in capsys.readouterr().err
    assert main(["calibrate", "--ed", "1e308"]) == 2  # finite but absurd
    assert "--ed must be a number from 0.5 to 2" in capsys.readouterr().err
    assert main(["calibrate", "--save-runs", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and len(err.strip().splitlines()) == 1


def test_loop_needs_two_runs():
    from umbmark.errors import InputError

    with pytest.raises(InputError, match="2 runs"):
        calibrate_loop(ErrorParams(1.01, 1.0), n_runs=1)
    with pytest.raises(InputError, match="passes"):
        calibrate_loop(ErrorParams(1.01, 1.0), max_passes=0)
    with pytest.raises(InputError, match="no runs files"):
        compose_passes([], 4.0, 0.34)
    assert np.isfinite(LABMATE.wheelbase_m)


def test_calibrate_records_into_the_history(tmp_path, capsys):
    from umbmark.history import open_history

    db = tmp_path / "h.sqlite"
    e = ErrorParams(1.02, 0.95)
    p1 = simulate_umbmark(e, n_runs=2, motion=EXACT_ARC)
    f1 = tmp_path / "p1.csv"
    write_runs_csv(p1, f1)
    # a real robot's passes (runs files)
    assert (
        main(
            [
                "calibrate",
                str(f1),
                "--wheelbase-mm",
                "340",
                "--side-mm",
                "4000",
                "--method",
                "bf",
                "--robot",
                "r1",
                "--record",
                "--db",
                str(db),
                "--json",
            ]
        )
        == 0
    )
    d = json.loads(capsys.readouterr().out)
    assert d["history"] == {"record_id": 1, "robot": "r1", "db": str(db)}
    # the simulator loop, human output
    assert (
        main(
            [
                "calibrate",
                "--ed",
                "1.01",
                "--eb",
                "1.05",
                "--noise",
                "none",
                "--seed",
                "1",
                "--robot",
                "r1",
                "--record",
                "--db",
                str(db),
            ]
        )
        == 0
    )
    assert "recorded as #2 in the history of r1" in capsys.readouterr().out
    with open_history(db, create=False) as h:
        r1, r2 = h.records("r1")
    assert (r1.kind, r1.method, r2.kind, r2.method) == ("calibrate", "bf", "calibrate", "exact")
    assert r1.source.endswith("p1.csv") and len(r1.input_sha256) == 64
    cal = d["final_calibration"]
    assert r1.parameters["c_left"] == pytest.approx(cal["c_left"]) and r1.parameters["Ed"] == pytest.approx(cal["Ed"])
    assert r1.parameters["wheelbase_mm"] == pytest.approx(cal["wheelbase_mm"])
    assert r1.emax_syst_mm == pytest.approx(d["passes"][0]["emax_syst_mm"])
    assert r2.parameters["wheelbase_mm"] == pytest.approx(357.0, abs=1e-3)  # the true wheelbase, 340 * 1.05
    assert r2.parameters["Eb"] == pytest.approx(1.05, abs=1e-5)
    # --record needs --robot: a usage error, nothing recorded
    assert main(["calibrate", "--noise", "none", "--record", "--db", str(db)]) == 2
    with open_history(db, create=False) as h:
        assert len(h.records("r1")) == 2


def test_choices_are_the_librarys():
    from umbmark.cli.app import METHOD_CHOICES, NOISE_CHOICES
    from umbmark.correct import METHODS
    from umbmark.model.simulate import NOISE_PRESETS

    assert list(METHOD_CHOICES) == sorted(METHODS) and list(NOISE_CHOICES) == sorted(NOISE_PRESETS)


def test_history_fields_of_a_simulated_loop_and_of_runs_files(tmp_path):
    from umbmark.history import file_sha256
    from umbmark.studies.iterate import history_fields

    loop = calibrate_loop(ErrorParams(1.01, 1.05), noise="none", motion=EXACT_ARC, method="bf", max_passes=1, seed=3)
    f = history_fields(loop)
    assert f["kind"] == "calibrate" and f["method"] == "bf" and f["note"] == "simulated robot"
    assert f["inputs"]["simulation"] == {
        "Ed": 1.01,
        "Eb": 1.05,
        "runs_per_direction": 5,
        "noise": "none",
        "seed": 3,
        "sample_period_ms": None,
        "max_passes": 1,
        "side_mm": 4000.0,
    }
    assert f["results"] == {
        **loop.to_dict(),
        "emax_syst_mm": loop.passes[0].result.emax_syst * 1e3,
        "emax_syst_last_pass_mm": loop.passes[-1].result.emax_syst * 1e3,
    }
    assert f["parameters"]["wheelbase_mm"] == loop.final_calibration.wheelbase_m * 1e3
    # runs files: each one hashed, the record's hash the hash of the hashes
    files = []
    for p in loop.passes:
        files.append(tmp_path / f"pass{p.index}.csv")
        write_runs_csv(p.runs, files[-1])
    real = compose_passes([p.runs for p in loop.passes], 4.0, 0.34, "bf", sources=[str(f) for f in files])
    g = history_fields(real)
    assert "simulation" not in g["inputs"] and "note" not in g
    assert [r["sha256"] for r in g["inputs"]["runs_files"]] == [file_sha256(f) for f in files]
    assert g["source"] == str(files[-1].resolve()) and len(g["input_sha256"]) == 64
    assert real.to_dict()["method"] == "bf" and real.simulation is None
