#!/usr/bin/env python3
"""Joints given in another order or role, found from the data: simulated robots of each kind.

    python benchmarks/joint_order.py                         # 8 robots of each kind
    python benchmarks/joint_order.py --robots 3 --jobs 2     # a quicker look
    python benchmarks/joint_order.py --out benchmarks/results

Each robot is drawn by :func:`umbmark.studies.kinematic.draw_robot` (a tricycle, a mecanum robot,
a bicycle-model car, an Ackermann car; a differential drive of 150 mm wheels and a 340 mm
wheelbase, each off by up to 2 % and 5 %) and drives for ``--seconds`` (default 40) with a
180-beam lidar, every move of its kind, and again without the moves that tell some mix-ups apart
(a mecanum robot without sideways motion, a tricycle without spins), written as a bag. The check
of the joints' readings (:func:`umbmark.realrobot.kinematic.check_joint_readings`, the first step
of ``umbmark selfcal``) then runs on the joints as recorded, and on every mistake its kind names
(:meth:`umbmark.kinds.Kind.readings`) made in the data: a mecanum robot's or an Ackermann car's
23 other orders of the joints, a tricycle's or a car's drive and steering joints exchanged, a
tricycle's steering zero a quarter turn off either way, a differential drive's wheels exchanged.

Reported per kind and drive: the recordings refused as recorded (the target: none), and of the
mistakes, those named with the right remedy (the joints' flags in the right order, or the
steering's offset), named otherwise, and let through.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_out, command, machine, machine_text, write_results  # noqa: E402

FEWER = {
    "mecanum": ["straight", "back", "arc+", "arc-", "spin+", "spin-"],
    "tricycle": ["straight", "back", "arc+", "arc-"],
}
"""The moves of the second drive of each kind: without those that tell some mix-ups apart."""


def _diff_drive(seed: int):
    """A differential drive drawn as the studies draw the other kinds (their DrawnRobot)."""
    import numpy as np

    from umbmark.kinds import DiffDrive
    from umbmark.model.kinematic_drive import JointNoise, KinematicRobot
    from umbmark.model.sensors import Lidar, SensorPose
    from umbmark.studies.kinematic import DrawnRobot

    rng = np.random.default_rng([seed, 99])
    u = lambda a, b: float(rng.uniform(a, b))  # noqa: E731
    nominal = DiffDrive(0.15, 0.15, 0.34)
    true = DiffDrive(0.15 * (1 + u(-0.02, 0.02)), 0.15 * (1 + u(-0.02, 0.02)), 0.34 * (1 + u(-0.05, 0.05)))
    pose = SensorPose(u(-0.2, 0.2), u(-0.1, 0.1), math.radians(u(-5, 5)))
    urdf = (pose.x_m + u(-0.02, 0.02), pose.y_m + u(-0.02, 0.02), pose.yaw_rad + math.radians(u(-2, 2)))
    lidar = Lidar(n_beams=180, range_noise_m=0.005, dropout_prob=0.005)
    noise = JointNoise(speed_rel_sd=u(0.005, 0.02), slip_m_per_sqrt_m=u(1e-4, 3e-4))
    return DrawnRobot(KinematicRobot(nominal, true, pose, lidar), urdf, noise, 0.0, seed)


def _mistakes(kind, names: tuple[str, ...]):
    """The mistakes a kind names, made in the data: for each of its readings
    (:meth:`umbmark.kinds.Kind.readings`), the joints' columns and names as given (the reading's
    order undone), the turn taken off each, and the remedy its message must hold."""
    import numpy as np

    out = []
    for r in kind.readings():
        given = tuple(int(i) for i in np.argsort(r.order))  # column j given holds role given[j]
        shift = np.asarray(r.shift_rad or (0.0,) * len(names))
        given_names = tuple(names[i] for i in given)
        what = f"{r.words} {r.order}" + (f" {np.degrees(shift).round().tolist()} deg" if r.shift_rad else "")
        out.append((what, given, -shift, kind.reading_cause(r, given_names)[1]))
    return out


def one(kind: str, seed: int, seconds: float, fewer: bool) -> dict:
    """Draw, simulate, write one robot; the check on its joints as recorded and on each mistake."""

    from umbmark.errors import InputError
    from umbmark.io.rosbag import read_selfcal_bag
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.kinds import kind_of
    from umbmark.model.kinematic_drive import kinematic_program, simulate_kinematic_drive
    from umbmark.realrobot.kinematic import check_joint_readings, joint_source
    from umbmark.realrobot.selfcal import IntervalOptions
    from umbmark.studies.kinematic import draw_robot

    drawn = _diff_drive(seed) if kind == "diff_drive" else draw_robot(kind, seed, n_beams=180)
    nominal = drawn.robot.nominal
    names = kind_of(nominal).sim_joints or ("left_wheel_joint", "right_wheel_joint")
    moves, start = kinematic_program(drawn.robot, seconds, seed=seed, kinds=FEWER.get(kind) if fewer else None)
    log = simulate_kinematic_drive(
        moves, drawn.robot, start_pose=start, joint_names=names, noise=drawn.noise, seed=seed
    )
    opts = IntervalOptions(sensor_pose=tuple(drawn.urdf_pose))
    out: dict = {"kind": kind, "seed": seed, "drive": "fewer moves" if fewer else "every move"}
    with tempfile.TemporaryDirectory() as tmp:
        path = write_drive_bag(log, Path(tmp) / "drive.bag", truth=False, tf_static=False, odom=False)
        bag = read_selfcal_bag(path, wheels=joint_source(nominal, names), scan_topic="/scan", two_wheels=False)

    def refusal(b, motion):
        try:
            check_joint_readings(b, nominal, opts, motion=motion)
        except InputError as err:
            return err.message
        return None

    motion = None
    try:
        motion = check_joint_readings(bag, nominal, opts)
        out["as_recorded"] = None
    except InputError as err:
        out["as_recorded"] = err.message
    named = other = through = 0
    missed = []
    for what, order, turn, remedy in _mistakes(kind_of(nominal), names):
        pos = bag.joint_positions[:, list(order)] + turn
        wrong = dataclasses.replace(bag, joint_positions=pos, joint_names=tuple(names[i] for i in order))
        msg = refusal(wrong, motion)
        if msg is None:
            through += 1
            missed.append(what)
        elif remedy in msg:
            named += 1
        else:
            other += 1
            missed.append(f"{what}: {msg}")
    out.update(named=named, other=other, through=through, missed=missed)
    return out


def summarise(rows: list[dict]) -> list[dict]:
    out = []
    for key in sorted({(r["kind"], r["drive"]) for r in rows}):
        rs = [r for r in rows if (r["kind"], r["drive"]) == key]
        out.append(
            {
                "kind": key[0],
                "drive": key[1],
                "robots": len(rs),
                "refused_as_recorded": sum(r["as_recorded"] is not None for r in rs),
                "mistakes": sum(r["named"] + r["other"] + r["through"] for r in rs),
                "named": sum(r["named"] for r in rs),
                "named_otherwise": sum(r["other"] for r in rs),
                "let_through": sum(r["through"] for r in rs),
            }
        )
    return out


def page(res: dict) -> str:
    lines = [
        "# Joints given in another order or role, found from the data",
        "",
        f"Command: `{res['command']}`  ",
        machine_text(res["machine"]),
        f"Wall time {res['wall_s'] / 60:.1f} min.",
        "",
        f"Each robot a seeded draw, {res['seconds']:g} s of driving with a 180-beam lidar, checked by "
        "`umbmark.realrobot.kinematic.check_joint_readings` (the first step of `umbmark selfcal`) as recorded "
        "and with each mistake of its kind made in its data. Named: the refusal gives the right remedy (the "
        "joints' flags in the right order, the steering's zero). Fewer moves: a mecanum robot that never moves "
        "sideways (front and rear exchanged then move it alike), a tricycle that never spins. An Ackermann car's "
        "left and right traction joints (or steering joints) exchanged move it nearly alike (the controller "
        "averages each pair): let through.",
        "",
        "| kind | drive | robots | refused as recorded | mistakes | named | named otherwise | let through |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in res["summary"]:
        lines.append(
            f"| {s['kind']} | {s['drive']} | {s['robots']} | {s['refused_as_recorded']} | {s['mistakes']} | "
            f"{s['named']} | {s['named_otherwise']} | {s['let_through']} |"
        )
    for r in res["robots"]:
        if r["as_recorded"] is not None:
            lines.append(f"\nRefused as recorded: {r['kind']} seed {r['seed']} ({r['drive']}): {r['as_recorded']}")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", type=int, default=8, help="robots of each kind (default 8)")
    p.add_argument("--seconds", type=float, default=40.0, help="each drive's length (default 40 s)")
    p.add_argument(
        "--kinds", default="diff_drive,tricycle,mecanum,bicycle,ackermann", help="the kinds (default every one)"
    )
    p.add_argument("--jobs", type=int, default=len(os.sched_getaffinity(0)), help="worker processes")
    add_out(p, "joint-order")
    args = p.parse_args(argv)
    if args.robots < 1 or args.jobs < 1 or not args.seconds > 0:
        p.error("--robots and --jobs must be at least 1, --seconds positive")
    t0 = time.perf_counter()
    tasks = [
        (k, s, args.seconds, fewer)
        for k in args.kinds.split(",")
        for s in range(args.robots)
        for fewer in ((False, True) if k in FEWER else (False,))
    ]
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(one, *zip(*tasks)))
    res = {
        "command": command("joint_order", argv),
        "machine": machine("scipy", "numba", "rosbags"),
        "wall_s": time.perf_counter() - t0,
        "seconds": args.seconds,
        "summary": summarise(rows),
        "robots": rows,
    }
    for path in write_results(Path(args.out), "joint_order", res, page(res)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
