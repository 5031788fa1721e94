"""Odometry: wheel travel or encoder increments to poses, the package's one integrator.

Pure numpy: this module imports only numpy and the lower :mod:`umbmark.model.geometry`.
Vectorised over samples and runs, chunked so memory stays bounded for logs of any length.

Public functions: :func:`integrate` / :func:`integrate_end` (wheel travel [m] per sample),
:func:`integrate_pulses` / :func:`integrate_pulses_end` (encoder increments and
:class:`~umbmark.model.geometry.OdometryParams`, Eqs. 2.2 and 2.3), the streaming
:class:`Odometer` and :func:`replay_stream`.

Methods: ``"exact"`` (constant wheel speeds within a sample: exact circular arcs),
``"midpoint"`` (straight chord along the mid-sample heading, chord length = travelled
distance) and ``"euler"`` (heading at the sample start).

Kernels (``kernel=``):

* ``"fast"`` (default), chosen by the input:

  * **float kernel** (any wheel travel): the heading is a cumulative sum; the cosine and sine
    of the heading are computed with one trig call per *block* of ``BLOCK`` samples (at the
    block start) and, within the block, with a short Taylor polynomial of the (small) heading
    change since the block start, combined by the angle-addition formula. Blocks whose
    heading changes by more than ``BLOCK_MAX_RAD`` fall back to ``numpy.cos`` / ``numpy.sin``
    (exact either way: the truncation error of the polynomials is below 1e-16 in that range).
  * **table kernel** (integer encoder increments, see :func:`integrate_pulses`): encoder
    increments are small integers, so the per-sample displacement in the robot frame takes
    only a few distinct values (one per pair of increments): it is looked up in a table. The
    heading is an integer combination of the cumulative pulse counts, ``theta = theta0 + a_R
    * S_R - a_L * S_L``, so ``exp(i theta)`` is a product of looked-up complex exponentials
    (the counts split into high and low bits): no trig call per sample at all.

* ``"trig"``: one ``numpy.cos`` and ``numpy.sin`` per sample on the whole arrays at once (not
  chunked). Cheaper to set up, so faster on short logs; the simulator and the replay of short
  logs use it. Same poses as ``"fast"`` to rounding (about 1e-11 m over 10^6 samples).

Streaming: :class:`Odometer` keeps the pose between calls; feed it a log chunk by chunk. The
chunk boundaries do not change the poses beyond rounding (tested to 1e-9 m over 10^6 samples):
each chunk starts from the pose the previous one ended on. :func:`replay_stream` replays an
iterable of chunks and keeps only what is asked (end pose, or every ``decimate``-th pose).
The per-sample loops of :mod:`umbmark.studies.reference` are the test oracle of both kernels.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from umbmark.errors import InputError
from umbmark.model.geometry import OdometryParams

__all__ = [
    "INTEGRATORS",
    "KERNELS",
    "BLOCK",
    "BLOCK_MAX_RAD",
    "DEFAULT_CHUNK",
    "Poses",
    "integrate",
    "integrate_end",
    "integrate_pulses",
    "integrate_pulses_end",
    "Odometer",
    "replay_stream",
    "StreamResult",
]

INTEGRATORS = ("exact", "midpoint", "euler")
KERNELS = ("fast", "trig")
BLOCK = 32  # samples per block sharing one trig call (float kernel)
BLOCK_MAX_RAD = 0.3  # largest heading change within a block handled by the polynomials
DEFAULT_CHUNK = 1 << 14  # samples per chunk (per run): bounds the working memory; temporaries this
# small are recycled by the allocator (larger chunks are slower: every temporary needs fresh pages)
_SHIFT = 10  # low bits of the cumulative pulse counts looked up directly (table kernel)
_MAX_PAIRS = 4096  # largest table of distinct increment pairs (else: float kernel)

# Taylor coefficients, Horner form: sin d = d (1 - d2/6 (1 - d2/20 (1 - d2/42 (1 - d2/72 (1 - d2/110)))))
_SIN_DIV = (6.0, 20.0, 42.0, 72.0, 110.0)  # truncation: d^13/13! < 3e-17 for |d| <= 0.3
_COS_DIV = (2.0, 12.0, 30.0, 56.0, 90.0, 132.0)  # truncation: d^14/14! < 1e-18
_SINC_DIV = (6.0, 20.0, 42.0, 72.0)  # sin(h)/h to the h^8 term
_SINC_MAX = 0.1  # above this half-angle per sample: numpy.sinc (h^10/11! < 3e-18 below it)


def _check_integrator(integrator):
    if integrator not in INTEGRATORS:
        raise InputError(f"unknown integrator {integrator!r} (use 'exact', 'midpoint' or 'euler')")


def _horner(d2, divs, out):
    """out = 1 - d2/divs[0] (1 - d2/divs[1] (...)); ``out`` must not be ``d2``."""
    np.multiply(d2, -1.0 / divs[-1], out=out)
    out += 1.0
    for dv in reversed(divs[:-1]):
        out *= d2
        out *= -1.0 / dv
        out += 1.0
    return out


class _Work(dict):
    """Reusable scratch arrays, one per name: a chunk reuses the memory of the previous one
    (fresh temporaries for every chunk cost page faults that dominate the run time)."""

    def arr(self, name, shape, dtype=float):
        n = int(np.prod(shape))
        buf = self.get((name, dtype))
        if buf is None or buf.size < n:
            buf = self[(name, dtype)] = np.empty(max(n, 1), dtype)
        return buf[:n].reshape(shape)


def _sinc_half(dth, out, work):
    """out = sin(dth/2) / (dth/2), elementwise (the chord factor of an exact arc)."""
    h = work.arr("h", dth.shape)
    np.multiply(dth, 0.5, out=h)
    if h.size and max(float(h.max()), -float(h.min())) > _SINC_MAX:
        out[...] = np.sinc(h / np.pi)
        return out
    h *= h
    return _horner(h, _SINC_DIV, out)


def _cos_sin_blocks(ref, work):
    """cos and sin of ``ref`` (R, C): one trig call per block of BLOCK samples."""
    R, C = ref.shape
    nb = -(-C // BLOCK)
    shape = (R, nb, BLOCK)
    if nb * BLOCK != C:
        padded = work.arr("pad", (R, nb * BLOCK))
        padded[:, :C] = ref
        padded[:, C:] = ref[:, -1:]
        ref = padded
    r = ref.reshape(shape)
    phi = r[:, :, :1]
    d = work.arr("d", shape)
    np.subtract(r, phi, out=d)
    d2 = work.arr("d2", shape)
    np.multiply(d, d, out=d2)
    s = _horner(d2, _SIN_DIV, work.arr("s", shape))
    s *= d
    c = _horner(d2, _COS_DIV, work.arr("c", shape))
    big = (d.max(axis=2) > BLOCK_MAX_RAD) | (d.min(axis=2) < -BLOCK_MAX_RAD)
    if big.any():
        db = d[big]
        c[big] = np.cos(db)
        s[big] = np.sin(db)
    cp = np.cos(phi)
    sp = np.sin(phi)
    # cos(phi + d) = cp c - sp s ; sin(phi + d) = sp c + cp s
    tmp = d2  # no longer needed
    cos_ = work.arr("cos", shape)
    np.multiply(c, cp, out=cos_)
    np.multiply(s, sp, out=tmp)
    cos_ -= tmp
    sin_ = work.arr("sin", shape)
    np.multiply(c, sp, out=sin_)
    np.multiply(s, cp, out=tmp)
    sin_ += tmp
    return cos_.reshape(R, nb * BLOCK)[:, :C], sin_.reshape(R, nb * BLOCK)[:, :C]


def _float_chunk(dl, dr, b, x0, y0, th0, integrator, poses, dest=None, work=None):
    """One chunk of the float kernel. dl, dr: (R, C); b, x0, y0, th0: (R,).
    Returns (x, y, theta) arrays (R, C) when ``poses`` (written into ``dest`` when given),
    else the end pose (R,) arrays."""
    work = _Work() if work is None else work
    if poses and dest is None:
        dest = tuple(np.empty(dl.shape) for _ in range(3))
    shape = dl.shape
    du = work.arr("du", shape)
    np.add(dl, dr, out=du)
    du *= 0.5
    dth = work.arr("dth", shape)
    np.subtract(dr, dl, out=dth)
    dth /= b[:, None]
    theta = dest[2] if poses else work.arr("theta", shape)
    np.cumsum(dth, axis=1, out=theta)
    theta += th0[:, None]
    ref = work.arr("ref", shape)
    chord = du
    if integrator == "euler":
        np.subtract(theta, dth, out=ref)
    else:
        np.multiply(dth, -0.5, out=ref)
        ref += theta
        if integrator == "exact":
            chord = _sinc_half(dth, work.arr("chord", shape), work)
            chord *= du
    dx, dy = _cos_sin_blocks(ref, work)
    dx *= chord
    dy *= chord
    if poses:
        x = np.cumsum(dx, axis=1, out=dest[0])
        x += x0[:, None]
        y = np.cumsum(dy, axis=1, out=dest[1])
        y += y0[:, None]
        return dest
    return x0 + dx.sum(axis=1), y0 + dy.sum(axis=1), theta[:, -1].copy()


def _table_row(nl, nr, m_l, m_r, b, x0, y0, th0, integrator, poses, cache=None, dest=None, work=None):
    """One run, one chunk of the table kernel (integer increments nl, nr: 1-D int64).
    Returns None when the increments are too varied for tables (caller uses the float kernel)."""
    lmin, lmax = int(nl.min()), int(nl.max())
    rmin, rmax = int(nr.min()), int(nr.max())
    w = rmax - rmin + 1
    if (lmax - lmin + 1) * w > _MAX_PAIRS:
        return None
    work = _Work() if work is None else work
    cache = {} if cache is None else cache
    n = nl.size
    i64 = np.int64
    s_r = np.cumsum(nr, out=work.arr("s_r", n, i64))
    s_l = np.cumsum(nl, out=work.arr("s_l", n, i64))
    # counts before each sample (the heading at the sample start), relative to the chunk start
    pr_ = np.subtract(s_r, nr, out=work.arr("p_r", n, i64))
    pl_ = np.subtract(s_l, nl, out=work.arr("p_l", n, i64))
    a_r, a_l = m_r / b, m_l / b
    los, his = [], []
    for cnt, a, sign in ((pr_, a_r, 1.0), (pl_, a_l, -1.0)):
        lo_c, hi_c = int(cnt.min()), int(cnt.max())
        q0 = lo_c >> _SHIFT
        nq = (hi_c >> _SHIFT) - q0 + 1
        if nq > max(64, n // 8):
            return None
        his.append((q0, np.exp(1j * sign * a * (np.arange(q0, q0 + nq, dtype=i64) << _SHIFT).astype(float))))
        key = (a, sign)
        lo = cache.get(key)
        if lo is None:
            lo = cache[key] = np.exp(1j * sign * a * np.arange(1 << _SHIFT, dtype=float))
        los.append(lo)
    # per-pair displacement in the frame of the sample-start heading
    gl = np.arange(lmin, lmax + 1, dtype=float)[:, None] * m_l
    gr = np.arange(rmin, rmax + 1, dtype=float)[None, :] * m_r
    du = 0.5 * (gl + gr)
    dth = (gr - gl) / b
    if integrator == "euler":
        f = du + 0j
    elif integrator == "midpoint":
        f = du * np.exp(0.5j * dth)
    else:
        f = du * np.sinc(dth / (2.0 * np.pi)) * np.exp(0.5j * dth)
    f = f.ravel()
    f *= complex(math.cos(th0), math.sin(th0))
    idx = np.subtract(nl, lmin, out=work.arr("idx", n, i64))
    idx *= w
    idx += nr
    idx -= rmin
    z = np.take(f, idx, out=work.arr("z", n, complex), mode="clip")
    tmp_c = work.arr("zt", n, complex)
    mask = (1 << _SHIFT) - 1
    for cnt, lo, (q0, hi) in zip((pr_, pl_), los, his):
        np.bitwise_and(cnt, mask, out=idx)
        z *= np.take(lo, idx, out=tmp_c, mode="clip")
        cnt >>= _SHIFT
        if q0:
            cnt -= q0
        z *= np.take(hi, cnt, out=tmp_c, mode="clip")
    if poses:
        p = np.cumsum(z, out=tmp_c)
        d = dest if dest is not None else tuple(np.empty(n) for _ in range(3))
        np.add(p.real, x0, out=d[0])
        np.add(p.imag, y0, out=d[1])
        theta = np.multiply(s_r, a_r, out=d[2])
        theta -= np.multiply(s_l, a_l, out=work.arr("t", n))
        theta += th0
        return d
    tot = z.sum()
    return x0 + tot.real, y0 + tot.imag, th0 + (a_r * s_r[-1] - a_l * s_l[-1])


def _as_state(v, R):
    a = np.asarray(v, dtype=float)
    return np.array(np.broadcast_to(a.reshape(-1) if a.size == R else a, (R,)), dtype=float)


Poses = tuple[np.ndarray, np.ndarray, np.ndarray]
"""``(x, y, theta)``: the poses after each sample, or one end pose."""


class Odometer:
    """Streaming odometry: keeps the pose of ``shape`` independent runs between chunks.

    Each ``update`` consumes chunks of shape ``shape + (C,)`` and returns the poses after each
    sample (or only the end pose with ``poses=False``); :attr:`pose` is the current pose.

    Parameters
    ----------
    wheelbase_m : float or array_like, optional
        Wheelbase [m], scalar or one per run; ``None``: the wheelbase of ``params``.
    pose0 : tuple of float or array_like
        Start pose ``(x, y, theta)``, scalars or one per run.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"``.
    shape : tuple of int
        The leading shape of the runs (``()`` for one log).
    params : OdometryParams, optional
        Metres per pulse of each wheel, for :meth:`update_pulses`.
    chunk : int
        Samples per run integrated at once (bounds the working memory).

    Raises
    ------
    InputError
        On an unknown integrator, a missing or non-positive wheelbase, or ``chunk < 1``.
    """

    def __init__(
        self,
        wheelbase_m: ArrayLike | None = None,
        pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
        integrator: str = "exact",
        shape: tuple = (),
        params: OdometryParams | None = None,
        chunk: int = DEFAULT_CHUNK,
    ) -> None:
        _check_integrator(integrator)
        if wheelbase_m is None:
            if params is None:
                raise InputError("Odometer needs a wheelbase or odometry parameters")
            wheelbase_m = params.wheelbase_m
        self.integrator = integrator
        self.params = params
        self.shape = tuple(shape)
        R = int(np.prod(self.shape)) if self.shape else 1
        self._R = R
        b = _as_state(wheelbase_m, R)
        if not np.all(np.isfinite(b) & (b > 0)):
            raise InputError("wheelbase must be positive and finite")
        self._b = b
        self._x, self._y, self._th = (_as_state(p, R) for p in pose0)
        if chunk < 1:
            raise InputError(f"chunk must be >= 1, got {chunk}")
        self.chunk = int(chunk)
        self.samples = 0
        self._cache: dict = {}
        self._work = _Work()

    @property
    def pose(self) -> tuple[Any, Any, Any]:
        """Current ``(x, y, theta)`` (theta not wrapped): floats for one log, else arrays of the leading shape."""

        def one(a):
            return a.reshape(self.shape) if self.shape else float(a[0])

        return one(self._x), one(self._y), one(self._th)

    def _rows(self, a, name):
        a = np.asarray(a)
        if a.shape[:-1] != self.shape or a.ndim != len(self.shape) + 1:
            raise InputError(f"{name} must have shape {self.shape + ('K',)}, got {a.shape}")
        return a.reshape(self._R, a.shape[-1])

    def update(self, d_left: ArrayLike, d_right: ArrayLike, poses: bool = True) -> tuple[Any, Any, Any]:
        """Consume wheel travel per sample (float kernel).

        Parameters
        ----------
        d_left, d_right : array_like
            Wheel travel [m] per sample, shape ``shape + (C,)``.
        poses : bool
            Return every pose (else only the end pose).

        Returns
        -------
        tuple
            ``(x, y, theta)``: arrays ``shape + (C,)``, or the end pose as :attr:`pose`.

        Raises
        ------
        InputError
            If the shapes do not match.
        """
        dl = self._rows(np.asarray(d_left, dtype=float), "d_left")
        dr = self._rows(np.asarray(d_right, dtype=float), "d_right")
        if dl.shape != dr.shape:
            raise InputError(f"d_left and d_right differ in shape: {dl.shape} vs {dr.shape}")
        return self._run(dl, dr, None, poses)

    def update_pulses(self, n_left: ArrayLike, n_right: ArrayLike, poses: bool = True) -> tuple[Any, Any, Any]:
        """Consume encoder pulse increments per sample.

        Integer increments use the table kernel; anything else the float kernel.

        Parameters
        ----------
        n_left, n_right : array_like
            Pulse increments per sample, shape ``shape + (C,)``.
        poses : bool
            Return every pose (else only the end pose).

        Returns
        -------
        tuple
            ``(x, y, theta)``: arrays ``shape + (C,)``, or the end pose as :attr:`pose`.

        Raises
        ------
        InputError
            Without ``params``, or if the shapes do not match.
        """
        p = self.params
        if p is None:
            raise InputError("update_pulses needs odometry parameters (give `params`)")
        nl = self._rows(np.asarray(n_left), "n_left")
        nr = self._rows(np.asarray(n_right), "n_right")
        if nl.shape != nr.shape:
            raise InputError(f"n_left and n_right differ in shape: {nl.shape} vs {nr.shape}")
        if nl.dtype.kind in "iub" and nr.dtype.kind in "iub":
            return self._run(nl.astype(np.int64, copy=False), nr.astype(np.int64, copy=False), p, poses)
        return self._run(nl * p.left_m_per_pulse, nr * p.right_m_per_pulse, None, poses)

    def _run(self, a, b_, pulses: OdometryParams | None, poses):
        """Integrate (R, K) wheel travel, or integer pulse increments when ``pulses`` gives their metres."""
        R, K = a.shape
        out = [np.empty((R, K)) for _ in range(3)] if poses else []
        C = self.chunk
        for s in range(0, K, C):
            e = min(K, s + C)
            res = None
            dest = tuple(o[:, s:e] for o in out) if poses else None
            if pulses is not None:
                res = self._table(pulses, a[:, s:e], b_[:, s:e], poses, dest)
            if res is None:
                if pulses is not None:
                    dl = a[:, s:e] * pulses.left_m_per_pulse
                    dr = b_[:, s:e] * pulses.right_m_per_pulse
                else:
                    dl, dr = a[:, s:e], b_[:, s:e]
                res = _float_chunk(
                    dl, dr, self._b, self._x, self._y, self._th, self.integrator, poses, dest, self._work
                )
            if dest is not None:
                for o, r in zip(dest, res):
                    if r is not o:
                        o[...] = r
                self._x, self._y, self._th = (np.array(o[:, -1]) for o in dest)
            else:
                self._x, self._y, self._th = (np.asarray(r, dtype=float).reshape(R) for r in res)
        self.samples += K
        if not poses:
            return self.pose
        if K == 0:
            out = [np.empty((R, 0)) for _ in range(3)]
        return tuple(o.reshape(self.shape + (K,)) for o in out)

    def _table(self, p: OdometryParams, nl, nr, poses, dest=None):
        rows = []
        for i in range(nl.shape[0]):
            r = _table_row(
                nl[i],
                nr[i],
                p.left_m_per_pulse,
                p.right_m_per_pulse,
                float(self._b[i]),
                float(self._x[i]),
                float(self._y[i]),
                float(self._th[i]),
                self.integrator,
                poses,
                self._cache,
                None if dest is None else tuple(d[i] for d in dest),
                self._work,
            )
            if r is None:
                return None
            rows.append(r)
        if poses:
            return dest  # written in place, row by row
        return tuple(np.array([r[j] for r in rows]) for j in range(3))


def _trig_poses(d_left, d_right, wheelbase_m, pose0, integrator, end):
    """The ``"trig"`` kernel: one cos and sin per sample, whole arrays (..., K) at once.

    ``wheelbase_m`` broadcasts to the leading shape. Returns the poses after each sample
    (arrays (..., K)), or with ``end`` the end pose (arrays of the leading shape).
    """
    x0, y0, th0 = (np.asarray(p, dtype=float) for p in pose0)
    du = 0.5 * (d_right + d_left)
    dth = (d_right - d_left) / np.asarray(wheelbase_m, dtype=float)[..., None]
    theta = th0[..., None] + np.cumsum(dth, axis=-1)
    if integrator == "euler":
        th_ref, chord = theta - dth, du
    elif integrator == "midpoint":
        th_ref, chord = theta - 0.5 * dth, du
    else:
        # chord of an arc of length du turning dth: du * sin(dth/2) / (dth/2)
        th_ref, chord = theta - 0.5 * dth, du * np.sinc(dth / (2.0 * np.pi))
    dx = chord * np.cos(th_ref)
    dy = chord * np.sin(th_ref)
    if end:
        return x0 + dx.sum(axis=-1), y0 + dy.sum(axis=-1), theta[..., -1]
    return x0[..., None] + np.cumsum(dx, axis=-1), y0[..., None] + np.cumsum(dy, axis=-1), theta


def _check_kernel(kernel: str, integrator: str) -> None:
    if kernel not in KERNELS:
        raise InputError(f"unknown odometry kernel {kernel!r} (use 'fast' or 'trig')")
    _check_integrator(integrator)


def _pair(left, right, names: str, end: bool, dtype=None):
    """The two per-sample arrays of one shape (..., K) (K >= 1 for an end pose), and the leading shape."""
    left = np.asarray(left, dtype=dtype)
    right = np.asarray(right, dtype=dtype)
    if left.ndim == 0 or left.shape != right.shape or (end and left.shape[-1] < 1):
        need = " with K >= 1" if end else ""
        raise InputError(f"{names} must be arrays of one shape (..., K){need}, got {left.shape} and {right.shape}")
    return left, right, left.shape[:-1]


def _pose_for(pose0, shape):
    return tuple(np.broadcast_to(np.asarray(p, dtype=float), shape) for p in pose0)


def _end_of(pose, shape):
    x, y, th = pose
    return (np.asarray(x), np.asarray(y), np.asarray(th)) if shape else (np.float64(x), np.float64(y), np.float64(th))


def integrate(
    d_left: ArrayLike,
    d_right: ArrayLike,
    wheelbase_m: ArrayLike,
    pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
    chunk: int = DEFAULT_CHUNK,
    kernel: str = "fast",
) -> Poses:
    """Integrate per-sample wheel travel into poses.

    Parameters
    ----------
    d_left, d_right : array_like
        Wheel travel [m] per sample, arrays of one shape (..., K); leading axes are
        independent runs.
    wheelbase_m : float or array_like
        Wheelbase [m], a scalar or an array of the leading shape.
    pose0 : tuple
        Start pose ``(x, y, theta)``, each a scalar or an array of the leading shape.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"`` (see the module docstring).
    chunk : int
        Samples per run integrated at once by the ``"fast"`` kernel (bounds the memory).
    kernel : str
        ``"fast"`` or ``"trig"`` (see the module docstring).

    Returns
    -------
    Poses
        ``(x, y, theta)``, each of shape (..., K): the pose after each sample (theta not wrapped).

    Raises
    ------
    InputError
        On arrays of different shapes, an unknown integrator or kernel, or a non-positive wheelbase.

    Examples
    --------
    Four samples of 25 cm on both wheels: one metre straight ahead.

    >>> x, y, theta = integrate(np.full(4, 0.25), np.full(4, 0.25), 0.34)
    >>> print(x, y, theta)
    [0.25 0.5  0.75 1.  ] [0. 0. 0. 0.] [0. 0. 0. 0.]

    Leading axes are runs: two runs of three samples, the second turning on the spot.

    >>> x, y, theta = integrate([[0.1, 0.1, 0.1], [-0.1, -0.1, -0.1]], [[0.1, 0.1, 0.1], [0.1, 0.1, 0.1]], 0.2)
    >>> print(np.round(theta, 6))
    [[0. 0. 0.]
     [1. 2. 3.]]
    """
    d_left, d_right, shape = _pair(d_left, d_right, "d_left and d_right", False, float)
    _check_kernel(kernel, integrator)
    if kernel == "trig":
        return _trig_poses(d_left, d_right, wheelbase_m, pose0, integrator, end=False)
    odo = Odometer(
        np.broadcast_to(np.asarray(wheelbase_m, dtype=float), shape),
        _pose_for(pose0, shape),
        integrator,
        shape,
        chunk=chunk,
    )
    return odo.update(d_left, d_right, poses=True)


def integrate_end(
    d_left: ArrayLike,
    d_right: ArrayLike,
    wheelbase_m: ArrayLike,
    pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
    chunk: int = DEFAULT_CHUNK,
    kernel: str = "fast",
) -> tuple[Any, Any, Any]:
    """The end pose of :func:`integrate` (same parameters; K must be >= 1).

    Returns
    -------
    tuple
        ``(x, y, theta)`` after the last sample: arrays of the leading shape (numpy floats for
        1-D input).

    Raises
    ------
    InputError
        On arrays of different shapes or without samples, an unknown integrator or kernel, or a
        non-positive wheelbase.

    Examples
    --------
    The right wheel rolling 1 % further than the left on a 1 m drive curves the path to the
    left, about 15 mm; an Euler integrator, which moves along the heading at a sample's start,
    falls short of the exact arcs:

    >>> left, right = np.full(100, 0.01), np.full(100, 0.0101)
    >>> [round(float(v), 4) for v in integrate_end(left, right, 0.34)]
    [1.0049, 0.0148, 0.0294]
    >>> [round(float(v), 4) for v in integrate_end(left, right, 0.34, integrator="euler")]
    [1.0049, 0.0146, 0.0294]
    """
    d_left, d_right, shape = _pair(d_left, d_right, "d_left and d_right", True, float)
    _check_kernel(kernel, integrator)
    if kernel == "trig":
        return _end_of(_trig_poses(d_left, d_right, wheelbase_m, pose0, integrator, end=True), shape)
    odo = Odometer(
        np.broadcast_to(np.asarray(wheelbase_m, dtype=float), shape),
        _pose_for(pose0, shape),
        integrator,
        shape,
        chunk=chunk,
    )
    return _end_of(odo.update(d_left, d_right, poses=False), shape)


def integrate_pulses(
    n_left: ArrayLike,
    n_right: ArrayLike,
    params: OdometryParams,
    pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
    chunk: int = DEFAULT_CHUNK,
    kernel: str = "fast",
) -> Poses:
    """Poses from encoder pulse increments (Eqs. 2.2, 2.3).

    With the ``"fast"`` kernel, integer increments use the table kernel, others the float
    kernel on ``n * m_per_pulse``.

    Parameters
    ----------
    n_left, n_right : array_like
        Pulse increments per sample, arrays of one shape (..., K); leading axes are
        independent runs.
    params : OdometryParams
        Metres per pulse of each wheel and the wheelbase.
    pose0 : tuple
        Start pose ``(x, y, theta)``, each a scalar or an array of the leading shape.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"``.
    chunk : int
        Samples per run integrated at once by the ``"fast"`` kernel.
    kernel : str
        ``"fast"`` or ``"trig"``.

    Returns
    -------
    Poses
        ``(x, y, theta)``, each of shape (..., K).

    Raises
    ------
    InputError
        On arrays of different shapes, an unknown integrator or kernel.
    """
    n_left, n_right, shape = _pair(n_left, n_right, "n_left and n_right", False)
    _check_kernel(kernel, integrator)
    if kernel == "trig":
        return _trig_poses(
            np.asarray(n_left, dtype=float) * params.left_m_per_pulse,
            np.asarray(n_right, dtype=float) * params.right_m_per_pulse,
            params.wheelbase_m,
            pose0,
            integrator,
            end=False,
        )
    odo = Odometer(None, _pose_for(pose0, shape), integrator, shape, params=params, chunk=chunk)
    return odo.update_pulses(n_left, n_right, poses=True)


def integrate_pulses_end(
    n_left: ArrayLike,
    n_right: ArrayLike,
    params: OdometryParams,
    pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
    chunk: int = DEFAULT_CHUNK,
    kernel: str = "fast",
) -> tuple[Any, Any, Any]:
    """The end pose of :func:`integrate_pulses` (same parameters; K must be >= 1).

    Returns
    -------
    tuple
        ``(x, y, theta)`` after the last sample: arrays of the leading shape (numpy floats for
        1-D input).

    Raises
    ------
    InputError
        On arrays of different shapes or without samples, an unknown integrator or kernel.

    Examples
    --------
    One robot's encoders count the same pulses on both wheels. Its nominal odometry says it
    drove straight; its true wheels (the right one 1 % larger, E_d = 1.01) went left:

    >>> from umbmark.model.geometry import LABMATE, ErrorParams
    >>> n = np.full(1000, 21)  # pulses per sample, both wheels
    >>> nominal = OdometryParams.from_geometry(LABMATE)
    >>> [round(float(v), 3) for v in integrate_pulses_end(n, n, nominal)]
    [0.99, 0.0, 0.0]
    >>> [round(float(v), 3) for v in integrate_pulses_end(n, n, ErrorParams(ed=1.01).true_params(LABMATE))]
    [0.989, 0.014, 0.029]
    """
    n_left, n_right, shape = _pair(n_left, n_right, "n_left and n_right", True)
    _check_kernel(kernel, integrator)
    if kernel == "trig":
        return _end_of(
            _trig_poses(
                np.asarray(n_left, dtype=float) * params.left_m_per_pulse,
                np.asarray(n_right, dtype=float) * params.right_m_per_pulse,
                params.wheelbase_m,
                pose0,
                integrator,
                end=True,
            ),
            shape,
        )
    odo = Odometer(None, _pose_for(pose0, shape), integrator, shape, params=params, chunk=chunk)
    return _end_of(odo.update_pulses(n_left, n_right, poses=False), shape)


@dataclass
class StreamResult:
    """Outcome of :func:`replay_stream`.

    Parameters
    ----------
    x, y, theta : float
        End pose (theta not wrapped).
    samples : int
        Samples replayed.
    kept : dict or None
        The kept poses: arrays (M,) ``sample`` (counted from 1), ``x``, ``y``, ``theta``; or
        None when only the end pose was asked for.
    """

    x: float
    y: float
    theta: float
    samples: int
    kept: dict | None = None


def replay_stream(
    chunks: Iterable[tuple[ArrayLike, ArrayLike]],
    params: OdometryParams | None = None,
    wheelbase_m: float | None = None,
    pose0: Iterable[ArrayLike] = (0.0, 0.0, 0.0),
    integrator: str = "exact",
    pulses: bool = True,
    decimate: int | None = None,
    chunk: int = DEFAULT_CHUNK,
) -> StreamResult:
    """Replay one log given as an iterable of ``(left, right)`` chunks, in bounded memory.

    Only the current chunk and the kept poses are held.

    Parameters
    ----------
    chunks : iterable of (array_like, array_like)
        1-D chunks of the log, in order.
    params : OdometryParams, optional
        Metres per pulse of each wheel (needed with ``pulses``).
    wheelbase_m : float, optional
        Wheelbase [m]; ``None``: the wheelbase of ``params``.
    pose0 : tuple of float
        Start pose ``(x, y, theta)``.
    integrator : str
        ``"exact"``, ``"midpoint"`` or ``"euler"``.
    pulses : bool
        Chunks are encoder increments (else wheel travel [m]).
    decimate : int, optional
        Keep the pose after every n-th sample (samples n, 2n, ... counted from 1); ``None``:
        keep only the end pose.
    chunk : int
        Samples integrated at once.

    Returns
    -------
    StreamResult

    Raises
    ------
    InputError
        On ``decimate < 1`` or the errors of :class:`Odometer`.
    """
    if decimate is not None and decimate < 1:
        raise InputError(f"decimate must be >= 1, got {decimate}")
    odo = Odometer(wheelbase_m, pose0, integrator, (), params=params, chunk=chunk)
    kept: dict[str, list] = {"sample": [], "x": [], "y": [], "theta": []}
    for left, right in chunks:
        start = odo.samples
        res = (
            odo.update_pulses(left, right, poses=bool(decimate))
            if pulses
            else odo.update(left, right, poses=bool(decimate))
        )
        if decimate:
            k = np.asarray(left).shape[-1]
            first = (-(start + 1)) % decimate
            sel = np.arange(first, k, decimate)
            kept["sample"].append(start + sel + 1)
            for name, arr in zip(("x", "y", "theta"), res):
                kept[name].append(arr[sel])
    x, y, th = odo.pose
    out = {k: (np.concatenate(v) if v else np.empty(0)) for k, v in kept.items()} if decimate else None
    return StreamResult(x, y, th, odo.samples, out)
