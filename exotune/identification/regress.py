"""Least squares for one equation of the plant over one or several logs, and the covariance of its
estimate.

**The regression.** The unknowns are the equation's free parameters (common to every log) and,
per log, a sensor offset and the three start-up transients of the filters (the nuisance columns,
zero outside their log: nothing is filtered, correlated or fitted across a log boundary). The
normal equations are accumulated log by log from the columns scaled to unit maximum (one matrix
product per log; no n×n matrix, no copy of a log beyond its scaled columns), solved, and refined
once with the explicit residual (the refinement restores the accuracy a QR factorization would
give: noise-free estimates come back to 1e-9). The condition number of the scaled columns is the
square root of the scaled normal matrix's: beyond √:data:`MAX_CONDITION` the log does not excite
the parameters.

**The covariance.** The residual of a regression between filtered signals is itself filtered
(sensor noise through H, sH and s²H): strongly correlated over a few filter time constants 1/ω,
so the textbook covariance σ²(XᵀX)⁻¹ is far too small. The covariance here is the sandwich
(XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹ with Σ the residual's autocovariance (block-diagonal over the logs),
estimated from the whole residual up to lag L = :data:`CORRELATION_TIME_CONSTANTS`/ω (the filter's
correlation length, in samples L·fs; pooled over the logs) and tapered by a Parzen window (so that
the Toeplitz Σ stays positive semi-definite), and per parameter at least the Newey–West (HAC)
variance of the same estimate with the same window. By Frisch–Waugh–Lovell the parameters' block
of the sandwich is that of the free columns with the nuisance columns projected out, so only
those columns are transformed: each quadratic form XᵀΣX is a sum over frequency of the columns'
spectra weighted by the kernel's spectrum (FFTs of length ≥ n + L per log, so the circular
correlation equals the linear one at every lag used). The FFTs run in float32 on columns scaled
to unit maximum (the standard errors are statistical estimates; float32 moves them by less than
1e-7 relative, measured against the float64 sandwich), the products and sums in float64; the
transforms of a log (its residual, the columns, the scores) in one batch on two threads. It assumes the residual stationary and
independent of the regressors' own fluctuations (sensor noise, also in closed loop where the
command depends on past measurements: tests/identification/test_coverage.py measures the
coverage), and covers no model error (friction when not modelled, a wrong delay).

References
----------
docs/identification.md#standard-errors.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["NotExcited", "Design", "Fit", "MAX_CONDITION", "CORRELATION_TIME_CONSTANTS", "parzen"]

MAX_CONDITION = 1e10  # of the scaled normal equations: beyond it, the log does not excite the parameters
CORRELATION_TIME_CONSTANTS = 30.0  # the residual's autocovariance is summed up to 30/ω
_WORKERS = 2  # threads of each FFT
_BINS = 1 << 16  # frequency bins converted to float64 at a time


class NotExcited(ValueError):
    """The log does not excite a regression's parameters (the message says how)."""


def parzen(lags: np.ndarray, L: int) -> np.ndarray:
    """The Parzen lag window over |lag| ≤ L.

    Parameters
    ----------
    lags : numpy.ndarray
        Lags [samples].
    L : int
        The window's half-width [samples].

    Returns
    -------
    numpy.ndarray
        The weights, in [0, 1].
    """
    x = np.abs(lags) / (L + 1.0)
    return np.where(x <= 0.5, 1 - 6 * x ** 2 + 6 * x ** 3, 2 * (1 - x) ** 3)


@dataclass(frozen=True)
class Fit:
    """One right-hand side fitted: the free parameters ``beta``, each log's nuisance coefficients
    ``nuisance`` (offset first, then the transients), the ``residual`` per log."""

    beta: np.ndarray
    nuisance: tuple[np.ndarray, ...]
    residual: tuple[np.ndarray, ...]

    @property
    def samples(self) -> int:
        return int(sum(r.size for r in self.residual))

    def rss(self) -> float:
        return float(sum(np.dot(r, r) for r in self.residual))

    def rms(self) -> float:
        return math.sqrt(self.rss() / max(self.samples, 1))


