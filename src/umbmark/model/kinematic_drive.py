"""A simulated robot of any kind (:mod:`umbmark.kinds`: a tricycle, a mecanum robot) with a lidar, driving in a room.

Pure numpy: imports numpy and the lower modules of :mod:`umbmark.model`. SI units, world frame
of the room. The differential drive's own simulator is :mod:`umbmark.model.drive`; this one
takes any kind of robot and records its joints as their controllers publish them.

The robot (:class:`KinematicRobot`) believes its nominal geometry: a :class:`Move` ``(duration,
v_x, v_y, omega)`` becomes the joint steps of the NOMINAL geometry's inverse kinematics
(:meth:`~umbmark.model.kinematics.Kinematics.joint_motion`) at ``wheel_rate_hz``; the robot
moves as its TRUE geometry makes those joint steps move it. A steering joint turns towards
its target at most ``steer_rate_radps`` (between two samples it turns linearly, and the step
takes its mean); a move without motion keeps the steering where it is. Noise
(:class:`JointNoise`): rolling-joint speed jitter (seen by the encoders), ground slip of each
rolling joint (not seen), steering-angle reading noise and encoder quantisation. The lidar scans at ``scan_rate_hz``
from the exact true pose (the sample's constant twist, a fraction of the way along).

:func:`kinematic_program` plans moves that keep the robot in the room and excite every
parameter of its kind (the moves its geometry names,
:attr:`~umbmark.model.kinematics.Kinematics.moves`); :func:`simulate_kinematic_drive` drives
them into a :class:`JointDriveLog`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model.drive import default_start
from umbmark.model.kinematics import JointSteps, Kinematics, integrate_steps, twist_displacement
from umbmark.model.se2 import Pose, between, compose
from umbmark.model.sensors import Lidar, Room, SensorPose
from umbmark.model.simulate import child_seeds

__all__ = [
    "Move",
    "JointNoise",
    "KinematicRobot",
    "JointDriveLog",
    "simulate_kinematic_drive",
    "kinematic_program",
    "MOVES",
    "ODOMETRY_SCHEMES",
]

ODOMETRY_SCHEMES = ("exact", "euler")
"""How a simulated odometry integrates the joints (:meth:`JointDriveLog.odometry`)."""

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Move:
    """Drive at a constant commanded twist for a time.

    Parameters
    ----------
    duration_s : float
        How long [s] (positive).
    vx_mps, vy_mps : float
        Commanded forward and leftward speed [m/s].
    omega_radps : float
        Commanded turn rate [rad/s], counter-clockwise positive.
    """

    duration_s: float
    vx_mps: float = 0.0
    vy_mps: float = 0.0
    omega_radps: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise InputError(f"a move's `duration_s` must be positive, got {self.duration_s!r}")
        for n in ("vx_mps", "vy_mps", "omega_radps"):
            if not math.isfinite(getattr(self, n)):
                raise InputError(f"a move's `{n}` must be finite, got {getattr(self, n)!r}")

    @property
    def still(self) -> bool:
        """No motion commanded."""
        return self.vx_mps == 0 and self.vy_mps == 0 and self.omega_radps == 0


@dataclass(frozen=True)
class JointNoise:
    """Non-systematic joint errors; each is off at zero.

    Parameters
    ----------
    speed_rel_sd : float
        Relative standard deviation of each rolling joint's speed per sample (the encoders see it).
    slip_m_per_sqrt_m : float
        Each rolling joint's ground travel per sample differs from ``r dphi`` by a Gaussian of
        standard deviation ``k sqrt(|r dphi|)`` (the encoders do not see it).
    steer_sd_rad : float
        Standard deviation of each steering reading about the true measured angle [rad].
    pulses_per_wheel_rev : int, optional
        The rolling joints are reported in whole encoder pulses of this many a revolution
        (``None``: exact).
    """

    speed_rel_sd: float = 0.0
    slip_m_per_sqrt_m: float = 0.0
    steer_sd_rad: float = 0.0
    pulses_per_wheel_rev: int | None = None

    def __post_init__(self) -> None:
        for n in ("speed_rel_sd", "slip_m_per_sqrt_m", "steer_sd_rad"):
            v = getattr(self, n)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"`{n}` must be >= 0, got {v!r}")
        ppr = self.pulses_per_wheel_rev
        if ppr is not None and not (isinstance(ppr, (int, np.integer)) and ppr > 0):
            raise InputError(f"`pulses_per_wheel_rev` must be a positive whole number, got {ppr!r}")

    @property
    def draws(self) -> bool:
        """Whether the noise needs random numbers."""
        return self.speed_rel_sd > 0 or self.slip_m_per_sqrt_m > 0 or self.steer_sd_rad > 0


@dataclass(frozen=True)
class KinematicRobot:
    """A simulated robot of any kind: what it believes, what it is, its lidar.

    Parameters
    ----------
    nominal : Kinematics
        The geometry it commands its joints with.
    true : Kinematics
        Its true geometry (the same kind).
    sensor_pose : SensorPose
        Where the lidar sits in the robot frame.
    lidar : Lidar
        The lidar.
    steer_rate_radps : float
        How fast a steering joint turns [rad/s].
    max_curvature_per_m : float, optional
        The tightest turn a car's programs drive (:func:`kinematic_program`'s loops and reversing
        arcs) [1/m]; default its nominal geometry's ``max_curvature_per_m`` (a car's full lock),
        else 2 (a 0.5 m radius).
    """

    nominal: Kinematics
    true: Kinematics
    sensor_pose: SensorPose = field(default_factory=SensorPose)
    lidar: Lidar = field(default_factory=Lidar)
    steer_rate_radps: float = 2.0
    max_curvature_per_m: float | None = None

    def __post_init__(self) -> None:
        if type(self.nominal) is not type(self.true):
            raise InputError(
                f"the nominal ({type(self.nominal).__name__}) and true ({type(self.true).__name__}) "
                "geometry must be of one kind"
            )
        if not (math.isfinite(self.steer_rate_radps) and self.steer_rate_radps > 0):
            raise InputError(f"`steer_rate_radps` must be positive, got {self.steer_rate_radps!r}")
        k = self.max_curvature_per_m
        if k is not None and not (math.isfinite(k) and k > 0):
            raise InputError(f"`max_curvature_per_m` must be positive, got {k!r}")

    @property
    def turn_limit_per_m(self) -> float:
        """The tightest turn of a car's moves [1/m] (see ``max_curvature_per_m``)."""
        if self.max_curvature_per_m is not None:
            return float(self.max_curvature_per_m)
        return float(getattr(self.nominal, "max_curvature_per_m", 2.0))

    @property
    def kind(self) -> str:
        """The kind of robot (``tricycle``, ``mecanum``, ``diff_drive``)."""
        return self.nominal.kind


