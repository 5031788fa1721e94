"""The scan matcher's compiled kernels (numba when installed) and their compiling: the point-to-line
ICP of :mod:`umbmark.realrobot.scanmatch` on arrays, with the layouts of its settings and results.

Kept apart from the matcher's configuration, results and public functions because the kernels
are long and compiled whole; :mod:`umbmark.realrobot.scanmatch` documents the method. Imports
numpy and :mod:`umbmark._numba` (numba lazily, on the first match).
"""

from __future__ import annotations

import math
import subprocess
import sys
import threading
from typing import Any

import numpy as np

from umbmark._numba import numba_module

__all__ = ["have_numba", "kernel_state", "start_compiling"]

# the outlier threshold never drops below this: on noise-free scans the residuals at the solution are
# rounding errors, and a threshold relative to them would keep an arbitrary (possibly degenerate) subset
_OUTLIER_FLOOR_M = 1e-6

# status codes of the compiled kernel
_OK, _FEW_REF, _FEW_CUR, _FEW_CORR, _DEGENERATE, _MAX_ITER, _FEW_INLIERS, _SINGULAR = range(8)

# layout of the kernel's per-pair output row
# (pose 3, covariance 9, rms, kept correspondences, valid current points, reference points with a
# line, iterations, status, constraint ratio, last step (m, rad), inliers)
_O_POSE, _O_COV, _O_RMS, _O_NIN, _O_NCUR, _O_NREF, _O_ITER, _O_STATUS, _O_RATIO, _O_STEP = (
    0,
    3,
    12,
    13,
    14,
    15,
    16,
    17,
    18,
    19,
)
_O_NCLOSE = 21
_O_WIDTH = 22


# ---------------------------------------------------------------- kernels (numba when installed)

# integer settings (``ip``) and real settings (``fp``) of the kernels, by index
_I_MAX_ITER, _I_LINE_POINTS, _I_MIN_POINTS, _I_COARSE, _I_CANDIDATES = range(5)
_I_WIDTH = 5
(
    _F_GATE,
    _F_TRIM,
    _F_OUT_SIGMAS,
    _F_LINE_RMS,
    _F_LINE_GAP,
    _F_TOL_M,
    _F_TOL_RAD,
    _F_TOL_SIGMA,
    _F_INLIER_M,
    _F_MIN_INLIERS,
    _F_MIN_RATIO,
    _F_COV_SCALE,
    _F_RANGE_MIN,
    _F_RANGE_MAX,
    _F_COARSE_M,
    _F_COARSE_RAD,
    _F_STEP_M,
    _F_STEP_RAD,
    _F_GAP_RATIO,
    _F_SPLIT_M,
    _F_SPLIT_SIGMAS,
    _F_NORMAL_SD,
) = range(22)
_F_WIDTH = 22

# a scan's arrays: rows of the float array ``pts`` and of the boolean array ``flags``
# point; unit normal and a point of its line; the extent of the line (along (-ny, nx) from that point)
_P_X, _P_Y, _P_NX, _P_NY, _P_LX, _P_LY, _P_U0, _P_U1 = range(8)
_P_WIDTH = 8
_B_VALID, _B_LINE, _B_WEAK = range(3)  # a valid return; a line was fitted; its direction is uncertain
_B_WIDTH = 3


def _split_pieces(x, y, order, nv, gap2, ratio2, split, iwork):
    """Cut the valid points (in beam order) into straight pieces; returns their number.

    A piece ends where consecutive points are further apart than ``sqrt(gap2)`` and than
    ``sqrt(ratio2)`` times the range of the nearer one; each run between such gaps is split
    recursively at its point furthest from the chord of its end points while that distance
    exceeds ``split``; the split point is on both pieces (it may be the corner, or next to it on
    either wall: :func:`_fit_pieces` leaves it out of the line it is off). Rows of ``iwork``: 0
    and 1 the first and last position of each piece in ``order``, 2 and 3 whether that end is a
    split point, 4 and 5 the stack.
    """
    seg_a = iwork[0]
    seg_b = iwork[1]
    cut_a = iwork[2]
    cut_b = iwork[3]
    stack_a = iwork[4]
    stack_b = iwork[5]
    nseg = 0
    start = 0
    for t in range(1, nv + 1):
        if t < nv:
            k = order[t]
            kp = order[t - 1]
            lim2 = max(gap2, ratio2 * min(x[k] * x[k] + y[k] * y[k], x[kp] * x[kp] + y[kp] * y[kp]))
            if (x[k] - x[kp]) ** 2 + (y[k] - y[kp]) ** 2 <= lim2:
                continue
        # the stack holds a piece as (first, last); a split end is stored as -1 - position
        ns = 1
        stack_a[0] = start
        stack_b[0] = t - 1
        while ns > 0:
            ns -= 1
            a = stack_a[ns]
            b = stack_b[ns]
            ca = a < 0
            cb = b < 0
            if ca:
                a = -1 - a
            if cb:
                b = -1 - b
            best = -1.0
            bq = a
            if b - a >= 2:
                ka = order[a]
                kb = order[b]
                cx = x[kb] - x[ka]
                cy = y[kb] - y[ka]
                cl = math.sqrt(cx * cx + cy * cy)
                for q in range(a + 1, b):
                    k = order[q]
                    if cl > 0.0:
                        d = abs((x[k] - x[ka]) * cy - (y[k] - y[ka]) * cx) / cl
                    else:
                        d = math.sqrt((x[k] - x[ka]) ** 2 + (y[k] - y[ka]) ** 2)
                    if d > best:
                        best = d
                        bq = q
            if best > split:
                stack_a[ns] = -1 - a if ca else a
                stack_b[ns] = -1 - bq
                stack_a[ns + 1] = -1 - bq
                stack_b[ns + 1] = -1 - b if cb else b
                ns += 2
            else:
                seg_a[nseg] = a
                seg_b[nseg] = b
                cut_a[nseg] = 1 if ca else 0
                cut_b[nseg] = 1 if cb else 0
                nseg += 1
        start = t
    return nseg


