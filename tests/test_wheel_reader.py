"""One wheel reader: the three bag paths (a replay's :func:`read_bag`, a self-calibration's
:func:`read_selfcal_bag`, a gyro's :func:`read_gyro_bag`) read the same wheel travel from the same
bag, whether the wheels are joint states, encoder counts or an odometry, clean or with a damaged
message; :class:`WheelSource` checks its fields once, for all of them."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")

from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import read_bag, read_gyro_bag, read_selfcal_bag  # noqa: E402
from umbmark.io.rosbag_write import JOINT_NAMES, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import EXAMPLE_ROBOT, Command, simulate_drive, simulate_gyro  # noqa: E402
from umbmark.model.sensors import Gyro, Lidar  # noqa: E402
from umbmark.realrobot.wheels import recording_wheel_angles  # noqa: E402

PPR = 4096.0
ROBOT = dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(n_beams=90))
NOMINAL = ROBOT.nominal_wheels
SOURCES = {
    "joints": WheelSource.joint_states(*JOINT_NAMES),
    "ticks": WheelSource.encoder_counts("/wheel_ticks", "vector.x", "vector.y", PPR),
    "odom": WheelSource.odometry("/odom"),
}


def _drive():
    program = [Command(1.0), Command(2.0, 0.3), Command(2.0, 0.2, 0.6), Command(2.0, 0.0, -0.8), Command(1.0)]
    return simulate_drive(program, ROBOT, seed=2)


def _bag(tmp_path, log, name, storage):
    g_t, g_w = simulate_gyro(log, Gyro(100.0, 1.0, 0.0, 1e-4), seed=3)
    path = tmp_path / (f"{name}.bag" if storage == "ros1" else name)
    return write_drive_bag(log, path, storage=storage, gyro=(g_t, g_w), ticks_per_rev=PPR)


def _three_paths(bag, source):
    """The wheel stamps and the wheel angles' increments [rad] each path reads."""
    ds = read_bag(bag, nominal=NOMINAL, wheels=source)
    (run,) = ds.runs
    k = 2 * math.pi / ds.units_per_wheel_rev
    replay = (run.t, run.d_left[1:] * k, run.d_right[1:] * k)
    sb = read_selfcal_bag(bag, wheels=source)
    left, right = recording_wheel_angles(sb, NOMINAL)
    selfcal = (sb.wheel_t_s - sb.wheel_t_s[0], np.diff(left), np.diff(right))
    gb = read_gyro_bag(bag, imu_topic="/imu", nominal=NOMINAL, wheels=source)
    gyro = (gb.wheel_t_s - gb.wheel_t_s[0], np.diff(gb.left_rad), np.diff(gb.right_rad))
    return replay, selfcal, gyro, (ds.meta["warnings"], sb.warnings, gb.warnings)


@pytest.mark.parametrize("storage", ["ros1", "mcap"])
@pytest.mark.parametrize("kind", sorted(SOURCES))
def test_the_three_bag_paths_read_the_same_wheel_travel(tmp_path, storage, kind):
    log = _drive()
    bag = _bag(tmp_path, log, "drive", storage)
    replay, selfcal, gyro, _ = _three_paths(bag, SOURCES[kind])
    for other in (selfcal, gyro):
        np.testing.assert_array_equal(replay[0], other[0])
        np.testing.assert_allclose(replay[1], other[1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(replay[2], other[2], rtol=0, atol=1e-12)
    # and what was read is the drive's wheel travel: to a pulse for the encoders, exactly else
    tol = 2 * math.pi / PPR if kind == "ticks" else 1e-9
    np.testing.assert_allclose(np.cumsum(replay[1]), log.left_rad[1:] - log.left_rad[0], rtol=0, atol=tol)
    np.testing.assert_allclose(np.cumsum(replay[2]), log.right_rad[1:] - log.right_rad[0], rtol=0, atol=tol)


@pytest.mark.parametrize("kind", ["joints", "ticks"])
def test_a_spike_is_dropped_alike_by_the_three_paths(tmp_path, kind):
    """A corrupt wheel sample (a jump far beyond any wheel, and back) is dropped by every path,
    with the same warning."""
    log = _drive()
    k = len(log.t_s) // 2
    left = log.left_rad.copy()
    left[k] += 1e6
    bag = _bag(tmp_path, dataclasses.replace(log, left_rad=left), "spike", "sqlite3")
    replay, selfcal, gyro, warnings = _three_paths(bag, SOURCES[kind])
    assert len(replay[0]) == len(log.t_s) - 1
    for other in (selfcal, gyro):
        np.testing.assert_array_equal(replay[0], other[0])
        np.testing.assert_allclose(replay[1], other[1], rtol=0, atol=1e-12)
    spikes = [[w for w in ws if "spike(s)" in w] for ws in warnings]
    assert all(len(s) == 1 for s in spikes)
    assert spikes[0][0].endswith(spikes[1][0]) and spikes[1][0] == spikes[2][0]


@pytest.mark.parametrize(
    ("source", "message"),
    [
        (WheelSource(), "give the wheel data"),
        (WheelSource(joints=JOINT_NAMES, odom_topic="/odom"), "one source of wheel data, not several"),
        (WheelSource(ticks_topic="/wheel_ticks", left_field="vector.x", right_field="vector.y"), "pulses per wheel"),
        (WheelSource.encoder_counts("/wheel_ticks", "vector.x", "vector.y", -5.0), "pulses per wheel"),
        (WheelSource.encoder_counts("/wheel_ticks", "vector.x", "vector.y", PPR, ticks="delta"), "ticks must be"),
        (WheelSource(ticks_topic="/wheel_ticks", left_field="vector.x", pulses_per_wheel_rev=PPR), "`right_field`"),
        (WheelSource(joints=("left", "")), "two names"),
    ],
)
def test_one_check_of_the_wheel_source_for_every_reader(tmp_path, source, message):
    bag = _bag(tmp_path, _drive(), "drive", "sqlite3")
    for read in (
        lambda: read_bag(bag, nominal=NOMINAL, wheels=source),
        lambda: read_selfcal_bag(bag, wheels=source),
        lambda: read_gyro_bag(bag, imu_topic="/imu", nominal=NOMINAL, wheels=source),
    ):
        with pytest.raises(InputError, match=message) as e:
            read()
        assert "\n" not in str(e.value)


def test_the_source_in_words():
    assert SOURCES["joints"].description == f"JointState {JOINT_NAMES[0]}, {JOINT_NAMES[1]} on /joint_states"
    ticks = "encoder counts vector.x, vector.y on /wheel_ticks (cumulative, 4096 per rev)"
    assert SOURCES["ticks"].description == ticks
    assert SOURCES["odom"].description == "nav_msgs/Odometry on /odom"
    assert [s.kind for s in SOURCES.values()] == ["joints", "ticks", "odom"]
    assert SOURCES["ticks"].units_per_wheel_rev == PPR and SOURCES["odom"].units_per_wheel_rev == pytest.approx(
        2 * math.pi
    )
