"""umbmark guide: the field procedure, step by step, and the ROS 2 node that drives the runs."""

import math
import sys
import types

import numpy as np
import pytest

from umbmark.cli import main
from umbmark.realrobot.guide import STEP_TITLES, guide_text, ros2_runs_script


def test_guide_has_every_step_in_order():
    text = guide_text()
    pos = [text.index(f"{i}. {t}") for i, t in enumerate(STEP_TITLES, 1)]
    assert pos == sorted(pos)
    for needle in (
        "start frame",
        "perpendicular",
        "5 runs clockwise and 5 runs counter-clockwise",
        "x along the first leg",
        "y to the left",
        "front mark -> side wall",
        "back mark -> back wall",
        "umbmark measure",
        "umbmark analyze",
        "--record",
        "x_odo",
        "theta_odo",
    ):
        assert needle in text, needle
    assert max(len(line) for line in text.splitlines()) <= 100


def test_guide_cli_options(capsys):
    assert main(["guide", "--side-mm", "2000", "--runs", "7"]) == 0
    out = capsys.readouterr().out
    assert "2000 mm sides" in out and "7 runs clockwise and 7 runs counter-clockwise" in out
    assert main(["guide", "--side-mm", "-1"]) == 2
    assert "--side-mm must be a positive number" in capsys.readouterr().err


# -- the ROS 2 driving script ------------------------------------------------------------------------


def _load_script(**kw):
    """The generated script as a module, without running its ROS entry point."""
    mod = types.ModuleType("umbmark_runs")
    exec(compile(ros2_runs_script(**kw), "umbmark_runs.py", "exec"), mod.__dict__)  # noqa: S102
    return mod


def _drive(mod, true_scale=(1.0, 1.0), wheelbase_m=0.30, dt=0.02, lag_s=0.08, t_max_s=2000.0):
    """Drive the script's SquareDriver on a simulated robot: the driver sees the odometry of the
    nominal geometry; the wheels follow the commanded speeds through a first-order lag and really
    travel ``true_scale`` times what the odometry thinks. Returns t, the wheel travels as the
    odometry counts them, the true poses and the driver's labels per sample."""
    driver = mod.SquareDriver()
    odo = np.zeros(3)
    true = np.zeros(3)
    vl = vr = 0.0
    t_list, dl_list, dr_list, pose_list = [0.0], [0.0], [0.0], [true.copy()]
    labels = [driver.label]
    b_true = wheelbase_m * 1.02  # the true wheelbase: 2 % more than the odometry's
    t = 0.0
    while t < t_max_s:
        cmd = driver.command(t, *odo)
        if cmd is None:
            break
        v, w = cmd
        a = dt / (lag_s + dt)
        vl += a * ((v - w * wheelbase_m / 2) - vl)
        vr += a * ((v + w * wheelbase_m / 2) - vr)
        dl, dr = vl * dt, vr * dt  # what the encoders report, in the odometry's metres
        for pose, (sl, sr), b in ((odo, (1.0, 1.0), wheelbase_m), (true, true_scale, b_true)):
            ds = (sl * dl + sr * dr) / 2
            dth = (sr * dr - sl * dl) / b
            pose[0] += ds * math.cos(pose[2] + dth / 2)
            pose[1] += ds * math.sin(pose[2] + dth / 2)
            pose[2] += dth
        t += dt
        t_list.append(t)
        dl_list.append(dl_list[-1] + dl)
        dr_list.append(dr_list[-1] + dr)
        pose_list.append(true.copy())
        labels.append(driver.label)
    else:
        raise AssertionError("the driver did not finish")
    return np.array(t_list), np.array(dl_list), np.array(dr_list), np.array(pose_list), labels


def test_ros2_script_drives_closed_squares_on_the_odometry():
    mod = _load_script(side_m=1.0, runs=2, pause_s=4.0)
    assert mod.CMD_VEL_TOPIC == "/cmd_vel" and mod.ODOM_TOPIC == "/odom" and mod.STAMPED is False
    driver = mod.SquareDriver()
    odo = [0.0, 0.0, 0.0]
    seen = []
    t, dt = 0.0, 0.02
    total_turn = {}
    while (cmd := driver.command(t, *odo)) is not None:
        v, w = cmd
        label = driver.label
        if label and label not in seen:
            seen.append(label)
        odo[0] += v * dt * math.cos(odo[2] + w * dt / 2)
        odo[1] += v * dt * math.sin(odo[2] + w * dt / 2)
        odo[2] += w * dt
        if label:
            total_turn[label] = total_turn.get(label, 0.0) + w * dt
        t += dt
    assert seen == ["cw run 1 of 2", "cw run 2 of 2", "ccw run 1 of 2", "ccw run 2 of 2"]
    for label, turn in total_turn.items():
        assert math.degrees(turn) == pytest.approx(-360 if label.startswith("cw") else 360, abs=1.5), label
    # four runs, each a closed square on the odometry: back at the origin
    assert math.hypot(odo[0], odo[1]) < 0.01


