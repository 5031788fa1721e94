"""The command line of ``umbmark selfcal --kinematics`` for a simulated robot of
:mod:`umbmark.studies.kinematic` (the coverage benchmark and the tests run the command itself).
"""

from __future__ import annotations

import math

__all__ = ["selfcal_args"]


def selfcal_args(drawn, bag) -> list[str]:
    """The arguments of ``umbmark selfcal`` for the drawn robot's bag (the pinned interface, with the
    URDF's guess of the lidar as the matching's start)."""
    from umbmark.model.kinematics import Mecanum, Tricycle
    from umbmark.studies.kinematic import JOINTS

    n = drawn.robot.nominal
    x, y, yaw = drawn.urdf_pose
    pose = ["--sensor-pose", f"{x * 1e3:.3f},{y * 1e3:.3f},{math.degrees(yaw):.4f}"]
    if isinstance(n, Tricycle):
        drive, steer = JOINTS["tricycle"]
        return [
            "selfcal", str(bag), "--kinematics", "tricycle", "--steer-joint", steer, "--drive-joint", drive,
            "--wheel-diameter-mm", f"{n.wheel_diameter_m * 1e3:g}", "--wheelbase-mm", f"{n.wheelbase_m * 1e3:g}",
            *pose, "--json",
        ]  # fmt: skip
    assert isinstance(n, Mecanum)
    return [
        "selfcal", str(bag), "--kinematics", "mecanum", "--joints", ",".join(JOINTS["mecanum"]),
        "--wheel-diameter-mm", f"{n.wheel_diameters_m[0] * 1e3:g}", "--lx-plus-ly-mm", f"{n.lx_plus_ly_m * 1e3:g}",
        *pose, "--json",
    ]  # fmt: skip
