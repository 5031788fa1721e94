"""A simulated differential-drive robot with a lidar, driving a program of commands in a room.

Pure numpy: this module imports only numpy and the lower modules of :mod:`umbmark.model`
(:mod:`~umbmark.model.geometry`, :mod:`~umbmark.model.intervals`, :mod:`~umbmark.model.se2`,
:mod:`~umbmark.model.sensors`, :mod:`~umbmark.model.simulate` for its seeding). SI units, world frame of the room.

The robot (:class:`SimRobot`) has a nominal :class:`~umbmark.model.geometry.Geometry` and
systematic errors :class:`~umbmark.model.geometry.ErrorParams` (E_d, E_b, E_s, as in the square
test): its true wheel diameters and wheelbase differ from the nominal ones. It believes its
nominal geometry: a :class:`Command` ``(duration_s, v_mps, omega_radps)`` becomes the wheel
speeds ``w_L = (v - omega b_n / 2) / r_n``, ``w_R = (v + omega b_n / 2) / r_n`` of the nominal
radius and wheelbase, and the robot moves as its TRUE wheels and wheelbase make it move.

:func:`simulate_drive` samples the wheels at ``wheel_rate_hz`` (each command lasts a whole number
of samples); within a sample the wheel speeds are constant, so the robot moves along the exact
arc :func:`umbmark.model.se2.arc` of its true geometry. Optional non-systematic noise
(:class:`WheelNoise`): wheel-speed jitter per sample (seen by the encoders) and random slip of
the ground travel (not seen by them), and encoder quantisation. The lidar, mounted at the
robot's :class:`~umbmark.model.sensors.SensorPose`, scans at ``scan_rate_hz`` from the exact
true pose at each scan time. The result is a :class:`DriveLog`.

Programs: :func:`mixed_program` (straights, arcs of both signs, spins both ways and pauses,
planned so the robot stays at least ``clearance_m`` from every wall), and the simpler
:func:`straight_only`, :func:`spins_only` and :func:`one_way_turns`, which leave parts of the
calibration unobservable; :func:`square_drive`, one UMBmark run at rest before and after.
:func:`concatenate_drives` joins drives as if the robot had been carried between them.

The commands, the integration of the wheels and the record of a drive are
:mod:`umbmark.model.drive_log` (their names are importable from here too).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.model.drive_log import Command, DriveLog, Program, _pose_along, _sample_of, integrate_wheels
from umbmark.model.geometry import LABMATE, ErrorParams, Geometry, WheelGeometry
from umbmark.model.se2 import Pose, compose
from umbmark.model.sensors import Gyro, Lidar, Room, SensorPose
from umbmark.model.simulate import child_seeds

__all__ = [
    "Command",
    "Program",
    "WheelNoise",
    "SimRobot",
    "EXAMPLE_ROBOT",
    "DriveLog",
    "simulate_drive",
    "integrate_wheels",
    "mixed_program",
    "straight_only",
    "spins_only",
    "one_way_turns",
    "default_start",
    "square_drive",
    "concatenate_drives",
    "skid_steer_robot",
    "simulate_gyro",
    "MAX_SAMPLES",
]

MAX_SAMPLES = 20_000_000  # wheel samples of one drive (55 h at 100 Hz): beyond it the inputs are wrong
_PLAN_DT_S = 0.05  # time between the points at which a planned command's path is checked


@dataclass(frozen=True)
class WheelNoise:
    """Non-systematic wheel errors; each is off at zero.

    Parameters
    ----------
    speed_rel_sd : float
        Relative standard deviation of each wheel's speed in each sample around its command.
        The encoders see it (it changes the path, not the odometry's accuracy).
    slip_m_per_sqrt_m : float
        Random slip: each wheel's ground travel in a sample differs from ``r * dphi`` by a
        zero-mean Gaussian of standard deviation ``k * sqrt(|r * dphi|)`` (a random walk in the
        distance rolled, independent of the sampling rate, as in
        :class:`umbmark.model.simulate.NoiseModel`). The encoders do not see it.
    quantise : bool
        The wheel angles are reported in whole encoder pulses of the nominal geometry
        (``pulses_per_wheel_rev`` per turn).
    slip_right_m_per_sqrt_m : float, optional
        The right wheel's random slip when it differs from the left's (``slip_m_per_sqrt_m``
        is then the left wheel's); the variance of a wheel's travel per metre is its square.

    Raises
    ------
    InputError
        If a parameter is negative or not finite.
    """

    speed_rel_sd: float = 0.0
    slip_m_per_sqrt_m: float = 0.0
    quantise: bool = False
    slip_right_m_per_sqrt_m: float | None = None

    def __post_init__(self) -> None:
        for name in ("speed_rel_sd", "slip_m_per_sqrt_m", "slip_right_m_per_sqrt_m"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise InputError(f"`{name}` must be >= 0, got {v!r}")

    @property
    def slip_right(self) -> float:
        """The right wheel's slip [m per sqrt(m)] (the left's unless given)."""
        return self.slip_m_per_sqrt_m if self.slip_right_m_per_sqrt_m is None else self.slip_right_m_per_sqrt_m

    @property
    def draws(self) -> bool:
        """Whether the noise needs random numbers."""
        return self.speed_rel_sd > 0 or self.slip_m_per_sqrt_m > 0 or self.slip_right > 0


@dataclass(frozen=True)
class SimRobot:
    """A simulated differential-drive robot: nominal geometry, its systematic errors, its lidar.

    Parameters
    ----------
    nominal : Geometry
        What the robot believes (and commands its wheels with).
    errors : ErrorParams
        Its true wheels and wheelbase relative to ``nominal``.
    sensor_pose : SensorPose
        Where the lidar sits in the robot frame.
    lidar : Lidar
        The lidar.
    """

    nominal: Geometry = LABMATE
    errors: ErrorParams = field(default_factory=ErrorParams)
    sensor_pose: SensorPose = field(default_factory=SensorPose)
    lidar: Lidar = field(default_factory=Lidar)

    @property
    def true_wheels(self) -> WheelGeometry:
        """The true wheel diameters and wheelbase."""
        return self.errors.wheels(self.nominal)

    @property
    def nominal_wheels(self) -> WheelGeometry:
        """The nominal wheel diameters and wheelbase."""
        return self.nominal.wheels()

    def wheel_rates(self, v_mps: ArrayLike, omega_radps: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The wheel speeds the robot commands for a speed and turn rate (nominal geometry).

        Parameters
        ----------
        v_mps, omega_radps : array_like
            Commanded forward speed [m/s] and turn rate [rad/s].

        Returns
        -------
        tuple of numpy.ndarray
            ``(w_left, w_right)`` [rad/s].
        """
        r = 0.5 * self.nominal.wheel_diameter_m
        half = 0.5 * self.nominal.wheelbase_m
        v = np.asarray(v_mps, dtype=float)
        w = np.asarray(omega_radps, dtype=float)
        return (v - w * half) / r, (v + w * half) / r

    def true_motion(
        self, w_left: ArrayLike, w_right: ArrayLike, duration_s: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The true ground travel of each wheel at constant wheel speeds, without slip.

        Parameters
        ----------
        w_left, w_right : array_like
            Wheel speeds [rad/s].
        duration_s : array_like
            For how long [s].

        Returns
        -------
        tuple of numpy.ndarray
            ``(d_left_m, d_right_m, wheelbase_m)``: the arguments of :func:`umbmark.model.se2.arc`.
        """
        true = self.true_wheels
        t = np.asarray(duration_s, dtype=float)
        d_left = 0.5 * true.diameter_left_m * np.asarray(w_left, dtype=float) * t
        d_right = 0.5 * true.diameter_right_m * np.asarray(w_right, dtype=float) * t
        return d_left, d_right, np.full(np.shape(d_left), true.wheelbase_m)


EXAMPLE_ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.006, eb=1.025, es=0.99),
    sensor_pose=SensorPose(0.12, -0.04, math.radians(3.0)),
    lidar=Lidar(),
)
"""A LabMate with systematic errors (E_d 1.006, E_b 1.025, E_s 0.99) and a lidar 12 cm ahead,
4 cm right of the axle centre, turned 3 degrees: the robot of the examples and tests."""


def _sample_counts(commands: Sequence[Command], rate_hz: float) -> np.ndarray:
    n = np.array([round(c.duration_s * rate_hz) for c in commands], dtype=np.int64)
    total = int(n.sum())
    if total < 1:
        raise InputError(f"the program lasts less than one wheel sample (1 / {rate_hz:g} s)")
    if total > MAX_SAMPLES:
        raise InputError(f"the program needs {total} wheel samples, more than {MAX_SAMPLES}: check the durations")
    return n


def _check_rate(name: str, v: float) -> float:
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"`{name}` must be a positive number, got {v!r}")
    return float(v)


def default_start(room: Room, clearance_m: float = 0.5) -> Pose:
    """The start pose of a program without one: the middle of the room's walls, heading along x.

    Parameters
    ----------
    room : Room
        The room.
    clearance_m : float
        The distance the start must keep from every wall [m].

    Returns
    -------
    tuple of float
        ``(x_m, y_m, 0.0)``.

    Raises
    ------
    InputError
        If the middle of the room is closer than ``clearance_m`` to a wall or outside it.
    """
    x0, y0, x1, y1 = room.bounds
    p = (0.5 * (x0 + x1), 0.5 * (y0 + y1))
    if not room.contains(p) or room.distance_to_walls(p) < clearance_m:
        raise InputError(f"the middle of the room is within {clearance_m:g} m of a wall: give `start_pose`")
    return (p[0], p[1], 0.0)


def simulate_drive(
    program: Program | Sequence[Command],
    robot: SimRobot = EXAMPLE_ROBOT,
    room: Room | None = None,
    start_pose: ArrayLike | None = None,
    *,
    wheel_rate_hz: float = 100.0,
    scan_rate_hz: float = 10.0,
    scan_offset_s: float = 0.0,
    noise: WheelNoise | None = None,
    seed: int | None = None,
    engine: str = "auto",
) -> DriveLog:
    """Drive ``program`` with ``robot`` in ``room``: wheel angles, true poses and lidar scans.

    Each command lasts ``round(duration_s * wheel_rate_hz)`` wheel samples. In each sample the
    wheels turn at the commanded speeds of the nominal geometry (times ``1 + speed_rel_sd * n``
    with noise), the encoders report the angles turned (in whole pulses when quantised), and
    the robot moves along the exact arc of its true wheels' ground travel (plus slip). Scans
    are taken at ``scan_offset_s + m / scan_rate_hz`` for every ``m >= 0`` within the drive,
    each from the exact true pose at its time.

    Parameters
    ----------
    program : Program or sequence of Command
        What to drive.
    robot : SimRobot
        The robot (true and nominal geometry, lidar and its pose).
    room : Room, optional
        The walls; default :meth:`Room.default`.
    start_pose : array_like, optional
        ``(x, y, yaw)`` in the room; default the program's own start, else
        :func:`default_start`.
    wheel_rate_hz : float
        Wheel (JointState) sampling rate.
    scan_rate_hz : float
        Lidar scan rate.
    scan_offset_s : float
        Time of the first scan, in ``[0, 1 / scan_rate_hz)``.
    noise : WheelNoise, optional
        Non-systematic wheel errors; default none.
    seed : int, optional
        Seed of the wheel noise and the lidar's range noise and dropouts (independent streams).
        Needed when either is noisy.
    engine : str
        Ray-casting engine of :func:`umbmark.model.sensors.cast_rays`.

    Returns
    -------
    DriveLog

    Raises
    ------
    InputError
        Bad rates, an empty or too long program, noise without a seed, a bad start pose.
    """
    room = Room.default() if room is None else room
    commands = tuple(program.commands if isinstance(program, Program) else program)
    if not commands:
        raise InputError("the program has no commands")
    rate = _check_rate("wheel_rate_hz", wheel_rate_hz)
    scan_rate = _check_rate("scan_rate_hz", scan_rate_hz)
    if not (math.isfinite(scan_offset_s) and 0 <= scan_offset_s < 1.0 / scan_rate):
        raise InputError(f"`scan_offset_s` must be in [0, 1 / scan_rate_hz), got {scan_offset_s!r}")
    noise = WheelNoise() if noise is None else noise
    lidar_noisy = robot.lidar.range_noise_m > 0 or robot.lidar.dropout_prob > 0
    if seed is None and (noise.draws or lidar_noisy):
        raise InputError("a noisy drive (wheel noise, lidar range noise or dropouts) needs a `seed`")
    if start_pose is None:
        start_pose = program.start_pose if isinstance(program, Program) and program.start_pose else None
    p0 = np.asarray(default_start(room) if start_pose is None else start_pose, dtype=float).reshape(-1)
    if p0.shape != (3,) or not np.all(np.isfinite(p0)):
        raise InputError("`start_pose` must be three finite numbers (x_m, y_m, yaw_rad)")

    wheel_seed, lidar_seed = child_seeds(0 if seed is None else seed, 2)
    t, left, right, travel_l, travel_r, pose = _drive_wheels(commands, robot, rate, noise, wheel_seed, p0)
    scan_t, scan_pose, ranges = _drive_scans(
        robot, room, t, pose, travel_l, travel_r, rate, scan_rate, scan_offset_s, lidar_seed, engine
    )
    true = robot.true_wheels
    return DriveLog(
        t_s=t,
        left_rad=left,
        right_rad=right,
        true_pose=pose,
        travel_left_m=travel_l,
        travel_right_m=travel_r,
        scan_t_s=scan_t,
        scan_pose=scan_pose,
        ranges_m=ranges.reshape(len(scan_t), robot.lidar.n_beams),
        angles_rad=robot.lidar.angles_rad,
        lidar=robot.lidar,
        sensor_pose=robot.sensor_pose,
        nominal_geometry=robot.nominal_wheels,
        true_geometry=true,
        room=room,
        wheel_rate_hz=rate,
        scan_rate_hz=scan_rate,
        commands=commands,
        seed=seed,
    )


def _drive_wheels(
    commands: tuple[Command, ...],
    robot: SimRobot,
    rate: float,
    noise: WheelNoise,
    wheel_seed: np.random.SeedSequence,
    p0: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The wheel samples of a drive: stamps, encoder angles, true ground travel and true poses."""
    n = _sample_counts(commands, rate)
    K = int(n.sum())
    dt = 1.0 / rate
    v = np.repeat([c.v_mps for c in commands], n)
    w = np.repeat([c.omega_radps for c in commands], n)
    wl, wr = robot.wheel_rates(v, w)
    if noise.draws:
        z = np.random.default_rng(wheel_seed).standard_normal((4, K))
        wl = wl * (1.0 + noise.speed_rel_sd * z[0])
        wr = wr * (1.0 + noise.speed_rel_sd * z[1])
    dphi_l, dphi_r = wl * dt, wr * dt
    true = robot.true_wheels
    travel_l = 0.5 * true.diameter_left_m * dphi_l
    travel_r = 0.5 * true.diameter_right_m * dphi_r
    if noise.slip_m_per_sqrt_m > 0 or noise.slip_right > 0:
        travel_l = travel_l + noise.slip_m_per_sqrt_m * np.sqrt(np.abs(travel_l)) * z[2]
        travel_r = travel_r + noise.slip_right * np.sqrt(np.abs(travel_r)) * z[3]
    left = np.concatenate([[0.0], np.cumsum(dphi_l)])
    right = np.concatenate([[0.0], np.cumsum(dphi_r)])
    if noise.quantise:
        step = 2.0 * math.pi / robot.nominal.pulses_per_wheel_rev
        left, right = np.floor(left / step + 1e-9) * step, np.floor(right / step + 1e-9) * step
    pose = integrate_wheels(travel_l, travel_r, true.wheelbase_m, p0)
    t = np.arange(K + 1) * dt
    return t, left, right, travel_l, travel_r, pose


def _drive_scans(
    robot: SimRobot,
    room: Room,
    t: np.ndarray,
    pose: np.ndarray,
    travel_l: np.ndarray,
    travel_r: np.ndarray,
    rate: float,
    scan_rate: float,
    scan_offset_s: float,
    lidar_seed: np.random.SeedSequence,
    engine: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lidar scans of a drive: their stamps, the exact true poses at them and their ranges."""
    K = t.size - 1
    true = robot.true_wheels
    n_scans = int(math.floor((t[-1] - scan_offset_s) * scan_rate + 1e-9)) + 1
    scan_t = scan_offset_s + np.arange(max(n_scans, 0)) / scan_rate
    k, f = _sample_of(scan_t, rate, K + 1)
    scan_pose = _pose_along(pose[k], f * travel_l[k], f * travel_r[k], true.wheelbase_m)
    sensor_world = compose(scan_pose, robot.sensor_pose.as_array())
    ranges = robot.lidar.scan(room, sensor_world, np.random.default_rng(lidar_seed), engine=engine)
    return scan_t, scan_pose, ranges


# ---------------------------------------------------------------- programs
def _path_points(robot: SimRobot, pose: np.ndarray, cmd: Command) -> np.ndarray:
    """The true noise-free poses along ``cmd`` from ``pose``, every :data:`_PLAN_DT_S` and at its end."""
    wl, wr = robot.wheel_rates(cmd.v_mps, cmd.omega_radps)
    k = max(1, math.ceil(cmd.duration_s / _PLAN_DT_S))
    tau = np.linspace(0.0, cmd.duration_s, k + 1)[1:]
    dl, dr, b = robot.true_motion(wl, wr, tau)
    return _pose_along(pose, dl, dr, b)


def _fits(room: Room, points: np.ndarray, clearance_m: float) -> bool:
    xy = points[:, :2]
    return bool(np.all(room.contains(xy)) and np.all(room.distance_to_walls(xy) >= clearance_m))


def _steps(duration_s: float, step_s: float) -> float:
    return max(1, round(duration_s / step_s)) * step_s


def _draw(kind: str, rng: np.random.Generator, step_s: float) -> Command:
    """A random command of one kind (durations in whole ``step_s``)."""
    if kind == "straight":
        if rng.random() < 0.2:  # one in five backwards, and shorter
            v = -rng.uniform(0.1, 0.25)
            length = rng.uniform(0.3, 1.0)
        else:
            v = rng.uniform(0.15, 0.4)
            length = rng.uniform(0.5, 3.0)
        return Command(_steps(length / abs(v), step_s), v, 0.0)
    if kind in ("arc+", "arc-"):
        v = rng.uniform(0.15, 0.35)
        omega = v / rng.uniform(0.4, 2.0) * (1.0 if kind == "arc+" else -1.0)
        return Command(_steps(math.radians(rng.uniform(30.0, 180.0)) / abs(omega), step_s), v, omega)
    if kind in ("spin+", "spin-"):
        omega = rng.uniform(0.4, 1.2) * (1.0 if kind == "spin+" else -1.0)
        return Command(_steps(math.radians(rng.uniform(45.0, 270.0)) / abs(omega), step_s), 0.0, omega)
    return Command(_steps(rng.uniform(0.3, 1.0), step_s), 0.0, 0.0)  # pause


_KINDS = ("straight", "arc+", "arc-", "spin+", "spin-")
_ROUND = _KINDS + ("pause",)


def mixed_program(
    duration_s: float = 120.0,
    seed: int = 0,
    *,
    robot: SimRobot = EXAMPLE_ROBOT,
    room: Room | None = None,
    start_pose: ArrayLike | None = None,
    clearance_m: float = 0.6,
    step_s: float = 0.1,
    attempts: int = 40,
) -> Program:
    """A random program of straights, arcs of both signs, spins both ways and pauses that stays in the room.

    Commands are drawn in rounds of six kinds (straight, left and right arc, spin either way,
    pause), each round in a random order. Each candidate is
    checked along the path ``robot`` would drive noise free (its TRUE geometry, from where the
    previous commands left it): it is kept only if the robot stays inside the room and at
    least ``clearance_m`` from every wall; else another of the same kind is drawn (then another
    kind). Straights: 0.5-3 m at 0.15-0.4 m/s (one in five backwards, 0.3-1 m); arcs: radius
    0.4-2 m, 30-180 degrees at 0.15-0.35 m/s; spins: 45-270 degrees at 0.4-1.2 rad/s; pauses
    0.3-1 s. Every duration is a whole number of ``step_s`` (by default the scan period, so
    each scan interval of a noise-free drive has constant wheel speeds); the last command is
    cut so the program lasts ``duration_s`` (rounded to ``step_s``).

    Parameters
    ----------
    duration_s : float
        Length of the program [s].
    seed : int
        Seed of the random choices.
    robot : SimRobot
        The robot it is planned for (its true geometry decides where it goes).
    room : Room, optional
        Default :meth:`Room.default`.
    start_pose : array_like, optional
        Default :func:`default_start`.
    clearance_m : float
        Least distance to any wall along the planned path [m].
    step_s : float
        The time grid of the durations [s].
    attempts : int
        Candidates drawn per kind before trying the next kind.

    Returns
    -------
    Program
        With its start pose.

    Raises
    ------
    InputError
        Bad arguments, a start closer than ``clearance_m`` to a wall, or no command of any kind
        fits where the robot is.
    """
    room = Room.default() if room is None else room
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"`duration_s` must be positive, got {duration_s!r}")
    _check_rate("step_s", step_s)
    if not (math.isfinite(clearance_m) and clearance_m >= 0):
        raise InputError(f"`clearance_m` must be >= 0, got {clearance_m!r}")
    start = np.asarray(default_start(room, clearance_m) if start_pose is None else start_pose, dtype=float)
    if start.shape != (3,) or not np.all(np.isfinite(start)):
        raise InputError("`start_pose` must be three finite numbers (x_m, y_m, yaw_rad)")
    if not _fits(room, start[None], clearance_m):
        raise InputError(f"`start_pose` is within {clearance_m:g} m of a wall or outside the room")
    rng = np.random.default_rng(seed)
    total = max(1, round(duration_s / step_s))
    used = 0
    pose = start.copy()
    commands: list[Command] = []
    queue: list[str] = []
    while used < total:
        if not queue:
            queue = [_ROUND[i] for i in rng.permutation(len(_ROUND))]
        first = queue.pop(0)
        chosen = None
        for kind in [first] + [k for k in _KINDS if k != first]:
            for _ in range(attempts):
                cmd = _draw(kind, rng, step_s)
                n = min(round(cmd.duration_s / step_s), total - used)
                cmd = Command(n * step_s, cmd.v_mps, cmd.omega_radps)
                points = _path_points(robot, pose, cmd)
                if _fits(room, points, clearance_m):
                    chosen = (cmd, n, points[-1])
                    break
            if chosen is not None:
                break
        if chosen is None:
            raise InputError(f"no command keeps the robot {clearance_m:g} m from the walls at {pose[:2].round(2)}")
        cmd, n, pose = chosen
        commands.append(cmd)
        used += n
    return Program(tuple(commands), (float(start[0]), float(start[1]), float(start[2])))


def _repeat(cycle: Sequence[Command], duration_s: float, step_s: float) -> Program:
    """``cycle`` repeated for ``duration_s``, durations in whole ``step_s``, the last command cut short."""
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"`duration_s` must be positive, got {duration_s!r}")
    _check_rate("step_s", step_s)
    steps = [max(1, round(c.duration_s / step_s)) for c in cycle]
    left = max(1, round(duration_s / step_s))
    out: list[Command] = []
    while left > 0:
        for c, n in zip(cycle, steps):
            n = min(n, left)
            if n == 0:
                break
            out.append(Command(n * step_s, c.v_mps, c.omega_radps))
            left -= n
    return Program(tuple(out))


def straight_only(
    duration_s: float = 60.0, speed_mps: float = 0.3, length_m: float = 2.0, step_s: float = 0.1
) -> Program:
    """Back and forth along a straight line: no turns, so the wheelbase is unobservable.

    Parameters
    ----------
    duration_s : float
        Length of the program [s].
    speed_mps : float
        Speed of each leg [m/s].
    length_m : float
        Length of each leg [m] (forward, then backward).
    step_s : float
        Every duration is rounded to a whole number of these [s].

    Returns
    -------
    Program

    Raises
    ------
    InputError
        If a parameter is not positive.
    """
    _check_rate("speed_mps", speed_mps)
    _check_rate("length_m", length_m)
    leg = length_m / speed_mps
    return _repeat([Command(leg, speed_mps), Command(leg, -speed_mps)], duration_s, step_s)


def spins_only(
    duration_s: float = 60.0, omega_radps: float = 0.8, angle_rad: float = 2.0 * math.pi, step_s: float = 0.1
) -> Program:
    """Spins on the spot, alternately counter-clockwise and clockwise: no translation.

    Parameters
    ----------
    duration_s : float
        Length of the program [s].
    omega_radps : float
        Turn rate [rad/s].
    angle_rad : float
        Angle of each spin [rad].
    step_s : float
        Every duration is rounded to a whole number of these [s].

    Returns
    -------
    Program

    Raises
    ------
    InputError
        If a parameter is not positive.
    """
    _check_rate("omega_radps", omega_radps)
    _check_rate("angle_rad", angle_rad)
    spin = angle_rad / omega_radps
    return _repeat([Command(spin, 0.0, omega_radps), Command(spin, 0.0, -omega_radps)], duration_s, step_s)


def one_way_turns(
    duration_s: float = 60.0,
    speed_mps: float = 0.25,
    radius_m: float = 1.0,
    omega_radps: float = 0.8,
    step_s: float = 0.1,
) -> Program:
    """Counter-clockwise turns only: a quarter arc, a quarter spin, repeated (a closed loop every two).

    Parameters
    ----------
    duration_s : float
        Length of the program [s].
    speed_mps : float
        Speed along the arcs [m/s].
    radius_m : float
        Radius of the arcs [m].
    omega_radps : float
        Turn rate of the spins [rad/s].
    step_s : float
        Every duration is rounded to a whole number of these [s].

    Returns
    -------
    Program

    Raises
    ------
    InputError
        If a parameter is not positive.
    """
    for name, v in (("speed_mps", speed_mps), ("radius_m", radius_m), ("omega_radps", omega_radps)):
        _check_rate(name, v)
    quarter = 0.5 * math.pi
    arc_cmd = Command(quarter * radius_m / speed_mps, speed_mps, speed_mps / radius_m)
    spin_cmd = Command(quarter / omega_radps, 0.0, omega_radps)
    return _repeat([arc_cmd, spin_cmd], duration_s, step_s)


def square_drive(
    direction: str,
    side_m: float = 2.0,
    *,
    speed_mps: float = 0.25,
    omega_radps: float = 0.5 * math.pi / 4.0,
    pause_s: float = 0.5,
    rest_s: float = 3.0,
) -> Program:
    """One UMBmark run: four legs of ``side_m`` and four on-the-spot 90 degree turns, at rest before and after.

    The robot rests ``rest_s`` seconds, then drives each leg and turns (to the right for
    ``cw``, to the left for ``ccw``), pausing ``pause_s`` seconds after every leg and turn
    but the last, and rests ``rest_s`` seconds at the end.

    Parameters
    ----------
    direction : str
        ``"cw"`` or ``"ccw"``.
    side_m : float
        The side of the square [m].
    speed_mps : float
        Speed along the legs [m/s].
    omega_radps : float
        Turn rate of the turns [rad/s].
    pause_s : float
        Stillness between a leg and its turn (0: none; keep it below the stillness that ends a run).
    rest_s : float
        Stillness before and after the run [s].

    Returns
    -------
    Program

    Raises
    ------
    InputError
        An unknown direction or a parameter that is not positive (``pause_s`` may be 0).
    """
    if direction not in ("cw", "ccw"):
        raise InputError(f"`direction` must be 'cw' or 'ccw', got {direction!r}")
    for name, v in (("side_m", side_m), ("speed_mps", speed_mps), ("omega_radps", omega_radps), ("rest_s", rest_s)):
        _check_rate(name, v)
    if not (math.isfinite(pause_s) and pause_s >= 0):
        raise InputError(f"`pause_s` must be >= 0, got {pause_s!r}")
    turn = -omega_radps if direction == "cw" else omega_radps
    out = [Command(rest_s)]
    for leg in range(4):
        out.append(Command(side_m / speed_mps, speed_mps, 0.0))
        if pause_s > 0:
            out.append(Command(pause_s))
        out.append(Command(0.5 * math.pi / omega_radps, 0.0, turn))
        if pause_s > 0 and leg < 3:
            out.append(Command(pause_s))
    out.append(Command(rest_s))
    return Program(tuple(out))


def concatenate_drives(logs: Sequence[DriveLog]) -> DriveLog:
    """Several drives of one robot as one log, as if the robot had been carried between them.

    Drive ``i + 1`` starts one wheel sample after drive ``i`` ended, at its own start pose (the
    wheels do not turn in between: the robot was lifted and put down at rest); the wheel angles
    continue from where they were. Each drive should end and start at rest.

    Parameters
    ----------
    logs : sequence of DriveLog
        Drives of the same robot, lidar and rates.

    Returns
    -------
    DriveLog
        Times, wheel angles, true poses and scans of all drives in order (seed and commands of
        the first drive).

    Raises
    ------
    InputError
        No drives, or drives of different robots, lidars or rates.
    """
    logs = list(logs)
    if not logs:
        raise InputError("no drives to concatenate")
    first = logs[0]
    for lg in logs[1:]:
        same = (
            lg.wheel_rate_hz == first.wheel_rate_hz
            and lg.scan_rate_hz == first.scan_rate_hz
            and lg.lidar == first.lidar
            and lg.sensor_pose == first.sensor_pose
            and lg.nominal_geometry == first.nominal_geometry
            and lg.true_geometry == first.true_geometry
        )
        if not same:
            raise InputError("drives to concatenate must have one robot, lidar and sampling rates")
    dt = 1.0 / first.wheel_rate_hz
    t: list[np.ndarray] = []
    left: list[np.ndarray] = []
    right: list[np.ndarray] = []
    scan_t: list[np.ndarray] = []
    tl: list[np.ndarray] = []
    tr: list[np.ndarray] = []
    t0, l0, r0 = 0.0, 0.0, 0.0
    for i, lg in enumerate(logs):
        if i:
            tl.append(np.zeros(1))
            tr.append(np.zeros(1))
        t.append(lg.t_s + t0)
        scan_t.append(lg.scan_t_s + t0)
        left.append(lg.left_rad + l0)
        right.append(lg.right_rad + r0)
        tl.append(lg.travel_left_m)
        tr.append(lg.travel_right_m)
        t0 = float(t[-1][-1]) + dt
        l0, r0 = float(left[-1][-1]), float(right[-1][-1])
    return DriveLog(
        t_s=np.concatenate(t),
        left_rad=np.concatenate(left),
        right_rad=np.concatenate(right),
        true_pose=np.concatenate([lg.true_pose for lg in logs]),
        travel_left_m=np.concatenate(tl),
        travel_right_m=np.concatenate(tr),
        scan_t_s=np.concatenate(scan_t),
        scan_pose=np.concatenate([lg.scan_pose for lg in logs]),
        ranges_m=np.concatenate([lg.ranges_m for lg in logs]),
        angles_rad=first.angles_rad,
        lidar=first.lidar,
        sensor_pose=first.sensor_pose,
        nominal_geometry=first.nominal_geometry,
        true_geometry=first.true_geometry,
        room=first.room,
        wheel_rate_hz=first.wheel_rate_hz,
        scan_rate_hz=first.scan_rate_hz,
        commands=tuple(c for lg in logs for c in lg.commands),
        seed=first.seed,
    )


def skid_steer_robot(
    track_m: float = 0.40,
    wheel_diameter_m: float = 0.20,
    factor: float = 1.6,
    *,
    ed: float = 1.0,
    sensor_pose: SensorPose | None = None,
    lidar: Lidar | None = None,
) -> SimRobot:
    """A skid-steer robot: its wheels slide sideways in every turn, so it turns as a differential
    drive with a wider wheelbase than its track (``factor`` times it, 1.5 to 2 for four-wheel
    skid-steer platforms on carpet or concrete).

    Its nominal geometry is what its drawing says (the track as wheelbase); its true effective
    wheelbase is ``factor x track`` (E_b = ``factor``): what ROS users set through
    ``wheel_separation_multiplier``.

    Parameters
    ----------
    track_m : float
        The distance between the left and right wheels [m].
    wheel_diameter_m : float
        The nominal wheel diameter [m].
    factor : float
        Effective wheelbase over track.
    ed : float
        E_d of the wheels.
    sensor_pose, lidar : optional
        The lidar and its mounting (default: centred, the default :class:`Lidar`).

    Returns
    -------
    SimRobot

    Raises
    ------
    InputError
        A size or factor that is not positive.
    """
    for name, v in (("track_m", track_m), ("wheel_diameter_m", wheel_diameter_m), ("factor", factor)):
        _check_rate(name, v)
    return SimRobot(
        nominal=Geometry(
            wheel_diameter_m=wheel_diameter_m, wheelbase_m=track_m, pulses_per_motor_rev=1024.0, gear_ratio=1.0
        ),
        errors=ErrorParams(ed=ed, eb=factor),
        sensor_pose=SensorPose() if sensor_pose is None else sensor_pose,
        lidar=Lidar() if lidar is None else lidar,
    )


def simulate_gyro(
    log: DriveLog, gyro: Gyro, seed: int | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The readings of a yaw-rate gyro on the robot during a drive (:meth:`Gyro.measure`).

    Parameters
    ----------
    log : DriveLog
        The drive.
    gyro : Gyro
        The gyro.
    seed : int, optional
        Seed of its noise (needed when it is noisy).

    Returns
    -------
    tuple of numpy.ndarray
        ``(t_s, rate_radps)``: reading times from ``1 / rate_hz`` to the end of the drive, and
        the readings.

    Raises
    ------
    InputError
        A noisy gyro without a seed, or a drive shorter than two gyro samples.
    """
    if seed is None and gyro.noise_radps > 0:
        raise InputError("a gyro with noise needs a `seed`")
    n = int(math.floor(log.duration_s * gyro.rate_hz + 1e-9))
    if n < 1:
        raise InputError("the drive is shorter than one gyro sample")
    t = np.arange(n + 1) / gyro.rate_hz
    yaw = log.true_pose_at(t)[:, 2]
    return gyro.measure(t, yaw, None if seed is None else np.random.default_rng(seed))
