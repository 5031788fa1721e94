"""The command line of ``umbmark selfcal --kinematics`` for a simulated robot of
:mod:`umbmark.studies.kinematic` (the coverage benchmark and the tests run the command itself).
"""

from __future__ import annotations

import math

__all__ = ["selfcal_args"]


def selfcal_args(drawn, bag) -> list[str]:
    """The arguments of ``umbmark selfcal`` for the drawn robot's bag (the pinned interface, with the
    URDF's guess of the lidar as the matching's start): its kind's joint flags with the simulated
    joints' names (:attr:`umbmark.kinds.Kind.sim_joints`) and its nominal sizes' flags."""
    from umbmark.cli.options import flag
    from umbmark.kinds import kind_of

    n = drawn.robot.nominal
    kind = kind_of(n)
    x, y, yaw = drawn.urdf_pose
    args = ["selfcal", str(bag), "--kinematics", kind.name]
    names = iter(kind.sim_joints)
    for j in kind.joints:
        args += [flag(j.option), ",".join(next(names) for _ in j.roles)]
    values = dict(zip(n.parameter_names, n.vector()))
    for s in kind.sizes:
        args += [flag(s.option), f"{values[s.parameters[0]] * 1e3:g}"]
    return args + ["--sensor-pose", f"{x * 1e3:.3f},{y * 1e3:.3f},{math.degrees(yaw):.4f}", "--json"]
