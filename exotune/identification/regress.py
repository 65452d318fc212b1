"""Least squares for one equation of the plant and the covariance of its estimate.

The residual of a regression between filtered signals is itself filtered (sensor noise through
H, sH and s²H): strongly correlated over a few filter time constants 1/ω, so the textbook
covariance σ²(XᵀX)⁻¹ is far too small. The covariance here is the sandwich
(XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹ with Σ the residual's autocovariance: estimated from the whole residual up
to lag L = :data:`CORRELATION_TIME_CONSTANTS`/ω (the filter's correlation length, in samples
L·fs) and tapered by a Parzen window (so that the Toeplitz Σ stays positive semi-definite), and
applied to the regressors by convolution. It assumes the residual stationary and independent of
the regressors' own fluctuations (sensor noise, also in closed loop where the command depends on
past measurements: tests/identification/test_coverage.py measures the coverage), and covers no
model error (friction when not modelled, a wrong delay).

References
----------
docs/identification.md#standard-errors.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["NotExcited", "solve", "residual_covariance", "MAX_CONDITION", "CORRELATION_TIME_CONSTANTS"]

MAX_CONDITION = 1e10  # of the scaled normal equations: beyond it, the log does not excite the parameters
CORRELATION_TIME_CONSTANTS = 30.0  # the residual's autocovariance is summed up to 30/ω


class NotExcited(ValueError):
    """The log does not excite a regression's parameters (the message says how)."""


def solve(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least squares with scaled columns.

    Raises
    ------
    NotExcited
        A regressor identically zero, a condition number beyond √MAX_CONDITION, or an overflow.
    """
    scale = np.max(np.abs(X), axis=0)  # (not the 2-norm: it overflows for values near 1e300)
    if np.any(scale == 0):
        raise NotExcited("a regressor is identically zero")
    Xs = X / scale
    s = np.linalg.svd(Xs, compute_uv=False)
    if s[-1] == 0 or s[0] / s[-1] > math.sqrt(MAX_CONDITION):
        raise NotExcited(f"condition number {s[0] / max(s[-1], 1e-300):.3g} of the regression")
    beta, *_ = np.linalg.lstsq(Xs, y, rcond=None)
    beta = beta / scale
    if not np.all(np.isfinite(beta)):
        raise NotExcited("the estimates overflow: check the log's units")
    return beta


def _parzen(lags: np.ndarray, L: int) -> np.ndarray:
    x = np.abs(lags) / (L + 1.0)
    return np.where(x <= 0.5, 1 - 6 * x ** 2 + 6 * x ** 3, 2 * (1 - x) ** 3)


def residual_covariance(X: np.ndarray, r: np.ndarray, lag: int) -> np.ndarray:
    """Covariance of the least-squares estimate of ``X β = y`` with residual ``r``: the sandwich
    (XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹, Σ the residual's autocovariance up to ``lag`` samples, Parzen-tapered
    (module docstring); scaled by n/(n − p) for the fitted parameters."""
    import scipy.signal

    n, p = X.shape
    L = int(max(1, min(lag, n // 4)))
    m = 1 << int(math.ceil(math.log2(2 * n)))
    R = np.fft.rfft(r, m)
    acov = np.fft.irfft(R * np.conj(R), m)[: L + 1] / n
    lags = np.arange(-L, L + 1)
    kern = acov[np.abs(lags)] * _parzen(lags, L)
    scale = np.max(np.abs(X), axis=0)
    Xs = X / scale
    G = Xs * r[:, None]  # the scores
    w = _parzen(lags, L)
    Ainv = np.linalg.inv(Xs.T @ Xs)
    meats = []
    for V, k in ((Xs, kern), (G, w)):
        Z = np.column_stack([scipy.signal.fftconvolve(V[:, j], k, mode="same") for j in range(p)])
        M = V.T @ Z
        meats.append(Ainv @ (0.5 * (M + M.T)) @ Ainv * (n / max(n - p, 1)))
    C, hac = meats
    d = np.sqrt(np.maximum(np.diag(hac) / np.maximum(np.diag(C), 1e-300), 1.0))
    return (C * np.outer(d, d)) / np.outer(scale, scale)
