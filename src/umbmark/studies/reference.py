"""Plain per-sample Python loops: the test oracle and the baseline of the speed benchmark.

Nothing here is vectorised on purpose. :func:`integrate` / :func:`integrate_pulses` replay
odometry one sample at a time with ``math.cos`` / ``math.sin``; :func:`run_program` drives the
closed-loop simulation of :func:`umbmark.model.simulate.run_program` one run and one sample at a
time, drawing the same random numbers from the same per-run generators (the draw layout is
part of the simulator's definition), so that both give the same results to rounding.
"""

from __future__ import annotations

import math

import numpy as np

from umbmark.errors import InputError
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry, OdometryParams
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import (
    Motion,
    NoiseModel,
    SimResult,
    child_seeds,
    noise_preset,
    program_inputs,
    run_seeds,
    runs_table,
    square_program,
)

__all__ = ["integrate", "integrate_pulses", "run_program", "simulate_umbmark"]


def _step(x, y, th, dl, dr, b, method):
    du = 0.5 * (dl + dr)
    dth = (dr - dl) / b
    if method == "euler":
        ref, chord = th, du
    elif method == "midpoint":
        ref, chord = th + 0.5 * dth, du
    elif method == "exact":
        h = 0.5 * dth
        ref, chord = th + h, (du * math.sin(h) / h if h != 0.0 else du)
    else:
        raise InputError(f"unknown integration method {method!r} (use 'exact', 'midpoint' or 'euler')")
    return x + chord * math.cos(ref), y + chord * math.sin(ref), th + dth


def integrate(d_left, d_right, wheelbase_m: float, pose0=(0.0, 0.0, 0.0), method: str = "exact"):
    """One log (1-D sequences of wheel travel [m]): poses after each sample, one at a time."""
    x, y, th = (float(v) for v in pose0)
    b = float(wheelbase_m)
    n = len(d_left)
    if len(d_right) != n:
        raise InputError("d_left and d_right differ in length")
    xs, ys, ts = np.empty(n), np.empty(n), np.empty(n)
    dl_list = [float(v) for v in d_left]
    dr_list = [float(v) for v in d_right]
    for k in range(n):
        x, y, th = _step(x, y, th, dl_list[k], dr_list[k], b, method)
        xs[k] = x
        ys[k] = y
        ts[k] = th
    return xs, ys, ts


def integrate_pulses(n_left, n_right, params: OdometryParams, pose0=(0.0, 0.0, 0.0), method: str = "exact"):
    """One log of encoder increments: poses after each sample, one at a time (Eqs. 2.2, 2.3)."""
    ml, mr = params.left_m_per_pulse, params.right_m_per_pulse
    return integrate(
        [ml * float(v) for v in n_left], [mr * float(v) for v in n_right], params.wheelbase_m, pose0, method
    )


def _plan(program, motion, noise, m_l, m_r, m_b):
    """Per segment: (kind, sign_l, sign_r, target, step, n_full, frac, kmax) for one run, as
    :func:`umbmark.model.simulate.run_program` plans it."""
    dt = motion.sample_period_s
    out = []
    for seg in program:
        if seg.kind == "straight":
            step = motion.speed_m_s * dt if dt is not None else None
            s_l, s_r, target, gain = 1.0, 1.0, seg.amount, 1.0
        else:
            step = motion.turn_wheel_speed_m_s * dt if dt is not None else None
            s = 1.0 if seg.amount > 0 else -1.0
            s_l, s_r, target, gain = -s, s, abs(seg.amount), 2.0 / m_b
        need = target / gain
        if step is None:
            out.append((seg.kind, s_l, s_r, target, need, 0, 1.0, 1))
            continue
        ratio = need / step
        n_full = int(math.floor(ratio + 1e-12))
        frac = max(ratio - n_full, 0.0)
        if frac < 1e-9:
            frac = 0.0
        margin = int(math.ceil(max(m_l, m_r) / step)) + 2 if noise.quantise else 0
        out.append((seg.kind, s_l, s_r, target, step, n_full, frac, n_full + (frac > 0) + margin))
    return out


def run_program(
    program,
    true: OdometryParams,
    model: OdometryParams,
    n_runs: int | None = None,
    noise: NoiseModel | None = None,
    motion: Motion | None = None,
    rngs=None,
    true_per_run: dict | None = None,
    model_per_run: dict | None = None,
) -> SimResult:
    """The closed-loop simulation of :func:`umbmark.model.simulate.run_program`, one run and one
    sample at a time (same arguments, same random draws, same results to rounding)."""
    program, noise, motion = program_inputs(program, noise, motion)
    if n_runs is None:
        n_runs = len(rngs) if rngs is not None else 1
    R = n_runs
    tp, mp = true_per_run or {}, model_per_run or {}

    def col(d, key, base):
        return np.broadcast_to(np.asarray(d.get(key, getattr(base, key) if base else None), dtype=float), (R,))

    T = [col(tp, k, true) for k in ("left_m_per_pulse", "right_m_per_pulse", "wheelbase_m")]
    M = [col(mp, k, model) for k in ("left_m_per_pulse", "right_m_per_pulse", "wheelbase_m")]
    if motion.sample_period_s is None and noise.moves_robot:
        raise InputError("a sampling period is needed when noise moves the robot (slip, bumps, quantisation)")
    needs_rng = noise.moves_robot or noise.abs_xy_std_m > 0 or noise.abs_theta_std_rad > 0
    if needs_rng and (rngs is None or len(rngs) != R):
        raise InputError("one random generator per run is needed when there is noise")
    has_slip = noise.slip_m_per_sqrt_m > 0
    has_bump = noise.bump_rate_per_m > 0 and noise.bump_loss_m > 0
    out = np.zeros((9, R))
    for r in range(R):
        t_l, t_r, t_b = (float(a[r]) for a in T)
        m_l, m_r, m_b = (float(a[r]) for a in M)
        plan = _plan(program, motion, noise, m_l, m_r, m_b)
        tot = sum(p[-1] for p in plan)
        slip = bu = bl = None
        phase = (0.0, 0.0)
        absn = (0.0, 0.0, 0.0)
        if needs_rng:
            g = rngs[r]
            if has_slip:
                slip = g.standard_normal((2, tot)).tolist()
            if has_bump:
                bu = g.random((2, tot)).tolist()
                bl = g.random((2, tot)).tolist()
            if noise.quantise:
                phase = tuple(g.random(2).tolist())
            absn = tuple(g.standard_normal(3).tolist())
        tx = ty = tth = ox = oy = oth = 0.0
        cont_l, cont_r = phase
        pos = 0
        for kind, s_l, s_r, target, step, n_full, frac, kmax in plan:
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
                gw = [rot_l * t_l, rot_r * t_r]
                for w in (0, 1):
                    gv = gw[w]
                    travel = abs(gv)
                    err = 0.0
                    if has_slip:
                        err += noise.slip_m_per_sqrt_m * math.sqrt(travel) * slip[w][pos + i]
                    if has_bump:
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
    seed=0,
) -> RunsTable:
    """:func:`umbmark.model.simulate.simulate_umbmark` with the per-sample reference loop (same seeds)."""
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
