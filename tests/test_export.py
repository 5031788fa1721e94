"""Export: ROS 2 / ROS 1 diff_drive_controller parameters, JSON, firmware header. The mapping
is checked by replaying odometry the way diff_drive_controller computes it."""

import json
import math

import numpy as np
import pytest
import simlogs
import yaml

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.io.export import ExportCalibration, calibration_from_json, format_export, ros_multipliers
from umbmark.model.dataset import Dataset, Run, WheelGeometry
from umbmark.realrobot.replay import replay, replay_report


def diff_drive_odometry(pos_left, pos_right, wheel_radius, wheel_separation, left_mult, right_mult, sep_mult):
    """What diff_drive_controller computes from wheel joint positions [rad]: wheel travel =
    position x wheel_radius x side multiplier; separation = wheel_separation x multiplier;
    exact integration (Runge-Kutta 2 for tiny angular steps)."""
    rl, rr, sep = wheel_radius * left_mult, wheel_radius * right_mult, wheel_separation * sep_mult
    x = y = heading = 0.0
    old_l, old_r = pos_left[0] * rl, pos_right[0] * rr
    out = [(0.0, 0.0, 0.0)]
    for pl, pr in zip(pos_left[1:], pos_right[1:]):
        cl, cr = pl * rl, pr * rr
        dl, dr = cl - old_l, cr - old_r
        old_l, old_r = cl, cr
        linear, angular = 0.5 * (dr + dl), (dr - dl) / sep
        if abs(angular) < 1e-6:
            d = heading + 0.5 * angular
            x += linear * math.cos(d)
            y += linear * math.sin(d)
            heading += angular
        else:
            h0 = heading
            r = linear / angular
            heading += angular
            x += r * (math.sin(heading) - math.sin(h0))
            y += -r * (math.cos(heading) - math.cos(h0))
        out.append((x, y, heading))
    return np.array(out)


@pytest.mark.parametrize("multipliers", [(1.0, 1.0, 1.0), (1.01, 0.995, 1.03)])
def test_ros_multipliers_reproduce_corrected_odometry(tmp_path, multipliers):
    m_l0, m_r0, m_b0 = multipliers
    r, s = 0.05, 0.3  # the controller's wheel_radius and wheel_separation
    # the robot's odometry ran with r*m and s*m_b0: that is the nominal geometry of the logs
    nominal = WheelGeometry(2 * r * m_l0, 2 * r * m_r0, s * m_b0)
    al, ar, pose = simlogs.simulate_wheels(simlogs.general_program())
    ds = Dataset("sim", nominal, 2 * math.pi, (Run("run-01", np.arange(len(al)) * 0.02, al, ar, pose),))
    rep = replay_report(ds, "lsq", heldout=False).to_dict()
    f = tmp_path / "cal.json"
    f.write_text(json.dumps(rep))
    cal = calibration_from_json(f)
    new = ros_multipliers(cal, m_l0, m_r0, m_b0)
    pos_l, pos_r = np.cumsum(al), np.cumsum(ar)
    ddc = diff_drive_odometry(
        pos_l,
        pos_r,
        r,
        s,
        new["left_wheel_radius_multiplier"],
        new["right_wheel_radius_multiplier"],
        new["wheel_separation_multiplier"],
    )
    x, y, th, _ = replay(
        ds,
        WheelGeometry(
            rep["diameter_left_mm"] * 1e-3, rep["diameter_right_mm"] * 1e-3, rep["wheelbase_corrected_mm"] * 1e-3
        ),
    )
    assert np.allclose(ddc[:, 0], x[0], atol=1e-9) and np.allclose(ddc[:, 1], y[0], atol=1e-9)
    assert np.allclose(ddc[:, 2], th[0], atol=1e-9)
    # and both follow the true robot (noise-free logs)
    assert np.abs(ddc[:, :2] - pose[:, :2]).max() < 1e-6
    # the old multipliers do not
    old = diff_drive_odometry(pos_l, pos_r, r, s, m_l0, m_r0, m_b0)
    assert np.abs(old[:, :2] - pose[:, :2]).max() > 0.05


