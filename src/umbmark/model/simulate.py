"""Closed-loop simulator of a differential-drive robot with systematic and non-systematic errors.

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

Everything is vectorised with numpy over runs (and robots: every per-run parameter may
differ) and over samples. Each run draws its noise from its own seeded generator, so a run's
result does not depend on the batch it is simulated in.
"""

from __future__ import annotations

import math
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

    * ``slip_m_per_sqrt_m``: random wheel slip. Each wheel's ground travel gets a zero-mean
      random error whose variance grows with the distance the wheel rolls (a random walk:
      standard deviation ``k * sqrt(travel)``), independent of the sampling period.
    * ``bump_rate_per_m``, ``bump_loss_m``: discrete floor bumps (cracks, debris, cables).
      Each wheel meets bumps at this rate per metre rolled; at a bump the wheel turns more
      than the ground it covers, losing a horizontal travel uniform in [0, bump_loss_m].
    * ``quantise``: the encoders report whole pulses (the controller stops on them too).
    * ``abs_xy_std_m``, ``abs_theta_std_rad``: error of the absolute measurement of the end
      pose (the paper's sonar calibrator: about 2 mm and 0.4 deg).
    """

    name: str = "custom"
    slip_m_per_sqrt_m: float = 0.0
    bump_rate_per_m: float = 0.0
    bump_loss_m: float = 0.0
    quantise: bool = False
    abs_xy_std_m: float = 0.0
    abs_theta_std_rad: float = 0.0

    def __post_init__(self):
        for k in ("slip_m_per_sqrt_m", "bump_rate_per_m", "bump_loss_m", "abs_xy_std_m", "abs_theta_std_rad"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"noise parameter {k} must be >= 0, got {v!r}")

    @property
    def moves_robot(self) -> bool:
        """True when the noise changes where the robot goes (not only what is measured)."""
        return self.slip_m_per_sqrt_m > 0 or (self.bump_rate_per_m > 0 and self.bump_loss_m > 0) or self.quantise


# The ``paper`` preset: chosen so that the per-run spread of return errors in one direction on
# the paper's 4 m square (LabMate, 0.2 m/s) is about sigma = 25 mm, as the paper reports
# (std as defined in benchmark.py). Measured with `python benchmarks/noise_preset.py`.
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
    try:
        return NOISE_PRESETS[name]
    except KeyError:
        raise InputError(f"unknown noise preset {name!r} (choose from {', '.join(NOISE_PRESETS)})") from None


@dataclass(frozen=True)
class Motion:
    """Speeds and sampling. The paper: 0.2 m/s on the legs, wheels at +-0.2 m/s in turns,
    sampling period below 10 ms. ``sample_period_s=None``: one exact step per segment
    (allowed only when no noise moves the robot)."""

    speed_m_s: float = 0.2
    turn_wheel_speed_m_s: float = 0.2
    sample_period_s: float | None = 0.01

    def __post_init__(self):
        for k in ("speed_m_s", "turn_wheel_speed_m_s"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{k} must be positive, got {v!r}")
        if self.sample_period_s is not None and not (math.isfinite(self.sample_period_s) and self.sample_period_s > 0):
            raise InputError(f"sample_period_s must be positive, got {self.sample_period_s!r}")


@dataclass(frozen=True)
class Segment:
    """One closed-loop motion: ``straight`` (amount: metres, > 0) or ``turn`` on the spot
    (amount: radians, counter-clockwise positive)."""

    kind: str
    amount: float

    def __post_init__(self):
        if self.kind not in ("straight", "turn"):
            raise InputError(f"unknown segment kind {self.kind!r}")
        if not math.isfinite(self.amount) or (self.kind == "straight" and self.amount <= 0) or self.amount == 0:
            raise InputError(f"bad {self.kind} amount {self.amount!r}")


def square_program(direction: str, side_m: float, turns: int = 4) -> tuple[Segment, ...]:
    """The UMBmark square: four legs of ``side_m``, each followed by an on-the-spot 90 deg
    turn (right for ``cw``, left for ``ccw``), the fourth turn at the end."""
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
    return (Segment("straight", length_m),)


def spin_program(angle_rad: float) -> tuple[Segment, ...]:
    return (Segment("turn", angle_rad),)


@dataclass
class SimResult:
    """Outcome of a batch of runs, SI units, arrays of shape (R,).

    ``true_*``: where the robot really is; ``abs_*``: the absolute measurement of it (true plus
    measurement noise); ``odo_*``: what its odometry reports. ``trajectory`` (when asked
    for): dict of (R, K) arrays ``true_x, true_y, true_theta, odo_x, odo_y, odo_theta``.
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


def program_inputs(program, noise: NoiseModel | None, motion: Motion | None):
    """The common inputs of every simulator: the program as a non-empty tuple, the noise model
    (default: none) and the motion (default: the paper's)."""
    program = tuple(program)
    if not program:
        raise InputError("empty path program")
    return program, noise or NOISE_PRESETS["none"], motion or Motion()


def _per_run(v, n):
    a = np.broadcast_to(np.asarray(v, dtype=float), (n,))
    return np.array(a)


def child_seeds(seed: int | np.random.SeedSequence, n: int) -> list[np.random.SeedSequence]:
    """The first ``n`` children of ``seed``, the same on every call.

    ``SeedSequence.spawn`` counts its calls (a second call gives new children), so a seed
    object passed twice would give two different simulations; this does not (it equals the
    first ``spawn(n)`` of a fresh copy)."""
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return [
        np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (i,), pool_size=ss.pool_size)
        for i in range(n)
    ]


