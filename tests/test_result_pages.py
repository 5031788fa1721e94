"""The report pages of a calibration loop and of a gyro result (umbmark report FILE.json, --id N)."""

from __future__ import annotations

import json
import math

from umbmark.cli import main
from umbmark.viz.result_pages import calibrate_page, gyro_page, is_calibrate_result, is_gyro_result


class _Out:
    def __init__(self, code, out, err):
        self.exit_code, self.output = code, out + err


def _run(*args):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in args])
    return _Out(rc, out.getvalue(), err.getvalue())


def _gyro_result(eb=1.6):
    turns = [
        {"source": "b", "t_s": [1e9 + 10 * i, 1e9 + 10 * i + 8], "wheels_deg": 360 * eb * s, "gyro_deg": 360.0 * s,
         "true_deg": 360.0 * s, "travel_mm": 0.0, "on_the_spot": True, "used": True}
        for i, s in enumerate((1, -1, 1))
    ]  # fmt: skip
    g = {"imu_topic": "/imu", "wheelbase_m": 0.4 * eb, "wheelbase_m_ci95": [0.4 * eb - 0.001, 0.4 * eb + 0.001],
         "nominal_wheelbase_m": 0.4, "Eb": eb, "Eb_ci95": [eb - 0.0025, eb + 0.0025], "wheel_separation_multiplier": eb,
         "gyro_scale": 1.0, "gyro_scale_ci95": None, "gyro_scale_source": "assumed", "bias_rad_per_s": 0.01,
         "noise_rad_per_s": 0.005, "still_s": 7.0, "readings": 500, "turns_used": 3, "turns": turns,
         "warnings": []}  # fmt: skip
    return {"gyro": g, "warnings": ["the gyro's scale is assumed"]}


def test_a_calibration_loop_page_holds_its_passes_and_the_calibration_to_load(tmp_path):
    out = _run("calibrate", "--json", "--seed", "1")
    assert out.exit_code == 0
    d = json.loads(out.output)
    assert is_calibrate_result(d) and not is_gyro_result(d)
    f = tmp_path / "cal.json"
    f.write_text(out.output)
    page_path = tmp_path / "cal.html"
    r = _run("report", f, "--out", page_path)
    assert r.exit_code == 0, r.output
    page = page_path.read_text()
    assert f"{d['final_calibration']['c_left']:.6f}" in page and f"{d['final_calibration']['wheelbase_mm']:.2f}" in page
    assert page.count("<tr>") >= len(d["passes"]) + 1 and "data:image/png;base64," in page
    n, c = len(d["passes"]), d["corrections"]
    assert f"<p>{n} pass{'' if n == 1 else 'es'}, {c} correction{'' if c == 1 else 's'} (" in page
    assert "wheel_radius_multiplier" in page or "radius" in page  # the ROS 2 parameters it writes
    r = _run("report", f, "--out", tmp_path / "x.html", "--wheelbase-mm", "340")
    assert r.exit_code == 2 and "--wheelbase-mm" in r.output


def test_a_recorded_calibration_loop_is_reported_by_id(tmp_path):
    db = tmp_path / "h.sqlite"
    out = _run("calibrate", "--seed", "2", "--robot", "r1", "--record", "--db", db, "--json")
    assert out.exit_code == 0, out.output
    rid = json.loads(out.output)["history"]["record_id"]
    r = _run("report", "--id", rid, "--db", db, "--out", tmp_path / "c.html")
    assert r.exit_code == 0, r.output
    page = (tmp_path / "c.html").read_text()
    assert "robot r1" in page and f"record #{rid}" in page


def test_a_gyro_page_holds_the_wheelbase_its_interval_and_each_turn(tmp_path):
    d = _gyro_result(1.6)
    assert is_gyro_result(d) and not is_calibrate_result(d)
    f = tmp_path / "gyro.json"
    f.write_text(json.dumps(d))
    r = _run("report", f, "--out", tmp_path / "g.html")
    assert r.exit_code == 0, r.output
    page = (tmp_path / "g.html").read_text()
    assert "640.00" in page and "[639.00, 641.00]" in page and "[1.59750, 1.60250]" in page
    assert "0.00 to 8.00" in page and "20.00 to 28.00" in page  # times from the first turn, not epoch seconds
    assert "wheel_separation_multiplier: 1.60000" in page and "the gyro&#x27;s scale is assumed" in page
    assert f"{math.degrees(0.01):.4f} deg/s" in page


def test_pages_survive_damaged_values():
    d = _gyro_result()
    d["gyro"]["Eb"] = "x"
    d["gyro"]["turns"][0]["wheels_deg"] = None
    d["gyro"]["wheelbase_m_ci95"] = ["a", 1]
    assert "<html" in gyro_page(d)
    c = {"passes": [{"pass": 1, "emax_syst_mm": "?", "correction": None}], "final_calibration": {"c_left": None}}
    assert "<html" in calibrate_page(c)
