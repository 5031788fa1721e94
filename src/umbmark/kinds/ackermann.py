"""The Ackermann car (ros2 ``ackermann_steering_controller``): two rear traction wheels, two front
steering joints.

Joints ``(traction_left, traction_right, steering_left, steering_right)``. The robot's origin is
the rear axle's midpoint, ``L`` (the wheelbase) behind the front axle; the traction wheels are
``w_t`` apart (``traction_track_width``), the steering joints ``w_s`` (``steering_track_width``).
Each steering joint's true angle is ``scale * measured + offset`` (one steering linkage: one offset
and one scale for both). The forward kinematics are the controller's (``update_from_velocity``
with two traction and two steering joints):

* each steering angle becomes the virtual centre wheel's, ``atan(L tan(d_R) / (L - w_s tan(d_R) / 2))``
  and ``atan(L tan(d_L) / (L + w_s tan(d_L) / 2))``, and the two are averaged into ``phi``;
* each traction wheel's speed ``r dphi`` becomes the centre's, ``u_R / (1 + w_t tan(phi) / (2 L))``
  and ``u_L / (1 - w_t tan(phi) / (2 L))`` (the controller's ``R / (R +- w_t / 2)`` with
  ``R = L / tan(phi)``), averaged into ``v``;
* ``v_x = v``, ``v_y = 0``, ``omega = v tan(phi) / L``.

Its parameters: the traction wheels' diameter (the controller has one radius), the wheelbase, the
two track widths, the steering offset and scale. The track widths are held at the nominal ones
given (the odometry hardly depends on them: a mismatch cancels to first order between the two
sides); the wheelbase too unless ``fit_wheelbase`` asks for it; the scale is estimated on request
(``fit_steering_scale``).

An Ackermann car's own odometry is a bicycle's (the controller turns its four joints into one
speed and one steering angle): calibrated from an odometry, it is a :mod:`~umbmark.kinds.bicycle`.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.kinds._base`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.kinds._base import (
    Coverage,
    Interval,
    JointOption,
    Kind,
    Parameter,
    Size,
    Uniform,
    finite_parameter,
    positive_parameter,
)
from umbmark.kinds.bicycle import (
    CAR_FITS,
    FULL_LOCK_RAD,
    MAX_OFFSET_RAD,
    car_advice,
    car_negative,
    car_steering,
    travel_steered,
)
from umbmark.kinds.tricycle import (
    STEERING,
    WHEEL_DIAMETER,
    WHEEL_DIAMETER_SIZE,
    WHEELBASE,
    steering_note,
    wheelbase_size,
)
from umbmark.model.geometry import ROBOT_SIZES_M, Quantity
from umbmark.model.kinematics import Kinematics

__all__ = ["Ackermann", "KIND", "ROLES", "TRACK_WIDTH"]

FloatArray = NDArray[np.float64]

ROLES = ("traction_left", "traction_right", "steering_left", "steering_right")
"""The joints, in the order of a step's values."""

TRACK_WIDTH = Quantity(
    "track_width",
    "track width",
    ROBOT_SIZES_M["wheelbase"],
    (1 / 1.5, 1.5),
    ((0.5, "half the track width given (the distance between the wheels' contact points)?"),),
)
"""The distance between a car's left and right wheels: within a wheelbase's sizes."""


