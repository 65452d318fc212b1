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

# Per-task work budgets of the adaptive kernels. A normal task takes ~50 evaluations and ~100
# leaves; a pathological design (e.g. a 1e-12 kg·m² motor inertia, or a GHz filter, with a delay:
# the phase of e^{-jωT} winds ~ω_max·T times) could otherwise run for hours. A task that exhausts
# its budget is reported unresolved (inconclusive: never "stable"), not computed forever.
MAX_TASK_EVALS = 200_000  # argument-principle count: evaluations per task (typical: ~50)
MAX_TASK_LEAVES = 100_000  # adaptive frequency sets: leaves per task (typical: ~100)
# Counts queued as one group (the sub-interval counts of one human family for one design) share
# this budget: a degenerate design can have hundreds of sub-intervals whose counts would each spend
# MAX_TASK_EVALS. A real design's group needs a few thousand evaluations (≤ 84 sub-intervals seen
# with a 50 ms delay); tasks left when it is spent are unresolved.
MAX_GROUP_EVALS = 1_000_000
# Argument-principle counts split a rejected interval [a, b] with b > GEO_SPLIT_RATIO·a at its
# geometric mean (see _split_point); the frequency sets (leaves) keep midpoints.
GEO_SPLIT_RATIO = 1.25

if AVAILABLE:

    @njit(cache=True, inline="always")
    def _horner(c, t, w):
        """Value and derivative of row t of c (ascending coefficients) at s = jω, in real
        arithmetic: multiplying by the pure-imaginary s costs two products, not a complex one."""
        m = c.shape[1]
        vr = c[t, m - 1].real
        vi = c[t, m - 1].imag
        dr = 0.0
        di = 0.0
        for k in range(m - 2, -1, -1):
            ndr = vr - w * di
            di = vi + w * dr
            dr = ndr
            ck = c[t, k]
            nvr = ck.real - w * vi
            vi = ck.imag + w * vr
            vr = nvr
        return vr, vi, dr, di

    @njit(cache=True, inline="always")
    def _eval(c0, c1, t, T, w):
        """Δ(jω) = P0 + P1 e^{−jωT} and dΔ/ds of row t (coefficients row-major: c[t, k])."""
        v0r, v0i, d0r, d0i = _horner(c0, t, w)
        v1r, v1i, d1r, d1i = _horner(c1, t, w)
        er = math.cos(w * T)
        ei = -math.sin(w * T)
        # v1·e and (d1 − T v1)·e
        pr = v1r * er - v1i * ei
        pi = v1r * ei + v1i * er
        qr = d1r - T * v1r
        qi = d1i - T * v1i
        val = complex(v0r + pr, v0i + pi)
        der = complex(d0r + qr * er - qi * ei, d0i + qr * ei + qi * er)
        return val, der

    @njit(cache=True, inline="always")
    def _interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step):
        """(accept, bad, phase step) for one tracked function on [a, b] (same rule as quasipoly).

        The phase step is arg(xb/xa), computed as arg(xb·conj(xa)) (no division), and only for
        intervals that pass the cheaper tests (NaN otherwise; the kernel computes it when needed)."""
        if a == 0.0 and xa == 0 and xb != 0:
            return True, False, 0.0  # structural zero at s = 0: skipped on the first interval
        if xa == 0 or xb == 0:
            return False, True, 0.0
        rr = xb.real * xa.real + xb.imag * xa.imag
        ri = xb.imag * xa.real - xb.real * xa.imag
        if not (np.isfinite(rr) and np.isfinite(ri)):
            return False, True, 0.0
        h = b - a
        dr = Lb.real - La.real
        di = Lb.imag - La.imag
        crit = h * math.sqrt(dr * dr + di * di)
        if not np.isfinite(crit):
            return False, True, math.nan
        if crit > der_step or not ((rr > 0) and (abs(ri) <= tan_arg * rr)):
            return False, False, math.nan
        ang = math.atan2(ri, rr)
        trap = 2.0 * abs(0.5 * h * (La.real + Lb.real) - ang)
        if not np.isfinite(trap):
            return False, True, ang
        return trap <= der_step, False, ang

    @njit(cache=True, inline="always")
    def _logd(d, v):
        """d/v (the log-derivative Δ'/Δ) by one real reciprocal; the scaled complex division only
        when |v|² over- or underflows."""
        n = v.real * v.real + v.imag * v.imag
        if n == 0.0 or not np.isfinite(n) or n < 1e-290:
            return d / v if v != 0 else 0j
        r = 1.0 / n
        return complex((d.real * v.real + d.imag * v.imag) * r, (d.imag * v.real - d.real * v.imag) * r)

    @njit(cache=True, inline="always")
    def _cdiv(a, b):
        """a / b, with numpy's inf/nan for b = 0 where numba's complex division raises
        ZeroDivisionError (a degenerate design must not fail the batch it belongs to)."""
        if b == 0:
            return complex(math.inf, math.nan) if a != 0 else complex(math.nan, math.nan)
        return a / b

    @njit(cache=True, inline="always")
    def _step(ang, xa, xb):
        """The phase step arg(xb/xa) when _interval_ok did not compute it."""
        if ang == ang:
            return ang
        return math.atan2(xb.imag * xa.real - xb.real * xa.imag, xb.real * xa.real + xb.imag * xa.imag)

    @njit(cache=True, inline="always")
    def _split_point(a, b):
        """Where a count splits a rejected interval: the geometric mean when the interval spans a
        ratio above GEO_SPLIT_RATIO (the first levels of the log-spaced grid, where the phase of a
        root changes evenly in log ω), else the midpoint. ~8 % fewer evaluations than midpoints."""
        if a > 0.0 and b > GEO_SPLIT_RATIO * a:
            return a * math.sqrt(b / a)
        return 0.5 * (a + b)

    @njit(cache=True, inline="always")
    def _push(sa, sb, sd, sva, svb, sla, slb, top, a, b, dep, xa, xb, La, Lb):
        sa[top] = a
        sb[top] = b
        sd[top] = dep
        sva[top] = xa
        svb[top] = xb
        sla[top] = La
        slb[top] = Lb
        return top + 1

    @njit(cache=True)
    def _task_sum(c0T, c1T, t, T, grid, gi, K, tan_arg, der_step, max_levels, sa, sb, sd, sva, svb, sla, slb,
                  max_evals):
        """(Σ accepted phase steps, resolved, evaluations) of row t over grid[gi, :K]; unresolved
        once ``max_evals`` evaluations are spent."""
        acc = 0.0
        res = True
        cnt = 0
        wa = grid[gi, 0]
        va, da = _eval(c0T, c1T, t, T, wa)
        cnt += 1
        for j in range(1, K):
            wb = grid[gi, j]
            vb, db = _eval(c0T, c1T, t, T, wb)
            cnt += 1
            top = _push(sa, sb, sd, sva, svb, sla, slb, 0, wa, wb, 0, va, vb, _logd(da, va), _logd(db, vb))
            if (va == 0) or (vb == 0):
                res = False
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
                    res = False
                    continue
                ok, bad, ang = _interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step)
                if bad:
                    res = False
                    continue
                floor = (h <= 1e-13 * max(abs(b), 1e-300)) or dep >= max_levels
                if ok or floor:
                    if floor and not ok:
                        res = False
                    acc += _step(ang, xa, xb)
                    continue
                if cnt >= max_evals:  # budget spent: unresolved (see MAX_TASK_EVALS)
                    return acc, False, cnt
                m = _split_point(a, b)
                vm, dm = _eval(c0T, c1T, t, T, m)
                cnt += 1
                Lm = _logd(dm, vm)
                if vm == 0:
                    res = False
                # push right then left (left processed first; order does not matter for a sum)
                top = _push(sa, sb, sd, sva, svb, sla, slb, top, m, b, dep + 1, vm, xb, Lm, Lb)
                top = _push(sa, sb, sd, sva, svb, sla, slb, top, a, m, dep + 1, xa, vm, La, Lm)
            wa = wb
            va = vb
            da = db
        return acc, res, cnt

    @njit(cache=True)
    def _stacks(max_levels):
        S = 4 * max_levels + 8
        return (np.empty(S), np.empty(S), np.empty(S, np.int64), np.empty(S, np.complex128),
                np.empty(S, np.complex128), np.empty(S, np.complex128), np.empty(S, np.complex128))

    @njit(cache=True)
    def _kernel(c0T, c1T, Ts, grid, valid, arg_step, der_step, max_levels, out_sum, out_res, out_count):
        tan_arg = math.tan(arg_step)
        sa, sb, sd, sva, svb, sla, slb = _stacks(max_levels)
        for t in range(grid.shape[0]):
            out_sum[t] = 0.0
            out_res[t] = False
            out_count[t] = 0
            if not valid[t]:
                continue
            acc, res, cnt = _task_sum(c0T, c1T, t, Ts[t], grid, t, grid.shape[1], tan_arg, der_step, max_levels,
                                      sa, sb, sd, sva, svb, sla, slb, MAX_TASK_EVALS)
            out_sum[t] = acc
            out_res[t] = res
            out_count[t] = cnt


