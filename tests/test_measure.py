"""umbmark measure: wall distances -> return pose in the start frame, checked against the
simulator's true poses (the distances a person would measure from a true pose go in, the pose
must come back)."""

import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.cli.app import app
from umbmark.errors import InputError
from umbmark.io.distances_csv import MeasuredRun, format_distances_csv, parse_distances_csv
from umbmark.io.runs_csv import read_runs_csv
from umbmark.model.geometry import FIG11_ERRORS, ErrorParams
from umbmark.model.simulate import simulate_umbmark
from umbmark.realrobot.guide import guide_text
from umbmark.realrobot.measure import (
    RobotMarks,
    WallPose,
    distances_for_runs,
    distances_from_pose,
    format_measured_csv,
    marks_for_direction,
    measure,
    measure_runs,
    pose_from_distances,
    relative_pose,
)

MARKS = RobotMarks((0.15, -0.12), (-0.15, -0.12), (-0.2, 0.0))
MARK_ARGS = ["--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"]


def _starts(n, seed, lo=0.45):
    rng = np.random.default_rng(seed)
    return WallPose(rng.uniform(lo, lo + 0.2, n), rng.uniform(lo, lo + 0.2, n), np.radians(rng.uniform(-3, 3, n)))


@pytest.mark.parametrize("noise,errors", [("paper", FIG11_ERRORS), ("none", ErrorParams(1.004, 0.985))])
def test_recovers_simulator_true_poses(noise, errors):
    runs = simulate_umbmark(errors, n_runs=5, noise=noise, seed=11)
    d = distances_for_runs(MARKS, runs, _starts(len(runs), 3, lo=0.9), side_wall="auto")
    rows = [
        MeasuredRun(
            str(runs.run[i]),
            str(runs.direction[i]),
            tuple(d[i] * 1e3),
            runs.x_odo[i] * 1e3,
            runs.y_odo[i] * 1e3,
            math.degrees(runs.theta_odo[i]),
        )
        for i in range(len(runs))
    ]
    res = measure_runs(MARKS, rows, resolution_m=1e-3, side_wall="auto")
    got, m = res.runs, res.measurement
    np.testing.assert_allclose(got.x_abs, runs.x_abs, atol=1e-9)
    np.testing.assert_allclose(got.y_abs, runs.y_abs, atol=1e-9)
    np.testing.assert_allclose(got.theta_abs, runs.theta_abs, atol=1e-9)
    np.testing.assert_allclose(got.x_odo, runs.x_odo)
    assert np.all(m.x_sd > 0) and np.all(m.theta_sd > 0)


def test_rounded_tape_readings_stay_within_the_propagated_bound():
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=5)
    d = distances_for_runs(MARKS, runs, _starts(len(runs), 8))
    m = measure_runs(
        MARKS,
        [MeasuredRun(str(i), str(runs.direction[i]), tuple(np.round(d[i] * 1e3)), 0.0, 0.0) for i in range(len(runs))],
        resolution_m=1e-3,
        side_wall="auto",
    ).measurement
    for got, true, bound in (
        (m.x, runs.x_abs, m.x_bound),
        (m.y, runs.y_abs, m.y_bound),
        (m.theta, runs.theta_abs, m.theta_bound),
    ):
        err = np.abs(got - true)
        assert np.all(err <= bound * 1.001 + 1e-12)
        assert np.max(err) > 0  # rounding really changed something


def test_propagated_sd_matches_monte_carlo():
    start, end = WallPose(0.55, 0.5, 0.02), WallPose(0.9, 0.3, -0.05)
    d = np.array(distances_from_pose(MARKS, start) + distances_from_pose(MARKS, end))
    m = measure(MARKS, d, resolution_m=2e-3)
    rng = np.random.default_rng(0)
    noisy = d + rng.uniform(-1e-3, 1e-3, size=(20000, 6))  # uniform within +-resolution/2
    mc = measure(MARKS, noisy, resolution_m=0.0)
    for name in ("x", "y", "theta"):
        sd_mc = np.std(getattr(mc, name))
        assert getattr(m, name + "_sd") == pytest.approx(sd_mc, rel=0.05), name
    x, y, th = relative_pose(start, end)
    assert float(m.x) == pytest.approx(x, abs=1e-12) and float(m.theta) == pytest.approx(th, abs=1e-12)


