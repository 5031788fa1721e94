"""Bags in the shapes people record: the robot's own nav_msgs/Odometry as the wheels, one bag per
run, both directions in one bag without --split-stops, a motion capture slower than the wheels,
bag-info's joint names, frames and rates, ROS units, convert of several bags, broken JointState
messages. Every bag is written here with rosbags from the closed-loop simulator of
tests/simlogs.py (noise free), with the motion capture in a rotated world frame."""

import json

import numpy as np
import pytest

pytest.importorskip("rosbags")
import simlogs  # noqa: E402
from test_bag_shapes_sim import (  # noqa: E402
    GEOMETRY,
    JOINTS,
    NO_SCALE,
    NOMINAL,
    YAW,
    _compose,
    _odometry,
    session,
    true_emax,
    write_bag,
)

from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.load import LogOptions, TruthSource, load_logs  # noqa: E402
from umbmark.io.rosbag import bag_info, read_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.realrobot.replay import end_poses, replay_report  # noqa: E402

# -- six one-run bags with the robot's own odometry: one test of six runs ----------------------------

JOINT_WHEELS = WheelSource(joints=("left_wheel_joint", "right_wheel_joint"))


def options(wheels, **kw):
    """The log options of these bags: 100 mm wheels, a 300 mm wheelbase, motion capture on /mocap/pose."""
    return LogOptions(0.1, 0.1, 0.3, wheels=wheels, truth=TruthSource("/mocap/pose"), **kw)


@pytest.fixture(scope="module")
def six_bags(tmp_path_factory):
    d = tmp_path_factory.mktemp("six")
    bags, truth = [], []
    odom_start = np.array([3.0, 4.0, -1.0])
    for i, direction in enumerate(["cw", "ccw", "cw", "ccw", "cw", "ccw"]):
        # one bag per run: the robot is carried back between the recordings
        t, pl, pr, world, _, tr = session([direction], pause_s=1.0, carry=False, origin=(1.5 + 0.03 * i, -0.8, YAW))
        # the odom frame runs on from bag to bag (the robot carried back keeps counting)
        rel = _odometry(np.diff(pl, prepend=pl[0]), np.diff(pr, prepend=pr[0]))
        odom = _compose(odom_start, rel)
        odom_start = odom[-1]
        bags.append(write_bag(d / f"run{i + 1}", t, pl, pr, world, odom, joints=False))
        truth += tr
    return bags, truth


def test_six_one_run_bags_with_odometry_are_one_test(six_bags, capsys):
    bags, truth = six_bags
    args = ["replay", *map(str, bags), "--odom-topic", "/odom", "--gt-topic", "/mocap/pose"]
    args += ["--wheelbase-mm", "300", "--wheel-diameter-mm", "100", "--side-mm", "2000", "--method", "exact", "--json"]
    assert main(args) == 0
    d = json.loads(capsys.readouterr().out)
    assert "datasets" not in d  # one test, not six data sets
    assert [r["run"] for r in d["runs"]] == [f"run{i}" for i in range(1, 7)]
    assert [r["direction"] for r in d["runs"]] == ["cw", "ccw"] * 3
    assert d["before"]["emax_syst_mm"] == pytest.approx(true_emax(truth) * 1e3, abs=2.0)
    true = simlogs.TRUE
    assert d["Ed"] == pytest.approx(true.ed, abs=2e-4)
    assert d["Eb"] == pytest.approx(true.eb / true.es, abs=1e-3)  # relative to the wheel scale
    assert d["after"]["emax_syst_mm"] < 0.01 * d["before"]["emax_syst_mm"]


def test_odometry_replayed_with_the_nominal_geometry_is_the_recorded_odometry(six_bags):
    bags, truth = six_bags
    ds = load_logs(bags, "bag", options(WheelSource(odom_topic="/odom"), side_m=2.0))
    assert len(ds.runs) == 6 and all(r.source == str(b) for r, b in zip(ds.runs, bags))
    odo = end_poses(ds, ds.nominal)
    # each run from its own start, though the odom frame ran on over the six bags
    assert np.allclose(odo, [r[2] for r in truth], atol=1e-9)