@dataclass(frozen=True)
class Ackermann:
    """An Ackermann car: two rear traction wheels and two front steering joints (see the module docstring).

    Parameters
    ----------
    wheel_diameter_m : float
        The traction wheels' diameter [m].
    wheelbase_m : float
        From the rear axle to the front axle [m].
    traction_track_m : float
        Between the traction wheels' contact points [m].
    steering_track_m : float
        Between the steering joints [m].
    steering_offset_rad : float
        Each steering joint's true angle less the measured one at a measured 0 [rad].
    steering_scale : float
        True over measured steering angle.
    """

    wheel_diameter_m: float
    wheelbase_m: float
    traction_track_m: float
    steering_track_m: float
    steering_offset_rad: float = 0.0
    steering_scale: float = 1.0

    kind: ClassVar[str] = "ackermann"
    joint_roles: ClassVar[tuple[str, ...]] = ROLES
    rolling: ClassVar[tuple[bool, ...]] = (True, True, False, False)
    parameter_names: ClassVar[tuple[str, ...]] = (
        "wheel_diameter_m",
        "wheelbase_m",
        "traction_track_m",
        "steering_track_m",
        "steering_offset_rad",
        "steering_scale",
    )
    moves: ClassVar[tuple[str, ...]] = ("straight", "back", "loop+", "loop-", "reverse+", "reverse-")

    def __post_init__(self) -> None:
        for n in ("wheel_diameter_m", "wheelbase_m", "traction_track_m", "steering_track_m", "steering_scale"):
            object.__setattr__(self, n, positive_parameter(n, getattr(self, n)))
        off = finite_parameter("steering_offset_rad", self.steering_offset_rad)
        if abs(off) > MAX_OFFSET_RAD:
            raise InputError(f"`steering_offset_rad` must be within {math.degrees(MAX_OFFSET_RAD):g} deg, got {off!r}")
        object.__setattr__(self, "steering_offset_rad", off)

    @classmethod
    def from_vector(cls, p: ArrayLike) -> Ackermann:
        q = np.asarray(p, dtype=float)
        return cls(float(q[0]), float(q[1]), float(q[2]), float(q[3]), float(q[4]), float(q[5]))

    def vector(self) -> FloatArray:
        return np.array(
            [
                self.wheel_diameter_m,
                self.wheelbase_m,
                self.traction_track_m,
                self.steering_track_m,
                self.steering_offset_rad,
                self.steering_scale,
            ]
        )

    def with_vector(self, p: ArrayLike) -> Ackermann:
        return self.from_vector(p)

    def rolling_diameters_m(self) -> FloatArray:
        return np.array([self.wheel_diameter_m, self.wheel_diameter_m])

    @property
    def max_curvature_per_m(self) -> float:
        """The tightest turn of the simulator's programs: ``tan(FULL_LOCK_RAD) / L`` [1/m]."""
        return math.tan(FULL_LOCK_RAD) / self.wheelbase_m

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        v = np.asarray(values, dtype=float)
        length, wt, ws = q[1], q[2], q[3]
        ul, ur = 0.5 * q[0] * v[..., 0], 0.5 * q[0] * v[..., 1]
        tl, tr = np.tan(q[5] * v[..., 2] + q[4]), np.tan(q[5] * v[..., 3] + q[4])
        phi = 0.5 * (
            np.arctan(length * tr / (length - 0.5 * ws * tr)) + np.arctan(length * tl / (length + 0.5 * ws * tl))
        )
        t = np.tan(phi)
        k = 0.5 * wt * t / length
        speed = 0.5 * (ur / (1.0 + k) + ul / (1.0 - k))
        return np.stack([speed, np.zeros_like(speed), speed * t / length], axis=-1)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        if np.any(vy != 0):
            raise InputError("a car cannot move sideways (`vy_mps` must be 0)")
        d, speed = car_steering(vx, w, self.wheelbase_m)
        t, length = np.tan(d), self.wheelbase_m
        half_s, half_t = 0.5 * self.steering_track_m * t, 0.5 * self.traction_track_m * t
        left = np.arctan(length * t / (length - half_s))
        right = np.arctan(length * t / (length + half_s))
        r = 0.5 * self.wheel_diameter_m
        return np.stack(
            [
                speed * (1.0 - half_t / length) * dt_s / r,
                speed * (1.0 + half_t / length) * dt_s / r,
                (left - self.steering_offset_rad) / self.steering_scale,
                (right - self.steering_offset_rad) / self.steering_scale,
            ],
            axis=-1,
        )


