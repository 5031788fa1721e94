"""Batched closed-loop simulation of many robots: :func:`simulate_batch` and :func:`run_batch`.

Same model, same random draws and same results (to rounding) as
:func:`umbmark.model.simulate.run_program` / :func:`~umbmark.model.simulate.simulate_umbmark`, for a whole
batch of robots at once (every per-run parameter may differ). Each run draws its noise from its
own seeded generator, so a robot's result does not depend on the batch it is simulated in.

Engines:

* ``"numba"`` (default when numba is installed, as umbmark's dependencies have it): one compiled
  loop over runs and samples. Noise is drawn with numpy exactly as ``run_program`` draws it
  (into preallocated buffers); the loop composes the heading as a rotation (cosine and sine of
  the per-sample heading change by a short Taylor series: no trig call per sample) and
  re-synchronises it with the accumulated angle at every segment end.
* ``"numpy"``: :func:`umbmark.model.simulate.run_program` on chunks of runs (the vectorised numpy
  simulator).

Both plan the program with :func:`umbmark.model.simulate.plan_program` and run in bounded
memory: runs are processed ``chunk_runs`` at a time. Pure numpy (and numba, when installed):
this module imports only the lower modules of :mod:`umbmark.model`.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from umbmark._numba import ENGINES, check_engine, numba_module
from umbmark.errors import InputError
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry, OdometryParams, wrap_angle
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import (
    PARAM_KEYS,
    Motion,
    NoiseModel,
    Segment,
    SimResult,
    check_noise_inputs,
    child_seeds,
    noise_preset,
    per_run_params,
    plan_program,
    program_inputs,
    run_program,
    run_seeds,
    square_program,
)

__all__ = ["ENGINES", "have_numba", "default_engine", "run_batch", "simulate_batch"]


def have_numba() -> bool:
    """True when numba is installed (the ``"numba"`` engine is available); imports it."""
    return numba_module() is not None


def default_engine() -> str:
    """The engine ``"auto"`` stands for: ``"numba"`` when installed, else ``"numpy"``."""
    return "numba" if have_numba() else "numpy"


def _buffer(work, name, n):
    """A float64 array of n elements from the reusable workspace ``work`` (a dict): reusing
    the buffers of the previous chunk avoids touching fresh pages for every chunk."""
    if work is None:
        return np.empty(n)
    buf = work.get(name)
    if buf is None or buf.size < n:
        buf = work[name] = np.empty(n)
    return buf[:n]


def _draws(noise: NoiseModel, rngs, tot, work=None):
    """The noise of each run, drawn in run_program's order (slip, bump uniforms, bump losses,
    encoder phase, absolute-measurement noise) into flat buffers; run r's (2, tot[r]) block
    starts at 2 * offs[r]."""
    R = tot.size
    offs = np.zeros(R, dtype=np.int64)
    if R > 1:
        offs[1:] = np.cumsum(tot)[:-1]
    n = 2 * int(tot.sum())
    has_slip, has_bump = noise.has_slip, noise.has_bumps
    slip = _buffer(work, "slip", n) if has_slip else np.zeros(1)
    bu = _buffer(work, "bu", n) if has_bump else np.zeros(1)
    bl = _buffer(work, "bl", n) if has_bump else np.zeros(1)
    phase = np.zeros((2, R))
    absn = np.zeros((3, R))
    for r in range(R):
        g = rngs[r]
        a, b = 2 * offs[r], 2 * (offs[r] + tot[r])
        t = int(tot[r])
        if has_slip:
            g.standard_normal(out=slip[a:b].reshape(2, t))
        if has_bump:
            g.random(out=bu[a:b].reshape(2, t))
            g.random(out=bl[a:b].reshape(2, t))
        if noise.quantise:
            phase[:, r] = g.random(2)
        absn[:, r] = g.standard_normal(3)
    return 2 * offs, slip, bu, bl, phase, absn


_S6, _S20, _S42 = 1.0 / 6.0, 1.0 / 20.0, 1.0 / 42.0
_C2, _C12, _C30, _C56 = 0.5, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0


def _arc_py(x, y, th, c, s, dl, dr, inv_b):
    """One exact arc: pose (x, y, th) with (c, s) = (cos th, sin th) composed so far."""
    du = 0.5 * (dl + dr)
    dth = (dr - dl) * inv_b
    h = 0.5 * dth
    if abs(h) < 0.02:  # Taylor: truncation below 1e-19
        h2 = h * h
        sinc = 1.0 - h2 * _S6 * (1.0 - h2 * _S20 * (1.0 - h2 * _S42))
        sh = h * sinc
        ch = 1.0 - h2 * _C2 * (1.0 - h2 * _C12 * (1.0 - h2 * _C30 * (1.0 - h2 * _C56)))
    else:
        sh = math.sin(h)
        ch = math.cos(h)
        sinc = sh / h
    rc = c * ch - s * sh
    rs = s * ch + c * sh
    chord = du * sinc
    return x + chord * rc, y + chord * rs, th + dth, rc * ch - rs * sh, rs * ch + rc * sh


_arc = _arc_py  # replaced by its compiled version before the kernel is compiled


def _kernel_py(
    kind,
    s_l,
    s_r,
    target,
    step,
    n_full,
    frac,
    kmax,
    t_l,
    t_r,
    t_b,
    m_l,
    m_r,
    m_b,
    quantise,
    slip_k,
    has_slip,
    bump_rate,
    bump_loss,
    has_bump,
    slip,
    bu,
    bl,
    doff,
    phase,
    out,
):
    R, S = step.shape
    for r in range(R):
        tot = 0
        for j in range(S):
            tot += kmax[r, j]
        off = doff[r]
        tx = 0.0
        ty = 0.0
        tth = 0.0
        tc = 1.0
        ts = 0.0
        ox = 0.0
        oy = 0.0
        oth = 0.0
        oc = 1.0
        os_ = 0.0
        cont_l = phase[0, r]
        cont_r = phase[1, r]
        tl = t_l[r]
        tr = t_r[r]
        tb = t_b[r]
        ml = m_l[r]
        mr = m_r[r]
        mb = m_b[r]
        ib_t = 1.0 / tb
        ib_m = 1.0 / mb
        pos = 0
        for j in range(S):
            p_l = s_l[j] * step[r, j] / ml
            p_r = s_r[j] * step[r, j] / mr
            base_l = math.floor(cont_l)
            base_r = math.floor(cont_r)
            qpl = 0.0
            qpr = 0.0
            tgt = target[j] - 1e-12
            nf = n_full[r, j]
            fr = frac[r, j]
            # ground travel of a full sample, and its noise parameters (constant in a segment)
            gl0 = p_l * tl
            gr0 = p_r * tr
            trl0 = abs(gl0)
            trr0 = abs(gr0)
            aml0 = slip_k * math.sqrt(trl0)
            amr0 = slip_k * math.sqrt(trr0)
            thl0 = bump_rate * trl0
            thr0 = bump_rate * trr0
            sgl = 1.0 if gl0 > 0 else (-1.0 if gl0 < 0 else 0.0)
            sgr = 1.0 if gr0 > 0 else (-1.0 if gr0 < 0 else 0.0)
            kl = off + pos
            kr = kl + tot
            for i in range(kmax[r, j]):
                done = False
                full = True
                if not quantise:
                    if i < nf:
                        mult = 1.0
                    elif i == nf:
                        mult = fr
                        full = False
                    else:
                        break
                    if mult == 0.0:
                        break
                    o_l = p_l * mult * ml
                    o_r = p_r * mult * mr
                else:
                    ql = math.floor(cont_l + p_l * (i + 1)) - base_l
                    qr = math.floor(cont_r + p_r * (i + 1)) - base_r
                    if kind[j] == 0:
                        prog = 0.5 * (ql * ml + qr * mr)
                    else:
                        prog = abs(qr * mr - ql * ml) / mb
                    o_l = (ql - qpl) * ml
                    o_r = (qr - qpr) * mr
                    qpl = ql
                    qpr = qr
                    done = prog >= tgt
                if full:
                    gl, trl, aml, thl = gl0, trl0, aml0, thl0
                    gr, trr, amr, thr = gr0, trr0, amr0, thr0
                else:
                    gl = p_l * mult * tl
                    gr = p_r * mult * tr
                    trl = abs(gl)
                    trr = abs(gr)
                    aml = slip_k * math.sqrt(trl)
                    amr = slip_k * math.sqrt(trr)
                    thl = bump_rate * trl
                    thr = bump_rate * trr
                if has_slip or has_bump:
                    el = 0.0
                    er = 0.0
                    if has_slip:
                        el += aml * slip[kl + i]
                        er += amr * slip[kr + i]
                    if has_bump:
                        if bu[kl + i] < thl:
                            el -= sgl * min(bump_loss * bl[kl + i], trl)
                        if bu[kr + i] < thr:
                            er -= sgr * min(bump_loss * bl[kr + i], trr)
                    gl = gl + el
                    gr = gr + er
                # exact arcs; headings composed as rotations (no trig call per sample)
                tx, ty, tth, tc, ts = _arc(tx, ty, tth, tc, ts, gl, gr, ib_t)
                ox, oy, oth, oc, os_ = _arc(ox, oy, oth, oc, os_, o_l, o_r, ib_m)
                if done:
                    cont_l += p_l * (i + 1)
                    cont_r += p_r * (i + 1)
                    break
            pos += kmax[r, j]
            # bound the drift of the composed rotations: back to the accumulated angles
            tc = math.cos(tth)
            ts = math.sin(tth)
            oc = math.cos(oth)
            os_ = math.sin(oth)
        out[0, r] = tx
        out[1, r] = ty
        out[2, r] = tth
        out[3, r] = ox
        out[4, r] = oy
        out[5, r] = oth


_kernel = None


def _get_kernel():
    global _kernel
    if _kernel is None:
        numba = numba_module()
        if numba is None:
            raise InputError(
                'engine "numba" needs numba (a dependency of umbmark that is missing here): pip install numba'
            )
        global _arc
        # fastmath only here: the arc accumulates the pose (no stopping decision depends on
        # its rounding); it lets the compiler fuse multiply-adds
        _arc = numba.njit(cache=True, fastmath=True)(_arc_py)
        _kernel = numba.njit(cache=True, nogil=True)(_kernel_py)
    return _kernel


def _check_engine(engine: str) -> str:
    check_engine(engine)
    return default_engine() if engine == "auto" else engine


def _batch_size(true_per_run, model_per_run, rngs, n_runs) -> int:
    """R: ``n_runs``, else one run per generator, else the longest per-run array (at least 1)."""
    if n_runs is None:
        if rngs is not None:
            n_runs = len(rngs)
        else:
            sizes = [np.size(v) for d in (true_per_run, model_per_run) if isinstance(d, dict) for v in d.values()]
            n_runs = max(sizes + [1])
    R = int(n_runs)
    if R < 1:
        raise InputError(f"number of runs must be >= 1, got {R}")
    return R


def _robot(per_run: dict | OdometryParams | None, R: int, name: str):
    if isinstance(per_run, OdometryParams):
        return per_run_params(None, per_run, R, name)
    return per_run_params(per_run if isinstance(per_run, dict) else None, None, R, name)


def _numpy_chunk(program, noise, motion, rngs, T, M) -> np.ndarray:
    """One chunk of runs with :func:`umbmark.model.simulate.run_program`: the (9, R) result rows."""
    keys = dict(zip(PARAM_KEYS, T)), dict(zip(PARAM_KEYS, M))
    res = run_program(
        program, None, None, T[0].size, noise, motion, rngs=rngs, true_per_run=keys[0], model_per_run=keys[1]
    )
    return np.array(
        [
            res.true_x,
            res.true_y,
            res.true_theta,
            res.odo_x,
            res.odo_y,
            res.odo_theta,
            res.abs_x,
            res.abs_y,
            res.abs_theta,
        ]
    )


def _numba_chunk(kernel, program, noise: NoiseModel, motion, rngs, T, M, work) -> np.ndarray:
    """One chunk of runs with the compiled kernel: the (9, R) result rows."""
    t_l, t_r, t_b = T
    m_l, m_r, m_b = M
    R = t_l.size
    plan = plan_program(program, motion, noise, m_l, m_r, m_b)
    if noise.needs_rng:
        doff, slip, bu, bl, phase, absn = _draws(noise, rngs, plan.samples.sum(axis=1), work)
    else:
        doff = np.zeros(R, dtype=np.int64)
        slip = bu = bl = np.zeros(1)
        phase = np.zeros((2, R))
        absn = np.zeros((3, R))
    part = np.zeros((6, R))
    kernel(
        plan.kind,
        plan.sign_left,
        plan.sign_right,
        plan.target,
        plan.step,
        plan.n_full,
        plan.frac,
        plan.samples,
        t_l,
        t_r,
        t_b,
        m_l,
        m_r,
        m_b,
        bool(noise.quantise),
        float(noise.slip_m_per_sqrt_m),
        noise.has_slip,
        float(noise.bump_rate_per_m),
        float(noise.bump_loss_m),
        noise.has_bumps,
        slip,
        bu,
        bl,
        doff,
        phase,
        part,
    )
    out = np.zeros((9, R))
    out[:6] = part
    out[6] = part[0] + noise.abs_xy_std_m * absn[0]
    out[7] = part[1] + noise.abs_xy_std_m * absn[1]
    out[8] = part[2] + noise.abs_theta_std_rad * absn[2]
    return out


def run_batch(
    program: Iterable[Segment],
    true_per_run: dict | OdometryParams,
    model_per_run: dict | OdometryParams,
    noise: NoiseModel | None = None,
    motion: Motion | None = None,
    rngs: Sequence[np.random.Generator] | None = None,
    n_runs: int | None = None,
    engine: str = "auto",
    chunk_runs: int | None = None,
    threads: int | None = 1,
) -> SimResult:
    """:func:`umbmark.model.simulate.run_program` for a batch of runs, without trajectories.

    Parameters
    ----------
    program : iterable of Segment
        The path program.
    true_per_run, model_per_run : dict or OdometryParams
        The physical robots and their odometry: dicts of :data:`~umbmark.model.simulate.PARAM_KEYS`
        (scalars or arrays (R,)), or one :class:`OdometryParams` for all runs.
    noise : NoiseModel, optional
        Default: none.
    motion : Motion, optional
        Default: the paper's.
    rngs : sequence of numpy.random.Generator, optional
        One generator per run (needed with noise).
    n_runs : int, optional
        R (default: one per generator, else the longest per-run array).
    engine : str
        ``"auto"``, ``"numba"`` or ``"numpy"`` (see the module docstring).
    chunk_runs : int, optional
        Runs simulated at once (default: 64 with numba, 32 with numpy).
    threads : int, optional
        Run chunks of runs on this many threads (the numba engine and the noise draws release
        the GIL; results do not depend on it; ``None``: 1).

    Returns
    -------
    SimResult

    Raises
    ------
    InputError
        On an unknown engine, bad parameters (as :func:`~umbmark.model.simulate.run_program`),
        ``chunk_runs < 1`` or ``threads < 1``.
    """
    engine = _check_engine(engine)
    program, noise, motion = program_inputs(program, noise, motion)
    R = _batch_size(true_per_run, model_per_run, rngs, n_runs)
    T = _robot(true_per_run, R, "true")
    M = _robot(model_per_run, R, "model")
    check_noise_inputs(noise, motion, rngs, R)
    if chunk_runs is None:
        chunk_runs = 64 if engine == "numba" else 32
    if chunk_runs < 1:
        raise InputError(f"chunk_runs must be >= 1, got {chunk_runs}")
    if threads is None:
        threads = 1
    if threads < 1:
        raise InputError(f"threads must be >= 1, got {threads}")
    out = np.zeros((9, R))
    kernel = _get_kernel() if engine == "numba" else None
    local = threading.local()  # per-thread reusable buffers for the noise draws

    def chunk(a):
        sl = slice(a, min(R, a + chunk_runs))
        g = rngs[sl] if rngs is not None else None
        Tc, Mc = tuple(v[sl] for v in T), tuple(v[sl] for v in M)
        if kernel is None:
            out[:, sl] = _numpy_chunk(program, noise, motion, g, Tc, Mc)
            return
        work = getattr(local, "work", None)
        if work is None:
            work = local.work = {}
        out[:, sl] = _numba_chunk(kernel, program, noise, motion, g, Tc, Mc, work)

    starts = range(0, R, chunk_runs)
    if threads == 1 or len(starts) == 1:
        for a in starts:
            chunk(a)
    else:
        # the compiled kernel and numpy's bulk random draws release the GIL; every run has
        # its own generator, so the result does not depend on the number of threads
        with ThreadPoolExecutor(max_workers=threads) as ex:
            list(ex.map(chunk, starts))
    return SimResult(*out)


def _robot_list(v, n, name):
    if v is None or not isinstance(v, Sequence) or isinstance(v, (str, bytes)):
        return [v] * n
    if len(v) != n:
        raise InputError(f"{name}: expected {n} entries (one per robot), got {len(v)}")
    return list(v)


def _robot_seeds(seeds, n: int) -> list:
    """One seed per robot: the list given, or the first ``n`` children of one seed."""
    if isinstance(seeds, (int, np.integer, np.random.SeedSequence)):
        root = seeds if isinstance(seeds, np.random.SeedSequence) else np.random.SeedSequence(int(seeds))
        seeds = child_seeds(root, n)
    seeds = list(seeds)
    if len(seeds) != n:
        raise InputError(f"seeds: expected {n} entries (one per robot), got {len(seeds)}")
    return seeds


def _tables(res: dict[str, SimResult], n: int, n_runs: int) -> list[RunsTable]:
    """Robot i's runs: rows i * n_runs .. (i + 1) * n_runs of the cw and the ccw batch."""
    direction = np.array(["cw"] * n_runs + ["ccw"] * n_runs)
    run = np.concatenate([np.arange(1, n_runs + 1)] * 2)
    tables = []
    for i in range(n):
        sl = slice(i * n_runs, (i + 1) * n_runs)

        def both(attr, sl=sl):
            return np.concatenate([getattr(res["cw"], attr)[sl], getattr(res["ccw"], attr)[sl]])

        tables.append(
            RunsTable.from_columns(
                direction=direction,
                x_abs=both("abs_x"),
                y_abs=both("abs_y"),
                x_odo=both("odo_x"),
                y_odo=both("odo_y"),
                theta_abs=wrap_angle(both("abs_theta")),
                theta_odo=wrap_angle(both("odo_theta")),
                run=run,
            )
        )
    return tables