def test_ros2_and_ros1_yaml(tmp_path):
    cal = ExportCalibration(0.999, 1.001, 0.98)
    d2 = yaml.safe_load(format_export(cal, "ros2", "my_ctrl", 1.0, 1.0, 1.02))
    p = d2["my_ctrl"]["ros__parameters"]
    assert p == {
        "wheel_separation_multiplier": pytest.approx(0.98 * 1.02),
        "left_wheel_radius_multiplier": pytest.approx(0.999),
        "right_wheel_radius_multiplier": pytest.approx(1.001),
    }
    d1 = yaml.safe_load(format_export(cal, "ros1", "mobile_base_controller", wheel_radius_m=0.05))
    assert d1["mobile_base_controller"]["wheel_radius"] == 0.05
    assert d1["mobile_base_controller"]["left_wheel_radius_multiplier"] == pytest.approx(0.999)
    with pytest.raises(InputError):
        format_export(cal, "ros2", "bad name")


def test_json_and_firmware():
    cal = ExportCalibration(0.999, 1.001, 0.98, 0.084, 0.084, 0.2, 43.7 * 64)
    d = json.loads(format_export(cal, "json"))
    assert d["diameter_left_mm"] == pytest.approx(84 * 0.999)
    assert d["wheelbase_mm"] == pytest.approx(196.0)
    assert d["left_mm_per_pulse"] == pytest.approx(math.pi * 84 * 0.999 / (43.7 * 64))
    h = format_export(cal, "firmware")
    assert "#define UMBMARK_LEFT_MM_PER_PULSE" in h and f"{d['right_mm_per_pulse']:.9g}" in h
    with pytest.raises(InputError, match="pulses per wheel"):
        format_export(ExportCalibration(1.0, 1.0, 1.0), "firmware")


def test_cli_export_from_replay_json(optiodom, tmp_path, capsys):
    assert main(["replay", str(optiodom / "square/230620202144"), "--json"]) == 0
    cal = tmp_path / "cal.json"
    cal.write_text(capsys.readouterr().out)
    rep = json.loads(cal.read_text())
    out = tmp_path / "params.yaml"
    assert main(["export", str(cal), "--format", "ros2", "--out", str(out)]) == 0
    p = yaml.safe_load(out.read_text())["diff_drive_controller"]["ros__parameters"]
    assert set(p) == {"wheel_separation_multiplier", "left_wheel_radius_multiplier", "right_wheel_radius_multiplier"}
    assert p["wheel_separation_multiplier"] == pytest.approx(rep["wheelbase_corrected_mm"] / 205.0)
    assert p["left_wheel_radius_multiplier"] == pytest.approx(rep["c_left"])
    capsys.readouterr()
    assert main(["export", str(cal), "--format", "firmware"]) == 0
    assert "UMBMARK_RIGHT_MM_PER_PULSE" in capsys.readouterr().out
    # from analyze's JSON too
    assert (
        main(["convert", str(optiodom / "square/230620202144"), "--to", "runs", "--out", str(tmp_path / "runs.csv")])
        == 0
    )
    capsys.readouterr()
    assert main(["analyze", str(tmp_path / "runs.csv"), "--wheelbase-mm", "205", "--side-mm", "750", "--json"]) == 0
    an = tmp_path / "an.json"
    an.write_text(capsys.readouterr().out)
    assert main(["export", str(an), "--format", "ros1"]) == 0
    p1 = yaml.safe_load(capsys.readouterr().out)["diff_drive_controller"]
    assert p1["wheel_separation_multiplier"] == pytest.approx(p["wheel_separation_multiplier"], rel=1e-9)


