"""The tricycle (ros2 ``tricycle_controller``): one steered and driven wheel ahead of a passive rear axle.

Joints ``(drive, steer)``: the steered wheel sits at ``(L, 0)``, ``L`` the wheelbase ahead of the
rear axle's midpoint (the robot's origin). The true steering angle is ``gamma = scale * measured
+ offset`` (0 straight ahead, counter-clockwise positive); the wheel rolls ``s = r dphi``; the
rear axle does not slip sideways, so ``v_x = s cos gamma``, ``v_y = 0``, ``omega = s sin gamma / L``.

Its parameters: the traction wheel's diameter, the wheelbase, the steering offset and (on
request, ``fit_steering_scale``) the steering scale. The controller takes ``wheelbase`` and
``wheel_radius``; the steering offset (and the scale) belong to the steering joint's
transmission in the ros2_control hardware description (``transmission_interface/
SimpleTransmission``, whose joint position is ``actuator / mechanical_reduction + offset``):
the parameter file ends with that transmission's ``<joint>`` element as a comment, composed with
the one in use when the bag was recorded.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.kinds._base`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar, Protocol, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.kinds._base import (
    Alternative,
    Coverage,
    FitOption,
    Interval,
    JointOption,
    Kind,
    Parameter,
    Reading,
    Size,
    Uniform,
    finite_parameter,
    positive_parameter,
)
from umbmark.model.geometry import QUANTITIES, wrap_angle
from umbmark.model.kinematics import Kinematics

__all__ = [
    "Tricycle",
    "KIND",
    "MAX_STEERING_RAD",
    "DriveSteer",
    "Steered",
    "steering_note",
    "WHEEL_DIAMETER",
    "WHEELBASE",
    "STEERING",
    "WHEEL_DIAMETER_SIZE",
    "wheelbase_size",
    "DRIVE_STEER_JOINTS",
    "FIT_STEERING_SCALE",
]

FloatArray = NDArray[np.float64]

MAX_STEERING_RAD = math.radians(100.0)
"""The largest steering angle a tricycle's steering joint may read (beyond a quarter turn for
robots that spin about the rear axle, with room for an offset)."""

_STEER_SIDE_RAD = math.radians(5.0)


_G = TypeVar("_G", bound="DriveSteer")


@dataclass(frozen=True)
class DriveSteer:
    """A geometry of one traction wheel's size, a wheelbase and one steering angle (a tricycle, a
    bicycle-model car): its four parameters, their checks and their vector. A kind's geometry
    subclasses it with its kinematics, its ``kind`` and its largest steering offset.

    Parameters
    ----------
    wheel_diameter_m : float
        The traction wheel's diameter [m].
    wheelbase_m : float
        From the rear axle to the steered wheel or axle [m].
    steering_offset_rad : float
        True steering angle less the measured one at a measured 0 [rad].
    steering_scale : float
        True over measured steering angle (1: the steering joint reads true angles).
    """

    wheel_diameter_m: float
    wheelbase_m: float
    steering_offset_rad: float = 0.0
    steering_scale: float = 1.0

    joint_roles: ClassVar[tuple[str, ...]] = ("drive", "steer")
    rolling: ClassVar[tuple[bool, ...]] = (True, False)
    parameter_names: ClassVar[tuple[str, ...]] = (
        "wheel_diameter_m",
        "wheelbase_m",
        "steering_offset_rad",
        "steering_scale",
    )
    max_offset_rad: ClassVar[float] = 0.5 * math.pi
    """The largest steering offset the geometry takes."""
    offset_bound: ClassVar[str] = "a quarter turn"
    """That bound in the words of its refusal."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "wheel_diameter_m", positive_parameter("wheel_diameter_m", self.wheel_diameter_m))
        object.__setattr__(self, "wheelbase_m", positive_parameter("wheelbase_m", self.wheelbase_m))
        off = finite_parameter("steering_offset_rad", self.steering_offset_rad)
        if abs(off) > self.max_offset_rad:
            raise InputError(f"`steering_offset_rad` must be within {self.offset_bound}, got {off!r}")
        object.__setattr__(self, "steering_offset_rad", off)
        object.__setattr__(self, "steering_scale", positive_parameter("steering_scale", self.steering_scale))

    @classmethod
    def from_vector(cls: type[_G], p: ArrayLike) -> _G:
        q = np.asarray(p, dtype=float)
        return cls(float(q[0]), float(q[1]), float(q[2]), float(q[3]))

    def vector(self) -> FloatArray:
        return np.array([self.wheel_diameter_m, self.wheelbase_m, self.steering_offset_rad, self.steering_scale])

    def with_vector(self: _G, p: ArrayLike) -> _G:
        return self.from_vector(p)

    def rolling_diameters_m(self) -> FloatArray:
        return np.array([self.wheel_diameter_m])


