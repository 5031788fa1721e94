"""The car of the bicycle model (ros2 ``bicycle_steering_controller`` with front steering; F1TENTH's and
MuSHR's ``vesc_to_odom``): a driven rear axle and one steering angle.

Joints ``(drive, steer)``. The robot's origin is the rear axle's midpoint; the steering angle is
the angle of a virtual wheel midway on the front axle, ``L`` (the wheelbase) ahead, counter-
clockwise positive. The true angle is ``delta = scale * measured + offset``; the rear wheels roll
``s = r dphi`` and do not slip sideways, so ``v_x = s``, ``v_y = 0``, ``omega = s tan(delta) / L``
(the controller's ``linear = traction_wheel_vel * traction_wheel_radius``, ``angular =
tan(steer_pos) * linear / wheelbase``).

Its parameters: the traction wheel's diameter, the wheelbase, the steering offset, the steering
scale. For small angles the driving sees only ``scale / L`` and ``offset / L``: the scale and the
wheelbase separate only through ``tan`` at large angles, so the wheelbase is held at the nominal
one given (a tape measure's number) unless ``fit_wheelbase`` asks for it, and the scale is
estimated on request (``fit_steering_scale``), as for a tricycle.

From the car's own odometry (``odom_topic``: ``vesc_to_odom``, or the controller's ``/odom``) the
joints are the odometry's speed and steering angle turned back with the nominal wheel size and
wheelbase (:func:`speed_and_steering`): each step's length is the distance between consecutive
poses (``vesc_to_odom`` steps along the heading before the step, exactly; the controller's exact
arcs to within ``dtheta^2 / 24``) and its steering angle ``atan(L dtheta / ds)``.

Exports: the controller's ``wheelbase`` and ``traction_wheel_radius`` with the joints' names
(ROS 2 Jazzy and later; Humble's names in a comment), the steering joint's transmission as a
comment (as for a tricycle); and the vesc driver's parameter file (``vesc.yaml``) with
``speed_to_erpm_gain``, ``steering_angle_to_servo_gain`` and ``steering_angle_to_servo_offset``
calibrated from the values in use (:func:`vesc_values`).

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.kinds._base`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.kinds._base import (
    Coverage,
    EditedFile,
    FitOption,
    Interval,
    Kind,
    Reading,
    Uniform,
)
from umbmark.kinds.tricycle import (
    DRIVE_STEER_JOINTS,
    DRIVE_STEER_WORDS,
    EXCHANGED,
    FIT_STEERING_SCALE,
    STEERING,
    WHEEL_DIAMETER,
    WHEEL_DIAMETER_SIZE,
    WHEELBASE,
    DriveSteer,
    steering_note,
    wheelbase_size,
)
from umbmark.model.geometry import wrap_angle
from umbmark.model.kinematics import Kinematics

__all__ = [
    "Bicycle",
    "KIND",
    "CAR_FITS",
    "FULL_LOCK_RAD",
    "MAX_OFFSET_RAD",
    "VESC_KEYS",
    "car_steering",
    "speed_and_steering",
    "vesc_values",
    "car_advice",
    "car_negative",
    "travel_steered",
]

FloatArray = NDArray[np.float64]

FULL_LOCK_RAD = math.radians(24.0)
"""How far a car's steering turns each way in the simulator's programs (an F1TENTH car's full
lock is about 24 deg): their tightest turn is ``tan(FULL_LOCK_RAD) / L``."""

MAX_OFFSET_RAD = math.radians(45.0)
"""The largest steering offset a car's geometry takes (beyond it: no car's steering)."""

_STEER_SIDE_RAD = math.radians(2.0)
_STILL_M = 1e-6  # an odometry step shorter than this holds the steering angle of the step before

VESC_KEYS = ("speed_to_erpm_gain", "steering_angle_to_servo_gain", "steering_angle_to_servo_offset")
"""The vesc driver's parameters a car's calibration changes (each computed from its value in use)."""


CAR_FITS = (
    dataclasses.replace(FIT_STEERING_SCALE, check=True),
    FitOption(
        "fit_wheelbase",
        "wheelbase_m",
        "also estimate the wheelbase (it separates from the steering scale only through tan at large "
        "steering angles: drive near full lock; else held at the nominal wheelbase).",
    ),
)
"""A car's fits: the steering scale (estimated anyway to check that 1 holds) and the wheelbase."""