def phase_sums(p0: np.ndarray, p1: np.ndarray, T: np.ndarray, grid: np.ndarray, valid: np.ndarray,
               arg_step: float, der_step: float, max_levels: int):
    """(Σ principal phase steps over [grid[:, 0], grid[:, -1]], resolved, evaluations) per task."""
    dt = complex if (np.iscomplexobj(p0) or np.iscomplexobj(p1)) else float
    c0T = np.ascontiguousarray(np.asarray(p0, dtype=dt))
    c1T = np.ascontiguousarray(np.asarray(p1, dtype=dt))
    n = grid.shape[0]
    out_sum = np.zeros(n)
    out_res = np.zeros(n, dtype=np.bool_)
    out_cnt = np.zeros(n, dtype=np.int64)
    _kernel(c0T, c1T, np.ascontiguousarray(T, dtype=float), np.ascontiguousarray(grid, dtype=float),
            np.ascontiguousarray(valid, dtype=np.bool_), float(arg_step), float(der_step), int(max_levels),
            out_sum, out_res, out_cnt)
    return out_sum, out_res, out_cnt


if AVAILABLE:

    @njit(cache=True, inline="always")
    def _push2(sa, sb, sd, sv, sl, top, a, b, dep, va0, vb0, va1, vb1, La0, Lb0, La1, Lb1):
        """Push an interval tracking two functions (values and log-derivatives at both ends)."""
        sa[top] = a
        sb[top] = b
        sd[top] = dep
        sv[top, 0] = va0
        sv[top, 1] = vb0
        sv[top, 2] = va1
        sv[top, 3] = vb1
        sl[top, 0] = La0
        sl[top, 1] = Lb0
        sl[top, 2] = La1
        sl[top, 3] = Lb1
        return top + 1

    @njit(cache=True)
    def _leaves2(cA0, cA1, cB0, cB1, Ts, grid, valid, arg_step, der_step, max_levels, mag_mode, lthr,
                 o_t, o_a, o_b, o_va0, o_vb0, o_va1, o_vb1, o_res, o_exh):
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
            o_exh[t] = False
            if not valid[t]:
                o_res[t] = False
                continue
            T = Ts[t]
            done = False
            nt = 0
            wa = grid[t, 0]
            a0, d0 = _eval(cA0, cA1, t, T, wa)
            a1, d1 = _eval(cB0, cB1, t, T, wa)
            for j in range(1, K):
                wb = grid[t, j]
                b0, e0 = _eval(cA0, cA1, t, T, wb)
                b1, e1 = _eval(cB0, cB1, t, T, wb)
                top = _push2(sa, sb, sd, sv, sl, 0, wa, wb, 0, a0, b0, a1, b1,
                             _logd(d0, a0), _logd(e0, b0), _logd(d1, a1), _logd(e1, b1))
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
                    ok0, bad0, _ = _interval_ok(a, b, xa0, xb0, La0, Lb0, tan_arg, der_step)
                    ok1, bad1, _ = _interval_ok(a, b, xa1, xb1, La1, Lb1, tan_arg, der_step)
                    ok = ok0 and ok1
                    bad = bad0 or bad1
                    h = b - a
                    floor = (h <= 1e-13 * max(abs(b), 1e-300)) or dep >= max_levels
                    if mag_mode and ok and not bad:
                        # |num/den| must not dip below the −3 dB level inside (see analysis)
                        fa = math.log(abs(_cdiv(xa0, xa1)))
                        fb = math.log(abs(_cdiv(xb0, xb1)))
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
                            _push(o_a, o_b, o_t, o_va0, o_vb0, o_va1, o_vb1, n, a, b, t, xa0, xb0, xa1, xb1)
                        n += 1
                        nt += 1
                        if nt >= MAX_TASK_LEAVES:  # budget spent: the task stays unresolved
                            o_res[t] = False
                            o_exh[t] = True
                            done = True
                            top = 0
                            continue
                        if mag_mode and not bad:
                            # only the first −3 dB down-crossing is wanted: stop this task once a
                            # leaf clearly brackets it (a 1e-9 relative margin, so the caller's
                            # own test of the emitted leaves agrees)
                            lev = math.exp(lthr[t])
                            if abs(_cdiv(xa0, xa1)) > lev * (1.0 + 1e-9) and abs(_cdiv(xb0, xb1)) < lev * (1.0 - 1e-9):
                                done = True
                                top = 0
                        continue
                    m = 0.5 * (a + b)
                    m0, f0 = _eval(cA0, cA1, t, T, m)
                    m1, f1 = _eval(cB0, cB1, t, T, m)
                    Lm0 = _logd(f0, m0)
                    Lm1 = _logd(f1, m1)
                    # right half first on the stack so the left half is processed first (sorted output)
                    top = _push2(sa, sb, sd, sv, sl, top, m, b, dep + 1, m0, xb0, m1, xb1, Lm0, Lb0, Lm1, Lb1)
                    top = _push2(sa, sb, sd, sv, sl, top, a, m, dep + 1, xa0, m0, xa1, m1, La0, Lm0, La1, Lm1)
                if done:
                    break
                wa = wb
                a0, d0, a1, d1 = b0, e0, b1, e1
        return n


