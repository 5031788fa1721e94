"""Every `umbmark ...` command line in a fenced code block of README.md and of every page of the
documentation (docs/**/*.md) runs with exit status 0.

Each file runs in its own temporary folder, its commands in order, with `data` pointing at the
repository's data folder and a history database of its own. The files run concurrently (one
worker per core). Blocks whose info string is ``console`` are not run: they hold commands that
take minutes, or that need a robot or a ROS installation. Pages that use the example ROS bags
(`calibration_bag`, `check_bag`, the lidar drive `selfcal_bag`) get simulated bags of that name in
their folder first. Each command runs in a process of its own, forked from a server that has
imported umbmark once (tests/cli_server.py).
"""

import contextlib
import math
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cli_server
import numpy as np
import pytest
from conftest import REPO

FENCE = re.compile(r"^\s*(```|~~~)\s*([^\s`]*)")
SKIP_INFO = {"console"}  # fenced blocks that are shown, not run


def readme_commands(text: str) -> list[tuple[int, str]]:
    """``(line number, command)`` for every line starting with ``umbmark `` inside fenced code
    blocks (except ``console`` blocks); a trailing backslash continues the command on the next
    line."""
    out = []
    in_block = False
    skip = False
    fence = None
    pending = None
    for i, line in enumerate(text.splitlines(), 1):
        m = FENCE.match(line)
        if m and (not in_block or line.strip().startswith(fence)):
            if in_block and pending:
                out.append(pending)
                pending = None
            in_block = not in_block
            fence = m.group(1) if in_block else None
            skip = in_block and m.group(2).lower() in SKIP_INFO
            continue
        if not in_block or skip:
            continue
        if pending is not None:
            start, cmd = pending
            body = line.strip()
            if body.endswith("\\"):
                pending = (start, cmd + " " + body[:-1].strip())
            else:
                out.append((start, cmd + " " + body))
                pending = None
            continue
        s = line.strip()
        if s.startswith("umbmark "):
            if s.endswith("\\"):
                pending = (i, s[:-1].strip())
            else:
                out.append((i, s))
    if pending:
        out.append(pending)
    return out


def test_extractor():
    text = "\n".join(
        [
            "umbmark outside a block",
            "```bash",
            "umbmark one --a 1",
            "  umbmark two \\",
            "    --b 2 \\",
            "    --c 3",
            "pip install umbmark",
            "python3 -m venv .venv && umbmark demo",
            "```",
            "```python",
            "x = 'umbmark not a command'",
            "```",
            "~~~",
            "umbmark three",
            "~~~",
            "```console",
            "umbmark slow --full",
            "```",
            "    ```bash",
            "    umbmark four",
            "    ```",
        ]
    )
    assert readme_commands(text) == [
        (3, "umbmark one --a 1"),
        (4, "umbmark two --b 2 --c 3"),
        (14, "umbmark three"),
        (20, "umbmark four"),
    ]


# --- example ROS bags: simulated, written with rosbags alone -----------------------------------------

BAG_DT = 0.05  # 20 Hz joint states and motion-capture poses
# The robot of docs/ros.md: nominal wheel_radius 0.05 m, wheel_separation 0.30 m; true wheels 99.3 and
# 99.7 mm, true wheelbase 306 mm. check_bag: the same robot with the calibration of the page loaded.
BAG_ROBOTS = {
    "calibration_bag": dict(model=(0.100, 0.100, 0.300), seed=1),
    "check_bag": dict(model=(0.0993107, 0.0997054, 0.306005), seed=2),
}
BAG_TRUE = (0.0993, 0.0997, 0.306)