def car_steering(vx_mps: ArrayLike, omega_radps: ArrayLike, wheelbase_m: float) -> tuple[FloatArray, FloatArray]:
    """The true steering angle (of the virtual centre wheel) and speed of a car for a twist.

    Parameters
    ----------
    vx_mps, omega_radps : array_like
        Forward speed [m/s] and turn rate [rad/s] of the rear axle's midpoint.
    wheelbase_m : float

    Returns
    -------
    tuple of numpy.ndarray
        ``(delta_rad, vx_mps)``: ``atan(omega L / v_x)`` (0 without motion, as the controller's
        ``convert_twist_to_steering_angle``).

    Raises
    ------
    InputError
        A turn without forward speed: a car cannot turn on the spot.
    """
    vx, w = np.broadcast_arrays(np.asarray(vx_mps, dtype=float), np.asarray(omega_radps, dtype=float))
    if np.any((vx == 0) & (w != 0)):
        raise InputError("a car cannot turn on the spot (`omega_radps` needs a forward speed `vx_mps`)")
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(vx == 0, 0.0, np.arctan(w * wheelbase_m / np.where(vx == 0, 1.0, vx)))
    return np.asarray(d, dtype=float), np.asarray(vx, dtype=float)


@dataclass(frozen=True)
class Bicycle(DriveSteer):
    """A car of the bicycle model: rear-wheel drive and one steering angle (see the module docstring).

    Parameters
    ----------
    wheel_diameter_m : float
        The traction (rear) wheels' diameter [m].
    wheelbase_m : float
        From the rear axle to the front axle [m].
    steering_offset_rad : float
        True steering angle less the measured one at a measured 0 [rad].
    steering_scale : float
        True over measured steering angle (1: the steering reads true angles).
    """

    kind: ClassVar[str] = "bicycle"
    moves: ClassVar[tuple[str, ...]] = ("straight", "back", "loop+", "loop-", "reverse+", "reverse-")
    max_offset_rad: ClassVar[float] = MAX_OFFSET_RAD
    offset_bound: ClassVar[str] = f"{math.degrees(MAX_OFFSET_RAD):g} deg"

    @property
    def max_curvature_per_m(self) -> float:
        """The tightest turn of the simulator's programs: ``tan(FULL_LOCK_RAD) / L`` [1/m]."""
        return math.tan(FULL_LOCK_RAD) / self.wheelbase_m

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        v = np.asarray(values, dtype=float)
        s = 0.5 * q[0] * v[..., 0]
        d = q[3] * v[..., 1] + q[2]
        return np.stack([s, np.zeros_like(s), s * np.tan(d) / q[1]], axis=-1)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        if np.any(vy != 0):
            raise InputError("a car cannot move sideways (`vy_mps` must be 0)")
        d, speed = car_steering(vx, w, self.wheelbase_m)
        measured = (d - self.steering_offset_rad) / self.steering_scale
        return np.stack([speed * dt_s / (0.5 * self.wheel_diameter_m), measured], axis=-1)


def speed_and_steering(pose: ArrayLike, wheelbase_m: float) -> tuple[FloatArray, FloatArray]:
    """The travel and steering angle of each step of a car's odometry (the inverse of its integration).

    Parameters
    ----------
    pose : array_like
        ``(K, 3)`` the odometry's poses ``(x_m, y_m, yaw_rad)`` in time order (yaw wrapped or not).
    wheelbase_m : float
        The wheelbase the odometry was computed with.

    Returns
    -------
    tuple of numpy.ndarray
        ``(ds_m, delta_rad)``, each ``(K - 1,)``: the distance between consecutive poses, negative
        where the car moved against its heading halfway through the step; ``atan(L dtheta / ds)``
        (a step shorter than a micrometre holds the angle of the step before; the first ones
        the first moving step's).

    Raises
    ------
    InputError
        Poses that are not ``(K, 3)``, or an odometry that moves but never turns (its heading
        does not come from the steering).
    """
    p = np.asarray(pose, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2:
        raise InputError(f"`pose` must have shape (K, 3) with K >= 2, got {p.shape}")
    dth = wrap_angle(np.diff(p[:, 2]))
    dx, dy = np.diff(p[:, 0]), np.diff(p[:, 1])
    mid = p[:-1, 2] + 0.5 * dth
    along = dx * np.cos(mid) + dy * np.sin(mid)
    ds = np.where(along < 0, -1.0, 1.0) * np.hypot(dx, dy)
    moving = np.abs(ds) > _STILL_M
    travel = float(np.abs(ds).sum())
    if travel > 1.0 and float(np.abs(dth).sum()) < 1e-9:
        raise InputError(
            f"the odometry moves {travel:.3g} m but its heading never changes: if the car turned, the odometry's "
            "heading does not come from its steering (vesc_to_odom turns only with "
            "use_servo_cmd_to_calc_angular_velocity: true; set it and record again)"
        )
    delta = np.full(len(ds), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta[moving] = np.arctan(wheelbase_m * dth[moving] / ds[moving])
    idx = np.where(moving, np.arange(len(ds)), -1)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(moving)) if moving.any() else -1
    fill = delta[first] if first >= 0 else 0.0
    delta = np.where(idx >= 0, delta[np.maximum(idx, 0)], fill)
    return ds, np.asarray(delta, dtype=float)


def vesc_values(g: Bicycle, nominal: Bicycle, in_use: Mapping[str, float]) -> dict[str, float]:
    """The vesc driver's gains calibrated (:data:`VESC_KEYS`), from those in use.

    With the true wheel diameter ``D`` against the nominal ``D_n`` the odometry was computed with,
    the steering scale ``s`` and offset ``delta_0`` (true = s measured + delta_0):
    ``speed_to_erpm_gain' = speed_to_erpm_gain D_n / D``, ``steering_angle_to_servo_gain' =
    steering_angle_to_servo_gain / s``, ``steering_angle_to_servo_offset' =
    steering_angle_to_servo_offset - delta_0 steering_angle_to_servo_gain / s`` (``speed_to_erpm_offset``
    is unchanged).

    Raises
    ------
    InputError
        A value in use missing or not a finite number, or a gain of 0 (the key named).
    """
    vals = {}
    for key in VESC_KEYS:
        v = in_use.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"`{key}` in use must be a number, got {v!r}")
        if key.endswith("_gain") and v == 0:
            raise InputError(f"`{key}` in use is 0: no gain the calibration can scale")
        vals[key] = float(v)
    s, d0 = g.steering_scale / nominal.steering_scale, g.steering_offset_rad - nominal.steering_offset_rad
    servo = vals["steering_angle_to_servo_gain"]
    return {
        "speed_to_erpm_gain": vals["speed_to_erpm_gain"] * nominal.wheel_diameter_m / g.wheel_diameter_m,
        "steering_angle_to_servo_gain": servo / s,
        "steering_angle_to_servo_offset": vals["steering_angle_to_servo_offset"] - d0 * servo / s,
    }


