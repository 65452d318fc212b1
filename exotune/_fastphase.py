"""Compiled (numba) kernel for the adaptive phase sum of :func:`exotune.quasipoly.count_rhp`.

Same algorithm and acceptance rule as :func:`exotune.quasipoly.adaptive_leaves` with a single
tracked function, run task by task with an explicit stack instead of level by level over flat
arrays: the numpy implementation remains the reference (and the fallback when numba is not
installed); tests check that both give the same counts.
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is optional: the numpy path is used without it
    from numba import njit
except Exception:  # pragma: no cover - exercised only where numba is missing
    njit = None

__all__ = ["AVAILABLE", "phase_sums"]

AVAILABLE = njit is not None

if AVAILABLE:

    @njit(cache=True, inline="always")
    def _eval(c0T, c1T, t, T, w):
        s = 1j * w
        m0 = c0T.shape[0]
        v0 = c0T[m0 - 1, t] + 0j
        d0 = 0j
        for k in range(m0 - 2, -1, -1):
            d0 = d0 * s + v0
            v0 = v0 * s + c0T[k, t]
        m1 = c1T.shape[0]
        v1 = c1T[m1 - 1, t] + 0j
        d1 = 0j
        for k in range(m1 - 2, -1, -1):
            d1 = d1 * s + v1
            v1 = v1 * s + c1T[k, t]
        e = np.exp(-s * T)
        val = v0 + v1 * e
        der = d0 + (d1 - T * v1) * e
        return val, der

    @njit(cache=True, inline="always")
    def _interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step):
        """(accept, bad) for one tracked function on [a, b] (same rule as quasipoly)."""
        if a == 0.0 and xa == 0 and xb != 0:
            return True, False  # structural zero at s = 0: skipped on the first interval
        if xa == 0 or xb == 0:
            return False, True
        if not (np.isfinite(xa.real) and np.isfinite(xa.imag) and np.isfinite(xb.real) and np.isfinite(xb.imag)):
            return False, True
        h = b - a
        r = xb / xa
        ang = math.atan2(r.imag, r.real)
        small = (r.real > 0) and (abs(r.imag) <= tan_arg * r.real)
        crit = h * abs(Lb - La)
        trap = abs(0.5 * h * (La.real + Lb.real) - ang)
        if 2.0 * trap > crit:
            crit = 2.0 * trap
        if not np.isfinite(crit):
            return False, True
        return small and crit <= der_step, False

    @njit(cache=True)
    def _kernel(c0T, c1T, Ts, grid, valid, arg_step, der_step, max_levels, out_sum, out_res, out_count):
        tan_arg = math.tan(arg_step)
        ntask = grid.shape[0]
        K = grid.shape[1]
        # explicit stack of intervals: a, b, depth and complex values/log-derivatives
        sa = np.empty(4 * max_levels + 8)
        sb = np.empty(4 * max_levels + 8)
        sd = np.empty(4 * max_levels + 8, np.int64)
        sva = np.empty(4 * max_levels + 8, np.complex128)
        svb = np.empty(4 * max_levels + 8, np.complex128)
        sla = np.empty(4 * max_levels + 8, np.complex128)
        slb = np.empty(4 * max_levels + 8, np.complex128)
        for t in range(ntask):
            out_sum[t] = 0.0
            out_res[t] = True
            out_count[t] = 0
            if not valid[t]:
                out_res[t] = False
                continue
            T = Ts[t]
            wa = grid[t, 0]
            va, da = _eval(c0T, c1T, t, T, wa)
            out_count[t] += 1
            for j in range(1, K):
                wb = grid[t, j]
                vb, db = _eval(c0T, c1T, t, T, wb)
                out_count[t] += 1
                top = 0
                sa[0] = wa
                sb[0] = wb
                sd[0] = 0
                sva[0] = va
                svb[0] = vb
                sla[0] = da / va if va != 0 else 0j
                slb[0] = db / vb if vb != 0 else 0j
                bad0 = (va == 0) or (vb == 0)
                if bad0:
                    out_res[t] = False
                top = 1
                while top > 0:
                    top -= 1
                    a = sa[top]
                    b = sb[top]
                    dep = sd[top]
                    xa = sva[top]
                    xb = svb[top]
                    La = sla[top]
                    Lb = slb[top]
                    h = b - a
                    if xa == 0:  # Δ(0) = 0: a root on the axis (the count is inconclusive)
                        out_res[t] = False
                        continue
                    ok, bad = _interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step)
                    if bad:
                        out_res[t] = False
                        continue
                    r = xb / xa
                    ang = math.atan2(r.imag, r.real)
                    floor = (h <= 1e-13 * max(abs(b), 1e-300)) or dep >= max_levels
                    if ok or floor:
                        if floor and not ok:
                            out_res[t] = False
                        out_sum[t] += ang
                        continue
                    m = 0.5 * (a + b)
                    vm, dm = _eval(c0T, c1T, t, T, m)
                    out_count[t] += 1
                    Lm = dm / vm if vm != 0 else 0j
                    if vm == 0:
                        out_res[t] = False
                    # push right then left (left processed first; order does not matter for a sum)
                    sa[top] = m
                    sb[top] = b
                    sd[top] = dep + 1
                    sva[top] = vm
                    svb[top] = xb
                    sla[top] = Lm
                    slb[top] = Lb
                    top += 1
                    sa[top] = a
                    sb[top] = m
                    sd[top] = dep + 1
                    sva[top] = xa
                    svb[top] = vm
                    sla[top] = La
                    slb[top] = Lm
                    top += 1
                wa = wb
                va = vb
                da = db


def phase_sums(p0: np.ndarray, p1: np.ndarray, T: np.ndarray, grid: np.ndarray, valid: np.ndarray,
               arg_step: float, der_step: float, max_levels: int):
    """(Σ principal phase steps over [grid[:, 0], grid[:, -1]], resolved, evaluations) per task."""
    dt = complex if (np.iscomplexobj(p0) or np.iscomplexobj(p1)) else float
    c0T = np.ascontiguousarray(np.asarray(p0, dtype=dt).T)
    c1T = np.ascontiguousarray(np.asarray(p1, dtype=dt).T)
    n = grid.shape[0]
    out_sum = np.zeros(n)
    out_res = np.zeros(n, dtype=np.bool_)
    out_cnt = np.zeros(n, dtype=np.int64)
    _kernel(c0T, c1T, np.ascontiguousarray(T, dtype=float), np.ascontiguousarray(grid, dtype=float),
            np.ascontiguousarray(valid, dtype=np.bool_), float(arg_step), float(der_step), int(max_levels),
            out_sum, out_res, out_cnt)
    return out_sum, out_res, out_cnt


if AVAILABLE:

    @njit(cache=True)
    def _leaves2(cA0, cA1, cB0, cB1, Ts, grid, valid, arg_step, der_step, max_levels, mag_mode, lthr,
                 o_t, o_a, o_b, o_va0, o_vb0, o_va1, o_vb1, o_res):
        tan_arg = math.tan(arg_step)
        ntask = grid.shape[0]
        K = grid.shape[1]
        cap = o_t.shape[0]
        n = 0
        S = 4 * max_levels + 8
        sa = np.empty(S)
        sb = np.empty(S)
        sd = np.empty(S, np.int64)
        sv = np.empty((S, 4), np.complex128)  # va0, vb0, va1, vb1
        sl = np.empty((S, 4), np.complex128)  # La0, Lb0, La1, Lb1
        for t in range(ntask):
            o_res[t] = True
            if not valid[t]:
                o_res[t] = False
                continue
            T = Ts[t]
            wa = grid[t, 0]
            a0, d0 = _eval(cA0, cA1, t, T, wa)
            a1, d1 = _eval(cB0, cB1, t, T, wa)
            for j in range(1, K):
                wb = grid[t, j]
                b0, e0 = _eval(cA0, cA1, t, T, wb)
                b1, e1 = _eval(cB0, cB1, t, T, wb)
                sa[0] = wa
                sb[0] = wb
                sd[0] = 0
                sv[0, 0] = a0
                sv[0, 1] = b0
                sv[0, 2] = a1
                sv[0, 3] = b1
                sl[0, 0] = d0 / a0 if a0 != 0 else 0j
                sl[0, 1] = e0 / b0 if b0 != 0 else 0j
                sl[0, 2] = d1 / a1 if a1 != 0 else 0j
                sl[0, 3] = e1 / b1 if b1 != 0 else 0j
                top = 1
                while top > 0:
                    top -= 1
                    a = sa[top]
                    b = sb[top]
                    dep = sd[top]
                    xa0 = sv[top, 0]
                    xb0 = sv[top, 1]
                    xa1 = sv[top, 2]
                    xb1 = sv[top, 3]
                    La0 = sl[top, 0]
                    Lb0 = sl[top, 1]
                    La1 = sl[top, 2]
                    Lb1 = sl[top, 3]
                    ok0, bad0 = _interval_ok(a, b, xa0, xb0, La0, Lb0, tan_arg, der_step)
                    ok1, bad1 = _interval_ok(a, b, xa1, xb1, La1, Lb1, tan_arg, der_step)
                    ok = ok0 and ok1
                    bad = bad0 or bad1
                    h = b - a
                    floor = (h <= 1e-13 * max(abs(b), 1e-300)) or dep >= max_levels
                    if mag_mode and ok and not bad:
                        # |num/den| must not dip below the −3 dB level inside (see analysis)
                        fa = math.log(abs(xa0 / xa1))
                        fb = math.log(abs(xb0 / xb1))
                        LA = La0 - La1
                        LB = Lb0 - Lb1
                        margin = min(fa, fb) - lthr[t]
                        dip = 0.5 * h * max(abs(LA.imag), abs(LB.imag)) + 0.125 * h * abs(LB - LA)
                        mok = (not np.isfinite(margin)) or margin <= 0.01 or margin > dip
                        if not mok:
                            ok = False
                            if h <= 1e-9 * max(abs(b), 1e-300):
                                floor = True
                                ok = True
                    if ok or floor or bad:
                        if (floor and not ok) or bad:
                            o_res[t] = False
                        if n < cap:
                            o_t[n] = t
                            o_a[n] = a
                            o_b[n] = b
                            o_va0[n] = xa0
                            o_vb0[n] = xb0
                            o_va1[n] = xa1
                            o_vb1[n] = xb1
                        n += 1
                        continue
                    m = 0.5 * (a + b)
                    m0, f0 = _eval(cA0, cA1, t, T, m)
                    m1, f1 = _eval(cB0, cB1, t, T, m)
                    Lm0 = f0 / m0 if m0 != 0 else 0j
                    Lm1 = f1 / m1 if m1 != 0 else 0j
                    # right half first on the stack so the left half is processed first (sorted output)
                    sa[top] = m
                    sb[top] = b
                    sd[top] = dep + 1
                    sv[top, 0] = m0
                    sv[top, 1] = xb0
                    sv[top, 2] = m1
                    sv[top, 3] = xb1
                    sl[top, 0] = Lm0
                    sl[top, 1] = Lb0
                    sl[top, 2] = Lm1
                    sl[top, 3] = Lb1
                    top += 1
                    sa[top] = a
                    sb[top] = m
                    sd[top] = dep + 1
                    sv[top, 0] = xa0
                    sv[top, 1] = m0
                    sv[top, 2] = xa1
                    sv[top, 3] = m1
                    sl[top, 0] = La0
                    sl[top, 1] = Lm0
                    sl[top, 2] = La1
                    sl[top, 3] = Lm1
                    top += 1
                wa = wb
                a0, d0, a1, d1 = b0, e0, b1, e1
        return n


def _coeffs(q):
    dt = complex if (np.iscomplexobj(q.p0) or np.iscomplexobj(q.p1)) else float
    return np.ascontiguousarray(np.asarray(q.p0, dtype=dt).T), np.ascontiguousarray(np.asarray(q.p1, dtype=dt).T)


def leaves2(qa, qb, grid, valid, arg_step, der_step, max_levels, lthr=None):
    """Compiled :func:`exotune.quasipoly.adaptive_leaves` for two tracked quasi-polynomials with the
    same delays (``qa.T``); ``lthr`` (log of the −3 dB level per task) adds the magnitude criterion
    of the amplification bandwidth. Returns the same dict layout."""
    cA0, cA1 = _coeffs(qa)
    cB0, cB1 = _coeffs(qb)
    if cA0.dtype != cB0.dtype:
        cA0, cA1, cB0, cB1 = (x.astype(complex) for x in (cA0, cA1, cB0, cB1))
    ntask, K = grid.shape
    mag = lthr is not None
    lt = np.ascontiguousarray(lthr if mag else np.zeros(ntask), dtype=float)
    cap = max(64, int(ntask * K * 6))
    while True:
        o_t = np.empty(cap, np.int64)
        o_a = np.empty(cap)
        o_b = np.empty(cap)
        o_v = [np.empty(cap, np.complex128) for _ in range(4)]
        o_res = np.zeros(ntask, np.bool_)
        n = _leaves2(cA0, cA1, cB0, cB1, np.ascontiguousarray(qa.T, dtype=float), np.ascontiguousarray(grid, dtype=float),
                     np.ascontiguousarray(valid, dtype=np.bool_), float(arg_step), float(der_step), int(max_levels),
                     mag, lt, o_t, o_a, o_b, o_v[0], o_v[1], o_v[2], o_v[3], o_res)
        if n <= cap:
            break
        cap = int(n * 1.2) + 16
    return {
        "task": o_t[:n],
        "a": o_a[:n],
        "b": o_b[:n],
        "va": [o_v[0][:n], o_v[2][:n]],
        "vb": [o_v[1][:n], o_v[3][:n]],
        "resolved": o_res,
    }


if AVAILABLE:

    @njit(cache=True)
    def _g_value(cA0, cA1, cB0, cB1, t, T, w, k, fre, fim):
        a, _ = _eval(cA0, cA1, t, T, w)
        b, _ = _eval(cB0, cB1, t, T, w)
        s = 1j * w
        phi = 1.0 + 0j
        for _ in range(k):
            phi = phi * s
        fb = complex(fre, fim) * phi * b
        return (a * fb.conjugate()).imag

    @njit(cache=True)
    def _illinois_g(cA0, cA1, cB0, cB1, Ts, task, a, b, fa, fb, k, fre, fim, out):
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            x0 = a[i]
            x1 = b[i]
            f0 = fa[i]
            f1 = fb[i]
            side = 0
            for _ in range(200):
                if abs(x1 - x0) <= 1e-14 * max(abs(x1), 1e-300):
                    break
                x = (x0 * f1 - x1 * f0) / (f1 - f0) if f1 != f0 else 0.5 * (x0 + x1)
                if not (x > min(x0, x1) and x < max(x0, x1)):
                    x = 0.5 * (x0 + x1)
                fx = _g_value(cA0, cA1, cB0, cB1, t, T, x, k, fre, fim)
                if fx == 0:
                    x0 = x
                    x1 = x
                    break
                if (fx > 0) == (f0 > 0):
                    if side == 1:
                        f1 = 0.5 * f1
                    x0 = x
                    f0 = fx
                    side = 1
                else:
                    if side == -1:
                        f0 = 0.5 * f0
                    x1 = x
                    f1 = fx
                    side = -1
            out[i] = 0.5 * (x0 + x1)


def refine_crossings(qa, qb, k: int, factor: complex, task, a, b, fa, fb):
    """Compiled Illinois refinement of the zeros of g(ω) = Im[Δa(jω)·conj(f (jω)^k Δb(jω))] on
    sign-change brackets (same algorithm as :func:`exotune.quasipoly.bisect_roots`)."""
    cA0, cA1 = _coeffs(qa)
    cB0, cB1 = _coeffs(qb)
    if cA0.dtype != cB0.dtype:
        cA0, cA1, cB0, cB1 = (x.astype(complex) for x in (cA0, cA1, cB0, cB1))
    out = np.empty(len(task))
    if len(task):
        _illinois_g(cA0, cA1, cB0, cB1, np.ascontiguousarray(qa.T, dtype=float), np.ascontiguousarray(task, dtype=np.int64),
                    np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float),
                    np.ascontiguousarray(fa, dtype=float), np.ascontiguousarray(fb, dtype=float),
                    int(k), float(factor.real), float(factor.imag), out)
    return out
