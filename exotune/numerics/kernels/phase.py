"""Compiled (numba) kernels of the argument-principle count: the adaptive phase sum of
:func:`exotune.quasipoly.count_rhp` and the whole per-task count pipeline of
:meth:`exotune.analysis._Counter.run`.

Same algorithm and acceptance rule as :func:`exotune.quasipoly.adaptive_leaves` with a single
tracked function, run task by task with an explicit stack instead of level by level over flat
arrays: the numpy implementation remains the reference (and the fallback when numba is not
installed); tests check that both give the same counts.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, GEO_SPLIT_RATIO, MAX_GROUP_EVALS, MAX_TASK_EVALS, njit

if AVAILABLE:
    from .bounds import omega_max_rows
    from .common import cdiv, eval_quasi, eval_quasi_n, interval_ok, log_derivative, push_interval, row_length

__all__ = ["phase_sums", "count_tasks"]

if AVAILABLE:

    @njit(cache=True, inline="always")
    def _step(ang, xa, xb):
        """The phase step arg(xb/xa) when interval_ok did not compute it."""
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

    @njit(cache=True)
    def _task_sum(c0T, c1T, t, T, grid, gi, K, tan_arg, der_step, max_levels, sa, sb, sd, sva, svb, sla, slb,
                  max_evals):
        """(Σ accepted phase steps, resolved, evaluations) of row t over grid[gi, :K]; unresolved
        once ``max_evals`` evaluations are spent. Δ is evaluated on the row's coefficients up to its
        highest nonzero ones only (rows padded to a batch's width: the same values, fewer steps)."""
        m0 = row_length(c0T, t)
        m1 = row_length(c1T, t)
        acc = 0.0
        res = True
        cnt = 0
        wa = grid[gi, 0]
        va, da = eval_quasi_n(c0T, c1T, t, T, wa, m0, m1)
        cnt += 1
        for j in range(1, K):
            wb = grid[gi, j]
            vb, db = eval_quasi_n(c0T, c1T, t, T, wb, m0, m1)
            cnt += 1
            top = push_interval(sa, sb, sd, sva, svb, sla, slb, 0, wa, wb, 0, va, vb, log_derivative(da, va), log_derivative(db, vb))
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
                ok, bad, ang = interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step)
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
                vm, dm = eval_quasi_n(c0T, c1T, t, T, m, m0, m1)
                cnt += 1
                Lm = log_derivative(dm, vm)
                if vm == 0:
                    res = False
                # push right then left (left processed first; order does not matter for a sum)
                top = push_interval(sa, sb, sd, sva, svb, sla, slb, top, m, b, dep + 1, vm, xb, Lm, Lb)
                top = push_interval(sa, sb, sd, sva, svb, sla, slb, top, a, m, dep + 1, xa, vm, La, Lm)
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
    """(Σ principal phase steps over [grid[:, 0], grid[:, -1]], resolved, evaluations) per task.

    Parameters
    ----------
    p0, p1 : ndarray, shape (ntask, ·)
        Ascending coefficients of P0 and P1 (real or complex).
    T : ndarray, shape (ntask,)
        The delays [s].
    grid : ndarray, shape (ntask, K)
        The initial frequencies [rad/s], increasing along axis 1.
    valid : ndarray of bool, shape (ntask,)
        The tasks to sum.
    arg_step : float
        The largest accepted phase step of an interval [rad] (``quasipoly.ARG_STEP``).
    der_step : float
        The largest accepted (b − a)·|Δ'/Δ(b) − Δ'/Δ(a)| of an interval (``quasipoly.DER_STEP``).
    max_levels : int
        The most halvings of an interval (``quasipoly.MAX_LEVELS``).

    Returns
    -------
    total : ndarray, shape (ntask,)
        The phase change of Δ(jω) over the grid [rad].
    resolved : ndarray of bool, shape (ntask,)
        Every interval resolved.
    evaluations : ndarray of int, shape (ntask,)
        The evaluations of Δ spent.
    """
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
            omega_max_rows(a0, a1, 0.25, wm)
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
            vmax, _ = eval_quasi(c0, c1, 0, T, wg)
            cn = c0[0, max(n, 0)]
            lead = cn * (1j ** max(n, 0)) if n >= 0 else 0j
            q = cdiv(lead, vmax)
            total += math.atan2(q.imag, q.real)
            base = c0[0, 0] + c1[0, 0]
            if has_reg[t] and np.isfinite(v0r):
                q = cdiv(base, complex(v0r, 0.0))
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
    own group). Returns (N, rigid_body_roots, conclusive).

    Parameters
    ----------
    P0, P1 : ndarray, shape (n, ·)
        Ascending coefficients of each task's P0 and P1 (real or complex).
    T : ndarray, shape (n,)
        The delays [s].
    R0, R1 : ndarray, shape (n, ·)
        The real regularized twin's coefficients (the hysteretic human's Δ(j0)).
    has_reg : ndarray of bool, shape (n,)
        The tasks whose twin is used.
    arg_step : float
        The largest accepted phase step of an interval [rad] (``quasipoly.ARG_STEP``).
    der_step : float
        The largest accepted (b − a)·|Δ'/Δ(b) − Δ'/Δ(a)| of an interval (``quasipoly.DER_STEP``).
    max_levels : int
        The most halvings of an interval (``quasipoly.MAX_LEVELS``).
    decades : float
        Decades of the initial frequency grid below the tail bound.
    per_decade : int
        Initial frequency points per decade.
    group : ndarray of int, shape (n,), optional
        Work-budget group of each task.

    Returns
    -------
    n_rhp : ndarray of int, shape (n,)
        Roots in the open right half-plane.
    rigid_body_roots : ndarray of int, shape (n,)
        Exact roots at s = 0 stripped.
    conclusive : ndarray of bool, shape (n,)
        Whether the count is exact.

    References
    ----------
    docs/method.md#free-and-locked-stability.
    """
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
