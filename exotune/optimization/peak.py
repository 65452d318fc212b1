"""Resonance peak of the strength amplification |C6/C5(jω)| relative to its DC value.

The bandwidth constraint alone ignores a resonance (an amplification 1.8× its DC value just
below the −3 dB frequency passes it); the constraint ``amplification_peak_db`` bounds

    peak = sup_{ω ≥ 0} 20 log10 |C6/C5(jω)| / |C6/C5(0)|   [dB]   (≥ 0: ω = 0 is included)

evaluated from the amplification quasi-polynomials (num/den, exact delay) on a per-design
log grid up to ten times the larger tail bound of the two, then refined around the grid maximum
by three rounds of a 17-point sub-grid (all designs at once).

References
----------
Paper §II-D (amplification C6/C5); docs/method.md#amplification.
"""

from __future__ import annotations

import numpy as np

__all__ = ["amplification_peak", "PEAK_GRID_DECADES", "PEAK_PER_DECADE"]

PEAK_GRID_DECADES = 9
PEAK_PER_DECADE = 48
_REFINE_ROUNDS = 3
_REFINE_POINTS = 17


def _size(cfg) -> int:
    """Number of designs of a batch configuration (the longest 1-D array among its numbers)."""
    import dataclasses

    n = 1
    stack = [cfg.plant, cfg.design, cfg.implementation]
    while stack:
        obj = stack.pop()
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if dataclasses.is_dataclass(v):
                stack.append(v)
            elif isinstance(v, np.ndarray) and v.ndim >= 1:
                n = max(n, v.shape[0])
    return n


def _ratio(num, den, rows, w):
    a, _ = num.eval(rows, w, deriv=False)
    b, _ = den.eval(rows, w, deriv=False)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.abs(a / b)


def amplification_peak(cfg) -> tuple[np.ndarray, np.ndarray]:
    """Peak of |C6/C5(jω)| over its DC value for a batch of designs.

    Parameters
    ----------
    cfg : DesignConfig
        A batch (``exotune.config.batch_config``) or one design.

    Returns
    -------
    peak_db : numpy.ndarray
        sup over ω ≥ 0 of 20 log10(|C6/C5(jω)| / |C6/C5(0)|) [dB], ≥ 0; NaN where the DC value
        is zero or not finite.
    peak_hz : numpy.ndarray
        Frequency of the peak [Hz] (0 when the peak is the DC value).

    References
    ----------
    Paper §II-D; docs/method.md#amplification.
    """
    from ..analysis.charfun import amplification_qps
    from ..model.controller import build_controller
    from ..numerics.quasipoly import omega_max

    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        num, den = amplification_qps(cfg.plant, cs, _size(cfg))
        N = num.n
        rows = np.arange(N)
        dc = _ratio(num, den, rows, np.zeros(N))
        wmax = np.maximum(omega_max(num.p0, num.p1), omega_max(den.p0, den.p1))
        wmax = np.where(np.isfinite(wmax) & (wmax > 0), wmax, 1e6) * 10.0
        u = np.linspace(-PEAK_GRID_DECADES, 0.0, PEAK_GRID_DECADES * PEAK_PER_DECADE + 1)
        W = wmax[:, None] * 10.0 ** u[None, :]
        R = _ratio(num, den, np.repeat(rows, W.shape[1]), W.ravel()).reshape(W.shape)
        R = np.where(np.isfinite(R), R, -np.inf)
        k = np.argmax(R, axis=1)
        best_r, best_w = R[rows, k], W[rows, k]
        lo = W[rows, np.maximum(k - 1, 0)]
        hi = W[rows, np.minimum(k + 1, W.shape[1] - 1)]
        t = np.linspace(0.0, 1.0, _REFINE_POINTS)
        for _ in range(_REFINE_ROUNDS):
            S = lo[:, None] * (hi / lo)[:, None] ** t[None, :]
            Rs = _ratio(num, den, np.repeat(rows, t.size), S.ravel()).reshape(S.shape)
            Rs = np.where(np.isfinite(Rs), Rs, -np.inf)
            j = np.argmax(Rs, axis=1)
            better = Rs[rows, j] > best_r
            best_r = np.where(better, Rs[rows, j], best_r)
            best_w = np.where(better, S[rows, j], best_w)
            lo, hi = S[rows, np.maximum(j - 1, 0)], S[rows, np.minimum(j + 1, t.size - 1)]
        rel = best_r / dc
        ok = np.isfinite(dc) & (dc > 0) & np.isfinite(rel)
        above = rel > 1.0
        peak_db = np.where(ok, np.where(above, 20.0 * np.log10(np.where(above, rel, 1.0)), 0.0), np.nan)
        peak_hz = np.where(ok, np.where(above, best_w / (2.0 * np.pi), 0.0), np.nan)
    return peak_db, peak_hz
