"""Bag time stamps: stamps that go backwards, repeated stamps, a ground truth covering part of the
log, spikes in the wheel positions, and a ground truth late against the wheels (estimated from
the turn rates, corrected with ``time_offset`` / ``--time-offset``).

The bags are a simulated UMBmark test (a cw and a ccw 2 m square, stops between them) written by
:func:`umbmark.io.rosbag_write.write_drive_bag`, then edited message by message (restamped,
duplicated, dropped, corrupted) into a second bag.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest

pytest.importorskip("rosbags")
from bagedit import edit_bag, restamp, stamp_ns  # noqa: E402

from umbmark.cli import main  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import read_bag  # noqa: E402
from umbmark.io.rosbag_write import JOINT_NAMES, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import EXAMPLE_ROBOT, Command, simulate_drive  # noqa: E402
from umbmark.model.geometry import ErrorParams  # noqa: E402
from umbmark.model.sensors import Lidar  # noqa: E402
from umbmark.realrobot.replay import replay_report  # noqa: E402

SIDE_M = 2.0
ROBOT = dataclasses.replace(
    EXAMPLE_ROBOT, errors=ErrorParams(ed=1.004, eb=1.02, es=0.99), lidar=Lidar(n_beams=4, range_noise_m=0.0)
)
NOMINAL = ROBOT.nominal_wheels
READ = dict(
    nominal=NOMINAL, wheels=WheelSource(joints=JOINT_NAMES), gt_topic="/ground_truth", stops=True, side_m=SIDE_M
)
CLI = [
    "--joints",
    ",".join(JOINT_NAMES),
    "--gt-topic",
    "/ground_truth",
    "--wheel-diameter-mm",
    f"{NOMINAL.diameter_left_m * 1e3:g}",
    "--wheelbase-mm",
    f"{NOMINAL.wheelbase_m * 1e3:g}",
    "--side-mm",
    f"{SIDE_M * 1e3:g}",
    "--split-stops",
    "--method",
    "exact",
    "--no-heldout",
    "--json",
]


def _square(sign: int, v: float = 0.4, w: float = 0.8) -> list[Command]:
    legs = []
    for _ in range(4):
        legs += [Command(SIDE_M / v, v), Command(0.3), Command(math.pi / 2 / w, 0.0, sign * w), Command(0.3)]
    return legs + [Command(2.5)]


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """A ROS 2 bag of a cw and a ccw square (wheels and ground truth at 100 Hz)."""
    program = [Command(2.5)] + _square(-1) + _square(1)
    log = simulate_drive(program, ROBOT, start_pose=(4.0, 4.0, 0.0), scan_rate_hz=1.0)
    return write_drive_bag(log, tmp_path_factory.mktemp("bags") / "clean", truth=True, odom=False)


def _later(msg, dt_s: float):
    return restamp(msg, stamp_ns(msg) + int(round(dt_s * 1e9)))


def delayed(tau_s: float, every: int = 1):
    """Ground-truth edit: every ``every``-th pose, stamped (and recorded) ``tau_s`` later."""

    def f(msgs):
        return [(ns + int(round(tau_s * 1e9)), _later(m, tau_s)) for ns, m in msgs[::every]]

    return f


def _cal(ds):
    rep = replay_report(ds, "exact", heldout=False)
    d = rep.to_dict()
    return d["Ed"], d["Eb"], rep


@pytest.fixture(scope="module")
def clean_cal(clean):
    ds = read_bag(clean, **READ)
    return _cal(ds)


def test_clean_bag_gives_no_warning_and_no_offset(clean, clean_cal):
    ds = read_bag(clean, **READ)
    assert ds.meta["warnings"] == ()
    (off,) = ds.meta["time_offset"]
    assert abs(off["estimated_s"]) < 1e-3
    assert off["applied_s"] == 0.0 and off["correlation"] > 0.95
    ed, eb, rep = clean_cal
    assert len(ds.runs) == 2
    assert ed == pytest.approx(1.004, abs=2e-4) and eb == pytest.approx(1.02 / 0.99, abs=2e-3)
    assert rep.to_dict()["time_offset"][0]["estimated_s"] == off["estimated_s"]


def test_stamps_jumping_back_are_an_error_naming_topic_and_message(clean, tmp_path, capsys):
    def back(msgs):
        half = len(msgs) // 2
        return [(ns, _later(m, -5.0) if k >= half else m) for k, (ns, m) in enumerate(msgs)]

    bag = edit_bag(clean, tmp_path / "back", joint_states=back, ground_truth=back)
    with pytest.raises(InputError, match=r"joint states on /joint_states go backwards at message \d+") as e:
        read_bag(bag, **READ)
    assert e.value.source == str(bag) and "by up to 4.990 s" in str(e.value)
    assert main(["replay", str(bag), *CLI]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "go backwards" in err and "/joint_states" in err


@pytest.mark.parametrize("same_content", [True, False])
def test_every_message_recorded_twice_or_stamped_in_pairs_is_warned_about(clean, clean_cal, tmp_path, same_content):
    def dup(msgs):
        if same_content:  # every message recorded twice
            return [x for ns, m in msgs for x in ((ns, m), (ns + 1, m))]
        # the stamp is updated every second message only
        return [(ns, restamp(m, stamp_ns(msgs[k - k % 2][1]))) for k, (ns, m) in enumerate(msgs)]

    bag = edit_bag(clean, tmp_path / "dup", joint_states=dup)
    ds = read_bag(bag, **READ)
    # copies are dropped; a stamp kept for two messages of new content is a stream stamped in
    # bursts (each message's sample time recovered)
    said = "repeat the message before (the same stamp and content" if same_content else "arrive in bursts ("
    (w,) = [w for w in ds.meta["warnings"] if said in w]
    assert w.startswith(f"{ds.source}: ")  # the bag is named
    (stream,) = ds.meta["wheel_stream"]  # also in replay's JSON, per bag
    assert stream["bag"] == str(bag)
    if same_content:  # every message twice: half of them dropped
        assert 2 * stream["duplicates"] == stream["messages"] == 2 * stream["kept"]
    assert stream["clock"] == ("as recorded" if same_content else "recovered")
    assert "/joint_states" in w and "joint states" in w
    ed, eb, _ = _cal(ds)
    if same_content:  # nothing lost: the same calibration
        assert ed == pytest.approx(clean_cal[0], abs=1e-9) and eb == pytest.approx(clean_cal[1], abs=1e-9)


def test_ground_truth_covering_a_fifth_of_the_log_is_warned_about(clean, tmp_path):
    def first_fifth(msgs):
        return msgs[: len(msgs) // 5]

    bag = edit_bag(clean, tmp_path / "short", ground_truth=first_fifth)
    ds = read_bag(bag, nominal=NOMINAL, gt_topic="/ground_truth", wheels=WheelSource(joints=JOINT_NAMES))
    (w,) = [w for w in ds.meta["warnings"] if "covers only" in w]
    assert w.startswith(f"{ds.source}: ")  # the bag is named
    assert "/ground_truth" in w and "covers only 20 %" in w


def test_ground_truth_gap_is_warned_about(clean, tmp_path):
    def gap(msgs):
        n = len(msgs)
        return msgs[: n // 2] + msgs[n // 2 + 500 :]  # 5 s without poses

    ds = read_bag(edit_bag(clean, tmp_path / "gap", ground_truth=gap), **READ)
    (w,) = [w for w in ds.meta["warnings"] if "gap" in w]
    assert w.startswith(f"{ds.source}: ")  # the bag is named
    assert "/ground_truth" in w and "5.0" in w


def _with_position(msg, k_left: float):
    return dataclasses.replace(msg, position=np.array([k_left, msg.position[1]]))


def test_a_1e300_spike_in_a_joint_position_is_dropped_with_a_warning(clean, clean_cal, tmp_path):
    def spike(msgs):
        k = len(msgs) // 3
        return [(ns, _with_position(m, 1e300) if i == k else m) for i, (ns, m) in enumerate(msgs)]

    ds = read_bag(edit_bag(clean, tmp_path / "spike", joint_states=spike), **READ)
    (w,) = [w for w in ds.meta["warnings"] if "spike" in w]
    assert w.startswith(f"{ds.source}: ")  # the bag is named
    assert "/joint_states" in w and "at t=" in w and "1e+300" in w
    ed, eb, _ = _cal(ds)
    assert ed == pytest.approx(clean_cal[0], abs=1e-6) and eb == pytest.approx(clean_cal[1], abs=1e-5)


def _jump(msgs):
    """Joint-state edit: the left wheel's counter jumps by 1e6 from a third of the recording on."""
    k = len(msgs) // 3
    return [(ns, _with_position(m, m.position[0] + 1e6) if i >= k else m) for i, (ns, m) in enumerate(msgs)]