def _square_session(true, model, n_runs=5, side_m=2.0, speed=0.3, turn_speed=0.15, seed=0):
    """Cumulative wheel angles (rad) and world poses of a robot driving n_runs cw, then n_runs ccw
    UMBmark squares closed-loop on its odometry (``model``: diameters and wheelbase it uses), with
    short stops after every segment and 3 s pauses between runs; motion-capture noise 0.5 mm and
    0.1 deg in a world frame rotated by 0.6 rad."""
    (dl_t, dr_t, b_t), (dl_m, dr_m, b_m) = true, model
    segs = [("pause", 1.0)]
    for d in ["cw"] * n_runs + ["ccw"] * n_runs:
        s = -1.0 if d == "cw" else 1.0
        arc = math.pi / 2 * b_m / 2  # model wheel travel of a 90 deg turn on the spot
        for _ in range(4):
            segs += [
                ("move", side_m, side_m, speed),
                ("pause", 0.4),
                ("move", -s * arc, s * arc, turn_speed),
                ("pause", 0.4),
            ]
        segs.append(("pause", 3.0))
    inc = []
    for seg in segs:
        if seg[0] == "pause":
            inc += [(0.0, 0.0)] * int(round(seg[1] / BAG_DT))
            continue
        _, ul, ur, v = seg
        dur = max(abs(ul), abs(ur)) / v
        n = math.ceil(dur / BAG_DT - 1e-9)
        frac = np.diff(np.minimum(np.arange(n + 1) * BAG_DT / dur, 1.0))
        inc += [(f * ul / (dl_m / 2), f * ur / (dr_m / 2)) for f in frac]
    inc = np.array([(0.0, 0.0)] + inc)
    phi_l, phi_r = np.cumsum(inc[:, 0]), np.cumsum(inc[:, 1])
    sl, sr = inc[:, 0] * dl_t / 2, inc[:, 1] * dr_t / 2
    ds, dth = (sl + sr) / 2, (sr - sl) / b_t
    th0 = np.concatenate([[0.0], np.cumsum(dth)[:-1]])
    small = np.abs(dth) < 1e-12
    k = np.where(small, 0.0, ds / np.where(small, 1.0, dth))
    dx = np.where(small, ds * np.cos(th0), k * (np.sin(th0 + dth) - np.sin(th0)))
    dy = np.where(small, ds * np.sin(th0), -k * (np.cos(th0 + dth) - np.cos(th0)))
    x, y, th = np.cumsum(dx), np.cumsum(dy), th0 + dth
    rng = np.random.default_rng(seed)
    yaw, c, s_ = 0.6, math.cos(0.6), math.sin(0.6)
    wx = 1.5 + c * x - s_ * y + rng.normal(0, 5e-4, len(x))
    wy = -0.8 + s_ * x + c * y + rng.normal(0, 5e-4, len(x))
    wth = th + yaw + rng.normal(0, math.radians(0.1), len(x))
    return phi_l, phi_r, np.column_stack([wx, wy, wth])


def _write_ros2_bag(path, phi_l, phi_r, pose, t0=1_760_000_000.0):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types

    def header(t, frame):
        sec = int(t)
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9))), frame_id=frame
        )

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        cj = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        cg = w.add_connection("/mocap/robot/pose", "geometry_msgs/msg/PoseStamped", typestore=ts)
        for k in range(len(phi_l)):
            t = t0 + k * BAG_DT
            ns = int(round(t * 1e9))
            js = T["sensor_msgs/msg/JointState"](
                header=header(t, ""),
                name=["left_wheel_joint", "right_wheel_joint"],
                position=np.array([phi_l[k], phi_r[k]]),
                velocity=np.array([], float),
                effort=np.array([], float),
            )
            w.write(cj, ns, ts.serialize_cdr(js, "sensor_msgs/msg/JointState"))
            x, y, th = pose[k]
            ps = T["geometry_msgs/msg/PoseStamped"](
                header=header(t, "world"),
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
                ),
            )
            w.write(cg, ns, ts.serialize_cdr(ps, "geometry_msgs/msg/PoseStamped"))


# The lidar robot of docs/selfcal.md: umbmark.model.drive.EXAMPLE_ROBOT (a LabMate, wheels 150 mm and
# wheelbase 340 mm nominal, with E_d 1.006, E_b 1.025, E_s 0.99; a 360-beam lidar with 5 mm noise at
# 10 Hz, 120 mm ahead, 40 mm right, turned 3 deg) driving straights, arcs and spins for 3 minutes; a
# ROS 2 mcap bag with /joint_states, /scan, /odom and a /tf_static whose lidar pose is the robot's
# drawing (100 mm ahead, centred, straight), not where the lidar is.
LIDAR_BAGS = {"selfcal_bag": dict(duration_s=180.0, seed=1, urdf_pose=(0.10, 0.0, 0.0))}


def _write_lidar_bag(path, duration_s, seed, urdf_pose):
    import dataclasses

    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
    from umbmark.model.sensors import SensorPose

    log = simulate_drive(mixed_program(duration_s, seed=seed), EXAMPLE_ROBOT, seed=seed)
    write_drive_bag(dataclasses.replace(log, sensor_pose=SensorPose(*urdf_pose)), path, storage="mcap", odom=True)


# The lidar square test of docs/ros.md: a LabMate (wheels 150 mm, wheelbase 340 mm nominal) with
# E_d 1.004, E_b 1.03, its 360-beam lidar (5 mm noise, 10 Hz) 35 mm ahead of the axle, driving 3 cw
# and 3 ccw 2 m squares, put back on its mark before each, resting 3 s before and after; a ROS 2
# sqlite3 bag with /joint_states and /scan only.
LIDAR_SQUARE_BAGS = {"lidar_squares_bag": dict(seed=1)}