def test_several_bags_missing_a_direction_names_the_bags(six_bags, capsys):
    bags, _ = six_bags
    cw = [str(b) for b in bags[0::2]]
    assert main(["replay", *cw, "--odom-topic", "/odom", "--gt-topic", "/mocap/pose", *GEOMETRY, "--method", "bf"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no ccw runs" in err
    for b in cw:
        assert b in err


def test_a_bag_that_is_not_a_square_is_named(six_bags, tmp_path, capsys):
    bags, _ = six_bags
    t, pl, pr, world, odom, _ = session(["ccw"], pause_s=1.0, carry=False, turns=3)  # stopped a turn short
    short = write_bag(tmp_path / "short", t, pl, pr, world, odom)
    args = ["replay", str(bags[0]), str(short), str(bags[1]), "--odom-topic", "/odom", "--gt-topic", "/mocap/pose"]
    assert main([*args, *GEOMETRY, "--method", "exact"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"umbmark: error: {short}: the odometry turns 270 deg")


def test_missing_wheel_source_suggests_the_odometry(six_bags, capsys):
    bag = six_bags[0][0]
    assert main(["replay", str(bag), "--gt-topic", "/mocap/pose", *GEOMETRY]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--odom-topic /odom" in err and "/odom (Odometry)" in err
    # no geometry either: the geometry asked for, and the odometry suggested
    assert main(["replay", str(bag), "--gt-topic", "/mocap/pose", "--side-mm", "2000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--wheel-separation-m" in err and "--odom-topic /odom" in err


# -- one bag with both directions, no --split-stops; a motion capture slower than the wheels ----------


@pytest.fixture(scope="module")
def session_bag(tmp_path_factory):
    d = tmp_path_factory.mktemp("session")
    # no scale error (E_s = 1): the square methods then explain the runs exactly
    t, pl, pr, world, odom, truth = session(["cw", "cw", "ccw", "ccw"], pause_s=3.0, errors=NO_SCALE)
    slow = write_bag(d / "slow", t, pl, pr, world, odom, mocap_hz=7.0, mocap_delay_s=0.031)
    return slow, truth


def _replay(bag, *extra, method="exact"):
    ds = load_logs([bag], "bag", options(JOINT_WHEELS, side_m=2.0, **dict(extra)))
    return replay_report(ds, method).to_dict()


def test_both_directions_in_one_bag_split_at_stops_without_asking(session_bag):
    bag, truth = session_bag
    auto = _replay(bag)
    asked = _replay(bag, ("split_stops", True))
    assert [r["direction"] for r in auto["runs"]] == ["cw", "cw", "ccw", "ccw"]
    assert any("split where both wheels stand still" in w and "split_stops" in w for w in auto["warnings"])
    assert not any("split where" in w for w in asked["warnings"])
    assert auto["Ed"] == asked["Ed"] and auto["Eb"] == asked["Eb"]


def test_several_bags_each_split_into_runs_are_one_test(session_bag, tmp_path):
    bag, truth = session_bag
    t, pl, pr, world, odom, truth2 = session(["ccw", "cw"], pause_s=3.0, errors=NO_SCALE)
    second = write_bag(tmp_path / "second", t, pl, pr, world, odom, mocap_hz=7.0, mocap_delay_s=0.05)
    ds = load_logs([bag, second], "bag", options(JOINT_WHEELS, side_m=2.0, split_stops=True))
    assert [r.name for r in ds.runs] == ["slow#1", "slow#2", "slow#3", "slow#4", "second#1", "second#2"]
    assert [r.source for r in ds.runs] == [str(bag)] * 4 + [str(second)] * 2
    rep = replay_report(ds, "exact").to_dict()
    assert [r["direction"] for r in rep["runs"]] == ["cw", "cw", "ccw", "ccw", "ccw", "cw"]
    assert rep["before"]["emax_syst_mm"] == pytest.approx(true_emax(truth + truth2) * 1e3, abs=0.05)
    assert rep["Ed"] == pytest.approx(NO_SCALE.ed, abs=2e-5)


def test_a_bag_that_is_not_squares_says_what_to_give(session_bag, capsys):
    bag, _ = session_bag
    # pauses shorter than --stop-s: no square pieces
    args = ["replay", str(bag), "--joints", "left_wheel_joint,right_wheel_joint", "--gt-topic", "/mocap/pose"]
    assert main([*args, *GEOMETRY, "--stop-s", "5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--ranges" in err and "--split-stops" in err and "--stop-s" in err


def test_end_pose_is_the_ground_truth_at_rest(session_bag, monkeypatch):
    """A 7 Hz motion capture against 50 Hz wheels, noise free: the exact method leaves nothing; the
    truth interpolated across the start and end of the stops leaves about a millimetre."""
    bag, truth = session_bag
    rep = _replay(bag, ("split_stops", True))
    assert rep["before"]["emax_syst_mm"] == pytest.approx(true_emax(truth) * 1e3, abs=0.05)
    assert rep["after"]["emax_syst_mm"] < 0.1
    assert rep["Ed"] == pytest.approx(NO_SCALE.ed, abs=2e-5) and rep["Eb"] == pytest.approx(NO_SCALE.eb, abs=2e-5)
    import umbmark.io.rosbag as rosbag

    monkeypatch.setattr(rosbag, "_truth_at_rest", lambda *a: None)  # interpolated across the stops
    blended = _replay(bag, ("split_stops", True))
    assert blended["after"]["emax_syst_mm"] > 0.5


# -- bag-info, errors that list what the bag has ---------------------------------------------------------


def test_bag_info_shows_joint_names_frames_and_rates(session_bag, capsys):
    bag, _ = session_bag
    info = {t["topic"]: t for t in bag_info(bag).to_dict()["topics"]}
    assert info["/joint_states"]["joint_names"] == JOINTS
    assert info["/joint_states"]["rate_hz"] == pytest.approx(50.0, rel=1e-6)
    assert info["/odom"]["frame_id"] == "odom" and info["/odom"]["child_frame_id"] == "base_link"
    assert info["/mocap/pose"]["frame_id"] == "world"
    assert info["/mocap/pose"]["rate_hz"] == pytest.approx(7.0, rel=1e-6)
    assert main(["bag-info", str(bag)]) == 0
    out = capsys.readouterr().out
    assert "left_wheel_joint, right_wheel_joint" in out and "odom -> base_link" in out and "frame world" in out
    assert main(["bag-info", str(bag), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["topics"][0]["joint_names"] == JOINTS


def test_topic_errors_list_what_the_bag_has(session_bag, capsys):
    bag, _ = session_bag
    base = ["replay", str(bag), "--gt-topic", "/mocap/pose", *GEOMETRY]
    assert main([*base, "--joints", "left_wheel,right_wheel"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "joints there: left_wheel_joint, right_wheel_joint" in err
    assert main([*base, "--joints", "left_wheel_joint,right_wheel_joint", "--joint-topic", "/joints"]) == 2
    err = capsys.readouterr().err
    assert "no topic '/joints'" in err and "/joint_states (JointState)" in err and "/mocap/pose (PoseStamped)" in err


# -- ROS units, convert of several bags, --help --------------------------------------------------------


def test_ros_units_are_accepted_and_must_agree(session_bag, capsys):
    bag, _ = session_bag
    base = ["replay", str(bag), "--joints", "left_wheel_joint,right_wheel_joint", "--gt-topic", "/mocap/pose"]
    base += ["--split-stops", "--side-mm", "2000", "--method", "exact", "--json", "--no-heldout"]
    assert main([*base, "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]) == 0
    mm = json.loads(capsys.readouterr().out)
    assert main([*base, "--wheel-radius-m", "0.05", "--wheel-separation-m", "0.30"]) == 0
    ros = json.loads(capsys.readouterr().out)
    assert ros["Ed"] == mm["Ed"] and ros["nominal"] == mm["nominal"]
    assert main([*base, "--wheel-radius-m", "0.05", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]) == 0
    capsys.readouterr()
    assert main([*base, "--wheel-radius-m", "0.06", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--wheel-diameter-mm 100 and --wheel-radius-m 0.06 disagree" in err


def test_convert_several_bags_keeps_the_geometry_for_replay(six_bags, tmp_path, capsys):
    bags, _ = six_bags
    src = ["--odom-topic", "/odom", "--gt-topic", "/mocap/pose", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]
    out = tmp_path / "six.csv"
    assert main(["convert", *map(str, bags), *src, "--out", str(out)]) == 0
    capsys.readouterr()
    assert out.read_text().startswith("# umbmark nominal geometry: left_diameter_mm=100.0 right_diameter_mm=100.0")
    common = ["--side-mm", "2000", "--method", "exact", "--json", "--no-heldout"]
    assert main(["replay", str(out), *common]) == 0  # no --pulses-per-wheel-rev, no geometry
    csv_rep = json.loads(capsys.readouterr().out)
    assert main(["replay", *map(str, bags), *src, *common]) == 0
    bag_rep = json.loads(capsys.readouterr().out)
    assert csv_rep["nominal"] == bag_rep["nominal"]
    for k in ("Ed", "Eb"):
        assert csv_rep[k] == pytest.approx(bag_rep[k], abs=1e-9)
    assert csv_rep["before"]["emax_syst_mm"] == pytest.approx(bag_rep["before"]["emax_syst_mm"], abs=1e-5)


def test_replay_help_shows_a_bag_example(capsys):
    assert main(["replay", "--help"]) == 0
    out = capsys.readouterr().out
    example = out.split("Example", 1)[1]
    assert "--joints" in example and "--gt-topic" in example and "--odom-topic" in example


# -- broken JointState messages, a .db3 alone ---------------------------------------------------------------


@pytest.mark.parametrize("damage", ["short", "empty"])
def test_a_jointstate_without_positions_is_dropped_with_a_warning(tmp_path, capsys, damage):
    """One JointState message that names the joints but lacks their positions is left out, and
    said (every reader of wheel data does so); a bag whose messages all lack them is refused."""
    t, pl, pr, world, odom, _ = session(["cw"], pause_s=0.5)

    def positions(k, pos):
        if k != 7:
            return pos
        return pos[:1] if damage == "short" else np.array([], float)

    bag = write_bag(tmp_path / "b", t, pl, pr, world, odom, positions=positions)
    whole = write_bag(tmp_path / "whole", t, pl, pr, world, odom)
    read = dict(nominal=NOMINAL, wheels=WheelSource(joints=tuple(JOINTS)), gt_topic="/mocap/pose")
    ds, ref = read_bag(bag, **read), read_bag(whole, **read)
    assert any("1 JointState messages on /joint_states without positions: dropped" in w for w in ds.meta["warnings"])
    assert sum(len(r) for r in ds.runs) == sum(len(r) for r in ref.runs) - 1
    args = ["replay", str(bag), "--joints", ",".join(JOINTS), "--gt-topic", "/mocap/pose", "--method", "lsq"]
    assert main([*args, "--json", "--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]) == 0
    assert "without positions: dropped" in capsys.readouterr().out


def test_joint_states_that_all_lack_positions_are_one_line(tmp_path, capsys):
    t, pl, pr, world, odom, _ = session(["cw"], pause_s=0.5)
    bag = write_bag(tmp_path / "b", t, pl, pr, world, odom, positions=lambda k, pos: np.array([], float))
    with pytest.raises(InputError, match=r"name the joints .* but carry no positions") as e:
        read_bag(bag, nominal=NOMINAL, wheels=WheelSource(joints=tuple(JOINTS)), gt_topic="/mocap/pose")
    assert e.value.source == str(bag)
    args = ["replay", str(bag), "--joints", ",".join(JOINTS), "--gt-topic", "/mocap/pose", *GEOMETRY]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bag) in err and "--odom-topic" in err and "Traceback" not in err


def test_db3_without_its_metadata(session_bag, tmp_path, capsys):
    """A .db3 alone is read when its file holds what it needs (rosbags reads the types from it),
    else one line that names the missing metadata.yaml."""
    bag, _ = session_bag
    lone = tmp_path / "lone.db3"
    lone.write_bytes(next(bag.glob("*.db3")).read_bytes())
    assert bag_info(lone).to_dict()["topics"] == bag_info(bag).to_dict()["topics"]
    broken = tmp_path / "broken.db3"
    broken.write_bytes(b"SQLite format 3\0" + b"\0" * 200)
    assert main(["bag-info", str(broken)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "metadata.yaml" in err and str(broken) in err and "Traceback" not in err