@dataclass(frozen=True, eq=False)
class JointDriveLog:
    """What a simulated drive of any kind records: joint positions, true poses and lidar scans.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(N + 1,)`` joint sample times [s], from 0.
    positions : numpy.ndarray
        ``(N + 1, J)`` the joints as their controller publishes them: a rolling joint's
        cumulative angle [rad] (0 at the start), a steering joint's angle [rad].
    joint_names : tuple of str
        The joints' names, in :attr:`~umbmark.model.kinematics.Kinematics.joint_roles` order.
    true_pose : numpy.ndarray
        ``(N + 1, 3)`` true robot poses in the room at ``t_s`` (yaw accumulated).
    true_twist : numpy.ndarray
        ``(N, 3)`` the true integrated twist of each sample (from the sample's start).
    scan_t_s, scan_pose, ranges_m, angles_rad : numpy.ndarray
        Scan times, true robot poses at them, ranges ``(M, n_beams)`` [m] and beam angles.
    lidar : Lidar
    sensor_pose : SensorPose
    nominal, true : Kinematics
        The geometry believed and the true one.
    room : Room
    wheel_rate_hz, scan_rate_hz : float
    moves : tuple of Move
    seed : int or None
    """

    t_s: FloatArray
    positions: FloatArray
    joint_names: tuple[str, ...]
    true_pose: FloatArray
    true_twist: FloatArray
    scan_t_s: FloatArray
    scan_pose: FloatArray
    ranges_m: FloatArray
    angles_rad: FloatArray
    lidar: Lidar
    sensor_pose: SensorPose
    nominal: Kinematics
    true: Kinematics
    room: Room
    wheel_rate_hz: float
    scan_rate_hz: float
    moves: tuple[Move, ...] = ()
    seed: int | None = None

    @property
    def scan_stamps_s(self) -> FloatArray:
        """The scans' stamps [s] (when they were taken)."""
        return self.scan_t_s

    @property
    def duration_s(self) -> float:
        """The time of the last sample [s]."""
        return float(self.t_s[-1])

    def joint_steps(self, t_s: ArrayLike | None = None) -> JointSteps:
        """The joints' steps between consecutive times, each interval one step.

        Parameters
        ----------
        t_s : array_like, optional
            Increasing times within the drive (default every sample): a rolling joint's
            increment between them, a steering joint's mean of its values at the two ends
            (linear between samples).

        Returns
        -------
        JointSteps
        """
        t = self.t_s if t_s is None else np.asarray(t_s, dtype=float)
        pos = np.column_stack([np.interp(t, self.t_s, self.positions[:, j]) for j in range(self.positions.shape[1])])
        vals = np.empty((len(t) - 1, pos.shape[1]))
        for j, rolls in enumerate(self.nominal.rolling):
            vals[:, j] = np.diff(pos[:, j]) if rolls else 0.5 * (pos[1:, j] + pos[:-1, j])
        return JointSteps(vals, np.arange(len(t)), np.diff(t))

    def odometry(self, kinematics: Kinematics | None = None, scheme: str = "exact") -> FloatArray:
        """``(N + 1, 3)`` the odometry of the recorded joints (default the nominal geometry), from the origin.

        Parameters
        ----------
        kinematics : Kinematics, optional
            The geometry (default the nominal one).
        scheme : str
            ``"exact"``: each sample's constant twist integrated exactly (a steering joint at its
            mean over the sample), as ros2_controllers' odometries do; ``"euler"``: as a car's
            ``vesc_to_odom`` does, the steering at the sample's end and the position advanced
            along the heading before the sample (:data:`ODOMETRY_SCHEMES`).
        """
        k = self.nominal if kinematics is None else kinematics
        if scheme not in ODOMETRY_SCHEMES:
            raise InputError(f"`scheme` must be one of {', '.join(ODOMETRY_SCHEMES)}, got {scheme!r}")
        if scheme == "exact":
            return integrate_steps(twist_displacement(k.twist(self.joint_steps().values)))
        vals = np.asarray(self.joint_steps().values, dtype=float).copy()
        for j, rolls in enumerate(self.nominal.rolling):
            if not rolls:
                vals[:, j] = self.positions[1:, j]
        return integrate_steps(k.twist(vals))

    def sensor_motion(self) -> FloatArray:
        """``(M - 1, 3)`` the true sensor motion between consecutive scans, in the sensor frame."""
        w = compose(self.scan_pose, self.sensor_pose.as_array())
        return between(w[:-1], w[1:])