@pytest.mark.parametrize(
    "content, msg",
    [
        ("{not json", "not valid JSON"),
        ('{"a": 1}', "no 'c_left'"),
        ('{"c_left": 1, "c_right": -1, "Eb": 1}', "c_right must be a positive number"),
        ('{"c_left": 1, "c_right": 1, "wheelbase_corrected_mm": 300, "nominal": "x"}', "'nominal' must be an object"),
        (
            '{"c_left": 1, "c_right": 1, "Eb": 1, "nominal": {"diameter_left_mm": "84"}}',
            "nominal diameter_left_mm must be a positive number",
        ),
        ("[" * 100000 + "]" * 100000, "nested too deeply"),
    ],
)
def test_cli_export_errors(tmp_path, capsys, content, msg):
    f = tmp_path / "cal.json"
    f.write_text(content)
    assert main(["export", str(f), "--format", "ros2"]) == 2
    err = capsys.readouterr().err
    assert msg in err and str(f) in err and err.count("\n") == 1
    assert main(["export", "--format", "ros2", "--c-left", "1"]) == 2


# -- absurd values, plausibility, the wheel scale ------------------------------------------------


@pytest.mark.parametrize(
    "fields, msg",
    [
        ({"c_left": 1e308}, "c_left = 1e+308 is not a correction factor"),
        ({"c_right": 1e-300}, "c_right = 1e-300 is not a correction factor"),
        ({"Eb": 1e-300, "wheelbase_corrected_mm": None}, "eb = 1e-300 is not a correction factor"),
        ({"c_left": float("inf")}, "c_left must be a positive number"),
        ({"c_left": -1.0}, "c_left must be a positive number"),
        ({"c_left": 0.0}, "c_left must be a positive number"),
        ({"c_left": "1.0"}, "c_left must be a positive number"),
        ({"c_left": True}, "c_left must be a positive number"),
    ],
)
def test_absurd_factors_are_refused(tmp_path, capsys, fields, msg):
    d = {
        "method": "bf",
        "c_left": 1.0,
        "c_right": 1.0,
        "Eb": 1.0,
        "wheelbase_mm": 340.0,
        "wheelbase_corrected_mm": 340.0,
    }
    d.update(fields)
    d = {k: v for k, v in d.items() if v is not None}
    f = tmp_path / "cal.json"
    f.write_text(json.dumps(d).replace("Infinity", "1e999"))
    out = tmp_path / "out.h"
    for fmt in ("json", "ros2", "firmware"):
        code = main(
            ["export", str(f), "--format", fmt, "--out", str(out), "--wheel-diameter-mm", "150"]
            + ["--pulses-per-wheel-rev", "1000"]
        )
        err = capsys.readouterr().err
        assert code == 2 and msg in err and len(err.strip().splitlines()) == 1, err
        assert not out.exists()