def _centre(nominal: Ackermann, values: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per step the travel [m] and the centre wheel's angle of the nominal geometry."""
    tw = nominal.twist(values)
    return np.abs(tw[:, 0]), np.arctan(tw[:, 2] * nominal.wheelbase_m / np.where(tw[:, 0] == 0, 1.0, tw[:, 0]))


class _AckermannKind(Kind):
    name = Ackermann.kind
    noun = "four-wheel Ackermann car"
    title = "Ackermann"
    geometry = Ackermann
    controller = "ackermann_steering_controller"
    drawable = True
    parameters = (
        WHEEL_DIAMETER,
        WHEELBASE,
        Parameter("traction_track_m", ("traction_track_width_mm",), "mm", "traction track width"),
        Parameter("steering_track_m", ("steering_track_width_mm",), "mm", "steering track width"),
        *STEERING,
    )
    sizes = (
        WHEEL_DIAMETER_SIZE,
        wheelbase_size("rear axle to front axle"),
        Size(
            "traction_track_width_mm",
            ("traction_track_m",),
            TRACK_WIDTH,
            "traction track width",
            "W",
            "between the traction wheels' contact points",
            "nominal distance between the traction wheels (traction_track_width).",
        ),
        Size(
            "steering_track_width_mm",
            ("steering_track_m",),
            TRACK_WIDTH,
            "steering track width",
            "W",
            "between the steering joints",
            "nominal distance between the steering joints (steering_track_width; default the traction track width).",
            fallback="traction_track_width_mm",
        ),
    )
    joints = (
        JointOption(
            "traction_joints",
            ("traction_left", "traction_right"),
            "LEFT,RIGHT",
            "the left and the right traction wheel",
            "JointState names of the traction wheels, left then right.",
        ),
        JointOption(
            "steering_joints",
            ("steering_left", "steering_right"),
            "LEFT,RIGHT",
            "the left and the right steering joint",
            "JointState names of the steering joints, left then right (radians, counter-clockwise positive).",
        ),
    )
    fits = CAR_FITS
    held = ("traction_track_m", "steering_track_m")
    legend = (
        "wheel diameter: the traction (rear) wheels'; wheelbase: rear axle to front axle (held at the nominal one "
        "unless asked to estimate it); track widths: held at the nominal ones; steering offset: each steering joint's "
        "true angle less the measured one (counter-clockwise positive); steering scale: true over measured angle.",
    )
    sim_joints = (
        "rear_left_wheel_joint",
        "rear_right_wheel_joint",
        "front_left_steering_joint",
        "front_right_steering_joint",
    )
    turn_backwards = "the traction joints turn backwards when the car drives forward, or are given right before left"
    role_words = {
        "traction_left": (("rear", "left"), ("traction", "left"), ("drive", "left")),
        "traction_right": (("rear", "right"), ("traction", "right"), ("drive", "right")),
        "steering_left": (("steer", "left"), ("steering", "left")),
        "steering_right": (("steer", "right"), ("steering", "right")),
    }
    turn_mirrored = (
        "the steering angles clockwise positive (they must be counter-clockwise positive), or the joints given right "
        "before left (`traction_joints` and `steering_joints` take LEFT,RIGHT)"
    )

    def steering_travel(self, nominal: Kinematics, values: FloatArray) -> tuple[float, float]:
        assert isinstance(nominal, Ackermann)
        return travel_steered(*_centre(nominal, values))

    def advice(self, coverage: Coverage) -> list[str]:
        return car_advice(coverage)

    def negative(self, g: FloatArray, bad: list[str]) -> tuple[list[str], str]:
        return car_negative(float(g[0]), float(g[4]), bad, "the traction joints turn")

    def odometry_refusal(self) -> str:
        return (
            "an Ackermann car's odometry is a bicycle's (its controller turns the four joints into one speed and one "
            "steering angle): calibrate from the odometry (`odom_topic`) with `kinematics` bicycle, or from the "
            "joint states with `traction_joints` and `steering_joints`"
        )

    def ros2_parameters(self, g: Kinematics) -> dict[str, float]:
        """ackermann_steering_controller's ``wheelbase``, ``traction_track_width``,
        ``steering_track_width`` and ``traction_wheels_radius`` (doubles, metres)."""
        assert isinstance(g, Ackermann)
        return {
            "wheelbase": float(g.wheelbase_m),
            "traction_track_width": float(g.traction_track_m),
            "steering_track_width": float(g.steering_track_m),
            "traction_wheels_radius": float(0.5 * g.wheel_diameter_m),
        }

    def ros2_joints(self, joints: Mapping[str, str]) -> dict[str, Any]:
        """The joints in the controller's order: right, then left."""
        return {
            "traction_joints_names": [joints["traction_right"], joints["traction_left"]],
            "steering_joints_names": [joints["steering_right"], joints["steering_left"]],
        }

    def ros2_notes(
        self,
        g: Kinematics,
        ci95: Mapping[str, Interval | None],
        steering_in_use: tuple[float, float],
        joints: Mapping[str, str] | None = None,
    ) -> list[str]:
        humble = (
            "ROS 2 Humble names them front_steering: true, rear_wheels_names, front_wheels_names, rear_wheel_track, "
            "front_wheel_track and rear_wheels_radius (Jazzy takes both); the joints right before left"
        )
        assert isinstance(g, Ackermann)
        scaled = ci95.get("steering_scale") is not None
        left, right = (
            steering_note(g, scaled, *steering_in_use, joint=(joints or {}).get(role) or role.upper())
            for role in ("steering_left", "steering_right")
        )
        return [humble, *left, "and the same for the other steering joint:", *right[3:]]

    def export_json(self, g: Kinematics, ci95: Mapping[str, Interval | None]) -> dict[str, float]:
        assert isinstance(g, Ackermann)
        return {"steering_offset_rad": g.steering_offset_rad, "steering_scale": g.steering_scale}

    def draw(self, u: Uniform) -> tuple[Kinematics, Kinematics]:
        """A nominal wheel of 100-350 mm, wheelbase of 300-1200 mm and track widths of 0.6-0.9 of it
        (whole millimetres); the true diameter off by up to +-3 %, the steering offset up to +-3 deg
        (the rest as nominal: held unless asked for)."""
        d, length = round(u(100, 350)) * 1e-3, round(u(300, 1200)) * 1e-3
        track = round(length * u(600, 900)) * 1e-3
        nominal = Ackermann(d, length, track, track)
        return nominal, Ackermann(d * (1 + u(-0.03, 0.03)), length, track, track, math.radians(u(-3, 3)))


KIND = _AckermannKind()
"""The Ackermann car."""