def _tls(x, y, order, a, b):
    """Total least squares line of the points ``order[a..b]``: (normal x, y, centroid x, y, sum
    of squared distances to the line, scatter along it); the normal is ``nan`` for coincident
    points."""
    cnt = b - a + 1
    # moments about the first point (no cancellation far from the sensor)
    k0 = order[a]
    x0 = x[k0]
    y0 = y[k0]
    sx = sy = sxx = sxy = syy = 0.0
    for q in range(a, b + 1):
        k = order[q]
        u = x[k] - x0
        v = y[k] - y0
        sx += u
        sy += v
        sxx += u * u
        sxy += u * v
        syy += v * v
    mx = sx / cnt
    my = sy / cnt
    ca = sxx - cnt * mx * mx
    cb = sxy - cnt * mx * my
    cc = syy - cnt * my * my
    h = 0.5 * (ca - cc)
    root = math.sqrt(h * h + cb * cb)
    lam = max(0.5 * (ca + cc) - root, 0.0)
    # the eigenvector of the smallest eigenvalue is the normal
    if h > 0.0:
        vx = cb
        vy = lam - ca
    else:
        vx = lam - cc
        vy = cb
    nn = math.sqrt(vx * vx + vy * vy)
    if not nn > 0.0:
        return math.nan, math.nan, mx + x0, my + y0, lam, 0.5 * (ca + cc) + root
    return vx / nn, vy / nn, mx + x0, my + y0, lam, 0.5 * (ca + cc) + root


def _fit_pieces(x, y, order, nseg, iwork, fits, m, max_rms2, noise2):
    """The total least squares line of every piece: rows of ``fits`` (normal x, y; centroid x, y;
    sum of squared distances to the line; scatter along it), normal x ``nan`` when fewer than
    ``m`` points fit or their residual (root mean square) exceeds ``sqrt(max_rms2)``.

    An end point more than four standard deviations off the line of the other points (their
    residual, at least ``noise2``) is left out of the fit, repeatedly: a point of the next
    surface that the split tolerance let in. Rows 2 and 3 of ``iwork`` become the numbers of points left
    out at the first and the last end.
    """
    for s in range(nseg):
        a = iwork[0, s]
        b = iwork[1, s]
        fits[0, s] = math.nan
        nx = ny = lx = ly = lam = lal = math.nan
        while True:
            nx, ny, lx, ly, lam, lal = _tls(x, y, order, a, b)
            if not nx == nx or b - a + 1 <= 2:
                break
            # each end point against the line of the others: leave out the worse one if it is
            # more than four standard deviations (of the others, at least the noise) off
            worst = 0.0
            side = 0
            for e in range(2):
                ke = order[a] if e == 0 else order[b]
                fnx, fny, flx, fly, flam, _ = _tls(x, y, order, a + 1 - e, b - e)
                if not fnx == fnx:
                    continue
                d2 = (fnx * (x[ke] - flx) + fny * (y[ke] - fly)) ** 2
                z2 = d2 / (16.0 * max(flam / max(b - a - 2, 1), noise2) + 1e-24)
                if z2 > worst:
                    worst = z2
                    side = e
            if worst <= 1.0:
                break
            if side == 0:
                a += 1
            else:
                b -= 1
        cnt = b - a + 1
        iwork[2, s] = a - iwork[0, s]
        iwork[3, s] = iwork[1, s] - b
        if cnt < m or not nx == nx or lam > max_rms2 * cnt:
            continue
        fits[0, s] = nx
        fits[1, s] = ny
        fits[2, s] = lx
        fits[3, s] = ly
        fits[4, s] = lam
        fits[5, s] = lal