def test_ros2_script_runs_are_cut_at_the_rests_and_calibrate():
    """Driven by the script, the robot's runs are cut at the rests by replay's stop splitting
    (default 1 s) into 2 cw and 2 ccw squares, and exact recovers the simulated errors."""
    from umbmark.model.dataset import Dataset, Run, WheelGeometry, split_at_stops
    from umbmark.realrobot.replay import replay_report

    mod = _load_script(side_m=1.0, runs=2, pause_s=4.0)
    t, sl, sr, pose, labels = _drive(mod, true_scale=(0.998, 1.002))
    r = 0.05
    upr = 4096.0  # encoder ticks per wheel revolution: the log counts whole ticks
    k = upr / (2 * math.pi * r)
    ticks_l, ticks_r = np.round(sl * k), np.round(sr * k)
    whole = Run("session", t, np.diff(ticks_l, prepend=0.0), np.diff(ticks_r, prepend=0.0), pose)
    runs = split_at_stops(whole, upr, stop_s=1.0)
    assert len(runs) == 4
    ds = Dataset("script", WheelGeometry(2 * r, 2 * r, 0.30), upr, tuple(runs), 1.0)
    rep = replay_report([ds], method="exact", heldout=False)
    d = rep.to_dict()
    assert [run["direction"] for run in d["runs"]] == ["cw", "cw", "ccw", "ccw"]
    assert d["Ed"] == pytest.approx(1.002 / 0.998, abs=5e-4)
    assert d["Eb"] == pytest.approx(1.02, abs=2e-3)