def _coeffs(q):
    dt = complex if (np.iscomplexobj(q.p0) or np.iscomplexobj(q.p1)) else float
    return np.ascontiguousarray(np.asarray(q.p0, dtype=dt)), np.ascontiguousarray(np.asarray(q.p1, dtype=dt))


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
        o_exh = np.zeros(ntask, np.bool_)
        n = _leaves2(cA0, cA1, cB0, cB1, np.ascontiguousarray(qa.T, dtype=float), np.ascontiguousarray(grid, dtype=float),
                     np.ascontiguousarray(valid, dtype=np.bool_), float(arg_step), float(der_step), int(max_levels),
                     mag, lt, o_t, o_a, o_b, o_v[0], o_v[1], o_v[2], o_v[3], o_res, o_exh)
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
        "exhausted": o_exh,
    }


if AVAILABLE:

    # scalar functions of the two tracked quasi-polynomials a = Δa(jω), b = Δb(jω):
    #   MODE_CROSS  g = Im[a · conj(f (jω)^k b)]      (crossings of κ = −a/(f φ b) with the real axis)
    #   MODE_MAG    g = |a/b|² − c_t                    (the −3 dB level of |C6/C5|)
    #   MODE_EXCESS g = passivity phase excess [deg] of b/a (C7 = Δ10/Δ00)
    MODE_CROSS, MODE_MAG, MODE_EXCESS = 0, 1, 2

    @njit(cache=True, inline="always")
    def _fun(cA0, cA1, cB0, cB1, t, T, w, mode, k, fre, fim, cval):
        a, _ = _eval(cA0, cA1, t, T, w)
        b, _ = _eval(cB0, cB1, t, T, w)
        if mode == 1:
            return abs(_cdiv(a, b)) ** 2 - cval
        if mode == 2:
            c = _cdiv(b, a)
            ph = math.degrees(math.atan2(c.imag, c.real))
            if not (ph > 0):  # also NaN
                return 0.0
            return min(ph, 180.0 - ph)
        s = 1j * w
        phi = 1.0 + 0j
        for _ in range(k):
            phi = phi * s
        fb = complex(fre, fim) * phi * b
        return (a * fb.conjugate()).imag

    @njit(cache=True)
    def _values(cA0, cA1, cB0, cB1, Ts, task, w, mode, k, fre, fim, cvals, out):
        for i in range(task.shape[0]):
            t = task[i]
            out[i] = _fun(cA0, cA1, cB0, cB1, t, Ts[t], w[i], mode, k, fre, fim, cvals[t])

    @njit(cache=True)
    def _illinois(cA0, cA1, cB0, cB1, Ts, task, a, b, fa, fb, mode, k, fre, fim, cvals, out):
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            cv = cvals[t]
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
                fx = _fun(cA0, cA1, cB0, cB1, t, T, x, mode, k, fre, fim, cv)
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

    @njit(cache=True)
    def _golden_max(cA0, cA1, cB0, cB1, Ts, task, a, b, mode, iters, out):
        gr = 0.5 * (math.sqrt(5.0) - 1.0)
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            lo = a[i]
            hi = b[i]
            c1 = hi - gr * (hi - lo)
            c2 = lo + gr * (hi - lo)
            f1 = _fun(cA0, cA1, cB0, cB1, t, T, c1, mode, 0, 1.0, 0.0, 0.0)
            f2 = _fun(cA0, cA1, cB0, cB1, t, T, c2, mode, 0, 1.0, 0.0, 0.0)
            for _ in range(iters):
                if f1 >= f2:
                    hi = c2
                    c2 = c1
                    f2 = f1
                    c1 = hi - gr * (hi - lo)
                    f1 = _fun(cA0, cA1, cB0, cB1, t, T, c1, mode, 0, 1.0, 0.0, 0.0)
                else:
                    lo = c1
                    c1 = c2
                    f1 = f2
                    c2 = lo + gr * (hi - lo)
                    f2 = _fun(cA0, cA1, cB0, cB1, t, T, c2, mode, 0, 1.0, 0.0, 0.0)
            out[i] = _fun(cA0, cA1, cB0, cB1, t, T, 0.5 * (lo + hi), mode, 0, 1.0, 0.0, 0.0)