def _scan_noise(iwork, fits, nseg, vals):
    """The scan's noise: the median, over the points of the lines of 5 points or more, of their
    line's residual variance (squared metres; 0 without such a line)."""
    nval = 0
    for s in range(nseg):
        cnt = iwork[1, s] - iwork[3, s] - iwork[0, s] - iwork[2, s] + 1
        if cnt >= 5 and fits[0, s] == fits[0, s]:
            v = fits[4, s] / (cnt - 2)
            for _ in range(cnt):
                vals[nval] = v
                nval += 1
    if nval == 0:
        return 0.0
    return _kth_smallest(vals, nval, nval // 2)


def _fit_lines(pts, flags, wrap, ip, fp, work, order, iwork, fits):
    """The reference line of every valid point: the line of the straight piece of the scan it is on.

    The valid points are taken in the order of the beams (a full circle starting after its
    widest gap) and cut into straight pieces (:func:`_split_pieces`) three times: first within
    1.5 ``line_max_rms_m``, then within ``line_split_sigmas`` times the noise of the pieces of
    the round before (:func:`_scan_noise`; at least ``line_split_m``). A piece whose line
    (:func:`_fit_pieces`) fits ``line_points`` or more points within ``line_max_rms_m`` gives its
    points that line, the extent of its points along it (half a point spacing beyond the ends)
    and, when the direction of the line is uncertain by more than ``line_max_normal_sd_rad``
    (its residual variance, at least the scan's noise, over the scatter along it), the weak
    flag. A point where two pieces meet takes the nearer line. ``work`` is a ``(5, n)`` scratch
    array, ``order`` ``(n,)`` and ``iwork`` ``(6, n + 1)`` integer ones, ``fits``
    ``(7, 2 n + 2)``. Returns the number of points with a line.
    """
    x = pts[_P_X]
    y = pts[_P_Y]
    valid = flags[_B_VALID]
    m = ip[_I_LINE_POINTS]
    nv = 0
    for i in range(x.size):
        flags[_B_LINE, i] = False
        flags[_B_WEAK, i] = False
        if valid[i]:
            order[nv] = i
            nv += 1
    if nv < m:
        return 0
    if wrap:
        # start after the widest gap, so that a wall across the first and last beam stays whole
        bg = -1.0
        bt = 0
        for t in range(nv):
            k = order[t]
            kp = order[t - 1] if t > 0 else order[nv - 1]
            g = (x[k] - x[kp]) ** 2 + (y[k] - y[kp]) ** 2
            if g > bg:
                bg = g
                bt = t
        tmp = iwork[4]
        for t in range(nv):
            tmp[t] = order[(t + bt) % nv]
        for t in range(nv):
            order[t] = tmp[t]
    gap2 = fp[_F_LINE_GAP] ** 2
    ratio2 = fp[_F_GAP_RATIO] ** 2
    max_rms2 = fp[_F_LINE_RMS] ** 2
    split_min = fp[_F_SPLIT_M]
    # the noise of the pieces within a generous tolerance sets the tolerance of the next cut;
    # a second round removes what corners inside the first pieces added to the noise
    split = 1.5 * fp[_F_LINE_RMS]
    noise2 = 0.0
    for _ in range(3):
        nseg = _split_pieces(x, y, order, nv, gap2, ratio2, split, iwork)
        _fit_pieces(x, y, order, nseg, iwork, fits, m, max_rms2, noise2)
        noise2 = _scan_noise(iwork, fits, nseg, fits[6])
        split = max(split_min, fp[_F_SPLIT_SIGMAS] * math.sqrt(noise2))
    sd2 = fp[_F_NORMAL_SD] ** 2
    dist = work[0]
    for t in range(nv):
        dist[t] = math.inf
    count = 0
    for s in range(nseg):
        if not fits[0, s] == fits[0, s]:
            continue
        a = iwork[0, s]
        b = iwork[1, s]
        cnt = b - a + 1 - iwork[2, s] - iwork[3, s]
        nx = fits[0, s]
        ny = fits[1, s]
        lx = fits[2, s]
        ly = fits[3, s]
        weak = max(fits[4, s] / max(cnt - 2, 1), noise2) > sd2 * fits[5, s]
        umin = math.inf
        umax = -math.inf
        for q in range(a, b + 1):
            k = order[q]
            u = nx * (y[k] - ly) - ny * (x[k] - lx)
            umin = min(umin, u)
            umax = max(umax, u)
        pad = 0.5 * (umax - umin) / max(cnt - 1, 1)
        for q in range(a, b + 1):
            k = order[q]
            d = abs(nx * (x[k] - lx) + ny * (y[k] - ly))
            if d < dist[q]:
                if dist[q] == math.inf:
                    count += 1
                dist[q] = d
                pts[_P_NX, k] = nx
                pts[_P_NY, k] = ny
                pts[_P_LX, k] = lx
                pts[_P_LY, k] = ly
                pts[_P_U0, k] = umin - pad
                pts[_P_U1, k] = umax + pad
                flags[_B_LINE, k] = True
                flags[_B_WEAK, k] = weak
    return count


def _prepare_scan(r, cosa, sina, wrap, ip, fp, pts, flags, work, order, iwork, fits):
    """The points of one scan and the line of each; returns (valid points, points with a line)."""
    n = r.size
    rmin = fp[_F_RANGE_MIN]
    rmax = fp[_F_RANGE_MAX]
    nvalid = 0
    for i in range(n):
        ri = r[i]
        ok = math.isfinite(ri) and ri > 0.0 and ri >= rmin and ri <= rmax
        flags[_B_VALID, i] = ok
        pts[_P_X, i] = ri * cosa[i] if ok else 0.0
        pts[_P_Y, i] = ri * sina[i] if ok else 0.0
        if ok:
            nvalid += 1
    nline = _fit_lines(pts, flags, wrap, ip, fp, work, order, iwork, fits)
    return nvalid, nline


def _kth_smallest(a, n, k):
    """The k-th smallest (0-based) of ``a[:n]``, reordering ``a`` (quickselect)."""
    lo = 0
    hi = n - 1
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i = lo
        j = hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                t = a[i]
                a[i] = a[j]
                a[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return a[k]
    return a[k]


def _sym3_eigen_ratio(a00, a01, a02, a11, a12, a22):
    """Smallest over largest eigenvalue of a symmetric positive semi-definite 3x3 matrix."""
    q = (a00 + a11 + a22) / 3.0
    if not q > 0.0:
        return 0.0
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    p = math.sqrt(((a00 - q) ** 2 + (a11 - q) ** 2 + (a22 - q) ** 2 + 2.0 * p1) / 6.0)
    if p < 1e-12 * q:
        return 1.0  # a multiple of the identity
    b00 = (a00 - q) / p
    b11 = (a11 - q) / p
    b22 = (a22 - q) / p
    b01 = a01 / p
    b02 = a02 / p
    b12 = a12 / p
    det_b = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02)
    phi = math.acos(min(1.0, max(-1.0, 0.5 * det_b))) / 3.0
    e_max = q + 2.0 * p * math.cos(phi)
    e_min = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return max(e_min, 0.0) / e_max


def _icp(rpts, rflags, cpts, cflags, ncur, beams, sin2, pose0, ip, fp, wf, wn, wi, out):
    """Point-to-line ICP of one pair from ``pose0``; fills ``out`` (the ``_O_*`` layout).

    ``beams`` is ``(first angle, increment, 1.0 for a full circle)``; ``sin2[d]`` the squared sine
    of the smallest angle to a beam ``d`` steps away; ``wf`` (5, n), ``wn`` (2, n) and ``wi`` (n)
    are scratch arrays.
    """
    rx = rpts[_P_X]
    ry = rpts[_P_Y]
    rnx = rpts[_P_NX]
    rny = rpts[_P_NY]
    rlx = rpts[_P_LX]
    rly = rpts[_P_LY]
    rline = rflags[_B_LINE]
    rweak = rflags[_B_WEAK]
    ru0 = rpts[_P_U0]
    ru1 = rpts[_P_U1]
    cx = cpts[_P_X]
    cy = cpts[_P_Y]
    cvalid = cflags[_B_VALID]
    wr = wf[0]  # residual
    wa = wf[1]  # its absolute value (reordered by the selections)
    wj0 = wf[2]  # Jacobian: the normal, and the rotation column
    wj1 = wf[3]
    wj2 = wf[4]
    wc = wn[0]  # the current point of the correspondence
    wk = wn[1]  # its reference point
    n = rx.size
    inc = beams[1]
    wrap = beams[2] > 0.0
    half = 0.5 * (n - 1)
    amid = beams[0] + half * inc
    amid = math.atan2(math.sin(amid), math.cos(amid))
    maxd = n // 2 + 1 if wrap else n
    max_iter = ip[_I_MAX_ITER]
    min_points = ip[_I_MIN_POINTS]
    gate2 = fp[_F_GATE] ** 2
    keep = 1.0 - fp[_F_TRIM]
    k_mad = fp[_F_OUT_SIGMAS]
    tol_t = fp[_F_TOL_M]
    tol_r = fp[_F_TOL_RAD]
    tol_s2 = fp[_F_TOL_SIGMA] ** 2
    close_m = fp[_F_INLIER_M]
    tx = pose0[0]
    ty = pose0[1]
    th = pose0[2]
    status = _MAX_ITER
    it = 0
    frozen = False  # the correspondences are kept fixed
    robust = not k_mad > 0.0  # the second stage is on (or not wanted)
    px1 = py1 = pt1 = math.inf  # the poses after the last two steps
    px2 = py2 = pt2 = math.inf
    m = 0
    nin = 0
    nclose = 0
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    ssr = 0.0
    ssp = 0.0
    st = 0.0
    sr = 0.0
    while it < max_iter:
        c = math.cos(th)
        s = math.sin(th)
        if frozen:
            # the correspondences and the kept set of the last update, at the new pose
            for q in range(m):
                j = wc[q]
                kb = wk[q]
                qx = c * cx[j] - s * cy[j]
                qy = s * cx[j] + c * cy[j]
                wr[q] = rnx[kb] * (qx + tx - rlx[kb]) + rny[kb] * (qy + ty - rly[kb])
                wj2[q] = rny[kb] * qx - rnx[kb] * qy
        else:
            m = 0
            nclose = 0
            for j in range(cx.size):
                if not cvalid[j]:
                    continue
                qx = c * cx[j] - s * cy[j]
                qy = s * cx[j] + c * cy[j]
                px = qx + tx
                py = qy + ty
                r2 = px * px + py * py
                # the beam of the point's direction (counted from the middle of the field of view)
                da = math.atan2(py, px) - amid
                if da > math.pi:
                    da -= 2.0 * math.pi
                elif da < -math.pi:
                    da += 2.0 * math.pi
                k0 = int(math.floor(da / inc + half + 0.5))
                if wrap:
                    k0 = k0 % n
                elif k0 < 0:
                    k0 = 0
                elif k0 >= n:
                    k0 = n - 1
                # nearest reference point with a line: outwards from k0 until the beams' rays
                # are further than the best distance so far
                best = gate2
                kb = -1
                for d in range(maxd):
                    if r2 * sin2[d] > best:
                        break
                    for side in range(2 if d > 0 else 1):
                        k = k0 + d if side == 0 else k0 - d
                        if wrap:
                            if k >= n:
                                k -= n
                            elif k < 0:
                                k += n
                        elif k < 0 or k >= n:
                            continue
                        if rline[k]:
                            dx = px - rx[k]
                            dy = py - ry[k]
                            dd = dx * dx + dy * dy
                            if dd < best:
                                best = dd
                                kb = k
                if kb < 0:
                    continue
                res = rnx[kb] * (px - rlx[kb]) + rny[kb] * (py - rly[kb])
                if abs(res) <= close_m:
                    nclose += 1
                # the line must be what the current sensor sees there: its ray through the point
                # meets the line within the extent of the line's points (and within the gate)
                rho = math.sqrt(qx * qx + qy * qy)
                den = (rnx[kb] * qx + rny[kb] * qy) / rho if rho > 0.0 else 0.0
                if abs(den) < 1e-6:
                    continue
                hit = rho - res / den  # range of the line along the ray
                hx = tx + qx * (hit / rho)
                hy = ty + qy * (hit / rho)
                u = rnx[kb] * (hy - rly[kb]) - rny[kb] * (hx - rlx[kb])
                if hit <= 0.0 or (hit - rho) ** 2 > gate2 or u < ru0[kb] or u > ru1[kb]:
                    continue
                wr[m] = res
                wa[m] = abs(res)
                wj0[m] = rnx[kb]
                wj1[m] = rny[kb]
                wj2[m] = rny[kb] * qx - rnx[kb] * qy
                wc[m] = j
                wk[m] = kb
                m += 1
            if m < min_points:
                status = _FEW_CORR
                nin = m
                break
            if robust and k_mad > 0.0:
                # second stage: the residuals beyond k_mad robust deviations (1.4826 median |r|) out
                thr = max(k_mad * 1.4826 * _kth_smallest(wa, m, m // 2), _OUTLIER_FLOOR_M)
            else:
                # first stage: the largest trim fraction of the residuals out
                kk = max(int(math.ceil(keep * m)) - 1, min(m, min_points) - 1)
                thr = _kth_smallest(wa, m, kk)
            # the lines of uncertain direction take part in the selection, not in the estimate
            for q in range(m):
                wi[q] = abs(wr[q]) <= thr and not rweak[wk[q]]
        # the normal equations of the kept correspondences
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        g0 = g1 = g2 = 0.0
        ssr = 0.0
        ssp = 0.0
        nin = 0
        for q in range(m):
            if not wi[q]:
                continue
            res = wr[q]
            j0 = wj0[q]
            j1 = wj1[q]
            j2 = wj2[q]
            h00 += j0 * j0
            h01 += j0 * j1
            h02 += j0 * j2
            h11 += j1 * j1
            h12 += j1 * j2
            h22 += j2 * j2
            g0 += j0 * res
            g1 += j1 * res
            g2 += j2 * res
            ssr += res * res
            ssp += j2 * j2
            nin += 1
        # closed-form solve of H d = -g (adjugate over determinant)
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        det = h00 * c00 + h01 * c01 + h02 * c02
        if not (math.isfinite(det) and abs(det) > 1e-14 * (h00 + h11) * h22):
            status = _SINGULAR
            break
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        d0 = -(c00 * g0 + c01 * g1 + c02 * g2) / det
        d1 = -(c01 * g0 + c11 * g1 + c12 * g2) / det
        d2 = -(c02 * g0 + c12 * g1 + c22 * g2) / det
        # no step beyond the correspondence gate: a direction the lines leave almost free (a
        # corridor) must not throw the pose out of reach of every correspondence
        sl = math.sqrt(d0 * d0 + d1 * d1)
        if sl > fp[_F_GATE]:
            f = fp[_F_GATE] / sl
            d0 *= f
            d1 *= f
            d2 *= f
        tx += d0
        ty += d1
        th += d2
        it += 1
        st = math.sqrt(d0 * d0 + d1 * d1)
        sr = abs(d2)
        # settled: the step is below the tolerances, or below tolerance_sigma standard deviations
        # of the estimate (d' H d / sigma^2); the first stage only has to come within ten times that
        settled = st < tol_t and sr < tol_r
        if not settled and nin > 3 and ssr > 0.0:
            q2 = (
                h00 * d0 * d0 + h11 * d1 * d1 + h22 * d2 * d2
                + 2.0 * (h01 * d0 * d1 + h02 * d0 * d2 + h12 * d1 * d2)
            )  # fmt: skip
            settled = q2 * (nin - 3) < (tol_s2 if robust else 100.0 * tol_s2) * ssr
        if settled:
            if robust:
                status = _OK
                break
            # second stage, from this close pose on: a threshold relative to the median residual
            # is safe only near the solution (from far off, the residuals of one well-seen wall
            # could shut out the walls that fix the other directions)
            robust = True
            frozen = False
            px1 = py1 = pt1 = px2 = py2 = pt2 = math.inf
            continue
        # a cycle between correspondence sets (back to the pose of two steps ago), or half the
        # iterations spent: keep the correspondences fixed and solve that problem to the end
        cycle = abs(tx - px2) < tol_t and abs(ty - py2) < tol_t and abs(th - pt2) < tol_r
        if cycle or it >= max_iter // 2:
            frozen = True
        px2 = px1
        py2 = py1
        pt2 = pt1
        px1 = tx
        py1 = ty
        pt1 = th
    for q in range(_O_WIDTH):
        out[q] = math.nan
    out[_O_POSE] = tx
    out[_O_POSE + 1] = ty
    out[_O_POSE + 2] = math.atan2(math.sin(th), math.cos(th))
    out[_O_NIN] = nin
    out[_O_NCUR] = ncur
    out[_O_ITER] = it
    out[_O_STEP] = st
    out[_O_STEP + 1] = sr
    out[_O_NCLOSE] = nclose
    if nin > 0 and status != _FEW_CORR:
        out[_O_RMS] = math.sqrt(ssr / nin)
    if status == _OK or status == _MAX_ITER:
        # covariance sigma^2 H^-1, sigma^2 the residual variance with n - 3 degrees of freedom
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        det = h00 * c00 + h01 * c01 + h02 * c02
        f = fp[_F_COV_SCALE] * ssr / max(nin - 3, 1) / det
        out[_O_COV + 0] = f * c00
        out[_O_COV + 1] = f * c01
        out[_O_COV + 2] = f * c02
        out[_O_COV + 3] = f * c01
        out[_O_COV + 4] = f * c11
        out[_O_COV + 5] = f * c12
        out[_O_COV + 6] = f * c02
        out[_O_COV + 7] = f * c12
        out[_O_COV + 8] = f * c22
        # the rotation in metres at the points' rms lever arm, so that the eigenvalues compare
        sl = 1.0 / math.sqrt(ssp / nin) if ssp > 0.0 else 1.0
        ratio = _sym3_eigen_ratio(h00, h01, h02 * sl, h11, h12 * sl, h22 * sl * sl)
        out[_O_RATIO] = ratio
        if ratio < fp[_F_MIN_RATIO]:
            # also the reason when the iteration wandered along the free direction without end
            status = _DEGENERATE
        elif status == _OK and nclose < fp[_F_MIN_INLIERS] * ncur:
            status = _FEW_INLIERS
    out[_O_STATUS] = status


def _coarse_peaks(rpts, rflags, cpts, cflags, pose0, fp, peaks):
    """Correlative grid search around ``pose0``: the best distinct poses into the rows of ``peaks``.

    The reference points are spread on a grid of ``coarse_step_m`` cells (a Gaussian of that
    width); every rotation step and translation step within the search window scores the sum of
    the grid cells the current points fall in. Returns the number of peaks found.
    """
    rx = rpts[_P_X]
    ry = rpts[_P_Y]
    rvalid = rflags[_B_VALID]
    cx = cpts[_P_X]
    cy = cpts[_P_Y]
    cvalid = cflags[_B_VALID]
    step = fp[_F_STEP_M]
    step_rad = fp[_F_STEP_RAD]
    n = rx.size
    pad = 3.0 * step
    xmin = ymin = math.inf
    xmax = ymax = -math.inf
    for i in range(n):
        if rvalid[i]:
            xmin = min(xmin, rx[i])
            xmax = max(xmax, rx[i])
            ymin = min(ymin, ry[i])
            ymax = max(ymax, ry[i])
    if not xmin <= xmax:
        return 0
    ox = xmin - pad
    oy = ymin - pad
    w = int((xmax - xmin + 2.0 * pad) / step) + 2
    h = int((ymax - ymin + 2.0 * pad) / step) + 2
    grid = np.zeros((w, h))
    rad = int(math.ceil(pad / step))
    inv2s2 = 0.5 / (step * step)
    for i in range(n):
        if not rvalid[i]:
            continue
        gi = int((rx[i] - ox) / step)
        gj = int((ry[i] - oy) / step)
        for a in range(max(gi - rad, 0), min(gi + rad + 1, w)):
            ddx = ox + (a + 0.5) * step - rx[i]
            for b in range(max(gj - rad, 0), min(gj + rad + 1, h)):
                ddy = oy + (b + 0.5) * step - ry[i]
                v = math.exp(-(ddx * ddx + ddy * ddy) * inv2s2)
                if v > grid[a, b]:
                    grid[a, b] = v
    nt = int(math.ceil(fp[_F_COARSE_M] / step))
    nr = int(math.ceil(fp[_F_COARSE_RAD] / step_rad))
    ntr = 2 * nt + 1
    nrot = 2 * nr + 1
    scores = np.zeros((nrot, ntr, ntr))
    ncp = cx.size
    bi = np.zeros(ncp, dtype=np.int64)
    bj = np.zeros(ncp, dtype=np.int64)
    for ir in range(nrot):
        th = pose0[2] + (ir - nr) * step_rad
        c = math.cos(th)
        s = math.sin(th)
        # the cell of each point at the first translation; the others are whole cells away
        for j in range(ncp):
            if cvalid[j]:
                px = c * cx[j] - s * cy[j] + pose0[0] - nt * step
                py = s * cx[j] + c * cy[j] + pose0[1] - nt * step
                bi[j] = int(math.floor((px - ox) / step))
                bj[j] = int(math.floor((py - oy) / step))
        for a in range(ntr):
            for b in range(ntr):
                tot = 0.0
                for j in range(ncp):
                    if cvalid[j]:
                        gi = bi[j] + a
                        gj = bj[j] + b
                        if gi >= 0 and gi < w and gj >= 0 and gj < h:
                            tot += grid[gi, gj]
                scores[ir, a, b] = tot
    found = 0
    for _ in range(peaks.shape[0]):
        best = 0.0
        br = -1
        ba = 0
        bb = 0
        for ir in range(nrot):
            for a in range(ntr):
                for b in range(ntr):
                    if scores[ir, a, b] > best:
                        best = scores[ir, a, b]
                        br = ir
                        ba = a
                        bb = b
        if br < 0:
            break
        peaks[found, 0] = pose0[0] + (ba - nt) * step
        peaks[found, 1] = pose0[1] + (bb - nt) * step
        peaks[found, 2] = pose0[2] + (br - nr) * step_rad
        found += 1
        # the next peak is at least 4 steps away in one of the directions
        for ir in range(max(br - 3, 0), min(br + 4, nrot)):
            for a in range(max(ba - 3, 0), min(ba + 4, ntr)):
                for b in range(max(bb - 3, 0), min(bb + 4, ntr)):
                    scores[ir, a, b] = -1.0
    return found


def _prepare_kernel(scans, cosa, sina, wrap, ip, fp, pts, flags, nvalid, nline, work, order, iwork, fits):
    """Every scan's points and lines, once (:func:`_prepare_scan`; the kernel allocates
    nothing: less to compile)."""
    for i in range(scans.shape[0]):
        nvalid[i], nline[i] = _prepare_scan(
            scans[i], cosa, sina, wrap, ip, fp, pts[i], flags[i], work, order, iwork, fits
        )  # fmt: skip


def _pairs_kernel(ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, sin2, wf, wn, wi):
    """Match the prepared scan ``cur_idx[k]`` against ``ref_idx[k]`` from ``init[k]`` for every
    k: row k of ``out``, in the work space :func:`_match_batch` makes."""
    for k in range(ref_idx.size):
        ri = ref_idx[k]
        ci = cur_idx[k]
        o = out[k]
        if _pair_start(ip, o, nvalid[ci], nline[ri]):
            _icp(pts[ri], flags[ri], pts[ci], flags[ci], nvalid[ci], beams, sin2, init[k], ip, fp, wf, wn, wi, o)
            o[_O_NREF] = nline[ri]


def _coarse_pairs_kernel(
    ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, sin2, wf, wn, wi, peaks, row
):
    """:func:`_pairs_kernel` after a wide search (:func:`_coarse_peaks`): from each of its
    starts, the result that puts most points on their lines (compiled only when asked for)."""
    for k in range(ref_idx.size):
        ri = ref_idx[k]
        ci = cur_idx[k]
        o = out[k]
        if not _pair_start(ip, o, nvalid[ci], nline[ri]):
            continue
        npk = _coarse_peaks(pts[ri], flags[ri], pts[ci], flags[ci], init[k], fp, peaks)
        best = -1.0
        for p in range(npk):
            _icp(pts[ri], flags[ri], pts[ci], flags[ci], nvalid[ci], beams, sin2, peaks[p], ip, fp, wf, wn, wi, row)
            # the start whose result puts most points on their lines wins (a converged one a tie)
            score = row[_O_NCLOSE] + (0.5 if row[_O_STATUS] == _OK else 0.0)
            if score > best:
                best = score
                for q in range(o.size):
                    o[q] = row[q]
        if npk == 0:
            o[_O_STATUS] = _FEW_REF
        o[_O_NREF] = nline[ri]


def _pair_start(ip, o, ncur, nref):
    """Row ``o`` of a pair cleared; False (and its status set) when a scan has too few points."""
    for q in range(o.size):
        o[q] = math.nan
    o[_O_NREF] = nref
    o[_O_NCUR] = ncur
    o[_O_NCLOSE] = 0.0
    o[_O_ITER] = 0.0
    if nref < ip[_I_MIN_POINTS]:
        o[_O_STATUS] = _FEW_REF
        return False
    if ncur < ip[_I_MIN_POINTS]:
        o[_O_STATUS] = _FEW_CUR
        return False
    return True


def _match_batch(scans, ref_idx, cur_idx, init, cosa, sina, beams, ip, fp, out):
    """Match ``scans[cur_idx[k]]`` against ``scans[ref_idx[k]]`` for every k: row k of ``out``
    (the scans prepared by :func:`_prepare_kernel`, matched by :func:`_pairs_kernel`: two
    kernels, compiled at the same time by two processes, see :func:`start_compiling`)."""
    ns, n = scans.shape
    pts = np.zeros((ns, _P_WIDTH, n))  # every scan's points and lines
    flags = np.zeros((ns, _B_WIDTH, n), dtype=np.bool_)
    nvalid = np.zeros(ns, dtype=np.int64)  # its valid points
    nline = np.zeros(ns, dtype=np.int64)  # its points with a line
    _prepare_kernel(
        scans, cosa, sina, bool(beams[2] > 0.0), ip, fp, pts, flags, nvalid, nline,
        np.zeros((5, n)), np.zeros(n, dtype=np.int64), np.zeros((6, n + 1), dtype=np.int64), np.zeros((7, 2 * n + 2)),
    )  # fmt: skip
    # the squared sine of the smallest angle between a direction and a beam d steps from its nearest
    ang = (np.arange(n + 1) - 0.5) * beams[1]
    sin2 = np.where(ang <= 0.0, 0.0, np.where(ang < 0.5 * math.pi, np.sin(np.clip(ang, 0.0, None)) ** 2, 1.0))
    args = (ref_idx, cur_idx, init, beams, ip, fp, out, pts, flags, nvalid, nline, np.ascontiguousarray(sin2))
    work = (np.zeros((5, n)), np.zeros((2, n), dtype=np.int64), np.zeros(n, dtype=np.bool_))
    if ip[_I_COARSE] == 0:
        _pairs_kernel(*args, *work)
    else:
        _coarse_pairs_kernel(*args, *work, np.zeros((ip[_I_CANDIDATES], 3)), np.zeros(out.shape[1]))


_KERNELS = (
    "_split_pieces",
    "_tls",
    "_fit_pieces",
    "_kth_smallest",
    "_scan_noise",
    "_fit_lines",
    "_prepare_scan",
    "_sym3_eigen_ratio",
    "_icp",
    "_prepare_kernel",
    "_pair_start",
    "_pairs_kernel",
    "_coarse_peaks",
    "_coarse_pairs_kernel",
)
_PY_KERNELS = {name: globals()[name] for name in _KERNELS}  # the Python functions, for numba
# the kernels' argument types (numba's notation): one compiled version each, in the order above
# (a callee before its callers)
_F1, _F2 = "float64[::1]", "float64[:, ::1]"
_I1, _I2 = "int64[::1]", "int64[:, ::1]"
_B1, _B2 = "boolean[::1]", "boolean[:, ::1]"
# the pairs kernels' arguments: the pairs, the settings, the prepared scans, the work space
_PAIRS = (_I1, _I1, _F2, _F1, _I1, _F1, _F2, "float64[:, :, ::1]", "boolean[:, :, ::1]", _I1, _I1, _F1, _F2, _I2, _B1)
_SIGNATURES = {
    "_split_pieces": (_F1, _F1, _I1, "int64", "float64", "float64", "float64", _I2),
    "_tls": (_F1, _F1, _I1, "int64", "int64"),
    "_fit_pieces": (_F1, _F1, _I1, "int64", _I2, _F2, "int64", "float64", "float64"),
    "_scan_noise": (_I2, _F2, "int64", _F1),
    "_fit_lines": (_F2, _B2, "boolean", _I1, _F1, _F2, _I1, _I2, _F2),
    "_prepare_scan": (_F1, _F1, _F1, "boolean", _I1, _F1, _F2, _B2, _F2, _I1, _I2, _F2),
    "_kth_smallest": (_F1, "int64", "int64"),
    "_sym3_eigen_ratio": ("float64",) * 6,
    "_icp": (_F2, _B2, _F2, _B2, "int64", _F1, _F1, _F1, _I1, _F1, _F2, _I2, _B1, _F1),
    "_coarse_peaks": (_F2, _B2, _F2, _B2, _F1, _F1, _F2),
    "_prepare_kernel": (_F2, _F1, _F1, "boolean", _I1, _F1, "float64[:, :, ::1]", "boolean[:, :, ::1]", _I1, _I1)
    + (_F2, _I1, _I2, _F2),
    "_pair_start": (_I1, _F1, "int64", "int64"),
    "_pairs_kernel": _PAIRS,
    "_coarse_pairs_kernel": _PAIRS + (_F2, _F1),  # and the wide search's starts, one start's result
}
# the two halves of the work: the scans' lines (compiled by the first match) and the matching
# (compiled by a second process at the same time, see start_compiling)
_FOREGROUND = (
    "_split_pieces",
    "_tls",
    "_fit_pieces",
    "_kth_smallest",
    "_scan_noise",
    "_fit_lines",
    "_prepare_scan",
    "_prepare_kernel",
)
_BACKGROUND = ("_kth_smallest", "_sym3_eigen_ratio", "_icp", "_pair_start", "_pairs_kernel")
_COARSE = ("_coarse_peaks", "_coarse_pairs_kernel")  # compiled when a wide search is first asked for
_done: set[str] = set()  # the kernels compiled (or loaded) in this process
_dispatchers: dict[str, Any] = {}
_compiled = False
_lock = threading.Lock()
_helper: list[Any] = []  # the process compiling _BACKGROUND, while it runs
_HELPER_TIMEOUT_S = 120.0  # the longest wait for it (its compile takes seconds)


def have_numba() -> bool:
    """Whether numba is installed (the kernels are compiled; else they run interpreted).

    Returns
    -------
    bool
    """
    return numba_module() is not None


def _jit() -> bool:
    """numba is installed and compiles (``NUMBA_DISABLE_JIT`` unset)."""
    numba: Any = numba_module()
    return numba is not None and not numba.config.DISABLE_JIT


def _dispatcher(name: str) -> Any:
    """numba's dispatcher of kernel ``name`` (created on first use; nothing compiled yet)."""
    if name not in _dispatchers:
        numba: Any = numba_module()
        _dispatchers[name] = numba.njit(cache=True, nogil=True)(_PY_KERNELS[name])
    return _dispatchers[name]


def _signature(name: str) -> tuple[Any, ...]:
    """The argument types of kernel ``name``, as numba's types."""
    from numba.core import sigutils

    return tuple(sigutils.normalize_signature("(" + ", ".join(_SIGNATURES[name]) + ",)")[0])


def _cached(name: str) -> bool:
    """Whether numba's cache holds kernel ``name`` for this source and machine (its index is
    read; the machine code is not loaded)."""
    d = _dispatcher(name)
    try:
        key = d._cache._index_key(_signature(name), d.targetctx.codegen())
        return key in d._cache._cache_file._load_index()  # numba's own check (source stamp, CPU)
    except Exception:  # another numba's layout: nothing known
        return True


def kernel_state() -> str:
    """Whether the scan matcher's kernels are ready to run fast.

    Returns
    -------
    str
        ``"interpreted"`` without numba, or with ``NUMBA_DISABLE_JIT`` (the same results, about a
        hundred times slower);
        ``"compile"`` when the next match compiles them (once per machine: numba caches the
        machine code beside the module, or in ``NUMBA_CACHE_DIR``); ``"ready"`` when they are
        compiled in this process or in numba's cache.
    """
    if not _jit():
        return "interpreted"
    if _compiled or (_cached("_prepare_kernel") and _cached("_pairs_kernel")):
        return "ready"
    return "compile"


def start_compiling() -> None:
    """Start compiling the kernels in the background when the next match would compile them.

    A second process compiles the matching kernels into numba's cache while this one goes on
    (reading a bag, say); the first match compiles the scans' kernels and takes the matching
    ones from the cache: about half the wait on a machine with two cores. The first match
    starts it too when it has not been started. Does nothing without numba, when the kernels
    are ready, or when a compile is already under way.
    """
    with _lock:
        _start_helper()


def _start_helper() -> None:
    if _helper or _compiled or getattr(sys, "frozen", False) or kernel_state() != "compile":
        return  # (a frozen program's executable is not a Python to run code with)
    code = "from umbmark.realrobot import scanmatch_kernel as k; k._compile(k._BACKGROUND)"
    try:
        _helper.append(
            subprocess.Popen(
                [sys.executable, "-c", code],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
    except OSError:  # no second process: the first match compiles everything
        pass


def _compile(names: tuple[str, ...]) -> None:
    """Compile (or load from numba's cache) the kernels ``names``, callees first."""
    for name in _KERNELS:
        if name in names and name not in _done:
            d = _dispatcher(name)
            d.compile(_signature(name))
            d.disable_compile()  # one version: a call of other types is an error, not a second compile
            globals()[name] = d
            _done.add(name)


def _kernel(coarse: bool = False) -> Any:
    """The batch kernel, compiled on first use when numba is installed (the wide search's
    kernels on the first use of it)."""
    global _compiled
    with _lock:
        if not _compiled:
            if _jit():
                _start_helper()
                _compile(_FOREGROUND)
                if _helper:
                    try:
                        _helper[0].wait(timeout=_HELPER_TIMEOUT_S)
                    except subprocess.TimeoutExpired:  # a helper that hangs: compile here
                        _helper[0].kill()
                    _helper.clear()
                _compile(tuple(name for name in _KERNELS if name not in _COARSE))
            _compiled = True
        if coarse and _jit():
            _compile(_COARSE)
    return _match_batch
