"""Compiled eigenvalues of a stack of small real matrices: the eigenvalue problems of the sampled-data
loops (:meth:`exotune.sampled.batch.BatchLoops.spectra`, the sweep's ``sampled: true`` columns).

LAPACK's ``dgeev`` (``numpy.linalg.eigvals``) spends most of its time on a 10–20-state loop matrix in
call overhead: each Householder reflector of its Hessenberg reduction is two level-2 BLAS calls. This
kernel runs the same three classical stages in one compiled loop per matrix:

1. balancing — a diagonal similarity by powers of two that equalizes row and column 2-norms as
   LAPACK's ``dgebal`` does (exact in floating point: it changes no eigenvalue, only their
   conditioning — and the choice of norm matters, see :func:`balance`);
2. reduction to upper Hessenberg form by Householder reflectors (an orthogonal similarity);
3. the Francis implicit double-shift QR iteration on the Hessenberg matrix, with deflation on a
   negligible subdiagonal entry (relative to its two diagonal neighbours) and the classical
   exceptional shifts after 10 and 20 iterations without deflation.

Every stage is backward stable, as ``dgeev`` is: the eigenvalues are those of a matrix within a small
multiple of the unit roundoff of the input (relative to its norm). A matrix with a non-finite
entry, or one whose iteration has not deflated an eigenvalue within ``MAX_ITS`` iterations, is
reported as not done (``ok`` False): the caller solves it with LAPACK instead, so the result never
depends on a failed iteration. The numpy reference is ``numpy.linalg.eigvals`` itself; the tests
compare the two on random, structured and ill-conditioned matrices (tests/numerics/kernels/test_eig.py).

References
----------
Golub & Van Loan, *Matrix Computations*, 4th ed., sections 7.4–7.5 (Hessenberg reduction, the Francis
double-shift QR step); Parlett & Reinsch (1969), balancing a matrix for eigenvalue calculation;
R. James, J. Langou & B. Lowery (2014), on matrix balancing and eigenvector computation (the
2-norm rule of LAPACK 3.5's ``dgebal``);
docs/method.md#sampled-data-verdicts (how the loop eigenvalues decide).
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, njit

__all__ = ["BALANCE_SWEEPS", "MAX_ITS", "balance", "eigvals_stack", "match_spectra"]

BALANCE_SWEEPS = 100  # sweeps of the balancing iteration at most (it converges in a few)
MAX_ITS = 30  # QR iterations allowed per deflated eigenvalue (or pair) before the matrix goes to LAPACK

if AVAILABLE:

    @njit(cache=True)
    def balance(a, d):
        """Balance ``a`` in place by a diagonal similarity of powers of two, a ← D⁻¹ a D with
        D = diag(d) (``d``, length n, is overwritten): row i is divided and column i multiplied by
        f until no power of two f reduces the sum of the row's and the column's 2-norms (diagonal
        included) by 5 % (Parlett & Reinsch's iteration with the 2-norms LAPACK's ``dgebal`` uses
        since version 3.5, James, Langou & Lowery 2014); at most ``BALANCE_SWEEPS`` sweeps.

        Why 2-norms: balanced by 1-norms that leave the diagonal out (the classical rule), a 10 kHz
        loop with a rigid-body mode and two slow modes within 1e-4 of z = 1 came out with a smaller
        norm but its eigenvalues near z = 1 computed 1.8e-7 from the exact (60-digit) ones; by
        2-norms, within 1e-9 (tests/numerics/kernels/test_eig.py)."""
        n = a.shape[0]
        for i in range(n):
            d[i] = 1.0
        for _sweep in range(BALANCE_SWEEPS):
            converged = True
            for i in range(n):
                c = 0.0
                r = 0.0
                for j in range(n):
                    c += a[j, i] * a[j, i]
                    r += a[i, j] * a[i, j]
                c = math.sqrt(c)
                r = math.sqrt(r)
                if c == 0.0 or r == 0.0 or not (math.isfinite(c) and math.isfinite(r)):
                    continue
                total = c + r
                f = 1.0
                g = r / 2.0
                while c < g and f < 1e150:
                    f *= 2.0
                    c *= 2.0
                    r /= 2.0
                    g /= 2.0
                g = c / 2.0
                while g >= r and f > 1e-150:
                    f /= 2.0
                    c /= 2.0
                    g /= 2.0
                    r *= 2.0
                if c + r >= 0.95 * total:
                    continue
                converged = False
                g = 1.0 / f
                for j in range(n):
                    a[i, j] *= g
                for j in range(n):
                    a[j, i] *= f
                d[i] *= f
            if converged:
                return

    @njit(cache=True)
    def _hessenberg(a, v, w):
        """Householder reduction of ``a`` to upper Hessenberg form, in place (``v``, ``w``:
        workspaces of n). A column already zero below its subdiagonal needs no reflector (the one
        that would be applied only flips a sign: a diagonal ±1 similarity)."""
        n = a.shape[0]
        for k in range(n - 2):
            scale = 0.0
            tail = 0.0
            for i in range(k + 1, n):
                scale = max(scale, abs(a[i, k]))
                if i > k + 1:
                    tail = max(tail, abs(a[i, k]))
            if tail == 0.0:
                continue
            ss = 0.0
            for i in range(k + 1, n):
                v[i] = a[i, k] / scale
                ss += v[i] * v[i]
            alpha = math.sqrt(ss)
            if v[k + 1] < 0.0:
                alpha = -alpha
            v[k + 1] += alpha
            beta = 1.0 / (alpha * v[k + 1])  # P = I − β v vᵀ maps column k below the diagonal to a multiple of e_{k+1}
            # P·a on rows k+1.. : w = β vᵀ a, row by row (contiguous), then a −= v wᵀ
            for j in range(k, n):
                w[j] = 0.0
            for i in range(k + 1, n):
                vi = v[i]
                for j in range(k, n):
                    w[j] += vi * a[i, j]
            for i in range(k + 1, n):
                f = beta * v[i]
                for j in range(k, n):
                    a[i, j] -= f * w[j]
            # a·P on columns k+1..
            for i in range(n):
                s = 0.0
                for j in range(k + 1, n):
                    s += a[i, j] * v[j]
                s *= beta
                for j in range(k + 1, n):
                    a[i, j] -= s * v[j]
            for i in range(k + 2, n):
                a[i, k] = 0.0

    @njit(cache=True)
    def _bulge_start(a, lo, hi, x, y, w):
        """(m, p, q, r): the row m where the double-shift step on the block lo..hi starts (the
        highest at which two consecutive small subdiagonal entries make it safe) and the first
        column (p, q, r) of (H − σ1)(H − σ2) there, normalized (σ1 + σ2 = x + y, σ1σ2 = xy − w:
        the trailing 2×2's eigenvalues)."""
        m = hi - 2
        p = q = r = 0.0
        while m >= lo:
            z = a[m, m]
            r = x - z
            s = y - z
            p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
            q = a[m + 1, m + 1] - z - r - s
            r = a[m + 2, m + 1]
            s = abs(p) + abs(q) + abs(r)
            p /= s
            q /= s
            r /= s
            if m == lo:
                break
            u = abs(a[m, m - 1]) * (abs(q) + abs(r))
            t = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
            if u + t == t:
                break
            m -= 1
        for i in range(m + 2, hi + 1):
            a[i, i - 2] = 0.0
            if i != m + 2:
                a[i, i - 3] = 0.0
        return m, p, q, r

    @njit(cache=True)
    def _chase(a, lo, hi, m, p, q, r):
        """One implicit double-shift QR step on rows/columns lo..hi of the Hessenberg ``a``: the
        bulge started at row m by the vector (p, q, r) is chased down with 3×3 Householder
        reflectors (Golub & Van Loan, Algorithm 7.5.1)."""
        x = 0.0
        for k in range(m, hi):
            last = k == hi - 1
            if k != m:
                p = a[k, k - 1]
                q = a[k + 1, k - 1]
                r = 0.0 if last else a[k + 2, k - 1]
                x = abs(p) + abs(q) + abs(r)
                if x != 0.0:
                    p /= x
                    q /= x
                    r /= x
            s = math.sqrt(p * p + q * q + r * r)
            if p < 0.0:
                s = -s
            if s == 0.0:
                continue
            if k == m:
                if lo != m:
                    a[k, k - 1] = -a[k, k - 1]
            else:
                a[k, k - 1] = -s * x
            p += s
            x = p / s
            y = q / s
            z = r / s
            q /= p
            r /= p
            top = min(hi, k + 3)
            if last:  # a 2×2 reflector closes the chase (the branch outside the loops: they stay simple)
                for j in range(k, hi + 1):
                    t = a[k, j] + q * a[k + 1, j]
                    a[k + 1, j] -= t * y
                    a[k, j] -= t * x
                for i in range(lo, top + 1):
                    t = x * a[i, k] + y * a[i, k + 1]
                    a[i, k + 1] -= t * q
                    a[i, k] -= t
            else:
                for j in range(k, hi + 1):
                    t = a[k, j] + q * a[k + 1, j] + r * a[k + 2, j]
                    a[k + 2, j] -= t * z
                    a[k + 1, j] -= t * y
                    a[k, j] -= t * x
                for i in range(lo, top + 1):
                    t = x * a[i, k] + y * a[i, k + 1] + z * a[i, k + 2]
                    a[i, k + 2] -= t * r
                    a[i, k + 1] -= t * q
                    a[i, k] -= t

    @njit(cache=True)
    def _francis(a, wr, wi, max_its):
        """Eigenvalues (wr + j·wi) of the upper Hessenberg ``a`` (overwritten) by the implicit
        double-shift QR iteration; False when an eigenvalue was not deflated within ``max_its``
        iterations (the values are then incomplete)."""
        n = a.shape[0]
        norm = 0.0
        for i in range(n):
            for j in range(max(i - 1, 0), n):
                norm += abs(a[i, j])
        hi = n - 1  # the active block is a[lo:hi+1, lo:hi+1]
        shift = 0.0  # accumulated exceptional shifts
        while hi >= 0:
            its = 0
            while True:
                # deflation: the lowest negligible subdiagonal entry splits off the block lo..hi
                lo = hi
                while lo >= 1:
                    s = abs(a[lo - 1, lo - 1]) + abs(a[lo, lo])
                    if s == 0.0:
                        s = norm
                    if abs(a[lo, lo - 1]) + s == s:
                        a[lo, lo - 1] = 0.0
                        break
                    lo -= 1
                x = a[hi, hi]
                if lo == hi:  # a 1×1 block: one real eigenvalue
                    wr[hi] = x + shift
                    wi[hi] = 0.0
                    hi -= 1
                    break
                y = a[hi - 1, hi - 1]
                w = a[hi, hi - 1] * a[hi - 1, hi]
                if lo == hi - 1:  # a 2×2 block: a real pair or a complex-conjugate pair
                    p = 0.5 * (y - x)
                    q = p * p + w
                    z = math.sqrt(abs(q))
                    x += shift
                    if q >= 0.0:
                        z = p + z if p >= 0.0 else p - z
                        wr[hi - 1] = x + z
                        wr[hi] = x - w / z if z != 0.0 else x + z
                        wi[hi - 1] = 0.0
                        wi[hi] = 0.0
                    else:
                        wr[hi - 1] = x + p
                        wr[hi] = x + p
                        wi[hi - 1] = z
                        wi[hi] = -z
                    hi -= 2
                    break
                if its == max_its:
                    return False
                if its == 10 or its == 20:  # exceptional shift: break a cycle of the standard one
                    shift += x
                    for i in range(hi + 1):
                        a[i, i] -= x
                    s = abs(a[hi, hi - 1]) + abs(a[hi - 1, hi - 2])
                    x = 0.75 * s
                    y = x
                    w = -0.4375 * s * s
                its += 1
                m, p, q, r = _bulge_start(a, lo, hi, x, y, w)
                _chase(a, lo, hi, m, p, q, r)
        return True

    @njit(cache=True)
    def _eigvals_kernel(M, out, ok, max_its):
        k, n, _ = M.shape
        a = np.empty((n, n))
        v = np.empty(n)
        w = np.empty(n)
        wr = np.empty(n)
        wi = np.empty(n)
        nan = complex(np.nan, np.nan)
        for t in range(k):
            finite = True
            for i in range(n):
                for j in range(n):
                    x = M[t, i, j]
                    a[i, j] = x
                    if not math.isfinite(x):
                        finite = False
            done = finite
            if finite:
                balance(a, wr)
                _hessenberg(a, v, w)
                done = _francis(a, wr, wi, max_its)
                for i in range(n):
                    if not (math.isfinite(wr[i]) and math.isfinite(wi[i])):
                        done = False
            ok[t] = done
            for i in range(n):
                out[t, i] = complex(wr[i], wi[i]) if done else nan


def eigvals_stack(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues of every matrix of a real stack, compiled (module docstring).

    Parameters
    ----------
    M : numpy.ndarray
        Real matrices, shape (k, n, n).

    Returns
    -------
    lam : numpy.ndarray
        Their eigenvalues, complex, shape (k, n), in no particular order (complex pairs adjacent);
        rows that are not ``ok`` hold NaN.
    ok : numpy.ndarray
        Per matrix (bool, shape (k,)): False where an entry is not finite or the iteration did not
        converge (solve those with ``numpy.linalg.eigvals``).
    """
    M = np.ascontiguousarray(M, dtype=float)
    k, n = M.shape[0], M.shape[1]
    lam = np.empty((k, n), complex)
    ok = np.zeros(k, bool)
    if k and n:
        _eigvals_kernel(M, lam, ok, MAX_ITS)
    elif k:
        ok[:] = True
    return lam, ok


if AVAILABLE:

    @njit(cache=True)
    def _match_kernel(la, lb, perm):
        c, N = la.shape
        D = np.empty((N, N))
        taken = np.zeros(N, np.bool_)
        for t in range(c):
            for i in range(N):
                for j in range(N):
                    dr = la[t, i].real - lb[t, j].real
                    di = la[t, i].imag - lb[t, j].imag
                    d = dr * dr + di * di
                    D[i, j] = d if d == d and d != math.inf else 1e300
            clash = False
            for j in range(N):
                taken[j] = False
            for i in range(N):
                best = 0
                for j in range(1, N):
                    if D[i, j] < D[i, best]:
                        best = j
                perm[t, i] = best
                if taken[best]:
                    clash = True
                taken[best] = True
            if not clash:
                continue
            for _ in range(N):  # nearest pair first, then the next nearest among the rest
                bi = 0
                bj = 0
                bd = math.inf
                for i in range(N):
                    for j in range(N):
                        if D[i, j] < bd:
                            bd = D[i, j]
                            bi = i
                            bj = j
                perm[t, bi] = bj
                for j in range(N):
                    D[bi, j] = math.inf
                for i in range(N):
                    D[i, bj] = math.inf


def match_spectra(la: np.ndarray, lb: np.ndarray) -> np.ndarray:
    """A one-to-one matching of the eigenvalues ``la`` to ``lb`` per row, nearest pairs first: where
    every eigenvalue's nearest partner is a different one, that is the matching; the other rows are
    matched pair by pair, the nearest remaining pair first (by squared distance, NaN and infinite
    ones counting as 1e300,
    as in the numpy reference :func:`exotune.sampled.families` uses without numba).

    Parameters
    ----------
    la, lb : numpy.ndarray
        Complex spectra, shape (c, N).

    Returns
    -------
    numpy.ndarray
        perm (c, N), int: ``lb[r, perm[r, i]]`` is the partner of ``la[r, i]``.
    """
    la = np.ascontiguousarray(la, dtype=complex)
    lb = np.ascontiguousarray(lb, dtype=complex)
    perm = np.zeros(la.shape, np.int64)
    if la.size:
        _match_kernel(la, lb, perm)
    return perm