_MODES = {"cross": 0, "mag": 1, "excess": 2}


def _pair_args(qa, qb):
    cA0, cA1 = _coeffs(qa)
    cB0, cB1 = _coeffs(qb)
    if cA0.dtype != cB0.dtype:
        cA0, cA1, cB0, cB1 = (x.astype(complex) for x in (cA0, cA1, cB0, cB1))
    return cA0, cA1, cB0, cB1, np.ascontiguousarray(qa.T, dtype=float)


def _cvals(c, n):
    return np.ascontiguousarray(np.broadcast_to(np.asarray(0.0 if c is None else c, dtype=float), (n,)))


def pair_values(qa, qb, mode: str, task, w, k: int = 0, factor: complex = 1.0, c=None):
    """One of the scalar functions of ``mode`` ("cross", "mag", "excess"; see ``_fun``) at the
    (task, ω) pairs, compiled."""
    factor = complex(factor)
    out = np.empty(len(task))
    if len(task):
        _values(*_pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), np.ascontiguousarray(w, dtype=float),
                _MODES[mode], int(k), factor.real, factor.imag, _cvals(c, qa.n), out)
    return out


def pair_roots(qa, qb, mode: str, task, a, b, fa, fb, k: int = 0, factor: complex = 1.0, c=None):
    """Compiled Illinois (same algorithm as :func:`exotune.quasipoly.bisect_roots`) on sign-change
    brackets of the ``mode`` function."""
    factor = complex(factor)
    out = np.empty(len(task))
    if len(task):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        _illinois(*_pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), f(a), f(b), f(fa), f(fb),
                  _MODES[mode], int(k), factor.real, factor.imag, _cvals(c, qa.n), out)
    return out


