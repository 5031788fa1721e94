"""The page of a self-calibration (`umbmark report selfcal.json`, `report --id N`) and the history
page with self-calibrations: the estimates with their intervals, the map before and after, the
texts to load; a damaged result or flags that belong to UMBmark reports say so."""

import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pages import check_page

pytest.importorskip("rosbags")
from test_selfcal_cli import ROBOT  # noqa: E402  (the simulated robot of the selfcal command tests)

from umbmark.cli import main  # noqa: E402
from umbmark.io.rosbag_write import write_drive_bag  # noqa: E402
from umbmark.jsonutil import decode_array, encode_array  # noqa: E402
from umbmark.model.drive import mixed_program, simulate_drive  # noqa: E402
from umbmark.realrobot.selfcal_map import decode_map, map_points, map_spread  # noqa: E402
from umbmark.viz.text import fmt  # noqa: E402

ARGS = ["--joints", "left_wheel_joint,right_wheel_joint", "--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]


def run(args, code=0):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    assert rc == code, (rc, err.getvalue(), out.getvalue()[-500:])
    if code == 0:
        return out.getvalue()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and re.match(r"umbmark( report)?: error: ", lines[0]) and "Traceback" not in err.getvalue()
    return lines[0]


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A simulated bag, its self-calibration saved and recorded in a history."""
    tmp = tmp_path_factory.mktemp("screport")
    log = simulate_drive(mixed_program(40.0, seed=2, robot=ROBOT), ROBOT, seed=3)
    bag = write_drive_bag(log, tmp / "drive", storage="mcap", odom=True)
    save, db = tmp / "selfcal.json", tmp / "h.sqlite"
    run(["selfcal", str(bag), *ARGS, "--save", str(save), "--robot", "r1", "--record", "--db", str(db)])
    return {"dir": tmp, "save": save, "db": db, "d": json.loads(save.read_text())}


def _text(page: str) -> str:
    return re.sub(r"\s+", " ", "".join(check_page(page).text))


def _assert_estimates(text: str, d: dict) -> None:
    for key in ("wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm"):
        lo, hi = d[key + "_ci95"]
        assert fmt(d[key], 3) in text, key
        assert f"{fmt(lo, 3)} to {fmt(hi, 3)}" in text, key
    sp = d["sensor_pose"]
    for key, digits in (("x_mm", 2), ("y_mm", 2), ("yaw_deg", 3)):
        lo, hi = sp[key + "_ci95"]
        assert fmt(sp[key], digits) in text and f"{fmt(lo, digits)} to {fmt(hi, digits)}" in text, key
    assert "95 % interval" in text


def test_the_saved_result_holds_a_map_the_calibration_sharpens(made):
    d = made["d"]
    (m,) = d["figures"]["maps"]
    spread = m["spread_mm"]
    # the true geometry differs from the nominal one by 0.8 % and 2 %: its walls come out blurred
    assert spread["calibrated"] < 0.5 * spread["nominal"], spread
    # the stored spread is what the stored points give
    mm = decode_map(m)
    again = map_spread(map_points(mm["base_calibrated"], mm["sensor_calibrated"], mm["points_m"], mm["counts"]))
    assert again * 1e3 == pytest.approx(spread["calibrated"], rel=1e-6)
    res = d["figures"]["residuals"]
    assert decode_array(res["t_s"]).shape == (d["intervals_used"] + len(d["intervals_rejected"]),)


def test_report_of_a_selfcal_file(made, tmp_path):
    out = tmp_path / "page.html"
    summary = json.loads(run(["report", str(made["save"]), "--out", str(out), "--json"]))
    assert summary["kind"] == "selfcal" and summary["maps"] == 1
    page = out.read_text()
    c = check_page(page)
    assert {i["alt"] for i in c.images} == {
        "map before and after calibration",
        "the lidar on the robot",
        "residuals over time",
    }
    text = _text(page)
    _assert_estimates(text, made["d"])
    # the texts to load, made from this file
    assert f"umbmark export {made['save']} --format ros2" in text
    assert "wheel_separation_multiplier" in text and "<origin xyz=" in text
    # the self-calibration's own definitions, not UMBmark's
    assert "c_left = D_L / D_nominal" in text and "2/(E_d+1)" not in text


def test_report_of_a_recorded_selfcal(made, tmp_path):
    out = tmp_path / "rec.html"
    run(["report", "--id", "1", "--db", str(made["db"]), "--out", str(out)])
    text = _text(out.read_text())
    _assert_estimates(text, made["d"])
    assert "robot r1" in text and "record #1" in text


def test_history_page_shows_the_self_calibrations(made, tmp_path):
    out = tmp_path / "r1.html"
    run(["report", "--robot", "r1", "--db", str(made["db"]), "--out", str(out)])
    page = out.read_text()
    text = _text(page)
    assert "Self-calibrations" in text
    d = made["d"]
    assert fmt(d["wheel_diameter_left_mm"], 3) in text and fmt(d["sensor_pose"]["x_mm"], 1) in text
    assert "c_left = D_L / D_nominal" in text and "2/(E_d+1)" not in text
    from umbmark.history import History
    from umbmark.viz.history_plot import history_figure

    with History(made["db"]) as h:
        fig = history_figure(h.records("r1"))
    labels = " ".join(ax.get_ylabel() for ax in fig.axes)
    assert "E_max" not in labels  # no record measured one: no empty panel
    assert "D_L" in labels or "diameter" in labels


def test_a_damaged_map_is_said_and_the_page_still_written(made, tmp_path):
    d = json.loads(made["save"].read_text())
    d["figures"]["maps"][0]["points_mm"]["base64"] = "not base64!"
    bad = tmp_path / "damaged.json"
    bad.write_text(json.dumps(d))
    out = tmp_path / "p.html"
    run(["report", str(bad), "--out", str(out)])
    text = _text(out.read_text())
    assert "map is damaged" in text
    _assert_estimates(text, made["d"])


def test_umbmark_flags_are_refused_and_nothing_is_written(made, tmp_path):
    out = tmp_path / "p.html"
    line = run(["report", str(made["save"]), "--wheelbase-mm", "340", "--out", str(out)], code=2)
    assert "--wheelbase-mm" in line
    assert not out.exists()
    # the report never replaces its input
    before = made["save"].read_bytes()
    run(["report", str(made["save"]), "--out", str(made["save"])], code=2)
    assert made["save"].read_bytes() == before


_DTYPES = {"<f8": np.float64, "<f4": np.float32, "<i2": np.int16, "<u2": np.uint16, "|u1": np.uint8}


@settings(max_examples=60, deadline=None)
@given(
    dtype=st.sampled_from(sorted(_DTYPES)),
    shape=st.lists(st.integers(0, 5), min_size=1, max_size=3),
    seed=st.integers(0, 2**32 - 1),
)
def test_encoded_arrays_round_trip(dtype, shape, seed):
    rng = np.random.default_rng(seed)
    info = np.iinfo(_DTYPES[dtype]) if dtype[1] in "iu" else None
    a = (
        rng.integers(info.min, info.max, size=shape, endpoint=True)
        if info is not None
        else rng.normal(0, 1e3, size=shape).astype(_DTYPES[dtype])
    )
    e = encode_array(a, dtype)
    assert json.loads(json.dumps(e)) == e  # plain JSON
    b = decode_array(e)
    assert b.shape == tuple(shape) and np.array_equal(b, a.astype(_DTYPES[dtype]))


def test_damaged_encodings_are_refused():
    e = encode_array(np.arange(6.0), "<f8")
    for bad in ({**e, "shape": [7]}, {**e, "dtype": "object"}, {**e, "base64": "###"}, {"shape": [6]}):
        with pytest.raises(ValueError):
            decode_array(bad)