def car_advice(coverage: Coverage) -> list[str]:
    """What a car's driving lacks for its steering: turns of the steering both ways (a car cannot spin)."""
    cov = coverage
    if min(cov.steer_left_m, cov.steer_right_m) >= 0.05 * max(cov.travel_m, 1e-9):
        return []
    side = "right" if cov.steer_right_m < cov.steer_left_m else "left"
    return [
        f"the steering hardly turns to the {side}: the steering offset then rests on the steering scale being "
        "right; drive loops both ways (figure-eights) near full lock, and reversing arcs"
    ]


def car_negative(diameter: float, offset: float, bad: list[str], joints: str) -> tuple[list[str], str]:
    """What a car's fit with a negative size means: its fitted wheel ``diameter`` and steering
    ``offset``, the sizes ``bad`` not positive, ``joints`` how its traction joints are named."""
    if abs(wrap_angle(offset)) > 0.5 * math.pi:
        bad = ["wheel_diameter_m"] if diameter > 0 else bad
    why = (
        f"{joints} backwards when the car drives forward (from an odometry: its speed has the wrong sign)"
        if "wheel_diameter_m" in bad
        else "the steering angle is clockwise positive (it must be counter-clockwise positive)"
    )
    return bad, why


def travel_steered(travel_m: FloatArray, steer_rad: FloatArray) -> tuple[float, float]:
    """The distance travelled with the steering beyond 2 deg to the left and to the right [m]."""
    return float(travel_m[steer_rad > _STEER_SIDE_RAD].sum()), float(travel_m[steer_rad < -_STEER_SIDE_RAD].sum())