def test_a_jump_that_stays_cuts_the_log_there(clean, tmp_path, capsys):
    """A counter reset (a jump that stays) is not a reason to refuse the recording: it is cut
    there with a warning, and the longer part is used."""
    ref = read_bag(clean, **READ)
    bag = edit_bag(clean, tmp_path / "jump", joint_states=_jump)
    ds = read_bag(bag, **READ)
    (w,) = [w for w in ds.meta["warnings"] if "do not come back" in w]
    assert w.startswith(f"{ds.source}: ") and "/joint_states jump by 1e+06 at t=" in w
    assert "a counter reset" in w and "only the longer part" in w
    # the cw square is cut at the jump, the ccw square after it is whole
    assert ds.runs[0].t.size < ref.runs[0].t.size and ds.runs[1].t.size == ref.runs[1].t.size
    # a square cut short is no UMBmark run: replay says so in one line
    assert main(["replay", str(bag), *CLI]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not close" in err[0]


def test_ground_truth_2_s_late_is_warned_about(clean, clean_cal, tmp_path, capsys):
    bag = edit_bag(clean, tmp_path / "late", ground_truth=delayed(2.0))
    ds = read_bag(bag, **READ)
    (w,) = [w for w in ds.meta["warnings"] if "late" in w]
    assert w.startswith(f"{ds.source}: ")  # the bag is named
    assert "/ground_truth" in w and "2.000 s late" in w and "`time_offset=auto`" in w
    assert ds.meta["time_offset"][0]["applied_s"] == 0.0
    assert main(["replay", str(bag), *CLI]) == 0
    captured = capsys.readouterr()
    d = json.loads(captured.out)
    assert any("--time-offset auto" in x for x in d["warnings"])
    assert "warning: " in captured.err and "2.000 s late" in captured.err  # stderr too, with --json
    assert d["time_offset"][0]["estimated_s"] == pytest.approx(2.0, abs=0.01)
    pooled = [a if a != "exact" else "lsq" for a in CLI] + ["--pool"]
    assert main(["replay", str(bag), *pooled]) == 0
    assert "2.000 s late" in capsys.readouterr().err


# E_d and E_b after time_offset auto against the undelayed bag's: measured equal (the offset is
# found to within 0.4 ms, and the runs' end poses lie in the stops)
ED_TOL, EB_TOL = 1e-8, 1e-8


@pytest.mark.parametrize("tau_s", [0.1, 0.1234, 0.357, 1.0, 1.987])
def test_late_ground_truth_is_detected_and_corrected(clean, clean_cal, tmp_path, tau_s):
    """A 25 Hz ground truth delayed by 0.1-2 s: found to within one of its periods (40 ms), and
    the calibration with ``time_offset="auto"`` matches the undelayed one."""
    bag = edit_bag(clean, tmp_path / "late", ground_truth=delayed(tau_s, every=4))
    ds = read_bag(bag, **READ)
    assert any("s late" in w for w in ds.meta["warnings"])
    fixed = read_bag(bag, **READ, time_offset="auto")
    (off,) = fixed.meta["time_offset"]
    assert off["truth_period_s"] == pytest.approx(0.04, abs=1e-6)
    assert abs(off["applied_s"] - tau_s) < off["truth_period_s"]
    assert not any("late" in w for w in fixed.meta["warnings"])
    ed, eb, _ = _cal(fixed)
    assert abs(ed - clean_cal[0]) < ED_TOL and abs(eb - clean_cal[1]) < EB_TOL
    # lsq along the path (where a delay biases even the stops-based runs): measured after auto
    # 5.6e-7 in E_d and 4.4e-6 in E_b from the undelayed 100 Hz bag (the 25 Hz sampling, at every
    # delay); uncorrected E_b off by 1.7e-3 (0.1 s) to 7e-2 (1.99 s)
    ref = replay_report(read_bag(clean, **READ), "lsq", heldout=False).to_dict()
    lsq = replay_report(fixed, "lsq", heldout=False).to_dict()
    raw = replay_report(ds, "lsq", heldout=False).to_dict()
    assert abs(lsq["Ed"] - ref["Ed"]) < 2e-6 and abs(lsq["Eb"] - ref["Eb"]) < 2e-5
    assert abs(raw["Eb"] - ref["Eb"]) > 1e-3
    given = read_bag(bag, **READ, time_offset=tau_s)
    assert given.meta["time_offset"][0]["applied_s"] == tau_s


def test_cli_time_offset_auto_and_seconds(clean, clean_cal, tmp_path, capsys):
    bag = edit_bag(clean, tmp_path / "late", ground_truth=delayed(0.5, every=2))
    assert main(["replay", str(bag), *CLI, "--time-offset", "auto"]) == 0
    d = json.loads(capsys.readouterr().out)
    (off,) = d["time_offset"]
    assert off["requested"] == "auto" and abs(off["applied_s"] - 0.5) < 0.02 and off["bag"] == str(bag)
    assert abs(d["Ed"] - clean_cal[0]) < ED_TOL
    assert main(["replay", str(bag), *CLI, "--time-offset", "0.5"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["time_offset"][0]["applied_s"] == 0.5 and d["time_offset"][0]["requested"] == "0.5"
    text = [a for a in CLI if a != "--json"]
    assert main(["replay", str(bag), *text, "--time-offset", "0.5"]) == 0
    line = r"ground truth late by: estimated (49\d|50\d)\.\d ms, 500\.0 ms subtracted from its stamps"
    assert re.search(line, capsys.readouterr().out)
    assert main(["replay", str(bag), *CLI, "--time-offset", "soon"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--time-offset" in err and "auto" in err


def test_auto_without_turns_is_an_error(tmp_path):
    log = simulate_drive([Command(1.0), Command(5.0, 0.3), Command(1.0)], ROBOT, start_pose=(3.0, 4.0, 0.0))
    bag = write_drive_bag(log, tmp_path / "straight", truth=True, odom=False)
    kw = dict(nominal=NOMINAL, wheels=WheelSource(joints=JOINT_NAMES), gt_topic="/ground_truth")
    ds = read_bag(bag, **kw)
    assert ds.meta["time_offset"][0]["estimated_s"] is None
    assert "hardly turns" in ds.meta["time_offset"][0]["reason"]
    with pytest.raises(InputError, match="`time_offset` auto: cannot estimate.*hardly turns.*give it in seconds"):
        read_bag(bag, **kw, time_offset="auto")


def test_convert_says_the_ground_truth_is_late_and_can_correct_it(clean, clean_cal, tmp_path, capsys):
    """``convert`` of a late bag warns (stderr); with ``--time-offset auto`` the CSV it writes
    holds the aligned ground truth, and replaying that CSV gives the undelayed calibration.
    ``--stream`` cannot move a ground truth: an error."""
    bag = edit_bag(clean, tmp_path / "late", ground_truth=delayed(0.4, every=4))
    geometry = CLI[:8]
    out = tmp_path / "late.csv"
    assert main(["convert", str(bag), *geometry, "--split-stops", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"warning: {bag}: the ground truth on /ground_truth is 0.40" in err and "--time-offset auto" in err
    fixed = tmp_path / "fixed.csv"
    args = ["convert", str(bag), *geometry, "--split-stops", "--time-offset", "auto", "--out", str(fixed)]
    assert main(args) == 0
    assert "warning" not in capsys.readouterr().err
    assert main(["replay", str(fixed), "--side-mm", "2000", "--method", "exact", "--no-heldout", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert abs(d["Ed"] - clean_cal[0]) < 1e-6 and abs(d["Eb"] - clean_cal[1]) < 1e-5
    assert main(["replay", str(out), "--stream", "--time-offset", "auto", "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--time-offset" in err and "--stream" in err


def test_selfcal_bag_spike_is_dropped_and_a_jump_cuts_the_stream(clean, tmp_path):
    """The lidar self-calibration's reader: a 1e300 joint position in one message is dropped
    with a warning naming topic and time; a jump that stays cuts the wheel data there."""
    from umbmark.io.rosbag import read_selfcal_bag

    ref = read_selfcal_bag(clean, wheels=WheelSource(joints=JOINT_NAMES))
    assert not any("spike" in w for w in ref.warnings)

    def spike(msgs):
        k = len(msgs) // 3
        return [(ns, _with_position(m, 1e300) if i == k else m) for i, (ns, m) in enumerate(msgs)]

    got = read_selfcal_bag(
        edit_bag(clean, tmp_path / "spike", joint_states=spike), wheels=WheelSource(joints=JOINT_NAMES)
    )
    (w,) = [w for w in got.warnings if "spike" in w]
    assert "/joint_states" in w and "at t=" in w
    assert len(got.wheel_t_s) == len(ref.wheel_t_s) - 1
    assert np.array_equal(np.delete(ref.left_rad, len(ref.left_rad) // 3), got.left_rad)

    cut = read_selfcal_bag(
        edit_bag(clean, tmp_path / "jump", joint_states=_jump), wheels=WheelSource(joints=JOINT_NAMES)
    )
    (w,) = [w for w in cut.warnings if "do not come back" in w]
    assert "/joint_states jump by 1e+06 at t=" in w
    k = len(ref.wheel_t_s) // 3
    assert np.array_equal(cut.wheel_t_s, ref.wheel_t_s[k:])  # the longer part, after the jump
    assert cut.wheel_stream is not None and cut.wheel_stream.resets == 1


@pytest.mark.slow
def test_selfcal_scan_delay_auto_and_seconds(tmp_path, capsys):
    """Scans stamped 0.2 s late against the wheels: ``selfcal`` (``--scan-delay auto``, the
    default) finds the delay (scan-matched turns against the wheels' turns) and moves the scans
    back, and the calibration is that of the undelayed bag; ``--scan-delay SECONDS`` applies a
    known delay, ``--scan-delay off`` takes the stamps as recorded."""
    from umbmark.model.drive import SimRobot, mixed_program
    from umbmark.model.geometry import LABMATE
    from umbmark.model.sensors import SensorPose

    robot = SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.008, eb=1.02, es=1.0),
        sensor_pose=SensorPose(0.10, 0.02, math.radians(-3.0)),
        lidar=Lidar(n_beams=180, range_noise_m=0.003),
    )
    log = simulate_drive(mixed_program(60.0, seed=2, robot=robot), robot, seed=3)
    bag = write_drive_bag(log, tmp_path / "drive", odom=False)
    late = edit_bag(bag, tmp_path / "late", scan=delayed(0.2))
    args = ["--joints", ",".join(JOINT_NAMES), "--wheel-diameter-mm", "150", "--wheelbase-mm", "340", "--json"]
    every = ["--keyframe-mm", "0", "--keyframe-deg", "0", "--keyframe-s", "0", "--keyframe-min-s", "0"]

    def selfcal(b, *extra):
        assert main(["selfcal", str(b), *args, *extra]) == 0
        return json.loads(capsys.readouterr().out)

    # every scan an interval: the pairs are matched again from the delayed odometry
    ref, raw, auto, given = (
        selfcal(bag, *every, "--scan-delay", "off"),
        selfcal(late, *every, "--scan-delay", "off"),
        selfcal(late, *every, "--scan-delay", "auto"),
        selfcal(late, *every, "--scan-delay", "0.2"),
    )
    assert ref["scan_delay"][0]["applied_s"] == 0 and raw["scan_delay"][0]["requested"] == "0"
    # the default keyframes: the same delay found; the keyframes, chosen on matches started from
    # the late or the on-time odometry, are a few scans apart here and there, so the estimates
    # agree within their intervals (measured: 0.4 of a half-width)
    default, default_ref = selfcal(late), selfcal(bag, "--scan-delay", "off")
    assert default["scan_delay"][0]["applied_s"] == pytest.approx(auto["scan_delay"][0]["applied_s"], abs=1e-3)
    for key in ("Ed", "Eb"):
        half = 0.5 * (default_ref[key + "_ci95"][1] - default_ref[key + "_ci95"][0])
        assert abs(default[key] - default_ref[key]) < 0.6 * half
    (d,) = auto["scan_delay"]
    assert d["requested"] == "auto" and abs(d["applied_s"] - 0.2) < 2e-3 and d["correlation"] > d["correlation_at_zero"]
    # measured: E_d within 4e-7 and E_b within 6e-7 of the undelayed bag's (uncorrected: 1.1e-6, 1.1e-5)
    assert abs(auto["Ed"] - ref["Ed"]) < 2e-6 and abs(auto["Eb"] - ref["Eb"]) < 2e-6
    assert abs(raw["Eb"] - ref["Eb"]) > 5 * abs(auto["Eb"] - ref["Eb"])
    assert given["scan_delay"][0]["applied_s"] == 0.2 and abs(given["Eb"] - ref["Eb"]) < 1e-6
    assert main(["selfcal", str(late), *args, "--scan-delay", "soon"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--scan-delay must be auto, off or seconds" in err


def test_messages_a_little_out_of_order_are_sorted_with_a_warning(clean, clean_cal, tmp_path):
    """Every 100th ground-truth pose recorded after the next one (delivered late over a
    network): put in stamp order with a warning, and the calibration is unchanged."""

    def late_delivery(msgs):
        out = list(msgs)
        for k in range(100, len(out) - 1, 100):
            (na, a), (nb, b) = out[k], out[k + 1]
            out[k], out[k + 1] = (na, b), (nb, a)  # b's stamp is later than a's, but it comes first
        return out

    ds = read_bag(edit_bag(clean, tmp_path / "jitter", ground_truth=late_delivery), **READ)
    (w,) = [w for w in ds.meta["warnings"] if "out of stamp order" in w]
    assert w.startswith(f"{ds.source}: ") and "ground-truth poses on /ground_truth" in w and "10.0 ms" in w
    ed, eb, _ = _cal(ds)
    assert ed == pytest.approx(clean_cal[0], abs=1e-12) and eb == pytest.approx(clean_cal[1], abs=1e-12)


def _moved(msg, dx_m: float):
    p = msg.pose.position
    pos = dataclasses.replace(p, x=p.x + dx_m)
    return dataclasses.replace(msg, pose=dataclasses.replace(msg.pose, position=pos))


def test_ground_truth_spike_is_dropped_and_a_jump_is_warned_about(clean, clean_cal, tmp_path):
    def spike(msgs):
        k = len(msgs) // 3
        return [(ns, _moved(m, 1e300) if i == k else m) for i, (ns, m) in enumerate(msgs)]

    ds = read_bag(edit_bag(clean, tmp_path / "spike", ground_truth=spike), **READ)
    (w,) = [w for w in ds.meta["warnings"] if "spike" in w]
    assert w.startswith(f"{ds.source}: ") and "ground-truth poses on /ground_truth" in w and "at t=" in w
    ed, eb, _ = _cal(ds)
    assert ed == pytest.approx(clean_cal[0], abs=1e-6) and eb == pytest.approx(clean_cal[1], abs=1e-5)

    def jump(msgs):
        k = len(msgs) // 3
        return [(ns, _moved(m, 3.0) if i >= k else m) for i, (ns, m) in enumerate(msgs)]

    ds = read_bag(edit_bag(clean, tmp_path / "jump", ground_truth=jump), **READ)
    (w,) = [w for w in ds.meta["warnings"] if "jump by" in w]
    assert "/ground_truth jump by 3 m at t=" in w and "stay there" in w