@dataclass(frozen=True)
class Tricycle(DriveSteer):
    """A tricycle: one steered and driven wheel ahead of a passive rear axle (see the module docstring).

    Parameters
    ----------
    wheel_diameter_m : float
        The traction wheel's diameter [m].
    wheelbase_m : float
        From the rear axle's midpoint (the robot's origin) to the steered wheel [m].
    steering_offset_rad : float
        True steering angle less the measured one at a measured 0 [rad].
    steering_scale : float
        True over measured steering angle (1: the steering joint reads true angles).
    """

    kind: ClassVar[str] = "tricycle"
    moves: ClassVar[tuple[str, ...]] = ("straight", "back", "arc+", "arc-", "spin+", "spin-")

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        v = np.asarray(values, dtype=float)
        s = 0.5 * q[0] * v[..., 0]
        g = q[3] * v[..., 1] + q[2]
        return np.stack([s * np.cos(g), np.zeros_like(s), s * np.sin(g) / q[1]], axis=-1)

    def steering_for(self, vx_mps: ArrayLike, omega_radps: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """The true steering angle and the traction wheel's ground speed for a twist.

        Parameters
        ----------
        vx_mps, omega_radps : array_like
            Forward speed [m/s] and turn rate [rad/s] of the robot's origin.

        Returns
        -------
        tuple of numpy.ndarray
            ``(gamma_rad, speed_mps)``: the angle in ``[-pi/2, pi/2]`` (a quarter turn for a spin
            on the spot, towards the turn) and the wheel's signed speed (negative: rolling back).
        """
        vx, w = np.broadcast_arrays(np.asarray(vx_mps, dtype=float), np.asarray(omega_radps, dtype=float))
        sign = np.where(vx < 0, -1.0, 1.0)
        lat = w * self.wheelbase_m  # the steered wheel's sideways speed
        g = np.arctan2(sign * lat, np.abs(vx))
        return g, sign * np.hypot(vx, lat)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        if np.any(vy != 0):
            raise InputError("a tricycle cannot move sideways (`vy_mps` must be 0)")
        g, speed = self.steering_for(vx, w)
        measured = (g - self.steering_offset_rad) / self.steering_scale
        return np.stack([speed * dt_s / (0.5 * self.wheel_diameter_m), measured], axis=-1)


class Steered(Protocol):
    """A geometry with a steering offset and scale (a tricycle, a car)."""

    @property
    def steering_offset_rad(self) -> float: ...

    @property
    def steering_scale(self) -> float: ...


def steering_note(
    g: Steered, scale_estimated: bool, offset0: float, reduction0: float, joint: str | None = None
) -> list[str]:
    """The steering joint's transmission that makes its angle the true one, composed with the one in use.

    ``true = scale (actuator / reduction0 + offset0) + offset = actuator / (reduction0 / scale) +
    (scale offset0 + offset)`` (the scale 1 unless it was estimated). ``g`` has a
    ``steering_offset_rad`` and a ``steering_scale`` (a tricycle, a car); ``joint`` the steering
    joint's name (``STEERING_JOINT`` when the calibration does not say, and a line saying so).
    """
    offset, scale = float(g.steering_offset_rad), float(g.steering_scale)
    scale = scale if scale_estimated else 1.0
    off = scale * offset0 + offset
    red = reduction0 / scale
    return [
        f"the steering offset {math.degrees(offset):.4f} deg "
        f"({offset:.6f} rad: true angle = measured + offset) belongs to the steering joint's",
        "transmission in the ros2_control hardware description (SimpleTransmission: joint = actuator /",
        f"mechanical_reduction + offset), composed with the one in use ({offset0:g} rad, reduction {reduction0:g}):",
        f'  <joint name="{joint or "STEERING_JOINT"}" role="joint1">',
        f"    <mechanical_reduction>{red:.9g}</mechanical_reduction>",
        f"    <offset>{off:.9g}</offset>",
        "  </joint>",
    ] + ([] if joint else ["(the calibration names no steering joint: put its name for STEERING_JOINT)"])


EXCHANGED = "the drive and steering joints look exchanged"
"""The words of a drive and a steering joint given the other way round (a tricycle's, a car's)."""

DRIVE_STEER_WORDS = {"drive": (("traction",), ("drive",), ("wheel",)), "steer": (("steer",), ("steering",))}
"""The words of a drive and a steering joint's names (a tricycle's, a car's)."""

# The parameters, sizes, joints and fit of a robot with one traction wheel size, a wheelbase and one
# steering angle (a tricycle's, a car's), as its kind declares them.
WHEEL_DIAMETER = Parameter("wheel_diameter_m", ("wheel_diameter_mm",), "mm", "wheel diameter")
WHEELBASE = Parameter("wheelbase_m", ("wheelbase_mm",), "mm", "wheelbase")
STEERING = (
    Parameter("steering_offset_rad", ("steering_offset_deg",), "deg", "steering offset", nominal=0.0),
    Parameter("steering_scale", ("steering_scale",), "", "steering scale", digits=5, nominal=1.0),
)
WHEEL_DIAMETER_SIZE = Size(
    "wheel_diameter_mm",
    ("wheel_diameter_m",),
    QUANTITIES["diameter"],
    "wheel diameter",
    "D",
    alternative=Alternative("wheel_radius_m", 2.0, "R"),
)
DRIVE_STEER_JOINTS = (
    JointOption("drive_joint", ("drive",), "NAME", "the traction wheel", "JointState name of the traction wheel."),
    JointOption(
        "steer_joint",
        ("steer",),
        "NAME",
        help="JointState name of the steering joint (radians, counter-clockwise positive, 0 straight).",
    ),
)
FIT_STEERING_SCALE = FitOption(
    "fit_steering_scale",
    "steering_scale",
    "also estimate the steering scale (true over measured angle; needs large steering angles).",
)


def wheelbase_size(between: str) -> Size:
    """The wheelbase's size option, ``between`` saying from where to where it is measured."""
    return Size("wheelbase_mm", ("wheelbase_m",), QUANTITIES["wheelbase"], "wheelbase", "L", between)


def _zero_off(shift: float, joint: str = "") -> tuple[str, str]:
    """The words and the remedy of a steering zero ``-shift`` off (the reading that adds ``shift`` fits)."""
    side = "right" if shift > 0 else "left"
    name = f" {joint}" if joint else ""
    return (
        f"the steering joint{name} reads {math.degrees(-shift):+.0f} deg (a quarter turn to the {side}) with the "
        "wheel straight ahead: its zero is a quarter turn off (an offset, not degrees)",
        "move the zero where the angle is made (the steering joint's transmission: its <offset> "
        f"{shift:+.6f} rad more, or the driver) and record again",
    )


class _TricycleKind(Kind):
    name = Tricycle.kind
    noun = "tricycle"
    title = "Tricycle"
    geometry = Tricycle
    controller = "tricycle_controller"
    drawable = True
    parameters = (WHEEL_DIAMETER, WHEELBASE, *STEERING)
    sizes = (WHEEL_DIAMETER_SIZE, wheelbase_size("rear axle to steered wheel"))
    joints = DRIVE_STEER_JOINTS
    fits = (FIT_STEERING_SCALE,)
    legend = (
        "wheel diameter: the traction wheel's; wheelbase: from the rear axle's midpoint to the steered wheel; "
        "steering offset: the true steering angle less the measured one (counter-clockwise positive), the "
        "number that makes a measured 0 drive straight.",
    )
    sim_joints = ("traction_wheel_joint", "steering_joint")
    turn_backwards = "the traction joint turns backwards when the robot drives forward"
    turn_mirrored = "the steering joint's angle clockwise positive (it must be counter-clockwise positive)"
    role_words = DRIVE_STEER_WORDS

    def readings(self) -> tuple[Reading, ...]:
        """The drive and steering joints exchanged, and the steering joint's zero a quarter turn
        off either way (the reading adds the turn back)."""
        exchanged = tuple(Reading(r.order, words=EXCHANGED) for r in super().readings())
        quarter = 0.5 * math.pi
        return exchanged + tuple(Reading((0, 1), (0.0, s * quarter), _zero_off(s * quarter)[0]) for s in (1.0, -1.0))

    def reading_cause(self, reading: Reading, names: Sequence[str]) -> tuple[str, str]:
        if any(reading.shift_rad):
            return _zero_off(reading.shift_rad[1], names[1])
        return super().reading_cause(reading, names)

    def steering_travel(self, nominal: Kinematics, values: FloatArray) -> tuple[float, float]:
        assert isinstance(nominal, Tricycle)
        s = np.abs(0.5 * nominal.wheel_diameter_m * values[:, 0])
        g = values[:, 1]
        return float(s[g > _STEER_SIDE_RAD].sum()), float(s[g < -_STEER_SIDE_RAD].sum())

    def advice(self, coverage: Coverage) -> list[str]:
        cov = coverage
        if min(cov.steer_left_m, cov.steer_right_m) >= 0.05 * max(cov.travel_m, 1e-9):
            return []
        side = "right" if cov.steer_right_m < cov.steer_left_m else "left"
        return [
            f"the steering hardly turns to the {side}: the steering offset then rests on the steering scale "
            "being right; steer both ways (arcs left and right)"
        ]

    def negative(self, g: FloatArray, bad: list[str]) -> tuple[list[str], str]:
        if abs(wrap_angle(g[2])) > 0.5 * math.pi:
            # a steering offset of half a turn is a wheel rolling the other way
            bad = ["wheel_diameter_m"] if g[0] > 0 else bad
        why = (
            "the traction joint turns backwards when the robot drives forward"
            if "wheel_diameter_m" in bad
            else "the steering joint's angle is clockwise positive (it must be counter-clockwise positive)"
        )
        return bad, why

    def ros2_parameters(self, g: Kinematics) -> dict[str, float]:
        """tricycle_controller's ``wheelbase`` and ``wheel_radius`` (doubles, metres)."""
        assert isinstance(g, Tricycle)
        return {"wheelbase": float(g.wheelbase_m), "wheel_radius": float(0.5 * g.wheel_diameter_m)}

    def ros2_joints(self, joints: Mapping[str, str]) -> dict[str, str]:
        """tricycle_controller's ``traction_joint_name`` and ``steering_joint_name`` (strings, required)."""
        return {"traction_joint_name": str(joints["drive"]), "steering_joint_name": str(joints["steer"])}

    def ros2_notes(
        self,
        g: Kinematics,
        ci95: Mapping[str, Interval | None],
        steering_in_use: tuple[float, float],
        joints: Mapping[str, str] | None = None,
    ) -> list[str]:
        assert isinstance(g, Tricycle)
        steer = None if joints is None else joints.get("steer")
        return steering_note(g, ci95.get("steering_scale") is not None, *steering_in_use, joint=steer)

    def export_json(self, g: Kinematics, ci95: Mapping[str, Interval | None]) -> dict[str, float]:
        assert isinstance(g, Tricycle)
        return {"steering_offset_rad": g.steering_offset_rad, "steering_scale": g.steering_scale}

    def draw(self, u: Uniform) -> tuple[Kinematics, Kinematics]:
        """A nominal traction wheel of 150-300 mm and wheelbase of 400-1000 mm (whole millimetres);
        the true diameter off by up to +-3 %, the wheelbase by +-5 %, the steering offset up to +-3 deg."""
        d, length = round(u(150, 300)) * 1e-3, round(u(400, 1000)) * 1e-3
        nominal = Tricycle(d, length)
        true = Tricycle(d * (1 + u(-0.03, 0.03)), length * (1 + u(-0.05, 0.05)), math.radians(u(-3, 3)))
        return nominal, true


KIND = _TricycleKind()
"""The tricycle."""
