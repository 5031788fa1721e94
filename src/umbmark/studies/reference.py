"""Plain per-sample Python loops: the test oracle and the baseline of the speed benchmark.

Nothing here is vectorised on purpose. :func:`integrate` / :func:`integrate_pulses` replay
odometry one sample at a time with ``math.cos`` / ``math.sin`` (the oracle of
:mod:`umbmark.model.odometry`); :func:`run_program` drives the closed-loop simulation of
:func:`umbmark.model.simulate.run_program` one run and one sample at a time. It plans the
program with the simulators' own :func:`~umbmark.model.simulate.plan_program` and draws the
same random numbers from the same per-run generators (the draw layout is part of the
simulator's definition), so that both give the same results to rounding.

Imports only numpy and :mod:`umbmark.model`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from umbmark.errors import InputError
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry, OdometryParams
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import (
    Motion,
    NoiseModel,
    Segment,
    SegmentPlan,
    SimResult,
    check_noise_inputs,
    child_seeds,
    noise_preset,
    per_run_params,
    plan_program,
    program_inputs,
    run_seeds,
    runs_table,
    square_program,
)

__all__ = ["integrate", "integrate_pulses", "run_program", "simulate_umbmark"]


def _step(x: float, y: float, th: float, dl: float, dr: float, b: float, integrator: str) -> tuple[float, float, float]:
    """One sample of odometry: the pose after wheel travel ``dl``, ``dr``."""
    du = 0.5 * (dl + dr)
    dth = (dr - dl) / b
    if integrator == "euler":
        ref, chord = th, du
    elif integrator == "midpoint":
        ref, chord = th + 0.5 * dth, du
    elif integrator == "exact":
        h = 0.5 * dth
        ref, chord = th + h, (du * math.sin(h) / h if h != 0.0 else du)
    else:
        raise InputError(f"unknown integrator {integrator!r} (use 'exact', 'midpoint' or 'euler')")
    return x + chord * math.cos(ref), y + chord * math.sin(ref), th + dth


def integrate(
    d_left: Sequence[float] | np.ndarray,
    d_right: Sequence[float] | np.ndarray,
    wheelbase_m: float,
    pose0: Iterable[float] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses of one log, one sample at a time: the oracle of :func:`umbmark.model.odometry.integrate`.

    Parameters
    ----------
    d_left, d_right : sequence of float
        Wheel travel [m] per sample (one log).
    wheelbase_m : float
        Wheelbase [m].
    pose0 : tuple of float
        Start pose ``(x, y, theta)``.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"``.

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, y, theta)`` after each sample.

    Raises
    ------
    InputError
        On sequences of different lengths or an unknown integrator.
    """
    x, y, th = (float(v) for v in pose0)
    b = float(wheelbase_m)
    n = len(d_left)
    if len(d_right) != n:
        raise InputError("d_left and d_right differ in length")
    xs, ys, ts = np.empty(n), np.empty(n), np.empty(n)
    dl_list = [float(v) for v in d_left]
    dr_list = [float(v) for v in d_right]
    for k in range(n):
        x, y, th = _step(x, y, th, dl_list[k], dr_list[k], b, integrator)
        xs[k] = x
        ys[k] = y
        ts[k] = th
    return xs, ys, ts