class Design:
    """The scaled columns of one equation's regression over the logs and their normal equations,
    ready for several right-hand sides (:meth:`fit`). ``free``: the free parameters' columns, each
    a sequence of per-log arrays; ``modes``: per log the filters' start-up transients (3, K_log),
    zero beyond their K_log samples. Each log's unknowns are the free parameters (shared) and its
    own sensor offset (a constant column: the filtered constant H[1] differs from 1 by a
    transient, in the modes' span) and three transient coefficients. ``lengths``: each log's
    samples, needed when there is no free column (an equation whose parameters are all fixed:
    only its offset and transients are fitted, its residual still measured).

    Raises
    ------
    NotExcited
        A regressor identically zero, a condition number beyond √MAX_CONDITION, or an overflow.
    """

    q = 4  # per log: the offset and three transients

    def __init__(self, free, modes, lengths=None):
        self.p, self.logs = len(free), len(modes)
        self.lengths = [int(part.size) for part in free[0]] if free else [int(k) for k in lengths]
        with np.errstate(over="ignore", invalid="ignore"):
            fmax = np.array([max(float(np.max(np.abs(part))) if part.size else 0.0 for part in col) for col in free])
        if np.any(fmax == 0):
            raise NotExcited("a regressor is identically zero")
        if not np.all(np.isfinite(fmax)):
            raise NotExcited("the estimates overflow: check the log's units")
        # each log's transients as orthonormal rows (the same span: the normal equations stay
        # well conditioned; the three transients alone are collinear to a condition number ~1e8)
        self.modes, self.back, scale = [], [], [fmax]
        for M in modes:
            mmax = np.max(np.abs(M), axis=1) if M.size else np.ones(M.shape[0])
            mmax[~(mmax > 0)] = 1.0
            Q, R = np.linalg.qr((M / mmax[:, None]).T)
            self.modes.append(np.ascontiguousarray(Q.T))
            self.back.append(R)
            scale.append(np.r_[1.0, mmax])
        self.scale = np.concatenate(scale)
        # the columns themselves (no copy), each divided by its maximum in every product; copied
        # scaled only where products of raw values could overflow or underflow
        moderate = (fmax >= 1e-100) & (fmax <= 1e100)
        self.div = np.where(moderate, fmax, 1.0)
        self.cols = [[col[i] if moderate[j] else col[i] / fmax[j] for j, col in enumerate(free)] for i in range(self.logs)]
        P = self.unknowns
        G = np.zeros((P, P))
        T = np.eye(P)  # from the transients' scaled rows to the orthonormal ones: X_scaled = X_orthonormal·T
        for i in range(self.logs):
            idx = self.index(i)
            G[np.ix_(idx, idx)] += self._gram(i)
            T[np.ix_(idx[self.p + 1:], idx[self.p + 1:])] = self.back[i]
        if not np.all(np.isfinite(G)):
            raise NotExcited("the estimates overflow: check the log's units")
        lam = np.linalg.eigvalsh(T.T @ G @ T)  # the condition of the columns scaled to unit maximum
        cond = math.sqrt(lam[-1] / lam[0]) if lam[0] > 0 else math.inf
        if not cond <= math.sqrt(MAX_CONDITION):
            raise NotExcited(f"condition number {cond:.3g} of the regression")
        self.G = G
        self.Ginv = np.linalg.inv(G)
        e = 1.0 / np.sqrt(np.diag(G))
        lam = np.linalg.eigvalsh(G * np.outer(e, e))
        self.refine = not lam[0] > 0 or lam[-1] / lam[0] > 1e4  # (equilibrated) normal equations exact to ~1e-12 below

    def _gram(self, i: int) -> np.ndarray:
        """Log ``i``'s scaled normal matrix (p + 4 square)."""
        C, M, p, d = self.cols[i], self.modes[i], self.p, self.div
        K = M.shape[1]
        g = np.zeros((p + self.q, p + self.q))
        for a in range(p):
            for b in range(a, p):
                g[a, b] = np.dot(C[a], C[b]) / (d[a] * d[b])
            g[a, p] = C[a].sum() / d[a]
            g[a, p + 1:] = M @ C[a][:K] / d[a]
        g[p, p] = self.lengths[i]
        g[p, p + 1:] = M.sum(axis=1)
        g[p + 1:, p + 1:] = M @ M.T
        return np.triu(g) + np.triu(g, 1).T

    def index(self, i: int) -> np.ndarray:
        """The unknowns of log ``i``'s columns: the free parameters, then its offset and transients."""
        return np.r_[np.arange(self.p), self.p + self.q * i + np.arange(self.q)]

    @property
    def n(self) -> int:
        return int(sum(self.lengths))

    @property
    def unknowns(self) -> int:
        return self.p + self.q * self.logs

    def dot(self, i: int, v: np.ndarray) -> np.ndarray:
        """Log ``i``'s columns (scaled) times ``v``: (p + 4,)."""
        C, M = self.cols[i], self.modes[i]
        return np.concatenate([[np.dot(c, v) / d for c, d in zip(C, self.div)], [v.sum()], M @ v[: M.shape[1]]])

    def combine(self, i: int, z: np.ndarray) -> np.ndarray:
        """Σ_j z_j·column_j of log ``i`` (``z``: the p + 4 coefficients of its columns, scaled;
        or a (p + 4, k) matrix for k combinations, returned as rows (k, n_log))."""
        from scipy.linalg.blas import daxpy

        C, M = self.cols[i], self.modes[i]
        p, K = self.p, M.shape[1]
        Z = np.asarray(z, float).reshape(p + self.q, -1)
        out = np.empty((Z.shape[1], self.lengths[i]))
        for k in range(Z.shape[1]):
            out[k] = Z[p, k]
            for c, d, zj in zip(C, self.div, Z[:p, k]):
                daxpy(c, out[k], a=zj / d)  # in place: no temporary of the log's length
            out[k, :K] += Z[p + 1:, k] @ M
        return out if np.ndim(z) > 1 else out[0]

    def _xty(self, ys) -> np.ndarray:
        b = np.zeros(self.unknowns)
        for i, y in enumerate(ys):
            b[self.index(i)] += self.dot(i, y)
        return b

    def _residual(self, ys, z) -> list:
        return [y - self.combine(i, z[self.index(i)]) for i, y in enumerate(ys)]

    def fit(self, y) -> Fit:
        """Least squares of ``y`` (per-log arrays) on the columns (refined once when the normal
        equations are ill-conditioned).

        Raises
        ------
        NotExcited
            The estimates overflow.
        """
        z = self.Ginv @ self._xty(y)
        r = self._residual(y, z)
        if self.refine:
            dz = self.Ginv @ self._xty(r)
            z = z + dz
            r = [ri - self.combine(i, dz[self.index(i)]) for i, ri in enumerate(r)]
        theta = z.copy()
        for i, R in enumerate(self.back):  # the transients' coefficients on their scaled rows
            m = self.index(i)[self.p + 1:]
            theta[m] = np.linalg.solve(R, z[m])
        theta /= self.scale
        if not np.all(np.isfinite(theta)):
            raise NotExcited("the estimates overflow: check the log's units")
        nuis = tuple(theta[self.p + self.q * i: self.p + self.q * (i + 1)] for i in range(self.logs))
        return Fit(theta[: self.p], nuis, tuple(r))

    def covariance(self, fit: Fit, lag: int, which=None) -> np.ndarray:
        """The covariance of ``fit.beta[which]`` (default: every free parameter): the sandwich with
        the residual's autocovariance up to ``lag`` samples, at least the Newey–West variance
        (module docstring); scaled by n/(n − unknowns)."""
        import scipy.fft

        which = list(range(self.p)) if which is None else list(which)
        n, P = self.n, self.unknowns
        L = int(max(1, min(lag, n // 4)))
        # the chosen parameters' columns with every other column projected out (Frisch–Waugh–Lovell):
        # X·G⁻¹[:, J]·(G⁻¹[J, J])⁻¹, per log; (F̃ᵀF̃)⁻¹ = G⁻¹[J, J]
        Ainv = self.Ginv[np.ix_(which, which)]
        W = np.linalg.solve(Ainv.T, self.Ginv[:, which].T).T
        J = len(which)
        acov, spectra = np.zeros(L + 1), []
        for i, r in enumerate(fit.residual):  # one batch of transforms per log: r, the columns, the scores
            m = _fft_length(r.size + L)
            Ft = self.combine(i, W[self.index(i)])  # (|J|, n_log)
            spec, sc = _spectra([r] + list(Ft) + [lambda a=a: a * r for a in Ft], m)
            Ft = None
            P0 = spec[0].real.astype(float) ** 2 + spec[0].imag.astype(float) ** 2  # |R|², float64 products
            acov += scipy.fft.irfft(P0.astype(np.float32), m)[: L + 1].astype(float) * sc[0] ** 2
            spectra.append((m, spec[1:], sc[1:]))
        acov /= n
        meat, hac = np.zeros((J, J)), np.zeros((J, J))
        for m, spec, sc in spectra:
            meat += _weighted_products(spec[:J], sc[:J], _lag_spectrum(acov, L, m), m)
            hac += _weighted_products(spec[J:], sc[J:], _parzen_spectrum(L, m), m)
        f = n / max(n - P, 1)
        C, H = Ainv @ meat @ Ainv * f, Ainv @ hac @ Ainv * f
        d = np.sqrt(np.maximum(np.diag(H) / np.maximum(np.diag(C), 1e-300), 1.0))
        sc = self.scale[which]
        return (C * np.outer(d, d)) / np.outer(sc, sc)


@functools.lru_cache(maxsize=64)
def _fft_length(n: int) -> int:
    import scipy.fft

    return int(scipy.fft.next_fast_len(n, real=True))


def _spectra(rows, m: int):
    """rfft (float32, length ``m``, two threads) of ``rows`` (arrays, or functions making them)
    each scaled to unit maximum, and those scales; the float32 rows are written in place, zero
    padded (no float64 copy of them)."""
    import scipy.fft

    buf, s = np.zeros((len(rows), m), np.float32), np.ones(len(rows))
    for j, x in enumerate(rows):
        x = x() if callable(x) else x
        a = float(np.max(np.abs(x))) if x.size else 0.0
        s[j] = a if a > 0 and math.isfinite(a) else 1.0
        np.multiply(x, 1.0 / s[j], out=buf[j, : x.size], casting="same_kind")
    return scipy.fft.rfft(buf, axis=1, workers=_WORKERS), s


def _lag_spectrum(acov: np.ndarray, L: int, m: int) -> np.ndarray:
    """The spectrum (real, length m//2 + 1) of the Parzen-tapered autocovariance at lags −L…L,
    placed circularly in ``m`` samples (a float32 FFT of the kernel scaled to unit maximum)."""
    import scipy.fft

    k = acov * parzen(np.arange(L + 1), L)
    s = float(np.max(np.abs(k)))
    if not s > 0:
        return np.zeros(m // 2 + 1)
    c = np.zeros(m, np.float32)
    c[: L + 1] = k / s
    c[m - L:] = c[1: L + 1][::-1]
    return scipy.fft.rfft(c, workers=_WORKERS).real.astype(float) * s


@functools.lru_cache(maxsize=16)
def _parzen_spectrum(L: int, m: int) -> np.ndarray:
    return _lag_spectrum(np.ones(L + 1), L, m)


def _weighted_products(Vh: np.ndarray, s: np.ndarray, K: np.ndarray, m: int) -> np.ndarray:
    """Σ_ℓ k(ℓ) Σ_t v_a(t) v_b(t + ℓ) for rows v (zero outside) from their spectra ``Vh`` (of the
    rows divided by ``s``): (1/m) Σ_f K(f) Re(conj(V̂_a(f)) V̂_b(f)) over the whole circle (the
    half spectrum counted twice but for the zero and Nyquist bins); float64 products."""
    w = np.full(K.size, 2.0 / m)
    w[0] = 1.0 / m
    if m % 2 == 0:
        w[-1] = 1.0 / m
    wK = w * K
    M = np.zeros((Vh.shape[0], Vh.shape[0]))
    for a in range(0, K.size, _BINS):  # a block of bins at a time
        R = Vh[:, a: a + _BINS].view(np.float32).astype(float)  # re, im of each bin
        M += (R * np.repeat(wK[a: a + _BINS], 2)) @ R.T
    return M * np.outer(s, s)
