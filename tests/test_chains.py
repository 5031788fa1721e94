"""Chains of commands that pass a calibration along: what ``umbmark export`` writes from the file
one command saved is what that command printed (no correction applied twice, none lost).

Chains: analyze --json -> export; replay --save / --json -> export; selfcal --save -> export;
calibrate --json -> export; analyze --record -> history --export -> export.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re

import pytest
import yaml

from umbmark.cli import main

OPTIODOM = "data/optiodom/square/230620202144"


def run(args: list[str]) -> str:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    assert code == 0, (args, err.getvalue())
    return out.getvalue()


def exports(cal, *extra: str) -> dict:
    """The json, ros2 and firmware exports of a calibration file, parsed."""
    j = json.loads(run(["export", str(cal), "--format", "json", *extra]))
    ros = yaml.safe_load(run(["export", str(cal), "--format", "ros2", *extra]))
    return {"json": j, "ros2": ros["diff_drive_controller"]["ros__parameters"], "extra": extra}


def firmware(cal, *extra: str) -> dict[str, float]:
    text = run(["export", str(cal), "--format", "firmware", *extra])
    return {m.group(1): float(m.group(2)) for m in re.finditer(r"#define UMBMARK_(\w+)[ \t]+(\S+)", text)}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("chains")
    f = d / "runs.csv"
    run(["-q", "simulate", "--ed", "1.006", "--eb", "0.985", "--seed", "7", "--out", str(f)])
    return f


@pytest.mark.parametrize("method", ["bf", "exact"])
@pytest.mark.parametrize("prior", [[], ["--c-left", "1.004", "--c-right", "0.996"]], ids=["nominal", "prior"])
def test_analyze_then_export(runs, tmp_path, method, prior):
    """analyze prints c_left, c_right and the corrected wheelbase; its JSON exported gives them."""
    args = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--method", method, *prior]
    printed = run(args)
    a = json.loads(run([*args, "--json"]))
    cal = tmp_path / "a.json"
    cal.write_text(json.dumps(a))
    e = exports(cal)
    assert e["json"]["c_left"] == a["c_left"] and e["json"]["c_right"] == a["c_right"]
    assert e["json"]["wheelbase_mm"] == pytest.approx(a["wheelbase_corrected_mm"], rel=1e-14)
    assert e["ros2"]["left_wheel_radius_multiplier"] == a["c_left"]
    assert e["ros2"]["right_wheel_radius_multiplier"] == a["c_right"]
    assert e["ros2"]["wheel_separation_multiplier"] * 340 == pytest.approx(a["wheelbase_corrected_mm"], rel=1e-14)
    fw = firmware(cal, "--wheel-diameter-mm", "150", "--pulses-per-wheel-rev", "1000")
    assert fw["WHEELBASE_MM"] == pytest.approx(a["wheelbase_corrected_mm"], abs=1e-6)
    assert fw["LEFT_MM_PER_PULSE"] == pytest.approx(a["c_left"] * 150 * math.pi / 1000, rel=1e-8)
    # the table shows the same numbers
    assert f"c_left = {a['c_left']:.6f}" in printed or f"{a['c_left']:.6f}" in printed
    assert f"-> {a['wheelbase_corrected_mm']:.2f}" in printed


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    d = tmp_path_factory.mktemp("replay")
    out = {}
    for method in ("bf", "exact", "lsq"):
        save = d / f"{method}.json"
        printed = json.loads(
            run(["replay", OPTIODOM, "--method", method, "--no-heldout", "--save", str(save), "--json"])
        )
        out[method] = (save, printed)
    return out


@pytest.mark.parametrize("method", ["bf", "exact", "lsq"])
def test_replay_then_export(replayed, method):
    save, r = replayed[method]
    assert json.loads(save.read_text()) == r  # --save holds what --json printed
    e = exports(save)
    j = e["json"]
    assert j["c_left"] == r["c_left"] and j["c_right"] == r["c_right"]
    assert j["diameter_left_mm"] == pytest.approx(r["diameter_left_mm"], rel=1e-14)
    assert j["diameter_right_mm"] == pytest.approx(r["diameter_right_mm"], rel=1e-14)
    assert j["wheelbase_mm"] == pytest.approx(r["wheelbase_corrected_mm"], rel=1e-14)
    assert j["Eb"] == pytest.approx(r["Eb"], rel=1e-12) and j["Ed"] == pytest.approx(r["Ed"], rel=1e-12)
    assert e["ros2"]["wheel_separation_multiplier"] == pytest.approx(r["Eb"], rel=1e-12)
    fw = firmware(save)
    upr = r["nominal"]["units_per_wheel_rev"]
    assert fw["LEFT_MM_PER_PULSE"] == pytest.approx(r["diameter_left_mm"] * math.pi / upr, rel=1e-8)
    assert fw["RIGHT_MM_PER_PULSE"] == pytest.approx(r["diameter_right_mm"] * math.pi / upr, rel=1e-8)
    assert fw["WHEELBASE_MM"] == pytest.approx(r["wheelbase_corrected_mm"], abs=1e-6)


def test_replay_with_multipliers_in_use(replayed):
    """Logs recorded with multipliers: the new ones are the old ones times the calibration."""
    save, r = replayed["bf"]
    e = exports(save, "--left-multiplier", "1.01", "--right-multiplier", "0.99", "--separation-multiplier", "1.05")
    assert e["ros2"]["left_wheel_radius_multiplier"] == pytest.approx(1.01 * r["c_left"], rel=1e-14)
    assert e["ros2"]["right_wheel_radius_multiplier"] == pytest.approx(0.99 * r["c_right"], rel=1e-14)
    assert e["ros2"]["wheel_separation_multiplier"] == pytest.approx(1.05 * r["Eb"], rel=1e-14)


def test_calibrate_then_export(tmp_path):
    printed = run(["calibrate", "--ed", "1.02", "--eb", "0.95", "--seed", "1"])
    c = json.loads(run(["calibrate", "--ed", "1.02", "--eb", "0.95", "--seed", "1", "--json"]))
    final = c["final_calibration"]
    cal = tmp_path / "loop.json"
    cal.write_text(json.dumps(c))
    e = exports(cal)
    assert e["json"]["c_left"] == final["c_left"] and e["json"]["c_right"] == final["c_right"]
    assert e["json"]["wheelbase_mm"] == pytest.approx(final["wheelbase_mm"], rel=1e-14)
    assert e["ros2"]["wheel_separation_multiplier"] * 340 == pytest.approx(final["wheelbase_mm"], rel=1e-14)
    assert f"c_left = {final['c_left']:.6f}" in printed and f"wheelbase = {final['wheelbase_mm']:.2f} mm" in printed


@pytest.fixture(scope="module")
def selfcal_result(tmp_path_factory):
    pytest.importorskip("rosbags")
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import SimRobot, mixed_program, simulate_drive
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.sensors import Lidar, SensorPose

    robot = SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.006, eb=0.98, es=1.004),
        sensor_pose=SensorPose(0.08, -0.01, math.radians(2.0)),
        lidar=Lidar(n_beams=180, range_noise_m=0.003),
    )
    d = tmp_path_factory.mktemp("selfcal")
    bag = write_drive_bag(simulate_drive(mixed_program(40.0, seed=4, robot=robot), robot, seed=5), d / "drive")
    save = d / "selfcal.json"
    geo = ["--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--joints", "left_wheel_joint,right_wheel_joint"]
    printed = json.loads(run(["selfcal", str(bag), *geo, "--save", str(save), "--json"]))
    return save, printed


def test_selfcal_then_export(selfcal_result):
    save, s = selfcal_result
    e = exports(save)
    j = e["json"]
    assert j["diameter_left_mm"] == pytest.approx(s["wheel_diameter_left_mm"], rel=1e-14)
    assert j["diameter_right_mm"] == pytest.approx(s["wheel_diameter_right_mm"], rel=1e-14)
    assert j["wheelbase_mm"] == pytest.approx(s["wheelbase_mm"], rel=1e-12)
    for k in ("x_mm", "y_mm", "yaw_deg"):
        assert j["sensor_pose"][k] == pytest.approx(s["sensor_pose"][k], rel=1e-12, abs=1e-12)
    assert e["ros2"]["left_wheel_radius_multiplier"] == pytest.approx(s["wheel_diameter_left_mm"] / 150, rel=1e-14)
    assert e["ros2"]["wheel_separation_multiplier"] == pytest.approx(s["wheelbase_mm"] / 340, rel=1e-12)
    assert j["scale_observed"] is True and j["warnings"] == []


def test_history_then_export(runs, tmp_path):
    """analyze --record, history --export, export: the parameters the record recommends."""
    db = tmp_path / "h.sqlite"
    args = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--c-left", "1.002"]
    args += ["--c-right", "0.998"]
    a = json.loads(run([*args, "--json"]))
    run(["-q", *args, "--robot", "r1", "--record", "--db", str(db)])
    for name in ("p.json", "p.yaml"):
        p = tmp_path / name
        run(["-q", "history", "r1", "--db", str(db), "--export", str(p)])
        if name.endswith(".yaml"):
            continue  # the YAML export is for people and ROS; export reads the JSON one
        e = exports(p)
        assert e["json"]["c_left"] == pytest.approx(a["c_left"], rel=1e-12)
        assert e["json"]["c_right"] == pytest.approx(a["c_right"], rel=1e-12)
        assert e["json"]["wheelbase_mm"] == pytest.approx(a["wheelbase_corrected_mm"], rel=1e-12)
        fw = firmware(p, "--wheel-diameter-mm", "150", "--pulses-per-wheel-rev", "1000")
        assert fw["WHEELBASE_MM"] == pytest.approx(a["wheelbase_corrected_mm"], abs=1e-6)


def test_a_prior_in_the_analysis_is_not_applied_twice_without_a_word(runs, tmp_path, capsys):
    """analyze given the robot's calibration (--c-left/--c-right) prints total wheel factors;
    exported with the multipliers in use they would be applied twice: export says so."""
    args = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--c-left", "1.004"]
    a = json.loads(run([*args, "--c-right", "0.996", "--json"]))
    cal = tmp_path / "a.json"
    cal.write_text(json.dumps(a))
    capsys.readouterr()
    assert (
        main(["export", str(cal), "--format", "ros2", "--left-multiplier", "1.004", "--right-multiplier", "0.996"]) == 0
    )
    cap = capsys.readouterr()
    assert "already include the wheel factors the robot ran with" in cap.err
    assert "# warning: c_left and c_right of this calibration already include" in cap.out
    # without multipliers, or from an analysis without a prior: no such warning
    assert main(["export", str(cal), "--format", "ros2"]) == 0
    assert "already include" not in capsys.readouterr().err
    b = json.loads(run(["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--json"]))
    cal.write_text(json.dumps(b))
    assert main(["export", str(cal), "--format", "ros2", "--left-multiplier", "1.004"]) == 0
    assert "already include" not in capsys.readouterr().err
