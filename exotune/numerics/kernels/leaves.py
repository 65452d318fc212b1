"""Compiled (numba) adaptive frequency sets for two tracked quasi-polynomials
(:func:`exotune.quasipoly.adaptive_leaves` with the same delays), with the optional magnitude
criterion of the amplification bandwidth.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, MAG_LEVEL_TOL, MAX_TASK_LEAVES, coefficients, njit

if AVAILABLE:
    from .common import cdiv, eval_quasi, interval_ok, log_derivative, push_interval

__all__ = ["leaves2"]

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
        """Leaves of every task (one explicit-stack subdivision per grid cell) into the o_* arrays
        (up to their capacity; returns the number of leaves). One function on purpose (one loop): the stack state
        lives in local arrays of this compiled function, and splitting it would move that state
        through calls the compiler does not inline."""
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
            a0, d0 = eval_quasi(cA0, cA1, t, T, wa)
            a1, d1 = eval_quasi(cB0, cB1, t, T, wa)
            for j in range(1, K):
                wb = grid[t, j]
                b0, e0 = eval_quasi(cA0, cA1, t, T, wb)
                b1, e1 = eval_quasi(cB0, cB1, t, T, wb)
                top = _push2(sa, sb, sd, sv, sl, 0, wa, wb, 0, a0, b0, a1, b1,
                             log_derivative(d0, a0), log_derivative(e0, b0), log_derivative(d1, a1), log_derivative(e1, b1))
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
                    ok0, bad0, _ = interval_ok(a, b, xa0, xb0, La0, Lb0, tan_arg, der_step)
                    ok1, bad1, _ = interval_ok(a, b, xa1, xb1, La1, Lb1, tan_arg, der_step)
                    ok = ok0 and ok1
                    bad = bad0 or bad1
                    h = b - a
                    floor = (h <= 1e-13 * max(abs(b), 1e-300)) or dep >= max_levels
                    if mag_mode and ok and not bad:
                        # |num/den| must not dip below the −3 dB level inside (see analysis)
                        fa = math.log(abs(cdiv(xa0, xa1)))
                        fb = math.log(abs(cdiv(xb0, xb1)))
                        LA = La0 - La1
                        LB = Lb0 - Lb1
                        margin = min(fa, fb) - lthr[t]
                        dip = 0.5 * h * max(abs(LA.imag), abs(LB.imag)) + 0.125 * h * abs(LB - LA)
                        mok = (not np.isfinite(margin)) or margin <= 0.0 or margin + MAG_LEVEL_TOL > dip
                        if not mok:
                            ok = False
                            if h <= 1e-9 * max(abs(b), 1e-300):
                                floor = True
                                ok = True
                    if ok or floor or bad:
                        if (floor and not ok) or bad:
                            o_res[t] = False
                        if n < cap:
                            push_interval(o_a, o_b, o_t, o_va0, o_vb0, o_va1, o_vb1, n, a, b, t, xa0, xb0, xa1, xb1)
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
                            if abs(cdiv(xa0, xa1)) > lev * (1.0 + 1e-9) and abs(cdiv(xb0, xb1)) < lev * (1.0 - 1e-9):
                                done = True
                                top = 0
                        continue
                    m = 0.5 * (a + b)
                    m0, f0 = eval_quasi(cA0, cA1, t, T, m)
                    m1, f1 = eval_quasi(cB0, cB1, t, T, m)
                    Lm0 = log_derivative(f0, m0)
                    Lm1 = log_derivative(f1, m1)
                    # right half first on the stack so the left half is processed first (sorted output)
                    top = _push2(sa, sb, sd, sv, sl, top, m, b, dep + 1, m0, xb0, m1, xb1, Lm0, Lb0, Lm1, Lb1)
                    top = _push2(sa, sb, sd, sv, sl, top, a, m, dep + 1, xa0, m0, xa1, m1, La0, Lm0, La1, Lm1)
                if done:
                    break
                wa = wb
                a0, d0, a1, d1 = b0, e0, b1, e1
        return n


def leaves2(qa, qb, grid, valid, arg_step, der_step, max_levels, lthr=None):
    """Compiled :func:`exotune.quasipoly.adaptive_leaves` for two tracked quasi-polynomials with the
    same delays (``qa.T``); ``lthr`` (log of the −3 dB level per task) adds the magnitude criterion
    of the amplification bandwidth. Returns the same dict layout.

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    grid : ndarray, shape (ntask, K)
        The initial frequencies [rad/s] of each task, increasing along axis 1.
    valid : ndarray of bool, shape (ntask,)
        The tasks to refine.
    arg_step : float
        The largest accepted phase step of an interval [rad] (``quasipoly.ARG_STEP``).
    der_step : float
        The largest accepted (b − a)·|Δ'/Δ(b) − Δ'/Δ(a)| of an interval (``quasipoly.DER_STEP``).
    max_levels : int
        The most halvings of an interval (``quasipoly.MAX_LEVELS``).
    lthr : ndarray, shape (ntask,), optional
        log of the −3 dB level dc/√2 of |C6/C5| per task; None: no magnitude criterion.

    Returns
    -------
    dict
        ``task``, ``a``, ``b`` (the leaves' ends [rad/s]), ``va``, ``vb`` (the values of Δa and Δb
        at them), and per task ``resolved`` and ``exhausted`` (the work budget spent).
    """
    cA0, cA1 = coefficients(qa)
    cB0, cB1 = coefficients(qb)
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