def test_absurd_written_values_are_refused(capsys):
    """Factors that are fine, a nominal geometry or multiplier that makes the written value absurd."""
    cal = ExportCalibration(1.0, 1.0, 1.0, 0.15, 0.15, 0.34, 1000.0)
    with pytest.raises(InputError, match=r"wheel_separation_multiplier in use \(`separation_multiplier`\) is 1e-300"):
        format_export(cal, "ros2", separation0=1e-300)
    with pytest.raises(InputError, match="left_wheel_radius_multiplier"):
        format_export(ExportCalibration(900.0, 1.0, 1.0), "ros2", left0=900.0)
    with pytest.raises(InputError, match="left_mm_per_pulse"):
        format_export(ExportCalibration(1.0, 1.0, 1.0, 3.0, 3.0, 0.34, 1e-9), "firmware")
    with pytest.raises(InputError, match="nominal_diameter_left_mm: 1e\\+08 mm is no wheel's diameter"):
        ExportCalibration(1.0, 1.0, 1.0, 1e5, 1e5, 0.34, 1e-5)  # a size no robot has: refused as such
    with pytest.raises(InputError, match="pulses_per_wheel_rev = 1e-300"):
        ExportCalibration(1.0, 1.0, 1.0, 0.15, 0.15, 0.34, 1e-300)
    with pytest.raises(InputError, match="nominal_diameter_left_mm = 1e\\+308"):
        ExportCalibration(1.0, 1.0, 1.0, 1e305, 0.15, 0.34, 1000.0)
    with pytest.raises(InputError, match="wheel radius"):
        format_export(cal, "ros2", wheel_radius_m=1e300)
    # the command line: one line, exit 2
    for args in (
        ["--c-left", "1e308", "--c-right", "1", "--eb", "1", "--format", "json"],
        ["--c-left", "1", "--c-right", "1", "--eb", "1", "--format", "ros2", "--separation-multiplier", "1e-300"],
        ["--c-left", "1", "--c-right", "1", "--eb", "1e-300", "--format", "ros2"],
    ):
        assert main(["export", *args]) == 2
        err = capsys.readouterr().err
        why = "no controller runs with a multiplier" if "--separation-multiplier" in args else "not a correction factor"
        assert why in err and len(err.strip().splitlines()) == 1


