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

An interval may also carry its **steps** (:class:`IntervalSteps`): the wheel rotations over
consecutive pieces of it (e.g. from one scan to the next inside an interval between two
keyframes). The robot's motion is then the composition of the steps' arcs (:func:`step_motion`),
exact when the wheel speeds change within the interval; with one step per interval it is the
arc above.

Pure numpy: this module imports numpy, :mod:`umbmark.errors` and :mod:`umbmark.model.se2`.
SI units: metres, radians, seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model import se2

__all__ = ["Intervals", "IntervalSteps", "sensor_motion", "step_motion", "intervals_from_motion"]


def _column(name: str, value: ArrayLike, source: str | None) -> NDArray[np.float64]:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"`{name}` must be an array of numbers", source) from None
    if a.ndim != 1:
        raise InputError(f"`{name}` must be one-dimensional (one value per interval), got shape {a.shape}", source)
    return a


@dataclass(frozen=True)
class IntervalSteps:
    """The wheel rotations of the consecutive steps of each interval.

    The arrays are copied (rotations to float, offsets to integers) and made read-only.

    Parameters
    ----------
    left_rad, right_rad : array_like
        ``(S,)`` rotation of each wheel in each step [rad], the steps of all intervals in order.
    start : array_like
        ``(K + 1,)`` offsets: the steps of interval ``k`` are ``start[k]`` to ``start[k + 1] - 1``
        (``start[0] = 0``, ``start[K] = S``, at least one step per interval).
    dt_s : array_like, optional
        ``(S,)`` the duration of each step [s] (``None``: not known; the model does not use
        them, an intervals file writes them).

    Raises
    ------
    InputError
        Arrays of the wrong shape or lengths, values that are not finite, offsets that do not
        start at 0, end at ``S`` and increase.
    """

    left_rad: NDArray[np.float64]
    right_rad: NDArray[np.float64]
    start: NDArray[np.intp]
    dt_s: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        left = _column("left_rad", self.left_rad, None)
        right = _column("right_rad", self.right_rad, None)
        if self.dt_s is not None:
            dt = _column("dt_s", self.dt_s, None)
            if dt.shape != left.shape or not np.all(np.isfinite(dt)) or np.any(dt < 0):
                raise InputError("`dt_s` must hold a finite duration >= 0 per step")
            dt.setflags(write=False)
            object.__setattr__(self, "dt_s", dt)
        try:
            start = np.array(self.start, dtype=np.intp)
        except (TypeError, ValueError):
            raise InputError("`start` must be an array of integers") from None
        if left.shape != right.shape:
            raise InputError(f"`left_rad` has {len(left)} steps, `right_rad` {len(right)}")
        if not (np.all(np.isfinite(left)) and np.all(np.isfinite(right))):
            raise InputError("a step's rotation is not a finite number")
        if start.ndim != 1 or len(start) < 2 or start[0] != 0 or start[-1] != len(left) or np.any(np.diff(start) < 1):
            raise InputError("`start` must rise from 0 to the number of steps, at least one step per interval")
        for name, a in (("left_rad", left), ("right_rad", right), ("start", start)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return len(self.start) - 1

    @property
    def totals(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(left_rad, right_rad)``: the rotation of each wheel over each interval, ``(K,)``."""
        return np.add.reduceat(self.left_rad, self.start[:-1]), np.add.reduceat(self.right_rad, self.start[:-1])

    def subset(self, index: ArrayLike) -> IntervalSteps:
        """The steps of the intervals ``index`` (integer indices, in their order).

        Parameters
        ----------
        index : array_like
            Integer indices of intervals.

        Returns
        -------
        IntervalSteps
        """
        idx = np.asarray(index, dtype=np.intp).reshape(-1)
        counts = np.diff(self.start)[idx]
        take = np.repeat(self.start[idx], counts) + (
            np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        )
        dt = None if self.dt_s is None else self.dt_s[take]
        return IntervalSteps(self.left_rad[take], self.right_rad[take], np.concatenate([[0], np.cumsum(counts)]), dt)

    @classmethod
    def concatenate(cls, parts: list[IntervalSteps]) -> IntervalSteps:
        """The steps of several sets of intervals, one after the other.

        Parameters
        ----------
        parts : list of IntervalSteps

        Returns
        -------
        IntervalSteps
        """
        offsets = np.cumsum([0] + [len(p.left_rad) for p in parts[:-1]])
        start = np.concatenate([[0]] + [p.start[1:] + o for p, o in zip(parts, offsets)])
        dts = [p.dt_s for p in parts]
        dt = None if any(d is None for d in dts) else np.concatenate([d for d in dts if d is not None])
        return cls(np.concatenate([p.left_rad for p in parts]), np.concatenate([p.right_rad for p in parts]), start, dt)

    @classmethod
    def one_each(cls, left_rad: ArrayLike, right_rad: ArrayLike, dt_s: ArrayLike | None = None) -> IntervalSteps:
        """One step per interval (the arc model).

        Parameters
        ----------
        left_rad, right_rad : array_like
            ``(K,)`` the intervals' rotations.
        dt_s : array_like, optional
            ``(K,)`` their durations.

        Returns
        -------
        IntervalSteps
        """
        left = np.asarray(left_rad, dtype=float).reshape(-1)
        dt = None if dt_s is None else np.asarray(dt_s, dtype=float).reshape(-1)
        return cls(left, np.asarray(right_rad, dtype=float).reshape(-1), np.arange(len(left) + 1), dt)


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
    steps : IntervalSteps, optional
        The wheel rotations of each interval's steps (their sums are ``left_rad`` and
        ``right_rad``); ``None``: one arc per interval.
    covariance : array_like, optional
        ``(K, 3, 3)`` the covariance of each sensor displacement as its measurement gives it
        (the scan matcher's), symmetric, not negative definite; a self-calibration adds the
        noise it estimates to it, so a direction a scene leaves unconstrained weighs little.
    end_rates : array_like, optional
        ``(K, 4)`` the wheels' rates at each interval's start and end [rad/s]: ``(left start,
        right start, left end, right end)``, from the wheel data around the two stamps (not
        from the interval's own rotation, which carries the stamps' errors); a
        self-calibration models the errors of the wheel data's stamps with them.

    Raises
    ------
    InputError
        On arrays of different lengths or wrong shapes, a value that is not a finite number,
        a negative duration, steps that are not of these intervals (their number, or sums
        other than the rotations), or covariances of another shape, not finite or not
        symmetric.
    """

    dt_s: NDArray[np.float64]
    left_rad: NDArray[np.float64]
    right_rad: NDArray[np.float64]
    sensor: NDArray[np.float64]
    source: str | None = None
    warnings: tuple[str, ...] = ()
    steps: IntervalSteps | None = None
    covariance: NDArray[np.float64] | None = None
    end_rates: NDArray[np.float64] | None = None

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
        st = self.steps
        if st is not None:
            if not isinstance(st, IntervalSteps):
                raise InputError(f"`steps` must be IntervalSteps, got {type(st).__name__}", src)
            if len(st) != k:
                raise InputError(f"`steps` are of {len(st)} intervals, there are {k}", src)
            tl, tr = st.totals
            scale = 1e-9 * (1.0 + np.abs(cols["left_rad"]) + np.abs(cols["right_rad"]))
            if np.any(np.abs(tl - cols["left_rad"]) > scale) or np.any(np.abs(tr - cols["right_rad"]) > scale):
                raise InputError("the steps' rotations do not add up to the intervals' rotations", src)
            if st.dt_s is not None:
                dt = np.add.reduceat(st.dt_s, st.start[:-1])
                if np.any(np.abs(dt - cols["dt_s"]) > 1e-9 * (1.0 + cols["dt_s"])):
                    raise InputError("the steps' durations do not add up to the intervals' durations", src)
        if self.covariance is not None:
            try:
                cov = np.array(self.covariance, dtype=float)
            except (TypeError, ValueError):
                raise InputError("`covariance` must be an array of numbers", src) from None
            if cov.shape != (k, 3, 3) or not np.all(np.isfinite(cov)):
                raise InputError(f"`covariance` must be ({k}, 3, 3) finite numbers, got shape {cov.shape}", src)
            if not np.allclose(cov, np.swapaxes(cov, 1, 2), rtol=1e-9, atol=1e-15):
                raise InputError("`covariance` must be symmetric", src)
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)
        if self.end_rates is not None:
            try:
                rates = np.array(self.end_rates, dtype=float)
            except (TypeError, ValueError):
                raise InputError("`end_rates` must be an array of numbers", src) from None
            if rates.shape != (k, 4) or not np.all(np.isfinite(rates)):
                raise InputError(f"`end_rates` must be ({k}, 4) finite numbers [rad/s], got shape {rates.shape}", src)
            rates.setflags(write=False)
            object.__setattr__(self, "end_rates", rates)

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
        steps = None
        if self.steps is not None:
            steps = self.steps.subset(np.flatnonzero(m) if m.dtype == bool else m)
        cov = None if self.covariance is None else self.covariance[m]
        rates = None if self.end_rates is None else self.end_rates[m]
        return Intervals(
            self.dt_s[m],
            self.left_rad[m],
            self.right_rad[m],
            self.sensor[m],
            self.source,
            self.warnings,
            steps,
            cov,
            rates,
        )


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

    Examples
    --------
    A lidar 10 cm ahead of the axle on 5 cm wheels, 30 cm apart. Ten radians on both wheels
    carry it half a metre forward; a quarter turn on the spot swings it around the axle's
    midpoint, back and to the side of where it started:

    >>> print(sensor_motion(10.0, 10.0, 0.05, 0.05, 0.3, (0.1, 0.0, 0.0)))
    [0.5 0.  0. ]
    >>> quarter = np.pi * 0.3 / 4 / 0.05  # each wheel's rotation for 90 deg on the spot
    >>> print(np.round(sensor_motion(-quarter, quarter, 0.05, 0.05, 0.3, (0.1, 0.0, 0.0)), 4))
    [-0.1     0.1     1.5708]
    """
    q = se2.arc(r_left_m * np.asarray(left_rad, float), r_right_m * np.asarray(right_rad, float), wheelbase_m)
    lp = np.asarray(sensor_pose, dtype=float)
    return se2.compose(se2.inverse(lp), se2.compose(q, lp))


def step_motion(
    steps: IntervalSteps, r_left_m: float, r_right_m: float, wheelbase_m: float, derivatives: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """The robot's motion over each interval: the arcs of its steps composed.

    Parameters
    ----------
    steps : IntervalSteps
        The steps of ``K`` intervals.
    r_left_m, r_right_m : float
        Wheel radii [m].
    wheelbase_m : float
        Wheelbase b [m].
    derivatives : bool
        Also return the derivatives by the radii and the wheelbase.

    Returns
    -------
    q : numpy.ndarray
        ``(K, 3)``: ``(x_m, y_m, yaw_rad)`` of the robot at each interval's end in its frame at
        the start (yaw the heading change, not wrapped).
    dq : numpy.ndarray or None
        ``(K, 3, 3)``: ``d q_k[i] / d (r_L, r_R, b)[j]``, or None.
    """
    fl, fr, start = steps.left_rad, steps.right_rad, steps.start
    first = start[:-1]
    seg = np.repeat(np.arange(len(first)), np.diff(start))
    ds = 0.5 * (r_left_m * fl + r_right_m * fr)
    dth = (r_right_m * fr - r_left_m * fl) / wheelbase_m
    half = 0.5 * dth
    k = se2.sinc(half)
    ch, sh = np.cos(half), np.sin(half)
    lx, ly = ds * k * ch, ds * k * sh  # each step's own displacement
    cum = np.cumsum(dth)
    phi = cum - dth  # heading before each step, from the first step
    phi = phi - phi[first][seg]  # ... from its interval's start
    c, s = np.cos(phi), np.sin(phi)
    gx, gy = c * lx - s * ly, s * lx + c * ly
    q = np.column_stack([np.add.reduceat(gx, first), np.add.reduceat(gy, first), np.add.reduceat(dth, first)])
    if not derivatives:
        return q, None
    # a step's displacement by its travel and its turn, rotated into the interval's frame
    dk = se2.dsinc(half)
    ddx_ds, ddy_ds = c * k * ch - s * k * sh, s * k * ch + c * k * sh
    ex, ey = 0.5 * ds * (dk * ch - k * sh), 0.5 * ds * (dk * sh + k * ch)
    ddx_dth, ddy_dth = c * ex - s * ey, s * ex + c * ey
    # a turn also turns every later step of the interval: + J (q_end - position after the step)
    px = np.cumsum(gx) - (np.cumsum(gx) - gx)[first][seg]
    py = np.cumsum(gy) - (np.cumsum(gy) - gy)[first][seg]
    ddx_dth = ddx_dth - (q[seg, 1] - py)
    ddy_dth = ddy_dth + (q[seg, 0] - px)
    dds = (0.5 * fl, 0.5 * fr, np.zeros_like(fl))
    ddth = (-fl / wheelbase_m, fr / wheelbase_m, -dth / wheelbase_m)
    dq = np.empty((len(first), 3, 3))
    for j in range(3):
        dq[:, 0, j] = np.add.reduceat(ddx_ds * dds[j] + ddx_dth * ddth[j], first)
        dq[:, 1, j] = np.add.reduceat(ddy_ds * dds[j] + ddy_dth * ddth[j], first)
        dq[:, 2, j] = np.add.reduceat(ddth[j], first)
    return q, dq


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

    Examples
    --------
    Two half-second intervals of the robot above: straight, then the right wheel 2 rad ahead:

    >>> iv = intervals_from_motion([10.0, 10.0], [10.0, 12.0], 0.5, 0.05, 0.05, 0.3, (0.1, 0.0, 0.0))
    >>> print(np.round(iv.sensor, 4))
    [[0.5    0.     0.    ]
     [0.5344 0.1235 0.3333]]
    """
    left = np.asarray(left_rad, dtype=float)
    right = np.asarray(right_rad, dtype=float)
    dt = np.broadcast_to(np.asarray(dt_s, dtype=float), left.shape)
    s = sensor_motion(left, right, r_left_m, r_right_m, wheelbase_m, sensor_pose)
    return Intervals(dt, left, right, s, source)