def _slew(target: FloatArray, start: float, max_step: float) -> FloatArray:
    """A steering angle that follows ``target`` (one per sample), turning at most ``max_step`` a
    sample: ``(N + 1,)`` from ``start``."""
    out = np.empty(len(target) + 1)
    out[0] = a = start
    for k, g in enumerate(target):
        a += min(max(g - a, -max_step), max_step)
        out[k + 1] = a
    return out


def _targets(robot: KinematicRobot, moves: Sequence[Move], n: NDArray[np.intp], dt: float) -> FloatArray:
    """``(N, J)`` per sample: rolling joints' commanded increments, steering joints' targets
    (a move without motion keeps the target of the move before)."""
    vx = np.repeat([m.vx_mps for m in moves], n)
    vy = np.repeat([m.vy_mps for m in moves], n)
    w = np.repeat([m.omega_radps for m in moves], n)
    cmd = robot.nominal.joint_motion(vx, vy, w, dt)
    still = np.repeat([m.still for m in moves], n)
    for j, rolls in enumerate(robot.nominal.rolling):
        if not rolls and still.any():
            col = cmd[:, j]
            idx = np.where(~still, np.arange(len(col)), -1)
            np.maximum.accumulate(idx, out=idx)
            cmd[:, j] = np.where(idx >= 0, col[np.maximum(idx, 0)], 0.0)
    return np.asarray(cmd, dtype=float)