def simulate_batch(
    errors: Sequence[ErrorParams],
    geometry: Geometry = LABMATE,
    side_m: float = 4.0,
    n_runs: int = 5,
    calibrations: Calibration | Sequence[Calibration | None] | None = None,
    noise: NoiseModel | str = "none",
    motion: Motion | None = None,
    seeds: int | np.random.SeedSequence | Sequence[int | np.random.SeedSequence] = 0,
    engine: str = "auto",
    chunk_runs: int | None = None,
    threads: int | None = 1,
) -> list[RunsTable]:
    """UMBmark (``n_runs`` cw + ``n_runs`` ccw runs) for a batch of robots.

    Equal (to rounding) to ``[simulate_umbmark(e, geometry, side_m, n_runs, cal, noise, motion,
    seed=s) ...]``.

    Parameters
    ----------
    errors : sequence of ErrorParams
        One per robot.
    geometry : Geometry
        The nominal geometry of all robots.
    side_m : float
        Side of the square [m].
    n_runs : int
        Runs per direction.
    calibrations : Calibration or sequence of Calibration or None
        One for all robots, or one per robot (None: nominal).
    noise : NoiseModel or str
        A noise model or the name of a preset.
    motion : Motion, optional
        Default: the paper's.
    seeds : int, SeedSequence or sequence of them
        One seed per robot, or a single seed whose children seed the robots in order.
    engine, chunk_runs, threads
        See :func:`run_batch`.

    Returns
    -------
    list of RunsTable
        One per robot, SI units.

    Raises
    ------
    InputError
        Without robots, on ``n_runs < 1`` or lists of the wrong length.
    """
    errors = list(errors)
    n = len(errors)
    if n == 0:
        raise InputError("simulate_batch needs at least one robot")
    if n_runs < 1:
        raise InputError(f"number of runs must be >= 1, got {n_runs}")
    if isinstance(noise, str):
        noise = noise_preset(noise)
    cals = _robot_list(calibrations, n, "calibrations")
    robot_seeds = _robot_seeds(seeds, n)
    true = [e.true_params(geometry) for e in errors]
    model = [OdometryParams.from_geometry(geometry, c) for c in cals]
    T = {k: np.repeat([getattr(p, k) for p in true], n_runs) for k in PARAM_KEYS}
    M = {k: np.repeat([getattr(p, k) for p in model], n_runs) for k in PARAM_KEYS}
    per_dir: dict[str, list[np.random.Generator]] = {"cw": [], "ccw": []}
    for s in robot_seeds:
        cw_ss, ccw_ss = child_seeds(s, 2)
        per_dir["cw"].extend(run_seeds(cw_ss, n_runs))
        per_dir["ccw"].extend(run_seeds(ccw_ss, n_runs))
    res = {
        d: run_batch(
            square_program(d, side_m), T, M, noise, motion, per_dir[d], n * n_runs, engine, chunk_runs, threads
        )
        for d in ("cw", "ccw")
    }
    return _tables(res, n, n_runs)
