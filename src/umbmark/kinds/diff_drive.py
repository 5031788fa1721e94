"""The differential drive (and the skid-steer robot, which turns as one with a wider wheelbase).

Two wheels on one axle, the robot's origin midway between them; joints ``(left, right)``:
``v_x = (r_L dphi_L + r_R dphi_R) / 2``, ``omega = (r_R dphi_R - r_L dphi_L) / b``
(ros2 ``diff_drive_controller``).

It is the default kind, calibrated by the differential drive's own pipeline (UMBmark's
correction factors, the lidar self-calibration of :mod:`umbmark.correct.selfcal`, the history);
its geometry here (:class:`DiffDrive`) is the one interface of every kind, for the simulator and
the self-calibration of any kind.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.kinds._base`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.kinds._base import Alternative, JointOption, Kind, Parameter, Reading, Size, positive_parameter
from umbmark.model.geometry import QUANTITIES

__all__ = ["DiffDrive", "KIND"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DiffDrive:
    """A differential drive: two wheels on one axle, the robot's origin midway between them.

    Parameters
    ----------
    diameter_left_m, diameter_right_m : float
        The wheels' diameters [m].
    wheelbase_m : float
        The distance between their contact points [m].
    """

    diameter_left_m: float
    diameter_right_m: float
    wheelbase_m: float

    kind: ClassVar[str] = "diff_drive"
    joint_roles: ClassVar[tuple[str, ...]] = ("left", "right")
    rolling: ClassVar[tuple[bool, ...]] = (True, True)
    parameter_names: ClassVar[tuple[str, ...]] = ("diameter_left_m", "diameter_right_m", "wheelbase_m")
    moves: ClassVar[tuple[str, ...]] = ("straight", "back", "arc+", "arc-", "spin+", "spin-")

    def __post_init__(self) -> None:
        for n in self.parameter_names:
            object.__setattr__(self, n, positive_parameter(n, getattr(self, n)))

    @classmethod
    def from_vector(cls, p: ArrayLike) -> DiffDrive:
        q = np.asarray(p, dtype=float)
        return cls(float(q[0]), float(q[1]), float(q[2]))

    def vector(self) -> FloatArray:
        return np.array([self.diameter_left_m, self.diameter_right_m, self.wheelbase_m])

    def with_vector(self, p: ArrayLike) -> DiffDrive:
        return self.from_vector(p)

    def rolling_diameters_m(self) -> FloatArray:
        return np.array([self.diameter_left_m, self.diameter_right_m])

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        v = np.asarray(values, dtype=float)
        ul, ur = 0.5 * q[0] * v[..., 0], 0.5 * q[1] * v[..., 1]
        return np.stack([0.5 * (ul + ur), np.zeros_like(ul), (ur - ul) / q[2]], axis=-1)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        if np.any(vy != 0):
            raise InputError("a differential drive cannot move sideways (`vy_mps` must be 0)")
        half = 0.5 * self.wheelbase_m
        left = (vx - w * half) / (0.5 * self.diameter_left_m)
        right = (vx + w * half) / (0.5 * self.diameter_right_m)
        return np.stack([left, right], axis=-1) * dt_s


class _DiffDriveKind(Kind):
    name = DiffDrive.kind
    noun = "differential drive"
    title = "Differential drive"
    geometry = DiffDrive
    differential = True
    controller = "diff_drive_controller"
    export_formats = ("ros2", "ros1", "json", "firmware", "urdf", "tf")
    parameters = (
        Parameter("diameter_left_m", ("wheel_diameter_left_mm",), "mm", "wheel diameter left"),
        Parameter("diameter_right_m", ("wheel_diameter_right_mm",), "mm", "wheel diameter right"),
        Parameter("wheelbase_m", ("wheelbase_mm",), "mm", "wheelbase"),
    )
    sizes = (
        Size(
            "wheel_diameter_mm",
            ("diameter_left_m", "diameter_right_m"),
            QUANTITIES["diameter"],
            "wheel diameter",
            "D",
            alternative=Alternative("wheel_radius_m", 2.0, "R"),
        ),
        Size(
            "wheelbase_mm",
            ("wheelbase_m",),
            QUANTITIES["wheelbase"],
            "wheelbase",
            "L",
            "the distance between the wheels' contact points",
            alternative=Alternative("wheel_separation_m", 1.0, "B"),
        ),
    )
    joints = (
        JointOption(
            "joints", ("left", "right"), "LEFT,RIGHT", "the left and the right wheel", "JointState names of the wheels."
        ),
    )
    turn_backwards = "both wheels' angles count backwards when the robot drives forward (negate them)"
    turn_mirrored = "the wheels given right before left (`joints`)"

    def readings(self) -> tuple[Reading, ...]:
        """The wheels exchanged."""
        return (Reading((1, 0), words="the wheels given right before left"),)


KIND = _DiffDriveKind()
"""The differential drive."""