def _sample_joints(
    robot: KinematicRobot,
    moves: Sequence[Move],
    rate: float,
    noise: JointNoise,
    rng: np.random.Generator | None,
    steer0: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The joints of a drive: ``(N + 1, J)`` reported positions, ``(N, J)`` the true steps the
    ground sees, and the steering angles at the end ``(J,)``."""
    n = np.array([max(1, round(m.duration_s * rate)) for m in moves], dtype=np.intp)
    dt = 1.0 / rate
    cmd = _targets(robot, moves, n, dt)
    big_n, nj = cmd.shape
    rolling = np.array(robot.nominal.rolling)
    reported = np.zeros((big_n + 1, nj))
    ground = np.empty((big_n, nj))
    end = np.zeros(nj) if steer0 is None else steer0.copy()
    for j in range(nj):
        if rolling[j]:
            inc = cmd[:, j]
            if noise.speed_rel_sd > 0 and rng is not None:
                inc = inc * (1.0 + noise.speed_rel_sd * rng.standard_normal(big_n))
            reported[1:, j] = np.cumsum(inc)
            ground[:, j] = inc
            if noise.pulses_per_wheel_rev is not None:
                step = 2.0 * math.pi / noise.pulses_per_wheel_rev
                reported[:, j] = np.floor(reported[:, j] / step + 1e-9) * step
        else:
            path = _slew(cmd[:, j], float(end[j]), robot.steer_rate_radps * dt)
            ground[:, j] = 0.5 * (path[1:] + path[:-1])
            reported[:, j] = path
            end[j] = path[-1]
            if noise.steer_sd_rad > 0 and rng is not None:
                reported[:, j] = path + noise.steer_sd_rad * rng.standard_normal(big_n + 1)
    if noise.slip_m_per_sqrt_m > 0 and rng is not None:
        radii = 0.5 * np.asarray(robot.true.rolling_diameters_m(), dtype=float)
        cols = np.flatnonzero(rolling)
        travel = ground[:, cols] * radii
        travel = travel + noise.slip_m_per_sqrt_m * np.sqrt(np.abs(travel)) * rng.standard_normal(travel.shape)
        ground[:, cols] = travel / radii
    return reported, ground, end


def simulate_kinematic_drive(
    moves: Sequence[Move],
    robot: KinematicRobot,
    room: Room | None = None,
    start_pose: ArrayLike | None = None,
    *,
    joint_names: Sequence[str] | None = None,
    wheel_rate_hz: float = 100.0,
    scan_rate_hz: float = 10.0,
    noise: JointNoise | None = None,
    seed: int | None = None,
    engine: str = "auto",
) -> JointDriveLog:
    """Drive ``moves`` with ``robot`` in ``room``: joint positions, true poses and lidar scans.

    Parameters
    ----------
    moves : sequence of Move
        What to drive (each lasts ``round(duration_s * wheel_rate_hz)`` samples, at least one).
    robot : KinematicRobot
    room : Room, optional
        Default :meth:`Room.default`.
    start_pose : array_like, optional
        ``(x, y, yaw)`` in the room; default :func:`umbmark.model.drive.default_start`.
    joint_names : sequence of str, optional
        The joints' names (default the kind's roles with ``_joint``).
    wheel_rate_hz, scan_rate_hz : float
        The joint and scan rates.
    noise : JointNoise, optional
        Default none.
    seed : int, optional
        Seed of the joint noise and the lidar's noise (needed when either is noisy).
    engine : str
        Ray-casting engine of :func:`umbmark.model.sensors.cast_rays`.

    Returns
    -------
    JointDriveLog

    Raises
    ------
    InputError
        No moves, bad rates, noise without a seed, a bad start pose or joint names.
    """
    room = Room.default() if room is None else room
    if not moves:
        raise InputError("the program has no moves")
    for name, v in (("wheel_rate_hz", wheel_rate_hz), ("scan_rate_hz", scan_rate_hz)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"`{name}` must be a positive number, got {v!r}")
    noise = JointNoise() if noise is None else noise
    lidar_noisy = robot.lidar.range_noise_m > 0 or robot.lidar.dropout_prob > 0
    if seed is None and (noise.draws or lidar_noisy):
        raise InputError("a noisy drive (joint noise, lidar range noise or dropouts) needs a `seed`")
    roles = robot.nominal.joint_roles
    names = tuple(f"{r}_joint" for r in roles) if joint_names is None else tuple(joint_names)
    if len(names) != len(roles) or len(set(names)) != len(names) or not all(names):
        raise InputError(f"`joint_names` must be {len(roles)} distinct names ({', '.join(roles)}), got {names!r}")
    p0 = np.asarray(default_start(room) if start_pose is None else start_pose, dtype=float).reshape(-1)
    if p0.shape != (3,) or not np.all(np.isfinite(p0)):
        raise InputError("`start_pose` must be three finite numbers (x_m, y_m, yaw_rad)")
    joint_seed, lidar_seed = child_seeds(0 if seed is None else seed, 2)
    rng = np.random.default_rng(joint_seed) if noise.draws else None
    reported, ground, _ = _sample_joints(robot, moves, float(wheel_rate_hz), noise, rng)
    twist = robot.true.twist(ground)
    pose = integrate_steps(twist_displacement(twist), p0)
    t = np.arange(len(pose)) / float(wheel_rate_hz)
    n_scans = int(math.floor(t[-1] * scan_rate_hz + 1e-9)) + 1
    scan_t = np.arange(n_scans) / float(scan_rate_hz)
    u = scan_t * wheel_rate_hz
    k = np.clip(np.floor(u + 1e-9).astype(np.intp), 0, len(twist) - 1)
    f = np.clip(u - k, 0.0, 1.0)
    scan_pose = compose(pose[k], twist_displacement(f[:, None] * twist[k]))
    scan_pose[:, 2] = pose[k, 2] + twist_displacement(f[:, None] * twist[k])[:, 2]
    sensor_world = compose(scan_pose, robot.sensor_pose.as_array())
    ranges = robot.lidar.scan(room, sensor_world, np.random.default_rng(lidar_seed), engine=engine)
    return JointDriveLog(
        t_s=t,
        positions=reported,
        joint_names=names,
        true_pose=pose,
        true_twist=twist,
        scan_t_s=scan_t,
        scan_pose=scan_pose,
        ranges_m=ranges.reshape(n_scans, robot.lidar.n_beams),
        angles_rad=robot.lidar.angles_rad,
        lidar=robot.lidar,
        sensor_pose=robot.sensor_pose,
        nominal=robot.nominal,
        true=robot.true,
        room=room,
        wheel_rate_hz=float(wheel_rate_hz),
        scan_rate_hz=float(scan_rate_hz),
        moves=tuple(moves),
        seed=seed,
    )


# ---------------------------------------------------------------- programs
MOVES = (
    "straight", "back", "left", "right", "diagonal", "arc+", "arc-", "spin+", "spin-", "loop+", "loop-",
    "reverse+", "reverse-",
)  # fmt: skip
"""The moves :func:`kinematic_program` can draw: forward, backward, sideways left and right, in
any direction, arcs and spins counter-clockwise (``+``) and clockwise (``-``); a car's loops (150 to
330 deg forward, 0.4 to 1 m/s; drawn as figure-eights, one way then the other) and reversing arcs
(30 to 90 deg backward) at 0.8 to 1 and 0.6 to 1 times its tightest turn
(:attr:`KinematicRobot.turn_limit_per_m`). Each kind of robot names those it can make
(:attr:`~umbmark.model.kinematics.Kinematics.moves`)."""


def _draw_car(kind: str, rng: np.random.Generator, limit: float) -> Move:
    """A random loop or reversing arc of a car whose tightest turn is ``limit`` [1/m]."""
    sign = 1.0 if kind.endswith("+") else -1.0
    if kind.startswith("loop"):
        curvature = rng.uniform(0.8, 1.0) * limit
        v, turn = rng.uniform(0.4, 1.0), math.radians(rng.uniform(150.0, 330.0))
    else:
        curvature = rng.uniform(0.6, 1.0) * limit
        v, turn = -rng.uniform(0.2, 0.4), math.radians(rng.uniform(30.0, 90.0))
    omega = sign * abs(v) * curvature
    return Move(turn / abs(omega), v, 0.0, omega)


def _draw(kind: str, rng: np.random.Generator, limit: float = 2.0) -> Move:
    """A random move of one kind (a car's tightest turn ``limit`` [1/m])."""
    if kind.startswith(("loop", "reverse")):
        return _draw_car(kind, rng, limit)
    if kind == "straight":
        v = rng.uniform(0.15, 0.4)
        return Move(rng.uniform(0.5, 2.5) / v, v)
    if kind == "back":
        v = rng.uniform(0.1, 0.25)
        return Move(rng.uniform(0.3, 1.0) / v, -v)
    if kind in ("left", "right"):
        v = rng.uniform(0.15, 0.3) * (1.0 if kind == "left" else -1.0)
        return Move(rng.uniform(0.4, 1.5) / abs(v), 0.0, v)
    if kind == "diagonal":
        a = rng.uniform(0, 2 * math.pi)
        v = rng.uniform(0.15, 0.3)
        return Move(rng.uniform(0.4, 1.5) / v, v * math.cos(a), v * math.sin(a))
    if kind in ("arc+", "arc-"):
        v = rng.uniform(0.15, 0.35)
        omega = v / rng.uniform(0.5, 2.0) * (1.0 if kind == "arc+" else -1.0)
        return Move(math.radians(rng.uniform(30.0, 150.0)) / abs(omega), v, 0.0, omega)
    omega = rng.uniform(0.4, 1.0) * (1.0 if kind == "spin+" else -1.0)
    return Move(math.radians(rng.uniform(60.0, 270.0)) / abs(omega), 0.0, 0.0, omega)


def _fits(room: Room, xy: FloatArray, clearance_m: float) -> bool:
    return bool(np.all(room.contains(xy)) and np.all(room.distance_to_walls(xy) >= clearance_m))


def kinematic_program(
    robot: KinematicRobot,
    duration_s: float = 150.0,
    seed: int = 0,
    *,
    room: Room | None = None,
    start_pose: ArrayLike | None = None,
    kinds: Sequence[str] | None = None,
    clearance_m: float = 0.6,
    wheel_rate_hz: float = 100.0,
    attempts: int = 40,
) -> tuple[tuple[Move, ...], Pose]:
    """Random moves of every kind the robot can make that keep it in the room.

    Moves are drawn in rounds of the robot's moves (its geometry's
    :attr:`~umbmark.model.kinematics.Kinematics.moves`, each round in a random order; a
    tricycle that cannot spin is given ``kinds`` without ``spin+`` / ``spin-``), each followed
    by a pause long enough for the steering to reach the next move's angle. A candidate is
    driven noise free with the robot's TRUE geometry from where the moves before left it, and
    kept only if the robot stays ``clearance_m`` from every wall; else another is drawn (then
    another kind).

    Parameters
    ----------
    robot : KinematicRobot
    duration_s : float
        About how long [s] (the moves are added until it is reached).
    seed : int
        Seed of the random choices.
    room : Room, optional
    start_pose : array_like, optional
    kinds : sequence of str, optional
        The moves to draw from (some of :data:`MOVES`; default the robot's own).
    clearance_m : float
        Least distance to any wall [m].
    wheel_rate_hz : float
        The rate the moves will be driven at (the check drives them so).
    attempts : int
        Candidates per kind before the next kind.

    Returns
    -------
    tuple
        ``(moves, start_pose)``.

    Raises
    ------
    InputError
        An unknown move kind, a start near a wall, or no move fits.
    """
    room = Room.default() if room is None else room
    pool = tuple(robot.nominal.moves if kinds is None else kinds)
    known = set(MOVES)
    if not pool or not set(pool) <= known:
        raise InputError(f"`kinds` must be some of {', '.join(sorted(known))}, got {pool!r}")
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"`duration_s` must be positive, got {duration_s!r}")
    start = np.asarray(default_start(room, clearance_m) if start_pose is None else start_pose, dtype=float)
    rng = np.random.default_rng(seed)
    pose = start.copy()
    steer = None
    moves: list[Move] = []
    used = 0.0
    queue: list[str] = []
    while used < duration_s:
        if not queue:
            queue = _figure_eights([pool[i] for i in rng.permutation(len(pool))])
        first = queue.pop(0)
        chosen = None
        for kind in [first] + [k for k in pool if k != first]:
            for _ in range(attempts):
                cand = _draw(kind, rng, robot.turn_limit_per_m)
                pause = Move(0.6 if steer is None else 0.2 + 1.2 / robot.steer_rate_radps)
                seq = [Move(pause.duration_s, 0.0, 0.0, 0.0), cand]
                seq[0] = _steer_first(seq[0], cand)
                rep, ground, end = _sample_joints(robot, seq, wheel_rate_hz, JointNoise(), None, steer)
                path = integrate_steps(twist_displacement(robot.true.twist(ground)), pose)
                if _fits(room, np.vstack([path[::10, :2], path[-1:, :2]]), clearance_m):
                    chosen = (seq, path[-1], end)
                    break
            if chosen is not None:
                break
        if chosen is None:
            raise InputError(f"no move keeps the robot {clearance_m:g} m from the walls at {pose[:2].round(2)}")
        seq, pose, steer = chosen
        moves += seq
        used += sum(m.duration_s for m in seq)
    return tuple(moves), (float(start[0]), float(start[1]), float(start[2]))


def _figure_eights(queue: list[str]) -> list[str]:
    """A round of moves with a car's second loop right after its first (a figure-eight)."""
    loops = [k for k in queue if k.startswith("loop")]
    if len(loops) < 2:
        return queue
    rest = [k for k in queue if k != loops[1]]
    at = rest.index(loops[0]) + 1
    return rest[:at] + [loops[1]] + rest[at:]


def _steer_first(pause: Move, nxt: Move) -> Move:
    """A pause before ``nxt`` in which a steering joint turns to ``nxt``'s angle: a crawl so slow
    that the robot does not move noticeably (a still move would keep the old angle)."""
    if nxt.still:
        return pause
    eps = 1e-9
    return Move(pause.duration_s, nxt.vx_mps * eps, nxt.vy_mps * eps, nxt.omega_radps * eps)