def refine_crossings(qa, qb, k: int, factor: complex, task, a, b, fa, fb):
    """Compiled Illinois refinement of the zeros of g(ω) = Im[Δa(jω)·conj(f (jω)^k Δb(jω))] on
    sign-change brackets (same algorithm as :func:`exotune.quasipoly.bisect_roots`)."""
    return pair_roots(qa, qb, "cross", task, a, b, fa, fb, k=k, factor=factor)


def golden_max(qa, qb, mode: str, task, a, b, iters: int = 40):
    """Golden-section maximization of the ``mode`` function on [a, b] per entry (one new
    evaluation per iteration); returns the value at the final midpoint (same iteration as the numpy
    reference in exotune.analysis)."""
    out = np.empty(len(task))
    if len(task):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        _golden_max(*_pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), f(a), f(b), _MODES[mode], int(iters), out)
    return out


if AVAILABLE:

    @njit(cache=True)
    def _omega_max(a0, a1, frac, out):
        for t in range(a0.shape[0]):
            n = -1
            for k in range(a0.shape[1] - 1, -1, -1):
                if a0[t, k] != 0:
                    n = k
                    break
            d1 = -1
            for k in range(a1.shape[1] - 1, -1, -1):
                if a1[t, k] != 0:
                    d1 = k
                    break
            cn = a0[t, n] if n >= 0 else 0.0
            cnt0 = 0
            for k in range(max(n, 0)):
                if a0[t, k] > 0:
                    cnt0 += 1
            cnt1 = 0
            for k in range(a1.shape[1]):
                if a1[t, k] > 0:
                    cnt1 += 1
            cnt0 = max(cnt0, 1)
            cnt1 = max(cnt1, 1)
            # the largest root (x)^(1/(n−k)) over the terms is exp of the largest log(x)/(n−k):
            # one exp per row instead of one per term (exp is monotone)
            # (a term whose root is +inf or NaN makes the bound infinite, as before)
            y = -math.inf
            finite = True
            if cn > 0:
                for k in range(n):
                    if a0[t, k] > 0:
                        v = math.log(cnt0 * a0[t, k] / (frac * cn)) / (n - k)
                        finite = finite and v < math.inf
                        y = max(y, v)
                for k in range(min(n, a1.shape[1])):
                    if a1[t, k] > 0:
                        v = math.log(cnt1 * a1[t, k] / (frac * (1.0 - frac) * cn)) / (n - k)
                        finite = finite and v < math.inf
                        y = max(y, v)
            w = math.exp(y)
            finite = finite and np.isfinite(w)
            if w <= 0:
                w = 1.0
            out[t] = w * 1.0000001 if (cn > 0 and d1 < n and finite) else math.inf


