"""Wheeled-robot kinematics: what the joints' motion makes the robot do, for any kind of robot.

Pure numpy: this module imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.model.se2`.
SI units; the robot frame: x forward, y to the left, angles counter-clockwise positive.

A robot's joints are read as **steps** (:class:`JointSteps`): in each step every rolling joint
turns by an increment [rad] and every steering joint holds an angle [rad] (its mean over the
step). Within a step the joints' rates are constant, so the robot moves at a constant twist
``(v_x, v_y, omega)`` and its displacement is the exact SE(2) exponential of the integrated
twist (:func:`twist_displacement`); the steps of an interval compose into its motion
(:func:`compose_steps`).

Every kind of robot offers one interface, :class:`Kinematics`: its forward kinematics (the
twist of a step of its joints, as its ros2 controller computes it) and their inverse (the joint
steps a controller of that geometry commands for a twist: the simulator drives with the nominal
geometry's). The kinds themselves, each in a module of its own, are in :mod:`umbmark.kinds`
(the differential drive, the tricycle, the mecanum robot).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2

__all__ = [
    "Kinematics",
    "JointSteps",
    "twist_displacement",
    "compose_steps",
    "integrate_steps",
    "JointIntervals",
    "joint_intervals_from_motion",
]

FloatArray = NDArray[np.float64]


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


class Kinematics(Protocol):
    """What every kind of robot's geometry offers (the kinds are in :mod:`umbmark.kinds`).

    Attributes
    ----------
    kind : str
        The kind's name (:data:`umbmark.kinds.KINDS`).
    joint_roles : tuple of str
        The joints, in the order of a step's values.
    rolling : tuple of bool
        Per joint: a rolling joint (its steps are increments) or a steering one (angles).
    parameter_names : tuple of str
        The geometry's parameters (SI), in the order of :meth:`vector`.
    moves : tuple of str
        The moves the simulator draws for it (:data:`umbmark.model.kinematic_drive.MOVES`).
    """

    kind: ClassVar[str]
    joint_roles: ClassVar[tuple[str, ...]]
    rolling: ClassVar[tuple[bool, ...]]
    parameter_names: ClassVar[tuple[str, ...]]
    moves: ClassVar[tuple[str, ...]]

    def vector(self) -> FloatArray:
        """The parameters as a vector, in :attr:`parameter_names` order (SI)."""
        ...

    def with_vector(self, p: ArrayLike) -> Kinematics:
        """The same kind with the parameters ``p``."""
        ...

    def rolling_diameters_m(self) -> FloatArray:
        """The diameters of the rolling joints' wheels [m], in their order."""
        ...

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        """``(S, 3)`` the integrated twist of each step of joint values ``(S, J)`` (parameters ``p``
        or the robot's own)."""
        ...

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        """``(S, J)`` the joint steps this geometry commands for twists held ``dt_s`` each."""
        ...


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
