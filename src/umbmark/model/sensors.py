"""A simulated 2D lidar in a room of walls: the sensor model behind the lidar self-calibration.

Pure numpy (and numba, when installed, for the ray caster): this module imports only numpy and
:mod:`umbmark.errors`. SI units (metres, radians), angles counter-clockwise positive.

* :class:`Room`: wall segments ``(N, 4)`` ``[x1, y1, x2, y2]`` in the world frame, with an
  optional outline (the closed polygon of the outer walls) telling inside from outside.
  :meth:`Room.rectangle` and :meth:`Room.default` (about 10 x 8 m, not symmetric: a cut corner,
  two stub walls, two pillars and a rotated box, so that a scan fixes x, y and yaw everywhere).
* :class:`SensorPose`: where the sensor sits on the robot (robot frame: x forward, y left).
* :class:`Lidar`: beams, field of view, range limits, Gaussian range noise and dropouts;
  :meth:`Lidar.scan` simulates the scans of many sensor poses at once.
* :class:`Gyro`: a yaw-rate gyro (scale factor, bias, white noise): :meth:`Gyro.measure` turns
  true headings at its sample times into its readings.
* :func:`cast_rays`: the exact ranges of rays from many sensor poses (beams x segments, over
  poses in chunks of bounded memory); ``inf`` where a ray hits nothing within range.

A scan is instantaneous: every beam of it is cast from the same sensor pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from umbmark._numba import ENGINES, check_engine, numba_module
from umbmark.errors import InputError

__all__ = [
    "ENGINES",
    "Room",
    "SensorPose",
    "Lidar",
    "Gyro",
    "cast_rays",
    "have_numba",
]

_CHUNK_ELEMENTS = 1 << 21  # rays x segments handled at once by the numpy engine (bounds its memory)
_U_TOL = 1e-12  # a ray meeting a segment this close (in segment lengths) beyond an end still hits it
_T_MIN = 1e-12  # hits closer than this [m] are the ray's own origin, not a return


_kernel: Any = None


def have_numba() -> bool:
    """Whether numba is installed (the ``"numba"`` engine of :func:`cast_rays` is available).

    Returns
    -------
    bool
    """
    return numba_module() is not None


# ---------------------------------------------------------------- geometry of the room
def _as_segments(segments: ArrayLike, name: str = "segments") -> np.ndarray:
    s = np.array(segments, dtype=float)
    if s.ndim != 2 or s.shape[1] != 4 or s.shape[0] < 1:
        raise InputError(f"`{name}` must have shape (N, 4) [x1, y1, x2, y2] with N >= 1, got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise InputError(f"`{name}` must be finite")
    if np.any(np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) <= 0.0):
        raise InputError(f"`{name}` has a segment of zero length")
    return s


def _polygon_segments(vertices: ArrayLike) -> np.ndarray:
    v = np.asarray(vertices, dtype=float)
    return np.column_stack([v, np.roll(v, -1, axis=0)])


def _box(cx: float, cy: float, length: float, width: float, yaw: float = 0.0) -> np.ndarray:
    """The four corners (counter-clockwise) of a ``length`` x ``width`` box centred at (cx, cy)."""
    c, s = math.cos(yaw), math.sin(yaw)
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float) * [length / 2, width / 2]
    return np.column_stack([cx + c * half[:, 0] - s * half[:, 1], cy + s * half[:, 0] + c * half[:, 1]])


@dataclass(frozen=True, eq=False)
class Room:
    """Wall segments in the world frame, and optionally the outline of the outer walls.

    Parameters
    ----------
    segments : array_like
        ``(N, 4)`` walls ``[x1, y1, x2, y2]`` [m]; a wall is seen from both sides.
    outline : array_like, optional
        ``(P, 2)`` vertices of the closed polygon of the outer walls (for :meth:`contains`);
        ``None``: the bounding box of the segments.

    Raises
    ------
    InputError
        If ``segments`` is not a finite ``(N, 4)`` array of segments of non-zero length, or the
        outline has fewer than three finite vertices.
    """

    segments: np.ndarray
    outline: np.ndarray | None = None

    def __post_init__(self) -> None:
        s = _as_segments(self.segments)
        s.flags.writeable = False
        object.__setattr__(self, "segments", s)
        if self.outline is not None:
            o = np.array(self.outline, dtype=float)
            if o.ndim != 2 or o.shape[1] != 2 or o.shape[0] < 3 or not np.all(np.isfinite(o)):
                raise InputError(f"`outline` must be (P, 2) finite vertices with P >= 3, got shape {o.shape}")
            o.flags.writeable = False
            object.__setattr__(self, "outline", o)

    @classmethod
    def rectangle(cls, width_m: float, height_m: float, x0_m: float = 0.0, y0_m: float = 0.0) -> Room:
        """An empty rectangular room ``[x0, x0 + width] x [y0, y0 + height]``.

        Parameters
        ----------
        width_m, height_m : float
            Its size along x and y [m].
        x0_m, y0_m : float
            Its lower-left corner [m].

        Returns
        -------
        Room

        Raises
        ------
        InputError
            If a side is not a positive finite number.
        """
        for name, v in (("width_m", width_m), ("height_m", height_m)):
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"`{name}` must be a positive number, got {v!r}")
        corners = np.array(
            [[x0_m, y0_m], [x0_m + width_m, y0_m], [x0_m + width_m, y0_m + height_m], [x0_m, y0_m + height_m]]
        )
        return cls(_polygon_segments(corners), corners)

    @classmethod
    def default(cls) -> Room:
        """The test room: about 10 x 8 m, ``[0, 10] x [0, 8]`` with the corner at (10, 8) cut off.

        Inside: a stub wall from the left wall at y = 2.6 m, one from the top wall at x = 4.6 m,
        a 0.4 m pillar at (2.6, 5.6), a 0.3 m pillar at (7.4, 5.0) and a 1.0 x 0.6 m box turned
        by 25 degrees at (7.2, 1.8). No symmetry maps the room onto itself, and walls of several
        directions are in view from everywhere, so a scan fixes x, y and yaw. The open middle
        (around (5, 4)) is at least 1.5 m from every wall.

        Returns
        -------
        Room
        """
        outline = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 6.4], [8.4, 8.0], [0.0, 8.0]])
        parts = [
            _polygon_segments(outline),
            np.array([[0.0, 2.6, 1.6, 2.6], [4.6, 8.0, 4.6, 6.9]]),
            _polygon_segments(_box(2.6, 5.6, 0.4, 0.4)),
            _polygon_segments(_box(7.4, 5.0, 0.3, 0.3)),
            _polygon_segments(_box(7.2, 1.8, 1.0, 0.6, math.radians(25.0))),
        ]
        return cls(np.vstack(parts), outline)

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the walls [m]."""
        s = self.segments
        xs, ys = s[:, [0, 2]], s[:, [1, 3]]
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    def distance_to_walls(self, points: ArrayLike) -> np.ndarray:
        """The distance of each point to the nearest wall.

        Parameters
        ----------
        points : array_like
            ``(..., 2)`` points ``[x, y]`` [m].

        Returns
        -------
        numpy.ndarray
            ``(...)`` distances [m].

        Raises
        ------
        InputError
            If the last axis of ``points`` is not of length 2.
        """
        p = np.asarray(points, dtype=float)
        if p.ndim < 1 or p.shape[-1] != 2:
            raise InputError(f"`points` must have shape (..., 2), got {p.shape}")
        flat = p.reshape(-1, 2)
        s = self.segments
        a, e = s[:, :2], s[:, 2:] - s[:, :2]
        ee = np.einsum("ij,ij->i", e, e)
        out = np.empty(len(flat))
        step = max(1, _CHUNK_ELEMENTS // len(s))
        for i in range(0, len(flat), step):
            q = flat[i : i + step, None, :] - a[None]  # (C, N, 2)
            u = np.clip(np.einsum("cnj,nj->cn", q, e) / ee, 0.0, 1.0)
            d = q - u[..., None] * e[None]
            out[i : i + step] = np.sqrt(np.min(np.einsum("cnj,cnj->cn", d, d), axis=1))
        return out.reshape(p.shape[:-1])

    def contains(self, points: ArrayLike) -> np.ndarray:
        """Whether each point is inside the outline (or the bounding box when there is none).

        Parameters
        ----------
        points : array_like
            ``(..., 2)`` points ``[x, y]`` [m].

        Returns
        -------
        numpy.ndarray of bool
            ``(...)``; points on the outline count as inside or outside by rounding.

        Raises
        ------
        InputError
            If the last axis of ``points`` is not of length 2.
        """
        p = np.asarray(points, dtype=float)
        if p.ndim < 1 or p.shape[-1] != 2:
            raise InputError(f"`points` must have shape (..., 2), got {p.shape}")
        x, y = p[..., 0], p[..., 1]
        if self.outline is None:
            x0, y0, x1, y1 = self.bounds
            return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        v = self.outline
        inside = np.zeros(x.shape, dtype=bool)
        for (xa, ya), (xb, yb) in zip(v, np.roll(v, -1, axis=0)):
            crosses = (ya > y) != (yb > y)  # the edge spans the point's y: a horizontal ray may cross it
            with np.errstate(divide="ignore", invalid="ignore"):
                x_cross = xa + (y - ya) * (xb - xa) / (yb - ya)
            inside ^= crosses & (x < x_cross)
        return inside


@dataclass(frozen=True)
class SensorPose:
    """Where the sensor sits on the robot, in the robot frame (x forward, y left, yaw counter-clockwise).

    Parameters
    ----------
    x_m, y_m : float
        Position of the sensor [m].
    yaw_rad : float
        Its heading relative to the robot's [rad].

    Raises
    ------
    InputError
        If a field is not finite.
    """

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x_m", "y_m", "yaw_rad"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise InputError(f"`{name}` must be a finite number, got {v!r}")

    def as_array(self) -> np.ndarray:
        """The pose as an array ``[x_m, y_m, yaw_rad]``.

        Returns
        -------
        numpy.ndarray
            Shape ``(3,)``.
        """
        return np.array([self.x_m, self.y_m, self.yaw_rad])

    @classmethod
    def from_array(cls, pose: ArrayLike) -> SensorPose:
        """A sensor pose from ``[x_m, y_m, yaw_rad]``.

        Parameters
        ----------
        pose : array_like
            Three numbers.

        Returns
        -------
        SensorPose

        Raises
        ------
        InputError
            If ``pose`` does not hold three finite numbers.
        """
        p = np.asarray(pose, dtype=float).reshape(-1)
        if p.shape != (3,):
            raise InputError(f"a sensor pose is three numbers [x_m, y_m, yaw_rad], got {p.size}")
        return cls(float(p[0]), float(p[1]), float(p[2]))


@dataclass(frozen=True)
class Lidar:
    """A 2D scanning range finder: beam directions, range limits, noise and dropouts.

    Beam ``i`` points at ``angle_min_rad + i * angle_increment_rad`` in the sensor frame. A full
    circle (``fov_rad = 2 pi``) has ``n_beams`` beams ``2 pi / n_beams`` apart; a smaller field of
    view has its first and last beam on its edges.

    Parameters
    ----------
    n_beams : int
        Beams per scan.
    fov_rad : float
        Field of view, in (0, 2 pi] [rad].
    max_range_m : float
        Returns beyond this are ``inf`` (no return) [m].
    min_range_m : float
        Returns closer than this are ``inf`` [m].
    range_noise_m : float
        Standard deviation of the Gaussian noise on each return [m].
    dropout_prob : float
        Probability that a beam returns nothing (``inf``), in [0, 1).
    angle_min_rad : float, optional
        The first beam's direction; default ``-fov_rad / 2`` (the beams centred on the sensor's x axis).

    Raises
    ------
    InputError
        If a field is out of its range.
    """

    n_beams: int = 360
    fov_rad: float = 2.0 * math.pi
    max_range_m: float = 12.0
    min_range_m: float = 0.05
    range_noise_m: float = 0.005
    dropout_prob: float = 0.0
    angle_min_rad: float | None = field(default=None)

    def __post_init__(self) -> None:
        if not (isinstance(self.n_beams, (int, np.integer)) and self.n_beams >= 1):
            raise InputError(f"`n_beams` must be a positive integer, got {self.n_beams!r}")
        if not (math.isfinite(self.fov_rad) and 0 < self.fov_rad <= 2.0 * math.pi + 1e-12):
            raise InputError(f"`fov_rad` must be in (0, 2 pi], got {self.fov_rad!r}")
        if not (self.max_range_m > 0 and not math.isnan(self.max_range_m)):
            raise InputError(f"`max_range_m` must be positive, got {self.max_range_m!r}")
        if not (math.isfinite(self.min_range_m) and 0 <= self.min_range_m < self.max_range_m):
            raise InputError(f"`min_range_m` must be in [0, max_range_m), got {self.min_range_m!r}")
        if not (math.isfinite(self.range_noise_m) and self.range_noise_m >= 0):
            raise InputError(f"`range_noise_m` must be >= 0, got {self.range_noise_m!r}")
        if not (0 <= self.dropout_prob < 1):
            raise InputError(f"`dropout_prob` must be in [0, 1), got {self.dropout_prob!r}")
        if self.angle_min_rad is not None and not math.isfinite(self.angle_min_rad):
            raise InputError(f"`angle_min_rad` must be finite, got {self.angle_min_rad!r}")

    @property
    def full_circle(self) -> bool:
        """Whether the beams cover the whole circle (``fov_rad`` is 2 pi)."""
        return abs(self.fov_rad - 2.0 * math.pi) <= 1e-12

    @property
    def angle_increment_rad(self) -> float:
        """The angle between neighbouring beams [rad]."""
        if self.full_circle:
            return 2.0 * math.pi / self.n_beams
        return self.fov_rad / (self.n_beams - 1) if self.n_beams > 1 else 0.0

    @property
    def first_angle_rad(self) -> float:
        """The direction of the first beam (``angle_min_rad``, or ``-fov_rad / 2``) [rad]."""
        return -0.5 * self.fov_rad if self.angle_min_rad is None else float(self.angle_min_rad)

    @property
    def last_angle_rad(self) -> float:
        """The direction of the last beam [rad] (a LaserScan's ``angle_max``)."""
        return self.first_angle_rad + (self.n_beams - 1) * self.angle_increment_rad

    @property
    def angles_rad(self) -> np.ndarray:
        """The ``(n_beams,)`` beam directions in the sensor frame [rad]."""
        return self.first_angle_rad + np.arange(self.n_beams) * self.angle_increment_rad

    def scan(
        self,
        room: Room,
        sensor_poses: ArrayLike,
        rng: np.random.Generator | int | np.random.SeedSequence | None = None,
        *,
        engine: str = "auto",
    ) -> np.ndarray:
        """The scans of the sensor at ``sensor_poses`` in ``room``: exact ranges, noise, dropouts, limits.

        Each beam's exact range (:func:`cast_rays`) gets Gaussian noise of standard deviation
        ``range_noise_m``; then a beam drops out with probability ``dropout_prob``; returns
        outside ``[min_range_m, max_range_m]`` become ``inf``. The draws are made for every beam
        (hit or not) in one fixed order, so the same generator state gives the same scans.

        Parameters
        ----------
        room : Room
            The walls.
        sensor_poses : array_like
            ``(M, 3)`` (or ``(3,)``) sensor poses ``[x, y, yaw]`` in the world frame.
        rng : numpy.random.Generator, int or SeedSequence, optional
            The noise source (a seed is turned into a generator); ``None`` needs a noise-free
            lidar (no range noise, no dropouts).
        engine : str
            :func:`cast_rays` engine.

        Returns
        -------
        numpy.ndarray
            ``(M, n_beams)`` ranges [m] (``(n_beams,)`` for one pose), ``inf`` for no return.

        Raises
        ------
        InputError
            Bad poses or engine, or a noisy lidar without ``rng``.
        """
        exact = cast_rays(room, sensor_poses, self.angles_rad, self.max_range_m, engine=engine)
        r = exact.copy()
        noisy = self.range_noise_m > 0 or self.dropout_prob > 0
        if noisy:
            if rng is None:
                raise InputError("a lidar with range noise or dropouts needs a random generator (`rng`)")
            g = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
            if self.range_noise_m > 0:
                noise = g.standard_normal(r.shape)
                hit = np.isfinite(r)
                r[hit] += self.range_noise_m * noise[hit]
            if self.dropout_prob > 0:
                r[g.random(r.shape) < self.dropout_prob] = np.inf
        r[(r < self.min_range_m) | (r > self.max_range_m)] = np.inf
        return r


@dataclass(frozen=True)
class Gyro:
    """A yaw-rate gyro (the z axis of an IMU), read at a fixed rate.

    Each reading is the mean true turn rate over the sample period that ends at its time, times
    ``scale``, plus ``bias_radps`` and Gaussian noise of standard deviation ``noise_radps``.

    Parameters
    ----------
    rate_hz : float
        Readings per second.
    scale : float
        The gyro's scale factor (1: exact).
    bias_radps : float
        Constant offset of every reading [rad/s].
    noise_radps : float
        Standard deviation of the noise on each reading [rad/s].

    Raises
    ------
    InputError
        A rate or scale that is not positive, a bias that is not finite, a negative noise.
    """

    rate_hz: float = 100.0
    scale: float = 1.0
    bias_radps: float = 0.0
    noise_radps: float = 0.0

    def __post_init__(self) -> None:
        for name in ("rate_hz", "scale"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"`{name}` must be a positive number, got {v!r}")
        if not math.isfinite(self.bias_radps):
            raise InputError(f"`bias_radps` must be finite, got {self.bias_radps!r}")
        if not (math.isfinite(self.noise_radps) and self.noise_radps >= 0):
            raise InputError(f"`noise_radps` must be >= 0, got {self.noise_radps!r}")

    def measure(
        self, t_s: ArrayLike, yaw_rad: ArrayLike, rng: np.random.Generator | int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The readings at the times ``t_s[1:]``, from the true headings at ``t_s``.

        Parameters
        ----------
        t_s : array_like
            ``(K,)`` increasing times [s] (the gyro's sample times, one before the first reading).
        yaw_rad : array_like
            ``(K,)`` true headings at those times [rad], accumulated (not wrapped).
        rng : numpy.random.Generator or int, optional
            The noise source; needed when ``noise_radps`` is positive.

        Returns
        -------
        tuple of numpy.ndarray
            ``(t_s[1:], readings [rad/s])``.

        Raises
        ------
        InputError
            Arrays of different lengths, fewer than two times or times that do not increase; a
            noisy gyro without ``rng``.
        """
        t = np.asarray(t_s, dtype=float).reshape(-1)
        yaw = np.asarray(yaw_rad, dtype=float).reshape(-1)
        if t.shape != yaw.shape or t.size < 2 or not np.all(np.diff(t) > 0):
            raise InputError("a gyro needs two or more increasing times and one heading per time")
        rate = self.scale * np.diff(yaw) / np.diff(t) + self.bias_radps
        if self.noise_radps > 0:
            if rng is None:
                raise InputError("a gyro with noise needs a random generator (`rng`)")
            g = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
            rate = rate + self.noise_radps * g.standard_normal(rate.shape)
        return t[1:], rate


# ---------------------------------------------------------------- ray casting
def _as_poses(poses: ArrayLike) -> tuple[np.ndarray, bool]:
    p = np.asarray(poses, dtype=float)
    single = p.ndim == 1
    p2 = p.reshape(1, -1) if single else p
    if p2.ndim != 2 or p2.shape[1] != 3:
        raise InputError(f"`sensor_poses` must have shape (M, 3) or (3,) [x, y, yaw], got {p.shape}")
    if not np.all(np.isfinite(p2)):
        raise InputError("`sensor_poses` must be finite")
    return p2, single


def _cast_numpy(seg: np.ndarray, poses: np.ndarray, angles: np.ndarray, max_range: float) -> np.ndarray:
    M, B, N = len(poses), len(angles), len(seg)
    ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    out = np.empty((M, B))
    step = max(1, _CHUNK_ELEMENTS // (B * N))
    for i in range(0, M, step):
        p = poses[i : i + step]
        wx = seg[None, :, 0] - p[:, 0, None]  # (C, N): segment start relative to the sensor
        wy = seg[None, :, 1] - p[:, 1, None]
        w_e = (wx * ey - wy * ex)[:, None, :]  # (C, 1, N)
        a = p[:, 2, None] + angles[None, :]  # (C, B) beam directions in the world
        dx, dy = np.cos(a)[..., None], np.sin(a)[..., None]  # (C, B, 1)
        den = dx * ey - dy * ex  # (C, B, N): d x e
        w_d = wx[:, None, :] * dy - wy[:, None, :] * dx  # w x d
        with np.errstate(divide="ignore", invalid="ignore"):
            t = w_e / den
            u = w_d / den
        hit = (t > _T_MIN) & (u >= -_U_TOL) & (u <= 1.0 + _U_TOL)
        r = np.where(hit, t, np.inf).min(axis=2)
        r[r > max_range] = np.inf
        out[i : i + step] = r
    return out


def _cast_kernel_py(seg, poses, angles, max_range, out):  # pragma: no cover - compiled by numba
    N = seg.shape[0]
    ex = seg[:, 2] - seg[:, 0]
    ey = seg[:, 3] - seg[:, 1]
    wx = np.empty(N)
    wy = np.empty(N)
    w_e = np.empty(N)
    for m in range(poses.shape[0]):
        px, py, yaw = poses[m, 0], poses[m, 1], poses[m, 2]
        for n in range(N):
            wx[n] = seg[n, 0] - px
            wy[n] = seg[n, 1] - py
            w_e[n] = wx[n] * ey[n] - wy[n] * ex[n]
        for b in range(angles.shape[0]):
            a = yaw + angles[b]
            dx = math.cos(a)
            dy = math.sin(a)
            best = np.inf
            for n in range(N):
                den = dx * ey[n] - dy * ex[n]
                if den == 0.0:
                    continue
                t = w_e[n] / den
                if t <= _T_MIN or t >= best:
                    continue
                u = (wx[n] * dy - wy[n] * dx) / den
                if u >= -_U_TOL and u <= 1.0 + _U_TOL:
                    best = t
            out[m, b] = best if best <= max_range else np.inf


def _get_kernel() -> Any:
    global _kernel
    if _kernel is None:
        if not have_numba():
            raise InputError(
                'engine "numba" needs numba (a dependency of umbmark that is missing here): pip install numba'
            )
        numba = numba_module()
        assert numba is not None
        _kernel = numba.njit(cache=True, nogil=True)(_cast_kernel_py)
    return _kernel


def cast_rays(
    room: Room | ArrayLike,
    sensor_poses: ArrayLike,
    angles_rad: ArrayLike,
    max_range_m: float = math.inf,
    *,
    engine: str = "auto",
) -> np.ndarray:
    """Exact ranges of rays from many sensor poses to the nearest wall.

    Ray ``b`` of pose ``m`` starts at ``(x_m, y_m)`` in the direction ``yaw_m + angles_rad[b]``
    and stops at the nearest segment it meets (a segment's end points included; a ray along a
    segment does not hit it).

    Parameters
    ----------
    room : Room or array_like
        The walls (a :class:`Room`, or ``(N, 4)`` segments ``[x1, y1, x2, y2]``).
    sensor_poses : array_like
        ``(M, 3)`` (or ``(3,)``) poses ``[x, y, yaw]`` in the world frame [m, rad].
    angles_rad : array_like
        ``(B,)`` beam directions in the sensor frame [rad].
    max_range_m : float
        Ranges beyond this are ``inf``.
    engine : str
        ``"numba"`` (compiled loop), ``"numpy"`` (vectorised over chunks of poses x beams x
        segments) or ``"auto"`` (numba when installed). Same ranges to rounding.

    Returns
    -------
    numpy.ndarray
        ``(M, B)`` ranges [m] (``(B,)`` for one pose); ``inf`` where nothing is hit within range.

    Raises
    ------
    InputError
        Bad segments, poses or angles, or an unknown or unavailable engine.
    """
    check_engine(engine)
    seg = room.segments if isinstance(room, Room) else _as_segments(room, "room")
    poses, single = _as_poses(sensor_poses)
    angles = np.asarray(angles_rad, dtype=float).reshape(-1)
    if not np.all(np.isfinite(angles)):
        raise InputError("`angles_rad` must be finite")
    if math.isnan(max_range_m) or max_range_m <= 0:
        raise InputError(f"`max_range_m` must be positive, got {max_range_m!r}")
    if engine == "auto":
        engine = "numba" if have_numba() else "numpy"
    if engine == "numba":
        out = np.empty((len(poses), len(angles)))
        _get_kernel()(np.ascontiguousarray(seg), np.ascontiguousarray(poses), angles, float(max_range_m), out)
    else:
        out = _cast_numpy(seg, poses, angles, float(max_range_m))
    return out[0] if single else out