if AVAILABLE:

    @njit(cache=True, inline="always")
    def _affine_row(A, B, t, phi, fr, fi, lo, hi, n, lo_c, hi_c, env):
        """Row t of C(p) = A + p·(B ⊛ φ)·f at p = lo and p = hi (n coefficients) and the envelope
        max(|C(lo)|, |C(hi)|); B ⊛ φ accumulated in :func:`exotune.poly.pmul`'s order."""
        for i in range(n):
            acc = 0.0
            for j in range(phi.shape[0]):
                if 0 <= i - j < B.shape[1]:
                    acc += B[t, i - j] * phi[j]
            br = acc * fr
            bi = acc * fi
            a = A[t, i] if i < A.shape[1] else 0.0
            lo_c[i] = complex(a + lo * br, lo * bi)
            hi_c[i] = complex(a + hi * br, hi * bi)
            env[0, i] = max(abs(lo_c[i]), abs(hi_c[i]))

    @njit(cache=True)
    def _family_wmax(A0, A1, B0, B1, phi, fr, fi, lo, hi, out):
        n0 = max(A0.shape[1], B0.shape[1] + phi.shape[0] - 1)
        n1 = max(A1.shape[1], B1.shape[1] + phi.shape[0] - 1)
        lo_c = np.zeros(n0, np.complex128)
        hi_c = np.zeros(n0, np.complex128)
        lo_1 = np.zeros(n1, np.complex128)
        hi_1 = np.zeros(n1, np.complex128)
        env0 = np.zeros((1, n0))
        env1 = np.zeros((1, n1))
        wm = np.empty(1)
        for t in range(A0.shape[0]):
            _affine_row(A0, B0, t, phi, fr, fi, lo, hi, n0, lo_c, hi_c, env0)
            _affine_row(A1, B1, t, phi, fr, fi, lo, hi, n1, lo_1, hi_1, env1)
            nlo = -1
            nhi = -1
            for i in range(n0 - 1, -1, -1):
                if nlo < 0 and lo_c[i] != 0:
                    nlo = i
                if nhi < 0 and hi_c[i] != 0:
                    nhi = i
            if nlo != nhi:
                out[t] = math.inf
                continue
            # min over τ ∈ [0, 1] of |c_lo + τ (c_hi − c_lo)| (the leading coefficient over the range)
            c_lo = lo_c[max(nlo, 0)]
            d = hi_c[max(nhi, 0)] - c_lo
            dd = abs(d) ** 2
            tau = 0.0
            if abs(d) > 0:
                tau = min(max(-(d.real * c_lo.real + d.imag * c_lo.imag) / dd, 0.0), 1.0)
                if tau != tau:
                    tau = 0.0
            cmin = abs(c_lo + tau * d)
            if not cmin > 0:
                out[t] = math.inf
                continue
            env0[0, max(nlo, 0)] = cmin
            _omega_max(env0, env1, 0.25, wm)
            out[t] = wm[0]


def family_wmax(p0a, p1a, p0b, p1b, phi, factor: complex, lo: float, hi: float) -> np.ndarray:
    """Compiled :func:`exotune.analysis._family_wmax` for real coefficient batches: a tail
    frequency valid for every p in [lo, hi] of Δa + p·φ·f·Δb."""
    f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
    out = np.empty(p0a.shape[0])
    factor = complex(factor)
    _family_wmax(f(p0a), f(p1a), f(p0b), f(p1b), f(phi), factor.real, factor.imag, float(lo), float(hi), out)
    return out


if AVAILABLE:

    @njit(cache=True)
    def _pmul_rows(a, b, out):
        """out[t] += a[t] * b[t] (ascending coefficients), accumulated in the order of
        :func:`exotune.poly.pmul` (by coefficient of b, then of a), so both give the same bits."""
        na = a.shape[1]
        for t in range(a.shape[0]):
            for j in range(b.shape[1]):
                bj = b[t, j]
                for i in range(na):
                    out[t, i + j] += a[t, i] * bj


