"""Compiled (numba) frequency bounds and polynomial products: the tail bound ω_max of
:func:`exotune.quasipoly.omega_max` row by row, the tail bound of a whole human family
(:func:`family_wmax`) and the batched polynomial product with the bits of
:func:`exotune.poly.pmul`.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, njit

__all__ = ["omega_max", "family_wmax", "pmul_rows"]  # and the compiled omega_max_rows (with numba)

if AVAILABLE:

    @njit(cache=True)
    def omega_max_rows(a0, a1, frac, out):
        """ω_max of every row of the coefficient magnitudes (a0, a1) into ``out`` (the bound of
        :func:`exotune.quasipoly.omega_max`; compiled, used inside other kernels)."""
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
            omega_max_rows(env0, env1, 0.25, wm)
            out[t] = wm[0]


def family_wmax(p0a, p1a, p0b, p1b, phi, factor: complex, lo: float, hi: float) -> np.ndarray:
    """Compiled :func:`exotune.analysis._family_wmax` for real coefficient batches: a tail
    frequency valid for every p in [lo, hi] of Δa + p·φ·f·Δb.

    Parameters
    ----------
    p0a, p1a, p0b, p1b : ndarray, shape (n, ·)
        Ascending real coefficients of P0 and P1 of Δa and Δb, one row per design.
    phi : ndarray
        Ascending coefficients of the polynomial φ(s) of the family.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    lo, hi : float
        The family's range (in its parameter's unit: [kg·m²], [N·m·s/rad] or [N·m/rad]).

    Returns
    -------
    ndarray, shape (n,)
        The tail frequency [rad/s] per row (+inf where no tail bound holds).
    """
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
    """Compiled batched product of two real polynomial batches of shape (n, ·).

    Parameters
    ----------
    a, b : ndarray, shape (n, ·)
        Ascending coefficients, one polynomial per row.

    Returns
    -------
    ndarray, shape (n, a.shape[1] + b.shape[1] − 1)
        The row-by-row products.
    """
    out = np.zeros((a.shape[0], a.shape[1] + b.shape[1] - 1))
    _pmul_rows(np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float), out)
    return out


def omega_max(p0: np.ndarray, p1: np.ndarray, frac: float = 0.25) -> np.ndarray:
    """Compiled :func:`exotune.quasipoly.omega_max` (same bound, row by row).

    Parameters
    ----------
    p0, p1 : ndarray, shape (n, ·)
        Ascending coefficients of the quasi-polynomials' P0 and P1.
    frac : float
        The tail bounds' fraction (0 < frac < 1).

    Returns
    -------
    ndarray, shape (n,)
        ω_max [rad/s] per row, +inf where no tail bound holds.
    """
    a0 = np.ascontiguousarray(np.abs(p0), dtype=float)
    a1 = np.ascontiguousarray(np.abs(p1), dtype=float)
    out = np.empty(a0.shape[0])
    omega_max_rows(a0, a1, float(frac), out)
    return out