def _write_lidar_square_bag(path, seed):
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import SimRobot, WheelNoise, concatenate_drives, simulate_drive, square_drive
    from umbmark.model.geometry import LABMATE, ErrorParams
    from umbmark.model.sensors import Lidar, SensorPose

    robot = SimRobot(LABMATE, ErrorParams(ed=1.004, eb=1.03), SensorPose(0.035, 0.0, 0.0), Lidar(range_noise_m=0.005))
    drives = [
        simulate_drive(square_drive(d), robot, start_pose=(4.0, 4.0, 0.0), noise=WheelNoise(0.01), seed=seed + i)
        for i, d in enumerate(["cw"] * 3 + ["ccw"] * 3)
    ]
    write_drive_bag(concatenate_drives(drives), path, odom=False, tf_static=False)


# The gyro example of docs/ros.md: a skid-steer robot (track 400 mm, wheels 200 mm, effective
# wheelbase 1.6 x the track, E_d 1.01) spinning 4 whole turns alternately both ways, resting 1.5 s
# between spins; a 100 Hz gyro with scale 1.01, bias 0.01 rad/s and 0.005 rad/s of noise; a ROS 2
# sqlite3 bag with /joint_states, /imu, /scan and /tf_static.
GYRO_BAGS = {"gyro_spins_bag": dict(seed=1)}


def _write_gyro_bag(path, seed):
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import Command, Program, simulate_drive, simulate_gyro, skid_steer_robot
    from umbmark.model.sensors import Gyro, Lidar

    robot = skid_steer_robot(0.40, 0.20, 1.6, ed=1.01, lidar=Lidar(range_noise_m=0.005))
    cmds = [Command(2.0)]
    for sign in (1, -1, 1, -1):
        cmds += [Command(2 * math.pi * 1.6 / 0.8, 0.0, sign * 0.8), Command(1.5)]
    log = simulate_drive(Program(tuple(cmds)), robot, seed=seed)
    t, w = simulate_gyro(log, Gyro(100.0, 1.01, 0.01, 0.005), seed=seed + 1)
    write_drive_bag(log, path, gyro=(t, w), odom=False)


# The tricycle and mecanum robots of docs/tricycle.md and docs/mecanum.md (tests/kinematic_bags.py): a
# 2.5-minute drive of every move the kind makes, a 360-beam lidar with 5 mm noise, joint-speed jitter and
# slip, a /tf_static with the drawing's lidar pose, and the true pose of the robot on /ground_truth (and
# as a TUM trajectory, KIND_truth.tum).
KINEMATIC_BAGS = ("tricycle_bag", "mecanum_bag")
# The cars of docs/cars.md and docs/f1tenth.md (umbmark.studies.cars): 45 s of straights, figure-eights and
# reversing arcs with joint states, the car's /odom as vesc_to_odom integrates it and the true pose; and
# the vesc driver's parameter file of the examples.
CAR_BAGS = {"f1tenth_bag": "f1tenth", "large_car_bag": "large", "ackermann_bag": "ackermann"}


def write_example_bags(folder, text):
    """The example bags a page mentions, simulated into ``folder``."""
    for name in KINEMATIC_BAGS:
        if name in text:
            from kinematic_bags import write_example_bag

            kind = name.removesuffix("_bag")  # and the base's true trajectory, for validate
            write_example_bag(folder / name, kind, tum=folder / f"{kind}_truth.tum")
    for name, car in CAR_BAGS.items():
        if name in text:
            from umbmark.studies.cars import car_bag

            car_bag(car, folder / name, tum=folder / f"{car}_truth.tum")
    if "vesc.yaml" in text:
        from umbmark.studies.cars import VESC_YAML

        (folder / "vesc.yaml").write_text(VESC_YAML)
    for name, spec in GYRO_BAGS.items():
        if name in text:
            _write_gyro_bag(folder / name, **spec)
    for name, spec in LIDAR_SQUARE_BAGS.items():
        if name in text:
            _write_lidar_square_bag(folder / name, **spec)
    for name, spec in BAG_ROBOTS.items():
        if name in text:
            _write_ros2_bag(folder / name, *_square_session(BAG_TRUE, spec["model"], seed=spec["seed"]))
    for name, spec in LIDAR_BAGS.items():
        if name in text:
            _write_lidar_bag(folder / name, **spec)
    if "sessions/day" in text:  # a robot's daily self-calibration intervals (umbmark.studies.drift.EXAMPLE_ROBOT)
        from umbmark.studies.drift import write_sessions

        write_sessions(folder / "sessions")
    if "fleet_example/" in text:  # two robots' sessions, one folder each
        import dataclasses

        from umbmark.studies.drift import EXAMPLE_ROBOT, write_sessions

        write_sessions(folder / "fleet_example" / "r7", n_sessions=4)
        write_sessions(folder / "fleet_example" / "r8", dataclasses.replace(EXAMPLE_ROBOT, step=None), 4, seed=1)
    if "odom_runs/" in text:  # six one-run bags with /odom and a motion capture (tests/test_bag_shapes_sim.py)
        from test_bag_shapes_sim import write_odom_run_bags

        write_odom_run_bags(folder)