def pmul_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Compiled batched product of two real polynomial batches of shape (n, ·)."""
    out = np.zeros((a.shape[0], a.shape[1] + b.shape[1] - 1))
    _pmul_rows(np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float), out)
    return out


def omega_max(p0: np.ndarray, p1: np.ndarray, frac: float = 0.25) -> np.ndarray:
    """Compiled :func:`exotune.quasipoly.omega_max` (same bound, row by row)."""
    a0 = np.ascontiguousarray(np.abs(p0), dtype=float)
    a1 = np.ascontiguousarray(np.abs(p1), dtype=float)
    out = np.empty(a0.shape[0])
    _omega_max(a0, a1, float(frac), out)
    return out


if AVAILABLE:

    @njit(cache=True, inline="always")
    def _first_nonzero(P, t, default):
        for k in range(P.shape[1]):
            if P[t, k] != 0:
                return k
        return default

    @njit(cache=True)
    def _count_tasks(P0, P1, Ts, R0, R1, has_reg, group, arg_step, der_step, max_levels, decades, per_decade,
                     outN, outR, outOK):
        tan_arg = math.tan(arg_step)
        stk = _stacks(max_levels)
        ntask, m0 = P0.shape
        m1 = P1.shape[1]
        m = max(m0, m1)
        c0 = np.zeros((1, m), np.complex128)
        c1 = np.zeros((1, m), np.complex128)
        a0 = np.zeros((1, m))
        a1 = np.zeros((1, m))
        K = int(decades * per_decade) + 1
        grid = np.zeros((1, K + 1))
        ratio = np.empty(K)
        for j in range(K):
            ratio[j] = 10.0 ** (-decades + decades * j / (K - 1))
        wm = np.empty(1)
        cur_group = -1
        left = 0
        for t in range(ntask):
            # exact common zero low-order coefficients of the task and its regularized twin
            r = min(_first_nonzero(P0, t, m), _first_nonzero(P1, t, m), _first_nonzero(R0, t, m),
                    _first_nonzero(R1, t, m))
            if r >= m:
                r = 0
            outR[t] = r
            T = Ts[t]
            for k in range(m):
                c0[0, k] = P0[t, k + r] if k + r < m0 else 0j
                c1[0, k] = P1[t, k + r] if k + r < m1 else 0j
            v0r = math.nan
            if has_reg[t]:
                v0r = (R0[t, r] if r < m0 else 0.0) + (R1[t, r] if r < m1 else 0.0)
            if T == 0.0:  # no delay: Δ is the polynomial P0 + P1
                for k in range(m):
                    c0[0, k] += c1[0, k]
                    c1[0, k] = 0j
            for k in range(m):
                a0[0, k] = abs(c0[0, k])
                a1[0, k] = abs(c1[0, k])
            _omega_max(a0, a1, 0.25, wm)
            wmax = wm[0]
            n = -1
            for k in range(m - 1, -1, -1):
                if c0[0, k] != 0:
                    n = k
                    break
            valid = np.isfinite(wmax)
            wg = wmax if valid else 1.0
            grid[0, 0] = 0.0
            for j in range(K):
                grid[0, j + 1] = wg * ratio[j]
            total = 0.0
            resolved = False
            if group[t] != cur_group:
                cur_group = group[t]
                left = MAX_GROUP_EVALS
            if valid and left > 0:
                total, resolved, used = _task_sum(c0, c1, 0, T, grid, 0, K + 1, tan_arg, der_step, max_levels,
                                                  stk[0], stk[1], stk[2], stk[3], stk[4], stk[5], stk[6],
                                                  min(MAX_TASK_EVALS, left))
                left -= used
            vmax, _ = _eval(c0, c1, 0, T, wg)
            cn = c0[0, max(n, 0)]
            lead = cn * (1j ** max(n, 0)) if n >= 0 else 0j
            q = _cdiv(lead, vmax)
            total += math.atan2(q.imag, q.real)
            base = c0[0, 0] + c1[0, 0]
            if has_reg[t] and np.isfinite(v0r):
                q = _cdiv(base, complex(v0r, 0.0))
                total += math.atan2(q.imag, q.real)
                base = complex(v0r, 0.0)
            psi = math.atan(cn.imag / cn.real) if cn.real != 0 else (math.nan if cn.imag == 0 else math.copysign(math.pi / 2, cn.imag))
            N = (n * math.pi / 2 + psi - total) / math.pi
            Nr = round(N)
            ok = valid and resolved and abs(N - Nr) < 0.05 and base != 0 and np.isfinite(N)
            outN[t] = int(Nr) if np.isfinite(N) else -1
            outOK[t] = ok


def count_tasks(P0, P1, T, R0, R1, has_reg, arg_step: float, der_step: float, max_levels: int,
                decades: float = 6.0, per_decade: int = 2, group=None):
    """Compiled :meth:`exotune.analysis._Counter.run` pipeline: per task, the exact common s = 0
    roots stripped (with the regularized twin), the zero-delay fold, the tail bound, the adaptive
    phase sum, the tail and ω = 0 terms and the count (same formulas as quasipoly.count_rhp).
    ``group``: consecutive tasks with the same id share MAX_GROUP_EVALS (default: every task its
    own group). Returns (N, rigid_body_roots, conclusive)."""
    n = P0.shape[0]
    group = np.arange(n, dtype=np.int64) if group is None else np.ascontiguousarray(group, dtype=np.int64)
    outN = np.empty(n, np.int64)
    outR = np.empty(n, np.int64)
    outOK = np.empty(n, np.bool_)
    c = lambda x: np.ascontiguousarray(x, dtype=complex)  # noqa: E731
    f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
    _count_tasks(c(P0), c(P1), f(T), f(R0), f(R1), np.ascontiguousarray(has_reg, dtype=np.bool_), group, float(arg_step),
                 float(der_step), int(max_levels), float(decades), int(per_decade), outN, outR, outOK)
    return outN, outR, outOK


if AVAILABLE:

    @njit(cache=True)
    def _classify(a, b, va0, va1, vb0, vb1, k, cr, ci, lo, hi, sin_near, ga, gb, flags):
        """Per leaf of a pair (Δ0, Δ1) and one family (f φ = c (jω)^k): the crossing function at
        both ends and the bracket/sub-sampling flags of :func:`exotune.analysis._classify_numpy`
        (bit 0: sign-change bracket, bit 1: sub-sample, bit 2: degenerate — a zero or non-finite
        value, left to the numpy reference)."""
        c = complex(cr, ci)
        for i in range(a.size):
            ai = a[i]
            bi = b[i]
            pa = 1.0
            pb = 1.0
            for _ in range(k):  # ω^k by products (numpy's power for k ≤ 2)
                pa *= ai
                pb *= bi
            fa = c * (pa * va1[i])
            fb = c * (pb * vb1[i])
            xa = va0[i]
            xb = vb0[i]
            g1 = xa.imag * fa.real - xa.real * fa.imag  # Im(xa·conj fa)
            g2 = xb.imag * fb.real - xb.real * fb.imag
            ga[i] = g1
            gb[i] = g2
            na = fa.real * fa.real + fa.imag * fa.imag
            nb = fb.real * fb.real + fb.imag * fb.imag
            if not (na > 0.0 and nb > 0.0 and np.isfinite(na) and np.isfinite(nb)
                    and np.isfinite(xa.real) and np.isfinite(xa.imag) and np.isfinite(xb.real) and np.isfinite(xb.imag)):
                flags[i] = 4
                continue
            # κ = −x/f at both ends
            kar = -(xa.real * fa.real + xa.imag * fa.imag) / na
            kai = -(xa.imag * fa.real - xa.real * fa.imag) / na
            kbr = -(xb.real * fb.real + xb.imag * fb.imag) / nb
            kbi = -(xb.imag * fb.real - xb.real * fb.imag) / nb
            ma = math.sqrt(kar * kar + kai * kai)
            mb = math.sqrt(kbr * kbr + kbi * kbi)
            if not (np.isfinite(ma) and np.isfinite(mb)):
                flags[i] = 4
                continue
            kmin = min(ma, mb)
            kmax = max(ma, mb)
            pos = ai > 0.0
            plausible = (kar > 0.0 or kbr > 0.0) and not (kmax * 1e3 < lo) and not (kmin > hi * 1e3)
            br = pos and ((g1 < 0.0 and g2 > 0.0) or (g1 > 0.0 and g2 < 0.0)) and plausible
            near = abs(kai) <= sin_near * ma or abs(kbi) <= sin_near * mb
            sus = pos and plausible and near and not (kmax * 4.0 < lo) and not (kmin > hi * 4.0)
            flags[i] = 2 if sus else (1 if br else 0)


def classify_leaves(lv: dict, k: int, factor: complex, lo: float, hi: float, sin_near: float):
    """Compiled :func:`exotune.analysis._classify_numpy` over the leaves ``lv`` of a pair:
    (ga, gb, bracket mask, sub-sample mask, degenerate mask)."""
    n = lv["a"].size
    ga, gb = np.empty(n), np.empty(n)
    flags = np.empty(n, np.uint8)
    f = lambda x: np.ascontiguousarray(x, dtype=complex)  # noqa: E731
    factor = complex(factor) * (1j ** int(k))
    if n:
        _classify(np.ascontiguousarray(lv["a"], dtype=float), np.ascontiguousarray(lv["b"], dtype=float),
                  f(lv["va"][0]), f(lv["va"][1]), f(lv["vb"][0]), f(lv["vb"][1]), int(k), factor.real, factor.imag,
                  float(lo), float(hi), float(sin_near), ga, gb, flags)
    return ga, gb, flags == 1, flags == 2, flags == 4


if AVAILABLE:

    @njit(cache=True)
    def _subsample(cA0, cA1, cB0, cB1, Ts, st, sa, sb, Ms, k, fre, fim, cvals, otask, oa, ob, oga, ogb):
        """Sign-change brackets of the crossing function on Ms[i] equally spaced points (ends
        included) of each leaf [sa, sb] of task st."""
        n = 0
        for i in range(st.shape[0]):
            t = st[i]
            T = Ts[t]
            a = sa[i]
            b = sb[i]
            M = Ms[i]
            wp = a
            gp = _fun(cA0, cA1, cB0, cB1, t, T, wp, MODE_CROSS, k, fre, fim, cvals[t])
            for j in range(1, M):
                w = a + (j / (M - 1)) * (b - a)
                g = _fun(cA0, cA1, cB0, cB1, t, T, w, MODE_CROSS, k, fre, fim, cvals[t])
                if (gp < 0.0 and g > 0.0) or (gp > 0.0 and g < 0.0):
                    otask[n] = t
                    oa[n] = wp
                    ob[n] = w
                    oga[n] = gp
                    ogb[n] = g
                    n += 1
                wp = w
                gp = g
        return n


def subsample_brackets(qa, qb, k: int, factor: complex, st, sa, sb):
    """Compiled sub-sampling of leaves (see :meth:`exotune.analysis._Side.submit`): the sign-change
    brackets (task, a, b, g(a), g(b)) of g(ω) = Im[Δa·conj(f (jω)^k Δb)] on each leaf's points."""
    factor = complex(factor)
    Tt = qa.T[st]
    per = np.where(Tt > 0, 2 * np.pi / np.maximum(Tt, 1e-300), np.inf)
    M = np.clip(np.ceil(8.0 * (sb - sa) / per), 8, 512).astype(np.int64)  # ≥ 8 points per ripple period
    m = int(M.sum()) - len(st)
    out = (np.empty(m, np.int64), np.empty(m), np.empty(m), np.empty(m), np.empty(m))
    n = 0
    if len(st):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        n = _subsample(*_pair_args(qa, qb), np.ascontiguousarray(st, dtype=np.int64), f(sa), f(sb), M, int(k),
                       factor.real, factor.imag, _cvals(None, qa.n), *out)
    return tuple(x[:n] for x in out)
