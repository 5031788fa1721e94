"""Hostile strings (line breaks, comment terminators, preprocessor lines, YAML keys, quotes,
markup, NUL, Unicode line separators) through every writer: the file parses back to the data
that was meant, never to new structure."""

from __future__ import annotations

import csv
import io
import json
import re
import shlex
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import numpy as np
import pytest
import yaml

from umbmark.cli import main
from umbmark.io.export import ExportCalibration, format_export
from umbmark.io.generic_csv import format_generic_csv
from umbmark.io.runs_csv import format_runs_csv, parse_runs_csv
from umbmark.model.dataset import Dataset, Run, WheelGeometry
from umbmark.model.runs import RunsTable

HOSTILE = [
    "a\nevil_controller:\n  ros__parameters:\n    use_sim_time: true",
    "x */\n#define UMBMARK_LEFT_MM_PER_PULSE 999\n/* y",
    "*/ #define EVIL 1 /*",
    "#define EVIL 1",
    "key: value\n- item",
    "'single' \"double\" `back`",
    "</script><script>alert(1)</script>",
    "<!-- a -- b --->",
    "nul\x00byte",
    "line\u2028separator\u2029paragraph\x85next\r\nline\rcr",
    "--- !!python/object/apply:os.system ['true']",
    "&amp; &lt;b&gt; <b>bold</b>",
    'a,b,"c"\n1,2',
    "back\\slash\\",
    "trailing-",
    "\ufeffbom \u200b zero width \u202e rtl",
]
IDS = [f"h{i}" for i in range(len(HOSTILE))]

POSE = (0.035, -0.01, 0.02)


def calibration(s: str, pose: bool = False) -> ExportCalibration:
    return ExportCalibration(
        1.001,
        0.999,
        0.98,
        0.15,
        0.15,
        0.34,
        1000.0,
        source=s,
        method=s,
        sensor_pose=POSE if pose else None,
        scale_observed=False,
    )


def defines_of(header: str) -> dict[str, str]:
    """The ``#define`` lines of a C header, read as a C compiler would after removing comments
    (``/* ... */`` closes at the first ``*/``; ``//`` to the end of the line); anything else
    outside the comments and the directives fails."""
    text, out, i = header, [], 0
    while i < len(text):
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            assert j >= 0, "an unclosed comment"
            out.append(" ")
            i = j + 2
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = len(text) if j < 0 else j
        else:
            out.append(text[i])
            i += 1
    defines = {}
    for line in "".join(out).split("\n"):
        line = line.strip()
        if not line:
            continue
        m = re.fullmatch(r"#define (\w+)(?:\s+(\S+))?", line)
        if m:
            assert m.group(1) not in defines, f"{m.group(1)} defined twice"
            defines[m.group(1)] = m.group(2) or ""
            continue
        assert re.fullmatch(r"#(ifndef \w+|endif)", line), f"unexpected line outside the comments: {line!r}"
    return defines


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_yaml_exports_hold_only_the_parameters(s):
    cal = calibration(s)
    expected = {
        "wheel_separation_multiplier": cal.eb,
        "left_wheel_radius_multiplier": cal.c_left,
        "right_wheel_radius_multiplier": cal.c_right,
    }
    for fmt in ("ros2", "ros1"):
        text = format_export(cal, fmt)
        body = yaml.safe_load(text)
        want = {"ros__parameters": expected} if fmt == "ros2" else expected
        assert body == {"diff_drive_controller": want}
        # every comment is one line starting with '#', and nothing else appeared
        lines = text.split("\n")
        assert all(line.startswith("#") for line in lines[:3])
        assert len(re.split(r"[\r\n\x85\u2028\u2029]", text)) == len(lines)


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_firmware_header_defines_only_its_values(s):
    text = format_export(calibration(s), "firmware")
    defines = defines_of(text)
    assert set(defines) == {
        "UMBMARK_CALIBRATION_H",
        "UMBMARK_LEFT_MM_PER_PULSE",
        "UMBMARK_RIGHT_MM_PER_PULSE",
        "UMBMARK_WHEELBASE_MM",
    }
    assert float(defines["UMBMARK_LEFT_MM_PER_PULSE"]) == pytest.approx(1.001 * 150 * np.pi / 1000, rel=1e-8)
    assert float(defines["UMBMARK_WHEELBASE_MM"]) == pytest.approx(0.98 * 340, abs=1e-6)
    assert not re.search(r"[\x00\x85\u2028\u2029\r]", text)


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_json_export_keeps_the_strings_as_data(s):
    d = json.loads(format_export(calibration(s), "json"))
    assert d["method"] == s and d["source"] == s
    assert d["c_left"] == 1.001


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_urdf_and_tf_exports(s):
    cal = calibration(s, pose=True)
    root = ET.fromstring(format_export(cal, "urdf"))  # comments must be well formed XML comments
    assert root.tag == "origin" and set(root.attrib) == {"xyz", "rpy"} and len(root) == 0
    assert [float(v) for v in root.attrib["xyz"].split()] == pytest.approx([0.035, -0.01, 0.0])
    text = format_export(cal, "tf")
    commands = [line for line in text.split("\n") if line and not line.startswith("#")]
    assert len(commands) == 1
    args = shlex.split(commands[0])
    assert args[:4] == ["ros2", "run", "tf2_ros", "static_transform_publisher"]
    assert args[4::2] == ["--x", "--y", "--z", "--roll", "--pitch", "--yaw", "--frame-id", "--child-frame-id"]
    # the ros exports of a self-calibration end with the pose as comments: still only parameters
    body = yaml.safe_load(format_export(cal, "ros2"))
    assert list(body) == ["diff_drive_controller"]


