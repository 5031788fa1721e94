"""Wheel data as real robots record them (umbmark.model.arrival, umbmark.model.wheel_stream):
streams stamped on arrival in bursts, late and repeated messages, holes and counter resets.

The maths on its own (the sample clock, the late messages found by their content), then
simulated bags with the artefacts of real recordings, self-calibrated: the same truth as the
clean bag."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.model.arrival import HEADING_LEVER_M, late_messages, sample_clock, steady_period
from umbmark.model.wheel_stream import check_wheel_stream


def _burst_stamps(rng, n: int, period: float, max_burst: int) -> tuple[np.ndarray, np.ndarray]:
    """A steady stream's sample times, and their arrival stamps: bursts of 1 to ``max_burst``,
    each arriving just after its last message was made."""
    tau = period * np.arange(n)
    s = np.empty(n)
    k = 0
    while k < n:
        m = int(rng.integers(1, max_burst + 1))
        last = min(n, k + m) - 1
        arrive = tau[last] + rng.uniform(0.0, 0.01 * period)
        s[k : last + 1] = arrive + 1e-5 * np.arange(last + 1 - k)
        k = last + 1
    return tau, s


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), max_burst=st.integers(1, 8), period=st.sampled_from([0.01, 0.02, 0.1]))
def test_the_sample_clock_of_a_steady_stream_stamped_on_arrival(seed, max_burst, period):
    """Recovered times: never after a stamp, increasing, and within a few per cent of a period
    per message of its burst of the true sample times; a stream on time keeps its stamps."""
    rng = np.random.default_rng(seed)
    tau, s = _burst_stamps(rng, 500, period, max_burst)
    p = steady_period(s)
    assert p == pytest.approx(period, rel=0.01)
    got = sample_clock(s, 0.97 * p)
    assert np.all(got <= s) and np.all(np.diff(got) > 0)
    assert np.max(np.abs(got - tau)) <= period * (0.05 * max_burst + 0.02)
    on_time = tau + rng.uniform(0.0, 0.01 * period, tau.size)
    assert np.array_equal(sample_clock(on_time, 0.97 * period), on_time)


def _path(rng, n: int) -> np.ndarray:
    """A robot's odometry content (x, y, lever x heading) at n samples: arcs, spins, stops, each
    for 20 or 25 samples."""
    v = np.repeat(rng.uniform(-0.03, 0.05, n // 20 + 1) * (rng.random(n // 20 + 1) < 0.8), 20)[:n]
    w = np.repeat(rng.uniform(-0.3, 0.3, n // 25 + 1) * (rng.random(n // 25 + 1) < 0.7), 25)[:n]
    h = np.cumsum(w)
    x = np.column_stack([np.cumsum(v * np.cos(h)), np.cumsum(v * np.sin(h)), HEADING_LEVER_M * h])
    return x


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), back=st.integers(2, 15))
def test_late_messages_are_found_by_their_content(seed, back):
    """A real path has no late message; copies of messages ``back`` samples old put into it
    (where the robot moved since, farther than two and a half of its steps there) are each found,
    and named as late."""
    rng = np.random.default_rng(seed)
    x = _path(rng, 400)
    assert late_messages(x) == []
    at = np.sort(rng.choice(np.arange(40, 380), 5, replace=False))
    at = at[np.diff(np.concatenate([[0], at])) > 3]
    rows, copies = list(x), []
    step = np.linalg.norm(np.diff(x, axis=0), axis=1)
    for i in at[::-1]:
        moved = np.linalg.norm(x[i] - x[i - back])  # the robot moved since: a visible copy
        if moved > 0.05 and moved > 2.5 * np.median(step[i - 10 : i + 10]):
            rows.insert(i + 1, x[i - back])
            copies.append(i + 1)
    runs = late_messages(np.array(rows))
    found = sorted(r.start for r in runs)
    shifted = sorted(c + sum(1 for d in copies if d < c) for c in copies)
    # each copy found; where the robot turns back along its path the copy lies on it and the
    # message beside it is the one off the path: one of the two is dropped, nothing elsewhere
    assert len(found) == len(shifted) and all(abs(f - c) <= 1 for f, c in zip(found, shifted)), (found, shifted)
    assert sum(r.late for r in runs) >= len(runs) - 1


def test_a_stream_in_bursts_with_late_copies_and_a_reset():
    """Odometry at 10 Hz arriving in pairs, two copies of older messages, a reset to zero: the
    clock recovered, the copies dropped, the stream cut at the reset; the report says so."""
    t = 0.1 * np.arange(600)
    x, y = 0.5 * t, np.zeros(600)  # 0.5 m/s ahead
    x[400:] -= x[400]  # the odometry starts again from zero
    s = t.copy()
    s[0:-1:2] = s[1::2] - 1e-4  # stamped on arrival, two at a time
    order = np.arange(600)
    idx = np.insert(order, [100, 250], [80, 200])  # two late copies, stamped as they arrive
    stamps = s[idx]
    stamps[[100, 251]] = stamps[[99, 250]] + 5e-5
    chk = check_wheel_stream(stamps, x[idx], y[idx], metres_per_unit=1.0, poses=True, what="odometry poses",
                             topic="/odom", heading=np.zeros(idx.size))  # fmt: skip
    r = chk.report
    assert r is not None and r.clock == "recovered" and r.late == 2 and r.resets == 1
    assert r.kept_span_s == pytest.approx((0.0, 39.9), abs=0.11)  # the part before the reset: 400 samples
    assert chk.t.size == 400 and np.allclose(chk.t, t[:400] + (chk.t[1] - t[1]), atol=0.004)
    said = " / ".join(chk.warnings)
    for words in ("arrive in bursts", "carry content older than their stamp", "a counter reset"):
        assert words in said
    line = r.summary()
    assert "the sample clock recovered" in line and "2 late" in line and "cut at 1 reset" in line


# ---- simulated bags with the artefacts of real recordings, self-calibrated

pytest.importorskip("rosbags")
import bagedit  # noqa: E402

from umbmark.io.rosbag_write import JOINT_NAMES, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import SimRobot, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import LABMATE, ErrorParams  # noqa: E402
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.selfcal import selfcal_from_bags  # noqa: E402

ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
    sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
    lidar=Lidar(n_beams=360, range_noise_m=0.005),
)


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    log = simulate_drive(mixed_program(120.0, seed=21, robot=ROBOT), ROBOT, seed=22)
    root = tmp_path_factory.mktemp("arrival")
    return log, write_drive_bag(log, root / "clean", storage="sqlite3", odom=True), root


def _selfcal(path, wheels):
    return selfcal_from_bags(path, LABMATE.wheel_diameter_m, LABMATE.wheelbase_m, wheels=wheels).to_dict()


def _check_truth(d, log):
    """The pinned accuracy of the clean bag: diameters and wheelbase within 0.3 %, the lidar
    within 5 mm and 0.3 deg."""
    true, pose = log.true_geometry, log.sensor_pose
    for key, value in (
        ("wheel_diameter_left_mm", true.diameter_left_m * 1e3),
        ("wheel_diameter_right_mm", true.diameter_right_m * 1e3),
        ("wheelbase_mm", true.wheelbase_m * 1e3),
    ):
        assert abs(d[key] / value - 1) < 0.003, (key, d[key], value)
    sp = d["sensor_pose"]
    assert abs(sp["x_mm"] - pose.x_m * 1e3) < 5 and abs(sp["y_mm"] - pose.y_m * 1e3) < 5
    assert abs(sp["yaw_deg"] - math.degrees(pose.yaw_rad)) < 0.3


def test_joint_states_in_bursts_with_late_and_repeated_messages_a_hole_and_lost_scans(drive, tmp_path):
    """Joint states stamped on arrival four at a time, every 150th sent again 0.6 s later, 2 %
    recorded twice, a 1.5 s hole; 3 % of the scans lost: the truth, and a report of each."""
    log, clean, _ = drive
    bag = bagedit.edit_bag(
        clean,
        tmp_path / "joints",
        joint_states=bagedit.chain(
            bagedit.hole(40.0, 1.5), bagedit.late_copies(150, 0.6), bagedit.arrival_bursts(4), bagedit.duplicated(0.02)
        ),
        scan=bagedit.dropped(0.03),
    )
    d = _selfcal(bag, WheelSource(joints=JOINT_NAMES))
    _check_truth(d, log)
    r = d["inputs"][0]["wheel_stream"]
    assert r["clock"] == "recovered" and 70 <= r["late"] <= 79 and r["duplicates"] > 100
    assert 0.55 < r["late_max_age_s"] < 0.65 and r["resets"] == 0 and r["rate_hz"] == pytest.approx(100, rel=0.01)
    said = " / ".join(d["warnings"])
    assert "wrapped" not in said and "reset" not in said and "spike" not in said


def test_odometry_over_a_wireless_link(drive, tmp_path):
    """/odom at 10 Hz arriving in bursts, 1 % followed by a copy of a message up to a second
    old: the truth, as from the clean bag."""
    log, clean, _ = drive
    bag = bagedit.edit_bag(clean, tmp_path / "odom", odom=bagedit.wireless_odometry())
    d = _selfcal(bag, WheelSource(odom_topic="/odom"))
    _check_truth(d, log)
    r = d["inputs"][0]["wheel_stream"]
    assert r["clock"] == "recovered" and r["late"] >= 5 and r["spikes"] == 0 and r["resets"] == 0
    assert r["rate_hz"] == pytest.approx(10.0, rel=0.01)
