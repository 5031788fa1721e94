"""Every command for every kind of robot (umbmark.kinds), on a short simulated drive of a tricycle
and of a mecanum robot: selfcal --save --robot --record --db (the history keeps the kind's own
parameters, a recording once), --window, drift, history --export, report (a saved result and a
record), validate against the base's true trajectory and the lidar's true relations with the
kind's joint flags, export --record; the features a kind has not, one line each (exit 2)."""

from __future__ import annotations

import contextlib
import io
import json

import pytest

pytest.importorskip("rosbags")
from kinematic_bags import ROBOTS, write_short_drive  # noqa: E402
from pages import check_page  # noqa: E402

from umbmark.cli import main  # noqa: E402
from umbmark.history import open_history  # noqa: E402
from umbmark.kinds import kind_named  # noqa: E402


def run(*args, code=0) -> str:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in args])
    assert rc == code, (rc, err.getvalue()[-800:], out.getvalue()[-300:])
    if code != 2:  # 0, or an alarm (3)
        return out.getvalue()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("umbmark: error: ") and "Traceback" not in err.getvalue(), lines
    return lines[0]


@pytest.fixture(scope="module", params=list(ROBOTS))
def kind(request, tmp_path_factory):
    """A kind's short drive, self-calibrated, saved and recorded (robot R in db.sqlite)."""
    tmp = tmp_path_factory.mktemp(request.param)
    drive = write_short_drive(tmp, request.param)
    db, cal = tmp / "db.sqlite", tmp / "cal.json"
    head = ["-q", "selfcal", drive["bag"], "--kinematics", request.param, *drive["joints"], *drive["sizes"]]
    d = json.loads(run(*head, "--save", cal, "--robot", "R", "--record", "--db", db, "--json"))
    return {"name": request.param, "tmp": tmp, "db": db, "cal": cal, "d": d, "head": head, **drive}


def test_selfcal_records_the_kinds_own_parameters_once(kind):
    d, k = kind["d"], kind_named(kind["name"])
    assert d["history"]["robot"] == "R" and d["kinematics"] == k.name and d["figures"]["maps"]
    with open_history(kind["db"], create=False) as h:
        rec = h.latest("R")
    assert rec.kind == "selfcal" and rec.method == "selfcal" and rec.input_sha256
    assert rec.parameters["kinematics"] == rec.parameters_in_use["kinematics"] == k.name
    for p in k.parameters:  # the kind's parameters under its keys, the nominal ones in use
        assert p.key[0] in rec.parameters and p.key[0] in rec.parameters_in_use
    assert set(rec.parameters["sensor_pose"]) == {"x_mm", "y_mm", "yaw_deg"}
    again = run(*kind["head"], "--robot", "R", "--record", "--db", kind["db"], code=2)
    assert f"holds this recording already: record #{rec.id}" in again
    exported = json.loads(run("history", "R", "--db", kind["db"], "--export", "-"))
    assert exported["kinematics"] == k.name and exported["controller"] == k.controller
    assert exported["controller_parameters"] == k.ros2_parameters(k.geometry_from_json(rec.parameters, "-")[0])


def test_drift_reads_the_record_and_follows_the_kinds_parameters_over_windows(kind):
    out = json.loads(run("drift", "R", "--db", kind["db"], "--json"))
    assert out["sessions"] == 1 and not out["alarm"]
    assert any("4 needed" in n for n in out["notes"])
    k = kind_named(kind["name"])
    db = kind["tmp"] / "windows.sqlite"
    d = json.loads(run(*kind["head"], "--window", "12s", "--robot", "W", "--record", "--db", db, "--json"))
    wins = [w for w in d["windows"] if w["result"] is not None]
    assert len(wins) >= 4 and all("figures" not in w["result"] and w["history"] for w in wins)
    trends = json.loads(run("drift", "W", "--db", db, "--json"))["trends"]
    estimated = {p.path for p in k.parameters if p.name in k.default_fit()}  # not a steering scale held at 1
    assert estimated | {"sensor_pose.x_mm", "sensor_pose.y_mm", "sensor_pose.yaw_deg"} == set(trends)
    assert {t["sessions"] for t in trends.values()} == {len(wins)}


def test_report_shows_the_kinds_estimates_and_figures(kind):
    k = kind_named(kind["name"])
    out = kind["tmp"] / "page.html"
    summary = json.loads(run("report", kind["cal"], "--out", out, "--json"))
    assert summary["kinematics"] == k.name and summary["maps"] == 1
    page = out.read_text()
    c = check_page(page)
    assert len(c.images) == 3  # the map before and after, the lidar on the robot, the residuals
    for p, v, ci in k.estimates_json(kind["d"]):
        if ci is not None:  # each estimate with its interval, in the table
            assert p.table_label in page and f"{v:.{p.digits}f}" in page and f"{ci[0]:.{p.digits}f} to" in page
    assert k.controller in page and "The map, before and after" in page
    rid = kind["d"]["history"]["record_id"]
    run("report", "--id", rid, "--db", kind["db"], "--out", kind["tmp"] / "record.html")
    assert f"{kind['d']['sensor_pose']['x_mm']:.2f}" in (kind["tmp"] / "record.html").read_text()
    run("report", "--robot", "R", "--db", kind["db"], "--out", kind["tmp"] / "history.html")
    history = (kind["tmp"] / "history.html").read_text()
    check_page(history)  # the robot's history: its kind's table, the plot of its parameters
    assert f"<h3>{k.title}</h3>" in history and k.controller in history and "D_L [mm]" not in history