def run_seeds(seed: int | np.random.SeedSequence, n: int) -> list[np.random.Generator]:
    """``n`` independent generators from one seed (run i always gets the same stream)."""
    return [np.random.default_rng(s) for s in child_seeds(seed, n)]


MAX_SAMPLES_PER_RUN = 5_000_000  # 14 h of driving at 10 ms: beyond it the inputs are wrong


def check_sample_count(samples_per_run, motion: Motion) -> None:
    """Refuse a program that would need more than :data:`MAX_SAMPLES_PER_RUN` samples in a run
    (a side in metres given in micrometres, a speed near zero, a sample period of nanoseconds):
    the simulation would exhaust memory or never end."""
    n = int(np.max(samples_per_run))
    if n > MAX_SAMPLES_PER_RUN:
        raise InputError(
            f"a run would need {n:,} samples (more than {MAX_SAMPLES_PER_RUN:,}): check the side length, "
            f"wheelbase, speed ({motion.speed_m_s:g} m/s) and sample period ({motion.sample_period_s:g} s)"
        )


def run_program(
    program,
    true: OdometryParams,
    model: OdometryParams,
    n_runs: int | None = None,
    noise: NoiseModel | None = None,
    motion: Motion | None = None,
    rngs=None,
    trajectory: bool = False,
    true_per_run: dict | None = None,
    model_per_run: dict | None = None,
) -> SimResult:
    """Drive ``program`` closed-loop ``n_runs`` times.

    ``true``: the physical robot (metres of ground travel per pulse, true wheelbase);
    ``model``: what the controller's odometry uses. For batches of different robots pass
    ``true_per_run`` / ``model_per_run``: dicts with arrays ``left_m_per_pulse``,
    ``right_m_per_pulse``, ``wheelbase_m`` of shape (R,), overriding ``true`` / ``model``.
    ``rngs``: one numpy Generator per run (see :func:`run_seeds`); needed when there is noise.
    """
    program, noise, motion = program_inputs(program, noise, motion)
    if n_runs is None:
        n_runs = len(rngs) if rngs is not None else 1
    if n_runs < 1:
        raise InputError(f"number of runs must be >= 1, got {n_runs}")
    R = n_runs
    tp = true_per_run or {}
    mp = model_per_run or {}
    t_l = _per_run(tp.get("left_m_per_pulse", true.left_m_per_pulse if true else None), R)
    t_r = _per_run(tp.get("right_m_per_pulse", true.right_m_per_pulse if true else None), R)
    t_b = _per_run(tp.get("wheelbase_m", true.wheelbase_m if true else None), R)
    m_l = _per_run(mp.get("left_m_per_pulse", model.left_m_per_pulse if model else None), R)
    m_r = _per_run(mp.get("right_m_per_pulse", model.right_m_per_pulse if model else None), R)
    m_b = _per_run(mp.get("wheelbase_m", model.wheelbase_m if model else None), R)
    for name, arr in (("true", np.r_[t_l, t_r, t_b]), ("model", np.r_[m_l, m_r, m_b])):
        if not np.all(np.isfinite(arr) & (arr > 0)):
            raise InputError(f"{name} robot parameters must be positive and finite")

    dt = motion.sample_period_s
    if dt is None and noise.moves_robot:
        raise InputError("a sampling period is needed when noise moves the robot (slip, bumps, quantisation)")
    needs_rng = noise.moves_robot or noise.abs_xy_std_m > 0 or noise.abs_theta_std_rad > 0
    if needs_rng:
        if rngs is None or len(rngs) != R:
            raise InputError("one random generator per run is needed when there is noise")

    # --- per segment: commanded model wheel travel per step, progress per step, step counts
    seg_info = []
    for seg in program:
        if seg.kind == "straight":
            step = motion.speed_m_s * dt if dt is not None else None
            a_l_sign, a_r_sign = 1.0, 1.0
            target = np.full(R, seg.amount)
            # progress (distance) per unit of model wheel travel commanded on both wheels
            gain = np.ones(R)
        else:
            step = motion.turn_wheel_speed_m_s * dt if dt is not None else None
            s = 1.0 if seg.amount > 0 else -1.0
            a_l_sign, a_r_sign = -s, s
            target = np.full(R, abs(seg.amount))
            gain = 2.0 / m_b  # heading change per metre of (opposite) model wheel travel
        # model wheel travel needed to reach the target, per wheel
        need = target / gain
        if step is None:
            steps = need.copy()  # one step covering the whole segment
            n_full = np.zeros(R, dtype=np.int64)
            frac = np.ones(R)
            kmax_run = np.ones(R, dtype=np.int64)
        else:
            steps = np.full(R, step)
            ratio = need / step
            n_full = np.floor(ratio + 1e-12).astype(np.int64)
            frac = np.clip(ratio - n_full, 0.0, None)
            frac[frac < 1e-9] = 0.0
            margin = 0
            if noise.quantise:
                # quantised odometry lags the commanded travel by at most one pulse per wheel
                margin = np.ceil(np.maximum(m_l, m_r) / step).astype(np.int64) + 2
            kmax_run = n_full + (frac > 0) + margin
        seg_info.append((seg, a_l_sign, a_r_sign, target, gain, steps, n_full, frac, kmax_run))

    # --- noise draws, per run from its own generator (independent of the batch)
    check_sample_count(sum(info[-1] for info in seg_info), motion)
    seg_k = [int(np.max(info[-1])) for info in seg_info]
    offs = np.concatenate([[0], np.cumsum(seg_k)])
    K = int(offs[-1])
    slip = bump_u = bump_loss = phase = None
    if noise.slip_m_per_sqrt_m > 0:
        slip = np.zeros((2, R, K))
    if noise.bump_rate_per_m > 0 and noise.bump_loss_m > 0:
        bump_u = np.ones((2, R, K))
        bump_loss = np.zeros((2, R, K))
    if noise.quantise:
        phase = np.zeros((2, R))
    abs_noise = np.zeros((3, R))
    if needs_rng:
        for r in range(R):
            g = rngs[r]
            lens = [int(info[-1][r]) for info in seg_info]
            tot = sum(lens)
            draws = {}
            if slip is not None:
                draws["slip"] = g.standard_normal((2, tot))
            if bump_u is not None:
                draws["bu"] = g.random((2, tot))
                draws["bl"] = g.random((2, tot))
            if phase is not None:
                phase[:, r] = g.random(2)
            abs_noise[:, r] = g.standard_normal(3)
            pos = 0
            for j, n in enumerate(lens):
                sl = slice(offs[j], offs[j] + n)
                if slip is not None:
                    slip[:, r, sl] = draws["slip"][:, pos : pos + n]
                if bump_u is not None:
                    bump_u[:, r, sl] = draws["bu"][:, pos : pos + n]
                    bump_loss[:, r, sl] = draws["bl"][:, pos : pos + n]
                pos += n

    # --- closed-loop execution, segment by segment
    odo_l = np.zeros((R, K))
    odo_r = np.zeros((R, K))
    rot_l = np.zeros((R, K))  # wheel rotation expressed in pulses (continuous)
    rot_r = np.zeros((R, K))
    cont = phase.copy() if phase is not None else None  # continuous encoder position (pulses)
    for j, (seg, sl_sign, sr_sign, target, _gain, steps, n_full, frac, _kmax_run) in enumerate(seg_info):
        kj = seg_k[j]
        cols = slice(offs[j], offs[j] + kj)
        idx = np.arange(kj)[None, :]
        # pulses per step of each wheel (continuous), commanded from model travel
        p_l = (sl_sign * steps / m_l)[:, None]
        p_r = (sr_sign * steps / m_r)[:, None]
        if not noise.quantise:
            mult = (idx < n_full[:, None]).astype(float) + (idx == n_full[:, None]) * frac[:, None]
            rot_l[:, cols] = p_l * mult
            rot_r[:, cols] = p_r * mult
            odo_l[:, cols] = rot_l[:, cols] * m_l[:, None]
            odo_r[:, cols] = rot_r[:, cols] * m_r[:, None]
        else:
            c_l = cont[0][:, None] + p_l * (idx + 1)
            c_r = cont[1][:, None] + p_r * (idx + 1)
            q_l = np.floor(c_l) - np.floor(cont[0])[:, None]
            q_r = np.floor(c_r) - np.floor(cont[1])[:, None]
            if seg.kind == "straight":
                prog = 0.5 * (q_l * m_l[:, None] + q_r * m_r[:, None])
            else:
                prog = np.abs(q_r * m_r[:, None] - q_l * m_l[:, None]) / m_b[:, None]
            reached = prog >= target[:, None] - 1e-12
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

    # --- true ground travel: rotation times true metres per pulse, minus slip and bumps
    g_l = rot_l * t_l[:, None]
    g_r = rot_r * t_r[:, None]
    if slip is not None or bump_u is not None:
        for w, g in ((0, g_l), (1, g_r)):
            travel = np.abs(g)
            err = np.zeros_like(g)
            if slip is not None:
                err += noise.slip_m_per_sqrt_m * np.sqrt(travel) * slip[w]
            if bump_u is not None:
                hit = bump_u[w] < noise.bump_rate_per_m * travel
                err -= np.sign(g) * np.minimum(hit * noise.bump_loss_m * bump_loss[w], travel)
            g += err

    if trajectory:
        tx, ty, tth = odometry.integrate(g_l, g_r, t_b, kernel="trig")
        ox, oy, oth = odometry.integrate(odo_l, odo_r, m_b, kernel="trig")
        traj = dict(true_x=tx, true_y=ty, true_theta=tth, odo_x=ox, odo_y=oy, odo_theta=oth)
        true_end = (tx[:, -1], ty[:, -1], tth[:, -1])
        odo_end = (ox[:, -1], oy[:, -1], oth[:, -1])
    else:
        traj = None
        true_end = odometry.integrate_end(g_l, g_r, t_b, kernel="trig")
        odo_end = odometry.integrate_end(odo_l, odo_r, m_b, kernel="trig")
    ax = true_end[0] + noise.abs_xy_std_m * abs_noise[0]
    ay = true_end[1] + noise.abs_xy_std_m * abs_noise[1]
    ath = true_end[2] + noise.abs_theta_std_rad * abs_noise[2]
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
    """``n_runs`` square runs in one direction of one robot."""
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

    Returns the runs as a :class:`RunsTable` (SI units). The cw runs use the first ``n_runs``
    child seeds of ``seed``, the ccw runs the next ``n_runs``.
    """
    cw_ss, ccw_ss = child_seeds(seed, 2)
    parts = []
    for direction, s in (("cw", cw_ss), ("ccw", ccw_ss)):
        res = simulate_runs(direction, n_runs, errors, geometry, side_m, calibration, noise, motion, seed=s)
        parts.append((direction, res))
    return runs_table(parts, n_runs)


def runs_table(parts, n_runs: int) -> RunsTable:
    """A :class:`RunsTable` from ``[("cw", SimResult), ("ccw", SimResult)]``, ``n_runs`` each:
    the absolute measurement and the odometry end pose of every run, headings wrapped."""
    cat = lambda attr: np.concatenate([getattr(r, attr) for _, r in parts])  # noqa: E731
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
