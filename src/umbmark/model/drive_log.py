"""What a simulated drive is made of and what it records: commands and programs
(:class:`Command`, :class:`Program`), the wheels integrated into poses (:func:`integrate_wheels`),
and the record of a drive (:class:`DriveLog`: wheel angles, true poses, lidar scans).

The simulation itself is :mod:`umbmark.model.drive` (which re-exports these names). Pure numpy:
imports only numpy and the lower modules of :mod:`umbmark.model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model.geometry import WheelGeometry
from umbmark.model.intervals import Intervals
from umbmark.model.se2 import Pose, arc, between, compose
from umbmark.model.sensors import Lidar, Room, SensorPose

__all__ = ["Command", "Program", "integrate_wheels", "DriveLog"]


@dataclass(frozen=True)
class Command:
    """Drive at a constant commanded speed and turn rate for a time.

    Parameters
    ----------
    duration_s : float
        How long [s] (positive).
    v_mps : float
        Commanded forward speed [m/s] (negative: backwards).
    omega_radps : float
        Commanded turn rate [rad/s] (positive: counter-clockwise).

    Raises
    ------
    InputError
        If the duration is not positive or a field is not finite.
    """

    duration_s: float
    v_mps: float = 0.0
    omega_radps: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise InputError(f"`duration_s` of a command must be positive, got {self.duration_s!r}")
        for name in ("v_mps", "omega_radps"):
            if not math.isfinite(getattr(self, name)):
                raise InputError(f"`{name}` of a command must be finite, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class Program:
    """A sequence of commands and, optionally, the pose it was planned to start from.

    Parameters
    ----------
    commands : tuple of Command
        Driven in order.
    start_pose : tuple of float, optional
        ``(x_m, y_m, yaw_rad)`` in the room the program was planned for; ``None``: any start.
    """

    commands: tuple[Command, ...]
    start_pose: Pose | None = None

    @property
    def duration_s(self) -> float:
        """The sum of the commands' durations [s]."""
        return float(sum(c.duration_s for c in self.commands))


def integrate_wheels(
    d_left_m: ArrayLike, d_right_m: ArrayLike, wheelbase_m: float, start_pose: ArrayLike = (0.0, 0.0, 0.0)
) -> NDArray[np.float64]:
    """The poses of a robot whose wheels roll ``d_left_m``, ``d_right_m`` at constant speed in each sample.

    Each sample is the exact arc :func:`umbmark.model.se2.arc`; the poses are the arcs composed
    from ``start_pose`` (the heading accumulated, not wrapped).

    Parameters
    ----------
    d_left_m, d_right_m : array_like
        ``(K,)`` ground travel of each wheel per sample [m].
    wheelbase_m : float
        The wheelbase [m].
    start_pose : array_like
        ``(x, y, yaw)`` before the first sample.

    Returns
    -------
    numpy.ndarray
        ``(K + 1, 3)`` poses ``[x, y, yaw]``: the start and the pose after each sample.

    Raises
    ------
    InputError
        If the shapes differ or the start pose is not three numbers.
    """
    dl = np.asarray(d_left_m, dtype=float).reshape(-1)
    dr = np.asarray(d_right_m, dtype=float).reshape(-1)
    if dl.shape != dr.shape:
        raise InputError(f"`d_left_m` and `d_right_m` differ in shape: {dl.shape} vs {dr.shape}")
    p0 = np.asarray(start_pose, dtype=float).reshape(-1)
    if p0.shape != (3,):
        raise InputError(f"`start_pose` must be three numbers (x, y, yaw), got {p0.size}")
    local = arc(dl, dr, wheelbase_m)
    th = p0[2] + np.concatenate([[0.0], np.cumsum(local[:, 2])])
    c, s = np.cos(th[:-1]), np.sin(th[:-1])
    gx = c * local[:, 0] - s * local[:, 1]
    gy = s * local[:, 0] + c * local[:, 1]
    out = np.empty((len(dl) + 1, 3))
    out[:, 0] = p0[0] + np.concatenate([[0.0], np.cumsum(gx)])
    out[:, 1] = p0[1] + np.concatenate([[0.0], np.cumsum(gy)])
    out[:, 2] = th
    return out


