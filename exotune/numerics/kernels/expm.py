"""Compiled matrix exponentials of a stack of small matrices: the zero-order-hold discretizations of
the sampled-data loops (:meth:`exotune.sampled.batch.BatchLoops.zoh`).

Each matrix is first balanced (a diagonal similarity by powers of two, exact:
e^M = D e^{D⁻¹MD} D⁻¹), then exponentiated as in Higham 2005: the Padé approximant of the lowest
degree 3, 5 or 7 that is exact to rounding at the balanced matrix's 1-norm, else Padé (13, 13) with
scaling and squaring by the matrix's own power of two (a hold at 1 kHz: degree 5 for about 95 %). Balancing matters for the plant
blocks: a spring over a light rotor has entries of 1e7 next to 1, and scaling by the unbalanced
norm (1e4 at 1 kHz) costs eleven squarings that amplify rounding to 1e-8 relative; balanced, the
result agrees with ``scipy.linalg.expm`` (the numpy reference, and the point-wise model's) to about
1e-14. The linear system (V − U) X = V + U is solved by Gaussian elimination with partial pivoting;
V − U is well conditioned for the scaled norm ≤ θ13 (Higham 2005, section 3). One compiled loop over the
stack: about 4 µs for a 6-state hold (tests/numerics/kernels/test_expm.py).

References
----------
N. J. Higham, "The scaling and squaring method for the matrix exponential revisited", SIAM J.
Matrix Anal. Appl. 26(4), 2005.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, njit

if AVAILABLE:
    from .eig import balance

__all__ = ["THETA", "THETA13", "PADE", "PADE13", "expm_stack"]

# Padé degrees m with θ_m, the largest 1-norm for which the (m, m) approximant is accurate to the unit
# roundoff (Higham 2005, Table 2.3), and the approximants' coefficients b_0 … b_m
THETA = {3: 1.495585217958292e-2, 5: 2.539398330063230e-1, 7: 9.504178996162932e-1}
THETA13 = 5.371920351148152
PADE = {3: (120.0, 60.0, 12.0, 1.0),
        5: (30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0),
        7: (17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0)}
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0, 129060195264000.0,
          10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0)

if AVAILABLE:
    _B = np.zeros((4, 14))  # rows: degree 3, 5, 7, 13
    for _r, _m in enumerate((3, 5, 7)):
        _B[_r, :_m + 1] = PADE[_m]
    _B[3] = PADE13
    _THETAS = np.array([THETA[3], THETA[5], THETA[7]])

    @njit(cache=True)
    def _matmul(x, y, out):
        n = x.shape[0]
        for i in range(n):
            for j in range(n):
                out[i, j] = 0.0
            for k in range(n):
                xik = x[i, k]
                if xik != 0.0:
                    for j in range(n):
                        out[i, j] += xik * y[k, j]

    @njit(cache=True)
    def _even_terms(out, c6, c4, c2, c0, A6, A4, A2, add):
        """out ← [out +] c6 A6 + c4 A4 + c2 A2 + c0 I (a sum of the Padé approximant's even powers)."""
        n = out.shape[0]
        for i in range(n):
            for j in range(n):
                x = c6 * A6[i, j] + c4 * A4[i, j] + c2 * A2[i, j]
                out[i, j] = out[i, j] + x if add else x
            out[i, i] += c0

    @njit(cache=True)
    def _solve_in_place(a, b):
        """b ← a⁻¹ b (a destroyed) by Gaussian elimination with partial pivoting; False if singular."""
        n = a.shape[0]
        for k in range(n):
            p = k
            big = abs(a[k, k])
            for i in range(k + 1, n):
                if abs(a[i, k]) > big:
                    big = abs(a[i, k])
                    p = i
            if big == 0.0 or not math.isfinite(big):
                return False
            if p != k:
                for j in range(n):
                    a[k, j], a[p, j] = a[p, j], a[k, j]
                    b[k, j], b[p, j] = b[p, j], b[k, j]
            piv = a[k, k]
            for i in range(k + 1, n):
                f = a[i, k] / piv
                if f != 0.0:
                    for j in range(k + 1, n):
                        a[i, j] -= f * a[k, j]
                    for j in range(n):
                        b[i, j] -= f * b[k, j]
                a[i, k] = 0.0
        for k in range(n - 1, -1, -1):
            for j in range(n):
                s = b[k, j]
                for i in range(k + 1, n):
                    s -= a[k, i] * b[i, j]
                b[k, j] = s / a[k, k]
        return True

    @njit(cache=True)
    def _pade_uv(A, A2, A4, A6, T1, T2, U, V, b, row):
        """The odd (U) and even (V) parts of the Padé approximant of e^A, of degree 3, 5, 7 or 13
        (``row`` 0–3, coefficients ``b``); T1, T2 are workspace."""
        _matmul(A, A, A2)
        if row >= 1:
            _matmul(A2, A2, A4)
        else:
            A4[:, :] = 0.0
        if row >= 2:
            _matmul(A4, A2, A6)
        else:
            A6[:, :] = 0.0
        if row < 3:
            # U = A (b7 A6 + b5 A4 + b3 A2 + b1 I), V = b6 A6 + b4 A4 + b2 A2 + b0 I (absent terms 0)
            m = 2 * row + 3
            b7 = b[7] if m >= 7 else 0.0
            b6 = b[6] if m >= 7 else 0.0
            b5 = b[5] if m >= 5 else 0.0
            b4 = b[4] if m >= 5 else 0.0
            _even_terms(T2, b7, b5, b[3], b[1], A6, A4, A2, False)
            _matmul(A, T2, U)
            _even_terms(V, b6, b4, b[2], b[0], A6, A4, A2, False)
            return
        # U = A (A6 (b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 + b3 A2 + b1 I)
        # V = A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I
        _even_terms(T1, b[13], b[11], b[9], 0.0, A6, A4, A2, False)
        _matmul(A6, T1, T2)
        _even_terms(T2, b[7], b[5], b[3], b[1], A6, A4, A2, True)
        _matmul(A, T2, U)
        _even_terms(T1, b[12], b[10], b[8], 0.0, A6, A4, A2, False)
        _matmul(A6, T1, V)
        _even_terms(V, b[6], b[4], b[2], b[0], A6, A4, A2, True)

    @njit(cache=True)
    def _expm_kernel(M, out, ok, b, thetas):
        k, n, _ = M.shape
        A = np.empty((n, n))
        A2 = np.empty((n, n))
        A4 = np.empty((n, n))
        A6 = np.empty((n, n))
        T1 = np.empty((n, n))
        T2 = np.empty((n, n))
        U = np.empty((n, n))
        V = np.empty((n, n))
        d = np.empty(n)
        for t in range(k):
            finite = True
            for i in range(n):
                for j in range(n):
                    A[i, j] = M[t, i, j]
                    if not math.isfinite(A[i, j]):
                        finite = False
            if not finite:
                ok[t] = False
                continue
            balance(A, d)  # A ← D⁻¹ M D exactly: e^M = D e^A D⁻¹, with a smaller norm to scale away
            norm = 0.0
            for j in range(n):
                c = 0.0
                for i in range(n):
                    c += abs(A[i, j])
                norm = max(norm, c)
            row = 3  # Padé (13, 13) with scaling, unless a lower degree is exact to rounding unscaled
            for r in range(3):
                if norm <= thetas[r]:
                    row = r
                    break
            s = 0
            if row == 3 and norm > 0.0:
                s = max(0, int(math.ceil(math.log2(max(norm, 1e-300) / THETA13))))
            scale = 2.0 ** (-s)
            for i in range(n):
                for j in range(n):
                    A[i, j] *= scale
            _pade_uv(A, A2, A4, A6, T1, T2, U, V, b[row], row)
            for i in range(n):
                for j in range(n):
                    T1[i, j] = V[i, j] - U[i, j]
                    T2[i, j] = V[i, j] + U[i, j]
            if not _solve_in_place(T1, T2):
                ok[t] = False
                continue
            for _ in range(s):
                _matmul(T2, T2, T1)
                for i in range(n):
                    for j in range(n):
                        T2[i, j] = T1[i, j]
            done = True
            for i in range(n):
                for j in range(n):
                    x = d[i] * T2[i, j] / d[j]
                    if not math.isfinite(x):
                        done = False
                    out[t, i, j] = x
            ok[t] = done


def expm_stack(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """e^M of every matrix of a real stack, compiled (module docstring).

    Parameters
    ----------
    M : numpy.ndarray
        Real square matrices, shape (k, n, n).

    Returns
    -------
    E : numpy.ndarray
        e^M per matrix, shape (k, n, n); rows that are not ``ok`` are unspecified.
    ok : numpy.ndarray
        Per matrix (bool, shape (k,)): False where an entry or the result is not finite or the
        Padé denominator is singular (compute those with the numpy reference).
    """
    M = np.ascontiguousarray(M, dtype=float)
    k, n = M.shape[0], M.shape[1]
    E = np.empty_like(M)
    ok = np.zeros(k, bool)
    if k and n:
        _expm_kernel(M, E, ok, _B, _THETAS)
    elif k:
        ok[:] = True
    return E, ok