@pytest.mark.parametrize("s", HOSTILE[:4] + HOSTILE[8:10], ids=IDS[:4] + IDS[8:10])
def test_hostile_strings_from_a_calibration_json_through_the_cli(tmp_path, capsys, s):
    """The method of a calibration JSON and the file's own name, through ``umbmark export``."""
    name = tmp_path / ("cal" + s.replace("/", "_").replace("\x00", "0") + ".json")
    name.write_text(json.dumps({"method": s, "c_left": 1.001, "c_right": 0.999, "Eb": 0.98, "wheelbase_mm": 340.0}))
    for fmt in ("ros2", "ros1", "firmware", "json"):
        extra = ["--wheel-diameter-mm", "150", "--pulses-per-wheel-rev", "1000"] if fmt == "firmware" else []
        assert main(["export", str(name), "--format", fmt, *extra]) == 0
        text = capsys.readouterr().out
        if fmt == "firmware":
            assert len(defines_of(text)) == 4
        elif fmt == "json":
            assert json.loads(text)["method"] == s
        else:
            assert len(yaml.safe_load(text)["diff_drive_controller"]) == (1 if fmt == "ros2" else 3)


@pytest.mark.parametrize("controller", ["a\nb: 1", "x: {y: 1}", "c #d", "ev'il", "e\u2028f", "", "a b"])
def test_a_hostile_controller_name_is_refused(controller, capsys):
    cal = calibration("x")
    with pytest.raises(Exception, match="bad controller name"):
        format_export(cal, "ros2", controller)
    assert (
        main(
            ["export", "--c-left", "1", "--c-right", "1", "--eb", "1", "--format", "ros2"]
            + ["--controller", controller]
        )
        == 2
    )
    assert "bad controller name" in capsys.readouterr().err


# -- CSV -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_runs_csv_labels_are_quoted(s):
    runs = RunsTable(
        np.array(["cw", "ccw"]),
        np.array([0.01, -0.02]),
        np.array([0.003, 0.004]),
        np.zeros(2),
        np.zeros(2),
        run=np.array([s, s + "2"], dtype=object),
    )
    rows = list(csv.reader(io.StringIO(format_runs_csv(runs), newline="")))
    assert len(rows) == 3
    assert [r[0] for r in rows[1:]] == [s, s + "2"]
    assert [r[1] for r in rows[1:]] == ["cw", "ccw"]
    assert float(rows[1][2]) == 10.0
    back = parse_runs_csv(format_runs_csv(runs), "runs.csv")  # umbmark's own reader: no row lost to a '#'
    assert list(back.run) == [s, s + "2"] and list(back.direction) == ["cw", "ccw"]