def _sample_of(t: np.ndarray, rate_hz: float, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The sample interval ``k`` each time falls in, and the fraction of the way through it."""
    end = (n_samples - 1) / rate_hz
    if t.size and not (np.all(t >= -1e-9) and np.all(t <= end + 1e-9)):
        raise InputError(f"times must be within the drive, 0 to {end:g} s")
    u = t * rate_hz
    k = np.clip(np.floor(u + 1e-9).astype(np.int64), 0, n_samples - 2)
    return k, np.clip(u - k, 0.0, 1.0)


def _pose_along(
    pose: np.ndarray, d_left_m: ArrayLike, d_right_m: ArrayLike, wheelbase_m: ArrayLike
) -> NDArray[np.float64]:
    """The poses reached from ``pose`` (heading accumulated) by the arcs of the given wheel travel."""
    local = arc(d_left_m, d_right_m, wheelbase_m)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    out = np.empty(np.broadcast_shapes(pose.shape, local.shape))
    out[..., 0] = pose[..., 0] + c * local[..., 0] - s * local[..., 1]
    out[..., 1] = pose[..., 1] + s * local[..., 0] + c * local[..., 1]
    out[..., 2] = pose[..., 2] + local[..., 2]
    return out


@dataclass(frozen=True, eq=False)
class DriveLog:
    """What a simulated drive records: wheel angles, true poses and lidar scans.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(K,)`` wheel sample times [s], from 0 at ``1 / wheel_rate_hz`` steps.
    left_rad, right_rad : numpy.ndarray
        ``(K,)`` cumulative wheel angles as the encoders report them [rad] (0 at the start).
    true_pose : numpy.ndarray
        ``(K, 3)`` true robot poses ``[x, y, yaw]`` in the room at ``t_s`` (yaw accumulated,
        not wrapped).
    travel_left_m, travel_right_m : numpy.ndarray
        ``(K - 1,)`` true ground travel of each wheel in each sample [m].
    scan_t_s : numpy.ndarray
        ``(M,)`` scan times [s].
    scan_pose : numpy.ndarray
        ``(M, 3)`` true robot poses at the scan times.
    ranges_m : numpy.ndarray
        ``(M, n_beams)`` scans [m], ``inf`` for no return.
    angles_rad : numpy.ndarray
        ``(n_beams,)`` beam directions in the sensor frame.
    lidar : Lidar
        The lidar.
    sensor_pose : SensorPose
        Where it sits on the robot.
    nominal_geometry, true_geometry : WheelGeometry
        The nominal and the true wheels and wheelbase.
    room : Room
        The walls the scans see.
    wheel_rate_hz, scan_rate_hz : float
        Sampling rates.
    commands : tuple of Command
        The program driven.
    seed : int, optional
        The seed of the noise (``None``: noise free).
    scan_stamp_s : numpy.ndarray, optional
        ``(M,)`` the stamps the scans carry [s] when they differ from the times they were
        taken (:meth:`stamped`: a lidar driver stamping on arrival, late and jittered);
        ``None``: stamped when taken.
    """

    t_s: np.ndarray
    left_rad: np.ndarray
    right_rad: np.ndarray
    true_pose: np.ndarray
    travel_left_m: np.ndarray
    travel_right_m: np.ndarray
    scan_t_s: np.ndarray
    scan_pose: np.ndarray
    ranges_m: np.ndarray
    angles_rad: np.ndarray
    lidar: Lidar
    sensor_pose: SensorPose
    nominal_geometry: WheelGeometry
    true_geometry: WheelGeometry
    room: Room
    wheel_rate_hz: float
    scan_rate_hz: float
    commands: tuple[Command, ...] = ()
    seed: int | None = None
    scan_stamp_s: np.ndarray | None = None

    @property
    def scan_stamps_s(self) -> NDArray[np.float64]:
        """``(M,)`` the stamps the scans carry [s] (:attr:`scan_stamp_s`, else the times taken)."""
        return np.asarray(self.scan_t_s if self.scan_stamp_s is None else self.scan_stamp_s, dtype=float)

    def stamped(self, delay_s: float = 0.0, jitter_s: float = 0.0, seed: int | None = None) -> DriveLog:
        """The drive with its scans stamped late and with jitter, as a driver that stamps a scan on
        arrival does: ``stamp = taken + delay_s + N(0, jitter_s^2)``, kept in order.

        Parameters
        ----------
        delay_s : float
            The mean delay of the stamps [s].
        jitter_s : float
            The standard deviation of the stamps about it [s].
        seed : int, optional
            The seed of the jitter.

        Returns
        -------
        DriveLog
            The same drive (scans, wheels, truth); only :attr:`scan_stamp_s` differs.

        Raises
        ------
        InputError
            A delay or jitter that is not finite, or a negative jitter.
        """
        if not (math.isfinite(delay_s) and math.isfinite(jitter_s) and jitter_s >= 0):
            raise InputError(f"`delay_s` must be finite and `jitter_s` >= 0, got {delay_s!r}, {jitter_s!r}")
        t = np.asarray(self.scan_t_s, dtype=float) + delay_s
        if jitter_s > 0:
            t = np.sort(t + np.random.default_rng(seed).normal(0.0, jitter_s, t.shape))
        return replace(self, scan_stamp_s=t)

    @property
    def duration_s(self) -> float:
        """The time of the last wheel sample [s]."""
        return float(self.t_s[-1])

    @property
    def sensor_world_pose(self) -> NDArray[np.float64]:
        """``(M, 3)`` true sensor poses in the room at the scan times (heading wrapped)."""
        return compose(self.scan_pose, self.sensor_pose.as_array())

    def true_pose_at(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """The exact true robot pose at any times within the drive.

        Within a sample the wheels turn at constant speed: the pose is the arc of the sample's
        true ground travel, a fraction of the way along.

        Parameters
        ----------
        t_s : array_like
            Times [s] in ``[0, duration_s]``.

        Returns
        -------
        numpy.ndarray
            ``shape(t_s) + (3,)`` poses ``[x, y, yaw]`` (yaw accumulated, not wrapped).

        Raises
        ------
        InputError
            If a time is outside the drive.
        """
        t = np.asarray(t_s, dtype=float)
        k, f = _sample_of(t, self.wheel_rate_hz, len(self.t_s))
        return _pose_along(
            self.true_pose[k], f * self.travel_left_m[k], f * self.travel_right_m[k], self.true_geometry.wheelbase_m
        )

    def wheel_angles_at(self, t_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The reported wheel angles at any times within the drive (linear within a sample).

        Parameters
        ----------
        t_s : array_like
            Times [s] in ``[0, duration_s]``.

        Returns
        -------
        tuple of numpy.ndarray
            ``(left_rad, right_rad)``, each of ``shape(t_s)``.

        Raises
        ------
        InputError
            If a time is outside the drive.
        """
        t = np.asarray(t_s, dtype=float)
        k, f = _sample_of(t, self.wheel_rate_hz, len(self.t_s))
        left = self.left_rad[k] + f * (self.left_rad[k + 1] - self.left_rad[k])
        right = self.right_rad[k] + f * (self.right_rad[k + 1] - self.right_rad[k])
        return left, right

    def sensor_motion(self) -> NDArray[np.float64]:
        """The true motion of the sensor between consecutive scans, in the sensor frame.

        Returns
        -------
        numpy.ndarray
            ``(M - 1, 3)`` ``[dx_m, dy_m, dyaw_rad]``: scan ``m + 1``'s sensor pose expressed in
            scan ``m``'s (what a perfect scan matcher returns), heading wrapped.
        """
        w = self.sensor_world_pose
        return between(w[:-1], w[1:])

    def scan_intervals(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The intervals between consecutive scans: durations, wheel rotations and true sensor motion.

        Returns
        -------
        tuple of numpy.ndarray
            ``(dt_s, left_rad, right_rad, sensor)``: ``(M - 1,)`` durations [s], ``(M - 1,)``
            reported wheel rotations [rad] over each interval, and ``(M - 1, 3)``
            :meth:`sensor_motion`.
        """
        left, right = self.wheel_angles_at(self.scan_t_s)
        return np.diff(self.scan_t_s), np.diff(left), np.diff(right), self.sensor_motion()

    def intervals(self) -> Intervals:
        """The scan intervals with the TRUE sensor motion: what a perfect scan matcher gives a self-calibration.

        Returns
        -------
        Intervals
            :meth:`scan_intervals` as :class:`umbmark.model.intervals.Intervals` (source
            ``"simulated drive"``).
        """
        dt, left, right, sensor = self.scan_intervals()
        return Intervals(dt, left, right, sensor, source="simulated drive")

    def odometry(self, wheels: WheelGeometry | None = None) -> NDArray[np.float64]:
        """The odometry of the reported wheel angles (exact arcs), from ``(0, 0, 0)`` at the start.

        Parameters
        ----------
        wheels : WheelGeometry, optional
            The geometry to compute with; default the nominal one.

        Returns
        -------
        numpy.ndarray
            ``(K, 3)`` poses ``[x, y, yaw]`` in the odometry frame at ``t_s`` (yaw accumulated).
        """
        g = self.nominal_geometry if wheels is None else wheels
        return integrate_wheels(
            0.5 * g.diameter_left_m * np.diff(self.left_rad),
            0.5 * g.diameter_right_m * np.diff(self.right_rad),
            g.wheelbase_m,
        )
