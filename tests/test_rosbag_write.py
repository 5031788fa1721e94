"""umbmark.io.rosbag_write: a simulated drive written as ROS 1, ROS 2 sqlite3 and ROS 2 mcap bags, read back
with rosbags and with umbmark.io.rosbag.read_bag."""

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from umbmark.correct.lsq import fit_lsq  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import read_bag  # noqa: E402
from umbmark.io.rosbag_write import EPOCH_S, JOINT_NAMES, storage_of, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.drive import EXAMPLE_ROBOT, Command, WheelNoise, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import wrap_angle  # noqa: E402
from umbmark.model.sensors import Lidar  # noqa: E402

NAMES = {"ros1": "drive.bag", "sqlite3": "drive", "mcap": "drive"}
T0_NS = 1_700_000_000 * 10**9


@pytest.fixture(scope="module")
def log():
    robot = dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(n_beams=120, range_noise_m=0.005, dropout_prob=0.05))
    return simulate_drive(mixed_program(20.0, seed=4), robot, noise=WheelNoise(slip_m_per_sqrt_m=1e-4), seed=4)


@pytest.fixture(scope="module", params=["ros1", "sqlite3", "mcap"])
def bag(request, log, tmp_path_factory):
    storage = request.param
    path = tmp_path_factory.mktemp(storage) / NAMES[storage]
    out = write_drive_bag(log, path, storage=storage, truth=True)
    assert out == path
    return storage, path


def _read_all(path):
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        msgs: dict[str, list] = {}
        for c, ns, raw in reader.messages():
            msgs.setdefault(c.topic, []).append((ns, reader.deserialize(raw, c.msgtype)))
    return counts, types, msgs


def _stamp_ns(msg):
    s = msg.header.stamp
    return s.sec * 10**9 + s.nanosec


def _yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def test_round_trip(bag, log):
    storage, path = bag
    assert path.is_file() == (storage == "ros1")
    if storage != "ros1":
        assert (path / "metadata.yaml").is_file() and (
            path / f"drive.{'db3' if storage == 'sqlite3' else 'mcap'}"
        ).is_file()
    counts, types, msgs = _read_all(path)
    K, M = len(log.t_s), len(log.scan_t_s)
    assert (K, M) == (2001, 201)
    assert counts == {"/joint_states": K, "/scan": M, "/odom": K, "/tf_static": 1, "/ground_truth": K}
    assert types["/scan"] == "sensor_msgs/msg/LaserScan" and types["/tf_static"] == "tf2_msgs/msg/TFMessage"

    wheel_ns = T0_NS + np.round(log.t_s * 1e9).astype(np.int64)
    joints = msgs["/joint_states"]
    assert [ns for ns, _ in joints] == wheel_ns.tolist()
    assert [_stamp_ns(m) for _, m in joints] == wheel_ns.tolist()
    assert all(list(m.name) == list(JOINT_NAMES) for _, m in joints)
    pos = np.array([m.position for _, m in joints])
    np.testing.assert_array_equal(pos, np.column_stack([log.left_rad, log.right_rad]))
    np.testing.assert_allclose(joints[500][1].velocity[0], (log.left_rad[500] - log.left_rad[499]) * 100.0)

    scans = msgs["/scan"]
    scan_ns = T0_NS + np.round(log.scan_t_s * 1e9).astype(np.int64)
    assert [_stamp_ns(m) for _, m in scans] == scan_ns.tolist() == [ns for ns, _ in scans]
    s = scans[57][1]
    assert s.header.frame_id == "laser"
    assert s.angle_min == pytest.approx(log.lidar.first_angle_rad, abs=1e-6)
    assert s.angle_increment == pytest.approx(log.lidar.angle_increment_rad, rel=1e-6)
    assert s.angle_max == pytest.approx(log.angles_rad[-1], abs=1e-6)
    assert (s.range_min, s.range_max) == pytest.approx((0.05, 12.0))
    assert s.ranges.dtype == np.float32
    np.testing.assert_array_equal(s.ranges, log.ranges_m[57].astype(np.float32))
    assert np.isinf(s.ranges).sum() > 0  # the dropouts are written as inf

    ((ns, tf),) = msgs["/tf_static"]
    assert ns == T0_NS
    (tr,) = tf.transforms
    assert (tr.header.frame_id, tr.child_frame_id) == ("base_link", "laser")
    p = log.sensor_pose
    assert (tr.transform.translation.x, tr.transform.translation.y, tr.transform.translation.z) == pytest.approx(
        (p.x_m, p.y_m, 0.0), abs=1e-15
    )
    assert _yaw(tr.transform.rotation) == pytest.approx(p.yaw_rad, abs=1e-15)

    odo = log.odometry()
    o = msgs["/odom"][-1][1]
    assert (o.header.frame_id, o.child_frame_id) == ("odom", "base_link")
    assert (o.pose.pose.position.x, o.pose.pose.position.y) == pytest.approx(tuple(odo[-1, :2]), abs=1e-12)
    assert _yaw(o.pose.pose.orientation) == pytest.approx(float(wrap_angle(odo[-1, 2])), abs=1e-12)
    g = log.nominal_geometry
    k = 700
    vl = 0.5 * g.diameter_left_m * (log.left_rad[k] - log.left_rad[k - 1]) * 100.0
    vr = 0.5 * g.diameter_right_m * (log.right_rad[k] - log.right_rad[k - 1]) * 100.0
    tw = msgs["/odom"][k][1].twist.twist
    assert (tw.linear.x, tw.angular.z) == pytest.approx((0.5 * (vl + vr), (vr - vl) / g.wheelbase_m), rel=1e-12)

    gt = msgs["/ground_truth"][1234][1]
    assert gt.header.frame_id == "map"
    assert (gt.pose.position.x, gt.pose.position.y) == pytest.approx(tuple(log.true_pose[1234, :2]), abs=1e-12)


