"""The command line of ``umbmark selfcal --kinematics`` for a simulated robot of
:mod:`umbmark.studies.kinematic` (the coverage benchmark and the tests run the command itself).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from umbmark.kinds import Kind
    from umbmark.model.kinematics import Kinematics
    from umbmark.studies.kinematic import DrawnRobot

__all__ = ["selfcal_args", "car_selfcal_args"]


def selfcal_args(drawn: DrawnRobot, bag: str | Path) -> list[str]:
    """The arguments of ``umbmark selfcal`` for the drawn robot's bag (the pinned interface, with the
    URDF's guess of the lidar as the matching's start): its kind's joint flags with the simulated
    joints' names (:attr:`umbmark.kinds.Kind.sim_joints`) and its nominal sizes' flags."""
    from umbmark.kinds import kind_of

    n = drawn.robot.nominal
    kind = kind_of(n)
    x, y, yaw = drawn.urdf_pose
    args = ["selfcal", str(bag), "--kinematics", kind.name, *_joint_flags(kind, kind.sim_joints), *_size_flags(n)]
    return args + ["--sensor-pose", f"{x * 1e3:.3f},{y * 1e3:.3f},{math.degrees(yaw):.4f}", "--json"]


def car_selfcal_args(name: str, bag: str | Path, source: str = "joints") -> list[str]:
    """The arguments of ``umbmark selfcal`` for a simulated car's bag
    (:data:`umbmark.studies.cars.CARS`) with ``--fit-steering-scale``: from its joints (its kind's
    joint flags) or from ``/odom`` (``source``), with its nominal sizes' flags."""
    from umbmark.kinds import kind_of
    from umbmark.studies.cars import car_named

    car = car_named(name)
    kind = kind_of(car.nominal)
    args = ["selfcal", str(bag), "--kinematics", kind.name]
    args += ["--odom-topic", "/odom"] if source == "odom" else _joint_flags(kind, car.joints)
    args += _size_flags(car.nominal)
    return args + ["--fit-steering-scale", "--json"]


def _joint_flags(kind: Kind, names: Iterable[str]) -> list[str]:
    """A kind's joint flags naming the joints ``names`` (in its roles' order)."""
    from umbmark.cli.options import flag

    it = iter(names)
    return [a for j in kind.joints for a in (flag(j.option), ",".join(next(it) for _ in j.roles))]


def _size_flags(nominal: Kinematics) -> list[str]:
    """The nominal sizes' flags of a geometry (millimetres)."""
    from umbmark.cli.options import flag
    from umbmark.kinds import kind_of

    values = dict(zip(nominal.parameter_names, nominal.vector()))
    return [a for s in kind_of(nominal).sizes for a in (flag(s.option), f"{values[s.parameters[0]] * 1e3:g}")]