@settings(max_examples=150, deadline=None)
@given(
    fx=st.floats(0.05, 0.4),
    rx=st.floats(-0.4, -0.05),
    fy=st.floats(-0.3, 0.3),
    dy=st.floats(-0.02, 0.02),
    bx=st.floats(-0.4, -0.1),
    by=st.floats(-0.1, 0.1),
    side=st.sampled_from(["left", "right"]),
    x=st.floats(0.5, 3.0),
    y=st.floats(0.5, 3.0),
    th=st.floats(-0.4, 0.4),
)
def test_pose_round_trip_property(fx, rx, fy, dy, bx, by, side, x, y, th):
    marks = RobotMarks((fx, fy), (rx, fy + dy), (bx, by), side)
    pose = WallPose(x, y if side == "right" else -y, th)
    got = pose_from_distances(marks, *distances_from_pose(marks, pose))
    assert float(got.x) == pytest.approx(x, abs=1e-9)
    assert float(got.y) == pytest.approx(float(pose.y), abs=1e-9)
    assert float(got.theta) == pytest.approx(th, abs=1e-9)


def test_marks_for_direction_turns_away_from_the_side_wall():
    assert marks_for_direction(MARKS, "ccw").side_wall == "right"
    cw = marks_for_direction(MARKS, "cw")
    assert cw.side_wall == "left" and cw.front == (0.15, 0.12)
    assert marks_for_direction(MARKS, "cw", "right").front == MARKS.front


def test_inconsistent_distances_name_the_line():
    text = (
        "run,direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\n"
        "1,cw,400,400,350,300,300,450,0,0\n"
        "2,cw,400,900,350,300,300,450,0,0\n"
    )
    rows = parse_distances_csv(text, "d.csv")
    with pytest.raises(InputError, match=r"d\.csv:3: front and rear distances differ by 500\.0 mm"):
        measure_runs(MARKS, rows, source="d.csv", side_wall="auto")


@pytest.mark.parametrize(
    "text,match",
    [
        ("run,direction,start_front\n1,cw,1\n", r"x\.csv:1: no header .* missing start_rear"),
        (
            "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\ncw,,,,1,2,3,0,0\n",
            r"x\.csv:2: the start distances are empty and there is no previous cw row",
        ),
        (
            "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\n"
            "cw,1,2,3,1,two,3,0,0\n",
            r"x\.csv:2: column end_rear: 'two' is not a number",
        ),
        (
            "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\nup,1,2,3,1,2,3,0,0\n",
            r"x\.csv:2: unknown direction 'up'",
        ),
        (
            "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\n"
            "cw,1,2,3,1,-2,3,0,0\n",
            r"x\.csv:2: column end_rear: a distance cannot be negative",
        ),
        (
            "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo,theta_odo\n"
            "cw,1,2,3,1,2,3,0,0,1\ncw,1,2,3,1,2,3,0,0,\n",
            r"x\.csv:3: column theta_odo is empty here",
        ),
    ],
)
def test_distances_file_errors(text, match):
    with pytest.raises(InputError, match=match):
        parse_distances_csv(text, "x.csv")


def test_empty_start_reuses_previous_row():
    text = (
        "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo\n"
        "cw,400,401,350,300,302,450,1,2\n"
        "ccw,420,421,360,300,302,450,1,2\n"
        "cw,,,,310,311,455,3,4\n"
        "ccw,,,,310,311,455,3,4\n"
    )
    rows = parse_distances_csv(text)
    assert rows[2].distances_mm[:3] == (400.0, 401.0, 350.0)  # the previous cw start, not the ccw one
    assert rows[3].distances_mm[:3] == (420.0, 421.0, 360.0)
    assert [r.run for r in rows] == ["1", "1", "2", "2"]
    with pytest.raises(InputError, match="no previous ccw row"):
        parse_distances_csv(text.replace("ccw,420,421,360", "ccw,,,"), "x.csv")


def test_guide_example_rows_measure_to_the_simulated_pose():
    """The two example rows in `umbmark guide` were made from a simulated run; they must parse
    and give back that run's true end pose within the tape's bound."""
    text = guide_text()
    lines = [ln.strip() for ln in text.splitlines() if ln.strip().startswith(("run,direction", "1,cw", "1,ccw"))]
    rows = parse_distances_csv("\n".join(lines))
    res = measure_runs(MARKS, rows, side_wall="auto")
    runs, m = res.runs, res.measurement
    truth = simulate_umbmark(FIG11_ERRORS, n_runs=1, noise="paper", seed=4)
    assert np.all(np.abs(runs.x_abs - truth.x_abs) <= m.x_bound + 1e-9)
    assert np.all(np.abs(runs.y_abs - truth.y_abs) <= m.y_bound + 1e-9)