def test_ros2_script_options_and_errors(capsys):
    from umbmark.cli import main

    assert (
        main(
            [
                "guide",
                "--ros2-script",
                "--side-mm",
                "1500",
                "--runs",
                "3",
                "--stamped",
                "--cmd-vel-topic",
                "/diff_drive_controller/cmd_vel",
                "--odom-topic",
                "/diff_drive_controller/odom",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    mod = types.ModuleType("m")
    exec(compile(text, "m.py", "exec"), mod.__dict__)  # noqa: S102
    assert (mod.SIDE_M, mod.RUNS, mod.STAMPED) == (1.5, 3, True)
    assert mod.CMD_VEL_TOPIC == "/diff_drive_controller/cmd_vel" and mod.ODOM_TOPIC == "/diff_drive_controller/odom"
    for args, flag in (
        (["--speed-m-s", "0"], "--speed-m-s"),
        (["--turn-rate-deg-s", "nan"], "--turn-rate-deg-s"),
        (["--pause-s", "-2"], "--pause-s"),
        (["--cmd-vel-topic", "/cmd vel\nimport os"], "--cmd-vel-topic"),
        (["--odom-topic", "odom'); import os; ('"], "--odom-topic"),
    ):
        assert main(["guide", "--ros2-script", *args]) == 2, args
        err = capsys.readouterr().err
        assert flag in err and len(err.strip().splitlines()) == 1, err
    # values no calibration run is driven with: the unit slip named, nothing written
    for args, words in (
        (["--speed-m-s", "200"], ("--speed-m-s", "metres per second")),
        (["--turn-rate-deg-s", "3000"], ("--turn-rate-deg-s", "degrees per second")),
        (["--side-mm", "2"], ("2 mm", "millimetres and metres")),
        (["--side-mm", "1e6"], ("1e+06 mm", "millimetres and metres")),
    ):
        assert main(["guide", "--ros2-script", *args]) == 2, args
        out = capsys.readouterr()
        assert out.out == "" and all(w in out.err for w in words) and len(out.err.strip().splitlines()) == 1, out.err
    assert main(["guide", "--side-mm", "1e308"]) == 2
    assert "millimetres and metres" in capsys.readouterr().err
    # the limits themselves are allowed
    for args in (["--speed-m-s", "3"], ["--turn-rate-deg-s", "360"], ["--side-mm", "250"], ["--side-mm", "50000"]):
        assert main(["guide", "--ros2-script", *args]) == 0, args
        capsys.readouterr()


class _FakeRos:
    """Just enough of rclpy, geometry_msgs and nav_msgs to run the script's ROS node: a clock that
    advances one timer period per spin, and an odometry that integrates the published commands."""

    def __init__(self, monkeypatch, stamped):
        ns = types.SimpleNamespace
        self.t = 0.0
        self.published = []
        self.logged = []
        self.pose = [0.0, 0.0, 0.0]
        fake = self

        class Vec:
            def __init__(self):
                self.x = self.y = self.z = 0.0

        class Twist:
            def __init__(self):
                self.linear, self.angular = Vec(), Vec()

        class TwistStamped:
            def __init__(self):
                self.header = ns(stamp=None)
                self.twist = Twist()

        class Odometry:
            pass

        class Clock:
            def now(self):
                return ns(nanoseconds=int(fake.t * 1e9), to_msg=lambda: ("stamp", fake.t))

        class Node:
            def __init__(self, name):
                fake.node = self
                self.subs, self.timers = [], []

            def create_publisher(self, msg_type, topic, depth):
                assert msg_type is (TwistStamped if stamped else Twist)
                return ns(publish=fake.published.append)

            def create_subscription(self, msg_type, topic, cb, depth):
                assert msg_type is Odometry
                self.subs.append(cb)

            def create_timer(self, period, cb):
                self.timers.append((period, cb))

            def get_clock(self):
                return Clock()

            def get_logger(self):
                return ns(info=fake.logged.append)

            def destroy_node(self):
                fake.destroyed = True

        def spin_once(node, timeout_sec=None):
            period, cb = node.timers[0]
            if fake.published:
                last = fake.published[-1]
                tw = last.twist if stamped else last
                v, w = tw.linear.x, tw.angular.z
                p = fake.pose
                p[0] += v * period * math.cos(p[2] + w * period / 2)
                p[1] += v * period * math.sin(p[2] + w * period / 2)
                p[2] += w * period
            fake.t += period
            q = ns(x=0.0, y=0.0, z=math.sin(fake.pose[2] / 2), w=math.cos(fake.pose[2] / 2))
            msg = ns(pose=ns(pose=ns(position=ns(x=fake.pose[0], y=fake.pose[1]), orientation=q)))
            for sub in node.subs:
                sub(msg)
            cb()

        rclpy = types.ModuleType("rclpy")
        rclpy.init = lambda: None
        rclpy.ok = lambda: True
        rclpy.spin_once = spin_once
        rclpy.shutdown = lambda: setattr(fake, "shut", True)
        node_mod = types.ModuleType("rclpy.node")
        node_mod.Node = Node
        rclpy.node = node_mod
        geo = types.ModuleType("geometry_msgs.msg")
        geo.Twist, geo.TwistStamped = Twist, TwistStamped
        nav = types.ModuleType("nav_msgs.msg")
        nav.Odometry = Odometry
        for name, m in {
            "rclpy": rclpy,
            "rclpy.node": node_mod,
            "geometry_msgs": types.ModuleType("geometry_msgs"),
            "geometry_msgs.msg": geo,
            "nav_msgs": types.ModuleType("nav_msgs"),
            "nav_msgs.msg": nav,
        }.items():
            monkeypatch.setitem(sys.modules, name, m)


@pytest.mark.parametrize("stamped", [False, True])
def test_ros2_script_node_runs_and_stops_the_robot(monkeypatch, stamped):
    fake = _FakeRos(monkeypatch, stamped)
    mod = _load_script(side_m=0.5, runs=1, pause_s=2.0, stamped=stamped)
    mod.main()
    assert fake.shut and fake.destroyed
    last = fake.published[-1].twist if stamped else fake.published[-1]
    assert (last.linear.x, last.angular.z) == (0.0, 0.0)
    if stamped:
        assert fake.published[-1].header.stamp is not None
    assert fake.logged[0] == "cw run 1 of 1" and "ccw run 1 of 1" in fake.logged
    assert fake.logged[-1] == "done: stop the recording"
    assert math.hypot(fake.pose[0], fake.pose[1]) < 0.01  # the two squares close on the odometry