def test_implausible_factors_are_warned_about(capsys):
    code = main(["export", "--c-left", "50", "--c-right", "0.02", "--eb", "1", "--format", "json"])
    cap = capsys.readouterr()
    assert code == 0
    d = json.loads(cap.out)
    assert d["c_left"] == 50 and d["c_right"] == 0.02
    assert any(w.startswith("c_left = 50 is far outside") for w in d["warnings"])
    assert any(w.startswith("c_right = 0.02 is far outside") for w in d["warnings"])
    assert any(w.startswith("E_d = c_right / c_left = 0.0004") for w in d["warnings"])
    assert cap.err.count("warning: ") == 3
    # ros: in the file as comments, and the composed multiplier is checked too
    code = main(
        ["export", "--c-left", "1.01", "--c-right", "0.99", "--eb", "1.4", "--format", "ros2"]
        + ["--separation-multiplier", "1.6"]
    )
    cap = capsys.readouterr()
    assert code == 0
    assert "wheel_separation_multiplier = 2.24 is far outside" in cap.err
    assert "# warning: wheel_separation_multiplier = 2.24" in cap.out
    assert yaml.safe_load(cap.out)["diff_drive_controller"]["ros__parameters"]["wheel_separation_multiplier"] == (
        pytest.approx(2.24)
    )
    # a real calibration: no warning
    assert main(["export", "--c-left", "1.01", "--c-right", "0.99", "--eb", "0.97", "--format", "json"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["warnings"] == [] and cap.err == ""


@pytest.fixture(scope="module")
def analyses(tmp_path_factory):
    """The analyze JSON of one simulated test (wheel scale 1.003) by bf, exact, and exact with a
    straight run."""
    import contextlib
    import io

    d = tmp_path_factory.mktemp("scale")
    runs = d / "runs.csv"
    sim = ["-q", "simulate", "--ed", "1.004", "--eb", "0.99", "--es", "1.003", "--seed", "4", "--noise", "none"]
    assert main([*sim, "--out", str(runs)]) == 0
    out = {}
    for key, extra in (("bf", []), ("exact", []), ("straight", ["--straight-mm", "4000", "4012"])):
        method = "bf" if key == "bf" else "exact"
        args = ["analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--method", method, *extra]
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
            assert main([*args, "--json"]) == 0
        out[key] = d / f"{key}.json"
        out[key].write_text(buf.getvalue())
    return out


@pytest.mark.parametrize("fmt", ["json", "ros2", "ros1", "firmware"])
def test_a_scale_the_method_cannot_see_is_said(analyses, capsys, fmt):
    """bf and exact on closed squares cannot see the wheel scale: the export says so (file and
    warning) and names how to measure it; exact with a straight run and lsq did measure it."""
    extra = ["--wheel-diameter-mm", "150", "--pulses-per-wheel-rev", "1000"] if fmt == "firmware" else []
    for key, method, said in (("bf", "bf", True), ("exact", "exact", True), ("straight", "exact", False)):
        cal = analyses[key]
        assert main(["export", str(cal), "--format", fmt, *extra]) == 0
        cap = capsys.readouterr()
        assert ("wheel scale not measured" in cap.out) == said, key
        assert ("wheel scale not measured" in cap.err) == said
        if said:
            assert f"{method} cannot see it" in cap.err
            assert "--straight-mm" in cap.err and "lsq" in cap.err
            assert "straight_mm" in cap.out and "lsq" in cap.out
        if fmt == "json":
            d = json.loads(cap.out)
            assert d["scale_observed"] is (not said)
            assert ("scale_note" in d) == said


def test_lsq_and_selfcal_measure_the_scale(optiodom, tmp_path, capsys):
    optiodom = optiodom / "square" / "230620202144"
    save = tmp_path / "lsq.json"
    assert main(["-q", "replay", str(optiodom), "--method", "lsq", "--no-heldout", "--save", str(save)]) == 0
    assert main(["export", str(save), "--format", "json"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["scale_observed"] is True and "scale" not in cap.err
    fixed = tmp_path / "fixed.json"
    assert (
        main(
            ["-q", "replay", str(optiodom), "--method", "lsq", "--scale", "fixed", "--no-heldout"]
            + ["--save", str(fixed)]
        )
        == 0
    )
    assert main(["export", str(fixed), "--format", "ros2"]) == 0
    cap = capsys.readouterr()
    assert "wheel scale not measured: lsq cannot see it" in cap.err
    assert calibration_from_json(fixed).scale_observed is False
    cal = ExportCalibration(1.0, 1.0, 1.0, source="x", method="selfcal", scale_observed=True)
    assert "scale" not in format_export(cal, "json").split('"warnings"')[1]


def test_the_json_of_calibrate_is_read(tmp_path, capsys):
    assert main(["calibrate", "--ed", "1.02", "--eb", "0.95", "--seed", "1", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    f = tmp_path / "loop.json"
    f.write_text(json.dumps(d))
    cal = calibration_from_json(f)
    final = d["final_calibration"]
    assert cal.c_left == final["c_left"] and cal.c_right == final["c_right"]
    assert cal.eb * cal.nominal_wheelbase_m * 1e3 == pytest.approx(final["wheelbase_mm"], rel=1e-12)
    assert cal.scale_observed is False
    f.write_text(json.dumps({**d, "final_calibration": None}))
    with pytest.raises(InputError, match="no final calibration"):
        calibration_from_json(f)


def test_the_calibrations_own_warnings_are_passed_on(tmp_path, capsys):
    """A warning in the calibration's JSON (here a selfcal result's) reaches the JSON export as
    input_warnings; an input without warnings gives an empty list."""
    d = {
        "method": "selfcal",
        "wheel_diameter_left_mm": 202.0,
        "wheel_diameter_right_mm": 202.4,
        "Eb": 0.95,
        "nominal_wheel_diameter_mm": 200.0,
        "nominal_wheelbase_mm": 400.0,
        "sensor_pose": {"x_mm": -54.0, "y_mm": -4.0, "yaw_deg": 1.2},
        "warnings": ["the estimated sensor pose differs from /tf_static base_link -> laser by 54 mm"],
    }
    src = tmp_path / "selfcal.json"
    src.write_text(json.dumps(d))
    assert calibration_from_json(src).input_warnings == tuple(d["warnings"])
    assert main(["export", str(src), "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["input_warnings"] == d["warnings"]
    src.write_text(json.dumps({**d, "warnings": []}))
    assert main(["export", str(src), "--format", "json"]) == 0
    assert json.loads(capsys.readouterr().out)["input_warnings"] == []