def _example_rows():
    """data/examples/distances.csv: what a person would have measured (to the mm) on a
    simulated LabMate with the paper's Fig. 11 errors and noise, 5 runs each way."""
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=2)
    d = np.round(distances_for_runs(MARKS, runs, _starts(len(runs), 21)) * 1e3)
    out = [
        "# Simulated: LabMate with the errors of the paper's Fig. 11, the paper's noise, seed 2;",
        "# marks --front 150,-120 --rear -150,-120 --back -200,0 (mirrored for cw runs); distances to 1 mm.",
        "# Regenerated and checked by tests/test_measure.py.",
        "run,direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo,theta_odo",
    ]
    for i in range(len(runs)):
        out.append(
            ",".join(
                [str(runs.run[i]), str(runs.direction[i])]
                + [f"{v:.0f}" for v in d[i]]
                + [f"{runs.x_odo[i] * 1e3:.1f}", f"{runs.y_odo[i] * 1e3:.1f}", f"{math.degrees(runs.theta_odo[i]):.2f}"]
            )
        )
    return "\n".join(out) + "\n", runs


def test_example_distances_file_is_what_the_simulator_gives(repo_root):
    text, truth = _example_rows()
    path = repo_root / "data" / "examples" / "distances.csv"
    assert path.read_text() == text
    res = measure_runs(MARKS, parse_distances_csv(text), side_wall="auto")
    runs, m = res.runs, res.measurement
    # odometry typed to 0.1 mm, distances to 1 mm: within the tape bound (+0.1 mm)
    assert np.all(np.abs(runs.x_abs - truth.x_abs) <= m.x_bound + 1e-9)
    assert np.all(np.abs(runs.y_abs - truth.y_abs) <= m.y_bound + 1e-9)


def test_cli_measure_file_then_analyze(tmp_path, repo_root, capsys):
    out = tmp_path / "runs.csv"
    src = repo_root / "data" / "examples" / "distances.csv"
    assert main(["measure", str(src), *MARK_ARGS, "--out", str(out)]) == 0
    table = capsys.readouterr().out
    assert "Return poses in the start frame" in table and "±" in table
    runs = read_runs_csv(out)
    assert len(runs) == 10 and runs.theta_abs is not None and runs.theta_odo is not None
    assert "x_abs_sd" in out.read_text().splitlines()[0]
    assert main(["analyze", str(out), "--wheelbase-mm", "340", "--side-mm", "4000", "--json"]) == 0


def test_cli_measure_bad_point_and_missing_file(tmp_path, capsys):
    assert main(["measure", "nope.csv", *MARK_ARGS, "--out", str(tmp_path / "r.csv")]) == 2
    assert "nope.csv: file not found" in capsys.readouterr().err
    assert (
        main(
            [
                "measure",
                "nope.csv",
                "--front",
                "1;2;3",
                "--rear",
                "0,0",
                "--back",
                "0,0",
                "--out",
                str(tmp_path / "r.csv"),
            ]
        )
        == 2
    )
    assert "not two numbers" in capsys.readouterr().err
    assert main(["measure", "nope.csv", *MARK_ARGS, "--resolution-mm", "1e308", "--out", str(tmp_path / "r.csv")]) == 2
    assert "--resolution-mm must be a number from 0 to 100 " in capsys.readouterr().err
    assert not (tmp_path / "r.csv").exists()


def test_cli_measure_interactive(tmp_path):
    """Interactive entry: 1 run each way typed at the prompts; the runs file is saved."""
    truth = simulate_umbmark(FIG11_ERRORS, n_runs=1, noise="paper", seed=9)
    d = distances_for_runs(MARKS, truth, _starts(2, 1)) * 1e3
    answers = []
    for i in range(2):
        answers += [
            f"{d[i, 0]:.4f}",
            f"{d[i, 1]:.4f}",
            f"{d[i, 2]:.4f}",
            f"{truth.x_odo[i] * 1e3:.4f}",
            f"{truth.y_odo[i] * 1e3:.4f}",
            f"{math.degrees(truth.theta_odo[i]):.4f}",
            f"{d[i, 3]:.4f}",
            f"{d[i, 4]:.4f}",
            f"{d[i, 5]:.4f}",
        ]
    out = tmp_path / "runs.csv"
    res = CliRunner().invoke(
        app, ["measure", "--interactive", "--runs", "1", *MARK_ARGS, "--out", str(out)], input="\n".join(answers) + "\n"
    )
    assert res.exit_code == 0, res.output
    runs = read_runs_csv(out)
    np.testing.assert_allclose(runs.x_abs, truth.x_abs, atol=2e-6)
    np.testing.assert_allclose(runs.y_abs, truth.y_abs, atol=2e-6)
    assert (tmp_path / "runs.distances.csv").exists()


