"""ROS 1 / ROS 2 (sqlite3, mcap) bags written here with the rosbags Writer: a simulated robot's
wheel joint positions and ground truth must give back its true geometry."""

import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
import simlogs  # noqa: E402
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from umbmark.cli import main  # noqa: E402
from umbmark.correct.lsq import fit_lsq  # noqa: E402
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.rosbag import bag_info, read_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.model.dataset import WheelGeometry  # noqa: E402

T0 = 1_700_000_000
DT = 0.02
NOMINAL = WheelGeometry(simlogs.GEOM.wheel_diameter_m, simlogs.GEOM.wheel_diameter_m, simlogs.GEOM.wheelbase_m)


@pytest.fixture(scope="module")
def sim():
    al, ar, pose = simlogs.simulate_wheels(simlogs.general_program())
    return np.cumsum(al), np.cumsum(ar), simlogs.world(pose)


def _msgs(ts, ros1, pos_l, pos_r, gt, gt_kind, ticks=None):
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]

    def header(k, frame=""):
        t = T0 + k * DT
        sec = int(t)
        stamp = Time(sec=sec, nanosec=int(round((t - sec) * 1e9)))
        if ros1:
            return T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=frame)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def quat(yaw):
        return T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    out = []
    for k in range(len(pos_l)):
        ns = int(round((T0 + k * DT) * 1e9))
        js = T["sensor_msgs/msg/JointState"](
            header=header(k),
            name=["wheel_left", "caster", "wheel_right"],
            position=np.array([pos_l[k], 0.3, pos_r[k]]),
            velocity=np.array([], float),
            effort=np.array([], float),
        )
        out.append(("/joint_states", "sensor_msgs/msg/JointState", ns, js))
        x, y, th = gt[k]
        pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=quat(th))
        if gt_kind == "pose":
            out.append(
                (
                    "/mocap/pose",
                    "geometry_msgs/msg/PoseStamped",
                    ns,
                    T["geometry_msgs/msg/PoseStamped"](header=header(k, "world"), pose=pose),
                )
            )
        elif gt_kind == "odom":
            cov = np.zeros(36)
            tw = T["geometry_msgs/msg/Twist"](
                linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            )
            out.append(
                (
                    "/ground_truth",
                    "nav_msgs/msg/Odometry",
                    ns,
                    T["nav_msgs/msg/Odometry"](
                        header=header(k, "world"),
                        child_frame_id="robot",
                        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
                        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=cov),
                    ),
                )
            )
        elif gt_kind == "tf":
            tr = T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0), rotation=quat(th)
            )
            other = T["geometry_msgs/msg/TransformStamped"](
                header=header(k, "world"), child_frame_id="decoy", transform=tr
            )
            mine = T["geometry_msgs/msg/TransformStamped"](
                header=header(k, "world"), child_frame_id="robot_mocap", transform=tr
            )
            out.append(("/tf", "tf2_msgs/msg/TFMessage", ns, T["tf2_msgs/msg/TFMessage"](transforms=[other, mine])))
        if ticks is not None:
            arr = T["std_msgs/msg/Int64MultiArray"](
                layout=T["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0),
                data=np.array([int(ticks[0][k]), int(ticks[1][k])], dtype=np.int64),
            )
            out.append(("/encoders", "std_msgs/msg/Int64MultiArray", ns, arr))
    return out


def write_ros2(path, storage, *args, **kw):
    ts = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as w:
        conns = {}
        for topic, mtype, ns, msg in _msgs(ts, False, *args, **kw):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, mtype, typestore=ts)
            w.write(conns[topic], ns, ts.serialize_cdr(msg, mtype))
    return path


def write_ros1(path, *args, **kw):
    ts = get_typestore(Stores.ROS1_NOETIC)
    with Writer1(path) as w:
        conns = {}
        for topic, mtype, ns, msg in _msgs(ts, True, *args, **kw):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, mtype, typestore=ts)
            w.write(conns[topic], ns, ts.serialize_ros1(msg, mtype))
    return path


def _check_true(ds):
    res = fit_lsq(ds)
    true = simlogs.true_geometry()
    assert res.scale_fitted
    assert abs(res.geometry.ed - true.ed) < 1e-4
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-3)
    assert res.geometry.diameter_left_m == pytest.approx(true.diameter_left_m, rel=1e-3)
    return res


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_jointstate_posestamped_gives_true_parameters(tmp_path, sim, storage):
    bag = write_ros2(tmp_path / f"bag_{storage}", storage, *sim, "pose")
    ds = read_bag(
        bag, nominal=NOMINAL, gt_topic="/mocap/pose", wheels=WheelSource(joints=("wheel_left", "wheel_right"))
    )
    assert ds.units_per_wheel_rev == pytest.approx(2 * math.pi)
    run = ds.runs[0]
    assert np.allclose(run.gt[0], 0.0, atol=1e-12)  # world frame -> start frame
    res = _check_true(ds)
    assert res.rms_position_m < 1e-6  # noise free: the replay matches the ground truth


def test_ros1_bag_with_odometry_ground_truth(tmp_path, sim):
    bag = write_ros1(tmp_path / "run.bag", *sim, "odom")
    ds = read_bag(
        bag, nominal=NOMINAL, gt_topic="/ground_truth", wheels=WheelSource(joints=("wheel_left", "wheel_right"))
    )
    _check_true(ds)


