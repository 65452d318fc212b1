"""Compiled exact deflation of the rigid-body eigenvalue z = 1 of a stack of ungrounded sampled-data
loop matrices: the twin of :func:`exotune.sampled.rigid.rigid_deflation` (its numpy reference, whose
module docstring gives the method; docs/method.md#sampled-data) and of
:func:`exotune.sampled.rigid.deflate`, one compiled loop over the stack instead of a dozen numpy
calls on small stacks and one ``dgebal`` or compiled balancing call per matrix.

Per matrix M (N × N, the n plant states first), in the order of the reference:

1. balancing, M_b = D⁻¹ M D by powers of two (:func:`exotune.numerics.kernels.eig.balance`, the
   compiled engine's twin of LAPACK's ``dgebal``; exact); a matrix with a non-finite entry is not
   deflated, scalings that are not positive and finite are replaced by 1 (M_b = M);
2. the vector v_b = [D⁻¹x; w]: w the least-squares solution of (M_b − I)[D⁻¹x; w] = 0, from a
   Householder QR factorization of [E_w, b] (E = M_b − I, E_w its last N − n columns,
   b = −E_x D⁻¹x) — R_w and the first N − n entries of Qᵀb — and back substitution; refused when a
   diagonal entry of R_w is 0;
3. the acceptance rule ‖M_b v_b − v_b‖ ≤ ulps·N·ε·‖M_b‖_F·‖v_b‖ (NaN refuses), and ‖v_b‖ > 0;
4. the Householder reflector H = I − 2uuᵀ/uᵀu, u = v̂ + sign(v̂₁)e₁ (v̂ = v_b/‖v_b‖, sign(0) = 1),
   Q₂ = H[:, 1:] and the projection Q₂ᵀ M_b Q₂ (explicit products, :func:`deflate_stack` the same
   code on the same balanced matrix: the deflated matrix and the deflation of the same matrix by
   its basis are the same numbers).

The results agree with the numpy reference to rounding, not bit for bit (a different QR and
summation order); the tests compare the two on random and loop matrices
(tests/numerics/kernels/test_rigid.py). The kernel calls :func:`.eig.balance`: after editing
:mod:`.eig`, delete this package's ``__pycache__`` (numba keys a cached kernel on its own module).
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, njit

if AVAILABLE:
    from .eig import balance

__all__ = ["rigid_deflation_stack", "deflate_stack"]

_EPS = float(np.finfo(float).eps)

if AVAILABLE:

    @njit(cache=True)
    def _project(a, q, t, out):
        """out = qᵀ a q (a: N × N, q: N × (N − 1), finite; t: an N × (N − 1) workspace). The zero
        entries of a (most of a loop matrix's delay line and controller rows) are skipped: they add
        exact zeros."""
        N, m = q.shape
        for i in range(N):
            for c in range(m):
                t[i, c] = 0.0
            for j in range(N):
                aij = a[i, j]
                if aij != 0.0:
                    for c in range(m):
                        t[i, c] += aij * q[j, c]
        for r in range(m):
            for c in range(m):
                out[r, c] = 0.0
        for i in range(N):
            for r in range(m):
                qir = q[i, r]
                for c in range(m):
                    out[r, c] += qir * t[i, c]

    @njit(cache=True)
    def _least_squares(a, n, v, A):
        """The controller/delay part v[n:] of the rigid vector (module docstring, step 2), from the
        balanced ``a`` and the plant part v[:n]; False when a diagonal entry of R_w is 0 (``A``:
        an N × (N − n + 1) workspace, overwritten by the factorization)."""
        N = a.shape[0]
        nw = N - n
        for i in range(N):
            b = 0.0
            for j in range(n):
                b -= (a[i, j] - (1.0 if i == j else 0.0)) * v[j]
            for c in range(nw):
                A[i, c] = a[i, n + c] - (1.0 if i == n + c else 0.0)
            A[i, nw] = b
        for j in range(nw):  # Householder reflector of column j, rows j..N−1, applied to columns j+1..nw
            scale = 0.0
            for i in range(j, N):
                scale = max(scale, abs(A[i, j]))
            if scale == 0.0 or not math.isfinite(scale):
                return False
            ss = 0.0
            for i in range(j, N):
                A[i, j] /= scale
                ss += A[i, j] * A[i, j]
            alpha = math.sqrt(ss)
            if A[j, j] < 0.0:
                alpha = -alpha
            A[j, j] += alpha  # the reflector's vector, in column j; R_jj = −alpha·scale
            beta = 1.0 / (alpha * A[j, j])
            for c in range(j + 1, nw + 1):
                t = 0.0
                for i in range(j, N):
                    t += A[i, j] * A[i, c]
                t *= beta
                for i in range(j, N):
                    A[i, c] -= t * A[i, j]
            A[j, j] = -alpha * scale
            if A[j, j] == 0.0:
                return False
        for i in range(nw - 1, -1, -1):  # back substitution: R_w w = (Qᵀb)[:nw]
            t = A[i, nw]
            for c in range(i + 1, nw):
                t -= A[i, c] * v[n + c]
            v[n + i] = t / A[i, i]
        return True

    @njit(cache=True)
    def _accepted(a, n, v, A, ulps):
        """Steps 2 and 3 of the module docstring on the balanced ``a`` (v[:n] set): whether v,
        completed in place, is an eigenvector at 1 to rounding."""
        N = a.shape[0]
        if N > n and not _least_squares(a, n, v, A):
            return False
        res = 0.0
        fro = 0.0
        vv = 0.0
        for i in range(N):
            r = -v[i]
            for j in range(N):
                r += a[i, j] * v[j]
                fro += a[i, j] * a[i, j]
            res += r * r
            vv += v[i] * v[i]
        return vv > 0.0 and math.sqrt(res) <= ulps * N * _EPS * (math.sqrt(fro) * math.sqrt(vv))

    @njit(cache=True)
    def _rigid_kernel(M, x, ulps, ok, s, Q2, D):
        k, N, _ = M.shape
        n = x.shape[1]
        a = np.empty((N, N))
        v = np.empty(N)
        A = np.empty((N, N - n + 1))
        t = np.empty((N, N - 1))
        m = 0
        for p in range(k):
            ok[p] = False
            finite = True
            for i in range(N):
                for j in range(N):
                    a[i, j] = M[p, i, j]
                    if not math.isfinite(a[i, j]):
                        finite = False
            if not finite:
                continue
            d = s[m]
            balance(a, d)
            good = True
            for i in range(N):
                if not (math.isfinite(d[i]) and d[i] > 0.0):
                    good = False
            if not good:
                for i in range(N):
                    d[i] = 1.0
                    for j in range(N):
                        a[i, j] = M[p, i, j]
            xr = x[p if x.shape[0] > 1 else 0]
            for i in range(n):
                v[i] = xr[i] / d[i]
            if not _accepted(a, n, v, A, ulps):
                continue
            nv = 0.0
            for i in range(N):
                nv += v[i] * v[i]
            nv = math.sqrt(nv)
            for i in range(N):
                v[i] /= nv  # v̂, then u = v̂ + sign(v̂₁)e₁
            v[0] += 1.0 if v[0] >= 0.0 else -1.0
            uu = 0.0
            for i in range(N):
                uu += v[i] * v[i]
            beta = 2.0 / uu
            q = Q2[m]
            for i in range(N):
                f = beta * v[i]
                for c in range(N - 1):
                    q[i, c] = (1.0 if i == c + 1 else 0.0) - f * v[c + 1]
            _project(a, q, t, D[m])
            ok[p] = True
            m += 1
        return m

    @njit(cache=True)
    def _deflate_kernel(M, s, Q2, D):
        k, N, _ = M.shape
        a = np.empty((N, N))
        t = np.empty((N, N - 1))
        for p in range(k):
            for i in range(N):
                for j in range(N):
                    a[i, j] = M[p, i, j] * (s[p, j] / s[p, i])
            _project(a, Q2[p], t, D[p])


def rigid_deflation_stack(M: np.ndarray, x: np.ndarray, ulps: float):
    """The exact deflation of the rigid-body eigenvalue of each matrix of a stack, compiled (module
    docstring): the outputs of :func:`exotune.sampled.rigid.rigid_deflation`.

    Parameters
    ----------
    M : numpy.ndarray
        Loop matrices (k, N, N), the n plant states first.
    x : numpy.ndarray
        The plant's rigid-body vector (n,) or one per matrix (k, n).
    ulps : float
        The acceptance rule's multiple of N·ε·‖M_b‖_F·‖v_b‖ (``exotune.sampled.rigid.RIGID_ULPS``).

    Returns
    -------
    ok : numpy.ndarray
        (k,) bool: the matrices whose rigid-body eigenvector checks.
    s : numpy.ndarray
        The balancing scalings (m, N) of the ``ok`` matrices, in order.
    Q2 : numpy.ndarray
        Their bases (m, N, N − 1): Q₂ᵀQ₂ = I, Q₂ᵀv_b = 0.
    deflated : numpy.ndarray
        Their deflated matrices Q₂ᵀ M_b Q₂ (m, N − 1, N − 1).
    """
    M = np.ascontiguousarray(M, dtype=float)
    k, N = M.shape[0], M.shape[1]
    x = np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=float)))
    ok = np.zeros(k, bool)
    s = np.ones((k, N))
    Q2 = np.empty((k, N, max(N - 1, 0)))
    D = np.empty((k, max(N - 1, 0), max(N - 1, 0)))
    m = 0
    if k and N and 0 < x.shape[1] <= N:
        m = _rigid_kernel(M, x, float(ulps), ok, s, Q2, D)
    return ok, s[:m], Q2[:m], D[:m]


def deflate_stack(M: np.ndarray, s: np.ndarray, Q2: np.ndarray) -> np.ndarray:
    """Q₂ᵀ D⁻¹ M D Q₂ of a stack, compiled: :func:`exotune.sampled.rigid.deflate` (the projection of
    :func:`rigid_deflation_stack`, the same numbers for the same balanced matrix).

    Parameters
    ----------
    M : numpy.ndarray
        Matrices (k, N, N).
    s : numpy.ndarray
        Scalings (k, N).
    Q2 : numpy.ndarray
        Bases (k, N, N − 1).

    Returns
    -------
    numpy.ndarray
        (k, N − 1, N − 1).
    """
    M = np.ascontiguousarray(M, dtype=float)
    k, N = M.shape[0], M.shape[1]
    D = np.empty((k, max(N - 1, 0), max(N - 1, 0)))
    if k and N:
        _deflate_kernel(M, np.ascontiguousarray(s, dtype=float), np.ascontiguousarray(Q2, dtype=float), D)
    return D
