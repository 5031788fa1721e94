"""The data of a lidar self-calibration: wheel rotations and sensor displacements per interval.

A self-calibration (Censi, Franchi, Marchionni, Oriolo, "Simultaneous calibration of odometry
and sensor parameters for mobile robots", IEEE T-RO 29(2), 2013) cuts a drive into intervals
``k`` (e.g. from one lidar scan to the next). For each it knows the duration ``dt_k``, the
rotation of each wheel ``phi_L,k``, ``phi_R,k`` [rad] (the total change of the wheel angle over
the interval, positive rolling forward) and the sensor's own displacement
``s_k = (dx, dy, dyaw)``: the sensor pose at the end of the interval expressed in the sensor
frame at its start (from scan matching).

The model: at constant wheel speeds within an interval the robot moves along the exact arc
``q_k = arc(r_L phi_L,k, r_R phi_R,k, b)`` (:func:`umbmark.model.se2.arc`), and a sensor
mounted at the pose ``l = (l_x, l_y, l_yaw)`` on the robot sees ``s_k = l^-1 (+) q_k (+) l``.
:func:`sensor_motion` is that model, :func:`intervals_from_motion` the exact intervals it
gives (the noise-free truth of tests and simulations).

Pure numpy: this module imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.model.se2`.
SI units: metres, radians, seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2

__all__ = ["Intervals", "sensor_motion", "intervals_from_motion"]


def _column(name: str, value: ArrayLike, source: str | None) -> NDArray[np.float64]:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"`{name}` must be an array of numbers", source) from None
    if a.ndim != 1:
        raise InputError(f"`{name}` must be one-dimensional (one value per interval), got shape {a.shape}", source)
    return a


@dataclass(frozen=True)
class Intervals:
    """Wheel rotations and sensor displacements of K intervals (see the module docstring).

    The arrays are copied to float and made read-only.

    Parameters
    ----------
    dt_s : array_like
        Duration of each interval [s], shape (K,), not negative.
    left_rad, right_rad : array_like
        Rotation of the left and right wheel over each interval [rad], shape (K,) (positive:
        rolling forward).
    sensor : array_like
        The sensor's displacement over each interval ``(dx_m, dy_m, dyaw_rad)`` in its own
        frame at the start of the interval, shape (K, 3).
    source : str, optional
        Where the intervals come from (a file name), for messages.
    warnings : tuple of str
        Things a reader noticed that do not stop a calibration but deserve a look (e.g.
        intervals of zero duration); a calibration reports them with its own.

    Raises
    ------
    InputError
        On arrays of different lengths or wrong shapes, a value that is not a finite number,
        or a negative duration.
    """

    dt_s: NDArray[np.float64]
    left_rad: NDArray[np.float64]
    right_rad: NDArray[np.float64]
    sensor: NDArray[np.float64]
    source: str | None = None
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        src = self.source
        object.__setattr__(self, "warnings", tuple(str(w) for w in self.warnings))
        cols = {name: _column(name, getattr(self, name), src) for name in ("dt_s", "left_rad", "right_rad")}
        k = len(cols["dt_s"])
        try:
            sensor = np.array(self.sensor, dtype=float)
        except (TypeError, ValueError):
            raise InputError("`sensor` must be an array of numbers", src) from None
        if sensor.ndim == 1 and sensor.size == 0:
            sensor = sensor.reshape(0, 3)
        if sensor.ndim != 2 or sensor.shape[1] != 3:
            raise InputError(f"`sensor` must have shape (K, 3) (dx_m, dy_m, dyaw_rad), got {sensor.shape}", src)
        cols["sensor"] = sensor
        for name, a in cols.items():
            if len(a) != k:
                raise InputError(f"`{name}` has {len(a)} intervals, `dt_s` has {k}", src)
            if not np.all(np.isfinite(a)):
                i = int(np.flatnonzero(~np.isfinite(a).reshape(len(a), -1).all(axis=1))[0])
                raise InputError(f"`{name}` of interval {i} is not a finite number", src)
        neg = np.flatnonzero(cols["dt_s"] < 0)
        if neg.size:
            raise InputError(f"`dt_s` of interval {int(neg[0])} is negative ({cols['dt_s'][neg[0]]:g} s)", src)
        for name, a in cols.items():
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return len(self.dt_s)

    def subset(self, mask: ArrayLike) -> Intervals:
        """The intervals selected by a boolean mask or an index array.

        Parameters
        ----------
        mask : array_like
            Booleans, shape (K,), or integer indices.

        Returns
        -------
        Intervals
            The selected intervals, in the order of ``mask``, with the same ``source`` and
            ``warnings``.

        Raises
        ------
        InputError
            If a boolean mask does not have one value per interval.
        """
        m = np.asarray(mask)
        if m.dtype == bool and m.shape != (len(self),):
            raise InputError(f"a mask of {m.shape} for {len(self)} intervals", self.source)
        return Intervals(self.dt_s[m], self.left_rad[m], self.right_rad[m], self.sensor[m], self.source, self.warnings)


def sensor_motion(
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    r_left_m: float,
    r_right_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike,
) -> NDArray[np.float64]:
    """The model's sensor displacements ``l^-1 (+) arc(r_L phi_L, r_R phi_R, b) (+) l``.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], broadcast together.
    r_left_m, r_right_m : float
        Wheel radii [m].
    wheelbase_m : float
        Wheelbase b [m].
    sensor_pose : array_like
        The sensor's pose on the robot ``(x_m, y_m, yaw_rad)`` (robot frame: x forward, y left).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(left_rad, right_rad).shape + (3,)``: ``(dx_m, dy_m, dyaw_rad)`` in
        the sensor frame at the start of each interval; ``dyaw`` wrapped into (-pi, pi].
    """
    q = se2.arc(r_left_m * np.asarray(left_rad, float), r_right_m * np.asarray(right_rad, float), wheelbase_m)
    lp = np.asarray(sensor_pose, dtype=float)
    return se2.compose(se2.inverse(lp), se2.compose(q, lp))


def intervals_from_motion(
    left_rad: ArrayLike,
    right_rad: ArrayLike,
    dt_s: ArrayLike,
    r_left_m: float,
    r_right_m: float,
    wheelbase_m: float,
    sensor_pose: ArrayLike,
    source: str | None = None,
) -> Intervals:
    """The exact (noise-free) intervals of given wheel rotations on a robot of known geometry.

    Parameters
    ----------
    left_rad, right_rad : array_like
        Wheel rotations per interval [rad], shape (K,).
    dt_s : array_like
        Durations [s], shape (K,) or a scalar for all.
    r_left_m, r_right_m : float
        True wheel radii [m].
    wheelbase_m : float
        True wheelbase [m].
    sensor_pose : array_like
        True sensor pose on the robot ``(x_m, y_m, yaw_rad)``.
    source : str, optional
        A name for messages.

    Returns
    -------
    Intervals
        The rotations as given and the sensor displacements of :func:`sensor_motion`.

    Raises
    ------
    InputError
        On inputs :class:`Intervals` refuses (lengths, non-finite values, negative durations).
    """
    left = np.asarray(left_rad, dtype=float)
    right = np.asarray(right_rad, dtype=float)
    dt = np.broadcast_to(np.asarray(dt_s, dtype=float), left.shape)
    s = sensor_motion(left, right, r_left_m, r_right_m, wheelbase_m, sensor_pose)
    return Intervals(dt, left, right, s, source)