def test_tf_ground_truth_and_tick_topic(tmp_path, sim):
    pos_l, pos_r, gt = sim
    ppr = 4096.0
    ticks = (np.round(pos_l / (2 * math.pi) * ppr), np.round(pos_r / (2 * math.pi) * ppr))
    bag = write_ros2(tmp_path / "tf", "sqlite3", pos_l, pos_r, gt, "tf", ticks=ticks)
    ds = read_bag(
        bag,
        nominal=NOMINAL,
        gt_topic="/tf",
        gt_frame="robot_mocap",
        wheels=WheelSource(
            ticks_topic="/encoders", left_field="data[0]", right_field="data[1]", pulses_per_wheel_rev=ppr
        ),
    )
    assert ds.units_per_wheel_rev == ppr
    res = fit_lsq(ds)
    true = simlogs.true_geometry()
    # quantised to whole pulses: still close
    assert abs(res.geometry.ed - true.ed) < 5e-4
    assert res.geometry.wheelbase_m == pytest.approx(true.wheelbase_m, rel=3e-3)
    # a frame /tf does not hold: the transforms it does hold are listed
    joints = dict(nominal=NOMINAL, wheels=WheelSource(joints=("wheel_left", "wheel_right")))
    with pytest.raises(InputError, match="for frame 'robot'.*transforms there: world -> decoy, world -> robot_mocap"):
        read_bag(bag, **joints, gt_topic="/tf", gt_frame="robot")
    # a ground-truth topic of another type: the topics and their types are listed
    with pytest.raises(InputError, match=r"has type std_msgs/msg/Int64MultiArray.*/tf \(TFMessage\)"):
        read_bag(bag, **joints, gt_topic="/encoders")


def test_ranges_and_stops_split_runs(tmp_path, sim):
    pos_l, pos_r, gt = sim
    # two runs with a 3 s standstill between them
    n = len(pos_l)
    pad = int(3.0 / DT)
    pl = np.concatenate([pos_l, np.full(pad, pos_l[-1]), pos_l[-1] + pos_l])
    pr = np.concatenate([pos_r, np.full(pad, pos_r[-1]), pos_r[-1] + pos_r])
    g = np.concatenate(
        [
            gt,
            np.repeat(gt[-1:], pad, 0),
            simlogs.world(simlogs.simulate_wheels(simlogs.general_program())[2], yaw=1.0, origin=(5.0, 5.0)),
        ]
    )
    bag = write_ros2(tmp_path / "two", "mcap", pl, pr, g, "pose")
    ds = read_bag(
        bag,
        nominal=NOMINAL,
        gt_topic="/mocap/pose",
        stops=True,
        stop_s=1.0,
        wheels=WheelSource(joints=("wheel_left", "wheel_right")),
    )
    assert len(ds.runs) == 2
    for r in ds.runs:
        assert np.allclose(r.gt[0], 0.0, atol=1e-12)
    _check_true(ds)
    t_end = (n - 1) * DT
    ds2 = read_bag(
        bag,
        nominal=NOMINAL,
        gt_topic="/mocap/pose",
        ranges=[(0.0, t_end), (t_end + 2.0, 1e9)],
        wheels=WheelSource(joints=("wheel_left", "wheel_right")),
    )
    assert len(ds2.runs) == 2


def test_bag_errors(tmp_path, sim):
    bag = write_ros2(tmp_path / "b", "sqlite3", *sim, "pose")
    with pytest.raises(
        InputError, match=r"no topic '/nope'.*topics: /joint_states \(JointState\), /mocap/pose \(PoseStamped\)"
    ):
        read_bag(bag, nominal=NOMINAL, gt_topic="/nope", wheels=WheelSource(joints=("wheel_left", "wheel_right")))
    with pytest.raises(InputError, match="names both joints"):
        read_bag(bag, nominal=NOMINAL, wheels=WheelSource(joints=("wheel_left", "nope")))
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"not a bag at all")
    with pytest.raises(InputError, match="cannot read as a ROS bag") as e:
        read_bag(junk, nominal=NOMINAL, wheels=WheelSource(joints=("a", "b")))
    assert e.value.source == str(junk)


def test_cli_bag_info_and_replay(tmp_path, sim, capsys):
    bag = write_ros2(tmp_path / "b", "mcap", *sim, "pose")
    info = bag_info(bag)
    assert {t.topic for t in info.topics} == {"/joint_states", "/mocap/pose"}
    joints = {
        "topic": "/joint_states",
        "type": "sensor_msgs/msg/JointState",
        "messages": len(sim[0]),
        "rate_hz": pytest.approx(1 / DT),
        "joint_names": ["wheel_left", "caster", "wheel_right"],
        "frame_id": "",
    }
    assert info.to_dict()["topics"][0] == joints
    assert main(["bag-info", str(bag)]) == 0
    assert "/mocap/pose" in capsys.readouterr().out
    args = [
        "replay",
        str(bag),
        "--method",
        "lsq",
        "--joints",
        "wheel_left,wheel_right",
        "--gt-topic",
        "/mocap/pose",
        "--wheel-diameter-mm",
        "100",
        "--wheelbase-mm",
        "300",
        "--json",
    ]
    assert main(args) == 0
    import json

    d = json.loads(capsys.readouterr().out)
    true = simlogs.true_geometry()
    assert abs(d["Ed"] - true.ed) < 1e-4
    assert d["wheelbase_corrected_mm"] == pytest.approx(true.wheelbase_m * 1e3, rel=1e-3)
    assert d["scale_fitted"] is True
    # missing nominal geometry: one line, exit 2
    assert main(args[:6] + ["--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--wheel-diameter-mm" in err