@pytest.mark.parametrize("s", HOSTILE, ids=IDS)
def test_generic_csv_run_names_are_quoted(s):
    t = np.arange(3) * 0.1
    z = np.zeros(3)
    ds = Dataset("d", WheelGeometry(0.1, 0.1, 0.3), 1000.0, (Run(s, t, t * 10, t * 11, np.column_stack([t, z, z])),))
    text = format_generic_csv(ds)
    lines = text.split("\n")
    while lines[0].startswith("#"):  # the geometry comment above the header
        lines.pop(0)
    rows = list(csv.reader(io.StringIO("\n".join(lines), newline="")))
    assert rows[0][0] == "run" and len(rows) == 4
    assert {r[0] for r in rows[1:]} == {s}
    assert [float(r[1]) for r in rows[1:]] == pytest.approx(t)


# -- HTML ----------------------------------------------------------------------------------------


class Structure(HTMLParser):
    """The tags of a page and its text."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)

    def handle_endtag(self, tag):
        self.tags.append("/" + tag)

    def handle_data(self, data):
        self.text.append(data)


def structure(html: str) -> Structure:
    p = Structure()
    p.feed(html)
    p.close()
    return p


def _report(tmp_path, label: str, robot: str) -> str:
    runs = tmp_path / f"runs{abs(hash(label))}.csv"
    with open(runs, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["run", "direction", "x_abs", "y_abs", "x_odo", "y_odo"])
        for i, (d, x, y) in enumerate([("cw", 10, 5), ("cw", 12, 4), ("ccw", -3, 20), ("ccw", -4, 22)]):
            w.writerow([f"run {label}{i}", d, x, y, 0, 0])
    out = tmp_path / "r.html"
    code = main(
        ["-q", "report", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--bootstrap", "0"]
        + ["--robot", robot, "--out", str(out)]
    )
    assert code == 0
    return out.read_text(encoding="utf-8")


@pytest.mark.parametrize("s", [h for h in HOSTILE if "\x00" not in h and "\r" not in h][:6])
def test_html_report_escapes_labels_and_robot_names(tmp_path, s):
    """The page with hostile run labels and robot name has the tags of the page with plain
    ones, and the strings are in its text."""
    plain = structure(_report(tmp_path, "run", "robot"))
    hostile = structure(_report(tmp_path, s, s))
    assert hostile.tags == plain.tags
    text = "".join(hostile.text)
    assert s.split("\n")[0] in text


ROBOT = "r1: {evil: 1} # \"q\" 'x' </script><b>&amp; --> */ #define X"


@pytest.fixture
def history_with_hostile_robot(tmp_path):
    runs = tmp_path / "runs.csv"
    assert main(["-q", "simulate", "--seed", "5", "--out", str(runs)]) == 0
    db = tmp_path / "h.sqlite"
    for robot in (ROBOT, "plain"):
        args = ["-q", "analyze", str(runs), "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", robot]
        assert main([*args, "--record", "--db", str(db)]) == 0
    return tmp_path, db


def test_history_exports_and_page_keep_a_hostile_robot_name_as_data(history_with_hostile_robot):
    tmp_path, db = history_with_hostile_robot
    for name in ("p.yaml", "p.json"):
        out = tmp_path / name
        assert main(["-q", "history", ROBOT, "--db", str(db), "--export", str(out)]) == 0
        text = out.read_text(encoding="utf-8")
        d = yaml.safe_load(text) if name.endswith(".yaml") else json.loads(text)
        found = [v for v in _strings(d) if v == ROBOT]
        assert found, f"the robot name is not a value of {name}"
        plain = tmp_path / ("plain-" + name)
        assert main(["-q", "history", "plain", "--db", str(db), "--export", str(plain)]) == 0
        d2 = yaml.safe_load(plain.read_text()) if name.endswith(".yaml") else json.loads(plain.read_text())
        assert _keys(d) == _keys(d2), "the hostile name changed the structure"
    pages = {}
    for robot in (ROBOT, "plain"):
        out = tmp_path / "page.html"
        assert main(["-q", "report", "--robot", robot, "--db", str(db), "--out", str(out)]) == 0
        pages[robot] = structure(out.read_text(encoding="utf-8"))
    assert pages[ROBOT].tags == pages["plain"].tags
    assert ROBOT in "".join(pages[ROBOT].text)


def _strings(d):
    if isinstance(d, dict):
        for v in d.values():
            yield from _strings(v)
    elif isinstance(d, list):
        for v in d:
            yield from _strings(v)
    elif isinstance(d, str):
        yield d


def _keys(d, prefix=""):
    if isinstance(d, dict):
        return sorted(k for key, v in d.items() for k in [prefix + str(key), *_keys(v, prefix + str(key) + ".")])
    return []