class _BicycleKind(Kind):
    name = Bicycle.kind
    noun = "bicycle-model car"
    title = "Bicycle"
    geometry = Bicycle
    controller = "bicycle_steering_controller"
    export_formats = ("ros2", "json", "urdf", "tf", "vesc")
    drawable = True
    reads_odometry = True
    parameters = (WHEEL_DIAMETER, WHEELBASE, *STEERING)
    sizes = (WHEEL_DIAMETER_SIZE, wheelbase_size("rear axle to front axle"))
    joints = DRIVE_STEER_JOINTS
    fits = CAR_FITS
    edited_files = (
        EditedFile(
            "vesc",
            "vesc_config",
            "VESC.yaml",
            VESC_KEYS,
            VESC_KEYS,
            "the vesc driver's parameter file (F1TENTH's, MuSHR's vesc.yaml)",
            "the calibration read joint states, not the odometry vesc_to_odom computes with these gains: the "
            "speed gain is right only if speed_to_erpm_gain was set for the nominal wheel diameter given, the "
            "servo's only if the steering joint reads the commanded steering angle",
        ),
    )
    legend = (
        "wheel diameter: the traction (rear) wheels'; wheelbase: rear axle to front axle (held at the nominal one "
        "unless asked to estimate it); steering offset: the true steering angle less the measured one (counter-"
        "clockwise positive), the number that makes a measured 0 drive straight; steering scale: true over "
        "measured angle.",
    )
    sim_joints = ("rear_wheel_joint", "steering_joint")
    turn_backwards = "the traction joint turns backwards when the car drives forward"
    turn_mirrored = "the steering angle clockwise positive (it must be counter-clockwise positive)"
    role_words = DRIVE_STEER_WORDS

    def readings(self) -> tuple[Reading, ...]:
        """The drive and steering joints exchanged."""
        return tuple(Reading(r.order, words=EXCHANGED) for r in super().readings())

    def steering_travel(self, nominal: Kinematics, values: FloatArray) -> tuple[float, float]:
        assert isinstance(nominal, Bicycle)
        s = np.abs(0.5 * nominal.wheel_diameter_m * values[:, 0])
        return travel_steered(s, values[:, 1])

    def advice(self, coverage: Coverage) -> list[str]:
        return car_advice(coverage)

    def negative(self, g: FloatArray, bad: list[str]) -> tuple[list[str], str]:
        return car_negative(float(g[0]), float(g[2]), bad, "the traction joint turns")

    def joints_from_odometry(self, nominal: Kinematics, pose: FloatArray) -> FloatArray:
        """The odometry's speed (as the traction wheel's angle through the nominal diameter) and
        steering angle (:func:`speed_and_steering` with the nominal wheelbase)."""
        assert isinstance(nominal, Bicycle)
        ds, delta = speed_and_steering(pose, nominal.wheelbase_m)
        drive = np.concatenate([[0.0], np.cumsum(ds)]) / (0.5 * nominal.wheel_diameter_m)
        return np.column_stack([drive, np.concatenate([delta[:1], delta])])

    def ros2_parameters(self, g: Kinematics) -> dict[str, float]:
        """bicycle_steering_controller's ``wheelbase`` and ``traction_wheel_radius`` (doubles, metres)."""
        assert isinstance(g, Bicycle)
        return {"wheelbase": float(g.wheelbase_m), "traction_wheel_radius": float(0.5 * g.wheel_diameter_m)}

    def ros2_joints(self, joints: Mapping[str, str]) -> dict[str, Any]:
        return {"traction_joints_names": [joints["drive"]], "steering_joints_names": [joints["steer"]]}

    def ros2_notes(
        self,
        g: Kinematics,
        ci95: Mapping[str, Interval | None],
        steering_in_use: tuple[float, float],
        joints: Mapping[str, str] | None = None,
    ) -> list[str]:
        humble = (
            "ROS 2 Humble names them front_steering: true, rear_wheels_names, front_wheels_names and "
            "rear_wheel_radius (Jazzy takes both)"
        )
        if joints is None:
            return [
                "calibrated from the car's odometry: no joints' names in the recording; add traction_joints_names "
                "and steering_joints_names of your car",
                humble,
                "the steering offset and scale belong to what turns the steering command into an angle (a vesc: "
                "umbmark's vesc export edits its vesc.yaml)",
            ]
        assert isinstance(g, Bicycle)
        scaled = ci95.get("steering_scale") is not None
        return [humble] + steering_note(g, scaled, *steering_in_use, joint=joints.get("steer"))

    def export_json(self, g: Kinematics, ci95: Mapping[str, Interval | None]) -> dict[str, float]:
        assert isinstance(g, Bicycle)
        return {"steering_offset_rad": g.steering_offset_rad, "steering_scale": g.steering_scale}

    def edited_values(
        self, fmt: str, g: Kinematics, nominal: Kinematics, in_use: Mapping[str, float]
    ) -> dict[str, float]:
        if fmt != self.edited_files[0].format:
            return super().edited_values(fmt, g, nominal, in_use)
        assert isinstance(g, Bicycle) and isinstance(nominal, Bicycle)
        return vesc_values(g, nominal, in_use)

    def edited_notes(self, fmt: str, g: Kinematics, ci95: Mapping[str, Interval | None]) -> list[str]:
        assert isinstance(g, Bicycle)
        if ci95.get("wheelbase_m") is None:
            return []
        return [
            f"the wheelbase was estimated too ({1e3 * g.wheelbase_m:.1f} mm): set vesc_to_odom's wheelbase to "
            f"{g.wheelbase_m:.4f} (the steering gains above are for it)"
        ]

    def draw(self, u: Uniform) -> tuple[Kinematics, Kinematics]:
        """A nominal wheel of 80-250 mm and wheelbase of 250-900 mm (whole millimetres); the true
        diameter off by up to +-3 %, the steering offset up to +-3 deg (the wheelbase and the scale
        as nominal: they are held unless asked for)."""
        d, length = round(u(80, 250)) * 1e-3, round(u(250, 900)) * 1e-3
        nominal = Bicycle(d, length)
        return nominal, Bicycle(d * (1 + u(-0.03, 0.03)), length, math.radians(u(-3, 3)))


KIND = _BicycleKind()
"""The car of the bicycle model."""
