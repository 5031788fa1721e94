"""Closed-loop simulator of a differential-drive robot with systematic and non-systematic errors.

Pure numpy: this module imports only numpy and the lower modules of :mod:`umbmark.model`.

The physical robot has true wheel diameters and a true wheelbase (from :class:`ErrorParams`);
its controller sees only its encoders and its *model* parameters (nominal, or a calibration).
It drives each segment of a path program until its own odometry says the segment is done:

* straight leg of length L: both wheels are commanded the same model wheel travel per sample
  (so the odometry's heading stays constant) until the odometry's travelled distance reaches L;
* on-the-spot turn through phi: the wheels are commanded opposite model travel until the
  odometry's heading change reaches phi.

The true robot moves with its true geometry (exact circular arcs per sample), so the
calculated end pose is near the nominal one while the true pose drifts.

Stops are exact (the last sample is shortened so the odometry lands exactly on the target)
unless the encoders are quantised, in which case the robot stops at the first sample whose
odometry reaches the target, as a real controller does. With no noise at all and
``sample_period_s=None`` every segment is one exact arc: the closed-loop model in closed form.

Every simulator (this vectorised one, :mod:`umbmark.model.batch` and the per-sample oracle
:mod:`umbmark.studies.reference`) plans a program with :func:`plan_program`. Everything here is
vectorised with numpy over runs (and robots: every per-run parameter may differ) and over
samples. Each run draws its noise from its own seeded generator, so a run's result does not
depend on the batch it is simulated in.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from umbmark.errors import InputError
from umbmark.model import odometry
from umbmark.model.geometry import (
    LABMATE,
    Calibration,
    ErrorParams,
    Geometry,
    OdometryParams,
    wrap_angle,
)
from umbmark.model.runs import RunsTable

__all__ = [
    "NoiseModel",
    "NOISE_PRESETS",
    "noise_preset",
    "Motion",
    "Segment",
    "square_program",
    "straight_program",
    "spin_program",
    "SegmentPlan",
    "plan_program",
    "MAX_SAMPLES_PER_RUN",
    "check_sample_count",
    "PARAM_KEYS",
    "per_run_params",
    "check_noise_inputs",
    "run_program",
    "SimResult",
    "simulate_umbmark",
    "simulate_runs",
    "run_seeds",
    "runs_table",
    "program_inputs",
    "child_seeds",
]


@dataclass(frozen=True)
class NoiseModel:
    """Non-systematic error sources; each one is off at zero.

    Parameters
    ----------
    name : str
        A label (the preset's name).
    slip_m_per_sqrt_m : float
        Random wheel slip. Each wheel's ground travel gets a zero-mean random error whose
        variance grows with the distance the wheel rolls (a random walk: standard deviation
        ``k * sqrt(travel)``), independent of the sampling period.
    bump_rate_per_m, bump_loss_m : float
        Discrete floor bumps (cracks, debris, cables). Each wheel meets bumps at this rate per
        metre rolled; at a bump the wheel turns more than the ground it covers, losing a
        horizontal travel uniform in [0, bump_loss_m].
    quantise : bool
        The encoders report whole pulses (the controller stops on them too).
    abs_xy_std_m, abs_theta_std_rad : float
        Error of the absolute measurement of the end pose (the paper's sonar calibrator:
        about 2 mm and 0.4 deg).

    Raises
    ------
    InputError
        If a parameter is negative or not finite.
    """

    name: str = "custom"
    slip_m_per_sqrt_m: float = 0.0
    bump_rate_per_m: float = 0.0
    bump_loss_m: float = 0.0
    quantise: bool = False
    abs_xy_std_m: float = 0.0
    abs_theta_std_rad: float = 0.0

    def __post_init__(self) -> None:
        for k in ("slip_m_per_sqrt_m", "bump_rate_per_m", "bump_loss_m", "abs_xy_std_m", "abs_theta_std_rad"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"noise parameter {k} must be >= 0, got {v!r}")

    @property
    def has_slip(self) -> bool:
        """True when the wheels slip."""
        return self.slip_m_per_sqrt_m > 0

    @property
    def has_bumps(self) -> bool:
        """True when the floor has bumps that cost travel."""
        return self.bump_rate_per_m > 0 and self.bump_loss_m > 0

    @property
    def moves_robot(self) -> bool:
        """True when the noise changes where the robot goes (not only what is measured)."""
        return self.has_slip or self.has_bumps or self.quantise

    @property
    def needs_rng(self) -> bool:
        """True when simulating with this noise draws random numbers."""
        return self.moves_robot or self.abs_xy_std_m > 0 or self.abs_theta_std_rad > 0


# The ``paper`` preset: chosen so that the per-run spread of return errors in one direction on
# the paper's 4 m square (LabMate, 0.2 m/s) is about sigma = 25 mm, as the paper reports
# (std as defined in umbmark.metrics). Measured with `python benchmarks/noise_preset.py`.
NOISE_PRESETS: dict[str, NoiseModel] = {
    "none": NoiseModel(name="none"),
    "paper": NoiseModel(
        name="paper",
        slip_m_per_sqrt_m=3.35e-4,
        bump_rate_per_m=0.5,
        bump_loss_m=0.5e-3,
        quantise=True,
        abs_xy_std_m=2e-3,
        abs_theta_std_rad=math.radians(0.4),
    ),
}


def noise_preset(name: str) -> NoiseModel:
    """The noise model of a preset.

    Parameters
    ----------
    name : str
        A key of :data:`NOISE_PRESETS` (``"none"``, ``"paper"``).

    Returns
    -------
    NoiseModel

    Raises
    ------
    InputError
        On an unknown name.

    Examples
    --------
    >>> paper = noise_preset("paper")
    >>> paper.slip_m_per_sqrt_m, paper.quantise, paper.needs_rng, noise_preset("none").needs_rng
    (0.000335, True, True, False)
    """
    try:
        return NOISE_PRESETS[name]
    except KeyError:
        raise InputError(f"unknown noise preset {name!r} (choose from {', '.join(NOISE_PRESETS)})") from None


# an odometry sampling its wheels less often than this (seconds) is not simulated
MAX_SAMPLE_PERIOD_S = 1.0


@dataclass(frozen=True)
class Motion:
    """Speeds and sampling of the controller.

    The paper: 0.2 m/s on the legs, wheels at +-0.2 m/s in turns, sampling period below 10 ms.

    Parameters
    ----------
    speed_m_s : float
        Speed on straight legs [m/s].
    turn_wheel_speed_m_s : float
        Speed of each wheel in on-the-spot turns [m/s].
    sample_period_s : float or None
        Sampling period [s]; ``None``: one exact step per segment (allowed only when no
        noise moves the robot).

    Raises
    ------
    InputError
        If a speed or the period is not positive and finite.
    """

    speed_m_s: float = 0.2
    turn_wheel_speed_m_s: float = 0.2
    sample_period_s: float | None = 0.01

    def __post_init__(self) -> None:
        for k in ("speed_m_s", "turn_wheel_speed_m_s"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{k} must be positive, got {v!r}")
        if self.sample_period_s is not None and not (math.isfinite(self.sample_period_s) and self.sample_period_s > 0):
            raise InputError(f"sample_period_s must be positive, got {self.sample_period_s!r}")
        if self.sample_period_s is not None and self.sample_period_s > MAX_SAMPLE_PERIOD_S:
            raise InputError(
                f"a sample period of {self.sample_period_s:g} s: an odometry samples its wheels at least once a "
                f"second (at most {MAX_SAMPLE_PERIOD_S:g} s): milliseconds and seconds mixed up?"
            )


@dataclass(frozen=True)
class Segment:
    """One closed-loop motion of a path program.

    Parameters
    ----------
    kind : str
        ``"straight"`` or ``"turn"`` (on the spot).
    amount : float
        Metres (> 0) for a straight, radians (counter-clockwise positive, not 0) for a turn.

    Raises
    ------
    InputError
        On an unknown kind or a bad amount.
    """

    kind: str
    amount: float

    def __post_init__(self) -> None:
        if self.kind not in ("straight", "turn"):
            raise InputError(f"unknown segment kind {self.kind!r}")
        if not math.isfinite(self.amount) or (self.kind == "straight" and self.amount <= 0) or self.amount == 0:
            raise InputError(f"bad {self.kind} amount {self.amount!r}")


def square_program(direction: str, side_m: float, turns: int = 4) -> tuple[Segment, ...]:
    """The UMBmark square.

    Parameters
    ----------
    direction : str
        ``"cw"`` (turns to the right) or ``"ccw"`` (to the left).
    side_m : float
        Side of the square [m].
    turns : int
        The first ``turns`` legs are followed by an on-the-spot 90 deg turn (4: the fourth
        turn at the end).

    Returns
    -------
    tuple of Segment

    Raises
    ------
    InputError
        On an unknown direction or a non-positive side.

    Examples
    --------
    A clockwise square: four legs, each followed by a quarter turn to the right.

    >>> [(s.kind, round(s.amount, 4)) for s in square_program("cw", 4.0)][:2]
    [('straight', 4.0), ('turn', -1.5708)]
    >>> len(square_program("ccw", 4.0)), len(square_program("ccw", 4.0, turns=3))
    (8, 7)
    """
    if direction not in ("cw", "ccw"):
        raise InputError(f"direction must be 'cw' or 'ccw', got {direction!r}")
    if not (math.isfinite(side_m) and side_m > 0):
        raise InputError(f"side must be positive, got {side_m!r}")
    turn = Segment("turn", -math.pi / 2 if direction == "cw" else math.pi / 2)
    segs: list[Segment] = []
    for i in range(4):
        segs.append(Segment("straight", side_m))
        if i < turns:
            segs.append(turn)
    return tuple(segs)


def straight_program(length_m: float) -> tuple[Segment, ...]:
    """One straight leg of ``length_m`` metres.

    Parameters
    ----------
    length_m : float
        Length [m], > 0.

    Returns
    -------
    tuple of Segment
    """
    return (Segment("straight", length_m),)


def spin_program(angle_rad: float) -> tuple[Segment, ...]:
    """One on-the-spot turn through ``angle_rad`` (counter-clockwise positive).

    Parameters
    ----------
    angle_rad : float
        Turn [rad], not 0.

    Returns
    -------
    tuple of Segment
    """
    return (Segment("turn", angle_rad),)


@dataclass
class SimResult:
    """Outcome of a batch of runs, SI units, arrays of shape (R,).

    Parameters
    ----------
    true_x, true_y, true_theta : numpy.ndarray
        Where the robot really is.
    odo_x, odo_y, odo_theta : numpy.ndarray
        What its odometry reports.
    abs_x, abs_y, abs_theta : numpy.ndarray
        The absolute measurement of the true pose (true plus measurement noise).
    trajectory : dict or None
        When asked for: (R, K) arrays ``true_x, true_y, true_theta, odo_x, odo_y, odo_theta``.
    """

    true_x: np.ndarray
    true_y: np.ndarray
    true_theta: np.ndarray
    odo_x: np.ndarray
    odo_y: np.ndarray
    odo_theta: np.ndarray
    abs_x: np.ndarray
    abs_y: np.ndarray
    abs_theta: np.ndarray
    trajectory: dict | None = field(default=None, repr=False)


def program_inputs(
    program: Iterable[Segment], noise: NoiseModel | None, motion: Motion | None
) -> tuple[tuple[Segment, ...], NoiseModel, Motion]:
    """The common inputs of every simulator, with their defaults.

    Parameters
    ----------
    program : iterable of Segment
        The path program.
    noise : NoiseModel or None
        ``None``: no noise.
    motion : Motion or None
        ``None``: the paper's speeds and sampling.

    Returns
    -------
    tuple
        ``(program, noise, motion)``, the program as a non-empty tuple.

    Raises
    ------
    InputError
        On an empty program.
    """
    program = tuple(program)
    if not program:
        raise InputError("empty path program")
    return program, noise or NOISE_PRESETS["none"], motion or Motion()


def child_seeds(seed: int | np.random.SeedSequence, n: int) -> list[np.random.SeedSequence]:
    """The first ``n`` children of ``seed``, the same on every call.

    ``SeedSequence.spawn`` counts its calls (a second call gives new children), so a seed
    object passed twice would give two different simulations; this does not (it equals the
    first ``spawn(n)`` of a fresh copy).

    Parameters
    ----------
    seed : int or numpy.random.SeedSequence
        The root seed.
    n : int
        Number of children.

    Returns
    -------
    list of numpy.random.SeedSequence
    """
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return [
        np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (i,), pool_size=ss.pool_size)
        for i in range(n)
    ]


def run_seeds(seed: int | np.random.SeedSequence, n: int) -> list[np.random.Generator]:
    """``n`` independent generators from one seed (run i always gets the same stream).

    Parameters
    ----------
    seed : int or numpy.random.SeedSequence
        The root seed.
    n : int
        Number of runs.

    Returns
    -------
    list of numpy.random.Generator
    """
    return [np.random.default_rng(s) for s in child_seeds(seed, n)]


MAX_SAMPLES_PER_RUN = 5_000_000  # 14 h of driving at 10 ms: beyond it the inputs are wrong


def check_sample_count(samples_per_run: np.ndarray, motion: Motion) -> None:
    """Refuse a program that would need more than :data:`MAX_SAMPLES_PER_RUN` samples in a run.

    A side in metres given in micrometres, a speed near zero, a sample period of nanoseconds:
    the simulation would exhaust memory or never end.

    Parameters
    ----------
    samples_per_run : numpy.ndarray
        Samples each run needs.
    motion : Motion
        The motion (named in the message).

    Raises
    ------
    InputError
        If a run needs too many samples.
    """
    n = int(np.max(samples_per_run))
    if n > MAX_SAMPLES_PER_RUN:
        raise InputError(
            f"a run would need {n:,} samples (more than {MAX_SAMPLES_PER_RUN:,}): check the side length, "
            f"wheelbase, speed ({motion.speed_m_s:g} m/s) and sample period ({motion.sample_period_s:g} s)"
        )


PARAM_KEYS = ("left_m_per_pulse", "right_m_per_pulse", "wheelbase_m")
"""The fields of :class:`OdometryParams`, the keys of the per-run parameter dicts."""


def per_run_params(
    per_run: dict | None, base: OdometryParams | None, n_runs: int, name: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The odometry parameters of every run: one array (R,) per :data:`PARAM_KEYS` entry.

    Parameters
    ----------
    per_run : dict or None
        Arrays (R,) or scalars by key, overriding ``base``.
    base : OdometryParams or None
        The parameters of runs without an entry in ``per_run``.
    n_runs : int
        R.
    name : str
        ``"true"`` or ``"model"`` (named in messages).

    Returns
    -------
    tuple of numpy.ndarray
        ``(left_m_per_pulse, right_m_per_pulse, wheelbase_m)``, each (R,).

    Raises
    ------
    InputError
        If a parameter is missing, not positive or not finite.
    """
    per_run = per_run or {}
    out = []
    for k in PARAM_KEYS:
        v = per_run.get(k, getattr(base, k) if base is not None else None)
        if v is None:
            raise InputError(f"{name} robot parameter {k} is missing")
        out.append(np.array(np.broadcast_to(np.asarray(v, dtype=float), (n_runs,))))
    both = np.concatenate(out)
    if not np.all(np.isfinite(both) & (both > 0)):
        raise InputError(f"{name} robot parameters must be positive and finite")
    return out[0], out[1], out[2]


def check_noise_inputs(noise: NoiseModel, motion: Motion, rngs: Sequence | None, n_runs: int) -> None:
    """Refuse noise the motion cannot simulate, or noise without one generator per run.

    Parameters
    ----------
    noise : NoiseModel
        The noise.
    motion : Motion
        The motion (its sampling period).
    rngs : sequence of numpy.random.Generator or None
        The generators given.
    n_runs : int
        R.

    Raises
    ------
    InputError
        When noise moves the robot without a sampling period, or ``rngs`` does not hold one
        generator per run while the noise draws random numbers.
    """
    if motion.sample_period_s is None and noise.moves_robot:
        raise InputError("a sampling period is needed when noise moves the robot (slip, bumps, quantisation)")
    if noise.needs_rng and (rngs is None or len(rngs) != n_runs):
        raise InputError("one random generator per run is needed when there is noise")


@dataclass(frozen=True)
class SegmentPlan:
    """How the controller drives each segment of a program, for every run.

    Arrays of shape (S,) hold what depends on the segment only; arrays (R, S) what depends on
    the run's model parameters too.

    Parameters
    ----------
    kind : numpy.ndarray
        (S,) int: 0 for a straight, 1 for a turn.
    sign_left, sign_right : numpy.ndarray
        (S,) sign of the commanded travel of each wheel.
    target : numpy.ndarray
        (S,) what the odometry must reach: distance [m] or absolute heading change [rad].
    step : numpy.ndarray
        (R, S) model wheel travel commanded per sample [m] (without a sampling period: the
        whole segment in one step).
    n_full : numpy.ndarray
        (R, S) int: full samples before the last, shortened one.
    frac : numpy.ndarray
        (R, S) the fraction of ``step`` in that last sample (0: none).
    samples : numpy.ndarray
        (R, S) int: samples reserved for the segment (quantised encoders: with a margin for
        the odometry's lag of up to one pulse per wheel).
    """

    kind: np.ndarray
    sign_left: np.ndarray
    sign_right: np.ndarray
    target: np.ndarray
    step: np.ndarray
    n_full: np.ndarray
    frac: np.ndarray
    samples: np.ndarray


def plan_program(
    program: Sequence[Segment],
    motion: Motion,
    noise: NoiseModel,
    m_l: np.ndarray,
    m_r: np.ndarray,
    m_b: np.ndarray,
) -> SegmentPlan:
    """Plan every segment of ``program`` for every run: the planner all simulators share.

    A straight needs its length of model wheel travel on both wheels; a turn through phi
    needs ``phi / (2 / b_model)`` of opposite travel. At ``step`` per sample that is
    ``n_full`` full samples and a last sample of ``frac`` steps (ratios within 1e-12 of a
    whole number count as whole; fractions below 1e-9 are dropped).

    Parameters
    ----------
    program : sequence of Segment
        The path program (S segments).
    motion : Motion
        Speeds and sampling period.
    noise : NoiseModel
        The noise (quantised encoders reserve extra samples).
    m_l, m_r, m_b : numpy.ndarray
        (R,) the model odometry of each run: metres per pulse of each wheel, wheelbase.

    Returns
    -------
    SegmentPlan

    Raises
    ------
    InputError
        If a run would need more than :data:`MAX_SAMPLES_PER_RUN` samples.
    """
    R, S = np.size(m_b), len(program)
    dt = motion.sample_period_s
    kind = np.zeros(S, dtype=np.int64)
    sign_l = np.zeros(S)
    sign_r = np.zeros(S)
    target = np.zeros(S)
    step = np.zeros((R, S))
    n_full = np.zeros((R, S), dtype=np.int64)
    frac = np.zeros((R, S))
    samples = np.zeros((R, S), dtype=np.int64)
    for j, seg in enumerate(program):
        if seg.kind == "straight":
            st = motion.speed_m_s * dt if dt is not None else None
            sign_l[j] = sign_r[j] = 1.0
            target[j] = seg.amount
            need = np.full(R, seg.amount)
        else:
            kind[j] = 1
            st = motion.turn_wheel_speed_m_s * dt if dt is not None else None
            s = 1.0 if seg.amount > 0 else -1.0
            sign_l[j], sign_r[j] = -s, s
            target[j] = abs(seg.amount)
            need = target[j] / (2.0 / m_b)  # heading change per metre of opposite wheel travel: 2 / b
        if st is None:  # one step covering the whole segment
            step[:, j] = need
            frac[:, j] = 1.0
            samples[:, j] = 1
            continue
        step[:, j] = st
        ratio = need / st
        nf = np.floor(ratio + 1e-12).astype(np.int64)
        fr = np.clip(ratio - nf, 0.0, None)
        fr[fr < 1e-9] = 0.0
        # quantised odometry lags the commanded travel by at most one pulse per wheel
        margin = (np.ceil(np.maximum(m_l, m_r) / st).astype(np.int64) + 2) if noise.quantise else 0
        n_full[:, j] = nf
        frac[:, j] = fr
        samples[:, j] = nf + (fr > 0) + margin
    check_sample_count(samples.sum(axis=1), motion)
    return SegmentPlan(kind, sign_l, sign_r, target, step, n_full, frac, samples)


@dataclass
class _Draws:
    """The random numbers of a batch, laid out like the samples (2 wheels, R runs, K samples)."""

    slip: np.ndarray | None  # (2, R, K) standard normal
    bump_u: np.ndarray | None  # (2, R, K) uniform: a bump when below rate x travel
    bump_loss: np.ndarray | None  # (2, R, K) uniform: the fraction of bump_loss_m lost
    phase: np.ndarray | None  # (2, R) encoder phase at the start (pulses)
    abs_noise: np.ndarray  # (3, R) standard normal: the absolute measurement


def _segment_columns(plan: SegmentPlan) -> np.ndarray:
    """Column offsets of the segments (S + 1,): segment j owns the columns offs[j]..offs[j+1]."""
    return np.concatenate([[0], np.cumsum(plan.samples.max(axis=0))]).astype(np.int64)


def _draw(noise: NoiseModel, plan: SegmentPlan, offs: np.ndarray, rngs) -> _Draws:
    """Each run's noise from its own generator, in the order that defines the simulator: slip,
    bump uniforms, bump losses (each (2, samples of the run)), encoder phase, measurement."""
    R = plan.samples.shape[0]
    K = int(offs[-1])
    d = _Draws(
        np.zeros((2, R, K)) if noise.has_slip else None,
        np.ones((2, R, K)) if noise.has_bumps else None,
        np.zeros((2, R, K)) if noise.has_bumps else None,
        np.zeros((2, R)) if noise.quantise else None,
        np.zeros((3, R)),
    )
    if not noise.needs_rng:
        return d
    for r in range(R):
        g = rngs[r]
        lens = [int(n) for n in plan.samples[r]]
        tot = sum(lens)
        slip = g.standard_normal((2, tot)) if d.slip is not None else None
        bu = g.random((2, tot)) if d.bump_u is not None else None
        bl = g.random((2, tot)) if d.bump_loss is not None else None
        if d.phase is not None:
            d.phase[:, r] = g.random(2)
        d.abs_noise[:, r] = g.standard_normal(3)
        pos = 0
        for j, n in enumerate(lens):
            sl = slice(offs[j], offs[j] + n)
            if d.slip is not None and slip is not None:
                d.slip[:, r, sl] = slip[:, pos : pos + n]
            if d.bump_u is not None and d.bump_loss is not None and bu is not None and bl is not None:
                d.bump_u[:, r, sl] = bu[:, pos : pos + n]
                d.bump_loss[:, r, sl] = bl[:, pos : pos + n]
            pos += n
    return d


def _drive(plan: SegmentPlan, offs: np.ndarray, noise: NoiseModel, m_l, m_r, m_b, phase):
    """The closed loop, segment by segment: per sample the wheel rotation (in pulses,
    continuous) and the travel the odometry sees, arrays (R, K) ``rot_l, rot_r, odo_l, odo_r``."""
    R, K = plan.samples.shape[0], int(offs[-1])
    odo_l = np.zeros((R, K))
    odo_r = np.zeros((R, K))
    rot_l = np.zeros((R, K))
    rot_r = np.zeros((R, K))
    cont = phase.copy() if phase is not None else None  # continuous encoder position (pulses)
    for j in range(len(plan.kind)):
        kj = int(offs[j + 1] - offs[j])
        cols = slice(offs[j], offs[j] + kj)
        idx = np.arange(kj)[None, :]
        # pulses per step of each wheel (continuous), commanded from model travel
        p_l = (plan.sign_left[j] * plan.step[:, j] / m_l)[:, None]
        p_r = (plan.sign_right[j] * plan.step[:, j] / m_r)[:, None]
        if cont is None:
            n_full, frac = plan.n_full[:, j], plan.frac[:, j]
            mult = (idx < n_full[:, None]).astype(float) + (idx == n_full[:, None]) * frac[:, None]
            rot_l[:, cols] = p_l * mult
            rot_r[:, cols] = p_r * mult
            odo_l[:, cols] = rot_l[:, cols] * m_l[:, None]
            odo_r[:, cols] = rot_r[:, cols] * m_r[:, None]
            continue
        c_l = cont[0][:, None] + p_l * (idx + 1)
        c_r = cont[1][:, None] + p_r * (idx + 1)
        q_l = np.floor(c_l) - np.floor(cont[0])[:, None]
        q_r = np.floor(c_r) - np.floor(cont[1])[:, None]
        if plan.kind[j] == 0:
            prog = 0.5 * (q_l * m_l[:, None] + q_r * m_r[:, None])
        else:
            prog = np.abs(q_r * m_r[:, None] - q_l * m_l[:, None]) / m_b[:, None]
        reached = prog >= plan.target[j] - 1e-12
        if not np.all(reached[:, -1]):
            raise RuntimeError("internal: quantised segment did not reach its target")  # pragma: no cover
        stop = np.argmax(reached, axis=1)  # index of the stopping sample
        live = idx <= stop[:, None]
        rot_l[:, cols] = np.where(live, p_l, 0.0)
        rot_r[:, cols] = np.where(live, p_r, 0.0)
        dq_l = np.diff(np.concatenate([np.zeros((R, 1)), q_l], axis=1), axis=1)
        dq_r = np.diff(np.concatenate([np.zeros((R, 1)), q_r], axis=1), axis=1)
        odo_l[:, cols] = np.where(live, dq_l, 0.0) * m_l[:, None]
        odo_r[:, cols] = np.where(live, dq_r, 0.0) * m_r[:, None]
        cont[0] += p_l[:, 0] * (stop + 1)
        cont[1] += p_r[:, 0] * (stop + 1)
    return rot_l, rot_r, odo_l, odo_r


def _ground_travel(rot_l, rot_r, t_l, t_r, noise: NoiseModel, draws: _Draws):
    """True ground travel per sample: rotation times true metres per pulse, minus slip and bumps."""
    g_l = rot_l * t_l[:, None]
    g_r = rot_r * t_r[:, None]
    if draws.slip is not None or draws.bump_u is not None:
        for w, g in ((0, g_l), (1, g_r)):
            travel = np.abs(g)
            err = np.zeros_like(g)
            if draws.slip is not None:
                err += noise.slip_m_per_sqrt_m * np.sqrt(travel) * draws.slip[w]
            if draws.bump_u is not None and draws.bump_loss is not None:
                hit = draws.bump_u[w] < noise.bump_rate_per_m * travel
                err -= np.sign(g) * np.minimum(hit * noise.bump_loss_m * draws.bump_loss[w], travel)
            g += err
    return g_l, g_r


def run_program(
    program: Iterable[Segment],
    true: OdometryParams | None,
    model: OdometryParams | None,
    n_runs: int | None = None,
    noise: NoiseModel | None = None,
    motion: Motion | None = None,
    rngs: Sequence[np.random.Generator] | None = None,
    trajectory: bool = False,
    true_per_run: dict | None = None,
    model_per_run: dict | None = None,
) -> SimResult:
    """Drive ``program`` closed-loop ``n_runs`` times.

    Parameters
    ----------
    program : iterable of Segment
        The path program.
    true : OdometryParams or None
        The physical robot: metres of ground travel per pulse, true wheelbase.
    model : OdometryParams or None
        What the controller's odometry uses.
    n_runs : int, optional
        R (default: one per generator in ``rngs``, else 1).
    noise : NoiseModel, optional
        Default: none.
    motion : Motion, optional
        Default: the paper's.
    rngs : sequence of numpy.random.Generator, optional
        One generator per run (see :func:`run_seeds`); needed when there is noise.
    trajectory : bool
        Also return every pose (:attr:`SimResult.trajectory`).
    true_per_run, model_per_run : dict, optional
        For batches of different robots: arrays (R,) by key of :data:`PARAM_KEYS`,
        overriding ``true`` / ``model``.

    Returns
    -------
    SimResult

    Raises
    ------
    InputError
        On bad parameters (see :func:`per_run_params`, :func:`check_noise_inputs`,
        :func:`plan_program`).
    """
    program, noise, motion = program_inputs(program, noise, motion)
    if n_runs is None:
        n_runs = len(rngs) if rngs is not None else 1
    if n_runs < 1:
        raise InputError(f"number of runs must be >= 1, got {n_runs}")
    t_l, t_r, t_b = per_run_params(true_per_run, true, n_runs, "true")
    m_l, m_r, m_b = per_run_params(model_per_run, model, n_runs, "model")
    check_noise_inputs(noise, motion, rngs, n_runs)
    plan = plan_program(program, motion, noise, m_l, m_r, m_b)
    offs = _segment_columns(plan)
    draws = _draw(noise, plan, offs, rngs)
    rot_l, rot_r, odo_l, odo_r = _drive(plan, offs, noise, m_l, m_r, m_b, draws.phase)
    g_l, g_r = _ground_travel(rot_l, rot_r, t_l, t_r, noise, draws)
    traj = None
    if trajectory:
        tx, ty, tth = odometry.integrate(g_l, g_r, t_b, kernel="trig")
        ox, oy, oth = odometry.integrate(odo_l, odo_r, m_b, kernel="trig")
        traj = dict(true_x=tx, true_y=ty, true_theta=tth, odo_x=ox, odo_y=oy, odo_theta=oth)
        true_end = (tx[:, -1], ty[:, -1], tth[:, -1])
        odo_end = (ox[:, -1], oy[:, -1], oth[:, -1])
    else:
        true_end = odometry.integrate_end(g_l, g_r, t_b, kernel="trig")
        odo_end = odometry.integrate_end(odo_l, odo_r, m_b, kernel="trig")
    absn = draws.abs_noise
    ax = true_end[0] + noise.abs_xy_std_m * absn[0]
    ay = true_end[1] + noise.abs_xy_std_m * absn[1]
    ath = true_end[2] + noise.abs_theta_std_rad * absn[2]
    return SimResult(*true_end, *odo_end, ax, ay, ath, trajectory=traj)


def simulate_runs(
    direction: str,
    n_runs: int,
    errors: ErrorParams,
    geometry: Geometry = LABMATE,
    side_m: float = 4.0,
    calibration: Calibration | None = None,
    noise: NoiseModel | str = "none",
    motion: Motion | None = None,
    seed: int | np.random.SeedSequence = 0,
    trajectory: bool = False,
) -> SimResult:
    """``n_runs`` square runs in one direction of one robot.

    Parameters
    ----------
    direction : str
        ``"cw"`` or ``"ccw"``.
    n_runs : int
        Number of runs.
    errors : ErrorParams
        The robot's systematic errors.
    geometry : Geometry
        Its nominal geometry.
    side_m : float
        Side of the square [m].
    calibration : Calibration, optional
        What its odometry runs with (None: nominal).
    noise : NoiseModel or str
        A noise model or the name of a preset.
    motion : Motion, optional
        Default: the paper's.
    seed : int or numpy.random.SeedSequence
        Run i uses the i-th child of ``seed`` (:func:`run_seeds`).
    trajectory : bool
        Also return every pose.

    Returns
    -------
    SimResult
    """
    if isinstance(noise, str):
        noise = noise_preset(noise)
    true = errors.true_params(geometry)
    model = OdometryParams.from_geometry(geometry, calibration)
    return run_program(
        square_program(direction, side_m),
        true,
        model,
        n_runs,
        noise,
        motion,
        rngs=run_seeds(seed, n_runs),
        trajectory=trajectory,
    )


def simulate_umbmark(
    errors: ErrorParams,
    geometry: Geometry = LABMATE,
    side_m: float = 4.0,
    n_runs: int = 5,
    calibration: Calibration | None = None,
    noise: NoiseModel | str = "none",
    motion: Motion | None = None,
    seed: int | np.random.SeedSequence = 0,
) -> RunsTable:
    """The bi-directional square test: ``n_runs`` cw runs and ``n_runs`` ccw runs.

    Parameters
    ----------
    errors : ErrorParams
        The robot's systematic errors.
    geometry : Geometry
        Its nominal geometry.
    side_m : float
        Side of the square [m].
    n_runs : int
        Runs per direction.
    calibration : Calibration, optional
        What its odometry runs with (None: nominal).
    noise : NoiseModel or str
        A noise model or the name of a preset.
    motion : Motion, optional
        Default: the paper's.
    seed : int or numpy.random.SeedSequence
        The cw runs use the first child seed of ``seed``, the ccw runs the second.

    Returns
    -------
    RunsTable
        The runs, SI units.

    Examples
    --------
    A robot without errors and without noise returns to where its odometry says it did (the
    return errors, absolute minus odometry, vanish):

    >>> runs = simulate_umbmark(ErrorParams(), n_runs=1)
    >>> print(runs.direction, np.allclose(runs.eps_x, 0), np.allclose(runs.eps_y, 0))
    ['cw' 'ccw'] True True

    A right wheel 0.2 % larger (E_d > 1) bends every leg to the left: the two directions end
    on opposite sides in x, on the same side in y (mm):

    >>> runs = simulate_umbmark(ErrorParams(ed=1.002), n_runs=1)
    >>> print(np.round(runs.eps_x * 1e3, 1), np.round(runs.eps_y * 1e3, 1))
    [-181.1  194.3] [-199.  -176.9]

    A wheelbase 1 % longer (E_b > 1) turns every corner short: the same side in x, opposite
    sides in y:

    >>> runs = simulate_umbmark(ErrorParams(eb=1.01), n_runs=1)
    >>> print(np.round(runs.eps_x * 1e3, 1), np.round(runs.eps_y * 1e3, 1))
    [-122.4 -122.4] [-128.3  128.3]

    The paper's robot of Fig. 11 before calibration: the larger of the two directions' return
    errors is about the 317 mm measured.

    >>> from umbmark.model.geometry import FIG11_ERRORS
    >>> runs = simulate_umbmark(FIG11_ERRORS, n_runs=1)
    >>> round(float(np.hypot(runs.eps_x, runs.eps_y).max()) * 1e3)
    311
    """
    cw_ss, ccw_ss = child_seeds(seed, 2)
    parts = []
    for direction, s in (("cw", cw_ss), ("ccw", ccw_ss)):
        res = simulate_runs(direction, n_runs, errors, geometry, side_m, calibration, noise, motion, seed=s)
        parts.append((direction, res))
    return runs_table(parts, n_runs)


def runs_table(parts: Sequence[tuple[str, SimResult]], n_runs: int) -> RunsTable:
    """A :class:`RunsTable` of simulated runs.

    Parameters
    ----------
    parts : sequence of (str, SimResult)
        ``[("cw", result), ("ccw", result)]``, ``n_runs`` runs each.
    n_runs : int
        Runs per part.

    Returns
    -------
    RunsTable
        The absolute measurement and the odometry end pose of every run, headings wrapped.
    """

    def cat(attr):
        return np.concatenate([getattr(r, attr) for _, r in parts])

    return RunsTable.from_columns(
        direction=np.array([d for d, _ in parts for _ in range(n_runs)]),
        x_abs=cat("abs_x"),
        y_abs=cat("abs_y"),
        x_odo=cat("odo_x"),
        y_odo=cat("odo_y"),
        theta_abs=wrap_angle(cat("abs_theta")),
        theta_odo=wrap_angle(cat("odo_theta")),
        run=np.concatenate([np.arange(1, n_runs + 1)] * len(parts)),
    )