def test_format_measured_csv_reads_back():
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=2, noise="paper", seed=1)
    d = distances_for_runs(MARKS, runs, _starts(4, 2))
    rows = [
        MeasuredRun(str(i), str(runs.direction[i]), tuple(d[i] * 1e3), runs.x_odo[i] * 1e3, runs.y_odo[i] * 1e3)
        for i in range(4)
    ]
    res = measure_runs(MARKS, rows, side_wall="auto")
    got = res.runs
    from umbmark.io.runs_csv import parse_runs_csv

    back = parse_runs_csv(format_measured_csv(got, res.measurement))
    np.testing.assert_allclose(back.x_abs, got.x_abs, atol=1e-6)
    assert back.theta_odo is None and back.theta_abs is not None


def test_cli_measure_json(tmp_path, repo_root, capsys):
    import json

    src = repo_root / "data" / "examples" / "distances.csv"
    assert (
        main(["measure", str(src), *MARK_ARGS, "--resolution-mm", "2", "--out", str(tmp_path / "r.csv"), "--json"]) == 0
    )
    j = json.loads(capsys.readouterr().out)
    assert j["resolution_mm"] == 2 and len(j["runs"]) == 10
    r0 = j["runs"][0]
    assert 0 < r0["x_abs_sd_mm"] < r0["x_abs_bound_mm"] and 0 < r0["theta_abs_sd_deg"]
    # twice the resolution, twice the standard deviation (linear propagation)
    assert main(["measure", str(src), *MARK_ARGS, "--out", str(tmp_path / "r1.csv"), "--json"]) == 0
    j1 = json.loads(capsys.readouterr().out)
    assert r0["x_abs_sd_mm"] == pytest.approx(2 * j1["runs"][0]["x_abs_sd_mm"], rel=1e-6)


def test_cli_measure_interactive_without_theta_and_with_reused_start(tmp_path):
    """No odometry heading on the first run: not asked again. Enter at a start prompt reuses the
    previous start of the same direction."""
    truth = simulate_umbmark(FIG11_ERRORS, n_runs=2, noise="paper", seed=9)
    d = distances_for_runs(MARKS, truth, WallPose(0.55, 0.5, 0.0)) * 1e3
    ans = []
    for i in range(4):
        start = [f"{v:.4f}" for v in d[i, :3]] if i in (0, 2) else ["", "", ""]  # 2nd run of each: Enter
        odo = [f"{truth.x_odo[i] * 1e3:.4f}", f"{truth.y_odo[i] * 1e3:.4f}"] + ([""] if i == 0 else [])
        ans += start + odo + [f"{v:.4f}" for v in d[i, 3:]]
    out = tmp_path / "runs.csv"
    res = CliRunner().invoke(
        app, ["measure", "--interactive", "--runs", "2", *MARK_ARGS, "--out", str(out)], input="\n".join(ans) + "\n"
    )
    assert res.exit_code == 0, res.output
    runs = read_runs_csv(out)
    assert runs.theta_odo is None and len(runs) == 4
    np.testing.assert_allclose(runs.x_abs, truth.x_abs, atol=2e-6)
    np.testing.assert_allclose(runs.theta_abs, truth.theta_abs, atol=1e-6)


def test_distances_file_reads_back():
    rows = parse_distances_csv(
        "direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo,theta_odo\n"
        "cw,409,411,350,294,278,471,45.7,44.9,-1.3\n"
        "cw,,,,290,280,470.5,40,41,-1\n"
    )
    assert rows[1].distances_mm[:3] == rows[0].distances_mm[:3]  # the start reused
    back = parse_distances_csv(format_distances_csv(rows))
    assert [(r.run, r.direction, r.distances_mm, r.x_odo_mm, r.theta_odo_deg) for r in back] == [
        (r.run, r.direction, r.distances_mm, r.x_odo_mm, r.theta_odo_deg) for r in rows
    ]