# --- running the pages -------------------------------------------------------------------------------


@contextlib.contextmanager
def _wrapper_bin(tmp_path):
    """A folder with an `umbmark` that runs this interpreter's umbmark, one process per command,
    forked from a server that has imported it once (tests/cli_server.py)."""
    b = tmp_path / "bin"
    b.mkdir()
    sock_dir = tempfile.mkdtemp(prefix="umbmark-cli-")  # (a Unix socket's path is short)
    sock = os.path.join(sock_dir, "cli.sock")
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("_UMBMARK_COMPLETE", None)
    server = subprocess.Popen(
        [sys.executable, str(Path(__file__).with_name("cli_server.py")), sock], stdout=subprocess.PIPE, env=env
    )
    try:
        assert server.stdout is not None and server.stdout.readline() == cli_server.READY, "the server did not start"
        exe = b / "umbmark"
        exe.write_text(cli_server.client_script(sock))
        exe.chmod(exe.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
        yield b
    finally:
        server.kill()
        server.wait()
        shutil.rmtree(sock_dir, ignore_errors=True)


def doc_files():
    return [REPO / "README.md"] + sorted((REPO / "docs").rglob("*.md"))


def run_file(md, root, bin_dir):
    """Run the commands of one Markdown file in a fresh folder: (commands, failures, timings)."""
    text = md.read_text(encoding="utf-8")
    cmds = readme_commands(text)
    rel = md.relative_to(REPO).as_posix()
    if not cmds:
        return cmds, [], []
    base = root / re.sub(r"[^A-Za-z0-9]+", "_", rel)
    work = base / "work"
    work.mkdir(parents=True)
    (work / "data").symlink_to(REPO / "data", target_is_directory=True)
    write_example_bags(work, text)
    env = dict(os.environ)
    env.update(
        {
            "PATH": f"{bin_dir}{os.pathsep}{env.get('PATH', '')}",
            "UMBMARK_DB": str(base / "history.sqlite"),  # never the user's own history
            "XDG_DATA_HOME": str(base / "xdg"),
            "MPLBACKEND": "Agg",
        }
    )
    env.pop("_UMBMARK_COMPLETE", None)
    failures, timings = [], []
    for line, cmd in cmds:
        t0 = time.monotonic()
        r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True, timeout=600)
        timings.append((time.monotonic() - t0, f"{rel}:{line}: {cmd}"))
        if r.returncode != 0:
            tail = (r.stderr or r.stdout).strip().splitlines()[-3:]
            failures.append(f"{rel}:{line}: exit {r.returncode}: {cmd}\n    " + "\n    ".join(tail))
    return cmds, failures, timings


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every file's commands, run once for the tests below: {relative path: (cmds, failures, timings)}."""
    root = tmp_path_factory.mktemp("docs_commands")
    files = doc_files()
    with (
        _wrapper_bin(root) as bin_dir,
        ThreadPoolExecutor(max_workers=max(1, min(len(files), os.cpu_count() or 1))) as pool,
    ):
        results = pool.map(lambda md: run_file(md, root, bin_dir), files)
        return {md.relative_to(REPO).as_posix(): res for md, res in zip(files, results)}


def _check(results):
    failures = [f for _, fails, _ in results for f in fails]
    timings = [t for _, _, ts in results for t in ts]
    slow = [f"{t:.1f} s: {c}" for t, c in sorted(timings, reverse=True)[:3]]
    assert not failures, "\n".join(failures) + "\nslowest: " + "; ".join(slow)


@pytest.mark.slow
def test_every_readme_command_runs(runs):
    cmds, _, _ = runs["README.md"]
    assert len(cmds) >= 5
    _check([runs["README.md"]])


@pytest.mark.slow
def test_every_docs_command_runs(runs):
    pages = {k: v for k, v in runs.items() if k.startswith("docs/")}
    assert sum(len(c) for c, _, _ in pages.values()) >= 50
    for page in (
        "docs/getting-started.md",
        "docs/tape-measure.md",
        "docs/ros.md",
        "docs/logs.md",
        "docs/history.md",
        "docs/methods.md",
    ):
        assert pages[page][0], f"{page} has no commands to run"
    _check(pages.values())
