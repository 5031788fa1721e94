"""Simulated robot logs for the real-robot tests: wheel rotations and true poses from the
closed-loop simulator (noise free), written as datasets, CSV files or ROS bags."""

from __future__ import annotations

import math

import numpy as np

from umbmark.model.dataset import Dataset, Run, WheelGeometry, wheel_travel_from_poses
from umbmark.model.geometry import ErrorParams, Geometry, OdometryParams
from umbmark.model.simulate import Motion, Segment, run_program, square_program

GEOM = Geometry(wheel_diameter_m=0.10, wheelbase_m=0.30, pulses_per_motor_rev=1000.0, gear_ratio=1.0)
TRUE = ErrorParams(ed=1.004, eb=1.02, es=0.99)


def general_program():
    return (
        Segment("straight", 1.0),
        Segment("turn", math.radians(120)),
        Segment("straight", 0.6),
        Segment("turn", math.radians(-200)),
        Segment("straight", 0.8),
        Segment("turn", math.radians(90)),
        Segment("straight", 0.4),
    )


def simulate_wheels(program, errors=TRUE, geom=GEOM, dt=0.02):
    """(rotation_left, rotation_right) per sample in radians of wheel angle, and the true poses
    (x, y, theta) after each sample, for one noise-free closed-loop run."""
    true = errors.true_params(geom)
    model = OdometryParams.from_geometry(geom)
    res = run_program(program, true, model, 1, motion=Motion(sample_period_s=dt), trajectory=True)
    tr = res.trajectory
    # prepend the start pose as sample 0
    odo = [np.concatenate([[0.0], tr[k][0]]) for k in ("odo_x", "odo_y", "odo_theta")]
    tl, trr = wheel_travel_from_poses(*odo, model.wheelbase_m)
    r_n = geom.wheel_diameter_m / 2
    ang_l, ang_r = tl / r_n, trr / r_n
    pose = np.column_stack([np.concatenate([[0.0], tr[k][0]]) for k in ("true_x", "true_y", "true_theta")])
    return ang_l, ang_r, pose


YAW_30 = math.radians(30)


def world(pose, yaw=YAW_30, origin=(2.0, -1.0)):
    """Poses of the start frame expressed in a world frame rotated by ``yaw`` at ``origin``."""
    c, s = math.cos(yaw), math.sin(yaw)
    x = origin[0] + c * pose[:, 0] - s * pose[:, 1]
    y = origin[1] + s * pose[:, 0] + c * pose[:, 1]
    return np.column_stack([x, y, pose[:, 2] + yaw])


def dataset(programs, geom=GEOM, errors=TRUE, dt=0.02, side_m=None, units="pulses"):
    """A Dataset of simulated runs (log units: encoder pulses of the nominal geometry)."""
    runs = []
    upr = geom.pulses_per_motor_rev * geom.gear_ratio
    for i, prog in enumerate(programs):
        al, ar, pose = simulate_wheels(prog, errors, geom, dt)
        k = upr / (2 * math.pi)
        runs.append(Run(f"run-{i + 1:02d}", np.arange(len(al)) * dt, al * k, ar * k, pose))
    d = geom.wheel_diameter_m
    return Dataset("sim", WheelGeometry(d, d, geom.wheelbase_m), upr, tuple(runs), side_m)


def squares(n=3, side_m=2.0):
    return [square_program("cw", side_m)] * n + [square_program("ccw", side_m)] * n


def true_geometry(errors=TRUE, geom=GEOM) -> WheelGeometry:
    dl, dr = errors.diameters_m(geom)
    return WheelGeometry(dl, dr, errors.eb * geom.wheelbase_m)