@pytest.mark.parametrize("reference", ["--reference", "--relations"])
def test_validate_with_the_kinds_joints_passes_against_the_truth(kind, reference):
    ref = kind["tum"] if reference == "--reference" else kind["relations"]
    args = ["validate", kind["bag"], kind["cal"], *kind["joints"], reference, ref, "--fail-on-worse", "--json"]
    v = json.loads(run(*args))
    assert v["verdict"] == "pass" and v["calibration"]["kinematics"] == kind["name"]
    span = v["spans"][0]
    for rule in span["rules"]:
        assert rule["passed"] is not False, rule
    assert span["after"]["short"]["translation"]["mse_m2"] < 0.2 * span["before"]["short"]["translation"]["mse_m2"]
    if reference == "--reference":  # a true base trajectory, not a SLAM's: each odometry through its lidar pose
        assert v["reference"]["base_trajectory"] == "true"


def test_the_features_a_kind_has_not_are_one_line_each(kind):
    base = ["validate", kind["bag"], kind["cal"], "--reference", kind["tum"]]
    missing = run(*base, code=2)  # the kind's joint flags named
    assert all(a in missing for a in kind["joints"] if a.startswith("--"))
    assert "--ticks-topic is a differential drive's" in run(*base, *kind["joints"], "--ticks-topic", "/t", code=2)
    assert "--wheelbase-mm is a differential drive's" in run(*base, *kind["joints"], "--wheelbase-mm", "300", code=2)
    jitter = run(*kind["head"], "--no-wheel-jitter", code=2)
    assert "--no-wheel-jitter" in jitter and "models no jitter" in jitter


def test_export_records_a_kinds_saved_calibration(kind):
    db = kind["tmp"] / "export.sqlite"
    run("-q", "export", kind["cal"], "--format", "ros2", "--out", kind["tmp"] / "params.yaml", "--robot", "E",
        "--record", "--db", db)  # fmt: skip
    with open_history(db, create=False) as h:
        assert h.latest("E").parameters["kinematics"] == kind["name"]
    assert "holds this recording already" in run(
        "export", kind["cal"], "--format", "json", "--robot", "E", "--record", "--db", db, code=2
    )


def test_drift_finds_a_step_in_one_wheel_of_a_mecanum_robot(tmp_path):
    from datetime import datetime, timedelta, timezone

    from umbmark.history import record_result

    db, start = tmp_path / "h.sqlite", datetime(2026, 3, 1, tzinfo=timezone.utc)
    k = kind_named("mecanum")
    for day in range(8):  # the front left wheel 1 % larger from the sixth session (a new tyre)
        fl = 101.0 if day >= 5 else 100.0
        res = {"kinematics": k.name, "sensor_pose": {"x_mm": 200.0, "x_mm_ci95": [199.0, 201.0]}}
        res["wheel_diameters_mm"] = {"front_left": fl, "front_right": 100.0, "rear_left": 100.0, "rear_right": 100.0}
        res["wheel_diameters_mm_ci95"] = {r: [v - 0.1, v + 0.1] for r, v in res["wheel_diameters_mm"].items()}
        res.update(lx_plus_ly_mm=400.0 + 0.01 * day, lx_plus_ly_mm_ci95=[399.8, 400.3])
        record_result("m", kind="selfcal", method="selfcal", results=res, parameters={}, db=db,
                      when=start + timedelta(days=day))  # fmt: skip
    d = json.loads(run("drift", "m", "--db", db, "--json", code=3))
    assert [c["parameter"] for c in d["changes"]] == ["wheel_diameters_mm.front_left"]
    assert d["changes"][0]["step"] == pytest.approx(1.0, abs=0.05)
    assert {"lx_plus_ly_mm", "sensor_pose.x_mm"} <= set(d["trends"])


def test_a_car_from_its_own_odometry_is_recorded_reported_and_checked(tmp_path):
    """A kind the commands were not written for (a bicycle-model car, read from its /odom) gets them
    all from its module."""
    from umbmark.studies.cars import car_bag

    bag = car_bag("f1tenth", tmp_path / "car.bag", tum=tmp_path / "true.tum")
    db, cal = tmp_path / "h.sqlite", tmp_path / "car.json"
    sizes = ["--wheel-diameter-mm", "110", "--wheelbase-mm", "330", "--fit-steering-scale"]
    run("-q", "selfcal", bag, "--kinematics", "bicycle", "--odom-topic", "/odom", *sizes, "--save", cal,
        "--robot", "car", "--record", "--db", db)  # fmt: skip
    trends = json.loads(run("drift", "car", "--db", db, "--json"))
    assert trends["sessions"] == 1 and not trends["alarm"]
    summary = json.loads(run("report", cal, "--out", tmp_path / "car.html", "--json"))
    assert summary["kinematics"] == "bicycle" and summary["maps"] == 1
    args = ["validate", bag, cal, "--odom-topic", "/odom", "--reference", tmp_path / "true.tum"]
    v = json.loads(run(*args, "--fail-on-worse", "--json"))
    assert v["verdict"] == "pass" and v["wheel_data"].startswith("nav_msgs/Odometry")
    assert "a bicycle-model car needs --drive-joint" in run(*args[:3], "--reference", tmp_path / "true.tum", code=2)