def test_read_bag_reads_the_joint_states(bag, log):
    _, path = bag
    ds = read_bag(path, nominal=log.nominal_geometry, wheels=WheelSource(joints=JOINT_NAMES))
    (run,) = ds.runs
    assert ds.units_per_wheel_rev == pytest.approx(2 * math.pi)
    np.testing.assert_allclose(run.t, log.t_s, atol=1e-6)
    np.testing.assert_allclose(np.cumsum(run.d_left), log.left_rad - log.left_rad[0], atol=1e-9)
    np.testing.assert_allclose(np.cumsum(run.d_right), log.right_rad - log.right_rad[0], atol=1e-9)


def test_the_ground_truth_gives_back_the_true_geometry(tmp_path):
    """With /ground_truth, umbmark's path fit finds the simulated robot's true wheels and wheelbase."""
    robot = dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(n_beams=8, range_noise_m=0.0))
    drive = simulate_drive(mixed_program(40.0, seed=1, robot=robot), robot)
    path = write_drive_bag(drive, tmp_path / "truth", storage="mcap", odom=False, truth=True)
    ds = read_bag(
        path, nominal=drive.nominal_geometry, gt_topic="/ground_truth", wheels=WheelSource(joints=JOINT_NAMES)
    )
    res = fit_lsq(ds)
    true = drive.true_geometry
    assert res.geometry.ed == pytest.approx(true.ed, abs=1e-6)
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-5)
    assert res.geometry.diameter_left_m == pytest.approx(true.diameter_left_m, rel=1e-5)


@pytest.mark.parametrize("storage", ["ros1", "sqlite3", "mcap"])
def test_an_existing_bag_is_not_overwritten(tmp_path, storage):
    short = simulate_drive([Command(0.1, 0.2)], EXAMPLE_ROBOT, seed=0)  # 11 wheel samples, 2 scans
    path = write_drive_bag(short, tmp_path / NAMES[storage], storage=storage, odom=False)
    before = sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns) for p in tmp_path.rglob("*"))
    with pytest.raises(InputError, match="not overwriting"):
        write_drive_bag(short, path, storage=storage)
    assert sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns) for p in tmp_path.rglob("*")) == before
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="not overwriting"):
        write_drive_bag(short, tmp_path / "empty", storage="mcap")
    counts, _, _ = _read_all(path)
    assert counts == {"/joint_states": 11, "/scan": 2, "/tf_static": 1}


def test_storage_names_and_bad_arguments(tmp_path, log):
    assert storage_of("x.bag") == "ros1" and storage_of("x") == "sqlite3" and storage_of("x", "mcap") == "mcap"
    with pytest.raises(InputError, match="unknown bag storage"):
        storage_of("x", "hdf5")
    with pytest.raises(InputError, match="ROS 1 bag is a .bag file"):
        storage_of("x", "ros1")
    with pytest.raises(InputError, match="folder, not a .bag"):
        storage_of("x.bag", "mcap")
    with pytest.raises(InputError, match="does not exist"):
        write_drive_bag(log, tmp_path / "missing" / "drive.bag")
    with pytest.raises(InputError, match="epoch_s"):
        write_drive_bag(log, tmp_path / "d.bag", epoch_s=math.nan)
    assert not any(tmp_path.iterdir())  # nothing left behind
    assert EPOCH_S == 1.7e9


def test_a_failed_write_leaves_nothing(tmp_path, log):
    broken = dataclasses.replace(log, ranges_m=np.full((len(log.scan_t_s), 2), "x"))  # no float32 ranges
    with pytest.raises(ValueError):
        write_drive_bag(broken, tmp_path / "d", storage="mcap")
    assert not any(tmp_path.iterdir())


def test_scans_stamped_late_and_with_jitter(log, tmp_path):
    """DriveLog.stamped: the scans' stamps (only) are late by the delay, scattered by the jitter
    and in order; the bag carries them, and the reader reads them back."""
    late = log.stamped(delay_s=0.03, jitter_s=0.004, seed=2)
    np.testing.assert_array_equal(late.scan_t_s, log.scan_t_s)
    np.testing.assert_array_equal(late.ranges_m, log.ranges_m)
    off = late.scan_stamps_s - log.scan_t_s
    assert np.all(np.diff(late.scan_stamps_s) > 0)
    assert abs(off.mean() - 0.03) < 0.002 and 0.002 < off.std() < 0.006
    np.testing.assert_array_equal(log.stamped(0.03, 0.004, seed=2).scan_stamp_s, late.scan_stamp_s)
    np.testing.assert_array_equal(log.stamped(0.5).scan_stamps_s, log.scan_t_s + 0.5)
    from umbmark.io.rosbag import read_selfcal_bag

    path = write_drive_bag(late, tmp_path / "late.bag", storage="ros1")
    bag = read_selfcal_bag(path, wheels=WheelSource(joints=JOINT_NAMES))
    np.testing.assert_allclose(bag.scan_t_s - EPOCH_S, late.scan_stamps_s, atol=1e-6)  # seconds since 1970
    with pytest.raises(InputError, match="`jitter_s` >= 0"):
        log.stamped(jitter_s=-1.0)