def integrate_pulses(
    n_left: Sequence[float] | np.ndarray,
    n_right: Sequence[float] | np.ndarray,
    params: OdometryParams,
    pose0: Iterable[float] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses of one log of encoder increments, one sample at a time (Eqs. 2.2, 2.3).

    The oracle of :func:`umbmark.model.odometry.integrate_pulses`; parameters as there, for
    1-D sequences.

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, y, theta)`` after each sample.
    """
    ml, mr = params.left_m_per_pulse, params.right_m_per_pulse
    return integrate(
        [ml * float(v) for v in n_left], [mr * float(v) for v in n_right], params.wheelbase_m, pose0, integrator
    )


def _segments(plan: SegmentPlan, r: int) -> list[tuple]:
    """Run r's plan as Python numbers, one tuple per segment:
    ``(kind, sign_l, sign_r, target, step, n_full, frac, samples)``."""
    return [
        (
            "straight" if plan.kind[j] == 0 else "turn",
            float(plan.sign_left[j]),
            float(plan.sign_right[j]),
            float(plan.target[j]),
            float(plan.step[r, j]),
            int(plan.n_full[r, j]),
            float(plan.frac[r, j]),
            int(plan.samples[r, j]),
        )
        for j in range(len(plan.kind))
    ]


def _run_draws(noise: NoiseModel, g, tot: int):
    """One run's random numbers, drawn in the simulator's order: slip, bump uniforms, bump
    losses (each (2, tot) lists), encoder phase, measurement noise."""
    slip = g.standard_normal((2, tot)).tolist() if noise.has_slip else None
    bu = g.random((2, tot)).tolist() if noise.has_bumps else None
    bl = g.random((2, tot)).tolist() if noise.has_bumps else None
    phase = tuple(g.random(2).tolist()) if noise.quantise else (0.0, 0.0)
    absn = tuple(g.standard_normal(3).tolist())
    return slip, bu, bl, phase, absn


_NO_DRAWS: tuple = (None, None, None, (0.0, 0.0), (0.0, 0.0, 0.0))


def _one_run(segments, noise: NoiseModel, true: tuple, model: tuple, draws) -> tuple:
    """Drive one run sample by sample: ``(true_x, true_y, true_theta, odo_x, odo_y, odo_theta)``."""
    t_l, t_r, t_b = true
    m_l, m_r, m_b = model
    slip, bu, bl, phase, _ = draws
    tx = ty = tth = ox = oy = oth = 0.0
    cont_l, cont_r = phase
    pos = 0
    for kind, s_l, s_r, target, step, n_full, frac, kmax in segments:
        p_l = s_l * step / m_l  # commanded pulses per sample
        p_r = s_r * step / m_r
        q_prev_l = q_prev_r = 0.0
        base_l, base_r = math.floor(cont_l), math.floor(cont_r)
        for i in range(kmax):
            if not noise.quantise:
                mult = 1.0 if i < n_full else (frac if i == n_full else 0.0)
                if mult == 0.0:
                    break
                rot_l, rot_r = p_l * mult, p_r * mult
                o_l, o_r = rot_l * m_l, rot_r * m_r
                done = False
            else:
                q_l = math.floor(cont_l + p_l * (i + 1)) - base_l
                q_r = math.floor(cont_r + p_r * (i + 1)) - base_r
                if kind == "straight":
                    prog = 0.5 * (q_l * m_l + q_r * m_r)
                else:
                    prog = abs(q_r * m_r - q_l * m_l) / m_b
                rot_l, rot_r = p_l, p_r
                o_l, o_r = (q_l - q_prev_l) * m_l, (q_r - q_prev_r) * m_r
                q_prev_l, q_prev_r = q_l, q_r
                done = prog >= target - 1e-12
            # true ground travel: commanded rotation times true metres per pulse, plus slip and bumps
            gw = [rot_l * t_l, rot_r * t_r]
            for w in (0, 1):
                gv = gw[w]
                travel = abs(gv)
                err = 0.0
                if slip is not None:
                    err += noise.slip_m_per_sqrt_m * math.sqrt(travel) * slip[w][pos + i]
                if bu is not None:
                    hit = bu[w][pos + i] < noise.bump_rate_per_m * travel
                    sign = (gv > 0) - (gv < 0)
                    err -= sign * min(hit * noise.bump_loss_m * bl[w][pos + i], travel)
                gw[w] = gv + err
            tx, ty, tth = _step(tx, ty, tth, gw[0], gw[1], t_b, "exact")
            ox, oy, oth = _step(ox, oy, oth, o_l, o_r, m_b, "exact")
            if done:
                cont_l += p_l * (i + 1)
                cont_r += p_r * (i + 1)
                break
        else:
            if noise.quantise:  # pragma: no cover - the margin makes this unreachable
                raise RuntimeError("internal: quantised segment did not reach its target")
        pos += kmax
    return tx, ty, tth, ox, oy, oth


def run_program(
    program: Iterable[Segment],
    true: OdometryParams | None,
    model: OdometryParams | None,
    n_runs: int | None = None,
    noise: NoiseModel | None = None,
    motion: Motion | None = None,
    rngs: Sequence[np.random.Generator] | None = None,
    true_per_run: dict | None = None,
    model_per_run: dict | None = None,
) -> SimResult:
    """The closed-loop simulation of :func:`umbmark.model.simulate.run_program`, one run and one sample at a time.

    Same arguments (without ``trajectory``), same plan (:func:`~umbmark.model.simulate.plan_program`),
    same random draws, same results to rounding.

    Returns
    -------
    SimResult

    Raises
    ------
    InputError
        As :func:`umbmark.model.simulate.run_program`.
    """
    program, noise, motion = program_inputs(program, noise, motion)
    if n_runs is None:
        n_runs = len(rngs) if rngs is not None else 1
    R = n_runs
    T = per_run_params(true_per_run, true, R, "true")
    M = per_run_params(model_per_run, model, R, "model")
    check_noise_inputs(noise, motion, rngs, R)
    plan = plan_program(program, motion, noise, *M)
    out = np.zeros((9, R))
    for r in range(R):
        segments = _segments(plan, r)
        tot = sum(s[-1] for s in segments)
        draws = _NO_DRAWS
        if noise.needs_rng and rngs is not None:
            draws = _run_draws(noise, rngs[r], tot)
        true_r = tuple(float(a[r]) for a in T)
        model_r = tuple(float(a[r]) for a in M)
        tx, ty, tth, ox, oy, oth = _one_run(segments, noise, true_r, model_r, draws)
        absn = draws[4]
        out[:, r] = (
            tx,
            ty,
            tth,
            ox,
            oy,
            oth,
            tx + noise.abs_xy_std_m * absn[0],
            ty + noise.abs_xy_std_m * absn[1],
            tth + noise.abs_theta_std_rad * absn[2],
        )
    return SimResult(*out)


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
    """:func:`umbmark.model.simulate.simulate_umbmark` with the per-sample reference loop.

    Same parameters, same seeds, same runs to rounding.

    Returns
    -------
    RunsTable
    """
    if isinstance(noise, str):
        noise = noise_preset(noise)
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    true = errors.true_params(geometry)
    model = OdometryParams.from_geometry(geometry, calibration)
    parts = []
    for direction, s in zip(("cw", "ccw"), child_seeds(ss, 2)):
        res = run_program(
            square_program(direction, side_m), true, model, n_runs, noise, motion, rngs=run_seeds(s, n_runs)
        )
        parts.append((direction, res))
    return runs_table(parts, n_runs)
