"""A campaign of geometry in the wrong unit or quantity, ground-truth mix-ups of replay, and
exports and reports of the wrong thing, run through the command line as users make them.

* Every wheel size, wheelbase, wheel separation and mecanum ``lx + ly`` option of every command
  (the kinematic ones too), and the nominal geometry line of a CSV log and of a calibration JSON,
  given in the other unit or beyond any robot's: one line naming the unit slip before any data
  are read.
* A nominal wheel the data show twice or half the robot's (a diameter given as the radius, the
  reverse): named by replay (lsq along the path, bf on a bag's squares), by selfcal of a
  differential drive and by the replay of a tricycle and a mecanum robot against a ground truth.
* A motion-capture marker off the axle: its offset fitted by default where the data determine it;
  a ground truth that lags the wheels named (and not taken for a marker), the sign of a given
  offset checked against the estimate.
* Exports: the multipliers in use, the ROS sizes and a tricycle's steering offset in use bounded;
  report and export of a gyro, pooled, several-set, path, tricycle or mecanum result say what the
  file holds and which command makes what they want.

Each case asserts: no traceback, exit 0 or 2, a refusal in one line naming the real cause, a
warning naming the likely cause and its fix, and a clean simulated case silent.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import click
import numpy as np
import pytest
import simlogs
from test_campaign import _one_line_refusal, base_commands, files, run  # noqa: F401 (files: a fixture)

from umbmark.cli.app import app
from umbmark.io.generic_csv import format_generic_csv
from umbmark.kinds import quantity_named
from umbmark.model.dataset import to_start_frame
from umbmark.model.geometry import ROBOT_SIZES_M, ErrorParams, Geometry, nominal_slip

REPO = Path(__file__).resolve().parents[1]
GEOM = Geometry(0.15, 0.34, 1000.0, 1.0)  # LabMate-like: 150 mm wheels, 340 mm wheelbase
TRUE = ErrorParams(ed=1.004, eb=1.03, es=0.99)
MECANUM = ["--kinematics", "mecanum", "--joints", "fl,fr,rl,rr", "--wheel-diameter-mm", "100", "--lx-plus-ly-mm", "400"]
TRICYCLE = ["--kinematics", "tricycle", "--drive-joint", "d", "--steer-joint", "s", "--wheel-diameter-mm", "250",
            "--wheelbase-mm", "800"]  # fmt: skip


# --- geometry options of every command in the other unit ------------------------------------------


def _leaves(group: click.Group, prefix: tuple[str, ...] = ()) -> dict[tuple[str, ...], click.Command]:
    out = {}
    for name, cmd in group.commands.items():
        if isinstance(cmd, click.Group):
            out.update(_leaves(cmd, (*prefix, name)))
        else:
            out[(*prefix, name)] = cmd
    return out


# a geometry option's kind by the words of its name (as the command line's guard reads them)
_KINDS = (("lx_plus_ly", "lx_plus_ly"), ("diameter", "diameter"), ("radius", "radius"), ("wheelbase", "wheelbase"),
          ("separation", "wheelbase"))  # fmt: skip


def _geometry_options(cmd: click.Command) -> list[tuple[click.Option, str, str]]:
    """(option, kind, unit) of each wheel size or wheelbase option of a command."""
    out = []
    for p in cmd.params:
        if not isinstance(p, click.Option) or not isinstance(p.type, click.types.FloatParamType) or not p.name:
            continue
        unit = "mm" if p.name.endswith("_mm") else "m" if p.name.endswith("_m") else None
        kind = next((k for word, k in _KINDS if word in p.name), None)
        if unit and kind and "multiplier" not in p.name:
            out.append((p, kind, unit))
    return out


def _lines(f: dict[str, Path]) -> dict[str, list[str]]:
    """A command line of every command with geometry options, and of the kinematic variants."""
    d = f["dir"]
    lines = dict(base_commands(f))
    lines["validate"] = ["validate", str(f["log"]), str(f["cal"])]
    lines["selfcal mecanum"] = ["selfcal", str(f["log"]), *MECANUM]
    lines["selfcal tricycle"] = ["selfcal", str(f["log"]), *TRICYCLE]
    lines["replay mecanum"] = ["replay", str(f["log"]), *MECANUM, "--gt-topic", "/gt", "--method", "lsq"]
    lines["replay tricycle"] = ["replay", str(f["log"]), *TRICYCLE, "--gt-topic", "/gt", "--method", "lsq"]
    lines["export ros1"] = ["export", str(f["cal"]), "--format", "ros1"]
    lines["export firmware"] = ["export", str(f["cal"]), "--format", "firmware", "--out", str(d / "fw.h")]
    return lines


def _slip_cases() -> list[tuple[str, str, str]]:
    leaves = {" ".join(k): v for k, v in _leaves(app).items()}
    names = [*leaves, "selfcal mecanum", "selfcal tricycle", "replay mecanum", "replay tricycle", "export ros1",
             "export firmware"]  # fmt: skip
    out = []
    for name in names:
        cmd = leaves.get(name) or leaves[name.split()[0]]
        for p, kind, _ in _geometry_options(cmd):
            if kind == "lx_plus_ly" and "mecanum" not in name:
                continue  # given to another kind it is refused as such (not a unit slip)
            if name.endswith("tricycle") and kind not in ("diameter", "wheelbase"):
                continue
            for how in ("other unit", "far too small", "far too large"):
                out.append((name, max(p.opts, key=len), how))
    return out


SLIP_CASES = _slip_cases()


def _slip_value(kind: str, unit: str, how: str) -> str:
    lo, hi = ROBOT_SIZES_M["diameter" if kind in ("diameter", "radius") else "wheelbase"]
    if kind == "radius":
        lo, hi = lo / 2, hi / 2
    typical_m = {"diameter": 0.15, "radius": 0.075, "wheelbase": 0.34, "lx_plus_ly": 0.4}[kind]
    scale = 1e3 if unit == "mm" else 1.0
    if how == "other unit":
        return f"{typical_m if unit == 'mm' else typical_m * 1e3:g}"
    return f"{(lo / 10 if how == 'far too small' else hi * 10) * scale:g}"


def _set(argv: list[str], flag: str, value: str) -> list[str]:
    out = list(argv)
    if flag in out:
        out[out.index(flag) + 1] = value
        return out
    return [*out, flag, value]


@pytest.mark.parametrize("name, flag, how", SLIP_CASES, ids=[f"{n}{f}-{h}" for n, f, h in SLIP_CASES])
def test_every_geometry_option_in_another_unit_is_named_before_any_data(files, name, flag, how):  # noqa: F811
    """Every wheel size, wheelbase, separation and lx + ly option of every command (the tricycle's
    and mecanum robot's too): one line naming the option and the unit slip, before any data are
    read (so no advice about the driving or the data follows)."""
    leaves = {" ".join(k): c for k, c in _leaves(app).items()}
    cmd = leaves.get(name) or leaves[name.split()[0]]
    kind, unit = next((k, u) for p, k, u in _geometry_options(cmd) if flag in p.opts)
    code, out, err = run(*_set(_lines(files)[name], flag, _slip_value(kind, unit, how)))
    _one_line_refusal(code, out, err)
    assert flag in err and " is no " in err, err
    if how == "other unit":
        assert "given in " in err
    for wrong in ("drive", "do not move", "hardly turns", "walls"):
        assert wrong not in err


def test_the_campaign_covers_every_command_with_a_geometry():
    """The cases above reach every command that takes a wheel size or a wheelbase."""
    with_geometry = {" ".join(k) for k, c in _leaves(app).items() if _geometry_options(c)}
    covered = {n.split()[0] for n, _, _ in SLIP_CASES}
    assert with_geometry <= covered and {"selfcal", "replay", "validate", "export", "simulate"} <= covered
    assert any(f == "--lx-plus-ly-mm" for _, f, _ in SLIP_CASES)


@pytest.mark.parametrize("key", ["left_diameter_mm", "right_diameter_mm", "wheelbase_mm"])
@pytest.mark.parametrize("value", ["0.15", "0.001", "90000"])
@pytest.mark.parametrize("command", ["replay", "convert"])
def test_a_csv_logs_geometry_line_in_metres_is_named_with_its_line(files, tmp_path, key, value, command):  # noqa: F811
    """The nominal geometry line of a CSV log with a size no robot has: the file, its line 1, the
    key and the unit slip; nothing is written."""
    src = files["log"].read_text()
    head, rest = src.split("\n", 1)
    assert head.startswith("# umbmark nominal geometry:")
    items = [f"{key}={value}" if i.startswith(key + "=") else i for i in head.split(" ")]
    bad = tmp_path / "metres.csv"
    bad.write_text(" ".join(items) + "\n" + rest)
    out_csv = tmp_path / "out.csv"
    argv = (
        ["replay", str(bad), "--method", "lsq"] if command == "replay" else ["convert", str(bad), "--out", str(out_csv)]
    )
    code, out, err = run(*argv)
    _one_line_refusal(code, out, err)
    assert "metres.csv:1:" in err and key in err and " is no " in err
    assert ("given in metres?" in err) == (float(value) < 10)
    assert not out_csv.exists()


# --- the data show the nominal wheel in another quantity --------------------------------------------


def _tracked(ds, off):
    """The data set with the ground truth of a point at ``off`` (x, y) [m] in the robot frame."""
    runs = []
    for r in ds.runs:
        g = r.gt
        c, s = np.cos(g[:, 2]), np.sin(g[:, 2])
        m = np.column_stack([g[:, 0] + c * off[0] - s * off[1], g[:, 1] + s * off[0] + c * off[1], g[:, 2]])
        runs.append(dataclasses.replace(r, gt=np.column_stack(to_start_frame(*m.T))))
    return ds.with_runs(runs)


def _shifted(ds, k: int):
    """The data set with its ground truth ``k`` samples late (k < 0: early)."""
    runs = []
    for r in ds.runs:
        g = r.gt
        g = np.vstack([np.repeat(g[:1], k, 0), g[:-k]]) if k > 0 else np.vstack([g[-k:], np.repeat(g[-1:], -k, 0)])
        runs.append(dataclasses.replace(r, gt=np.column_stack(to_start_frame(*g.T))))
    return ds.with_runs(runs)


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, Path]:
    """CSV logs of a LabMate-like robot (E_b 1.03) on three general paths (20 ms samples): the
    ground truth at the axle, of a marker 120 mm ahead, of one 20 mm ahead, 0.3 s late, 0.3 s early."""
    d = tmp_path_factory.mktemp("units")
    ds = simlogs.dataset([simlogs.general_program()] * 3, geom=GEOM, errors=TRUE)
    out = {}
    for name, data in (
        ("clean", ds),
        ("marker", _tracked(ds, (0.12, 0.0))),
        ("small_marker", _tracked(ds, (0.02, 0.0))),
        ("late", _shifted(ds, 15)),
        ("early", _shifted(ds, -15)),
        ("late_marker", _shifted(_tracked(ds, (0.12, 0.0)), 15)),
    ):
        out[name] = d / f"{name}.csv"
        out[name].write_text(format_generic_csv(data))
    out["dir"] = d
    return out


def _replay_json(path: Path, *extra: str) -> tuple[dict, str]:
    code, out, err = run("replay", str(path), "--method", "lsq", "--no-heldout", "--json", *extra)
    assert code == 0 and "Traceback" not in err, err[-800:]
    return json.loads(out), err


@pytest.mark.parametrize(
    "flags, slip",
    [
        (["--wheel-radius-m", "0.15"], "a diameter given as the radius"),
        (["--wheel-diameter-mm", "75"], "a radius given as the diameter"),
        (["--wheel-diameter-mm", "150"], None),
        (["--wheel-radius-m", "0.075"], None),
    ],
    ids=["diameter-as-radius", "radius-as-diameter", "right-mm", "right-radius"],
)
def test_replay_names_a_nominal_wheel_twice_or_half_the_robots(logs, flags, slip):
    """--wheel-radius-m 0.15 for 150 mm wheels (a diameter given as the radius) or 75 mm as the
    diameter: lsq finds the true geometry from the ground truth, and both the reader (wheels against
    the ground truth) and the calibration name the slip; the right size is silent."""
    d, err = _replay_json(logs["clean"], *flags, "--wheelbase-mm", "340")
    assert d["Eb"] == pytest.approx(1.03, rel=1e-6) and d["wheelbase_corrected_mm"] == pytest.approx(350.2, rel=1e-6)
    notes = " ".join(d["warnings"])
    if slip is None:
        assert d["warnings"] == [] and "warning" not in err
    else:
        assert slip in notes and "times the one the travel shows" in err.replace("\n", " ")
        assert "nominal size is likely in another unit or another quantity" in notes


@pytest.fixture(scope="module")
def squares_bag(tmp_path_factory) -> Path:
    """A ROS 1 bag of six 2 m squares (3 cw, 3 ccw) of a LabMate with E_d 1.008, E_b 1.03, each
    from its own start (the robot carried between them), ground truth at the axle."""
    pytest.importorskip("rosbags")
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import SimRobot, concatenate_drives, simulate_drive, square_drive
    from umbmark.model.geometry import LABMATE

    robot = SimRobot(nominal=LABMATE, errors=ErrorParams(ed=1.008, eb=1.03, es=1.0))
    drives = [simulate_drive(square_drive(d, 2.0), robot, seed=i) for i, d in enumerate(["cw", "ccw"] * 3)]
    bag = tmp_path_factory.mktemp("sq") / "squares.bag"
    return write_drive_bag(concatenate_drives(drives), bag, odom=False, truth=True)


JOINTS = ["--joints", "left_wheel_joint,right_wheel_joint"]


@pytest.mark.parametrize(
    "radius, slip",
    [("0.15", "a diameter given as the radius"), ("0.0375", "a radius given as the diameter"), ("0.075", None)],
)
def test_a_bags_squares_with_a_nominal_wheel_twice_the_robots_are_named(squares_bag, radius, slip):
    """bf on a bag's squares cannot see the wheel scale: the bag's runs against their ground truth
    name a nominal wheel twice or half the robot's (not just the odometry's 720 deg turns)."""
    argv = ["replay", str(squares_bag), *JOINTS, "--gt-topic", "/ground_truth", "--split-stops", "--side-mm", "2000",
            "--method", "bf", "--wheel-radius-m", radius, "--wheel-separation-m", "0.34", "--no-heldout",
            "--json"]  # fmt: skip
    code, out, err = run(*argv)
    assert code == 0 and "Traceback" not in err
    notes = " ".join(json.loads(out)["warnings"])
    if slip is None:
        assert "travel shows" not in notes and "not about +-360" not in notes
    else:
        assert slip in notes and "times the one the travel shows" in notes


@pytest.mark.parametrize("ratio", [0.5, 2.0, 1e3, 1e-3, 25.4, 4.0, 1.0, 1.2, 0.8])
@pytest.mark.parametrize("kind", ["diameter", "wheelbase", "lx_plus_ly"])
def test_nominal_slip_names_the_quantity_and_stays_silent_for_real_errors(kind, ratio):
    """An estimate twice, half, a thousand times or 25.4 times the nominal is named; the corrections
    of real robots (0.8 to 1.25, and a skid-steer's wheelbase up to twice its track) are not."""
    text = nominal_slip(quantity_named(kind), ratio)
    if ratio in (1.0, 1.2, 0.8) or (kind != "diameter" and ratio == 2.0):
        assert text is None
        return
    assert text is not None and text.endswith("?")
    if ratio == 0.5 and kind == "diameter":
        assert "a diameter given as the radius" in text
    if ratio == 2.0:
        assert "a radius given as the diameter" in text
    if ratio == 1e3:
        assert "metres given as millimetres" in text
    if ratio == 1e-3:
        assert "millimetres given as metres" in text


def test_selfcal_of_a_differential_drive_names_a_diameter_given_as_the_radius(tmp_path):
    """selfcal with the nominal wheel twice the robot's: the estimate is the robot's and the warning
    names a diameter given as the radius; with the right nominal wheel it is silent."""
    pytest.importorskip("rosbags")
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import SimRobot, mixed_program, simulate_drive
    from umbmark.model.geometry import LABMATE
    from umbmark.model.sensors import Lidar, SensorPose

    robot = SimRobot(nominal=LABMATE, errors=ErrorParams(ed=1.008, eb=1.02, es=1.0),
                     sensor_pose=SensorPose(0.10, 0.02, math.radians(-3.0)), lidar=Lidar(n_beams=180))  # fmt: skip
    bag = write_drive_bag(simulate_drive(mixed_program(25.0, seed=2, robot=robot), robot, seed=3), tmp_path / "d")
    for d_mm, slip in (("300", "a diameter given as the radius"), ("150", None)):
        code, out, err = run(
            "selfcal", str(bag), *JOINTS, "--wheel-diameter-mm", d_mm, "--wheelbase-mm", "340", "--json"
        )
        assert code == 0, err
        res = json.loads(out)
        assert res["wheel_diameter_left_mm"] == pytest.approx(150.0 * 2 / 2.008, rel=0.01)
        found = [w for w in res["warnings"] if "comes out" in w and "diameter" in w]
        assert (slip is not None) == bool(found) and all(slip in w for w in found if slip)


@pytest.fixture(scope="module")
def kinematic_bags(tmp_path_factory) -> dict[str, tuple]:
    """A drawn tricycle and mecanum robot, each driving a minute, ground truth at the base."""
    pytest.importorskip("rosbags")
    from umbmark.studies.kinematic import draw_robot, simulated_bag

    out = {}
    for kind in ("tricycle", "mecanum"):
        drawn = dataclasses.replace(draw_robot(kind, seed=11), duration_s=60.0)
        out[kind] = (drawn, simulated_bag(drawn, tmp_path_factory.mktemp(kind) / "drive.bag"))
    return out


def _kinematic_replay(drawn, bag, factor: float, save: Path | None = None) -> tuple[dict, str]:
    from umbmark.cli.kinematic_args import selfcal_args

    args = selfcal_args(drawn, bag)
    args[0] = "replay"
    i = args.index("--sensor-pose")
    del args[i : i + 2]
    j = args.index("--wheel-diameter-mm")
    args[j + 1] = f"{float(args[j + 1]) * factor:g}"
    args += ["--gt-topic", "/ground_truth", "--method", "lsq"] + (["--save", str(save)] if save else [])
    code, out, err = run(*args)
    assert code == 0 and "Traceback" not in err, err[-800:]
    return json.loads(out), err


@pytest.mark.parametrize("factor", [2.0, 0.5, 1.0])
@pytest.mark.parametrize("kind", ["tricycle", "mecanum"])
def test_a_tricycles_or_mecanum_robots_nominal_wheel_twice_or_half_is_named(kinematic_bags, kind, factor):
    """The replay of a tricycle or mecanum robot against its ground truth with the nominal wheel
    twice or half its own: the estimate is the robot's, the warning names the slip; the right
    nominal is silent about it."""
    drawn, bag = kinematic_bags[kind]
    d, _ = _kinematic_replay(drawn, bag, factor)
    found = [w for w in d["warnings"] if "x the nominal" in w]
    if factor == 1.0:
        assert found == []
        return
    (note,) = found
    want = "a diameter given as the radius" if factor == 2.0 else "a radius given as the diameter"
    assert want in note and "wheel diameter comes out" in note


# --- the marker and the ground truth's delay -------------------------------------------------------


def test_a_marker_ahead_of_the_axle_is_fitted_by_default(logs):
    """A marker 120 mm ahead of the axle: E_b is the true 1.03 by default (the offset fitted, with a
    warning saying so and how to fit without it) and the odometry is judged at the axle; without
    the offset E_b is off and the warning names --fit-marker-offset."""
    d, err = _replay_json(logs["marker"])
    assert d["Eb"] == pytest.approx(1.03, rel=1e-6) and d["tracked_point_offset_mm"][0] == pytest.approx(120, abs=0.01)
    assert d["after"]["path_position_rms_mm"] < 1e-3
    (note,) = d["warnings"]
    assert "120 mm ahead of" in note and "fitted with the geometry" in note and "--no-fit-marker-offset" in note
    off, err = _replay_json(logs["marker"], "--no-fit-marker-offset")
    assert abs(off["Eb"] - 1.03) > 0.03 and "tracked_point_offset_mm" not in off
    (note,) = off["warnings"]
    assert "E_b is 1.0300" in note and "(--fit-marker-offset)" in note
    on, _ = _replay_json(logs["marker"], "--fit-marker-offset")
    assert on["Eb"] == pytest.approx(1.03, rel=1e-6) and on["warnings"] == []


@pytest.mark.parametrize("log", ["clean", "small_marker"])
def test_no_marker_or_a_small_one_is_not_fitted_by_default(logs, log):
    """The ground truth at the axle: silent, E_b true. A marker 20 mm ahead (as the OptiOdom sets'):
    not fitted by default, named with --fit-marker-offset."""
    d, _ = _replay_json(logs[log])
    assert "tracked_point_offset_mm" not in d
    if log == "clean":
        assert d["warnings"] == [] and d["Eb"] == pytest.approx(1.03, rel=1e-6)
    else:
        (note,) = d["warnings"]
        assert "20 mm ahead of" in note and "(--fit-marker-offset)" in note


@pytest.mark.parametrize("log, late", [("late", True), ("early", False), ("late_marker", True)])
def test_a_csv_ground_truth_that_lags_is_named_and_not_taken_for_a_marker(logs, log, late):
    """A CSV log whose ground truth is 0.3 s late (or early) and no --time-offset: a warning names
    the delay and --time-offset auto; no marker is fitted or guessed for it; auto gives E_b back."""
    d, _ = _replay_json(logs[log])
    (note,) = [w for w in d["warnings"] if "against the wheels" in w]
    assert f"0.300 s {'late' if late else 'early'}" in note and "--time-offset auto" in note
    assert not [w for w in d["warnings"] if "axle" in w] and "tracked_point_offset_mm" not in d
    fixed, _ = _replay_json(logs[log], "--time-offset", "auto")
    if log == "late":
        assert fixed["Eb"] == pytest.approx(1.03, abs=2e-3)
    assert not [w for w in fixed["warnings"] if "against the wheels" in w]


@pytest.mark.parametrize("given, sign", [("-0.3", True), ("0.1", False), ("0.3", None)])
def test_a_given_time_offset_is_checked_against_the_estimate(logs, given, sign):
    """--time-offset -0.3 for a ground truth 0.3 s late: the warning names the sign convention and
    the estimate; 0.1: the estimate; 0.3 (right): E_b is the truth and no such warning."""
    d, err = _replay_json(logs["late"], "--time-offset", given)
    found = [w for w in d["warnings"] if "was given, but" in w]
    if sign is None:
        assert found == [] and d["Eb"] == pytest.approx(1.03, abs=2e-3)
        return
    assert len(found) == 3 and all("0.300 s late" in w for w in found)
    assert all(("the sign mixed up? (positive: the ground truth is late); give 0.300" in w) == sign for w in found)
    assert not [w for w in d["warnings"] if "axle" in w]


# --- exports ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cal_json(logs) -> Path:
    """The replay result (lsq, nominal geometry 150 / 340 mm) of the clean log."""
    path = logs["dir"] / "cal.json"
    code, _, err = run("-q", "replay", str(logs["clean"]), "--method", "lsq", "--no-heldout", "--save", str(path))
    assert code == 0, err
    return path


MULTIPLIERS = ["--left-multiplier", "--right-multiplier", "--separation-multiplier"]


@pytest.mark.parametrize("fmt", ["ros2", "ros1"])
@pytest.mark.parametrize("value, outcome", [("340", "refused"), ("0.001", "refused"), ("3", "warned"), ("1.01", "ok")])
@pytest.mark.parametrize("flag", MULTIPLIERS)
def test_multipliers_in_use_are_a_controllers(cal_json, tmp_path, flag, value, outcome, fmt):
    """A multiplier in use no controller runs with (a wheel separation typed for it): refused naming
    the option, nothing written; one beyond real corrections: the warning names the option in use,
    not the calibration; a usual one is silent."""
    out = tmp_path / "p.yaml"
    code, _, err = run("export", str(cal_json), "--format", fmt, flag, value, "--out", str(out))
    assert "Traceback" not in err
    if outcome == "refused":
        _one_line_refusal(code, "", err)
        assert flag in err and "no controller runs with" in err and not out.exists()
    elif outcome == "warned":
        assert code == 0 and flag in err and "in use" in err and "check the calibration" not in err
    else:
        assert code == 0 and "warning" not in err


@pytest.mark.parametrize("fmt", ["ros2", "ros1", "json", "firmware"])
@pytest.mark.parametrize(
    "flag, value",
    [
        ("--wheel-separation-m", "340"),
        ("--wheel-radius-m", "75"),
        ("--wheel-diameter-mm", "0.15"),
        ("--wheelbase-mm", "0.34"),
    ],  # fmt: skip
)
def test_export_sizes_in_the_other_unit_are_refused(cal_json, tmp_path, fmt, flag, value):
    """Every exporter's size options in the other unit: refused naming the unit, nothing written."""
    out = tmp_path / "x"
    code, _, err = run("export", str(cal_json), "--format", fmt, flag, value, "--out", str(out))
    _one_line_refusal(code, "", err)
    assert flag in err and "given in " in err and not out.exists()


@pytest.mark.parametrize("fmt", ["ros2", "ros1", "json", "firmware"])
def test_a_calibration_json_in_metres_is_refused(cal_json, tmp_path, fmt):
    """A calibration JSON whose millimetre keys hold metres (0.15 for 150 mm): refused naming the
    unit slip, not written with a 0.15 mm wheel."""
    d = json.loads(cal_json.read_text())
    d["nominal"] = {k: v / 1e3 if k.endswith("_mm") else v for k, v in d["nominal"].items()}
    bad = tmp_path / "metres.json"
    bad.write_text(json.dumps(d))
    code, _, err = run("export", str(bad), "--format", fmt)
    _one_line_refusal(code, "", err)
    assert "metres.json" in err and "given in metres?" in err


def test_the_ros_sizes_of_an_export_are_checked_against_the_calibration(cal_json):
    """--wheel-radius-m given the diameter (0.15 for 150 mm wheels): the warning names it; the right
    radius is silent."""
    code, _, err = run("export", str(cal_json), "--format", "ros2", "--wheel-radius-m", "0.15")
    assert code == 0 and "a diameter given as the radius?" in err
    code, _, err = run("export", str(cal_json), "--format", "ros2", "--wheel-radius-m", "0.075")
    assert code == 0 and "warning" not in err


# --- report and export of another kind of result ----------------------------------------------------


@pytest.fixture(scope="module")
def results(logs, kinematic_bags) -> dict[str, Path]:
    """Saved results of other kinds: pooled, of several data sets, along a path, a gyro's, a
    tricycle's and a mecanum robot's replay."""
    d = logs["dir"]
    out = {"path": d / "path.json", "pooled": d / "pooled.json", "several": d / "several.json"}
    assert (
        run("-q", "replay", str(logs["clean"]), "--method", "lsq", "--no-heldout", "--save", str(out["path"]))[0] == 0
    )
    argv = [
        "-q",
        "replay",
        str(logs["clean"]),
        "--method",
        "lsq",
        "--pool",
        "--no-heldout",
        "--save",
        str(out["pooled"]),
    ]
    assert run(*argv)[0] == 0
    sets = [REPO / "data" / "optiodom" / "square" / s for s in ("230620202144", "230620202258")]
    assert run("-q", "replay", *map(str, sets), "--no-heldout", "--save", str(out["several"]))[0] == 0
    for kind in ("tricycle", "mecanum"):
        out[kind] = d / f"{kind}.json"
        _kinematic_replay(*kinematic_bags[kind], 1.0, save=out[kind])
    return out


@pytest.fixture(scope="module")
def gyro_json(tmp_path_factory) -> Path:
    """replay --imu-topic --save of a skid-steer robot spinning both ways."""
    pytest.importorskip("rosbags")
    from test_gyro import BIAS, NOISE, SKID, SKID_GEO, bag_of, spins
    from test_gyro import JOINTS as GJ

    from umbmark.model.drive import simulate_drive
    from umbmark.model.sensors import Gyro

    d = tmp_path_factory.mktemp("gyro")
    bag = bag_of(
        simulate_drive(spins(2 * math.pi, [1, -1] * 2), SKID, seed=1), d / "imu", Gyro(100.0, 1.0, BIAS, NOISE)
    )
    save = d / "gyro.json"
    assert run("-q", "replay", str(bag), "--imu-topic", "/imu", *GJ, *SKID_GEO, "--save", str(save))[0] == 0
    return save


REPORT_CASES = {
    "path": ("a replay along a general path (method lsq)", "exports as it is (--format ros2)"),
    "pooled": ("a pooled replay", "replay one data set of square runs without pooling"),
    "several": ("a replay of 2 data sets", "replay the one to show on its own"),
    "tricycle": ("a tricycle's replay against a ground truth", "its export (--format ros2) writes"),
    "mecanum": ("a mecanum robot's replay against a ground truth", "its export (--format ros2) writes"),
}


@pytest.mark.parametrize("kind", list(REPORT_CASES))
def test_report_of_another_kind_says_what_it_holds_and_what_to_do(results, tmp_path, kind):
    """report of a result it cannot draw: one line saying what the file holds and which command
    makes what the user wants; no page written."""
    out = tmp_path / "r.html"
    code, o, err = run("report", str(results[kind]), "--out", str(out))
    _one_line_refusal(code, o, err)
    holds, todo = REPORT_CASES[kind]
    assert holds in err and todo in err and not out.exists()


def test_report_and_export_of_a_gyro_result(gyro_json, tmp_path):
    """A gyro result: the report draws it; ros2 exports its wheelbase multiplier with the warning
    that the wheels were not measured; firmware says the file holds the wheelbase only."""
    out = tmp_path / "g.html"
    code, _, err = run("report", str(gyro_json), "--out", str(out))
    assert code == 0 and out.exists()
    code, text, err = run("export", str(gyro_json), "--format", "ros2")
    assert code == 0 and "wheel_separation_multiplier" in text and "wheels not measured" in err
    code, o, err = run("export", str(gyro_json), "--format", "firmware")
    _one_line_refusal(code, o, err)
    assert "gyro result (--imu-topic) holds the wheelbase only" in err and "--wheel-diameter-mm" in err


@pytest.mark.parametrize("fmt", ["ros2", "json", "urdf"])
@pytest.mark.parametrize("kind", ["pooled", "several", "tricycle"])
def test_export_of_other_kinds_writes_or_names_what_it_needs(results, kind, fmt):
    """Export of a pooled, several-set or tricycle result: written where the file holds what the
    format needs, else one line naming what it holds (--dataset, the lidar's pose of a selfcal)."""
    code, text, err = run("export", str(results[kind]), "--format", fmt)
    assert "Traceback" not in err
    if kind == "several":
        _one_line_refusal(code, text, err)
        assert "--dataset" in err and "230620202144" in err
    elif fmt == "urdf" and kind == "pooled":
        _one_line_refusal(code, text, err)
        assert "self-calibration" in err
    else:
        assert code == 0 and text.strip()


@pytest.mark.parametrize("deg, ok", [("400", False), ("-200", False), ("1.5", True)])
def test_a_tricycles_steering_offset_in_use_beyond_half_a_turn_is_refused(results, deg, ok):
    code, text, err = run("export", str(results["tricycle"]), "--format", "ros2", "--steering-offset-in-use-deg", deg)
    if ok:
        assert code == 0 and "tricycle_controller" in text
    else:
        _one_line_refusal(code, text, err)
        assert "beyond half a turn" in err


def test_the_campaign_of_units_has_its_share_of_cases():
    """This file's share of the campaign (parametrised cases count)."""
    assert len(SLIP_CASES) >= 100
