"""Shared pieces of the compiled kernels: numba (optional), the work budgets, and the inlined
scalar primitives every kernel family uses — Δ(jω) = P0 + P1 e^{−jωT} and its derivative by
Horner's rule in real arithmetic, the acceptance rule of an interval for one tracked function,
the log-derivative, a complex division that never raises, and the interval stack.

The numpy implementation in :mod:`exotune.numerics.quasipoly` remains the reference (and the
fallback when numba is not installed).
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is optional: the numpy path is used without it
    from numba import njit
except Exception:  # pragma: no cover - exercised only where numba is missing
    njit = None

# (the compiled primitives eval_quasi, eval_quasi_n, interval_ok, log_derivative, cdiv and push_interval exist only
# when numba is available)
__all__ = ["AVAILABLE", "MAX_TASK_EVALS", "MAX_TASK_LEAVES", "MAX_GROUP_EVALS", "GEO_SPLIT_RATIO", "MAG_LEVEL_TOL", "njit",
           "coefficients"]

AVAILABLE = njit is not None

# Per-task work budgets (exotune.numerics.budgets; the numpy engine reads them without numba)
from ..budgets import GEO_SPLIT_RATIO, MAG_LEVEL_TOL, MAX_GROUP_EVALS, MAX_TASK_EVALS, MAX_TASK_LEAVES  # noqa: E402,F401

if AVAILABLE:

    @njit(cache=True, inline="always")
    def horner(c, t, w):
        """Value and derivative of row t of c (ascending coefficients) at s = jω, in real
        arithmetic: multiplying by the pure-imaginary s costs two products, not a complex one."""
        return horner_n(c, t, w, c.shape[1])

    @njit(cache=True, inline="always")
    def horner_n(c, t, w, m):
        """:func:`horner` over the first ``m`` ≥ 1 coefficients of row t only (the row's higher ones
        zero: a row padded to a batch's width). The same values, bit for bit: the skipped steps of
        the full recurrence carry exact zeros (ω ≥ 0)."""
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
    def eval_quasi_n(c0, c1, t, T, w, m0, m1):
        """:func:`eval_quasi` with P0 and P1 of row t of lengths m0, m1 ≥ 1 (:func:`horner_n`)."""
        v0r, v0i, d0r, d0i = horner_n(c0, t, w, m0)
        v1r, v1i, d1r, d1i = horner_n(c1, t, w, m1)
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
    def row_length(c, t):
        """1 + the index of the highest nonzero coefficient of row t (1 for a zero row)."""
        for k in range(c.shape[1] - 1, 0, -1):
            if c[t, k] != 0:
                return k + 1
        return 1

    @njit(cache=True, inline="always")
    def eval_quasi(c0, c1, t, T, w):
        """Δ(jω) = P0 + P1 e^{−jωT} and dΔ/ds of row t (coefficients row-major: c[t, k])."""
        return eval_quasi_n(c0, c1, t, T, w, c0.shape[1], c1.shape[1])

    @njit(cache=True, inline="always")
    def interval_ok(a, b, xa, xb, La, Lb, tan_arg, der_step):
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
    def log_derivative(d, v):
        """d/v (the log-derivative Δ'/Δ) by one real reciprocal; the scaled complex division only
        when |v|² over- or underflows."""
        n = v.real * v.real + v.imag * v.imag
        if n == 0.0 or not np.isfinite(n) or n < 1e-290:
            return d / v if v != 0 else 0j
        r = 1.0 / n
        return complex((d.real * v.real + d.imag * v.imag) * r, (d.imag * v.real - d.real * v.imag) * r)

    @njit(cache=True, inline="always")
    def cdiv(a, b):
        """a / b, with numpy's inf/nan for b = 0 where numba's complex division raises
        ZeroDivisionError (a degenerate design must not fail the batch it belongs to)."""
        if b == 0:
            return complex(math.inf, math.nan) if a != 0 else complex(math.nan, math.nan)
        return a / b

    @njit(cache=True, inline="always")
    def push_interval(sa, sb, sd, sva, svb, sla, slb, top, a, b, dep, xa, xb, La, Lb):
        """Push the interval [a, b] (depth ``dep``, values and log-derivatives of the tracked
        function at both ends) on the stack arrays at ``top``; returns the new top."""
        sa[top] = a
        sb[top] = b
        sd[top] = dep
        sva[top] = xa
        svb[top] = xb
        sla[top] = La
        slb[top] = Lb
        return top + 1


def coefficients(q):
    """The coefficient rows (p0, p1) of the quasi-polynomial batch ``q``, contiguous, complex when
    either is complex (else float): the layout the kernels take.

    Parameters
    ----------
    q : QP
        A batch of quasi-polynomials.

    Returns
    -------
    p0, p1 : ndarray
        Its ascending coefficient rows, C-contiguous, of a common dtype.
    """
    dt = complex if (np.iscomplexobj(q.p0) or np.iscomplexobj(q.p1)) else float
    return np.ascontiguousarray(np.asarray(q.p0, dtype=dt)), np.ascontiguousarray(np.asarray(q.p1, dtype=dt))
