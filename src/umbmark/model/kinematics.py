"""Wheeled-robot kinematics: what the joints' motion makes the robot do, for three kinds of robot.

Pure numpy: this module imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.model.se2`.
SI units; the robot frame: x forward, y to the left, angles counter-clockwise positive.

A robot's joints are read as **steps** (:class:`JointSteps`): in each step every rolling joint
turns by an increment [rad] and every steering joint holds an angle [rad] (its mean over the
step). Within a step the joints' rates are constant, so the robot moves at a constant twist
``(v_x, v_y, omega)`` and its displacement is the exact SE(2) exponential of the integrated
twist (:func:`twist_displacement`); the steps of an interval compose into its motion
(:func:`compose_steps`).

The kinds (one interface, :class:`Kinematics`):

* :class:`DiffDrive`, joints ``(left, right)``: ``v_x = (r_L dphi_L + r_R dphi_R) / 2``,
  ``omega = (r_R dphi_R - r_L dphi_L) / b``.
* :class:`Tricycle` (ros2 ``tricycle_controller``), joints ``(drive, steer)``: one steered and
  driven wheel at ``(L, 0)``, ``L`` the wheelbase ahead of the rear axle's midpoint (the
  robot's origin). The true steering angle is ``gamma = scale * measured + offset`` (0
  straight ahead, counter-clockwise positive); the wheel rolls ``s = r dphi``; the rear axle
  does not slip sideways, so ``v_x = s cos gamma``, ``v_y = 0``, ``omega = s sin gamma / L``.
* :class:`Mecanum` (ros2 ``mecanum_drive_controller``), joints ``(front_left, front_right,
  rear_left, rear_right)``, rollers at 45 deg: with ``u_i = r_i dphi_i`` and
  ``k = l_x + l_y`` (the controller's ``sum_of_robot_center_projection_on_X_Y_axis``)::

      v_x   = ( u_FL + u_FR + u_RL + u_RR) / 4
      v_y   = (-u_FL + u_FR + u_RL - u_RR) / 4
      omega = (-u_FL + u_FR - u_RL + u_RR) / (4 k)

  (the controller's forward kinematics with a radius per wheel; a bigger front-right wheel
  drifts the robot left and turns it left).

Each kind's :meth:`~Kinematics.joint_motion` is its inverse: the joint steps a controller of
that geometry commands for a twist (the simulator drives with the nominal geometry's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2

__all__ = [
    "KINEMATICS",
    "Kinematics",
    "DiffDrive",
    "Tricycle",
    "Mecanum",
    "JointSteps",
    "twist_displacement",
    "compose_steps",
    "integrate_steps",
    "kinematics_class",
    "MAX_STEERING_RAD",
    "JointIntervals",
    "joint_intervals_from_motion",
]

FloatArray = NDArray[np.float64]

MAX_STEERING_RAD = math.radians(100.0)
"""The largest steering angle a tricycle's steering joint may read (beyond a quarter turn for
robots that spin about the rear axle, with room for an offset)."""


def twist_displacement(twist: ArrayLike) -> FloatArray:
    """The displacement of a constant twist held for a step: the SE(2) exponential.

    Parameters
    ----------
    twist : array_like
        ``(..., 3)`` the twist integrated over the step ``(a, b, theta) = (v_x dt, v_y dt,
        omega dt)`` [m, m, rad].

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` ``(x, y, theta)``: ``x = a sinc(theta) - b s``, ``y = a s + b sinc(theta)``
        with ``s = sin(theta / 2) sinc(theta / 2) = (1 - cos theta) / theta``; ``theta`` not
        wrapped. Exact to rounding at every ``theta`` (a differential drive's arc when ``b = 0``).
    """
    w = np.asarray(twist, dtype=float)
    a, b, th = w[..., 0], w[..., 1], w[..., 2]
    half = 0.5 * th
    k = se2.sinc(th)
    s = np.sin(half) * se2.sinc(half)
    return np.stack([a * k - b * s, a * s + b * k, th], axis=-1)


def compose_steps(local: ArrayLike, start: ArrayLike) -> FloatArray:
    """The motion over each interval: its steps' displacements composed.

    Parameters
    ----------
    local : array_like
        ``(S, 3)`` each step's displacement in the robot frame at the step's start.
    start : array_like
        ``(K + 1,)`` offsets of the intervals' steps (:attr:`JointSteps.start`).

    Returns
    -------
    numpy.ndarray
        ``(K, 3)`` the robot's pose at each interval's end in its frame at the start (heading
        not wrapped).
    """
    d = np.asarray(local, dtype=float)
    st = np.asarray(start, dtype=np.intp)
    first = st[:-1]
    seg = np.repeat(np.arange(len(first)), np.diff(st))
    cum = np.cumsum(d[:, 2])
    phi = cum - d[:, 2]
    phi = phi - phi[first][seg]
    c, s = np.cos(phi), np.sin(phi)
    gx = c * d[:, 0] - s * d[:, 1]
    gy = s * d[:, 0] + c * d[:, 1]
    return np.column_stack([np.add.reduceat(gx, first), np.add.reduceat(gy, first), np.add.reduceat(d[:, 2], first)])


def integrate_steps(local: ArrayLike, start_pose: ArrayLike = (0.0, 0.0, 0.0)) -> FloatArray:
    """The poses along consecutive steps from ``start_pose``.

    Parameters
    ----------
    local : array_like
        ``(S, 3)`` each step's displacement in the robot frame at its start.
    start_pose : array_like
        ``(x, y, yaw)`` before the first step.

    Returns
    -------
    numpy.ndarray
        ``(S + 1, 3)`` the poses (heading accumulated, not wrapped).
    """
    d = np.asarray(local, dtype=float).reshape(-1, 3)
    p0 = np.asarray(start_pose, dtype=float).reshape(3)
    th = p0[2] + np.concatenate([[0.0], np.cumsum(d[:, 2])])
    c, s = np.cos(th[:-1]), np.sin(th[:-1])
    out = np.empty((len(d) + 1, 3))
    out[:, 0] = p0[0] + np.concatenate([[0.0], np.cumsum(c * d[:, 0] - s * d[:, 1])])
    out[:, 1] = p0[1] + np.concatenate([[0.0], np.cumsum(s * d[:, 0] + c * d[:, 1])])
    out[:, 2] = th
    return out


def _positive(name: str, v: float) -> float:
    if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v) and v > 0):
        raise InputError(f"`{name}` must be a positive number, got {v!r}")
    return float(v)


def _finite(name: str, v: float) -> float:
    if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v)):
        raise InputError(f"`{name}` must be a finite number, got {v!r}")
    return float(v)


class Kinematics(Protocol):
    """What every kind of robot offers (:class:`DiffDrive`, :class:`Tricycle`, :class:`Mecanum`)."""

    kind: ClassVar[str]
    joint_roles: ClassVar[tuple[str, ...]]
    rolling: ClassVar[tuple[bool, ...]]
    parameter_names: ClassVar[tuple[str, ...]]

    def vector(self) -> FloatArray:
        """The parameters as a vector, in :attr:`parameter_names` order (SI)."""
        ...

    def with_vector(self, p: ArrayLike) -> Kinematics:
        """The same kind with the parameters ``p``."""
        ...

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        """``(S, 3)`` the integrated twist of each step of joint values ``(S, J)`` (parameters ``p``
        or the robot's own)."""
        ...

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        """``(S, J)`` the joint steps this geometry commands for twists held ``dt_s`` each."""
        ...


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

    def __post_init__(self) -> None:
        for n in self.parameter_names:
            object.__setattr__(self, n, _positive(n, getattr(self, n)))

    def vector(self) -> FloatArray:
        return np.array([self.diameter_left_m, self.diameter_right_m, self.wheelbase_m])

    def with_vector(self, p: ArrayLike) -> DiffDrive:
        q = np.asarray(p, dtype=float)
        return DiffDrive(float(q[0]), float(q[1]), float(q[2]))

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


@dataclass(frozen=True)
class Tricycle:
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

    wheel_diameter_m: float
    wheelbase_m: float
    steering_offset_rad: float = 0.0
    steering_scale: float = 1.0

    kind: ClassVar[str] = "tricycle"
    joint_roles: ClassVar[tuple[str, ...]] = ("drive", "steer")
    rolling: ClassVar[tuple[bool, ...]] = (True, False)
    parameter_names: ClassVar[tuple[str, ...]] = (
        "wheel_diameter_m",
        "wheelbase_m",
        "steering_offset_rad",
        "steering_scale",
    )

    def __post_init__(self) -> None:
        object.__setattr__(self, "wheel_diameter_m", _positive("wheel_diameter_m", self.wheel_diameter_m))
        object.__setattr__(self, "wheelbase_m", _positive("wheelbase_m", self.wheelbase_m))
        off = _finite("steering_offset_rad", self.steering_offset_rad)
        if abs(off) > 0.5 * math.pi:
            raise InputError(f"`steering_offset_rad` must be within a quarter turn, got {off!r}")
        object.__setattr__(self, "steering_offset_rad", off)
        object.__setattr__(self, "steering_scale", _positive("steering_scale", self.steering_scale))

    def vector(self) -> FloatArray:
        return np.array([self.wheel_diameter_m, self.wheelbase_m, self.steering_offset_rad, self.steering_scale])

    def with_vector(self, p: ArrayLike) -> Tricycle:
        q = np.asarray(p, dtype=float)
        return Tricycle(float(q[0]), float(q[1]), float(q[2]), float(q[3]))

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


@dataclass(frozen=True)
class Mecanum:
    """A mecanum robot: four wheels with rollers at 45 deg (see the module docstring).

    Parameters
    ----------
    wheel_diameters_m : tuple of float
        ``(front_left, front_right, rear_left, rear_right)`` [m].
    lx_plus_ly_m : float
        Half the wheelbase plus half the track [m] (``kinematics.sum_of_robot_center_projection_on_X_Y_axis``).
    """

    wheel_diameters_m: tuple[float, float, float, float]
    lx_plus_ly_m: float

    kind: ClassVar[str] = "mecanum"
    joint_roles: ClassVar[tuple[str, ...]] = ("front_left", "front_right", "rear_left", "rear_right")
    rolling: ClassVar[tuple[bool, ...]] = (True, True, True, True)
    parameter_names: ClassVar[tuple[str, ...]] = (
        "diameter_front_left_m",
        "diameter_front_right_m",
        "diameter_rear_left_m",
        "diameter_rear_right_m",
        "lx_plus_ly_m",
    )

    # the signs of each wheel's travel in (v_x, v_y, omega k)
    _SIGNS: ClassVar[FloatArray] = np.array([[1.0, 1.0, 1.0, 1.0], [-1.0, 1.0, 1.0, -1.0], [-1.0, 1.0, -1.0, 1.0]])

    def __post_init__(self) -> None:
        d = tuple(self.wheel_diameters_m)
        if len(d) != 4:
            raise InputError(f"`wheel_diameters_m` needs four diameters (FL, FR, RL, RR), got {len(d)}")
        object.__setattr__(
            self, "wheel_diameters_m", tuple(_positive(f"wheel_diameters_m[{i}]", v) for i, v in enumerate(d))
        )
        object.__setattr__(self, "lx_plus_ly_m", _positive("lx_plus_ly_m", self.lx_plus_ly_m))

    @classmethod
    def uniform(cls, wheel_diameter_m: float, lx_plus_ly_m: float) -> Mecanum:
        """Four wheels of one diameter."""
        return cls((wheel_diameter_m, wheel_diameter_m, wheel_diameter_m, wheel_diameter_m), lx_plus_ly_m)

    def vector(self) -> FloatArray:
        return np.array([*self.wheel_diameters_m, self.lx_plus_ly_m])

    def with_vector(self, p: ArrayLike) -> Mecanum:
        q = np.asarray(p, dtype=float)
        return Mecanum((float(q[0]), float(q[1]), float(q[2]), float(q[3])), float(q[4]))

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        u = 0.5 * q[:4] * np.asarray(values, dtype=float)
        t = u @ self._SIGNS.T * 0.25
        t[..., 2] = t[..., 2] / q[4]
        return np.asarray(t, dtype=float)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        tw = np.stack([vx, vy, w * self.lx_plus_ly_m], axis=-1)
        travel = tw @ self._SIGNS  # each wheel's rim speed
        return np.asarray(travel * dt_s / (0.5 * np.asarray(self.wheel_diameters_m)), dtype=float)


KINEMATICS = {"diff_drive": DiffDrive, "tricycle": Tricycle, "mecanum": Mecanum}
"""The kinds of robot by name."""


def kinematics_class(kind: str) -> type:
    """The class of a kind of robot (:data:`KINEMATICS`).

    Raises
    ------
    InputError
        An unknown kind (the known ones named).
    """
    try:
        return KINEMATICS[kind]
    except KeyError:
        raise InputError(f"unknown kinematics {kind!r} (choose from {', '.join(KINEMATICS)})") from None


@dataclass(frozen=True)
class JointSteps:
    """The joints' motion over the consecutive steps of K intervals.

    The arrays are copied and made read-only.

    Parameters
    ----------
    values : array_like
        ``(S, J)`` per step and joint: a rolling joint's increment [rad], a steering joint's
        angle [rad] (its mean over the step).
    start : array_like
        ``(K + 1,)`` offsets: the steps of interval ``k`` are ``start[k]`` to ``start[k + 1] - 1``
        (from 0 to ``S``, at least one step per interval).
    dt_s : array_like, optional
        ``(S,)`` each step's duration [s].

    Raises
    ------
    InputError
        Values that are not a finite ``(S, J)`` array, offsets that do not rise from 0 to ``S``,
        durations of another length or negative.
    """

    values: FloatArray
    start: NDArray[np.intp]
    dt_s: FloatArray | None = None

    def __post_init__(self) -> None:
        try:
            v = np.array(self.values, dtype=float)
            st = np.array(self.start, dtype=np.intp)
        except (TypeError, ValueError):
            raise InputError("`values` and `start` must be arrays of numbers") from None
        if v.ndim != 2 or not np.all(np.isfinite(v)):
            raise InputError(f"`values` must be a finite (steps, joints) array, got shape {v.shape}")
        if st.ndim != 1 or len(st) < 2 or st[0] != 0 or st[-1] != len(v) or np.any(np.diff(st) < 1):
            raise InputError("`start` must rise from 0 to the number of steps, at least one step per interval")
        v.setflags(write=False)
        st.setflags(write=False)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "start", st)
        if self.dt_s is not None:
            dt = np.array(self.dt_s, dtype=float).reshape(-1)
            if dt.shape != (len(v),) or not np.all(np.isfinite(dt)) or np.any(dt < 0):
                raise InputError("`dt_s` must hold a finite duration >= 0 per step")
            dt.setflags(write=False)
            object.__setattr__(self, "dt_s", dt)

    def __len__(self) -> int:
        return len(self.start) - 1

    @property
    def joints(self) -> int:
        """The number of joints (columns)."""
        return int(self.values.shape[1])

    def subset(self, index: ArrayLike) -> JointSteps:
        """The steps of the intervals ``index`` (integer indices, in their order)."""
        idx = np.asarray(index, dtype=np.intp).reshape(-1)
        counts = np.diff(self.start)[idx]
        take = np.repeat(self.start[idx], counts) + (
            np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        )
        dt = None if self.dt_s is None else self.dt_s[take]
        return JointSteps(self.values[take], np.concatenate([[0], np.cumsum(counts)]), dt)

    @classmethod
    def concatenate(cls, parts: list[JointSteps]) -> JointSteps:
        """The steps of several sets of intervals, one after the other."""
        offsets = np.cumsum([0] + [len(p.values) for p in parts[:-1]])
        start = np.concatenate([[0]] + [p.start[1:] + o for p, o in zip(parts, offsets)])
        dts = [p.dt_s for p in parts]
        dt = None if any(d is None for d in dts) else np.concatenate([d for d in dts if d is not None])
        return cls(np.concatenate([p.values for p in parts]), start, dt)

    def motion(self, kinematics: Kinematics, p: ArrayLike | None = None) -> FloatArray:
        """``(K, 3)`` the robot's motion over each interval for a geometry (:func:`compose_steps`)."""
        return compose_steps(twist_displacement(kinematics.twist(self.values, p)), self.start)


@dataclass(frozen=True)
class JointIntervals:
    """The data of a self-calibration of any kind of robot: joint steps and sensor displacements of K intervals.

    Parameters
    ----------
    dt_s : array_like
        ``(K,)`` durations [s].
    steps : JointSteps
        The joints' steps of each interval.
    sensor : array_like
        ``(K, 3)`` the sensor's displacement ``(dx_m, dy_m, dyaw_rad)`` over each interval, in
        its frame at the start (scan matching).
    source : str, optional
        Where they come from, for messages.
    warnings : tuple of str
        What their making noticed.
    covariance : array_like, optional
        ``(K, 3, 3)`` each displacement's covariance as its measurement gives it.

    Raises
    ------
    InputError
        Arrays of the wrong shapes or lengths, values that are not finite, negative durations.
    """

    dt_s: FloatArray
    steps: JointSteps
    sensor: FloatArray
    source: str | None = None
    warnings: tuple[str, ...] = ()
    covariance: FloatArray | None = None

    def __post_init__(self) -> None:
        src = self.source
        dt = np.array(self.dt_s, dtype=float).reshape(-1)
        s = np.array(self.sensor, dtype=float)
        k = len(dt)
        if not isinstance(self.steps, JointSteps) or len(self.steps) != k:
            raise InputError(f"`steps` must be JointSteps of the {k} intervals", src)
        if s.shape != (k, 3) or not np.all(np.isfinite(s)):
            raise InputError(f"`sensor` must be ({k}, 3) finite numbers (dx_m, dy_m, dyaw_rad), got {s.shape}", src)
        if not np.all(np.isfinite(dt)) or np.any(dt < 0):
            raise InputError("`dt_s` must hold finite durations >= 0", src)
        for name, a in (("dt_s", dt), ("sensor", s)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "warnings", tuple(str(w) for w in self.warnings))
        if self.covariance is not None:
            c = np.array(self.covariance, dtype=float)
            if c.shape != (k, 3, 3) or not np.all(np.isfinite(c)):
                raise InputError(f"`covariance` must be ({k}, 3, 3) finite numbers, got {c.shape}", src)
            c = 0.5 * (c + np.swapaxes(c, 1, 2))
            c.setflags(write=False)
            object.__setattr__(self, "covariance", c)

    def __len__(self) -> int:
        return len(self.dt_s)

    def subset(self, index: ArrayLike) -> JointIntervals:
        """The intervals ``index`` (integer indices or a boolean mask), in its order."""
        m = np.asarray(index)
        idx = np.flatnonzero(m) if m.dtype == bool else m.astype(np.intp).reshape(-1)
        cov = None if self.covariance is None else self.covariance[idx]
        return JointIntervals(self.dt_s[idx], self.steps.subset(idx), self.sensor[idx], self.source, self.warnings, cov)

    @classmethod
    def concatenate(cls, parts: list[JointIntervals], source: str | None = None) -> JointIntervals:
        """Several sets of intervals, one after the other (covariances kept when all have them)."""
        covs = [p.covariance for p in parts]
        cov = None if any(c is None for c in covs) else np.concatenate([c for c in covs if c is not None])
        warnings = tuple(w for p in parts for w in p.warnings)
        return cls(
            np.concatenate([p.dt_s for p in parts]),
            JointSteps.concatenate([p.steps for p in parts]),
            np.concatenate([p.sensor for p in parts]),
            source,
            warnings,
            cov,
        )


def joint_intervals_from_motion(
    steps: JointSteps, kinematics: Kinematics, sensor_pose: ArrayLike, source: str | None = None
) -> JointIntervals:
    """The exact (noise-free) intervals of joint steps on a robot of known geometry and sensor pose.

    Parameters
    ----------
    steps : JointSteps
        With durations.
    kinematics : Kinematics
        The true geometry.
    sensor_pose : array_like
        ``(x_m, y_m, yaw_rad)`` on the robot.
    source : str, optional

    Returns
    -------
    JointIntervals
    """
    q = steps.motion(kinematics)
    lp = np.asarray(sensor_pose, dtype=float)
    s = se2.compose(se2.inverse(lp), se2.compose(q, lp))
    dt = np.zeros(len(steps)) if steps.dt_s is None else np.add.reduceat(steps.dt_s, steps.start[:-1])
    return JointIntervals(dt, steps, s, source)
